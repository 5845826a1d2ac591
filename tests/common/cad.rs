//! Generated CAD parts for the sweep of issue 42: plates with through and blind holes, L, T
//! and U brackets of boxes sharing face planes, stacked blocks, bosses and ribs on plates,
//! fillets by `smooth_union` and by `offset`, overlapping scatters of primitives, flanges
//! with bolt circles of rotated copies, rod lattices, and any of these turned and moved.
//! Each part is kept as data (`Solid`), so that the test can
//! - write it as `.surf` text with the language's solids, as a CAD user would (`source`);
//! - evaluate the same solid natively (`Solid::value`), without surfc's parser, compiler or
//!   evaluator: the language's formulas of docs/language.md (*Solids*) written out here,
//!   `smooth_union` as the same polynomial smooth minimum, `offset` as the exact distance to
//!   the operand minus d (`Solid::distance`: exact formulas of the primitives, and of unions
//!   outside them);
//! - know by construction its *smallest feature* (the smallest wall thickness, hole radius,
//!   gap, ledge, rib width, fillet radius or offset that the generator made) and, where the
//!   construction gives it, the Euler characteristic of its surface (a plate with n through
//!   holes: χ = 2 − 2n);
//! - count it on voxel grids (`reference`): the solid {f < 0} read both ways on grids of a
//!   quarter of the smallest feature and finer, trusted only when both readings of a grid agree
//!   and two grids agree (`common::voxel`, as `tests/mesh/creases.rs` does for random CSG
//!   trees). The reference never evaluates surfc.
//!
//! Lengths are whole multiples of 0.0025 (`len`), mostly of 0.01, written as short decimals
//! (0.35, 1.2): the numbers a user types. Sums of them are computed by the user (the text
//! has `0.35`, not `0.2 + 0.15`), so faces meant to be flush are flush in the text, and where
//! a centre and a half-height are added back (a cylinder standing on a face) or a part is
//! turned, rounding makes coincident faces only nearly equal, as it does for users.
#![allow(dead_code)]

use std::f64::consts::{PI, TAU};

use glam::{DMat3, DVec2, DVec3};

use super::csg;
use super::rng::Rng;
use super::voxel::{Lattice, SolidCount, two_readings_on};

/// Lengths are counted in units of 1/`PER`.
const PER: f64 = 400.0;

/// A length in units, as the f64 the text's decimal parses to.
pub fn len(u: i64) -> f64 {
    u as f64 / PER
}

/// `v` rounded to `places` decimals: a number as a user would write it.
fn decimal(v: f64, places: i32) -> f64 {
    let s = 10f64.powi(places);
    (v * s).round() / s
}

/// A number as the text writes it: Rust's shortest round-trip form (never an exponent).
fn num(v: f64) -> String {
    format!("{v}")
}

fn point(p: DVec3) -> String {
    format!("({}, {}, {})", num(p.x), num(p.y), num(p.z))
}

/// An angle as written in the text, and its value as the language folds that text.
#[derive(Clone, Debug)]
pub struct Angle {
    pub value: f64,
    pub text: String,
}

impl Angle {
    /// `pi / den` or `pi * k / den`, folded as written: (π·k)/den.
    pub fn of_pi(k: i64, den: i64) -> Angle {
        Angle::fraction("pi", PI, k, den)
    }

    /// `tau * k / den`, folded as written: (τ·k)/den.
    pub fn of_tau(k: i64, den: i64) -> Angle {
        Angle::fraction("tau", TAU, k, den)
    }

    fn fraction(name: &str, full: f64, k: i64, den: i64) -> Angle {
        let (value, text) = if k == 1 {
            (full / den as f64, format!("{name} / {den}"))
        } else {
            (
                full * k as f64 / den as f64,
                format!("{name} * {k} / {den}"),
            )
        };
        Angle { value, text }
    }

    /// A decimal number of radians.
    pub fn radians(v: f64) -> Angle {
        Angle {
            value: v,
            text: num(v),
        }
    }
}

/// The matrix of `rotate(S, axis: a, angle: θ)` as docs/language.md defines it: Rodrigues'
/// formula on the normalised axis, entries within 1e-15 of 0 set to 0 (so that quarter turns
/// map the axes onto each other exactly). Rows.
pub fn rotation(axis: DVec3, angle: f64) -> [[f64; 3]; 3] {
    let k = axis.normalize().to_array();
    let (s, c) = angle.sin_cos();
    let cross = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let id = if i == j { c } else { 0.0 };
            let v = id + (1.0 - c) * k[i] * k[j] + s * cross[i][j];
            if v.abs() < 1e-15 { 0.0 } else { v }
        })
    })
}

/// m·p, row by row, zero coefficients skipped (as the language's transform is folded).
fn apply(m: &[[f64; 3]; 3], p: DVec3) -> DVec3 {
    let p = p.to_array();
    let row = |i: usize| {
        let mut acc: Option<f64> = None;
        for j in 0..3 {
            if m[i][j] != 0.0 {
                let t = m[i][j] * p[j];
                acc = Some(acc.map_or(t, |a| a + t));
            }
        }
        acc.unwrap_or(0.0)
    };
    DVec3::new(row(0), row(1), row(2))
}

/// The polynomial smooth minimum of the smooth booleans, as docs/language.md defines it:
/// h = clamp(0.5 + 0.5·(b − a)/r, 0, 1), smin = b + (a − b)·h − r·h·(1 − h). Where a = b
/// (two flush faces) it is a − r/4: the face moves out by a quarter of the radius.
pub fn smin(a: f64, b: f64, r: f64) -> f64 {
    let h = (0.5 + 0.5 * ((b - a) / r)).clamp(0.0, 1.0);
    b + (a - b) * h - r * h * (1.0 - h)
}

/// A solid as the language writes it.
#[derive(Clone, Debug)]
pub enum Solid {
    /// `box(lo, hi)`.
    Box {
        lo: DVec3,
        hi: DVec3,
    },
    /// `cylinder(r, h)`: axis z, from −h/2 to h/2.
    Cylinder {
        r: f64,
        h: f64,
    },
    /// `sphere(r)`.
    Sphere {
        r: f64,
    },
    /// `torus(R, r)`.
    Torus {
        big: f64,
        small: f64,
    },
    Union(Vec<Solid>),
    Intersection(Vec<Solid>),
    /// The first without the others.
    Difference(Vec<Solid>),
    /// `smooth_union(a, b, r)`.
    SmoothUnion(Box<Solid>, Box<Solid>, f64),
    /// `offset(S, d)`, d > 0 (S a primitive, a transform of one or a union of them).
    Offset(Box<Solid>, f64),
    Translate(Box<Solid>, DVec3),
    /// `rotate(S, axis: a, angle: θ)`: the axis as written (not normalised).
    Rotate(Box<Solid>, DVec3, Angle),
}

/// `box(lo, hi)` of lengths in units.
pub fn cuboid(lo: [i64; 3], hi: [i64; 3]) -> Solid {
    Solid::Box {
        lo: DVec3::from_array(lo.map(len)),
        hi: DVec3::from_array(hi.map(len)),
    }
}

pub fn translate(s: Solid, d: DVec3) -> Solid {
    Solid::Translate(Box::new(s), d)
}

pub fn rotate(s: Solid, axis: DVec3, angle: Angle) -> Solid {
    Solid::Rotate(Box::new(s), axis, angle)
}

/// `cylinder(r, h)` standing on the axis z at (x, y) from z0 to z0 + h (units; h even, so
/// that the centre is a whole unit).
pub fn post(r: i64, x: i64, y: i64, z0: i64, h: i64) -> Solid {
    assert!(h % 2 == 0, "an even height");
    translate(
        Solid::Cylinder {
            r: len(r),
            h: len(h),
        },
        DVec3::new(len(x), len(y), len(z0 + h / 2)),
    )
}

impl Solid {
    /// The planes n·p + c of the solid's top-level `max` (a box's six faces, a cylinder's
    /// caps), moved and turned with it; none for other solids.
    fn planes(&self) -> Vec<(DVec3, f64)> {
        match self {
            Solid::Box { lo, hi } => vec![
                (-DVec3::X, lo.x),
                (DVec3::X, -hi.x),
                (-DVec3::Y, lo.y),
                (DVec3::Y, -hi.y),
                (-DVec3::Z, lo.z),
                (DVec3::Z, -hi.z),
            ],
            Solid::Cylinder { h, .. } => vec![(DVec3::Z, -0.5 * h), (-DVec3::Z, -0.5 * h)],
            Solid::Translate(s, d) => s
                .planes()
                .into_iter()
                .map(|(n, c)| (n, c - n.dot(*d)))
                .collect(),
            Solid::Rotate(s, axis, angle) => {
                let m = rotation(*axis, -angle.value);
                s.planes()
                    .into_iter()
                    .map(|(n, c)| {
                        let t = DVec3::from_array(std::array::from_fn(|j| {
                            (0..3).map(|i| m[i][j] * n[i]).sum()
                        }));
                        (t, c)
                    })
                    .collect()
            }
            _ => Vec::new(),
        }
    }

