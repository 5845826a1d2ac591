//! Random CSG trees for the crease property test (issue 12, M5), kept as data so that the
//! test can (a) write them as `.surf` text for the mesher, (b) evaluate them natively for the
//! voxel reference — without surfc's parser, compiler or evaluator — and (c) decide *before
//! meshing*, from the primitives' own geometry, whether a tree is in general position.
//!
//! General position, decided cheaply from the primitives alone (never from the mesher): every
//! smooth piece of every primitive (a sphere, a torus, a box face, a cylinder's side or cap) is
//! sampled densely; wherever a sample lies within `reach` of another piece, their normals must
//! make an angle of at least `min_sine` (no near-tangency, no thin gap or sliver between
//! nearly parallel sheets); within `reach` of two others, the three normals must span space
//! (|det| ≥ `min_det`: a corner, not a near-degenerate one); and no sample may lie within
//! `reach` of three others (four pieces near one point). The test is conservative: it looks
//! only at samples where the tree's surface passes (its value changes sign across the piece
//! within `reach`), but at every piece near such a sample.
#![allow(dead_code)]

use glam::{DMat3, DVec3};

use super::rng::Rng;

/// A primitive's shape in its own frame (X, Y, Z).
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// X² + Y² + Z² − r².
    Sphere { r: f64 },
    /// max(|X| − a, |Y| − b, |Z| − c): half-extents.
    Box { half: DVec3 },
    /// max(X² + Y² − r², |Z| − h): radius r, from −h to h.
    Cylinder { r: f64, h: f64 },
    /// (√(X² + Y²) − big)² + Z² − small².
    Torus { big: f64, small: f64 },
}

/// A shape moved and turned: its frame is X = M·(p − c) row by row.
#[derive(Clone, Copy, Debug)]
pub struct Primitive {
    pub shape: Shape,
    pub centre: DVec3,
    /// Rows: the frame's axes in world coordinates.
    pub turn: DMat3,
}

/// A tree of primitives joined by min, max and difference, sharp or smooth.
#[derive(Clone, Debug)]
pub enum Tree {
    Leaf(Primitive),
    Min(Box<Tree>, Box<Tree>),
    Max(Box<Tree>, Box<Tree>),
    /// max(a, −b).
    Difference(Box<Tree>, Box<Tree>),
    /// A smooth boolean of docs/language.md with its rounding radius.
    Smooth(SmoothOp, Box<Tree>, Box<Tree>, f64),
}

/// The smooth booleans, as docs/language.md defines them from the polynomial smooth minimum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SmoothOp {
    /// smin(a, b).
    Union,
    /// −smin(−a, −b).
    Intersection,
    /// −smin(−a, b).
    Difference,
}

impl SmoothOp {
    fn name(self) -> &'static str {
        match self {
            SmoothOp::Union => "smooth_union",
            SmoothOp::Intersection => "smooth_intersection",
            SmoothOp::Difference => "smooth_difference",
        }
    }

    /// The boolean of a and b with radius r, written out here (not surfc's code):
    /// h = clamp(0.5 + 0.5·(b − a)/r, 0, 1), smin = b + (a − b)·h − r·h·(1 − h).
    pub fn apply(self, a: f64, b: f64, r: f64) -> f64 {
        let smin = |a: f64, b: f64| {
            let h = (0.5 + 0.5 * (b - a) / r).clamp(0.0, 1.0);
            b + (a - b) * h - r * h * (1.0 - h)
        };
        match self {
            SmoothOp::Union => smin(a, b),
            SmoothOp::Intersection => -smin(-a, -b),
            SmoothOp::Difference => -smin(-a, b),
        }
    }
}

/// The quadratic smooth minimum of the reference's rounding, radius k.
fn round_min(a: f64, b: f64, k: f64) -> f64 {
    let h = (k - (a - b).abs()).max(0.0) / k;
    a.min(b) - 0.25 * h * h * k
}

