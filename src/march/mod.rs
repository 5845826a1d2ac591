//! The marching method of E. Hartmann (paper Sect. 2): an advancing front of near-equilateral
//! triangles over a surface it sees only through the `Surface` oracle and surfacepoint.
//!
//! Input: a step δ, a start (a point near the surface, or a first front polygon), optional
//! bounding polygons and a box. Output: a `Mesh` whose triangles are oriented so that their
//! normals agree with ∇f, or a `MarchError` that says why and where it stopped.
//!
//! Orientation rule for polygons (front and bounds): walking along the polygon, seen from the
//! side ∇f points to, the area to be meshed lies on the LEFT — the polygon runs the way the
//! boundary edges of the resulting triangles run. Polygon vertices become mesh vertices with
//! bit-identical coordinates, first the front's, then each bound's in the order given;
//! vertices with bit-identical coordinates in several polygons are one mesh vertex.
//!
//! After the march the quality stage (`improve`) flips edges to the restricted Delaunay
//! condition, smooths free vertices on the surface and inserts off-centres where a triangle
//! stays below `MarchSettings::quality_angle`, keeping the topology and polygon vertices; the
//! verification then checks the improved mesh. [`improve_patch`] gives a part of a finished
//! mesh the stage and the verification again (the seams of joined slabs, whose polygon
//! vertices are free once the slabs are one mesh).
//!
//! Edges follow a local step h(p) ≤ δ from the surface's curvature and thickness
//! (`survey::sizing`) unless the input asks for the paper's uniform step. Every finished mesh
//! is verified against the surface (`verify`); one that fails is re-marched with the local
//! step capped near the failures, a bounded number of times, and then refused: a wrong mesh
//! is never returned.
//!
//! `SURFC_TRACE=1` in the environment prints a step-by-step trace to stderr.

pub mod angle;
pub mod guard;
pub mod hash;
mod improve;
mod marcher;
pub mod ring;
pub mod settings;
pub mod verify;

use glam::DVec3;

pub(crate) use marcher::changes_sign;
pub use ring::{FrontId, NodeId, PointId};
pub use settings::MarchSettings;

use crate::mesh::Mesh;
use crate::mesh::edges::Edges;
use crate::mesh::progress::Tally;
use crate::solve::SurfacePointError;
use crate::surface::{Fork, Surface};
use crate::survey::sizing::{Cap, PresetCaps, Sizing};
use verify::Flaw;

/// Where the triangulation starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Start {
    /// A point near the surface: the paper's Step 0 puts a hexagon around its surface point.
    Point(DVec3),
    /// A closed polygon on the surface (last vertex not repeated) as the first actual front;
    /// the area to its left (seen from where ∇f points) is meshed.
    Front(Vec<DVec3>),
}

/// What to triangulate.
#[derive(Clone, Debug, PartialEq)]
pub struct MarchInput {
    /// The step δ, ≈ the edge length of the triangles.
    pub step: f64,
    pub start: Start,
    /// Bounding front polygons (each closed, on the surface, area to mesh on its left).
    pub bounds: Vec<Vec<DVec3>>,
    /// A global bounding box (lo, hi): the mesh stops at its faces.
    pub bbox: Option<(DVec3, DVec3)>,
    /// Overrides the default limit: `MarchSettings::max_triangles`, or with a box what the
    /// box can hold (`guard::default_limit`).
    pub max_triangles: Option<u64>,
    /// The largest chord error allowed (model units); `None`: `MarchSettings::tolerance`·δ.
    pub tolerance: Option<f64>,
    /// The paper's fixed step everywhere (no local step, no refinement): a mesh that fails
    /// its verification, a chord error above the tolerance included, is refused.
    pub uniform: bool,
    /// About how many triangles the march will make, where the caller knows (a slab, from
    /// the survey's area): the marcher's per-point and per-node vectors are reserved for
    /// them at the start. No output depends on it. (Grown by doubling instead, each slab's
    /// vectors were copied at every growth: about 1 % of the fine sphere's run; its page
    /// faults on one thread 48.6 k without the hint, 43.4 k with it.)
    pub expected_triangles: Option<u64>,
}

impl MarchInput {
    /// A closed-surface run from a start point.
    pub fn from_point(step: f64, start: DVec3) -> Self {
        MarchInput {
            step,
            start: Start::Point(start),
            bounds: Vec::new(),
            bbox: None,
            max_triangles: None,
            tolerance: None,
            uniform: false,
            expected_triangles: None,
        }
    }
}

