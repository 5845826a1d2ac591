//! Creases (docs/creases.md; the paper's coherent nets, Sects. 3.9 and 3.11, found
//! automatically): a surface whose spine (`survey::spine`) switches between smooth forms is
//! meshed as one net of smooth pieces that share their crease polygons bit for bit.
//!
//! 1. Seeds: an octree over the box keeps the cells where f's interval and the intervals of at
//!    least two forms hold 0 (the spine pruned cell by cell, so a cell sees only the forms
//!    that can be chosen in it); in each leaf, Newton from the centre onto every such pair
//!    of forms gives a crease point when both are chosen there. Forms found to be one sheet
//!    there are one face (`survey::faces::relate`).
//! 2. What a seed is: `survey::faces::crossing` says, from f's sign around it, whether two
//!    faces really meet there (a crease), or one face goes on (operands tied inside the solid,
//!    a face two boxes share), or no surface passes (the inner face of two boxes side by side).
//! 3. Tracing: from a crease seed not on a crease traced already, both ways along ∇Lᵢ × ∇Lⱼ
//!    in short steps, each point corrected onto both forms, until the curve closes or another
//!    face is chosen: there the junction, where a third form is zero with them, is solved by
//!    Newton and asked which creases leave it (`survey::faces::junction`): a crease passing
//!    through (the walk goes on), or a corner of three faces or more. Creases that leave a
//!    corner and no seed found are traced from it. A walk stuck where its faces' normals
//!    meet ends at a tangent crossing (`trace/tangent.rs`: rods of one radius whose axes
//!    cross, a corner of four creases) or where the crease dies out into a sheet both faces
//!    share (`trace/dying.rs`: closed by a seam through that sheet).
//! 4. Polygons: each crease is resampled at the local step of both pieces (corners kept), and
//!    given to each of its two faces walked so that the face lies on its left.
//! 5. Pieces: every face's polygons are chained at the corners into loops and marched on the
//!    face's form as front and bounds (`march::march_verified`), so the pieces share the
//!    crease vertices and the whole is watertight. The pieces are marched side by side on
//!    the rayon pool, each on fresh oracles of the spine's branches, and taken in face order
//!    as if marched one after another (the same bits for any number of threads). Every vertex of a piece must lie where its
//!    face is chosen (f = Lᵢ there): a vertex elsewhere means a crease was missed, and the mesh
//!    fails.
//! 6. Components that no crease touches are found and marched by the component search around
//!    the pieces; each of their triangles must lie on one face.
//! 7. Slide: the crease vertices, which each piece had to keep, move along their creases
//!    for the angles and radius ratios of their stars in both pieces (`slide.rs`); the joined
//!    mesh is checked after that (crossings included), and kept as marched where it fails.
//!
//! Whatever cannot be traced — normals parallel along a crease (tangential contact), a solid
//! touching itself along an edge, a crease leaving the box — is an error at its place, never
//! a mesh. Deterministic: cells, pairs and creases follow fixed orders.

mod join;
mod pair;
mod slide;
#[cfg(test)]
mod tests;
mod trace;
mod width;

use std::collections::BTreeMap;
use std::sync::atomic::Ordering;

use glam::DVec3;
use rayon::prelude::*;

use super::components::{self, Marching, SearchError, SearchSettings};
use crate::march::{self, MarchError, MarchInput, MarchSettings, Start};
use crate::mesh::Mesh;
use crate::mesh::check::ANY_GROUP;
use crate::mesh::progress::Counts;
use crate::surface::{BranchFork, Surface};
use crate::survey::faces::{FaceError, FaceSettings};
use crate::survey::sizing::{Cap, PresetCaps, Sizing};
use crate::survey::spine::{Creased, Detached, Form, Whole};
use join::{Side, bits, chain, check_joined, check_smooth};
pub(crate) use join::{merge, merge_at};
use trace::{CREASE_SHARE, Tracer};