/// max rounded like `round_min`.
fn round_max(a: f64, b: f64, k: f64) -> f64 {
    -round_min(-a, -b, k)
}

impl Primitive {
    fn random(rng: &mut Rng) -> Primitive {
        let centre = DVec3::new(
            rng.range(-0.8, 0.8),
            rng.range(-0.8, 0.8),
            rng.range(-0.8, 0.8),
        );
        // A random turn: Rodrigues' matrix of a random axis and angle.
        let axis = DVec3::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        )
        .normalize_or(DVec3::Z);
        let turn = DMat3::from_axis_angle(axis, rng.range(0.0, std::f64::consts::PI)).transpose();
        let shape = match rng.next() % 4 {
            0 => Shape::Sphere {
                r: rng.range(0.4, 0.9),
            },
            1 => Shape::Box {
                half: DVec3::new(
                    rng.range(0.3, 0.8),
                    rng.range(0.3, 0.8),
                    rng.range(0.3, 0.8),
                ),
            },
            2 => Shape::Cylinder {
                r: rng.range(0.25, 0.6),
                h: rng.range(0.3, 0.8),
            },
            _ => Shape::Torus {
                big: rng.range(0.5, 0.8),
                small: rng.range(0.15, 0.3),
            },
        };
        Primitive {
            shape,
            centre,
            turn,
        }
    }

    /// The radius of a ball about the centre that holds the primitive.
    fn radius(&self) -> f64 {
        match self.shape {
            Shape::Sphere { r } => r,
            Shape::Box { half } => half.length(),
            Shape::Cylinder { r, h } => (r * r + h * h).sqrt(),
            Shape::Torus { big, small } => big + small,
        }
    }

    /// The point in the primitive's frame.
    fn local(&self, p: DVec3) -> DVec3 {
        self.turn * (p - self.centre)
    }

    /// A local direction in world coordinates.
    fn world(&self, v: DVec3) -> DVec3 {
        self.turn.transpose() * v
    }

    /// The implicit function, as the `.surf` text writes it.
    pub fn value(&self, p: DVec3) -> f64 {
        let q = self.local(p);
        match self.shape {
            Shape::Sphere { r } => q.x * q.x + q.y * q.y + q.z * q.z - r * r,
            Shape::Box { half } => (q.x.abs() - half.x)
                .max(q.y.abs() - half.y)
                .max(q.z.abs() - half.z),
            Shape::Cylinder { r, h } => (q.x * q.x + q.y * q.y - r * r).max(q.z.abs() - h),
            Shape::Torus { big, small } => {
                let rho = (q.x * q.x + q.y * q.y).sqrt();
                (rho - big) * (rho - big) + q.z * q.z - small * small
            }
        }
    }

    /// The implicit function as the `.surf` text writes it, with its own sharp edges (those of
    /// boxes and cylinders) rounded in value by `round_max` of radius k: what a smooth boolean
    /// of the primitive sees, with no wedge tip for the grid to break.
    fn softened(&self, p: DVec3, k: f64) -> f64 {
        let q = self.local(p);
        match self.shape {
            Shape::Box { half } => round_max(
                round_max(q.x.abs() - half.x, q.y.abs() - half.y, k),
                q.z.abs() - half.z,
                k,
            ),
            Shape::Cylinder { r, h } => round_max(q.x * q.x + q.y * q.y - r * r, q.z.abs() - h, k),
            Shape::Sphere { .. } | Shape::Torus { .. } => self.value(p),
        }
    }

    /// The exact signed distance of the primitive with its edges rounded to radius `k` (boxes
    /// and cylinders; k = 0 is the primitive itself).
    fn rounded_distance(&self, p: DVec3, k: f64) -> f64 {
        let q = self.local(p);
        // The distance to a box of half-extents `half` rounded by k (in any dimension).
        fn rounded_box<const N: usize>(q: [f64; N], half: [f64; N], k: f64) -> f64 {
            let (mut outside, mut inside) = (0.0f64, f64::NEG_INFINITY);
            for i in 0..N {
                let d = q[i].abs() - (half[i] - k);
                outside += d.max(0.0).powi(2);
                inside = inside.max(d);
            }
            outside.sqrt() + inside.min(0.0) - k
        }
        match self.shape {
            Shape::Sphere { r } => q.length() - r,
            Shape::Box { half } => rounded_box(q.to_array(), half.to_array(), k),
            Shape::Cylinder { r, h } => {
                let rho = q.truncate().length();
                // In the (ρ, z) half-plane the cylinder is a rectangle centred on the axis.
                rounded_box([rho, q.z], [r, h], k)
            }
            Shape::Torus { big, small } => {
                let rho = q.truncate().length();
                ((rho - big).powi(2) + q.z * q.z).sqrt() - small
            }
        }
    }

    /// The implicit function as `.surf` text.
    pub fn source(&self) -> String {
        let row = |k: usize| {
            let r = self.turn.row(k);
            let c = self.centre;
            format!(
                "({} * (x - {}) + {} * (y - {}) + {} * (z - {}))",
                r.x, c.x, r.y, c.y, r.z, c.z
            )
        };
        let (x, y, z) = (row(0), row(1), row(2));
        match self.shape {
            Shape::Sphere { r } => format!("({x}^2 + {y}^2 + {z}^2 - {})", r * r),
            Shape::Box { half } => format!(
                "max(max(abs({x}) - {}, abs({y}) - {}), abs({z}) - {})",
                half.x, half.y, half.z
            ),
            Shape::Cylinder { r, h } => format!("max({x}^2 + {y}^2 - {}, abs({z}) - {h})", r * r),
            Shape::Torus { big, small } => format!(
                "((sqrt({x}^2 + {y}^2) - {big})^2 + {z}^2 - {})",
                small * small
            ),
        }
    }

    /// The smooth pieces of the primitive's surface.
    fn pieces(&self) -> Vec<Piece> {
        match self.shape {
            Shape::Sphere { .. } | Shape::Torus { .. } => vec![Piece::Whole],
            Shape::Box { .. } => (0..6).map(Piece::Face).collect(),
            Shape::Cylinder { .. } => vec![Piece::Side, Piece::Cap(1.0), Piece::Cap(-1.0)],
        }
    }
}

