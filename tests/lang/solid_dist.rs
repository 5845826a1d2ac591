//! The distance to solids with edges and corners (`dist` of a surface with creases,
//! `surface::SolidDist` over `solve::solid`), through the public API as `surfc eval` builds it:
//! values against exact distances computed here from the solids' geometry (never by surfc),
//! inside and outside, at random points (a property test); gradients against central
//! differences of the value and against the unit vector from the nearest point; the corner
//! of a rounded box exactly.

use glam::DVec3;
use proptest::prelude::*;

/// A box [lo, hi] (the language's `box`).
#[derive(Clone, Copy, Debug)]
struct Cuboid {
    lo: DVec3,
    hi: DVec3,
}

impl Cuboid {
    /// Signed distance to the box: exact inside and out.
    fn sdf(self, p: DVec3) -> f64 {
        let c = (self.lo + self.hi) * 0.5;
        let h = (self.hi - self.lo) * 0.5;
        let q = (p - c).abs() - h;
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    }

    /// The six outer half-spaces {x_k ≤ lo_k}, {x_k ≥ hi_k} as (axis, bound, upper): the
    /// outside of the box is their union.
    fn outsides(self) -> [(usize, f64, bool); 6] {
        let mut out = [(0, 0.0, false); 6];
        for k in 0..3 {
            out[2 * k] = (k, self.lo[k], false);
            out[2 * k + 1] = (k, self.hi[k], true);
        }
        out
    }
}

/// The distance from p to {x_a ≥ b (upper) or ≤ b} ∩ {x_c ≥ d or ≤ d}: a quadrant, a half-space
/// or a slab of axis-aligned half-spaces; None when empty.
fn to_two_halfspaces(
    p: DVec3,
    (a, b, ua): (usize, f64, bool),
    (c, d, uc): (usize, f64, bool),
) -> Option<f64> {
    let short = |k: usize, bound: f64, upper: bool| {
        if upper {
            (bound - p[k]).max(0.0)
        } else {
            (p[k] - bound).max(0.0)
        }
    };
    if a == c {
        if ua == uc {
            return Some(short(a, b, ua).max(short(c, d, uc)));
        }
        // {x ≥ lo'} ∩ {x ≤ hi'}: a slab, empty when lo' > hi'.
        let (lo, hi) = if ua { (b, d) } else { (d, b) };
        return (lo <= hi).then(|| (lo - p[a]).max(p[a] - hi).max(0.0));
    }
    Some(short(a, b, ua).hypot(short(c, d, uc)))
}

/// The signed distance to the union of two boxes: outside, the nearer box; inside, the
/// nearest point of the outside of both, which is the union of the quadrants (or slabs) where
/// one half-space of each box's outside meet.
fn union_of_boxes(a: Cuboid, b: Cuboid, p: DVec3) -> f64 {
    let (da, db) = (a.sdf(p), b.sdf(p));
    if da > 0.0 && db > 0.0 {
        return da.min(db);
    }
    let mut best = f64::INFINITY;
    for ha in a.outsides() {
        for hb in b.outsides() {
            if let Some(d) = to_two_halfspaces(p, ha, hb) {
                best = best.min(d);
            }
        }
    }
    -best
}

/// The signed distance to the union of two balls (centre, radius): outside, the nearer ball;
/// inside, the nearest of the radial projections onto each sphere that lie outside the other
/// ball and of the nearest point of the circle where the spheres meet.
fn union_of_balls((ca, ra): (DVec3, f64), (cb, rb): (DVec3, f64), p: DVec3) -> f64 {
    let (da, db) = ((p - ca).length() - ra, (p - cb).length() - rb);
    if da > 0.0 && db > 0.0 {
        return da.min(db);
    }
    let mut best = f64::INFINITY;
    for ((c, r), (oc, or)) in [((ca, ra), (cb, rb)), ((cb, rb), (ca, ra))] {
        let q = c + r * (p - c).normalize();
        if (q - oc).length() >= or {
            best = best.min((p - q).length());
        }
    }
    // The circle: its plane at distance t from ca along the axis, radius ρ.
    let l = (cb - ca).length();
    let axis = (cb - ca) / l;
    let t = (l * l + ra * ra - rb * rb) / (2.0 * l);
    let rho = (ra * ra - t * t).sqrt();
    let centre = ca + t * axis;
    let off = p - centre;
    let radial = off - off.dot(axis) * axis;
    let q = centre + rho * radial.normalize();
    best = best.min((p - q).length());
    -best
}

