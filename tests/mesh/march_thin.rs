//! Features thinner than the step (issue 10): a thin torus, a genus-2 plate with a bridge
//! thinner than the step, a flat ellipsoid, a dumbbell with a thin neck. The local step must
//! mesh each with its true topology (known from its genus), one component, the surface's
//! bounding box within the tolerance, no crossing triangles and no angle below 15°.

use crate::common;

use common::thin::{Shape, dumbbell, plate, superquadric, torus};
use common::*;
use glam::{DMat3, DVec3};
use surfc::march::{MarchInput, MarchSettings, march_verified};
use surfc::mesh::check::{Expect, check};
use surfc::mesh::quality::quality;

/// Meshes `shape` at `step` with the default tolerance (0.1·step) and checks it against
/// what is known of the shape, with no angle below `min_angle_deg`.
fn thin_case(shape: &Shape, step: f64, min_angle_deg: f64) {
    let mut s = shape.surface();
    let input = MarchInput::from_point(step, shape.start);
    let settings = MarchSettings::default();
    let tolerance = settings.tolerance * step;
    let m = match march_verified(s.as_mut(), None, &input, &settings, None) {
        Ok(m) => m,
        Err(e) => panic!("{} at step {step}: {e}", shape.name),
    };
    let expect = Expect {
        closed: true,
        euler: Some(shape.euler),
        components: Some(1),
        max_vertex_error: Some(1e-9 * step),
        min_angle_deg,
        ..Expect::default()
    };
    let (topo, violations) = check(&m.mesh, Some(s.as_mut()), &expect);
    let (lo, hi) = m.mesh.vertices.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), &v| (lo.min(v), hi.max(v)),
    );
    let q = quality(&m.mesh);
    println!(
        "{} step {step}: {} triangles, euler {}, min angle {:.1}°, chord {:.2e} (tol {:.2e}), box {lo} .. {hi}, {} refinement(s), warnings {:?}",
        shape.name,
        topo.triangles,
        topo.euler_characteristic,
        q.min_angle_deg,
        m.max_chord_error,
        tolerance,
        m.refinements,
        m.warnings
    );
    assert!(violations.is_empty(), "{}: {violations:?}", shape.name);
    assert!(m.max_chord_error <= tolerance, "{}", shape.name);
    let off = (lo - shape.bbox.0).abs().max((hi - shape.bbox.1).abs());
    assert!(
        off.max_element() <= tolerance,
        "{}: box {lo} .. {hi}, the surface's {:?}",
        shape.name,
        shape.bbox
    );
}

#[test]
fn thin_torus_at_twice_and_four_times_its_tube() {
    let t = torus(1.0, 0.05, DMat3::IDENTITY);
    thin_case(&t, 0.1, 30.0);
    thin_case(&t, 0.2, 30.0);
}

#[test]
fn genus2_plate_with_a_bridge_thinner_than_the_step() {
    // Holes of radius 0.6 with a 0.12-wide, 0.07-thick bridge between them, at step 0.2.
    let p = plate(2, 2.0, 1.0, 0.6, 0.12, 0.2);
    assert!(p.feature < 0.2, "{}", p.feature);
    thin_case(&p, 0.2, 30.0);
}

/// The rim's radius of curvature is 0.0008 = step/250, at the floor of the local step: the
/// triangles across it reached 13.8° before the quality stage (issue 10 asks 15°), 29.5°
/// with its first version, 30.2° with the ODT, the corner removal and grading 0.2.
#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn flat_ellipsoid_at_five_times_its_thickness() {
    thin_case(&superquadric(2.0, 2.0, 0.04, 2), 0.2, 30.0);
}

#[test]
fn dumbbell_with_a_neck_thinner_than_the_step() {
    thin_case(&dumbbell(0.05, DMat3::IDENTITY), 0.15, 30.0);
}

/// The paper's genus 3 at its step 0.3: the tight rims need the local step (the uniform
/// step left triangles 0.53 δ off the surface there).
#[test]
fn genus3_chord_error_within_a_tenth_of_the_step() {
    let mut s = genus3();
    let settings = MarchSettings::default();
    let input = MarchInput::from_point(0.3, DVec3::new(0.0, 3.0, 0.0));
    let m = march_verified(s.as_mut(), None, &input, &settings, None).expect("genus 3 meshes");
    println!(
        "genus 3: {} triangles, chord {:.3e}",
        m.mesh.triangles.len(),
        m.max_chord_error
    );
    assert!(m.max_chord_error <= 0.1 * 0.3);
    let (topo, violations) = check(
        &m.mesh,
        None,
        &Expect {
            closed: true,
            euler: Some(-4),
            components: Some(1),
            ..Expect::default()
        },
    );
    assert!(violations.is_empty(), "{violations:?} {topo:?}");
}

