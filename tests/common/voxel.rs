//! An independent topology reference for mesh tests: the solid {f < 0} sampled on a regular
//! grid, counted as a cubical complex. It never looks at a mesh, so a test that compares a
//! mesh's Euler characteristic or component count with it does not check the mesher against
//! itself.
//!
//! The complex: every grid vertex with f < 0, every grid edge whose two ends are inside, every
//! grid square whose four corners are inside, every grid cube whose eight corners are inside.
//! Once the grid spacing is below the solid's smallest feature (thickness, neck, gap), this
//! complex has the solid's homotopy type, so for a closed surface S bounding the solid
//! χ(S) = 2·χ(solid), and each solid component without cavities is one surface component.
#![allow(dead_code)]

use glam::DVec3;

/// What the grid sees of the solid {f < 0} in a box.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SolidCount {
    /// χ of the solid: V − E + F − C of the cubical complex.
    pub euler: i64,
    /// Connected components of the solid (grid vertices joined along grid edges).
    pub components: usize,
    /// Whether any inside vertex lies on the box's faces: then the solid is cut by the box
    /// and the counts are of the cut solid.
    pub touches_box: bool,
    /// The grid indices (lowest, highest corner) of the box around every inside vertex, or
    /// `None` if no vertex is inside: the solid's extent to within one cell.
    pub inside: Option<([usize; 3], [usize; 3])>,
}

impl SolidCount {
    /// χ of the closed surface that bounds the solid: 2·χ(solid).
    pub fn surface_euler(&self) -> i64 {
        2 * self.euler
    }
}

/// Samples `f` on an `n`×`n`×`n`-cell grid over `lo..hi` (so (n+1)³ values) and counts the
/// solid {f < 0}.
pub fn solid_count(f: impl Fn(DVec3) -> f64, lo: DVec3, hi: DVec3, n: usize) -> SolidCount {
    assert!(n >= 2, "a grid needs at least two cells a side");
    let m = n + 1;
    let idx = |i: usize, j: usize, k: usize| (k * m + j) * m + i;
    let h = (hi - lo) / n as f64;
    let mut inside = vec![false; m * m * m];
    let mut touches_box = false;
    let mut inside_box: Option<([usize; 3], [usize; 3])> = None;
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                let p = lo + h * DVec3::new(i as f64, j as f64, k as f64);
                let is_in = f(p) < 0.0;
                inside[idx(i, j, k)] = is_in;
                if is_in {
                    touches_box |= [i, j, k].iter().any(|&c| c == 0 || c == n);
                    let (lo, hi) = inside_box.get_or_insert(([i, j, k], [i, j, k]));
                    for (a, c) in [i, j, k].into_iter().enumerate() {
                        lo[a] = lo[a].min(c);
                        hi[a] = hi[a].max(c);
                    }
                }
            }
        }
    }
    let at = |i: usize, j: usize, k: usize| inside[idx(i, j, k)];
    let (mut v, mut e, mut f2, mut c) = (0i64, 0i64, 0i64, 0i64);
    for k in 0..m {
        for j in 0..m {
            for i in 0..m {
                if !at(i, j, k) {
                    continue;
                }
                v += 1;
                let (xi, yj, zk) = (i + 1 < m, j + 1 < m, k + 1 < m);
                let x = xi && at(i + 1, j, k);
                let y = yj && at(i, j + 1, k);
                let z = zk && at(i, j, k + 1);
                e += x as i64 + y as i64 + z as i64;
                let xy = x && y && at(i + 1, j + 1, k);
                let xz = x && z && at(i + 1, j, k + 1);
                let yz = y && z && at(i, j + 1, k + 1);
                f2 += xy as i64 + xz as i64 + yz as i64;
                if xy && xz && yz && at(i + 1, j + 1, k + 1) {
                    c += 1;
                }
            }
        }
    }
    SolidCount {
        euler: v - e + f2 - c,
        components: components(&inside, m),
        touches_box,
        inside: inside_box,
    }
}

/// Connected components of the inside vertices, joined along grid edges (6-neighbours).
fn components(inside: &[bool], m: usize) -> usize {
    let mut seen = vec![false; inside.len()];
    let mut stack = Vec::new();
    let mut count = 0;
    for start in 0..inside.len() {
        if !inside[start] || seen[start] {
            continue;
        }
        count += 1;
        seen[start] = true;
        stack.push(start);
        while let Some(s) = stack.pop() {
            let (i, j, k) = (s % m, (s / m) % m, s / (m * m));
            let mut visit = |t: usize| {
                if inside[t] && !seen[t] {
                    seen[t] = true;
                    stack.push(t);
                }
            };
            if i > 0 {
                visit(s - 1);
            }
            if i + 1 < m {
                visit(s + 1);
            }
            if j > 0 {
                visit(s - m);
            }
            if j + 1 < m {
                visit(s + m);
            }
            if k > 0 {
                visit(s - m * m);
            }
            if k + 1 < m {
                visit(s + m * m);
            }
        }
    }
    count
}
