//! Which faces of a surface with creases meet at a point (docs/creases.md, *Faces*): the
//! groundwork that lets the crease search mesh solids as CAD users write them, with operands
//! that share face planes, overlap or touch.
//!
//! - *One face, several forms.* Two forms whose zero sets are one oriented sheet (two boxes'
//!   faces in one plane, coaxial cylinders of one radius, the same face after a rotation that
//!   rounding moved by an ulp) are one face: [`relate`] decides it from their values and
//!   gradients at points of the sheet, not from the syntax, and [`Creased::unite`] records it.
//! - *What crosses a point of a crease.* In the plane normal to the crease, every form tied at
//!   the point has a zero line; f keeps its sign between consecutive lines, so the sign of f
//!   in the middle of each sector says which lines are the surface (f changes sign across
//!   them) and which face each one is ([`crossing`]). Two lines of one face in one direction
//!   are a smooth face (a "crease" of operands hidden inside the solid, or of a shared face);
//!   no line is no surface (the inner face of two boxes side by side); two faces meet along a
//!   real crease; more is an edge where the solid touches itself, refused.
//! - *What leaves a corner.* At a point where three forms or more are zero, each pair of them
//!   meets along a line; stepping a little along each and asking [`crossing`] there gives the
//!   creases that really leave the point ([`junction`]): two of one pair is a crease passing
//!   through (a tie of operands inside the solid), three or more a corner of as many faces.
//!
//! Asks only the creased surface's forms and f; knows nothing of syntax or of the marcher.

use glam::{DMat3, DVec3};

use crate::solve::surfacepoint::tangent_frame;
use crate::surface::ValueGrad;
use crate::survey::spine::Creased;

/// Lengths are multiples of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceSettings {
    /// Radius of the circle on which f's sign is probed around a crease point. Default 1e-3:
    /// far above the tie tolerance (1e-6) and the rounding of crease points (1e-13), far
    /// below any feature the step can mesh, so the zero sets are straight lines at that
    /// radius.
    pub probe: f64,
    /// How far from a corner its creases are followed to see which pairs of faces really
    /// meet there. Default 1e-2.
    pub leave: f64,
    /// Two forms are one sheet when, at points up to `reach · step` apart on it, the other's
    /// distance |L|/|∇L| stays within `coincide · step`. Defaults 1e-9 and 0.25: rounding
    /// makes coincident faces differ by ulps; a tangent sheet curving away differs by its
    /// curvature times reach², far more.
    pub coincide: f64,
    pub reach: f64,
    /// Zero lines closer in angle than this (radians) are one line. Default 1e-6.
    pub same_line: f64,
    /// A sector narrower than this (radians) cannot be probed: the faces there are tangent.
    /// Default 1e-3.
    pub narrowest: f64,
}

impl Default for FaceSettings {
    fn default() -> Self {
        FaceSettings {
            probe: 1e-3,
            leave: 1e-2,
            coincide: 1e-9,
            reach: 0.25,
            same_line: 1e-6,
            narrowest: 1e-3,
        }
    }
}

/// How two forms with parallel normals at a common zero relate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relation {
    /// One oriented sheet: one face.
    Same,
    /// One sheet, opposite orientations (the faces two solids press together).
    Opposite,
    /// Tangent, on the same side, parting away from the point: the one hides the other
    /// there (a smooth boolean that saturates onto a face, a ball touching a wall from
    /// inside the solid), so they make no crease there.
    Shadow,
    /// Tangent with opposite sides, parting away: two solids touching.
    Touching,
}

/// What the surface does around a crease point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crossing {
    /// No surface: f keeps its sign all round (an inner face of a union).
    None,
    /// One face continues across (a tie of operands inside the solid, a shared face).
    Smooth,
    /// Two faces meet: each face's form and the unit direction, normal to the crease, in
    /// which that face leaves it.
    Crease { faces: [(usize, DVec3); 2] },
    /// A form tied here crosses the crease: the point is a corner (or next to one).
    Corner,
}

/// A crease leaving a junction: its two faces (form, direction away from the crease), its
/// direction, and the point `leave · step` along it where it was seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Leaving {
    pub faces: [(usize, DVec3); 2],
    pub direction: DVec3,
    pub at: DVec3,
}