/// Settings of the crease search. Lengths are multiples of the step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CreaseSettings {
    /// Octree leaves are at most `leaf · step` across. Default 0.5: a crease loop smaller than
    /// the leaf still crosses a leaf where both forms' intervals hold 0.
    pub leaf: f64,
    /// The tracing step, before resampling. Default 0.25.
    pub trace: f64,
    /// Two choices of the spine are a tie when their values differ by less than
    /// `tie · step · |∇|`. Default 1e-6: crease points are solved far closer, and a third
    /// form that close to a crease point is at a corner.
    pub tie: f64,
    /// A piece's vertex lies where its form is chosen when |f − Lᵢ|/|∇Lᵢ| ≤ `region · step`.
    /// Default 1e-6.
    pub region: f64,
    /// A seed within `covered · step` of a crease traced already (same pair of forms) starts
    /// nothing. Default 0.5.
    pub covered: f64,
    /// Normals closer to parallel than this sine make a tangential contact, not a crease.
    /// Default 1e-3.
    pub tangent_sine: f64,
    /// The shortest crease between two corners, and the shortest polygon edge the pieces
    /// march with. Default 0.02: shorter, two corners nearly coincide (four pieces nearly
    /// meet at a point).
    pub shortest: f64,
    /// Most octree cells bounded. Default 2 000 000.
    pub max_cells: usize,
    /// Most tracing points of one crease. Default 1 000 000.
    pub max_points: usize,
    /// How the faces at a point are told (`survey::faces`).
    pub faces: FaceSettings,
}

impl Default for CreaseSettings {
    fn default() -> Self {
        CreaseSettings {
            leaf: 0.5,
            trace: 0.25,
            tie: 1e-6,
            region: 1e-6,
            covered: 0.5,
            tangent_sine: 1e-3,
            shortest: 0.02,
            max_cells: 2_000_000,
            max_points: 1_000_000,
            faces: FaceSettings::default(),
        }
    }
}

/// Why a surface with creases could not be meshed; each says where.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CreaseError {
    #[error("the step {step} is not a positive finite number")]
    InvalidStep { step: f64 },
    #[error("the box {lo} .. {hi} is empty or not finite")]
    InvalidBox { lo: DVec3, hi: DVec3 },
    #[error(
        "two pieces of the surface touch tangentially at {at} (their normals are parallel, sine {sine:.1e}): the crease there cannot be traced"
    )]
    Tangent { at: DVec3, sine: f64 },
    #[error("{pieces} smooth pieces meet at {at} in a way that cannot be meshed")]
    SingularCorner { at: DVec3, pieces: usize },
    #[error(
        "the solid touches itself along an edge near {at}: {faces} faces meet there, where a crease has two"
    )]
    NonManifold { at: DVec3, faces: usize },
    #[error("the faces at {at} cannot be told apart (f is zero or undefined around it)")]
    Undecided { at: DVec3 },
    #[error(
        "more than {} smooth pieces may meet near {at} (choices of min, max and abs)",
        crate::survey::spine::MAX_CELL_FORMS
    )]
    TooManyForms { at: DVec3 },
    #[error("a crease ends near {at} without a corner where a third piece begins")]
    Lost { at: DVec3 },
    #[error(
        "two pieces of the surface cross at {at} that are one sheet elsewhere (operands that coincide on part of a face only)"
    )]
    PartlyOneSheet { at: DVec3, forms: (usize, usize) },
    #[error("a crease leaves the box at {at}: the box must hold every crease of the surface")]
    LeavesBox { at: DVec3 },
    #[error("a crease near {at} is {length:.3e} long: two of its corners nearly coincide")]
    Short { at: DVec3, length: f64 },
    #[error("a crease near {at} did not close within {points} tracing points")]
    TooLong { at: DVec3, points: usize },
    #[error("the pieces at the crease near {at} do not lie on its two sides")]
    Sides { at: DVec3 },
    #[error("the crease polygons of one piece do not join into loops at {at}")]
    Chain { at: DVec3 },
    #[error("the piece bounded by the crease through {at}: {source}")]
    March {
        at: DVec3,
        #[source]
        source: MarchError,
    },
    #[error(
        "the mesh of a piece reaches {at}, {distance:.3e} outside the part of the surface it belongs to: a crease was missed there"
    )]
    LeftPiece { at: DVec3, distance: f64 },
    #[error("a triangle near {at} spans two pieces of the surface: a crease was missed there")]
    MissedCrease { at: DVec3 },
    #[error("the pieces do not join into one surface near {at}: {why}")]
    Joined { at: DVec3, why: &'static str },
    #[error("the crease search stopped after {cells} cells; a smaller box would let it finish")]
    CellLimit { cells: usize },
    #[error(transparent)]
    Search(#[from] SearchError),
}

/// A surface with creases, meshed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CreasedMesh {
    pub mesh: Mesh,
    pub max_chord_error: f64,
    pub warnings: Vec<String>,
    /// Crease curves traced (closed loops and corner-to-corner curves).
    pub creases: usize,
    /// Corners where three pieces meet.
    pub corners: usize,
    /// Smooth pieces marched (one march per form with creases).
    pub pieces: usize,
    /// Components without a crease, from the component search.
    pub smooth_components: usize,
    /// The crease polygons as given to the pieces (one per crease, before orientation).
    pub polygons: Vec<Vec<DVec3>>,
}

