//! The quality stage between the march and the verification (issue 13): restricted-Delaunay
//! edge flips, angle-based smoothing of free vertices on the surface, insertion of
//! off-centres where a triangle stays below the target angle, and the merge of a free corner
//! into a neighbour where insertion cannot mend it (`Stage::remove_corner`); then the mean
//! radius ratio (issue 10, M4) raised to `Limits::ratio`, cheapest first: a round of
//! smoothing towards the rings' centroids (`Stage::centroid_round`), and only where that
//! falls short, valence flips and smoothing up the gradient of each fan's radius ratios
//! (`Stage::polish`) around rounds towards the optimal Delaunay triangulation — all under a
//! guard that cannot lower the smallest angle below min(target, what the rounds reached).
//!
//! Input: the marcher's triangulation (vertices exactly on the surface, normals ∇f/|∇f|,
//! which vertices are polygon or border points) and the surface. Output: the same
//! triangulation improved in place, and counts of what was done.
//!
//! Invariants kept: every vertex is a surfacepoint (a moved or new vertex is projected with
//! surfacepoint and its normal is ∇f/|∇f| there); polygon vertices (given fronts, bounds,
//! crease polygons, net seams) and border points on the box never move and an edge between two
//! polygon vertices is never flipped or split, so polygons and box borders stay edges of the
//! mesh, bit for bit; the topology does not change (a flip replaces two triangles by two, a
//! move keeps incidences, an insertion splits one triangle into three or an edge's two
//! triangles into four, a removal takes a vertex, three edges and two triangles where the
//! link allows it: χ, boundary loops and components stay); every change keeps each
//! touched triangle facing the side ∇f points to at its corners. Work is bounded (flip
//! budgets, `rounds`, `max_inserted`, `ODT_ROUNDS`) and done in index order, but for the
//! centroid round, which moves blocks of consecutive vertices on rayon's pool (each block in
//! index order, on its own oracle, the vertices between blocks after them); the passes that
//! only read the mesh (the twins, the first round's queue, the shapes, the survey) run on
//! the pool with the result of one thread: the output is the same for any thread count.
//! The verification (`verify.rs`) still checks the result: the stage does not have to be
//! trusted for correctness, only for quality.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use glam::DVec3;
use rayon::prelude::*;

use crate::surface::{Fork, Surface};

/// Puts a point near the surface onto it: the surface point and its unit normal, or None.
/// Shared by the centroid round's blocks on rayon's pool, each with its own oracle.
pub(super) type Project<'a> = dyn Fn(&mut dyn Surface, DVec3) -> Option<(DVec3, DVec3)> + Sync + 'a;

/// No half-edge across (a boundary edge, or an edge in more than two triangles).
const NONE: u32 = u32::MAX;

/// A fan around a vertex longer than this is not treated (a pathological star).
const MAX_STAR: usize = 64;

/// A fan longer than this is not smoothed (kept small so that `Fan` lives on the stack
/// cheaply; the marcher's vertices have 4–9 neighbours).
const MAX_FAN: usize = 16;

/// The vertices `Stage::new` takes at a time in one thread.
const TWIN_BLOCK: usize = 1 << 12;

/// A vertex that moved by less than this fraction of its local step does not mark its
/// neighbours for the next round: the rounds after the first then cost in proportion to
/// what still changes, not to the mesh.
const SETTLE: f64 = 0.05;

/// The ratios' rounds (`polish`) stop when fewer than this fraction of the vertices moved
/// by more than `SETTLE` in a round.
const STALL: f64 = 0.03;

/// The rounds proper stop, once no triangle is below the target, when fewer than this
/// fraction of the vertices moved in a round (at 3 % the plate's mean radius ratio lost
/// 0.0003; at 1 % no gallery mesh changes by more than 0.00015).
const ROUNDS_STALL: f64 = 0.01;

/// Cosine of the largest angle allowed between the two triangles made by a flip (≈ 37°):
/// beyond it the quad is folded over a ridge rather than a flat pair.
const FOLD_COS: f64 = 0.8;

/// A flip must beat the Delaunay condition by this much (radians) so that nearly
/// cocircular quads do not flip back and forth under rounding.
const DELAUNAY_MARGIN: f64 = 1e-3;

/// A smoothing move must raise the sum of its fan's radius ratios by this much (unless it
/// raises the fan's smallest angle): vertices that have converged stop moving, and stop
/// marking their neighbours for the next round, so the rounds after the first cost little.
const SMOOTH_GAIN: f64 = 2e-4;

/// The gain `SMOOTH_GAIN` asks where a move aims at the angle (around an insertion on trial,
/// and slides along box faces): larger, so that those moves stay few and the trials'
/// outcomes as they were measured.
const ANGLE_GAIN: f64 = 2e-3;

/// A smoothing move for the radius ratios may lower its fan's smallest angle, but not below
/// this (nor below where it was): the mean radius ratio gains without giving the angle bar
/// (30°) away.
const KEEP_ANGLE: f64 = 34.0 * std::f64::consts::PI / 180.0;

/// Where a fan's radius ratios are probed along their gradient, as a fraction of its
/// longest edge; the step the secant rule takes from there lies between a sixteenth of it
/// and twice it (`Fan::ascent`).
const ASCENT_STEP: f64 = 0.08;

/// Only fans with a triangle of radius ratio below this try the angle's candidate places
/// (around an insertion every fan does): a fan of good triangles gains little for the cost
/// of a surfacepoint.
const SMOOTH_BELOW: f64 = 0.97;

/// The rounds proper smooth for the angle only the vertices within this many rings of a
/// triangle below the target; the ratios everywhere else are the smoothing rounds' and
/// `polish`'s. Smoothing also the corners of every triangle below 42° (the second to seventh sessions)
/// touched four in five of the fine sphere's vertices in each round for a mean radius ratio
/// that the ODT's first round then sets anyway (0.9771 with them, 0.9768 without, at 2.4
/// times the rounds' cost; docs/marcher.md, *The stage as cheap as its aim*).
const BAD_RINGS: usize = 2;

/// Rounds after `Limits::rounds`, while a triangle is still below the target, in which the
/// border vertices of such triangles slide along their box face (`slide`). Sliding from the
/// start changed which insertions the trials kept and left worse box-face triangles than
/// before (cylinder_box 22.6° against 31.5°, patches 15.9° against 26.5°); as a last resort
/// it only acts where the rounds proper left a bad triangle.
const SLIDE_ROUNDS: u32 = 2;

/// Rounds of the ODT smoothing (`Stage::odt_rounds`) between the two passes of
/// `polish`: genus 3
/// 0.9679, 0.9691, 0.9699 and 0.9699 of mean radius ratio after 1, 2, 4 and 6.
const ODT_ROUNDS: u32 = 4;

/// The centroid round is tried first only where the mean radius ratio is within this of
/// the aim. With an ODT round in its place (the eighth session), one round gained
/// 0.011–0.027 on the gallery's meshes and the fine sphere, and none more than this short of
/// 0.975 reached it (0.937–0.948 ended at 0.964–0.971); where it cannot, the round tried
/// first costs a round and leaves the ratio phase less to gain (the sweep's flat
/// superquadrics ended 0.002 lower with it). The centroid's round gains more (0.024 on the
/// fine sphere) but did not bring the gallery's meshes from 0.944–0.948 to the aim either:
/// at 0.035 or 0.05 they all took the full path after it, and ended up to 0.0007 lower.
const ODT_REACH: f64 = 0.025;

/// An ODT move may lengthen an edge of its fan while the edge's midpoint stays within this
/// fraction of the chord tolerance from the surface (at 0.25 genus 3 lost 0.001, at 1 it
/// gained 0.0001).
const ODT_CHORD: f64 = 0.5;

/// The whole-mesh scans that sum (`Stage::survey`, the end of each angle round) sum blocks
/// of this many triangles on rayon's pool and add the blocks' sums in order: the mean's
/// bits do not depend on the thread count.
const SCAN_BLOCK: usize = 1 << 14;

/// The centroid round takes the vertices in blocks of this many consecutive indices, each
/// block on rayon's pool with its own oracle from the fork: first the vertices whose ring
/// lies in their own block, in index order, then the others in index order in one thread.
/// A block's moves read and write only its own vertices, so the blocks' order does not
/// show, and the blocks are the same for any thread count. A mesh of at most this many
/// vertices is one block, smoothed in index order as before the blocks (the gallery's
/// meshes are the same bits). The march numbers its points as its front makes them, so
/// a ring's indices are near each other (on the fine sphere half of all edges join indices
/// at most 10 apart, 99 % at most 15 000): there 18 360 of 671 273 vertices wait for the
/// second pass.
const CENTROID_BLOCK: usize = 1 << 16;

/// A smoothing target nearer than this fraction of the vertex's local step is not taken
/// (nor projected): on the fine sphere three quarters of the moves were below it; skipping them
/// (and visiting only the vertices around the last round's moves) cost the gallery's means
/// at most 0.0004.
const ODT_SETTLE: f64 = 0.01;

/// What the stage aims at and how much it may do.
#[derive(Clone, Copy, Debug)]
pub(super) struct Limits {
    /// The target smallest angle (radians): triangles below it get insertions.
    pub angle: f64,
    /// Rounds of (flips, smoothing, insertion).
    pub rounds: u32,
    /// Largest number of new vertices, as a fraction of the triangles (plus 64).
    pub insert_fraction: f64,
    /// The largest chord error a flip may make (model units).
    pub tolerance: f64,
    /// The mean radius ratio the stage raises the mesh to once the angle is mended: a mesh
    /// at it is left as it is, one within `ODT_REACH` gets a centroid round, and only a mesh
    /// still below it gets the ratios' phase (`polish`).
    pub ratio: f64,
}

/// What the stage did, for `SURFC_TRACE`.
#[derive(Clone, Debug, Default)]
pub(super) struct Report {
    pub below_after: usize,
    pub flips: usize,
    pub moves: usize,
    /// Moves of the smoothing rounds (`Stage::centroid_round`, `Stage::odt_rounds`).
    pub smoothing_moves: usize,
    pub inserted: usize,
    /// Free corners removed (`Stage::remove_corner`).
    pub collapsed: usize,
    pub rounds: u32,
    /// Rounds of the radius ratio's phase after them (`polish`, both passes).
    pub polish_rounds: u32,
    /// Seconds the rounds proper took (the rest of the stage is `polish`).
    pub rounds_seconds: f64,
    /// Seconds the smoothing rounds took.
    pub smoothing_seconds: f64,
    /// Smoothing rounds towards the rings' centroids (`Stage::centroid_round`), and towards
    /// the ODT positions (`Stage::odt_rounds`).
    pub centroid_rounds: u32,
    pub odt_rounds: u32,
    /// The mean radius ratio after the rounds proper, and at the end.
    pub ratio_after_rounds: f64,
    pub ratio_after: f64,
    /// Why the stage stopped.
    pub stop: &'static str,
    /// The triangles left below the target whose corners are all free, as (centroid, the
    /// largest local step of its corners): no given corner excuses them, so the march's
    /// loop refines the local step there (`march_verified`).
    pub poor: Vec<(DVec3, f64)>,
    /// The worst triangle left below the target with a corner the stage may not move (a
    /// polygon vertex, a border point on the box, a corner at a non-manifold edge), as
    /// (sine of its smallest angle, centroid); there are `below_after − poor.len()` of
    /// them. No refinement of the local step moves those corners, so the user is told
    /// (`march_verified`'s warning).
    pub worst_held: Option<(f64, DVec3)>,
}

/// sin of the smallest angle of triangle (a, b, c): the smallest angle is opposite the
/// shortest edge, so sin = |(b−a)×(c−a)| / (product of the two longer edges). 0 if
/// degenerate.
pub(super) fn min_sin(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, bc, ca) = (
        a.distance_squared(b),
        b.distance_squared(c),
        c.distance_squared(a),
    );
    let shortest = ab.min(bc).min(ca);
    let longer = (ab * bc * ca / shortest).sqrt();
    let area2 = (b - a).cross(c - a).length();
    if longer > 0.0 && shortest > 0.0 {
        area2 / longer
    } else {
        0.0
    }
}

/// The sum of the shapes' radius ratios, in order.
fn ratio_sum_of(shapes: &[Shape]) -> f64 {
    shapes.iter().map(|shape| shape.ratio).sum()
}

/// The mean radius ratio of the shapes (1 for none), summed in blocks of `SCAN_BLOCK` on
/// rayon's pool and the blocks' sums added in order, as the scan at the end of an angle round
/// sums them: the same bits for any thread count.
fn mean_ratio(shapes: &[Shape]) -> f64 {
    if shapes.is_empty() {
        return 1.0;
    }
    let blocks: Vec<f64> = shapes.par_chunks(SCAN_BLOCK).map(ratio_sum_of).collect();
    blocks.iter().sum::<f64>() / shapes.len() as f64
}

/// The radius ratio 2·r_in/r_circ = 16·A² / (abc·(a+b+c)): 1 for an equilateral triangle,
/// 0 for a degenerate one.
pub(super) fn radius_ratio(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let area2 = (b - a).cross(c - a).length_squared(); // (2A)²
    ratio_of_sides(a.distance(b), b.distance(c), c.distance(a), area2)
}

/// (`min_sin`, `radius_ratio`) of a triangle, from one set of side lengths.
fn shape([a, b, c]: [DVec3; 3]) -> (f64, f64) {
    let (ab, bc, ca) = (
        a.distance_squared(b),
        b.distance_squared(c),
        c.distance_squared(a),
    );
    let area2 = (b - a).cross(c - a).length_squared();
    let sin = sin2_of(area2, ab, bc, ca).sqrt();
    (sin, ratio_of_sides(ab.sqrt(), bc.sqrt(), ca.sqrt(), area2))
}

/// sin² of the smallest angle of a triangle from |cross|² of two of its sides (`area2`) and
/// its squared sides: |c|²·m²/(x²y²z²), m the shortest side, with no square root. 0 if
/// degenerate.
fn sin2_of(area2: f64, x2: f64, y2: f64, z2: f64) -> f64 {
    let product = x2 * y2 * z2;
    if product > 0.0 {
        area2 * x2.min(y2).min(z2) / product
    } else {
        0.0
    }
}

/// 2·r_in/r_circ of a triangle with sides x, y, z and (2A)² = `area2`; 0 if degenerate.
fn ratio_of_sides(x: f64, y: f64, z: f64, area2: f64) -> f64 {
    let den = x * y * z * (x + y + z);
    if den > 0.0 { 4.0 * area2 / den } else { 0.0 }
}

/// The triangulation being improved: triangles with their half-edge twins.
pub(super) struct Stage<'a> {
    pub pos: &'a mut Vec<DVec3>,
    pub normal: &'a mut Vec<DVec3>,
    pub tri: &'a mut Vec<[u32; 3]>,
    pub border: &'a mut Vec<bool>,
    pub h: &'a mut Vec<f64>,
    /// Vertices below this index are polygon vertices.
    pub fixed: usize,
    pub bbox: Option<(DVec3, DVec3)>,
    /// Per half-edge 3t+k (from tri[t][k] to tri[t][k+1]): the half-edge running the other
    /// way, or NONE.
    twin: Vec<u32>,
    /// Per vertex: one outgoing half-edge (NONE for an unused vertex).
    out: Vec<u32>,
    /// Per vertex: touches an edge in more than two triangles (left alone).
    frozen: Vec<bool>,
    /// While an insertion is on trial: what it changed, to undo it.
    log: Option<Vec<Undo>>,
    /// Per vertex: the number of triangles around it (its valence where it is free).
    valence: Vec<u32>,
    /// sin² of the target angle (set by `run`): a fan with a triangle below it is smoothed
    /// for its angle first.
    bad_sin2: f64,
}

/// A triangle's smallest angle's sine (`min_sin`) and radius ratio (`radius_ratio`).
#[derive(Clone, Copy)]
struct Shape {
    sin: f64,
    ratio: f64,
}

/// One change recorded while an insertion is on trial.
enum Undo {
    Tri(u32, [u32; 3]),
    Twin(u32, u32),
    Out(u32, u32),
    Pos(u32, DVec3, DVec3),
}

/// Whether the angle opposite half-edge e (in its triangle) or opposite its twin f (in
/// theirs) is obtuse, by the triangles' `Stage::obtuse_corners` masks: the corner opposite
/// a half-edge is the next after its end.
fn obtuse_opposite(obtuse: &[u8], e: u32, f: u32) -> bool {
    let opposite = |g: u32| 1u8 << ((g + 2) % 3);
    obtuse[(e / 3) as usize] & opposite(e) != 0 || obtuse[(f / 3) as usize] & opposite(f) != 0
}

fn next(e: u32) -> u32 {
    if e % 3 == 2 { e - 2 } else { e + 1 }
}

fn prev(e: u32) -> u32 {
    if e % 3 == 0 { e + 2 } else { e - 1 }
}

