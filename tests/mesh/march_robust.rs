//! Robustness: rotated and scaled copies of the sphere and torus, the sphere over a range of
//! steps, singular surfaces (a cone's apex, a cusp) and the failure paths — each ends with a
//! mesh or a `MarchError` that says where, never a hang or a panic.

use crate::common;

use common::*;
use glam::{DMat3, DVec3};
use surfc::march::{MarchError, MarchInput, MarchSettings, Start, march};
use surfc::mesh::check::{Expect, check};
use surfc::mesh::quality::MeshReport;
use surfc::surface::{NativeSurface, Surface};

/// A closed surface of the given Euler characteristic, every triangle at 30° or more (the
/// quality stage, issue 13).
fn closed_at_30(euler: i64) -> Expect {
    Expect {
        min_angle_deg: 30.0,
        ..closed(euler)
    }
}

fn rotations() -> Vec<(String, DMat3)> {
    vec![
        ("id".into(), DMat3::IDENTITY),
        ("x30".into(), DMat3::from_rotation_x(0.52)),
        (
            "y90".into(),
            DMat3::from_rotation_y(std::f64::consts::FRAC_PI_2),
        ),
        (
            "xyz".into(),
            DMat3::from_rotation_z(1.1)
                * DMat3::from_rotation_y(-0.7)
                * DMat3::from_rotation_x(2.3),
        ),
    ]
}

#[test]
fn rotated_and_scaled_spheres_and_tori() {
    for (name, rot) in rotations() {
        for scale in [0.1, 1.0, 10.0] {
            let mut s = transformed(sphere(2.0), rot, scale);
            let start = rot * DVec3::new(1.0, 1.0, 1.0) * scale;
            mesh_and_check(
                &format!("sphere {name} ×{scale}"),
                &mut s,
                &MarchInput::from_point(0.3 * scale, start),
                closed_at_30(2),
            );
            let mut t = transformed(torus(1.0, 0.35), rot, scale);
            let start = rot * DVec3::new(1.0, 0.0, 0.5) * scale;
            mesh_and_check(
                &format!("torus {name} ×{scale}"),
                &mut t,
                &MarchInput::from_point(0.1 * scale, start),
                closed_at_30(0),
            );
        }
    }
}

#[test]
fn sphere_from_half_the_radius_down_to_a_hundredth() {
    for div in [2.0, 3.0, 5.0, 10.0, 20.0, 50.0, 100.0] {
        let mut s = sphere(2.0);
        mesh_and_check(
            &format!("sphere δ=r/{div}"),
            &mut s,
            &MarchInput::from_point(2.0 / div, DVec3::new(1.0, 1.0, 1.0)),
            closed_at_30(2),
        );
    }
}

/// A coarse sphere (< 200 triangles), the future OBJ snapshot.
#[test]
fn coarse_sphere() {
    let mut s = sphere(1.0);
    let m = mesh_and_check(
        "coarse sphere δ=0.5",
        &mut s,
        &MarchInput::from_point(0.5, DVec3::new(0.0, 0.0, 1.0)),
        closed_at_30(2),
    );
    assert!(m.triangles.len() < 200, "{}", m.triangles.len());
    let report = MeshReport::new(&m, s.as_mut(), None);
    assert_eq!(report.triangles, m.triangles.len());
    assert_eq!((report.euler_characteristic, report.components), (2, 1));
    assert_eq!((report.boundary_edges, report.boundary_loops), (0, 0));
    assert!(report.max_vertex_error <= 1e-9 * 0.5);
    let json = serde_json::to_value(&report).unwrap_or_default();
    for key in [
        "vertices",
        "triangles",
        "boundary_edges",
        "boundary_loops",
        "non_manifold_edges",
        "euler_characteristic",
        "components",
        "min_angle_deg",
        "max_vertex_error",
    ] {
        assert!(json.get(key).is_some(), "{key} missing in {json}");
    }
}

