//! `surfc mesh` through the binary: the JSON report, exit codes, diagnostics of meshes that
//! cannot be completed (E0601) or whose curves cannot be built (E0602), atomic output (a
//! failed run leaves an existing file as it was), and byte-for-byte determinism.

use crate::common::cli;
use std::path::Path;

fn write(dir: &Path, name: &str, text: &str) -> String {
    std::fs::write(dir.join(name), text).unwrap();
    name.to_string()
}

const SPHERE: &str = "surface sphere = x^2 + y^2 + z^2 - 4;\n\
                      mesh ball = sphere { step: 0.5; start: (1, 1, 1); }\n";

#[test]
fn json_report_and_default_output() {
    let dir = cli::scratch("mesh-cli-json");
    let file = write(&dir, "ball.surf", SPHERE);
    let (code, stdout, _) = cli::surfc(&["mesh", &file, "--json", "--quiet"], &dir).text();
    assert_eq!(code, 0);
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let m = &json["meshes"][0];
    for key in [
        "name",
        "surface",
        "step",
        "vertices",
        "triangles",
        "boundary_edges",
        "boundary_loops",
        "non_manifold_edges",
        "euler_characteristic",
        "components",
        "min_angle_deg",
        "max_vertex_error",
        "seconds",
    ] {
        assert!(!m[key].is_null(), "missing {key} in {m}");
    }
    assert_eq!(m["name"], "ball");
    assert_eq!(m["surface"], "sphere");
    assert_eq!(m["euler_characteristic"], 2);
    assert_eq!(m["boundary_edges"], 0);
    assert!(m["max_vertex_error"].as_f64().unwrap() <= 1e-9 * 0.5);
    assert!(json["seconds"].as_f64().unwrap() >= 0.0);
    // Without -o the file is `<stem>.obj` in the current directory.
    let obj = std::fs::read_to_string(dir.join("ball.obj")).expect("ball.obj written");
    assert!(obj.contains("o ball"));
}

#[test]
fn same_input_same_bytes_in_every_format() {
    let dir = cli::scratch("mesh-cli-determinism");
    let file = write(&dir, "ball.surf", SPHERE);
    for ext in ["obj", "stl", "ply", "off", "glb"] {
        let (a, b) = (format!("a.{ext}"), format!("b.{ext}"));
        assert_eq!(cli::surfc(&["mesh", &file, "-q", "-o", &a], &dir).code, 0);
        assert_eq!(cli::surfc(&["mesh", &file, "-q", "-o", &b], &dir).code, 0);
        let (a, b) = (
            std::fs::read(dir.join(a)).unwrap(),
            std::fs::read(dir.join(b)).unwrap(),
        );
        assert!(!a.is_empty());
        assert_eq!(a, b, "{ext} differs between two runs");
    }
    // The interpreter writes the same file as the default native code.
    let c = "c.obj";
    let interpreted = ["mesh", &file, "-q", "-o", c, "--engine", "interpreter"];
    assert_eq!(cli::surfc(&interpreted, &dir).code, 0);
    assert_eq!(
        std::fs::read(dir.join("a.obj")).unwrap(),
        std::fs::read(dir.join(c)).unwrap(),
        "the engines' meshes differ"
    );
}

#[test]
fn mesh_that_cannot_be_completed_is_e0601_and_leaves_the_output_alone() {
    let dir = cli::scratch("mesh-cli-e0601");
    let file = write(
        &dir,
        "small.surf",
        "surface sphere = x^2 + y^2 + z^2 - 4;\n\
         mesh ball = sphere { step: 0.3; start: (1, 1, 1); max_triangles: 10; }\n",
    );
    std::fs::write(dir.join("small.obj"), "precious").unwrap();
    let (code, stdout, stderr) = cli::surfc(&["mesh", &file, "--color", "never"], &dir).text();
    assert_eq!(code, 1);
    assert!(stdout.is_empty());
    assert_eq!(
        std::fs::read_to_string(dir.join("small.obj")).unwrap(),
        "precious"
    );
    insta::assert_snapshot!(stderr);
}

