//! `surfc watch`: a rebuild at every save of the file or of a file it imports, one line per
//! rebuild, a broken save reported without ending the watch and without touching the last
//! good output, Ctrl-C ending it with exit 0 and no temporary file left (docs/cli.md).
//!
//! The tests wait for what the watch prints (`--json`: one object per rebuild on stdout)
//! and for the output's contents, each with a generous deadline, never for a fixed time.

#![cfg(unix)]

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use crate::common::cli;

/// Long enough for a rebuild on a loaded two-core machine, many times over.
const DEADLINE: Duration = Duration::from_secs(120);

fn ball(radius: f64) -> String {
    format!(
        "surface ball = sphere({radius});\nmesh ball = ball {{ step: 0.25; start: ({radius}, 0, 0); }}\n"
    )
}

/// A running `surfc watch` with its stdout and stderr read line by line.
struct Watch {
    child: Child,
    stdout: Receiver<String>,
    stderr: Receiver<String>,
    /// Every stderr line read so far.
    log: Vec<String>,
}

impl Watch {
    fn start(dir: &Path, args: &[&str]) -> Watch {
        let mut child = Command::new(env!("CARGO_BIN_EXE_surfc"))
            .arg("watch")
            .args(args)
            .current_dir(dir)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("surfc runs");
        let lines = |stream: Box<dyn std::io::Read + Send>| {
            let (send, receive) = channel();
            std::thread::spawn(move || {
                for line in BufReader::new(stream).lines() {
                    let Ok(line) = line else { break };
                    if send.send(line).is_err() {
                        break;
                    }
                }
            });
            receive
        };
        let stdout = lines(Box::new(child.stdout.take().expect("stdout")));
        let stderr = lines(Box::new(child.stderr.take().expect("stderr")));
        Watch {
            child,
            stdout,
            stderr,
            log: Vec::new(),
        }
    }

    /// The next JSON object on stdout (one per rebuild), once the rebuild's line on stderr
    /// (which follows it) is there too.
    fn next_report(&mut self) -> serde_json::Value {
        let line = self.stdout.recv_timeout(DEADLINE).unwrap_or_else(|e| {
            self.drain();
            panic!(
                "no rebuild within {DEADLINE:?} ({e}); stderr:\n{}",
                self.log.join("\n")
            )
        });
        loop {
            let Ok(log) = self.stderr.recv_timeout(DEADLINE) else {
                panic!("no line of the rebuild on stderr:\n{}", self.log.join("\n"));
            };
            let done = log.starts_with("rebuilt ") || log.starts_with("failed in ");
            self.log.push(log);
            if done {
                break;
            }
        }
        serde_json::from_str(&line).unwrap_or_else(|e| panic!("not JSON ({e}): {line}"))
    }

    fn drain(&mut self) {
        while let Ok(line) = self.stderr.try_recv() {
            self.log.push(line);
        }
    }