/// A verified triangulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Marched {
    pub mesh: Mesh,
    /// The largest distance from a triangle's centroid or edge midpoint to the surface.
    pub max_chord_error: f64,
    /// What the user should know about a mesh that is right (a feature cut at the floor of
    /// the local step, a chord error above the tolerance with `uniform`).
    pub warnings: Vec<String>,
    /// The triangles left below the quality stage's angle with a corner it may not move,
    /// also among `warnings`: a caller that moves such corners (`pipeline::crease_net`'s
    /// slide along creases) counts them again.
    pub held: Option<Held>,
    /// How many times the mesh was re-marched with a finer local step near failures.
    pub refinements: u32,
    /// The most triangles the marcher made in one round (before the quality stage): what
    /// `MarchInput::max_triangles` was held against. A march with a larger limit whose peak
    /// stays within a smaller one made the same mesh as with the smaller limit.
    pub peak_triangles: u64,
}

/// Triangles below the quality stage's target angle with a corner on a polygon, a crease or
/// the box, which the stage may not move: a warning.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Held {
    pub count: usize,
    /// The smallest angle among them (degrees), and the centroid of its triangle.
    pub worst: f64,
    pub at: DVec3,
    /// The target angle (degrees).
    pub target: f64,
}

impl Held {
    /// Both sets of triangles: the counts added, the worst of the two.
    pub fn and(self, other: Held) -> Held {
        let worst = if other.worst < self.worst {
            other
        } else {
            self
        };
        Held {
            count: self.count + other.count,
            ..worst
        }
    }
}

impl std::fmt::Display for Held {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} triangle(s) with a corner on a polygon, a crease or the box stay below {:.1}°: the smallest angle is {:.1}° near {}",
            self.count, self.target, self.worst, self.at
        )
    }
}

/// Which input polygon an error refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PolygonRole {
    Front,
    /// Index into `MarchInput::bounds`.
    Bound(usize),
}

impl std::fmt::Display for PolygonRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PolygonRole::Front => write!(f, "the front polygon"),
            PolygonRole::Bound(i) => write!(f, "bound polygon {i}"),
        }
    }
}

/// Why a triangulation could not be completed. Input errors name the input; numerical ones
/// say where on the surface they happened.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MarchError {
    #[error("the step {step} is not a positive finite number")]
    InvalidStep { step: f64 },
    #[error("the box {lo} .. {hi} is empty or not finite")]
    InvalidBox { lo: DVec3, hi: DVec3 },
    #[error("no surface point found from the start {start}: {source}")]
    Start {
        start: DVec3,
        source: SurfacePointError,
    },
    #[error("the surface point {at} of the start lies outside the box")]
    StartOutsideBox { at: DVec3 },
    #[error(
        "f does not change sign across the surface at {at}, along its normal from a millionth to a hundredth of the step: it touches zero there without crossing it (a double root, as of a square or an `abs`), or it is singular there (a cusp or a crossing of two sheets closer than that)"
    )]
    NoSignChange { at: DVec3 },
    #[error("{polygon} has {len} vertices; a closed polygon needs at least 3")]
    PolygonTooShort { polygon: PolygonRole, len: usize },
    #[error(
        "{polygon}: the edge from vertex {index} at {at} is {length} long, far from the step {step} (allowed {min} .. {max})"
    )]
    PolygonSpacing {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
        length: f64,
        step: f64,
        min: f64,
        max: f64,
    },
    #[error("{polygon}: vertex {index} at {at} is {distance:e} off the surface")]
    PolygonOffSurface {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
        distance: f64,
    },
    #[error("{polygon}: the gradient at vertex {index} ({at}) is zero or not finite")]
    PolygonGradient {
        polygon: PolygonRole,
        index: usize,
        at: DVec3,
    },
    #[error("a new front point near {near} could not be put on the surface: {source}")]
    NewPoint {
        near: DVec3,
        source: SurfacePointError,
    },
    #[error("more than {limit} triangles (the front was last advanced at {at})")]
    TooManyTriangles { limit: u64, at: DVec3 },
    #[error(
        "the surface is unbounded here, add a box: after {triangles} triangles the mesh is {extent:.3e} across and still growing (the front was last advanced at {at})"
    )]
    Unbounded {
        at: DVec3,
        triangles: u64,
        /// The diagonal of the mesh's bounding box.
        extent: f64,
    },
    #[error(
        "the front keeps overlapping itself near {at}: the step is too coarse for the surface there ({triangles} triangles in {lo} .. {hi}, more than that region holds at this step)"
    )]
    Overlapping {
        at: DVec3,
        triangles: u64,
        lo: DVec3,
        hi: DVec3,
    },
    #[error(
        "the front stopped making progress near {at} after {iterations} steps without a triangle"
    )]
    Stalled { at: DVec3, iterations: u64 },
    #[error(
        "the surface has a sharp edge near {at} (the direction of its gradient jumps by {degrees:.0}°) that the crease search does not see"
    )]
    HiddenCrease { at: DVec3, degrees: f64 },
    #[error("the tolerance {tolerance} is not a positive finite number")]
    InvalidTolerance { tolerance: f64 },
    /// With the uniform step and the default tolerance, a mesh whose chord error exceeds
    /// the tolerance is kept only if it covers the mesh the local step makes: this one
    /// leaves part of the surface out (a cap over a neck thinner than the step).
    #[error(
        "with the uniform step the mesh leaves part of the surface out: a point of it near {at} is {distance:.3e} from the mesh ({count} such point(s) of the surface meshed with the local step), where the chord error is {chord:.3e}; the step is too coarse for a feature there (a neck, a rim or a gap thinner than the step)"
    )]
    UniformMisses {
        at: DVec3,
        distance: f64,
        count: usize,
        chord: f64,
    },
    /// The same, where the meshes' topologies differ.
    #[error(
        "with the uniform step the mesh has Euler characteristic {uniform_euler} and {uniform_components} component(s), the surface meshed with the local step {local_euler} and {local_components}: the step is too coarse for a feature of the surface (its largest chord error {chord:.3e} is near {at})"
    )]
    UniformTopology {
        at: DVec3,
        chord: f64,
        uniform_euler: i64,
        uniform_components: usize,
        local_euler: i64,
        local_components: usize,
    },
    /// The surface could not be evaluated where the march needed it: a foot point of one of
    /// its `dist`s was not found (`Surface::fault`).
    #[error("the surface could not be evaluated at {at}: {reason}")]
    Fault { at: DVec3, reason: String },
    #[error(
        "the mesh is not the surface near {at}: {flaw} ({count} place(s)), still after {rounds} refinement(s) of the local step"
    )]
    Unverified {
        flaw: Flaw,
        at: DVec3,
        count: usize,
        rounds: u32,
    },
    /// A flaw that is a given polygon's, which no refinement mends (boxed: the largest).
    #[error("{0}")]
    CoarsePolygon(Box<CoarsePolygon>),
    #[error(
        "the mesh was not the surface near {at} ({flaw}), and re-marching it with a finer local step there failed (refinement {rounds}): {source}"
    )]
    Refining {
        /// The first flaw of the verification that asked for the re-march.
        flaw: Flaw,
        at: DVec3,
        rounds: u32,
        /// Why the re-march stopped.
        source: Box<MarchError>,
    },
}

