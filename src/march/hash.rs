//! A spatial hash of front nodes: cubic cells eight query radii wide, so that all nodes
//! within the radius of a point are found in the (at most 8) cells its cube overlaps. Lookups only: the candidates come
//! back in cell order and insertion order, never in a hash-map iteration order. Each node
//! carries its position and one number (the marcher's local step there), so that a query
//! filters its candidates without looking anything up elsewhere.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;

use super::ring::NodeId;
use crate::values::floor;

/// A small multiplicative hasher for cell keys (the std SipHash costs more than the lookup).
#[derive(Default)]
pub struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

/// A cell's three integer coordinates packed into 21 bits each. Far-away cells that wrap
/// onto the same key only cost extra candidates, which callers filter by distance.
type Cell = u64;

/// A node in its cell: its id, position and number.
pub type Entry = (NodeId, DVec3, f64);

/// Nodes by cell.
#[derive(Debug)]
pub struct SpatialHash {
    /// Cells are eight query radii wide: fewer lookups, a few more candidates, which are
    /// cheap to reject (front points lie along curves, so a cell holds few of them). On the
    /// fine sphere a query looks up 2.0 cells and filters 13 candidates (3.4 and 8 at four
    /// radii, which cost an eighth more; at sixteen radii no less).
    inv_cell: f64,
    radius: f64,
    /// Only cells that hold nodes: the front's neighbourhood, small enough to stay in cache
    /// (keeping emptied cells doubled the cost of a query on the fine sphere).
    cells: HashMap<Cell, Vec<Entry>, BuildHasherDefault<CellHasher>>,
}

fn pack(x: i64, y: i64, z: i64) -> Cell {
    const MASK: u64 = (1 << 21) - 1;
    ((x as u64 & MASK) << 42) | ((y as u64 & MASK) << 21) | (z as u64 & MASK)
}

impl SpatialHash {
    /// A hash for queries within `radius` (> 0).
    pub fn new(radius: f64) -> Self {
        SpatialHash {
            inv_cell: 0.125 / radius,
            radius,
            cells: HashMap::default(),
        }
    }

    fn cell(&self, p: DVec3) -> Cell {
        let [x, y, z] = (p * self.inv_cell).to_array().map(floor);
        pack(x, y, z)
    }

    /// Inserts `n` at `p` with the number `h`.
    pub fn insert(&mut self, n: NodeId, p: DVec3, h: f64) {
        let c = self.cell(p);
        self.cells.entry(c).or_default().push((n, p, h));
    }

    /// Removes `n` (inserted at `p`); no-op if absent.
    pub fn remove(&mut self, n: NodeId, p: DVec3) {
        let c = self.cell(p);
        if let Some(v) = self.cells.get_mut(&c) {
            if let Some(i) = v.iter().position(|e| e.0 == n) {
                // Order within a cell only affects ties, which callers break by id.
                v.swap_remove(i);
            }
            if v.is_empty() {
                self.cells.remove(&c);
            }
        }
    }

    /// Calls `f` with the nodes of each cell that may hold nodes within the radius of `p`
    /// (and some a little farther), each with its position and number, a cell's nodes as
    /// one slice: the caller filters them in a loop of its own (as a call a node, its
    /// filter's kept count went through memory from one node to the next).
    pub fn for_near(&self, p: DVec3, mut f: impl FnMut(&[Entry])) {
        // The cells the cube p ± radius overlaps: 1 or 2 per axis (1.25³ ≈ 2 on average).
        let lo = ((p - self.radius) * self.inv_cell).to_array().map(floor);
        let hi = ((p + self.radius) * self.inv_cell).to_array().map(floor);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    if let Some(v) = self.cells.get(&pack(x, y, z)) {
                        f(v);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_every_node_within_a_cell_and_forgets_removed_ones() {
        let mut h = SpatialHash::new(0.5);
        // Probe several points, in every octant of their cells.
        let pts: Vec<DVec3> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.37;
                DVec3::new(t.sin() * 2.0, (1.3 * t).cos() * 2.0, (0.7 * t).sin())
            })
            .collect();
        for (i, &p) in pts.iter().enumerate() {
            h.insert(NodeId(i as u32), p, i as f64);
        }
        for &i in &[3usize, 50, 51, 120] {
            h.remove(NodeId(i as u32), pts[i]);
        }
        for k in 0..50 {
            let t = k as f64 * 0.29;
            let probe = DVec3::new(1.7 * t.cos(), -1.9 * (0.8 * t).sin(), 0.9 * (1.7 * t).cos());
            let mut found = Vec::new();
            h.for_near(probe, |cell| {
                for &(n, _, number) in cell {
                    assert_eq!(number, n.0 as f64, "the number inserted with the node");
                    found.push(n.0 as usize);
                }
            });
            for (i, &p) in pts.iter().enumerate() {
                let removed = [3usize, 50, 51, 120].contains(&i);
                if p.distance(probe) < 0.5 && !removed {
                    assert!(found.contains(&i), "missed node {i} near {probe}");
                }
                if removed {
                    assert!(!found.contains(&i));
                }
            }
        }
    }
}
