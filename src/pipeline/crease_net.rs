//! Creases (docs/creases.md; the paper's coherent nets, Sects. 3.9 and 3.11, found
//! automatically): a surface whose spine (`survey::spine`) switches between smooth forms is
//! meshed as one net of smooth pieces that share their crease polygons bit for bit.
//!
//! 1. Seeds: an octree over the box keeps the cells where f's interval and the intervals of at
//!    least two forms hold 0; in each leaf, Newton from the centre onto every such pair of forms
//!    gives a crease point when both forms are chosen there (f = 0).
//! 2. Tracing: from a seed not on a crease traced already, both ways along ∇Lᵢ × ∇Lⱼ in
//!    short steps, each point corrected onto both forms, until the curve closes or a third
//!    form is chosen: there the corner, where the three forms are zero, is solved by Newton.
//! 3. Polygons: each crease is resampled at the local step of both pieces (corners kept), and
//!    given to each of its two pieces walked so that the piece lies on its left.
//! 4. Pieces: every form's polygons are chained at the corners into loops and marched on the
//!    form as front and bounds (`march::march_verified`), so the pieces share the crease
//!    vertices and the whole is watertight. Every vertex of a piece must lie where its form is
//!    chosen (f = Lᵢ there): a vertex elsewhere means a crease was missed, and the mesh fails.
//! 5. Components that no crease touches are found and marched by the component search around
//!    the pieces; each of their triangles must lie on one form.
//!
//! Whatever cannot be traced — normals parallel along a crease (tangential contact), more than
//! three forms at a corner, a crease leaving the box — is an error at its place, never a mesh.
//! Deterministic: cells, pairs and creases follow fixed orders.

use std::collections::{HashMap, HashSet};

use glam::{DMat3, DVec3};

use super::components::{self, Marching, SearchError, SearchSettings};
use crate::march::{self, MarchError, MarchInput, MarchSettings, Start};
use crate::mesh::Mesh;
use crate::mesh::bits::BitsHash;
use crate::mesh::progress::Counts;
use crate::solve::SurfacePoint;
use crate::solve::curve::{ArcLength, min_norm_step};
use crate::solve::surfacepoint::tangent_frame;
use crate::surface::{Surface, ValueGrad};
use crate::survey::sizing::Sizing;
use crate::survey::spine::Creased;

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
    #[error(
        "{pieces} smooth pieces meet at {at}: a corner of more than three pieces cannot be meshed"
    )]
    SingularCorner { at: DVec3, pieces: usize },
    #[error("a crease ends near {at} without a corner where a third piece begins")]
    Lost { at: DVec3 },
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

/// A traced crease: forms (i, j), its points along ∇Lᵢ × ∇Lⱼ, and the corners at its ends.
struct Traced {
    forms: (usize, usize),
    points: Vec<DVec3>,
    /// Corner ids at the first and last point; None for a closed crease.
    ends: Option<(usize, usize)>,
}