/// A given polygon too coarse for the surface at the step: an edge whose own chord strays
/// from the surface, or too long for the local step at its ends, with the flaw beside it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "{polygon} is too coarse for the surface at this step: its edge near {at} is {length:.3e} long where the surface asks for a local step of {h:.3e}, and no finer local step changes a given polygon; the mesh is not the surface near {flaw_at}: {flaw} ({count} place(s))"
)]
pub struct CoarsePolygon {
    pub polygon: PolygonRole,
    /// The edge's midpoint.
    pub at: DVec3,
    pub length: f64,
    /// The smaller local step at the edge's ends.
    pub h: f64,
    pub flaw: Flaw,
    pub flaw_at: DVec3,
    /// The flaws of the mesh in all.
    pub count: usize,
}

/// Triangulates `surface` as `input` says (paper Sect. 2), verified (see [`march_verified`]).
pub fn march(
    surface: &mut dyn Surface,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Result<Mesh, MarchError> {
    march_verified(surface, None, input, settings, None).map(|m| m.mesh)
}

/// Triangulates `surface` with the local step, verifies the mesh against the surface, and
/// re-marches with the local step capped near the flaws until it passes or
/// `MarchSettings::refine_rounds` are spent; then the first flaw is the error.
///
/// `fork`, where given, makes fresh oracles of `surface` for the quality stage's centroid
/// round, whose blocks run on the rayon pool (`improve::Stage::centroid_round`); without it
/// the blocks run one after another on `surface`. `progress`, where given, is a count that
/// this march adds its triangles to as it goes, for a progress bar on another thread (an
/// atomic add per batch of triangles, `mesh::progress::Tally`; marches on several threads
/// may share it): a march made again takes back what the one before added, the result's
/// triangles stay added, and a failed march takes back all it added.
pub fn march_verified(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    input: &MarchInput,
    settings: &MarchSettings,
    progress: Option<&std::sync::atomic::AtomicU64>,
) -> Result<Marched, MarchError> {
    march_verified_capped(
        surface,
        fork,
        input,
        settings,
        progress,
        &PresetCaps::none(),
    )
}

/// A part of a finished, verified mesh to go through the quality stage again: where slabs
/// marched apart were joined (`pipeline::pieces`), the cut polygons' vertices, which neither
/// slab could move, are free here.
pub struct Patch {
    /// Its vertices below `fixed` stay where they are (the patch's rim, points on the box);
    /// every open edge of the patch lies between two of them.
    pub mesh: Mesh,
    pub fixed: usize,
    /// Per vertex: the local step there.
    pub h: Vec<f64>,
}

/// The quality stage (towards `settings`' aim, in `input`'s box) over `patch`, then the
/// verification of what it made: the improved patch — its first `fixed` vertices the same,
/// bit for bit, in the same order; the others moved, and some added or removed — if the
/// verification finds no flaw and no chord error above the tolerance, else None (the patch
/// as it was is the caller's to keep). Crossings between the patch and the rest of the mesh
/// are the caller's to check.
pub fn improve_patch(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    patch: Patch,
    input: &MarchInput,
    settings: &MarchSettings,
) -> Option<Mesh> {
    let tolerance = input.tolerance.unwrap_or(settings.tolerance * input.step);
    let n = patch.mesh.vertices.len();
    // The patch's open edges, each between two fixed vertices: the verification allows them
    // as it allows a given polygon's.
    let mut polygon_edges: Vec<[u32; 2]> = Edges::new(n, &patch.mesh.triangles)
        .runs()
        .filter(|(_, _, run)| run.len() == 1)
        .map(|(a, b, _)| [a, b])
        .collect();
    polygon_edges.sort_unstable();
    let mut m = marcher::Triangulation {
        mesh: patch.mesh,
        border: vec![false; n],
        fixed: patch.fixed,
        polygon_edges,
        h: patch.h,
        wanted: Vec::new(),
        floored: None,
    };
    improve(surface, fork, &mut m, input, settings, tolerance);
    let verdict = verify::verify(surface, &m, tolerance, input.step, &settings.surface_point);
    (verdict.wrong.is_empty() && verdict.coarse.is_empty() && surface.fault().is_none())
        .then_some(m.mesh)
}

/// [`march_verified`] with the local step bounded by `caps` from the start (graded from
/// each): what the caller knows of the surface that the marcher's probes do not see, such
/// as the width of a narrow face between two creases (`pipeline::crease_net`).
pub fn march_verified_capped(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    input: &MarchInput,
    settings: &MarchSettings,
    progress: Option<&std::sync::atomic::AtomicU64>,
    caps: &PresetCaps,
) -> Result<Marched, MarchError> {
    let tally = Tally::new(progress);
    let result = verified(surface, fork, input, settings, &tally, caps);
    match &result {
        Ok(m) => tally.set(m.mesh.triangles.len() as u64),
        Err(_) => tally.retract(),
    }
    result
}

/// [`march_verified`], its share of the count in `tally`.
fn verified(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    input: &MarchInput,
    settings: &MarchSettings,
    tally: &Tally<'_>,
    caps: &PresetCaps,
) -> Result<Marched, MarchError> {
    let step = input.step;
    if !(step.is_finite() && step > 0.0) {
        return Err(MarchError::InvalidStep { step });
    }
    let tolerance = input.tolerance.unwrap_or(settings.tolerance * step);
    if !(tolerance.is_finite() && tolerance > 0.0) {
        return Err(MarchError::InvalidTolerance { tolerance });
    }
    let mut sizing = Sizing::of_mesh(step, tolerance, input.uniform, settings.sizing);
    if !caps.is_empty() && !input.uniform {
        sizing.add_preset(caps);
    }
    let mut round = 0;
    let mut peak_triangles = 0;
    // The first flaw that asked for the current re-march: a re-march that fails says what it
    // was refining for (else a runaway re-march reads as a surface too large for its step).
    let mut refining: Option<verify::Found> = None;
    // A right mesh with triangles the quality stage left below its angle, while a finer
    // local step there is tried: returned if the finer march fails or is no better.
    let mut fallback: Option<(usize, Marched)> = None;
    // A march that was not graded both ways is made again with caps that grade it
    // (`regrading_caps`), up to `regrade_rounds` times: a march too coarse to see a neck
    // learns of it only from the next. While such a march is tried, the sizing without its
    // caps, to go back to if it fails (at the triangle limit, say): the march before is then
    // verified as it would have been.
    let mut regrades = 0;
    let mut ungraded: Option<Sizing> = None;
    let mut regrade_failed: Option<MarchError> = None;
    loop {
        // Whatever stopped a march that met a fault (a NaN from a `dist` without a foot
        // point, which surfacepoint reports as f not finite there), the fault is the reason.
        let run = marcher::run(surface, input, settings, &sizing, tally).map_err(|e| match surface
            .fault()
        {
            Some(fault) => MarchError::Fault {
                at: fault.at,
                reason: fault.reason,
            },
            None => e,
        });
        if let Err(e @ MarchError::Fault { .. }) = run {
            return Err(e);
        }
        let mut marched = match run {
            Ok(m) => m,
            Err(e) if ungraded.is_some() => {
                sizing = ungraded.take().expect("checked");
                regrade_failed = Some(e);
                regrades = settings.sizing.regrade_rounds;
                continue;
            }
            Err(source) => {
                if let Some((_, mut m)) = fallback {
                    // The finer march failed, maybe at the triangle limit: the mesh is not
                    // what a larger limit would give.
                    if let MarchError::TooManyTriangles { limit, .. } = source {
                        m.peak_triangles = m.peak_triangles.max(limit.saturating_add(1));
                    }
                    return Ok(m);
                }
                return Err(match refining {
                    Some(first) => MarchError::Refining {
                        flaw: first.flaw,
                        at: first.at,
                        rounds: round,
                        source: Box::new(source),
                    },
                    None => source,
                });
            }
        };
        peak_triangles = peak_triangles.max(marched.mesh.triangles.len() as u64);
        ungraded = None;
        let wanted = std::mem::take(&mut marched.wanted);
        if regrades < settings.sizing.regrade_rounds {
            regrades += 1;
            let caps = sizing.regrading_caps(&marched.mesh.vertices, &wanted, &marched.h);
            if !caps.is_empty() {
                ungraded = Some(sizing.clone());
                sizing.add_caps(caps);
                continue;
            }
        }
        let Leftovers { poor, held } =
            improve(surface, fork, &mut marched, input, settings, tolerance);
        let verdict = verify::verify(surface, &marched, tolerance, step, &settings.surface_point);
        if let Some(fault) = surface.fault() {
            return Err(MarchError::Fault {
                at: fault.at,
                reason: fault.reason,
            });
        }
        // A chord error above the tolerance may be a wrong mesh (a cap over a neck thinner
        // than the step): refined like one. With the uniform step (which cannot refine) and
        // the default tolerance, the user asked for the paper's fixed step, not for that
        // tolerance: a mesh whose only flaw is its chord error is kept, with a warning that
        // gives the figure, once it agrees with the local step's mesh of the same block
        // (`uniform_against_local`: the chord error may be the only sign of a cap over a
        // neck); a `tolerance` the user set is enforced (refused as a flaw). Crossings and
        // wrong topology refuse either way.
        let mut flaws = verdict.wrong.clone();
        let coarse_kept = input.uniform
            && input.tolerance.is_none()
            && verdict.wrong.is_empty()
            && !verdict.coarse.is_empty();
        if !coarse_kept {
            flaws.extend(&verdict.coarse);
        }
        // A flaw that is a given polygon's (its own edge's chord error, or beside an edge too
        // long for the local step there) is refused now, not refined: no refinement changes
        // a given polygon, and each round would re-march a larger wrong mesh.
        let limit = 2.0 * settings.near_distance;
        if let Some((edge, flaw)) = verify::coarse_polygon_edge(&marched, &flaws, limit) {
            if let Some((_, m)) = fallback {
                return Ok(m);
            }
            return Err(MarchError::CoarsePolygon(Box::new(CoarsePolygon {
                polygon: polygon_of(input, edge.ends[0]),
                at: edge.mid,
                length: edge.length,
                h: edge.h,
                flaw: flaw.flaw,
                flaw_at: flaw.at,
                count: flaws.len(),
            })));
        }
        let may_refine = !input.uniform && round < settings.refine_rounds;
        if flaws.is_empty() {
            let mut warnings = Vec::new();
            if coarse_kept {
                match uniform_against_local(surface, fork, input, settings, &marched, &verdict) {
                    Ok(()) => warnings.push(coarse_warning(&verdict, tolerance, step)),
                    Err(e) => {
                        if let Some((_, m)) = fallback {
                            return Ok(m);
                        }
                        return Err(e);
                    }
                }
            }
            if let Some(at) = marched.floored {
                warnings.push(format!(
                    "a feature near {at} is smaller than the local step's floor {:e} (step/{}): meshed at the floor",
                    sizing.floor(),
                    (1.0 / settings.sizing.min_size).round()
                ));
            }
            if let Some(e) = &regrade_failed {
                warnings.push(format!(
                    "the march with its local step graded towards fine places too failed ({e}): the mesh's step is graded away from them only, and its triangles are less even where it falls fast"
                ));
            }
            if let Some(&(at, _)) = poor.first() {
                warnings.push(format!(
                    "{} triangle(s) with no given corner stay below {:.1}° near {at} after {round} refinement(s) of the local step",
                    poor.len(),
                    settings.quality_angle.to_degrees()
                ));
            }
            let held = held.map(|(count, worst, at)| Held {
                count,
                worst,
                at,
                target: settings.quality_angle.to_degrees(),
            });
            if let Some(held) = held {
                warnings.push(held.to_string());
            }
            let right = Marched {
                mesh: marched.mesh,
                max_chord_error: verdict.max_chord_error,
                warnings,
                held,
                refinements: round,
                peak_triangles,
            };
            // The fewer such triangles, the better. A refinement that did not lower their
            // number ends the search (a place no step mends, such as a singular point,
            // costs one re-march, not `refine_rounds`).
            let (best, improved) = match fallback.take() {
                Some((n, m)) if n <= poor.len() => ((n, m), false),
                _ => ((poor.len(), right), true),
            };
            if best.0 == 0 || !may_refine || !improved {
                return Ok(best.1);
            }
            fallback = Some(best);
        } else if !may_refine {
            if let Some((_, m)) = fallback {
                return Ok(m);
            }
            let first = flaws[0];
            return Err(MarchError::Unverified {
                flaw: first.flaw,
                at: first.at,
                count: flaws.len(),
                rounds: round,
            });
        }
        if crate::trace::enabled() {
            match flaws.first() {
                Some(first) => eprintln!(
                    "march: verification round {round}: {} flaw(s), first {} at {}; refining",
                    flaws.len(),
                    first.flaw,
                    first.at
                ),
                None => eprintln!(
                    "march: verification round {round}: right, but {} triangle(s) below the quality angle, first at {}; refining",
                    poor.len(),
                    poor[0].0
                ),
            }
        }
        // Triangles the quality stage could not mend with no given corner to excuse them
        // were made with too coarse a step for it (a neck's saddle at a step three times
        // its width): refined like flaws.
        let caps = flaws
            .iter()
            .map(|f| (f.at, f.h))
            .chain(poor.iter().copied())
            .map(|(at, h)| Cap {
                at,
                size: settings.refine_factor * h,
            });
        sizing.add_caps(caps);
        if let Some(&first) = flaws.first() {
            refining = Some(first);
        }
        round += 1;
    }
}

/// A vertex of the local step's mesh this many chord errors of the uniform mesh (plus
/// `UNIFORM_COVER_STEP` steps) from it is a part of the surface the uniform mesh left out.
/// A right mesh is within about one chord error of every surface point (a chord's sagitta);
/// the factor leaves room for the chord error between the measured centroids and midpoints.
const UNIFORM_COVER_CHORDS: f64 = 2.0;
const UNIFORM_COVER_STEP: f64 = 0.1;

/// Where the uniform step's mesh (`marched`, verified but for its chord error `verdict`)
/// is kept with a warning: the surface is meshed again with the local step, which refines
/// where the uniform step is too coarse, and the two must agree — the same Euler
/// characteristic, components and boundary loops, and every vertex of the local step's
/// mesh within `UNIFORM_COVER_CHORDS` chord errors of the uniform one. A chord error can be
/// the only sign of a wrong mesh: the dumbbell with a neck 0.05 wide at the uniform step 0.12
/// meshes one bulb capped at the neck, watertight with χ = 2. Err says how they differ; a
/// local-step march that fails refuses the uniform mesh with its first flaw, as before.
fn uniform_against_local(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    input: &MarchInput,
    settings: &MarchSettings,
    marched: &marcher::Triangulation,
    verdict: &verify::Verdict,
) -> Result<(), MarchError> {
    let step = input.step;
    let Some(worst) = worst_chord(verdict) else {
        return Ok(());
    };
    let local_input = MarchInput {
        uniform: false,
        ..input.clone()
    };
    let Ok(local) = march_verified(surface, fork, &local_input, settings, None) else {
        return Err(MarchError::Unverified {
            flaw: worst.flaw,
            at: worst.at,
            count: verdict.coarse.len(),
            rounds: 0,
        });
    };
    let at = worst.at;
    let chord = verdict.max_chord_error;
    let (mine, theirs) = (
        crate::mesh::topology::topology(&marched.mesh),
        crate::mesh::topology::topology(&local.mesh),
    );
    if (
        mine.euler_characteristic,
        mine.components,
        mine.boundary_loops.len(),
    ) != (
        theirs.euler_characteristic,
        theirs.components,
        theirs.boundary_loops.len(),
    ) {
        return Err(MarchError::UniformTopology {
            at,
            chord,
            uniform_euler: mine.euler_characteristic,
            uniform_components: mine.components,
            local_euler: theirs.euler_characteristic,
            local_components: theirs.components,
        });
    }
    let reach = UNIFORM_COVER_CHORDS * chord + UNIFORM_COVER_STEP * step;
    if let Some((p, distance, count)) = verify::uncovered(&local.mesh, &marched.mesh, reach) {
        return Err(MarchError::UniformMisses {
            at: p,
            distance,
            count,
            chord,
        });
    }
    Ok(())
}

/// The place of the largest chord error above the tolerance (the first of equals).
fn worst_chord(verdict: &verify::Verdict) -> Option<verify::Found> {
    let error = |f: &verify::Found| match f.flaw {
        Flaw::Chord { error, .. } => error,
        _ => f64::NEG_INFINITY,
    };
    verdict
        .coarse
        .iter()
        .copied()
        .fold(None, |best: Option<verify::Found>, f| match best {
            Some(b) if error(&b) >= error(&f) => Some(b),
            _ => Some(f),
        })
}

/// The warning of a mesh with the uniform step kept although its chord error exceeds the
/// default tolerance: the largest error, its place and both as multiples of the step.
fn coarse_warning(verdict: &verify::Verdict, tolerance: f64, step: f64) -> String {
    let error = verdict.max_chord_error;
    let at = worst_chord(verdict).map_or(DVec3::NAN, |w| w.at);
    format!(
        "the chord error {error:.3e} ({:.2}·step) near {at} is above the default tolerance {tolerance:.3e} ({:.2}·step) at {} place(s): `uniform: true` keeps the fixed step; set `tolerance` to have such a mesh refused, or leave out `uniform` to let the local step refine it",
        error / step,
        tolerance / step,
        verdict.coarse.len()
    )
}

/// The given polygon with a vertex at `p` (bit for bit, as the marcher keeps them): the
/// front polygon, else the first bound that has it.
fn polygon_of(input: &MarchInput, p: DVec3) -> PolygonRole {
    let has = |poly: &[DVec3]| {
        poly.iter()
            .any(|q| q.to_array().map(f64::to_bits) == p.to_array().map(f64::to_bits))
    };
    match &input.start {
        Start::Front(front) if has(front) => PolygonRole::Front,
        _ => input
            .bounds
            .iter()
            .position(|b| has(b))
            .map_or(PolygonRole::Front, PolygonRole::Bound),
    }
}

/// The triangles the quality stage left below its angle.
#[derive(Default)]
struct Leftovers {
    /// Those with no given corner, as (centroid, local step): refined like flaws.
    poor: Vec<(DVec3, f64)>,
    /// Those with a corner the stage may not move (on a polygon, a crease or the box): how
    /// many, and the worst as (smallest angle in degrees, centroid). A warning.
    held: Option<(usize, f64, DVec3)>,
}

/// The quality stage (`improve/`) over a finished triangulation; what it did goes to
/// `SURFC_TRACE`. Returns the triangles it left below its angle.
fn improve(
    surface: &mut dyn Surface,
    fork: Option<&Fork<'_>>,
    m: &mut marcher::Triangulation,
    input: &MarchInput,
    settings: &MarchSettings,
    tolerance: f64,
) -> Leftovers {
    if settings.quality_angle <= 0.0 {
        return Leftovers::default();
    }
    let limits = improve::Limits {
        angle: settings.quality_angle.min(std::f64::consts::FRAC_PI_3),
        rounds: settings.quality_rounds,
        insert_fraction: settings.quality_insert,
        tolerance,
        ratio: settings.quality_ratio,
    };
    let (step, sp_tol) = (input.step, settings.surface_point);
    let mut project = |s: &mut dyn Surface, q: DVec3| {
        crate::solve::surface_point_and_normal(s, q, step, &sp_tol).ok()
    };
    let trace = crate::trace::enabled();
    // For the trace only: a whole-mesh scan the stage itself does not need.
    let below_before = trace.then(|| {
        let sin_bad = limits.angle.sin();
        let vs = &m.mesh.vertices;
        let corners = |t: &[u32; 3]| t.map(|v| vs[v as usize]);
        m.mesh
            .triangles
            .iter()
            .filter(|t| {
                let [a, b, c] = corners(t);
                improve::min_sin(a, b, c) < sin_bad
            })
            .count()
    });
    let started = std::time::Instant::now();
    let report = improve::Stage::new(
        &mut m.mesh.vertices,
        &mut m.mesh.normals,
        &mut m.mesh.triangles,
        &mut m.border,
        &mut m.h,
        m.fixed,
        input.bbox,
    )
    .run(&limits, surface, fork, &mut project);
    if report.collapsed > 0 {
        m.drop_unused();
    }
    if let Some(below_before) = below_before {
        eprintln!(
            "march: quality: {} triangle(s) below {:.1}° before, {} after; {} flip(s), {} move(s), {} inserted vertex(es), {} removed in {} round(s) ({:.3} s); mean radius ratio {:.4}, then {} centroid and {} ODT round(s) of smoothing with {} move(s) ({:.3} s) and {} round(s) of the ratios' phase: {:.4}; {:.3} s in all; stopped: {}{}",
            below_before,
            limits.angle.to_degrees(),
            report.below_after,
            report.flips,
            report.moves,
            report.inserted,
            report.collapsed,
            report.rounds,
            report.rounds_seconds,
            report.ratio_after_rounds,
            report.centroid_rounds,
            report.odt_rounds,
            report.smoothing_moves,
            report.smoothing_seconds,
            report.polish_rounds,
            report.ratio_after,
            started.elapsed().as_secs_f64(),
            report.stop,
            if report.above_default_undone {
                "; the phases above the default aim made a crossing: undone"
            } else {
                ""
            }
        );
    }
    Leftovers {
        held: report.worst_held.map(|(sin, at)| {
            (
                report.below_after - report.poor.len(),
                sin.asin().to_degrees(),
                at,
            )
        }),
        poor: report.poor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::quality;
    use crate::testing::Plane;

    /// A patch of the plane: an 8 × 8 lattice of unit triangles whose inner vertices are
    /// shaken by up to 0.2, its rim (the lattice's border) fixed and first.
    fn shaken_patch() -> Patch {
        let n = 8;
        let rim = |i: usize, j: usize| i == 0 || j == 0 || i == n - 1 || j == n - 1;
        let cells: Vec<(usize, usize)> = (0..n).flat_map(|j| (0..n).map(move |i| (i, j))).collect();
        let order: Vec<(usize, usize)> = cells
            .iter()
            .filter(|&&(i, j)| rim(i, j))
            .chain(cells.iter().filter(|&&(i, j)| !rim(i, j)))
            .copied()
            .collect();
        let index = |i: usize, j: usize| order.iter().position(|&c| c == (i, j)).unwrap() as u32;
        let mut draw = crate::testing::uniform(41);
        let vertices: Vec<DVec3> = order
            .iter()
            .map(|&(i, j)| {
                let p = DVec3::new(
                    i as f64 + 0.5 * (j % 2) as f64,
                    j as f64 * 0.75f64.sqrt(),
                    0.0,
                );
                if rim(i, j) {
                    p
                } else {
                    p + 0.2 * DVec3::new(2.0 * draw() - 1.0, 2.0 * draw() - 1.0, 0.0)
                }
            })
            .collect();
        let mut triangles = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let [a, b, c, d] = [
                    index(i, j),
                    index(i + 1, j),
                    index(i, j + 1),
                    index(i + 1, j + 1),
                ];
                if j % 2 == 0 {
                    triangles.extend([[a, b, c], [b, d, c]]);
                } else {
                    triangles.extend([[a, b, d], [a, d, c]]);
                }
            }
        }
        let fixed = order.iter().filter(|&&(i, j)| rim(i, j)).count();
        Patch {
            mesh: Mesh {
                normals: vec![DVec3::Z; vertices.len()],
                vertices,
                triangles,
                sides: Vec::new(),
            },
            fixed,
            h: vec![1.0; n * n],
        }
    }

    fn round() -> MarchSettings {
        MarchSettings {
            quality_ratio: 1.0,
            ..MarchSettings::default()
        }
    }

    #[test]
    fn a_patch_is_polished_with_its_rim_kept_bit_for_bit() {
        let patch = shaken_patch();
        let (before, rim) = (
            quality::quality(&patch.mesh).radius_ratio_mean,
            patch.mesh.vertices[..patch.fixed].to_vec(),
        );
        let input = MarchInput::from_point(1.0, DVec3::ZERO);
        let polished = improve_patch(&mut Plane, None, patch, &input, &round()).expect("verified");
        let after = quality::quality(&polished).radius_ratio_mean;
        assert!(after > before + 0.01, "{before} → {after}");
        assert_eq!(&polished.vertices[..rim.len()], &rim[..]);
        assert!(polished.vertices.iter().all(|v| v.z == 0.0));
    }

    /// Two rim vertices swapped: triangles along the rim fold over, which no move of the free
    /// vertices mends; the verification refuses the patch.
    #[test]
    fn a_patch_left_folded_is_refused() {
        let mut patch = shaken_patch();
        patch.mesh.vertices.swap(1, 2);
        let input = MarchInput::from_point(1.0, DVec3::ZERO);
        assert!(improve_patch(&mut Plane, None, patch, &input, &round()).is_none());
    }
}
