//! Front angles (paper Step 1) and the number of triangles at a completed point (Step 3 with
//! its corrections for extreme cases). Pure functions of coordinates and settings.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use super::settings::MarchSettings;

/// Polar angle of `v − p` in the tangent frame (t1, t2) at p, in (−π, π].
pub fn polar(p: DVec3, t1: DVec3, t2: DVec3, v: DVec3) -> f64 {
    let d = v - p;
    d.dot(t2).atan2(d.dot(t1))
}

/// Step 1: the front angle at p between its front neighbours v1 (previous) and v2 (next),
/// measured counter-clockwise (seen from the normal) from v1 to v2, in [0, 2π).
pub fn front_angle(p: DVec3, t1: DVec3, t2: DVec3, v1: DVec3, v2: DVec3) -> f64 {
    // One atan2 of the projected vectors' cross and dot products instead of two polar
    // angles: the same angle, half the cost (this runs for every changed front point).
    let (d1, d2) = (v1 - p, v2 - p);
    let (x1, y1, x2, y2) = (d1.dot(t1), d1.dot(t2), d2.dot(t1), d2.dot(t2));
    let w = (x1 * y2 - y1 * x2).atan2(x1 * x2 + y1 * y2);
    if w >= 0.0 { w } else { w + TAU }
}

/// The counter-clockwise angle from polar angle `w1` to `w2`, in [0, 2π).
pub fn ccw(w1: f64, w2: f64) -> f64 {
    let w = w2 - w1;
    let w = if w >= 0.0 { w } else { w + TAU };
    if w >= TAU { 0.0 } else { w }
}

/// Step 3: how many triangles to put around a point with front angle `omega` whose
/// neighbours are at distances `d1`, `d2` from it and `gap` from each other, for step
/// `step`; with the paper's corrections for extreme cases (Fig. 5a–c).
pub fn triangle_count(omega: f64, d1: f64, d2: f64, gap: f64, step: f64, s: &MarchSettings) -> u32 {
    let mut nt = (3.0 * omega / PI).trunc().max(0.0) as u32 + 1;
    let mut dw = omega / nt as f64;
    if dw < s.min_delta_angle && nt > 1 {
        nt -= 1;
        dw = omega / nt as f64;
    }
    if nt == 1 && dw > s.min_delta_angle && gap > s.split_gap * step {
        nt = 2;
    }
    if omega < s.close_angle && (d1 <= s.close_neighbour * step || d2 <= s.close_neighbour * step) {
        nt = 1;
    }
    nt
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_angle_of_a_hexagon_corner_is_240_degrees() {
        let (t1, t2) = (DVec3::X, DVec3::Y);
        let corner = |i: f64| DVec3::new((i * PI / 3.0).cos(), (i * PI / 3.0).sin(), 0.0);
        let w = front_angle(corner(1.0), t1, t2, corner(0.0), corner(2.0));
        assert!((w - 4.0 * PI / 3.0).abs() < 1e-12, "{w}");
        // Walking the other way, the meshed side is the other one: 120°.
        let w = front_angle(corner(1.0), t1, t2, corner(2.0), corner(0.0));
        assert!((w - 2.0 * PI / 3.0).abs() < 1e-12, "{w}");
    }

    #[test]
    fn ccw_wraps_into_zero_to_two_pi() {
        assert!((ccw(3.0, -3.0) - (TAU - 6.0)).abs() < 1e-12);
        assert!((ccw(-3.0, 3.0) - 6.0).abs() < 1e-12);
        assert_eq!(ccw(1.0, 1.0), 0.0);
    }

    #[test]
    fn triangle_count_follows_the_paper_corrections() {
        let s = MarchSettings::default();
        // 60°: trunc(1)+1 = 2, Δω = 0.52 < 0.8 → 1.
        assert_eq!(triangle_count(PI / 3.0, 1.0, 1.0, 1.0, 1.0, &s), 1);
        // 100°: 2 triangles of 0.87 rad.
        assert_eq!(triangle_count(1.745, 1.0, 1.0, 1.6, 1.0, &s), 2);
        // 50° with a wide gap: Fig. 5b does not apply (Δω < 0.8), one triangle.
        assert_eq!(triangle_count(0.87, 1.0, 1.0, 1.3, 1.0, &s), 2);
        assert_eq!(triangle_count(0.7, 1.0, 1.0, 1.3, 1.0, &s), 1);
        // 90° whose neighbour is close: Fig. 5c, one triangle.
        assert_eq!(triangle_count(PI / 2.0, 0.4, 1.0, 1.1, 1.0, &s), 1);
        // 4.3 rad: trunc(4.1)+1 = 5 triangles, Δω = 0.86.
        assert_eq!(triangle_count(4.3, 1.0, 1.0, 1.0, 1.0, &s), 5);
        // 3.3 rad: 4 triangles would be 0.825 each, kept.
        assert_eq!(triangle_count(3.3, 1.0, 1.0, 1.0, 1.0, &s), 4);
        // 3.1 rad: 3·3.1/π → 3+1 = 4 of 0.775 < 0.8 → 3.
        assert_eq!(triangle_count(3.1, 1.0, 1.0, 1.0, 1.0, &s), 3);
    }
}
