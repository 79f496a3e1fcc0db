//! The `hadou` command: a thin layer over the library.

// No Vulkan of its own: the viewer's window surface is made by hadou-gpu (tests/layers.rs).
#![deny(unsafe_code)]

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    // SIGINT/SIGTERM remove this run's output temporaries before it exits (130/143).
    if let Err(e) = hadou::output::interrupt::install() {
        log::warn!("cannot handle SIGINT/SIGTERM ({e}); an interrupted write may leave a .tmp file");
    }
    let args = cli::Cli::parse();
    let error_code = args.error_code();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            // File names reach the terminal escaped (a name may hold an escape sequence); the
            // message's own line breaks stay.
            let text: Vec<String> = cli::message(&e).split('\n').map(cli::escape_controls).collect();
            eprintln!("error: {}", text.join("\n"));
            error_code
        }
    }
}

#[cfg(test)]
mod tests {
    use super::cli::message;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read x.obj: {source}")]
    struct Repeats {
        source: std::io::Error,
    }

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = std::io::Error::from(std::io::ErrorKind::NotFound);
        let os = io.to_string();
        let e = anyhow::Error::new(Repeats { source: io }).context("bake");
        assert_eq!(message(&e), format!("bake: cannot read x.obj: {os}"));
        let plain = anyhow::anyhow!("inner").context("outer");
        assert_eq!(message(&plain), "outer: inner");
    }
}