/// Meshes `creased` (f itself is `whole`, with its interval bound) inside the box as the
/// module documentation says. With `fork` (fresh oracles of f), the smooth components are
/// marched on the rayon pool as `components::mesh_components_forked` says. `progress`, where
/// given, counts the triangles of the pieces and components as they are marched.
// The oracles, the marching, the box, three settings structs and the counts: each a
// caller's choice.
#[allow(clippy::too_many_arguments)]
pub fn mesh_creased(
    creased: &mut Creased,
    whole: &mut dyn Surface,
    fork: Option<&crate::surface::Fork<'_>>,
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
    let mut t = Tracer {
        c: creased,
        step,
        bbox,
        s: *settings,
        corners: Vec::new(),
        traced: Vec::new(),
        near: HashMap::new(),
    };
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
                if !t.c.adjacent(i, j) {
                    continue;
                }
                if let Some(seed) = t.seed(i, j, *cell_lo, *cell_hi)? {
                    if !t.covered(i, j, seed) {
                        let traced = t.trace(i, j, seed)?;
                        t.keep(traced, trace, seed);
                    }
                }
            }
        }
    }
    // Every corner ends three creases; one that no seed found (shorter than a cell's reach)
    // is traced from the corner.
    let mut next = 0;
    while next < t.corners.len() {
        let (at, [a, b, c]) = t.corners[next];
        for (i, j) in [(a, b), (a, c), (b, c)] {
            let known = t.traced.iter().any(|tr| {
                tr.forms == (i, j) || tr.forms == (j, i)
            } && tr.ends.is_some_and(|(s, e)| s == next || e == next));
            if !known && let Some(traced) = t.trace_from_corner(i, j, next)? {
                t.keep(traced, trace, at);
            }
        }
        next += 1;
    }
    let tolerance = marching
        .tolerance
        .unwrap_or(march_settings.tolerance * step);
    let sizing = Sizing::of_mesh(step, tolerance, marching.uniform, march_settings.sizing);
    let min_edge = march_settings.polygon_edge_min * step;
    let traced = std::mem::take(&mut t.traced);
    let mut polygons = Vec::with_capacity(traced.len());
    // Per form: its directed polygons with their end corners.
    let mut sides: Vec<Vec<Side>> = vec![Vec::new(); t.c.form_count()];
    for tr in &traced {
        let poly = t.resample(tr, &sizing, min_edge)?;
        let (i, j) = tr.forms;
        let left_i = t.left_side(i, j, &tr.points)?;
        let left_j = t.left_side(j, i, &tr.points)?;
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
            sides[form].push((p, ends));
        }
        polygons.push(poly);
    }
    let mut out = CreasedMesh {
        creases: traced.len(),
        corners: t.corners.len(),
        polygons,
        ..CreasedMesh::default()
    };
    let mut limit = marching.max_triangles;
    let piece_settings = MarchSettings {
        polygon_edge_min: march_settings.polygon_edge_min.min(settings.shortest),
        ..*march_settings
    };
    let mut parts = Vec::new();
    for (form, polys) in sides.into_iter().enumerate() {
        if polys.is_empty() {
            continue;
        }
        let loops = chain(polys, &t.corners)?;
        if trace {
            eprintln!("creases: piece of form {form}: {} loop(s)", loops.len());
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
        };
        let marched = march::march_verified(
            &mut t.c.piece(form),
            None,
            &input,
            &piece_settings,
            progress.map(|p| &p.triangles),
        )
        .map_err(|source| CreaseError::March { at, source })?;
        t.check_piece(form, &marched.mesh)?;
        out.max_chord_error = out.max_chord_error.max(marched.max_chord_error);
        out.warnings.extend(marched.warnings);
        limit = limit.map(|l| l.saturating_sub(marched.mesh.triangles.len() as u64).max(1));
        out.pieces += 1;
        parts.push(marched.mesh);
    }
    let pieces = merge(&parts);
    let marching = Marching {
        max_triangles: limit,
        ..marching
    };
    let found = components::mesh_components_beside(
        whole,
        fork,
        marching,
        bbox,
        march_settings,
        search,
        &pieces,
        progress,
    )?;
    check_smooth(
        t.c,
        &found.mesh,
        pieces.triangles.len(),
        settings.tie * step,
    )?;
    out.max_chord_error = out.max_chord_error.max(found.max_chord_error);
    out.warnings
        .extend(found.warnings.iter().map(ToString::to_string));
    out.warnings.extend(found.march_warnings);
    out.smooth_components = found.components;
    out.mesh = merge(&[found.mesh]);
    check_joined(&out.mesh)?;
    Ok(out)
}

/// The joined mesh is one surface: no edge in more than two triangles, none walked the same
/// way twice (two pieces on one side of a crease), every triangle facing where the normals
/// of its vertices point (a sliver closed across a thin piece does not), and no triangles
/// crossing (each march checks its own; this checks them across pieces and components).
fn check_joined(mesh: &Mesh) -> Result<(), CreaseError> {
    let centre = |t: usize| {
        mesh.triangles[t]
            .iter()
            .map(|&k| mesh.vertices[k as usize])
            .sum::<DVec3>()
            / 3.0
    };
    let mut uses: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for (n, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = t.map(|k| mesh.vertices[k as usize]);
        let normals: DVec3 = t.iter().map(|&k| mesh.normals[k as usize]).sum();
        let facing = (b - a).cross(c - a).dot(normals);
        if facing.is_nan() || facing <= 0.0 {
            return Err(CreaseError::Joined {
                at: centre(n),
                why: "a triangle faces against the surface's normal",
            });
        }
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let entry = uses.entry((a.min(b), a.max(b))).or_insert((0, 0));
            if a < b {
                entry.0 += 1;
            } else {
                entry.1 += 1;
            }
            if entry.0 > 1 || entry.1 > 1 {
                let why = if entry.0 + entry.1 > 2 {
                    "an edge is in more than two triangles"
                } else {
                    "two triangles on one side of an edge"
                };
                return Err(CreaseError::Joined { at: centre(n), why });
            }
        }
    }
    if let Some([a, _]) = crate::mesh::check::intersecting_pairs(mesh).first() {
        return Err(CreaseError::Joined {
            at: centre(*a as usize),
            why: "triangles of two pieces cross",
        });
    }
    Ok(())
}

/// How many traced points of a crease are probed for the side its pieces lie on.
const PROBES: usize = 8;

