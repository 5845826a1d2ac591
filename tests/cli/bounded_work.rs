//! Inputs that used to make surfc work for minutes end in seconds with a diagnostic that says
//! which limit was reached and where (docs/language.md "Limits"): an exponential
//! chain of functions (E0603), `dist` nested too deep (E0604), a march that cannot end because
//! the surface is unbounded or the front overlaps itself (E0601).

use std::path::Path;
use std::time::Duration;

use crate::common;

/// Runs `surfc ARGS` in `dir`: exit code, stderr and how long it took.
fn surfc(args: &[&str], dir: &Path) -> (i32, String, Duration) {
    let run = common::cli::surfc(args, dir);
    (run.code, run.stderr, run.took)
}

/// A scratch directory holding `file` with `text`.
fn scratch(name: &str, file: &str, text: &str) -> common::cli::Scratch {
    let dir = common::cli::scratch(&format!("bounded-{name}"));
    std::fs::write(dir.join(file), text).unwrap();
    dir
}

/// Generous: the limits are reached in milliseconds; a loaded machine gets slack.
const QUICK: Duration = Duration::from_secs(2);

/// `fn f1(t) = f0(f0(t)); fn f2(t) = f1(f1(t)); …` up to `levels`: 2^levels copies of f0.
fn doubling_chain(levels: usize) -> String {
    let mut s = String::from("fn f0(t) = sin(t) + t;\n");
    for k in 1..=levels {
        s.push_str(&format!("fn f{k}(t) = f{j}(f{j}(t));\n", j = k - 1));
    }
    s.push_str(&format!(
        "surface s = f{levels}(x) + y^2 + z^2 - 1;\nmesh m = s {{ step: 0.5; start: (1, 0, 0); }}\n"
    ));
    s
}

#[test]
fn an_exponential_function_chain_is_stopped_while_inlining() {
    let dir = scratch("chain", "chain.surf", &doubling_chain(22));
    for args in [
        &["check", "chain.surf"][..],
        &["eval", "chain.surf", "s", "1", "0", "0"],
        &["bytecode", "chain.surf", "s"],
        &["mesh", "chain.surf", "-q", "-o", "chain.obj"],
    ] {
        let (code, stderr, took) = surfc(args, &dir);
        assert_eq!(code, 1, "{args:?}: {stderr}");
        assert!(stderr.contains("error[E0603]"), "{args:?}: {stderr}");
        // The chain is named, outermost first, and the size reached is given.
        assert!(stderr.contains("`f22` → `f21` → `f20`"), "{stderr}");
        assert!(
            stderr.contains("lowering stopped at 20001 operations"),
            "{stderr}"
        );
        // The label is on the outermost call, in the surface.
        assert!(stderr.contains("surface s = f22(x)"), "{stderr}");
        assert!(took < QUICK, "{args:?} took {took:?}");
    }
    assert!(!dir.join("chain.obj").exists());
}

#[test]
fn a_short_function_chain_still_compiles() {
    // 2^10 copies of f0: about 2000 operations, well below the limit.
    let dir = scratch("short", "short.surf", &doubling_chain(10));
    let (code, stderr, _) = surfc(&["eval", "short.surf", "s", "1", "0", "0"], &dir);
    assert_eq!(code, 0, "{stderr}");
}

/// Surfaces s1 … s`levels`, each `dist` of the one before, less 0.1.
fn dist_chain(levels: usize) -> String {
    let mut s = String::from("surface s0 = x^2 + y^2 + z^2 - 1;\n");
    for k in 1..=levels {
        s.push_str(&format!("surface s{k} = dist(s{j}) - 0.1;\n", j = k - 1));
    }
    s.push_str(&format!(
        "mesh m = s{levels} {{ step: 0.3; start: (2, 0, 0); }}\n"
    ));
    s
}