/// A bound polygon sampled at a step much coarser than the surface's local step beside it
/// lets the front through: the mesh is refused at once as the polygon's, pointing at the
/// curve it was sampled from, not after refinement rounds that cannot change it (the
/// blend of three cylinders at eight times its step re-marched an ever larger wrong mesh
/// for over ten minutes).
#[test]
fn a_polygon_too_coarse_for_the_surface_is_refused_at_once_naming_its_curve() {
    let dir = cli::scratch("mesh-cli-coarse-polygon");
    let gallery = include_str!("../../examples/blend_three_cylinders.surf");
    assert!(gallery.contains("step: pi / 20;"));
    let file = write(
        &dir,
        "blend.surf",
        &gallery.replace("step: pi / 20;", "step: 8 * pi / 20;"),
    );
    let (code, stdout, stderr) = cli::surfc(&["mesh", &file, "--color", "never"], &dir).text();
    assert_eq!(code, 1, "{stdout}{stderr}");
    assert!(
        stderr.contains("error[E0601]: mesh `blend` could not be completed"),
        "{stderr}"
    );
    assert!(
        stderr.contains("bound polygon 0 is too coarse for the surface at this step"),
        "{stderr}"
    );
    // The first bound is `contact_z_top`: its definition carries the label.
    let label = stderr
        .lines()
        .position(|l| l.contains("the polygon is sampled from this curve"))
        .unwrap_or_else(|| panic!("no label on the curve:\n{stderr}"));
    assert!(
        stderr
            .lines()
            .nth(label - 1)
            .is_some_and(|l| l.contains("curve contact_z_top")),
        "{stderr}"
    );
    assert!(!stderr.contains("refinement"), "{stderr}");
    assert!(!dir.join("blend.obj").exists());
}

#[test]
fn curve_that_cannot_be_traced_is_e0602() {
    let dir = cli::scratch("mesh-cli-e0602");
    let file = write(
        &dir,
        "apart.surf",
        "surface sphere = x^2 + y^2 + z^2 - 4;\n\
         curve none = intersection(sphere, z - 5, near: (0, 0, 5));\n\
         mesh cap = sphere { step: 0.3; front: none; }\n",
    );
    let (code, _, stderr) = cli::surfc(&["mesh", &file, "--color", "never"], &dir).text();
    assert_eq!(code, 1);
    assert!(!dir.join("apart.obj").exists());
    insta::assert_snapshot!(stderr);
}

#[test]
fn usage_and_io_errors_exit_2_naming_the_path() {
    let dir = cli::scratch("mesh-cli-usage");
    let file = write(&dir, "ball.surf", SPHERE);
    let (code, _, stderr) = cli::surfc(&["mesh", &file, "--only", "bal"], &dir).text();
    assert_eq!(code, 2);
    assert!(
        stderr.contains("no mesh block `bal`") && stderr.contains("ball"),
        "{stderr}"
    );
    let (code, _, stderr) = cli::surfc(&["mesh", &file, "-o", "missing/dir/out.obj"], &dir).text();
    assert_eq!(code, 2);
    assert!(stderr.contains("missing/dir"), "{stderr}");
    let (code, _, stderr) = cli::surfc(&["mesh", &file, "-o", "out.xyz"], &dir).text();
    assert_eq!(code, 2);
    assert!(stderr.contains("out.xyz"), "{stderr}");
    let (code, _, _) = cli::surfc(&["mesh", "nowhere.surf"], &dir).text();
    assert_eq!(code, 2);
}

/// A box and no start: every component in the box; `components` and `warnings` in the JSON
/// report, the warning (a ball smaller than the local step's floor, step/256) also on stderr, and the components
/// column in the summary table.
#[test]
fn box_only_mesh_reports_components_and_warnings() {
    let dir = cli::scratch("mesh-cli-components");
    let file = write(
        &dir,
        "balls.surf",
        "surface balls = min(x^2 + y^2 + z^2 - 1, min((x - 3)^2 + y^2 + z^2 - 1, (x - 1.5)^2 + (y - 1.5)^2 + z^2 - 0.00000001));\n\
         mesh balls = balls { step: 0.25; box: (-2, -2, -2) .. (5, 2, 2); }\n",
    );
    let (code, stdout, stderr) = cli::surfc(&["mesh", &file, "--json"], &dir).text();
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let m = &json["meshes"][0];
    assert_eq!(m["components"], 2, "{m}");
    assert_eq!(m["euler_characteristic"], 4, "{m}");
    let warnings = m["warnings"].as_array().expect("warnings is a list");
    assert_eq!(warnings.len(), 1, "{m}");
    let w = warnings[0].as_str().expect("a string");
    assert!(w.contains("smaller than the step"), "{w}");
    assert!(
        stderr.contains(&format!("warning: mesh `balls`: {w}")),
        "{stderr}"
    );
    let header = stderr
        .lines()
        .find(|l| l.starts_with("mesh "))
        .unwrap_or("");
    assert!(header.contains("components"), "{stderr}");
}

