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
    /// Grid vertices inside: times a cell's volume, the solid's volume to within about a
    /// cell's thickness over its surface.
    pub inside_vertices: i64,
    /// Connected components of the complement (the outside vertices, joined across the
    /// cubes the complex leaves out: 26-neighbours). Each beyond the one that holds the box's
    /// faces is a cavity, a further component of the bounding surface.
    pub outside_components: usize,
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
    count(&sample(f, lo, hi, n), n)
}

/// A regular grid of sample points: `cells[a]` cells of side `spacing[a]` along axis a from
/// `origin`, so `cells[a] + 1` vertices along it. Cubic cells over a box that is not a cube
/// (a plate) sample it without wasting vertices on its thin axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    pub origin: DVec3,
    pub spacing: DVec3,
    pub cells: [usize; 3],
}

impl Lattice {
    /// Cubic cells of side `h` from `origin`, `cells` along each axis.
    pub fn cubic(origin: DVec3, h: f64, cells: [usize; 3]) -> Lattice {
        Lattice {
            origin,
            spacing: DVec3::splat(h),
            cells,
        }
    }

    /// The grid vertex (i, j, k).
    pub fn point(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.origin + self.spacing * DVec3::new(i as f64, j as f64, k as f64)
    }

    /// Grid vertices along each axis.
    fn dims(&self) -> [usize; 3] {
        self.cells.map(|c| c + 1)
    }

    /// Grid vertices in all.
    pub fn vertices(&self) -> usize {
        self.dims().iter().product()
    }
}

/// Whether each of the (n+1)³ grid vertices is inside, x fastest.
fn sample(f: impl Fn(DVec3) -> f64, lo: DVec3, hi: DVec3, n: usize) -> Vec<bool> {
    assert!(n >= 2, "a grid needs at least two cells a side");
    sample_lattice(
        f,
        &Lattice {
            origin: lo,
            spacing: (hi - lo) / n as f64,
            cells: [n; 3],
        },
    )
}

/// Whether each grid vertex of `lattice` is inside, x fastest.
fn sample_lattice(f: impl Fn(DVec3) -> f64, lattice: &Lattice) -> Vec<bool> {
    let [mx, my, mz] = lattice.dims();
    let mut inside = Vec::with_capacity(mx * my * mz);
    for k in 0..mz {
        for j in 0..my {
            for i in 0..mx {
                inside.push(f(lattice.point(i, j, k)) < 0.0);
            }
        }
    }
    inside
}

/// The counts of the inside vertices of an (n+1)³ sampling.
fn count(inside: &[bool], n: usize) -> SolidCount {
    count_dims(inside, [n + 1; 3])
}

