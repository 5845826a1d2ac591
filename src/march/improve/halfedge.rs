//! The half-edges of the stage's triangulation: the twins `Stage::new` builds, the star
//! around a vertex (closed, or open at a border), and the changes every phase makes
//! through them (`set`, `link`, `place`), recorded while an insertion is on trial.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering::Relaxed};

use glam::DVec3;
use rayon::prelude::*;

use super::{MAX_STAR, NONE, Stage, TWIN_BLOCK, Undo, next, prev};

impl<'a> Stage<'a> {
    /// Builds the half-edge twins of `tri`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        pos: &'a mut Vec<DVec3>,
        normal: &'a mut Vec<DVec3>,
        tri: &'a mut Vec<[u32; 3]>,
        border: &'a mut Vec<bool>,
        h: &'a mut Vec<f64>,
        fixed: usize,
        bbox: Option<(DVec3, DVec3)>,
    ) -> Self {
        let n = pos.len();
        let corners = 3 * tri.len();
        // Per vertex, its corners in triangle order, each named by the half-edge leaving it
        // (3t + k): a counting sort into one array, vertex a's run from `first[a]` to
        // `first[a + 1]`, so that blocks of vertices can be taken in parallel below (a
        // linked list threaded through `twin`, as before, saved this array's 12 bytes a
        // triangle but had to be walked in one thread).
        let mut first = vec![0u32; n + 1];
        for t in tri.iter() {
            for &v in t {
                first[v as usize] += 1;
            }
        }
        // First where each run ends; filled from the last corner down, each run comes out
        // in increasing order and `first` at the runs' starts (`first[n]` the total).
        for a in 1..=n {
            first[a] += first[a - 1];
        }
        let mut corner = vec![0u32; corners];
        for e in (0..corners).rev() {
            let a = tri[e / 3][e % 3] as usize;
            first[a] -= 1;
            corner[first[a] as usize] = e as u32;
        }
        // At the corner of triangle (a, b, c) at a, the half-edge a → b leaves a and c → a
        // arrives: the twin of a → b (the half-edge b → a) is the arriving half-edge of the
        // corner of a whose third vertex is b. Every twin is found among one vertex's own
        // corners: searching the other end's corners, as before, took half as long again
        // on the fine sphere. Each vertex writes only its own corners' twins (and, at a
        // non-manifold edge, marks both ends frozen, which commutes): the vertices are
        // taken in parallel, in blocks, and the result is the same for any thread count.
        let twin: Vec<AtomicU32> = (0..corners)
            .into_par_iter()
            .map(|_| AtomicU32::new(NONE))
            .collect();
        let frozen: Vec<AtomicBool> = (0..n).map(|_| AtomicBool::new(false)).collect();
        let mut out = vec![NONE; n];
        out.par_chunks_mut(TWIN_BLOCK)
            .enumerate()
            .for_each(|(block, out)| {
                // The corners of one vertex: (leaving half-edge, its end b, the third vertex c).
                let mut fan: Vec<(u32, u32, u32)> = Vec::new();
                for (i, out) in out.iter_mut().enumerate() {
                    let a = block * TWIN_BLOCK + i;
                    fan.clear();
                    for &e in &corner[first[a] as usize..first[a + 1] as usize] {
                        let t = tri[(e / 3) as usize];
                        fan.push((e, t[((e + 1) % 3) as usize], t[((e + 2) % 3) as usize]));
                    }
                    if let Some(&(e, _, _)) = fan.first() {
                        *out = e;
                    }
                    // A manifold vertex (nearly every one) has its corners' ends all
                    // different, and their third vertices too: then a half-edge's twin is the
                    // one arriving from its end, if any. Elsewhere an end met twice is a
                    // non-manifold edge: no twins there.
                    let manifold = fan
                        .iter()
                        .enumerate()
                        .all(|(i, x)| fan[i + 1..].iter().all(|y| x.1 != y.1 && x.2 != y.2));
                    // A vertex with more than one boundary edge leaving it is where two fans
                    // touch: neither smoothing nor a slide sees all its triangles, so it stays.
                    let mut gaps = 0;
                    for &(e, b, _) in &fan {
                        // Half-edges a → b, and the first b → a and whether there is another.
                        let leaving = if manifold {
                            1
                        } else {
                            fan.iter().filter(|d| d.1 == b).count()
                        };
                        let mut arriving = fan.iter().filter(|d| d.2 == b);
                        let (back, more) =
                            (arriving.next(), !manifold && arriving.next().is_some());
                        match (leaving, back, more) {
                            (1, Some(back), false) => twin[e as usize].store(prev(back.0), Relaxed),
                            (1, None, _) => gaps += 1,
                            _ => {
                                frozen[a].store(true, Relaxed);
                                frozen[b as usize].store(true, Relaxed);
                                gaps += 1;
                            }
                        }
                    }
                    if gaps > 1 {
                        frozen[a].store(true, Relaxed);
                    }
                }
            });
        let twin = twin.into_iter().map(AtomicU32::into_inner).collect();
        let frozen = frozen.into_iter().map(AtomicBool::into_inner).collect();
        Stage {
            pos,
            normal,
            tri,
            border,
            h,
            fixed,
            bbox,
            twin,
            out,
            frozen,
            log: None,
            valence: Vec::new(),
            bad_sin2: 0.0,
        }
    }

    /// The outgoing half-edges of v in counter-clockwise order, or None where the fan is
    /// not closed (a boundary vertex) or too long.
    pub(super) fn star(&self, v: u32, buf: &mut Vec<u32>) -> bool {
        buf.clear();
        let first = self.out[v as usize];
        if first == NONE {
            return false;
        }
        let mut e = first;
        loop {
            buf.push(e);
            let back = self.twin[prev(e) as usize];
            if back == NONE || buf.len() > MAX_STAR {
                return false;
            }
            e = back;
            if e == first {
                return true;
            }
        }
    }

    /// Sets triangle t to `v` and records its outgoing half-edges.
    pub(super) fn set(&mut self, t: u32, v: [u32; 3]) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Tri(t, self.tri[t as usize]));
            log.extend(v.iter().map(|&p| Undo::Out(p, self.out[p as usize])));
        }
        self.tri[t as usize] = v;
        for (k, &p) in v.iter().enumerate() {
            self.out[p as usize] = 3 * t + k as u32;
        }
    }

    pub(super) fn link(&mut self, e: u32, f: u32) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Twin(e, self.twin[e as usize]));
            if f != NONE {
                log.push(Undo::Twin(f, self.twin[f as usize]));
            }
        }
        self.twin[e as usize] = f;
        if f != NONE {
            self.twin[f as usize] = e;
        }
    }

    /// Puts vertex v at p with normal n (recorded while an insertion is on trial).
    pub(super) fn place(&mut self, v: u32, p: DVec3, n: DVec3) {
        if let Some(log) = &mut self.log {
            log.push(Undo::Pos(v, self.pos[v as usize], self.normal[v as usize]));
        }
        self.pos[v as usize] = p;
        self.normal[v as usize] = n;
    }

    /// The twins of the four outer edges of the quad over half-edge e = a→b (in t, with c)
    /// and its twin f = b→a (in u, with d): [a→d, d→b, b→c, c→a].
    pub(super) fn outer(&self, e: u32, f: u32) -> [u32; 4] {
        [next(f), prev(f), next(e), prev(e)].map(|x| self.twin[x as usize])
    }

    /// Whether a and b are joined by an edge (searched around a, both ways from out[a]).
    pub(super) fn edge_exists(&self, a: u32, b: u32) -> bool {
        let first = self.out[a as usize];
        if first == NONE {
            return false;
        }
        // Counter-clockwise until the fan closes or opens.
        let mut e = first;
        for _ in 0..=MAX_STAR {
            if self.dst(e) == b || self.org(prev(e)) == b {
                return true;
            }
            let back = self.twin[prev(e) as usize];
            if back == NONE || back == first {
                break;
            }
            e = back;
        }
        // Clockwise from the first (an open fan).
        let mut e = first;
        for _ in 0..=MAX_STAR {
            let t = self.twin[e as usize];
            if t == NONE {
                break;
            }
            e = next(t);
            if e == first {
                break;
            }
            if self.dst(e) == b || self.org(prev(e)) == b {
                return true;
            }
        }
        false
    }

    /// The outgoing half-edges of border vertex v in counter-clockwise order, from the
    /// boundary edge leaving v to the one arriving at it; false if the fan is closed, has
    /// more than one gap, or is too long.
    pub(super) fn open_star(&self, v: u32, buf: &mut Vec<u32>) -> bool {
        buf.clear();
        let first = self.out[v as usize];
        if first == NONE {
            return false;
        }
        // Clockwise to the half-edge whose edge is on the boundary.
        let mut e = first;
        for _ in 0..=MAX_STAR {
            let t = self.twin[e as usize];
            if t == NONE {
                break;
            }
            e = next(t);
            if e == first {
                return false;
            }
        }
        if self.twin[e as usize] != NONE {
            return false;
        }
        loop {
            buf.push(e);
            let back = self.twin[prev(e) as usize];
            if back == NONE {
                break;
            }
            if buf.len() > MAX_STAR {
                return false;
            }
            e = back;
        }
        // A second gap would leave triangles out: `new` froze such vertices.
        true
    }
}
