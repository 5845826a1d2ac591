//! An interrupted write leaves nothing behind: SIGINT (Ctrl-C) or SIGTERM sent to `surfc
//! mesh` while it writes a large file removes its temporary file, keeps the output as it was,
//! and exits 128 + the signal (130, 143), as docs/cli.md says.

#![cfg(unix)]

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::cli;

/// A sphere of about 580 000 triangles: its OBJ (about 60 MB) takes a good part of a second
/// to write, long after its temporary file appears.
const LARGE: &str =
    "surface ball = sphere(2);\nmesh ball = ball { step: 0.015; start: (2, 0, 0); }\n";

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("the directory lists")
        .map(|e| {
            e.expect("an entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    names
}

/// Runs `surfc mesh large.surf -o large.obj` in `dir`, sends `signal` as soon as the
/// temporary file of the output appears, and returns the exit code.
fn interrupted_write(dir: &Path, signal: libc::c_int) -> i32 {
    let mut child = Command::new(env!("CARGO_BIN_EXE_surfc"))
        .args(["mesh", "large.surf", "-o", "large.obj", "--quiet"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("surfc runs");
    let started = Instant::now();
    let temporary = loop {
        if let Some(name) = listing(dir)
            .into_iter()
            .find(|n| n.starts_with(".large.obj.") && n.ends_with(".tmp"))
        {
            break name;
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("surfc ended ({status}) before it wrote a temporary file");
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no temporary file after two minutes"
        );
        std::thread::sleep(Duration::from_millis(1));
    };
    let pid = libc::pid_t::try_from(child.id()).expect("a pid");
    // SAFETY: kill(2) with the pid of a child this test started and has not waited for.
    let sent = unsafe { libc::kill(pid, signal) };
    assert_eq!(sent, 0, "the signal is sent");
    let out = child.wait_with_output().expect("surfc ends");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !listing(dir).contains(&temporary),
        "{temporary} is left behind; stderr: {stderr}"
    );
    out.status.code().unwrap_or(-1)
}

#[test]
fn an_interrupted_write_leaves_no_temporary_file() {
    let dir = cli::scratch("interrupt");
    std::fs::write(dir.join("large.surf"), LARGE).expect("written");
    // The output exists already: an interrupted write leaves it as it was.
    std::fs::write(dir.join("large.obj"), "old\n").expect("written");
    for (signal, code) in [(libc::SIGINT, 130), (libc::SIGTERM, 143)] {
        assert_eq!(
            interrupted_write(&dir, signal),
            code,
            "the exit code after signal {signal}"
        );
        assert_eq!(listing(&dir), ["large.obj", "large.surf"]);
        assert_eq!(
            std::fs::read_to_string(dir.join("large.obj")).expect("read"),
            "old\n"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