impl<'a> Stage<'a> {
    /// Builds the half-edge twins of `tri`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        pos: &'a mut Vec<DVec3>,
        normal: &'a mut Vec<DVec3>,
        tri: &'a mut Vec<[u32; 3]>,
        border: &'a mut Vec<bool>,
        h: &'a mut Vec<f64>,
        fixed: usize,
        bbox: Option<(DVec3, DVec3)>,
    ) -> Self {
        let n = pos.len();
        let corners = 3 * tri.len();
        // Per vertex, its corners in triangle order, each named by the half-edge leaving it
        // (3t + k): a counting sort into one array, vertex a's run from `first[a]` to
        // `first[a + 1]`, so that blocks of vertices can be taken in parallel below (a
        // linked list threaded through `twin`, as before, saved this array's 12 bytes a
        // triangle but had to be walked in one thread).
        let mut first = vec![0u32; n + 1];
        for t in tri.iter() {
            for &v in t {
                first[v as usize] += 1;
            }
        }
        // First where each run ends; filled from the last corner down, each run comes out
        // in increasing order and `first` at the runs' starts (`first[n]` the total).
        for a in 1..=n {
            first[a] += first[a - 1];
        }
        let mut corner = vec![0u32; corners];
        for e in (0..corners).rev() {
            let a = tri[e / 3][e % 3] as usize;
            first[a] -= 1;
            corner[first[a] as usize] = e as u32;
        }
        // At the corner of triangle (a, b, c) at a, the half-edge a → b leaves a and c → a
        // arrives: the twin of a → b (the half-edge b → a) is the arriving half-edge of the
        // corner of a whose third vertex is b. Every twin is found among one vertex's own
        // corners: searching the other end's corners, as before, took half as long again
        // on the fine sphere. Each vertex writes only its own corners' twins (and, at a
        // non-manifold edge, marks both ends frozen, which commutes): the vertices are
        // taken in parallel, in blocks, and the result is the same for any thread count.
        let twin: Vec<AtomicU32> = (0..corners)
            .into_par_iter()
            .map(|_| AtomicU32::new(NONE))
            .collect();
        let frozen: Vec<AtomicBool> = (0..n).map(|_| AtomicBool::new(false)).collect();
        let mut out = vec![NONE; n];
        out.par_chunks_mut(TWIN_BLOCK)
            .enumerate()
            .for_each(|(block, out)| {
                // The corners of one vertex: (leaving half-edge, its end b, the third vertex c).
                let mut fan: Vec<(u32, u32, u32)> = Vec::new();
                for (i, out) in out.iter_mut().enumerate() {
                    let a = block * TWIN_BLOCK + i;
                    fan.clear();
                    for &e in &corner[first[a] as usize..first[a + 1] as usize] {
                        let t = tri[(e / 3) as usize];
                        fan.push((e, t[((e + 1) % 3) as usize], t[((e + 2) % 3) as usize]));
                    }
                    if let Some(&(e, _, _)) = fan.first() {
                        *out = e;
                    }
                    // A manifold vertex (nearly every one) has its corners' ends all
                    // different, and their third vertices too: then a half-edge's twin is the
                    // one arriving from its end, if any. Elsewhere an end met twice is a
                    // non-manifold edge: no twins there.
                    let manifold = fan
                        .iter()
                        .enumerate()
                        .all(|(i, x)| fan[i + 1..].iter().all(|y| x.1 != y.1 && x.2 != y.2));
                    // A vertex with more than one boundary edge leaving it is where two fans
                    // touch: neither smoothing nor a slide sees all its triangles, so it stays.
                    let mut gaps = 0;
                    for &(e, b, _) in &fan {
                        // Half-edges a → b, and the first b → a and whether there is another.
                        let leaving = if manifold {
                            1
                        } else {
                            fan.iter().filter(|d| d.1 == b).count()
                        };
                        let mut arriving = fan.iter().filter(|d| d.2 == b);
                        let (back, more) =
                            (arriving.next(), !manifold && arriving.next().is_some());
                        match (leaving, back, more) {
                            (1, Some(back), false) => twin[e as usize].store(prev(back.0), Relaxed),
                            (1, None, _) => gaps += 1,
                            _ => {
                                frozen[a].store(true, Relaxed);
                                frozen[b as usize].store(true, Relaxed);
                                gaps += 1;
                            }
                        }
                    }
                    if gaps > 1 {
                        frozen[a].store(true, Relaxed);
                    }
                }
            });
        let twin = twin.into_iter().map(AtomicU32::into_inner).collect();
        let frozen = frozen.into_iter().map(AtomicBool::into_inner).collect();
        Stage {
            pos,
            normal,
            tri,
            border,
            h,
            fixed,
            bbox,
            twin,
            out,
            frozen,
            log: None,
            valence: Vec::new(),
            bad_sin2: 0.0,
        }
    }

    fn org(&self, e: u32) -> u32 {
        self.tri[(e / 3) as usize][(e % 3) as usize]
    }

    fn dst(&self, e: u32) -> u32 {
        self.org(next(e))
    }

    fn p(&self, v: u32) -> DVec3 {
        self.pos[v as usize]
    }

    fn corners(&self, t: [u32; 3]) -> [DVec3; 3] {
        t.map(|v| self.p(v))
    }

    fn q(&self, t: [u32; 3]) -> f64 {
        let [a, b, c] = self.corners(t);
        min_sin(a, b, c)
    }

    /// A vertex that may move: not a polygon vertex, not on the box, not at a
    /// non-manifold edge.
    fn free(&self, v: u32) -> bool {
        (v as usize) >= self.fixed && !self.border[v as usize] && !self.frozen[v as usize]
    }

    /// An edge that is part of a given polygon (both ends polygon vertices) or at a
    /// non-manifold place: never flipped or split.
    fn constrained(&self, a: u32, b: u32) -> bool {
        ((a as usize) < self.fixed && (b as usize) < self.fixed)
            || self.frozen[a as usize]
            || self.frozen[b as usize]
    }

    /// Triangle `t` with corners `p` faces the side ∇f points to at every corner, and its
    /// plane is no steeper than 60° to the normal at any corner unless it already was.
    fn facing(&self, t: [u32; 3], p: [DVec3; 3]) -> bool {
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.length();
        len > 0.0 && t.iter().all(|&v| n.dot(self.normal[v as usize]) > 0.0)
    }

    /// The outgoing half-edges of v in counter-clockwise order, or None where the fan is
    /// not closed (a boundary vertex) or too long.
    fn star(&self, v: u32, buf: &mut Vec<u32>) -> bool {
        buf.clear();
        let first = self.out[v as usize];
        if first == NONE {
            return false;
        }
        let mut e = first;
        loop {
            buf.push(e);
            let back = self.twin[prev(e) as usize];
            if back == NONE || buf.len() > MAX_STAR {
                return false;
            }
            e = back;
            if e == first {
                return true;
            }
        }
    }

    /// Sets triangle t to `v` and records its outgoing half-edges.
    fn set(&mut self, t: u32, v: [u32; 3]) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Tri(t, self.tri[t as usize]));
            log.extend(v.iter().map(|&p| Undo::Out(p, self.out[p as usize])));
        }
        self.tri[t as usize] = v;
        for (k, &p) in v.iter().enumerate() {
            self.out[p as usize] = 3 * t + k as u32;
        }
    }

    fn link(&mut self, e: u32, f: u32) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Twin(e, self.twin[e as usize]));
            if f != NONE {
                log.push(Undo::Twin(f, self.twin[f as usize]));
            }
        }
        self.twin[e as usize] = f;
        if f != NONE {
            self.twin[f as usize] = e;
        }
    }

    /// Puts vertex v at p with normal n (recorded while an insertion is on trial).
    fn place(&mut self, v: u32, p: DVec3, n: DVec3) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Pos(v, self.pos[v as usize], self.normal[v as usize]));
        }
        self.pos[v as usize] = p;
        self.normal[v as usize] = n;
    }

    /// Inserts a vertex for bad triangle t on trial: kept only if, after flips around it
    /// and smoothing of it and its ring, every triangle the insertion changed has a larger
    /// smallest angle than t had. Returns whether it was kept.
    fn insert_on_trial(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
        sliding: bool,
        project: &mut Project<'_>,
    ) -> (bool, usize) {
        let before = self.q(self.tri[t as usize]);
        let (points, triangles) = (self.pos.len(), self.tri.len());
        self.log = Some(Vec::new());
        let mut flips = 0;
        let kept = 'trial: {
            let Some(p) = self.insert(t, surface, project) else {
                break 'trial false;
            };
            let mut star = Vec::new();
            if self.star(p, &mut star) || (sliding && self.open_star(p, &mut star)) {
                let q: Vec<u32> = star.iter().map(|&e| next(e)).collect();
                flips = self.flip_all(q, None, 64, surface, tolerance, None).0;
            }
            // Smooth the new vertex, the corners of every triangle changed, and the new
            // vertex again.
            let mut ring: Vec<u32> = self
                .log
                .iter()
                .flatten()
                .filter_map(|u| match u {
                    Undo::Tri(t, _) => Some(self.tri[*t as usize]),
                    _ => None,
                })
                .flatten()
                .filter(|&v| v != p)
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let mut moved = vec![p];
            for v in std::iter::once(p).chain(ring).chain(std::iter::once(p)) {
                if (sliding || self.free(v))
                    && self.relax(v, &mut star, f64::INFINITY, false, surface, project)
                {
                    moved.push(v);
                }
            }
            // The triangles changed: those whose slots were set, and the fans of moved
            // vertices.
            let mut after = f64::INFINITY;
            let slots: Vec<u32> = self
                .log
                .iter()
                .flatten()
                .filter_map(|u| match u {
                    Undo::Tri(t, _) => Some(*t),
                    _ => None,
                })
                .collect();
            for s in slots {
                after = after.min(self.q(self.tri[s as usize]));
            }
            for v in moved {
                if self.star(v, &mut star) || self.open_star(v, &mut star) {
                    for &e in &star {
                        after = after.min(self.q(self.tri[(e / 3) as usize]));
                    }
                }
            }
            after > before
        };
        let log = self.log.take().unwrap_or_default();
        if !kept {
            for u in log.into_iter().rev() {
                match u {
                    Undo::Tri(t, v) => self.tri[t as usize] = v,
                    Undo::Twin(e, f) => self.twin[e as usize] = f,
                    Undo::Out(v, e) => self.out[v as usize] = e,
                    Undo::Pos(v, p, n) => {
                        self.pos[v as usize] = p;
                        self.normal[v as usize] = n;
                    }
                }
            }
            self.pos.truncate(points);
            self.normal.truncate(points);
            self.border.truncate(points);
            self.h.truncate(points);
            self.out.truncate(points);
            self.frozen.truncate(points);
            self.tri.truncate(triangles);
            self.twin.truncate(3 * triangles);
            return (false, 0);
        }
        (true, flips)
    }

    // ---------------------------------------------------------------- flips

    /// Flips the edge of half-edge e if the quad violates the Delaunay condition (the angles
    /// opposite the edge sum to more than π), the flip does not lower the smaller of the
    /// pair's smallest angles, both new triangles face ∇f, the pair is not folded, and the
    /// new edge's midpoint is within `tolerance` of the surface. Returns whether it flipped.
    fn try_flip(&mut self, e: u32, surface: &mut dyn Surface, tolerance: f64) -> bool {
        self.try_flip_as(e, surface, tolerance, None)
    }

    fn try_flip_as(
        &mut self,
        e: u32,
        surface: &mut dyn Surface,
        tolerance: f64,
        valence_floor: Option<f64>,
    ) -> bool {
        let f = self.twin[e as usize];
        if f == NONE {
            return false;
        }
        let (a, b) = (self.org(e), self.dst(e));
        let c = self.org(prev(e));
        let d = self.org(prev(f));
        if c == d || self.constrained(a, b) {
            return false;
        }
        let (nt, nu) = ([a, d, c], [d, b, c]);
        let old = || self.q([a, b, c]).min(self.q([b, a, d]));
        // The cheap tests first (most edges fail them): the valences before the vertices'
        // flags and positions.
        if let Some(floor) = valence_floor {
            let val = |v: u32| self.valence[v as usize] as f64;
            let en = |x: f64| (x - 6.0) * (x - 6.0);
            let before = en(val(a)) + en(val(b)) + en(val(c)) + en(val(d));
            let after = en(val(a) - 1.0) + en(val(b) - 1.0) + en(val(c) + 1.0) + en(val(d) + 1.0);
            if after >= before {
                return false;
            }
            if ![a, b, c, d].iter().all(|&v| self.free(v)) {
                return false;
            }
            if self.q(nt).min(self.q(nu)) < old().min(floor) {
                return false;
            }
        } else {
            // sin(α + β) of the angles at c and d opposite a–b, without inverse cosines:
            // α + β > π + margin exactly where it is below −sin(margin).
            let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.p(v));
            let (u1, v1, u2, v2) = (pa - pc, pb - pc, pa - pd, pb - pd);
            // Neither angle obtuse: both terms of sin(α + β) below are ≥ 0, so the test
            // fails; most edges of a marched mesh end here, before the lengths and crosses.
            let (cos1, cos2) = (u1.dot(v1), u2.dot(v2));
            if cos1 >= 0.0 && cos2 >= 0.0 {
                return false;
            }
            let lens = u1.length() * v1.length() * u2.length() * v2.length();
            let sin_sum = u1.cross(v1).length() * cos2 + cos1 * u2.cross(v2).length();
            if !(lens > 0.0 && sin_sum < -DELAUNAY_MARGIN.sin() * lens) {
                return false;
            }
            if self.q(nt).min(self.q(nu)) < old() {
                return false;
            }
        }
        let (pt, pu) = (self.corners(nt), self.corners(nu));
        if !self.facing(nt, pt) || !self.facing(nu, pu) {
            return false;
        }
        let n1 = (pt[1] - pt[0]).cross(pt[2] - pt[0]).normalize_or_zero();
        let n2 = (pu[1] - pu[0]).cross(pu[2] - pu[0]).normalize_or_zero();
        if n1.dot(n2) < FOLD_COS {
            return false;
        }
        // c–d must not already be an edge (the flip would make it non-manifold).
        if self.edge_exists(c, d) {
            return false;
        }
        if !midpoint_within(surface, self.p(c), self.p(d), tolerance) {
            return false;
        }
        let [o_ad, o_db, o_bc, o_ca] = self.outer(e, f);
        let (t, u) = (e / 3, f / 3);
        self.set(t, nt);
        self.set(u, nu);
        // t = [a, d, c]: a→d, d→c, c→a; u = [d, b, c]: d→b, b→c, c→d.
        self.link(3 * t, o_ad);
        self.link(3 * t + 1, 3 * u + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * u, o_db);
        self.link(3 * u + 1, o_bc);
        if valence_floor.is_some() {
            self.valence[a as usize] -= 1;
            self.valence[b as usize] -= 1;
            self.valence[c as usize] += 1;
            self.valence[d as usize] += 1;
        }
        true
    }

    /// The twins of the four outer edges of the quad over half-edge e = a→b (in t, with c)
    /// and its twin f = b→a (in u, with d): [a→d, d→b, b→c, c→a].
    fn outer(&self, e: u32, f: u32) -> [u32; 4] {
        [next(f), prev(f), next(e), prev(e)].map(|x| self.twin[x as usize])
    }

    /// Whether a and b are joined by an edge (searched around a, both ways from out[a]).
    fn edge_exists(&self, a: u32, b: u32) -> bool {
        let first = self.out[a as usize];
        if first == NONE {
            return false;
        }
        // Counter-clockwise until the fan closes or opens.
        let mut e = first;
        for _ in 0..=MAX_STAR {
            if self.dst(e) == b || self.org(prev(e)) == b {
                return true;
            }
            let back = self.twin[prev(e) as usize];
            if back == NONE || back == first {
                break;
            }
            e = back;
        }
        // Clockwise from the first (an open fan).
        let mut e = first;
        for _ in 0..=MAX_STAR {
            let t = self.twin[e as usize];
            if t == NONE {
                break;
            }
            e = next(t);
            if e == first {
                break;
            }
            if self.dst(e) == b || self.org(prev(e)) == b {
                return true;
            }
        }
        false
    }

    /// Flips until no edge of `queue` (and of what the flips touch) violates the Delaunay
    /// condition, at most `budget` flips. With `obtuse` (`delaunay_queue`'s screen), an
    /// edge the flips push is tried only where a triangle of its has an obtuse angle
    /// opposite it, the masks kept up to date through the flips. With `flipped`, the two
    /// triangles of every flip are listed there.
    fn flip_all(
        &mut self,
        mut queue: Vec<u32>,
        mut obtuse: Option<Vec<u8>>,
        budget: usize,
        surface: &mut dyn Surface,
        tolerance: f64,
        mut flipped: Option<&mut Vec<u32>>,
    ) -> (usize, bool) {
        let mut flips = 0;
        queue.reverse();
        while let Some(e) = queue.pop() {
            if flips >= budget {
                return (flips, false);
            }
            let f = self.twin[e as usize];
            if f == NONE {
                continue;
            }
            let (t, u) = (e / 3, f / 3);
            if obtuse
                .as_deref()
                .is_some_and(|obtuse| !obtuse_opposite(obtuse, e, f))
            {
                continue;
            }
            if self.try_flip(e, surface, tolerance) {
                flips += 1;
                if let Some(flipped) = &mut flipped {
                    flipped.extend([t, u]);
                }
                if let Some(obtuse) = &mut obtuse {
                    obtuse[t as usize] = self.obtuse_corners(t);
                    obtuse[u as usize] = self.obtuse_corners(u);
                }
                // The four outer edges of the quad.
                for x in [3 * t, 3 * t + 2, 3 * u, 3 * u + 1] {
                    queue.push(x);
                }
            }
        }
        (flips, true)
    }

    /// Bit k: the angle of triangle t at its corner k is obtuse (the dot product of its
    /// sides there is negative, computed as `try_flip_as` does).
    fn obtuse_corners(&self, t: u32) -> u8 {
        let p = self.corners(self.tri[t as usize]);
        (0..3).fold(0, |bits, k| {
            // Corner k is opposite the side from corner k + 1 to k + 2.
            let (a, b, c) = (p[(k + 1) % 3], p[(k + 2) % 3], p[k]);
            if (a - c).dot(b - c) < 0.0 {
                bits | 1 << k
            } else {
                bits
            }
        })
    }

    // ------------------------------------------------------------ smoothing

    /// The worst smallest-angle sine, the worst radius ratio and the sum of radius ratios of
    /// the fan of v (half-edges `star`) with v at `p`.
    fn star_quality(&self, star: &[u32], p: DVec3) -> (f64, f64, f64) {
        let (mut worst, mut worst_rr, mut sum) = (f64::INFINITY, f64::INFINITY, 0.0);
        for &e in star {
            let (b, c) = (self.p(self.dst(e)), self.p(self.org(prev(e))));
            worst = worst.min(min_sin(p, b, c));
            let rr = radius_ratio(p, b, c);
            worst_rr = worst_rr.min(rr);
            sum += rr;
        }
        (worst, worst_rr, sum)
    }

    /// Zhou–Shimada's angle-based position for v, in the tangent plane at v: each ring
    /// neighbour proposes the point at v's distance on the bisector of its own angle in the
    /// ring; the mean of the proposals.
    fn angle_based(&self, v: u32, star: &[u32]) -> DVec3 {
        let (p, n) = (self.p(v), self.normal[v as usize]);
        let flat = |q: DVec3| q - (q - p).dot(n) * n;
        let k = star.len().min(MAX_FAN);
        let mut ring = [DVec3::ZERO; MAX_FAN];
        for (r, &e) in ring.iter_mut().zip(star) {
            *r = flat(self.p(self.dst(e)));
        }
        let mut sum = DVec3::ZERO;
        for j in 0..k {
            let pj = ring[j];
            let (before, after) = (ring[(j + k - 1) % k], ring[(j + 1) % k]);
            let mut bis = (before - pj).normalize_or_zero() + (after - pj).normalize_or_zero();
            if bis.dot(p - pj) < 0.0 {
                bis = -bis;
            }
            let bis = bis.normalize_or_zero();
            if bis == DVec3::ZERO {
                sum += p;
            } else {
                sum += pj + p.distance(pj) * bis;
            }
        }
        sum / k as f64
    }

    /// The apex of the equilateral triangle over the far edge of the fan's worst triangle
    /// (in the tangent plane at v): where the worst triangle wants v.
    fn ideal_apex(&self, v: u32, star: &[u32]) -> DVec3 {
        let (p, n) = (self.p(v), self.normal[v as usize]);
        // The first worst triangle (as `min_by` would pick it), each sine computed once.
        let mut worst: Option<(f64, (DVec3, DVec3))> = None;
        for &e in star {
            let (b, c) = (self.p(self.dst(e)), self.p(self.org(prev(e))));
            let sin = min_sin(p, b, c);
            if worst.is_none_or(|(w, _)| sin.total_cmp(&w).is_lt()) {
                worst = Some((sin, (b, c)));
            }
        }
        worst.map_or(p, |(_, (b, c))| {
            let d = c - b;
            let left = n.cross(d).normalize_or_zero();
            let m = 0.5 * (b + c);
            let m = m - (m - p).dot(n) * n;
            m + left * (d.length() * 3f64.sqrt() / 2.0)
        })
    }

    /// Moves free vertex v to a better place on the surface. For the angle (`ratio` false:
    /// the rounds proper and insertions on trial), where the fan has a triangle of radius
    /// ratio below `below`: the angle-based position, the mean of the ring and halfway to
    /// either or towards the worst triangle's ideal apex, the first that is better (the
    /// fan's smallest angle rises, or stays and its radius ratios rise by `ANGLE_GAIN`). For
    /// the ratios (`polish`): first a step up the gradient of the fan's sum of radius ratios
    /// (`Fan::ascent`), then the same candidates, better if the smallest angle rises or the
    /// ratios rise by `SMOOTH_GAIN` while the smallest angle stays at or above min(its old
    /// value, `KEEP_ANGLE`). The candidate is projected; the move is kept if the fan is
    /// still better there, every triangle faces ∇f and no edge of the fan grows beyond its
    /// longest.
    fn smooth(
        &mut self,
        v: u32,
        star: &[u32],
        below: f64,
        ratio: bool,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> bool {
        let Some(fan) = Fan::closed(self, star) else {
            return false;
        };
        let p = self.p(v);
        let for_angle = !ratio;
        let (old, gradient) = if for_angle {
            (fan.eval(p), DVec3::ZERO)
        } else {
            fan.eval_grad(p)
        };
        let longest = fan.longest(p);
        let (keep, gain) = if for_angle {
            (old.worst, ANGLE_GAIN)
        } else {
            (old.worst.min(KEEP_ANGLE.sin().powi(2)), SMOOTH_GAIN)
        };
        let better = |q: &FanQuality| {
            q.worst > old.worst * (1.0 + 1e-6) || (q.worst >= keep && q.sum > old.sum + gain)
        };
        let n = self.normal[v as usize];
        // For the ratios, a fan with a triangle below the target tries the angle's candidates
        // first (the ascent would take the move and leave the angle where it is); the others
        // the ascent first. For the angle, only the angle's candidates.
        let angle_first = for_angle || old.worst < self.bad_sin2;
        let by_ratio = || {
            if for_angle {
                return None;
            }
            fan.ascent(p, n, gradient, longest.sqrt())?
                .into_iter()
                .find(|&q| better(&fan.eval(q)))
        };
        let by_angle = |s: &Self| {
            if old.worst_rr >= below {
                return None;
            }
            let ring_mean = fan.ring[..fan.k]
                .iter()
                .map(|&q| q - (q - p).dot(n) * n)
                .sum::<DVec3>()
                / fan.k as f64;
            let ab = s.angle_based(v, star);
            [ab, ring_mean, 0.5 * (p + ab), 0.5 * (p + ring_mean)]
                .into_iter()
                .find(|&q| better(&fan.eval(q)))
                .or_else(|| {
                    // Towards the worst triangle's ideal apex, computed only when the
                    // candidates above fail.
                    let ideal = s.ideal_apex(v, star);
                    [
                        0.5 * (p + ideal),
                        0.75 * p + 0.25 * ideal,
                        0.875 * p + 0.125 * ideal,
                    ]
                    .into_iter()
                    .find(|&q| better(&fan.eval(q)))
                })
        };
        let target = if angle_first {
            by_angle(self).or_else(by_ratio)
        } else {
            by_ratio().or_else(|| by_angle(self))
        };
        let Some(target) = target else {
            return false;
        };
        let Some((sp, sn)) = project(target) else {
            return false;
        };
        if better(&fan.eval(sp)) && fan.holds(sp, sn, longest) {
            self.place(v, sp, sn);
            true
        } else {
            false
        }
    }

    /// Puts v at `to` (point, normal) if the fan is `better` there, every triangle of it
    /// still faces ∇f and no edge of it is longer than `longest` (squared): what a move
    /// checks once its target is on the surface. Returns whether v moved.
    fn move_if(
        &mut self,
        v: u32,
        star: &[u32],
        to: (DVec3, DVec3),
        longest: f64,
        better: &dyn Fn(&Self, DVec3) -> bool,
    ) -> bool {
        let (sp, sn) = to;
        let (old_p, old_n) = (self.p(v), self.normal[v as usize]);
        self.pos[v as usize] = sp;
        self.normal[v as usize] = sn;
        let ok = better(self, sp)
            && star.iter().all(|&e| {
                let t = self.tri[(e / 3) as usize];
                self.facing(t, self.corners(t))
                    && sp.distance_squared(self.p(self.dst(e))) <= longest
            });
        self.pos[v as usize] = old_p;
        self.normal[v as usize] = old_n;
        if ok {
            self.place(v, sp, sn);
        }
        ok
    }

    /// Moves vertex v to a better place if it may move: a free vertex on the surface
    /// (`smooth`), a border vertex along its box face (`slide`). `star` is scratch space.
    fn relax(
        &mut self,
        v: u32,
        star: &mut Vec<u32>,
        below: f64,
        ratio: bool,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
    ) -> bool {
        if self.free(v) {
            if !self.star(v, star) {
                return false;
            }
            let mut proj = |q: DVec3| project(surface, q);
            self.smooth(v, star, below, ratio, &mut proj)
        } else if let Some(face) = self.slide_face(v).filter(|_| !ratio) {
            self.open_star(v, star) && self.slide(v, star, face, below, surface)
        } else {
            false
        }
    }

    // ------------------------------------------------------------ box faces

    /// The box face a border vertex may slide on, as (axis, value): a border point that is
    /// no polygon vertex, touches no non-manifold edge, and lies on exactly one face of the
    /// box (a point on a box edge or corner stays, so the box's edges keep their points).
    fn slide_face(&self, v: u32) -> Option<(usize, f64)> {
        let i = v as usize;
        if i < self.fixed || !self.border[i] || self.frozen[i] {
            return None;
        }
        self.face_of(self.p(v))
    }

    /// The outgoing half-edges of border vertex v in counter-clockwise order, from the
    /// boundary edge leaving v to the one arriving at it; false if the fan is closed, has
    /// more than one gap, or is too long.
    fn open_star(&self, v: u32, buf: &mut Vec<u32>) -> bool {
        buf.clear();
        let first = self.out[v as usize];
        if first == NONE {
            return false;
        }
        // Clockwise to the half-edge whose edge is on the boundary.
        let mut e = first;
        for _ in 0..=MAX_STAR {
            let t = self.twin[e as usize];
            if t == NONE {
                break;
            }
            e = next(t);
            if e == first {
                return false;
            }
        }
        if self.twin[e as usize] != NONE {
            return false;
        }
        loop {
            buf.push(e);
            let back = self.twin[prev(e) as usize];
            if back == NONE {
                break;
            }
            if buf.len() > MAX_STAR {
                return false;
            }
            e = back;
        }
        // A second gap would leave triangles out: `new` froze such vertices.
        true
    }

    /// Slides border vertex v along the curve where the surface meets its box face (the
    /// face coordinate held exactly, `face_point`), if a place on that curve raises the
    /// fan's quality as `smooth` asks. Targets: the point between the two boundary
    /// neighbours, and the worst triangle's ideal apex and the ring's mean projected onto
    /// the curve's tangent, each also halfway.
    fn slide(
        &mut self,
        v: u32,
        star: &[u32],
        face: (usize, f64),
        below: f64,
        surface: &mut dyn Surface,
    ) -> bool {
        let p = self.p(v);
        let (old_worst, old_worst_rr, old_sum) = self.star_quality(star, p);
        if old_worst_rr >= below {
            return false;
        }
        let (axis, value) = face;
        let n = self.normal[v as usize];
        let mut along = DVec3::ZERO;
        along[axis] = 1.0;
        let tangent = n.cross(along).normalize_or_zero();
        if tangent == DVec3::ZERO {
            return false;
        }
        let (Some(&e0), Some(&e1)) = (star.first(), star.last()) else {
            return false;
        };
        let (b0, b1) = (self.p(self.dst(e0)), self.p(self.org(prev(e1))));
        let ring_mean =
            star.iter().map(|&e| self.p(self.dst(e))).sum::<DVec3>() / star.len() as f64;
        let ideal = self.ideal_apex(v, star);
        let on_line = |q: DVec3| p + tangent * (q - p).dot(tangent);
        let targets = [on_line(0.5 * (b0 + b1)), on_line(ideal), on_line(ring_mean)];
        let better = |s: &Self, q: DVec3| {
            let (w, _, sum) = s.star_quality(star, q);
            w > old_worst * (1.0 + 1e-6) || (w >= old_worst && sum > old_sum + ANGLE_GAIN)
        };
        let longest = star
            .iter()
            .map(|&e| p.distance_squared(self.p(self.dst(e))))
            .fold(0.0f64, f64::max);
        let scale = self.h[v as usize];
        for target in targets.into_iter().flat_map(|q| [q, 0.5 * (p + q)]) {
            if !better(self, target) {
                continue;
            }
            let Some((sp, sn)) = face_point(surface, target, axis, value, scale) else {
                continue;
            };
            if self.in_box(sp)
                && self.face_of(sp) == Some(face)
                && self.move_if(v, star, (sp, sn), longest, &better)
            {
                return true;
            }
        }
        false
    }

    /// The face of the box point p is on, as (axis, value), if it is on exactly one (a slide
    /// must not end on a box edge, where the next could not tell its face).
    fn face_of(&self, p: DVec3) -> Option<(usize, f64)> {
        let (lo, hi) = self.bbox?;
        let mut on = (0..3).filter_map(|k| {
            [lo[k], hi[k]]
                .into_iter()
                .find(|&b| p[k] == b)
                .map(|b| (k, b))
        });
        let face = on.next()?;
        on.next().is_none().then_some(face)
    }

    // ------------------------------------------------------------ removal

    /// Removes a free corner c of bad triangle t by merging it into one of t's other two
    /// corners (the kept corner stays where it is), where neither a flip, the smoothing nor
    /// an insertion mended t: a needle's short edge (the sweep's blobs had 8° triangles at
    /// their necks that the off-centres only ever made smaller), or an obtuse free corner
    /// resting on an edge no flip may change (a box's or a polygon's). Of every free corner
    /// and either kept corner, the merge that leaves the best smallest angle is taken, and
    /// only if every triangle it makes faces ∇f, folds no more than a flip may, has a
    /// smallest angle above the worst of c's fan before, and every new edge has its midpoint
    /// within `tolerance` of the surface; and only where the merge keeps the mesh a
    /// manifold (c's ring and the kept corner's neighbours share only the two corners next
    /// to it). The two triangles at the edge c–keep go, the others of c's fan take the kept
    /// corner instead of c, and c is left unused (dropped after the stage). Returns the
    /// kept corner.
    fn remove_corner(&mut self, t: u32, surface: &mut dyn Surface, tolerance: f64) -> Option<u32> {
        debug_assert!(self.log.is_none());
        let tv = self.tri[t as usize];
        // (worst new sine, c, its star, index in c's ring of the kept corner).
        let mut best: Option<(f64, u32, Vec<u32>, usize)> = None;
        for k in 0..3 {
            let c = tv[k];
            let mut star = Vec::new();
            if !self.free(c) || !self.star(c, &mut star) {
                continue;
            }
            let others = [tv[(k + 1) % 3], tv[(k + 2) % 3]];
            if let Some((worst, i)) = self.best_merge(&star, others, surface, tolerance) {
                if best.as_ref().is_none_or(|b| worst > b.0) {
                    best = Some((worst, c, star, i));
                }
            }
        }
        let (_, c, star, i) = best?;
        let ring: Vec<u32> = star.iter().map(|&e| self.dst(e)).collect();
        let n = ring.len();
        let keep = ring[i];
        // The triangles of c's fan: star[j] leaves c towards ring[j]; its triangle is
        // (c, ring[j], ring[j + 1]). The two at the edge c–keep are star[i] (c, keep,
        // ring[i + 1]) and star[i − 1] (c, ring[i − 1], keep).
        let gone = [star[i] / 3, star[(i + n - 1) % n] / 3];
        let kept: Vec<u32> = star
            .iter()
            .map(|&e| e / 3)
            .filter(|t| !gone.contains(t))
            .collect();
        // The triangles on the far side of the removed ones' outer edges.
        let mut around: Vec<u32> = Vec::new();
        for &g in &gone {
            for h in 0..3 {
                let tw = self.twin[(3 * g + h) as usize];
                if tw != NONE && !gone.contains(&(tw / 3)) {
                    around.push(tw / 3);
                }
            }
        }
        for &u in &kept {
            let v = self.tri[u as usize].map(|x| if x == c { keep } else { x });
            self.tri[u as usize] = v;
        }
        // Relink the half-edges of the changed triangles and their far neighbours among
        // themselves; an edge with no partner among them keeps its twin if that still runs
        // the other way, else it is open.
        let mut local: Vec<u32> = kept.iter().chain(&around).copied().collect();
        local.sort_unstable();
        local.dedup();
        let half: Vec<u32> = local
            .iter()
            .flat_map(|&u| (0..3).map(move |h| 3 * u + h))
            .collect();
        for &e in &half {
            let (o, d) = (self.org(e), self.dst(e));
            let partner = half
                .iter()
                .copied()
                .find(|&f| self.org(f) == d && self.dst(f) == o);
            let tw = self.twin[e as usize];
            let twin = match partner {
                Some(f) => f,
                None if tw != NONE
                    && !gone.contains(&(tw / 3))
                    && self.org(tw) == d
                    && self.dst(tw) == o =>
                {
                    tw
                }
                None => NONE,
            };
            self.twin[e as usize] = twin;
            if twin != NONE {
                self.twin[twin as usize] = e;
            }
        }
        self.out[c as usize] = NONE;
        for &u in &local {
            for (h, &v) in self.tri[u as usize].iter().enumerate() {
                self.out[v as usize] = 3 * u + h as u32;
            }
        }
        // Remove the two triangles, the higher index first (each swap moves the last
        // triangle into the freed slot).
        let mut gone = gone;
        gone.sort_unstable_by(|x, y| y.cmp(x));
        for g in gone {
            self.remove_triangle(g);
        }
        Some(keep)
    }

    /// For free vertex c with closed fan `star`: the best of merging c into either vertex
    /// of `keeps` (both in c's ring), as (the new triangles' worst sine, index in the ring
    /// of the kept corner), if it passes `remove_corner`'s tests.
    fn best_merge(
        &self,
        star: &[u32],
        keeps: [u32; 2],
        surface: &mut dyn Surface,
        tolerance: f64,
    ) -> Option<(f64, usize)> {
        let ring: Vec<u32> = star.iter().map(|&e| self.dst(e)).collect();
        let old_worst = star
            .iter()
            .map(|&e| self.q(self.tri[(e / 3) as usize]))
            .fold(f64::INFINITY, f64::min);
        let n = ring.len();
        let mut best: Option<(f64, usize)> = None;
        for (i, &keep) in ring.iter().enumerate() {
            // A corner at a non-manifold edge has more than one fan: the manifold test
            // below could not see all its edges.
            if !keeps.contains(&keep) || self.frozen[keep as usize] {
                continue;
            }
            // The new edges keep–r, r the ring's other corners, must not exist yet.
            let others: Vec<u32> = (2..n - 1).map(|j| ring[(i + j) % n]).collect();
            if others
                .iter()
                .any(|&r| r == keep || self.edge_exists(keep, r))
            {
                continue;
            }
            let pk = self.p(keep);
            let mut worst = f64::INFINITY;
            let mut ok = true;
            let mut prev_normal: Option<DVec3> = None;
            // The new triangles (keep, ring[i+j], ring[i+j+1]) for j = 1 .. n−2.
            for j in 1..n - 1 {
                let (r1, r2) = (ring[(i + j) % n], ring[(i + j + 1) % n]);
                let tri = [keep, r1, r2];
                let corners = [pk, self.p(r1), self.p(r2)];
                if !self.facing(tri, corners) {
                    ok = false;
                    break;
                }
                let normal = (corners[1] - pk).cross(corners[2] - pk).normalize_or_zero();
                if prev_normal.is_some_and(|m| m.dot(normal) < FOLD_COS) {
                    ok = false;
                    break;
                }
                prev_normal = Some(normal);
                worst = worst.min(min_sin(corners[0], corners[1], corners[2]));
            }
            if !ok || worst <= old_worst {
                continue;
            }
            let chords = others
                .iter()
                .all(|&r| midpoint_within(surface, pk, self.p(r), tolerance));
            if chords && best.is_none_or(|(w, _)| worst > w) {
                best = Some((worst, i));
            }
        }
        best
    }

    /// Removes triangle g, whose half-edges no twin points to any more, by moving the last
    /// triangle into its slot.
    fn remove_triangle(&mut self, g: u32) {
        let last = self.tri.len() as u32 - 1;
        if g != last {
            let moved = self.tri[last as usize];
            self.tri[g as usize] = moved;
            for h in 0..3 {
                let tw = self.twin[(3 * last + h) as usize];
                self.twin[(3 * g + h) as usize] = tw;
                if tw != NONE {
                    self.twin[tw as usize] = 3 * g + h;
                }
                let v = moved[h as usize] as usize;
                if self.out[v] / 3 == last {
                    self.out[v] = 3 * g + self.out[v] % 3;
                }
            }
        }
        self.tri.pop();
        self.twin.truncate(3 * last as usize);
    }

    // ------------------------------------------------------------ insertion

    /// Inserts a vertex for bad triangle t: the off-centre of its shortest edge (the apex of
    /// the equilateral triangle over it, or the circumcentre where that is nearer), placed
    /// in t or split onto the edge it lies across, projected onto the surface. Returns the
    /// new vertex.
    fn insert(
        &mut self,
        t: u32,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
    ) -> Option<u32> {
        let tv = self.tri[t as usize];
        if tv.iter().any(|&v| self.frozen[v as usize]) {
            return None;
        }
        let [a, b, c] = self.corners(tv);
        let lens = [a.distance(b), b.distance(c), c.distance(a)];
        // A cap on the box: its longest edge runs along a face; split it on the face.
        let long = (0..3)
            .max_by(|&i, &j| lens[i].total_cmp(&lens[j]))
            .unwrap_or(0);
        let e = 3 * t + long as u32;
        if self.twin[e as usize] == NONE {
            if let Some(p) = self.split_on_face(e, surface) {
                return Some(p);
            }
        }
        let mut proj = |q: DVec3| project(surface, q);
        let project = &mut proj;
        // k: the shortest edge tv[k]→tv[k+1]; r the corner opposite.
        let k = (0..3)
            .min_by(|&i, &j| lens[i].total_cmp(&lens[j]))
            .unwrap_or(0);
        let (p, q, r) = (
            self.p(tv[k]),
            self.p(tv[(k + 1) % 3]),
            self.p(tv[(k + 2) % 3]),
        );
        let m = 0.5 * (p + q);
        let normal = (q - p).cross(r - p);
        let dir = normal.cross(q - p).normalize_or_zero(); // in the plane, towards r
        if dir == DVec3::ZERO {
            return None;
        }
        let circ = circumcentre(p, q, r)?;
        let off = lens[k] * 3f64.sqrt() / 2.0;
        let o = m + dir * off.min((circ - m).dot(dir).max(0.0));
        // Barycentric coordinates of o in t's plane.
        let bary = barycentric(a, b, c, o)?;
        let min_i = (0..3)
            .min_by(|&i, &j| bary[i].total_cmp(&bary[j]))
            .unwrap_or(0);
        if bary[min_i] > 0.05 {
            self.split_triangle(t, o, project)
        } else {
            // Across (or at) the edge opposite the corner with the smallest coordinate:
            // split that edge at the point nearest o.
            let e = 3 * t + ((min_i + 1) % 3) as u32;
            let (x, y) = (self.p(self.org(e)), self.p(self.dst(e)));
            let s = ((o - x).dot(y - x) / (y - x).length_squared()).clamp(0.25, 0.75);
            self.split_edge(e, x + s * (y - x), project)
        }
    }

    /// Splits the boundary edge of half-edge e, between two border points on one face of
    /// the box, at the point of the surface on that face nearest its midpoint; the new
    /// vertex is a border point.
    fn split_on_face(&mut self, e: u32, surface: &mut dyn Surface) -> Option<u32> {
        let (a, b, c) = (self.org(e), self.dst(e), self.org(prev(e)));
        let (lo, hi) = self.bbox?;
        let (pa, pb) = (self.p(a), self.p(b));
        if !(self.border[a as usize] && self.border[b as usize]) || self.constrained(a, b) {
            return None;
        }
        let (axis, value) = (0..3).find_map(|k| {
            [lo[k], hi[k]]
                .into_iter()
                .find(|&v| pa[k] == v && pb[k] == v)
                .map(|v| (k, v))
        })?;
        let scale = self.h_of(&[a, b]);
        let (sp, sn) = face_point(surface, 0.5 * (pa + pb), axis, value, scale)?;
        if !self.in_box(sp) {
            return None;
        }
        let pc = self.p(c);
        for (x, y) in [(pa, sp), (sp, pb)] {
            let n = (y - x).cross(pc - x);
            if !(n.dot(sn) > 0.0 && n.dot(self.normal[c as usize]) > 0.0) {
                return None;
            }
        }
        let h = self.h_of(&[a, b, c]);
        let p = self.new_vertex(sp, sn, h);
        self.border[p as usize] = true;
        let (o_bc, o_ca) = (self.twin[next(e) as usize], self.twin[prev(e) as usize]);
        let t = e / 3;
        let n1 = self.tri.len() as u32;
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 3]);
        // t = [a, p, c]: a→p (open), p→c, c→a; n1 = [p, b, c]: p→b (open), b→c, c→p.
        self.set(t, [a, p, c]);
        self.set(n1, [p, b, c]);
        self.link(3 * t, NONE);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * n1, NONE);
        self.link(3 * n1 + 1, o_bc);
        Some(p)
    }

    fn new_vertex(&mut self, p: DVec3, n: DVec3, h: f64) -> u32 {
        self.pos.push(p);
        self.normal.push(n);
        self.border.push(false);
        self.h.push(h);
        self.out.push(NONE);
        self.frozen.push(false);
        (self.pos.len() - 1) as u32
    }

    fn h_of(&self, vs: &[u32]) -> f64 {
        vs.iter().map(|&v| self.h[v as usize]).fold(0.0, f64::max)
    }

    fn in_box(&self, p: DVec3) -> bool {
        self.bbox
            .is_none_or(|(lo, hi)| p.cmpge(lo).all() && p.cmple(hi).all())
    }

    fn split_triangle(
        &mut self,
        t: u32,
        o: DVec3,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> Option<u32> {
        let [a, b, c] = self.tri[t as usize];
        let (sp, sn) = project(o)?;
        if !self.in_box(sp) {
            return None;
        }
        let news = [[a, b], [b, c], [c, a]];
        for [x, y] in news {
            let pts = [self.p(x), self.p(y), sp];
            let n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
            if !([x, y].iter().all(|&v| n.dot(self.normal[v as usize]) > 0.0) && n.dot(sn) > 0.0) {
                return None;
            }
        }
        let h = self.h_of(&[a, b, c]);
        let p = self.new_vertex(sp, sn, h);
        let (o_ab, o_bc, o_ca) = (
            self.twin[3 * t as usize],
            self.twin[3 * t as usize + 1],
            self.twin[3 * t as usize + 2],
        );
        let n1 = self.tri.len() as u32;
        let n2 = n1 + 1;
        self.tri.push([0; 3]);
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 6]);
        self.set(t, [a, b, p]);
        self.set(n1, [b, c, p]);
        self.set(n2, [c, a, p]);
        self.link(3 * t, o_ab);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, 3 * n2 + 1);
        self.link(3 * n1, o_bc);
        self.link(3 * n1 + 1, 3 * n2 + 2);
        self.link(3 * n2, o_ca);
        Some(p)
    }

    fn split_edge(
        &mut self,
        e: u32,
        o: DVec3,
        project: &mut dyn FnMut(DVec3) -> Option<(DVec3, DVec3)>,
    ) -> Option<u32> {
        let f = self.twin[e as usize];
        let (a, b) = (self.org(e), self.dst(e));
        if f == NONE || self.constrained(a, b) {
            return None;
        }
        let (c, d) = (self.org(prev(e)), self.org(prev(f)));
        let (sp, sn) = project(o)?;
        if !self.in_box(sp) {
            return None;
        }
        // t = [a, p, c], n1 = [p, b, c], u = [b, p, d], n2 = [p, a, d].
        let check = |x: u32, y: u32, first: bool| {
            // Triangle (x, p, y) or (p, x, y): corners in order.
            let (p0, p1, p2) = if first {
                (self.p(x), sp, self.p(y))
            } else {
                (sp, self.p(x), self.p(y))
            };
            let n = (p1 - p0).cross(p2 - p0);
            n.dot(self.normal[x as usize]) > 0.0
                && n.dot(self.normal[y as usize]) > 0.0
                && n.dot(sn) > 0.0
        };
        if !(check(a, c, true) && check(b, c, false) && check(b, d, true) && check(a, d, false)) {
            return None;
        }
        let h = self.h_of(&[a, b, c, d]);
        let p = self.new_vertex(sp, sn, h);
        let [o_ad, o_db, o_bc, o_ca] = self.outer(e, f);
        let (t, u) = (e / 3, f / 3);
        let n1 = self.tri.len() as u32;
        let n2 = n1 + 1;
        self.tri.push([0; 3]);
        self.tri.push([0; 3]);
        self.twin.extend([NONE; 6]);
        self.set(t, [a, p, c]);
        self.set(n1, [p, b, c]);
        self.set(u, [b, p, d]);
        self.set(n2, [p, a, d]);
        // t: a→p, p→c, c→a; n1: p→b, b→c, c→p; u: b→p, p→d, d→b; n2: p→a, a→d, d→p.
        self.link(3 * t, 3 * n2);
        self.link(3 * t + 1, 3 * n1 + 2);
        self.link(3 * t + 2, o_ca);
        self.link(3 * n1, 3 * u);
        self.link(3 * n1 + 1, o_bc);
        self.link(3 * u + 1, 3 * n2 + 2);
        self.link(3 * u + 2, o_db);
        self.link(3 * n2 + 1, o_ad);
        Some(p)
    }

    // ------------------------------------------------------------ driver

    /// Triangle t's `Shape`.
    fn shape_of(&self, t: [u32; 3]) -> Shape {
        let [a, b, c] = self.corners(t);
        Shape {
            sin: min_sin(a, b, c),
            ratio: radius_ratio(a, b, c),
        }
    }

    /// Per triangle: its `Shape`, for the scans of a round to share; and per vertex, whether
    /// it is a corner of a triangle whose smallest angle's sine is below `sin`.
    /// `known`: the shapes of the triangles as they were before the triangles listed with
    /// them changed (nothing else changed since), brought up to date instead of computed
    /// anew.
    fn shapes_and_corners_below(
        &self,
        sin: f64,
        known: Option<(Vec<Shape>, &[u32])>,
    ) -> (Vec<Shape>, Vec<bool>) {
        let shapes = match known {
            Some((mut shapes, changed)) => {
                for &t in changed {
                    shapes[t as usize] = self.shape_of(self.tri[t as usize]);
                }
                // The tests' builds check the claim: every shape as computed anew, bit for bit.
                debug_assert!(
                    shapes.len() == self.tri.len()
                        && shapes.iter().zip(self.tri.iter()).all(|(s, &t)| {
                            let fresh = self.shape_of(t);
                            (s.sin.to_bits(), s.ratio.to_bits())
                                == (fresh.sin.to_bits(), fresh.ratio.to_bits())
                        }),
                    "a triangle changed that the carried shapes do not know of"
                );
                shapes
            }
            None => self.tri.par_iter().map(|&t| self.shape_of(t)).collect(),
        };
        let mut below = Vec::new();
        below.par_extend(
            (0..shapes.len())
                .into_par_iter()
                .filter(|&t| shapes[t].sin < sin),
        );
        let mut marked = vec![false; self.pos.len()];
        for t in below {
            for v in self.tri[t] {
                marked[v as usize] = true;
            }
        }
        (shapes, marked)
    }

    /// `marked` and the vertices that share a triangle with a marked one.
    fn grow(&self, marked: &[bool]) -> Vec<bool> {
        let mut grown = marked.to_vec();
        // Nothing marked (the usual case once no triangle is below the target): no scan.
        if !marked.contains(&true) {
            return grown;
        }
        // The triangles touching a marked vertex found on the pool, in order; their
        // corners marked after.
        let mut touching: Vec<&[u32; 3]> = Vec::new();
        touching.par_extend(
            self.tri
                .par_iter()
                .filter(|t| t.iter().any(|&v| marked[v as usize])),
        );
        for t in touching {
            for &v in t {
                grown[v as usize] = true;
            }
        }
        grown
    }

    /// The queue for `flip_all`: the interior edges with an end marked in `dirty`. Where at
    /// least half the vertices are marked (the first round marks all), only those with an
    /// obtuse angle opposite them in a triangle of theirs, and the triangles' obtuse
    /// corners (`obtuse_corners`) to screen the edges the flips push: an edge with neither
    /// opposite angle obtuse is not flipped (`try_flip_as`'s first test, on the same dot
    /// products), and an edge screened out here that a flip changes is one of the flipped
    /// quad's outer edges, which the flip pushes. On a marched mesh that is nearly every
    /// edge: the fine sphere's first queue is 7 451 edges instead of two million, built in
    /// two passes on the pool (screening every edge in the flips' loop, in one thread, was
    /// most of the first round's flips). Fewer marked vertices: `dirty_edges`, unscreened,
    /// without a pass over every triangle.
    fn delaunay_queue(&self, dirty: &[bool]) -> (Vec<u32>, Option<Vec<u8>>) {
        let marked = dirty.iter().filter(|&&d| d).count();
        if 2 * marked < dirty.len() {
            return (self.dirty_edges(dirty), None);
        }
        let obtuse: Vec<u8> = (0..self.tri.len() as u32)
            .into_par_iter()
            .map(|t| self.obtuse_corners(t))
            .collect();
        let mut queue = Vec::new();
        // In parallel, in order: the queue is the same for any thread count.
        queue.par_extend((0..3 * self.tri.len() as u32).into_par_iter().filter(|&e| {
            let f = self.twin[e as usize];
            f != NONE
                && e < f
                && (dirty[self.org(e) as usize] || dirty[self.dst(e) as usize])
                && obtuse_opposite(&obtuse, e, f)
        }));
        (queue, Some(obtuse))
    }

    /// The interior edges (one half-edge each, the lower) with an end marked in `dirty`.
    fn dirty_edges(&self, dirty: &[bool]) -> Vec<u32> {
        // Room for every inner edge up front: collecting into a growing vector copied the
        // first round's (every edge's) queue several times over.
        let mut queue = Vec::with_capacity(3 * self.tri.len() / 2 + 1);
        // In parallel, in order: the queue is the same for any thread count.
        queue.par_extend((0..3 * self.tri.len() as u32).into_par_iter().filter(|&e| {
            let f = self.twin[e as usize];
            f != NONE && e < f && (dirty[self.org(e) as usize] || dirty[self.dst(e) as usize])
        }));
        queue
    }

    /// Runs the stage. `project` puts a point near the surface onto it (point and unit
    /// normal) or gives None.
    pub fn run(
        &mut self,
        limits: &Limits,
        surface: &mut dyn Surface,
        fork: Option<&Fork<'_>>,
        project: &mut Project<'_>,
    ) -> Report {
        let sin_bad = limits.angle.sin();
        self.bad_sin2 = sin_bad * sin_bad;
        let mut report = Report {
            stop: "no triangle below the target",
            ..Report::default()
        };
        let max_inserted = (limits.insert_fraction * self.tri.len() as f64) as usize + 64;
        let started = std::time::Instant::now();
        let all = vec![true; self.pos.len()];
        report.ratio_after_rounds =
            self.angle_rounds(all, limits, max_inserted, &mut report, surface, project);
        // The angle is where the rounds proper leave it; now the mean radius ratio, raised
        // to `Limits::ratio` cheapest first: a round of smoothing towards the rings'
        // centroids (a projection a vertex) where it can reach it (`ODT_REACH`); only where
        // it does not, the ratios' phase (valence flips and an ascent a fan, about five times
        // the cost of a smoothing round) over every vertex, ODT rounds, and the ratios' phase
        // where they moved something — under a guard that cannot lower the angle (`polish`).
        report.rounds_seconds = started.elapsed().as_secs_f64();
        let (aim, reach) = (limits.ratio, limits.ratio - ODT_REACH);
        if (reach..aim).contains(&report.ratio_after_rounds) {
            let smoothing_started = std::time::Instant::now();
            self.centroid_round(limits.tolerance, surface, fork, project, &mut report);
            report.smoothing_seconds += smoothing_started.elapsed().as_secs_f64();
        }
        // The mean and the triangles below the target, in one scan.
        let (mut mean, mut below) = self.survey(sin_bad);
        // Where triangles stay below the target, the full path runs too, as if the aim
        // were not met: the angle's rounds could not mend them, and the moves of its
        // valence flips and ODT rounds around them may. (Two of the gallery's meshes keep
        // one such triangle beside a box face after the centroid's round, at 29.2° and
        // 29.8°; the full path mends both, as it did when an ODT round left their means
        // below the aim.)
        if mean < aim || !below.is_empty() {
            self.polish(
                vec![true; self.pos.len()],
                limits,
                surface,
                project,
                &mut report,
            );
            let smoothing_started = std::time::Instant::now();
            let moved =
                self.odt_rounds(ODT_ROUNDS, limits.tolerance, surface, project, &mut report);
            report.smoothing_seconds += smoothing_started.elapsed().as_secs_f64();
            let dirty = self.grow(&moved);
            self.polish(dirty, limits, surface, project, &mut report);
            (mean, below) = self.survey(sin_bad);
        }
        report.ratio_after = mean;
        // The triangles left below the target: how many, where those with only free
        // corners are, and the worst of the others.
        report.below_after = below.len();
        for t in below {
            let t = self.tri[t as usize];
            let centroid = self.corners(t).iter().sum::<DVec3>() / 3.0;
            if t.iter().all(|&v| self.free(v)) {
                report.poor.push((centroid, self.h_of(&t)));
            } else {
                let q = self.q(t);
                if report.worst_held.is_none_or(|(w, _)| q < w) {
                    report.worst_held = Some((q, centroid));
                }
            }
        }
        report
    }

    /// The rounds proper, for the angle: flips, smoothing near triangles below the target,
    /// insertion and removal, starting from the vertices marked `dirty`, while at most
    /// `max_inserted` vertices are inserted in all (`report.inserted` counts them). Returns
    /// the mean radius ratio they leave (1 for no triangle).
    fn angle_rounds(
        &mut self,
        mut dirty: Vec<bool>,
        limits: &Limits,
        max_inserted: usize,
        report: &mut Report,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
    ) -> f64 {
        let sin_bad = limits.angle.sin();
        let mut ratio_sum = 0.0;
        let mut star = Vec::new();
        // The shapes at the end of the last round, of the triangles and positions the next
        // round's flips start from: only the flipped triangles' are computed again (on the
        // three cylinders at step 0.1, 8 rounds of 120 000 triangles with 114 flips).
        let mut carried: Option<Vec<Shape>> = None;
        // The rounds proper, then up to `SLIDE_ROUNDS` more while triangles stay below the
        // target, in which border vertices slide too.
        let total = limits.rounds + SLIDE_ROUNDS;
        for round in 0..total {
            let sliding = round >= limits.rounds;
            report.rounds += 1;
            // 1. Flips over every edge (the first round) or the edges around what changed.
            let (queue, obtuse) = self.delaunay_queue(&dirty);
            let budget = 2 * self.tri.len() + 64;
            let mut flipped = Vec::new();
            let (flips, _) = self.flip_all(
                queue,
                obtuse,
                budget,
                surface,
                limits.tolerance,
                Some(&mut flipped),
            );
            report.flips += flips;
            // 2. Smoothing, in index order, of free vertices whose fan changed and that are
            // within `BAD_RINGS` rings of a triangle below the target: these rounds are for
            // the angle (the ratios are the smoothing rounds' and `polish`'s), and a bad triangle whose
            // corners may not move is mended by moving its neighbours.
            let mut moved = vec![false; self.pos.len()];
            let mut moves = 0;
            // Border vertices slide only where a triangle of theirs is below the target:
            // elsewhere the box's border is as the march placed it.
            // The triangles' shapes, computed once here and kept up to date through the
            // smoothing (only the fans of moved vertices change) for the scans after it and
            // for the mean radius ratio the rounds end with.
            let (mut shapes, bad_corner) =
                self.shapes_and_corners_below(sin_bad, carried.take().map(|s| (s, &flipped[..])));
            // With no triangle below the target, the round has nothing to smooth, insert or
            // remove, and the rounds end here, with the mean of the shapes summed as the scan
            // at the end of a round sums them (on the fine sphere's first round that scan,
            // the rings grown around nothing and the smoothing's pass over every vertex were
            // a third of the round).
            if !bad_corner.contains(&true) {
                report.stop = "no triangle below the target";
                return mean_ratio(&shapes);
            }
            let mut smoothed = bad_corner.clone();
            for _ in 0..BAD_RINGS {
                smoothed = self.grow(&smoothed);
            }
            for v in 0..self.pos.len() as u32 {
                let may =
                    (self.free(v) && smoothed[v as usize]) || (sliding && bad_corner[v as usize]);
                if dirty[v as usize]
                    && may
                    && self.relax(v, &mut star, SMOOTH_BELOW, false, surface, project)
                {
                    moves += 1;
                    moved[v as usize] = true;
                }
            }
            report.moves += moves;
            // 3. Insertion where a triangle is still below the target (not in the last
            // round, which flips and smooths around the last insertions). The triangles
            // below it are listed in the scan that brings the moved fans' shapes up to date.
            let last = round + 1 == limits.rounds || round + 1 == total;
            let mut bad: Vec<u32> = Vec::new();
            if moves > 0 || !last {
                // On the pool, the triangles below the target listed in order.
                let stage = &*self;
                bad.par_extend(
                    (stage.tri.par_iter().zip(shapes.par_iter_mut()).enumerate()).filter_map(
                        |(i, (t, shape))| {
                            if moves > 0 && t.iter().any(|&v| moved[v as usize]) {
                                *shape = stage.shape_of(*t);
                            }
                            (!last && shape.sin < sin_bad).then_some(i as u32)
                        },
                    ),
                );
            }
            let any_bad = !bad.is_empty();
            if report.inserted < max_inserted {
                for t in bad {
                    if report.inserted >= max_inserted {
                        break;
                    }
                    if self.q(self.tri[t as usize]) >= sin_bad {
                        continue;
                    }
                    let (kept, flips) =
                        self.insert_on_trial(t, surface, limits.tolerance, sliding, project);
                    if kept {
                        report.inserted += 1;
                        report.flips += flips;
                    }
                }
            }
            // 4. Removal of a free corner of a bad triangle (merged into another corner of it),
            // where insertion did not mend it.
            if any_bad {
                let mut t = 0;
                while t < self.tri.len() as u32 {
                    let merged = (self.q(self.tri[t as usize]) < sin_bad)
                        .then(|| self.remove_corner(t, surface, limits.tolerance))
                        .flatten();
                    if let Some(keep) = merged {
                        report.collapsed += 1;
                        // Its fan changed: flips and smoothing around it next round (a
                        // vertex inserted this round counts as moved already).
                        if let Some(m) = moved.get_mut(keep as usize) {
                            *m = true;
                        }
                        // The triangle now at t (moved there by the removal) is looked at next.
                        continue;
                    }
                    t += 1;
                }
            }
            // Insertions and removals change triangles: then the shapes are computed anew.
            if any_bad {
                shapes = self.shapes_and_corners_below(sin_bad, None).0;
            }
            // What changed (moved or new vertices, triangles still bad) marks the
            // corners of the triangles around it for the next round.
            // In blocks on the pool, summed and marked in block order (the same bits for any
            // thread count, as `survey`).
            let changed = |(t, shape): (&[u32; 3], &Shape)| {
                shape.sin < sin_bad || t.iter().any(|&v| moved.get(v as usize).is_none_or(|&m| m))
            };
            let blocks: Vec<(f64, bool, Vec<u32>)> = self
                .tri
                .par_chunks(SCAN_BLOCK)
                .zip(shapes.par_chunks(SCAN_BLOCK))
                .enumerate()
                .map(|(block, (tri, shapes))| {
                    let sum = ratio_sum_of(shapes);
                    let bad = shapes.iter().any(|shape| shape.sin < sin_bad);
                    let changed = (tri.iter().zip(shapes).enumerate())
                        .filter(|&(_, pair)| changed(pair))
                        .map(|(i, _)| (block * SCAN_BLOCK + i) as u32)
                        .collect();
                    (sum, bad, changed)
                })
                .collect();
            let mut next_dirty = vec![false; self.pos.len()];
            let mut bad_left = false;
            ratio_sum = 0.0;
            for (block_sum, block_bad, changed) in blocks {
                ratio_sum += block_sum;
                bad_left |= block_bad;
                for t in changed {
                    for v in self.tri[t as usize] {
                        next_dirty[v as usize] = true;
                    }
                }
            }
            dirty = next_dirty;
            carried = Some(shapes);
            if report.inserted >= max_inserted {
                report.stop = "insertion budget exhausted";
            } else if bad_left {
                report.stop = "rounds exhausted";
            } else {
                report.stop = "no triangle below the target";
            }
            // With no triangle below the target left, the rounds end once they stall: the
            // fine sphere's rounds 3–6 moved ~100 of 650 000 vertices each for no gain in
            // its smallest angle (which the ratios' phase then sets anyway), at ~80 ms a
            // round of whole-mesh scans.
            let stalled = (moves as f64) < ROUNDS_STALL * self.pos.len() as f64;
            if !bad_left && (stalled || round + 1 >= limits.rounds) {
                break;
            }
        }
        if self.tri.is_empty() {
            1.0
        } else {
            ratio_sum / self.tri.len() as f64
        }
    }

    /// Raises the mean radius ratio once the rounds proper are done (issue 10, M4):
    /// valence flips (`try_flip_as`) on every edge and then around what changed, and
    /// smoothing of free vertices up the gradient of their fan's radius ratios
    /// (`smooth` with `ratio`), for up to `Limits::rounds` rounds and until fewer than
    /// `STALL` of the vertices move by more than `SETTLE` of their step, starting from the
    /// vertices marked `dirty` (all of them the first time, those around the ODT's moves
    /// the second). No insertion, no Delaunay flip (it would undo the valence flips), no
    /// slide: box faces and polygons are as the rounds proper left them.
    ///
    /// The angle guard: a flip or a move is taken only if the smallest angle of the
    /// triangles it changes stays at or above the smaller of the target (`Limits::angle`,
    /// `KEEP_ANGLE` for moves) and the smallest angle those triangles had before. Every
    /// triangle a change makes is then at least min(target, smallest angle of the mesh
    /// before the change), so the mesh's smallest angle after this phase is at least
    /// min(target, what the rounds proper reached): where they reached 30° it stays, and
    /// where they left a triangle below it (patches' 26.5°), no triangle goes lower. Run
    /// interleaved with the rounds proper, the same moves left the flat ellipsoid's and the
    /// plate's last bad triangles where insertion and the angle's smoothing no longer fixed
    /// them (28.4° against 30°): the angle comes first, then the ratios.
    fn polish(
        &mut self,
        mut dirty: Vec<bool>,
        limits: &Limits,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
        report: &mut Report,
    ) {
        let sin_bad = limits.angle.sin();
        let mut star = Vec::new();
        // Counted once: the phase's flips (`try_flip_as`) keep it up to date, and nothing
        // else in the phase changes the triangles.
        self.valence.clear();
        self.valence.resize(self.pos.len(), 0);
        for t in self.tri.iter() {
            for &v in t {
                self.valence[v as usize] += 1;
            }
        }
        for _ in 0..limits.rounds {
            report.polish_rounds += 1;
            let queue = self.dirty_edges(&dirty);
            for e in queue {
                let f = self.twin[e as usize];
                if f == NONE {
                    continue;
                }
                if self.try_flip_as(e, surface, limits.tolerance, Some(sin_bad)) {
                    report.flips += 1;
                    // The flipped pair's triangles keep their slots: their corners are the
                    // quad's four.
                    for t in [e / 3, f / 3] {
                        for v in self.tri[t as usize] {
                            dirty[v as usize] = true;
                        }
                    }
                }
            }
            let mut moved = vec![false; self.pos.len()];
            let (mut moves, mut settled) = (0, 0);
            for v in 0..self.pos.len() as u32 {
                let from = self.p(v);
                if dirty[v as usize]
                    && self.free(v)
                    && self.relax(v, &mut star, SMOOTH_BELOW, true, surface, project)
                {
                    moves += 1;
                    if from.distance(self.p(v)) > SETTLE * self.h[v as usize] {
                        moved[v as usize] = true;
                    } else {
                        settled += 1;
                    }
                }
            }
            report.moves += moves;
            let mut next_dirty = vec![false; self.pos.len()];
            for t in self.tri.iter() {
                if t.iter().any(|&v| moved[v as usize]) {
                    for &v in t {
                        next_dirty[v as usize] = true;
                    }
                }
            }
            dirty = next_dirty;
            if ((moves - settled) as f64) < STALL * self.pos.len() as f64 {
                break;
            }
        }
    }

    /// `rounds` rounds of ODT smoothing over every free vertex in index order, moving each
    /// to its ODT position (`odt_target`). After the first round only the vertices around
    /// the last round's moves are visited, and they move only by more than `ODT_SETTLE` of
    /// their local step. Returns which vertices moved.
    ///
    /// A move is kept under `polish`'s angle guard (the fan's smallest angle stays at or
    /// above the smaller of `KEEP_ANGLE` and what it was), with every triangle facing ∇f,
    /// and every edge that grows beyond the fan's longest with its midpoint within
    /// `ODT_CHORD` of the chord tolerance from the surface (the flips' test; the
    /// verification checks the centroids too, which lie up to a third further out)
    /// (`Fan::guards_move`).
    fn odt_rounds(
        &mut self,
        rounds: u32,
        tolerance: f64,
        surface: &mut dyn Surface,
        project: &mut Project<'_>,
        report: &mut Report,
    ) -> Vec<bool> {
        let spacing = self.spacing();
        let keep = KEEP_ANGLE.sin().powi(2);
        let mut moved = vec![false; self.pos.len()];
        let mut star = Vec::new();
        let mut fan = Fan::empty();
        // Each round visits the vertices around what the round before moved.
        let mut active = vec![true; self.pos.len()];
        for round in 0..rounds {
            let mut moved_now = vec![false; self.pos.len()];
            for v in 0..self.pos.len() as u32 {
                if !active[v as usize] || !self.free(v) {
                    continue;
                }
                let p = self.p(v);
                // The target needs only the star: the fan is gathered only for the targets
                // that are not too near to take.
                if !self.star(v, &mut star) || !(3..=MAX_FAN).contains(&star.len()) {
                    continue;
                }
                let settled = |target: DVec3| p.distance(target) < ODT_SETTLE * self.h[v as usize];
                let target = match self.odt_target(v, &star, &spacing) {
                    Some(target) if !settled(target) => target,
                    _ => continue,
                };
                if !fan.gather(self, &star) {
                    continue;
                }
                let Some((sp, sn)) = project(surface, target) else {
                    continue;
                };
                if fan.guards_move(p, sp, sn, keep, surface, ODT_CHORD * tolerance) {
                    self.place(v, sp, sn);
                    moved[v as usize] = true;
                    moved_now[v as usize] = true;
                    report.smoothing_moves += 1;
                }
            }
            report.odt_rounds += 1;
            if round + 1 < rounds {
                active = self.grow(&moved_now);
            }
        }
        moved
    }

    /// One round of smoothing towards the rings' centroids (`Fan::centroid`), the round
    /// tried first towards the aim: every free vertex whose target is at least
    /// `ODT_SETTLE` of its local step away moves there, projected, under the guard of
    /// `odt_rounds` (`Fan::guards_move`). The guard is what makes the centroid safe where
    /// the issue warns of plain Laplace smoothing: no move lowers a fan's smallest angle
    /// below 34° or below where it was.
    ///
    /// Gauss–Seidel in index order within blocks of `CENTROID_BLOCK` vertices, the blocks on
    /// rayon's pool each with an oracle from `fork` (without one, or where it gives none,
    /// on `surface` one after another, which is the same for a surface without history);
    /// the vertices whose ring reaches into another block wait and move after all blocks,
    /// in index order, on `surface`. The result is the same for any thread count.
    fn centroid_round(
        &mut self,
        tolerance: f64,
        surface: &mut dyn Surface,
        fork: Option<&Fork<'_>>,
        project: &Project<'_>,
        report: &mut Report,
    ) {
        let guard = CentroidGuard {
            keep: KEEP_ANGLE.sin().powi(2),
            chord: ODT_CHORD * tolerance,
        };
        // The positions and normals are taken out of the stage for the round, so that the
        // blocks write their slices of them while every block reads the rest of the stage
        // (the half-edges, which vertices may move, their steps); put back at the end.
        let (mut pos, mut normal) = (
            std::mem::take(&mut *self.pos),
            std::mem::take(&mut *self.normal),
        );
        let stage = &*self;
        let n = pos.len();
        // A block's vertices (base, base + len), smoothed where their ring is in the block.
        let smooth_block =
            |base: usize, pos: &mut [DVec3], normal: &mut [DVec3], surface: &mut dyn Surface| {
                let block = (base..base + pos.len()).map(|v| v as u32);
                let mut moves = Moves::default();
                moves.smooth(block, base, pos, normal, stage, &guard, surface, project);
                moves
            };
        let blocks: Vec<Moves> = match fork {
            Some(fork) if n > CENTROID_BLOCK => pos
                .par_chunks_mut(CENTROID_BLOCK)
                .zip(normal.par_chunks_mut(CENTROID_BLOCK))
                .enumerate()
                .map(|(block, (pos, normal))| {
                    let base = block * CENTROID_BLOCK;
                    match fork() {
                        Some(mut oracle) => smooth_block(base, pos, normal, &mut *oracle),
                        // No oracle: the whole block waits for the second pass.
                        None => Moves {
                            waiting: (base..base + pos.len()).map(|v| v as u32).collect(),
                            ..Moves::default()
                        },
                    }
                })
                .collect(),
            _ => pos
                .chunks_mut(CENTROID_BLOCK)
                .zip(normal.chunks_mut(CENTROID_BLOCK))
                .enumerate()
                .map(|(block, (pos, normal))| {
                    smooth_block(block * CENTROID_BLOCK, pos, normal, &mut *surface)
                })
                .collect(),
        };
        let mut waiting = Vec::new();
        for block in blocks {
            report.smoothing_moves += block.moves;
            waiting.extend(block.waiting);
        }
        // The vertices between blocks, with every vertex in reach.
        let mut rest = Moves::default();
        rest.smooth(
            waiting.into_iter(),
            0,
            &mut pos,
            &mut normal,
            stage,
            &guard,
            surface,
            project,
        );
        debug_assert!(rest.waiting.is_empty());
        (*self.pos, *self.normal) = (pos, normal);
        report.smoothing_moves += rest.moves;
        report.centroid_rounds += 1;
    }
    /// The mean radius ratio of the triangles (1 for none), and the triangles whose
    /// smallest angle has a sine below `sin_bad`, in one scan.
    fn survey(&self, sin_bad: f64) -> (f64, Vec<u32>) {
        // In blocks on the pool, summed in block order (`SCAN_BLOCK`).
        let blocks: Vec<(f64, Vec<u32>)> = self
            .tri
            .par_chunks(SCAN_BLOCK)
            .enumerate()
            .map(|(block, tri)| {
                let mut below = Vec::new();
                let mut sum = 0.0;
                for (i, &t) in tri.iter().enumerate() {
                    let (sin, ratio) = shape(self.corners(t));
                    sum += ratio;
                    if sin < sin_bad {
                        below.push((block * SCAN_BLOCK + i) as u32);
                    }
                }
                (sum, below)
            })
            .collect();
        let mut below = Vec::new();
        let mut sum = 0.0;
        for (block_sum, block_below) in blocks {
            sum += block_sum;
            below.extend(block_below);
        }
        let mean = if self.tri.is_empty() {
            1.0
        } else {
            sum / self.tri.len() as f64
        };
        (mean, below)
    }

    /// The ODT position of free vertex v (closed fan `star`), in the tangent plane at v;
    /// None for a fan without area. The position is the mean of the circumcentres of the
    /// fan's triangles weighted by their area and a density ρ = s⁻⁴ of the mesh's own spacing
    /// s (Chen & Xu's ODT update; in the plane a mesh of size s has ρ ∝ s⁻⁴, Du & Wang).
    ///
    /// Where `polish` moves a vertex only if its own fan's ratios rise, these moves may
    /// lower one fan for the next: the energy they descend is the whole mesh's, which lets
    /// the grading zones' triangles even out (genus 3: 0.962 → 0.970 of mean radius ratio
    /// with `polish` again after it; docs/marcher.md). The spacing is the mesh's, not the
    /// local step: the triangles' sizes are what the march and the rounds made of it
    /// (with the local step, genus 3 reached 0.966).
    fn odt_target(&self, v: u32, star: &[u32], spacing: &[f64]) -> Option<DVec3> {
        let p = self.p(v);
        let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
        for &e in star {
            // The fan's triangle (v, i, j).
            let (i, j) = (self.dst(e) as usize, self.org(prev(e)) as usize);
            let (a, b) = (self.pos[i], self.pos[j]);
            let Some((centre, normal)) = circumcentre_and_normal(p, a, b) else {
                continue;
            };
            let s = (spacing[v as usize] + spacing[i] + spacing[j]) / 3.0;
            let w = normal.length() / s.powi(4);
            sum += w * centre;
            weight += w;
        }
        // Also None for a NaN weight (a degenerate fan).
        if weight.is_nan() || weight <= 0.0 {
            return None;
        }
        let n = self.normal[v as usize];
        let d = sum / weight - p;
        Some(p + d - d.dot(n) * n)
    }

    /// Per vertex: the mean length of the edges at it (counted once per triangle side, so
    /// a boundary edge once and an inner edge twice).
    fn spacing(&self) -> Vec<f64> {
        let mut sum = vec![0.0; self.pos.len()];
        let mut count = vec![0u32; self.pos.len()];
        for t in self.tri.iter() {
            for k in 0..3 {
                let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
                let l = self.pos[a].distance(self.pos[b]);
                sum[a] += l;
                sum[b] += l;
                count[a] += 1;
                count[b] += 1;
            }
        }
        sum.iter()
            .zip(&count)
            .map(|(&l, &c)| if c > 0 { l / c as f64 } else { 0.0 })
            .collect()
    }
}

