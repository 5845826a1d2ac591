//! Issue 5, the marcher half: a given polygon as the first front and bounding polygons the
//! front unites with (Sects. 3.2b, 3.3, 3.8). Polygon vertices come out as mesh vertices,
//! bit-identical and in order, and the polygons are exactly the mesh's boundary loops.
//!
//! Orientation rule: walking along a polygon, seen from where ∇f points, the area to be
//! meshed lies on the left.

use crate::common;

use std::f64::consts::{PI, TAU};

use common::*;
use glam::DVec3;
use surfc::march::verify::Flaw;
use surfc::march::{
    CoarsePolygon, MarchError, MarchInput, MarchSettings, PolygonRole, Start, march, march_verified,
};
use surfc::mesh::Mesh;
use surfc::mesh::check::Expect;
use surfc::mesh::topology::topology;

fn input(step: f64, front: Vec<DVec3>, bounds: Vec<Vec<DVec3>>) -> MarchInput {
    MarchInput {
        step,
        start: Start::Front(front),
        bounds,
        bbox: None,
        max_triangles: None,
        tolerance: None,
        uniform: false,
        expected_triangles: None,
    }
}

/// The boundary loop through `poly[0]`, rotated to start there.
fn loop_through(mesh: &Mesh, first: DVec3) -> Vec<DVec3> {
    let t = topology(mesh);
    for lp in &t.boundary_loops {
        if let Some(k) = lp.iter().position(|&v| mesh.vertices[v as usize] == first) {
            let n = lp.len();
            return (0..n)
                .map(|i| mesh.vertices[lp[(k + i) % n] as usize])
                .collect();
        }
    }
    panic!("no boundary loop through {first}");
}

/// Each polygon is a boundary loop, vertex for vertex (bit-identical, same order).
fn assert_polygons_are_loops(mesh: &Mesh, polys: &[&Vec<DVec3>]) {
    for poly in polys {
        assert_eq!(&loop_through(mesh, poly[0]), *poly);
    }
}

/// A band between two loops: χ = 0, the two loops its boundary, one component.
fn band() -> Expect {
    Expect {
        euler: Some(0),
        boundary_loops: Some(2),
        components: Some(1),
        ..Expect::default()
    }
}

#[test]
fn cylinder_between_two_circles() {
    let step = 0.2;
    let n = samples(TAU, step);
    // Top circle z = 1, area below it: clockwise seen from above (∇f points outwards).
    let top = circle(DVec3::Z, -DVec3::Z, DVec3::X, 1.0, n);
    // Base circle z = −1, area above it: counter-clockwise seen from above.
    let base = circle(-DVec3::Z, DVec3::Z, DVec3::X, 1.0, n);
    let mut s = cylinder(1.0);
    let m = mesh_and_check(
        "cylinder front+bound δ=0.2",
        &mut s,
        &input(step, top.clone(), vec![base.clone()]),
        band(),
    );
    // The polygons' vertices are the first mesh vertices, in the order given.
    assert_eq!(&m.vertices[..n], &top[..]);
    assert_eq!(&m.vertices[n..2 * n], &base[..]);
    assert_polygons_are_loops(&m, &[&top, &base]);
}

/// Short bands between a front circle and a bound circle (a disc's or a flange's outer wall:
/// 2.4 and about 4 steps tall): the march stays in the band and needs no refinement. Before
/// Step 3 kept new points off the node beyond a neighbour, the paper's split of a wide
/// triangle put a point just past the bound beside its next node, and the march ran out of
/// the band until the verification refined it (docs/marcher.md, Step 3).
#[test]
fn short_bands_between_two_circles_mesh_in_one_round() {
    for (r, h, step) in [
        (0.3, 0.12, 0.05),
        (0.77, 0.12, 0.05),
        (1.35, 0.27, 0.065),
        (1.27, 0.29, 0.07),
    ] {
        let n = samples(TAU * r, step);
        let top = circle(0.5 * h * DVec3::Z, -DVec3::Z, DVec3::X, r, n);
        let base = circle(-0.5 * h * DVec3::Z, DVec3::Z, DVec3::X, r, n);
        let mut s = cylinder(r);
        let name = format!("band r = {r}, h = {h} at step {step}");
        let marched = march_verified(
            s.as_mut(),
            None,
            &input(step, top.clone(), vec![base.clone()]),
            &MarchSettings::default(),
            None,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(marched.refinements, 0, "{name}: refined");
        let m = mesh_and_check(
            &name,
            &mut s,
            &input(step, top.clone(), vec![base.clone()]),
            Expect {
                min_angle_deg: 30.0,
                ..band()
            },
        );
        assert_polygons_are_loops(&m, &[&top, &base]);
        let (lo, hi) = m
            .vertices
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            });
        assert!(
            lo.z >= -0.5 * h && hi.z <= 0.5 * h,
            "{name}: leaves the band"
        );
    }
}

