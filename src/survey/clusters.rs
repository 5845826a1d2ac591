//! Which seeds of the component search can be marched ahead, beside the one whose turn it
//! is, without the work being thrown away (`components::mesh_components_forked`). Input: the
//! surface oracle over the search's box; output: the clusters of cells the surface may pass
//! through, and for a seed, later seeds in other clusters.
//!
//! A connected piece of the surface lies in cells whose interval bound holds 0, and those
//! cells are connected across faces, edges or corners: two seeds in different clusters of
//! such cells are on different components, so marching one never covers the other. (Two
//! seeds in one cluster may be on one component or on two close ones: they are not marched
//! ahead of each other.) The clusters only decide what runs at the same time; what is
//! accepted, and in which order, is decided by the search alone, so they never change the
//! mesh.

use std::collections::HashMap;

use glam::DVec3;

use super::cells::{Cell, surface_cells};
use crate::surface::Surface;

/// Cells per side of the box at most: the clusters cost a few thousand bounds, not a
/// second search at the step.
const CELLS_PER_SIDE: f64 = 24.0;

/// The clusters are given up (nothing is marched ahead) past this many cells bounded, or
/// past the budget the caller gives.
const MAX_CELLS: usize = 200_000;

/// Leaves no smaller than this many steps.
const MIN_LEAF_STEPS: f64 = 2.0;

/// The clusters of the cells of a box the surface may pass through (26-connected).
pub struct Clusters {
    lo: DVec3,
    /// The side of the octree's leaves (they all have one size: a cell's children depend
    /// only on its size).
    size: DVec3,
    cluster: HashMap<[i64; 3], u32>,
}

impl Clusters {
    /// The clusters of `surface` in `lo .. hi`, at leaves of about the box's longest side /
    /// `CELLS_PER_SIDE` (at least `MIN_LEAF_STEPS` steps). None when the octree grew past
    /// `budget` cells (and `MAX_CELLS`) or gave no cells.
    pub fn new(
        surface: &mut dyn Surface,
        (lo, hi): (DVec3, DVec3),
        step: f64,
        budget: usize,
    ) -> Option<Self> {
        let leaf = ((hi - lo).max_element() / CELLS_PER_SIDE).max(MIN_LEAF_STEPS * step);
        let found = surface_cells(surface, lo, hi, leaf, budget.min(MAX_CELLS));
        if found.truncated {
            return None;
        }
        let first: Cell = *found.cells.first()?;
        let size = first.hi - first.lo;
        if !size.cmpgt(DVec3::ZERO).all() {
            return None;
        }
        let mut clusters = Clusters {
            lo,
            size,
            cluster: HashMap::new(),
        };
        let keys: Vec<[i64; 3]> = found
            .cells
            .iter()
            .map(|c| clusters.key(c.centre()))
            .collect();
        let index: HashMap<[i64; 3], u32> = keys
            .iter()
            .enumerate()
            .map(|(i, k)| (*k, i as u32))
            .collect();
        let mut parent: Vec<u32> = (0..keys.len() as u32).collect();
        for (i, k) in keys.iter().enumerate() {
            for d in NEIGHBOURS {
                let n = [k[0] + d[0], k[1] + d[1], k[2] + d[2]];
                if let Some(&j) = index.get(&n) {
                    union(&mut parent, i as u32, j);
                }
            }
        }
        for (i, k) in keys.iter().enumerate() {
            let root = find(&mut parent, i as u32);
            clusters.cluster.insert(*k, root);
        }
        Some(clusters)
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        // Saturating float-to-int casts: a point far out lands in no cell.
        ((p - self.lo) / self.size)
            .floor()
            .to_array()
            .map(|c| c as i64)
    }

    /// The cluster of the cell holding `p`, if that cell may hold the surface.
    pub fn of(&self, p: DVec3) -> Option<u32> {
        self.cluster.get(&self.key(p)).copied()
    }

    /// Up to `most` seeds after `seeds[first]`, in order, that `passed_over` does not skip
    /// and that lie in clusters other than `first`'s, `busy`'s (seeds marched ahead already)
    /// and each other's. None of them where `first`'s cluster is unknown.
    pub fn beside<S: Seeded>(
        &self,
        seeds: &[S],
        first: usize,
        busy: &[usize],
        most: usize,
        passed_over: impl Fn(&S) -> bool,
    ) -> Vec<usize> {
        let Some(own) = seeds.get(first).and_then(|s| self.of(s.point())) else {
            return Vec::new();
        };
        let mut taken: Vec<u32> = vec![own];
        taken.extend(busy.iter().filter_map(|&j| self.of(seeds[j].point())));
        let mut out = Vec::new();
        for (j, seed) in seeds.iter().enumerate().skip(first + 1) {
            if out.len() >= most {
                break;
            }
            if busy.contains(&j) {
                continue;
            }
            let Some(c) = self.of(seed.point()) else {
                continue;
            };
            if taken.contains(&c) || passed_over(seed) {
                continue;
            }
            taken.push(c);
            out.push(j);
        }
        out
    }
}