/// The ring around a free vertex, gathered once per smoothing attempt so that the many
/// candidate places are judged without index chasing: ring points in order (the fan is
/// closed), their normals, and the lengths of the ring's edges (the sides opposite v).
struct Fan {
    k: usize,
    ring: [DVec3; MAX_FAN + 1],
    normal: [DVec3; MAX_FAN + 1],
    opp: [f64; MAX_FAN + 1],
    /// The ring's edge lengths squared (the guards need no more).
    opp2: [f64; MAX_FAN + 1],
}

/// The quality of a fan with its centre at some place: the worst sin² of a smallest angle,
/// the worst radius ratio, the sum of radius ratios.
struct FanQuality {
    worst: f64,
    worst_rr: f64,
    sum: f64,
}

impl Fan {
    /// The fan of a closed star (`Stage::star`'s half-edges), or None if it is too long.
    fn closed(stage: &Stage<'_>, star: &[u32]) -> Option<Fan> {
        let mut fan = Fan::empty();
        fan.gather(stage, star).then_some(fan)
    }

    /// A fan of no triangles, to `gather` into.
    fn empty() -> Fan {
        Fan {
            k: 0,
            ring: [DVec3::ZERO; MAX_FAN + 1],
            normal: [DVec3::ZERO; MAX_FAN + 1],
            opp: [0.0; MAX_FAN + 1],
            opp2: [0.0; MAX_FAN + 1],
        }
    }