    /// Sends SIGINT (Ctrl-C) and waits for the end: the exit code and every stderr line.
    fn interrupt(mut self) -> (i32, Vec<String>) {
        let pid = libc::pid_t::try_from(self.child.id()).expect("a pid");
        // SAFETY: kill(2) with the pid of a child this test started and has not waited for.
        assert_eq!(
            unsafe { libc::kill(pid, libc::SIGINT) },
            0,
            "the signal is sent"
        );
        let started = Instant::now();
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("waitable") {
                break status;
            }
            if started.elapsed() > DEADLINE {
                let _ = self.child.kill();
                panic!("surfc watch did not end after Ctrl-C");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        // The reader ends at the end of the stream.
        while let Ok(line) = self.stderr.recv_timeout(DEADLINE) {
            self.log.push(line);
        }
        (status.code().unwrap_or(-1), std::mem::take(&mut self.log))
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        // A failed test does not leave the watch running.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Saves as editors do: a new file renamed over the old one.
fn save_by_rename(path: &Path, text: &str) {
    let temporary = path.with_extension("surf.swp");
    std::fs::write(&temporary, text).expect("written");
    std::fs::rename(&temporary, path).expect("renamed");
}

fn temporary_files(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .expect("listable")
        .map(|e| {
            e.expect("an entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[test]
fn a_broken_save_reports_and_keeps_the_last_good_output() {
    let dir = cli::scratch("watch-good-broken-good");
    let file = dir.join("ball.surf");
    std::fs::write(&file, ball(1.0)).expect("written");
    let mut watch = Watch::start(&dir, &["ball.surf", "-o", "ball.obj", "--json"]);

    // The first build, at the start.
    let first = watch.next_report();
    assert_eq!(first["meshes"][0]["name"], "ball", "{first}");
    let good = std::fs::read(dir.join("ball.obj")).expect("the first output");

    // A broken save: the diagnostic, and the output as it was.
    save_by_rename(&file, "surface ball = sphere(1;\n");
    let broken = watch.next_report();
    assert_eq!(broken["errors"][0]["code"], "E0003", "{broken}");
    assert_eq!(broken["errors"][0]["line"], 1, "{broken}");
    assert_eq!(
        std::fs::read(dir.join("ball.obj")).expect("still there"),
        good,
        "the broken save changed the output"
    );

    // A good save, written in place: a new output.
    std::fs::write(&file, ball(1.5)).expect("written");
    let second = watch.next_report();
    assert_eq!(second["meshes"][0]["name"], "ball", "{second}");
    let new = std::fs::read(dir.join("ball.obj")).expect("the second output");
    assert_ne!(new, good, "the output was not rebuilt");

    let (code, stderr) = watch.interrupt();
    let text = stderr.join("\n");
    assert_eq!(code, 0, "Ctrl-C ends a watch with exit 0:\n{text}");
    let rebuilt = stderr
        .iter()
        .filter(|l| l.starts_with("rebuilt ball.obj in "))
        .count();
    let failed = stderr
        .iter()
        .filter(|l| l.starts_with("failed in "))
        .count();
    assert_eq!((rebuilt, failed), (2, 1), "{text}");
    assert!(
        text.contains("error[E0003]"),
        "the diagnostic is rendered:\n{text}"
    );
    assert!(text.contains("ball.surf:1:"), "{text}");
    assert!(
        text.contains("the files of the last good build are left in place"),
        "{text}"
    );
    assert!(text.contains("stopped watching"), "{text}");
    assert!(
        temporary_files(&dir).is_empty(),
        "{:?}",
        temporary_files(&dir)
    );
}

#[test]
fn a_save_of_an_imported_file_rebuilds_and_redraws() {
    let dir = cli::scratch("watch-imports");
    std::fs::create_dir(dir.join("lib")).expect("a directory");
    std::fs::write(dir.join("lib/shape.surf"), "const r = 1;\n").expect("written");
    std::fs::write(
        dir.join("main.surf"),
        "import \"lib/shape.surf\";\nsurface ball = sphere(r);\n\
         mesh ball = ball { step: 0.25; start: (1, 0, 0); }\n",
    )
    .expect("written");
    let mut watch = Watch::start(
        &dir,
        &[
            "main.surf",
            "--json",
            "--render",
            "main.png",
            "--size",
            "64x48",
        ],
    );
    let first = watch.next_report();
    let triangles = first["meshes"][0]["triangles"].as_u64().expect("a count");
    let picture = std::fs::read(dir.join("main.png")).expect("the picture");
    assert!(dir.join("main.obj").is_file());

    // A save of the imported file (a larger sphere: more triangles, another picture).
    save_by_rename(&dir.join("lib/shape.surf"), "const r = 2;\n");
    let second = watch.next_report();
    let more = second["meshes"][0]["triangles"].as_u64().expect("a count");
    assert!(
        more > triangles,
        "{triangles} → {more}: not rebuilt from the import"
    );
    assert_ne!(
        std::fs::read(dir.join("main.png")).expect("the picture"),
        picture
    );

    // A file the source does not read: no rebuild. Then the root again: one.
    std::fs::write(dir.join("lib/other.surf"), "const q = 1;\n").expect("written");
    std::fs::write(dir.join("main.obj.note"), "x").expect("written");
    std::fs::write(
        dir.join("main.surf"),
        "import \"lib/shape.surf\";\nsurface ball = sphere(r / 2);\n\
         mesh ball = ball { step: 0.25; start: (1, 0, 0); }\n",
    )
    .expect("written");
    let third = watch.next_report();
    assert_eq!(
        third["meshes"][0]["triangles"].as_u64(),
        Some(triangles),
        "the next rebuild is the root's save (r / 2 = 1): {third}"
    );
    let (code, stderr) = watch.interrupt();
    let text = stderr.join("\n");
    assert_eq!(code, 0, "{text}");
    let rebuilt = stderr
        .iter()
        .filter(|l| l.starts_with("rebuilt main.obj and main.png in "))
        .count();
    assert_eq!(rebuilt, 3, "{text}");
}

#[test]
fn what_cannot_be_watched_is_a_usage_error() {
    let dir = cli::scratch("watch-usage");
    std::fs::write(dir.join("ball.surf"), ball(1.0)).expect("written");
    for (args, says) in [
        (&["-"][..], "standard input"),
        (&["ball.surf", "-o", "-"][..], "`-o -`"),
        (&["missing.surf"][..], "cannot read `missing.surf`"),
        (
            &["ball.surf", "-o", "ball.surf", "--format", "obj"][..],
            "it is the input file",
        ),
        (
            &["ball.surf", "--render", "ball.jpg"][..],
            "use .png or .svg",
        ),
    ] {
        let mut all = vec!["watch"];
        all.extend_from_slice(args);
        let (code, stderr) = cli::surfc(&all, &dir).code_and_stderr();
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}
