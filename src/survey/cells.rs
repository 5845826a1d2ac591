//! Where a surface can be in a box: octrees over the box's inside, faces and edges whose
//! cells the interval bound of f (and of its partials) cannot exclude, down to a leaf size
//! (docs/components.md, step 1). Groundwork of the component search (`pipeline::components`)
//! and of the clusters it marches ahead (`survey::clusters`); asks the oracle only.

use glam::DVec3;

use crate::surface::Surface;

/// An axis-aligned cell of the octree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Cell {
    pub fn centre(self) -> DVec3 {
        (self.lo + self.hi) * 0.5
    }

    /// The children: each side longer than half the longest (and than `leaf`) is halved,
    /// so cells of a flat box become near-cubic before they shrink. In a fixed order.
    pub fn split(self, leaf: f64) -> Vec<Cell> {
        let size = self.hi - self.lo;
        let longest = size.max_element();
        let mid = self.centre();
        let halve = [0, 1, 2].map(|k| size[k] > leaf && size[k] >= 0.5 * longest);
        let mut cells = vec![self];
        for k in 0..3 {
            if !halve[k] {
                continue;
            }
            cells = cells
                .into_iter()
                .flat_map(|c| {
                    let (mut a, mut b) = (c, c);
                    a.hi[k] = mid[k];
                    b.lo[k] = mid[k];
                    [a, b]
                })
                .collect();
        }
        cells
    }

    pub fn octants(self) -> Vec<Cell> {
        self.split(0.0)
    }
}

/// The cells the search seeds from ([`candidate_cells`]), in a fixed order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Candidates {
    /// The leaves that passed every test: cells of the box's inside first, then of its
    /// faces (flat along one axis), then of its edges (flat along two), each region in
    /// depth-first order.
    pub cells: Vec<Cell>,
    /// Cells bounded (the octree's work).
    pub visited: usize,
    /// Whether `max_cells` cut the search short.
    pub truncated: bool,
}

/// A region of the box searched by one octree: the box itself, a face or an edge, and which
/// derivatives must be able to vanish in a cell for it to be kept.
pub struct Region {
    pub cell: Cell,
    pub need: Need,
}

/// Keep only cells where the derivatives of f along these directions may all be 0 (a zero
/// vector asks nothing): where a piece of the surface may have its extreme along the
/// direction orthogonal to them.
pub type Need = [DVec3; 2];

/// Asks nothing of the derivatives.
pub const NO_NEED: Need = [DVec3::ZERO; 2];

/// The direction along which the inside's octree looks for each component's extreme. Any
/// direction would do (every closed piece has a largest d·p); an axis would not do well: a
/// face of a part perpendicular to it is all extreme (both other partials vanish on the whole
/// face), and an axis-aligned plate kept every leaf along two of its faces — 226 319 cells
/// bounded and 39 880 seeds, every one covered, on the speed bench's CAD plate. Along this
/// direction, which no face of a part drawn on a grid or at a round angle is orthogonal to,
/// an extreme is a point: a corner, or where a curved face turns to face it.
const EXTREME_ALONG: DVec3 = DVec3::new(0.729_051_7, 0.550_340_4, 0.406_973_8);

/// The regions of the box `lo .. hi` (the module documentation, step 1): the inside, where a
/// component that does not reach the faces has its largest d·p ([`EXTREME_ALONG`]) with the
/// derivatives across d = 0; each face, where a curve of the surface that does not reach the
/// face's edges has its largest value of the face's first free axis with the derivative along
/// the second = 0; each edge.
pub fn regions(lo: DVec3, hi: DVec3) -> Vec<Region> {
    let (across, across2) = EXTREME_ALONG.normalize().any_orthonormal_pair();
    let mut out = vec![Region {
        cell: Cell { lo, hi },
        need: [across, across2],
    }];
    for flat in 0..3 {
        for at in [lo[flat], hi[flat]] {
            let mut cell = Cell { lo, hi };
            cell.lo[flat] = at;
            cell.hi[flat] = at;
            // The second free axis: the partial that vanishes at an extreme along the first.
            let second = if flat == 2 { 1 } else { 2 };
            let mut need = NO_NEED;
            need[0][second] = 1.0;
            out.push(Region { cell, need });
        }
    }
    for free in 0..3 {
        let (j, k) = ((free + 1) % 3, (free + 2) % 3);
        for (aj, ak) in [
            (lo[j], lo[k]),
            (hi[j], lo[k]),
            (lo[j], hi[k]),
            (hi[j], hi[k]),
        ] {
            let mut cell = Cell { lo, hi };
            (cell.lo[j], cell.hi[j]) = (aj, aj);
            (cell.lo[k], cell.hi[k]) = (ak, ak);
            out.push(Region {
                cell,
                need: NO_NEED,
            });
        }
    }
    out
}