    /// Makes this the fan of a closed star (as `closed`) in place; false, and the fan left
    /// as it was, if the star is too long. A loop over every vertex gathers into one fan:
    /// a `Fan` is near a kilobyte, and building and moving one a vertex was a tenth of the
    /// smoothing round's time on the fine sphere.
    fn gather(&mut self, stage: &Stage<'_>, star: &[u32]) -> bool {
        let k = star.len();
        if !(3..=MAX_FAN).contains(&k) {
            return false;
        }
        for (i, &e) in star.iter().enumerate() {
            let b = stage.dst(e);
            self.ring[i] = stage.p(b);
            self.normal[i] = stage.normal[b as usize];
        }
        self.close(k);
        for i in 0..k {
            self.opp[i] = self.opp2[i].sqrt();
        }
        true
    }

    /// `gather` of the closed star of v, walked here from the half-edges (as `Stage::star`)
    /// without listing it, and without the ring's edge lengths: for `guards_move` and
    /// `centroid` only (`eval` and `eval_grad` need `gather`). `pos` and `normal` are the
    /// vertices from `base` on (a block of the centroid round, or all of them from 0); the
    /// stage's own are taken out of it for the round.
    fn walk(
        &mut self,
        stage: &Stage<'_>,
        pos: &[DVec3],
        normal: &[DVec3],
        base: usize,
        v: u32,
    ) -> Walk {
        let first = stage.out[v as usize];
        if first == NONE {
            return Walk::Open;
        }
        let (mut e, mut k) = (first, 0);
        loop {
            if k == MAX_FAN {
                return Walk::Open;
            }
            let b = stage.dst(e) as usize;
            let Some(i) = b.checked_sub(base).filter(|&i| i < pos.len()) else {
                return Walk::Outside;
            };
            self.ring[k] = pos[i];
            self.normal[k] = normal[i];
            k += 1;
            e = stage.twin[prev(e) as usize];
            if e == NONE {
                return Walk::Open;
            }
            if e == first {
                break;
            }
        }
        if k < 3 {
            return Walk::Open;
        }
        self.close(k);
        Walk::Closed
    }

