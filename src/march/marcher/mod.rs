//! The state of one triangulation and the paper's Steps 0–4 over it.
//!
//! Invariants: every live front ring walks counter-clockwise (seen from ∇f) around the meshed
//! area, i.e. the area still to be meshed lies to its right; the front angle of a live,
//! non-border node is up to date (recomputed whenever a neighbour changes — the paper's
//! angle_changed — with a version bump that invalidates older heap entries); the spatial hash
//! holds exactly the live nodes that take part in distance checks.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap};

use glam::DVec3;

use super::angle::{ccw, front_angle, polar, triangle_count};
use super::guard::{self, Guard};
use super::hash::SpatialHash;
use super::ring::{FrontId, NodeId, PointId, Rings};
use super::settings::MarchSettings;
use super::{MarchError, MarchInput, PolygonRole, Start};
use crate::mesh::Mesh;
use crate::solve::{SurfacePoint, surface_point, tangent_frame};
use crate::surface::Surface;
use crate::survey::jump;
use crate::survey::sizing::{Size, Sizing};

/// Splits and unions add no triangle but retire at least two nodes from distance checks, so
/// their number is bounded; this guards against a bug turning that into a hang.
const MAX_STEPS_WITHOUT_TRIANGLE: u64 = 1_000_000;

/// How often a new point is made again nearer its parent when it landed where the local step
/// is much finer (`graded_point`); each retry moves it to where its own step allows.
const GRADING_RETRIES: u32 = 3;
/// At most this many floored points are looked at for a hidden sharp edge.
const MAX_JUMP_CHECKS: u32 = 1024;

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
    progress: Option<&'s std::sync::atomic::AtomicU64>,
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
    let trace = std::env::var_os("SURFC_TRACE").is_some_and(|v| !v.is_empty() && v != "0");
    let mut m = Marcher {
        surface,
        s: *settings,
        step,
        sizing,
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
        progress,
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
    /// Where the triangle count goes for a progress bar, if anyone watches.
    progress: Option<&'s std::sync::atomic::AtomicU64>,
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
            self.hidden_crease = jump::gradient_jump(self.surface, sp.point, (sp.t1, sp.t2), reach);
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

    /// A new point `r` from `parent` along the tangent `dir` (Steps 0 and 3), nearer where
    /// the point's own local step says that r jumped into a finer region than grading allows
    /// (h(q) < (1 − grading)·r, e.g. onto a thin rim): then it is made again at
    /// h(q)/(1 − grading), a few times.
    fn graded_point(&mut self, parent: PointId, dir: DVec3, r: f64) -> Result<PointId, MarchError> {
        let from = self.pos[parent.index()];
        let keep = 1.0 - self.sizing.settings().grading;
        let mut r = r;
        for _ in 0..GRADING_RETRIES {
            let id = self.new_point(parent, from + r * dir)?;
            let hq = self.h[id.index()];
            if self.border[id.index()] || hq >= keep * r || self.sizing.is_uniform() {
                return Ok(id);
            }
            self.pop_point();
            r = hq / keep;
        }
        self.new_point(parent, from + r * dir)
    }

    /// Undoes the last `add_point` (a point nothing refers to yet).
    fn pop_point(&mut self) {
        self.pos.pop();
        self.normal.pop();
        self.t1.pop();
        self.t2.pop();
        self.border.pop();
        self.first_tri.pop();
        self.h.pop();
        self.size.pop();
    }

    /// A new point for the chord from point `parent` to q: surfacepoint of q, or, if the
    /// chord or its surface point leaves the box, a border point where the chord meets it.
    fn new_point(&mut self, parent: PointId, q: DVec3) -> Result<PointId, MarchError> {
        let from = self.pos[parent.index()];
        if !self.inside(q) {
            return self.border_point(parent, from, q);
        }
        let sp = surface_point(self.surface, q, self.step, &self.s.surface_point)
            .map_err(|source| MarchError::NewPoint { near: q, source })?;
        if !self.inside(sp.point) {
            return self.border_point(parent, from, sp.point);
        }
        if let Some((lo, hi)) = self.bbox {
            // A point this close to a face would leave slivers between it and the border
            // points beyond it: it goes onto the face instead.
            let p = sp.point;
            let snap = self.s.box_snap * self.h[parent.index()];
            let (mut best, mut axis, mut value) = (snap, usize::MAX, 0.0);
            for k in 0..3 {
                for bound in [lo[k], hi[k]] {
                    let d = (p[k] - bound).abs();
                    if d < best {
                        (best, axis, value) = (d, k, bound);
                    }
                }
            }
            if axis != usize::MAX {
                let mut u = p;
                u[axis] = value;
                return self.face_point(parent, u, axis);
            }
        }
        Ok(self.add_point(sp, false, Some(parent)))
    }

    /// The chord from → q (from inside, q outside the box) truncated at the box, then moved
    /// onto the surface within the box face it hit (Newton along the gradient projected into
    /// the face), so that border points lie on the box.
    fn border_point(
        &mut self,
        parent: PointId,
        from: DVec3,
        q: DVec3,
    ) -> Result<PointId, MarchError> {
        // Without a box (never the case: callers check `inside` first) nothing truncates.
        let (lo, hi) = self
            .bbox
            .unwrap_or((DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)));
        let d = q - from;
        let (mut t, mut axis, mut value) = (1.0f64, 0usize, 0.0);
        for k in 0..3 {
            let bound = if d[k] > 0.0 && q[k] > hi[k] {
                hi[k]
            } else if d[k] < 0.0 && q[k] < lo[k] {
                lo[k]
            } else {
                continue;
            };
            let tk = ((bound - from[k]) / d[k]).clamp(0.0, 1.0);
            if tk < t {
                (t, axis, value) = (tk, k, bound);
            }
        }
        let mut u = from + t * d;
        u[axis] = value;
        self.face_point(parent, u, axis)
    }

    /// A border point: from `start` on the box face orthogonal to `axis`, onto the surface
    /// within that face (falling back to plain surfacepoint where the surface runs along
    /// the face).
    fn face_point(
        &mut self,
        parent: PointId,
        start: DVec3,
        axis: usize,
    ) -> Result<PointId, MarchError> {
        let value = start[axis];
        let mut u = start;
        let tol = self.s.surface_point.relative_step * self.step;
        let mut converged = false;
        for _ in 0..self.s.surface_point.max_iterations {
            let vg = self.surface.value_gradient(u);
            let mut g = vg.gradient;
            g[axis] = 0.0;
            let g2 = g.length_squared();
            if !(g2 > 0.0 && g2.is_finite() && vg.value.is_finite()) {
                break;
            }
            let delta = g * (vg.value / g2);
            if delta.length() > self.step {
                // The surface runs nearly parallel to the face here: give up on the face.
                break;
            }
            u -= delta;
            u[axis] = value;
            if delta.length() <= tol.max(8.0 * f64::EPSILON * u.abs().max_element()) {
                converged = true;
                break;
            }
        }
        let sp = if converged && self.inside_loose(u) {
            let vg = self.surface.value_gradient(u);
            let normal = vg.gradient.normalize_or_zero();
            let (t1, t2) = tangent_frame(normal);
            SurfacePoint {
                point: u,
                normal,
                t1,
                t2,
            }
        } else {
            surface_point(self.surface, start, self.step, &self.s.surface_point).map_err(
                |source| MarchError::NewPoint {
                    near: start,
                    source,
                },
            )?
        };
        if self.trace {
            eprintln!("march: border point {} (face axis {axis})", sp.point);
        }
        Ok(self.add_point(sp, true, Some(parent)))
    }

    /// Inside the box up to rounding of the face coordinate.
    fn inside_loose(&self, p: DVec3) -> bool {
        match self.bbox {
            Some((lo, hi)) => {
                let eps = 1e-12 * self.step;
                p.cmpge(lo - eps).all() && p.cmple(hi + eps).all()
            }
            None => true,
        }
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
            if let Some(progress) = self.progress {
                progress.store(
                    self.triangles.len() as u64,
                    std::sync::atomic::Ordering::Relaxed,
                );
            }
            if let Some((at, turn)) = self.hidden_crease {
                return Err(MarchError::HiddenCrease {
                    at,
                    degrees: turn.to_degrees(),
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

    /// Step 2 over the nodes that are new or changed. Splits or unites at the first near
    /// pair found and returns the new actual front.
    fn distance_checks(&mut self, actual: FrontId) -> Result<Option<FrontId>, MarchError> {
        while let Some(a) = self.pending.pop() {
            self.pending_flag[a.index()] = false;
            if !self.rings.alive(a) || !self.checkable[a.index()] || self.rings.front(a) != actual {
                continue;
            }
            let Some(b) = self.near_partner(a) else {
                continue;
            };
            return if self.rings.front(b) == actual {
                Ok(Some(self.split(a, b)))
            } else {
                self.unite(a, b).map(Some)
            };
        }
        Ok(None)
    }

    /// The nearest node b that is near a in the sense of Step 2: closer than the near
    /// distance, not a or its (second) neighbour, normals agreeing, and each inside the
    /// other's front angle (Remark 3: otherwise the two are separated by meshed area).
    fn near_partner(&mut self, a: NodeId) -> Option<NodeId> {
        let pa_id = self.rings.point(a);
        let pa = self.pos[pa_id.index()];
        let (ap, an) = (self.rings.prev(a), self.rings.next(a));
        let (ap_id, an_id) = (self.rings.point(ap), self.rings.point(an));
        // Near within the smaller of the two local steps: with the larger, fronts across a
        // plate's tight rim were joined (docs/marcher.md, the local step). A given polygon
        // with edges longer than twice the local step beside it can thus be passed between
        // its vertices: the verification lays such flaws to the polygon (`CoarsePolygon`).
        let ha = self.h[pa_id.index()];
        let near = self.s.near_distance;
        let mut cands = std::mem::take(&mut self.scratch);
        cands.clear();
        self.hash.for_near(pa, |b, pb, hb| {
            let r = near * ha.min(hb);
            if pb.distance_squared(pa) < r * r {
                cands.push((b, pb));
            }
        });
        let (t1a, t2a, na) = (
            self.t1[pa_id.index()],
            self.t2[pa_id.index()],
            self.normal[pa_id.index()],
        );
        // Computed at the first candidate that passes the cheap tests (most checks have none).
        let mut w1a = None;
        let mut best: Option<(f64, NodeId)> = None;
        for &(b, pb) in &cands {
            let pb_id = self.rings.point(b);
            if b == a || pb_id == pa_id || pb_id == ap_id || pb_id == an_id {
                continue;
            }
            let (bp, bn) = (self.rings.prev(b), self.rings.next(b));
            if self.rings.point(bp) == pa_id || self.rings.point(bn) == pa_id {
                continue;
            }
            if self.rings.front(b) == self.rings.front(a)
                && (b == self.rings.next(an) || b == self.rings.prev(ap))
            {
                continue;
            }
            let bi = pb_id.index();
            if na.dot(self.normal[bi]) < self.s.near_normal_cos {
                continue;
            }
            let w1 = *w1a.get_or_insert_with(|| polar(pa, t1a, t2a, self.pos[ap_id.index()]));
            let th = ccw(w1, polar(pa, t1a, t2a, pb));
            if !(th > 0.0 && th < self.angle[a.index()]) {
                continue;
            }
            let w1b = polar(pb, self.t1[bi], self.t2[bi], self.p(bp));
            let thb = ccw(w1b, polar(pb, self.t1[bi], self.t2[bi], pa));
            if !(thb > 0.0 && thb < self.angle[b.index()]) {
                continue;
            }
            let d = pa.distance(pb);
            if best.is_some_and(|(bd, bb)| (d, b) >= (bd, bb)) || !self.same_sheet(pa, pb) {
                continue;
            }
            best = Some((d, b));
        }
        self.scratch = cands;
        best.map(|(_, b)| b)
    }

    /// Do two near front points see each other across the surface, not across a gap between
    /// two sheets? The midpoint of their chord must lie within `near_midpoint`·|a − b| of
    /// the surface (linear estimate |f|/|∇f|): on one sheet it is the chord's sagitta, across
    /// a gap half the gap.
    fn same_sheet(&mut self, pa: DVec3, pb: DVec3) -> bool {
        let vg = self.surface.value_gradient(0.5 * (pa + pb));
        let g = vg.gradient.length();
        g > 0.0 && vg.value.abs() <= self.s.near_midpoint * pa.distance(pb) * g
    }

    /// Step 2, first case: a and b of the actual front are near. The shorter arc becomes a
    /// new front and the actual one; the ends take no part in later distance checks.
    fn split(&mut self, a: NodeId, b: NodeId) -> FrontId {
        let old = self.rings.front(a);
        let (x, y) = if self.rings.forward_arc_shorter(a, b) {
            (a, b)
        } else {
            (b, a)
        };
        let (nf, x2, y2) = self.rings.split(x, y);
        self.ensure_heap(nf);
        self.grow();
        for n in [x, y, x2, y2] {
            self.uncheck(n);
        }
        for n in self.rings.walk(nf) {
            if n != x2 && n != y2 && !self.border[self.rings.point(n).index()] {
                let e = Reverse((
                    self.angle[n.index()].to_bits(),
                    n.0,
                    self.version[n.index()],
                ));
                self.heaps[nf.index()].push(e);
            }
        }
        for n in [x, y, x2, y2] {
            self.update_angle(n);
        }
        if self.trace {
            eprintln!(
                "march: split front {} at {} – {}: new front {} of {} points, old keeps {}",
                old.0,
                self.p(x),
                self.p(y),
                nf.0,
                self.rings.len(nf),
                self.rings.len(old)
            );
        }
        self.passive.push(old);
        nf
    }

    /// Step 2, second case: a of the actual front is near b of another front. The fronts
    /// are united with a and b doubled; the first appearances are completed at once, the
    /// smaller front angle first, and the second ones take no part in later distance checks.
    fn unite(&mut self, a: NodeId, b: NodeId) -> Result<FrontId, MarchError> {
        let fa = self.rings.front(a);
        let fb = self.rings.front(b);
        let other: Vec<NodeId> = self.rings.walk(fb);
        let (b1, a2) = self.rings.unite(a, b);
        self.grow();
        let moved = std::mem::take(&mut self.heaps[fb.index()]);
        self.heaps[fa.index()].extend(moved);
        for n in [a, b, b1, a2] {
            self.uncheck(n);
        }
        for n in other {
            if self.checkable[n.index()] {
                self.mark_pending(n);
            }
        }
        for n in [a, b, b1, a2] {
            self.update_angle(n);
        }
        if self.trace {
            eprintln!(
                "march: unite front {} with front {} at {} – {} ({} points)",
                fa.0,
                fb.0,
                self.p(a),
                self.p(b),
                self.rings.len(fa)
            );
        }
        let (first, second) = if self.angle[a.index()] <= self.angle[b1.index()] {
            (a, b1)
        } else {
            (b1, a)
        };
        self.complete(first)?;
        if self.rings.alive(second) && self.rings.len(fa) > 3 {
            self.complete(second)?;
        }
        Ok(fa)
    }

    /// Step 3 at node m: surround it with triangles of ≈ 60°, replace it in its front by the
    /// new points, and mark the neighbours changed.
    fn complete(&mut self, m: NodeId) -> Result<(), MarchError> {
        let (v1, v2) = (self.rings.prev(m), self.rings.next(m));
        let (pm_id, p1_id, p2_id) = (
            self.rings.point(m),
            self.rings.point(v1),
            self.rings.point(v2),
        );
        let (pm, p1, p2) = (
            self.pos[pm_id.index()],
            self.pos[p1_id.index()],
            self.pos[p2_id.index()],
        );
        let omega = self.angle[m.index()];
        if omega < self.s.collapse_angle
            && self.rings.len(self.rings.front(m)) > 4
            && self.collapse(m, v1, v2)
        {
            return Ok(());
        }
        let hm = self.h[pm_id.index()];
        let nt = if self.rings.len(self.rings.front(m)) <= 3 {
            1
        } else {
            triangle_count(
                omega,
                pm.distance(p1),
                pm.distance(p2),
                p1.distance(p2),
                hm,
                &self.s,
            )
        };
        if self.trace {
            eprintln!(
                "march: complete {} (point {}) angle {:.4} with {} triangle(s)",
                pm, pm_id.0, omega, nt
            );
        }
        let mut new_points = Vec::with_capacity(nt as usize - 1);
        if nt > 1 {
            let (t1, t2) = (self.t1[pm_id.index()], self.t2[pm_id.index()]);
            let w1 = polar(pm, t1, t2, p1);
            let dw = omega / nt as f64;
            for i in 1..nt {
                let w = w1 + i as f64 * dw;
                new_points.push(self.graded_point(pm_id, w.cos() * t1 + w.sin() * t2, hm)?);
            }
        }
        let mut prev = p1_id;
        for &p in &new_points {
            self.add_triangle(prev, p, pm_id);
            prev = p;
        }
        self.add_triangle(prev, p2_id, pm_id);
        self.uncheck(m);
        let new_nodes = self.rings.replace(m, &new_points);
        self.grow();
        self.drop_spikes(v1);
        for n in new_nodes {
            self.update_angle(n);
        }
        for n in [v1, v2] {
            if self.rings.alive(n) {
                self.update_angle(n);
                if self.checkable[n.index()] {
                    self.mark_pending(n);
                }
            }
        }
        Ok(())
    }

    /// Step 3 for a needle: m's front angle is tiny and its neighbours v1, v2 lie within
    /// `close_neighbour`·δ of each other, so the triangle (v1, v2, m) would be a sliver.
    /// Instead the newer of the two points is merged into the older (an edge collapse):
    /// its triangles take the older point, and m and its node leave the front. False
    /// (nothing done) where that is not safe: border or polygon points, a point with
    /// several nodes, or an existing edge between the two.
    fn collapse(&mut self, m: NodeId, v1: NodeId, v2: NodeId) -> bool {
        let (p1, p2) = (self.rings.point(v1), self.rings.point(v2));
        if p1 == p2
            || self.border[p1.index()]
            || self.border[p2.index()]
            || self.pos[p1.index()].distance(self.pos[p2.index()])
                > self.s.close_neighbour * self.h[self.rings.point(m).index()]
        {
            return false;
        }
        let (keep, gone, gone_node) = if p1 < p2 { (p1, p2, v2) } else { (p2, p1, v1) };
        if gone.0 < self.fixed_points || !self.checkable[gone_node.index()] {
            return false;
        }
        let from = self.first_tri[gone.index()] as usize;
        let tris = &self.triangles[from.min(self.triangles.len())..];
        if tris
            .iter()
            .any(|t| t.contains(&gone.0) && t.contains(&keep.0))
        {
            return false;
        }
        // Moving the triangles' corner from `gone` to `keep` must not flip any of them.
        let pk = self.pos[keep.index()];
        let flips = tris.iter().filter(|t| t.contains(&gone.0)).any(|t| {
            let [a, b, c] = t.map(|v| {
                if v == gone.0 {
                    pk
                } else {
                    self.pos[v as usize]
                }
            });
            let n = t.iter().map(|&v| self.normal[v as usize]).sum::<DVec3>();
            (b - a).cross(c - a).dot(n) <= 0.0
        });
        if flips {
            return false;
        }
        if self.trace {
            eprintln!(
                "march: collapse point {} into {} at {} (front angle {:.4})",
                gone.0,
                keep.0,
                self.pos[keep.index()],
                self.angle[m.index()]
            );
        }
        for t in &mut self.triangles[from..] {
            for v in t.iter_mut() {
                if *v == gone.0 {
                    *v = keep.0;
                }
            }
        }
        let fk = self.first_tri[keep.index()].min(from as u32);
        self.first_tri[keep.index()] = fk;
        self.merged += 1;
        self.uncheck(m);
        self.rings.replace(m, &[]);
        self.uncheck(gone_node);
        self.rings.replace(gone_node, &[]);
        let kept = if gone_node == v1 { v2 } else { v1 };
        for n in [self.rings.prev(kept), kept, self.rings.next(kept)] {
            self.update_angle(n);
            if self.checkable[n.index()] {
                self.mark_pending(n);
            }
        }
        true
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

    /// After a completion, two consecutive nodes of the same point (possible next to the
    /// doubled points of a union) would form a zero-length front edge: keep one.
    fn drop_spikes(&mut self, v: NodeId) {
        if !self.rings.alive(v) {
            return;
        }
        let n = self.rings.next(v);
        if n != v
            && self.rings.point(n) == self.rings.point(v)
            && self.rings.len(self.rings.front(v)) > 3
        {
            self.uncheck(n);
            self.rings.replace(n, &[]);
            self.update_angle(v);
            let nn = self.rings.next(v);
            self.update_angle(nn);
        }
    }
}

/// Whether f changes sign across the surface point `sp` along its normal, within a
/// millionth to a hundredth of the step. The marcher meshes the boundary between f < 0 and
/// f > 0; where f only touches zero (a double root: `g^2`, `abs(g)`) its gradient vanishes
/// on the surface, the curvature from it is meaningless and the local step falls to its
/// floor, so the march would run into the triangle limit after minutes instead of saying
/// why at once. Distances below 64 ulps of the point are skipped (they round to it).
fn changes_sign(surface: &mut dyn Surface, sp: &SurfacePoint, step: f64) -> bool {
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
