//! Offsets of solids (issue 42, "rounded solids"): `offset` of a box meshed in a box is the
//! rounded box — closed, χ = 2, every vertex at the offset distance from the box by the exact
//! box distance computed here, its area the rounded box's; offsets of a union of two spheres
//! and of an L of two boxes, whose outward offsets have a crease hidden inside `dist`, mesh
//! right or are refused with a place, within seconds.

use std::time::{Duration, Instant};

use glam::DVec3;
use surfc::pipeline::mesh_source;

use crate::common;

/// The exact signed distance to the box [lo, hi].
fn box_distance(lo: DVec3, hi: DVec3, p: DVec3) -> f64 {
    let q = (p - (lo + hi) * 0.5).abs() - (hi - lo) * 0.5;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

fn area(m: &surfc::Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
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
    let a = area(&m.mesh);
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

/// What a mesh of an offset must be, or how it must be refused: closed and every vertex at
/// distance `d` from the solid by `exact` (to 1e-9), or E0601 naming a place, within
/// `within`.
fn meshes_right_or_refuses(source: &str, exact: &dyn Fn(DVec3) -> f64, d: f64, within: Duration) {
    let started = Instant::now();
    let result = mesh_source(source);
    let took = started.elapsed();
    match result {
        Ok(mut m) => {
            let m = m.remove(0);
            common::assert_closed(&m, &common::closed(2));
            let worst = m
                .mesh
                .vertices
                .iter()
                .map(|&v| (exact(v) - d).abs())
                .fold(0.0, f64::max);
            println!(
                "meshed: {} triangles in {took:?}, vertices within {worst:.1e}",
                m.mesh.triangles.len()
            );
            assert!(worst <= 1e-9, "a vertex is {worst:e} off the offset");
        }
        Err(d) => {
            println!("refused in {took:?}: {d:?}");
            assert_eq!(d[0].code, "E0601", "{d:?}");
            assert!(
                d[0].notes
                    .iter()
                    .any(|n| n.contains(" near [") || n.contains(" at [")),
                "no place: {d:?}"
            );
        }
    }
    assert!(took <= within, "{took:?}");
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
) {
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
}

/// The outward offset of a union is the union of its operands' offsets (`compile::lower`):
/// the concave crease where they meet, which `dist` of the whole hides inside one smooth
/// branch, is a crease the search traces. Two overlapping balls (their crease a circle) and
/// a boss standing on a plate (a circle where the boss's side meets the plate's top, the
/// boss's top edge and the plate's edges rounded).
#[test]
fn the_offset_of_a_union_is_the_union_of_the_offsets() {
    let source = "surface s = union(sphere(1), translate(sphere(0.7), (1.2, 0.3, 0)));\n\
                  surface o = offset(s, 0.2);\n\
                  mesh o = o { step: 0.05; box: (-1.5, -1.5, -1.5) .. (2.5, 1.5, 1.5); }\n";
    let (a, b) = (DVec3::ZERO, DVec3::new(1.2, 0.3, 0.0));
    let balls = |p: DVec3| vec![(p - a).length() - 1.0, (p - b).length() - 0.7];
    offset_of_union_meshes(source, &balls, 0.2, 2, 40);
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
    offset_of_union_meshes(source, &boss, 0.1, 2, 40);
}

/// The outward offset of an L of two boxes that share face planes: the crease of the two
/// rounded boxes dies out where they meet a face they share (docs/creases.md, *Limits*).
#[test]
fn the_offset_of_an_l_meshes_right_or_is_refused_in_seconds() {
    let source = "surface s = union(box((0, 0, 0), (2, 1, 0.3)), box((0, 0, 0), (0.3, 1, 1.5)));\n\
                  surface o = offset(s, 0.2);\n\
                  mesh o = o { step: 0.05; box: (-0.5, -0.5, -0.5) .. (2.5, 1.5, 2); }\n";
    let outside = |p: DVec3| {
        box_distance(DVec3::ZERO, DVec3::new(2.0, 1.0, 0.3), p).min(box_distance(
            DVec3::ZERO,
            DVec3::new(0.3, 1.0, 1.5),
            p,
        ))
    };
    meshes_right_or_refuses(source, &outside, 0.2, Duration::from_secs(60));
}

/// Rounded by `offset`, an upright standing on a plate and flush with its underside: the two
/// rounded solids are one sheet on the underside and cross around the upright, which the
/// faces of the crease net cannot hold (one face on one part, two across the crease). Refused
/// where they cross, with what to change — not meshed wrong, and not read as a tangency.
#[test]
fn solids_flush_on_a_face_and_rounded_are_refused_where_they_cross() {
    let source = "surface s = union(box((0, 0, 0), (2, 1, 0.3)), box((0.8, 0.2, 0), (1.1, 0.8, 1.2)));\n\
                  surface o = offset(s, 0.1);\n\
                  mesh o = o { step: 0.05; box: (-0.3, -0.3, -0.3) .. (2.3, 1.3, 1.5); }\n";
    let d = match mesh_source(source) {
        Ok(_) => panic!("meshed"),
        Err(d) => d,
    };
    assert_eq!(d[0].code, "E0601", "{d:?}");
    assert!(
        d[0].notes
            .iter()
            .any(|n| n.contains("that are one sheet elsewhere")),
        "{d:?}"
    );
    assert!(
        d[0].help
            .as_deref()
            .is_some_and(|h| h.contains("smooth_union")),
        "{d:?}"
    );
}
