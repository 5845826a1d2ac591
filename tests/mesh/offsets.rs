//! Offsets of solids (issue 42, "rounded solids"): `offset` of a box meshed in a box is the
//! rounded box — closed, χ = 2, every vertex at the offset distance from the box by the exact
//! box distance computed here, its area the rounded box's; offsets of a union of two spheres
//! and of an L of two boxes, whose outward offsets have a crease hidden inside `dist`, mesh
//! right or are refused with a place, within seconds.

use std::time::Instant;

use glam::DVec3;
use surfc::pipeline::mesh_source;

use crate::common;

/// The exact signed distance to the box [lo, hi].
fn box_distance(lo: DVec3, hi: DVec3, p: DVec3) -> f64 {
    let q = (p - (lo + hi) * 0.5).abs() - (hi - lo) * 0.5;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

/// The box [−½, ½]³ rounded by 0.2 at step 0.05: watertight with χ = 2, every vertex 0.2 from
/// the box to 1e-9, and its area that of six unit faces, twelve quarter cylinders of radius
/// 0.2 and length 1, and eight sphere octants of radius 0.2: 6 + 1.2π + 0.16π.
#[test]
fn the_offset_of_a_box_is_the_rounded_box() {
    let source = "surface b = box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5));\n\
                  surface r = offset(b, 0.2);\n\
                  mesh r = r { step: 0.05; box: (-1, -1, -1) .. (1, 1, 1); }\n";
    let started = Instant::now();
    let m = mesh_source(source)
        .expect("the rounded box meshes")
        .remove(0);
    let took = started.elapsed();
    common::assert_closed(&m, &common::closed(2));
    let (lo, hi) = (DVec3::splat(-0.5), DVec3::splat(0.5));
    let worst = m
        .mesh
        .vertices
        .iter()
        .map(|&v| (box_distance(lo, hi, v) - 0.2).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 1e-9, "a vertex is {worst:e} off the offset");
    let exact = 6.0 + 1.2 * std::f64::consts::PI + 0.16 * std::f64::consts::PI;
    let a = common::area(&m.mesh);
    println!(
        "rounded box: {} triangles, area {a:.5} (exact {exact:.5}, {:+.3} %), vertices within {worst:.1e}, {took:?}",
        m.mesh.triangles.len(),
        100.0 * (a - exact) / exact
    );
    assert!(
        (a - exact).abs() <= 0.005 * exact,
        "area {a} against {exact}"
    );
    // Chord error within the default tolerance (0.1·step) and triangles near-equilateral.
    assert!(m.max_chord_error <= 0.1 * 0.05, "{}", m.max_chord_error);
    assert!(m.report.min_angle_deg >= 30.0, "{}", m.report.min_angle_deg);
}

/// The exact signed distance to `cylinder(r, h)` at `c` (axis along z).
fn cylinder_distance(c: DVec3, r: f64, h: f64, p: DVec3) -> f64 {
    let p = p - c;
    let (a, b) = (p.x.hypot(p.y) - r, p.z.abs() - 0.5 * h);
    a.max(0.0).hypot(b.max(0.0)) + a.max(b).min(0.0)
}

/// A mesh of the offset by `d` of a union whose solids are at distance `parts(p)` from p:
/// closed with Euler characteristic `euler`, every triangle ≥ 30°, every vertex at distance
/// `d` from the union (the least of the parts') to 1e-9, and at least `crease` vertices on
/// the concave crease where two parts' offsets meet (two parts at distance `d` to 1e-9).
fn offset_of_union_meshes(
    source: &str,
    parts: &dyn Fn(DVec3) -> Vec<f64>,
    d: f64,
    euler: i64,
    crease: usize,
) -> surfc::Mesh {
    let m = match mesh_source(source) {
        Ok(mut m) => m.remove(0),
        Err(e) => panic!("does not mesh: {e:?}"),
    };
    let expect = surfc::mesh::check::Expect {
        min_angle_deg: 30.0,
        ..common::closed(euler)
    };
    common::assert_closed(&m, &expect);
    let mut on_crease = 0;
    for &v in &m.mesh.vertices {
        let mut each = parts(v);
        each.sort_by(f64::total_cmp);
        assert!(
            (each[0] - d).abs() <= 1e-9,
            "{v} is {} from the union",
            each[0]
        );
        if (each[1] - d).abs() <= 1e-9 {
            on_crease += 1;
        }
    }
    assert!(on_crease >= crease, "{on_crease} vertices on the crease");
    m.mesh
}

/// The outward offset of a union is the union of its operands' offsets (`compile::lower`):
/// the concave crease where they meet, which `dist` of the whole hides inside one smooth
/// branch, is a crease the search traces. Two overlapping balls (their crease a circle) and
/// a boss standing on a plate (a circle where the boss's side meets the plate's top, the
/// boss's top edge and the plate's edges rounded).
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn the_offset_of_a_union_is_the_union_of_the_offsets() {
    let source = "surface s = union(sphere(1), translate(sphere(0.7), (1.2, 0.3, 0)));\n\
                  surface o = offset(s, 0.2);\n\
                  mesh o = o { step: 0.05; box: (-1.5, -1.5, -1.5) .. (2.5, 1.5, 1.5); }\n";
    let (a, b) = (DVec3::ZERO, DVec3::new(1.2, 0.3, 0.0));
    let balls = |p: DVec3| vec![(p - a).length() - 1.0, (p - b).length() - 0.7];
    let _ = offset_of_union_meshes(source, &balls, 0.2, 2, 40);
    let source = "surface s = union(box((-1, -1, 0), (1, 1, 0.3)),\n\
                                    translate(cylinder(0.3, 0.6), (0, 0, 0.5)));\n\
                  surface o = offset(s, 0.1);\n\
                  mesh o = o { step: 0.05; box: (-1.3, -1.3, -0.3) .. (1.3, 1.3, 1.1); }\n";
    let boss = |p: DVec3| {
        vec![
            box_distance(DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.3), p),
            cylinder_distance(DVec3::new(0.0, 0.0, 0.5), 0.3, 0.6, p),
        ]
    };
    let _ = offset_of_union_meshes(source, &boss, 0.1, 2, 40);
}

