//! The component search (docs/components.md): every component of a surface inside a
//! box, without a start point. Input: the surface oracle, the step, the box; output: one mesh
//! holding every component the marcher made from the seeds found, the number of components,
//! and warnings (with their places) for what could not be meshed.
//!
//! 1. Octrees over the box's inside, its six faces and its twelve edges keep the cells, down
//!    to about the step (`SearchSettings::leaf`), where a piece of the surface in the box
//!    must pass at one of its extremes: a piece that does not reach the faces is closed and
//!    has a point of largest d·p (d a fixed direction off every axis), where the derivatives
//!    across d vanish (for a crease, 0 is in the hull of the gradients'); a piece that
//!    reaches them crosses a face in curves, each of which has a point of largest first face
//!    coordinate inside the face (where the derivative along the second vanishes) or meets
//!    an edge. A cell is dropped when the interval bound of f ([`Surface::bound`], and the
//!    mean-value form on small cells) excludes 0, or when the interval partials
//!    ([`Surface::bound_gradient`]) or, for a piecewise f, its forms' gradients
//!    ([`Surface::gradient_may_face`]) show that the derivatives the region needs cannot
//!    vanish there.
//! 2. Each remaining cell (a face or edge cell grown into the box by a leaf), in octree
//!    order, gives a seed: surfacepoint from its centre (or,
//!    when that does not converge or leaves the box while the cell shows a sign change, from
//!    the centres of its eight octants). A seed inside the box that no mesh covers yet — no
//!    triangle within `covered` local steps or edges whose normal agrees with the seed's: two sheets
//!    closer than the step have opposite normals, so they are never mistaken for one — starts
//!    a new component, marched with `march::march` from that point and the box.
//! 3. Seeds at least `face_margin · step` from the box's faces go first (a hexagon at a face
//!    would leave slivers), the others after, so a component that touches the box only near
//!    a face is still found.
//!
//! Where a leaf gives no seed, or its seeds' local step (`survey::sizing`) is well below the
//! leaf, the leaf is walked again with leaves of about that size (a thin tube, a flat plate,
//! small balls: docs/components.md, "cells of about the local step"), and the coverage and
//! smallness tests are sized by the local step and the mesh's own edges.
//!
//! Deterministic: the cells, their seeds and the components follow one fixed order, so the
//! same surface gives the same mesh, bit for bit. A component smaller than its local step
//! (the hexagon of Step 0 does not fit on it even at the floor) and a cell with a sign change where no seed
//! converges are warnings, never silently dropped; a component the marcher cannot complete
//! is an error, as for a start point.

mod cover;

use std::collections::BTreeMap;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::march::{self, MarchError, MarchInput, MarchSettings, Start};
use crate::mesh::Mesh;
use crate::mesh::progress::Counts;
use crate::solve::{SurfacePoint, surface_point};
use crate::surface::{Fork, Surface};

use crate::survey::cells::{Cell, Walk, regions};
use crate::survey::clusters as ahead;
use crate::survey::gradient_jump::gradient_jump;
use crate::survey::sizing::Sizing;
use cover::Cover;

/// Settings of the component search. Lengths are multiples of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchSettings {
    /// Octree cells are split until their longest side is at most `leaf · step`. Default
    /// 1.0: a kept cell's centre is within a step of the extreme point it holds, so Newton
    /// from there reaches the piece through that point.
    pub leaf: f64,
    /// A seed is covered when a triangle of the mesh so far lies within `covered` times the
    /// larger of the seed's local step and the triangle's longest edge, with a normal that
    /// agrees (`covered_normal_cos`). Default 0.3: a triangle's chord
    /// error at the curvature the marcher meshes is well below it, and another sheet that
    /// close has the opposite normal.
    pub covered: f64,
    /// The same within `face_margin · step` of the box's faces, where the marcher's last
    /// triangles stop short of the box's edges and corners by up to a step. Default 1.0.
    pub covered_at_faces: f64,
    /// Normals agree when their cosine is above this. Default 0.5.
    pub covered_normal_cos: f64,
    /// First pass: seeds closer than `face_margin · step` to a face of the box wait for the
    /// second pass. Default 0.5.
    pub face_margin: f64,
    /// A seed whose Step 0 hexagon points (of side h, the local step there) land within
    /// `small · h` of it (the surface closes up within h) is a component smaller than its
    /// local step: a warning, not a march. Default 0.5 (a sphere of diameter below about h;
    /// h is at its floor, step/256, on such a sphere, or the step with `uniform: true`).
    pub small: f64,
    /// A cell's seed must land within `seed_reach · step` of the cell. Default 1.0.
    pub seed_reach: f64,
    /// Newton steps from a cell's centre before its seed is given up (when it has not come
    /// within 1 % of a step of the surface). Default 12.
    pub seed_iterations: u32,
    /// Most octree cells bounded before the search gives up with a warning. Default
    /// 4 000 000 (a few seconds).
    pub max_cells: usize,
}

