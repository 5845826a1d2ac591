//! Crease vertices slid along their creases once the pieces are joined (docs/creases.md,
//! *Sliding along creases*). Each piece is marched and improved up to crease polygons it may
//! not move, as the other piece on the crease shares them bit for bit: a triangle with two
//! crease vertices keeps the shape their spacing and the other piece's rows leave it (29°
//! where a hole's rim meets a plate's rows, 0.93 of radius ratio along a rim at coarse
//! steps). Here, with both pieces' triangles around it, each vertex inside a crease polygon
//! or a seam (not a corner) may move along it: to raise the smallest angle of its star
//! where that is below `KEEP_ANGLE`, else the sum of the star's radius ratios, never
//! lowering its smallest angle below `KEEP_ANGLE`. After each round over them, the free
//! vertices within two rings of them (whose places the pieces chose for the crease vertices
//! as they were) move towards their ring's centroid by the same rules, or around their place
//! where their star holds an angle below `KEEP_ANGLE` (`smooth_near`).
//!
//! A move is kept only when the new place is on both forms (Newton within the plane normal
//! to the crease, `survey::faces::correct`), or on the seam's form and plane
//! (`trace::seam_point`), and on the surface (f is zero there: no third form is chosen),
//! stays between its polygon neighbours with its polygon edges no longer than the step (or
//! than they were: a crease keeps a vertex a step at least), every triangle of its star still
//! faces the side its corners' normals point to and turns from the nearest piece normal no
//! further than it did (or 45°), and the star's centroids and the midpoints of its moved
//! edges are within the chord tolerance. The joined mesh is then checked as before
//! (`join::check_joined`, crossings included) by the caller, which keeps the mesh as
//! marched where the slid one fails. Vertices are visited in polygon order, in rounds:
//! the same mesh for any thread count.

use std::collections::{HashMap, HashSet};

use glam::DVec3;

use super::join::bits;
use super::trace::{Traced, seam_point};
use crate::march::Held;
use crate::mesh::Mesh;
use crate::mesh::bits::BitsHash;
use crate::mesh::quality::radius_ratio;
use crate::solve::tangent_frame;
use crate::survey::faces;
use crate::survey::spine::Creased;

/// Rounds over every crease vertex.
const ROUNDS: usize = 3;
/// The places tried along the crease, as fractions of the shorter polygon edge at the vertex.
const TRIES: [f64; 6] = [-0.3, -0.15, -0.05, 0.05, 0.15, 0.3];
/// Below this smallest angle a move aims at the angle; above it, at the radius ratios
/// (`march::improve`'s `KEEP_ANGLE`).
const KEEP_ANGLE: f64 = 34.0 * std::f64::consts::PI / 180.0;
/// Directions tried around a free vertex whose star holds an angle below `KEEP_ANGLE`
/// (`smooth_near`), and how far, as fractions of its mean distance to its ring.
const AROUND: usize = 12;
const AROUND_SHARES: [f64; 2] = [0.08, 0.16];
/// The gain in the star's sum of radius ratios that a move for the ratios must make.
const RATIO_GAIN: f64 = 2e-4;
/// The gain in the sine of the star's smallest angle that a move for the angle must make.
const SINE_GAIN: f64 = 1e-4;
/// A triangle may turn from its nearest piece normal up to this cosine (45°) after a move,
/// or as far as it did before.
const TURN_COS: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// What the slide needs of the mesh's setting.
pub(super) struct Limits {
    /// The chord tolerance (model units).
    pub tolerance: f64,
    /// |f|/|∇f| below this is on the surface (model units).
    pub on_surface: f64,
    /// The step: Newton's convergence is relative to it.
    pub step: f64,
    /// The mesh's box: border vertices on its faces do not move.
    pub bbox: (DVec3, DVec3),
}

