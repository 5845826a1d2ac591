//! The state of one triangulation and the paper's Steps 0–4 over it.
//!
//! Invariants: every live front ring walks counter-clockwise (seen from ∇f) around the meshed
//! area, i.e. the area still to be meshed lies to its right; the front angle of a live,
//! non-border node is up to date (recomputed whenever a neighbour changes — the paper's
//! angle_changed — with a version bump that invalidates older heap entries); the spatial hash
//! holds exactly the live nodes that take part in distance checks.
//!
//! This file holds the state (`Marcher`), its bookkeeping, Steps 0, 1 and 4 and the march's
//! loop; Step 2 (fronts that come near themselves or each other: split and union) is in
//! `near`, Step 3 (a node completed with triangles, the new points it and Step 0 make, the
//! collapse of a needle) in `complete`. They import from this file, never the other way.

mod complete;
mod near;

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use glam::DVec3;

use super::angle::front_angle;
use super::guard::{self, Guard};
use super::hash::SpatialHash;
use super::ring::{FrontId, NodeId, PointId, Rings};
use super::settings::MarchSettings;
use super::{MarchError, MarchInput, PolygonRole, Start};
use crate::mesh::Mesh;
use crate::mesh::progress::Tally;
use crate::solve::{SurfacePoint, surface_point, tangent_frame};
use crate::surface::Surface;
use crate::survey::free_cells::FreeCells;
use crate::survey::gradient_jump;
use crate::survey::sizing::{Size, Sizing};

/// Splits and unions add no triangle but retire at least two nodes from distance checks, so
/// their number is bounded; this guards against a bug turning that into a hang.
const MAX_STEPS_WITHOUT_TRIANGLE: u64 = 1_000_000;

/// How often a new point is made again nearer its parent when it landed where the local step
/// is much finer (`graded_point`); each retry moves it to where its own step allows.
const GRADING_RETRIES: u32 = 3;
/// At most this many floored points are looked at for a hidden sharp edge.
const MAX_JUMP_CHECKS: u32 = 1024;
/// The most triangles `MarchInput::expected_triangles` reserves room for (about 0.2 GB of
/// vectors): a larger march grows its vectors beyond, as any march without the hint.
const RESERVED_AT_MOST: u64 = 2_000_000;

type HeapEntry = Reverse<(u64, u32, u32)>;

/// A finished triangulation with what the verification needs to know of its points.
pub(super) struct Triangulation {
    pub mesh: Mesh,
    /// Per vertex: a border point (on the box).
    pub border: Vec<bool>,
    /// Vertices below this index are polygon vertices (front and bounds).
    pub fixed: usize,
    /// The given polygons' edges as (lower, higher) vertex index, sorted: the only edges
    /// between two polygon vertices that may stay open (in one triangle).
    pub polygon_edges: Vec<[u32; 2]>,
    /// Per vertex: the local step h it was made with.
    pub h: Vec<f64>,
    /// Per vertex: the local step the surface asked for there, before grading from the
    /// point's parent. Taken (left empty) by the regrading check before the quality stage,
    /// which adds and removes vertices without it.
    pub wanted: Vec<f64>,
    /// Where the surface asked for a step below the sizing's floor (the first such point).
    pub floored: Option<DVec3>,
}

impl Triangulation {
    /// Drops the vertices no triangle uses (merged away by Step 3's collapse or removed by
    /// the quality stage), renumbering the others in order. Polygon vertices stay even if
    /// unused (a bound never reached), so they keep their indices below `fixed` and
    /// `polygon_edges` stays valid.
    pub fn drop_unused(&mut self) {
        let n = self.mesh.vertices.len();
        let mut used = vec![false; n];
        for t in &self.mesh.triangles {
            for &v in t {
                used[v as usize] = true;
            }
        }
        for u in used.iter_mut().take(self.fixed) {
            *u = true;
        }
        if used.iter().all(|&u| u) {
            return;
        }
        let mut map = vec![u32::MAX; n];
        let mut kept = 0;
        for i in 0..n {
            if used[i] {
                map[i] = kept as u32;
                self.mesh.vertices[kept] = self.mesh.vertices[i];
                self.mesh.normals[kept] = self.mesh.normals[i];
                self.border[kept] = self.border[i];
                self.h[kept] = self.h[i];
                if let Some(w) = self.wanted.get(i).copied() {
                    self.wanted[kept] = w;
                }
                kept += 1;
            }
        }
        self.mesh.vertices.truncate(kept);
        self.mesh.normals.truncate(kept);
        self.border.truncate(kept);
        self.h.truncate(kept);
        self.wanted.truncate(kept);
        for t in &mut self.mesh.triangles {
            *t = t.map(|v| map[v as usize]);
        }
    }
}