#[test]
fn nested_dist_is_limited() {
    let anonymous = "surface s = x^2 + y^2 + z^2 - 1;\n\
                     surface d = dist(dist(dist(dist(s) - 0.1) - 0.1) - 0.1) - 0.1;\n\
                     mesh m = d { step: 0.3; start: (1.4, 0, 0); }\n";
    for (name, text, top, chain) in [
        (
            "anonymous",
            anonymous.to_string(),
            "d",
            "level 4 of dist(…) → dist(…) → dist(…) → dist(s)",
        ),
        (
            "four",
            dist_chain(4),
            "s4",
            "level 4 of dist(s3) → dist(s2) → dist(s1) → dist(s0)",
        ),
        (
            "two_hundred",
            dist_chain(200),
            "s200",
            // `check` reports the first surface past the limit (s4), `eval` and `mesh` s200.
            "level 4 of dist(s",
        ),
    ] {
        let dir = scratch(name, "d.surf", &text);
        for args in [
            &["check", "d.surf"][..],
            &["eval", "d.surf", top, "1", "0", "0"],
            &["mesh", "d.surf", "-q", "-o", "d.obj"],
        ] {
            let (code, stderr, took) = surfc(args, &dir);
            assert_eq!(code, 1, "{name} {args:?}: {stderr}");
            assert!(stderr.contains("error[E0604]"), "{name}: {stderr}");
            assert!(
                stderr.contains("nested more than 3 deep"),
                "{name}: {stderr}"
            );
            assert!(stderr.contains(chain), "{name}: {stderr}");
            assert!(took < QUICK, "{name} {args:?} took {took:?}");
        }
    }
}

#[test]
fn dist_three_deep_still_evaluates() {
    let dir = scratch("three", "d.surf", &dist_chain(3));
    let run = common::cli::surfc(&["eval", "d.surf", "s3", "2", "0", "0", "--json"], &dir);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    // |p| − 1 − 0.3 at |p| = 2: three offsets of the unit sphere's distance.
    let value = json["value"].as_f64().unwrap();
    assert!((value - 0.7).abs() < 1e-6, "{value}");
}

/// A mesh that can never close is stopped early with the reason that fits: an unbounded
/// surface (a plane, a tube). (A front overlapping itself is tested in `guard.rs`; two
/// spheres 0.2 apart at step 0.6, which overlapped before the local step, now mesh right:
/// `close_spheres_at_a_coarse_step_mesh_right`.)
#[test]
fn a_march_that_cannot_end_says_why_within_two_seconds() {
    let cases = [
        (
            "plane",
            "surface p = z;\nmesh m = p { step: 0.1; start: (0, 0, 0); }\n",
            "the surface is unbounded here, add a box",
        ),
        (
            "tube",
            "surface c = x^2 + y^2 - 1;\nmesh m = c { step: 0.1; start: (1, 0, 0); }\n",
            "the surface is unbounded here, add a box",
        ),
        // Neither flat nor a tube: the surface itself is asked whether it reaches farther out.
        (
            "paraboloid",
            "surface p = z - x^2 - y^2;\nmesh m = p { step: 0.1; start: (0, 0, 0); }\n",
            "the surface is unbounded here, add a box",
        ),
        (
            "saddle",
            "surface p = z - x * y;\nmesh m = p { step: 0.1; start: (0, 0, 0); }\n",
            "the surface is unbounded here, add a box",
        ),
        (
            "hyperboloid",
            "surface p = x^2 + y^2 - z^2 - 1;\nmesh m = p { step: 0.1; start: (1, 0, 0); }\n",
            "the surface is unbounded here, add a box",
        ),
    ];
    for (name, text, reason) in cases {
        let dir = scratch(name, "m.surf", text);
        let (code, stderr, took) = surfc(&["mesh", "m.surf", "-q", "-o", "m.obj"], &dir);
        assert_eq!(code, 1, "{name}: {stderr}");
        assert!(stderr.contains("error[E0601]"), "{name}: {stderr}");
        assert!(stderr.contains(reason), "{name}: {stderr}");
        assert!(took < QUICK, "{name} took {took:?}");
        assert!(!dir.join("m.obj").exists());
    }
}