/// The plate [−1, 1]² × [−0.2, 0.2] without the cylinder of radius 0.4 around z (taller than
/// the plate): the solid is the product of the square-with-a-hole and the interval, so
/// outside its distance is the hypotenuse of the two; inside, the nearer of the box's faces
/// and the hole's side.
fn plate_with_hole(p: DVec3) -> f64 {
    let plate = Cuboid {
        lo: DVec3::new(-1.0, -1.0, -0.2),
        hi: DVec3::new(1.0, 1.0, 0.2),
    };
    let r = 0.4;
    let rho = p.x.hypot(p.y);
    let inside = plate.sdf(p) < 0.0 && rho > r;
    if inside {
        return -(-plate.sdf(p)).min(rho - r);
    }
    let dz = (-0.2 - p.z).max(p.z - 0.2).max(0.0);
    let square = p.x.abs().max(p.y.abs());
    let d2 = if rho < r {
        r - rho
    } else if square > 1.0 {
        (p.x.abs() - 1.0).max(0.0).hypot((p.y.abs() - 1.0).max(0.0))
    } else {
        0.0
    };
    d2.hypot(dz)
}

/// One solid of the property test: its source, the exact signed distance, and the box the
/// points are drawn from.
struct Solid {
    name: &'static str,
    source: &'static str,
    exact: fn(DVec3) -> f64,
    lo: DVec3,
    hi: DVec3,
}

fn rounded_box_exact(p: DVec3) -> f64 {
    Cuboid {
        lo: DVec3::splat(-0.5),
        hi: DVec3::splat(0.5),
    }
    .sdf(p)
}

fn balls_exact(p: DVec3) -> f64 {
    union_of_balls((DVec3::ZERO, 1.0), (DVec3::new(1.2, 0.3, 0.0), 0.7), p)
}

fn ell_exact(p: DVec3) -> f64 {
    union_of_boxes(
        Cuboid {
            lo: DVec3::ZERO,
            hi: DVec3::new(2.0, 1.0, 0.3),
        },
        Cuboid {
            lo: DVec3::ZERO,
            hi: DVec3::new(0.3, 1.0, 1.5),
        },
        p,
    )
}

/// The box [−0.5, 0.5] × [−0.3, 0.3] × [−0.2, 0.2] turned by 0.5 about (1, 1, 0) and moved
/// by (0.1, 0, −0.2): the distance of the point turned and moved back.
fn turned_box_exact(p: DVec3) -> f64 {
    let turn = glam::DQuat::from_axis_angle(DVec3::new(1.0, 1.0, 0.0).normalize(), 0.5);
    let q = turn.inverse() * (p - DVec3::new(0.1, 0.0, -0.2));
    Cuboid {
        lo: DVec3::new(-0.5, -0.3, -0.2),
        hi: DVec3::new(0.5, 0.3, 0.2),
    }
    .sdf(q)
}

const SOLIDS: [Solid; 5] = [
    Solid {
        name: "box",
        source: "surface s = box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5));\nsurface d = dist(s);\n",
        exact: rounded_box_exact,
        lo: DVec3::splat(-1.2),
        hi: DVec3::splat(1.2),
    },
    Solid {
        name: "two spheres",
        source: "surface s = union(sphere(1), translate(sphere(0.7), (1.2, 0.3, 0)));\nsurface d = dist(s);\n",
        exact: balls_exact,
        lo: DVec3::new(-1.5, -1.5, -1.5),
        hi: DVec3::new(2.5, 1.5, 1.5),
    },
    Solid {
        name: "L of two boxes",
        source: "surface s = union(box((0, 0, 0), (2, 1, 0.3)), box((0, 0, 0), (0.3, 1, 1.5)));\nsurface d = dist(s);\n",
        exact: ell_exact,
        lo: DVec3::new(-0.6, -0.6, -0.6),
        hi: DVec3::new(2.6, 1.6, 2.1),
    },
    Solid {
        name: "plate with a hole",
        source: "surface s = difference(box((-1, -1, -0.2), (1, 1, 0.2)), cylinder(0.4, 1));\nsurface d = dist(s);\n",
        exact: plate_with_hole,
        lo: DVec3::new(-1.5, -1.5, -0.8),
        hi: DVec3::new(1.5, 1.5, 0.8),
    },
    Solid {
        name: "turned box",
        source: "surface s = translate(rotate(box((-0.5, -0.3, -0.2), (0.5, 0.3, 0.2)), axis: (1, 1, 0), angle: 0.5), (0.1, 0, -0.2));\nsurface d = dist(s);\n",
        exact: turned_box_exact,
        lo: DVec3::splat(-1.0),
        hi: DVec3::splat(1.0),
    },
];

fn compile(source: &str) -> surfc::Function {
    surfc::check(source)
        .expect("the source checks")
        .compile("d")
        .expect("dist compiles")
}

/// Central differences of `f` at p with step h.
fn differences(f: &mut dyn FnMut(DVec3) -> f64, p: DVec3, h: f64) -> DVec3 {
    let mut g = DVec3::ZERO;
    for k in 0..3 {
        let mut e = DVec3::ZERO;
        e[k] = h;
        g[k] = (f(p + e) - f(p - e)) / (2.0 * h);
    }
    g
}

