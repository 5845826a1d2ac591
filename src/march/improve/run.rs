//! The stage's driver: `Stage::run` takes the rounds for the angle (`angle_rounds`:
//! flips, smoothing near bad triangles, insertion, removal), then the radius ratio's
//! phases as far as the aim asks, and reports what is left below the target.

use glam::DVec3;
use rayon::prelude::*;

use crate::march::settings::DEFAULT_QUALITY_RATIO;
use crate::mesh::check::crossing_pairs;
use crate::surface::{Fork, Surface};

use super::shape::{Shape, mean_ratio, ratio_sum_of};
use super::{
    BAD_RINGS, CENTROID_GAIN, CENTROID_ROUNDS, Limits, MEND_RINGS, ODT_REACH, ODT_ROUNDS, Project,
    ROUNDS_STALL, Report, SCAN_BLOCK, SLIDE_ROUNDS, SMOOTH_BELOW, Stage,
};

impl Stage<'_> {
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
        // to the aim cheapest first (`ratio_phases`): first to the default aim at most, as
        // every mesh block without a `radius_ratio:` has it.
        report.rounds_seconds = started.elapsed().as_secs_f64();
        let aim = limits.ratio;
        let to_default = Limits {
            ratio: aim.min(DEFAULT_QUALITY_RATIO),
            ..*limits
        };
        let start = report.ratio_after_rounds;
        let (mut mean, mut below) =
            self.ratio_phases(&to_default, 1, start, surface, fork, project, &mut report);
        // Above the default aim, the phases again from the default's mesh with as many
        // centroid rounds as gain (`CENTROID_ROUNDS`), kept only where they cross nothing:
        // on a plate a step and a half thick their moves near the rim pushed triangles
        // through the far sheet (a random superquadric 0.006 thick at step 0.0044 with
        // `radius_ratio: 1` was refused for crossings after four refinements, where the
        // default's mesh is right). The check is the verification's (`crossing_pairs`), on
        // the stage's mesh; the default's mesh is put back where it finds a pair.
        if aim > DEFAULT_QUALITY_RATIO && mean < aim {
            let saved = self.save();
            let (higher, higher_below) = self.ratio_phases(
                limits,
                CENTROID_ROUNDS,
                mean,
                surface,
                fork,
                project,
                &mut report,
            );
            if crossing_pairs(self.pos, self.tri, None).is_empty() {
                (mean, below) = (higher, higher_below);
            } else {
                self.restore(saved);
                report.above_default_undone = true;
            }
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

    /// The mean radius ratio raised from `start` (the mesh's mean now) towards
    /// `limits.ratio`, cheapest first: smoothing towards the rings' centroids (a projection
    /// a vertex a round; up to `rounds` rounds while they gain) where it can reach it
    /// (within `ODT_REACH` of the aim, or of the default aim where that is lower); only where
    /// it does not, the ratios' phase (valence flips and an ascent a fan, about five times
    /// the cost of a smoothing round) over every vertex, ODT rounds, and the ratios' phase
    /// where they moved something — under a guard that cannot lower the angle (`polish`) —
    /// and, with more than one round allowed, the centroid's rounds again after them (their
    /// flips and moves leave rings the centroid still evens out: the sphere at step 0.03
    /// with 0.995, 0.9927 → 0.9931 and its smallest angle 33.4° → 41.0°, in 0.02 s more).
    /// Returns the mean and the triangles below the target angle (`Stage::survey`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn ratio_phases(
        &mut self,
        limits: &Limits,
        rounds: u32,
        start: f64,
        surface: &mut dyn Surface,
        fork: Option<&Fork<'_>>,
        project: &mut Project<'_>,
        report: &mut Report,
    ) -> (f64, Vec<u32>) {
        let sin_bad = limits.angle.sin();
        let aim = limits.ratio;
        let reach = aim.min(DEFAULT_QUALITY_RATIO) - ODT_REACH;
        // The mean and the triangles below the target, from the scan after the last
        // centroid round or from one scan here.
        let mut surveyed = None;
        if (reach..aim).contains(&start) {
            let smoothing_started = std::time::Instant::now();
            surveyed =
                Some(self.centroid_rounds(rounds, start, limits, surface, fork, project, report));
            report.smoothing_seconds += smoothing_started.elapsed().as_secs_f64();
        }
        let (mut mean, mut below) = surveyed.unwrap_or_else(|| self.survey(sin_bad));
        // Where triangles stay below the target, the full path runs too, as if the aim
        // were not met: the angle's rounds could not mend them, and the moves of its
        // valence flips and ODT rounds around them may. (Two of the gallery's meshes keep
        // one such triangle beside a box face after the centroid's round, at 29.2° and
        // 29.8°; the full path mends both, as it did when an ODT round left their means
        // below the aim.) With the mean at the aim, the path runs first only around them
        // (`MEND_RINGS`), and over the whole mesh only where that leaves one: over the whole
        // it cost one of the fine sphere's eight slabs 0.13 s for one triangle at 29.6°, an
        // eighth of the one-thread call.
        let scopes: &[bool] = if mean >= aim {
            &[true, false]
        } else {
            &[false]
        };
        for &around in scopes {
            if mean >= aim && below.is_empty() {
                break;
            }
            let from = if around {
                let mut near = vec![false; self.pos.len()];
                for &t in &below {
                    for v in self.tri[t as usize] {
                        near[v as usize] = true;
                    }
                }
                for _ in 0..MEND_RINGS {
                    near = self.grow(&near);
                }
                near
            } else {
                vec![true; self.pos.len()]
            };
            self.polish(from.clone(), limits, surface, project, report);
            let smoothing_started = std::time::Instant::now();
            let moved =
                self.odt_rounds(from, ODT_ROUNDS, limits.tolerance, surface, project, report);
            report.smoothing_seconds += smoothing_started.elapsed().as_secs_f64();
            let dirty = self.grow(&moved);
            self.polish(dirty, limits, surface, project, report);
            (mean, below) = self.survey(sin_bad);
            if rounds > 1 && mean < aim {
                let smoothing_started = std::time::Instant::now();
                (mean, below) =
                    self.centroid_rounds(rounds, mean, limits, surface, fork, project, report);
                report.smoothing_seconds += smoothing_started.elapsed().as_secs_f64();
            }
        }
        (mean, below)
    }

    /// Up to `rounds` centroid rounds (`Stage::centroid_round`) from a mesh whose mean
    /// radius ratio is `mean`, while the mean stays below the aim and a round raises it by
    /// at least `CENTROID_GAIN`. Returns the mean and the triangles below the target angle
    /// after the last (`Stage::survey`).
    #[allow(clippy::too_many_arguments)]
    fn centroid_rounds(
        &mut self,
        rounds: u32,
        mut mean: f64,
        limits: &Limits,
        surface: &mut dyn Surface,
        fork: Option<&Fork<'_>>,
        project: &Project<'_>,
        report: &mut Report,
    ) -> (f64, Vec<u32>) {
        debug_assert!(rounds > 0);
        let sin_bad = limits.angle.sin();
        let mut surveyed = (mean, Vec::new());
        for _ in 0..rounds {
            self.centroid_round(limits.tolerance, surface, fork, project, report);
            surveyed = self.survey(sin_bad);
            let gain = surveyed.0 - mean;
            mean = surveyed.0;
            if mean >= limits.ratio || gain < CENTROID_GAIN {
                break;
            }
        }
        surveyed
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
        // A round that changes nothing (no flip, move, insertion or removal kept) leaves
        // the mesh as it found it, and the next round of its kind tries a part of what it
        // tried on that same mesh: the vertices it marks are the bad triangles' corners, a
        // part of those it started from, and each flip, move, trial and removal is judged on
        // the mesh alone (a failed trial is undone exactly). So the rest of its kind change
        // nothing either and are skipped (one of the fine sphere's slabs ran seven such
        // rounds of whole-mesh scans, 50 ms, around a triangle the ratios' phase then
        // mended). Only on a surface that answers the same whatever the order of its
        // queries: a `dist`'s warm starts would see the skipped rounds' queries missing.
        let order_free = surface.value_gradient_batch(&[], &mut []);
        let mut resume_at = 0;
        for round in 0..total {
            if round < resume_at {
                continue;
            }
            let sliding = round >= limits.rounds;
            report.rounds += 1;
            let (inserted_before, collapsed_before) = (report.inserted, report.collapsed);
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
            // or else, at a fixed corner, two free vertices merged into one, where insertion
            // did not mend it.
            if any_bad {
                let mut t = 0;
                while t < self.tri.len() as u32 {
                    let merged = (self.q(self.tri[t as usize]) < sin_bad)
                        .then(|| {
                            self.remove_corner(t, surface, limits.tolerance)
                                .or_else(|| self.merge_pair(t, surface, limits.tolerance, project))
                        })
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
            let unchanged = flips == 0
                && moves == 0
                && report.inserted == inserted_before
                && report.collapsed == collapsed_before;
            if order_free && unchanged {
                if sliding {
                    break;
                }
                resume_at = limits.rounds;
            }
        }
        if self.tri.is_empty() {
            1.0
        } else {
            ratio_sum / self.tri.len() as f64
        }
    }

    /// `marked` and the vertices that share a triangle with a marked one.
    pub(super) fn grow(&self, marked: &[bool]) -> Vec<bool> {
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
}