/// A thin closed ring, an O-ring 2 wide of tube 0.04 at step 0.004: its mesh grows as a
/// tube's does along most of the ring (doubling its extent with its triangles, 1.4 across
/// after 33 k triangles), and was refused as "unbounded, add a box" until the growth watch
/// asked the surface too, as it does for every growing mesh. The probes fall back onto the
/// ring: it meshes whole, a torus.
#[test]
fn a_thin_ring_is_not_taken_for_an_unbounded_tube() {
    let text = "surface s = torus(1, 0.02);\n\
                mesh m = s { step: 0.004; start: (1, 0, 0.02); }\n";
    let dir = scratch("ring", "m.surf", text);
    let run = common::cli::surfc(&["mesh", "m.surf", "-q", "--json", "-o", "m.obj"], &dir);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let m = &json["meshes"][0];
    assert_eq!(m["euler_characteristic"], 0, "{m}");
    assert_eq!(m["components"], 1, "{m}");
    assert_eq!(m["boundary_edges"], 0, "{m}");
    assert_eq!(m["non_manifold_edges"], 0, "{m}");
    // Area 4π²·1·0.02 ≈ 0.79 over triangles of side ≈ 0.004: about 115 k.
    let triangles = m["triangles"].as_u64().unwrap();
    assert!((90_000..200_000).contains(&triangles), "{triangles}");
}

/// The same plane in a box meshes: the box bounds it, and the default limit (what the box
/// holds) leaves room for it.
#[test]
fn a_plane_in_a_box_meshes() {
    let text = "surface p = z;\n\
                mesh m = p { step: 0.1; start: (0, 0, 0); box: (-2, -2, -1) .. (2, 2, 1); }\n";
    let dir = scratch("boxed", "m.surf", text);
    let run = common::cli::surfc(&["mesh", "m.surf", "-q", "--json", "-o", "m.obj"], &dir);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let m = &json["meshes"][0];
    // A 4 × 4 square at step 0.1: one boundary loop, a disc.
    assert_eq!(m["boundary_loops"], 1);
    assert_eq!(m["euler_characteristic"], 1);
    let triangles = m["triangles"].as_u64().unwrap();
    // Area 16 over equilateral triangles of side ≈ 0.1 (area ≈ 0.0043): about 3700.
    assert!((2500..6000).contains(&triangles), "{triangles}");
}

/// Two unit spheres 0.2 apart at step 0.6, three times the gap: the local step takes the gap
/// as a feature, so the sphere through the start meshes closed, and the box alone finds both.
#[test]
fn close_spheres_at_a_coarse_step_mesh_right() {
    let surface =
        "surface s = min(sqrt((x - 1.1)^2 + y^2 + z^2) - 1, sqrt((x + 1.1)^2 + y^2 + z^2) - 1);\n";
    let cases = [
        (
            "one",
            "mesh m = s { step: 0.6; start: (2.1, 0, 0); }\n",
            1,
            2,
        ),
        (
            "both",
            "mesh m = s { step: 0.6; box: (-2.5, -1.5, -1.5) .. (2.5, 1.5, 1.5); }\n",
            2,
            4,
        ),
    ];
    for (name, block, components, euler) in cases {
        let dir = scratch(name, "m.surf", &format!("{surface}{block}"));
        let run = common::cli::surfc(&["mesh", "m.surf", "-q", "-o", "m.obj", "--json"], &dir);
        assert_eq!(run.code, 0, "{name}: {}", run.stderr);
        assert!(run.took < QUICK, "{name} took {:?}", run.took);
        let json: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
        let mesh = &json["meshes"][0];
        assert_eq!(mesh["components"], components, "{name}: {mesh}");
        assert_eq!(mesh["euler_characteristic"], euler, "{name}: {mesh}");
        assert_eq!(mesh["boundary_edges"], 0, "{name}: {mesh}");
        assert_eq!(mesh["non_manifold_edges"], 0, "{name}: {mesh}");
    }
}

