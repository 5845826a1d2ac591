//! Closed surfaces with features of a chosen size (tubes, necks, plates, bridges), each with
//! what is known of it independently of any mesh: its Euler characteristic (from its genus),
//! its bounding box (from its formula) and its smallest feature. For the thin-feature tests
//! and the generated sweep.
#![allow(dead_code)]

use glam::{DMat3, DVec3};
use surfc::surface::{NativeSurface, ValueGrad};

use super::{Boxed, vg};

/// A closed surface and what is known of it.
pub struct Shape {
    pub name: String,
    /// f and ∇f, in world coordinates.
    pub f: std::sync::Arc<dyn Fn(DVec3) -> ValueGrad + Send + Sync>,
    /// A point near the surface to start from.
    pub start: DVec3,
    /// χ = 2 − 2·genus.
    pub euler: i64,
    /// The surface's bounding box (exact if `bbox_exact`, else a box the surface lies in).
    pub bbox: (DVec3, DVec3),
    pub bbox_exact: bool,
    /// The smallest feature: tube or neck diameter, plate thickness, bridge width.
    pub feature: f64,
}

impl Shape {
    pub fn surface(&self) -> Boxed {
        let f = self.f.clone();
        Box::new(NativeSurface(move |p: DVec3| f(p)))
    }
}

/// The torus of major radius `big` and tube radius `r` about the axis `rot`·z.
pub fn torus(big: f64, r: f64, rot: DMat3) -> Shape {
    let inv = rot.transpose();
    let f = move |w: DVec3| {
        let p = inv * w;
        let k = p.length_squared() + big * big - r * r;
        let v = k * k - 4.0 * big * big * (p.x * p.x + p.y * p.y);
        let g = DVec3::new(
            4.0 * p.x * (k - 2.0 * big * big),
            4.0 * p.y * (k - 2.0 * big * big),
            4.0 * p.z * k,
        );
        vg(v, rot * g)
    };
    let axis = rot * DVec3::Z;
    let ext = DVec3::from_array(
        [0, 1, 2].map(|k| big * (1.0 - axis[k] * axis[k]).max(0.0).sqrt() + r * 1.0),
    );
    Shape {
        name: format!("torus R={big:.3} r={r:.3}"),
        f: std::sync::Arc::new(f),
        start: rot * DVec3::new(big, 0.0, r),
        euler: 0,
        bbox: (-ext, ext),
        bbox_exact: true,
        feature: 2.0 * r,
    }
}

/// The dumbbell y² + z² = (1 − x²)(x² + n²) (neck radius n at x = 0) about the axis `rot`·x.
pub fn dumbbell(n: f64, rot: DMat3) -> Shape {
    let inv = rot.transpose();
    let n2 = n * n;
    let f = move |w: DVec3| {
        let p = inv * w;
        let (x2, q) = (p.x * p.x, 1.0 - p.x * p.x);
        let v = p.y * p.y + p.z * p.z - q * (x2 + n2);
        let dx = -(-2.0 * p.x * (x2 + n2) + q * 2.0 * p.x);
        vg(v, rot * DVec3::new(dx, 2.0 * p.y, 2.0 * p.z))
    };
    // The box of a surface of revolution: along axis k, max over the profile of
    // |x·a_k| + ρ(x)·√(1 − a_k²).
    let axis = rot * DVec3::X;
    let mut ext = DVec3::ZERO;
    for i in 0..=20_000 {
        let x = -1.0 + i as f64 / 10_000.0;
        let rho = ((1.0 - x * x) * (x * x + n2)).max(0.0).sqrt();
        for k in 0..3 {
            let e = (x * axis[k]).abs() + rho * (1.0 - axis[k] * axis[k]).max(0.0).sqrt();
            ext[k] = ext[k].max(e);
        }
    }
    Shape {
        name: format!("dumbbell neck={n:.3}"),
        f: std::sync::Arc::new(f),
        start: rot * DVec3::new(-0.5, (0.75 * (0.25 + n2)).sqrt(), 0.0),
        euler: 2,
        bbox: (-ext, ext),
        bbox_exact: true,
        feature: 2.0 * n,
    }
}

/// A plate z² = k·(−e)·h1⋯hn over the ellipse x²/a² + y²/b² < 1 with `holes` round holes of
/// radius `hole` in a row along x, `gap` apart (the bridges between them): genus = holes.
pub fn plate(holes: usize, a: f64, b: f64, hole: f64, gap: f64, k: f64) -> Shape {
    let pitch = 2.0 * hole + gap;
    let centres: Vec<f64> = (0..holes)
        .map(|i| (i as f64 - (holes as f64 - 1.0) / 2.0) * pitch)
        .collect();
    let cs = centres.clone();
    // D < 0 inside the domain: e < 0 inside the ellipse, each hᵢ = hole² − |xy − cᵢ|² < 0
    // outside hole i; the sign of the product flips once per factor.
    let sign = if holes % 2 == 1 { -1.0 } else { 1.0 };
    let d = move |x: f64, y: f64| -> (f64, f64, f64) {
        let e = x * x / (a * a) + y * y / (b * b) - 1.0;
        let (mut v, mut dx, mut dy) = (e, 2.0 * x / (a * a), 2.0 * y / (b * b));
        for &c in &cs {
            let h = hole * hole - (x - c) * (x - c) - y * y;
            let (hx, hy) = (-2.0 * (x - c), -2.0 * y);
            (dx, dy) = (dx * h + v * hx, dy * h + v * hy);
            v *= h;
        }
        (sign * v, sign * dx, sign * dy)
    };
    let dd = d.clone();
    let f = move |p: DVec3| {
        let (v, dx, dy) = dd(p.x, p.y);
        vg(p.z * p.z + k * v, DVec3::new(k * dx, k * dy, 2.0 * p.z))
    };
    let mut zmax = 0.0f64;
    let n = 800;
    for i in 0..=n {
        for j in 0..=n {
            let (x, y) = (
                -a + 2.0 * a * i as f64 / n as f64,
                -b + 2.0 * b * j as f64 / n as f64,
            );
            zmax = zmax.max((-k * d(x, y).0).max(0.0).sqrt());
        }
    }
    // Thinnest bridge: the half-thickness at the middle of a gap.
    let bridge = if holes > 1 {
        let x = 0.5 * (centres[0] + centres[1]);
        2.0 * (-k * d(x, 0.0).0).max(0.0).sqrt()
    } else {
        f64::INFINITY
    };
    let side = b - hole;
    Shape {
        name: format!("plate holes={holes} gap={gap:.3} k={k:.3}"),
        f: std::sync::Arc::new(f),
        start: DVec3::new(0.0, 0.5 * (hole + b), zmax),
        euler: 2 - 2 * holes as i64,
        bbox: (DVec3::new(-a, -b, -zmax), DVec3::new(a, b, zmax)),
        bbox_exact: true,
        feature: bridge.min(gap).min(side).min(2.0 * zmax),
    }
}