    /// The solid's function as the language computes it (docs/language.md, *Solids*),
    /// natively.
    pub fn value(&self, p: DVec3) -> f64 {
        match self {
            Solid::Box { lo, hi } => [
                lo.x - p.x,
                p.x - hi.x,
                lo.y - p.y,
                p.y - hi.y,
                lo.z - p.z,
                p.z - hi.z,
            ]
            .into_iter()
            .fold(f64::NEG_INFINITY, f64::max),
            Solid::Cylinder { r, h } => (p.x.hypot(p.y) - r).max(p.z.abs() - 0.5 * h),
            Solid::Sphere { r } => (p.x * p.x + p.y * p.y + p.z * p.z).sqrt() - r,
            Solid::Torus { big, small } => (p.x.hypot(p.y) - big).hypot(p.z) - small,
            Solid::Union(v) => v.iter().map(|s| s.value(p)).fold(f64::INFINITY, f64::min),
            Solid::Intersection(v) => v
                .iter()
                .map(|s| s.value(p))
                .fold(f64::NEG_INFINITY, f64::max),
            Solid::Difference(v) => v[1..]
                .iter()
                .map(|s| -s.value(p))
                .fold(v[0].value(p), f64::max),
            Solid::SmoothUnion(a, b, r) => {
                // Clipped by the faces both operands have, as surfc compiles it
                // (src/compile/flush.rs): flush faces stay flat.
                let planes = b.planes();
                a.planes()
                    .into_iter()
                    .filter(|(n, c)| {
                        planes
                            .iter()
                            .any(|(m, d)| (*n - *m).length() < 1e-9 && (c - d).abs() < 1e-9)
                    })
                    .map(|(n, c)| n.dot(p) + c)
                    .fold(smin(a.value(p), b.value(p), *r), f64::max)
            }
            Solid::Offset(s, d) => s.distance(p) - d,
            Solid::Translate(s, d) => s.value(p - *d),
            Solid::Rotate(s, axis, angle) => s.value(apply(&rotation(*axis, -angle.value), p)),
        }
    }

    /// The exact signed distance to the solid's surface, for what `offset` is generated over:
    /// primitives (exact), their transforms (rigid), and unions of them (exact outside, where
    /// the distance to a union is the least distance to its operands; of the right sign
    /// inside, which is all an outward offset needs).
    pub fn distance(&self, p: DVec3) -> f64 {
        match self {
            Solid::Box { lo, hi } => {
                let q = (p - 0.5 * (*lo + *hi)).abs() - 0.5 * (*hi - *lo);
                q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
            }
            Solid::Cylinder { r, h } => {
                let d = DVec2::new(p.x.hypot(p.y) - r, p.z.abs() - 0.5 * h);
                d.max(DVec2::ZERO).length() + d.max_element().min(0.0)
            }
            Solid::Sphere { r } => p.length() - r,
            Solid::Torus { .. } => self.value(p),
            Solid::Union(v) => v
                .iter()
                .map(|s| s.distance(p))
                .fold(f64::INFINITY, f64::min),
            Solid::Translate(s, d) => s.distance(p - *d),
            Solid::Rotate(s, axis, angle) => s.distance(apply(&rotation(*axis, -angle.value), p)),
            other => panic!("no exact distance is generated for {other:?}"),
        }
    }

    /// A box that holds the solid.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let grow = |(lo, hi): (DVec3, DVec3), d: f64| (lo - DVec3::splat(d), hi + DVec3::splat(d));
        match self {
            Solid::Box { lo, hi } => (*lo, *hi),
            Solid::Cylinder { r, h } => (DVec3::new(-r, -r, -0.5 * h), DVec3::new(*r, *r, 0.5 * h)),
            Solid::Sphere { r } => (DVec3::splat(-r), DVec3::splat(*r)),
            Solid::Torus { big, small } => {
                let a = big + small;
                (DVec3::new(-a, -a, -small), DVec3::new(a, a, *small))
            }
            Solid::Union(v) => v.iter().map(Solid::bounds).fold(
                (DVec3::INFINITY, DVec3::NEG_INFINITY),
                |(lo, hi), (l, h)| (lo.min(l), hi.max(h)),
            ),
            Solid::Intersection(v) => v.iter().map(Solid::bounds).fold(
                (DVec3::NEG_INFINITY, DVec3::INFINITY),
                |(lo, hi), (l, h)| (lo.max(l), hi.min(h)),
            ),
            Solid::Difference(v) => v[0].bounds(),
            // The smooth minimum is at least min(a, b) − r/4, and the operands grow by at
            // most their value's excess: r/4 around both.
            Solid::SmoothUnion(a, b, r) => {
                let (al, ah) = a.bounds();
                let (bl, bh) = b.bounds();
                grow((al.min(bl), ah.max(bh)), 0.25 * r)
            }
            Solid::Offset(s, d) => grow(s.bounds(), *d),
            Solid::Translate(s, d) => {
                let (lo, hi) = s.bounds();
                (lo + *d, hi + *d)
            }
            Solid::Rotate(s, axis, angle) => {
                let (lo, hi) = s.bounds();
                let m = rotation(*axis, angle.value);
                (0..8).fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(a, b), c| {
                    let corner = DVec3::new(
                        if c & 1 == 0 { lo.x } else { hi.x },
                        if c & 2 == 0 { lo.y } else { hi.y },
                        if c & 4 == 0 { lo.z } else { hi.z },
                    );
                    let q = apply(&m, corner);
                    (a.min(q), b.max(q))
                })
            }
        }
    }

    /// The solid as `.surf` text, operands of the booleans one a line, indented by `depth`.
    pub fn text(&self, depth: usize) -> String {
        let pad = "  ".repeat(depth + 1);
        let list = |name: &str, v: &[Solid]| {
            let parts: Vec<String> = v.iter().map(|s| s.text(depth + 1)).collect();
            format!("{name}(\n{pad}{})", parts.join(&format!(",\n{pad}")))
        };
        match self {
            Solid::Box { lo, hi } => format!("box({}, {})", point(*lo), point(*hi)),
            Solid::Cylinder { r, h } => format!("cylinder({}, {})", num(*r), num(*h)),
            Solid::Sphere { r } => format!("sphere({})", num(*r)),
            Solid::Torus { big, small } => format!("torus({}, {})", num(*big), num(*small)),
            Solid::Union(v) => list("union", v),
            Solid::Intersection(v) => list("intersection", v),
            Solid::Difference(v) => list("difference", v),
            Solid::SmoothUnion(a, b, r) => format!(
                "smooth_union(\n{pad}{},\n{pad}{},\n{pad}{})",
                a.text(depth + 1),
                b.text(depth + 1),
                num(*r)
            ),
            Solid::Offset(s, d) => format!("offset({}, {})", s.text(depth), num(*d)),
            Solid::Translate(s, d) => format!("translate({}, {})", s.text(depth), point(*d)),
            Solid::Rotate(s, axis, angle) => format!(
                "rotate({}, axis: {}, angle: {})",
                s.text(depth),
                point(*axis),
                angle.text
            ),
        }
    }

    /// The solid turned about `axis` by `angle` and then moved by `by`; an `offset` keeps
    /// the transforms inside it (a transform of a `dist` is E0211, docs/language.md).
    pub fn moved(self, axis: DVec3, angle: Angle, by: DVec3) -> Solid {
        match self {
            Solid::Offset(s, d) => Solid::Offset(Box::new(s.moved(axis, angle, by)), d),
            s => translate(rotate(s, axis, angle), by),
        }
    }
}

/// The classes of the sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Class {
    /// A plate with through holes (flush or longer than the plate) and blind holes (ending
    /// flush with the top face or above it).
    Plate,
    /// L, T and U brackets of boxes sharing face planes, with mounting holes.
    Bracket,
    /// Blocks on blocks (and beside them) sharing faces, partly flush.
    Stacked,
    /// Bosses (cylinders standing on a plate, flush with its face, some bored through) and
    /// ribs (thin boxes standing on it, some flush with its sides).
    BossRib,
    /// Fillets by `smooth_union` of flush boxes or of a plate and a boss, and rounding by
    /// `offset` of a box or of a union.
    Fillet,
    /// Overlapping scatters of boxes, spheres, tori and cylinders, turned.
    Scatter,
    /// A disc with a hub, a bore, a bolt circle and ribs: copies turned about the axis.
    Flange,
    /// Rods crossing on a grid (a grate, or a 3D lattice).
    Lattice,
    /// Any of the above (but scatters) turned about a random axis and moved.
    Rotated,
}

