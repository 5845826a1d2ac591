//! Marcher throughput (triangles per second) on the paper's sphere and genus-3 surface, with
//! native closures and with the tapes compiled from the gallery files (what `surfc mesh` runs:
//! native code; and on the interpreter), and the share of the time spent evaluating the
//! surface (printed once per case, measured with a timing wrapper around the surface).
//! `components/…`: genus 3 at step 0.3 meshed from its box alone (the component search of
//! `pipeline::components`) against the same box with a start point, and the search's share of
//! the time (printed once). `quality/sphere_0.01_{off,on}`: the sphere at step 0.01 with the
//! quality stage off and on (its cost), and its share from interleaved pairs (printed once),
//! marched as one piece and in slabs as `surfc mesh` marches it.
//! `verify/crossings_sphere_0.01`: the crossing check of the verification alone on the
//! 1.3 M-triangle sphere; `verify/crossings_searched_sphere_0.01` the same pairs by the grid
//! search alone, without the certificate that vouches for most of the mesh first.

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use surfc::eval::Engine;
use surfc::march::{MarchInput, MarchSettings, march, march_verified};
use surfc::mesh::check::{intersecting_pairs, intersecting_pairs_searched};
use surfc::pipeline::components::{Marching, SearchSettings, mesh_components};
use surfc::pipeline::pieces;
use surfc::sema::program::{SurfaceId, SurfaceRef};
use surfc::surface::compiled::CompiledSurface;
use surfc::surface::compiled::compile_surface;
use surfc::surface::{NativeSurface, Surface, ValueGrad};

fn sphere() -> impl Surface {
    NativeSurface(|p: DVec3| ValueGrad {
        value: p.length_squared() - 4.0,
        gradient: 2.0 * p,
    })
}

fn genus3() -> impl Surface {
    let (rx, ry, rz, r1, x1) = (6.0f64, 3.5f64, 4.0f64, 1.2f64, 3.9f64);
    NativeSurface(move |p: DVec3| {
        let (x, y, z) = (p.x, p.y, p.z);
        let a = 1.0 - (x / rx).powi(2) - (y / ry).powi(2);
        let b = (x - x1).powi(2) + y * y - r1 * r1;
        let c = x * x + y * y - r1 * r1;
        let d = (x + x1).powi(2) + y * y - r1 * r1;
        let rz4 = rz.powi(4);
        let (ax, ay) = (-2.0 * x / (rx * rx), -2.0 * y / (ry * ry));
        let gx = -(ax * b * c * d
            + a * 2.0 * (x - x1) * c * d
            + a * b * 2.0 * x * d
            + a * b * c * 2.0 * (x + x1));
        let gy = -(ay * b * c * d + a * 2.0 * y * (c * d + b * d + b * c));
        ValueGrad {
            value: rz4 * z * z - a * b * c * d,
            gradient: DVec3::new(gx, gy, 2.0 * rz4 * z),
        }
    })
}

/// Counts evaluations and the time spent in them.
struct Timed<S> {
    inner: S,
    calls: u64,
    spent: Duration,
}

impl<S: Surface> Surface for Timed<S> {
    fn value_gradient(&mut self, p: DVec3) -> ValueGrad {
        let t = Instant::now();
        let r = self.inner.value_gradient(p);
        self.spent += t.elapsed();
        self.calls += 1;
        r
    }
}

fn case<S: Surface>(
    c: &mut Criterion,
    name: &str,
    make: impl FnMut() -> S,
    step: f64,
    start: DVec3,
) {
    case_with(c, name, make, MarchInput::from_point(step, start));
}

fn case_with<S: Surface>(
    c: &mut Criterion,
    name: &str,
    mut make: impl FnMut() -> S,
    input: MarchInput,
) {
    let settings = MarchSettings::default();
    // One timed run: triangle count and the evaluation share (the timer's own cost inflates
    // the share a little for cheap surfaces).
    let mut timed = Timed {
        inner: make(),
        calls: 0,
        spent: Duration::ZERO,
    };
    let t = Instant::now();
    let mesh = match march(&mut timed, &input, &settings) {
        Ok(m) => m,
        Err(e) => panic!("{name}: {e}"),
    };
    let total = t.elapsed();
    let triangles = mesh.triangles.len() as u64;
    eprintln!(
        "{name}: {triangles} triangles in {:.3} s, {} evaluations ({:.2} per triangle), {:.0} % of the time in the surface",
        total.as_secs_f64(),
        timed.calls,
        timed.calls as f64 / triangles as f64,
        100.0 * timed.spent.as_secs_f64() / total.as_secs_f64()
    );
    let mut g = c.benchmark_group("march");
    g.throughput(Throughput::Elements(triangles));
    if triangles > 100_000 {
        g.sample_size(10);
    }
    g.bench_function(name, |b| {
        b.iter(|| {
            let mut s = make();
            black_box(march(&mut s, black_box(&input), &settings).map(|m| m.triangles.len()))
        })
    });
    g.finish();
}