/// The meshes as one, vertices with bit-identical positions merged (the crease vertices the
/// pieces share), in order of first appearance.
/// A vertex shared by pieces gets the normalised sum of their normals, which agrees with
/// every triangle around it wherever the crease is not a fold (normals less than 180° apart),
/// and, where the pieces' normals there differ, each of them as a side (`Mesh::sides`, the
/// parts' own sides carried along), so that writers can keep the edge sharp.
pub(crate) fn merge(parts: &[Mesh]) -> Mesh {
    merge_at(parts, None).0
}

/// `merge`, where given `only` the positions that may be shared: then only those go into a
/// table (which stays in cache: the slabs of `pipeline::pieces` share only their cut
/// polygons), and each vertex is looked up there rather than hashed into a table of all.
/// Also returns which vertices of the result are among `only` (none without it). Slabs of
/// one smooth surface (`only` given) have no sides: none are recorded.
pub(crate) fn merge_at(parts: &[Mesh], only: Option<&[DVec3]>) -> (Mesh, Vec<bool>) {
    let vertices: usize = parts.iter().map(|p| p.vertices.len()).sum();
    // Each position's id in the merged mesh, once it has one.
    let mut index: HashMap<[u64; 3], Option<u32>, BitsHash> = match only {
        Some(shared) => shared.iter().map(|&p| (bits(p), None)).collect(),
        None => HashMap::with_capacity_and_hasher(vertices, BitsHash),
    };
    let mut out = Mesh {
        vertices: Vec::with_capacity(vertices),
        normals: Vec::with_capacity(vertices),
        triangles: Vec::with_capacity(parts.iter().map(|p| p.triangles.len()).sum()),
        sides: Vec::new(),
    };
    let mut among = Vec::with_capacity(if only.is_some() { vertices } else { 0 });
    let mut met_again = Vec::new();
    // Sides (slabs of one smooth surface, `only` given, have none): the normals met at each
    // vertex met again, where a part's vertex with sides of its own brings those rather than
    // its summed normal; `sided` marks the vertices whose first part brought sides.
    let record_sides = only.is_none();
    let mut side_normals: HashMap<u32, Vec<DVec3>> = HashMap::new();
    let mut sided: HashSet<u32> = HashSet::new();
    for part in parts {
        let part_sided: HashSet<u32> = part.sides.iter().map(|s| s.vertex).collect();
        let ids: Vec<u32> = part
            .vertices
            .iter()
            .zip(&part.normals)
            .enumerate()
            .map(|(k, (v, n))| {
                let fresh = out.vertices.len() as u32;
                let has_sides = !part_sided.is_empty() && part_sided.contains(&(k as u32));
                let slot = match only {
                    Some(_) => index.get_mut(&bits(*v)),
                    None => Some(index.entry(bits(*v)).or_insert(None)),
                };
                if let Some(&mut Some(id)) = slot {
                    if record_sides {
                        // When the vertex is first met again, the first normal met there is
                        // still the sum's only term.
                        let first = out.normals[id as usize];
                        let met = side_normals.entry(id).or_insert_with(|| {
                            if sided.contains(&id) {
                                Vec::new()
                            } else {
                                vec![first]
                            }
                        });
                        if !has_sides {
                            met.push(*n);
                        }
                    }
                    out.normals[id as usize] += *n;
                    met_again.push(id);
                    return id;
                }
                if only.is_some() {
                    among.push(slot.is_some());
                }
                if let Some(slot) = slot {
                    *slot = Some(fresh);
                }
                if has_sides {
                    sided.insert(fresh);
                }
                out.vertices.push(*v);
                // Summed from zero (a −0 component becomes +0).
                out.normals.push(DVec3::ZERO + *n);
                fresh
            })
            .collect();
        if record_sides {
            for side in &part.sides {
                if let Some(&id) = ids.get(side.vertex as usize) {
                    side_normals.entry(id).or_default().push(side.normal);
                }
            }
        }
        out.triangles
            .extend(part.triangles.iter().map(|t| t.map(|k| ids[k as usize])));
    }
    met_again.sort_unstable();
    met_again.dedup();
    for id in met_again {
        let n = &mut out.normals[id as usize];
        *n = n.normalize_or(*n);
    }
    out.sides = sides(side_normals);
    (out, among)
}

/// The sides of the vertices where different normals met, sorted by vertex, each normal
/// once (compared by value: −0 and +0 are one), in the order they were met.
fn sides(met: HashMap<u32, Vec<DVec3>>) -> Vec<crate::mesh::Side> {
    let mut sides = Vec::new();
    let mut vertices: Vec<u32> = met.keys().copied().collect();
    vertices.sort_unstable();
    for vertex in vertices {
        let mut distinct: Vec<DVec3> = Vec::new();
        for &n in &met[&vertex] {
            if !distinct.contains(&n) {
                distinct.push(n);
            }
        }
        if distinct.len() > 1 {
            sides.extend(
                distinct
                    .into_iter()
                    .map(|normal| crate::mesh::Side { vertex, normal }),
            );
        }
    }
    sides
}