/// What meets at a point where three forms or more are zero.
#[derive(Clone, Debug, PartialEq)]
pub enum Junction {
    /// One crease passes through (ties of operands inside the solid).
    PassThrough,
    /// A corner of as many faces as creases leave it.
    Corner(Vec<Leaving>),
}

/// Why the faces at a point cannot be told.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum FaceError {
    #[error(
        "two pieces of the surface touch tangentially at {at} (their normals are parallel, sine {sine:.1e}): the crease there cannot be traced"
    )]
    Tangent { at: DVec3, sine: f64 },
    #[error(
        "the solid touches itself along an edge near {at}: {faces} faces meet there, where a crease has two"
    )]
    NonManifold { at: DVec3, faces: usize },
    #[error("{pieces} smooth pieces meet at {at} in a way that cannot be meshed")]
    SingularCorner { at: DVec3, pieces: usize },
    #[error("a crease ends near {at} without a corner where a third piece begins")]
    Lost { at: DVec3 },
    #[error("the faces at {at} cannot be told apart (f is zero or undefined around it)")]
    Undecided { at: DVec3 },
    #[error(
        "two pieces of the surface cross at {at} that are one sheet elsewhere (operands that coincide on part of a face only)"
    )]
    PartlyOneSheet { at: DVec3, forms: (usize, usize) },
}

/// The local frame of the checks: the step they are relative to and the tie tolerance.
#[derive(Clone, Copy, Debug)]
pub struct Scale {
    pub step: f64,
    /// Two choices of the spine within `tie · step · |∇|` of each other are a tie.
    pub tie: f64,
}

impl Scale {
    fn eps(&self, g: f64) -> f64 {
        self.tie * self.step * g.max(f64::MIN_POSITIVE)
    }
}

/// The forms tied at p (chosen within the tie tolerance), with their values and gradients.
fn tied(c: &mut Creased, p: DVec3, scale: &Scale) -> Vec<(usize, ValueGrad)> {
    let g = c.whole(p).gradient.length();
    let active = c.active(p, scale.eps(g));
    active.into_iter().map(|k| (k, c.form(k, p))).collect()
}

/// The point of form i's zero set nearest `q` along its gradient (Newton), if it converges.
pub fn onto(c: &mut Creased, i: usize, q: DVec3, step: f64) -> Option<DVec3> {
    let mut x = q;
    for _ in 0..16 {
        let vg = c.form(i, x);
        let g2 = vg.gradient.length_squared();
        if !(g2 > 0.0 && vg.value.is_finite()) {
            return None;
        }
        let delta = vg.gradient * (vg.value / g2);
        x -= delta;
        if delta.length() <= 1e-13 * step.max(x.abs().max_element() * 1e-3) {
            return Some(x);
        }
    }
    None
}

/// How forms i and j relate where both are zero at p with parallel normals: whether they are
/// one sheet at points up to `reach · step` around p on form i's zero set (and with which
/// orientation), or only touch.
pub fn relate(
    c: &mut Creased,
    i: usize,
    j: usize,
    p: DVec3,
    scale: &Scale,
    s: &FaceSettings,
) -> Relation {
    let step = scale.step;
    let gi = c.form(i, p).gradient;
    let n = gi.normalize_or_zero();
    if n == DVec3::ZERO {
        return Relation::Touching;
    }
    let apart = if c.form(j, p).gradient.dot(gi) > 0.0 {
        Relation::Shadow
    } else {
        Relation::Touching
    };
    let (t1, t2) = tangent_frame(n);
    let mut orientation = 0.0;
    for r in [0.0, 0.2 * s.reach, s.reach] {
        let dirs: &[DVec3] = if r == 0.0 {
            &[DVec3::ZERO]
        } else {
            &[t1, -t1, t2, -t2]
        };
        for &d in dirs {
            let Some(q) = onto(c, i, p + r * step * d, step) else {
                return apart;
            };
            let (a, b) = (c.form(i, q), c.form(j, q));
            let (na, nb) = (a.gradient.length(), b.gradient.length());
            if !(na > 0.0 && nb > 0.0) {
                return apart;
            }
            let distance = b.value.abs() / nb;
            let sine = a.gradient.cross(b.gradient).length() / (na * nb);
            if distance.is_nan() || distance > s.coincide * step || sine > 1e-7 {
                return apart;
            }
            orientation += a.gradient.dot(b.gradient).signum();
        }
    }
    if orientation > 0.0 {
        Relation::Same
    } else {
        Relation::Opposite
    }
}

