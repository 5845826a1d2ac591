//! The voxel reference of `common::voxel` on solids whose topology is known in closed form:
//! it must be right before mesh tests may trust it.

use crate::common;

use common::voxel::solid_count;
use glam::DVec3;

fn cube(a: f64) -> (DVec3, DVec3) {
    (DVec3::splat(-a), DVec3::splat(a))
}

#[test]
fn ball_is_one_contractible_solid() {
    let (lo, hi) = cube(1.5);
    let c = solid_count(|p| p.length_squared() - 1.0, lo, hi, 40);
    assert_eq!((c.euler, c.components, c.touches_box), (1, 1, false));
    assert_eq!(c.surface_euler(), 2);
}

#[test]
fn solid_torus_has_euler_zero_and_thin_tube_needs_a_fine_grid() {
    let torus = |a: f64| move |p: DVec3| (p.truncate().length() - 1.0).hypot(p.z) - a;
    let (lo, hi) = cube(1.5);
    let c = solid_count(torus(0.3), lo, hi, 40);
    assert_eq!((c.euler, c.components), (0, 1));
    // A tube of radius 0.05 falls between the vertices of a 10-cell grid (spacing 0.3) but
    // not of a 150-cell one (spacing 0.02): the grid must be finer than the feature.
    let coarse = solid_count(torus(0.05), lo, hi, 10);
    assert_ne!((coarse.euler, coarse.components), (0, 1));
    let fine = solid_count(torus(0.05), lo, hi, 150);
    assert_eq!((fine.euler, fine.components), (0, 1));
}

#[test]
fn genus_two_plate_and_disjoint_balls() {
    // A slab |z| < 0.2 over the disc r < 2 with two round holes: χ(solid) = 1 − 2 = −1.
    let plate = |p: DVec3| {
        let disc = p.truncate().length() - 2.0;
        let slab = p.z.abs() - 0.2;
        let hole = |c: f64| 0.5 - (p.truncate() - glam::DVec2::new(c, 0.0)).length();
        disc.max(slab).max(hole(-0.9)).max(hole(0.9))
    };
    let (lo, hi) = cube(2.5);
    let c = solid_count(plate, lo, hi, 100);
    assert_eq!((c.euler, c.components), (-1, 1));
    assert_eq!(c.surface_euler(), -2);

    let two = |p: DVec3| ((p - DVec3::X).length() - 0.6).min((p + DVec3::X).length() - 0.6);
    let c = solid_count(two, lo, hi, 50);
    assert_eq!((c.euler, c.components), (2, 2));
}

#[test]
fn hollow_ball_counts_its_cavity_and_box_contact_is_reported() {
    let shell = |p: DVec3| (p.length() - 1.0).abs() - 0.2;
    let (lo, hi) = cube(1.5);
    // A ball with a cavity: χ = 1 + 1 = 2 (its boundary is two spheres, χ = 4).
    let c = solid_count(shell, lo, hi, 60);
    assert_eq!((c.euler, c.components, c.touches_box), (2, 1, false));
    let half = solid_count(|p| p.z, lo, hi, 10);
    assert!(half.touches_box);
    assert_eq!(half.euler, 1);
}
