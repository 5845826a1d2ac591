//! surfc against fast-surface-nets (docs/speed.md, issues 14 and 41): the same surface, the
//! same box, the same mean edge length, in one run. For each case it prints two lines: the
//! medians of interleaved runs and their ratios (so a load from elsewhere on the machine falls
//! on all alike), and the one-thread mesh call's triangles, seconds, nanoseconds and
//! evaluations of the surface per output vertex (point evaluations, value alone or with the
//! gradient, and interval evaluations, counted by the compiled surfaces of the whole
//! `surfc mesh` path: `surface::compiled::evaluations`, in the untimed run that calibrates
//! the grid); then criterion measures each part on its own; and after the last case a table
//! of all of them:
//! - `fsn`: fast-surface-nets sampling the formula (f32, native Rust) on a grid over the box
//!   and extracting its mesh, in fresh memory (cold); the grid spacing is chosen so that its
//!   mean edge length equals surfc's (calibrated by one or two corrections, both printed);
//! - `fsn_warm`: the same in memory it used before (its grid and buffer kept from an untimed
//!   run). On the fine sphere its two grid-sized arrays are about 460 MB, whose first touch
//!   costs this machine 0.2 to 0.8 s as the host's page faults go: the cold time moves by
//!   that, the warm one does not (docs/speed.md, *The reference's memory*);
//! - `march`: surfc's verified march alone (compiled surface, native code), for the cases with
//!   a start point and no creases (`march::march` does not trace creases: not for
//!   `cad_plate`);
//! - `mesh_1t`, `mesh_2t`: the whole `surfc mesh` path of the gallery file (parse, compile,
//!   march, verification, report) on a rayon pool of one and two threads.
//!
//! `cargo bench --bench speed` (docs/speed.md); `SPEED_ROUNDS` sets the interleaved rounds
//! (default 5), `SPEED_CASES` a comma-separated subset of
//! `sphere,genus3,three_cylinders,cad_plate` (or `finer_sphere`: the sphere at step 0.005, run
//! only when named).

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use fast_surface_nets::ndshape::{RuntimeShape, Shape};
use fast_surface_nets::{SurfaceNetsBuffer, surface_nets};
use glam::DVec3;
use surfc::march::{MarchInput, MarchSettings, march};
use surfc::pipeline::mesh_source;
use surfc::surface::compiled::evaluations;

/// One case: a gallery file at a step, the formula for fast-surface-nets and the box.
struct Case {
    name: &'static str,
    source: String,
    /// The surface's name in the file (compiled for `march`).
    surface: &'static str,
    step: f64,
    /// The start point of `march`, None where `march::march` does not apply (creases).
    start: Option<DVec3>,
    /// The box surfc meshes in, if the block has one.
    mesh_box: Option<(DVec3, DVec3)>,
    /// The box fast-surface-nets samples (the block's box, or one around the surface).
    grid_box: (DVec3, DVec3),
    f: fn(f32, f32, f32) -> f32,
    /// Run without `SPEED_CASES` naming it.
    by_default: bool,
}

fn genus3(x: f32, y: f32, z: f32) -> f32 {
    let (rx, ry, rz, r1, x1) = (6.0f32, 3.5f32, 4.0f32, 1.2f32, 3.9f32);
    let a = 1.0 - (x / rx).powi(2) - (y / ry).powi(2);
    let b = (x - x1).powi(2) + y * y - r1 * r1;
    let c = x * x + y * y - r1 * r1;
    let d = (x + x1).powi(2) + y * y - r1 * r1;
    rz.powi(4) * z * z - a * b * c * d
}

fn three_cylinders(x: f32, y: f32, z: f32) -> f32 {
    let f1 = x * x + (z - 5.0).powi(2) - 4.0;
    let f2 = (y + 4.0).powi(2) + z * z - 4.0;
    let f3 = (y - 4.0).powi(2) + z * z - 4.0;
    f1 * f2 * f3 - 2287.5587
}