/// Slides the crease vertices of `mesh` (the joined pieces) along their creases, and the
/// points of `polygons` (one per crease of `traced`) with them. Returns how many moves
/// were made.
pub(super) fn slide(
    c: &mut Creased,
    mesh: &mut Mesh,
    polygons: &mut [Vec<DVec3>],
    traced: &[Traced],
    limits: &Limits,
) -> usize {
    let index: HashMap<[u64; 3], u32, BitsHash> = mesh
        .vertices
        .iter()
        .enumerate()
        .map(|(k, &p)| (bits(p), k as u32))
        .collect();
    // Each crease vertex with its polygon, its place there and its two forms.
    let mut movable: Vec<(usize, usize, u32)> = Vec::new();
    let mut uses = vec![0u32; mesh.vertices.len()];
    for (k, (poly, tr)) in polygons.iter().zip(traced).enumerate() {
        for p in poly {
            if let Some(&v) = index.get(&bits(*p)) {
                uses[v as usize] += 1;
            }
        }
        if poly.len() < 3 {
            continue;
        }
        let closed = tr.ends.is_none();
        let inner = if closed {
            0..looped(poly)
        } else {
            1..poly.len() - 1
        };
        for at in inner {
            if let Some(&v) = index.get(&bits(poly[at])) {
                movable.push((k, at, v));
            }
        }
    }
    // A vertex on two polygons (a corner, a loop's repeated first point) does not move.
    movable.retain(|&(k, at, v)| {
        let closed_repeat = traced[k].ends.is_none() && at == 0 && uses[v as usize] == 2;
        uses[v as usize] == 1 || closed_repeat
    });
    let star = Stars::new(mesh);
    let crease_vertices: Vec<u32> = movable.iter().map(|&(_, _, v)| v).collect();
    let near = near_creases(mesh, &star, &crease_vertices, &uses, limits);
    let sides_of = |mesh: &Mesh, v: u32| {
        let lo = mesh.sides.partition_point(|s| s.vertex < v);
        let hi = mesh.sides.partition_point(|s| s.vertex <= v);
        lo..hi
    };
    let mut moves = 0;
    // Buffers a vertex, kept from one to the next.
    let mut old_sides: Vec<DVec3> = Vec::new();
    let mut candidates: Vec<(DVec3, Normals, Score)> = Vec::new();
    for _ in 0..ROUNDS {
        let mut moved = 0;
        for &(k, at, v) in &movable {
            let poly = &polygons[k];
            let n = looped(poly);
            let closed = traced[k].ends.is_none();
            let (before, after) = if closed {
                (poly[(at + n - 1) % n], poly[(at + 1) % n])
            } else {
                (poly[at - 1], poly[at + 1])
            };
            let p = mesh.vertices[v as usize];
            let Some(tangent) = (after - before).try_normalize() else {
                continue;
            };
            let reach = p.distance(before).min(p.distance(after));
            let longer = p.distance(before).max(p.distance(after));
            let sides = sides_of(mesh, v);
            old_sides.clear();
            old_sides.extend(mesh.sides[sides.clone()].iter().map(|s| s.normal));
            let old_normal = mesh.normals[v as usize];
            let tris = star.of(v);
            let Some(now) = score(mesh, tris, v, p, old_normal, &old_sides, None) else {
                continue;
            };
            candidates.clear();
            for t in TRIES {
                let guess = p + t * reach * tangent;
                let (i, j) = traced[k].forms;
                let q = match traced[k].seam {
                    None => faces::correct(c, i, j, guess, guess, tangent, limits.step),
                    Some(seam) => seam_point(c, i, seam.plane, guess, tangent, limits.step),
                };
                let Some(q) = q else {
                    continue;
                };
                // Between its polygon neighbours, by a tenth of the shorter edge at least, and
                // its polygon edges no longer than the step (or than they were): the polygon
                // keeps a vertex a step at least.
                let margin = 0.1 * reach;
                if (q - before).dot(tangent) < margin
                    || (after - q).dot(tangent) < margin
                    || q.distance(before).max(q.distance(after)) > longer.max(limits.step)
                {
                    continue;
                }
                // NaN is not on the surface.
                let f = c.whole(q);
                let on_surface = f.value.abs() <= limits.on_surface * f.gradient.length();
                if !on_surface {
                    continue;
                }
                let Some(normals) = normals_at(c, &traced[k], q, old_normal, &old_sides) else {
                    continue;
                };
                if let Some(s) = score(mesh, tris, v, q, normals.normal, &normals.sides, Some(&now))
                    && better(&now, &s)
                {
                    candidates.push((q, normals, s));
                }
            }
            let Some((q, normals)) =
                best_within_chord(c, mesh, tris, v, &now, &mut candidates, limits.tolerance)
            else {
                continue;
            };
            mesh.vertices[v as usize] = q;
            for (side, n) in mesh.sides[sides].iter_mut().zip(normals.sides) {
                side.normal = n;
            }
            mesh.normals[v as usize] = normals.normal;
            let poly = &mut polygons[k];
            poly[at] = q;
            if closed && at == 0 && poly.len() > n {
                let last = poly.len() - 1;
                poly[last] = q;
            }
            moved += 1;
        }
        moved += smooth_near(c, mesh, &near, &star, limits);
        moves += moved;
        if moved == 0 {
            break;
        }
    }
    moves
}