/// Where the exact distance is smooth around p at the scale of the difference step: its
/// central differences are a unit vector (not on the medial surface, not at a sharp edge of
/// the solid itself, where the distance has a kink).
fn smooth_at(exact: fn(DVec3) -> f64, p: DVec3) -> Option<DVec3> {
    let mut f = |q: DVec3| exact(q);
    let a = differences(&mut f, p, 1e-6);
    let b = differences(&mut f, p, 1e-5);
    ((a.length() - 1.0).abs() < 1e-6 && (a - b).length() < 1e-6 && exact(p).abs() > 1e-4)
        .then_some(a)
}

/// Checks one point of a solid: the value against the exact distance, and where the exact
/// distance is smooth, the gradient against its differences and against those of surfc's
/// value (true then).
fn check_point(solid: &Solid, d: &mut surfc::Function, p: DVec3) -> Result<bool, TestCaseError> {
    let (value, gradient) = d.value_gradient(p.to_array());
    let truth = (solid.exact)(p);
    prop_assert!(
        (value - truth).abs() <= 1e-10,
        "{} at {p}: dist {value} against the exact {truth}",
        solid.name
    );
    if let Some(g) = smooth_at(solid.exact, p) {
        let gradient = DVec3::from_array(gradient);
        prop_assert!(
            (gradient - g).length() <= 1e-6,
            "{} at {p}: gradient {gradient} against the exact distance's {g}",
            solid.name
        );
        let mut f = |q: DVec3| d.value(q.to_array());
        let own = differences(&mut f, p, 1e-6);
        prop_assert!(
            (gradient - own).length() <= 1e-5,
            "{} at {p}: gradient {gradient} against central differences {own}",
            solid.name
        );
        return Ok(true);
    }
    Ok(false)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: crate::common::env_number("SURFC_DIST_CASES").unwrap_or(24),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Values at random points inside and outside each solid agree with the exact distance
    /// to 1e-10; gradients with the exact distance's and with central differences. Each case
    /// compiles its solid afresh (a cold `dist`, which the Cranelift of the test build compiles
    /// in about a tenth of a second): `SURFC_DIST_CASES=N` runs N cases (default 24; `.ci/run`
    /// runs 64).
    #[test]
    fn dist_of_solids_is_exact_inside_and_outside(
        which in 0usize..5,
        u in prop::array::uniform3(0.0f64..1.0),
    ) {
        let solid = &SOLIDS[which];
        let mut d = compile(solid.source);
        let p = solid.lo + (solid.hi - solid.lo) * DVec3::from_array(u);
        check_point(solid, &mut d, p)?;
    }
}

/// The same at a fixed 1500 points per solid, on one `dist` (its warm starts along the
/// sequence): how a mesh asks. Points are drawn uniformly in the box and, half of them, near
/// the surface (within 0.05), where the edges and corners are.
#[test]
fn dist_of_solids_is_exact_along_a_sequence() {
    let mut rng = crate::common::rng::Rng::new(42);
    for solid in &SOLIDS {
        let mut d = compile(solid.source);
        let (mut inside, mut outside, mut gradients) = (0, 0, 0);
        for i in 0..1500 {
            let mut p = rng.point(solid.lo, solid.hi);
            if i % 2 == 1 {
                // Onto the surface along the exact gradient, then off it a little.
                for _ in 0..3 {
                    let mut f = |q: DVec3| (solid.exact)(q);
                    let g = differences(&mut f, p, 1e-7);
                    p -= (solid.exact)(p) * g / g.length_squared().max(1e-12);
                }
                p += rng.direction() * rng.range(0.0, 0.05);
            }
            if (solid.exact)(p) < 0.0 {
                inside += 1;
            } else {
                outside += 1;
            }
            match check_point(solid, &mut d, p) {
                Ok(checked) => gradients += usize::from(checked),
                Err(e) => panic!("{e}"),
            }
        }
        println!(
            "{}: {inside} inside, {outside} outside, {gradients} gradients",
            solid.name
        );
        assert!(
            inside > 200 && outside > 200 && gradients > 1000,
            "{}: {inside} inside, {outside} outside, {gradients} gradients checked",
            solid.name
        );
    }
}

/// `offset` of a box rounds it: beyond a corner the value is the distance to the corner minus
/// the offset, and the gradient the unit vector from the corner (what `surfc eval` prints).
#[test]
fn the_offset_of_a_box_beyond_its_corner_is_the_distance_to_the_corner() {
    let mut r = surfc::check(
        "surface b = box((-0.5, -0.5, -0.5), (0.5, 0.5, 0.5));\nsurface r = offset(b, 0.2);\n",
    )
    .expect("checks")
    .compile("r")
    .expect("compiles");
    let p = DVec3::splat(0.65);
    let (value, gradient) = r.value_gradient(p.to_array());
    let corner = DVec3::splat(0.5);
    assert!(
        ((p - corner).length() - 0.2 - value).abs() <= 1e-15,
        "{value}"
    );
    let unit = (p - corner).normalize();
    assert!(
        (DVec3::from_array(gradient) - unit).length() <= 1e-15,
        "{gradient:?}"
    );
}