/// A seed of the search, as far as the clusters see it.
pub trait Seeded {
    fn point(&self) -> DVec3;
}

/// The 26 neighbours of a cell.
const NEIGHBOURS: [[i64; 3]; 26] = {
    let mut out = [[0; 3]; 26];
    let mut n = 0;
    let mut i = 0;
    while i < 27 {
        let d = [i % 3 - 1, i / 3 % 3 - 1, i / 9 - 1];
        if !(d[0] == 0 && d[1] == 0 && d[2] == 0) {
            out[n] = d;
            n += 1;
        }
        i += 1;
    }
    out
};

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The smaller root wins: the labels do not depend on the order of the unions.
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi as usize] = lo;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eval::Interval;
    use crate::surface::ValueGrad;

    /// Two balls of radius 0.5 at x = ±2 (the smaller of their two distances), bounded
    /// (`bounded`) or not.
    struct TwoBalls {
        bounded: bool,
    }

    const CENTRES: [DVec3; 2] = [DVec3::new(2.0, 0.0, 0.0), DVec3::new(-2.0, 0.0, 0.0)];

    impl Surface for TwoBalls {
        fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
            let q = CENTRES
                .map(|c| p - c)
                .into_iter()
                .min_by(|a, b| a.length().total_cmp(&b.length()))
                .unwrap_or(p);
            let len = q.length().max(1e-300);
            ValueGrad {
                value: len - 0.5,
                gradient: q / len,
            }
        }

        fn bound(&mut self, lo: DVec3, hi: DVec3) -> Option<Interval> {
            // The nearest and farthest points of the box from each centre.
            let near = |c: DVec3| (c.clamp(lo, hi) - c).length();
            let far = |c: DVec3| (c - lo).abs().max((hi - c).abs()).length();
            let [a, b] = CENTRES;
            self.bounded
                .then(|| Interval::new(near(a).min(near(b)) - 0.5, far(a).min(far(b)) - 0.5))
        }
    }

    struct At(DVec3);

    impl Seeded for At {
        fn point(&self) -> DVec3 {
            self.0
        }
    }

    #[test]
    fn neighbours_are_the_26_around() {
        let mut sorted = NEIGHBOURS.to_vec();
        sorted.sort();
        sorted.dedup();
        assert_eq!(sorted.len(), 26);
        assert!(NEIGHBOURS.iter().all(|d| d.iter().all(|c| c.abs() <= 1)));
    }

    #[test]
    fn seeds_on_separate_balls_are_marched_beside_each_other() {
        let bbox = (DVec3::splat(-3.0), DVec3::splat(3.0));
        // Without an interval bound every cell is kept: one cluster, nothing ahead.
        let loose =
            Clusters::new(&mut TwoBalls { bounded: false }, bbox, 0.1, MAX_CELLS).expect("cells");
        let seeds = [
            At(DVec3::new(2.5, 0.0, 0.0)),
            At(DVec3::new(-1.5, 0.0, 0.0)),
        ];
        assert!(loose.beside(&seeds, 0, &[], 4, |_| false).is_empty());
        // Bounded: two clusters, so the second seed goes beside the first, and not when
        // the first's cluster is busy with it already or it is passed over.
        let c =
            Clusters::new(&mut TwoBalls { bounded: true }, bbox, 0.1, MAX_CELLS).expect("cells");
        assert_ne!(c.of(seeds[0].0), c.of(seeds[1].0));
        assert_eq!(c.beside(&seeds, 0, &[], 4, |_| false), vec![1]);
        assert!(c.beside(&seeds, 0, &[1], 4, |_| false).is_empty());
        assert!(c.beside(&seeds, 0, &[], 4, |_| true).is_empty());
        assert!(c.beside(&seeds, 0, &[], 0, |_| false).is_empty());
        // Past its budget, nothing is marched ahead.
        assert!(Clusters::new(&mut TwoBalls { bounded: true }, bbox, 0.1, 10).is_none());
        // Two seeds on one ball: one cluster.
        let same = [At(DVec3::new(2.5, 0.0, 0.0)), At(DVec3::new(1.5, 0.0, 0.0))];
        assert!(c.beside(&same, 0, &[], 4, |_| false).is_empty());
    }
}