/// The free vertices within two rings of the movable crease vertices `movable`: not on a
/// polygon, without sides, not on the box.
fn near_creases(
    mesh: &Mesh,
    star: &Stars,
    movable: &[u32],
    uses: &[u32],
    limits: &Limits,
) -> Vec<u32> {
    let (lo, hi) = limits.bbox;
    let free = |v: u32| {
        let p = mesh.vertices[v as usize];
        uses[v as usize] == 0 && !(0..3).any(|k| p[k] == lo[k] || p[k] == hi[k])
    };
    let ring = |v: u32| {
        star.of(v)
            .iter()
            .flat_map(|&t| mesh.triangles[t as usize])
            .filter(move |&w| w != v)
    };
    let mut seen = vec![false; mesh.vertices.len()];
    let mut out = Vec::new();
    let mut front: Vec<u32> = movable.to_vec();
    for _ in 0..2 {
        let mut next = Vec::new();
        for &v in &front {
            for w in ring(v) {
                if !seen[w as usize] && free(w) {
                    seen[w as usize] = true;
                    out.push(w);
                    next.push(w);
                }
            }
        }
        front = next;
    }
    let sided: HashSet<u32, BitsHash> = mesh.sides.iter().map(|s| s.vertex).collect();
    out.retain(|v| !sided.contains(v));
    out.sort_unstable();
    out
}