impl Default for SearchSettings {
    fn default() -> Self {
        SearchSettings {
            leaf: 1.0,
            covered: 0.3,
            covered_at_faces: 1.0,
            covered_normal_cos: 0.5,
            face_margin: 0.5,
            small: 0.5,
            seed_reach: 1.0,
            seed_iterations: 12,
            max_cells: 4_000_000,
        }
    }
}

/// Something the search could not mesh, with its place.
#[derive(Clone, Debug, PartialEq)]
pub enum Warning {
    /// A component the Step 0 hexagon of the local step `h` does not fit on.
    SmallComponent { at: DVec3, h: f64 },
    /// Cells where f changes sign but no seed converged onto the surface in the box.
    NoSeed { at: DVec3, cells: usize },
    /// The octree reached `max_cells`; cells beyond were not searched.
    CellLimit { cells: usize },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = |p: DVec3| format!("({}, {}, {})", p.x, p.y, p.z);
        match self {
            Warning::SmallComponent { at, h } => write!(
                f,
                "a component near {} is smaller than the step can resolve (the local step there is {h:e}) and was not meshed",
                p(*at)
            ),
            Warning::NoSeed { at, cells: 1 } => write!(
                f,
                "the surface crosses the cell around {} but no surface point converged there; a smaller step may reach it",
                p(*at)
            ),
            Warning::NoSeed { at, cells } => write!(
                f,
                "the surface crosses {cells} cells (the first around {}) but no surface point converged there; a smaller step may reach it",
                p(*at)
            ),
            Warning::CellLimit { cells } => write!(
                f,
                "the component search stopped after {cells} cells; parts of the box were not searched"
            ),
        }
    }
}

/// Why the search could not complete.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SearchError {
    #[error("the step {step} is not a positive finite number")]
    InvalidStep { step: f64 },
    #[error("the box {lo} .. {hi} is empty or not finite")]
    InvalidBox { lo: DVec3, hi: DVec3 },
    /// A fresh oracle of the surface for a march on another thread could not be built
    /// (it was built once already: our bug, not the input's).
    #[error("the surface could not be built again for a march on another thread")]
    Fork,
    /// The marcher failed on the component found at `seed`.
    #[error("the component found at {seed}: {source}")]
    March { seed: DVec3, source: MarchError },
    /// The octree bounded more cells than a surface of `triangles` triangles passes through.
    #[error(
        "the component search bounded {cells} cells of the box, more than a surface of at most {triangles} triangles (`max_triangles`) passes through: the surface in the box is larger than that, or its bounds are loose"
    )]
    CellBudget { cells: usize, triangles: u64 },
    /// The surface could not be evaluated where the search asked (a `dist` found no foot
    /// point there: `Surface::fault`).
    #[error("the surface could not be evaluated at {at}: {reason}")]
    Fault { at: DVec3, reason: String },
}

/// Octree cells bounded per triangle the mesh may hold. A surface of T triangles (edges up
/// to 1.2·step) has area below 0.62·T·step², so it passes through about 1.7·0.62·T ≈ T leaf
/// cells of a step (a slab of kept cells about its thickness times √3 deep); with the
/// siblings of each kept cell and the levels above, the octree bounds about 10 T cells when
/// its bounds are tight. The gallery's box-only meshes bound 2–5 cells per triangle; 64
/// leaves room for interval bounds that are loose by several cells.
const CELLS_PER_TRIANGLE: u64 = 64;

/// The most octree cells worth bounding for a mesh of at most `triangles` triangles.
fn cell_budget(triangles: u64) -> usize {
    usize::try_from(triangles.saturating_mul(CELLS_PER_TRIANGLE)).unwrap_or(usize::MAX)
}

/// Every component found in the box, joined into one mesh in the order found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Components {
    pub mesh: Mesh,
    /// Components marched.
    pub components: usize,
    /// The seed of each component.
    pub seeds: Vec<DVec3>,
    /// The triangles of each component (they follow each other in `mesh.triangles`).
    pub triangles: Vec<usize>,
    /// Marches that gave a sheet meshed already, dropped (a seed the coverage test missed).
    pub duplicates: usize,
    pub warnings: Vec<Warning>,
    /// The largest chord error of the components' meshes.
    pub max_chord_error: f64,
    /// What the marches of the components said (see `march::Marched::warnings`).
    pub march_warnings: Vec<String>,
}

impl ahead::Seeded for Seed {
    fn point(&self) -> DVec3 {
        self.sp.point
    }
}

/// How each component is marched: the step, the limit on triangles (for the total, as it
/// bounds one march), the tolerance and the uniform step of `MarchInput`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marching {
    pub step: f64,
    pub max_triangles: Option<u64>,
    pub tolerance: Option<f64>,
    pub uniform: bool,
}

impl Marching {
    /// The local step with the default tolerance and limit.
    pub fn step(step: f64) -> Self {
        Marching {
            step,
            max_triangles: None,
            tolerance: None,
            uniform: false,
        }
    }
}