/// The quality stage's share of the meshing time (issue 13, M4: aim ≤ 15 %): the sphere at
/// step 0.01 meshed with the stage off (`quality_angle = 0`) and on, interleaved in one run,
/// marched as one piece (the march's mean radius ratio furthest from the aim) and in slabs
/// as `surfc mesh` marches it.
fn quality_share(c: &mut Criterion, start: DVec3) {
    let input = MarchInput::from_point(0.01, start);
    let off = MarchSettings {
        quality_angle: 0.0,
        ..MarchSettings::default()
    };
    let on = MarchSettings::default();
    // The one piece as `surfc mesh` marches a component it does not cut: with fresh oracles
    // for the centroid round's blocks, on the default pool.
    let fork = || Some(Box::new(sphere()) as Box<dyn Surface>);
    let one_piece = |settings: &MarchSettings| {
        let marched = march_verified(&mut sphere(), Some(&fork), &input, settings, None);
        black_box(marched.map(|m| m.mesh.triangles.len())).ok();
    };
    // The share, from interleaved pairs of runs (after a warm-up pair) so that a load from
    // elsewhere on the machine falls on both alike: criterion's samples of one and then of
    // the other cannot separate the stage's tenths of a second from this machine's swings
    // of a second.
    let time = |settings: &MarchSettings| {
        let t = Instant::now();
        one_piece(settings);
        t.elapsed().as_secs_f64()
    };
    print_share("marched as one piece", time, &off, &on);
    // The same sphere as `surfc mesh` marches it: cut into slabs (`pipeline::pieces`), here on
    // a pool of one thread.
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool of one thread");
    let time_pieces = |settings: &MarchSettings| {
        let t = Instant::now();
        one_thread.install(|| {
            let pieced = pieces::march(&mut sphere(), Some(&fork), &input, settings, None);
            black_box(pieced.map(|p| p.marched.mesh.triangles.len())).ok();
        });
        t.elapsed().as_secs_f64()
    };
    print_share(
        "in slabs, as `surfc mesh` marches it, one thread",
        time_pieces,
        &off,
        &on,
    );
    let mut g = c.benchmark_group("quality");
    g.sample_size(10);
    for (name, settings) in [("sphere_0.01_off", off), ("sphere_0.01_on", on)] {
        g.bench_function(name, |b| b.iter(|| one_piece(black_box(&settings))));
    }
    g.finish();
}