/// `benches/cad_plate.surf` as surfc lowers it (`sema::solids`): a box is the max of its six
/// face planes, `cylinder(r, h)` max(hypot(x, y) − r, |z| − h/2), union min, difference
/// max(a, −b), each in surfc's order of operands. The hypot is √(x² + y²), as surfc computes
/// it wherever x² + y² is a normal number or zero (`values::hypot`), not libm's `hypotf`,
/// which guards against overflow at several times the cost: it was more than half of this
/// function's time, and fast-surface-nets took 0.72-0.77 s on the plate with it where it
/// takes 0.42-0.45 s without (the same grid and triangles).
fn cad_plate(x: f32, y: f32, z: f32) -> f32 {
    let cylinder = |x: f32, y: f32, z: f32, r: f32, h: f32| {
        ((x * x + y * y).sqrt() - r).max(z.abs() - 0.5 * h)
    };
    let plate = (-2.0 - x)
        .max(x - 2.0)
        .max(-1.5 - y)
        .max(y - 1.5)
        .max(-0.2 - z)
        .max(z - 0.2);
    let mut holes = f32::INFINITY;
    for hx in [-1.6f32, -0.9, 0.9, 1.6] {
        for hy in [-1.0f32, 0.0, 1.0] {
            holes = holes.min(cylinder(x - hx, y - hy, z, 0.15, 1.0));
        }
    }
    let bosses =
        cylinder(x, y + 0.7, z - 0.35, 0.35, 0.9).min(cylinder(x, y - 0.7, z - 0.35, 0.35, 0.9));
    let boss_holes = cylinder(x, y + 0.7, z, 0.15, 2.0).min(cylinder(x, y - 0.7, z, 0.15, 2.0));
    plate.max(-holes).min(bosses).max(-boss_holes)
}

fn cases() -> Vec<Case> {
    let at = |text: &str, from: &str, to: &str| {
        assert!(text.contains(from), "the gallery file has `{from}`");
        text.replace(from, to)
    };
    let v = DVec3::new;
    let sphere = |name: &'static str, step: f64, by_default: bool| Case {
        name,
        source: at(
            include_str!("../examples/sphere.surf"),
            "step: 0.3;",
            &format!("step: {step};"),
        ),
        surface: "sphere",
        step,
        start: Some(v(1.0, 1.0, 1.0)),
        mesh_box: None,
        grid_box: (v(-2.05, -2.05, -2.05), v(2.05, 2.05, 2.05)),
        f: |x, y, z| x * x + y * y + z * z - 4.0,
        by_default,
    };
    vec![
        sphere("sphere_0.01", 0.01, true),
        Case {
            name: "genus3_0.05",
            source: at(
                include_str!("../examples/genus3.surf"),
                "step: 0.3;",
                "step: 0.05;",
            ),
            surface: "genus3",
            step: 0.05,
            start: Some(v(0.0, 3.0, 0.0)),
            mesh_box: None,
            grid_box: (v(-6.5, -4.0, -2.5), v(6.5, 4.0, 2.5)),
            f: genus3,
            by_default: true,
        },
        Case {
            name: "three_cylinders_0.1",
            source: at(
                include_str!("../examples/three_cylinders.surf"),
                "step: 0.5;",
                "step: 0.1;",
            ),
            surface: "three_cylinders",
            step: 0.1,
            start: Some(v(0.0, -4.0, -2.0)),
            mesh_box: Some((v(-7.0, -7.0, -7.0), v(7.0, 7.0, 5.0))),
            grid_box: (v(-7.0, -7.0, -7.0), v(7.0, 7.0, 5.0)),
            f: three_cylinders,
            by_default: true,
        },
        // The CAD part of issue 41: about 30 primitives under min and max, every edge a crease
        // (marched face by face up to its traced creases: docs/creases.md), where sampling a
        // grid costs more than on the algebraic surfaces.
        Case {
            name: "cad_plate_0.015",
            source: include_str!("cad_plate.surf").to_string(),
            surface: "part",
            step: 0.015,
            start: None,
            mesh_box: Some((v(-2.1, -1.6, -0.3), v(2.1, 1.6, 0.9))),
            grid_box: (v(-2.1, -1.6, -0.3), v(2.1, 1.6, 0.9)),
            f: cad_plate,
            by_default: true,
        },
        // The sphere at half the step: how the ratio moves with the step. surfc's work grows
        // with the triangles (×4); were fast-surface-nets' time its grid's volume (×8), the
        // ratio would halve (it does not: docs/speed.md). Only when named (the bench then
        // peaks at about 5.5 GB).
        sphere("finer_sphere_0.005", 0.005, false),
    ]
}

