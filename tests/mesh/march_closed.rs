//! Closed surfaces of the paper (Sects. 3.1, 3.3, 3.5): watertight, consistently oriented,
//! one component, the Euler characteristic of their genus, triangle counts near the paper's.

use crate::common;

use common::*;
use glam::DVec3;
use surfc::march::MarchInput;
use surfc::mesh::check::Expect;

#[test]
fn sphere_of_the_paper() {
    let mut s = sphere(2.0);
    let m = mesh_and_check(
        "sphere r=2 δ=0.3",
        &mut s,
        &MarchInput {
            uniform: true,
            ..MarchInput::from_point(0.3, DVec3::new(1.0, 1.0, 1.0))
        },
        closed(2),
    );
    assert_near_paper("sphere", m.triangles.len(), 1544);
}

#[test]
fn torus_of_the_paper() {
    let mut s = torus(1.0, 0.35);
    mesh_and_check(
        "torus δ=0.1",
        &mut s,
        &MarchInput::from_point(0.1, DVec3::new(1.0, 0.0, 0.5)),
        closed(0),
    );
}

#[test]
fn genus3_of_the_paper() {
    let mut s = genus3();
    let m = mesh_and_check(
        "genus 3 δ=0.3",
        &mut s,
        &MarchInput {
            uniform: true,
            // The paper's step leaves 0.53 δ at the tight rims.
            tolerance: Some(0.6 * 0.3),
            ..MarchInput::from_point(0.3, DVec3::new(0.0, 3.0, 0.0))
        },
        closed(-4),
    );
    assert_near_paper("genus 3", m.triangles.len(), 7354);
}

/// A flat ellipsoid x²/4 + y²/4 + z²/0.01 = 1, 0.2 thick at step 0.3: its two sheets pass
/// closer than the near distance with opposed normals and must never be joined. (The rim's
/// radius of curvature is 0.005 = δ/60, so its triangles are thin and a triangle across the
/// rim has vertex normals that nearly cancel: no angle or normal check here.)
#[test]
fn flat_ellipsoid_sheets_stay_apart() {
    let mut s: Boxed = Box::new(surfc::surface::NativeSurface(|p: DVec3| {
        vg(
            p.x * p.x / 4.0 + p.y * p.y / 4.0 + p.z * p.z / 0.01 - 1.0,
            DVec3::new(p.x / 2.0, p.y / 2.0, p.z / 0.005),
        )
    }));
    mesh_and_check(
        "flat ellipsoid δ=0.3",
        &mut s,
        &MarchInput::from_point(0.3, DVec3::new(0.3, 0.2, 0.1)),
        Expect {
            min_angle_deg: 0.0,
            normals_agree: false,
            ..closed(2)
        },
    );
}

/// `expected_triangles` only reserves room: the torus marched with no hint, a hint far too
/// small and one far too large gives the same mesh, bit for bit.
#[test]
fn the_expected_triangles_change_no_bit() {
    let march = |expected: Option<u64>| {
        let mut s = torus(1.0, 0.35);
        let input = MarchInput {
            expected_triangles: expected,
            ..MarchInput::from_point(0.1, DVec3::new(1.0, 0.0, 0.5))
        };
        surfc::march::march(&mut s, &input, &surfc::march::MarchSettings::default())
            .expect("the torus marches")
    };
    let plain = march(None);
    assert!(plain.triangles.len() > 1000, "{}", plain.triangles.len());
    for expected in [
        Some(10),
        Some(plain.triangles.len() as u64),
        Some(10_000_000),
    ] {
        let hinted = march(expected);
        assert_eq!(hinted.triangles, plain.triangles, "{expected:?}");
        let bits = |m: &surfc::mesh::Mesh| -> Vec<[u64; 3]> {
            (m.vertices.iter().chain(&m.normals))
                .map(|v| v.to_array().map(f64::to_bits))
                .collect()
        };
        assert_eq!(bits(&hinted), bits(&plain), "{expected:?}");
    }
}
