//! The quality stage between the march and the verification (issue 13): restricted-Delaunay
//! edge flips, angle-based smoothing of free vertices on the surface, insertion of
//! off-centres where a triangle stays below the target angle, and the merge of a free corner
//! into a neighbour where insertion cannot mend it (`Stage::remove_corner`), or of two free
//! vertices into one beside a corner that may not move (`Stage::merge_pair`); then the mean
//! radius ratio (issue 10, M4) raised to `Limits::ratio`, cheapest first: a round of
//! smoothing towards the rings' centroids (`Stage::centroid_round`), and only where that
//! falls short, valence flips and smoothing up the gradient of each fan's radius ratios
//! (`Stage::polish`) around rounds towards the optimal Delaunay triangulation — all under a
//! guard that cannot lower the smallest angle below min(target, what the rounds reached).
//! An aim above the default gets the default's phases first, then centroid rounds while they
//! gain and the rest again, kept only if they leave no two triangles crossing.
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
//!
//! This file holds the stage's state (`Stage`), its limits and report, its constants and
//! the small accessors every phase shares; the phases are one file each: `halfedge` (the
//! twins, stars and the bookkeeping of a change), `flips`, `smooth` (and the slides along
//! box faces), `insert` (off-centres, splits, removal of a corner), `polish` (the radius
//! ratio's phases), `fan` (a vertex's ring as the smoothing judges it), `shape` (a
//! triangle's measures and the scans over them) and `run` (the order of the phases).
//! This file imports none of them; they import from it, and from one another downwards
//! only: `fan` from `shape`, `smooth` from `fan` and `shape`, `insert` from `smooth` and
//! `shape`, `polish` from `fan` and `shape`, `run` from `shape`.

mod fan;
mod flips;
mod halfedge;
mod insert;
mod polish;
mod run;
mod shape;
mod smooth;
#[cfg(test)]
mod tests;

use glam::DVec3;

use crate::surface::Surface;

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
/// times the rounds' cost; CHANGELOG.md, Notes, *The stage as cheap as its aim*).
const BAD_RINGS: usize = 2;
/// Where the mean radius ratio is at the aim and the angle's rounds leave triangles below
/// the target, the ratios' phase and the ODT rounds run over the vertices within this many
/// rings of them (`Stage::ratio_phases`), not over the whole mesh.
const MEND_RINGS: usize = 8;

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

/// Above the default aim, centroid rounds follow one another while the mean stays below the
/// aim and a round raises it by at least `CENTROID_GAIN`, at most `CENTROID_ROUNDS` of them
/// (at the default aim one round, `Stage::run`). An aim of 0.995 takes the sphere at step
/// 0.03 from the default's 0.9877 to 0.9917 in four more rounds (then the ratios' phase to
/// 0.9927, and the rounds again to 0.9931), where the ratios' phase alone, which the aim 1
/// ran before, made 0.9844: the centroid's moves keep the march's valences, the valence
/// flips of that phase first doubled the vertices of valence 5 and 7 there (6 600 →
/// 12 900).
const CENTROID_GAIN: f64 = 1e-4;
const CENTROID_ROUNDS: u32 = 12;

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
    /// at it is left as it is, one within `ODT_REACH` of it (or of the default aim, the
    /// lower) gets centroid rounds, and only a mesh still below it gets the ratios' phase
    /// (`polish`).
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
    /// Vertices removed (`Stage::remove_corner`, `Stage::merge_pair`).
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
    /// The phases above the default aim made a crossing, and the default's mesh was put
    /// back (`Stage::run`).
    pub above_default_undone: bool,
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

/// What the phases above the default aim may change (positions, normals, flips), kept to
/// be put back (`Stage::save`, `Stage::restore`).
pub(super) struct Saved {
    pos: Vec<DVec3>,
    normal: Vec<DVec3>,
    tri: Vec<[u32; 3]>,
    twin: Vec<u32>,
    out: Vec<u32>,
    valence: Vec<u32>,
}

/// One change recorded while an insertion is on trial.
enum Undo {
    Tri(u32, [u32; 3]),
    Twin(u32, u32),
    Out(u32, u32),
    Pos(u32, DVec3, DVec3),
}

fn next(e: u32) -> u32 {
    if e % 3 == 2 { e - 2 } else { e + 1 }
}

fn prev(e: u32) -> u32 {
    if e % 3 == 0 { e + 2 } else { e - 1 }
}

impl Stage<'_> {
    /// The state the ratio's phases change (they neither insert nor remove vertices, nor
    /// slide border points).
    pub(super) fn save(&self) -> Saved {
        Saved {
            pos: self.pos.clone(),
            normal: self.normal.clone(),
            tri: self.tri.clone(),
            twin: self.twin.clone(),
            out: self.out.clone(),
            valence: self.valence.clone(),
        }
    }

    /// Puts back what `save` kept.
    pub(super) fn restore(&mut self, saved: Saved) {
        *self.pos = saved.pos;
        *self.normal = saved.normal;
        *self.tri = saved.tri;
        self.twin = saved.twin;
        self.out = saved.out;
        self.valence = saved.valence;
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

    fn h_of(&self, vs: &[u32]) -> f64 {
        vs.iter().map(|&v| self.h[v as usize]).fold(0.0, f64::max)
    }

    fn in_box(&self, p: DVec3) -> bool {
        self.bbox
            .is_none_or(|(lo, hi)| p.cmpge(lo).all() && p.cmple(hi).all())
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
