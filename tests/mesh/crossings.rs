//! The crossing check (`mesh::check::intersecting_pairs`, the verification's search for
//! triangles that cross) on marched meshes that are made to cross: two overlapping spheres
//! put into one mesh cross exactly along their intersection circle. Checked against the
//! geometry and against a test of every pair near the circle written here on its own (signs
//! of orientation determinants): every pair found joins the two spheres and lies at the
//! circle, the pairs found go all the way round it, and they are exactly the pairs near the
//! circle that cross; for spheres of one step and of steps three times apart (two size
//! classes of the search's grids), near the origin and far from it.

use crate::common;

use common::sphere;
use glam::DVec3;
use surfc::march::{MarchInput, MarchSettings, march};
use surfc::mesh::Mesh;
use surfc::mesh::check::{intersecting_pairs, intersecting_pairs_searched};

/// A sphere of radius 2 about the origin, marched at `step` and moved by `shift`.
fn marched_sphere(step: f64, shift: DVec3) -> Mesh {
    let mut s = sphere(2.0);
    let input = MarchInput::from_point(step, DVec3::new(1.0, 1.0, 1.0));
    let mut m = march(s.as_mut(), &input, &MarchSettings::default()).expect("the sphere meshes");
    for v in &mut m.vertices {
        *v += shift;
    }
    m
}

/// Both meshes as one (the second's indices after the first's).
fn join(a: &Mesh, b: &Mesh) -> Mesh {
    let base = a.vertices.len() as u32;
    Mesh {
        vertices: a.vertices.iter().chain(&b.vertices).copied().collect(),
        normals: a.normals.iter().chain(&b.normals).copied().collect(),
        triangles: a
            .triangles
            .iter()
            .copied()
            .chain(b.triangles.iter().map(|t| t.map(|k| k + base)))
            .collect(),
        sides: Vec::new(),
    }
}

/// Spheres about `origin` and `origin + (1, 0, 0)` (radius 2): they meet in the circle of
/// radius √3.75 in the plane x = origin.x + 0.5.
fn crossing_spheres(step_a: f64, step_b: f64, origin: DVec3) {
    let a = marched_sphere(step_a, origin);
    let b = marched_sphere(step_b, origin + DVec3::X);
    let (na, coarse) = (a.triangles.len() as u32, step_a.max(step_b));
    assert!(intersecting_pairs(&a).is_empty() && intersecting_pairs(&b).is_empty());
    let m = join(&a, &b);
    let pairs = intersecting_pairs(&m);
    let centre = origin + DVec3::new(0.5, 0.0, 0.0);
    let radius = 3.75f64.sqrt();
    let centroid = |t: u32| {
        m.triangles[t as usize]
            .iter()
            .map(|&k| m.vertices[k as usize])
            .sum::<DVec3>()
            / 3.0
    };
    // How far a point is from the circle, and its angle about the x axis.
    let off_circle = |p: DVec3| {
        let d = p - centre;
        let r = (d.y * d.y + d.z * d.z).sqrt();
        (d.x * d.x + (r - radius).powi(2)).sqrt()
    };
    let mut covered = [false; 72];
    for &[i, j] in &pairs {
        assert!(
            i < na && j >= na,
            "pair {i}, {j}: a crossing within one sphere"
        );
        for t in [i, j] {
            let p = centroid(t);
            assert!(
                off_circle(p) < coarse,
                "triangle {t} at {p} is {} from the circle",
                off_circle(p)
            );
            let d = p - centre;
            let turn = d.z.atan2(d.y).rem_euclid(std::f64::consts::TAU);
            covered[((turn / std::f64::consts::TAU * 72.0) as usize).min(71)] = true;
        }
    }
    // Every pair of triangles near the circle, one of each sphere, by the test below.
    let near: Vec<u32> = (0..m.triangles.len() as u32)
        .filter(|&t| off_circle(centroid(t)) < 2.0 * coarse)
        .collect();
    let corners = |t: u32| m.triangles[t as usize].map(|k| m.vertices[k as usize]);
    let mut expected: Vec<[u32; 2]> = Vec::new();
    for &i in near.iter().filter(|&&t| t < na) {
        for &j in near.iter().filter(|&&t| t >= na) {
            if cross(corners(i), corners(j)) {
                expected.push([i, j]);
            }
        }
    }
    assert_eq!(pairs, expected, "steps {step_a}, {step_b} at {origin}");
    // The circle is 12 units long; every 5° of it (0.17) is crossed by triangles of the
    // coarser sphere, which the search must find.
    let missed: Vec<usize> = (0..72).filter(|&k| !covered[k]).collect();
    assert!(
        missed.is_empty(),
        "steps {step_a}, {step_b} at {origin}: no crossing found at {:?} (×5°); {} pairs",
        missed,
        pairs.len()
    );
}

