//! The radius ratio's phases after the rounds for the angle: the centroid round, the
//! ratios' rounds of valence flips and ascents (`polish`) and the ODT rounds, all under
//! the guard that keeps the smallest angle.

use glam::DVec3;
use rayon::prelude::*;

use crate::surface::{Fork, Surface};

use super::fan::{Fan, Walk};
use super::shape::circumcentre_and_normal;
use super::{
    CENTROID_BLOCK, KEEP_ANGLE, Limits, MAX_FAN, NONE, ODT_CHORD, ODT_SETTLE, Project, Report,
    SETTLE, SMOOTH_BELOW, STALL, Stage, prev,
};

impl Stage<'_> {
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
    pub(super) fn polish(
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

    /// `rounds` rounds of ODT smoothing over the free vertices `active` marks in index order,
    /// moving each to its ODT position (`odt_target`). After the first round only the vertices around
    /// the last round's moves are visited, and they move only by more than `ODT_SETTLE` of
    /// their local step. Returns which vertices moved.
    ///
    /// A move is kept under `polish`'s angle guard (the fan's smallest angle stays at or
    /// above the smaller of `KEEP_ANGLE` and what it was), with every triangle facing ∇f,
    /// and every edge that grows beyond the fan's longest with its midpoint within
    /// `ODT_CHORD` of the chord tolerance from the surface (the flips' test; the
    /// verification checks the centroids too, which lie up to a third further out)
    /// (`Fan::guards_move`).
    pub(super) fn odt_rounds(
        &mut self,
        mut active: Vec<bool>,
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
        // The first round visits the vertices `active` marks, each round after it those
        // around what the round before moved.
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
    pub(super) fn centroid_round(
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