/// Whether the surface may pass through `cell` at a point where the partials `need` asks
/// for vanish: the natural interval bound of f must hold 0, and on cells of at most
/// `MEAN_VALUE_CELLS` leaves the mean-value form too (far tighter there: the natural bound
/// of a product of quadrics keeps a shell several leaves thick around the surface). A
/// surface that cannot bound its derivatives is asked for its value bound alone; one that
/// cannot bound itself keeps every cell.
pub fn may_hold(surface: &mut dyn Surface, cell: Cell, need: Need, leaf: f64) -> bool {
    // The value first: its bound costs a fraction of the partials', and drops most cells.
    if surface
        .bound(cell.lo, cell.hi)
        .is_some_and(|i| !i.contains(0.0))
    {
        return false;
    }
    let free = [0, 1, 2].map(|k| cell.hi[k] > cell.lo[k]);
    let small = (cell.hi - cell.lo).max_element() <= MEAN_VALUE_CELLS * leaf;
    let needed = [0, 1, 2].map(|k| need.iter().any(|d| d[k] != 0.0));
    let axes = if small { free } else { needed };
    if !axes.contains(&true) {
        return true;
    }
    let Some(g) = surface.bound_gradient(cell.lo, cell.hi, axes) else {
        return true;
    };
    let asked = need.iter().filter(|&&d| d != DVec3::ZERO);
    if asked.copied().any(|d| !g.derivative_may_vanish(d)) || !g.v.contains(0.0) {
        return false;
    }
    // Two directions (the inside's extreme): where f is piecewise, its forms' gradients one
    // by one (a crease's two normals span a box of partials that holds 0).
    if need[1] != DVec3::ZERO && !surface.gradient_may_face(cell.lo, cell.hi, need) {
        return false;
    }
    if small && g.defined {
        let c = cell.centre();
        if let Some(at_centre) = surface.bound(c, c) {
            return g
                .mean_value(at_centre, cell.lo, cell.hi, free)
                .contains(0.0);
        }
    }
    true
}

/// Cells up to this many leaves a side are bounded by the mean-value form as well.
const MEAN_VALUE_CELLS: f64 = 4.0;

/// The octrees over the box's inside, faces and edges (the module documentation, step 1):
/// the cells of about `leaf` size a component of the surface in the box must pass through
/// at one of its extremes, and the count of cells bounded. Sound: every component of the
/// surface inside the box passes through one of the cells (docs/components.md has the
/// argument).
pub fn candidate_cells(
    surface: &mut dyn Surface,
    lo: DVec3,
    hi: DVec3,
    leaf: f64,
    max_cells: usize,
) -> Candidates {
    octree(surface, regions(lo, hi), leaf, max_cells)
}

/// The cells of about `leaf` size in `lo .. hi` the surface may pass through (its value
/// bound holds 0), whatever its gradient: where the surface is, not only where a component
/// has an extreme — for the extent of a surface rather than seeds of its components.
pub fn surface_cells(
    surface: &mut dyn Surface,
    lo: DVec3,
    hi: DVec3,
    leaf: f64,
    max_cells: usize,
) -> Candidates {
    let whole = Region {
        cell: Cell { lo, hi },
        need: NO_NEED,
    };
    octree(surface, vec![whole], leaf, max_cells)
}

/// The octrees over `regions`, each cell kept while `may_hold` says so, down to `leaf`.
pub fn octree(
    surface: &mut dyn Surface,
    regions: Vec<Region>,
    leaf: f64,
    max_cells: usize,
) -> Candidates {
    let mut walk = Walk::new(regions, leaf, max_cells);
    let mut cells = Vec::new();
    while let Some(pending) = walk.next(surface) {
        cells.push(pending.cell);
    }
    Candidates {
        cells,
        visited: walk.visited,
        truncated: walk.truncated,
    }
}

/// The octrees of [`octree`] walked lazily, one kept leaf at a time in the same order, so
/// that the search can seed and march from the first leaves before the rest are bounded (and
/// stop there when the marches reach `max_triangles`). A kept leaf can be walked again with
/// a finer leaf ([`Walk::refine`]): the octree goes down to about the local step where the
/// surface has features smaller than the step (docs/components.md).
pub struct Walk {
    /// Regions not begun, last first.
    pub regions: Vec<Region>,
    /// Cells still to bound, next last, each with its region's `need` and its leaf size.
    pub stack: Vec<Pending>,
    pub leaf: f64,
    pub max_cells: usize,
    pub visited: usize,
    pub truncated: bool,
}

/// A cell of [`Walk`] with what bounding it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pending {
    pub cell: Cell,
    pub need: Need,
    pub leaf: f64,
}

impl Walk {
    pub fn new(mut regions: Vec<Region>, leaf: f64, max_cells: usize) -> Walk {
        regions.reverse();
        Walk {
            regions,
            stack: Vec::new(),
            leaf,
            max_cells,
            visited: 0,
            truncated: false,
        }
    }

    /// The next kept leaf, or None when every region is walked or `max_cells` is reached.
    pub fn next(&mut self, surface: &mut dyn Surface) -> Option<Pending> {
        loop {
            if self.truncated {
                return None;
            }
            let Some(pending) = self.stack.pop() else {
                let region = self.regions.pop()?;
                self.stack.push(Pending {
                    cell: region.cell,
                    need: region.need,
                    leaf: self.leaf,
                });
                continue;
            };
            self.visited += 1;
            if self.visited > self.max_cells {
                self.truncated = true;
                return None;
            }
            let Pending { cell, need, leaf } = pending;
            if !may_hold(surface, cell, need, leaf) {
                continue;
            }
            if (cell.hi - cell.lo).max_element() <= leaf {
                return Some(pending);
            }
            // Reversed, so that the first child is searched first.
            self.stack
                .extend(cell.split(leaf).into_iter().rev().map(|cell| Pending {
                    cell,
                    need,
                    leaf,
                }));
        }
    }

    /// Walks the kept leaf `pending` again, down to `leaf`, before anything else.
    pub fn refine(&mut self, pending: Pending, leaf: f64) {
        let need = pending.need;
        self.stack.extend(
            pending
                .cell
                .split(leaf)
                .into_iter()
                .rev()
                .map(|cell| Pending { cell, need, leaf }),
        );
    }
}
