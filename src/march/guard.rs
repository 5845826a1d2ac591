//! Bounded meshing: how many triangles a mesh block may make, and a watch on the growing mesh
//! that stops a march that cannot end long before that limit, saying why.
//!
//! A march ends when its fronts close. Two things keep them from closing:
//! - the surface is unbounded where the front walks (a plane, a tube without a box, a bound
//!   walked the wrong way round on an open surface): the mesh's extent grows with its
//!   triangles and never stops — like a disc (√2 per doubling of the triangles, all normals
//!   one way) or like a tube (2 per doubling);
//! - the step is too coarse for the surface (two sheets closer than the step): new points
//!   land on the other sheet, fronts overlap and never meet, and triangles pile up in the same
//!   place — more of them than the mesh's extent can hold at this step.
//!
//! A mesh that keeps growing (a paraboloid's extent grows by 2^(2/3) per doubling) is asked
//! of the surface itself: surfacepoint from points 2, 4 and 8 times as far from the start as
//! the mesh's farthest vertex must land about that far out too. A closed surface, however
//! large, sends them back to itself, within its diameter. Growth alone is no proof, however
//! fast or flat: the mesh of a thin closed ring (`torus(1, 0.02)` at step 0.004) grows as a
//! tube does along most of the ring, and that of a thin closed plate as a flat disc does
//! across most of a face, both over 200 steps across, before their fronts meet.
//!
//! The watch looks at the triangles made so far at every doubling of their number (from
//! `FIRST_CHECK`), so it costs O(1) per triangle, and probes the surface (three
//! surfacepoints) only at a check where the mesh is over 200 steps across and has grown at the
//! three checks before.

use glam::DVec3;

use super::MarchError;

/// The first check, in triangles; then every doubling.
const FIRST_CHECK: u64 = 4096;
/// The mesh must be at least this many steps across before it is called unbounded.
const UNBOUNDED_EXTENT: f64 = 200.0;
/// Per doubling of the triangles a disc grows by √2 in extent, a tube by 2, a closed surface
/// less and less (once its fronts turn back). These many checks in a row must show growth by
/// this factor before the surface is probed.
const GROWING_CHECKS: usize = 3;
const GROWTH: f64 = 1.3;
/// The probes of a growing mesh: how many times as far from the start as the farthest
/// vertex they start, and the share of that a probe's surface point must keep (surfacepoint
/// moves a point at most about its distance to the surface).
const PROBE_FACTORS: [f64; 3] = [2.0, 4.0, 8.0];
const PROBE_KEEP: f64 = 0.75;
/// At most this many triangles per cube of the step in the mesh's extent (grown by a step on
/// every side). Sheets the marcher keeps apart are at least about a step apart, so a surface
/// holds about 2.3 triangles per step³ of volume at the densest; the factor leaves room for
/// a local step below the step and for small meshes.
pub const TRIANGLES_PER_STEP_CUBED: f64 = 32.0;
/// The area of a triangle of edge `step`, in step²: the overlap test counts area, not
/// triangles, so that the local step's smaller triangles where the surface needs them are
/// not taken for a pile-up.
const EQUILATERAL_AREA: f64 = 0.433_012_701_892_219_3;
/// A box-sized default limit never goes below this many triangles: the local step may need
/// far more triangles than the box holds at the step where the surface is thin or curved
/// (a flat ellipsoid 0.08 thick at step 0.2 takes 0.5 M), and the overlap and growth
/// watches, not the limit, stop the marches that cannot end.
const MIN_BOX_LIMIT: u64 = 2_000_000;

/// The default triangle limit of a mesh block: what its box can hold at the step
/// (`TRIANGLES_PER_STEP_CUBED` per step³ of the box grown by a step), between
/// `MIN_BOX_LIMIT` and `cap`; without a box, `cap`.
pub fn default_limit(bbox: Option<(DVec3, DVec3)>, step: f64, cap: u64) -> u64 {
    let Some((lo, hi)) = bbox else {
        return cap;
    };
    let cells = ((hi - lo) / step + 2.0).element_product();
    let limit = TRIANGLES_PER_STEP_CUBED * cells;
    // Saturating: a huge box (or a NaN from a degenerate one) gives the cap.
    if limit.is_finite() && limit < cap as f64 {
        (limit.ceil() as u64).clamp(MIN_BOX_LIMIT.min(cap), cap)
    } else {
        cap
    }
}

/// The watch on one march.
#[derive(Clone, Debug)]
pub struct Guard {
    step: f64,
    /// A box bounds the mesh: it cannot be unbounded.
    boxed: bool,
    limit: u64,
    /// Triangles already looked at.
    seen: usize,
    next_check: u64,
    lo: DVec3,
    hi: DVec3,
    /// Σ of the triangles' areas.
    area: f64,
    /// The extent (bounding-box diagonal) at each check so far.
    extents: Vec<f64>,
    /// The first vertex of the mesh (the start) and the vertex farthest from it.
    origin: Option<DVec3>,
    farthest: DVec3,
}

