//! Creases meshed as one coherent net (issue 12, the mesher's must-shows): surfaces written
//! with raw `min`, `max` and `abs`, meshed through the library form of `surfc mesh`, checked
//! by the one mesh checker and against the exact geometry of the shapes (crease circles,
//! box corners and edges), and — for random CSG trees — against the voxel reference
//! (`common::voxel`), which never looks at a mesh.
//!
//! Smallest angles: the marcher's own triangles keep ≥ 20° here; the exception allowed by
//! DESIGN.md §6 (corners of given polygons sharper than 60°) does not arise in these shapes,
//! whose crease loops turn by at most 90° at a corner.

mod common;

use std::cell::RefCell;

use common::build::{build, checked};
use common::rng::Rng;
use common::voxel::solid_count;
use glam::DVec3;
use surfc::cli::mesh::{Meshed, mesh_source};
use surfc::mesh::check::{Expect, check};
use surfc::surface::Surface;

fn mesh_one(source: &str) -> Meshed {
    match mesh_source(source) {
        Ok(mut m) if m.len() == 1 => m.remove(0),
        Ok(m) => panic!("expected one mesh, got {}", m.len()),
        Err(d) => panic!("does not mesh: {d:?}\n{source}"),
    }
}

/// Watertight, consistently oriented (normals agree with ∇f), no crossing triangles, Euler
/// characteristic `euler`, smallest angle ≥ `min_angle`.
fn assert_closed(m: &Meshed, euler: i64, min_angle: f64) {
    let expect = Expect {
        closed: true,
        euler: Some(euler),
        boundary_loops: Some(0),
        min_angle_deg: min_angle,
        ..Expect::default()
    };
    let (_, violations) = check(&m.mesh, None, &expect);
    assert!(violations.is_empty(), "{}: {violations:?}", m.name);
}

fn min_angle_deg(m: &Meshed) -> f64 {
    let mut min = f64::INFINITY;
    for t in &m.mesh.triangles {
        let p = t.map(|k| m.mesh.vertices[k as usize]);
        for i in 0..3 {
            let (a, b, c) = (p[i], p[(i + 1) % 3], p[(i + 2) % 3]);
            min = min.min((b - a).angle_between(c - a).to_degrees());
        }
    }
    min
}

/// M1: a unit ball with a bite of radius 0.7 at (0.8, 0, 0), written with raw `max`.
#[test]
fn ball_with_a_bite() {
    assert_bite("max(x^2 + y^2 + z^2 - 1, -((x - 0.8)^2 + y^2 + z^2 - 0.49))");
}

/// M1 written with the named boolean and primitives (the language's `difference`, `sphere`,
/// `translate`): the same checks.
#[test]
fn ball_with_a_bite_written_as_a_difference() {
    assert_bite("difference(sphere(1), translate(sphere(0.7), (0.8, 0, 0)))");
}