/// The quality stage's share of the meshing time as `time` measures it with the stage off and
/// on: from the medians of nine interleaved pairs of runs (after a warm-up pair), so that a
/// load from elsewhere on the machine falls on both alike (criterion's samples of one and
/// then of the other cannot separate the stage's tenths of a second from this machine's
/// swings of a second), and the spread of the pairs' own shares.
fn print_share(
    case: &str,
    time: impl Fn(&MarchSettings) -> f64,
    off: &MarchSettings,
    on: &MarchSettings,
) {
    let pairs: Vec<(f64, f64)> = (0..10).map(|_| (time(off), time(on))).skip(1).collect();
    let median = |mut t: Vec<f64>| {
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let (t_off, t_on) = (
        median(pairs.iter().map(|p| p.0).collect()),
        median(pairs.iter().map(|p| p.1).collect()),
    );
    let shares: Vec<f64> = pairs.iter().map(|(a, b)| 100.0 * (b - a) / b).collect();
    eprintln!(
        "sphere_0.01 {case}, quality stage: off {t_off:.3} s, on {t_on:.3} s (medians of {} interleaved pairs): the stage is {:.0} % of the meshing time (median of the pairs' shares {:.0} %, from {:.0} to {:.0} %)",
        pairs.len(),
        100.0 * (t_on - t_off) / t_on,
        median(shares.clone()),
        shares.iter().copied().fold(f64::INFINITY, f64::min),
        shares.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    );
}

/// The surface `name` of a gallery file, compiled to bytecode (no `dist` in these files).
fn compiled(source: &str, name: &str) -> impl Fn() -> CompiledSurface {
    let (file, diags) = surfc::syntax::parse(source);
    let file = file.unwrap_or_else(|| panic!("{diags:?}"));
    let (program, _) = surfc::sema::check(&file);
    let id = program
        .surfaces
        .iter()
        .position(|s| s.name == name)
        .expect("the surface is defined");
    let r = SurfaceRef::Surface(SurfaceId(id as u32));
    move || {
        compile_surface(&program, &r, &mut |_| -> Result<Box<dyn Surface>, String> {
            Err("no dist() in the benched surfaces".into())
        })
        .expect("the surface compiles")
    }
}

/// Genus 3 at step 0.3 in a box around it: meshed from the box alone (octree, seeds, march)
/// and from a start point with the same box; the difference is the search.
fn components(c: &mut Criterion, make: &dyn Fn() -> CompiledSurface) {
    let (step, start) = (0.3, DVec3::new(0.0, 3.0, 0.0));
    let bbox = (DVec3::new(-6.5, -4.0, -2.5), DVec3::new(6.5, 4.0, 2.5));
    let settings = MarchSettings::default();
    let search = SearchSettings::default();
    let mut input = MarchInput::from_point(step, start);
    input.bbox = Some(bbox);
    let from_box = || {
        let mut s = make();
        mesh_components(&mut s, Marching::step(step), bbox, &settings, &search).map(|m| m.mesh)
    };
    let from_start = || {
        let mut s = make();
        march(&mut s, &input, &settings)
    };
    // The share: medians of timed runs of each, interleaved (after a warm-up of each) so
    // that a load from elsewhere on the machine falls on both alike.
    let time = |f: &dyn Fn() -> usize| {
        let t = Instant::now();
        black_box(f());
        t.elapsed().as_secs_f64()
    };
    let count = |m: Result<surfc::mesh::Mesh, String>| m.map(|m| m.triangles.len()).unwrap_or(0);
    let octree = || {
        surfc::survey::cells::candidate_cells(
            &mut make(),
            bbox.0,
            bbox.1,
            search.leaf * step,
            search.max_cells,
        )
    };
    let runs: Vec<[f64; 3]> = (0..10)
        .map(|_| {
            [
                time(&|| count(from_box().map_err(|e| e.to_string()))),
                time(&|| count(from_start().map_err(|e| e.to_string()))),
                time(&|| octree().cells.len()),
            ]
        })
        .skip(1)
        .collect();
    let median = |k: usize| {
        let mut t: Vec<f64> = runs.iter().map(|r| r[k]).collect();
        t.sort_by(f64::total_cmp);
        t[t.len() / 2]
    };
    let (t_box, t_start, t_octree) = (median(0), median(1), median(2));
    let found = octree();
    eprintln!(
        "genus3_0.3 from its box: {:.2} ms, from a start with the box: {:.2} ms; the search is {:.0} % of the box run (octree {:.2} ms: {} cells bounded, {} kept; {} triangles)",
        t_box * 1e3,
        t_start * 1e3,
        100.0 * (t_box - t_start) / t_box,
        t_octree * 1e3,
        found.visited,
        found.cells.len(),
        count(from_box().map_err(|e| e.to_string())),
    );
    let mut g = c.benchmark_group("components");
    g.bench_function("genus3_0.3_box", |b| {
        b.iter(|| black_box(from_box().is_ok()))
    });
    g.bench_function("genus3_0.3_start_and_box", |b| {
        b.iter(|| black_box(from_start().is_ok()))
    });
    g.finish();
}

/// The crossing check alone (the verification's most expensive part) on a finished mesh,
/// with its certificate and by the search alone.
fn crossings(c: &mut Criterion, name: &str, mesh: &surfc::mesh::Mesh) {
    let mut g = c.benchmark_group("verify");
    g.throughput(Throughput::Elements(mesh.triangles.len() as u64));
    g.sample_size(10);
    g.bench_function(format!("crossings_{name}"), |b| {
        b.iter(|| black_box(intersecting_pairs(black_box(mesh)).len()))
    });
    g.bench_function(format!("crossings_searched_{name}"), |b| {
        b.iter(|| black_box(intersecting_pairs_searched(black_box(mesh)).len()))
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    let s = DVec3::new(1.0, 1.0, 1.0);
    let fine = march(
        &mut sphere(),
        &MarchInput::from_point(0.01, s),
        &MarchSettings::default(),
    )
    .expect("the sphere meshes");
    crossings(c, "sphere_0.01", &fine);
    case(c, "sphere_0.3", sphere, 0.3, s);
    case(c, "sphere_0.03", sphere, 0.03, s);
    case(c, "sphere_0.01", sphere, 0.01, s);
    // The local step against the paper's uniform step where it never binds (issue 10: the
    // sizing's cost, ≤ 10 %).
    case_with(
        c,
        "sphere_0.01_uniform",
        sphere,
        MarchInput {
            uniform: true,
            ..MarchInput::from_point(0.01, s)
        },
    );
    quality_share(c, s);
    let g = DVec3::new(0.0, 3.0, 0.0);
    case(c, "genus3_0.3", genus3, 0.3, g);
    case(c, "genus3_0.05", genus3, 0.05, g);
    // Compiled from the gallery files, as `surfc mesh` runs them (native code), and on the
    // interpreter.
    let sphere_tape = compiled(include_str!("../examples/sphere.surf"), "sphere");
    let genus3_tape = compiled(include_str!("../examples/genus3.surf"), "genus3");
    let interpreted = |make: &dyn Fn() -> CompiledSurface| {
        let mut s = make();
        s.set_engine(Engine::Interpreter);
        s
    };
    case(c, "sphere_0.01_bytecode", &sphere_tape, 0.01, s);
    case(
        c,
        "sphere_0.01_interpreter",
        || interpreted(&sphere_tape),
        0.01,
        s,
    );
    components(c, &genus3_tape);
    case(c, "genus3_0.05_bytecode", &genus3_tape, 0.05, g);
    case(
        c,
        "genus3_0.05_interpreter",
        || interpreted(&genus3_tape),
        0.05,
        g,
    );
}

criterion_group!(march_benches, benches);
criterion_main!(march_benches);
