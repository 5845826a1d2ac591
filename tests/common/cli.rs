//! Running the built `surfc` binary, for tests through the command line: the one runner
//! (`surfc`, and `surfc_with_input` when the run reads standard input) and scratch
//! directories.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What a run of the binary gave.
pub struct Run {
    pub code: i32,
    pub stdout: Vec<u8>,
    pub stderr: String,
    pub took: Duration,
}

impl Run {
    /// (exit code, stdout, stderr).
    pub fn bytes(self) -> (i32, Vec<u8>, String) {
        (self.code, self.stdout, self.stderr)
    }

    /// (exit code, stderr).
    pub fn code_and_stderr(self) -> (i32, String) {
        (self.code, self.stderr)
    }

    /// (exit code, stdout as text, stderr).
    pub fn text(self) -> (i32, String, String) {
        let stdout = String::from_utf8_lossy(&self.stdout).into_owned();
        (self.code, stdout, self.stderr)
    }
}

/// Runs `surfc ARGS` in `dir`, its standard input empty.
pub fn surfc(args: &[&str], dir: &Path) -> Run {
    surfc_with_input(args, dir, &[])
}

/// Runs `surfc ARGS` in `dir` with `stdin` as its standard input.
pub fn surfc_with_input(args: &[&str], dir: &Path, stdin: &[u8]) -> Run {
    let started = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_surfc"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("surfc runs");
    let mut input = child.stdin.take().expect("a stdin pipe");
    // surfc may exit before reading (a usage error): a closed pipe is fine then.
    let _ = input.write_all(stdin);
    drop(input);
    let out = child.wait_with_output().expect("surfc finishes");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: out.stdout,
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        took: started.elapsed(),
    }
}

/// A fresh, empty directory for one test (`what` begins its name), removed when the test
/// ends; kept when it fails, for its files to be looked at (its path is printed then).
pub fn scratch(what: &str) -> Scratch {
    let dir = tempfile::Builder::new()
        .prefix(&format!("surfc-{what}-"))
        .tempdir()
        .expect("a scratch directory");
    Scratch(dir)
}

/// A test's scratch directory (`scratch`): `tempfile`'s, kept where the test panics.
pub struct Scratch(tempfile::TempDir);

impl std::ops::Deref for Scratch {
    type Target = Path;

    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.disable_cleanup(true);
            eprintln!(
                "the failed test's files are kept in {}",
                self.0.path().display()
            );
        }
    }
}