impl Class {
    pub const ALL: [Class; 9] = [
        Class::Plate,
        Class::Bracket,
        Class::Stacked,
        Class::BossRib,
        Class::Fillet,
        Class::Scatter,
        Class::Flange,
        Class::Lattice,
        Class::Rotated,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Class::Plate => "plate",
            Class::Bracket => "bracket",
            Class::Stacked => "stacked",
            Class::BossRib => "boss_rib",
            Class::Fillet => "fillet",
            Class::Scatter => "scatter",
            Class::Flange => "flange",
            Class::Lattice => "lattice",
            Class::Rotated => "rotated",
        }
    }

    pub fn from_name(name: &str) -> Option<Class> {
        Class::ALL.into_iter().find(|c| c.name() == name)
    }
}

/// A generated part: its solid, its smallest feature and what the construction knows of its
/// topology.
#[derive(Clone, Debug)]
pub struct Part {
    pub class: Class,
    /// One line saying what it is.
    pub what: String,
    pub solid: Solid,
    /// The smallest feature the generator made (wall, hole radius, gap, ledge, rib, fillet
    /// radius, offset): the steps are multiples of it.
    pub feature: f64,
    /// χ of the surface, where the construction gives it.
    pub euler: Option<i64>,
    /// Components of the surface, where the construction gives them.
    pub components: Option<usize>,
    /// For scatters: the same solid as a `common::csg` tree, whose general position was
    /// checked and whose rounded form the reference samples (acute wedges between primitives
    /// would otherwise break into crumbs on the grid).
    pub scatter: Option<csg::Tree>,
}

impl Part {
    pub fn value(&self, p: DVec3) -> f64 {
        self.solid.value(p)
    }

    /// The mesh block's box at `step`: the solid's bounds and a margin of two steps and half
    /// a feature, rounded outward to 0.001.
    pub fn mesh_box(&self, step: f64) -> (DVec3, DVec3) {
        let (lo, hi) = self.solid.bounds();
        let m = 2.0 * step + 0.5 * self.feature;
        let lo = (lo - DVec3::splat(m))
            .to_array()
            .map(|c| (c * 1000.0).floor() / 1000.0);
        let hi = (hi + DVec3::splat(m))
            .to_array()
            .map(|c| (c * 1000.0).ceil() / 1000.0);
        (DVec3::from_array(lo), DVec3::from_array(hi))
    }

    /// The step `multiple` times the smallest feature, as written (to 1e-6).
    pub fn step(&self, multiple: f64) -> f64 {
        decimal(multiple * self.feature, 6)
    }

    /// The `.surf` file: the part as surface `part`, meshed at `step` in its box with no
    /// start.
    pub fn source(&self, step: f64) -> String {
        let (lo, hi) = self.mesh_box(step);
        format!(
            "// {}: {}; smallest feature {}\nsurface part = {};\nmesh part = part {{ step: {}; box: {} .. {}; }}\n",
            self.class.name(),
            self.what,
            num(self.feature),
            self.solid.text(0),
            num(step),
            point(lo),
            point(hi)
        )
    }
}

// ---------------------------------------------------------------------------------------------
// The generators. Lengths in units (`len`); `t` is the feature the part is drawn from.

fn int(rng: &mut Rng, lo: i64, hi: i64) -> i64 {
    lo + (rng.next() % (hi - lo + 1) as u64) as i64
}

fn chance(rng: &mut Rng, p: f64) -> bool {
    rng.unit() < p
}

/// A length from t to about `factor`·t, in steps of 0.01 (4 units).
fn size(rng: &mut Rng, t: i64, factor: f64) -> i64 {
    t + 4 * int(rng, 0, (((factor - 1.0) * t as f64) / 4.0).max(0.0) as i64)
}

/// The smallest of the lengths noted (units).
struct Smallest(i64);

impl Smallest {
    fn new() -> Smallest {
        Smallest(i64::MAX)
    }

    fn note(&mut self, u: i64) {
        assert!(u > 0, "a feature of {u} units");
        self.0 = self.0.min(u);
    }

    /// Notes `u` unless it is 0 (flush).
    fn note_gap(&mut self, u: i64) {
        assert!(u >= 0, "a gap of {u} units");
        if u > 0 {
            self.note(u);
        }
    }

    fn get(&self) -> f64 {
        len(self.0)
    }
}

/// The feature a part is drawn from: 0.05 to 0.15 in steps of 0.01.
fn draw_feature(rng: &mut Rng) -> i64 {
    4 * int(rng, 5, 15)
}

/// Draws a part of `class`.
pub fn generate(class: Class, rng: &mut Rng) -> Part {
    let t = draw_feature(rng);
    match class {
        Class::Plate => plate(rng, t),
        Class::Bracket => bracket(rng, t),
        Class::Stacked => stacked(rng, t),
        Class::BossRib => boss_rib(rng, t),
        Class::Fillet => fillet(rng, t),
        Class::Scatter => scatter(rng, t),
        Class::Flange => flange(rng, t),
        Class::Lattice => lattice(rng, t),
        Class::Rotated => rotated(rng),
    }
}

/// How a hole's cylinder ends at a face.
#[derive(Clone, Copy, Debug, PartialEq)]
enum End {
    /// Exactly at the face.
    Flush,
    /// Beyond it (by `o` units), as users make sure a cut goes through.
    Over(i64),
}

fn draw_end(rng: &mut Rng, t: i64) -> End {
    if chance(rng, 0.5) {
        End::Flush
    } else {
        End::Over(4 * int(rng, 1, (t / 4).max(1)))
    }
}

/// A vertical hole of radius r at (x, y) from z0 to z1, each end flush or over.
fn vertical_hole(r: i64, x: i64, y: i64, z0: i64, z1: i64, ends: (End, End)) -> Solid {
    let over = |e: End| match e {
        End::Flush => 0,
        End::Over(o) => o,
    };
    let (a, b) = (z0 - over(ends.0), z1 + over(ends.1));
    // The centre (a + b)/2 must be a whole unit: lengths are multiples of 4 units.
    post(r, x, y, a, b - a)
}

/// A plate W×D×T with a grid of holes, each through (flush with both faces or longer) or
/// blind from the top (its floor at least t thick).
fn plate(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let r = size(rng, t, 2.0);
    let thick = size(rng, t, 3.0);
    let (nx, ny) = (int(rng, 1, 5), int(rng, 1, 4));
    let (gx, gy) = (size(rng, t, 3.0), size(rng, t, 3.0));
    let (ex, ey) = (size(rng, t, 3.0), size(rng, t, 3.0));
    small.note(r);
    small.note(thick);
    small.note(ex);
    small.note(ey);
    if nx > 1 {
        small.note(gx);
    }
    if ny > 1 {
        small.note(gy);
    }
    let (px, py) = (2 * r + gx, 2 * r + gy);
    let w = 2 * (ex + r) + (nx - 1) * px;
    let d = 2 * (ey + r) + (ny - 1) * py;
    let mut parts = vec![cuboid([0, 0, 0], [w, d, thick])];
    let (mut through, mut flush, mut blind) = (0, 0, 0);
    for i in 0..nx {
        for j in 0..ny {
            let (x, y) = (ex + r + i * px, ey + r + j * py);
            let top = draw_end(rng, t);
            if thick >= 2 * t && chance(rng, 0.3) {
                let depth = size(rng, t, (thick - t) as f64 / t as f64);
                small.note(depth);
                small.note(thick - depth);
                parts.push(vertical_hole(
                    r,
                    x,
                    y,
                    thick - depth,
                    thick,
                    (End::Flush, top),
                ));
                blind += 1;
            } else {
                let bottom = draw_end(rng, t);
                flush += (top == End::Flush && bottom == End::Flush) as usize;
                parts.push(vertical_hole(r, x, y, 0, thick, (bottom, top)));
                through += 1;
            }
        }
    }
    Part {
        class: Class::Plate,
        what: format!(
            "plate {}×{}×{}, {through} through holes of radius {} ({flush} flush with both faces), {blind} blind",
            len(w),
            len(d),
            len(thick),
            len(r)
        ),
        solid: Solid::Difference(parts),
        feature: small.get(),
        euler: Some(2 - 2 * through as i64),
        components: Some(1),
        scatter: None,
    }
}

