//! The quality stage (docs/marcher.md, "Quality stage"): the same input meshed with the stage
//! off (`quality_angle = 0`) and on. The stage must keep the Euler characteristic and the
//! boundary loops, add or remove vertices only with their triangles (an insertion adds one
//! vertex and two triangles, a removal takes one vertex and two: T − 2V unchanged on a closed
//! surface), keep the box's border (a vertex on a box edge or corner stays bit for bit, one on
//! a box face may slide along it, never off it), raise the smallest angle and the mean radius
//! ratio, and not lower the median. The worst triangle of
//! the raw mesh is printed with its neighbourhood (run with --nocapture), which is how the
//! thin triangles were diagnosed.

use crate::common;

use common::*;
use glam::DVec3;
use surfc::march::{MarchInput, MarchSettings, march};
use surfc::mesh::Mesh;
use surfc::mesh::quality::{quality, triangle_angles};
use surfc::mesh::topology::topology;

fn smallest(m: &Mesh, t: [u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| m.vertices[v as usize]);
    triangle_angles(a, b, c)
        .into_iter()
        .fold(f64::INFINITY, f64::min)
}

/// The worst triangle of `m`, its corners, and every triangle sharing a corner with it.
fn print_worst(name: &str, m: &Mesh, step: f64) {
    let Some((worst, &t)) = m
        .triangles
        .iter()
        .enumerate()
        .min_by(|x, y| smallest(m, *x.1).total_cmp(&smallest(m, *y.1)))
    else {
        return;
    };
    println!(
        "{name}: worst triangle {worst} {t:?} smallest angle {:.1}°",
        smallest(m, t)
    );
    for v in t {
        println!("  corner {v} at {}", m.vertices[v as usize]);
    }
    for (i, &u) in m.triangles.iter().enumerate() {
        if i != worst && u.iter().any(|v| t.contains(v)) {
            let [a, b, c] = u.map(|v| m.vertices[v as usize]);
            println!(
                "  neighbour {i} {u:?} smallest angle {:.1}°, edges {:.2} {:.2} {:.2} δ",
                smallest(m, u),
                a.distance(b) / step,
                b.distance(c) / step,
                c.distance(a) / step
            );
        }
    }
}

fn compare(name: &str, mut surface: Boxed, input: &MarchInput, min_angle: f64) {
    // The quality stage on the paper's meshes: with the local step the two runs may refine
    // differently.
    let input = &MarchInput {
        uniform: true,
        tolerance: Some(0.6 * input.step),
        ..input.clone()
    };
    let off = MarchSettings {
        quality_angle: 0.0,
        ..MarchSettings::default()
    };
    let raw = march(surface.as_mut(), input, &off).expect("meshes without the pass");
    let fixed = march(surface.as_mut(), input, &MarchSettings::default()).expect("meshes");
    print_worst(name, &raw, input.step);
    let (tr, tf) = (topology(&raw), topology(&fixed));
    if tr.boundary_edges.is_empty() {
        let excess = |m: &Mesh| m.triangles.len() as i64 - 2 * m.vertices.len() as i64;
        assert_eq!(excess(&raw), excess(&fixed), "{name}");
    }
    assert_eq!(tr.euler_characteristic, tf.euler_characteristic, "{name}");
    // Face splits add vertices to the loops on the box; their number stays.
    assert_eq!(tr.boundary_loops.len(), tf.boundary_loops.len(), "{name}");
    if let Some((lo, hi)) = input.bbox {
        // A vertex on a box face may slide along it (the face coordinate bit for bit); one on
        // a box edge or corner stays where it is. Removed vertices renumber the others, so
        // this is checked on the sets: every raw point on an edge or corner is still a
        // vertex, and no face has fewer vertices than before (face splits add some; a vertex
        // that left its face would be missing from it).
        let faces = |p: DVec3| -> Vec<(usize, f64)> {
            (0..3)
                .flat_map(|k| [(k, lo[k]), (k, hi[k])])
                .filter(|&(k, b)| p[k] == b)
                .collect()
        };
        let on_face = |m: &Mesh, face: (usize, f64)| {
            m.vertices.iter().filter(|&&p| faces(p) == [face]).count()
        };
        for p in &raw.vertices {
            let on = faces(*p);
            match on.len() {
                0 => {}
                1 => assert!(
                    on_face(&fixed, on[0]) >= on_face(&raw, on[0]),
                    "{name}: a vertex left the box face {:?}",
                    on[0]
                ),
                _ => assert!(
                    fixed.vertices.contains(p),
                    "{name}: a vertex on a box edge moved: {p}"
                ),
            }
        }
    }
    let (qr, qf) = (quality(&raw), quality(&fixed));
    println!(
        "{name}: smallest angle {:.1}° → {:.1}°, 1 % {:.1}° → {:.1}°, median {:.1}° → {:.1}°, mean radius ratio {:.4} → {:.4}",
        qr.min_angle_deg,
        qf.min_angle_deg,
        qr.p1_angle_deg,
        qf.p1_angle_deg,
        qr.median_angle_deg,
        qf.median_angle_deg,
        qr.radius_ratio_mean,
        qf.radius_ratio_mean
    );
    assert!(qf.min_angle_deg > qr.min_angle_deg, "{name}");
    assert!(qf.min_angle_deg >= min_angle, "{name}");
    assert!(qf.radius_ratio_mean > qr.radius_ratio_mean, "{name}");
    assert!(qf.median_angle_deg >= qr.median_angle_deg, "{name}");
}

#[test]
fn genus3_keeps_its_topology_and_gains_angle() {
    compare(
        "genus 3 δ=0.3",
        genus3(),
        &MarchInput::from_point(0.3, DVec3::new(0.0, 3.0, 0.0)),
        30.0,
    );
}

#[test]
fn three_cylinders_keep_their_border() {
    let mut input = MarchInput::from_point(0.5, DVec3::ZERO);
    input.bbox = Some((DVec3::new(-7.0, -7.0, -7.0), DVec3::new(7.0, 7.0, 5.0)));
    compare(
        "three cylinders δ=0.5",
        three_cylinders(2287.5587),
        &input,
        // With the uniform step one box-face triangle stayed at 27.4° even with border points
        // sliding, until the stage removed free corners resting on a box edge (31.0° now).
        30.0,
    );
}

#[test]
fn torus_keeps_its_topology_and_gains_angle() {
    compare(
        "torus δ=0.1",
        torus(1.0, 0.35),
        &MarchInput::from_point(0.1, DVec3::new(1.0, 0.0, 0.5)),
        30.0,
    );
}