/// Meshes every component of `surface` inside `lo .. hi` (the module documentation), each
/// marched and verified as `marching` says.
pub fn mesh_components(
    surface: &mut dyn Surface,
    marching: Marching,
    (lo, hi): (DVec3, DVec3),
    march_settings: &MarchSettings,
    settings: &SearchSettings,
) -> Result<Components, SearchError> {
    search_components(
        surface,
        None,
        marching,
        (lo, hi),
        march_settings,
        settings,
        Mesh::default(),
        false,
        None,
    )
}

/// [`mesh_components`] with the components marched on the rayon pool:
/// each march on a fresh oracle from `fork`, so a march never depends on what the oracle
/// evaluated before (the warm start of `dist`), and the components accepted in seed order
/// exactly as one thread would. The same mesh, bit for bit, for any number of threads; for
/// a surface without `dist` also the same as [`mesh_components`].
/// `progress`, where given, counts the triangles of the marches as they go and the
/// components as they are found (`mesh::progress`).
pub fn mesh_components_forked(
    surface: &mut dyn Surface,
    fork: &Fork<'_>,
    marching: Marching,
    bbox: (DVec3, DVec3),
    march_settings: &MarchSettings,
    settings: &SearchSettings,
    progress: Option<&Counts>,
) -> Result<Components, SearchError> {
    search_components(
        surface,
        Some(fork),
        marching,
        bbox,
        march_settings,
        settings,
        Mesh::default(),
        false,
        progress,
    )
}

/// [`mesh_components`] around a mesh made already (`existing`, the smooth pieces of a surface
/// with creases): seeds it covers start nothing. The result's mesh begins with `existing`
/// (taken, not copied: it is the bulk of the result);
/// its component count and seeds are those of the new components only. With `fork`, the
/// marches run as [`mesh_components_forked`] says, and `progress` counts as it says there
/// (`existing`'s triangles are not added: the caller counted them). A seed where f touches
/// zero without changing sign starts nothing: for a surface with creases that is the inner
/// face of a union (two solids side by side, f ≤ 0 on both sides), which is no part of the
/// surface.
#[allow(clippy::too_many_arguments)]
pub fn mesh_components_beside(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    marching: Marching,
    bbox: (DVec3, DVec3),
    march_settings: &MarchSettings,
    settings: &SearchSettings,
    existing: Mesh,
    progress: Option<&Counts>,
) -> Result<Components, SearchError> {
    search_components(
        surface,
        fork,
        marching,
        bbox,
        march_settings,
        settings,
        existing,
        true,
        progress,
    )
}