/// L, T and U brackets: a base plate and uprights of full depth (flush with the base's
/// sides) or inset, mounting holes through the base and through an upright.
fn bracket(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let kind = int(rng, 0, 2);
    let tb = size(rng, t, 3.0);
    let tu = size(rng, t, 3.0);
    small.note(tb);
    small.note(tu);
    // Base holes: radius, count along y, margins (to the upright, the edges, each other).
    let base_holes = chance(rng, 0.6);
    let r = size(rng, t, 1.5);
    let m = int(rng, 1, 3);
    let (ex, ey, gy) = (size(rng, t, 3.0), size(rng, t, 3.0), size(rng, t, 3.0));
    // A free stretch of base: with holes, two margins and a hole's width.
    let mut frees = Vec::new();
    let mut free = || {
        let f = if base_holes {
            2 * ex + 2 * r
        } else {
            size(rng, t, 10.0)
        };
        frees.push(f);
        f
    };
    // The uprights' x ranges, and the free stretches where base holes go (x of their start).
    let (w, uprights, stretches) = match kind {
        0 => {
            let f = free();
            (tu + f, vec![0], vec![tu])
        }
        1 => {
            let (a, b) = (free(), free());
            (a + tu + b, vec![a], vec![0, a + tu])
        }
        _ => {
            let g = free();
            (2 * tu + g, vec![0, tu + g], vec![tu])
        }
    };
    for f in frees {
        small.note(f);
    }
    // Depth: the holes' span, or a drawn depth; uprights full depth or inset at either end.
    let span = 2 * ey + 2 * r * m + gy * (m - 1);
    let core = if base_holes { span } else { size(rng, t, 10.0) };
    let mut inset = || {
        if chance(rng, 0.6) {
            0
        } else {
            size(rng, t, 3.0)
        }
    };
    let (a0, a1) = (inset(), inset());
    let d = a0 + core + a1;
    small.note_gap(a0);
    small.note_gap(a1);
    small.note(core);
    // Upright height above the base, with room for a horizontal hole.
    let up_hole = chance(rng, 0.4) && kind != 2;
    let r2 = size(rng, t, 1.5);
    let ez = size(rng, t, 3.0);
    let rise = if up_hole {
        2 * ez + 2 * r2
    } else {
        size(rng, t, 10.0)
    };
    small.note(rise);
    let h = tb + rise;
    let mut solids = vec![cuboid([0, 0, 0], [w, d, tb])];
    for &x0 in &uprights {
        solids.push(cuboid([x0, a0, 0], [x0 + tu, a0 + core, h]));
    }
    let mut holes = Vec::new();
    if base_holes {
        small.note(r);
        small.note(ex);
        small.note(ey);
        if m > 1 {
            small.note(gy);
        }
        for &x0 in &stretches {
            for k in 0..m {
                let y = ey + r + k * (2 * r + gy) + a0;
                let ends = (draw_end(rng, t), draw_end(rng, t));
                holes.push(vertical_hole(r, x0 + ex + r, y, 0, tb, ends));
            }
        }
    }
    if up_hole && core >= 2 * r2 + 2 * t {
        small.note(r2);
        small.note(ez);
        small.note((core - 2 * r2) / 2);
        let x0 = uprights[0];
        let over = match draw_end(rng, t) {
            End::Flush => 0,
            End::Over(o) => o,
        };
        let cyl = Solid::Cylinder {
            r: len(r2),
            h: len(tu + 2 * over),
        };
        let turned = rotate(cyl, DVec3::Y, Angle::of_pi(1, 2));
        holes.push(translate(
            turned,
            DVec3::new(len(x0 + tu / 2), len(a0 + core / 2), len(tb + ez + r2)),
        ));
    }
    let n_holes = holes.len();
    let body = Solid::Union(solids);
    let solid = if holes.is_empty() {
        body
    } else {
        let mut v = vec![body];
        v.extend(holes);
        Solid::Difference(v)
    };
    Part {
        class: Class::Bracket,
        what: format!(
            "{} bracket {}×{}, base {}, upright {} to {}{}, {n_holes} holes",
            ["L", "T", "U"][kind as usize],
            len(w),
            len(d),
            len(tb),
            len(tu),
            len(h),
            if a0 + a1 == 0 {
                " (full depth)"
            } else {
                " (inset)"
            }
        ),
        solid,
        feature: small.get(),
        euler: Some(2 - 2 * n_holes as i64),
        components: Some(1),
        scatter: None,
    }
}

/// A box of lengths in units: lo, hi.
type Block = ([i64; 3], [i64; 3]);

/// The distance between two blocks along the axis where they are furthest apart (0 if they
/// touch or overlap).
fn block_gap(a: &Block, b: &Block) -> i64 {
    (0..3)
        .map(|k| (b.0[k] - a.1[k]).max(a.0[k] - b.1[k]))
        .max()
        .unwrap_or(0)
        .max(0)
}

/// Two to four blocks, each on (or beside) the one before, sharing a face or sunk into it,
/// its sides flush with the one below, inset or overhanging by at least t. Any two face
/// planes of one direction are flush or at least t apart, and blocks that are not neighbours
/// in the chain are at least t apart: the chain is one solid without handles (χ = 2).
fn stacked(rng: &mut Rng, t: i64) -> Part {
    'draw: loop {
        let mut blocks: Vec<Block> = vec![(
            [0, 0, 0],
            [size(rng, t, 10.0), size(rng, t, 10.0), size(rng, t, 6.0)],
        )];
        let n = int(rng, 2, 4) as usize;
        let mut sunk = 0;
        'block: while blocks.len() < n {
            for _ in 0..40 {
                let prev = *blocks.last().expect("a block");
                let axis = match int(rng, 0, 9) {
                    0..=5 => 2,
                    6..=8 => 0,
                    _ => 1,
                };
                let mut lo = [0; 3];
                let mut hi = [0; 3];
                for a in (0..3).filter(|&a| a != axis) {
                    let mut side = || match int(rng, 0, 4) {
                        0 | 1 => 0,
                        2 | 3 => size(rng, t, 3.0),
                        _ => -size(rng, t, 3.0),
                    };
                    lo[a] = prev.0[a] + side();
                    hi[a] = prev.1[a] - side();
                }
                let contact = if chance(rng, 0.75) {
                    0
                } else {
                    size(rng, t, 3.0)
                };
                lo[axis] = prev.1[axis] - contact;
                hi[axis] = prev.1[axis] + size(rng, t, 6.0);
                let block = (lo, hi);
                let ok = (0..3).all(|a| hi[a] - lo[a] >= t)
                    && (0..3)
                        .filter(|&a| a != axis)
                        .all(|a| hi[a].min(prev.1[a]) - lo[a].max(prev.0[a]) >= t)
                    && prev.1[axis] - lo[axis] <= prev.1[axis] - prev.0[axis] - t
                    && blocks[..blocks.len() - 1]
                        .iter()
                        .all(|b| block_gap(b, &block) >= t)
                    && blocks.iter().all(|b| {
                        (0..3).all(|a| {
                            [b.0[a], b.1[a]].iter().all(|&p| {
                                [lo[a], hi[a]].iter().all(|&q| p == q || (p - q).abs() >= t)
                            })
                        })
                    });
                if ok {
                    sunk += (contact > 0) as usize;
                    blocks.push(block);
                    continue 'block;
                }
            }
            continue 'draw;
        }
        let mut small = Smallest::new();
        for b in &blocks {
            for a in 0..3 {
                small.note(b.1[a] - b.0[a]);
            }
        }
        for a in 0..3 {
            let mut planes: Vec<i64> = blocks.iter().flat_map(|b| [b.0[a], b.1[a]]).collect();
            planes.sort();
            for w in planes.windows(2) {
                small.note_gap(w[1] - w[0]);
            }
        }
        return Part {
            class: Class::Stacked,
            what: format!(
                "{} blocks in a chain, {sunk} sunk into the one before",
                blocks.len()
            ),
            solid: Solid::Union(blocks.iter().map(|b| cuboid(b.0, b.1)).collect()),
            feature: small.get(),
            euler: Some(2),
            components: Some(1),
            scatter: None,
        };
    }
}

