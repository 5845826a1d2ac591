//! A spatial hash of front nodes: cubic cells of a fixed size, so that all nodes within that
//! distance of a point are found in the 27 cells around it. Lookups only: the candidates come
//! back in cell order and insertion order, never in a hash-map iteration order.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;

use super::ring::NodeId;

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
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

type Cell = [i32; 3];

/// Nodes by cell.
#[derive(Debug)]
pub struct SpatialHash {
    inv_cell: f64,
    cells: HashMap<Cell, Vec<(NodeId, DVec3)>, BuildHasherDefault<CellHasher>>,
}

impl SpatialHash {
    /// A hash with cells of edge `cell` (> 0).
    pub fn new(cell: f64) -> Self {
        SpatialHash {
            inv_cell: 1.0 / cell,
            cells: HashMap::default(),
        }
    }

    fn cell(&self, p: DVec3) -> Cell {
        let c = (p * self.inv_cell).floor();
        // Saturating casts: far-away points share the outermost cells, still correct.
        [c.x as i32, c.y as i32, c.z as i32]
    }

    pub fn insert(&mut self, n: NodeId, p: DVec3) {
        let c = self.cell(p);
        self.cells.entry(c).or_default().push((n, p));
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

    /// Calls `f` for every node within one cell size of `p` (and possibly a little more).
    pub fn for_near(&self, p: DVec3, mut f: impl FnMut(NodeId, DVec3)) {
        let c = self.cell(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let k = [
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ];
                    if let Some(v) = self.cells.get(&k) {
                        for &(n, q) in v {
                            f(n, q);
                        }
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
        let pts: Vec<DVec3> = (0..200)
            .map(|i| {
                let t = i as f64 * 0.37;
                DVec3::new(t.sin() * 2.0, (1.3 * t).cos() * 2.0, (0.7 * t).sin())
            })
            .collect();
        for (i, &p) in pts.iter().enumerate() {
            h.insert(NodeId(i as u32), p);
        }
        for &i in &[3usize, 50, 51, 120] {
            h.remove(NodeId(i as u32), pts[i]);
        }
        let probe = DVec3::new(0.3, -0.2, 0.1);
        let mut found = Vec::new();
        h.for_near(probe, |n, _| found.push(n.0 as usize));
        for (i, &p) in pts.iter().enumerate() {
            let removed = [3usize, 50, 51, 120].contains(&i);
            if p.distance(probe) < 0.5 && !removed {
                assert!(found.contains(&i), "missed node {i}");
            }
            if removed {
                assert!(!found.contains(&i));
            }
        }
    }
}