    /// Sets the fan's size to k (ring points 0..k gathered) and completes it: the closing
    /// copy of the first ring point and the ring's edge lengths squared (`walk`'s fans, for
    /// the guard only, need no more; `gather` adds the lengths).
    fn close(&mut self, k: usize) {
        self.k = k;
        // The closing copy: triangle i is (centre, ring[i], ring[i + 1]).
        self.ring[k] = self.ring[0];
        self.normal[k] = self.normal[0];
        for i in 0..k {
            self.opp2[i] = self.ring[i].distance_squared(self.ring[i + 1]);
        }
    }

    /// The fan's quality with its centre at p.
    fn eval(&self, p: DVec3) -> FanQuality {
        self.measure::<false>(p).0
    }

    /// The fan's quality with its centre at p and the gradient of its sum of radius ratios
    /// with respect to p.
    fn eval_grad(&self, p: DVec3) -> (FanQuality, DVec3) {
        self.measure::<true>(p)
    }

    /// One pass over the fan's triangles (p, a, b): with u = a − p, w = b − p, c = u × w
    /// and sides x = |u|, y = |b − a|, z = |w|, the radius ratio is 4|c|²/(xyz(x+y+z))
    /// (`ratio_of_sides`) and sin² of the smallest angle |c|²·m²/(xyz)², m the shortest
    /// side. With `GRAD`, also Σ ∇ratio = Σ ratio·∇ ln ratio, where ∇|c|² = 2(u − w) × c,
    /// ∇x = −u/x, ∇z = −w/z and ln ratio = ln |c|² − ln x − ln z − ln(x+y+z) + const.
    fn measure<const GRAD: bool>(&self, p: DVec3) -> (FanQuality, DVec3) {
        let mut q = FanQuality {
            worst: f64::INFINITY,
            worst_rr: f64::INFINITY,
            sum: 0.0,
        };
        let mut grad = DVec3::ZERO;
        let mut u = self.ring[0] - p;
        let mut x = u.length();
        // With `GRAD`, 1/x, carried over as 1/z of the triangle before: the gradient
        // multiplies by reciprocals, three divisions a triangle instead of eighteen.
        let mut inv_x = if GRAD { 1.0 / x } else { 0.0 };
        for i in 0..self.k {
            let w = self.ring[i + 1] - p;
            let (y, z) = (self.opp[i], w.length());
            let inv_z = if GRAD { 1.0 / z } else { 0.0 };
            let c = u.cross(w);
            let area2 = c.length_squared();
            let xyz = x * y * z;
            let rr = ratio_of_sides(x, y, z, area2);
            let m = x.min(y).min(z);
            let sin2 = if xyz > 0.0 {
                area2 * m * m / (xyz * xyz)
            } else {
                0.0
            };
            q.worst = q.worst.min(sin2);
            q.worst_rr = q.worst_rr.min(rr);
            q.sum += rr;
            if GRAD && rr > 0.0 {
                // −∇x = u/x and −∇z = w/z, the unit vectors along the two edges at p.
                let (ux, wz) = (u * inv_x, w * inv_z);
                grad += rr
                    * ((u - w).cross(c) * (2.0 / area2)
                        + ux * inv_x
                        + wz * inv_z
                        + (ux + wz) * (1.0 / (x + y + z)));
            }
            (u, x, inv_x) = (w, z, inv_z);
        }
        (q, grad)
    }

