//! README.md stays true: its shell blocks run, in order, through the built binary in a fresh
//! directory holding a copy of `examples/` (as a clone's root does), and every link in it
//! resolves to a file of the repository. `cargo test` and `cargo install` lines are not run
//! (this is `cargo test`; the binary under test stands in for the installed one), and
//! `cargo run --release --` is the binary itself.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn readme() -> String {
    std::fs::read_to_string(root().join("README.md")).expect("README.md")
}

/// The fenced ```sh blocks, in order.
fn shell_blocks(text: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match (&mut current, line.trim_end()) {
            (None, "```sh") => current = Some(String::new()),
            (Some(block), "```") => {
                blocks.push(std::mem::take(block));
                current = None;
            }
            (Some(block), _) => {
                block.push_str(line);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    assert!(current.is_none(), "an unclosed ```sh block");
    blocks
}

/// A block as the test runs it: cargo's own commands left out, `cargo run --release --` as
/// the binary on PATH.
fn runnable(block: &str) -> String {
    block
        .lines()
        .map(|line| {
            let trimmed = line.trim_start();
            if trimmed.starts_with("cargo test") || trimmed.starts_with("cargo install") {
                ":".to_owned()
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
    let blocks = shell_blocks(&readme());
    assert!(blocks.len() >= 5, "the README has its walk-through");
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
    for (k, block) in blocks.iter().enumerate() {
        let script = format!("set -euo pipefail\n{}", runnable(block));
        let out = Command::new("bash")
            .arg("-c")
            .arg(&script)
            .current_dir(dir.path())
            .env("PATH", &path)
            .output()
            .expect("bash runs");
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
    ] {
        assert!(dir.path().join(file).is_file(), "{file} was not written");
    }
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