#[test]
fn sphere_with_six_holes() {
    let (r, a) = (2.0f64, 1.6f64);
    let step = a * PI / 30.0;
    let rc = (r * r - a * a).sqrt();
    // δ = aπ/30 reads as the angle step π/30 of the circles: 60 vertices each (spacing
    // 0.75 δ on circles of radius 1.2). Sampled at δ instead (45 vertices) the mesh has
    // 1792 triangles, which matches the area (20.1 / (0.433 δ²) ≈ 1650 equilateral ones).
    let n = 60;
    // Circle on the plane x_k = ±a; the sphere body lies towards the centre, i.e. on the
    // left when walking clockwise seen from outside (∇f points outwards).
    let mut polys = Vec::new();
    for axis in [
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Y,
        DVec3::Z,
        -DVec3::Z,
    ] {
        let u = if axis.x.abs() > 0.5 {
            DVec3::Y
        } else {
            DVec3::X
        };
        polys.push(circle(a * axis, -axis, u, rc, n));
    }
    let mut s = sphere(r);
    let inp = MarchInput {
        uniform: true,
        ..input(step, polys[0].clone(), polys[1..].to_vec())
    };
    let m = mesh_and_check(
        "sphere with six holes",
        &mut s,
        &inp,
        Expect {
            euler: Some(-4),
            boundary_loops: Some(6),
            components: Some(1),
            ..Expect::default()
        },
    );
    assert_near_paper("sphere with six holes", m.triangles.len(), 2206);
    assert_polygons_are_loops(&m, &polys.iter().collect::<Vec<_>>());
}

/// The whole torus from one meridian circle: the bound is the same polygon reversed (the
/// meshed area must lie on its left too, coming around the other way); shared vertices are
/// one mesh vertex, so the mesh closes up.
#[test]
fn whole_torus_from_one_circle() {
    let (r, a, step) = (1.0, 0.35, 0.1);
    let n = samples(TAU * a, step);
    let meridian = circle(DVec3::new(r, 0.0, 0.0), DVec3::Y, DVec3::X, a, n);
    let mut reversed = meridian.clone();
    reversed.reverse();
    let mut s = torus(r, a);
    let m = mesh_and_check(
        "torus from one circle",
        &mut s,
        &input(step, meridian.clone(), vec![reversed]),
        Expect {
            closed: true,
            euler: Some(0),
            components: Some(1),
            ..Expect::default()
        },
    );
    assert_eq!(&m.vertices[..n], &meridian[..]);
}

/// The meridian circles (`n` vertices each) at angles 0 and 2 around the z axis of the torus
/// with radii `r`, `a`: the front and the bound of the part between them.
fn meridians(r: f64, a: f64, n: usize) -> (Vec<DVec3>, Vec<DVec3>) {
    let at = |phi: f64| {
        let d = DVec3::new(phi.cos(), phi.sin(), 0.0);
        (r * d, DVec3::Z.cross(d))
    };
    let (c0, t0) = at(0.0);
    let (c1, t1) = at(2.0);
    (
        circle(c0, t0, c0.normalize(), a, n),
        circle(c1, -t1, c1.normalize(), a, n),
    )
}

#[test]
fn torus_part_between_two_meridians() {
    let (r, a, step) = (1.0, 0.35, 0.1);
    let (front, bound) = meridians(r, a, samples(TAU * a, step));
    let mut s = torus(r, a);
    let m = mesh_and_check(
        "torus part",
        &mut s,
        &input(step, front.clone(), vec![bound.clone()]),
        Expect {
            euler: Some(0),
            boundary_loops: Some(2),
            components: Some(1),
            ..Expect::default()
        },
    );
    assert_polygons_are_loops(&m, &[&front, &bound]);
}