    /// The longest edge from p to the ring, squared.
    fn longest(&self, p: DVec3) -> f64 {
        self.ring[..self.k]
            .iter()
            .map(|&q| p.distance_squared(q))
            .fold(0.0, f64::max)
    }

    /// The centroid of the ring, moved into the tangent plane at p (normal n): where the
    /// first smoothing round puts the fan's centre (`Stage::centroid_round`).
    fn centroid(&self, p: DVec3, n: DVec3) -> DVec3 {
        let d = self.ring[..self.k].iter().sum::<DVec3>() / self.k as f64 - p;
        p + d - d.dot(n) * n
    }

    /// The worst sin² of a smallest angle of the fan with its centre at p (as `eval`'s
    /// `worst`, without square roots: sin² = |c|²·m²/(x²y²z²), m the shortest side).
    fn worst_sin2(&self, p: DVec3) -> f64 {
        let mut worst = f64::INFINITY;
        let mut u = self.ring[0] - p;
        let mut x2 = u.length_squared();
        for i in 0..self.k {
            let w = self.ring[i + 1] - p;
            let (y2, z2) = (self.opp2[i], w.length_squared());
            worst = worst.min(sin2_of(u.cross(w).length_squared(), x2, y2, z2));
            (u, x2) = (w, z2);
        }
        worst
    }

    /// The smoothing rounds' guard for moving the fan's centre from `from` to `to` (normal
    /// n there), in one pass over the fan at `to`: every triangle faces ∇f (as `holds`),
    /// the smallest angle stays at or above the smaller of `keep` (sin²) and what it was,
    /// and every edge from `to` longer than the fan's longest from `from` has its midpoint
    /// within `tolerance` of the surface (|f|/|∇f|, as a flip's new diagonal).
    fn guards_move(
        &self,
        from: DVec3,
        to: DVec3,
        n: DVec3,
        keep: f64,
        surface: &mut dyn Surface,
        tolerance: f64,
    ) -> bool {
        let longest = self.longest(from);
        let mut worst = f64::INFINITY;
        // Bit i: the edge from `to` to ring point i grew beyond `longest`.
        let mut grown = 0u32;
        let mut u = self.ring[0] - to;
        let mut x2 = u.length_squared();
        for i in 0..self.k {
            let w = self.ring[i + 1] - to;
            let (y2, z2) = (self.opp2[i], w.length_squared());
            let c = u.cross(w);
            if !(c.dot(n) > 0.0 && c.dot(self.normal[i]) > 0.0 && c.dot(self.normal[i + 1]) > 0.0) {
                return false;
            }
            worst = worst.min(sin2_of(c.length_squared(), x2, y2, z2));
            if x2 > longest {
                grown |= 1 << i;
            }
            (u, x2) = (w, z2);
        }
        // Most fans stay above `keep`: then the fan where it was is not measured.
        if worst < keep && worst < self.worst_sin2(from) {
            return false;
        }
        (0..self.k)
            .filter(|&i| grown & (1 << i) != 0)
            .all(|i| midpoint_within(surface, to, self.ring[i], tolerance))
    }

    /// Every triangle with the centre at p (normal n) faces the side ∇f points to at its
    /// three corners, and no edge from p is longer than `longest` (squared).
    fn holds(&self, p: DVec3, n: DVec3, longest: f64) -> bool {
        (0..self.k).all(|i| {
            let t = (self.ring[i] - p).cross(self.ring[i + 1] - p);
            t.dot(n) > 0.0
                && t.dot(self.normal[i]) > 0.0
                && t.dot(self.normal[i + 1]) > 0.0
                && p.distance_squared(self.ring[i]) <= longest
        })
    }

    /// A step up the gradient `g` of the fan's sum of radius ratios at p, in the tangent
    /// plane at p (normal n): the slope along it at `ASCENT_STEP`·`len` fixes the step by
    /// the secant rule (between a sixteenth of that and twice it). None where the gradient
    /// cannot gain `SMOOTH_GAIN` within that reach; else that step, a quarter and a
    /// sixteenth of it, for the caller to judge in turn.
    fn ascent(&self, p: DVec3, n: DVec3, g: DVec3, len: f64) -> Option<[DVec3; 3]> {
        let g = g - g.dot(n) * n;
        let slope = g.length();
        let reach = 2.0 * ASCENT_STEP * len;
        // Also None for a NaN slope (a degenerate fan).
        if slope * reach <= SMOOTH_GAIN || slope.is_nan() {
            return None;
        }
        let dir = g / slope;
        let probe = ASCENT_STEP * len;
        let slope_there = self.eval_grad(p + dir * probe).1.dot(dir);
        let t = if slope_there < slope {
            (probe * slope / (slope - slope_there)).clamp(probe / 16.0, reach)
        } else {
            reach
        };
        Some([1.0, 0.25, 0.0625].map(|f| p + dir * (f * t)))
    }
}

/// What `Fan::walk` found around a vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Walk {
    /// A closed fan of 3 to `MAX_FAN` triangles, gathered.
    Closed,
    /// An open fan (a boundary), or one of more than `MAX_FAN` triangles: not smoothed.
    Open,
    /// A ring vertex outside the vertices given (another block of the centroid round).
    Outside,
}

/// The centroid round's guard (`Fan::guards_move`): the smallest angle's sin² it keeps,
/// and the distance from the surface a lengthened edge's midpoint may have.
struct CentroidGuard {
    keep: f64,
    chord: f64,
}

/// What one pass of the centroid round did: its moves, and the vertices it left for the
/// pass after the blocks (their ring reaches beyond the block).
#[derive(Default)]
struct Moves {
    moves: usize,
    waiting: Vec<u32>,
}

impl Moves {
    /// Moves each free vertex of `vertices` (in that order) to its ring's centroid,
    /// projected, where the guard allows; `pos` and `normal` hold the vertices from `base`
    /// on, and a vertex whose ring leaves them waits.
    #[allow(clippy::too_many_arguments)]
    fn smooth(
        &mut self,
        vertices: impl Iterator<Item = u32>,
        base: usize,
        pos: &mut [DVec3],
        normal: &mut [DVec3],
        stage: &Stage<'_>,
        guard: &CentroidGuard,
        surface: &mut dyn Surface,
        project: &Project<'_>,
    ) {
        let mut fan = Fan::empty();
        for v in vertices {
            if !stage.free(v) {
                continue;
            }
            match fan.walk(stage, pos, normal, base, v) {
                Walk::Closed => {}
                Walk::Open => continue,
                Walk::Outside => {
                    self.waiting.push(v);
                    continue;
                }
            }
            let at = v as usize - base;
            let (p, n) = (pos[at], normal[at]);
            let target = fan.centroid(p, n);
            if p.distance(target) < ODT_SETTLE * stage.h[v as usize] {
                continue;
            }
            let Some((sp, sn)) = project(surface, target) else {
                continue;
            };
            if fan.guards_move(p, sp, sn, guard.keep, surface, guard.chord) {
                (pos[at], normal[at]) = (sp, sn);
                self.moves += 1;
            }
        }
    }
}

/// Whether the midpoint of the chord a–b is within `tolerance` of the surface by the linear
/// estimate |f|/|∇f| (one evaluation): the chord test of a flip's new diagonal and of the
/// edges a move or a removal makes longer or new.
fn midpoint_within(surface: &mut dyn Surface, a: DVec3, b: DVec3, tolerance: f64) -> bool {
    let vg = surface.value_gradient(0.5 * (a + b));
    let g = vg.gradient.length();
    g > 0.0 && vg.value.abs() / g <= tolerance
}

