//! Curves (`solve::curve`): intersection curves traced and sampled (closed, clipped by a box,
//! and the typed failures), circles, patch boundaries, reversal — vertex positions on the
//! surfaces, spacing, counts, orientation and determinism.

use glam::DVec3;
use surfc::solve::curve::{
    CurveError, Polygon, boundary, circle, intersection, intersection_with, project_onto, reverse,
};
use surfc::solve::tolerance::{CurveTolerance, SurfacePointTolerance};
use surfc::surface::{NativeSurface, Patch, PatchJet, Surface, ValueGrad};

fn sphere(center: DVec3, radius: f64) -> NativeSurface<impl FnMut(DVec3) -> ValueGrad> {
    NativeSurface(move |p: DVec3| ValueGrad {
        value: (p - center).length_squared() - radius * radius,
        gradient: 2.0 * (p - center),
    })
}

fn plane_z(height: f64) -> NativeSurface<impl FnMut(DVec3) -> ValueGrad> {
    NativeSurface(move |p: DVec3| ValueGrad {
        value: p.z - height,
        gradient: DVec3::Z,
    })
}

/// max |f|/|∇f| over the vertices: the first-order distance to the surface.
fn max_off(surface: &mut dyn Surface, polygon: &Polygon) -> f64 {
    polygon
        .points
        .iter()
        .map(|&p| {
            let vg = surface.value_gradient(p);
            vg.value.abs() / vg.gradient.length()
        })
        .fold(0.0, f64::max)
}

/// Lengths of the polygon's edges (including the closing one for closed polygons).
fn spacings(polygon: &Polygon) -> Vec<f64> {
    let n = polygon.points.len();
    let edges = if polygon.closed { n } else { n - 1 };
    (0..edges)
        .map(|i| (polygon.points[(i + 1) % n] - polygon.points[i]).length())
        .collect()
}

fn assert_spacing(polygon: &Polygon, step: f64, low: f64) {
    for (i, s) in spacings(polygon).into_iter().enumerate() {
        assert!(
            s <= step * (1.0 + 1e-9) && s >= low * step,
            "edge {i}: length {s} for step {step}"
        );
    }
}

#[test]
fn sphere_and_plane_meet_in_a_circle() {
    let step = 0.1;
    let (mut s, mut p) = (sphere(DVec3::ZERO, 2.0), plane_z(1.0));
    let c = intersection(&mut s, &mut p, DVec3::new(1.0, 0.0, 1.0), step, None).unwrap();
    assert!(c.closed);
    let expected = (std::f64::consts::TAU * 3f64.sqrt() / step).ceil() as usize;
    assert_eq!(c.points.len(), expected);
    let off = max_off(&mut s, &c).max(max_off(&mut p, &c));
    assert!(off <= 1e-10);
    eprintln!(
        "sphere ∩ plane: {} vertices, max |f|/|∇f| {off:e}",
        c.points.len()
    );
    for q in &c.points {
        assert!((q.truncate().length() - 3f64.sqrt()).abs() <= 1e-10);
    }
    // Equal arcs of 2π√3/n: chords within 0.1 % of each other and at most δ.
    let chord = 2.0 * 3f64.sqrt() * (std::f64::consts::PI / expected as f64).sin();
    for s in spacings(&c) {
        assert!((s - chord).abs() <= 1e-3 * chord, "{s} vs {chord}");
    }
    assert_spacing(&c, step, 0.97);
    // Starts at the curve point nearest `near`, walks along ∇f1 × ∇f2 = (0, −2√3, 0) there.
    assert!((c.points[0] - DVec3::new(3f64.sqrt(), 0.0, 1.0)).length() <= 1e-10);
    assert!(c.points[1].y < 0.0);
    // Deterministic to the bit.
    let again = intersection(&mut s, &mut p, DVec3::new(1.0, 0.0, 1.0), step, None).unwrap();
    assert_eq!(c, again);
}

