//! `surfc eval` and `surfc bytecode` through the binary.

use crate::common::cli;
use crate::common::sources as common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// The gallery's sphere file if it is there, else the same formula in a temporary file.
fn sphere_file(dir: &tempfile::TempDir) -> PathBuf {
    let example = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples/sphere.surf");
    if example.exists() {
        return example;
    }
    let path = dir.path().join("sphere.surf");
    std::fs::write(&path, common::SPHERE).unwrap();
    path
}

#[test]
fn eval_json_prints_value_and_gradient() {
    let dir = tempfile::tempdir().unwrap();
    let file = sphere_file(&dir);
    let mut args = vec!["eval", file.to_str().unwrap(), "sphere", "1", "1", "1"];
    args.push("--json");
    let (code, stdout, stderr) = cli::surfc(&args, Path::new(".")).text();
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    assert_eq!(
        v,
        serde_json::json!({"value": -1.0, "gradient": [2.0, 2.0, 2.0]})
    );
    assert_eq!(stdout.lines().count(), 1);
    // The interpreter prints the same; an unknown engine is a usage error.
    args.extend(["--engine", "interpreter"]);
    assert_eq!(
        cli::surfc(&args, Path::new(".")).text(),
        (0, stdout, String::new())
    );
    args.pop();
    args.push("jit");
    let (code, _, stderr) = cli::surfc(&args, Path::new(".")).text();
    assert_eq!(code, 2, "{stderr}");
    assert!(stderr.contains("invalid value 'jit'"), "{stderr}");
}

#[test]
fn eval_accepts_negative_coordinates_and_prints_a_line() {
    let dir = tempfile::tempdir().unwrap();
    let file = sphere_file(&dir);
    let (code, stdout, stderr) = cli::surfc(
        &["eval", file.to_str().unwrap(), "sphere", "-2", "0", "0.5"],
        Path::new("."),
    )
    .text();
    assert_eq!(code, 0, "{stderr}");
    assert_eq!(stdout, "sphere(-2, 0, 0.5) = 0.25, gradient (-4, 0, 1)\n");
}

#[test]
fn unknown_surface_lists_the_known_ones() {
    let dir = tempfile::tempdir().unwrap();
    let file = sphere_file(&dir);
    let (code, stdout, stderr) = cli::surfc(
        &["eval", file.to_str().unwrap(), "sphre", "0", "0", "0"],
        Path::new("."),
    )
    .text();
    assert_eq!(code, 1);
    assert!(stdout.is_empty());
    assert!(
        stderr.contains("no surface `sphre`") && stderr.contains("sphere"),
        "{stderr}"
    );
    let (code, _, stderr) = cli::surfc(
        &["bytecode", file.to_str().unwrap(), "nope"],
        Path::new("."),
    )
    .text();
    assert_eq!(code, 1);
    assert!(stderr.contains("the file defines: sphere"), "{stderr}");
}

#[test]
fn bytecode_prints_the_listing() {
    let dir = tempfile::tempdir().unwrap();
    let file = sphere_file(&dir);
    let (code, stdout, stderr) = cli::surfc(
        &["bytecode", file.to_str().unwrap(), "sphere"],
        Path::new("."),
    )
    .text();
    assert_eq!(code, 0, "{stderr}");
    let p = common::program(common::SPHERE);
    let l = surfc::compile::lower_surface(
        &p,
        &surfc::sema::program::SurfaceRef::Surface(common::surface_id(&p, "sphere")),
    )
    .unwrap();
    assert_eq!(stdout, surfc::compile::listing(&p, &l));
    assert!(stdout.contains("  0  r4 = square r0\n"), "{stdout}");
}

/// `surfc bytecode … | head -1`: a reader that stops early is not an error (no panic, exit 0).
#[test]
fn a_reader_that_stops_early_is_not_an_error() {
    use std::io::BufRead;
    // A listing far longer than a pipe's buffer: 1000 distinct terms.
    let source = common::large_source("long", 20, |k| {
        format!("(x * {} - y * {}.5)^2", k + 1, k % 7)
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("long.surf");
    std::fs::write(&path, source).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_surfc"))
        .args(["bytecode", path.to_str().unwrap(), "long"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run surfc");
    let mut first = String::new();
    {
        let stdout = child.stdout.take().unwrap();
        std::io::BufReader::new(stdout)
            .read_line(&mut first)
            .unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(first.starts_with("; 3 inputs"), "{first}");
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    assert!(stderr.is_empty(), "{stderr}");
}

/// `offset` rounds a box (issue 42): beyond its corner, `surfc eval` gives the distance to
/// the corner minus the offset and the unit vector from the corner (before: NaN).
#[test]
fn eval_of_a_rounded_box_beyond_its_corner() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rounded.surf");
    std::fs::write(
        &path,
        "surface b = box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5));\nsurface r = offset(b, 0.2);\n",
    )
    .unwrap();
    let args = [
        "eval",
        path.to_str().unwrap(),
        "r",
        "0.65",
        "0.65",
        "0.65",
        "--json",
    ];
    let (code, stdout, stderr) = cli::surfc(&args, Path::new(".")).text();
    assert_eq!(code, 0, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap();
    let value = v["value"].as_f64().expect("a number");
    let expected = (3.0f64 * 0.15 * 0.15).sqrt() - 0.2;
    assert!(
        (value - expected).abs() <= 1e-15,
        "{value} against {expected}"
    );
    let unit = 1.0 / 3.0f64.sqrt();
    for g in v["gradient"].as_array().expect("three numbers") {
        assert!((g.as_f64().expect("a number") - unit).abs() <= 1e-15, "{v}");
    }
}
