//! Surfaces cut by the global box (Sects. 3.2a, 3.4, 3.6): the front stops at the box, its
//! border points become the mesh boundary, every vertex lies inside the box.

use crate::common;

use common::*;
use glam::DVec3;
use surfc::march::MarchInput;
use surfc::mesh::check::Expect;

fn boxed(step: f64, start: DVec3, lo: DVec3, hi: DVec3) -> (MarchInput, Expect) {
    let mut input = MarchInput::from_point(step, start);
    input.bbox = Some((lo, hi));
    let expect = Expect {
        bbox: Some((lo, hi)),
        boundary_on_box: true,
        box_tolerance: 1e-9 * step,
        ..Expect::default()
    };
    (input, expect)
}

#[test]
fn cylinder_in_a_box() {
    let (lo, hi) = (DVec3::new(-2.0, -2.0, -1.0), DVec3::new(2.0, 2.0, 1.0));
    let (input, mut expect) = boxed(0.2, DVec3::new(1.0, 0.0, 0.0), lo, hi);
    expect.euler = Some(0);
    expect.boundary_loops = Some(2);
    expect.components = Some(1);
    let mut s = cylinder(1.0);
    mesh_and_check("cylinder in box δ=0.2", &mut s, &input, expect);
}

#[test]
fn six_peak_in_its_box() {
    let (lo, hi) = (DVec3::new(-1.2, -1.2, -0.3), DVec3::new(1.2, 1.2, 1.0));
    let (input, mut expect) = boxed(0.07, DVec3::new(0.0, 0.0, 0.1), lo, hi);
    expect.components = Some(1);
    let mut s = six_peak();
    mesh_and_check("six-peak δ=0.07", &mut s, &input, expect);
}

/// The start point: surfacepoint from the origin (f = 737 there) reaches the surface; the
/// paper gives none.
#[test]
fn three_cylinders_in_their_box() {
    let (lo, hi) = (DVec3::new(-7.0, -7.0, -7.0), DVec3::new(7.0, 7.0, 5.0));
    let (mut input, mut expect) = boxed(0.5, DVec3::ZERO, lo, hi);
    input.uniform = true;
    input.tolerance = Some(0.6 * 0.5);
    expect.components = Some(1);
    let mut s = three_cylinders(2287.5587);
    let m = mesh_and_check("three cylinders δ=0.5", &mut s, &input, expect);
    assert_near_paper("three cylinders", m.triangles.len(), 5297);
}