impl From<FaceError> for CreaseError {
    fn from(e: FaceError) -> Self {
        match e {
            FaceError::Tangent { at, sine } => CreaseError::Tangent { at, sine },
            FaceError::NonManifold { at, faces } => CreaseError::NonManifold { at, faces },
            FaceError::SingularCorner { at, pieces } => CreaseError::SingularCorner { at, pieces },
            FaceError::Lost { at } => CreaseError::Lost { at },
            FaceError::Undecided { at } => CreaseError::Undecided { at },
            FaceError::PartlyOneSheet { at, forms } => CreaseError::PartlyOneSheet { at, forms },
        }
    }
}

/// Meshes `creased` (f itself is `whole`, with its interval bound) inside the box as the
/// module documentation says. With `fork` (fresh oracles of f), the smooth components are
/// marched on the rayon pool as `components::mesh_components_forked` says; with `branches`
/// (fresh oracles of the spine's branches), the smooth pieces too, each on its own. The mesh
/// is the same for any number of threads. `progress`, where given, counts the triangles of
/// the pieces and components as they are marched.
// The oracles, the marching, the box, three settings structs and the counts: each a
// caller's choice.
#[allow(clippy::too_many_arguments)]
pub fn mesh_creased(
    creased: &mut Creased,
    whole: &mut dyn Surface,
    fork: Option<&crate::surface::Fork<'_>>,
    branches: Option<&BranchFork<'_>>,
    marching: Marching,
    bbox: (DVec3, DVec3),
    march_settings: &MarchSettings,
    search: &SearchSettings,
    settings: &CreaseSettings,
    progress: Option<&Counts>,
) -> Result<CreasedMesh, CreaseError> {
    // Two forms found one sheet in one place and crossing at an angle in another (the
    // offsets of two solids flush on a face) are kept two faces, and the search starts over.
    let mut kept_apart = 0;
    loop {
        match mesh_creased_once(
            creased,
            whole,
            fork,
            branches,
            marching,
            bbox,
            march_settings,
            search,
            settings,
            progress,
        ) {
            Err(CreaseError::PartlyOneSheet { forms: (a, b), .. }) if kept_apart < MAX_APART => {
                if crate::trace::enabled() {
                    eprintln!(
                        "creases: forms {a} and {b} are kept two faces; the search starts over"
                    );
                }
                creased.keep_apart(a, b);
                kept_apart += 1;
            }
            other => return other,
        }
    }
}

/// A smooth piece to march: its loops as front and bounds, and the forms it may be marched
/// on, in the order they are tried.
struct PieceJob {
    at: DVec3,
    input: MarchInput,
    forms: Vec<usize>,
}

/// How many pairs of forms `mesh_creased` keeps apart before it gives up.
const MAX_APART: usize = 8;

