//! Sharp edges the crease search did not see: whether the direction of ∇f jumps near a point
//! (a sharp boolean, `abs` or primitive hidden inside a function or a product, or inside a
//! smooth boolean too large to lift, where the spine of `compile::spine` does not reach). The local step shrinks without end at
//! such an edge — its curvature probes always straddle it — so the marcher asks this where the
//! step reaches its floor, and stops with the place instead of creeping along the edge.

use glam::DVec3;

use crate::surface::Surface;

/// Bisections of a straddling segment: a smooth surface's turn over the last piece is then
/// 2^-40 of the whole, a jump's stays whole.
const BISECTIONS: u32 = 40;
/// A turn of ∇f's direction over a segment this large (radians, ≈ 10°) is looked into, and
/// still this large over the last piece is a jump.
const MIN_JUMP: f64 = 0.17;
/// |∇f| at both ends of the last piece at least this share of |∇f| at the point: a turn
/// through a zero of the gradient (a cone's apex, a cuspidal edge) is no crease.
const MIN_GRADIENT_SHARE: f64 = 0.01;

/// The place and size (radians) of a jump of ∇f's direction within `reach` of `p` along the
/// tangent directions `t1`, `t2` and their diagonals, if there is one.
pub fn gradient_jump(
    surface: &mut dyn Surface,
    p: DVec3,
    (t1, t2): (DVec3, DVec3),
    reach: f64,
) -> Option<(DVec3, f64)> {
    let g0 = surface.value_gradient(p).gradient.length();
    if !(g0.is_finite() && g0 > 0.0) {
        return None;
    }
    let diagonals = [
        (t1 + t2) * std::f64::consts::FRAC_1_SQRT_2,
        (t1 - t2) * std::f64::consts::FRAC_1_SQRT_2,
    ];
    for t in [t1, t2, diagonals[0], diagonals[1]] {
        let (mut a, mut b) = (p - reach * t, p + reach * t);
        let (mut ga, mut gb) = (
            surface.value_gradient(a).gradient,
            surface.value_gradient(b).gradient,
        );
        if !(ga.is_finite() && gb.is_finite()) || ga.angle_between(gb) < MIN_JUMP {
            continue;
        }
        for _ in 0..BISECTIONS {
            let m = 0.5 * (a + b);
            let gm = surface.value_gradient(m).gradient;
            if !gm.is_finite() {
                break;
            }
            if ga.angle_between(gm) >= gm.angle_between(gb) {
                (b, gb) = (m, gm);
            } else {
                (a, ga) = (m, gm);
            }
        }
        let turn = ga.angle_between(gb);
        let strong = ga.length().min(gb.length()) >= MIN_GRADIENT_SHARE * g0;
        if turn >= MIN_JUMP && strong {
            return Some((0.5 * (a + b), turn));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::ValueGrad;

    struct Closure<F: FnMut(DVec3) -> ValueGrad>(F);
    impl<F: FnMut(DVec3) -> ValueGrad> Surface for Closure<F> {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            (self.0)(p)
        }
    }

    #[test]
    fn a_max_jumps_a_sphere_and_a_cone_do_not() {
        let frame = (DVec3::X, DVec3::Y);
        // max(z, x + z): the edge x = 0 of the plane z = 0 (for x < 0) and x + z = 0.
        let mut edge = Closure(|p: DVec3| {
            if p.z >= p.x + p.z {
                ValueGrad {
                    value: p.z,
                    gradient: DVec3::Z,
                }
            } else {
                ValueGrad {
                    value: p.x + p.z,
                    gradient: DVec3::new(1.0, 0.0, 1.0),
                }
            }
        });
        let found = gradient_jump(&mut edge, DVec3::new(-1e-4, 0.0, 0.0), frame, 1e-3);
        let (at, turn) = found.expect("the edge is found");
        assert!(at.x.abs() < 1e-9, "{at}");
        assert!((turn - std::f64::consts::FRAC_PI_4).abs() < 1e-9, "{turn}");
        // A tight sphere of radius 1e-3, probed at its own size: smooth.
        let mut ball = Closure(|p: DVec3| ValueGrad {
            value: p.length_squared() - 1e-6,
            gradient: 2.0 * p,
        });
        let top = DVec3::new(0.0, 0.0, 1e-3);
        assert_eq!(gradient_jump(&mut ball, top, frame, 5e-4), None);
        // A cone's apex: ∇f turns through zero, no crease.
        let mut cone = Closure(|p: DVec3| ValueGrad {
            value: p.x * p.x + p.y * p.y - p.z * p.z,
            gradient: 2.0 * DVec3::new(p.x, p.y, -p.z),
        });
        let near_apex = DVec3::new(1e-4, 0.0, 1e-4);
        let frame = (DVec3::new(1.0, 0.0, 1.0).normalize(), DVec3::Y);
        assert_eq!(gradient_jump(&mut cone, near_apex, frame, 1e-3), None);
    }
}