/// A zero line of a tied form in the plane normal to the crease: its angle, the form, and
/// the form's in-plane gradient.
struct Line {
    angle: f64,
    form: usize,
    normal: DVec3,
}

/// What crosses the crease point p whose tangent is t (see the module documentation).
pub fn crossing(
    c: &mut Creased,
    p: DVec3,
    t: DVec3,
    scale: &Scale,
    s: &FaceSettings,
) -> Result<Crossing, FaceError> {
    let t = t.normalize_or_zero();
    if t == DVec3::ZERO {
        return Err(FaceError::Undecided { at: p });
    }
    let (u, v) = tangent_frame(t);
    let whole = c.whole(p);
    if whole
        .value
        .abs()
        .partial_cmp(&(1e-9 * scale.step * whole.gradient.length()))
        != Some(std::cmp::Ordering::Less)
        && whole.value != 0.0
    {
        // Not on the surface (a line of two forms where neither is chosen).
        return Ok(Crossing::None);
    }
    let forms = tied(c, p, scale);
    let mut lines: Vec<Line> = Vec::with_capacity(2 * forms.len());
    for &(k, vg) in &forms {
        let g = vg.gradient;
        let w = g - g.dot(t) * t;
        if w.length() <= 1e-3 * g.length() || w.length().is_nan() {
            // The form's zero set crosses the crease here.
            return Ok(Crossing::Corner);
        }
        let d = t.cross(w).normalize();
        for dir in [d, -d] {
            lines.push(Line {
                angle: dir.dot(v).atan2(dir.dot(u)),
                form: k,
                normal: w,
            });
        }
    }
    if lines.is_empty() {
        return Ok(Crossing::None);
    }
    lines.sort_by(|a, b| a.angle.total_cmp(&b.angle).then(a.form.cmp(&b.form)));
    // Rays: lines of (nearly) one angle together.
    let mut rays: Vec<Vec<usize>> = Vec::new();
    for (n, l) in lines.iter().enumerate() {
        match rays.last_mut() {
            Some(r) if l.angle - lines[r[0]].angle <= s.same_line => r.push(n),
            _ => rays.push(vec![n]),
        }
    }
    // The last ray and the first are one when they meet across ±π.
    if rays.len() > 1 {
        let first = lines[rays[0][0]].angle;
        let last = rays[rays.len() - 1]
            .iter()
            .map(|&l| lines[l].angle)
            .fold(f64::MIN, f64::max);
        if first + std::f64::consts::TAU - last <= s.same_line {
            let tail = rays.pop().unwrap_or_default();
            rays[0].extend(tail);
        }
    }
    let ray_angle = |r: &[usize]| lines[r[0]].angle;
    let n = rays.len();
    if n < 2 {
        return Err(FaceError::Undecided { at: p });
    }
    // The sign of f in the middle of each sector (sector k runs from ray k to ray k+1).
    let mut sign = Vec::with_capacity(n);
    let mut middle = Vec::with_capacity(n);
    for k in 0..n {
        let a = ray_angle(&rays[k]);
        let mut b = ray_angle(&rays[(k + 1) % n]);
        if b <= a {
            b += std::f64::consts::TAU;
        }
        if b - a < s.narrowest {
            return Err(FaceError::Tangent {
                at: p,
                sine: (b - a).sin().abs(),
            });
        }
        let m = 0.5 * (a + b);
        let dir = m.cos() * u + m.sin() * v;
        let f = c.whole(p + s.probe * scale.step * dir).value;
        if f.is_nan() || f == 0.0 {
            return Err(FaceError::Undecided { at: p });
        }
        sign.push(f > 0.0);
        middle.push(dir);
    }
    // Boundary rays: the sign differs on their two sides. Each one's face: the form of the
    // ray that the spine chooses a little along it (one sheet if several: coincident forms,
    // whose choice rounding decides; a selector decides between a lifted pair).
    let mut faces: Vec<(usize, DVec3)> = Vec::new();
    for k in 0..n {
        let before = (k + n - 1) % n;
        if sign[before] == sign[k] {
            continue;
        }
        let a = ray_angle(&rays[k]);
        let dir = a.cos() * u + a.sin() * v;
        let on: Vec<usize> = rays[k].iter().map(|&l| lines[l].form).collect();
        let q = p + s.probe * scale.step * dir;
        let g = c.whole(q).gradient.length();
        let mut chosen: Vec<usize> = c
            .active(q, scale.eps(g))
            .into_iter()
            .filter(|f| on.contains(f))
            .collect();
        if chosen.is_empty() {
            // Curvature moved the sheet off the probe: the forms of the ray that grow towards
            // the positive side (f is one of them there).
            let towards = if sign[k] { middle[k] } else { middle[before] };
            chosen = rays[k]
                .iter()
                .filter(|&&l| lines[l].normal.dot(towards) > 0.0)
                .map(|&l| lines[l].form)
                .collect();
        }
        let Some(&face) = chosen.first() else {
            return Err(FaceError::Undecided { at: p });
        };
        for &other in &chosen[1..] {
            if other == face || c.class(other) == c.class(face) {
                continue;
            }
            if c.by_selector(face, other) {
                return Err(FaceError::Undecided { at: p });
            }
            match relate(c, face, other, p, scale, s) {
                Relation::Same => c.unite(face, other),
                Relation::Shadow => {}
                Relation::Opposite | Relation::Touching => {
                    return Err(FaceError::Tangent { at: p, sine: 0.0 });
                }
            }
        }
        faces.push((face, dir));
    }
    match faces[..] {
        [] => Ok(Crossing::None),
        [(fa, da), (fb, db)] => {
            let opposite = da.dot(db) < -1.0 + 1e-9;
            if c.class(fa) == c.class(fb) {
                // Two forms found to be one sheet somewhere (one face) meet here at an angle:
                // they coincide on part of a sheet only (the offsets of two solids flush on a
                // face), and the crease between them ends where they become one.
                return if opposite {
                    Ok(Crossing::Smooth)
                } else {
                    Err(FaceError::PartlyOneSheet {
                        at: p,
                        forms: (fa, fb),
                    })
                };
            }
            if opposite && !c.by_selector(fa, fb) {
                // One line, two forms: one sheet (a face two operands share), or a tangent
                // seam between two faces, which has no direction to trace.
                return match relate(c, fa, fb, p, scale, s) {
                    Relation::Same => {
                        c.unite(fa, fb);
                        Ok(Crossing::Smooth)
                    }
                    _ => Err(FaceError::Tangent { at: p, sine: 0.0 }),
                };
            }
            Ok(Crossing::Crease {
                faces: [(fa, da), (fb, db)],
            })
        }
        _ => Err(FaceError::NonManifold {
            at: p,
            faces: faces.len(),
        }),
    }
}