/// A plate with a row of bosses (standing flush on its top face, sunk into it, or running
/// down to its bottom face; some bored through) and ribs (thin boxes standing on it, some
/// running its full depth, flush with its sides).
fn boss_rib(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let thick = size(rng, t, 3.0);
    small.note(thick);
    let n = int(rng, 1, 4);
    enum Item {
        Boss {
            r: i64,
            h: i64,
            base: i64,
            bore: Option<(i64, End, End)>,
        },
        Rib {
            w: i64,
            l: i64,
            h: i64,
            full: bool,
        },
    }
    let mut items = Vec::new();
    for _ in 0..n {
        let h = size(rng, t, 6.0);
        small.note(h);
        if chance(rng, 0.5) {
            let bore = chance(rng, 0.4).then(|| {
                let rb = size(rng, t, 2.0);
                (rb, draw_end(rng, t), draw_end(rng, t))
            });
            let r = match bore {
                Some((rb, ..)) => {
                    let wall = size(rng, t, 2.0);
                    small.note(rb);
                    small.note(wall);
                    rb + wall
                }
                None => size(rng, t, 3.0),
            };
            small.note(r);
            // Where the boss starts: on the top face, sunk into the plate, or at its bottom.
            let base = match int(rng, 0, 2) {
                0 if thick >= 2 * t => {
                    let e = size(rng, t, (thick - t) as f64 / t as f64);
                    small.note(e);
                    small.note(thick - e);
                    thick - e
                }
                1 => 0,
                _ => thick,
            };
            items.push(Item::Boss { r, h, base, bore });
        } else {
            let w = size(rng, t, 2.0);
            small.note(w);
            items.push(Item::Rib {
                w,
                l: size(rng, t, 12.0),
                h,
                full: chance(rng, 0.4),
            });
        }
    }
    // The depth: the widest item and margins of at least t on both sides.
    let ym = size(rng, t, 3.0);
    let widest = items
        .iter()
        .map(|i| match i {
            Item::Boss { r, .. } => 2 * r,
            Item::Rib { l, full: false, .. } => *l,
            Item::Rib { .. } => 0,
        })
        .max()
        .unwrap_or(0)
        .max(t);
    let d = widest + 2 * ym;
    // Along x: a margin, the items with gaps of at least t, a margin (0 beside a rib that
    // ends flush with the plate's side).
    let mut x = size(rng, t, 3.0);
    let mut solids = Vec::new();
    let mut bores = Vec::new();
    for (k, item) in items.iter().enumerate() {
        if k > 0 {
            let g = size(rng, t, 4.0);
            small.note(g);
            x += g;
        } else {
            small.note(x);
        }
        match *item {
            Item::Boss { r, h, base, bore } => {
                small.note((d - 2 * r) / 2);
                let (cx, cy) = (x + r, d / 2);
                let top = thick + h;
                solids.push(post(r, cx, cy, base, top - base));
                if let Some((rb, bottom, upper)) = bore {
                    bores.push(vertical_hole(rb, cx, cy, 0, top, (bottom, upper)));
                }
                x += 2 * r;
            }
            Item::Rib { w, l, h, full } => {
                let (y0, y1) = if full {
                    (0, d)
                } else {
                    ((d - l) / 2, (d + l) / 2)
                };
                small.note(y1 - y0);
                small.note_gap(y0);
                solids.push(cuboid([x, y0, thick], [x + w, y1, thick + h]));
                x += w;
            }
        }
    }
    let end = size(rng, t, 3.0);
    small.note(end);
    let w = x + end;
    let mut all = vec![cuboid([0, 0, 0], [w, d, thick])];
    all.extend(solids);
    let n_bores = bores.len();
    let body = Solid::Union(all);
    let solid = if bores.is_empty() {
        body
    } else {
        let mut v = vec![body];
        v.extend(bores);
        Solid::Difference(v)
    };
    let (bosses, ribs) = items.iter().fold((0, 0), |(b, r), i| match i {
        Item::Boss { .. } => (b + 1, r),
        Item::Rib { .. } => (b, r + 1),
    });
    Part {
        class: Class::BossRib,
        what: format!(
            "plate {}×{}×{} with {bosses} bosses ({n_bores} bored) and {ribs} ribs",
            len(w),
            len(d),
            len(thick)
        ),
        solid,
        feature: small.get(),
        euler: Some(2 - 2 * n_bores as i64),
        components: Some(1),
        scatter: None,
    }
}

/// Fillets and rounds: `smooth_union` of an L or T of flush boxes or of a plate and a boss
/// standing on it; `offset` of a box, of an L of boxes, or of a plate with a boss.
fn fillet(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let variant = int(rng, 0, 5);
    let rf = size(rng, t, 2.0);
    small.note(rf);
    let tb = size(rng, t, 3.0);
    let tu = size(rng, t, 3.0);
    let d = size(rng, t, 8.0);
    small.note(tb);
    // Stretches beside a fillet leave at least t of flat face.
    let stretch = |rng: &mut Rng| size(rng, t, 8.0) + rf;
    let (what, solid) = match variant {
        0 | 1 => {
            small.note(tu);
            small.note(d);
            let rise = stretch(rng);
            small.note(rise);
            let a = if variant == 0 { 0 } else { stretch(rng) };
            let b = stretch(rng);
            small.note_gap(a);
            small.note(b);
            let w = a + tu + b;
            let base = cuboid([0, 0, 0], [w, d, tb]);
            let web = cuboid([a, 0, 0], [a + tu, d, tb + rise]);
            (
                format!(
                    "{} of flush boxes {}×{}, smooth_union radius {}",
                    if variant == 0 { "L" } else { "T" },
                    len(w),
                    len(d),
                    len(rf)
                ),
                Solid::SmoothUnion(Box::new(base), Box::new(web), len(rf)),
            )
        }
        2 => {
            let r = size(rng, t, 3.0);
            let h = size(rng, t, 6.0);
            let m = stretch(rng);
            small.note(r);
            small.note(h);
            small.note(m);
            let side = 2 * (m + r);
            let plate = cuboid([0, 0, 0], [side, side + d - t, tb]);
            let boss = post(r, m + r, m + r, tb, h);
            (
                format!(
                    "plate and boss of radius {}, smooth_union radius {}",
                    len(r),
                    len(rf)
                ),
                Solid::SmoothUnion(Box::new(plate), Box::new(boss), len(rf)),
            )
        }
        3 => {
            let (a, b) = (size(rng, t, 10.0), size(rng, t, 10.0));
            small.note(a);
            small.note(b);
            (
                format!(
                    "box {}×{}×{} offset by {}",
                    len(a),
                    len(b),
                    len(tb),
                    len(rf)
                ),
                Solid::Offset(Box::new(cuboid([0, 0, 0], [a, b, tb])), len(rf)),
            )
        }
        4 => {
            let (free, rise) = (size(rng, t, 10.0), size(rng, t, 10.0));
            small.note(tu);
            small.note(d);
            small.note(free);
            small.note(rise);
            let base = cuboid([0, 0, 0], [tu + free, d, tb]);
            let web = cuboid([0, 0, 0], [tu, d, tb + rise]);
            (
                format!("L of boxes offset by {}", len(rf)),
                Solid::Offset(Box::new(Solid::Union(vec![base, web])), len(rf)),
            )
        }
        _ => {
            let r = size(rng, t, 3.0);
            let h = size(rng, t, 6.0);
            let m = size(rng, t, 4.0);
            small.note(r);
            small.note(h);
            small.note(m);
            let side = 2 * (m + r);
            let plate = cuboid([0, 0, 0], [side, side, tb]);
            let boss = post(r, m + r, m + r, tb, h);
            (
                format!("plate and boss of radius {} offset by {}", len(r), len(rf)),
                Solid::Offset(Box::new(Solid::Union(vec![plate, boss])), len(rf)),
            )
        }
    };
    Part {
        class: Class::Fillet,
        what,
        solid,
        feature: small.get(),
        euler: Some(2),
        components: Some(1),
        scatter: None,
    }
}

/// Axes a user might turn about.
const AXES: [[f64; 3]; 10] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 0.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [1.0, 1.0, 1.0],
    [1.0, 2.0, 0.0],
    [2.0, 1.0, 1.0],
    [1.0, 2.0, 3.0],
];

/// One primitive of a scatter: its shape in its own frame, turned, then moved.
#[derive(Clone, Debug)]
struct Placed {
    shape: Solid,
    turn: Option<(DVec3, Angle)>,
    at: DVec3,
}

impl Placed {
    fn solid(&self) -> Solid {
        let s = match &self.turn {
            Some((axis, angle)) => rotate(self.shape.clone(), *axis, angle.clone()),
            None => self.shape.clone(),
        };
        translate(s, self.at)
    }

    /// The inverse turn (world → frame), rows.
    fn inverse(&self) -> [[f64; 3]; 3] {
        match &self.turn {
            Some((axis, angle)) => rotation(*axis, -angle.value),
            None => rotation(DVec3::Z, 0.0),
        }
    }

    fn forward(&self) -> [[f64; 3]; 3] {
        match &self.turn {
            Some((axis, angle)) => rotation(*axis, angle.value),
            None => rotation(DVec3::Z, 0.0),
        }
    }

    fn distance(&self, p: DVec3) -> f64 {
        self.shape.distance(apply(&self.inverse(), p - self.at))
    }