#[test]
fn a_loop_shorter_than_the_step_is_a_triangle() {
    // The sphere of radius 2 and the plane z = 2 − 1e-4 meet in a circle of radius ≈ 0.02,
    // circumference 0.126, far below the step 0.3.
    let (mut s, mut p) = (sphere(DVec3::ZERO, 2.0), plane_z(2.0 - 1e-4));
    let c = intersection(&mut s, &mut p, DVec3::new(0.1, 0.0, 2.0), 0.3, None).unwrap();
    assert!(c.closed);
    assert_eq!(c.points.len(), 3);
    assert!(max_off(&mut s, &c).max(max_off(&mut p, &c)) <= 1e-10);
    let radius = (4.0 - (2.0f64 - 1e-4).powi(2)).sqrt();
    let side = radius * 3f64.sqrt();
    for l in spacings(&c) {
        assert!((l - side).abs() <= 1e-3 * side, "{l} vs {side}");
    }
}

#[test]
fn superellipsoid_and_cylinder_of_section_3_9() {
    let step = 0.1;
    let mut quartic = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x.powi(4) + p.y.powi(4) + p.z.powi(4) - 16.0,
        gradient: 4.0 * DVec3::new(p.x.powi(3), p.y.powi(3), p.z.powi(3)),
    });
    let mut cylinder = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x * p.x + (p.z - 1.1).powi(2) - 1.0,
        gradient: DVec3::new(2.0 * p.x, 0.0, 2.0 * (p.z - 1.1)),
    });
    // Below the axis of the cylinder the curve runs at y ≈ ±2.
    let c = intersection(
        &mut quartic,
        &mut cylinder,
        DVec3::new(0.0, 2.0, 0.1),
        step,
        None,
    )
    .unwrap();
    assert!(c.closed);
    let off = max_off(&mut quartic, &c).max(max_off(&mut cylinder, &c));
    assert!(off <= 1e-10);
    let sp = spacings(&c);
    eprintln!(
        "Sect. 3.9 curve: {} vertices, max |f|/|∇f| {off:e}, spacing {:.5}..{:.5}",
        c.points.len(),
        sp.iter().copied().fold(f64::INFINITY, f64::min),
        sp.iter().copied().fold(0.0, f64::max)
    );
    assert_spacing(&c, step, 0.9);
    // One loop through both y > 0 and y < 0 (the branches meet where y = 0, near the top).
    assert!(c.points.iter().any(|p| p.y > 1.5) && c.points.iter().any(|p| p.y < -1.5));
    let length: f64 = spacings(&c).iter().sum();
    assert_eq!(c.points.len(), (length / step).ceil() as usize);
}

#[test]
fn a_line_clipped_by_the_box_is_an_open_polyline() {
    // The cylinder x² + z² = 1 and the plane x = 0.5 meet in two lines parallel to y.
    let step = 0.25;
    let mut cylinder = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x * p.x + p.z * p.z - 1.0,
        gradient: DVec3::new(2.0 * p.x, 0.0, 2.0 * p.z),
    });
    let mut plane = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x - 0.5,
        gradient: DVec3::X,
    });
    let bbox = (DVec3::splat(-2.0), DVec3::new(2.0, 1.5, 2.0));
    let c = intersection(
        &mut cylinder,
        &mut plane,
        DVec3::new(0.5, 0.3, 0.9),
        step,
        Some(bbox),
    )
    .unwrap();
    assert!(!c.closed);
    assert!(max_off(&mut cylinder, &c) <= 1e-10 && max_off(&mut plane, &c) <= 1e-10);
    // The ends lie on the two faces y = −2 and y = 1.5 (which comes first depends on the
    // direction of ∇f1 × ∇f2 along the line).
    let (first, last) = (c.points[0], *c.points.last().unwrap());
    let ends = [first.y, last.y];
    assert!(ends.contains(&-2.0) && ends.contains(&1.5), "{ends:?}");
    assert_eq!(c.points.len(), (3.5f64 / step).ceil() as usize + 1);
    assert_spacing(&c, step, 0.999);
}