/// One smooth piece of a primitive's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Piece {
    /// The whole surface of a sphere or a torus.
    Whole,
    /// Box face: axis k = i / 2, on the side of sign (−1)^i.
    Face(usize),
    /// A cylinder's side.
    Side,
    /// A cylinder's cap at Z = ±h.
    Cap(f64),
}

/// A piece of a primitive's surface, placed.
#[derive(Clone, Copy, Debug)]
struct Placed {
    prim: Primitive,
    piece: Piece,
}

impl Placed {
    /// Distance from p to the piece (the piece itself, not the surface it lies on), and the
    /// piece's unit normal at the point of it nearest p (for a face or a cap: its plane's).
    fn near(&self, p: DVec3) -> (f64, DVec3) {
        let q = self.prim.local(p);
        let (d, n) = match (self.prim.shape, self.piece) {
            (Shape::Sphere { r }, _) => (q.length() - r, q.normalize_or(DVec3::Z)),
            (Shape::Torus { big, small }, _) => {
                let rho = q.truncate().length();
                let radial = q.truncate().normalize_or(glam::DVec2::X);
                let tube = DVec3::new(radial.x * (rho - big), radial.y * (rho - big), q.z);
                (tube.length() - small, tube.normalize_or(DVec3::Z))
            }
            (Shape::Box { half }, Piece::Face(i)) => {
                let (k, s) = (i / 2, if i % 2 == 0 { 1.0 } else { -1.0 });
                let mut out = (q[k] - s * half[k]).powi(2);
                for o in (0..3).filter(|&o| o != k) {
                    out += (q[o].abs() - half[o]).max(0.0).powi(2);
                }
                let mut n = DVec3::ZERO;
                n[k] = s;
                (out.sqrt(), n)
            }
            (Shape::Cylinder { r, h }, Piece::Side) => {
                let rho = q.truncate().length();
                let n = q.truncate().normalize_or(glam::DVec2::X).extend(0.0);
                (
                    ((rho - r).powi(2) + (q.z.abs() - h).max(0.0).powi(2)).sqrt(),
                    n,
                )
            }
            (Shape::Cylinder { r, h }, Piece::Cap(s)) => {
                let rho = q.truncate().length();
                (
                    ((q.z - s * h).powi(2) + (rho - r).max(0.0).powi(2)).sqrt(),
                    DVec3::new(0.0, 0.0, s),
                )
            }
            _ => unreachable!("pieces match their shapes"),
        };
        (d.abs(), self.prim.world(n))
    }

