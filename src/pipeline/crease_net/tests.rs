//! The smooth pieces marched side by side on fresh oracles of the branches (and the widths
//! of the faces beside the creases measured side by side, `width::all_caps`) are the pieces
//! marched one after another on the surface itself: the same mesh bit for bit, the same
//! warnings, and under a `max_triangles` that the pieces share, the same refusal, on pools
//! of one, two and four threads.

use glam::DVec3;

use super::{CreaseSettings, mesh_creased};
use crate::eval::Engine;
use crate::march::MarchSettings;
use crate::pipeline::build::{Builder, march_settings};
use crate::pipeline::components::{Marching, SearchSettings};
use crate::pipeline::creased::creased_of;
use crate::surface::Surface;

/// Parts of several pieces: a plate with two holes, an L of two boxes sharing face planes,
/// a boss with a hole through it on a plate, a ring of boxes turned about z, and a plate two
/// steps thin with a hole (its rim and the hole's wall narrower than `width::REACH` steps:
/// the local step capped along every crease).
const PARTS: [&str; 5] = [
    "surface p = difference(box((-1, -0.6, 0), (1, 0.6, 0.2)), union(translate(cylinder(0.15, 1), (-0.5, 0, 0)), translate(cylinder(0.2, 1), (0.5, 0.1, 0))));
     mesh p = p { step: 0.06; box: (-1.2, -0.8, -0.2) .. (1.2, 0.8, 0.4); }",
    "surface p = union(box((0, 0, 0), (1, 0.2, 0.5)), box((0, 0, 0), (0.2, 0.8, 0.5)));
     mesh p = p { step: 0.05; box: (-0.2, -0.2, -0.2) .. (1.2, 1, 0.7); }",
    "surface p = difference(union(box((-0.8, -0.8, 0), (0.8, 0.8, 0.2)), translate(cylinder(0.3, 0.6), (0, 0, 0.4))), translate(cylinder(0.12, 2), (0, 0, 0.4)));
     mesh p = p { step: 0.05; box: (-1, -1, -0.2) .. (1, 1, 0.9); }",
    "surface b = box((0.4, -0.1, -0.1), (0.8, 0.1, 0.1));
     surface p = union(b, rotate(b, axis: (0, 0, 1), angle: pi / 2), rotate(b, axis: (0, 0, 1), angle: pi), rotate(b, axis: (0, 0, 1), angle: 3 * pi / 2));
     mesh p = p { step: 0.04; box: (-1, -1, -0.3) .. (1, 1, 0.3); }",
    "surface p = difference(box((-0.6, -0.4, 0), (0.6, 0.4, 0.08)), translate(cylinder(0.15, 1), (0.1, 0, 0)));
     mesh p = p { step: 0.04; box: (-0.7, -0.5, -0.1) .. (0.7, 0.5, 0.2); }",
];

/// What a meshing gave: the mesh's bits and the warnings, or the error's message.
type Outcome = Result<(Vec<u64>, Vec<[u32; 3]>, Vec<String>, usize), String>;

/// The part's block meshed crease by crease on a pool of `threads`, its pieces on fresh
/// branches (`pool`) or one after another on the surface itself, with `max_triangles`.
fn mesh(source: &str, threads: usize, pool: bool, max_triangles: Option<u64>) -> Outcome {
    let run = || {
        let (_, checked, diags) = crate::pipeline::load::analyse(source);
        let Some((_, program)) = checked else {
            panic!("{diags:?}");
        };
        let def = &program.meshes[0];
        let engine = Engine::default();
        let builder = Builder::new(&program, engine);
        let mut whole = builder
            .surface(&def.surface, def.step)
            .expect("the surface");
        let mut creased = creased_of(&builder, def)
            .ok()
            .flatten()
            .expect("a surface with creases");
        let fork = || {
            Builder::new(&program, engine)
                .surface(&def.surface, def.step)
                .ok()
                .map(|s| Box::new(s) as Box<dyn Surface>)
        };
        let branches = || {
            Builder::new(&program, engine)
                .creased(&def.surface, def.step)
                .ok()
                .flatten()
                .map(|(_, b)| b)
        };
        let settings: MarchSettings = march_settings(def);
        mesh_creased(
            &mut creased,
            &mut whole,
            Some(&fork),
            pool.then_some(&branches as _),
            Marching {
                step: def.step,
                max_triangles,
                tolerance: def.tolerance,
                uniform: def.uniform,
            },
            def.bbox.expect("a box"),
            &settings,
            &SearchSettings::default(),
            &CreaseSettings::default(),
            None,
        )
        .map(|m| {
            let bits = (m.mesh.vertices.iter())
                .flat_map(|v: &DVec3| v.to_array().map(f64::to_bits))
                .collect();
            (bits, m.mesh.triangles, m.warnings, m.pieces)
        })
        .map_err(|e| e.to_string())
    };
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a pool")
        .install(run)
}

#[test]
#[ignore = "long run: `.ci/run` runs it (cargo test -- --include-ignored)"]
fn pieces_on_the_pool_are_the_pieces_one_after_another() {
    for (k, source) in PARTS.iter().enumerate() {
        let alone = mesh(source, 1, false, None);
        let Ok((_, triangles, _, pieces)) = &alone else {
            panic!("part {k}: {alone:?}");
        };
        assert!(*pieces >= 3, "part {k}: {pieces} pieces");
        // Limits that pass, and limits that the pieces reach one after another at the first
        // piece, in the middle and near the end (the pieces run ahead with the whole limit:
        // those whose peak went past what the pieces before them left are marched again).
        let n = triangles.len() as u64;
        let limits = [
            None,
            Some(2 * n),
            Some(n / 8),
            Some(n / 2),
            Some(n * 9 / 10),
        ];
        let mut refused = 0;
        for limit in limits {
            let alone = if limit.is_none() {
                alone.clone()
            } else {
                mesh(source, 1, false, limit)
            };
            refused += usize::from(alone.is_err());
            // Without a limit on pools of one, two and four threads; with one on two.
            let pools: &[usize] = if limit.is_none() { &[1, 2, 4] } else { &[2] };
            for &threads in pools {
                let pooled = mesh(source, threads, true, limit);
                assert!(
                    pooled == alone,
                    "part {k}, limit {limit:?}, {threads} thread(s): {:?} against {:?}",
                    pooled.as_ref().map(|m| m.1.len()),
                    alone.as_ref().map(|m| m.1.len())
                );
            }
        }
        assert!(refused >= 2, "part {k}: {refused} limits refused");
    }
}