/// The volume inside the closed mesh (the divergence theorem over its triangles).
fn volume(m: &surfc::Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// The volume of {p : parts(p) ≤ d} in [lo, hi] counted on a grid of spacing `h` (cell
/// centres): the independent reference of a rounded solid's volume.
fn voxel_volume(parts: &dyn Fn(DVec3) -> f64, d: f64, lo: DVec3, hi: DVec3, h: f64) -> f64 {
    let n = ((hi - lo) / h).ceil().as_uvec3();
    let mut inside = 0u64;
    for i in 0..n.x {
        for j in 0..n.y {
            for k in 0..n.z {
                let p = lo + h * (DVec3::new(i as f64, j as f64, k as f64) + 0.5);
                if parts(p) <= d {
                    inside += 1;
                }
            }
        }
    }
    inside as f64 * h * h * h
}

/// Solids that share a face plane, rounded by `offset`: the two rounded solids are one sheet
/// where they share the face and cross elsewhere. An L of two boxes flush at its back and
/// sides (the crease between the rounded boxes dies out where both become the shared side
/// face: the two ends are joined by a seam through the side faces, the back and the bottom),
/// and an upright flush with a plate's underside (one sheet there, a crease loop around the
/// upright): every vertex at the offset distance from the union to 1e-9, closed, χ = 2, ≥ 30°,
/// and the volume within 1 % of a voxel count of the rounded solid.
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn solids_flush_on_a_face_and_rounded_mesh_right() {
    let b = DVec3::new;
    for (name, boxes, r, step) in [
        (
            "L",
            [
                (b(0.0, 0.0, 0.0), b(2.0, 1.0, 0.3)),
                (b(0.0, 0.0, 0.0), b(0.3, 1.0, 1.5)),
            ],
            0.1,
            0.05,
        ),
        (
            "upright flush below",
            [
                (b(0.0, 0.0, 0.0), b(2.0, 1.0, 0.3)),
                (b(0.8, 0.2, 0.0), b(1.1, 0.8, 1.2)),
            ],
            0.1,
            0.05,
        ),
        (
            "L of other proportions",
            [
                (b(0.0, 0.0, 0.0), b(1.2, 0.8, 0.25)),
                (b(0.0, 0.0, 0.0), b(0.4, 0.8, 0.9)),
            ],
            0.15,
            0.06,
        ),
    ] {
        let [(lo0, hi0), (lo1, hi1)] = boxes;
        let v = |p: DVec3| format!("({}, {}, {})", p.x, p.y, p.z);
        let (lo, hi) = (lo0.min(lo1) - 3.0 * r, hi0.max(hi1) + 3.0 * r);
        let source = format!(
            "surface s = union(box({}, {}), box({}, {}));\n\
             surface o = offset(s, {r});\n\
             mesh o = o {{ step: {step}; box: {} .. {}; }}\n",
            v(lo0),
            v(hi0),
            v(lo1),
            v(hi1),
            v(lo),
            v(hi)
        );
        let parts = |p: DVec3| vec![box_distance(lo0, hi0, p), box_distance(lo1, hi1, p)];
        let m = offset_of_union_meshes(&source, &parts, r, 2, 40);
        let union = |p: DVec3| box_distance(lo0, hi0, p).min(box_distance(lo1, hi1, p));
        let reference = voxel_volume(&union, r, lo, hi, 0.01);
        let meshed = volume(&m);
        assert!(
            (meshed / reference - 1.0).abs() <= 0.01,
            "{name}: volume {meshed} against {reference}"
        );
    }
}