/// One round of smoothing of the free vertices `near` the creases on the joined mesh: each
/// towards the centroid of its ring, put onto the surface by Newton on f (it stays on its
/// own face: crossing a crease polygon would turn a triangle over), kept by the rules of
/// the slide (`turn_kept`, `better`, `within_chord`). Returns the moves.
fn smooth_near(
    c: &mut Creased,
    mesh: &mut Mesh,
    near: &[u32],
    star: &Stars,
    limits: &Limits,
) -> usize {
    let mut moved = 0;
    // Buffers a vertex, kept from one to the next.
    let (mut ring, mut guesses, mut candidates) = (Vec::new(), Vec::new(), Vec::new());
    for &v in near {
        let tris = star.of(v);
        let p = mesh.vertices[v as usize];
        ring.clear();
        ring.extend(
            tris.iter()
                .flat_map(|&t| mesh.triangles[t as usize])
                .filter(|&w| w != v)
                .map(|w| mesh.vertices[w as usize]),
        );
        if ring.is_empty() {
            continue;
        }
        // Each ring vertex appears in two triangles of a closed fan: the mean is the ring's.
        let centroid = ring.iter().sum::<DVec3>() / ring.len() as f64;
        let old_normal = mesh.normals[v as usize];
        let Some(now) = score(mesh, tris, v, p, old_normal, &[], None) else {
            continue;
        };
        candidates.clear();
        // Towards the centroid; and where the star holds an angle below `KEEP_ANGLE`, also
        // around the vertex (`AROUND`): a free corner between a crease corner and the
        // crease's next vertex may need to move sideways, not to the centroid, for its
        // smallest angle (29.4° → 33° at a lattice's junction).
        guesses.clear();
        guesses.extend([1.0, 0.5].map(|share| p + share * (centroid - p)));
        if now.min_sine < KEEP_ANGLE.sin() {
            let reach = ring.iter().map(|w| w.distance(p)).sum::<f64>() / ring.len() as f64;
            let (t1, t2) = tangent_frame(old_normal);
            for k in 0..AROUND {
                let turn = std::f64::consts::TAU * k as f64 / AROUND as f64;
                let dir = turn.cos() * t1 + turn.sin() * t2;
                for share in AROUND_SHARES {
                    guesses.push(p + share * reach * dir);
                }
            }
        }
        for &guess in &guesses {
            let Some((q, normal)) = onto_surface(c, guess, limits) else {
                continue;
            };
            if !(q.cmpge(limits.bbox.0).all() && q.cmple(limits.bbox.1).all())
                || normal.dot(old_normal) < 0.5
            {
                continue;
            }
            if let Some(s) = score(mesh, tris, v, q, normal, &[], Some(&now))
                && better(&now, &s)
            {
                candidates.push((q, normal, s));
            }
        }
        if let Some((q, normal)) =
            best_within_chord(c, mesh, tris, v, &now, &mut candidates, limits.tolerance)
        {
            mesh.vertices[v as usize] = q;
            mesh.normals[v as usize] = normal;
            moved += 1;
        }
    }
    moved
}

/// The point of the surface f = 0 near p by Newton along ∇f, converged as the tracer's
/// Newton is (a step below 1e-13·step or rounding), with its unit normal, or None.
fn onto_surface(c: &mut Creased, mut p: DVec3, limits: &Limits) -> Option<(DVec3, DVec3)> {
    for _ in 0..32 {
        let f = c.whole(p);
        let g2 = f.gradient.length_squared();
        if !(g2 > 0.0 && f.value.is_finite()) {
            return None;
        }
        let delta = f.gradient * (f.value / g2);
        p -= delta;
        if delta.length() <= (1e-13 * limits.step).max(4.0 * f64::EPSILON * p.abs().max_element()) {
            let f = c.whole(p);
            let g = f.gradient.length();
            return (f.value.abs() <= limits.on_surface * g).then(|| (p, f.gradient / g));
        }
    }
    None
}

/// The points of a polygon before a closed loop's repeated first point.
fn looped(poly: &[DVec3]) -> usize {
    if poly.len() > 1 && poly[0] == poly[poly.len() - 1] {
        poly.len() - 1
    } else {
        poly.len()
    }
}

/// The triangles around each vertex, in ascending order, in one array (a list a vertex
/// was a few allocations for each of the hundreds of thousands of vertices of a part, of
/// which the slide looks at a tenth).
struct Stars {
    /// Where each vertex's triangles start in `tris`; one more entry for the end.
    first: Vec<usize>,
    tris: Vec<u32>,
}

impl Stars {
    fn new(mesh: &Mesh) -> Stars {
        let mut first = vec![0usize; mesh.vertices.len() + 1];
        for tri in &mesh.triangles {
            for &v in tri {
                first[v as usize + 1] += 1;
            }
        }
        for k in 1..first.len() {
            first[k] += first[k - 1];
        }
        let mut next = first.clone();
        let mut tris = vec![0u32; first[mesh.vertices.len()]];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for &v in tri {
                tris[next[v as usize]] = t as u32;
                next[v as usize] += 1;
            }
        }
        Stars { first, tris }
    }

    /// The triangles around v.
    fn of(&self, v: u32) -> &[u32] {
        &self.tris[self.first[v as usize]..self.first[v as usize + 1]]
    }
}

/// A vertex's normal and its pieces' normals (`Mesh::sides`) at a new place.
struct Normals {
    normal: DVec3,
    sides: Vec<DVec3>,
}

