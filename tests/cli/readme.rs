//! README.md stays true: its shell blocks run, in order, through the built binary in a fresh
//! directory holding a copy of `examples/` (as a clone's root does), and every link in it
//! resolves to a file of the repository. `cargo test` and `cargo install` lines are not run
//! (this is `cargo test`; the binary under test stands in for the installed one), and
//! `cargo run --release --` is the binary itself. A `surfc watch FILE …` line runs as a
//! person uses it: until its first build, then FILE is saved again (a comment appended), and
//! after the rebuild Ctrl-C ends it, which must exit 0 after two `rebuilt` lines. `pip
//! install` lines are not run either; the ```python blocks run through `python3` where the
//! `surfc` package is installed (`.ci/run` installs it, then runs this test again with
//! `SURFC_REQUIRE_PY_PACKAGE=1`, which makes its absence a failure), and are skipped with a
//! note elsewhere.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).expect("README.md")
}

/// A fenced block the test runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Shell,
    Python,
}

/// The fenced ```sh blocks, in order.
fn shell_blocks(text: &str) -> Vec<String> {
    blocks(text)
        .into_iter()
        .filter(|(kind, _)| *kind == Kind::Shell)
        .map(|(_, block)| block)
        .collect()
}

/// The fenced ```sh and ```python blocks, in order.
fn blocks(text: &str) -> Vec<(Kind, String)> {
    let mut blocks = Vec::new();
    let mut current: Option<(Kind, String)> = None;
    for line in text.lines() {
        match (&mut current, line.trim_end()) {
            (None, "```sh") => current = Some((Kind::Shell, String::new())),
            (None, "```python") => current = Some((Kind::Python, String::new())),
            (Some((kind, block)), "```") => {
                blocks.push((*kind, std::mem::take(block)));
                current = None;
            }
            (Some((_, block)), _) => {
                block.push_str(line);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    assert!(current.is_none(), "an unclosed ```sh or ```python block");
    blocks
}

/// Defines `surfc_watch`, which runs `surfc watch FILE …` (FILE first after `watch`) to its
/// first build, saves FILE again, waits for the rebuild and presses Ctrl-C: exit 0, two
/// `rebuilt` lines. Each wait has a deadline of two minutes.
const WATCH: &str = r#"
surfc_watch() {
    local file=$3 log pid
    log=$(mktemp)
    "$@" 2> "$log" &
    pid=$!
    builds() { grep -c '^rebuilt \|^failed in ' "$log" || true; }
    await() {
        for _ in $(seq 1200); do
            [ "$(builds)" -ge "$1" ] && return 0
            kill -0 "$pid" 2> /dev/null || break
            sleep 0.1
        done
        cat "$log" >&2
        echo "surfc watch: no build $1" >&2
        return 1
    }
    await 1
    echo '// saved again' >> "$file"
    await 2
    kill -INT "$pid"
    wait "$pid"
    cat "$log" >&2
    [ "$(grep -c '^rebuilt ' "$log")" -eq 2 ]
}
"#;

/// A block as the test runs it: cargo's own commands left out, `cargo run --release --` as
/// the binary on PATH.
fn runnable(block: &str) -> String {
    block
        .lines()
        .map(|line| {
            let trimmed = line.trim_start();
            if trimmed.starts_with("cargo test")
                || trimmed.starts_with("cargo install")
                || trimmed.starts_with("pip install")
            {
                ":".to_owned()
            } else if trimmed.starts_with("surfc watch ") {
                format!("surfc_watch {trimmed}")
            } else {
                line.replace("cargo run --release --", "surfc")
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("a directory");
    for entry in std::fs::read_dir(from).expect("listable") {
        let entry = entry.expect("an entry");
        if entry.file_type().expect("a type").is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).expect("copied");
        }
    }
}

#[test]
fn the_readme_commands_work_as_written() {
    assert!(
        shell_blocks(&readme()).len() >= 5,
        "the README has its walk-through"
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    copy_dir(&root().join("examples"), &dir.path().join("examples"));
    let bin = dir.path().join("bin");
    std::fs::create_dir(&bin).expect("a directory");
    #[cfg(unix)]
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_surfc"), bin.join("surfc")).expect("linked");
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let python = python_package(dir.path());
    for (k, (kind, block)) in blocks(&readme()).iter().enumerate() {
        let out = match kind {
            Kind::Shell => Command::new("bash")
                .arg("-c")
                .arg(format!("set -euo pipefail\n{WATCH}\n{}", runnable(block)))
                .current_dir(dir.path())
                .env("PATH", &path)
                .output()
                .expect("bash runs"),
            Kind::Python if !python => continue,
            Kind::Python => run_python(block, dir.path()),
        };
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "README block {} failed:\n{block}\n--- stderr:\n{stderr}",
            k + 1
        );
        if k == 0 {
            // The first command says where the mesh went, and it is there.
            assert!(stderr.contains("wrote sphere.obj"), "{stderr}");
            assert!(dir.path().join("sphere.obj").is_file());
        }
    }
    for file in [
        "first.obj",
        "first.png",
        "first.svg",
        "top.stl",
        "first.glb",
        "top.png",
    ] {
        assert!(dir.path().join(file).is_file(), "{file} was not written");
    }
}

/// Whether `python3` imports the `surfc` package (run from `dir`, where no source folder
/// shadows it). Without it the ```python blocks are skipped with a note, or fail the test
/// under `SURFC_REQUIRE_PY_PACKAGE=1`.
fn python_package(dir: &Path) -> bool {
    let imported = Command::new("python3")
        .args(["-c", "import surfc"])
        .current_dir(dir)
        .output()
        .is_ok_and(|out| out.status.success());
    if !imported {
        assert!(
            std::env::var_os("SURFC_REQUIRE_PY_PACKAGE").is_none(),
            "SURFC_REQUIRE_PY_PACKAGE is set, and python3 cannot import surfc (pip install ./python)"
        );
        eprintln!(
            "readme: python3 has no surfc package (pip install ./python): the Python blocks are not run"
        );
    }
    imported
}

/// Runs a ```python block with `python3 -` in `dir`.
fn run_python(block: &str, dir: &Path) -> std::process::Output {
    use std::io::Write;
    let mut child = Command::new("python3")
        .arg("-")
        .current_dir(dir)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("python3 runs");
    child
        .stdin
        .take()
        .expect("a stdin pipe")
        .write_all(block.as_bytes())
        .expect("the block is written");
    child.wait_with_output().expect("python3 ends")
}

#[test]
fn the_readme_links_resolve_inside_the_repository() {
    let text = readme();
    let mut links = Vec::new();
    let mut rest = text.as_str();
    while let Some(start) = rest.find("](") {
        let after = &rest[start + 2..];
        let end = after.find(')').expect("a closed link");
        links.push(after[..end].to_owned());
        rest = &after[end..];
    }
    assert!(!links.is_empty());
    assert!(
        links
            .iter()
            .any(|l| l.starts_with("docs/gallery/") && l.ends_with(".png")),
        "a gallery picture"
    );
    let root = root().canonicalize().expect("the repository");
    for link in &links {
        assert!(
            !link.contains("://") && !link.starts_with('/'),
            "{link} points outside the repository"
        );
        let target = root.join(link.split('#').next().unwrap_or(link));
        let resolved = target
            .canonicalize()
            .unwrap_or_else(|_| panic!("{link} does not exist"));
        assert!(
            resolved.starts_with(&root),
            "{link} points outside the repository"
        );
    }
    // No path that leaves the repository, linked or not.
    assert!(
        !text.contains("../"),
        "the README refers to files outside the repository"
    );
}