/// The component search is bounded by `max_triangles` (issue 16): the octree is walked
/// lazily and each component is marched as soon as its seed is found, so a surface larger
/// than the limit stops at the first march that passes it — here the `dist` product of the
/// gallery's intersecting patches, whose every octree cell costs three foot points (before:
/// the whole octree first, 2.4–3 s of CPU native, over 10 s interpreted). Both engines.
#[test]
fn the_component_search_stops_at_max_triangles() {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/intersecting_patches.surf"),
    )
    .unwrap()
    .replace("step: 0.25;", "step: 0.25; max_triangles: 2000;");
    let dir = scratch("patches", "patches.surf", &text);
    for engine in ["native", "interpreter"] {
        let (code, stderr, took) = surfc(
            &[
                "mesh",
                "patches.surf",
                "-q",
                "-o",
                "p.obj",
                "--engine",
                engine,
            ],
            &dir,
        );
        assert_eq!(code, 1, "{engine}: {stderr}");
        assert!(stderr.contains("error[E0601]"), "{engine}: {stderr}");
        assert!(stderr.contains("more than 2000 triangles"), "{stderr}");
        // 0.4 s of CPU on either engine; the wall clock gets slack for a loaded machine.
        assert!(took < 3 * QUICK, "{engine} took {took:?}");
    }
}

/// Where interval bounds never drop a cell (sin² + cos² holds 0 over every cell, the
/// surface is nowhere), the octree's work is bounded by 64 cells per triangle allowed: with
/// `max_triangles: 100` the search stops after 6400 cells and says so, instead of bounding
/// every cell of the box.
#[test]
fn a_search_with_loose_bounds_stops_at_its_cell_budget() {
    let dir = scratch(
        "loose",
        "loose.surf",
        "surface s = sin(10 * x)^2 + cos(10 * x)^2 + 0 * (y + z) - 0.999;\n\
         mesh m = s { step: 0.1; box: (-2, -2, -2) .. (2, 2, 2); max_triangles: 100; }\n",
    );
    let (code, stderr, took) = surfc(&["mesh", "loose.surf", "-q", "-o", "l.obj"], &dir);
    assert_eq!(code, 1, "{stderr}");
    assert!(stderr.contains("error[E0601]"), "{stderr}");
    assert!(
        stderr.contains("the component search bounded 6400 cells of the box"),
        "{stderr}"
    );
    assert!(stderr.contains("raise `max_triangles`"), "{stderr}");
    assert!(took < QUICK, "took {took:?}");
}

/// A `dist` whose foot point cannot be found (a sharp corner hidden inside `exp`, where the
/// smooth foot-point search does not converge) is reported at once with its place, in the
/// component search and in a march from a start point (issue 42: the rounded box ran past
/// 300 s with no message while every query near a corner failed).
#[test]
fn a_dist_without_a_foot_point_is_refused_at_once_with_its_place() {
    let surface = "surface c = exp(max(max(abs(x), abs(y)), abs(z))) - exp(0.5);\n\
                   surface o = offset(c, 0.2);\n";
    for (name, block) in [
        (
            "box",
            "mesh o = o { step: 0.05; box: (-1, -1, -1) .. (1, 1, 1); }\n",
        ),
        ("start", "mesh o = o { step: 0.05; start: (0.7, 0, 0); }\n"),
    ] {
        let dir = scratch(
            &format!("foot-{name}"),
            "o.surf",
            &format!("{surface}{block}"),
        );
        let (code, stderr, took) = surfc(&["mesh", "o.surf", "-q", "-o", "o.obj"], &dir);
        assert_eq!(code, 1, "{name}: {stderr}");
        assert!(stderr.contains("error[E0601]"), "{name}: {stderr}");
        assert!(
            stderr.contains("the surface could not be evaluated at [")
                && stderr.contains("no foot point of"),
            "{name}: {stderr}"
        );
        assert!(took < QUICK, "{name} took {took:?}");
        assert!(!dir.join("o.obj").exists(), "{name}");
    }
}