/// The normals at q of a vertex of crease or seam `tr` whose normal and sides were `normal`
/// and `sides`: on a crease, the two forms' unit gradients, each as the side it is nearest
/// to, and their normalised sum; on a seam (one sheet), the first form's unit gradient for
/// all. None where they turned by 60° or more from what they were.
fn normals_at(
    c: &mut Creased,
    tr: &Traced,
    q: DVec3,
    normal: DVec3,
    sides: &[DVec3],
) -> Option<Normals> {
    let (i, j) = tr.forms;
    let ni = c.form(i, q).gradient.try_normalize()?;
    let out = if tr.seam.is_some() {
        Normals {
            normal: ni,
            sides: vec![ni; sides.len()],
        }
    } else {
        let nj = c.form(j, q).gradient.try_normalize()?;
        let [a, b] = sides else {
            return None;
        };
        let pair = if a.dot(ni) + b.dot(nj) >= a.dot(nj) + b.dot(ni) {
            vec![ni, nj]
        } else {
            vec![nj, ni]
        };
        Normals {
            normal: (ni + nj).normalize_or_zero(),
            sides: pair,
        }
    };
    let kept =
        out.normal.dot(normal) > 0.5 && out.sides.iter().zip(sides).all(|(n, s)| n.dot(*s) > 0.5);
    kept.then_some(out)
}

/// A star's measures with its centre at one place.
struct Score {
    /// Sine of the smallest angle of the star's triangles.
    min_sine: f64,
    /// Sum of their radius ratios.
    ratios: f64,
    /// Per triangle: the cosine between its normal and the nearest of the centre's normal
    /// and piece normals; NaN where a triangle is degenerate or faces against its corners'
    /// normals. Empty for a place tried (`score` against the star as it is).
    turns: Vec<f64>,
}

/// Whether a triangle of a star still faces its corners' normals and turns no further from
/// the nearest normal at the centre than it did (`then`, its turn before the move) or than
/// `TURN_COS`: a move is valid when this holds for every triangle of its star.
fn turn_kept(then: f64, turn: f64) -> bool {
    turn >= then.min(TURN_COS)
}

/// Whether `s` gains on `now` by the rule of the module documentation.
fn better(now: &Score, s: &Score) -> bool {
    let keep = KEEP_ANGLE.sin();
    if now.min_sine < keep {
        s.min_sine > now.min_sine + SINE_GAIN
    } else {
        s.min_sine >= keep && s.ratios > now.ratios + RATIO_GAIN
    }
}

/// What a move from `now` ranks its places by: the star's smallest sine while it holds an
/// angle below `KEEP_ANGLE`, else its sum of radius ratios.
fn measure(now: &Score, s: &Score) -> f64 {
    if now.min_sine < KEEP_ANGLE.sin() {
        s.min_sine
    } else {
        s.ratios
    }
}

/// The star of v (triangles `tris`) with v at q, its normal `normal` and piece normals
/// `sides` there (none for a free vertex, or a seam vertex without sides). A place tried is
/// scored `against` the star as it is (`now`): None as soon as a triangle's turn is not kept
/// (`turn_kept`), and its turns are not kept (it is never compared as `now`).
fn score(
    mesh: &Mesh,
    tris: &[u32],
    v: u32,
    q: DVec3,
    normal: DVec3,
    sides: &[DVec3],
    against: Option<&Score>,
) -> Option<Score> {
    let mut turns = Vec::with_capacity(if against.is_none() { tris.len() } else { 0 });
    let (mut min_sine, mut ratios) = (f64::INFINITY, 0.0);
    for (k, &t) in tris.iter().enumerate() {
        let tri = mesh.triangles[t as usize];
        let at = |k: u32| if k == v { q } else { mesh.vertices[k as usize] };
        let [a, b, c] = tri.map(at);
        let n = (b - a).cross(c - a);
        let corners: DVec3 = tri
            .iter()
            .map(|&k| {
                if k == v {
                    normal
                } else {
                    mesh.normals[k as usize]
                }
            })
            .sum();
        let turn = match n.try_normalize() {
            Some(u) if n.dot(corners) > 0.0 => sides
                .iter()
                .map(|s| u.dot(*s))
                .fold(u.dot(normal), f64::max),
            _ => f64::NAN,
        };
        match against {
            Some(now) if !turn_kept(now.turns[k], turn) => return None,
            Some(_) => {}
            None => turns.push(turn),
        }
        min_sine = min_sine.min(min_sine_of(a, b, c));
        ratios += radius_ratio(a, b, c);
    }
    Some(Score {
        min_sine,
        ratios,
        turns,
    })
}

