//! `surfc mesh -o OUT` never loses a user's file: the input as output is refused (exit 2,
//! both paths named) and stays unchanged; a read-only file is refused and unchanged; a
//! symlink stays a link and its target gets the mesh; a FIFO is written in place, read by a
//! reader; a regular file is still replaced (atomically) as before.
#![cfg(unix)]

use std::fs;
use std::os::unix::fs::{FileTypeExt, PermissionsExt};
use std::path::Path;
use std::process::Command;

use crate::common;

use common::cli::scratch;

/// Runs `surfc ARGS` in `dir`: exit code and stderr.
fn surfc(args: &[&str], dir: &Path) -> (i32, String) {
    let run = common::cli::surfc(args, dir);
    (run.code, run.stderr)
}

const SPHERE: &str = "surface sphere = x^2 + y^2 + z^2 - 4;\n\
                      mesh ball = sphere { step: 0.8; start: (1, 1, 1); }\n";

/// Whether `bytes` are an OBJ file with a mesh in it (vertices and faces).
fn is_obj_mesh(bytes: &[u8]) -> bool {
    let text = String::from_utf8_lossy(bytes);
    text.lines().any(|l| l.starts_with("v ")) && text.lines().any(|l| l.starts_with("f "))
}

#[test]
fn the_input_file_is_never_the_output() {
    let dir = scratch("out-input");
    fs::write(dir.join("ball.surf"), SPHERE).unwrap();
    // By name, through another spelling of the path, and through a hard link.
    fs::hard_link(dir.join("ball.surf"), dir.join("hard.obj")).unwrap();
    for out in ["ball.surf", "./ball.surf", "hard.obj"] {
        let (code, stderr) = surfc(
            &["mesh", "ball.surf", "-o", out, "--format", "obj", "-q"],
            &dir,
        );
        assert_eq!(code, 2, "{out}: {stderr}");
        assert!(
            stderr.contains(&format!("`{out}`")) && stderr.contains("input file `ball.surf`"),
            "{out}: {stderr}"
        );
        assert_eq!(fs::read_to_string(dir.join("ball.surf")).unwrap(), SPHERE);
    }
}

#[test]
fn a_read_only_file_is_not_replaced() {
    let dir = scratch("out-readonly");
    fs::write(dir.join("ball.surf"), SPHERE).unwrap();
    let out = dir.join("keep.obj");
    fs::write(&out, "precious\n").unwrap();
    fs::set_permissions(&out, fs::Permissions::from_mode(0o444)).unwrap();
    let (code, stderr) = surfc(&["mesh", "ball.surf", "-o", "keep.obj", "-q"], &dir);
    assert_eq!(code, 2, "{stderr}");
    assert!(
        stderr.contains("`keep.obj`") && stderr.contains("permission denied"),
        "{stderr}"
    );
    assert_eq!(fs::read_to_string(&out).unwrap(), "precious\n");
    assert_eq!(
        fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o444
    );
}

#[test]
fn a_symlink_stays_a_link_and_its_target_gets_the_mesh() {
    let dir = scratch("out-symlink");
    fs::write(dir.join("ball.surf"), SPHERE).unwrap();
    fs::create_dir_all(dir.join("store")).unwrap();
    fs::write(dir.join("store/real.obj"), "old\n").unwrap();
    std::os::unix::fs::symlink("store/real.obj", dir.join("link.obj")).unwrap();
    let (code, stderr) = surfc(&["mesh", "ball.surf", "-o", "link.obj", "-q"], &dir);
    assert_eq!(code, 0, "{stderr}");
    let link = fs::symlink_metadata(dir.join("link.obj")).unwrap();
    assert!(link.file_type().is_symlink());
    assert_eq!(
        fs::read_link(dir.join("link.obj")).unwrap(),
        Path::new("store/real.obj")
    );
    assert!(is_obj_mesh(&fs::read(dir.join("store/real.obj")).unwrap()));
    // No temporary file left beside the link or the target.
    for d in [dir.to_path_buf(), dir.join("store")] {
        for entry in fs::read_dir(d).unwrap() {
            let name = entry.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.ends_with(".tmp"), "left over: {name}");
        }
    }
}

#[test]
fn a_fifo_is_written_in_place_and_read_by_a_reader() {
    let dir = scratch("out-fifo");
    fs::write(dir.join("ball.surf"), SPHERE).unwrap();
    let fifo = dir.join("pipe.obj");
    let made = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || fs::read(fifo).expect("the reader reads the FIFO"))
    };
    let (code, stderr) = surfc(&["mesh", "ball.surf", "-o", "pipe.obj", "-q"], &dir);
    assert_eq!(code, 0, "{stderr}");
    let bytes = reader.join().unwrap();
    assert!(is_obj_mesh(&bytes));
    assert!(fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
}

#[test]
fn a_regular_file_is_replaced_with_its_permissions() {
    let dir = scratch("out-regular");
    fs::write(dir.join("ball.surf"), SPHERE).unwrap();
    let out = dir.join("ball.obj");
    fs::write(&out, "old\n").unwrap();
    fs::set_permissions(&out, fs::Permissions::from_mode(0o640)).unwrap();
    let (code, stderr) = surfc(&["mesh", "ball.surf", "-q"], &dir);
    assert_eq!(code, 0, "{stderr}");
    assert!(is_obj_mesh(&fs::read(&out).unwrap()));
    assert_eq!(
        fs::metadata(&out).unwrap().permissions().mode() & 0o777,
        0o640
    );
}