impl Guard {
    pub fn new(step: f64, bbox: Option<(DVec3, DVec3)>, limit: u64) -> Guard {
        Guard {
            step,
            boxed: bbox.is_some(),
            limit,
            seen: 0,
            next_check: FIRST_CHECK,
            lo: DVec3::INFINITY,
            hi: DVec3::NEG_INFINITY,
            area: 0.0,
            extents: Vec::new(),
            origin: None,
            farthest: DVec3::ZERO,
        }
    }

    /// Looks at the triangles made since the last call; an error if there are more than the
    /// limit, or at a check, if the mesh grows without end or piles up. `at` is where the
    /// front was last advanced. `surface_point` projects a point onto the surface (None where
    /// surfacepoint fails): the probe of a growing mesh.
    pub fn check(
        &mut self,
        points: &[DVec3],
        triangles: &[[u32; 3]],
        at: DVec3,
        surface_point: impl FnMut(DVec3) -> Option<DVec3>,
    ) -> Result<(), MarchError> {
        let origin = *self
            .origin
            .get_or_insert(points.first().copied().unwrap_or(at));
        let mut farthest = (self.farthest, self.farthest.distance_squared(origin));
        for t in triangles.get(self.seen..).unwrap_or_default() {
            let [Some(&a), Some(&b), Some(&c)] = t.map(|i| points.get(i as usize)) else {
                continue;
            };
            for p in [a, b, c] {
                let d = p.distance_squared(origin);
                if d > farthest.1 {
                    farthest = (p, d);
                }
            }
            self.lo = self.lo.min(a).min(b).min(c);
            self.hi = self.hi.max(a).max(b).max(c);
            self.area += 0.5 * (b - a).cross(c - a).length();
        }
        self.farthest = farthest.0;
        self.seen = triangles.len();
        let count = triangles.len() as u64;
        if count > self.limit {
            return Err(MarchError::TooManyTriangles {
                limit: self.limit,
                at,
            });
        }
        if count < self.next_check {
            return Ok(());
        }
        self.next_check = count.saturating_mul(2);
        self.at_check(count, at, surface_point)
    }