/// Torus parts between two meridian circles at a step of 0.3, on tubes from thin to thick,
/// the circles sampled from 4 vertices to about one a step: each part is meshed right (one
/// tube between the two loops) or refused as the polygons' (`CoarsePolygon`, naming the
/// front or the bound and an edge whose own chord strays from the tube or which is longer
/// than twice the local step there), never after refinement rounds that cannot change a
/// given polygon.
#[test]
fn polygons_too_coarse_for_the_surface_are_refused_as_theirs() {
    let (r, step) = (1.0, 0.3);
    let settings = MarchSettings::default();
    let (mut right, mut refused) = (0, 0);
    for a in [0.12, 0.2, 0.3, 0.45] {
        let fine = samples(TAU * a, step);
        for n in [4, 5, 6, 8, fine].into_iter().filter(|&n| n <= fine) {
            let name = format!("torus part a = {a}, {n} vertices a circle");
            let (front, bound) = meridians(r, a, n);
            let mut s = torus(r, a);
            match march(s.as_mut(), &input(step, front, vec![bound]), &settings) {
                Ok(mesh) => {
                    let (t, violations) = surfc::mesh::check::check(
                        &mesh,
                        Some(s.as_mut()),
                        &Expect {
                            euler: Some(0),
                            boundary_loops: Some(2),
                            components: Some(1),
                            min_angle_deg: 0.0,
                            ..Expect::default()
                        },
                    );
                    assert!(violations.is_empty(), "{name}: {violations:?} ({t:?})");
                    right += 1;
                }
                Err(MarchError::CoarsePolygon(c)) => {
                    let CoarsePolygon {
                        polygon,
                        at,
                        length,
                        h,
                        flaw,
                        flaw_at,
                        ..
                    } = *c;
                    assert!(
                        matches!(polygon, PolygonRole::Front | PolygonRole::Bound(0)),
                        "{name}: {polygon:?}"
                    );
                    // The edge named is one of the polygon's (2πa/n long, on the tube).
                    let side = 2.0 * a * (std::f64::consts::PI / n as f64).sin();
                    assert!((length - side).abs() < 1e-9, "{name}: {length} for {side}");
                    let own_chord = flaw_at == at && matches!(flaw, Flaw::Chord { .. });
                    assert!(
                        own_chord || length > 2.0 * settings.near_distance * h,
                        "{name}: edge {length} at a local step {h}, {flaw} at {flaw_at}"
                    );
                    refused += 1;
                }
                Err(e) => panic!("{name}: {e}"),
            }
        }
    }
    assert!(right > 0 && refused > 0, "{right} right, {refused} refused");
}

#[test]
fn badly_spaced_or_off_surface_polygons_are_errors() {
    let mut s = cylinder(1.0);
    let coarse = circle(DVec3::Z, -DVec3::Z, DVec3::X, 1.0, 8);
    let e = march(
        s.as_mut(),
        &input(0.2, coarse, vec![]),
        &MarchSettings::default(),
    );
    assert!(
        matches!(
            e,
            Err(MarchError::PolygonSpacing {
                polygon: PolygonRole::Front,
                index: 0,
                ..
            })
        ),
        "{e:?}"
    );
    let n = samples(TAU, 0.2);
    let off = circle(DVec3::Z, -DVec3::Z, DVec3::X, 1.01, n);
    let e = march(
        s.as_mut(),
        &input(
            0.2,
            circle(DVec3::Z, -DVec3::Z, DVec3::X, 1.0, n),
            vec![off],
        ),
        &MarchSettings::default(),
    );
    assert!(
        matches!(
            e,
            Err(MarchError::PolygonOffSurface {
                polygon: PolygonRole::Bound(0),
                index: 0,
                ..
            })
        ),
        "{e:?}"
    );
    let e = march(
        s.as_mut(),
        &input(0.2, vec![DVec3::X, DVec3::Y], vec![]),
        &MarchSettings::default(),
    );
    assert!(
        matches!(e, Err(MarchError::PolygonTooShort { len: 2, .. })),
        "{e:?}"
    );
}

/// A polygon with a 15° corner (a curved triangle on the cylinder: an arc of the circle
/// z = 0, a vertical side, and a helix back at 15° to the arc): the triangle at the corner
/// cannot reach 30°, and since no refinement moves a polygon vertex the mesh is right but
/// says so in a warning with the smallest angle and its place (issue 13: no triangle below
/// the bar goes unreported).
#[test]
fn a_sharp_polygon_corner_is_reported_in_a_warning() {
    let (step, arc) = (0.1, 1.0);
    let rise = arc * 15f64.to_radians().tan();
    let on_cylinder = |theta: f64, z: f64| DVec3::new(theta.cos(), theta.sin(), z);
    // Counter-clockwise in (θ, z) seen from outside, where ∇f points: the area on the left.
    let mut poly = Vec::new();
    let n = samples(arc, step);
    poly.extend((0..n).map(|i| on_cylinder(arc * i as f64 / n as f64, 0.0)));
    let up = samples(rise, step);
    poly.extend((0..up).map(|i| on_cylinder(arc, rise * i as f64 / up as f64)));
    let back = samples((arc * arc + rise * rise).sqrt(), step);
    poly.extend((0..back).map(|i| {
        let s = 1.0 - i as f64 / back as f64;
        on_cylinder(arc * s, rise * s)
    }));
    let mut s = cylinder(1.0);
    let m = surfc::march::march_verified(
        s.as_mut(),
        None,
        &input(step, poly, vec![]),
        &MarchSettings::default(),
        None,
    )
    .expect("the wedge meshes");
    let smallest = surfc::mesh::quality::quality(&m.mesh).min_angle_deg;
    // The corner's angle between its first chords, a little off 15° on the curved surface.
    assert!(smallest < 15.1, "smallest angle {smallest}°");
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    let w = &m.warnings[0];
    assert!(
        w.contains("triangle(s) with a corner on a polygon, a crease or the box stay below 30.0°"),
        "{w}"
    );
    assert!(
        w.contains(&format!("the smallest angle is {smallest:.1}° near")),
        "{w}"
    );
}