/// Of `candidates` (places q for v in the order tried, each with what moves with it, each
/// valid and gaining on `now`), the one a move takes: the best by `measure`, the
/// first tried among equals, whose star is `within_chord`. The chord is checked down that
/// ranking until a place passes — the place that keeping each candidate better than the
/// best so far and within the chord gives, with fewer checks (a check evaluates f at every
/// centroid and edge midpoint of the star).
fn best_within_chord<T>(
    c: &mut Creased,
    mesh: &Mesh,
    tris: &[u32],
    v: u32,
    now: &Score,
    candidates: &mut Vec<(DVec3, T, Score)>,
    tolerance: f64,
) -> Option<(DVec3, T)> {
    let mut passed = Vec::with_capacity(tris.len() + 1);
    best_passing(now, candidates, |q| {
        within_chord(c, mesh, tris, v, q, tolerance, &mut passed)
    })
}

/// The candidate of the highest `measure` for `now`, the first among equals,
/// for which `passes` holds, asking `passes` down that ranking.
fn best_passing<T>(
    now: &Score,
    candidates: &mut Vec<(DVec3, T, Score)>,
    mut passes: impl FnMut(DVec3) -> bool,
) -> Option<(DVec3, T)> {
    // Gaining on `now` makes the measures numbers (a NaN compares false). Stable: the first
    // tried leads among equals. Drained: the caller's list is empty again after.
    candidates.sort_by(|a, b| measure(now, &b.2).total_cmp(&measure(now, &a.2)));
    candidates
        .drain(..)
        .find(|(q, _, _)| passes(*q))
        .map(|(q, moved, _)| (q, moved))
}

/// The centroids of the star's triangles and the midpoints of its edges at v, with v at q,
/// are within `tolerance` of the surface by the linear estimate |f|/|∇f|.
fn within_chord(
    c: &mut Creased,
    mesh: &Mesh,
    tris: &[u32],
    v: u32,
    q: DVec3,
    tolerance: f64,
    passed: &mut Vec<u32>,
) -> bool {
    let near = |c: &mut Creased, p: DVec3| {
        let f = c.whole(p);
        let g = f.gradient.length();
        g > 0.0 && f.value.abs() <= tolerance * g
    };
    // An edge at v is in two triangles of the star: its midpoint, once it passed, is not
    // evaluated again (`passed`: the caller's buffer).
    passed.clear();
    tris.iter().all(|&t| {
        let tri = mesh.triangles[t as usize];
        let at = |k: u32| if k == v { q } else { mesh.vertices[k as usize] };
        let [a, b, d] = tri.map(at);
        near(c, (a + b + d) / 3.0)
            && tri.iter().filter(|&&k| k != v).all(|&k| {
                if passed.contains(&k) {
                    return true;
                }
                passed.push(k);
                near(c, 0.5 * (q + mesh.vertices[k as usize]))
            })
    })
}