    /// Points of the piece about `spacing` apart, with the piece's normal there.
    fn samples(&self, spacing: f64) -> Vec<(DVec3, DVec3)> {
        let mut local: Vec<DVec3> = Vec::new();
        let steps = |len: f64| ((len / spacing).ceil() as usize).max(2);
        match (self.prim.shape, self.piece) {
            (Shape::Sphere { r }, _) => {
                let nt = steps(std::f64::consts::PI * r);
                for i in 0..=nt {
                    let t = std::f64::consts::PI * i as f64 / nt as f64;
                    let np = steps(std::f64::consts::TAU * r * t.sin());
                    for j in 0..np {
                        let f = std::f64::consts::TAU * j as f64 / np as f64;
                        local.push(r * DVec3::new(t.sin() * f.cos(), t.sin() * f.sin(), t.cos()));
                    }
                }
            }
            (Shape::Torus { big, small }, _) => {
                let nu = steps(std::f64::consts::TAU * (big + small));
                let nv = steps(std::f64::consts::TAU * small);
                for i in 0..nu {
                    let u = std::f64::consts::TAU * i as f64 / nu as f64;
                    for j in 0..nv {
                        let v = std::f64::consts::TAU * j as f64 / nv as f64;
                        let rho = big + small * v.cos();
                        local.push(DVec3::new(rho * u.cos(), rho * u.sin(), small * v.sin()));
                    }
                }
            }
            (Shape::Box { half }, Piece::Face(i)) => {
                let (k, s) = (i / 2, if i % 2 == 0 { 1.0 } else { -1.0 });
                let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                let (na, nb) = (steps(2.0 * half[a]), steps(2.0 * half[b]));
                for ia in 0..=na {
                    for ib in 0..=nb {
                        let mut q = DVec3::ZERO;
                        q[k] = s * half[k];
                        q[a] = half[a] * (2.0 * ia as f64 / na as f64 - 1.0);
                        q[b] = half[b] * (2.0 * ib as f64 / nb as f64 - 1.0);
                        local.push(q);
                    }
                }
            }
            (Shape::Cylinder { r, h }, Piece::Side) => {
                let (nu, nz) = (steps(std::f64::consts::TAU * r), steps(2.0 * h));
                for i in 0..nu {
                    let u = std::f64::consts::TAU * i as f64 / nu as f64;
                    for j in 0..=nz {
                        let z = h * (2.0 * j as f64 / nz as f64 - 1.0);
                        local.push(DVec3::new(r * u.cos(), r * u.sin(), z));
                    }
                }
            }
            (Shape::Cylinder { r, h }, Piece::Cap(s)) => {
                let nr = steps(r);
                for i in 0..=nr {
                    let rho = r * i as f64 / nr as f64;
                    let nu = steps(std::f64::consts::TAU * rho);
                    for j in 0..nu {
                        let u = std::f64::consts::TAU * j as f64 / nu as f64;
                        local.push(DVec3::new(rho * u.cos(), rho * u.sin(), s * h));
                    }
                }
            }
            _ => unreachable!("pieces match their shapes"),
        }
        local
            .into_iter()
            .map(|q| {
                let p = self.prim.centre + self.prim.world(q);
                (p, self.near(p).1)
            })
            .collect()
    }
}