fn bits(p: DVec3) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// Joins one form's directed polygons into closed loops at their corners (the last vertex of
/// each loop not repeated).
fn chain(
    polys: Vec<Side>,
    corners: &[(DVec3, [usize; 3])],
) -> Result<Vec<Vec<DVec3>>, CreaseError> {
    let mut loops = Vec::new();
    let mut open: Vec<(Vec<DVec3>, usize, usize)> = Vec::new();
    for (p, ends) in polys {
        match ends {
            None => loops.push(p),
            Some((a, b)) => open.push((p, a, b)),
        }
    }
    let mut used = vec![false; open.len()];
    for first in 0..open.len() {
        if used[first] {
            continue;
        }
        used[first] = true;
        let start = open[first].1;
        let mut ring: Vec<DVec3> = open[first].0.clone();
        let mut end = open[first].2;
        while end != start {
            let next: Vec<usize> = (0..open.len())
                .filter(|&k| !used[k] && open[k].1 == end)
                .collect();
            match next[..] {
                [k] => {
                    used[k] = true;
                    ring.extend_from_slice(&open[k].0[1..]);
                    end = open[k].2;
                }
                [] => return Err(CreaseError::Chain { at: corners[end].0 }),
                _ => {
                    return Err(CreaseError::SingularCorner {
                        at: corners[end].0,
                        pieces: next.len() + 2,
                    });
                }
            }
        }
        // The start corner closes the loop: not repeated.
        ring.pop();
        if ring.len() < 3 {
            return Err(CreaseError::Chain { at: ring[0] });
        }
        loops.push(ring);
    }
    Ok(loops)
}

/// A crease polygon walked with its piece on the left, and its end corners (None: closed).
type Side = (Vec<DVec3>, Option<(usize, usize)>);

/// The state of one crease search.
struct Tracer<'a> {
    c: &'a mut Creased,
    step: f64,
    bbox: (DVec3, DVec3),
    s: CreaseSettings,
    /// Corners found: the point and its three forms (sorted).
    corners: Vec<(DVec3, [usize; 3])>,
    traced: Vec<Traced>,
    /// Tracing points by (forms, cell of side `covered · step`).
    near: HashMap<(usize, usize, [i64; 3]), Vec<DVec3>>,
}