/// The checks of M1 for the unit ball with a bite of radius 0.7 at (0.8, 0, 0), written as
/// `formula`, at step 0.08.
fn assert_bite(formula: &str) {
    let step = 0.08;
    let m = mesh_one(&format!(
        "surface bite = {formula};\n\
         mesh bite = bite {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_closed(&m, 2, 20.0);
    let c = DVec3::new(0.8, 0.0, 0.0);
    let on_big = |p: DVec3| (p.length() - 1.0).abs();
    let on_small = |p: DVec3| (p.distance(c) - 0.7).abs();
    // The crease circle: x = 0.71875, radius √(1 − 0.71875²), found from the spheres alone.
    let xc: f64 = (1.0 - 0.49 + 0.64) / 1.6;
    let rc = (1.0 - xc * xc).sqrt();
    let mut angles: Vec<f64> = m
        .mesh
        .vertices
        .iter()
        .filter(|p| on_big(**p) <= 1e-9 * step && on_small(**p) <= 1e-9 * step)
        .map(|p| p.z.atan2(p.y))
        .collect();
    angles.sort_by(f64::total_cmp);
    assert!(angles.len() >= 3, "crease vertices: {}", angles.len());
    let mut gap: f64 = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
    for w in angles.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    // Chord between neighbours along the circle at most a step: one vertex per step.
    assert!(
        2.0 * rc * (gap / 2.0).sin() <= step * (1.0 + 1e-9),
        "largest gap between crease vertices {} (radius {rc})",
        2.0 * rc * (gap / 2.0).sin()
    );
    // Chord error against the exact spheres, at centroids and edge midpoints.
    let mut worst: f64 = 0.0;
    for t in &m.mesh.triangles {
        let p = t.map(|k| m.mesh.vertices[k as usize]);
        let samples = [
            (p[0] + p[1] + p[2]) / 3.0,
            0.5 * (p[0] + p[1]),
            0.5 * (p[1] + p[2]),
            0.5 * (p[2] + p[0]),
        ];
        for s in samples {
            worst = worst.max(on_big(s).min(on_small(s)));
        }
    }
    assert!(worst <= 0.1 * step, "chord error {worst}");
    eprintln!(
        "bite: {} triangles, {} crease vertices, smallest angle {:.1}°, chord error {worst:.2e}",
        m.mesh.triangles.len(),
        angles.len(),
        min_angle_deg(&m)
    );
}

/// The ball with a bite given a `start` and no `box` (before: a 0.38° triangle at
/// step 0.2, 25 s into the triangle guard at 0.08): a box from interval bounds, then creases.
#[test]
fn a_start_without_a_box_gets_a_box_from_intervals() {
    for step in [0.2, 0.08] {
        let m = mesh_one(&format!(
            "surface bite = max(x^2 + y^2 + z^2 - 1, -((x - 0.8)^2 + y^2 + z^2 - 0.49));\n\
             mesh bite = bite {{ step: {step}; start: (-1, 0, 0); }}\n"
        ));
        assert_closed(&m, 2, 20.0);
    }
}

/// The checks of M2 for the cube [−1, 1]³ meshed at `step`.
fn assert_cube(m: &Meshed, step: f64) {
    assert_closed(m, 2, 20.0);
    let v = &m.mesh.vertices;
    for corner in 0..8 {
        let c = DVec3::new(
            if corner & 1 == 0 { -1.0 } else { 1.0 },
            if corner & 2 == 0 { -1.0 } else { 1.0 },
            if corner & 4 == 0 { -1.0 } else { 1.0 },
        );
        assert!(v.contains(&c), "corner {c} is not a vertex");
    }
    // Each of the 12 edges: the vertices with two coordinates exactly ±1, no gap above a step.
    for axis in 0..3 {
        for signs in 0..4 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let sa = if signs & 1 == 0 { -1.0 } else { 1.0 };
            let sb = if signs & 2 == 0 { -1.0 } else { 1.0 };
            let mut along: Vec<f64> = v
                .iter()
                .filter(|p| p[a] == sa && p[b] == sb)
                .map(|p| p[axis])
                .collect();
            along.sort_by(f64::total_cmp);
            assert_eq!(along.first(), Some(&-1.0), "edge {axis} {sa} {sb}");
            assert_eq!(along.last(), Some(&1.0), "edge {axis} {sa} {sb}");
            let gap = along.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            assert!(gap <= step * (1.0 + 1e-9), "edge {axis}: gap {gap}");
        }
    }
    // Every triangle lies in one face: its three vertices share a coordinate ±1 (to 1e-9).
    for t in &m.mesh.triangles {
        let p = t.map(|k| v[k as usize]);
        let in_face = (0..3).any(|k| {
            [-1.0, 1.0]
                .iter()
                .any(|s| p.iter().all(|q| (q[k] - s).abs() <= 1e-9))
        });
        assert!(in_face, "triangle {p:?} is in no face");
    }
}

/// M2: the cube written as a max of abs.
#[test]
fn cube_of_abs() {
    let step = 0.15;
    let m = mesh_one(&format!(
        "surface cube = max(max(abs(x), abs(y)), abs(z)) - 1;\n\
         mesh cube = cube {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_cube(&m, step);
    eprintln!(
        "cube (abs): {} triangles, smallest angle {:.1}°",
        m.mesh.triangles.len(),
        min_angle_deg(&m)
    );
}

/// M2: the cube written as a max of six planes.
#[test]
fn cube_of_planes() {
    let step = 0.15;
    let m = mesh_one(&format!(
        "surface cube = max(max(max(x - 1, -x - 1), max(y - 1, -y - 1)), max(z - 1, -z - 1));\n\
         mesh cube = cube {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_cube(&m, step);
}

/// M2 written with the `box` primitive.
#[test]
fn cube_primitive() {
    let step = 0.15;
    let m = mesh_one(&format!(
        "surface cube = box((-1, -1, -1), (1, 1, 1));\n\
         mesh cube = cube {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_cube(&m, step);
}

/// M3: a plate with two cylindrical holes: χ = −2 (genus 2), its extent exactly the plate.
#[test]
fn plate_with_two_holes() {
    assert_plate(
        "max(max(max(abs(x) - 2, abs(y) - 1), abs(z) - 0.25),\n\
           max(-((x - 1)^2 + y^2 - 0.16), -((x + 1)^2 + y^2 - 0.16)))",
    );
}

/// M3 as users write it: `difference(box, translate(cylinder), translate(cylinder))`.
#[test]
fn plate_with_two_holes_written_as_a_difference() {
    assert_plate(
        "difference(box((-2, -1, -0.25), (2, 1, 0.25)),\n\
           translate(cylinder(0.4, 1), (1, 0, 0)), translate(cylinder(0.4, 1), (-1, 0, 0)))",
    );
}

fn assert_plate(formula: &str) {
    let m = mesh_one(&format!(
        "surface plate = {formula};\n\
         mesh plate = plate {{ step: 0.1; box: (-2.5, -1.5, -0.5) .. (2.5, 1.5, 0.5); }}\n",
    ));
    assert_closed(&m, -2, 20.0);
    let v = &m.mesh.vertices;
    let lo = v.iter().fold(DVec3::INFINITY, |a, b| a.min(*b));
    let hi = v.iter().fold(DVec3::NEG_INFINITY, |a, b| a.max(*b));
    assert_eq!(lo, DVec3::new(-2.0, -1.0, -0.25));
    assert_eq!(hi, DVec3::new(2.0, 1.0, 0.25));
}

/// M3: a ball joined with a torus through it: χ = 2, raw and as `union(sphere, torus)`.
#[test]
fn ball_and_torus() {
    for formula in [
        "min(x^2 + y^2 + z^2 - 1, (sqrt(x^2 + y^2) - 1.2)^2 + z^2 - 0.09)",
        "union(sphere(1), torus(1.2, 0.3))",
    ] {
        let m = mesh_one(&format!(
            "surface s = {formula};\n\
             mesh s = s {{ step: 0.1; box: (-2, -2, -1.5) .. (2, 2, 1.5); }}\n",
        ));
        assert_closed(&m, 2, 20.0);
    }
}

/// A ball far from the rest has no crease: it is found and meshed by the component search
/// beside the creased part.
#[test]
fn a_component_without_creases_is_meshed_too() {
    let m = mesh_one(
        "surface s = min(max(x^2 + y^2 + z^2 - 1, -((x - 0.8)^2 + y^2 + z^2 - 0.49)),\n\
           (x + 3)^2 + y^2 + z^2 - 0.25);\n\
         mesh s = s { step: 0.1; box: (-4, -1.5, -1.5) .. (1.5, 1.5, 1.5); }\n",
    );
    assert_closed(&m, 4, 20.0);
    assert_eq!(m.report.components, 2);
}

/// Two spheres that touch: the crease has no direction there; the mesh fails at that place
/// and does so quickly.
#[test]
fn tangential_contact_is_refused_at_its_place() {
    let started = std::time::Instant::now();
    let d = match mesh_source(
        "surface s = min(x^2 + y^2 + z^2 - 1, (x - 2)^2 + y^2 + z^2 - 1);\n\
         mesh s = s { step: 0.1; box: (-1.5, -1.5, -1.5) .. (3.5, 1.5, 1.5); }\n",
    ) {
        Ok(_) => panic!("touching spheres meshed"),
        Err(d) => d,
    };
    let text = format!("{:?}", d[0]);
    assert_eq!(d[0].code, "E0601");
    assert!(text.contains("tangentially"), "{text}");
    assert!(started.elapsed().as_secs_f64() < 20.0);
}

/// Sharp edges hidden inside a smooth boolean (the box's, in `smooth_union(box, sphere)`) are
/// not traced: the march stops where its step reaches the floor at such an edge, naming the
/// place (before: more than two minutes creeping along the edge). A box with a `start` only,
/// a box with a `box`, and a raw `max` inside a smooth union alike.
#[test]
fn sharp_edges_inside_a_smooth_boolean_are_refused_at_their_place() {
    for (surface, block) in [
        (
            "smooth_union(box((-1, -1, -1), (1, 1, 1)), translate(sphere(0.6), (0, 0, 1)), 0.2)",
            "box: (-2, -2, -2) .. (2, 2, 2);",
        ),
        (
            "smooth_union(max(max(abs(x), abs(y)), abs(z)) - 1, sphere(0.5), 0.1)",
            "start: (1, 0.2, 0.3);",
        ),
    ] {
        let started = std::time::Instant::now();
        let source = format!("surface s = {surface};\nmesh s = s {{ step: 0.15; {block} }}\n");
        let d = match mesh_source(&source) {
            Ok(_) => panic!("a hidden sharp edge meshed: {source}"),
            Err(d) => d,
        };
        let text = format!("{:?}", d[0]);
        assert_eq!(d[0].code, "E0601", "{text}");
        assert!(text.contains("sharp edge near"), "{text}");
        let took = started.elapsed().as_secs_f64();
        assert!(took < 5.0, "{source}: {took} s");
    }
}

// ---------------------------------------------------------------------------------------------
// M5: random CSG trees.

/// A primitive in its own frame (X, Y, Z) as `.surf` text.
fn primitive(rng: &mut Rng) -> String {
    let c = DVec3::new(
        rng.range(-0.8, 0.8),
        rng.range(-0.8, 0.8),
        rng.range(-0.8, 0.8),
    );
    // A random turn: Rodrigues' matrix of a random axis and angle.
    let axis = DVec3::new(
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
        rng.range(-1.0, 1.0),
    )
    .normalize_or(DVec3::Z);
    let m = glam::DMat3::from_axis_angle(axis, rng.range(0.0, std::f64::consts::PI));
    let row = |k: usize| {
        let r = m.row(k);
        format!(
            "({} * (x - {}) + {} * (y - {}) + {} * (z - {}))",
            r.x, c.x, r.y, c.y, r.z, c.z
        )
    };
    let (x, y, z) = (row(0), row(1), row(2));
    match rng.next() % 4 {
        0 => {
            let r = rng.range(0.4, 0.9);
            format!("({x}^2 + {y}^2 + {z}^2 - {})", r * r)
        }
        1 => {
            let (a, b, cc) = (
                rng.range(0.3, 0.8),
                rng.range(0.3, 0.8),
                rng.range(0.3, 0.8),
            );
            format!("max(max(abs({x}) - {a}, abs({y}) - {b}), abs({z}) - {cc})")
        }
        2 => {
            let (r, h) = (rng.range(0.25, 0.6), rng.range(0.3, 0.8));
            format!("max({x}^2 + {y}^2 - {}, abs({z}) - {h})", r * r)
        }
        _ => {
            let (big, small) = (rng.range(0.5, 0.8), rng.range(0.15, 0.3));
            format!(
                "((sqrt({x}^2 + {y}^2) - {big})^2 + {z}^2 - {})",
                small * small
            )
        }
    }
}

/// A random tree of `n` primitives joined by min, max and max with a negation (difference).
fn tree(rng: &mut Rng, n: usize) -> String {
    if n == 1 {
        return primitive(rng);
    }
    let left = 1 + (rng.next() as usize) % (n - 1);
    let (a, b) = (tree(rng, left), tree(rng, n - left));
    match rng.next() % 3 {
        0 => format!("min({a},\n  {b})"),
        1 => format!("max({a},\n  {b})"),
        _ => format!("max({a},\n  -({b}))"),
    }
}

#[test]
fn random_csg_trees_mesh_right_or_refuse() {
    let cases: u64 = std::env::var("SURFC_CSG_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(6);
    let step = 0.1;
    let (mut meshed, mut refused, mut empty, mut skipped) = (0, 0, 0, 0);
    for case in 0..cases {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ (case + 1).wrapping_mul(0x1000_0001));
        let n = 2 + (rng.next() as usize) % 4;
        let source = format!(
            "surface s = {};\nmesh s = s {{ step: {step}; box: (-2.5, -2.5, -2.5) .. (2.5, 2.5, 2.5); }}\n",
            tree(&mut rng, n)
        );
        let program = checked(&source);
        let def = &program.meshes[0];
        let f = RefCell::new(build(&program, &def.surface, step).expect("compiles"));
        let (lo, hi) = def.bbox.expect("a box");
        // The reference at two grids: where they disagree a feature is thinner than the grid
        // (a sliver, a near-tangency), the case is not in general position, and it is skipped.
        let truth = solid_count(|p| f.borrow_mut().value(p), lo, hi, 160);
        let finer = solid_count(|p| f.borrow_mut().value(p), lo, hi, 240);
        assert!(!truth.touches_box);
        // (The counts only: the grid indices of the inside's extent differ between grids.)
        if (truth.euler, truth.components) != (finer.euler, finer.components) {
            eprintln!("case {case} skipped: the voxel counts at two grids disagree");
            skipped += 1;
            continue;
        }
        match mesh_source(&source) {
            Ok(m) if m[0].mesh.triangles.is_empty() => {
                assert_eq!(truth.components, 0, "case {case}: nothing meshed\n{source}");
                empty += 1;
            }
            Ok(m) => {
                let expect = Expect {
                    closed: true,
                    euler: Some(truth.surface_euler()),
                    min_angle_deg: 0.0,
                    ..Expect::default()
                };
                let (_, violations) = check(&m[0].mesh, None, &expect);
                assert!(
                    violations.is_empty(),
                    "case {case}: a wrong mesh reported as success: {violations:?}\n{source}"
                );
                meshed += 1;
            }
            Err(d) => {
                assert_eq!(d[0].code, "E0601", "case {case}: {d:?}");
                eprintln!("case {case} refused: {:?}", d[0].notes);
                if let Some(dir) = std::env::var_os("SURFC_CSG_DUMP") {
                    let path = std::path::Path::new(&dir).join(format!("case{case}.surf"));
                    std::fs::write(path, &source).expect("writes the refused case");
                }
                refused += 1;
            }
        }
    }
    eprintln!(
        "random CSG: {meshed} meshed, {refused} refused, {empty} empty, {skipped} skipped of {cases}"
    );
    assert!(meshed >= refused, "most cases should mesh");
    // A reference that skips most cases would leave the meshes unchecked.
    assert!(
        meshed > 0 && 3 * skipped <= cases,
        "only {meshed} of {cases} checked against the voxel count ({skipped} skipped)"
    );
}