    /// Points of the surface about `spacing` apart.
    fn samples(&self, spacing: f64) -> Vec<DVec3> {
        let steps = |l: f64| ((l / spacing).ceil() as usize).max(4);
        let mut local = Vec::new();
        let ring = |local: &mut Vec<DVec3>, rho: f64, z: f64| {
            let n = steps(TAU * rho);
            for i in 0..n {
                let u = TAU * i as f64 / n as f64;
                local.push(DVec3::new(rho * u.cos(), rho * u.sin(), z));
            }
        };
        match self.shape {
            Solid::Sphere { r } => {
                let nt = steps(PI * r);
                for i in 0..=nt {
                    let th = PI * i as f64 / nt as f64;
                    ring(&mut local, r * th.sin(), r * th.cos());
                }
            }
            Solid::Torus { big, small } => {
                let nv = steps(TAU * small);
                for j in 0..nv {
                    let v = TAU * j as f64 / nv as f64;
                    ring(&mut local, big + small * v.cos(), small * v.sin());
                }
            }
            Solid::Cylinder { r, h } => {
                let nz = steps(h);
                for j in 0..=nz {
                    ring(&mut local, r, h * (j as f64 / nz as f64 - 0.5));
                }
                let nr = steps(r);
                for i in 0..=nr {
                    let rho = r * i as f64 / nr as f64;
                    ring(&mut local, rho, 0.5 * h);
                    ring(&mut local, rho, -0.5 * h);
                }
            }
            Solid::Box { lo, hi } => {
                for k in 0..3 {
                    let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                    let (na, nb) = (steps(hi[a] - lo[a]), steps(hi[b] - lo[b]));
                    for side in [lo[k], hi[k]] {
                        for i in 0..=na {
                            for j in 0..=nb {
                                let mut q = DVec3::ZERO;
                                q[k] = side;
                                q[a] = lo[a] + (hi[a] - lo[a]) * i as f64 / na as f64;
                                q[b] = lo[b] + (hi[b] - lo[b]) * j as f64 / nb as f64;
                                local.push(q);
                            }
                        }
                    }
                }
            }
            _ => unreachable!("scatters are of primitives"),
        }
        let m = self.forward();
        local.into_iter().map(|q| self.at + apply(&m, q)).collect()
    }

    /// The primitive as a `common::csg` primitive (same zero set): frame X = turn·(p − c).
    fn csg(&self) -> csg::Primitive {
        let m = self.inverse();
        let turn = DMat3::from_cols_array_2d(&m).transpose();
        let (shape, centre) = match self.shape {
            Solid::Sphere { r } => (csg::Shape::Sphere { r }, self.at),
            Solid::Torus { big, small } => (csg::Shape::Torus { big, small }, self.at),
            Solid::Cylinder { r, h } => (csg::Shape::Cylinder { r, h: 0.5 * h }, self.at),
            Solid::Box { lo, hi } => (
                csg::Shape::Box {
                    half: 0.5 * (hi - lo),
                },
                self.at + apply(&self.forward(), 0.5 * (lo + hi)),
            ),
            _ => unreachable!("scatters are of primitives"),
        };
        csg::Primitive {
            shape,
            centre,
            turn,
        }
    }

    /// A radius about `at` that holds the primitive.
    fn reach(&self) -> f64 {
        match self.shape {
            Solid::Sphere { r } => r,
            Solid::Torus { big, small } => big + small,
            Solid::Cylinder { r, h } => r.hypot(0.5 * h),
            Solid::Box { lo, hi } => lo.length().max(hi.length()),
            _ => unreachable!("scatters are of primitives"),
        }
    }
}

/// How two primitives of a scatter lie: `Some(true)` overlapping by at least `t` both ways
/// (each reaches at least t into the other and sticks out of it by at least t) and nowhere
/// grazing, `Some(false)` at least `t` apart, None otherwise (a thin neck, a sliver, a
/// narrow gap, a kiss).
fn relation(a: &Placed, b: &Placed, t: f64) -> Option<bool> {
    let extremes = |from: &Placed, into: &Placed| {
        from.samples(0.5 * t)
            .into_iter()
            .map(|p| into.distance(p))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                (lo.min(d), hi.max(d))
            })
    };
    let (ab_lo, ab_hi) = extremes(b, a);
    let (ba_lo, ba_hi) = extremes(a, b);
    if ab_lo >= t && ba_lo >= t {
        return Some(false);
    }
    let deep = ab_lo <= -t && ab_hi >= t && ba_lo <= -t && ba_hi >= t;
    (deep && !grazing(a, b, t) && !grazing(b, a, t)).then_some(true)
}

/// Whether `a`'s surface comes near `b`'s in a way that makes a feature smaller than `t`:
/// within t/4 of it at less than 30° (a near-tangent contact: two tori kissing where they
/// also overlap elsewhere), or outside it within t and parallel to it within 30° (a thin gap
/// between them, or a thin layer of `a` over `b`). Looked at on all of `a`, not only where
/// the union's surface passes: `csg::Tree::degenerate` asks for a sign change across a
/// piece within its reach, which a kiss thinner than the reach does not show.
fn grazing(a: &Placed, b: &Placed, t: f64) -> bool {
    let gradient = |s: &Placed, p: DVec3| {
        let e = 1e-6 * t;
        DVec3::new(
            s.distance(p + DVec3::X * e) - s.distance(p - DVec3::X * e),
            s.distance(p + DVec3::Y * e) - s.distance(p - DVec3::Y * e),
            s.distance(p + DVec3::Z * e) - s.distance(p - DVec3::Z * e),
        ) / (2.0 * e)
    };
    a.samples(0.25 * t).into_iter().any(|p| {
        let d = b.distance(p);
        if d.abs() >= t {
            return false;
        }
        // On an edge of a box or a cylinder a has no normal (its distance's gradient is
        // shorter there); its faces on both sides are sampled.
        let na = gradient(a, p);
        if na.length() < 0.99 {
            return false;
        }
        let (na, nb) = (na.normalize(), gradient(b, p).normalize());
        let sine = na.cross(nb).length();
        (d.abs() < 0.25 * t && sine < 0.5) || (d > 0.0 && na.dot(nb).abs() > 0.87)
    })
}

/// Three to six primitives, each overlapping one before it, turned about a random axis or
/// not, every size at least 2t (a cylinder's radius and a torus's tube at least t), every
/// two overlapping by at least t both ways or t apart, and the whole in general position
/// (`csg::Tree::degenerate`: within t/2 of each other, pieces meet at 30° or more, no three
/// normals flatter than |det| 0.2, no four pieces; and `grazing`): drawn again otherwise.
fn scatter(rng: &mut Rng, t: i64) -> Part {
    let tf = len(t);
    loop {
        let n = int(rng, 3, 6) as usize;
        let mut placed: Vec<Placed> = Vec::new();
        let mut tries = 0;
        while placed.len() < n && tries < 200 {
            tries += 1;
            let shape = match int(rng, 0, 5) {
                0 => Solid::Sphere {
                    r: len(size(rng, 2 * t, 2.5)),
                },
                1 | 2 => {
                    let s = [
                        size(rng, 2 * t, 4.0),
                        size(rng, 2 * t, 4.0),
                        size(rng, 2 * t, 4.0),
                    ];
                    let lo = s.map(|v| -(v / 2));
                    let hi = [s[0] + lo[0], s[1] + lo[1], s[2] + lo[2]];
                    cuboid(lo, hi)
                }
                3 | 4 => Solid::Cylinder {
                    r: len(size(rng, t, 3.0)),
                    h: len(size(rng, 2 * t, 4.0)),
                },
                _ => {
                    let small = size(rng, t, 2.0);
                    Solid::Torus {
                        big: len(small + size(rng, 2 * t, 2.0)),
                        small: len(small),
                    }
                }
            };
            let turn = chance(rng, 0.6).then(|| {
                let a = AXES[int(rng, 0, AXES.len() as i64 - 1) as usize];
                (
                    DVec3::from_array(a),
                    Angle::radians(decimal(rng.range(0.1, 3.0), 2)),
                )
            });
            let at = match placed.len() {
                0 => DVec3::ZERO,
                k => {
                    let parent = &placed[int(rng, 0, k as i64 - 1) as usize];
                    let dir = rng.direction();
                    let c = parent.at + dir * parent.reach() * rng.range(0.5, 1.0);
                    DVec3::from_array(c.to_array().map(|v| decimal(v, 2)))
                }
            };
            let candidate = Placed { shape, turn, at };
            let relations: Vec<Option<bool>> =
                placed.iter().map(|p| relation(p, &candidate, tf)).collect();
            let joined = placed.is_empty() || relations.contains(&Some(true));
            if relations.iter().any(Option::is_none) || !joined {
                continue;
            }
            placed.push(candidate);
        }
        if placed.len() < n {
            continue;
        }
        let tree = placed
            .iter()
            .map(|p| csg::Tree::Leaf(p.csg()))
            .reduce(|a, b| csg::Tree::Min(Box::new(a), Box::new(b)))
            .expect("primitives");
        let general = csg::GeneralPosition {
            reach: 0.5 * tf,
            spacing: 0.25 * tf,
            min_sine: 0.5,
            min_det: 0.2,
        };
        if tree.degenerate(&general).is_some() {
            continue;
        }
        let names: Vec<&str> = placed
            .iter()
            .map(|p| match p.shape {
                Solid::Sphere { .. } => "sphere",
                Solid::Box { .. } => "box",
                Solid::Cylinder { .. } => "cylinder",
                _ => "torus",
            })
            .collect();
        return Part {
            class: Class::Scatter,
            what: format!("union of {}", names.join(", ")),
            solid: Solid::Union(placed.iter().map(Placed::solid).collect()),
            feature: tf,
            euler: None,
            components: Some(1),
            scatter: Some(tree),
        };
    }
}