/// fast-surface-nets' memory: the grid of samples and the output buffer (whose table from
/// grid cells to vertices is as large as the grid).
#[derive(Default)]
struct Grid {
    sdf: Vec<f32>,
    buffer: SurfaceNetsBuffer,
}

/// fast-surface-nets over `grid_box` at `spacing` in fresh memory (`cold`: what one call
/// costs, the first touch of the grid's and the buffer's pages included); the triangle
/// count and the mean edge length (model units).
fn fsn(f: fn(f32, f32, f32) -> f32, grid_box: (DVec3, DVec3), spacing: f64) -> (usize, f64) {
    fsn_in(f, grid_box, spacing, &mut Grid::default())
}

/// fast-surface-nets over `grid_box` at `spacing` in `grid`'s memory: samples, extracts. With
/// a `grid` used before at the same spacing (`warm`) nothing is allocated or touched for the
/// first time, as when a caller meshes again with the same buffers.
fn fsn_in(
    f: fn(f32, f32, f32) -> f32,
    (lo, hi): (DVec3, DVec3),
    spacing: f64,
    grid: &mut Grid,
) -> (usize, f64) {
    // One sample beyond the box on each side, so that the surface inside it is all meshed.
    let n = ((hi - lo) / spacing).ceil().as_uvec3() + glam::UVec3::splat(3);
    let shape = RuntimeShape::<u32, 3>::new([n.x, n.y, n.z]);
    let origin = lo - DVec3::splat(spacing);
    let Grid { sdf, buffer } = grid;
    if sdf.len() != shape.usize() {
        // Zeroed pages from the system, first touched by the sampling.
        *sdf = vec![0f32; shape.usize()];
    }
    let s = spacing as f32;
    let (ox, oy, oz) = (origin.x as f32, origin.y as f32, origin.z as f32);
    let mut i = 0;
    for z in 0..n.z {
        let pz = oz + z as f32 * s;
        for y in 0..n.y {
            let py = oy + y as f32 * s;
            for x in 0..n.x {
                sdf[i] = f(ox + x as f32 * s, py, pz);
                i += 1;
            }
        }
    }
    surface_nets(sdf, &shape, [0; 3], [n.x - 1, n.y - 1, n.z - 1], buffer);
    let (mut sum, mut count) = (0.0f64, 0usize);
    for t in buffer.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (
                buffer.positions[t[k] as usize],
                buffer.positions[t[(k + 1) % 3] as usize],
            );
            let d = (0..3).map(|j| (a[j] - b[j]).powi(2)).sum::<f32>().sqrt();
            sum += f64::from(d) * spacing;
            count += 1;
        }
    }
    (buffer.indices.len() / 3, sum / count.max(1) as f64)
}

/// The surface of the case compiled from its file (native code), as `surfc mesh` runs it.
fn compiled(case: &Case) -> surfc::surface::compiled::CompiledSurface {
    use surfc::sema::program::{SurfaceId, SurfaceRef};
    let (file, diags) = surfc::syntax::parse(&case.source);
    let file = file.unwrap_or_else(|| panic!("{diags:?}"));
    let (program, _) = surfc::sema::check(&file);
    let id = program
        .surfaces
        .iter()
        .position(|s| s.name == case.surface)
        .expect("the surface is defined");
    surfc::surface::compiled::compile_surface(
        &program,
        &SurfaceRef::Surface(SurfaceId(id as u32)),
        &mut |_| -> Result<Box<dyn surfc::surface::Surface>, String> {
            Err("no dist() in the benched surfaces".into())
        },
    )
    .expect("the surface compiles")
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
}