#[test]
fn surfaces_that_do_not_meet_are_a_typed_error() {
    let (mut a, mut b) = (
        sphere(DVec3::ZERO, 1.0),
        sphere(DVec3::new(5.0, 0.0, 0.0), 1.0),
    );
    match intersection(&mut a, &mut b, DVec3::new(2.5, 0.1, 0.0), 0.1, None) {
        Err(CurveError::NoMeeting { residual, best, .. }) => {
            assert!(residual > 0.5, "best {best}, residual {residual}");
        }
        other => panic!("expected NoMeeting, got {other:?}"),
    }
    let (mut s, mut p) = (sphere(DVec3::ZERO, 2.0), plane_z(5.0));
    assert!(matches!(
        intersection(&mut s, &mut p, DVec3::new(0.0, 0.0, 4.0), 0.1, None),
        Err(CurveError::NoMeeting { .. })
    ));
}

#[test]
fn an_unbounded_curve_without_a_box_exceeds_the_length_budget() {
    // The planes x = 0 and y = 0 meet in the z axis, which never closes.
    let mut a = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x,
        gradient: DVec3::X,
    });
    let mut b = NativeSurface(|p: DVec3| ValueGrad {
        value: p.y,
        gradient: DVec3::Y,
    });
    let tol = CurveTolerance {
        max_length: 100.0,
        ..CurveTolerance::default()
    };
    match intersection_with(&mut a, &mut b, DVec3::new(0.1, 0.1, 0.0), 0.1, None, &tol) {
        Err(CurveError::NoClosure { length, last, .. }) => {
            assert!(length >= 10.0 && (last.z.abs() - length).abs() <= 1e-6);
        }
        other => panic!("expected NoClosure, got {other:?}"),
    }
}

#[test]
fn touching_spheres_have_no_tangent() {
    let (mut a, mut b) = (
        sphere(DVec3::ZERO, 1.0),
        sphere(DVec3::new(2.0, 0.0, 0.0), 1.0),
    );
    match intersection(&mut a, &mut b, DVec3::new(1.0, 0.3, 0.1), 0.1, None) {
        Err(CurveError::TangentVanishes { at, sine }) => {
            assert!((at - DVec3::X).length() <= 1e-3, "at {at}");
            assert!(sine < 1e-6);
        }
        other => panic!("expected TangentVanishes, got {other:?}"),
    }
}

#[test]
fn nan_surfaces_are_errors_not_panics() {
    let mut nan = NativeSurface(|_: DVec3| ValueGrad {
        value: f64::NAN,
        gradient: DVec3::NAN,
    });
    let mut p = plane_z(0.0);
    assert!(matches!(
        intersection(&mut nan, &mut p, DVec3::ZERO, 0.1, None),
        Err(CurveError::NotFinite { .. })
    ));
    let c = circle(DVec3::ZERO, DVec3::Z, 1.0, 0.1).unwrap();
    assert!(matches!(
        project_onto(&mut nan, &c, 0.1, &SurfacePointTolerance::default()),
        Err(CurveError::Projection { index: 0, .. })
    ));
    for step in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            intersection(&mut p, &mut nan, DVec3::ZERO, step, None),
            Err(CurveError::InvalidStep { .. })
        ));
    }
}