/// Thresholds of the general-position test.
#[derive(Clone, Copy, Debug)]
pub struct GeneralPosition {
    /// How near another piece a sample must be to be checked against it.
    pub reach: f64,
    /// Sample spacing on each piece.
    pub spacing: f64,
    /// Smallest sine between the normals of two pieces within `reach`.
    pub min_sine: f64,
    /// Smallest |det| of the normals of three pieces within `reach` of one point.
    pub min_det: f64,
}

/// Why a tree is not in general position, and where.
#[derive(Clone, Debug, PartialEq)]
pub enum Degenerate {
    /// Two pieces near each other with nearly parallel normals (tangency, thin gap, sliver).
    NearTangent { at: DVec3, sine: f64 },
    /// Three pieces near one point whose normals nearly share a plane.
    FlatCorner { at: DVec3, det: f64 },
    /// Four or more pieces near one point.
    Crowded { at: DVec3, pieces: usize },
}

impl Tree {
    /// A random tree of `n` primitives; with `smooth`, one node in three (on average) is a
    /// smooth boolean with a radius from 0.08 to 0.25.
    pub fn random(rng: &mut Rng, n: usize, smooth: bool) -> Tree {
        if n == 1 {
            return Tree::Leaf(Primitive::random(rng));
        }
        let left = 1 + (rng.next() as usize) % (n - 1);
        let (a, b) = (
            Box::new(Tree::random(rng, left, smooth)),
            Box::new(Tree::random(rng, n - left, smooth)),
        );
        if smooth && rng.next() % 3 == 0 {
            let op = match rng.next() % 3 {
                0 => SmoothOp::Union,
                1 => SmoothOp::Intersection,
                _ => SmoothOp::Difference,
            };
            return Tree::Smooth(op, a, b, rng.range(0.08, 0.25));
        }
        match rng.next() % 3 {
            0 => Tree::Min(a, b),
            1 => Tree::Max(a, b),
            _ => Tree::Difference(a, b),
        }
    }

    /// Whether a smooth boolean is in the tree.
    pub fn has_smooth(&self) -> bool {
        match self {
            Tree::Leaf(_) => false,
            Tree::Smooth(..) => true,
            Tree::Min(a, b) | Tree::Max(a, b) | Tree::Difference(a, b) => {
                a.has_smooth() || b.has_smooth()
            }
        }
    }

    /// The tree's function, natively.
    pub fn value(&self, p: DVec3) -> f64 {
        match self {
            Tree::Leaf(prim) => prim.value(p),
            Tree::Min(a, b) => a.value(p).min(b.value(p)),
            Tree::Max(a, b) => a.value(p).max(b.value(p)),
            Tree::Difference(a, b) => a.value(p).max(-b.value(p)),
            Tree::Smooth(op, a, b, r) => op.apply(a.value(p), b.value(p), *r),
        }
    }

    /// The solid with every crease rounded to about radius `k`: exact distances of the
    /// primitives with rounded edges, joined by the polynomial smooth minimum and maximum.
    /// In general position (no two pieces near each other at a shallow angle, no third piece
    /// near a crease) it has the tree's topology, and no wedge thinner than about `k` — the
    /// tips of sharp wedges, which a sampling grid breaks into crumbs and strands at any
    /// resolution, are gone.
    ///
    /// A tree with a smooth boolean is rounded in the values the `.surf` text computes
    /// instead (`Primitive::softened`, sharp nodes by `round_min`): a smooth boolean's
    /// fillet depends on its operands' values, not on their distances, so only those give
    /// its shape. They differ from the tree's function by at most k/4 in value.
    pub fn rounded(&self, p: DVec3, k: f64) -> f64 {
        self.rounded_as(p, k, self.has_smooth())
    }