/// Newton onto forms i and j within the plane through `o` normal to `m`, from `p0`.
pub fn correct(
    c: &mut Creased,
    i: usize,
    j: usize,
    p0: DVec3,
    o: DVec3,
    m: DVec3,
    step: f64,
) -> Option<DVec3> {
    solve3(p0, step, |p| {
        let (a, b) = c.seam(i, j, p);
        let scale = a.gradient.length() * b.gradient.length() * m.length();
        (
            [a.gradient, b.gradient, m],
            DVec3::new(a.value, b.value, m.dot(p - o)),
            scale,
        )
    })
}

/// Newton on three equations from `start`: `system(p)` gives their gradients (the rows of
/// the Jacobian), their values and the scale of its determinant; None where the determinant
/// is below 1e-12 of that scale, or a step is not finite, or 32 steps do not bring one below
/// 1e-13·step (or rounding).
pub fn solve3(
    start: DVec3,
    step: f64,
    mut system: impl FnMut(DVec3) -> ([DVec3; 3], DVec3, f64),
) -> Option<DVec3> {
    let mut p = start;
    for _ in 0..32 {
        let ([r0, r1, r2], values, scale) = system(p);
        let rows = DMat3::from_cols(r0, r1, r2).transpose();
        let det = rows.determinant();
        if det.is_nan() || det.abs() <= 1e-12 * scale {
            return None;
        }
        let delta = rows.inverse() * values;
        if !delta.is_finite() {
            return None;
        }
        p -= delta;
        if delta.length() <= (1e-13 * step).max(4.0 * f64::EPSILON * p.abs().max_element()) {
            return Some(p);
        }
    }
    None
}

