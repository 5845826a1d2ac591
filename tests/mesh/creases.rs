//! Creases meshed as one coherent net (issue 12, the mesher's must-shows): surfaces written
//! with raw `min`, `max` and `abs`, meshed through the library form of `surfc mesh`, checked
//! by the one mesh checker and against the exact geometry of the shapes (crease circles,
//! box corners and edges), and — for random CSG trees — against the voxel reference
//! (`common::voxel`), which never looks at a mesh.
//!
//! Smallest angles: the marcher's own triangles keep ≥ 20° here; the exception allowed by
//! docs/quality.md (corners of given polygons sharper than 60°) does not arise in these shapes,
//! whose crease loops turn by at most 90° at a corner.

use crate::common;

use common::csg::{Degenerate, GeneralPosition, Primitive, Shape, SmoothOp, Tree};
use common::rng::Rng;
use common::voxel::{SolidCount, solid_count, two_readings};
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use surfc::mesh::check::{Expect, check};
use surfc::pipeline::{CreaseCounts, Meshed, mesh_source};

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
        components: None,
        min_angle_deg: min_angle,
        ..common::closed(euler)
    };
    common::assert_closed(m, &expect);
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
    // `--json`'s counts: one closed crease, no corner, its vertices those found on both spheres.
    assert_eq!(
        m.creases,
        Some(CreaseCounts {
            creases: 1,
            corners: 0,
            crease_vertices: angles.len()
        })
    );
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