/// The superquadric (x/a)^p + (y/b)^p + (z/c)^p = 1 for an even p.
pub fn superquadric(a: f64, b: f64, c: f64, p: i32) -> Shape {
    let s = DVec3::new(a, b, c);
    let f = move |w: DVec3| {
        let q = w / s;
        let v = q.x.powi(p) + q.y.powi(p) + q.z.powi(p) - 1.0;
        let g = DVec3::new(q.x.powi(p - 1), q.y.powi(p - 1), q.z.powi(p - 1)) * p as f64 / s;
        vg(v, g)
    };
    Shape {
        name: format!("superquadric {a:.3}×{b:.3}×{c:.3} p={p}"),
        f: std::sync::Arc::new(f),
        start: DVec3::new(0.0, 0.0, c),
        euler: 2,
        bbox: (-s, s),
        bbox_exact: true,
        feature: 2.0 * a.min(b).min(c),
    }
}

/// A chain of Gaussian blobs joined by necks: f = level − Σ exp(−|p − cᵢ|²/w²), w = `width`.
/// Consecutive centres are placed so that the two-blob neck between them has radius
/// `necks[i]` (the sum of two blobs at distance d has the neck radius
/// r = w·√(ln(2/level) − d²/(4w²)) at its middle), each in a random direction that keeps
/// every other centre at least 1.5 d away, so the solid is a tree of balls and necks: a
/// sphere (χ = 2). The neck radii are measured again on the final sum (the other blobs'
/// tails widen them a little) and the smallest diameter is the feature. The bounding box is
/// not known in closed form: `bbox` is a box the surface lies in (where even k blobs' sum
/// stays below the level), and the sweep takes the extent from the voxel reference.
pub fn blobs(
    level: f64,
    width: f64,
    necks: &[f64],
    mut direction: impl FnMut() -> DVec3,
) -> Option<Shape> {
    let w2 = width * width;
    let mut centres = vec![DVec3::ZERO];
    for &r in necks {
        let d2 = 4.0 * w2 * ((2.0 / level).ln() - r * r / w2);
        // Two blobs closer than √2·w have no neck between them (the middle is no saddle).
        if d2.is_nan() || d2 <= 2.0 * w2 {
            return None;
        }
        let d = d2.sqrt();
        let last = *centres.last()?;
        let next = (0..64).map(|_| last + d * direction()).find(|c| {
            centres[..centres.len() - 1]
                .iter()
                .all(|o| o.distance(*c) >= 1.5 * d)
        })?;
        centres.push(next);
    }
    let cs = centres.clone();
    let f = move |p: DVec3| {
        let (mut v, mut g) = (level, DVec3::ZERO);
        for c in &cs {
            let e = (-(p - *c).length_squared() / w2).exp();
            v -= e;
            g += e * 2.0 * (p - *c) / w2;
        }
        vg(v, g)
    };
    // The neck radius across the middle of each pair, by bisection along a perpendicular.
    let mut feature = f64::INFINITY;
    for pair in centres.windows(2) {
        let (m, axis) = (0.5 * (pair[0] + pair[1]), (pair[1] - pair[0]).normalize());
        let side = axis.any_orthonormal_vector();
        if f(m).value >= 0.0 {
            return None;
        }
        let (mut a, mut b) = (0.0, width);
        for _ in 0..50 {
            let t = 0.5 * (a + b);
            if f(m + t * side).value < 0.0 {
                a = t;
            } else {
                b = t;
            }
        }
        feature = feature.min(2.0 * a);
    }
    let ball = width * (1.0 / level).ln().sqrt();
    let reach = DVec3::splat(width * (centres.len() as f64 / level).ln().sqrt());
    let (lo, hi) = centres
        .iter()
        .fold((centres[0], centres[0]), |(lo, hi), c| {
            (lo.min(*c), hi.max(*c))
        });
    Some(Shape {
        name: format!(
            "blobs n={} level={level:.3} necks={:?}",
            centres.len(),
            necks
                .iter()
                .map(|r| (r * 1000.0).round() / 1000.0)
                .collect::<Vec<_>>()
        ),
        f: std::sync::Arc::new(f),
        start: DVec3::new(0.0, 0.0, ball),
        euler: 2,
        bbox: (lo - reach, hi + reach),
        bbox_exact: false,
        feature: feature.min(2.0 * ball),
    })
}
