//! The report's header: where and how the numbers were measured.

use crate::profile::build_profile_name;
use hadou::gpu::DeviceInfo;

use super::ReportOptions;

#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub device: String,
    pub device_kind: String,
    pub driver: String,
    pub api_version: String,
    pub cpu: String,
    /// /proc/loadavg's 1/5/15-minute load averages at the start ("unknown" elsewhere): other work
    /// on the machine skews every time measured.
    pub load: String,
    pub git_revision: String,
    /// UTC, `YYYY-MM-DD HH:MM`.
    pub date: String,
    pub quick: bool,
    pub build_profile: &'static str,
    pub command: String,
    pub effect_size: (u32, u32),
    pub frame_sizes: Vec<(u32, u32)>,
    pub frames: usize,
    pub warmup: usize,
}

impl Header {
    pub fn collect(info: &DeviceInfo, opts: &ReportOptions, command: &str) -> Header {
        Header {
            device: info.name.clone(),
            device_kind: info.kind.clone(),
            driver: info.driver.clone(),
            api_version: info.api_version.clone(),
            cpu: cpu_model(),
            load: load_average(),
            git_revision: git_revision(),
            date: utc_now(),
            quick: opts.quick,
            build_profile: build_profile_name(),
            command: command.to_string(),
            effect_size: opts.effect_size,
            frame_sizes: opts.frame_sizes.clone(),
            frames: opts.frames,
            warmup: opts.warmup,
        }
    }

    /// One line naming the machine, for the blocks copied into docs.
    pub fn machine(&self) -> String {
        format!(
            "{} ({}, load average {}), {} build, {}, rev {}",
            self.device, self.cpu, self.load, self.build_profile, self.date, self.git_revision
        )
    }

    pub fn markdown(&self) -> String {
        let sizes: Vec<String> = self.frame_sizes.iter().map(|(w, h)| format!("{w}×{h}")).collect();
        let mode = if self.quick {
            "**quick** (fewer frames, smaller images and fewer variants than a full run: a smoke test of the \
             report, not numbers to quote)"
        } else {
            "full"
        };
        format!(
            "| | |\n|---|---|\n\
             | command | `{}` |\n| mode | {mode} |\n| device | {} ({}) |\n| driver | {} |\n| Vulkan | {} |\n\
             | CPU | {} ({} logical cores), load average {} at the start |\n| build | {} |\n| git revision | {} |\n| date (UTC) | {} |\n\
             | effect sections | {}×{}, {} frames measured after {} warm-up |\n| frame section | {} |\n\n\
             Times are GPU timestamps around each pass, p50 over the measured frames. On a software device \
             (lavapipe) compare variants as ratios within this run.\n",
            self.command,
            self.device,
            self.device_kind,
            self.driver,
            self.api_version,
            self.cpu,
            std::thread::available_parallelism().map_or(0, |n| n.get()),
            self.load,
            self.build_profile,
            self.git_revision,
            self.date,
            self.effect_size.0,
            self.effect_size.1,
            self.frames,
            self.warmup,
            sizes.join(", "),
        )
    }
}

/// The CPU's model name from /proc/cpuinfo (Linux), else "unknown".
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|text| {
            text.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// The 1, 5 and 15-minute load averages from /proc/loadavg (Linux), else "unknown".
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|t| t.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .filter(|t| !t.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// `git rev-parse --short HEAD` (with "-dirty" when the tree has changes), else "unknown".
pub fn git_revision() -> String {
    let run = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    match run(&["rev-parse", "--short", "HEAD"]) {
        Some(rev) if !rev.is_empty() => {
            let dirty =
                run(&["status", "--porcelain", "--untracked-files=no"]).is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{rev}-dirty")
            } else {
                rev
            }
        }
        _ => "unknown".into(),
    }
}

/// The current UTC date and time, `YYYY-MM-DD HH:MM`.
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    format_utc(secs)
}

/// Seconds since 1970-01-01 as `YYYY-MM-DD HH:MM` (proleptic Gregorian; H. Hinnant's civil_from_days).
pub fn format_utc(secs: u64) -> String {
    let days = (secs / 86400) as i64;
    let (hh, mm) = ((secs % 86400) / 3600, (secs % 3600) / 60);
    let z = days + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {hh:02}:{mm:02}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_dates() {
        assert_eq!(format_utc(0), "1970-01-01 00:00");
        // 2000-02-29 12:34 (a leap day in a century leap year).
        assert_eq!(format_utc(951_827_640), "2000-02-29 12:34");
        assert_eq!(format_utc(1_700_000_000), "2023-11-14 22:13");
    }
}