/// `radius_ratio:` is the mean radius ratio the quality stage raises the mesh to: the
/// default's aim (0.975) is reached, a higher aim costs more phases and gives a higher mean,
/// a low one leaves the march's triangles as the angle's rounds left them (still ≥ 30°).
/// An aim above the default on a mesh large enough to be cut into slabs: the centroid's
/// rounds lift it past what one round and the ratios' phase reached (the sphere 0.9844 with
/// `radius_ratio: 1` before), and the cut is kept (the joined slabs were held to the aim and
/// refused, and the whole march made less), into slabs four times smaller than the default's
/// whose seams are polished once joined (`pipeline::pieces::seams`).
#[test]
fn a_high_radius_ratio_cuts_finer_slabs_polishes_their_seams_and_lifts_the_mean() {
    let dir = cli::scratch("mesh-cli-high-radius-ratio");
    let run = |aim: &str| {
        let text = format!(
            "surface s = x^2 + y^2 + z^2 - 4;\nmesh m = s {{ step: 0.03; start: (1, 1, 1); {aim} }}\n"
        );
        let file = write(&dir, "m.surf", &text);
        let (code, stdout, stderr) =
            cli::surfc(&["mesh", &file, "--json", "-q", "-o", "m.obj"], &dir).text();
        assert_eq!(code, 0, "{text}: {stderr}");
        let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
        let m = json["meshes"][0].clone();
        assert_eq!(m["euler_characteristic"], 2, "{aim}");
        assert_eq!(m["boundary_edges"], 0, "{aim}");
        assert!(m["min_angle_deg"].as_f64().unwrap() >= 30.0, "{aim}: {m}");
        (
            m["radius_ratio_mean"].as_f64().unwrap(),
            m["pieces"].as_u64().unwrap_or(1),
            m["min_angle_deg"].as_f64().unwrap(),
        )
    };
    let (default, default_pieces, _) = run("");
    assert_eq!(
        default_pieces, 2,
        "about 150 k triangles: two slabs of at most 200 k"
    );
    for aim in ["radius_ratio: 0.995;", "radius_ratio: 1;"] {
        let (high, pieces, angle) = run(aim);
        eprintln!(
            "sphere at step 0.03: default {default:.4} in {default_pieces} slab(s), {aim} {high:.4} in {pieces}, smallest angle {angle:.1}°"
        );
        // Slabs of a quarter of the default's triangles: four (a power of two).
        assert_eq!(pieces, 4, "{aim}: the cut is kept, finer");
        assert!(
            high >= 0.992 && high > default + 0.004,
            "{aim}: {high} against {default}"
        );
        // Unpolished, the seams' triangles fell to 35.0° (the slabs' own, away from the
        // cuts, are above 38°).
        assert!(angle >= 37.0, "{aim}: the seams' smallest angle {angle}°");
    }
}

#[test]
fn radius_ratio_sets_the_quality_stages_aim() {
    let dir = cli::scratch("mesh-cli-radius-ratio");
    let shapes = [
        ("x^2 + y^2 + z^2 - 4", "step: 0.3; start: (1, 1, 1);"),
        (
            "(x^2 + y^2 + z^2 + 4 - 0.25)^2 - 16 * (x^2 + y^2)",
            "step: 0.12; start: (2.5, 0, 0);",
        ),
    ];
    for (formula, options) in shapes {
        let mean_and_angle = |aim: &str| {
            let text = format!("surface s = {formula};\nmesh m = s {{ {options} {aim} }}\n");
            let file = write(&dir, "m.surf", &text);
            let (code, stdout, stderr) =
                cli::surfc(&["mesh", &file, "--json", "-q", "-o", "m.obj"], &dir).text();
            assert_eq!(code, 0, "{text}: {stderr}");
            let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
            let m = &json["meshes"][0];
            assert_eq!(
                m["euler_characteristic"],
                if formula.contains("16") { 0 } else { 2 }
            );
            (
                m["radius_ratio_mean"].as_f64().unwrap(),
                m["min_angle_deg"].as_f64().unwrap(),
            )
        };
        let (low, low_angle) = mean_and_angle("radius_ratio: 0.5;");
        let (default, default_angle) = mean_and_angle("");
        let (full, full_angle) = mean_and_angle("radius_ratio: 1;");
        eprintln!("{formula}: radius_ratio 0.5 {low:.4}, default {default:.4}, 1 {full:.4}");
        for angle in [low_angle, default_angle, full_angle] {
            assert!(angle >= 30.0, "{formula}: {angle}°");
        }
        assert!(default >= 0.975, "{formula}: {default}");
        assert!(
            low < default && default < full,
            "{formula}: {low} {default} {full}"
        );
        assert!(full >= 0.98, "{formula}: {full}");
    }
}