/// The same input gives the same mesh, bit for bit.
#[test]
fn deterministic() {
    let run = || {
        let mut s = genus3();
        march(
            s.as_mut(),
            &MarchInput::from_point(0.3, DVec3::new(0.0, 3.0, 0.0)),
            &MarchSettings::default(),
        )
    };
    assert_eq!(run(), run());
}

/// Ends with a mesh (then checked for overlaps and manifoldness) or an error with a location.
fn ends_cleanly(name: &str, s: &mut dyn Surface, input: &MarchInput) {
    match march(s, input, &MarchSettings::default()) {
        Ok(m) => {
            let expect = Expect {
                min_angle_deg: 0.0,
                no_intersections: false,
                ..Expect::default()
            };
            let (t, v) = check(&m, None, &expect);
            println!(
                "{name}: mesh of {} triangles, {} non-manifold edges, violations {v:?}",
                t.triangles,
                t.non_manifold_edges.len()
            );
        }
        Err(e) => {
            println!("{name}: {e}");
            let at = match e {
                MarchError::NewPoint { near, .. } => near,
                MarchError::TooManyTriangles { at, .. } | MarchError::Stalled { at, .. } => at,
                MarchError::Refining { at, .. } => at,
                MarchError::Start { start, .. } => start,
                other => panic!("{name}: unexpected error {other:?}"),
            };
            assert!(at.is_finite());
        }
    }
}

#[test]
fn cone_apex_ends_with_a_mesh_or_an_error() {
    let mut cone = NativeSurface(|p: DVec3| {
        vg(
            p.x * p.x + p.y * p.y - p.z * p.z,
            DVec3::new(2.0 * p.x, 2.0 * p.y, -2.0 * p.z),
        )
    });
    let mut input = MarchInput::from_point(0.1, DVec3::new(1.0, 0.0, 1.0));
    input.bbox = Some((DVec3::splat(-1.5), DVec3::splat(1.5)));
    input.max_triangles = Some(200_000);
    ends_cleanly("cone", &mut cone, &input);
    // Without a box the cone is unbounded: the triangle guard stops it.
    input.bbox = None;
    input.max_triangles = Some(20_000);
    ends_cleanly("cone without box", &mut cone, &input);
}

#[test]
fn cusp_ends_with_a_mesh_or_an_error() {
    // y² − x³: a cuspidal edge along the z axis, where ∇f vanishes.
    let mut cusp = NativeSurface(|p: DVec3| {
        vg(
            p.y * p.y - p.x.powi(3),
            DVec3::new(-3.0 * p.x * p.x, 2.0 * p.y, 0.0),
        )
    });
    let mut input = MarchInput::from_point(0.1, DVec3::new(1.0, 1.0, 0.0));
    input.bbox = Some((DVec3::splat(-1.5), DVec3::splat(1.5)));
    input.max_triangles = Some(200_000);
    ends_cleanly("cusp", &mut cusp, &input);
}

