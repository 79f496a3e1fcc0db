//! A virtual X server for window tests.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};

/// An Xvfb server on a display number it picks itself (`-displayfd`), killed when dropped, so a
/// failing test never leaves it running.
pub struct Xvfb {
    child: Child,
    /// The `DISPLAY` value.
    pub display: String,
}

impl Xvfb {
    pub fn start() -> Xvfb {
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("window tests need Xvfb (scripts/setup.sh installs xvfb): {e}"));
        // Xvfb writes the display number once it accepts connections.
        let mut line = String::new();
        let read = BufReader::new(child.stdout.take().unwrap()).read_line(&mut line);
        let number = line.trim().to_string();
        let mut server = Xvfb { child, display: format!(":{number}") };
        if read.is_err() || number.is_empty() || number.parse::<u32>().is_err() {
            let _ = server.child.kill();
            panic!("Xvfb did not report a display number (got {line:?})");
        }
        server.display = format!(":{number}");
        server
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