/// A flange: a disc and a hub standing on the same face (flush), a bore through the hub, a
/// bolt circle of n holes (one hole turned n times: `rotate(…, angle: tau * k / n)`), and
/// ribs between the holes from the hub to near the rim, flush on the disc (turned copies too).
fn flange(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let rb = size(rng, t, 2.0);
    let wall = size(rng, t, 3.0);
    let rh = rb + wall;
    let r = size(rng, t, 1.5);
    let n = int(rng, 3, 8);
    let s = (PI / n as f64).sin();
    // Bolt circle radius: clear of the hub by at least t, the holes at least t apart.
    let mut rbc = rh + size(rng, t, 3.0) + r;
    let needed = ((len(t + 2 * r) / (2.0 * s)) * PER / 4.0).ceil() as i64 * 4;
    rbc = rbc.max(needed);
    let rim = size(rng, t, 3.0);
    let big = rbc + r + rim;
    let thick = size(rng, t, 3.0);
    let h = thick + size(rng, t, 6.0);
    for u in [rb, wall, r, rbc - r - rh, rim, thick, h - thick] {
        small.note(u);
    }
    let chord = 2.0 * len(rbc) * s - 2.0 * len(r);
    let mut feature = small.get().min(chord);
    let disc = post(big, 0, 0, 0, thick);
    let hub = post(rh, 0, 0, 0, h);
    let mut body = vec![disc, hub];
    // Ribs: between the holes, clear of them by t, from inside the hub wall to near the rim.
    let w = size(rng, t, 2.0);
    let x_in = ((rb + rh) / 8) * 4;
    let x_out = big - size(rng, t, 2.0);
    let clear = len(rbc) * s - len(r) - 0.5 * len(w);
    let corner_in = len(x_in).hypot(0.5 * len(w));
    let corner_out = len(x_out).hypot(0.5 * len(w));
    let ribs = chance(rng, 0.5)
        && clear >= len(t)
        && x_in - rb >= t
        && len(rh) - corner_in >= len(t)
        && len(big) - corner_out >= len(t);
    if ribs {
        let mut hr = if chance(rng, 0.3) {
            h - thick
        } else {
            size(rng, t, 4.0).min(h - thick)
        };
        if h - thick - hr < t {
            hr = h - thick;
        }
        small.note(hr);
        small.note(w);
        small.note(x_in - rb);
        small.note_gap(h - thick - hr);
        feature = small
            .get()
            .min(chord)
            .min(clear)
            .min(len(rh) - corner_in)
            .min(len(big) - corner_out);
        for k in 0..n {
            let rib = cuboid([x_in, -(w / 2), thick], [x_out, w - w / 2, thick + hr]);
            body.push(rotate(rib, DVec3::Z, Angle::of_tau(2 * k + 1, 2 * n)));
        }
    }
    let ends = (draw_end(rng, t), draw_end(rng, t));
    let mut parts = vec![Solid::Union(body), vertical_hole(rb, 0, 0, 0, h, ends)];
    let hole_ends = (draw_end(rng, t), draw_end(rng, t));
    for k in 0..n {
        let hole = vertical_hole(r, rbc, 0, 0, thick, hole_ends);
        parts.push(if k == 0 {
            hole
        } else {
            rotate(hole, DVec3::Z, Angle::of_tau(k, n))
        });
    }
    Part {
        class: Class::Flange,
        what: format!(
            "flange of radius {}, hub {}, bore {}, {n} holes of radius {} at {}{}",
            len(big),
            len(rh),
            len(rb),
            len(r),
            len(rbc),
            if ribs { ", ribs" } else { "" }
        ),
        solid: Solid::Difference(parts),
        feature,
        euler: Some(2 - 2 * (n + 1)),
        components: Some(1),
        scatter: None,
    }
}

/// Rods crossing on a grid of nodes: along x and y (a grate) or along x, y and z (a 3D
/// lattice), of one radius or of radii at least t apart, reaching past the last nodes. The
/// solid is a thickened graph: χ(solid) = nodes − rod segments between nodes.
fn lattice(rng: &mut Rng, t: i64) -> Part {
    let mut small = Smallest::new();
    let (nx, ny, nz) = (int(rng, 2, 4), int(rng, 2, 4), int(rng, 1, 3));
    // One radius, or two at least t apart (equal rods cross tangentially at two points of
    // each node, as users draw them).
    let r = size(rng, t, 2.0);
    let thick = r + size(rng, t, 2.0);
    let radii = match int(rng, 0, 3) {
        0 | 1 => [r, r, r],
        2 => [r, thick, r],
        _ => [r, thick, thick],
    };
    for a in 0..3 {
        small.note(radii[a]);
        for b in 0..a {
            small.note_gap((radii[a] - radii[b]).abs());
        }
    }
    let rmax = radii.into_iter().max().unwrap_or(r);
    let gap = size(rng, t, 4.0);
    let pitch = 2 * rmax + gap;
    let over = rmax + size(rng, t, 3.0);
    small.note(gap);
    small.note(over - rmax);
    let counts = [nx, ny, nz];
    let mut rods = Vec::new();
    for axis in 0..3 {
        if axis == 2 && nz == 1 {
            continue;
        }
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let length = (counts[axis] - 1) * pitch + 2 * over;
        for i in 0..counts[a] {
            for j in 0..counts[b] {
                let mut c = [0i64; 3];
                c[axis] = (counts[axis] - 1) * pitch / 2;
                c[a] = i * pitch;
                c[b] = j * pitch;
                let rod = Solid::Cylinder {
                    r: len(radii[axis]),
                    h: len(length),
                };
                let rod = match axis {
                    0 => rotate(rod, DVec3::Y, Angle::of_pi(1, 2)),
                    1 => rotate(rod, DVec3::X, Angle::of_pi(1, 2)),
                    _ => rod,
                };
                rods.push(translate(rod, DVec3::from_array(c.map(len))));
            }
        }
    }
    let nodes = nx * ny * nz;
    let segments =
        (nx - 1) * ny * nz + nx * (ny - 1) * nz + if nz > 1 { nx * ny * (nz - 1) } else { 0 };
    Part {
        class: Class::Lattice,
        what: format!(
            "{nx}×{ny}×{nz} lattice of rods of radius {}, pitch {}",
            if radii[0] == radii[1] && radii[1] == radii[2] {
                num(len(r))
            } else {
                format!("{}/{}/{}", len(radii[0]), len(radii[1]), len(radii[2]))
            },
            len(pitch)
        ),
        solid: Solid::Union(rods),
        feature: small.get(),
        euler: Some(2 * (nodes - segments)),
        components: Some(1),
        scatter: None,
    }
}

/// A part of another class turned about a random axis (a quarter turn about a coordinate
/// axis in one case of three, where coincident faces stay exactly coincident) and moved.
fn rotated(rng: &mut Rng) -> Part {
    let classes = [
        Class::Plate,
        Class::Bracket,
        Class::Stacked,
        Class::BossRib,
        Class::Fillet,
        Class::Flange,
        Class::Lattice,
    ];
    let class = classes[int(rng, 0, classes.len() as i64 - 1) as usize];
    let base = generate(class, rng);
    let (axis, angle) = if chance(rng, 0.33) {
        (
            DVec3::from_array(AXES[int(rng, 0, 2) as usize]),
            Angle::of_pi(1, 2),
        )
    } else {
        (
            DVec3::from_array(AXES[int(rng, 0, AXES.len() as i64 - 1) as usize]),
            Angle::radians(decimal(rng.range(0.1, 3.0), 2)),
        )
    };
    let by = DVec3::from_array([0; 3].map(|_| decimal(rng.range(-1.0, 1.0), 2)));
    Part {
        class: Class::Rotated,
        what: format!(
            "{} ({}) turned by {} about {} and moved by {}",
            base.what,
            class.name(),
            angle.text,
            point(axis),
            point(by)
        ),
        solid: base.solid.moved(axis, angle, by),
        ..base
    }
}