/// M2 with one `max` of six operands (folded by sema): the same cube.
#[test]
fn cube_of_one_max_of_six_planes() {
    let step = 0.15;
    let m = mesh_one(&format!(
        "surface cube = max(x - 1, -x - 1, y - 1, -y - 1, z - 1, -z - 1);\n\
         mesh cube = cube {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_cube(&m, step);
}

/// M2 written with the `box` primitive; `--json`'s crease counts: 12 edges, 8 corners, and as
/// crease vertices exactly the mesh's vertices with two coordinates at ±1.
#[test]
fn cube_primitive() {
    let step = 0.15;
    let m = mesh_one(&format!(
        "surface cube = box((-1, -1, -1), (1, 1, 1));\n\
         mesh cube = cube {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_cube(&m, step);
    let on_edges = m
        .mesh
        .vertices
        .iter()
        .filter(|p| p.to_array().iter().filter(|c| c.abs() == 1.0).count() >= 2)
        .count();
    assert_eq!(
        m.creases,
        Some(CreaseCounts {
            creases: 12,
            corners: 8,
            crease_vertices: on_edges
        })
    );
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

/// Two rods of one radius whose axes cross touch at two points, where the two ellipses of
/// their crossing meet: four creases at a point with no angle between the faces. Each such
/// point is a corner of four creases (a tangent crossing), a mesh vertex; the pieces of each
/// rod meet it in two opposite sectors. At axes crossing at 90°, 60°, 30° and 15°, and the
/// whole turned: closed, χ = 2, every triangle ≥ 30°, both touching points vertices, and
/// the area and volume those of the union (each rod loses 8r²/sin α of its side and the two
/// share 16r³/(3 sin α) of volume, the oblique Steinmetz solid) to the chord error of the
/// step. (Touching balls, a contact that is no crossing, are still refused: above.)
#[test]
fn crossing_rods_of_one_radius_mesh_with_a_corner_where_they_touch() {
    let (r, length, step) = (0.05, 1.2, 0.025);
    for (alpha, turn) in [
        (90.0f64, None),
        (60.0, None),
        (30.0, None),
        (15.0, None),
        (90.0, Some("(1, 2, 3), angle: 0.7")),
    ] {
        let pair = format!(
            "union(\n\
               rotate(cylinder({r}, {length}), axis: (0, 1, 0), angle: pi / 2),\n\
               rotate(rotate(cylinder({r}, {length}), axis: (1, 0, 0), angle: pi / 2),\n\
                      axis: (0, 0, 1), angle: {} * pi / 180))",
            90.0 - alpha
        );
        let (surface, rotation) = match turn {
            None => (pair, DMat3::IDENTITY),
            Some(how) => (
                format!("rotate({pair}, axis: {how})"),
                DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7),
            ),
        };
        let source = format!(
            "surface s = {surface};\n\
             mesh s = s {{ step: {step}; box: (-0.7, -0.7, -0.7) .. (0.7, 0.7, 0.7); }}\n"
        );
        let m = mesh_one(&source);
        assert_closed(&m, 2, 30.0);
        let v = &m.mesh.vertices;
        for z in [r, -r] {
            let touch = rotation * DVec3::new(0.0, 0.0, z);
            let nearest = v
                .iter()
                .map(|p| p.distance(touch))
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest <= 1e-9,
                "α = {alpha}°: no vertex at {touch} ({nearest:e})"
            );
        }
        let (mut area, mut volume) = (0.0, 0.0);
        for t in &m.mesh.triangles {
            let [a, b, c] = t.map(|k| v[k as usize]);
            area += 0.5 * (b - a).cross(c - a).length();
            volume += a.dot(b.cross(c)) / 6.0;
        }
        let sin = alpha.to_radians().sin();
        let pi = std::f64::consts::PI;
        let exact_area = 2.0 * (2.0 * pi * r * length + 2.0 * pi * r * r) - 16.0 * r * r / sin;
        let exact_volume = 2.0 * pi * r * r * length - 16.0 * r.powi(3) / (3.0 * sin);
        assert!(
            (area / exact_area - 1.0).abs() <= 0.015,
            "α = {alpha}°: area {area} against {exact_area}"
        );
        assert!(
            (volume / exact_volume - 1.0).abs() <= 0.03,
            "α = {alpha}°: volume {volume} against {exact_volume}"
        );
    }
}

/// Four faces at a point (the apex of a pyramid of four planes, a 5-ary `max`): the apex is
/// a mesh vertex where the four faces' creases meet, every triangle lies in one face, and
/// the area is the pyramid's (four triangles √2 each and the base 4).
#[test]
fn a_corner_of_four_faces_is_one_vertex() {
    let step = 0.1;
    let m = mesh_one(&format!(
        "surface s = max(x + z, -x + z, y + z, -y + z, -z - 1);\n\
         mesh s = s {{ step: {step}; box: (-3, -3, -2) .. (3, 3, 1); }}\n"
    ));
    assert_closed(&m, 2, 30.0);
    let v = &m.mesh.vertices;
    assert!(v.contains(&DVec3::ZERO), "the apex is not a vertex");
    for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let c = DVec3::new(sx, sy, -1.0);
        assert!(
            v.iter().any(|p| p.distance(c) <= 1e-12),
            "corner {c} is not a vertex"
        );
    }
    let planes = [
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::new(-1.0, 0.0, 1.0),
        DVec3::new(0.0, 1.0, 1.0),
        DVec3::new(0.0, -1.0, 1.0),
    ];
    let on = |p: DVec3, k: usize| match k {
        4 => (p.z + 1.0).abs() <= 1e-9,
        _ => (planes[k].dot(p)).abs() <= 1e-9,
    };
    let mut area = 0.0;
    for t in &m.mesh.triangles {
        let p = t.map(|k| v[k as usize]);
        assert!(
            (0..5).any(|k| p.iter().all(|q| on(*q, k))),
            "triangle {p:?} is in no face"
        );
        area += 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    }
    let exact = 4.0 * 2f64.sqrt() + 4.0;
    assert!(
        (area - exact).abs() <= 1e-9 * exact,
        "area {area}, exact {exact}"
    );
    assert_eq!(m.creases.map(|c| (c.creases, c.corners)), Some((8, 5)));
}

/// Sharp edges hidden under a function the spine does not see through (`exp` of a cube) are
/// not traced: the march stops where its step reaches the floor at such an edge, naming the
/// place (before: minutes creeping along the edge). With a `box` and with a `start` only.
#[test]
fn sharp_edges_the_spine_does_not_reach_are_refused_at_their_place() {
    for block in ["box: (-2, -2, -2) .. (2, 2, 2);", "start: (1, 0.2, 0.3);"] {
        let started = std::time::Instant::now();
        let source = format!(
            "surface s = exp(max(max(abs(x), abs(y)), abs(z))) - exp(1);
             mesh s = s {{ step: 0.15; {block} }}\n"
        );
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
// Sharp parts inside smooth booleans (the spine lifts them, `compile::spine`).

/// A primitive at `centre`, not turned.
fn placed(shape: Shape, centre: DVec3) -> Tree {
    Tree::Leaf(Primitive {
        shape,
        centre,
        turn: DMat3::IDENTITY,
    })
}

fn smooth(op: SmoothOp, a: Tree, b: Tree, r: f64) -> Tree {
    Tree::Smooth(op, Box::new(a), Box::new(b), r)
}

/// Meshes `tree` (its text: raw formulas under the named smooth booleans) at step 0.1 and
/// requires what the random test requires of a mesh — the χ, components, extent and volume
/// of the voxel reference, every vertex on the tree's own function, watertight, oriented, no
/// crossings — and a smallest angle of 20° or more.
fn assert_smooth_shape(what: &str, tree: &Tree) -> Meshed {
    let step = 0.1;
    let source = format!(
        "surface s = {};
mesh s = s {{ step: {step}; box: (-2.5, -2.5, -2.5) .. (2.5, 2.5, 2.5); }}\n",
        tree.source()
    );
    let (outcome, m) = csg_mesh(tree, &source, step, 0.025);
    match outcome {
        Outcome::Right => {}
        Outcome::Refused => panic!("{what} refused:\n{source}"),
        Outcome::Empty => panic!("{what}: nothing to mesh"),
        Outcome::Small => panic!("{what}: a component below the step"),
        Outcome::Skipped => panic!("{what}: the reference grids disagree"),
        Outcome::Wrong(why) => panic!("{what}: {why}\n{source}"),
    }
    let m = m.expect("a mesh");
    let angle = min_angle_deg(&m);
    assert!(angle >= 20.0, "{what}: smallest angle {angle}°");
    eprintln!(
        "{what}: {} triangles, χ {}, smallest angle {angle:.1}°, creases {:?}",
        m.mesh.triangles.len(),
        m.report.euler_characteristic,
        m.creases
    );
    m
}

/// The edges of the box of half-extents `half` about the origin that `keep` accepts (by a
/// point on them), with the corners they end in: vertices on both face planes exactly (to
/// 1e-9·step: on both lifted branch surfaces), no gap above a step, the corners exact.
fn assert_box_edges(m: &Meshed, half: DVec3, step: f64, keep: impl Fn(DVec3) -> bool) {
    let v = &m.mesh.vertices;
    let tol = 1e-9 * step;
    let mut edges = 0;
    for axis in 0..3 {
        for signs in 0..4 {
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let sa = if signs & 1 == 0 { -half[a] } else { half[a] };
            let sb = if signs & 2 == 0 { -half[b] } else { half[b] };
            let mut mid = DVec3::ZERO;
            mid[a] = sa;
            mid[b] = sb;
            if !keep(mid) {
                continue;
            }
            edges += 1;
            let mut along: Vec<f64> = v
                .iter()
                .filter(|p| (p[a] - sa).abs() <= tol && (p[b] - sb).abs() <= tol)
                .map(|p| p[axis])
                .collect();
            along.sort_by(f64::total_cmp);
            let (first, last) = (along.first().copied(), along.last().copied());
            assert!(
                first.is_some_and(|f| (f + half[axis]).abs() <= tol)
                    && last.is_some_and(|l| (l - half[axis]).abs() <= tol),
                "edge {axis} {sa} {sb}: ends {first:?} {last:?}"
            );
            let gap = along.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max);
            assert!(gap <= step * (1.0 + 1e-9), "edge {axis}: gap {gap}");
        }
    }
    assert!(edges > 0);
}

/// The everyday fillet: `smooth_union(box, sphere)`, the ball on the top face (every
/// box edge stays sharp: traced exactly, its vertices on both faces), and a ball over an edge
/// (the edge runs into the fillet, where the crease fades into a seam through smooth surface).
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn smooth_union_of_a_box_and_a_ball() {
    let half = DVec3::new(1.0, 1.0, 0.3);
    let plate = || placed(Shape::Box { half }, DVec3::ZERO);
    let ball = |r: f64, c: DVec3| placed(Shape::Sphere { r }, c);
    let tree = smooth(
        SmoothOp::Union,
        plate(),
        ball(0.45, DVec3::new(0.2, 0.1, 0.4)),
        0.2,
    );
    let m = assert_smooth_shape("ball on a plate", &tree);
    assert_eq!(m.report.euler_characteristic, 2);
    assert_box_edges(&m, half, 0.1, |_| true);
    let tree = smooth(
        SmoothOp::Union,
        plate(),
        ball(0.5, DVec3::new(1.0, 0.2, 0.3)),
        0.2,
    );
    let m = assert_smooth_shape("ball over an edge", &tree);
    // The edges the ball does not reach (no point within its radius and the fillet's).
    assert_box_edges(&m, half, 0.1, |p| p.x < 0.0);
}

/// A filleted hole: `smooth_difference(box, cylinder)` (χ = 0), as raw formulas against the
/// reference and as the language's primitives (`box`, `cylinder`), whose outer edges stay sharp.
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn smooth_difference_of_a_box_and_a_cylinder() {
    let half = DVec3::new(1.0, 1.0, 0.3);
    let tree = smooth(
        SmoothOp::Difference,
        placed(Shape::Box { half }, DVec3::ZERO),
        placed(Shape::Cylinder { r: 0.4, h: 0.6 }, DVec3::ZERO),
        0.15,
    );
    let m = assert_smooth_shape("filleted hole", &tree);
    assert_eq!(m.report.euler_characteristic, 0);
    let step = 0.1;
    let m = mesh_one(&format!(
        "surface s = smooth_difference(box((-1, -1, -0.3), (1, 1, 0.3)), cylinder(0.4, 1), 0.15);\n\
         mesh s = s {{ step: {step}; box: (-1.5, -1.5, -1.5) .. (1.5, 1.5, 1.5); }}\n"
    ));
    assert_closed(&m, 0, 20.0);
    assert_box_edges(&m, half, step, |_| true);
}

/// A plate with a hole and a boss joined to it by a fillet: `smooth_union` of a difference
/// (sharp CSG inside a smooth boolean) and a cylinder.
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn plate_with_a_smoothly_joined_boss() {
    let plate = Tree::Difference(
        Box::new(placed(
            Shape::Box {
                half: DVec3::new(1.2, 0.8, 0.15),
            },
            DVec3::ZERO,
        )),
        Box::new(placed(
            Shape::Cylinder { r: 0.2, h: 0.5 },
            DVec3::new(0.75, 0.35, 0.0),
        )),
    );
    let boss = placed(
        Shape::Cylinder { r: 0.3, h: 0.3 },
        DVec3::new(-0.3, 0.0, 0.3),
    );
    let tree = smooth(SmoothOp::Union, plate, boss, 0.1);
    let m = assert_smooth_shape("plate with a boss", &tree);
    assert_eq!(m.report.euler_characteristic, 0);
}

// ---------------------------------------------------------------------------------------------
// M5: random CSG trees against the voxel reference.

/// What the voxel reference says of a tree's solid on one grid.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Reference {
    /// χ of the bounding surface: 2·χ(solid).
    euler: i64,
    /// Components of the bounding surface: one per solid component and one per cavity (the
    /// regions of space and the surfaces between them form a tree).
    components: usize,
}

/// One grid of the reference: a cube of voxels of side `voxel` around the tree's bounds (its
/// primitives' bounding balls), its lattice shifted by the fraction `shift` of a voxel (the
/// shifts are irrational, so two grids never sample the same points), and what it sees of the
/// tree's solid with its creases rounded to two voxels (`Tree::rounded`: the same topology in
/// general position, no wedge tip thinner than the grid); None when the grid cannot be
/// trusted.
///
/// Trusted means that the two ways of reading a sampled solid agree (`voxel::two_readings`):
/// the inside vertices joined along grid edges with the outside joined across cubes, and the
/// other way round. They differ where the solid or its complement is thinner than the grid,
/// and there neither can be believed.
struct Grid {
    /// The grid's first vertex.
    origin: DVec3,
    voxel: f64,
    solid: SolidCount,
    reference: Reference,
}

impl Grid {
    fn new(tree: &Tree, voxel: f64, shift: DVec3) -> Option<Grid> {
        let (blo, bhi) = tree.bounds();
        // Two voxels of margin, so that the solid never reaches the grid's faces.
        let side = (bhi - blo).max_element() + 4.0 * voxel;
        let n = (side / voxel).ceil() as usize;
        let origin = 0.5 * (blo + bhi) - DVec3::splat(0.5 * n as f64 * voxel) - shift * voxel;
        let end = origin + DVec3::splat(n as f64 * voxel);
        // Crumbs: fewer vertices than a 3×3×3 block (a feature that thin is out of general
        // position, and a component that small is below the step anyway).
        let (solid, outside) = two_readings(|p| tree.rounded(p, 2.0 * voxel), origin, end, n, 27);
        let inside_complex = Reference {
            euler: solid.surface_euler(),
            components: (solid.components + solid.outside_components).saturating_sub(1),
        };
        let outside_complex = Reference {
            euler: 2 * (outside.euler - 1),
            components: (outside.outside_components + outside.components).saturating_sub(1),
        };
        (inside_complex == outside_complex).then_some(Grid {
            origin,
            voxel,
            solid,
            reference: inside_complex,
        })
    }

    /// The reference: two trusted grids (of three, finer and finer, shifted) that agree; None
    /// when no two do.
    fn verdict(tree: &Tree, voxel: f64) -> Option<Grid> {
        let grids = [
            (voxel, DVec3::ZERO),
            (
                voxel * 8.0 / 11.0,
                DVec3::new(0.414_213_56, 0.732_050_81, 0.236_067_98),
            ),
            (
                voxel * 4.0 / 7.0,
                DVec3::new(0.645_751_31, 0.162_277_66, 0.605_551_28),
            ),
        ];
        let mut trusted: Vec<Grid> = Vec::new();
        for (h, shift) in grids {
            let Some(g) = Grid::new(tree, h, shift) else {
                continue;
            };
            if let Some(k) = trusted.iter().position(|t| t.reference == g.reference) {
                return Some(trusted.swap_remove(k));
            }
            trusted.push(g);
        }
        None
    }
}

/// The mesh's signed volume (divergence theorem) and area.
fn volume_and_area(m: &Meshed) -> (f64, f64) {
    let (mut volume, mut area) = (0.0, 0.0);
    for t in &m.mesh.triangles {
        let [a, b, c] = t.map(|k| m.mesh.vertices[k as usize]);
        volume += a.dot(b.cross(c)) / 6.0;
        area += 0.5 * (b - a).cross(c - a).length();
    }
    (volume, area)
}

/// The outcome of one random case.
enum Outcome {
    Right,
    Refused,
    Empty,
    /// No two of the reference's grids agree: the case is not checked.
    Skipped,
    /// The mesh differs from the reference, and surfc warned of a component smaller than
    /// the step that it did not mesh (docs/components.md: reported, not silently dropped).
    Small,
    /// A mesh reported as success that is not the surface: what is wrong.
    Wrong(String),
}

/// `csg_case`, with the mesh when there is one.
fn csg_mesh(tree: &Tree, source: &str, step: f64, voxel: f64) -> (Outcome, Option<Meshed>) {
    let Some(grid) = Grid::verdict(tree, voxel) else {
        return (Outcome::Skipped, None);
    };
    let meshed = match mesh_source(source) {
        Ok(mut m) => m.remove(0),
        Err(d) if d[0].code == "E0601" => return (Outcome::Refused, None),
        // Nothing in the box (E0605): right where the reference sees nothing too; where it
        // sees a component, right only if surfc said it was smaller than the step.
        Err(d) if d[0].code == "E0605" => {
            let small = d[0]
                .notes
                .iter()
                .any(|n| n.contains("smaller than the step"));
            let outcome = if grid.reference.components == 0 {
                Outcome::Empty
            } else if small {
                Outcome::Small
            } else {
                Outcome::Wrong(format!(
                    "E0605 (nothing in the box), the reference sees {:?}",
                    grid.reference
                ))
            };
            return (outcome, None);
        }
        Err(d) => return (Outcome::Wrong(format!("not E0601: {d:?}")), None),
    };
    let small = meshed
        .warnings
        .iter()
        .any(|w| w.contains("smaller than the step and was not meshed"));
    match compare(tree, &meshed, step, &grid) {
        Outcome::Wrong(_) if small => (Outcome::Small, Some(meshed)),
        outcome => (outcome, Some(meshed)),
    }
}

/// The mesh of a tree against the reference grid: the checks of `random_csg`.
fn compare(tree: &Tree, meshed: &Meshed, step: f64, grid: &Grid) -> Outcome {
    let reference = grid.reference;
    if meshed.mesh.triangles.is_empty() {
        return if reference.components == 0 {
            Outcome::Empty
        } else {
            Outcome::Wrong(format!("nothing meshed, the reference sees {reference:?}"))
        };
    }
    let expect = Expect {
        closed: true,
        euler: Some(reference.euler),
        components: Some(reference.components),
        boundary_loops: Some(0),
        min_angle_deg: 0.0,
        ..Expect::default()
    };
    let (_, violations) = check(&meshed.mesh, None, &expect);
    if !violations.is_empty() {
        return Outcome::Wrong(format!(
            "{violations:?} against {reference:?} ({:?}, outside {})",
            grid.solid, grid.solid.outside_components
        ));
    }
    // On the surface: every vertex, by the tree's own function evaluated natively (value
    // over a central-difference gradient).
    for &p in &meshed.mesh.vertices {
        let e = 1e-7;
        let g = DVec3::new(
            tree.value(p + DVec3::X * e) - tree.value(p - DVec3::X * e),
            tree.value(p + DVec3::Y * e) - tree.value(p - DVec3::Y * e),
            tree.value(p + DVec3::Z * e) - tree.value(p - DVec3::Z * e),
        ) / (2.0 * e);
        let off = tree.value(p).abs() / g.length();
        if off.is_nan() || off > 1e-6 * step {
            return Outcome::Wrong(format!("vertex {p} is {off:.1e} off the surface"));
        }
    }
    // The extent: the mesh's must reach within the chord tolerance (the default, 0.1·step)
    // of the grid's inside vertices' (a part missed shows here). Rounding the creases only
    // shrinks the solid where it is convex, where its extreme points are.
    let Some((ilo, ihi)) = grid.solid.inside else {
        return Outcome::Wrong("the reference saw nothing inside".into());
    };
    let v = &meshed.mesh.vertices;
    let mlo = v.iter().fold(DVec3::INFINITY, |a, b| a.min(*b));
    let mhi = v.iter().fold(DVec3::NEG_INFINITY, |a, b| a.max(*b));
    let (voxel, slack) = (grid.voxel, 1e-9 + 0.1 * step);
    for a in 0..3 {
        let inner_lo = grid.origin[a] + ilo[a] as f64 * voxel;
        let inner_hi = grid.origin[a] + ihi[a] as f64 * voxel;
        if mlo[a] > inner_lo + slack || mhi[a] < inner_hi - slack {
            return Outcome::Wrong(format!(
                "extent on axis {a}: mesh {}..{}, reference inside {inner_lo}..{inner_hi} (voxel {voxel})",
                mlo[a], mhi[a]
            ));
        }
    }
    // The volume, which also says that the mesh faces outward: one voxel per inside grid
    // vertex is the true volume to within about a voxel's thickness over the surface.
    let (volume, area) = volume_and_area(meshed);
    let grid_volume = grid.solid.inside_vertices as f64 * voxel.powi(3);
    if (volume - grid_volume).abs() > area * voxel {
        return Outcome::Wrong(format!(
            "volume {volume} against the grid's {grid_volume} (area {area})"
        ));
    }
    Outcome::Right
}

/// M5: random CSG trees of 2–5 spheres, boxes, cylinders and tori, moved and turned, joined
/// by min, max and difference, in general position (decided from the primitives' geometry,
/// `common::csg`; the trees out of it are drawn again and counted): each meshes with the χ,
/// the components, the extent and the volume of the independent voxel reference (`Grid`),
/// every vertex on the surface by the tree's own function, watertight, oriented, no crossing
/// triangles — or is refused with E0601. Never a wrong mesh reported as success. Default 1
/// case (about 3 s; `.ci/run` runs 12); `SURFC_CSG_CASES=200` for a larger run, `SURFC_CSG_DUMP=DIR` to keep
/// the refused and wrong cases' sources, `SURFC_CSG_ONLY=K` to run case K alone, `SURFC_CSG_STEP=H` to mesh at another step
/// than 0.1. The right meshes' smallest angles are reported, not asserted: a narrow band of
/// surface between two crease polygons is crossed by triangles with only polygon corners,
/// which the quality stage cannot move (case 8 of 40: a band 0.01 wide between creases
/// sampled every 0.1, 4.0°).
#[test]
fn random_csg_trees_mesh_right_or_refuse() {
    random_csg(false, 0x9E37_79B9_7F4A_7C15, 1);
}

/// M5 for the smooth booleans: the same property on random trees with at least one smooth
/// boolean (`smooth_union`, `smooth_intersection`, `smooth_difference` with radii 0.08–0.25)
/// over the same primitives, so that boxes, cylinders and their sharp CSG sit inside smooth
/// booleans (the spine lifts them, `compile::spine`). The reference rounds the values the
/// text computes (`Tree::rounded`). Default 1 case; the same variables as above.
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn random_smooth_csg_trees_mesh_right_or_refuse() {
    random_csg(true, 0x2545_F491_4F6C_DD1D, 1);
}

/// The random CSG property test: `default_cases` trees (or `SURFC_CSG_CASES`) drawn from
/// `seed`, with smooth booleans if `smooth`.
fn random_csg(smooth: bool, seed: u64, default_cases: usize) {
    let cases: usize = common::env_number("SURFC_CSG_CASES").unwrap_or(default_cases);
    let started = std::time::Instant::now();
    let step: f64 = common::env_number("SURFC_CSG_STEP").unwrap_or(0.1);
    let (lo, hi) = (DVec3::splat(-2.5), DVec3::splat(2.5));
    // The reference's first grid; its creases are rounded to two voxels.
    let voxel = 0.025;
    // Reach: the rounding's two voxels; sines and determinants: about 11.5° between two
    // pieces, and three normals no flatter than that.
    let general = GeneralPosition {
        reach: 0.05,
        spacing: 0.02,
        min_sine: 0.2,
        min_det: 0.1,
    };
    let (mut right, mut refused, mut empty, mut skipped, mut small) = (0, 0, 0, 0, 0);
    // The quality of the right meshes (issue 13's bar, reported): how many have a triangle
    // below 30°, and the smallest angle of all.
    let (mut below_30, mut lowest) = (0, f64::INFINITY);
    // Right meshes with a triangle below 30° that no warning told the user of.
    let mut unwarned: Vec<usize> = Vec::new();
    let mut wrong: Vec<String> = Vec::new();
    let (mut drawn, mut tangent, mut flat, mut crowded, mut outside) = (0, 0, 0, 0, 0);
    let mut rng = Rng(seed);
    // One case alone (the others drawn, not meshed), to look at it.
    let only: Option<usize> = common::env_number("SURFC_CSG_ONLY");
    // The cases drawn in order (the same draws and rejections whatever runs), then meshed
    // on the pool and tallied in order.
    let mut chosen: Vec<(usize, String, Tree)> = Vec::new();
    let mut case = 0;
    while case < cases {
        drawn += 1;
        let n = 2 + (rng.next() as usize) % 4;
        let tree = Tree::random(&mut rng, n, smooth);
        if smooth && !tree.has_smooth() {
            continue;
        }
        let rejected = match tree.degenerate(&general) {
            Some(Degenerate::NearTangent { .. }) => Some(&mut tangent),
            Some(Degenerate::FlatCorner { .. }) => Some(&mut flat),
            Some(Degenerate::Crowded { .. }) => Some(&mut crowded),
            None => None,
        };
        if let Some(count) = rejected {
            *count += 1;
            continue;
        }
        // The solid must lie inside the mesh box, a voxel clear of its faces.
        let margin = DVec3::splat(voxel);
        let reaches_out = solid_count(|p| tree.value(p), lo + margin, hi - margin, 64).touches_box;
        if reaches_out {
            outside += 1;
            continue;
        }
        if only.is_none_or(|k| k == case) {
            let source = format!(
                "surface s = {};\nmesh s = s {{ step: {step}; box: ({}, {}, {}) .. ({}, {}, {}); }}\n",
                tree.source(),
                lo.x,
                lo.y,
                lo.z,
                hi.x,
                hi.y,
                hi.z
            );
            chosen.push((case, source, tree));
        }
        case += 1;
    }
    let judged: Vec<(Outcome, Option<Meshed>)> = chosen
        .par_iter()
        .map(|(_, source, tree)| csg_mesh(tree, source, step, voxel))
        .collect();
    for ((case, source, _), (outcome, meshed)) in chosen.iter().zip(judged) {
        let case = *case;
        let dump = |what: &str| {
            if let Some(dir) = std::env::var_os("SURFC_CSG_DUMP") {
                let kind = if smooth { "smooth_" } else { "" };
                let path = std::path::Path::new(&dir).join(format!("{kind}{what}{case}.surf"));
                std::fs::write(path, source).expect("writes the case");
            }
        };
        match outcome {
            Outcome::Right => {
                right += 1;
                let angle = meshed.as_ref().map_or(f64::NAN, min_angle_deg);
                if angle < 30.0 {
                    eprintln!("case {case}: smallest angle {angle:.1}°\n{source}");
                    below_30 += 1;
                    let told = meshed
                        .as_ref()
                        .is_some_and(|m| m.warnings.iter().any(|w| w.contains("stay below")));
                    if !told {
                        unwarned.push(case);
                    }
                }
                lowest = lowest.min(angle);
            }
            Outcome::Empty => empty += 1,
            Outcome::Small => small += 1,
            Outcome::Skipped => {
                eprintln!("case {case} skipped: no two reference grids agree");
                skipped += 1;
            }
            Outcome::Refused => {
                dump("refused");
                refused += 1;
            }
            Outcome::Wrong(why) => {
                dump("wrong");
                eprintln!("case {case}: A WRONG MESH REPORTED AS SUCCESS: {why}\n{source}");
                wrong.push(format!("case {case}: {why}"));
            }
        }
    }
    eprintln!(
        "random CSG{}: {right} right, {refused} refused, {empty} empty, {skipped} skipped, \
         {small} with a component below the step reported, {} wrong \
         of {cases} cases; {drawn} drawn, rejected before meshing: {tangent} near-tangent, \
         {flat} flat corner, {crowded} four pieces near a point, {outside} reaching the box; \
         {:.1} s; {below_30} right mesh(es) with a triangle below 30°, smallest angle {lowest:.1}°",
        if smooth { " (smooth booleans)" } else { "" },
        wrong.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(
        wrong.is_empty(),
        "wrong meshes reported as success: {wrong:#?}"
    );
    assert!(
        unwarned.is_empty(),
        "right meshes with a triangle below 30° and no warning: cases {unwarned:?}"
    );
    assert!(right >= refused, "most cases should mesh");
    // The reference must check nearly every case: at most 5 % skipped.
    assert!(
        20 * skipped <= cases,
        "{skipped} of {cases} cases unchecked (the reference grids disagree)"
    );
}
