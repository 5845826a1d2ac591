//! Closed surfaces of the paper (Sects. 3.1, 3.3, 3.5): watertight, consistently oriented,
//! one component, the Euler characteristic of their genus, triangle counts near the paper's.

mod common;

use common::*;
use glam::DVec3;
use surfc::march::MarchInput;
use surfc::mesh::check::Expect;

fn closed(euler: i64) -> Expect {
    Expect {
        closed: true,
        euler: Some(euler),
        components: Some(1),
        ..Expect::default()
    }
}

#[test]
fn sphere_of_the_paper() {
    let mut s = sphere(2.0);
    let m = mesh_and_check(
        "sphere r=2 δ=0.3",
        &mut s,
        &MarchInput::from_point(0.3, DVec3::new(1.0, 1.0, 1.0)),
        closed(2),
    );
    assert_near_paper("sphere", m.triangles.len(), 1544);
}

#[test]
fn torus_of_the_paper() {
    let mut s = torus(1.0, 0.35);
    mesh_and_check(
        "torus δ=0.1",
        &mut s,
        &MarchInput::from_point(0.1, DVec3::new(1.0, 0.0, 0.5)),
        closed(0),
    );
}

#[test]
fn genus3_of_the_paper() {
    let mut s = genus3();
    let m = mesh_and_check(
        "genus 3 δ=0.3",
        &mut s,
        &MarchInput::from_point(0.3, DVec3::new(0.0, 3.0, 0.0)),
        closed(-4),
    );
    assert_near_paper("genus 3", m.triangles.len(), 7354);
}
