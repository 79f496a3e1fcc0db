//! A virtual X server for window tests.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// How long Xvfb may take to report its display: it starts in well under a second, so this only
/// turns a server that never answers into a failure instead of a hung test.
const START_LIMIT: Duration = Duration::from_secs(60);

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
        // Xvfb writes the display number once it accepts connections. Read on a thread, so the
        // wait has a limit: a server that never writes it fails the test (and is killed).
        let stdout = child.stdout.take().unwrap();
        let (send, receive) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let mut line = String::new();
            let read = BufReader::new(stdout).read_line(&mut line).map(|_| line);
            let _ = send.send(read);
        });
        let mut server = Xvfb { child, display: String::new() };
        let line = match receive.recv_timeout(START_LIMIT) {
            Ok(Ok(line)) => line,
            Ok(Err(e)) => panic!("Xvfb's display number could not be read: {e}"),
            Err(_) => panic!("Xvfb did not report a display number within {START_LIMIT:?}"),
        };
        let number = line.trim();
        if number.is_empty() || number.parse::<u32>().is_err() {
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