/// The point of the surface in the plane x[axis] = value nearest q (Newton on f with the
/// gradient's component along the axis removed), its unit normal; None if it does not
/// converge to within 1e-13·scale.
fn face_point(
    surface: &mut dyn Surface,
    q: DVec3,
    axis: usize,
    value: f64,
    scale: f64,
) -> Option<(DVec3, DVec3)> {
    let mut u = q;
    u[axis] = value;
    for _ in 0..32 {
        let vg = surface.value_gradient(u);
        let mut g = vg.gradient;
        g[axis] = 0.0;
        let gg = g.length_squared();
        if !(vg.value.is_finite() && gg > 0.0 && gg.is_finite()) {
            return None;
        }
        let step = g * (vg.value / gg);
        if step.length() > scale {
            // The surface runs nearly parallel to the face here.
            return None;
        }
        u -= step;
        u[axis] = value;
        if step.length() <= (1e-12 * scale).max(8.0 * f64::EPSILON * u.abs().max_element()) {
            let n = surface.value_gradient(u).gradient.normalize_or_zero();
            return (n != DVec3::ZERO).then_some((u, n));
        }
    }
    None
}

/// The circumcentre of triangle (a, b, c), or None if degenerate.
fn circumcentre(a: DVec3, b: DVec3, c: DVec3) -> Option<DVec3> {
    circumcentre_and_normal(a, b, c).map(|(centre, _)| centre)
}

/// The circumcentre of triangle (a, b, c) and the normal (b − a) × (c − a) it is computed
/// from (twice the area as its length), or None if degenerate.
fn circumcentre_and_normal(a: DVec3, b: DVec3, c: DVec3) -> Option<(DVec3, DVec3)> {
    let (u, v) = (b - a, c - a);
    let n = u.cross(v);
    let d = 2.0 * n.length_squared();
    if d <= 0.0 {
        return None;
    }
    let centre = a + (u.length_squared() * v.cross(n) + v.length_squared() * n.cross(u)) / d;
    Some((centre, n))
}