// ---------------------------------------------------------------------------------------------
// The reference.

/// What the voxel grids say of a part's solid.
#[derive(Clone, Debug)]
pub struct Reference {
    /// χ of the bounding surface: 2·χ(solid).
    pub euler: i64,
    /// Components of the bounding surface: solid components plus cavities.
    pub components: usize,
    /// The voxel of the grid the figures below come from.
    pub voxel: f64,
    /// The extent of the grid's inside vertices: the solid's to within a voxel.
    pub lo: DVec3,
    pub hi: DVec3,
    /// Inside vertices times a voxel's volume.
    pub volume: f64,
    /// Grid vertices within a voxel of the surface (|f|/|∇f| < voxel) times voxel²/2: the
    /// surface's area from the volume of its shell of two voxels.
    pub area: f64,
    /// Whether the grids sampled the solid with its creases rounded (scatters).
    pub rounded: bool,
}

/// The most vertices a reference grid may have.
const MAX_GRID: usize = 40_000_000;

/// Counts the part's solid on grids of a quarter of its smallest feature and finer (8/11
/// and 4/7 of it), each at an irrational shift so that no grid vertex lies on a face the text
/// puts at a decimal place. A grid is trusted when both ways of reading it agree
/// (`voxel::two_readings_on`, crumbs of fewer than 27 vertices dropped); the reference is two
/// trusted grids that agree, and, where the construction knows the topology, agree with it.
/// Scatters are sampled with their creases rounded to two voxels (`csg::Tree::rounded`): in
/// general position the same topology, and no wedge tip thinner than the grid; as rounding
/// fills concave wedges (and could close a tunnel that general position let through), all
/// three grids must agree for them. Err says why there is no reference.
pub fn reference(part: &Part) -> Result<Reference, String> {
    let (blo, bhi) = part.solid.bounds();
    let voxel = part.feature / 4.0;
    let grids = [
        (voxel, DVec3::new(0.381_966_01, 0.577_215_66, 0.141_421_36)),
        (
            voxel * 8.0 / 11.0,
            DVec3::new(0.414_213_56, 0.732_050_81, 0.236_067_98),
        ),
        (
            voxel * 4.0 / 7.0,
            DVec3::new(0.645_751_31, 0.162_277_66, 0.605_551_28),
        ),
    ];
    let mut trusted: Vec<(Lattice, SolidCount, (i64, usize))> = Vec::new();
    let mut agreed = None;
    // Rounding fills concave wedges, which could close a thin tunnel that the general
    // position test let through: a rounded reference must agree at all three resolutions
    // (its rounding radius changes with them).
    let needed = if part.scatter.is_some() { 3 } else { 2 };
    let mut why = Vec::new();
    for (h, shift) in grids {
        let origin = blo - DVec3::splat(2.0 * h) - shift * h;
        let cells = ((bhi - blo) / h).to_array().map(|c| c.ceil() as usize + 5);
        let lattice = Lattice::cubic(origin, h, cells);
        if lattice.vertices() > MAX_GRID {
            why.push(format!("grid {h:.4}: {} vertices", lattice.vertices()));
            continue;
        }
        let f = |p: DVec3| match &part.scatter {
            Some(tree) => tree.rounded(p, 2.0 * h),
            None => part.value(p),
        };
        let (solid, outside) = two_readings_on(f, &lattice, 27);
        let inside_reading = (
            solid.surface_euler(),
            (solid.components + solid.outside_components).saturating_sub(1),
        );
        let outside_reading = (
            2 * (outside.euler - 1),
            (outside.outside_components + outside.components).saturating_sub(1),
        );
        if solid.touches_box {
            why.push(format!("grid {h:.4}: the solid reaches the grid's faces"));
            continue;
        }
        if inside_reading != outside_reading {
            why.push(format!(
                "grid {h:.4}: the readings disagree ({inside_reading:?} and {outside_reading:?})"
            ));
            continue;
        }
        // Enough trusted grids that agree: the finest one's figures.
        trusted.push((lattice, solid, inside_reading));
        if trusted.iter().filter(|g| g.2 == inside_reading).count() >= needed {
            agreed = trusted.pop();
            break;
        }
    }
    let Some((lattice, solid, (euler, components))) = agreed else {
        let seen: Vec<String> = trusted.iter().map(|g| format!("{:?}", g.2)).collect();
        why.push(format!(
            "trusted grids (χ, components): {}",
            seen.join(", ")
        ));
        return Err(format!("no two grids agree: {}", why.join("; ")));
    };
    if part.euler.is_some_and(|e| e != euler) || part.components.is_some_and(|c| c != components) {
        return Err(format!(
            "the grids (χ {euler}, {components} components) disagree with the construction \
             (χ {:?}, {:?} components)",
            part.euler, part.components
        ));
    }
    let h = lattice.spacing.x;
    let (ilo, ihi) = solid.inside.expect("the grids saw the solid");
    // The area on a grid of its own, finer than the topology's where the part is large
    // against its smallest feature: the estimate's error is of the order of the spacing
    // times the length of the edges (a quarter of the feature would be a few per cent).
    let area_h = h.min((bhi - blo).length() / 200.0);
    let area_cells = ((bhi - blo) / area_h)
        .to_array()
        .map(|c| c.ceil() as usize + 5);
    let area = shell_area(
        part,
        &Lattice::cubic(
            blo - DVec3::splat(2.0 * area_h) - 0.3 * area_h,
            area_h,
            area_cells,
        ),
    );
    Ok(Reference {
        euler,
        components,
        voxel: h,
        lo: lattice.point(ilo[0], ilo[1], ilo[2]),
        hi: lattice.point(ihi[0], ihi[1], ihi[2]),
        volume: solid.inside_vertices as f64 * h.powi(3),
        area,
        rounded: part.scatter.is_some(),
    })
}

/// The area of the part's surface from the grid vertices of `lattice` near it: each vertex
/// at distance d < h (projected onto f = 0 along ∇f, by central differences) weighs the hat
/// 1 − d/h, and the weights times h² sum to the area. Along a face's normal the hats of
/// the grid planes sum to one whatever the face's offset from them (a count of the vertices
/// within h would see one or two planes of a face parallel to the grid, ±50 %).
/// Only where the surface is one between inside and outside: among the vertex and its 26
/// neighbours (±h along each axis) one is inside and one outside, as a plane nearer than h
/// always separates two of them. A hole flush with a face leaves f = 0 on the disk across
/// its mouth (max(plate, −cylinder) with both 0 there) with f ≥ 0 on either side, a zero
/// set that is not the solid's surface and is left out but for a band of about h at its
/// rim.
fn shell_area(part: &Part, lattice: &Lattice) -> f64 {
    let h = lattice.spacing.x;
    let e = 1e-3 * h;
    let mut weight = 0.0;
    for k in 0..=lattice.cells[2] {
        for j in 0..=lattice.cells[1] {
            for i in 0..=lattice.cells[0] {
                let p = lattice.point(i, j, k);
                let v = part.value(p);
                if v.abs() >= 2.0 * h {
                    continue;
                }
                let grad = |q: DVec3| {
                    DVec3::new(
                        part.value(q + DVec3::X * e) - part.value(q - DVec3::X * e),
                        part.value(q + DVec3::Y * e) - part.value(q - DVec3::Y * e),
                        part.value(q + DVec3::Z * e) - part.value(q - DVec3::Z * e),
                    ) / (2.0 * e)
                };
                let g = grad(p);
                if v.abs() >= h * g.length() {
                    continue;
                }
                // The distance to f = 0 by a few projections along ∇f: |f|/|∇f| of a box's
                // max is the distance to the nearest face plane, short of the distance to
                // an edge beyond it (a square around a convex edge instead of a quarter
                // disk, an excess of about h per length of edge).
                let mut q = p;
                let mut fq = v;
                for _ in 0..4 {
                    let gq = grad(q);
                    if fq == 0.0 || gq.length() == 0.0 {
                        break;
                    }
                    q -= gq * (fq / gq.length_squared());
                    fq = part.value(q);
                }
                let d = (p - q).length();
                if d >= h || fq.abs() > 1e-9 * h {
                    continue;
                }
                let (mut inside, mut outside) = (false, false);
                for s in 0..27 {
                    let offset = DVec3::new(
                        f64::from(s % 3) - 1.0,
                        f64::from(s / 3 % 3) - 1.0,
                        f64::from(s / 9) - 1.0,
                    );
                    let w = part.value(p + h * offset);
                    inside |= w < 0.0;
                    outside |= w > 0.0;
                }
                if inside && outside {
                    weight += 1.0 - d / h;
                }
            }
        }
    }
    weight * h * h
}