/// The triangles of the pieces (the first `pieces` of `mesh`) below `target` (radians) with a
/// corner on a crease polygon or on the box: what the pieces' own warnings said before the
/// slide, counted again after it.
pub(super) fn held(
    mesh: &Mesh,
    pieces: usize,
    polygons: &[Vec<DVec3>],
    (lo, hi): (DVec3, DVec3),
    target: f64,
) -> Option<Held> {
    let on_crease: HashSet<[u64; 3], BitsHash> =
        polygons.iter().flatten().map(|&p| bits(p)).collect();
    let fixed =
        |p: DVec3| on_crease.contains(&bits(p)) || (0..3).any(|k| p[k] == lo[k] || p[k] == hi[k]);
    let sin_target = target.sin();
    let mut out: Option<Held> = None;
    for tri in &mesh.triangles[..pieces.min(mesh.triangles.len())] {
        let [a, b, c] = tri.map(|k| mesh.vertices[k as usize]);
        let sine = min_sine_of(a, b, c);
        if sine >= sin_target || ![a, b, c].into_iter().any(fixed) {
            continue;
        }
        let one = Held {
            count: 1,
            worst: sine.clamp(0.0, 1.0).asin().to_degrees(),
            at: (a + b + c) / 3.0,
            target: target.to_degrees(),
        };
        out = Some(out.map_or(one, |h| h.and(one)));
    }
    out
}

/// Sine of the smallest angle of triangle (a, b, c), 0 where it is degenerate.
fn min_sine_of(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (x, y, z) = (a.distance(b), b.distance(c), c.distance(a));
    let longer = x * y * z / x.min(y).min(z);
    let area2 = (b - a).cross(c - a).length();
    if longer > 0.0 { area2 / longer } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ranking takes the place the greedy rule of before took: each candidate in the
    /// order tried kept when valid, better than `now` and the best so far, and passing the
    /// chord; with the chord asked fewer times. Random measures with ties, both measures
    /// (`now` below and above `KEEP_ANGLE`), random chord outcomes.
    #[test]
    fn the_ranking_takes_what_the_greedy_rule_took() {
        let mut unit = crate::testing::uniform(0x5EED_51DE);
        let keep = KEEP_ANGLE.sin();
        let (mut asked_greedy, mut asked_ranked) = (0, 0);
        for round in 0..4000 {
            let now = Score {
                min_sine: if round % 2 == 0 { 0.3 } else { keep + 0.01 },
                ratios: 3.0,
                turns: vec![0.9; 3],
            };
            // Measures on a coarse grid: ties are common.
            let n = 1 + (unit() * 9.0) as usize;
            let tried: Vec<(DVec3, usize, Score)> = (0..n)
                .map(|k| {
                    let score = Score {
                        min_sine: now.min_sine - 0.05 + 0.05 * (unit() * 8.0).floor(),
                        ratios: 2.98 + 0.01 * (unit() * 6.0).floor(),
                        turns: vec![if unit() < 0.1 { 0.1 } else { 0.95 }; 3],
                    };
                    (DVec3::new(k as f64, round as f64, 0.0), k, score)
                })
                .collect();
            let fails: Vec<bool> = (0..n).map(|_| unit() < 0.4).collect();
            let passes = |q: DVec3| !fails[q.x as usize];
            let valid = |s: &Score| {
                s.turns
                    .iter()
                    .zip(&now.turns)
                    .all(|(&turn, &then)| turn_kept(then, turn))
            };
            let mut greedy: Option<usize> = None;
            for (q, k, s) in &tried {
                let beats_best =
                    greedy.is_none_or(|g| measure(&now, s) > measure(&now, &tried[g].2));
                if !valid(s) || !better(&now, s) || !beats_best {
                    continue;
                }
                asked_greedy += 1;
                if passes(*q) {
                    greedy = Some(*k);
                }
            }
            let mut gaining: Vec<(DVec3, usize, Score)> = tried
                .into_iter()
                .filter(|(_, _, s)| valid(s) && better(&now, s))
                .collect();
            let ranked = best_passing(&now, &mut gaining, |q| {
                asked_ranked += 1;
                passes(q)
            });
            assert_eq!(ranked.map(|r| r.1), greedy, "round {round}");
        }
        assert!(
            asked_ranked < asked_greedy,
            "{asked_ranked} vs {asked_greedy}"
        );
    }
}