/// Barycentric coordinates of o (projected into the plane of a, b, c).
fn barycentric(a: DVec3, b: DVec3, c: DVec3, o: DVec3) -> Option<[f64; 3]> {
    let n = (b - a).cross(c - a);
    let area = n.length_squared();
    if area <= 0.0 {
        return None;
    }
    let wa = (c - b).cross(o - b).dot(n) / area;
    let wb = (a - c).cross(o - c).dot(n) / area;
    Some([wa, wb, 1.0 - wa - wb])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::ValueGrad;

    /// `Stage::new` over a mesh of several of its parallel blocks (`TWIN_BLOCK` vertices):
    /// a grid whose vertex numbers scatter neighbours across the blocks, with holes (open
    /// fans, vertices where two fans touch) and extra triangles on grid edges (non-manifold
    /// edges between blocks). The twins, first corners and frozen vertices against the rule
    /// the proptest above checks on small soups, from a map of the half-edges (its counts
    /// would take too long here).
    #[test]
    fn the_twins_hold_across_the_parallel_blocks() {
        let side = 100u32;
        let nv = (side * side) as usize;
        assert!(nv > 2 * TWIN_BLOCK);
        // 7919 is prime to 10 000: a permutation of the vertices.
        let id = |i: u32, j: u32| (i * side + j) * 7919 % (side * side);
        let mut tri = Vec::new();
        for i in 0..side - 1 {
            for j in 0..side - 1 {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                for t in [[a, b, c], [a, c, d]] {
                    // Holes, a few of them neighbours (a vertex between two of them).
                    if (i * side + j) % 37 != 5 && (i * side + j) % 41 != 6 {
                        tri.push(t);
                    }
                }
            }
        }
        for k in 0..40 {
            tri.push([id(k, k), id(k + 1, k), id(k + 50, k + 3)]);
        }
        let mut case = Case::new(vec![DVec3::ZERO; nv], tri.clone());
        let stage = case.stage(0, None);
        let half = |e: usize| (tri[e / 3][e % 3], tri[e / 3][(e + 1) % 3]);
        let mut halves: std::collections::HashMap<(u32, u32), Vec<u32>> = Default::default();
        for e in 0..3 * tri.len() {
            halves.entry(half(e)).or_default().push(e as u32);
        }
        let count = |a: u32, b: u32| halves.get(&(a, b)).map_or(0, Vec::len);
        let (mut frozen, mut open) = (vec![false; nv], vec![0; nv]);
        let mut non_manifold = 0;
        for e in 0..3 * tri.len() {
            let (a, b) = half(e);
            let (ab, ba) = (count(a, b), count(b, a));
            let expected = if ab == 1 && ba == 1 {
                halves[&(b, a)][0]
            } else {
                NONE
            };
            assert_eq!(stage.twin[e], expected, "half-edge {e} {:?}", (a, b));
            if ab > 1 || ba > 1 {
                frozen[a as usize] = true;
                frozen[b as usize] = true;
                non_manifold += 1;
            }
            if expected == NONE {
                open[a as usize] += 1;
            }
        }
        assert!(non_manifold > 0);
        let mut first = vec![NONE; nv];
        for e in (0..3 * tri.len()).rev() {
            first[half(e).0 as usize] = e as u32;
        }
        let mut touching = 0;
        for v in 0..nv {
            assert_eq!(stage.out[v], first[v], "vertex {v}");
            assert_eq!(stage.frozen[v], frozen[v] || open[v] > 1, "vertex {v}");
            touching += usize::from(!frozen[v] && open[v] > 1);
        }
        assert!(touching > 0);
    }

    /// The centroid round in blocks (`CENTROID_BLOCK` vertices) on a jittered grid of two
    /// blocks: the same positions on a pool of one thread and of two, and without a fork
    /// (the plane has no history); the moves counted are the positions that changed; and
    /// the vertices whose ring reaches into the other block, which wait for the pass after
    /// the blocks, moved as the others did.
    #[test]
    fn the_centroid_round_in_blocks_is_the_same_on_any_pool() {
        let side = 300u32;
        let nv = (side * side) as usize;
        assert!(nv > CENTROID_BLOCK && nv <= 2 * CENTROID_BLOCK);
        let jitter = |k: u32| f64::from(k % 11) / 11.0 - 0.5;
        let pos: Vec<DVec3> = (0..side * side)
            .map(|v| {
                let (i, j) = (v / side, v % side);
                DVec3::new(
                    f64::from(i) + 0.2 * jitter(7 * i + 13 * j),
                    f64::from(j) + 0.2 * jitter(5 * i + 3 * j + 1),
                    0.0,
                )
            })
            .collect();
        let tri = grid_triangles(side);
        let fork = || Some(Box::new(Plane) as Box<dyn Surface>);
        let round = |threads: usize, fork: Option<&Fork<'_>>| {
            let mut case = Case::new(pos.clone(), tri.clone());
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            let mut report = Report::default();
            pool.install(|| {
                let mut stage = case.stage(0, None);
                stage.centroid_round(1.0, &mut Plane, fork, &onto_plane, &mut report);
            });
            (case.pos, report.smoothing_moves)
        };
        let (smoothed, moves) = round(1, Some(&fork));
        assert_eq!(round(2, Some(&fork)), (smoothed.clone(), moves));
        assert_eq!(round(2, None), (smoothed.clone(), moves));
        let moved = |v: u32| smoothed[v as usize] != pos[v as usize];
        assert_eq!((0..side * side).filter(|&v| moved(v)).count(), moves);
        // The grid's inner vertices with a neighbour (±1, ±side, ±(side + 1)) in the other
        // block.
        let block = |v: u32| v as usize / CENTROID_BLOCK;
        let inner =
            |v: u32| (1..side - 1).contains(&(v / side)) && (1..side - 1).contains(&(v % side));
        let between: Vec<u32> = (0..side * side)
            .filter(|&v| inner(v))
            .filter(|&v| {
                [v - 1, v + 1, v - side, v + side, v - side - 1, v + side + 1]
                    .iter()
                    .any(|&w| block(w) != block(v))
            })
            .collect();
        let inner_count = (0..side * side).filter(|&v| inner(v)).count();
        assert!(between.len() > side as usize);
        // Nearly every inner vertex moves (a few targets are nearer than `ODT_SETTLE`), and
        // so do those between the blocks.
        let share = |moved: usize, of: usize| moved as f64 / of as f64;
        assert!(share(moves, inner_count) > 0.9, "{moves} of {inner_count}");
        let between_moved = between.iter().filter(|&&v| moved(v)).count();
        assert!(
            share(between_moved, between.len()) > 0.9,
            "{between_moved} of {}",
            between.len()
        );
    }

    /// The first round's screened queue (`delaunay_queue`: only edges with an obtuse
    /// angle opposite them, the pushed edges screened by the masks the flips keep) flips
    /// exactly as the unscreened queue of every edge, each tried in full: on a jittered
    /// grid with many non-Delaunay edges, the same flips to the same triangles, from a
    /// queue of a fraction of the edges.
    #[test]
    fn the_screened_queue_flips_as_every_edge_tried_would() {
        let side = 80u32;
        // A fixed linear congruential sequence: jitter in [−0.2, 0.2), too little to fold a
        // triangle of the unit grid over.
        let mut seed = 12345u64;
        let mut jitter = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.4
        };
        let pos: Vec<DVec3> = (0..side * side)
            .map(|v| {
                let (i, j) = (f64::from(v / side), f64::from(v % side));
                DVec3::new(i + jitter(), j + jitter(), 0.0)
            })
            .collect();
        let tri = grid_triangles(side);
        let all = vec![true; pos.len()];
        let flipped = |screened: bool| {
            let mut case = Case::new(pos.clone(), tri.clone());
            let mut stage = case.stage(0, None);
            let (queue, obtuse) = if screened {
                stage.delaunay_queue(&all)
            } else {
                (stage.dirty_edges(&all), None)
            };
            let queued = queue.len();
            let budget = 2 * stage.tri.len();
            let (flips, done) = stage.flip_all(queue, obtuse, budget, &mut Plane, 1.0, None);
            assert!(done);
            (flips, queued, case.tri)
        };
        let (flips, queued, screened) = flipped(true);
        let (every_flips, every_queued, every) = flipped(false);
        assert_eq!(flips, every_flips);
        let differing = screened.iter().zip(&every).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "triangles differ of {}", every.len());
        // 3 113 flips from a queue of 4 437 of the 18 565 inner edges.
        assert!(flips > 1000, "{flips} flips");
        assert!(
            queued < every_queued / 2,
            "{queued} of {every_queued} edges"
        );
    }

    /// The triangles of a side × side grid of vertices numbered row by row (vertex
    /// (i, j) is i·side + j), two a square, counter-clockwise seen from +z.
    fn grid_triangles(side: u32) -> Vec<[u32; 3]> {
        let mut tri = Vec::new();
        for i in 0..side - 1 {
            for j in 0..side - 1 {
                let (a, b) = (i * side + j, (i + 1) * side + j);
                tri.push([a, b, b + 1]);
                tri.push([a, b + 1, a + 1]);
            }
        }
        tri
    }

    /// The plane z = 0 with ∇f = +z.
    struct Plane;

    impl Surface for Plane {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            ValueGrad {
                value: p.z,
                gradient: DVec3::Z,
            }
        }
    }

    fn onto_plane(_: &mut dyn Surface, q: DVec3) -> Option<(DVec3, DVec3)> {
        Some((DVec3::new(q.x, q.y, 0.0), DVec3::Z))
    }

    struct Case {
        pos: Vec<DVec3>,
        normal: Vec<DVec3>,
        tri: Vec<[u32; 3]>,
        border: Vec<bool>,
        h: Vec<f64>,
    }

    impl Case {
        fn new(pos: Vec<DVec3>, tri: Vec<[u32; 3]>) -> Self {
            let n = pos.len();
            Case {
                pos,
                normal: vec![DVec3::Z; n],
                tri,
                border: vec![false; n],
                h: vec![1.0; n],
            }
        }

        /// Runs the stage with the first `fixed` vertices as polygon vertices.
        fn run(&mut self, fixed: usize) -> Report {
            self.run_in(fixed, None)
        }

        fn run_in(&mut self, fixed: usize, bbox: Option<(DVec3, DVec3)>) -> Report {
            self.run_aiming(fixed, bbox, 1.0)
        }

        /// Runs the stage with the mean radius ratio `ratio` as its aim (1: every phase).
        fn run_aiming(&mut self, fixed: usize, bbox: Option<(DVec3, DVec3)>, ratio: f64) -> Report {
            let limits = Limits {
                angle: 0.524,
                rounds: 6,
                insert_fraction: 0.05,
                tolerance: 0.1,
                ratio,
            };
            self.stage(fixed, bbox)
                .run(&limits, &mut Plane, None, &mut onto_plane)
        }

        fn mean_ratio(&self) -> f64 {
            let sum: f64 = self
                .tri
                .iter()
                .map(|t| {
                    radius_ratio(
                        self.pos[t[0] as usize],
                        self.pos[t[1] as usize],
                        self.pos[t[2] as usize],
                    )
                })
                .sum();
            sum / self.tri.len() as f64
        }

        /// The stage over the case, with the first `fixed` vertices as polygon vertices.
        fn stage(&mut self, fixed: usize, bbox: Option<(DVec3, DVec3)>) -> Stage<'_> {
            Stage::new(
                &mut self.pos,
                &mut self.normal,
                &mut self.tri,
                &mut self.border,
                &mut self.h,
                fixed,
                bbox,
            )
        }

        fn worst_deg(&self) -> f64 {
            self.tri
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|v| self.pos[v as usize]);
                    min_sin(a, b, c).asin().to_degrees()
                })
                .fold(f64::INFINITY, f64::min)
        }

        /// χ = V − E + F over the vertices used.
        fn euler(&self) -> i64 {
            let mut edges: Vec<(u32, u32)> = self
                .tri
                .iter()
                .flat_map(|t| {
                    (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3])))
                })
                .collect();
            edges.sort_unstable();
            edges.dedup();
            let mut used: Vec<u32> = self.tri.iter().flatten().copied().collect();
            used.sort_unstable();
            used.dedup();
            used.len() as i64 - edges.len() as i64 + self.tri.len() as i64
        }

        /// Every triangle counter-clockwise seen from +z (faces ∇f).
        fn all_up(&self) -> bool {
            self.tri.iter().all(|t| {
                let [a, b, c] = t.map(|v| self.pos[v as usize]);
                (b - a).cross(c - a).z > 0.0
            })
        }
    }

    /// Two triangles over the quad a(0,0) b(2,0) c(1,0.2) d(1,−1.5): the shared edge a–b
    /// makes (a, b, c) an 11° sliver; the quad is not Delaunay over a–b.
    fn sliver_pair() -> Case {
        Case::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(2.0, 0.0, 0.0),
                DVec3::new(1.0, 0.2, 0.0),
                DVec3::new(1.0, -1.5, 0.0),
            ],
            vec![[0, 1, 2], [1, 0, 3]],
        )
    }

    /// Every twin runs the other way and is its twin's twin.
    fn assert_twins(stage: &Stage<'_>) {
        for e in 0..3 * stage.tri.len() as u32 {
            let f = stage.twin[e as usize];
            if f != NONE {
                assert_eq!(stage.twin[f as usize], e);
                assert_eq!((stage.org(f), stage.dst(f)), (stage.dst(e), stage.org(e)));
            }
        }
    }

    /// A free corner 0.05 above a polygon edge a–b, in a fan of four (a, b, e, f), with a
    /// triangle beyond the polygon edge and beyond f–a: `remove_corner` merges it into a
    /// corner of a–b, keeps the half-edges consistent (every twin runs the other way and is
    /// its twin's twin, every used vertex's outgoing half-edge leaves it), the polygon edge
    /// between the same two triangles' sides, χ, and raises the smallest angle.
    #[test]
    fn a_free_corner_on_a_polygon_edge_is_removed() {
        let p = |x: f64, y: f64| DVec3::new(x, y, 0.0);
        // a b e f c g w s
        let mut case = Case::new(
            vec![
                p(0.0, 0.0),
                p(1.0, 0.0),
                p(1.0, 0.9),
                p(0.0, 0.9),
                p(0.5, 0.05),
                p(0.5, 1.6),
                p(-0.8, 0.45),
                p(0.5, -0.8),
            ],
            vec![
                [0, 1, 4],
                [1, 2, 4],
                [2, 3, 4],
                [3, 0, 4],
                [3, 2, 5],
                [0, 3, 6],
                [1, 0, 7],
            ],
        );
        let (euler, worst) = (case.euler(), case.worst_deg());
        let mut stage = case.stage(2, None);
        assert!(stage.remove_corner(0, &mut Plane, 0.1).is_some());
        assert_eq!(stage.tri.len(), 5);
        assert!(stage.tri.iter().all(|t| !t.contains(&4)), "{:?}", stage.tri);
        assert_eq!(stage.out[4], NONE);
        assert_twins(&stage);
        for v in [0, 1, 2, 3, 5, 6, 7] {
            assert_eq!(stage.org(stage.out[v as usize]), v);
        }
        // The polygon edge a–b still has a triangle on each side, now (a|b, b|a, e|s).
        let sides = stage
            .tri
            .iter()
            .filter(|t| t.contains(&0) && t.contains(&1))
            .count();
        assert_eq!(sides, 2);
        let open = stage.twin.iter().filter(|&&f| f == NONE).count();
        drop(stage);
        assert_eq!(case.euler(), euler);
        assert!(case.all_up());
        assert!(
            case.worst_deg() > worst + 20.0,
            "{} → {}",
            worst,
            case.worst_deg()
        );
        // The outline: a–s–b, b–e, e–g–f, f–w–a: 7 open edges, as before.
        assert_eq!(open, 7);
    }

    /// A needle between two free vertices b and c 0.02 apart inside a ring of eight polygon
    /// points (its smallest angle 1.1°, its short edge b–c interior and flippable): the
    /// removal merges one into the other, the mesh stays consistent with χ unchanged, and
    /// the smallest angle is near the ring's 45°.
    #[test]
    fn a_needle_between_two_free_corners_is_merged() {
        let mut pos: Vec<DVec3> = (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::FRAC_PI_4;
                DVec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        pos.extend([DVec3::new(-0.01, 0.0, 0.0), DVec3::new(0.01, 0.0, 0.0)]);
        let (b, c) = (8, 9);
        let mut case = Case::new(
            pos,
            vec![
                [b, c, 2],
                [c, b, 6],
                [c, 0, 1],
                [c, 1, 2],
                [c, 7, 0],
                [c, 6, 7],
                [b, 2, 3],
                [b, 3, 4],
                [b, 4, 5],
                [b, 5, 6],
            ],
        );
        let (euler, worst) = (case.euler(), case.worst_deg());
        assert!(worst < 2.0, "{worst}");
        let mut stage = case.stage(8, None);
        let keep = stage.remove_corner(0, &mut Plane, 0.1);
        assert!(keep == Some(b) || keep == Some(c), "{keep:?}");
        assert_eq!(stage.tri.len(), 8);
        let gone = if keep == Some(b) { c } else { b };
        assert!(stage.tri.iter().all(|t| !t.contains(&gone)));
        assert_eq!(stage.out[gone as usize], NONE);
        assert_twins(&stage);
        let open = stage.twin.iter().filter(|&&f| f == NONE).count();
        drop(stage);
        assert_eq!(open, 8, "the ring's eight edges stay the outline");
        assert_eq!(case.euler(), euler);
        assert!(case.all_up());
        assert!(case.worst_deg() > 44.0, "{}", case.worst_deg());
    }

    /// A fan of `k` ring points around the origin at radii and heights from `jitter`.
    fn fan_of(k: usize, jitter: &[f64]) -> Fan {
        let mut fan = Fan {
            k,
            ring: [DVec3::ZERO; MAX_FAN + 1],
            normal: [DVec3::Z; MAX_FAN + 1],
            opp: [0.0; MAX_FAN + 1],
            opp2: [0.0; MAX_FAN + 1],
        };
        for i in 0..k {
            let a = std::f64::consts::TAU * (i as f64 + 0.3 * jitter[2 * i]) / k as f64;
            let r = 1.0 + 0.4 * jitter[2 * i + 1];
            fan.ring[i] = DVec3::new(r * a.cos(), r * a.sin(), 0.2 * jitter[2 * i]);
        }
        fan.ring[k] = fan.ring[0];
        for i in 0..k {
            fan.opp2[i] = fan.ring[i].distance_squared(fan.ring[i + 1]);
            fan.opp[i] = fan.opp2[i].sqrt();
        }
        fan
    }

    proptest::proptest! {
        /// `Stage::new`'s twins, first corners and frozen vertices against counts over every
        /// pair of half-edges, on triangle soups over a few vertices: manifold fans, open
        /// fans, and edges in three or more triangles or twice the same way (non-manifold).
        #[test]
        fn the_twins_match_a_count_of_every_half_edge_pair(
            n in 4u32..9,
            picks in proptest::collection::vec(proptest::array::uniform3(0u32..9), 1..16),
        ) {
            let tri: Vec<[u32; 3]> = picks
                .iter()
                .map(|t| t.map(|v| v % n))
                .filter(|t| t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
                .collect();
            let nv = n as usize;
            let mut case = Case::new(vec![DVec3::ZERO; nv], tri.clone());
            let stage = case.stage(0, None);
            let half = |e: usize| (tri[e / 3][e % 3], tri[e / 3][(e + 1) % 3]);
            let count = |a: u32, b: u32| (0..3 * tri.len()).filter(|&f| half(f) == (a, b)).count();
            let mut frozen = vec![false; nv];
            let mut open = vec![0; nv];
            for e in 0..3 * tri.len() {
                let (a, b) = half(e);
                let (ab, ba) = (count(a, b), count(b, a));
                let expected = if ab == 1 && ba == 1 {
                    (0..3 * tri.len()).find(|&f| half(f) == (b, a)).unwrap() as u32
                } else {
                    NONE
                };
                proptest::prop_assert_eq!(stage.twin[e], expected, "half-edge {} {:?}", e, (a, b));
                if ab > 1 || ba > 1 {
                    frozen[a as usize] = true;
                    frozen[b as usize] = true;
                }
                if expected == NONE {
                    open[a as usize] += 1;
                }
            }
            for v in 0..nv {
                let first = (0..3 * tri.len()).find(|&e| half(e).0 == v as u32);
                proptest::prop_assert_eq!(stage.out[v], first.map_or(NONE, |e| e as u32));
                proptest::prop_assert_eq!(stage.frozen[v], frozen[v] || open[v] > 1, "vertex {}", v);
            }
        }

        /// `Fan::eval_grad`'s gradient of the sum of radius ratios against central
        /// differences, over fans of 3 to 9 triangles with the centre off the middle.
        #[test]
        fn the_ratio_gradient_matches_finite_differences(
            k in 3usize..10,
            jitter in proptest::collection::vec(-1.0f64..1.0, 18),
            centre in proptest::array::uniform3(-0.3f64..0.3),
        ) {
            let fan = fan_of(k, &jitter);
            let p = DVec3::from_array(centre);
            let (q, g) = fan.eval_grad(p);
            proptest::prop_assume!(q.worst_rr > 0.05);
            let h = 1e-6;
            let diff = DVec3::new(
                fan.eval(p + h * DVec3::X).sum - fan.eval(p - h * DVec3::X).sum,
                fan.eval(p + h * DVec3::Y).sum - fan.eval(p - h * DVec3::Y).sum,
                fan.eval(p + h * DVec3::Z).sum - fan.eval(p - h * DVec3::Z).sum,
            ) / (2.0 * h);
            proptest::prop_assert!(
                (g - diff).length() <= 1e-5 * (1.0 + diff.length()),
                "analytic {g} against differences {diff}"
            );
        }
    }

    /// `Fan::guards_move` (one pass, no square roots) against the guard it replaced:
    /// `eval`'s smallest angle at both places, `holds`, and the midpoint test of the edges
    /// that grew beyond the fan's longest, on a bowl, over fans and moves of every kind
    /// (both verdicts and each way of failing occur).
    #[test]
    fn the_smoothing_guard_agrees_with_its_parts() {
        let mut bowl = crate::surface::NativeSurface(|p: DVec3| ValueGrad {
            value: p.z - 0.3 * (p.x * p.x + p.y * p.y),
            gradient: DVec3::new(-0.6 * p.x, -0.6 * p.y, 1.0),
        });
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut taken, mut facing, mut angle, mut chord) = (0, 0, 0, 0);
        for case in 0..4000 {
            let k = 3 + case % 7;
            let jitter: Vec<f64> = (0..18).map(|_| uniform()).collect();
            let fan = fan_of(k, &jitter);
            let from = DVec3::new(0.3 * uniform(), 0.3 * uniform(), 0.1 * uniform());
            let to = from + DVec3::new(0.6 * uniform(), 0.6 * uniform(), 0.1 * uniform());
            let keep = (25.0 + 10.0 * uniform()).to_radians().sin().powi(2);
            let n = (DVec3::Z + 0.3 * DVec3::new(uniform(), uniform(), 0.0)).normalize();
            let tolerance = 0.01;
            let worst = fan.eval(to).worst;
            let longest = fan.longest(from);
            let faces = fan.holds(to, n, f64::INFINITY);
            let keeps = worst >= keep || worst >= fan.eval(from).worst;
            let chords = fan.ring[..k].iter().all(|&q| {
                to.distance_squared(q) <= longest || midpoint_within(&mut bowl, to, q, tolerance)
            });
            let fused = fan.guards_move(from, to, n, keep, &mut bowl, tolerance);
            assert_eq!(fused, faces && keeps && chords, "case {case}");
            let w = fan.worst_sin2(to);
            assert!(
                (w - worst).abs() <= 1e-12 * worst.max(1e-12),
                "{w} vs {worst}"
            );
            taken += usize::from(fused);
            facing += usize::from(!faces);
            angle += usize::from(faces && !keeps);
            chord += usize::from(faces && keeps && !chords);
        }
        for count in [taken, facing, angle, chord] {
            assert!(
                count >= 40,
                "{taken} taken, {facing} facing, {angle} angle, {chord} chord"
            );
        }
    }

    #[test]
    fn the_ascent_raises_the_ratios_of_an_off_centre_fan() {
        let fan = fan_of(6, &[0.0; 12]);
        let p = DVec3::new(0.3, 0.1, 0.0);
        let (q, g) = fan.eval_grad(p);
        let steps = fan.ascent(p, DVec3::Z, g, 1.3).expect("a step");
        let best = fan.eval(steps[0]);
        assert!(best.sum > q.sum + SMOOTH_GAIN, "{} → {}", q.sum, best.sum);
        // The regular hexagon's centre is the optimum: the step heads towards it.
        assert!(steps[0].length() < p.length(), "{}", steps[0]);
    }

    #[test]
    fn radius_ratio_is_one_for_an_equilateral_triangle() {
        let h = 3f64.sqrt() / 2.0;
        let r = radius_ratio(DVec3::ZERO, DVec3::X, DVec3::new(0.5, h, 0.0));
        assert!((r - 1.0).abs() < 1e-12, "{r}");
        // Right isosceles: r_in = 1 − 1/√2, r_circ = 1/√2 (legs 1): 2·r_in/r_circ = 2(√2 − 1).
        let r = radius_ratio(DVec3::ZERO, DVec3::X, DVec3::Y);
        assert!((r - 2.0 * (2f64.sqrt() - 1.0)).abs() < 1e-12, "{r}");
        assert_eq!(radius_ratio(DVec3::ZERO, DVec3::X, 2.0 * DVec3::X), 0.0);
    }

    #[test]
    fn a_non_delaunay_pair_is_flipped() {
        let mut c = sliver_pair();
        let before = c.worst_deg();
        let report = c.run(0);
        assert!(report.flips >= 1, "{report:?}");
        assert!(c.worst_deg() > before);
        assert!(c.all_up());
        // Corner 0 and 1 lost their shared edge (c–d is the diagonal now).
        assert!(
            c.tri.iter().all(|t| !(t.contains(&0) && t.contains(&1))),
            "{:?}",
            c.tri
        );
    }

    #[test]
    fn an_edge_between_polygon_vertices_is_never_flipped_or_split() {
        let mut c = sliver_pair();
        c.run(4);
        assert!(c.tri.iter().any(|t| t.contains(&0) && t.contains(&1)));
        assert_eq!(c.pos.len(), 4, "no vertex on a polygon edge");
    }

    /// A fan of 6 around a free vertex pushed close to one rim edge.
    fn fan() -> Case {
        let mut pos = vec![DVec3::new(0.7, 0.05, 0.0)];
        for k in 0..6 {
            let a = std::f64::consts::FRAC_PI_3 * k as f64;
            pos.push(DVec3::new(a.cos(), a.sin(), 0.0));
        }
        let tri = (0..6u32).map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
        Case::new(pos, tri)
    }

    #[test]
    fn a_free_vertex_moves_onto_the_surface_and_polygon_vertices_stay() {
        let mut c = fan();
        c.pos.rotate_left(1);
        // Vertex 6 is the centre now; the rim (0..6) is the polygon.
        for t in c.tri.iter_mut() {
            *t = t.map(|v| (v + 6) % 7);
        }
        let rim: Vec<DVec3> = c.pos[..6].to_vec();
        let before = c.worst_deg();
        c.run(6);
        assert_eq!(&c.pos[..6], &rim[..], "polygon vertices keep their bits");
        assert!(c.worst_deg() > before.max(45.0), "{}", c.worst_deg());
        assert!(c.pos.iter().all(|p| p.z == 0.0));
        assert!(c.all_up());
        assert_eq!(c.euler(), 1);
    }

    #[test]
    fn the_ratio_phases_stop_at_their_aim() {
        // A hexagonal grid in the plane with its inner vertices shaken by up to 0.15 of
        // the spacing (every angle stays above 30°, so only the ratio phases act); the
        // outline is fixed (listed first).
        let n = 12;
        let at =
            |i: i32, j: i32| DVec3::new(i as f64 + 0.5 * j as f64, 0.75f64.sqrt() * j as f64, 0.0);
        let mut rnd = crate::testing::uniform(7);
        let (mut outline, mut inner) = (Vec::new(), Vec::new());
        for j in 0..=n {
            for i in 0..=n {
                if i == 0 || j == 0 || i == n || j == n {
                    outline.push((i, j));
                } else {
                    inner.push((i, j));
                }
            }
        }
        let index = |i: i32, j: i32| {
            let k = outline
                .iter()
                .chain(&inner)
                .position(|&q| q == (i, j))
                .unwrap();
            k as u32
        };
        let mut pos: Vec<DVec3> = outline.iter().map(|&(i, j)| at(i, j)).collect();
        for &(i, j) in &inner {
            let shake = DVec3::new(rnd() - 0.5, rnd() - 0.5, 0.0) * 0.3;
            pos.push(at(i, j) + shake);
        }
        let mut tri = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tri.push([index(i, j), index(i + 1, j), index(i, j + 1)]);
                tri.push([index(i + 1, j), index(i + 1, j + 1), index(i, j + 1)]);
            }
        }
        let fresh = || Case::new(pos.clone(), tri.clone());
        let before = fresh().mean_ratio();
        let worst = fresh().worst_deg();
        assert!(worst > 30.5 && before < 0.97, "{worst}° {before}");
        // At the aim already: nothing moves.
        let mut at_aim = fresh();
        let report = at_aim.run_aiming(outline.len(), None, before);
        assert_eq!(
            (
                report.centroid_rounds,
                report.odt_rounds,
                report.polish_rounds,
                report.moves
            ),
            (0, 0, 0, 0)
        );
        assert_eq!(at_aim.pos, pos);
        // An aim one centroid round reaches: that round, no ratio phase.
        let mut one = fresh();
        let report = one.run_aiming(outline.len(), None, before + 0.001);
        let after_one = one.mean_ratio();
        assert_eq!(
            (
                report.centroid_rounds,
                report.odt_rounds,
                report.polish_rounds
            ),
            (1, 0, 0),
            "{report:?}"
        );
        assert!(after_one >= before + 0.001, "{before} → {after_one}");
        assert_eq!(report.ratio_after, after_one);
        // Out of reach: the ratios' phase around the ODT's rounds, and a higher mean than
        // the centroid round alone gave.
        let mut all = fresh();
        let report = all.run_aiming(outline.len(), None, 1.0);
        assert!(
            report.odt_rounds > 1 && report.polish_rounds > 0,
            "{report:?}"
        );
        assert!(
            all.mean_ratio() > after_one,
            "{} vs {after_one}",
            all.mean_ratio()
        );
        for case in [&one, &all] {
            assert!(case.worst_deg() >= 30.0 && case.all_up());
            assert_eq!(case.euler(), fresh().euler());
        }
    }

    #[test]
    fn a_strip_of_needles_is_lifted_and_the_topology_stays() {
        // A strip of 17° needles between two rows of free vertices (flips, moves and
        // insertions may all take part).
        let mut pos = Vec::new();
        for i in 0..6 {
            pos.push(DVec3::new(0.3 * i as f64, 0.0, 0.0));
        }
        for i in 0..6 {
            pos.push(DVec3::new(0.3 * i as f64 + 0.15, 1.0, 0.0));
        }
        let mut tri = Vec::new();
        for i in 0..5u32 {
            tri.push([i, i + 1, i + 6]);
            tri.push([i + 1, i + 7, i + 6]);
        }
        let mut c = Case::new(pos, tri);
        let (chi, before) = (c.euler(), c.worst_deg());
        let report = c.run(0);
        assert!(
            c.worst_deg() > before + 5.0,
            "{} vs {before}: {report:?}",
            c.worst_deg()
        );
        assert_eq!(c.euler(), chi);
        assert!(c.all_up());
        assert!(c.pos.iter().all(|p| p.z == 0.0));
    }

    #[test]
    fn border_vertices_slide_along_their_box_face_only() {
        // The plane z = 0 cut by the box face x = 0: border points 0, 1, 2 on the face, 1
        // close to 0, so (0, 3, 1) is an 8° sliver that only a slide of 1 (or 0) along the
        // face can open.
        let mut c = Case::new(
            vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(0.0, 0.15, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(0.866, 0.5, 0.0),
            ],
            vec![[0, 3, 1], [1, 3, 2]],
        );
        c.border = vec![true, true, true, false];
        let bbox = (DVec3::new(0.0, -1.0, -1.0), DVec3::new(2.0, 2.0, 1.0));
        let before = c.worst_deg();
        c.run_in(0, Some(bbox));
        assert!(
            c.worst_deg() > before + 10.0,
            "{} vs {before}",
            c.worst_deg()
        );
        assert!(
            c.pos[0].y != 0.0 || c.pos[1].y != 0.15,
            "no border point slid"
        );
        for (p, &border) in c.pos.iter().zip(&c.border) {
            assert_eq!(p.z, 0.0);
            if border {
                assert_eq!(p.x, 0.0, "a border point left its face: {p}");
                assert!((-1.0..=2.0).contains(&p.y), "{p}");
            }
        }
        assert!(c.all_up());
        assert_eq!(c.euler(), 1);
    }

    #[test]
    fn the_same_input_gives_the_same_bits() {
        let (mut a, mut b) = (fan(), fan());
        a.run(0);
        b.run(0);
        let bits = |c: &Case| -> Vec<u64> {
            c.pos
                .iter()
                .flat_map(|p| p.to_array().map(f64::to_bits))
                .collect()
        };
        assert_eq!(bits(&a), bits(&b));
        assert_eq!(a.tri, b.tri);
    }
}
