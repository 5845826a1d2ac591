//! The gallery's `dist()` meshes (docs/examples.md: Sects. 3.7 and 3.11) against the accuracy bar of
//! docs/quality.md: every vertex satisfies |f|/|∇f| ≤ 1e-9·step when re-evaluated with a FRESH
//! surface instance (cold foot-point searches, no warm start; every tenth vertex by default,
//! all with `SURFC_DIST_COLD_ALL=1`), and also with one instance
//! evaluating every vertex in order (warm starts, as the mesh report does). The two differ
//! when a foot-point search returns a local, not the global, nearest point (regression: the
//! closure of the G² set's quartic cylinder near its axis, and the offset of the quartic
//! cylinder in `patches_offset`, had errors up to 6e-2).
//!
//! The fresh surfaces are built through the public API, mirroring the CLI's builder: parse,
//! check, `compile_surface` with `dist` children as `ImplicitDist` / `PatchDist` whose
//! foot tolerance has `scale` = the mesh step.

use crate::common;

use common::build::{build, checked};
use glam::DVec3;
use surfc::surface::Surface;

/// docs/quality.md: vertices within this many steps of their surface.
const VERTEX_ERROR_PER_STEP: f64 = 1e-9;

/// |f|/|∇f| at p (infinite for NaN: a failed foot point is as bad as a wrong one).
fn vertex_error(surface: &mut dyn Surface, p: DVec3) -> f64 {
    let vg = surface.value_gradient(p);
    let e = vg.value.abs() / vg.gradient.length();
    if vg.value == 0.0 {
        0.0
    } else if e.is_nan() {
        f64::INFINITY
    } else {
        e
    }
}

/// Checks the named meshes of the example (the gallery's shared meshes) vertex by vertex:
/// every vertex by one surface evaluated warm (its `dist` oracle starting from the last foot
/// point), and every tenth by a surface compiled afresh for it (cold); every vertex cold with
/// `SURFC_DIST_COLD_ALL=1` (`.ci/run` sets it; a compile per vertex is most of the time).
fn assert_vertices_on_surface(path: &str, names: &[&str]) {
    let cold_every = if common::env_flag("SURFC_DIST_COLD_ALL") {
        1
    } else {
        10
    };
    let source = std::fs::read_to_string(path).expect("the example exists");
    let program = checked(&source);
    let meshed = &crate::gallery::gallery_mesh(std::path::Path::new(path)).meshed;
    for name in names {
        let m = meshed
            .iter()
            .find(|m| m.name == *name)
            .unwrap_or_else(|| panic!("{path} has no mesh `{name}`"));
        let def = program
            .meshes
            .iter()
            .find(|d| d.name == *name)
            .expect("every meshed block is defined");
        let bound = VERTEX_ERROR_PER_STEP * def.step;
        assert!(!m.mesh.vertices.is_empty(), "{name}: empty mesh");
        let mut same = build(&program, &def.surface, def.step).expect("compiles");
        let (mut worst_fresh, mut worst_same) = (0.0f64, 0.0f64);
        for (i, &p) in m.mesh.vertices.iter().enumerate() {
            let e_same = vertex_error(&mut same, p);
            assert!(
                e_same <= bound,
                "{name}: vertex {i} at {p} is {e_same:e} off its surface evaluated warm (bound {bound:e})"
            );
            worst_same = worst_same.max(e_same);
            if i % cold_every != 0 {
                continue;
            }
            let mut fresh = build(&program, &def.surface, def.step).expect("compiles");
            let e_fresh = vertex_error(&mut fresh, p);
            assert!(
                e_fresh <= bound,
                "{name}: vertex {i} at {p} is {e_fresh:e} off its surface evaluated cold (bound {bound:e})"
            );
            worst_fresh = worst_fresh.max(e_fresh);
        }
        assert!(
            m.report.max_vertex_error <= bound,
            "{name}: the mesh report says {:e}",
            m.report.max_vertex_error
        );
        println!(
            "{name}: {} vertices, max |f|/|∇f| cold {worst_fresh:e}, warm {worst_same:e}, report {:e}",
            m.mesh.vertices.len(),
            m.report.max_vertex_error
        );
    }
}

#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn g2_set_dist_meshes_have_every_vertex_on_the_surface() {
    assert_vertices_on_surface("examples/g2_set.surf", &["roof", "blend", "closure"]);
}

#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn intersecting_patches_meshes_have_every_vertex_on_the_surface() {
    assert_vertices_on_surface(
        "examples/intersecting_patches.surf",
        &["patches", "patches_offset"],
    );
}