impl Tracer<'_> {
    fn inside(&self, p: DVec3) -> bool {
        let (lo, hi) = self.bbox;
        p.cmpge(lo).all() && p.cmple(hi).all()
    }

    /// The octree leaves where f and at least two forms may be zero, with those forms.
    #[allow(clippy::type_complexity)]
    fn cells(
        &mut self,
        whole: &mut dyn Surface,
    ) -> Result<Vec<(DVec3, DVec3, Vec<usize>)>, CreaseError> {
        let leaf = self.s.leaf * self.step;
        let mut out = Vec::new();
        let mut stack = vec![self.bbox];
        let mut visited = 0usize;
        while let Some((lo, hi)) = stack.pop() {
            visited += 1;
            if visited > self.s.max_cells {
                return Err(CreaseError::CellLimit {
                    cells: self.s.max_cells,
                });
            }
            if !whole.bound(lo, hi).is_none_or(|i| i.contains(0.0)) {
                continue;
            }
            let zero: Vec<usize> = (0..self.c.form_count())
                .filter(|&i| self.c.form_bound(i, lo, hi).is_none_or(|b| b.contains(0.0)))
                .collect();
            if zero.len() < 2 {
                continue;
            }
            let size = hi - lo;
            if size.max_element() <= leaf {
                out.push((lo, hi, zero));
                continue;
            }
            // Split the sides longer than the leaf in two; children pushed reversed so the
            // first is searched first.
            let mid = 0.5 * (lo + hi);
            let mut children = vec![(lo, hi)];
            for k in 0..3 {
                if size[k] > leaf {
                    children = children
                        .into_iter()
                        .flat_map(|(a, b)| {
                            let (mut a1, mut b0) = (b, a);
                            a1[k] = mid[k];
                            b0[k] = mid[k];
                            [(a, a1), (b0, b)]
                        })
                        .collect();
                }
            }
            stack.extend(children.into_iter().rev());
        }
        Ok(out)
    }

    /// Form i and the function whose zero on it is the seam with form j
    /// (`Creased::seam`: form j, or the selector of a lifted choice).
    fn pair(&mut self, i: usize, j: usize, p: DVec3) -> (ValueGrad, ValueGrad) {
        self.c.seam(i, j, p)
    }

    /// The tie tolerance of the spine at a point where the gradients are about `g` long.
    fn eps(&self, g: f64) -> f64 {
        self.s.tie * self.step * g.max(f64::MIN_POSITIVE)
    }

    /// A crease point of forms i and j from the centre of the cell, if Newton lands near the
    /// cell, in the box, where both are chosen. Tangential contact there is an error.
    fn seed(
        &mut self,
        i: usize,
        j: usize,
        lo: DVec3,
        hi: DVec3,
    ) -> Result<Option<DVec3>, CreaseError> {
        let mut p = 0.5 * (lo + hi);
        let margin = hi - lo;
        let floor = 1e-13 * self.step;
        let mut converged = false;
        for _ in 0..40 {
            let (a, b) = self.pair(i, j, p);
            let delta = min_norm_step(a, b, 1e-9);
            if !delta.is_finite() {
                return Ok(None);
            }
            p -= delta;
            if !(p.cmpge(lo - margin).all() && p.cmple(hi + margin).all()) {
                return Ok(None);
            }
            if delta.length() <= floor.max(4.0 * f64::EPSILON * p.abs().max_element()) {
                converged = true;
                break;
            }
        }
        let (a, b) = self.pair(i, j, p);
        let g = a.gradient.length().max(b.gradient.length());
        let residual = a.value.abs().max(b.value.abs()) / g;
        if residual.is_nan() || residual > 1e-9 * self.step || !self.inside(p) {
            return Ok(None);
        }
        let active = self.c.active(p, self.eps(g));
        if !(active.contains(&i) && active.contains(&j)) {
            return Ok(None);
        }
        let sine = sine(a.gradient, b.gradient);
        if sine < self.s.tangent_sine || !converged {
            return Err(CreaseError::Tangent { at: p, sine });
        }
        // A seed at a corner is traced from a cell along the crease instead.
        Ok((active.len() == 2).then_some(p))
    }

    fn key(&self, p: DVec3) -> [i64; 3] {
        (p / (self.s.covered * self.step))
            .floor()
            .to_array()
            .map(|c| c as i64)
    }

    fn covered(&self, i: usize, j: usize, p: DVec3) -> bool {
        let k = self.key(p);
        let r = self.s.covered * self.step;
        (-1..=1).any(|dx| {
            (-1..=1).any(|dy| {
                (-1..=1).any(|dz| {
                    let key = (i, j, [k[0] + dx, k[1] + dy, k[2] + dz]);
                    self.near
                        .get(&key)
                        .is_some_and(|v| v.iter().any(|q| q.distance(p) <= r))
                })
            })
        })
    }

    /// Keeps a traced crease (found from `from`), and says so under `SURFC_TRACE`.
    fn keep(&mut self, tr: Traced, trace: bool, from: DVec3) {
        if trace {
            let (i, j) = tr.forms;
            eprintln!(
                "creases: forms {i} and {j} from {from}: {} points, ends {:?}",
                tr.points.len(),
                tr.ends
            );
        }
        self.remember(&tr);
        self.traced.push(tr);
    }

    fn remember(&mut self, tr: &Traced) {
        let (i, j) = tr.forms;
        for &p in &tr.points {
            let k = self.key(p);
            self.near.entry((i, j, k)).or_default().push(p);
        }
    }

    /// Newton onto forms i and j within the plane through `o` normal to `m`.
    fn correct(&mut self, i: usize, j: usize, p0: DVec3, o: DVec3, m: DVec3) -> Option<DVec3> {
        let mut p = p0;
        for _ in 0..32 {
            let (a, b) = self.pair(i, j, p);
            let rows = DMat3::from_cols(a.gradient, b.gradient, m).transpose();
            let det = rows.determinant();
            let size = a.gradient.length() * b.gradient.length() * m.length();
            if det.is_nan() || det.abs() <= 1e-12 * size {
                return None;
            }
            let delta = rows.inverse() * DVec3::new(a.value, b.value, m.dot(p - o));
            if !delta.is_finite() {
                return None;
            }
            p -= delta;
            if delta.length() <= (1e-13 * self.step).max(4.0 * f64::EPSILON * p.abs().max_element())
            {
                return Some(p);
            }
        }
        None
    }

    fn tangent(&mut self, i: usize, j: usize, p: DVec3) -> Result<DVec3, CreaseError> {
        let (a, b) = self.pair(i, j, p);
        let c = a.gradient.cross(b.gradient);
        let s = sine(a.gradient, b.gradient);
        if s.is_nan() || s < self.s.tangent_sine {
            return Err(CreaseError::Tangent { at: p, sine: s });
        }
        Ok(c / c.length())
    }

    /// The crease of forms i and j through `seed`, both ways, to its corners or round.
    fn trace(&mut self, i: usize, j: usize, seed: DVec3) -> Result<Traced, CreaseError> {
        let (forward, end) = self.walk(i, j, seed, 1.0, false)?;
        let Some(end) = end else {
            return Ok(Traced {
                forms: (i, j),
                points: forward,
                ends: None,
            });
        };
        let (mut backward, start) = self.walk(i, j, seed, -1.0, false)?;
        let start = start.ok_or(CreaseError::Lost { at: seed })?;
        backward.reverse();
        backward.extend_from_slice(&forward[1..]);
        Ok(Traced {
            forms: (i, j),
            points: backward,
            ends: Some((start, end)),
        })
    }

    /// The crease of forms i and j that ends at corner `id`, traced from it the way the two
    /// forms are chosen; None when neither way is (the crease has no length there).
    fn trace_from_corner(
        &mut self,
        i: usize,
        j: usize,
        id: usize,
    ) -> Result<Option<Traced>, CreaseError> {
        let at = self.corners[id].0;
        let h = 0.01 * self.s.trace * self.step;
        for dir in [1.0, -1.0] {
            let t = dir * self.tangent(i, j, at)?;
            let y = at + h * t;
            let Some(q) = self.correct(i, j, y, y, t) else {
                continue;
            };
            let (a, b) = self.pair(i, j, q);
            let g = a.gradient.length().max(b.gradient.length());
            let active = self.c.active(q, self.eps(g));
            if !(active.len() == 2 && active.contains(&i) && active.contains(&j)) {
                continue;
            }
            let (points, end) = self.walk(i, j, at, dir, true)?;
            let end = end.ok_or(CreaseError::Lost { at })?;
            return Ok(Some(Traced {
                forms: (i, j),
                points,
                ends: Some((id, end)),
            }));
        }
        Ok(None)
    }

    /// Walks from `seed` along dir·(∇Lᵢ × ∇Lⱼ): the points, and the corner id where it
    /// stopped (None: closed, back at the seed).
    fn walk(
        &mut self,
        i: usize,
        j: usize,
        seed: DVec3,
        dir: f64,
        at_corner: bool,
    ) -> Result<(Vec<DVec3>, Option<usize>), CreaseError> {
        let h0 = self.s.trace * self.step;
        let mut points = vec![seed];
        let mut p = seed;
        let mut t = dir * self.tangent(i, j, p)?;
        let mut h = h0;
        loop {
            if points.len() > self.s.max_points {
                return Err(CreaseError::TooLong {
                    at: seed,
                    points: points.len(),
                });
            }
            let mut halvings = 0;
            let (q, next_t) = loop {
                let y = p + h * t;
                if let Some(c) = self.correct(i, j, y, y, t) {
                    let nt = dir * self.tangent(i, j, c)?;
                    let chord = c.distance(p);
                    if (0.5 * h..=1.5 * h).contains(&chord) && t.angle_between(nt) <= 0.3 {
                        break (c, nt);
                    }
                }
                halvings += 1;
                if halvings > 30 {
                    return Err(CreaseError::Lost { at: p });
                }
                h *= 0.5;
            };
            let (a, b) = self.pair(i, j, q);
            let g = a.gradient.length().max(b.gradient.length());
            let active = self.c.active(q, self.eps(g));
            let on = active.contains(&i) && active.contains(&j);
            if !(on && active.len() == 2) {
                // From a corner, the first step's corner is the other end, not the start.
                let skip = (at_corner && points.len() == 1).then_some(seed);
                let corner = self.corner(i, j, p, q, skip)?;
                points.push(self.corners[corner].0);
                return Ok((points, Some(corner)));
            }
            if !self.inside(q) {
                return Err(CreaseError::LeavesBox { at: q });
            }
            let seg = q - p;
            if points.len() >= 3 {
                let s = ((seed - p).dot(seg) / seg.length_squared()).clamp(0.0, 1.0);
                if (p + s * seg - seed).length() <= 0.5 * h {
                    return Ok((points, None));
                }
            }
            points.push(q);
            p = q;
            t = next_t;
            h = (2.0 * h).min(h0);
        }
    }

    /// The corner where the crease of i and j, chosen at p but not (alone) at q, ends: the
    /// point near p where a third form k is zero with them and all three are chosen. Solved
    /// by Newton on (Lᵢ, Lⱼ, Lₖ) to rounding; a corner found before is reused bit for bit.
    fn corner(
        &mut self,
        i: usize,
        j: usize,
        p: DVec3,
        q: DVec3,
        skip: Option<DVec3>,
    ) -> Result<usize, CreaseError> {
        let reach = 2.0 * p.distance(q) + 1e-9 * self.step;
        let mut best: Option<(f64, DVec3, usize, Vec<usize>)> = None;
        for k in 0..self.c.form_count() {
            if k == i || k == j {
                continue;
            }
            for start in [p, q] {
                let Some(c) = self.newton3([i, j, k], start) else {
                    continue;
                };
                let d = c.distance(p);
                if d > reach || skip.is_some_and(|s| s.distance(c) <= 1e-7 * self.step) {
                    continue;
                }
                let g = (0..3)
                    .map(|m| self.c.form([i, j, k][m], c).gradient.length())
                    .fold(0.0, f64::max);
                let active = self.c.active(c, self.eps(g));
                if ![i, j, k].iter().all(|f| active.contains(f)) {
                    continue;
                }
                if best.as_ref().is_none_or(|b| d < b.0) {
                    best = Some((d, c, k, active));
                }
            }
        }
        let Some((_, c, k, active)) = best else {
            return Err(CreaseError::Lost { at: p });
        };
        if active.len() > 3 {
            return Err(CreaseError::SingularCorner {
                at: c,
                pieces: active.len(),
            });
        }
        if !self.inside(c) {
            return Err(CreaseError::LeavesBox { at: c });
        }
        let mut forms = [i, j, k];
        forms.sort_unstable();
        let merge = 1e-7 * self.step;
        if let Some(id) = self
            .corners
            .iter()
            .position(|(x, f)| *f == forms && x.distance(c) <= merge)
        {
            return Ok(id);
        }
        self.corners.push((c, forms));
        Ok(self.corners.len() - 1)
    }

    /// Newton on three forms from `start` (form i and its seams with j and k): the common
    /// zero, or None (no convergence, or normals that do not span space: a singular corner
    /// is found as such by the caller).
    fn newton3(&mut self, forms: [usize; 3], start: DVec3) -> Option<DVec3> {
        let mut p = start;
        let mut last = f64::INFINITY;
        // Pivot on a form whose seams with both others exist.
        let [i, j, k] = match forms {
            [i, j, k] if !self.c.adjacent(i, k) && self.c.adjacent(j, k) => [j, i, k],
            [i, j, k] if !self.c.adjacent(i, j) && self.c.adjacent(k, j) => [k, i, j],
            f => f,
        };
        for _ in 0..60 {
            let (li, sj) = self.pair(i, j, p);
            let v = [li, sj, self.pair(i, k, p).1];
            let rows = DMat3::from_cols(v[0].gradient, v[1].gradient, v[2].gradient).transpose();
            let det = rows.determinant();
            let size: f64 = v.iter().map(|x| x.gradient.length()).product();
            if det.is_nan() || det.abs() <= 1e-9 * size {
                return None;
            }
            let delta = rows.inverse() * DVec3::new(v[0].value, v[1].value, v[2].value);
            if !delta.is_finite() || delta.length() > 4.0 * self.step {
                return None;
            }
            let len = delta.length();
            // Converged to rounding: a step no shorter than the last, once small.
            if len >= last && len <= 1e-12 * self.step.max(p.abs().max_element()) {
                return Some(p);
            }
            p -= delta;
            if len == 0.0 {
                return Some(p);
            }
            last = len;
        }
        None
    }

    /// The crease's polygon: n segments of equal arc length at most the local step of both
    /// pieces (and above the marcher's shortest polygon edge), ends kept exactly.
    fn resample(
        &mut self,
        tr: &Traced,
        sizing: &Sizing,
        min_edge: f64,
    ) -> Result<Vec<DVec3>, CreaseError> {
        let (i, j) = tr.forms;
        let fine = &tr.points;
        let closed = tr.ends.is_none();
        let m = fine.len();
        let line = ArcLength::new(fine, closed).ok_or(CreaseError::Short {
            at: fine.first().copied().unwrap_or(DVec3::ZERO),
            length: 0.0,
        })?;
        let total = line.total();
        // The local step along the crease, on both pieces, every step or so.
        let mut h = self.step;
        let every = ((self.step / (self.s.trace * self.step)).round() as usize).max(1);
        for k in (0..m).step_by(every) {
            for f in [i, j] {
                let vg = self.c.form(f, fine[k]);
                let normal = vg.gradient.normalize_or_zero();
                if normal == DVec3::ZERO {
                    continue;
                }
                let (t1, t2) = tangent_frame(normal);
                let sp = SurfacePoint {
                    point: fine[k],
                    normal,
                    t1,
                    t2,
                };
                h = h.min(sizing.size(&mut self.c.piece(f), &sp, None).h);
            }
        }
        let h = h.max(min_edge / 0.8);
        let n = ((total / h).ceil() as usize).max(if closed { 3 } else { 1 });
        // A crease shorter than the marcher's shortest polygon edge between two corners is
        // one edge (the pieces march with that limit lowered to `shortest`); shorter still,
        // the corners nearly coincide and the crease is refused.
        if total / (n as f64) < min_edge.min(self.s.shortest * self.step) {
            return Err(CreaseError::Short {
                at: fine[0],
                length: total,
            });
        }
        line.resample(n, |y, dir| self.correct(i, j, y, y, dir))
            .map_err(|at| CreaseError::Lost { at })
    }

    /// Whether form i's piece lies on the left of the crease walked as traced (seen from where
    /// ∇Lᵢ points); j is the other piece. Probed a little off the crease on both sides at up to
    /// `PROBES` of its traced points (corners excepted): the probes that decide must agree, and
    /// one at least must decide.
    fn left_side(&mut self, i: usize, j: usize, fine: &[DVec3]) -> Result<bool, CreaseError> {
        let mut found: Option<bool> = None;
        let inner = fine.len().saturating_sub(2).max(1);
        let every = inner.div_ceil(PROBES).max(1);
        for k in (1..fine.len().saturating_sub(1)).step_by(every) {
            match self.probe(i, j, fine[k], fine[k + 1]) {
                Some(left) if found.is_some_and(|f| f != left) => {
                    return Err(CreaseError::Sides { at: fine[k] });
                }
                Some(left) => found = Some(left),
                None => {}
            }
        }
        if found.is_none() && fine.len() == 2 {
            // A crease of one tracing step (corner to corner): probed at its middle.
            let (a, b) = (fine[0], fine[1]);
            let m = a.lerp(b, 0.5);
            if let Some(o) = self.correct(i, j, m, m, (b - a).normalize_or_zero()) {
                found = self.probe(i, j, o, b);
            }
        }
        found.ok_or(CreaseError::Sides {
            at: fine[fine.len() / 2],
        })
    }

    /// At crease vertex o (followed by b): on which side of the crease, walked towards b,
    /// form i alone is chosen on its own surface; None when the probes do not tell.
    fn probe(&mut self, i: usize, j: usize, o: DVec3, b: DVec3) -> Option<bool> {
        // At a vertex (on the crease, unlike an edge's midpoint, which its sagitta moves off
        // by more than a short probe), along the crease's own tangent.
        let (vi, vj) = self.pair(i, j, o);
        let mut d = vi.gradient.cross(vj.gradient).normalize_or_zero();
        if d.dot(b - o) < 0.0 {
            d = -d;
        }
        let w = vi.gradient.normalize_or_zero().cross(d);
        let eps = 0.01 * o.distance(b);
        let mut side = [false; 2];
        for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
            let mut q = o + sign * eps * w;
            for _ in 0..8 {
                let vg = self.c.form(i, q);
                let g2 = vg.gradient.length_squared();
                if g2.is_nan() || g2 <= 0.0 {
                    break;
                }
                q -= vg.gradient * (vg.value / g2);
            }
            let active = self.c.active(q, 0.0);
            side[s] = active.contains(&i) && !active.contains(&j);
        }
        match side {
            [true, false] => Some(true),
            [false, true] => Some(false),
            _ => None,
        }
    }

    /// Every vertex of form i's mesh lies where form i is chosen.
    fn check_piece(&mut self, form: usize, mesh: &Mesh) -> Result<(), CreaseError> {
        for &v in &mesh.vertices {
            let l = self.c.form(form, v);
            let f = self.c.whole(v);
            let distance = (f.value - l.value).abs() / l.gradient.length();
            if distance.is_nan() || distance > self.s.region * self.step {
                return Err(CreaseError::LeftPiece { at: v, distance });
            }
        }
        Ok(())
    }
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