pub(super) fn run<'s>(
    surface: &'s mut dyn Surface,
    input: &MarchInput,
    settings: &MarchSettings,
    sizing: &'s Sizing,
    tally: &'s Tally<'s>,
) -> Result<Triangulation, MarchError> {
    let step = input.step;
    if !(step.is_finite() && step > 0.0) {
        return Err(MarchError::InvalidStep { step });
    }
    if let Some((lo, hi)) = input.bbox {
        if !(lo.is_finite() && hi.is_finite() && lo.cmplt(hi).all()) {
            return Err(MarchError::InvalidBox { lo, hi });
        }
    }
    let trace = crate::trace::enabled();
    let mut m = Marcher {
        surface,
        s: *settings,
        step,
        sizing,
        free_cells: FreeCells::new(sizing.reach()),
        h: Vec::new(),
        size: Vec::new(),
        floored: None,
        hidden_crease: None,
        jump_checks: 0,
        bbox: input.bbox,
        guard: Guard::new(
            step,
            input.bbox,
            input
                .max_triangles
                .unwrap_or_else(|| guard::default_limit(input.bbox, step, settings.max_triangles)),
        ),
        tally,
        trace,
        pos: Vec::new(),
        normal: Vec::new(),
        t1: Vec::new(),
        t2: Vec::new(),
        border: Vec::new(),
        triangles: Vec::new(),
        first_tri: Vec::new(),
        fixed_points: 0,
        polygon_edges: Vec::new(),
        merged: 0,
        rings: Rings::default(),
        angle: Vec::new(),
        version: Vec::new(),
        checkable: Vec::new(),
        pending_flag: Vec::new(),
        heaps: Vec::new(),
        passive: Vec::new(),
        hash: SpatialHash::new(settings.near_distance * step),
        pending: Vec::new(),
        scratch: Vec::new(),
    };
    if let Some(t) = input.expected_triangles {
        m.reserve(t.min(RESERVED_AT_MOST) as usize);
    }
    // The given polygons' vertices come first and are the fixed points; a start point's
    // hexagon comes after them, so that its points are ordinary ones: merged or moved like
    // any other (fixed, a hexagon whose ring the local step graded unevenly kept its 17.7°
    // triangles through the quality stage).
    let mut seen = BTreeMap::new();
    let actual = match &input.start {
        Start::Point(s) => {
            m.bounds(&input.bounds, &mut seen)?;
            m.hexagon(*s)?
        }
        Start::Front(poly) => {
            let f = m.polygon(poly, PolygonRole::Front, &mut seen)?;
            m.bounds(&input.bounds, &mut seen)?;
            f
        }
    };
    // Bounds were pushed in input order; the first given is tried first when the actual
    // front is done.
    m.passive.reverse();
    m.march(actual)?;
    Ok(m.into_marched())
}

struct Marcher<'s> {
    surface: &'s mut dyn Surface,
    s: MarchSettings,
    step: f64,
    sizing: &'s Sizing,
    /// Where the sizing's thickness rays are proven free (`survey::free_cells`).
    free_cells: FreeCells,
    /// Per point: the local step h (≤ step), graded from its parent.
    h: Vec<f64>,
    /// Per point: what the sizing found there (inherited by the points made from it).
    size: Vec<Size>,
    floored: Option<DVec3>,
    /// A sharp edge found where the step reached its floor, and the checks made for one.
    hidden_crease: Option<(DVec3, f64)>,
    jump_checks: u32,
    bbox: Option<(DVec3, DVec3)>,
    /// The triangle limit and the watch for marches that cannot end.
    guard: Guard,
    /// The march's share of the triangle count a progress bar shows (a batch at a time).
    tally: &'s Tally<'s>,
    trace: bool,
    // Points (= mesh vertices).
    pos: Vec<DVec3>,
    normal: Vec<DVec3>,
    t1: Vec<DVec3>,
    t2: Vec<DVec3>,
    /// The paper's border_point: on the box, never completed nor distance-checked.
    border: Vec<bool>,
    triangles: Vec<[u32; 3]>,
    /// Per point: index of the first triangle that uses it (u32::MAX: none yet).
    first_tri: Vec<u32>,
    /// Points below this id are polygon vertices: never moved or merged away.
    fixed_points: u32,
    /// The given polygons' edges, (lower, higher) point id (`Triangulation::polygon_edges`).
    polygon_edges: Vec<[u32; 2]>,
    /// Points merged into others (`collapse`); dropped from the mesh at the end.
    merged: usize,
    rings: Rings,
    // Per node.
    angle: Vec<f64>,
    version: Vec<u32>,
    /// In the spatial hash (takes part in distance checks).
    checkable: Vec<bool>,
    pending_flag: Vec<bool>,
    /// Per front: (front angle bits, node, version), smallest first.
    heaps: Vec<BinaryHeap<HeapEntry>>,
    /// Fronts waiting to become the actual front (bounds and split-off parts); last first.
    passive: Vec<FrontId>,
    hash: SpatialHash,
    /// Nodes to distance-check (new or changed).
    pending: Vec<NodeId>,
    scratch: Vec<(NodeId, DVec3)>,
}