#[test]
fn failures_say_why_and_where() {
    let mut s = sphere(2.0);
    let st = MarchSettings::default();
    // A start at the centre: the gradient vanishes.
    let e = march(s.as_mut(), &MarchInput::from_point(0.3, DVec3::ZERO), &st);
    assert!(matches!(e, Err(MarchError::Start { .. })), "{e:?}");
    // A surface with no zero: surfacepoint does not converge.
    let mut none = NativeSurface(|p: DVec3| vg(p.length_squared() + 1.0, 2.0 * p));
    let e = march(&mut none, &MarchInput::from_point(0.3, DVec3::ONE), &st);
    assert!(matches!(e, Err(MarchError::Start { .. })), "{e:?}");
    // Surfaces where f touches zero without changing sign (a double root): refused at the
    // start, where the sphere of radius √2 they vanish on is, at once and not after the
    // triangle limit (the gradient vanishes there, and with it the local step).
    let start = DVec3::new(1.5, 0.0, 0.0);
    let mut square = NativeSurface(|p: DVec3| {
        let g = p.length_squared() - 2.0;
        vg(g * g, 4.0 * g * p)
    });
    let mut absolute = NativeSurface(|p: DVec3| {
        let g = p.length_squared() - 2.0;
        vg(g.abs(), 2.0 * g.signum() * p)
    });
    for surface in [&mut square as &mut dyn Surface, &mut absolute] {
        match march(surface, &MarchInput::from_point(0.3, start), &st) {
            Err(MarchError::NoSignChange { at }) => {
                assert!((at.length() - 2f64.sqrt()).abs() < 1e-6, "{at}")
            }
            other => panic!("{other:?}"),
        }
    }
    // The triangle guard.
    let mut input = MarchInput::from_point(0.3, DVec3::ONE);
    input.max_triangles = Some(100);
    let e = march(s.as_mut(), &input, &st);
    match e {
        Err(MarchError::TooManyTriangles { limit: 100, at }) => {
            assert!((at.length() - 2.0).abs() < 1e-9, "{at}")
        }
        other => panic!("{other:?}"),
    }
    // Bad steps and boxes, and a start outside the box.
    for step in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = march(s.as_mut(), &MarchInput::from_point(step, DVec3::ONE), &st);
        assert!(matches!(e, Err(MarchError::InvalidStep { .. })), "{e:?}");
    }
    let mut input = MarchInput::from_point(0.3, DVec3::ONE);
    input.bbox = Some((DVec3::ONE, DVec3::ZERO));
    assert!(matches!(
        march(s.as_mut(), &input, &st),
        Err(MarchError::InvalidBox { .. })
    ));
    input.bbox = Some((DVec3::splat(-1.0), DVec3::splat(1.0)));
    assert!(matches!(
        march(s.as_mut(), &input, &st),
        Err(MarchError::StartOutsideBox { .. })
    ));
    let _ = Start::Point(DVec3::ZERO);
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        // A fixed seed: the same cases on every run (and no regression files written).
        #![proptest_config(ProptestConfig {
            cases: 24,
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5eed_4a27),
            failure_persistence: None,
            ..ProptestConfig::default()
        })]

        /// Ellipsoids of random axes, meshed from random start directions at steps of a tenth
        /// to a twentieth of the smallest axis: always watertight with Euler 2.
        #[test]
        fn ellipsoids_are_watertight(
            a in 0.5f64..2.0, b in 0.5f64..2.0, c in 0.5f64..2.0,
            dir in (-1.0f64..1.0, -1.0f64..1.0, 0.1f64..1.0),
            div in 10.0f64..20.0,
        ) {
            let axes = DVec3::new(a, b, c);
            let inv2 = 1.0 / (axes * axes);
            let mut s: Boxed = Box::new(NativeSurface(move |p: DVec3| {
                vg((p * p * inv2).element_sum() - 1.0, 2.0 * p * inv2)
            }));
            let step = a.min(b).min(c) / div;
            let start = DVec3::new(dir.0, dir.1, dir.2) * axes;
            mesh_and_check(
                &format!("ellipsoid {axes} δ={step:.3}"),
                &mut s,
                &MarchInput::from_point(step, start),
                closed_at_30(2),
            );
        }

        /// Tori of random radii, rotations and steps (split and union happen on every one):
        /// always watertight with Euler 0 and no triangle below 30° (the marcher alone
        /// reaches 14.1° here; the quality stage lifts it past 30°, docs/marcher.md).
        #[test]
        fn tori_are_watertight(
            r in 1.0f64..2.0, ratio in 0.2f64..0.5,
            rx in -3.0f64..3.0, ry in -3.0f64..3.0,
            div in 3.0f64..8.0,
        ) {
            let a = r * ratio;
            let rot = DMat3::from_rotation_y(ry) * DMat3::from_rotation_x(rx);
            let mut s = transformed(torus(r, a), rot, 1.0);
            let start = rot * DVec3::new(r, 0.0, a * 0.9);
            mesh_and_check(
                &format!("torus r={r:.2} a={a:.2} δ={:.3}", a / div),
                &mut s,
                &MarchInput::from_point(a / div, start),
                closed_at_30(0),
            );
        }
    }
}
