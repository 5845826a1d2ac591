//! The progress lines a person sees while `surfc mesh` works, read from a pseudo-terminal
//! (util-linux's `script` gives the command one): for each mesh block that takes a while, a
//! count of triangles that rises while it meshes — from the marches of the parallel pieces
//! of a large component, and from the component search of a block with a box, where a bar
//! towards the box's estimate, the time left and the components found show too — drawn one
//! below the other while the blocks mesh at once; then the bytes of the file being written.
//!
//! Without `script` the test says so on stderr and passes.

#![cfg(target_os = "linux")]

use std::io::Write as _;
use std::process::Command;

use crate::common::cli;

/// Two blocks that take a second or more each in the test build: a sphere from a start
/// point (parallel pieces) and two in a box (the component search), written as an OBJ of
/// some 100 MB. The box's small ball is found first, so the line counts one component
/// while the large one is still marching (the count rises when a component is accepted,
/// after its march: a box of one component would show it only in its last tenth of a
/// second).
const TWO: &str = "surface ball = sphere(2);\n\
                   surface pair = sphere(2) * translate(sphere(0.8), (-4, 0, 0));\n\
                   mesh whole = ball { step: 0.014; start: (2, 0, 0); }\n\
                   mesh boxed = pair { step: 0.02; box: (-5, -3, -3) .. (3, 3, 3); }\n";

/// The lines as a terminal shows them one after another: split at carriage returns and
/// newlines, escape sequences left out.
fn screens(output: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    let mut chars = output.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\r' | '\n' => lines.push(std::mem::take(&mut line)),
            // CSI sequences: ESC [ parameters final-byte.
            '\x1b' => {
                if chars.peek() == Some(&'[') {
                    chars.next();
                    for c in chars.by_ref() {
                        if c.is_ascii_alphabetic() {
                            break;
                        }
                    }
                }
            }
            c => line.push(c),
        }
    }
    lines.push(line);
    lines
}

/// The counts the lines of block `name` showed, in order.
fn counts(lines: &[String], name: &str) -> Vec<u64> {
    let key = format!("meshing {name}: ");
    lines
        .iter()
        .filter_map(|l| {
            let rest = &l[l.find(&key)? + key.len()..];
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            digits.parse().ok()
        })
        .collect()
}

/// The triangles of block `name` in the summary table.
fn summary_triangles(lines: &[String], name: &str) -> u64 {
    lines
        .iter()
        .find_map(|l| {
            let mut cells = l.split_whitespace();
            (cells.next() == Some(name))
                .then(|| cells.next()?.parse().ok())
                .flatten()
        })
        .unwrap_or_else(|| panic!("no summary row for `{name}`"))
}

#[test]
fn the_progress_lines_count_while_the_blocks_mesh() {
    if !Command::new("script")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        let _ = writeln!(
            std::io::stderr(),
            "\n*** SKIPPED: util-linux's `script` is not available; the progress lines are NOT \
             checked. ***\n"
        );
        return;
    }
    let dir = cli::scratch("progress");
    std::fs::write(dir.join("two.surf"), TWO).expect("written");
    let surfc = env!("CARGO_BIN_EXE_surfc");
    // `script` runs the command on a pseudo-terminal and copies what it shows to stdout.
    let out = Command::new("script")
        .args(["--quiet", "--return", "--flush", "--command"])
        .arg(format!("'{surfc}' mesh two.surf -o two.obj --threads 2"))
        .arg("/dev/null")
        .current_dir(&dir)
        .env("TERM", "xterm")
        .env("SURFC_PROGRESS_DELAY_MS", "0")
        .output()
        .expect("script runs");
    let shown = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{}\n{shown}", out.status);
    let lines = screens(&shown);
    for name in ["whole", "boxed"] {
        let seen = counts(&lines, name);
        let made = summary_triangles(&lines, name);
        // The count rises while the block meshes: several values between none and the
        // mesh's triangles, in increasing order at least twice.
        let between: Vec<u64> = seen
            .iter()
            .copied()
            .filter(|&n| 0 < n && n < made)
            .collect();
        let rises = seen.windows(2).filter(|w| w[0] < w[1]).count();
        assert!(
            between.len() >= 2 && rises >= 2,
            "`{name}` ({made} triangles) showed {seen:?}"
        );
        assert!(seen.iter().all(|&n| n <= 2 * made), "`{name}`: {seen:?}");
    }
    // The block in a box has an estimate: a bar, the time left, and its component.
    let boxed = |needle: &str| {
        lines
            .iter()
            .any(|l| l.contains("meshing boxed: ") && l.contains(needle))
    };
    assert!(
        boxed(" of ~") && boxed("left)") && boxed("1 component"),
        "{shown}"
    );
    // Both blocks' lines were up at once, one below the other.
    assert!(
        lines.windows(2).any(|w| {
            let pair = format!("{}\n{}", w[0], w[1]);
            pair.contains("meshing whole: ") && pair.contains("meshing boxed: ")
        }),
        "{shown}"
    );
    // The file is written with its own line, counting bytes.
    assert!(
        lines
            .iter()
            .any(|l| l.contains("writing two.obj: ") && !l.contains(": 0 B")),
        "{shown}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