impl Marcher<'_> {
    fn p(&self, n: NodeId) -> DVec3 {
        self.pos[self.rings.point(n).index()]
    }

    /// A new point with its local step, graded from `parent` (the point it was stepped
    /// from), if any.
    fn add_point(&mut self, sp: SurfacePoint, border: bool, parent: Option<PointId>) -> PointId {
        let id = PointId(self.pos.len() as u32);
        let from = parent.map(|q| {
            let q = q.index();
            (self.size[q], self.pos[q], self.normal[q])
        });
        let size = self.sizing.size(
            self.surface,
            &sp,
            from.as_ref().map(|(s, p, n)| (s, *p, *n)),
            Some(&mut self.free_cells),
        );
        self.size.push(size);
        if size.floored && self.floored.is_none() {
            self.floored = Some(sp.point);
        }
        // Where the step reaches its floor, the reason may be a sharp edge the crease search
        // did not see: the step would shrink along it without end (bounded: each check costs
        // about 170 gradients).
        if size.floored && self.hidden_crease.is_none() && self.jump_checks < MAX_JUMP_CHECKS {
            self.jump_checks += 1;
            let reach = self.sizing.floor();
            self.hidden_crease =
                gradient_jump::gradient_jump(self.surface, sp.point, (sp.t1, sp.t2), reach);
        }
        let h = match parent {
            Some(q) => {
                let q = q.index();
                self.sizing
                    .graded(size.h, self.h[q], self.pos[q].distance(sp.point))
            }
            None => size.h,
        };
        self.h.push(h);
        self.pos.push(sp.point);
        self.normal.push(sp.normal);
        self.t1.push(sp.t1);
        self.t2.push(sp.t2);
        self.border.push(border);
        self.first_tri.push(u32::MAX);
        id
    }

    fn add_triangle(&mut self, a: PointId, b: PointId, c: PointId) {
        if a != b && b != c && a != c {
            let t = self.triangles.len() as u32;
            for p in [a, b, c] {
                let f = &mut self.first_tri[p.index()];
                *f = (*f).min(t);
            }
            self.triangles.push([a.0, b.0, c.0]);
        }
    }

    /// Room for `triangles` triangles and their points and front nodes (about half as many
    /// each, on a closed surface), so that the vectors need not grow on the way.
    fn reserve(&mut self, triangles: usize) {
        let points = triangles / 2;
        self.triangles.reserve(triangles);
        self.h.reserve(points);
        self.size.reserve(points);
        self.pos.reserve(points);
        self.normal.reserve(points);
        self.t1.reserve(points);
        self.t2.reserve(points);
        self.border.reserve(points);
        self.first_tri.reserve(points);
        self.angle.reserve(points);
        self.version.reserve(points);
        self.checkable.reserve(points);
        self.pending_flag.reserve(points);
    }

    /// Brings per-node and per-front arrays up to the rings' size; new nodes enter the hash
    /// (unless border points) and the pending list.
    fn grow(&mut self) {
        let old = self.angle.len();
        let n = self.rings.node_count();
        self.angle.resize(n, f64::NAN);
        self.version.resize(n, 0);
        self.checkable.resize(n, false);
        self.pending_flag.resize(n, false);
        for i in old..n {
            let node = NodeId(i as u32);
            if !self.border[self.rings.point(node).index()] {
                self.checkable[i] = true;
                let pi = self.rings.point(node).index();
                self.hash.insert(node, self.pos[pi], self.h[pi]);
                self.mark_pending(node);
            }
        }
    }

    fn ensure_heap(&mut self, f: FrontId) {
        while self.heaps.len() <= f.index() {
            self.heaps.push(BinaryHeap::new());
        }
    }

    fn mark_pending(&mut self, n: NodeId) {
        if !self.pending_flag[n.index()] {
            self.pending_flag[n.index()] = true;
            self.pending.push(n);
        }
    }

    /// Takes a node out of distance checks (the paper: "must not be involved in later
    /// distance checks"), or out of everything when it dies.
    fn uncheck(&mut self, n: NodeId) {
        if self.checkable[n.index()] {
            self.checkable[n.index()] = false;
            self.hash.remove(n, self.p(n));
        }
    }

    /// Step 1 for one node: recompute its front angle and queue it in its front's heap.
    fn update_angle(&mut self, n: NodeId) {
        let pi = self.rings.point(n).index();
        if self.border[pi] || !self.rings.alive(n) {
            return;
        }
        let (v1, v2) = (self.p(self.rings.prev(n)), self.p(self.rings.next(n)));
        let w = front_angle(self.pos[pi], self.t1[pi], self.t2[pi], v1, v2);
        self.angle[n.index()] = w;
        self.version[n.index()] += 1;
        let f = self.rings.front(n);
        self.ensure_heap(f);
        self.heaps[f.index()].push(Reverse((w.to_bits(), n.0, self.version[n.index()])));
    }

    /// The live non-border node of smallest front angle of front `f`.
    fn peek_min(&mut self, f: FrontId) -> Option<NodeId> {
        self.ensure_heap(f);
        while let Some(&Reverse((_, n, v))) = self.heaps[f.index()].peek() {
            let node = NodeId(n);
            if self.rings.alive(node)
                && self.rings.front(node) == f
                && self.version[n as usize] == v
            {
                return Some(node);
            }
            self.heaps[f.index()].pop();
        }
        None
    }

    fn inside(&self, p: DVec3) -> bool {
        match self.bbox {
            Some((lo, hi)) => p.cmpge(lo).all() && p.cmple(hi).all(),
            None => true,
        }
    }

    /// Step 0: the surface point of `s` and the hexagon around it; returns the first front.
    fn hexagon(&mut self, s: DVec3) -> Result<FrontId, MarchError> {
        let sp = surface_point(self.surface, s, self.step, &self.s.surface_point)
            .map_err(|source| MarchError::Start { start: s, source })?;
        if !self.inside(sp.point) {
            return Err(MarchError::StartOutsideBox { at: sp.point });
        }
        if !changes_sign(self.surface, &sp, self.step) {
            return Err(MarchError::NoSignChange { at: sp.point });
        }
        let c = self.add_point(sp, false, None);
        let hc = self.h[c.index()];
        let mut ring = Vec::with_capacity(6);
        for i in 0..6 {
            let w = i as f64 * std::f64::consts::FRAC_PI_3;
            ring.push(self.graded_point(c, w.cos() * sp.t1 + w.sin() * sp.t2, hc)?);
        }
        for i in 0..6 {
            self.add_triangle(c, ring[i], ring[(i + 1) % 6]);
        }
        if self.trace {
            eprintln!("march: start {} → {} step {}", s, sp.point, self.step);
        }
        let (f, nodes) = self.rings.make_ring(&ring);
        self.grow();
        for n in nodes {
            self.update_angle(n);
        }
        Ok(f)
    }

    /// The bound polygons as passive fronts, after which every point so far is fixed.
    fn bounds(
        &mut self,
        bounds: &[Vec<DVec3>],
        seen: &mut BTreeMap<[u64; 3], PointId>,
    ) -> Result<(), MarchError> {
        for (i, b) in bounds.iter().enumerate() {
            let g = self.polygon(b, PolygonRole::Bound(i), seen)?;
            self.passive.push(g);
        }
        self.fixed_points = self.pos.len() as u32;
        Ok(())
    }

    /// A given polygon (area to mesh on its left) as a front ring (area to mesh on its
    /// right, so walked backwards). Vertices are kept bit-identical; `seen` merges vertices
    /// shared with polygons given before.
    fn polygon(
        &mut self,
        poly: &[DVec3],
        role: PolygonRole,
        seen: &mut BTreeMap<[u64; 3], PointId>,
    ) -> Result<FrontId, MarchError> {
        let n = poly.len();
        if n < 3 {
            return Err(MarchError::PolygonTooShort {
                polygon: role,
                len: n,
            });
        }
        let (min, max) = (
            self.s.polygon_edge_min * self.step,
            self.s.polygon_edge_max * self.step,
        );
        let mut ids = Vec::with_capacity(n);
        for (i, &p) in poly.iter().enumerate() {
            let length = p.distance(poly[(i + 1) % n]);
            if !(length >= min && length <= max) {
                return Err(MarchError::PolygonSpacing {
                    polygon: role,
                    index: i,
                    at: p,
                    length,
                    step: self.step,
                    min,
                    max,
                });
            }
            let key = [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
            if let Some(&id) = seen.get(&key) {
                ids.push(id);
                continue;
            }
            let vg = self.surface.value_gradient(p);
            let g = vg.gradient;
            let gl = g.length();
            if !(gl > 0.0 && gl.is_finite() && vg.value.is_finite()) {
                return Err(MarchError::PolygonGradient {
                    polygon: role,
                    index: i,
                    at: p,
                });
            }
            let distance = vg.value.abs() / gl;
            if distance > self.s.polygon_on_surface * self.step {
                return Err(MarchError::PolygonOffSurface {
                    polygon: role,
                    index: i,
                    at: p,
                    distance,
                });
            }
            let normal = g / gl;
            let (t1, t2) = tangent_frame(normal);
            let id = self.add_point(
                SurfacePoint {
                    point: p,
                    normal,
                    t1,
                    t2,
                },
                false,
                None,
            );
            seen.insert(key, id);
            ids.push(id);
        }
        for (i, &a) in ids.iter().enumerate() {
            let b = ids[(i + 1) % n];
            self.polygon_edges.push([a.0.min(b.0), a.0.max(b.0)]);
        }
        ids.reverse();
        let (f, nodes) = self.rings.make_ring(&ids);
        self.ensure_heap(f);
        self.grow();
        for n in nodes {
            self.update_angle(n);
        }
        Ok(f)
    }

    /// Steps 1–4 until no front is left.
    fn march(&mut self, first: FrontId) -> Result<(), MarchError> {
        let mut actual = first;
        let mut idle: u64 = 0;
        loop {
            let Some(m) = self.peek_min(actual) else {
                // Step 4: this front is done (only border points left); take the next one.
                self.retire(actual);
                match self.next_front() {
                    Some(f) => {
                        actual = f;
                        continue;
                    }
                    None => return Ok(()),
                }
            };
            let last_at = self.p(m);
            // A front of four points closes with two triangles, one of three with one.
            let closed = if self.rings.len(actual) == 4 && self.close_quad(m) {
                if self.trace {
                    eprintln!(
                        "march: close front {} with two triangles at {}",
                        actual.0, last_at
                    );
                }
                true
            } else if self.close_fan(actual)? {
                if self.trace {
                    eprintln!("march: close front {} with a fan at {}", actual.0, last_at);
                }
                true
            } else if self.rings.len(actual) <= 3 {
                let (a, b) = (self.rings.prev(m), self.rings.next(m));
                if self.rings.len(actual) == 3 {
                    let (pa, pb, pm) = (
                        self.rings.point(a),
                        self.rings.point(b),
                        self.rings.point(m),
                    );
                    self.add_triangle(pa, pb, pm);
                    if self.trace {
                        eprintln!(
                            "march: close front {} with a triangle at {}",
                            actual.0, last_at
                        );
                    }
                }
                true
            } else {
                false
            };
            if closed {
                self.retire(actual);
                match self.next_front() {
                    Some(f) => {
                        actual = f;
                        continue;
                    }
                    None => return Ok(()),
                }
            }
            // Remark 2: small angles first, distance checks (Step 2) only then.
            if self.angle[m.index()] >= self.s.small_angle {
                if let Some(f) = self.distance_checks(actual)? {
                    actual = f;
                    idle += 1;
                    if idle > MAX_STEPS_WITHOUT_TRIANGLE {
                        return Err(MarchError::Stalled {
                            at: last_at,
                            iterations: idle,
                        });
                    }
                    continue;
                }
            }
            self.complete(m)?;
            idle = 0;
            self.tally.at(self.triangles.len() as u64);
            if let Some((at, turn)) = self.hidden_crease {
                return Err(MarchError::HiddenCrease {
                    at,
                    degrees: turn.to_degrees(),
                });
            }
            // A NaN from a `dist` that found no foot point stops the march here, with its
            // place, instead of steering the front by it.
            if let Some(fault) = self.surface.fault() {
                return Err(MarchError::Fault {
                    at: fault.at,
                    reason: fault.reason,
                });
            }
            let (surface, step, tolerance) = (&mut *self.surface, self.step, self.s.surface_point);
            self.guard.check(&self.pos, &self.triangles, last_at, |q| {
                surface_point(surface, q, step, &tolerance)
                    .ok()
                    .map(|sp| sp.point)
            })?;
        }
    }

    /// Step 4 for a front of four points a → b → c → d (m among them): two triangles over
    /// the diagonal that gives the larger smallest angle, instead of completing m with a
    /// possibly thin triangle. False (nothing done) if the quad has border or repeated
    /// points.
    fn close_quad(&mut self, m: NodeId) -> bool {
        let a = m;
        let b = self.rings.next(a);
        let c = self.rings.next(b);
        let d = self.rings.next(c);
        let ids = [a, b, c, d].map(|n| self.rings.point(n));
        if ids.iter().any(|p| self.border[p.index()])
            || (0..4).any(|i| (i + 1..4).any(|j| ids[i] == ids[j]))
        {
            return false;
        }
        let [pa, pb, pc, pd] = ids.map(|p| self.pos[p.index()]);
        let worst = |x: DVec3, y: DVec3, z: DVec3| {
            let t = crate::mesh::quality::triangle_angles(x, y, z);
            t[0].min(t[1]).min(t[2])
        };
        // Diagonal a–c: (a, c, b), (a, d, c); diagonal b–d: (b, d, c), (d, b, a).
        let ac = worst(pa, pc, pb).min(worst(pa, pd, pc));
        let bd = worst(pb, pd, pc).min(worst(pd, pb, pa));
        let [ia, ib, ic, id] = ids;
        if ac >= bd {
            self.add_triangle(ia, ic, ib);
            self.add_triangle(ia, id, ic);
        } else {
            self.add_triangle(ib, id, ic);
            self.add_triangle(id, ib, ia);
        }
        true
    }

    fn retire(&mut self, f: FrontId) {
        for n in self.rings.walk(f) {
            self.uncheck(n);
        }
        self.rings.clear(f);
    }

    fn next_front(&mut self) -> Option<FrontId> {
        while let Some(f) = self.passive.pop() {
            if self.rings.len(f) == 0 {
                continue;
            }
            if self.trace {
                eprintln!(
                    "march: front {} becomes actual ({} points)",
                    f.0,
                    self.rings.len(f)
                );
            }
            for n in self.rings.walk(f) {
                if self.checkable[n.index()] {
                    self.mark_pending(n);
                }
            }
            return Some(f);
        }
        None
    }

    /// The mesh, without the points merged away by `collapse` (renumbered in order, so
    /// polygon vertices keep their places at the front), with its per-vertex facts.
    fn into_marched(mut self) -> Triangulation {
        // Polygon points keep their ids below: the renumbering keeps every point below
        // `fixed_points` and the order.
        self.polygon_edges.sort_unstable();
        self.polygon_edges.dedup();
        let mut marched = Triangulation {
            mesh: Mesh {
                vertices: self.pos,
                normals: self.normal,
                triangles: self.triangles,
                sides: Vec::new(),
            },
            border: self.border,
            fixed: self.fixed_points as usize,
            polygon_edges: self.polygon_edges,
            h: self.h,
            wanted: self.size.iter().map(|s| s.h).collect(),
            floored: self.floored,
        };
        if self.merged > 0 {
            marched.drop_unused();
        }
        marched
    }
}

/// Whether f changes sign across the surface point `sp` along its normal, within a
/// millionth to a hundredth of the step. The marcher meshes the boundary between f < 0 and
/// f > 0; where f only touches zero (a double root: `g^2`, `abs(g)`) its gradient vanishes
/// on the surface, the curvature from it is meaningless and the local step falls to its
/// floor, so the march would run into the triangle limit after minutes instead of saying
/// why at once. Distances below 64 ulps of the point are skipped (they round to it).
pub(crate) fn changes_sign(surface: &mut dyn Surface, sp: &SurfacePoint, step: f64) -> bool {
    let ulps = 64.0 * f64::EPSILON * sp.point.abs().max_element();
    [1e-6, 1e-4, 1e-2]
        .iter()
        .map(|k| (k * step).max(ulps))
        .any(|d| {
            let above = surface.value(sp.point + d * sp.normal);
            let below = surface.value(sp.point - d * sp.normal);
            // A NaN or an exact zero is no evidence of a double root: only a product
            // that compares greater than zero is.
            (above * below).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        })
}