/// What a case measured, for the table after the last case.
struct Row {
    name: &'static str,
    triangles: usize,
    vertices: usize,
    /// Medians of fast-surface-nets cold and warm, march (None where it does not apply), mesh
    /// on one and on two threads, seconds.
    fsn: f64,
    fsn_warm: f64,
    march: Option<f64>,
    mesh_1t: f64,
    mesh_2t: f64,
    /// Evaluations of the one-thread mesh call: values, values with gradients, intervals.
    values: u64,
    value_gradients: u64,
    intervals: u64,
}

impl Row {
    fn per_vertex(&self, n: u64) -> f64 {
        n as f64 / self.vertices.max(1) as f64
    }
}

fn bench_case(c: &mut Criterion, case: &Case, rounds: usize) -> Row {
    let (one, two) = (pool(1), pool(2));
    let mesh = |p: &rayon::ThreadPool| {
        p.install(|| {
            let m = mesh_source(&case.source).unwrap_or_else(|e| panic!("{}: {e:?}", case.name));
            let r = &m[0].report;
            (r.triangles, r.vertices, r.stats.edge_mean)
        })
    };
    let run_march = |start: DVec3| {
        let input = MarchInput {
            bbox: case.mesh_box,
            ..MarchInput::from_point(case.step, start)
        };
        one.install(|| {
            let mut s = compiled(case);
            march(&mut s, &input, &MarchSettings::default())
                .map(|m| m.triangles.len())
                .unwrap_or_else(|e| panic!("{}: {e}", case.name))
        })
    };
    // The evaluations of the whole one-thread mesh call, counted by the compiled surfaces it
    // builds (added to the totals as each is dropped, all of them by the time it returns),
    // in this untimed run; and the grid spacing that gives fast-surface-nets surfc's mean
    // edge length.
    let before = evaluations();
    let (surfc_triangles, surfc_vertices, surfc_edge) = mesh(&one);
    let evals = evaluations().since(&before);
    // The mean edge is nearly proportional to the spacing; a second correction where it is
    // not yet within 2·10⁻⁴ (the creases of `cad_plate`).
    let mut spacing = surfc_edge;
    let (mut fsn_triangles, mut fsn_edge) = fsn(case.f, case.grid_box, spacing);
    for _ in 0..2 {
        if (fsn_edge / surfc_edge - 1.0).abs() < 2e-4 {
            break;
        }
        spacing *= surfc_edge / fsn_edge;
        (fsn_triangles, fsn_edge) = fsn(case.f, case.grid_box, spacing);
    }

    // fast-surface-nets warm: its memory allocated and touched by one untimed run.
    let warm = std::cell::RefCell::new(Grid::default());
    let fsn_warm = || fsn_in(case.f, case.grid_box, spacing, &mut warm.borrow_mut());
    fsn_warm();

    // Interleaved medians and their ratios.
    let time = |f: &dyn Fn()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    let mut runs: Vec<[f64; 5]> = Vec::new();
    for _ in 0..rounds {
        runs.push([
            time(&|| {
                black_box(fsn(case.f, case.grid_box, spacing));
            }),
            time(&|| {
                black_box(fsn_warm());
            }),
            case.start.map_or(f64::NAN, |start| {
                time(&|| {
                    black_box(run_march(start));
                })
            }),
            time(&|| {
                black_box(mesh(&one));
            }),
            time(&|| {
                black_box(mesh(&two));
            }),
        ]);
    }
    let median = |k: usize| {
        let mut t: Vec<f64> = runs.iter().map(|r| r[k]).collect();
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let [f, fw, m, m1, m2] = [0, 1, 2, 3, 4].map(median);
    let row = Row {
        name: case.name,
        triangles: surfc_triangles,
        vertices: surfc_vertices,
        fsn: f,
        fsn_warm: fw,
        march: case.start.map(|_| m),
        mesh_1t: m1,
        mesh_2t: m2,
        values: evals.values,
        value_gradients: evals.value_gradients,
        intervals: evals.intervals,
    };
    let march_text = |t: Option<f64>, digits: usize, unit: &str| {
        t.map_or("— (not run: creases)".to_string(), |t| {
            format!("{t:.digits$}{unit}")
        })
    };
    eprintln!(
        "speed {}: fast-surface-nets {:.3} s cold, {:.3} s warm ({} triangles, mean edge {:.5}, spacing {:.5}); surfc march {}, mesh 1 thread {:.3} s, 2 threads {:.3} s ({} triangles, mean edge {:.5}); ratio to fast-surface-nets cold: march {}, mesh 1 thread {:.2}, 2 threads {:.2}; warm: mesh 1 thread {:.2}, 2 threads {:.2} (medians of {} interleaved rounds)",
        case.name,
        f,
        fw,
        fsn_triangles,
        fsn_edge,
        spacing,
        march_text(row.march, 3, " s"),
        m1,
        m2,
        surfc_triangles,
        surfc_edge,
        march_text(row.march.map(|m| m / f), 2, ""),
        m1 / f,
        m2 / f,
        m1 / fw,
        m2 / fw,
        rounds
    );
    eprintln!(
        "speed {}: mesh 1 thread: {} triangles, {} vertices, {:.3} s, {:.0} ns a vertex; evaluations a vertex: {:.2} at points ({:.2} values, {:.2} values with gradients), {:.3} on intervals",
        case.name,
        row.triangles,
        row.vertices,
        m1,
        m1 * 1e9 / row.vertices.max(1) as f64,
        row.per_vertex(evals.points()),
        row.per_vertex(evals.values),
        row.per_vertex(evals.value_gradients),
        row.per_vertex(evals.intervals),
    );

    let mut g = c.benchmark_group(format!("speed/{}", case.name));
    g.sample_size(10);
    g.bench_function("fsn", |b| {
        b.iter(|| black_box(fsn(case.f, case.grid_box, spacing)))
    });
    g.bench_function("fsn_warm", |b| b.iter(|| black_box(fsn_warm())));
    if let Some(start) = case.start {
        g.bench_function("march", |b| b.iter(|| black_box(run_march(start))));
    }
    g.bench_function("mesh_1t", |b| b.iter(|| black_box(mesh(&one))));
    g.bench_function("mesh_2t", |b| b.iter(|| black_box(mesh(&two))));
    g.finish();
    row
}

/// The cases run, one line each (Markdown, for docs/speed.md).
fn print_table(rows: &[Row], rounds: usize) {
    if rows.is_empty() {
        return;
    }
    eprintln!(
        "speed: medians of {rounds} interleaved rounds; mesh 1 thread, its evaluations a vertex, and ratios to fast-surface-nets cold (fresh memory) and warm (its memory reused)\n\
         | case | triangles | s (1 thread) | ns/vertex | point evals/vertex | interval evals/vertex | fast-surface-nets s cold / warm | ratio to cold: march / 1 thread / 2 threads | ratio to warm: 1 thread / 2 threads |\n\
         |---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let march = r
            .march
            .map_or("—".to_string(), |m| format!("{:.2}", m / r.fsn));
        eprintln!(
            "| {} | {} | {:.3} | {:.0} | {:.2} | {:.3} | {:.3} / {:.3} | {} / {:.2} / {:.2} | {:.2} / {:.2} |",
            r.name,
            r.triangles,
            r.mesh_1t,
            r.mesh_1t * 1e9 / r.vertices.max(1) as f64,
            r.per_vertex(r.values + r.value_gradients),
            r.per_vertex(r.intervals),
            r.fsn,
            r.fsn_warm,
            march,
            r.mesh_1t / r.fsn,
            r.mesh_2t / r.fsn,
            r.mesh_1t / r.fsn_warm,
            r.mesh_2t / r.fsn_warm
        );
    }
}

fn benches(c: &mut Criterion) {
    let rounds = std::env::var("SPEED_ROUNDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(5usize)
        .max(1);
    let only = std::env::var("SPEED_CASES").ok();
    let mut rows = Vec::new();
    for case in cases() {
        let wanted = only.as_deref().map_or(case.by_default, |o| {
            o.split(',')
                .any(|w| !w.is_empty() && case.name.starts_with(w.trim()))
        });
        if wanted {
            rows.push(bench_case(c, &case, rounds));
        }
    }
    print_table(&rows, rounds);
}

criterion_group!(speed_benches, benches);
criterion_main!(speed_benches);