/// The sizing's cost where it never binds: the sphere r = 2 at step 0.01 (≈ 1.3 M
/// triangles) with the local step and with `uniform: true`, in one run. Run with
/// `cargo test --release --test mesh march_thin:: -- --ignored --nocapture`
/// (benches/march.rs has the same pair under criterion).
#[test]
#[ignore]
fn sphere_local_step_cost() {
    let settings = MarchSettings::default();
    let time = |uniform: bool| {
        let mut s = sphere(2.0);
        let input = MarchInput {
            uniform,
            ..MarchInput::from_point(0.01, DVec3::new(1.0, 1.0, 1.0))
        };
        let t = std::time::Instant::now();
        let m =
            march_verified(s.as_mut(), None, &input, &settings, None).expect("the sphere meshes");
        (t.elapsed().as_secs_f64(), m.mesh.triangles.len())
    };
    let (uniform, nu) = time(true);
    let (local, nl) = time(false);
    println!(
        "sphere step 0.01: local step {local:.3} s ({nl} triangles), uniform {uniform:.3} s ({nu} triangles), ratio {:.3}",
        local / uniform
    );
    // The verification's crossing check alone, on the same mesh.
    let mut s = sphere(2.0);
    let input = MarchInput::from_point(0.01, DVec3::new(1.0, 1.0, 1.0));
    let m = march_verified(s.as_mut(), None, &input, &settings, None).expect("the sphere meshes");
    let t = std::time::Instant::now();
    let pairs = surfc::mesh::check::intersecting_pairs(&m.mesh);
    println!(
        "crossing check: {:.3} s, {} pair(s)",
        t.elapsed().as_secs_f64(),
        pairs.len()
    );
    assert!(pairs.is_empty());
}

/// With the uniform step and the default tolerance a chord error above the tolerance is a
/// warning (issue 42) — but not where it is the only sign of a wrong mesh: the dumbbell with a
/// neck 0.05 wide at uniform steps of 0.12 to 0.25 meshes one bulb capped at the neck,
/// watertight with χ = 2, and must be refused (the local step's mesh reaches the other bulb),
/// never returned; a mesh that is returned covers both bulbs.
#[test]
fn the_uniform_step_never_caps_a_neck() {
    let shape = dumbbell(0.05, DMat3::IDENTITY);
    for step in [0.12, 0.15, 0.18, 0.2, 0.25] {
        let mut s = shape.surface();
        let input = MarchInput {
            uniform: true,
            ..MarchInput::from_point(step, shape.start)
        };
        match march_verified(s.as_mut(), None, &input, &MarchSettings::default(), None) {
            Err(e) => println!("step {step}: refused: {e}"),
            Ok(m) => {
                let (lo, hi) = m
                    .mesh
                    .vertices
                    .iter()
                    .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &v| {
                        (lo.min(v), hi.max(v))
                    });
                println!("step {step}: meshed, x from {} to {}", lo.x, hi.x);
                assert!(
                    lo.x < -0.9 && hi.x > 0.9,
                    "step {step}: one bulb, {lo} .. {hi}"
                );
            }
        }
    }
}

/// The sizing's proven free cells (`survey::free_cells`) give the size the thickness rays'
/// walk gives, bit for bit: random ellipsoids, tori (tubes from thinner than the rays' reach
/// to wider), wavy slabs and products of two spheres (a neck or two blobs), compiled from
/// source as `surfc mesh` compiles them, at random surface points. Both outcomes of the
/// proof occur, so the comparison is not vacuous.
#[test]
fn free_cells_give_the_size_the_rays_walk_gives() {
    use surfc::solve::surface_point;
    use surfc::survey::free_cells::FreeCells;
    use surfc::survey::sizing::{Sizing, SizingSettings};

    let mut rng = common::rng::Rng::new(41);
    let (mut proven, mut walked) = (0usize, 0usize);
    for case in 0..24 {
        let (a, b, c) = (
            rng.range(0.2, 2.0),
            rng.range(0.2, 2.0),
            rng.range(0.2, 2.0),
        );
        let step = rng.range(0.01, 0.1);
        let surface = match case % 4 {
            0 => format!("x^2 / {} + y^2 / {} + z^2 / {} - 1", a * a, b * b, c * c),
            1 => format!(
                "(hypot(x, y) - {})^2 + z^2 - {}",
                a.max(0.6),
                (0.2 * c * step / 0.1 + 0.01).powi(2)
            ),
            2 => format!(
                "z^2 - {} + 0.1 * sin({a} * x) * cos({b} * y)",
                (c * step).powi(2)
            ),
            _ => format!(
                "(x^2 + y^2 + z^2 - 1) * ((x - {})^2 + y^2 + z^2 - 1) - {}",
                1.5 + 0.3 * a,
                0.05 * b
            ),
        };
        let source =
            format!("surface s = {surface};\nmesh m = s {{ step: {step}; start: (0, 0, 0); }}\n");
        let program = common::build::checked(&source);
        let def = &program.meshes[0];
        let mut f = common::build::build(&program, &def.surface, def.step).expect("compiles");
        let sizing = Sizing::new(step, 0.1 * step, SizingSettings::default());
        let mut cells = FreeCells::new(sizing.reach());
        for _ in 0..150 {
            let q = rng.direction() * rng.range(0.0, 2.0 * a.max(b).max(c));
            let Ok(sp) = surface_point(&mut f, q, step, &Default::default()) else {
                continue;
            };
            let walk = sizing.size(&mut f, &sp, None, None);
            let before = proven;
            if cells.proves_free(&mut f, sp.point, sp.normal) {
                proven += 1;
            } else {
                walked += 1;
            }
            let with_cells = sizing.size(&mut f, &sp, None, Some(&mut cells));
            assert_eq!(
                with_cells,
                walk,
                "case {case} ({surface}, step {step}) at {} (proven: {})",
                sp.point,
                proven > before
            );
        }
    }
    println!("free cells: {proven} points proven free, {walked} walked");
    assert!(
        proven > 100 && walked > 100,
        "{proven} proven, {walked} walked"
    );
}