#[test]
fn circles_have_exact_counts_radii_and_orientation() {
    let (center, normal, radius, step) = (DVec3::new(1.6, 0.0, 0.0), DVec3::X, 1.2, 0.1);
    let c = circle(center, normal, radius, step).unwrap();
    assert!(c.closed);
    let n = (std::f64::consts::TAU * radius / step).ceil() as usize;
    assert_eq!(c.points.len(), n);
    for (i, p) in c.points.iter().enumerate() {
        assert!(
            ((*p - center).length() - radius).abs() <= 1e-14,
            "vertex {i}"
        );
        assert!(
            (*p - center).dot(normal).abs() <= 1e-14,
            "vertex {i} off the plane"
        );
    }
    let chord = 2.0 * radius * (std::f64::consts::PI / n as f64).sin();
    for s in spacings(&c) {
        assert!((s - chord).abs() <= 1e-12);
    }
    // Counter-clockwise around the normal.
    for i in 0..n {
        let (a, b) = (c.points[i] - center, c.points[(i + 1) % n] - center);
        assert!(a.cross(b).dot(normal) > 0.0);
    }
    // The documented first vertex: center + r·t1, t1 = (n_y, −n_x, 0)/|…| for n = (1, 0, 0).
    assert!((c.points[0] - (center + radius * DVec3::new(0.0, -1.0, 0.0))).length() <= 1e-15);
    // A tiny radius still gives a polygon (three vertices), bad input an error.
    assert_eq!(circle(center, normal, 1e-3, step).unwrap().points.len(), 3);
    assert!(matches!(
        circle(center, DVec3::ZERO, radius, step),
        Err(CurveError::InvalidCircle { .. })
    ));
    assert!(matches!(
        circle(center, normal, -1.0, step),
        Err(CurveError::InvalidCircle { .. })
    ));
}

#[test]
fn circles_project_onto_the_surface_that_uses_them() {
    // The circle x = 1.6, radius 1.2 lies on the sphere of radius 2; one of radius 1.3 does
    // not, and its projection does.
    let mut s = sphere(DVec3::ZERO, 2.0);
    let tol = SurfacePointTolerance::default();
    let on = circle(DVec3::new(1.6, 0.0, 0.0), DVec3::X, 1.2, 0.1).unwrap();
    let projected = project_onto(&mut s, &on, 0.1, &tol).unwrap();
    for (a, b) in on.points.iter().zip(&projected.points) {
        assert!((*a - *b).length() <= 1e-14);
    }
    let off = circle(DVec3::new(1.6, 0.0, 0.0), DVec3::X, 1.3, 0.1).unwrap();
    let projected = project_onto(&mut s, &off, 0.1, &tol).unwrap();
    assert_eq!(projected.points.len(), off.points.len());
    assert!(max_off(&mut s, &projected) <= 1e-12);
}

struct Roof;

impl Patch for Roof {
    fn point_jacobian(&mut self, u: f64, v: f64) -> PatchJet {
        PatchJet {
            point: DVec3::new(
                10.0 * v - 5.0,
                10.0 * u - 5.0,
                6.0 * (u - u * u + v - v * v),
            ),
            du: DVec3::new(0.0, 10.0, 6.0 * (1.0 - 2.0 * u)),
            dv: DVec3::new(10.0, 0.0, 6.0 * (1.0 - 2.0 * v)),
        }
    }
    fn domain(&self) -> ((f64, f64), (f64, f64)) {
        ((0.0, 1.0), (0.0, 0.8))
    }
}

#[test]
fn roof_boundary_is_closed_with_its_corners() {
    let step = 0.3;
    let c = boundary(&mut Roof, step).unwrap();
    assert!(c.closed);
    let corners = [(0.0, 0.0), (1.0, 0.0), (1.0, 0.8), (0.0, 0.8)]
        .map(|(u, v)| Roof.point_jacobian(u, v).point);
    // The corners are vertices, in counter-clockwise (u, v) order, the first one first.
    assert_eq!(c.points[0], corners[0]);
    let at: Vec<usize> = corners
        .iter()
        .map(|k| c.points.iter().position(|p| p == k).expect("corner kept"))
        .collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{at:?}");
    // Every vertex on the boundary of the domain's image; spacing ≈ δ, never more.
    assert_spacing(&c, step, 0.95);
    // Within each edge the spacing is uniform in arc length (chords of nearly straight
    // arcs): max/min ratio close to 1.
    for e in 0..4 {
        let (a, b) = (at[e], if e == 3 { c.points.len() } else { at[e + 1] });
        let n = c.points.len();
        let edge: Vec<f64> = (a..b)
            .map(|i| (c.points[(i + 1) % n] - c.points[i]).length())
            .collect();
        let (lo, hi) = edge.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &s| {
            (lo.min(s), hi.max(s))
        });
        assert!(hi / lo <= 1.002, "edge {e}: spacing from {lo} to {hi}");
    }
    // The same step gives the same polygon; reversing keeps the first corner first.
    assert_eq!(boundary(&mut Roof, step).unwrap(), c);
    let r = reverse(&c);
    assert_eq!(r.points[0], c.points[0]);
    assert_eq!(r.points[1], *c.points.last().unwrap());
    assert_eq!(reverse(&r), c);
}