/// What meets at v, where three forms or more are zero (see the module documentation).
pub fn junction(
    c: &mut Creased,
    v: DVec3,
    scale: &Scale,
    s: &FaceSettings,
) -> Result<Junction, FaceError> {
    let forms = tied(c, v, scale);
    let mut leaving: Vec<Leaving> = Vec::new();
    for (x, &(a, ga)) in forms.iter().enumerate() {
        for &(b, gb) in &forms[x + 1..] {
            if c.class(a) == c.class(b) || !c.adjacent(a, b) {
                continue;
            }
            // The pair's seam: where they are equal, or a lifted choice's selector is zero.
            let gb = if c.by_selector(a, b) {
                c.seam(a, b, v).1
            } else {
                gb
            };
            let cross = ga.gradient.cross(gb.gradient);
            let sine = cross.length() / (ga.gradient.length() * gb.gradient.length());
            if sine <= 1e-7 || sine.is_nan() {
                if c.by_selector(a, b) {
                    continue;
                }
                match relate(c, a, b, v, scale, s) {
                    Relation::Same => c.unite(a, b),
                    Relation::Opposite | Relation::Shadow => {}
                    Relation::Touching => return Err(FaceError::Tangent { at: v, sine }),
                }
                continue;
            }
            let d = cross / cross.length();
            for dir in [d, -d] {
                let y = v + s.leave * scale.step * dir;
                let Some(q) = correct(c, a, b, y, y, dir, scale.step) else {
                    continue;
                };
                if q.distance(v) > 2.0 * s.leave * scale.step {
                    continue;
                }
                let (la, lb) = c.seam(a, b, q);
                let mut tq = la.gradient.cross(lb.gradient);
                if tq.dot(dir) < 0.0 {
                    tq = -tq;
                }
                match crossing(c, q, tq, scale, s)? {
                    Crossing::Crease { faces } => {
                        let direction = (q - v).normalize_or_zero();
                        let known = leaving.iter().any(|l| {
                            l.direction.dot(direction) > 1.0 - 1e-9 && same_pair(c, l.faces, faces)
                        });
                        if !known {
                            leaving.push(Leaving {
                                faces,
                                direction,
                                at: q,
                            });
                        }
                    }
                    Crossing::None | Crossing::Smooth | Crossing::Corner => {}
                }
            }
        }
    }
    if crate::trace::enabled() {
        eprintln!(
            "faces: junction at {v}: tied {:?}, leaving {:?}",
            forms.iter().map(|f| f.0).collect::<Vec<_>>(),
            leaving
                .iter()
                .map(|l| (l.faces[0].0, l.faces[1].0, l.direction))
                .collect::<Vec<_>>()
        );
    }
    match leaving.len() {
        0 | 1 => Err(FaceError::Lost { at: v }),
        2 if same_pair(c, leaving[0].faces, leaving[1].faces) => Ok(Junction::PassThrough),
        2 => Err(FaceError::Lost { at: v }),
        _ => {
            // Every face of a corner lies between two of its creases.
            let mut count: Vec<(usize, usize)> = Vec::new();
            for l in &leaving {
                for (f, _) in l.faces {
                    let k = c.class(f);
                    match count.iter_mut().find(|e| e.0 == k) {
                        Some(e) => e.1 += 1,
                        None => count.push((k, 1)),
                    }
                }
            }
            if count.iter().any(|&(_, n)| n != 2) {
                return Err(FaceError::SingularCorner {
                    at: v,
                    pieces: count.len(),
                });
            }
            Ok(Junction::Corner(leaving))
        }
    }
}

/// Whether two creases are between the same two faces.
fn same_pair(c: &mut Creased, a: [(usize, DVec3); 2], b: [(usize, DVec3); 2]) -> bool {
    let (a0, a1) = (c.class(a[0].0), c.class(a[1].0));
    let (b0, b1) = (c.class(b[0].0), c.class(b[1].0));
    (a0 == b0 && a1 == b1) || (a0 == b1 && a1 == b0)
}
