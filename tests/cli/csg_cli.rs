//! CSG, `import` and `-D` through the binary (issue 12, Must show 4 and the smooth boolean):
//! `surfc eval` of a turned and moved sphere, a part imported from a subfolder from any
//! working directory, `-D` on `mesh`, `eval`, `check` and `render`, and a smooth union meshed
//! watertight with the Euler characteristic of a sphere.

use crate::common;

use std::path::Path;

use common::cli::{scratch, surfc};

fn json(stdout: &[u8]) -> serde_json::Value {
    serde_json::from_slice(stdout).expect("one JSON object on stdout")
}

/// The vertices of an OBJ file.
fn obj_vertices(path: &Path) -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(path).expect("the OBJ file");
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .map(|t| t.parse().expect("a number"))
                .collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

#[test]
fn eval_of_a_turned_and_moved_sphere() {
    let dir = scratch("csg-eval");
    std::fs::write(
        dir.join("turned.surf"),
        "surface s = rotate(translate(sphere(1), (2, 0, 0)), axis: (0, 0, 1), angle: pi / 2);\n",
    )
    .expect("write");
    let run = surfc(&["eval", "turned.surf", "s", "0", "3", "0", "--json"], &dir);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let out = json(&run.stdout);
    let value = out["value"].as_f64().expect("value");
    let g: Vec<f64> = out["gradient"]
        .as_array()
        .expect("gradient")
        .iter()
        .map(|v| v.as_f64().expect("number"))
        .collect();
    assert!(value.abs() <= 1e-12, "value {value}");
    assert!(
        g[0].abs() <= 1e-12 && (g[1] - 1.0).abs() <= 1e-12 && g[2].abs() <= 1e-12,
        "{g:?}"
    );
}

/// A part in a subfolder that imports a file beside it, and a main file that imports the part.
fn project(dir: &Path) {
    std::fs::create_dir_all(dir.join("parts")).expect("mkdir");
    std::fs::write(dir.join("parts/units.surf"), "const unit = 0.5;\n").expect("write");
    std::fs::write(
        dir.join("parts/ball.surf"),
        "import \"units.surf\";\nconst r = 1;\nsurface ball = sphere(r * 2 * unit);\n\
         mesh not_mine = ball { step: 0.5; start: (1, 0, 0); }\n",
    )
    .expect("write");
    std::fs::write(
        dir.join("main.surf"),
        "import \"parts/ball.surf\";\n\
         surface moved = translate(ball, (0, 0, 1));\n\
         mesh m = moved { step: 0.2; box: (-3, -3, -3) .. (3, 3, 4); }\n",
    )
    .expect("write");
}