#[test]
fn reversing_an_open_polyline_swaps_its_ends() {
    let open = Polygon {
        points: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
        closed: false,
    };
    assert_eq!(reverse(&open).points, vec![DVec3::Y, DVec3::X, DVec3::ZERO]);
}

#[test]
fn sphere_and_plane_rotated_and_scaled() {
    // The first test's circle, moved, turned and scaled: counts and accuracy scale with it.
    for (scale, center) in [
        (1e-3, DVec3::new(0.2, -0.1, 0.05)),
        (1e3, DVec3::new(5e3, 2e3, -1e3)),
    ] {
        let axis = DVec3::new(0.3, -0.5, 0.8).normalize();
        let radius = 2.0 * scale;
        let height = 1.0 * scale;
        let mut s = sphere(center, radius);
        let mut p = NativeSurface(move |q: DVec3| ValueGrad {
            value: (q - center).dot(axis) - height,
            gradient: axis,
        });
        let step = 0.1 * scale;
        let near = center + height * axis + DVec3::new(0.9, 0.4, 0.1) * scale;
        let c = intersection(&mut s, &mut p, near, step, None).unwrap();
        assert!(c.closed);
        let expected = (std::f64::consts::TAU * 3f64.sqrt() / 0.1).ceil() as usize;
        assert_eq!(c.points.len(), expected, "scale {scale}");
        let off = max_off(&mut s, &c).max(max_off(&mut p, &c));
        assert!(off <= 1e-10 * scale, "scale {scale}: {off:e}");
        assert_spacing(&c, step, 0.97);
    }
}

#[test]
fn curves_on_distance_surfaces() {
    use surfc::surface::{ImplicitDist, PatchDist};
    // offset(sphere, 0.5) = dist(sphere) − 0.5 meets z = 1 in the circle of radius √(2.5² − 1).
    let mut offset = {
        let mut d = ImplicitDist::new(Box::new(sphere(DVec3::ZERO, 2.0)));
        NativeSurface(move |p: DVec3| {
            let vg = d.value_gradient(p);
            ValueGrad {
                value: vg.value - 0.5,
                gradient: vg.gradient,
            }
        })
    };
    let mut plane = plane_z(1.0);
    let c = intersection(
        &mut offset,
        &mut plane,
        DVec3::new(2.0, 0.5, 1.0),
        0.1,
        None,
    )
    .unwrap();
    assert!(c.closed);
    let radius = (2.5f64 * 2.5 - 1.0).sqrt();
    assert_eq!(
        c.points.len(),
        (std::f64::consts::TAU * radius / 0.1).ceil() as usize
    );
    for p in &c.points {
        assert!((p.truncate().length() - radius).abs() <= 1e-10 && (p.z - 1.0).abs() <= 1e-12);
    }
    // The extended roof is the paraboloid z = 3 − 0.06(x² + y²) (its patch formula, read
    // beyond the declared domain): dist(roof) meets z = 1 in the circle x² + y² = 100/3.
    let mut roof = PatchDist::new(Box::new(Roof));
    let c = intersection(&mut roof, &mut plane, DVec3::new(5.0, 1.0, 1.0), 0.2, None).unwrap();
    assert!(c.closed);
    for p in &c.points {
        assert!(
            roof.value(*p).abs() <= 1e-10 && (p.z - 1.0).abs() <= 1e-12,
            "{p}"
        );
        assert!(
            (p.truncate().length_squared() - 100.0 / 3.0).abs() <= 1e-8,
            "{p}"
        );
    }
    assert_spacing(&c, 0.2, 0.95);
}