/// The paper's own example in the paper's mode (issue 42): genus 3 at step 0.3 with
/// `uniform: true` meshes (about the paper's 7354 triangles, χ = −4) with a warning that
/// gives its chord error above the default tolerance, on stderr and in `--json` `warnings`;
/// a `tolerance` written in the block is enforced (refused, E0601, naming the place).
#[test]
fn the_uniform_step_warns_of_a_chord_error_above_the_default_tolerance() {
    let dir = cli::scratch("mesh-cli-uniform");
    let genus3 =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/genus3.surf"))
            .unwrap();
    assert!(genus3.contains("start: (0, 3, 0);"));
    let uniform = write(
        &dir,
        "uniform.surf",
        &genus3.replace("start: (0, 3, 0);", "start: (0, 3, 0); uniform: true;"),
    );
    let (code, stdout, stderr) =
        cli::surfc(&["mesh", &uniform, "--json", "-o", "u.obj"], &dir).text();
    assert_eq!(code, 0, "{stderr}");
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    let m = &json["meshes"][0];
    let triangles = m["triangles"].as_u64().expect("a count");
    assert!(
        (6700..=8100).contains(&triangles),
        "{triangles} triangles, the paper's 7354"
    );
    assert_eq!(m["euler_characteristic"], -4, "{m}");
    assert_eq!(m["boundary_edges"], 0, "{m}");
    let chord = m["max_chord_error"].as_f64().expect("a number");
    assert!(chord > 0.03, "{chord}");
    let warnings = m["warnings"].as_array().expect("a list");
    let w = warnings
        .iter()
        .filter_map(|w| w.as_str())
        .find(|w| w.contains("above the default tolerance"))
        .unwrap_or_else(|| panic!("no chord warning in {warnings:?}"));
    // The figure: the largest chord error, as the report gives it.
    assert!(w.contains(&format!("{chord:.3e}")), "{w} ({chord})");
    assert!(w.contains("uniform: true"), "{w}");
    assert!(
        stderr.contains(&format!("warning: mesh `genus3`: {w}")),
        "{stderr}"
    );
    // The summary on stderr (without --json) has the warning too.
    let (code, _, stderr) = cli::surfc(&["mesh", &uniform, "-o", "u.obj"], &dir).text();
    assert_eq!(code, 0, "{stderr}");
    assert!(stderr.contains("above the default tolerance"), "{stderr}");
    // An explicit tolerance is enforced.
    let strict = write(
        &dir,
        "strict.surf",
        &genus3.replace(
            "start: (0, 3, 0);",
            "start: (0, 3, 0); uniform: true; tolerance: 0.03;",
        ),
    );
    let (code, _, stderr) = cli::surfc(&["mesh", &strict, "-o", "s.obj"], &dir).text();
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("error[E0601]"), "{stderr}");
    assert!(stderr.contains("above the tolerance 3.000e-2"), "{stderr}");
}

/// A box with no surface in it (issue 42) is an error, E0605, that gives the range of f over
/// the box, and writes no file; `--json` has the code.
#[test]
fn a_box_without_surface_is_e0605_with_the_range_of_f() {
    let dir = cli::scratch("mesh-cli-empty-box");
    let file = write(
        &dir,
        "far.surf",
        "surface ball = x^2 + y^2 + z^2 - 1;\nmesh m = ball { step: 0.2; box: (3, 3, 3) .. (4, 4, 4); }\n",
    );
    let (code, _, stderr) = cli::surfc(&["mesh", &file, "-o", "far.obj"], &dir).text();
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("error[E0605]"), "{stderr}");
    // f = |p|² − 1 over [3, 4]³: from 26 at (3, 3, 3) to 47 at (4, 4, 4).
    assert!(stderr.contains("f ranges over [26, 47]"), "{stderr}");
    assert!(!dir.join("far.obj").exists());
    let (code, stdout, _) = cli::surfc(&["mesh", &file, "--json", "-o", "far.obj"], &dir).text();
    assert_eq!(code, 1);
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("one JSON object");
    assert_eq!(json["errors"][0]["code"], "E0605", "{json}");
}
