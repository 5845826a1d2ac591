//! Running the built `surfc` binary in a scratch directory, for tests through the command
//! line.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// What a run of the binary gave.
pub struct Run {
    pub code: i32,
    pub stdout: Vec<u8>,
    pub stderr: String,
    pub took: Duration,
}

/// Runs `surfc ARGS` in `dir`.
pub fn surfc(args: &[&str], dir: &Path) -> Run {
    let started = Instant::now();
    let out = Command::new(env!("CARGO_BIN_EXE_surfc"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("surfc runs");
    Run {
        code: out.status.code().unwrap_or(-1),
        stdout: out.stdout,
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
        took: started.elapsed(),
    }
}

/// A fresh, empty directory for one test (`what` and the process id name it).
pub fn scratch(what: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("surfc-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}