/// The search of [`mesh_components_beside`]; with `fork`, the marches run as
/// [`mesh_components_forked`] says, else one after another on `surface`. With
/// `skip_touching`, seeds where f does not change sign start nothing.
// The oracles, the marching, the box, two settings structs, the mesh so far, the flag and
// the counts: each a caller's choice.
#[allow(clippy::too_many_arguments)]
fn search_components(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    marching: Marching,
    (lo, hi): (DVec3, DVec3),
    march_settings: &MarchSettings,
    settings: &SearchSettings,
    existing: Mesh,
    skip_touching: bool,
    progress: Option<&Counts>,
) -> Result<Components, SearchError> {
    let step = marching.step;
    let max_triangles = marching.max_triangles;
    if !(step.is_finite() && step > 0.0) {
        return Err(SearchError::InvalidStep { step });
    }
    if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
        return Err(SearchError::InvalidBox { lo, hi });
    }
    // The same default as a march in this box (what the box holds at the step), so that a
    // block without `max_triangles` is bounded alike with or without a start point.
    let limit = max_triangles.unwrap_or_else(|| {
        crate::march::guard::default_limit(Some((lo, hi)), step, march_settings.max_triangles)
    });
    // The octree's work, bounded by what the mesh may hold as well as by `max_cells`.
    let budget = cell_budget(limit).min(settings.max_cells);
    let mut walk = Walk::new(regions(lo, hi), settings.leaf * step, budget);
    let tolerance = marching
        .tolerance
        .unwrap_or(march_settings.tolerance * step);
    let sizing = Sizing::of_mesh(step, tolerance, marching.uniform, march_settings.sizing);
    let mut search = Search {
        surface,
        step,
        sizing,
        marching,
        bbox: (lo, hi),
        march_settings,
        settings,
        limit,
        cover: Cover::new(step),
        out: Components::default(),
        small: Vec::new(),
        skip_touching,
        progress,
    };
    let Search { cover, out, .. } = &mut search;
    out.mesh = existing;
    cover.hash_from(&out.mesh, 0);
    // First pass, as the octree yields its leaves: seeds away from the faces are marched at
    // once (a march past `max_triangles` ends the search there); the others wait for the
    // second pass. A kept leaf is walked again with smaller leaves where it may hide what its
    // seeds did not find: when no seed came from it (Newton from its centre missed a thin
    // plate or a small ball in it), and when the thickness across its seeds asks for a local
    // step well below the leaf (a thin tube, a small ball, a narrow gap: a second component
    // in the cell gets cells and seeds of its own at about that size).
    let floor = search.sizing.floor();
    // With `fork`, the seeds away from the faces go into a queue that is marched
    // `LOOKAHEAD` seeds behind the walk (the walk does not depend on the marches), so that
    // seeds of other components are known when a march starts.
    let mut queue = fork.map(Queue::new);
    let mut near_faces: Vec<Seed> = Vec::new();
    let mut unseeded: Vec<Cell> = Vec::new();
    let mut refined = 0_usize;
    while let Some(pending) = walk.next(&mut *search.surface) {
        search.no_fault()?;
        let cell = search.solid(pending.cell, pending.leaf);
        // A leaf without a seed is halved down to `SEEDLESS_LEAF` of a step: a plate or
        // ball that thin is seeded by then (Newton from a centre within a few thicknesses of
        // it converges), and going on to the floor costs many cells where Newton fails for
        // other reasons (near the kinks of a `max`).
        let seedless_floor = floor.max(SEEDLESS_LEAF * step);
        let finer_than_floor = |leaf: f64| (leaf >= seedless_floor).then_some(leaf);
        let finer = match search.seeds_of(cell) {
            CellSeeds::Touching => None,
            CellSeeds::Missed => {
                let finer = finer_than_floor(0.5 * pending.leaf);
                if finer.is_none() {
                    unseeded.push(cell);
                }
                finer
            }
            CellSeeds::Found(found) if found.is_empty() => finer_than_floor(0.5 * pending.leaf),
            CellSeeds::Found(found) => {
                let mut finest = f64::INFINITY;
                for sp in found {
                    let seed = search.sized(sp);
                    // Beside a crease the thickness probe along one face's normal runs along
                    // the other face: a kink, not a thin feature.
                    let thin = REFINE_LEAF * seed.across < 0.5 * pending.leaf;
                    if thin && !search.beside_crease(&seed) {
                        finest = finest.min(seed.across);
                    }
                    if !search.away_from_faces(seed.sp.point) {
                        near_faces.push(seed);
                    } else if let Some(queue) = queue.as_mut() {
                        queue.seeds.push(seed);
                        queue.cells = walk.visited;
                        while queue.seeds.len() - queue.next > LOOKAHEAD {
                            search.next_of(queue)?;
                        }
                    } else {
                        search.try_seed(&seed)?;
                    }
                }
                let finer = (REFINE_LEAF * finest).max(floor);
                (finer < 0.5 * pending.leaf).then_some(finer)
            }
        };
        search.no_fault()?;
        if let Some(leaf) = finer {
            walk.refine(pending, leaf);
            refined += 1;
        }
    }
    search.no_fault()?;
    if let Some(queue) = queue.as_mut() {
        queue.cells = walk.visited;
        search.drain(queue)?;
    }
    if crate::trace::enabled() {
        eprintln!(
            "components: {} cells bounded, {refined} leaves walked again finer, {} components",
            walk.visited, search.out.components
        );
    }
    if walk.truncated {
        if budget < settings.max_cells {
            return Err(SearchError::CellBudget {
                cells: budget,
                triangles: limit,
            });
        }
        search.out.warnings.insert(
            0,
            Warning::CellLimit {
                cells: settings.max_cells,
            },
        );
    }
    match queue.as_mut() {
        Some(queue) => {
            queue.seeds.extend(near_faces);
            search.drain(queue)?;
        }
        None => {
            for seed in &near_faces {
                search.try_seed(seed)?;
            }
        }
    }
    // A cell the marcher went through anyway is no gap.
    let Search { cover, out, .. } = &mut search;
    unseeded.retain(|c| !cover.touches(&out.mesh, *c));
    if let Some(first) = unseeded.first() {
        out.warnings.push(Warning::NoSeed {
            at: first.centre(),
            cells: unseeded.len(),
        });
    }
    Ok(search.out)
}

/// The state of one search.
struct Search<'a> {
    surface: &'a mut dyn Surface,
    step: f64,
    /// The local step the marches will use, for sizing the seeds' tests.
    sizing: Sizing,
    marching: Marching,
    bbox: (DVec3, DVec3),
    march_settings: &'a MarchSettings,
    settings: &'a SearchSettings,
    /// Triangles left for the components still to come.
    limit: u64,
    /// Counts for a progress bar: the marches' triangles and the components found.
    progress: Option<&'a Counts>,
    cover: Cover,
    out: Components,
    /// Seeds of components smaller than their local step (warned once).
    small: Vec<Seed>,
    /// Seeds where f touches zero without changing sign start nothing.
    skip_touching: bool,
}

/// What Newton from a cell's centre found.
enum Seeded {
    At(SurfacePoint),
    /// A place where f touches zero without changing sign (with `skip_touching`).
    Touching,
    Missed,
}

/// The seeds of a cell.
enum CellSeeds {
    /// Seeds (none: no seed, and no sign change over the cell).
    Found(Vec<SurfacePoint>),
    /// f touches zero there without changing sign (with `skip_touching`): no seed, and no
    /// reason to look closer.
    Touching,
    /// f changes sign over the cell but no seed converged in the box.
    Missed,
}

/// A seed with the local step there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Seed {
    sp: SurfacePoint,
    h: f64,
    /// The local step the thickness across the seed allows (another sheet along ±n: a
    /// small ball's far side, a thin tube's, a plate's, a gap), at least `h`. The curvature
    /// part of `h` does not count here: at a crease it measures the kink.
    across: f64,
}