/// The counts of the inside vertices of a sampling with `dims` vertices along the axes.
fn count_dims(inside: &[bool], dims: [usize; 3]) -> SolidCount {
    let [mx, my, mz] = dims;
    let idx = |i: usize, j: usize, k: usize| (k * my + j) * mx + i;
    let mut touches_box = false;
    let mut inside_box: Option<([usize; 3], [usize; 3])> = None;
    for k in 0..mz {
        for j in 0..my {
            for i in 0..mx {
                if inside[idx(i, j, k)] {
                    touches_box |= [i, j, k]
                        .iter()
                        .zip(dims)
                        .any(|(&c, m)| c == 0 || c + 1 == m);
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
    for k in 0..mz {
        for j in 0..my {
            for i in 0..mx {
                if !at(i, j, k) {
                    continue;
                }
                v += 1;
                let (xi, yj, zk) = (i + 1 < mx, j + 1 < my, k + 1 < mz);
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
        inside_vertices: v,
        components: components(inside, dims, true, false),
        outside_components: components(inside, dims, false, true),
        touches_box,
        inside: inside_box,
    }
}

/// Connected components of the grid vertices whose inside flag is `side`: joined along grid
/// edges (6-neighbours), or across whole cubes too (26-neighbours) when `diagonal`.
fn components(inside: &[bool], dims: [usize; 3], side: bool, diagonal: bool) -> usize {
    let mut count = 0;
    each_component(inside, dims, side, diagonal, |_| count += 1);
    count
}

/// Calls `visit` with the vertices of each connected component of the grid vertices whose
/// inside flag is `side` (joined as in `components`).
///
/// The flood fill runs on a copy of the grid with a border of one vertex all round that
/// belongs to no component, so that a neighbour is one offset away in memory and needs no
/// bounds test (the voxel reference is a good share of the mesh sweeps' time).
fn each_component(
    inside: &[bool],
    dims: [usize; 3],
    side: bool,
    diagonal: bool,
    mut visit: impl FnMut(&[usize]),
) {
    let [mx, my, mz] = dims;
    let (px, py) = (mx + 2, my + 2);
    let padded = |i: usize, j: usize, k: usize| ((k + 1) * py + j + 1) * px + i + 1;
    // `open[t]`: padded vertex t is on `side` and not yet in a component.
    let mut open = vec![false; px * py * (mz + 2)];
    for k in 0..mz {
        for j in 0..my {
            let row = (k * my + j) * mx;
            let start = padded(0, j, k);
            for (o, &v) in open[start..start + mx]
                .iter_mut()
                .zip(&inside[row..row + mx])
            {
                *o = v == side;
            }
        }
    }
    let offsets: Vec<isize> = (-1..=1isize)
        .flat_map(|k| (-1..=1isize).flat_map(move |j| (-1..=1isize).map(move |i| [i, j, k])))
        .filter(|o| {
            let nonzero = o.iter().filter(|&&c| c != 0).count();
            nonzero > 0 && (diagonal || nonzero == 1)
        })
        .map(|[i, j, k]| (k * py as isize + j) * px as isize + i)
        .collect();
    let mut stack = Vec::new();
    let mut members = Vec::new();
    // The padded grid in memory order is the grid's vertices in theirs (its border is never
    // open): the components are visited in the same order.
    for start in 0..open.len() {
        if !open[start] {
            continue;
        }
        members.clear();
        open[start] = false;
        stack.push(start);
        while let Some(s) = stack.pop() {
            let (i, j, k) = (s % px - 1, (s / px) % py - 1, s / (px * py) - 1);
            members.push((k * my + j) * mx + i);
            for &o in &offsets {
                let t = s.wrapping_add_signed(o);
                if open[t] {
                    open[t] = false;
                    stack.push(t);
                }
            }
        }
        visit(&members);
    }
}

/// The solid {f < 0} sampled as `solid_count` does, read in both ways a sampling can be read,
/// with crumbs of fewer than `smallest` vertices removed first:
/// - `.0` the inside's complex (inside vertices joined along grid edges, the outside across
///   cubes), as `solid_count` counts it;
/// - `.1` the complement's complex (the outside joined along edges, the inside across cubes):
///   the count of {f ≥ 0}, whose χ is 1 + χ(solid) by duality in the grid's box.
///
/// Where the solid or its complement is thinner than the grid — the tip of a sharp wedge along
/// a crease — each reading breaks it into crumbs differently: crumbs are inside (outside)
/// components of fewer than `smallest` vertices, which are given to the other side before
/// counting. When the two readings still disagree, the grid does not resolve the solid.
pub fn two_readings(
    f: impl Fn(DVec3) -> f64,
    lo: DVec3,
    hi: DVec3,
    n: usize,
    smallest: usize,
) -> (SolidCount, SolidCount) {
    assert!(n >= 2, "a grid needs at least two cells a side");
    two_readings_on(
        f,
        &Lattice {
            origin: lo,
            spacing: (hi - lo) / n as f64,
            cells: [n; 3],
        },
        smallest,
    )
}

/// `two_readings` on any lattice (cells of other numbers along the axes).
pub fn two_readings_on(
    f: impl Fn(DVec3) -> f64,
    lattice: &Lattice,
    smallest: usize,
) -> (SolidCount, SolidCount) {
    let sampled = sample_lattice(f, lattice);
    let dims = lattice.dims();
    let cleaned = |inside_diagonal: bool| {
        let mut cells = sampled.clone();
        for side in [true, false] {
            let diagonal = side == inside_diagonal;
            let mut crumbs = Vec::new();
            each_component(&cells, dims, side, diagonal, |c| {
                if c.len() < smallest {
                    crumbs.extend_from_slice(c);
                }
            });
            for c in crumbs {
                cells[c] = !side;
            }
        }
        cells
    };
    let inside = cleaned(false);
    let outside: Vec<bool> = cleaned(true).iter().map(|b| !b).collect();
    (count_dims(&inside, dims), count_dims(&outside, dims))
}