    fn at_check(
        &mut self,
        count: u64,
        at: DVec3,
        mut surface_point: impl FnMut(DVec3) -> Option<DVec3>,
    ) -> Result<(), MarchError> {
        let size = self.hi - self.lo;
        let extent = size.length();
        self.extents.push(extent);
        let cells = (size / self.step + 2.0).element_product();
        let area_in_steps = self.area / (self.step * self.step);
        if area_in_steps > TRIANGLES_PER_STEP_CUBED * EQUILATERAL_AREA * cells {
            return Err(MarchError::Overlapping {
                at,
                triangles: count,
                lo: self.lo,
                hi: self.hi,
            });
        }
        if self.boxed || extent < UNBOUNDED_EXTENT * self.step {
            return Ok(());
        }
        let growing = self.extents.len() > GROWING_CHECKS
            && self
                .extents
                .windows(2)
                .rev()
                .take(GROWING_CHECKS)
                .all(|w| w[1] >= GROWTH * w[0]);
        let reaches_out = |surface_point: &mut dyn FnMut(DVec3) -> Option<DVec3>| {
            let Some(origin) = self.origin else {
                return false;
            };
            let reach = self.farthest - origin;
            PROBE_FACTORS.iter().all(|&k| {
                surface_point(origin + k * reach)
                    .is_some_and(|p| (p - origin).length() >= PROBE_KEEP * k * reach.length())
            })
        };
        if growing && reaches_out(&mut surface_point) {
            return Err(MarchError::Unbounded {
                at,
                triangles: count,
                extent,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_limit_follows_the_box() {
        assert_eq!(default_limit(None, 0.1, 10_000_000), 10_000_000);
        // A box 10 steps wide: 12³ cells of the step (the box grown by a step each side).
        let unit = Some((DVec3::ZERO, DVec3::splat(1.0)));
        assert_eq!(default_limit(unit, 0.1, 10_000_000), MIN_BOX_LIMIT);
        let big = Some((DVec3::ZERO, DVec3::splat(100.0)));
        let expected = (TRIANGLES_PER_STEP_CUBED * 102.0f64.powi(3)).ceil() as u64;
        assert_eq!(default_limit(big, 1.0, 100_000_000), expected);
        assert_eq!(default_limit(big, 1.0, 10_000_000), 10_000_000);
        assert_eq!(default_limit(big, 1e-300, 10_000_000), 10_000_000);
    }

    /// A flat disc of triangles growing ring by ring.
    fn disc(rings: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut points = vec![DVec3::ZERO];
        let mut triangles = Vec::new();
        for r in 1..=rings {
            let n = 6 * r;
            let first = points.len() as u32;
            for k in 0..n {
                let a = std::f64::consts::TAU * f64::from(k) / f64::from(n);
                points.push(f64::from(r) * DVec3::new(a.cos(), a.sin(), 0.0));
            }
            // Each edge of the ring joined to the nearest point of the ring inside: triangles
            // of about unit size, so areas and extents are those of a disc.
            let inner = 6 * (r - 1);
            for k in 0..n {
                let j = if inner == 0 {
                    0
                } else {
                    first - inner + (k * (r - 1) / r) % inner
                };
                triangles.push([j, first + k, first + (k + 1) % n]);
            }
        }
        (points, triangles)
    }

    #[test]
    fn a_growing_plane_is_unbounded_and_a_boxed_one_is_not() {
        let (points, triangles) = disc(400);
        // The plane z = 0: a probe lands where it starts.
        let found = first_failure(&points, &triangles, |q| Some(DVec3::new(q.x, q.y, 0.0)));
        assert!(
            matches!(found, Some(MarchError::Unbounded { .. })),
            "{found:?}"
        );
        let boxed = Some((DVec3::splat(-1e6), DVec3::splat(1e6)));
        let mut guard = Guard::new(1.0, boxed, u64::MAX);
        assert!(
            guard
                .check(&points, &triangles, DVec3::ZERO, |_| None)
                .is_ok()
        );
    }

    /// The first check that fails, feeding `triangles` a thousand at a time.
    fn first_failure(
        points: &[DVec3],
        triangles: &[[u32; 3]],
        mut surface_point: impl FnMut(DVec3) -> Option<DVec3>,
    ) -> Option<MarchError> {
        let mut guard = Guard::new(1.0, None, u64::MAX);
        (1000..=triangles.len()).step_by(1000).find_map(|end| {
            guard
                .check(points, &triangles[..end], points[0], &mut surface_point)
                .err()
        })
    }

    /// The same flat disc as one face of a thin closed plate 1 000 steps across (the probes
    /// land on its rim, within its diameter): it grows as a plane's mesh does, but the
    /// surface does not reach out, so it is not unbounded. Nor is a mesh whose probes find
    /// no surface point.
    #[test]
    fn a_growing_flat_mesh_of_a_closed_plate_is_not_unbounded() {
        let (points, triangles) = disc(400);
        let plate = |q: DVec3| {
            let r = q.truncate().length();
            let p = DVec3::new(q.x, q.y, 0.0);
            Some(if r > 500.0 { p * (500.0 / r) } else { p })
        };
        let mut probed = false;
        let found = first_failure(&points, &triangles, |q| {
            probed = true;
            plate(q)
        });
        assert!(found.is_none(), "{found:?}");
        assert!(probed, "the growth checks never asked the surface");
        assert!(first_failure(&points, &triangles, |_| None).is_none());
    }

    /// The disc bent onto a paraboloid (z = r²/40) is unbounded, and
    /// onto a sphere of radius 150 (a cap 200 steps across, still growing by 1.3 per
    /// doubling) is not: the probes land far out on the one and fall back onto the other.
    #[test]
    fn a_growing_curved_mesh_is_unbounded_only_where_the_surface_reaches_out() {
        let (disc, triangles) = disc(300);
        let paraboloid = |p: DVec3| DVec3::new(p.x, p.y, (p.x * p.x + p.y * p.y) / 40.0);
        let points: Vec<DVec3> = disc.iter().map(|&p| paraboloid(p)).collect();
        let found = first_failure(&points, &triangles, |q| Some(paraboloid(q)));
        assert!(
            matches!(found, Some(MarchError::Unbounded { .. })),
            "{found:?}"
        );

        let radius = 150.0;
        let centre = DVec3::new(0.0, 0.0, -radius);
        // The disc's radius r becomes the arc length from the pole.
        let sphere = |p: DVec3| {
            let r = p.truncate().length();
            if r == 0.0 {
                return DVec3::ZERO;
            }
            let angle = r / radius;
            let dir = p.truncate() / r;
            centre + radius * DVec3::new(dir.x * angle.sin(), dir.y * angle.sin(), angle.cos())
        };
        let points: Vec<DVec3> = disc.iter().map(|&p| sphere(p)).collect();
        let project = |q: DVec3| Some(centre + radius * (q - centre).normalize());
        assert!(first_failure(&points, &triangles, project).is_none());
        // Without the probes the sphere's cap would be taken for a paraboloid.
        let mut probed = false;
        first_failure(&points, &triangles, |q| {
            probed = true;
            project(q)
        });
        assert!(probed, "the growth checks never asked the surface");
    }

    #[test]
    fn triangles_piling_up_in_place_are_overlapping() {
        // The same small triangle, again and again: a front walking over itself.
        let points = vec![DVec3::ZERO, DVec3::X, DVec3::Y];
        let triangles = vec![[0, 1, 2]; 5000];
        let mut guard = Guard::new(1.0, None, u64::MAX);
        assert!(matches!(
            guard.check(&points, &triangles, DVec3::ZERO, |_| None),
            Err(MarchError::Overlapping {
                triangles: 5000,
                ..
            })
        ));
    }
}