#[test]
fn import_from_a_subfolder_works_from_any_directory() {
    let dir = scratch("csg-import");
    project(&dir);
    let elsewhere = scratch("csg-import-elsewhere");
    let main = dir.join("main.surf");
    let main = main.to_str().expect("utf-8 path");
    // From the project, from its subfolder (a relative path upwards), from somewhere else.
    for (cwd, file) in [
        (dir.to_path_buf(), "main.surf".to_string()),
        (dir.join("parts"), "../main.surf".to_string()),
        (elsewhere.to_path_buf(), main.to_string()),
    ] {
        let run = surfc(&["check", &file], &cwd);
        assert_eq!(run.code, 0, "check from {}: {}", cwd.display(), run.stderr);
        // An imported file's unused constant is not the main file's business.
        assert!(!run.stderr.contains("warning"), "{}", run.stderr);
        let run = surfc(&["eval", &file, "moved", "0", "0", "2", "--json"], &cwd);
        assert_eq!(run.code, 0, "eval from {}: {}", cwd.display(), run.stderr);
        assert!(json(&run.stdout)["value"].as_f64().expect("value").abs() <= 1e-12);
    }
    // Only the main file's mesh block is meshed; the imported one is not in scope.
    let run = surfc(
        &["mesh", main, "--json", "--quiet", "-o", "out.obj"],
        &elsewhere,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let report = json(&run.stdout);
    let meshes = report["meshes"].as_array().expect("meshes");
    assert_eq!(meshes.len(), 1);
    assert_eq!(meshes[0]["name"], "m");
    assert_eq!(meshes[0]["euler_characteristic"], 2);
    assert_eq!(meshes[0]["boundary_edges"], 0);
    // A diagnostic inside the imported file names that file.
    std::fs::write(dir.join("parts/units.surf"), "const unit = sphere(1);\n").expect("write");
    let run = surfc(&["check", "--color", "never", main], &elsewhere);
    assert_eq!(run.code, 1);
    assert!(
        run.stderr.contains("parts/units.surf:1:14"),
        "{}",
        run.stderr
    );
}

#[test]
fn define_sets_a_constant_for_mesh_eval_check_and_render() {
    let dir = scratch("csg-define");
    std::fs::write(
        dir.join("ball.surf"),
        "const r = 1;\nconst h = 2;\nsurface s = sphere(r);\n\
         mesh m = s { step: 0.25; box: (-3, -3, -3) .. (3, 3, 3); }\n",
    )
    .expect("write");
    let run = surfc(
        &[
            "mesh",
            "ball.surf",
            "-D",
            "r=2",
            "--quiet",
            "-o",
            "ball.obj",
        ],
        &dir,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let v = obj_vertices(&dir.join("ball.obj"));
    assert!(v.len() > 100);
    let radius = |p: &[f64; 3]| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    assert!(
        v.iter().all(|p| (radius(p) - 2.0).abs() <= 1e-9),
        "a vertex off the radius-2 sphere"
    );
    // The extent is that of the radius-2 sphere along every axis (within a step).
    for k in 0..3 {
        let hi = v.iter().map(|p| p[k]).fold(f64::MIN, f64::max);
        let lo = v.iter().map(|p| p[k]).fold(f64::MAX, f64::min);
        assert!(
            hi > 2.0 - 0.25 && lo < -2.0 + 0.25,
            "axis {k}: {lo} .. {hi}"
        );
    }
    let run = surfc(
        &[
            "eval",
            "ball.surf",
            "s",
            "2",
            "0",
            "0",
            "-D",
            "r=2",
            "--json",
        ],
        &dir,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(json(&run.stdout)["value"].as_f64().expect("value").abs() <= 1e-12);
    let run = surfc(
        &["check", "ball.surf", "-D", "r=0.5", "-D", "h=-1e-3"],
        &dir,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let run = surfc(
        &[
            "render",
            "ball.surf",
            "-D",
            "r=2",
            "-o",
            "ball.png",
            "--quiet",
        ],
        &dir,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    // An unknown name lists the file's constants (exit 1).
    let run = surfc(
        &["check", "--color", "never", "ball.surf", "-D", "radius=2"],
        &dir,
    );
    assert_eq!(run.code, 1);
    assert!(run.stderr.contains("E0701"), "{}", run.stderr);
    assert!(run.stderr.contains("`r`, `h`"), "{}", run.stderr);
    // A surface is no constant.
    let run = surfc(
        &["check", "--color", "never", "ball.surf", "-D", "s=2"],
        &dir,
    );
    assert_eq!(run.code, 1);
    assert!(run.stderr.contains("`s` is a surface"), "{}", run.stderr);
    // A malformed value and a name given twice are usage errors (exit 2).
    for bad in [
        ["-D", "r=two"],
        ["-D", "r"],
        ["-D", "r=inf"],
        ["-D", "2r=1"],
    ] {
        let run = surfc(&["check", "ball.surf", bad[0], bad[1]], &dir);
        assert_eq!(run.code, 2, "{bad:?}: {}", run.stderr);
        assert!(run.stderr.contains("NAME=VALUE"), "{}", run.stderr);
    }
    let run = surfc(&["check", "ball.surf", "-D", "r=1", "-D", "r=2"], &dir);
    assert_eq!(run.code, 2);
    assert!(run.stderr.contains("given twice"), "{}", run.stderr);
}

#[test]
fn smooth_union_of_two_spheres_meshes_watertight() {
    let dir = scratch("csg-smooth");
    std::fs::write(
        dir.join("blob.surf"),
        "surface blob = smooth_union(sphere(1), translate(sphere(0.8), (1.5, 0, 0)), 0.4);\n\
         mesh m = blob { step: 0.15; box: (-2, -2, -2) .. (3, 2, 2); }\n",
    )
    .expect("write");
    let run = surfc(
        &["mesh", "blob.surf", "--json", "--quiet", "-o", "blob.obj"],
        &dir,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let m = &json(&run.stdout)["meshes"][0];
    assert_eq!(m["euler_characteristic"], 2, "{m}");
    assert_eq!(m["boundary_edges"], 0, "{m}");
    assert_eq!(m["non_manifold_edges"], 0, "{m}");
    assert_eq!(m["components"], 1, "{m}");
    assert!(
        m["max_chord_error"].as_f64().expect("chord") <= 0.1 * 0.15,
        "{m}"
    );
    // The extent along x: from the first sphere's left pole to the second's right one.
    let v = obj_vertices(&dir.join("blob.obj"));
    let lo = v.iter().map(|p| p[0]).fold(f64::MAX, f64::min);
    let hi = v.iter().map(|p| p[0]).fold(f64::MIN, f64::max);
    assert!((-1.0 - 1e-9..-1.0 + 0.15).contains(&lo), "{lo}");
    assert!(hi > 2.3 - 0.15 && hi - 2.3 <= 1e-9, "{hi}");
}