#[allow(clippy::too_many_arguments)]
fn mesh_creased_once(
    creased: &mut Creased,
    whole: &mut dyn Surface,
    fork: Option<&crate::surface::Fork<'_>>,
    branches: Option<&BranchFork<'_>>,
    marching: Marching,
    bbox: (DVec3, DVec3),
    march_settings: &MarchSettings,
    search: &SearchSettings,
    settings: &CreaseSettings,
    progress: Option<&Counts>,
) -> Result<CreasedMesh, CreaseError> {
    let step = marching.step;
    if !(step.is_finite() && step > 0.0) {
        return Err(CreaseError::InvalidStep { step });
    }
    let (lo, hi) = bbox;
    if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
        return Err(CreaseError::InvalidBox { lo, hi });
    }
    creased.localize(4.0 * step);
    let mut t = Tracer::new(creased, step, bbox, *settings);
    let trace = crate::trace::enabled();
    let cells = t.cells(whole)?;
    if trace {
        eprintln!(
            "creases: {} forms, {} cells where two may meet",
            t.c.form_count(),
            cells.len()
        );
    }
    for (cell_lo, cell_hi, zero) in &cells {
        for (a, &i) in zero.iter().enumerate() {
            for &j in &zero[a + 1..] {
                // Forms of one face are looked at too: one sheet in one place, they may
                // cross in another (`CreaseError::PartlyOneSheet`).
                if !t.c.adjacent(i, j) {
                    continue;
                }
                let Some(seed) = t.seed(i, j, *cell_lo, *cell_hi)? else {
                    continue;
                };
                // A crease of these faces traced already, or a line of them found to be none,
                // passes here.
                if t.covered(i, j, seed) {
                    continue;
                }
                let Some((fa, fb)) = t.seed_crease(i, j, seed)? else {
                    t.remember(seed, i, j);
                    continue;
                };
                if !t.covered(fa, fb, seed) {
                    let traced = t.trace(fa, fb, seed)?;
                    t.keep(traced, trace, seed);
                }
            }
        }
    }
    t.trace_from_corners(trace)?;
    t.close_dying_creases()?;
    let tolerance = marching
        .tolerance
        .unwrap_or(march_settings.tolerance * step);
    let mut sizing = Sizing::of_mesh(step, tolerance, marching.uniform, march_settings.sizing);
    // The pieces march with polygon edges down to `shortest` steps (`piece_settings`): the
    // polygons follow the pieces' local step down to that, not to the marcher's shortest
    // front edge (a quarter step), which at steps above a part's smallest feature spaced
    // the holes' rims by 0.31 step where their walls asked for less (crease edges 1.4 times
    // the triangles' other edges, mean radius ratio 0.948 at three times the feature; 0.964
    // with the pieces' shortest).
    let min_edge = march_settings.polygon_edge_min.min(settings.shortest) * step;
    let traced = std::mem::take(&mut t.traced);
    // Faces up to a few steps wide beside a crease: their width, in whole rows of
    // triangles, caps the local step of the polygons and of the pieces' marches (the
    // paper's fixed step keeps the step).
    let index = pair::FineIndex::new(&traced, step);
    let caps: Vec<Cap> = if marching.uniform {
        Vec::new()
    } else {
        width::all_caps(&mut t, &traced, &index, branches)
    };
    sizing.add_caps(caps.iter().copied());
    let mut polygons = Vec::with_capacity(traced.len());
    // Per face (the smallest form of its class): its directed polygons with their corners.
    let mut sides: BTreeMap<usize, Vec<Side>> = BTreeMap::new();
    // Creases across narrow faces in phase (`pair.rs`): the places each crease's polygon
    // asks of those made after it; a crease is resampled through the places of the one
    // crease that asks for most (places from two creases, each in its own phase, would
    // space the polygon unevenly).
    let mut wanted: Vec<BTreeMap<usize, Vec<pair::Wanted>>> = vec![BTreeMap::new(); traced.len()];
    let mut made = vec![false; traced.len()];
    for (k, tr) in traced.iter().enumerate() {
        let places = wanted[k]
            .values()
            .rev()
            .max_by_key(|places| places.len())
            .map_or(&[][..], |places| &places[..]);
        let poly = t.resample(tr, &sizing, min_edge, places)?;
        made[k] = true;
        if !marching.uniform {
            for (b, q) in pair::across(&mut t, &traced, &index, k, &poly, &made) {
                wanted[b].entry(k).or_default().push(q);
            }
        }
        let (i, j) = tr.forms;
        let (left_i, left_j) = t.sides(tr)?;
        if left_i == left_j {
            return Err(CreaseError::Sides { at: poly[0] });
        }
        for (form, left) in [(i, left_i), (j, left_j)] {
            let (mut p, ends) = (poly.clone(), tr.ends);
            let ends = if left {
                ends
            } else {
                p.reverse();
                ends.map(|(a, b)| (b, a))
            };
            let face = t.c.class(form);
            sides.entry(face).or_default().push((p, ends));
        }
        polygons.push(poly);
    }
    // Each polygon vertex caps the pieces' local step at the step its longer polygon edge was
    // spaced for (the edge over `CREASE_SHARE`): a face whose rim is sampled finer than its
    // own step (a blind hole's floor, whose rim follows the wall's curvature) is marched from
    // that spacing, graded inwards, instead of with triangles of its own step on short edges
    // (slivers fanning across the floor). Capped at the edge itself, the share shrank the
    // pieces' rows with the crease's edges, and a strip's whole rows no longer fitted it.
    let mut caps = caps;
    if !marching.uniform {
        for poly in &polygons {
            for (k, &v) in poly.iter().enumerate() {
                let edge = |w: Option<&DVec3>| w.map_or(0.0, |w| w.distance(v));
                let longer =
                    edge(k.checked_sub(1).and_then(|k| poly.get(k))).max(edge(poly.get(k + 1)));
                // An edge spaced for the step or more caps nothing.
                let spaced_for = longer / CREASE_SHARE;
                if longer > 0.0 && spaced_for < step {
                    caps.push(Cap {
                        at: v,
                        size: spaced_for,
                    });
                }
            }
        }
    }
    // Their tree built once for all the pieces.
    let caps = PresetCaps::new(caps, step, &march_settings.sizing);
    let mut out = CreasedMesh {
        creases: traced.len(),
        corners: t.corners.len(),
        polygons,
        ..CreasedMesh::default()
    };
    let corners: Vec<(DVec3, Option<DVec3>)> =
        t.corners.iter().map(|c| (c.at, c.tangent)).collect();
    let mut limit = marching.max_triangles;
    let piece_settings = MarchSettings {
        polygon_edge_min: march_settings.polygon_edge_min.min(settings.shortest),
        ..*march_settings
    };
    let slides = march_settings.quality_angle > 0.0;
    // The pieces to march, in face order: a chain that fails ends the list, its error
    // given after the earlier pieces' (as one march after another gave it).
    let region = settings.region * step;
    let mut jobs: Vec<PieceJob> = Vec::new();
    let mut unchained = None;
    for (face, polys) in sides {
        let loops = match chain(polys, &corners) {
            Ok(loops) => loops,
            Err(e) => {
                unchained = Some(e);
                break;
            }
        };
        if trace {
            eprintln!("creases: piece of face {face}: {} loop(s)", loops.len());
        }
        let at = loops[0][0];
        let input = MarchInput {
            step,
            start: Start::Front(loops[0].clone()),
            bounds: loops[1..].to_vec(),
            bbox: Some(bbox),
            max_triangles: limit,
            tolerance: marching.tolerance,
            uniform: marching.uniform,
            expected_triangles: None,
        };
        // The face's forms whose zero sets hold its polygons, its first form first: where a
        // form is another's shadow over part of the face (a smooth boolean saturating onto
        // it), the one that is the face throughout is the one whose piece stays on it.
        let mut forms: Vec<usize> = Vec::new();
        for k in 0..t.c.form_count() {
            if t.c.class(k) != face {
                continue;
            }
            let holds = loops.iter().flatten().all(|&v| {
                let l = t.c.form(k, v);
                l.value.abs() <= region * l.gradient.length()
            });
            if holds {
                forms.push(k);
            }
        }
        if forms.is_empty() {
            forms.push(face);
        }
        jobs.push(PieceJob { at, input, forms });
    }
    // A form is marched on fresh oracles of the branches where `branches` makes them (then
    // what a piece computes does not depend on which thread marched what before it), else
    // on the surface itself.
    let counter = progress.map(|p| &p.triangles);
    let march_form = |surface: &mut dyn Surface, input: &MarchInput| {
        march::march_verified_capped(surface, None, input, &piece_settings, counter, &caps)
    };
    // Each piece's first form marched side by side on the rayon pool (one piece a task, so
    // that the large faces go to different threads), with the block's limit; then, in face
    // order, each piece is taken as one march after another would have it: kept where its
    // peak stayed within what the pieces before it left of the limit (the same mesh:
    // `Marched::peak_triangles`), else marched again with that.
    let mut first: Vec<Option<Result<march::Marched, MarchError>>> = match branches {
        Some(fork) if jobs.len() > 1 => {
            let forms: Vec<Form> = jobs.iter().map(|j| t.c.form_terms(j.forms[0])).collect();
            jobs.par_iter()
                .zip(forms)
                .with_max_len(1)
                .map(|(job, form)| {
                    let mut piece = Detached::new(form, fork()?)?;
                    Some(march_form(&mut piece, &job.input))
                })
                .collect()
        }
        _ => jobs.iter().map(|_| None).collect(),
    };
    let mut parts = Vec::new();
    for (job, first) in jobs.iter().zip(&mut first) {
        let input = MarchInput {
            max_triangles: limit,
            ..job.input.clone()
        };
        let mut tried: Result<march::Marched, CreaseError> = Err(CreaseError::Chain { at: job.at });
        for (n, &form) in job.forms.iter().enumerate() {
            let ahead = if n == 0 { first.take() } else { None };
            let marched = match ahead {
                Some(Ok(m)) if limit.is_none_or(|l| m.peak_triangles <= l) => Ok(m),
                Some(Err(e)) if limit == job.input.max_triangles => Err(e),
                ahead => {
                    // Made with a larger limit than this piece has: its count taken back.
                    if let (Some(Ok(m)), Some(c)) = (&ahead, counter) {
                        c.fetch_sub(m.mesh.triangles.len() as u64, Ordering::Relaxed);
                    }
                    let fresh = branches
                        .and_then(|fork| fork())
                        .and_then(|b| Detached::new(t.c.form_terms(form), b));
                    match fresh {
                        Some(mut piece) => march_form(&mut piece, &input),
                        None => march_form(&mut t.c.piece(form), &input),
                    }
                }
            };
            tried = marched
                .map_err(|source| CreaseError::March { at: job.at, source })
                .and_then(|marched| {
                    check_piece(t.c, form, &marched.mesh, region)?;
                    Ok(marched)
                });
            if tried.is_ok() {
                break;
            }
        }
        let marched = tried?;
        out.max_chord_error = out.max_chord_error.max(marched.max_chord_error);
        // Triangles held below the angle by a crease vertex are counted again once the
        // crease vertices have slid (`slide::held`).
        let held = marched.held.filter(|_| slides).map(|h| h.to_string());
        out.warnings.extend(
            marched
                .warnings
                .into_iter()
                .filter(|w| Some(w) != held.as_ref()),
        );
        limit = limit.map(|l| l.saturating_sub(marched.mesh.triangles.len() as u64).max(1));
        out.pieces += 1;
        parts.push(marched.mesh);
    }
    if let Some(e) = unchained {
        return Err(e);
    }
    // Each piece's triangles were checked for crossings by its own march: the joined check
    // looks only across pieces, at the components and where the slide moved a vertex.
    let mut groups: Vec<u32> = Vec::new();
    for (k, part) in parts.iter().enumerate() {
        groups.extend(std::iter::repeat_n(k as u32, part.triangles.len()));
    }
    let pieces = merge(&parts);
    let marching = Marching {
        max_triangles: limit,
        ..marching
    };
    // The search bounds f over its cells through the spine pruned there (the forms near a
    // cell, not the whole tape); its marches run on `fork`'s tapes, or on the spine's f.
    let piece_triangles = pieces.triangles.len();
    let found = components::mesh_components_beside(
        &mut Whole(t.c),
        fork,
        marching,
        bbox,
        march_settings,
        search,
        pieces,
        progress,
    )?;
    check_smooth(t.c, &found.mesh, piece_triangles, settings.tie * step)?;
    out.max_chord_error = out.max_chord_error.max(found.max_chord_error);
    out.warnings
        .extend(found.warnings.iter().map(ToString::to_string));
    out.warnings.extend(found.march_warnings);
    out.smooth_components = found.components;
    // The search's mesh begins with the pieces' (merged above: each position once, normals
    // summed from +0, sides sorted); merged again it would be the same bits, so only
    // components found beside them are merged in.
    out.mesh = if found.mesh.triangles.len() == piece_triangles {
        found.mesh
    } else {
        merge(&[found.mesh])
    };
    groups.resize(out.mesh.triangles.len(), ANY_GROUP);
    // The crease vertices slid along their creases (`slide`), where the quality stage runs:
    // the mesh as marched is kept where the slid one fails the joined check.
    let mut checked = false;
    if slides {
        let (mesh, polygons) = (out.mesh.clone(), out.polygons.clone());
        let limits = slide::Limits {
            tolerance,
            on_surface: settings.region * step,
            step,
            bbox,
        };
        let moves = slide::slide(t.c, &mut out.mesh, &mut out.polygons, &traced, &limits);
        if trace {
            eprintln!("creases: {moves} crease vertex moves");
        }
        if moves > 0 {
            // The triangles around a moved vertex are checked against every other.
            let moved: Vec<bool> = (out.mesh.vertices.iter().zip(&mesh.vertices))
                .map(|(&now, &was)| bits(now) != bits(was))
                .collect();
            let mut slid = groups.clone();
            for (g, tri) in slid.iter_mut().zip(&out.mesh.triangles) {
                if tri.iter().any(|&v| moved[v as usize]) {
                    *g = ANY_GROUP;
                }
            }
            checked = check_joined(&out.mesh, &slid).is_ok();
            if !checked {
                if trace {
                    eprintln!("creases: the slid mesh fails the joined check; kept as marched");
                }
                (out.mesh, out.polygons) = (mesh, polygons);
            }
        }
    }
    if !checked {
        check_joined(&out.mesh, &groups)?;
    }
    if slides {
        let target = march_settings.quality_angle;
        let held = slide::held(&out.mesh, piece_triangles, &out.polygons, bbox, target);
        out.warnings.extend(held.map(|h| h.to_string()));
    }
    Ok(out)
}

/// Every vertex of face `form`'s mesh lies where the face is chosen: |f − L|/|∇L| ≤ `region`.
fn check_piece(c: &mut Creased, form: usize, mesh: &Mesh, region: f64) -> Result<(), CreaseError> {
    for &v in &mesh.vertices {
        let l = c.form(form, v);
        let f = c.whole(v);
        let distance = (f.value - l.value).abs() / l.gradient.length();
        if distance.is_nan() || distance > region {
            return Err(CreaseError::LeftPiece { at: v, distance });
        }
    }
    Ok(())
}

/// Checks a mesh of a creased surface made without the crease search (a `start` without a
/// box): every triangle lies on one smooth piece, else the crease it spans is an error.
pub fn check_one_piece_each(
    c: &mut Creased,
    mesh: &Mesh,
    step: f64,
    settings: &CreaseSettings,
) -> Result<(), CreaseError> {
    check_smooth(c, mesh, 0, settings.tie * step)
}