impl Search<'_> {
    /// Err with the place where the surface could not be evaluated, if it met one (a NaN
    /// from a `dist` that found no foot point): the search stops at once.
    fn no_fault(&self) -> Result<(), SearchError> {
        match self.surface.fault() {
            Some(f) => Err(SearchError::Fault {
                at: f.at,
                reason: f.reason,
            }),
            None => Ok(()),
        }
    }

    fn inside(&self, p: DVec3) -> bool {
        let (lo, hi) = self.bbox;
        p.cmpge(lo).all() && p.cmple(hi).all()
    }

    /// A face or edge cell made solid: grown into the box by a leaf's size along its flat
    /// axes, so that its seeds start inside the box next to where the surface crosses the
    /// face. Cells of the inside are returned as they are.
    fn solid(&self, mut cell: Cell, leaf: f64) -> Cell {
        let (lo, hi) = self.bbox;
        for k in 0..3 {
            if cell.lo[k] < cell.hi[k] {
                continue;
            }
            let depth = leaf.min(hi[k] - lo[k]);
            if cell.lo[k] >= hi[k] {
                cell.lo[k] = hi[k] - depth;
            } else {
                cell.hi[k] = lo[k] + depth;
            }
        }
        cell
    }

    fn away_from_faces(&self, p: DVec3) -> bool {
        let (lo, hi) = self.bbox;
        let m = self.settings.face_margin * self.step;
        (p - lo).min_element() >= m && (hi - p).min_element() >= m
    }

    /// The surface point from the centre of `cell`, if Newton reaches the surface within
    /// `seed_iterations` steps without leaving the cell's neighbourhood (`seed_reach · step`
    /// around it), and lands inside the box. A centre far from the surface is not this cell's
    /// seed (a cell nearer the surface gives it): giving up early keeps the cells the interval
    /// bound could not drop cheap.
    fn seed_from(&mut self, cell: Cell) -> Seeded {
        let margin = DVec3::splat(self.settings.seed_reach * self.step);
        let (lo, hi) = (cell.lo - margin, cell.hi + margin);
        let near = |u: DVec3| u.cmpge(lo).all() && u.cmple(hi).all();
        let mut u = cell.centre();
        let mut close = false;
        for _ in 0..self.settings.seed_iterations {
            let vg = self.surface.value_gradient(u);
            let g2 = vg.gradient.length_squared();
            if vg.value == 0.0 && g2 == 0.0 {
                // On a tie of operands whose gradients cancel: where f touches zero between
                // two solids side by side, unless it changes sign (then a seed is near).
                return if self.skip_touching && !self.sign_changes(cell) {
                    Seeded::Touching
                } else {
                    Seeded::Missed
                };
            }
            if !(vg.value.is_finite() && g2 > 0.0 && g2.is_finite()) {
                return Seeded::Missed;
            }
            let delta = vg.gradient * (vg.value / g2);
            u -= delta;
            if !near(u) {
                return Seeded::Missed;
            }
            if delta.length() < SEED_CLOSE * self.step {
                close = true;
                break;
            }
        }
        if !close {
            return Seeded::Missed;
        }
        let Ok(sp) = surface_point(
            self.surface,
            u,
            self.step,
            &self.march_settings.surface_point,
        ) else {
            return Seeded::Missed;
        };
        if !(near(sp.point) && self.inside(sp.point)) {
            return Seeded::Missed;
        }
        if self.skip_touching && !march::changes_sign(&mut *self.surface, &sp, self.step) {
            return Seeded::Touching;
        }
        Seeded::At(sp)
    }

    /// The seeds of a cell: from its centre, else from its octants' centres where f changes
    /// sign over the cell (otherwise the interval bound was only loose there).
    fn seeds_of(&mut self, cell: Cell) -> CellSeeds {
        match self.seed_from(cell) {
            Seeded::At(sp) => return CellSeeds::Found(vec![sp]),
            Seeded::Touching => return CellSeeds::Touching,
            Seeded::Missed => {}
        }
        if !self.sign_changes(cell) {
            return CellSeeds::Found(Vec::new());
        }
        let found: Vec<SurfacePoint> = cell
            .octants()
            .into_iter()
            .filter_map(|c| match self.seed_from(c) {
                Seeded::At(sp) => Some(sp),
                _ => None,
            })
            .collect();
        if found.is_empty() {
            CellSeeds::Missed
        } else {
            CellSeeds::Found(found)
        }
    }

    /// Whether f takes both signs at the corners and centre of the cell.
    fn sign_changes(&mut self, cell: Cell) -> bool {
        let (mut neg, mut pos) = (false, false);
        let corners = (0..8).map(|i| {
            let pick = |k: usize, bit: usize| {
                if i & bit == 0 { cell.lo[k] } else { cell.hi[k] }
            };
            DVec3::new(pick(0, 1), pick(1, 2), pick(2, 4))
        });
        for p in corners.chain([cell.centre()]) {
            let v = self.surface.value(p);
            neg |= v < 0.0;
            pos |= v > 0.0;
        }
        neg && pos
    }

    /// `sp` with the local step the march would take there (the step itself with
    /// `uniform: true`), and the part of it that the thickness across sets.
    fn sized(&mut self, sp: SurfacePoint) -> Seed {
        let size = self.sizing.size(self.surface, &sp, None, None);
        let across =
            (self.sizing.settings().thickness_fraction * size.free).clamp(size.h, self.step);
        Seed {
            sp,
            h: size.h,
            across,
        }
    }

    /// Whether the direction of ∇f jumps within the seed's `across` of it (a crease).
    fn beside_crease(&mut self, seed: &Seed) -> bool {
        let sp = &seed.sp;
        gradient_jump(self.surface, sp.point, (sp.t1, sp.t2), seed.across).is_some()
    }

    /// Marches a new component from `seed` unless a mesh already covers it. The tests are
    /// sized by the local step at the seed: a mesh there has edges of about that length, and
    /// another sheet or component nearer than it has its own cells and seeds.
    fn try_seed(&mut self, seed: &Seed) -> Result<(), SearchError> {
        if !self.screen(seed) {
            return Ok(());
        }
        let input = self.march_input(seed.sp.point, self.limit.max(1));
        let triangles = self.progress.map(|p| &p.triangles);
        let marched =
            march::march_verified(self.surface, None, &input, self.march_settings, triangles)
                .map_err(|source| SearchError::March {
                    seed: seed.sp.point,
                    source,
                })?;
        self.accept(seed.sp.point, marched);
        Ok(())
    }

    /// Whether `seed` starts a march: not covered by the mesh so far, not on a component
    /// smaller than its local step (warned once here). Evaluates the search's oracle, so it
    /// is called once per seed, in seed order.
    fn screen(&mut self, seed: &Seed) -> bool {
        if self.passed_over(seed) {
            return false;
        }
        if self.is_small(seed) {
            self.small.push(*seed);
            self.out.warnings.push(Warning::SmallComponent {
                at: seed.sp.point,
                h: seed.h,
            });
            return false;
        }
        true
    }

    /// Whether the mesh so far covers `seed`, or it lies on a small component warned of
    /// already: the part of [`Search::screen`] that does not evaluate the surface.
    fn passed_over(&self, seed: &Seed) -> bool {
        let Seed { sp, h, .. } = seed;
        let factor = if self.away_from_faces(sp.point) {
            self.settings.covered
        } else {
            self.settings.covered_at_faces
        };
        let cos = self.settings.covered_normal_cos;
        if self
            .cover
            .covered(&self.out.mesh, sp.point, sp.normal, factor, *h, cos)
        {
            return true;
        }
        // On a component smaller than its local step the normals of nearby seeds point every
        // way: distance alone tells the seeds of one small component.
        self.small
            .iter()
            .any(|s| (s.sp.point - sp.point).length() < 2.0 * s.h)
    }

    /// The march of a component from `at` with at most `limit` triangles.
    fn march_input(&self, at: DVec3, limit: u64) -> MarchInput {
        MarchInput {
            step: self.step,
            start: Start::Point(at),
            bounds: Vec::new(),
            bbox: Some(self.bbox),
            max_triangles: Some(limit),
            tolerance: self.marching.tolerance,
            uniform: self.marching.uniform,
            expected_triangles: None,
        }
    }

    /// Takes the component marched from `at` into the result, unless it is a sheet meshed
    /// already.
    fn accept(&mut self, at: DVec3, marched: march::Marched) {
        let mesh = marched.mesh;
        self.out.max_chord_error = self.out.max_chord_error.max(marched.max_chord_error);
        self.out.march_warnings.extend(marched.warnings);
        self.limit = self.limit.saturating_sub(mesh.triangles.len() as u64);
        if self.duplicates(&mesh) {
            // A sheet meshed already (its seed was missed as covered where the earlier mesh
            // stops short of the box's edges): kept once.
            self.out.duplicates += 1;
            self.forget(&mesh);
            return;
        }
        self.cover.add(&mut self.out.mesh, &mesh);
        self.out.components += 1;
        if let Some(p) = self.progress {
            p.components.fetch_add(1, Ordering::Relaxed);
        }
        self.out.seeds.push(at);
        self.out.triangles.push(mesh.triangles.len());
    }

    /// The count the marches add their triangles to, if any.
    fn triangles(&self) -> Option<&AtomicU64> {
        self.progress.map(|p| &p.triangles)
    }

    /// Takes the triangles of a marched mesh that is thrown away back from the count (its
    /// march added them).
    fn forget(&self, mesh: &Mesh) {
        if let Some(p) = self.progress {
            p.triangles
                .fetch_sub(mesh.triangles.len() as u64, Ordering::Relaxed);
        }
    }

    /// [`Search::try_seed`] for the next seed of `queue`, its march on a fresh oracle from
    /// the queue's fork, several at once on the rayon pool: where a seed needs a march, the
    /// later seeds known that lie in other clusters of the surface's cells (`ahead::Clusters`:
    /// surely another component, so not covered by this one) and that nothing covers yet are
    /// marched beside it, and their meshes wait for their turn. At its turn a seed is
    /// screened again as one thread would screen it; a mesh marched ahead is taken as it is
    /// if its march had the triangle limit left at that turn, or stayed within it (then it is
    /// the mesh that limit gives), else the seed is marched again with that limit. So the
    /// result is what marching the seeds one after another on fresh oracles gives, whatever
    /// the threads.
    fn next_of(&mut self, q: &mut Queue<'_>) -> Result<(), SearchError> {
        let i = q.next;
        let Some(seed) = q.seeds.get(i).copied() else {
            return Ok(());
        };
        q.next += 1;
        if !self.screen(&seed) {
            if let Some((_, Some(Ok(m)))) = q.ready.remove(&i) {
                self.forget(&m.mesh);
            }
            return Ok(());
        }
        let limit = self.limit.max(1);
        let (used_limit, early) = match q.ready.remove(&i) {
            Some(early) => {
                q.used += 1;
                early
            }
            None => {
                let mut batch = vec![i];
                let threads = rayon::current_num_threads();
                if threads > 1 && q.seeds[i + 1..].iter().any(|s| !self.passed_over(s)) {
                    // The clusters never cost more than twice the cells of the search's own
                    // walk so far (on a `dist` surface each is a foot point): tried again
                    // when the walk has bounded twice as many as at the last try.
                    let budget = (2 * q.cells).max(MIN_CLUSTER_CELLS);
                    if q.clusters.is_none() && budget >= 2 * q.tried {
                        q.tried = budget;
                        let started = std::time::Instant::now();
                        // On a fresh oracle: the search's own must see the same evaluations
                        // for any number of threads (the warm start of `dist`).
                        q.clusters = (q.fork)().and_then(|mut s| {
                            ahead::Clusters::new(&mut *s, self.bbox, self.step, budget)
                        });
                        if crate::trace::enabled() {
                            eprintln!(
                                "components: clusters of the surface's cells (at most {budget}) {} in {:.3} s",
                                if q.clusters.is_some() {
                                    "found"
                                } else {
                                    "given up"
                                },
                                started.elapsed().as_secs_f64()
                            );
                        }
                    }
                    if let Some(clusters) = &q.clusters {
                        let busy: Vec<usize> = q.ready.keys().copied().collect();
                        batch.extend(
                            clusters
                                .beside(&q.seeds, i, &busy, threads - 1, |s| self.passed_over(s)),
                        );
                    }
                }
                let mut marched = self.march_on_forks(&batch, &q.seeds, q.fork, limit);
                let first = marched.remove(0);
                q.ahead += batch.len() - 1;
                q.ready.extend(
                    batch[1..]
                        .iter()
                        .map(|&j| (j, limit))
                        .zip(marched)
                        .map(|((j, l), m)| (j, (l, m))),
                );
                (limit, first)
            }
        };
        let marched = match early {
            Some(Ok(m)) if used_limit == limit || m.peak_triangles <= limit => m,
            Some(Err(source)) if used_limit == limit => {
                return Err(SearchError::March {
                    seed: seed.sp.point,
                    source,
                });
            }
            // Without an oracle, failed or past this turn's limit: as one thread marches it.
            early => {
                if let Some(Ok(m)) = &early {
                    self.forget(&m.mesh);
                }
                let mut surface = (q.fork)().ok_or(SearchError::Fork)?;
                let input = self.march_input(seed.sp.point, limit);
                march::march_verified(
                    &mut *surface,
                    Some(q.fork),
                    &input,
                    self.march_settings,
                    self.triangles(),
                )
                .map_err(|source| SearchError::March {
                    seed: seed.sp.point,
                    source,
                })?
            }
        };
        self.accept(seed.sp.point, marched);
        Ok(())
    }

    /// [`Search::next_of`] until `queue` is empty.
    fn drain(&mut self, q: &mut Queue<'_>) -> Result<(), SearchError> {
        while q.next < q.seeds.len() {
            self.next_of(q)?;
        }
        if crate::trace::enabled() {
            eprintln!(
                "components: {} seeds, {} marches ahead of their turn, {} of them taken",
                q.seeds.len(),
                q.ahead,
                q.used
            );
        }
        Ok(())
    }

    /// The marches from `seeds[i]` for each i of `batch`, on the pool, each on a fresh
    /// oracle (None where `fork` gave none), in `batch` order.
    fn march_on_forks(
        &self,
        batch: &[usize],
        seeds: &[Seed],
        fork: &Fork<'_>,
        limit: u64,
    ) -> Vec<Option<Result<march::Marched, MarchError>>> {
        let inputs: Vec<MarchInput> = batch
            .iter()
            .map(|&i| self.march_input(seeds[i].sp.point, limit))
            .collect();
        let settings = self.march_settings;
        let triangles = self.triangles();
        inputs
            .par_iter()
            .map(|input| {
                let mut surface = fork()?;
                Some(march::march_verified(
                    &mut *surface,
                    Some(fork),
                    input,
                    settings,
                    triangles,
                ))
            })
            .collect()
    }

    /// Whether most of `part`'s vertices (a sample of up to `DUPLICATE_SAMPLES`) are covered
    /// by the mesh so far (within `covered` times the edges of its triangles): then `part` is
    /// a sheet meshed already.
    fn duplicates(&self, part: &Mesh) -> bool {
        let n = part.vertices.len();
        if n == 0 || self.out.mesh.triangles.is_empty() {
            return false;
        }
        let stride = n.div_ceil(DUPLICATE_SAMPLES);
        let cos = self.settings.covered_normal_cos;
        let sampled = (0..n).step_by(stride);
        let total = sampled.clone().count();
        let covered = sampled
            .filter(|&i| {
                self.cover.covered(
                    &self.out.mesh,
                    part.vertices[i],
                    part.normals[i],
                    self.settings.covered,
                    0.0,
                    cos,
                )
            })
            .count();
        2 * covered > total
    }

    /// Whether the surface closes up within the local step around the seed: the points of
    /// the Step 0 hexagon of side h, put on the surface, come back within `small · h` of it
    /// (or do not converge at all). With the local step, h has reached its floor there.
    fn is_small(&mut self, seed: &Seed) -> bool {
        let Seed { sp, h, .. } = *seed;
        (0..6).any(|i| {
            let w = i as f64 * std::f64::consts::FRAC_PI_3;
            let q = sp.point + h * (w.cos() * sp.t1 + w.sin() * sp.t2);
            match surface_point(self.surface, q, h, &self.march_settings.surface_point) {
                Ok(r) => (r.point - sp.point).length() < self.settings.small * h,
                Err(_) => true,
            }
        })
    }
}