    fn rounded_as(&self, p: DVec3, k: f64, raw: bool) -> f64 {
        let smin = |a: f64, b: f64| round_min(a, b, k);
        let r = |t: &Tree| t.rounded_as(p, k, raw);
        match self {
            Tree::Leaf(prim) if raw => prim.softened(p, k),
            Tree::Leaf(prim) => prim.rounded_distance(p, k),
            Tree::Min(a, b) => smin(r(a), r(b)),
            Tree::Max(a, b) => -smin(-r(a), -r(b)),
            Tree::Difference(a, b) => -smin(-r(a), r(b)),
            Tree::Smooth(op, a, b, radius) => op.apply(r(a), r(b), *radius),
        }
    }

    /// The tree as `.surf` text (raw min and max, as users write them by hand).
    pub fn source(&self) -> String {
        match self {
            Tree::Leaf(prim) => prim.source(),
            Tree::Min(a, b) => format!("min({},\n  {})", a.source(), b.source()),
            Tree::Max(a, b) => format!("max({},\n  {})", a.source(), b.source()),
            Tree::Difference(a, b) => format!("max({},\n  -({}))", a.source(), b.source()),
            Tree::Smooth(op, a, b, r) => {
                format!("{}({},\n  {}, {r})", op.name(), a.source(), b.source())
            }
        }
    }

    /// A box that holds the solid: the union of the primitives' bounding balls' boxes.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.primitives()
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
                let r = DVec3::splat(p.radius());
                (lo.min(p.centre - r), hi.max(p.centre + r))
            })
    }

    pub fn primitives(&self) -> Vec<Primitive> {
        match self {
            Tree::Leaf(prim) => vec![*prim],
            Tree::Min(a, b)
            | Tree::Max(a, b)
            | Tree::Difference(a, b)
            | Tree::Smooth(_, a, b, _) => {
                let mut out = a.primitives();
                out.extend(b.primitives());
                out
            }
        }
    }

    /// The first place where the tree's primitives are not in general position (module
    /// documentation), or None.
    pub fn degenerate(&self, g: &GeneralPosition) -> Option<Degenerate> {
        let placed: Vec<Placed> = self
            .primitives()
            .into_iter()
            .flat_map(|prim| {
                prim.pieces()
                    .into_iter()
                    .map(move |piece| Placed { prim, piece })
            })
            .collect();
        for (ia, a) in placed.iter().enumerate() {
            for (p, na) in a.samples(g.spacing) {
                // Only where the tree's surface passes (its sign changes across the piece
                // within reach): the parts the booleans drop do not matter.
                let (outer, inner) = (self.value(p + g.reach * na), self.value(p - g.reach * na));
                if (outer < 0.0) == (inner < 0.0) {
                    continue;
                }
                let near: Vec<DVec3> = placed
                    .iter()
                    .enumerate()
                    .filter(|&(ib, _)| ib != ia)
                    .filter_map(|(_, b)| {
                        let (d, n) = b.near(p);
                        (d < g.reach).then_some(n)
                    })
                    .collect();
                if near.len() >= 3 {
                    return Some(Degenerate::Crowded {
                        at: p,
                        pieces: near.len() + 1,
                    });
                }
                for nb in &near {
                    let sine = na.cross(*nb).length();
                    if sine < g.min_sine {
                        return Some(Degenerate::NearTangent { at: p, sine });
                    }
                }
                if let [nb, nc] = near[..] {
                    let det = na.dot(nb.cross(nc)).abs();
                    if det < g.min_det {
                        return Some(Degenerate::FlatCorner { at: p, det });
                    }
                }
            }
        }
        None
    }
}
