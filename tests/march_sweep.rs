//! Generated closed surfaces with features of random size (tori with random tube radii and
//! orientations, dumbbells with random necks and axes, genus-n plates with random bridges and
//! thickness, superquadrics with random axes) meshed at steps from a quarter of the smallest
//! feature to four times it. Each must come out right (watertight, the Euler characteristic
//! of its genus, one component, its bounding box within the tolerance, no crossing
//! triangles) or be refused with an error: never a wrong mesh reported as success.
//!
//! `SURFC_SWEEP=N` runs N shapes (default 60, ~15 s on one core; 200 take ~30 s); the figures
//! (right, refused, wrong, time) are printed.

mod common;

use common::thin::{Shape, dumbbell, plate, superquadric, torus};
use glam::{DMat3, DVec3};
use surfc::march::{MarchInput, MarchSettings, march_verified};
use surfc::mesh::check::{Expect, check};

/// A small deterministic generator (SplitMix64), so every run sees the same shapes.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    /// Log-uniform in [lo, hi].
    fn log_range(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.next()).exp()
    }
    fn rotation(&mut self) -> DMat3 {
        let axis = DVec3::new(
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
            self.range(-1.0, 1.0),
        )
        .try_normalize()
        .unwrap_or(DVec3::Z);
        DMat3::from_axis_angle(axis, self.range(0.0, std::f64::consts::TAU))
    }
}

fn shape(rng: &mut Rng, i: usize) -> Shape {
    match i % 4 {
        0 => torus(
            rng.range(0.6, 1.2),
            rng.log_range(0.03, 0.3),
            rng.rotation(),
        ),
        1 => dumbbell(rng.log_range(0.03, 0.2), rng.rotation()),
        2 => {
            let holes = 1 + (rng.next() * 3.0) as usize;
            let hole = rng.range(0.25, 0.4);
            let gap = rng.log_range(0.05, 0.4);
            let a = holes as f64 * (hole + 0.5 * gap) + rng.range(0.3, 0.6);
            let b = hole + rng.range(0.2, 0.5);
            plate(holes, a, b, hole, gap, rng.log_range(0.05, 0.5))
        }
        _ => superquadric(
            rng.log_range(0.03, 1.0),
            rng.log_range(0.3, 1.0),
            rng.log_range(0.3, 1.0),
            if rng.next() < 0.5 { 2 } else { 4 },
        ),
    }
}

#[derive(Debug, Default)]
struct Tally {
    right: usize,
    refused: usize,
    wrong: Vec<String>,
}

#[test]
fn generated_shapes_are_meshed_right_or_refused() {
    let n: usize = std::env::var("SURFC_SWEEP")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60);
    let mut rng = Rng(0x5EED_0010);
    let settings = MarchSettings::default();
    let started = std::time::Instant::now();
    let mut tally = Tally::default();
    for i in 0..n {
        let sh = shape(&mut rng, i);
        let step = sh.feature * rng.log_range(0.25, 4.0);
        let mut s = sh.surface();
        let input = MarchInput {
            max_triangles: Some(500_000),
            ..MarchInput::from_point(step, sh.start)
        };
        let tolerance = settings.tolerance * step;
        let t = std::time::Instant::now();
        let result = march_verified(s.as_mut(), &input, &settings, None);
        let what = format!(
            "#{i} {} (feature {:.3}) at step {step:.4}",
            sh.name, sh.feature
        );
        match result {
            Err(e) => {
                println!("{what}: refused: {e}");
                tally.refused += 1;
            }
            Ok(m) => {
                let (topo, violations) = check(
                    &m.mesh,
                    None,
                    &Expect {
                        closed: true,
                        euler: Some(sh.euler),
                        components: Some(1),
                        // Quality is measured elsewhere; here only rightness counts.
                        min_angle_deg: 0.0,
                        ..Expect::default()
                    },
                );
                let (lo, hi) = m.mesh.vertices.iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), &v| (lo.min(v), hi.max(v)),
                );
                let off = (lo - sh.bbox.0).abs().max((hi - sh.bbox.1).abs());
                let mut bad: Vec<String> = violations.iter().map(|v| format!("{v:?}")).collect();
                if off.max_element() > tolerance {
                    bad.push(format!("box off by {:.3e}", off.max_element()));
                }
                if m.max_chord_error > tolerance {
                    bad.push(format!("chord {:.3e}", m.max_chord_error));
                }
                println!(
                    "{what}: {} triangles, euler {}, {} refinement(s), {:.2} s{}",
                    topo.triangles,
                    topo.euler_characteristic,
                    m.refinements,
                    t.elapsed().as_secs_f64(),
                    if bad.is_empty() {
                        String::new()
                    } else {
                        format!(" WRONG: {}", bad.join(", "))
                    }
                );
                if bad.is_empty() {
                    tally.right += 1;
                } else {
                    tally.wrong.push(what);
                }
            }
        }
    }
    println!(
        "sweep of {n}: {} right, {} refused, {} wrong, {:.1} s",
        tally.right,
        tally.refused,
        tally.wrong.len(),
        started.elapsed().as_secs_f64()
    );
    assert!(tally.wrong.is_empty(), "wrong meshes: {:#?}", tally.wrong);
}