/// Every triangle of `mesh` from triangle `first` on lies on one form: its vertices have a
/// chosen form in common (ties within `tie · |∇f|`).
fn check_smooth(c: &mut Creased, mesh: &Mesh, first: usize, tie: f64) -> Result<(), CreaseError> {
    let mut active: HashMap<u32, Vec<usize>> = HashMap::new();
    for t in &mesh.triangles[first..] {
        let mut common: Option<Vec<usize>> = None;
        for &k in t {
            let v = mesh.vertices[k as usize];
            let set = active
                .entry(k)
                .or_insert_with(|| {
                    let g = c.whole(v).gradient.length();
                    c.active(v, tie * g.max(f64::MIN_POSITIVE))
                })
                .clone();
            common = Some(match common {
                None => set,
                Some(cm) => cm.into_iter().filter(|f| set.contains(f)).collect(),
            });
        }
        if common.is_some_and(|cm| cm.is_empty()) {
            let at = t.iter().map(|&k| mesh.vertices[k as usize]).sum::<DVec3>() / 3.0;
            return Err(CreaseError::MissedCrease { at });
        }
    }
    Ok(())
}

/// |n1 × n2| of the unit normals (0 where a gradient vanishes).
fn sine(g1: DVec3, g2: DVec3) -> f64 {
    let d = g1.length() * g2.length();
    if d > 0.0 {
        g1.cross(g2).length() / d
    } else {
        0.0
    }
}