/// The seeds of a search with `fork`, marched in order (`Search::next_of`).
struct Queue<'f> {
    fork: &'f Fork<'f>,
    seeds: Vec<Seed>,
    /// The next seed to screen.
    next: usize,
    /// Marches run ahead of their turn, by seed, with the triangle limit they had.
    ready: BTreeMap<usize, (u64, Option<Result<march::Marched, MarchError>>)>,
    /// The clusters of the surface's cells, once a march could run beside another.
    clusters: Option<ahead::Clusters>,
    /// The cell budget of the last try at the clusters (0: not tried).
    tried: usize,
    /// Cells the search's walk has bounded so far: the clusters' budget.
    cells: usize,
    /// For the trace: marches run ahead, and those of them taken.
    ahead: usize,
    used: usize,
}

impl<'f> Queue<'f> {
    fn new(fork: &'f Fork<'f>) -> Self {
        Queue {
            fork,
            seeds: Vec::new(),
            next: 0,
            ready: BTreeMap::new(),
            clusters: None,
            tried: 0,
            cells: 0,
            ahead: 0,
            used: 0,
        }
    }
}

/// Seeds known beyond the one marched during the walk: enough to reach the seeds of other
/// components (a component gives a few seeds, a large one a few dozen), few enough that a
/// march past `max_triangles` still ends the search early in the walk.
const LOOKAHEAD: usize = 32;