#[test]
fn overlapping_spheres_cross_all_round_their_circle() {
    crossing_spheres(0.1, 0.1, DVec3::ZERO);
}

#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn spheres_of_different_steps_cross_all_round_their_circle() {
    crossing_spheres(0.05, 0.15, DVec3::ZERO);
    crossing_spheres(0.15, 0.05, DVec3::ZERO);
}

#[test]
fn spheres_far_from_the_origin_cross_all_round_their_circle() {
    crossing_spheres(0.1, 0.05, DVec3::new(3.0e5, -2.0e5, 1.0e5));
}

#[test]
fn spheres_apart_do_not_cross() {
    let a = marched_sphere(0.1, DVec3::ZERO);
    let b = marched_sphere(0.1, DVec3::new(4.2, 0.0, 0.0));
    assert_eq!(intersecting_pairs(&join(&a, &b)), Vec::<[u32; 2]>::new());
}

/// Marched spheres with corners moved (a few or many, by up to four steps, in one place or
/// all over): the check with its certificate (`mesh::height_fields`) returns exactly the pairs
/// the search over every triangle returns, crossing or not — the verification's refusals are
/// the same. Most rounds cross (20 of the 24).
#[test]
fn moved_corners_of_a_marched_sphere_give_the_searchs_pairs() {
    let step = 0.1;
    let base = marched_sphere(step, DVec3::ZERO);
    assert!(intersecting_pairs(&base).is_empty());
    let mut rng = common::rng::Rng::new(0x9e37_79b9_7f4a_7c15);
    let mut unit = move || rng.unit();
    let mut crossed = 0;
    for round in 0..24 {
        let mut m = base.clone();
        let moves = [10, 100, 1000][round % 3];
        let reach = [1.0, 2.0, 4.0][round / 3 % 3] * step;
        let centre = m.vertices[(unit() * m.vertices.len() as f64) as usize];
        let near: Vec<usize> = (0..m.vertices.len())
            .filter(|&k| round % 2 == 0 || m.vertices[k].distance(centre) < 8.0 * step)
            .collect();
        for _ in 0..moves {
            let k = near[(unit() * near.len() as f64) as usize];
            m.vertices[k] += reach * 2.0 * DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
        }
        let searched = intersecting_pairs_searched(&m);
        crossed += usize::from(!searched.is_empty());
        assert_eq!(intersecting_pairs(&m), searched, "round {round}");
    }
    assert!(crossed >= 18, "{crossed} of 24 rounds crossed");
}

/// The sign of the orientation determinant of (b − a, c − a, d − a).
fn orient(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).cross(c - a).dot(d - a).signum()
}

/// Does an edge of one triangle pass through the other's interior (strictly: the ends on
/// opposite sides of its plane, the edge's line on one side of each of its edges)? For two
/// triangles with no corner in common.
fn cross(t: [DVec3; 3], u: [DVec3; 3]) -> bool {
    let through = |[p, q]: [DVec3; 2], [a, b, c]: [DVec3; 3]| {
        let (sp, sq) = (orient(a, b, c, p), orient(a, b, c, q));
        let sides = [orient(p, q, a, b), orient(p, q, b, c), orient(p, q, c, a)];
        sp * sq < 0.0 && sides[0] != 0.0 && sides.iter().all(|&s| s == sides[0])
    };
    (0..3).any(|k| through([t[k], t[(k + 1) % 3]], u) || through([u[k], u[(k + 1) % 3]], t))
}