/// The clusters may bound at least this many cells, however few the walk has bounded.
const MIN_CLUSTER_CELLS: usize = 256;

/// A kept leaf is walked again with leaves of this many local steps (at the finest of its
/// seeds) when that is below half the leaf: cells of about the local step, as the marcher
/// sees the surface there.
const REFINE_LEAF: f64 = 2.0;

/// Leaves without a seed are walked again down to this many steps (five halvings).
const SEEDLESS_LEAF: f64 = 1.0 / 32.0;

/// A seed's Newton iteration is close when its step is below this many steps; surfacepoint
/// converges from there.
const SEED_CLOSE: f64 = 0.01;

/// Vertices of a new component checked against the mesh so far ([`Search::duplicates`]).
const DUPLICATE_SAMPLES: usize = 32;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::check::closest_on_triangle;

    #[test]
    fn closest_point_in_each_region() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let cases = [
            (DVec3::new(0.2, 0.2, 1.0), DVec3::new(0.2, 0.2, 0.0)),
            (DVec3::new(-1.0, -1.0, 0.0), a),
            (DVec3::new(2.0, -0.5, 0.0), b),
            (DVec3::new(-0.5, 2.0, 0.0), c),
            (DVec3::new(0.5, -1.0, 0.0), DVec3::new(0.5, 0.0, 0.0)),
            (DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.5, 0.5, 0.0)),
        ];
        for (p, want) in cases {
            let got = closest_on_triangle(p, a, b, c);
            assert!((got - want).length() < 1e-12, "{p}: {got} ≠ {want}");
        }
    }

    #[test]
    fn cells_split_to_near_cubes() {
        let cell = Cell {
            lo: DVec3::ZERO,
            hi: DVec3::new(4.0, 4.0, 1.0),
        };
        let kids = cell.split(0.1);
        assert_eq!(kids.len(), 4, "the short side waits");
        let total: f64 = kids.iter().map(|c| (c.hi - c.lo).element_product()).sum();
        assert!((total - 16.0).abs() < 1e-12);
    }
}
