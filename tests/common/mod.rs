//! Shared helpers of the marcher tests: the paper's surfaces as native closures with
//! hand-written gradients, polygon samplers, rotation/scaling wrappers, and `mesh_and_check`,
//! which runs the marcher, applies the one reusable checker and prints the quality line.
#![allow(dead_code)]

pub mod build;
pub mod cad;
pub mod cli;
pub mod csg;
pub mod rng;
pub mod sources;
pub mod thin;
pub mod voxel;

use glam::{DMat3, DVec3};
use surfc::march::{MarchInput, MarchSettings, march};
use surfc::mesh::Mesh;
use surfc::mesh::check::{Expect, check};
use surfc::mesh::quality::quality;
use surfc::mesh::topology::Topology;
use surfc::pipeline::Meshed;
use surfc::surface::{NativeSurface, Surface, ValueGrad};

pub fn vg(value: f64, gradient: DVec3) -> ValueGrad {
    ValueGrad { value, gradient }
}

pub type Boxed = Box<dyn Surface>;

pub fn sphere(r: f64) -> Boxed {
    Box::new(NativeSurface(move |p: DVec3| {
        vg(p.length_squared() - r * r, 2.0 * p)
    }))
}

/// (x²+y²+z²+r²−a²)² − 4r²(x²+y²).
pub fn torus(r: f64, a: f64) -> Boxed {
    Box::new(NativeSurface(move |p: DVec3| {
        let k = p.length_squared() + r * r - a * a;
        let v = k * k - 4.0 * r * r * (p.x * p.x + p.y * p.y);
        let g = DVec3::new(
            4.0 * p.x * (k - 2.0 * r * r),
            4.0 * p.y * (k - 2.0 * r * r),
            4.0 * p.z * k,
        );
        vg(v, g)
    }))
}

/// The genus 3 surface of the paper's Sect. 3.5.
pub fn genus3() -> Boxed {
    let (rx, ry, rz, r1, x1) = (6.0f64, 3.5f64, 4.0f64, 1.2f64, 3.9f64);
    Box::new(NativeSurface(move |p: DVec3| {
        let (x, y, z) = (p.x, p.y, p.z);
        let a = 1.0 - (x / rx).powi(2) - (y / ry).powi(2);
        let b = (x - x1).powi(2) + y * y - r1 * r1;
        let c = x * x + y * y - r1 * r1;
        let d = (x + x1).powi(2) + y * y - r1 * r1;
        let rz4 = rz.powi(4);
        let v = rz4 * z * z - a * b * c * d;
        let (ax, ay) = (-2.0 * x / (rx * rx), -2.0 * y / (ry * ry));
        let gx = -(ax * b * c * d
            + a * 2.0 * (x - x1) * c * d
            + a * b * 2.0 * x * d
            + a * b * c * 2.0 * (x + x1));
        let gy = -(ay * b * c * d + a * 2.0 * y * (c * d + b * d + b * c));
        vg(v, DVec3::new(gx, gy, 2.0 * rz4 * z))
    }))
}

/// (3x²−y²)²y² − (x²+y²)⁴ − z³ − 0.001z.
pub fn six_peak() -> Boxed {
    Box::new(NativeSurface(|p: DVec3| {
        let (x, y, z) = (p.x, p.y, p.z);
        let u = 3.0 * x * x - y * y;
        let s = x * x + y * y;
        let v = u * u * y * y - s.powi(4) - z.powi(3) - 0.001 * z;
        let gx = 12.0 * x * u * y * y - 8.0 * x * s.powi(3);
        let gy = -4.0 * u * y.powi(3) + 2.0 * u * u * y - 8.0 * y * s.powi(3);
        vg(v, DVec3::new(gx, gy, -3.0 * z * z - 0.001))
    }))
}

/// The sum of the triangles' areas.
pub fn area(m: &Mesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.vertices[i as usize]);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// f1 f2 f3 − c of the paper's Sect. 3.6.
pub fn three_cylinders(c: f64) -> Boxed {
    Box::new(NativeSurface(move |p: DVec3| {
        let (x, y, z) = (p.x, p.y, p.z);
        let f1 = x * x + (z - 5.0).powi(2) - 4.0;
        let f2 = (y + 4.0).powi(2) + z * z - 4.0;
        let f3 = (y - 4.0).powi(2) + z * z - 4.0;
        let g1 = DVec3::new(2.0 * x, 0.0, 2.0 * (z - 5.0));
        let g2 = DVec3::new(0.0, 2.0 * (y + 4.0), 2.0 * z);
        let g3 = DVec3::new(0.0, 2.0 * (y - 4.0), 2.0 * z);
        vg(f1 * f2 * f3 - c, g1 * f2 * f3 + g2 * f1 * f3 + g3 * f1 * f2)
    }))
}

/// x² + y² − r².
pub fn cylinder(r: f64) -> Boxed {
    Box::new(NativeSurface(move |p: DVec3| {
        vg(
            p.x * p.x + p.y * p.y - r * r,
            DVec3::new(2.0 * p.x, 2.0 * p.y, 0.0),
        )
    }))
}

/// The surface `inner` rotated by `rot` and scaled by `scale` about the origin.
pub fn transformed(mut inner: Boxed, rot: DMat3, scale: f64) -> Boxed {
    let inv = rot.transpose();
    Box::new(NativeSurface(move |p: DVec3| {
        let r = inner.value_gradient(inv * p / scale);
        vg(r.value, rot * r.gradient / scale)
    }))
}

/// `n` points of the circle with centre `c`, axis `axis` (unit) and radius `r`, walked
/// counter-clockwise seen from the tip of `axis` (starting at the direction `u`, ⊥ axis).
pub fn circle(c: DVec3, axis: DVec3, u: DVec3, r: f64, n: usize) -> Vec<DVec3> {
    let v = axis.cross(u);
    (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            c + r * (t.cos() * u + t.sin() * v)
        })
        .collect()
}

/// Number of polygon vertices for a closed curve of length `len` at step `step`.
pub fn samples(len: f64, step: f64) -> usize {
    (len / step).round().max(3.0) as usize
}

/// What a closed surface of one component with Euler characteristic `euler` must meet: no
/// boundary, consistently oriented, no crossings, the checker's default smallest angle.
/// Widen it with struct update syntax (`Expect { components: None, ..closed(χ) }`).
pub fn closed(euler: i64) -> Expect {
    Expect {
        closed: true,
        euler: Some(euler),
        components: Some(1),
        boundary_loops: Some(0),
        ..Expect::default()
    }
}

/// Asserts that the mesh block `m`, meshed through the library form of `surfc mesh`, meets
/// `expect` (the one mesh checker, `mesh::check::check`); the message names the mesh and every
/// violation. Returns the mesh's topology.
pub fn assert_closed(m: &Meshed, expect: &Expect) -> Topology {
    let (topo, violations) = check(&m.mesh, None, expect);
    assert!(violations.is_empty(), "{}: {violations:?}", m.name);
    topo
}

/// Runs the marcher, checks the mesh against `expect` (plus vertices on the surface within
/// 1e-9·step) and prints one quality line. Panics with every violation found.
pub fn mesh_and_check(name: &str, surface: &mut Boxed, input: &MarchInput, expect: Expect) -> Mesh {
    let mut st = MarchSettings::default();
    if let Ok(v) = std::env::var("NEAR") {
        st.near_distance = v.parse().unwrap();
    }
    let mesh = match march(surface.as_mut(), input, &st) {
        Ok(m) => m,
        Err(e) => panic!("{name}: the marcher failed: {e}"),
    };
    let mut expect = expect;
    expect.max_vertex_error.get_or_insert(1e-9 * input.step);
    let (topo, violations) = check(&mesh, Some(surface.as_mut()), &expect);
    let q = quality(&mesh);
    println!(
        "{name:<28} triangles {:>7}  euler {:>3}  loops {}  min angle {:5.1}°  1% {:5.1}°  median {:5.1}°  radius ratio {:.4}  edges {:.3}/{:.3}/{:.3}·δ",
        topo.triangles,
        topo.euler_characteristic,
        topo.boundary_loops.len(),
        q.min_angle_deg,
        q.p1_angle_deg,
        q.median_angle_deg,
        q.radius_ratio_mean,
        q.min_edge / input.step,
        q.mean_edge / input.step,
        q.max_edge / input.step,
    );
    assert!(violations.is_empty(), "{name}: {violations:?}");
    assert!(
        q.radius_ratio_mean >= MEAN_RADIUS_RATIO,
        "{name}: mean radius ratio {:.4} < {MEAN_RADIUS_RATIO}",
        q.radius_ratio_mean
    );
    mesh
}

/// The gallery files (`examples/`, by stem) that take nine tenths of its meshing: the
/// bracket's `offset` and the patches' `dist` solve foot points at every evaluation, the plate
/// traces 15 creases. The default run leaves them out of `mesh::gallery` and
/// `cli::threads` (a fifth of the mesh tests' time); `SURFC_GALLERY_ALL=1` and
/// `SURFC_THREADS_ALL=1`, which `.ci/run`'s long runs set, put them back.
pub const SLOW_GALLERY_FILES: [&str; 3] = ["bracket", "intersecting_patches", "plate"];

/// The number in the environment variable `name` (spaces around it allowed), if it is set and
/// one: the sizes, seeds and cases of the sweeps (tests/README.md, *The long runs*).
pub fn env_number<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok()?.trim().parse().ok()
}

/// Whether the environment variable `name` is set to anything but `0`: the switches of the
/// long runs (`SURFC_GALLERY_ALL`, `SURFC_THREADS_ALL`, `SURFC_DIST_COLD_ALL`).
pub fn env_flag(name: &str) -> bool {
    std::env::var_os(name).is_some_and(|v| v != "0")
}

/// Whether the gallery file `path` is left out of the default run: one of
/// `SLOW_GALLERY_FILES`, unless the variable `all` (`SURFC_GALLERY_ALL`, `SURFC_THREADS_ALL`)
/// is set to anything but `0`.
pub fn skipped_gallery_file(path: &std::path::Path, all: &str) -> bool {
    let everything = env_flag(all);
    let stem = path.file_stem().unwrap_or_default();
    !everything && SLOW_GALLERY_FILES.iter().any(|slow| stem == *slow)
}

/// Runs `check` on every file of the folder `dir` (from the crate's root) whose name ends in
/// `.{ext}`, in name order, each under insta's settings as `insta::glob!` sets them: the file
/// as the snapshot's input file and its name as the snapshot's suffix, so that its snapshots
/// are `<test>@<file name>.snap`. Every file is checked, and the test fails after the last
/// one, naming each file that failed. (insta's `glob` feature does the same through a glob
/// matcher and its regex engine: about 15 s of a fresh clone's CPU for three folder
/// listings.)
pub fn each_file(dir: &str, ext: &str, mut check: impl FnMut(&std::path::Path)) {
    let folder = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let folder = folder.canonicalize().unwrap_or(folder);
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(&folder)
        .unwrap_or_else(|e| panic!("{}: {e}", folder.display()))
        .map(|entry| entry.expect("a readable folder entry").path())
        .filter(|path| path.is_file() && path.extension().is_some_and(|e| e == ext))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .{ext} file in {}", folder.display());
    let mut failed = Vec::new();
    for path in &files {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let mut settings = insta::Settings::clone_current();
        settings.set_input_file(path);
        settings.set_snapshot_suffix(name.as_ref());
        let run = || std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| check(path)));
        if settings.bind(run).is_err() {
            failed.push(name.into_owned());
        }
    }
    assert!(
        failed.is_empty(),
        "{} of {} files failed (above): {}",
        failed.len(),
        files.len(),
        failed.join(", ")
    );
}

/// The mean radius ratio (2·r_in/r_circ) every march test's mesh reaches: issue 13's bar,
/// docs/quality.md (the flat ellipsoid of `march_thin` reached it when the local step was graded
/// towards fine places too, `Sizing::regrading_caps`).
pub const MEAN_RADIUS_RATIO: f64 = 0.97;

/// |found − paper| ≤ 15 % of paper.
pub fn assert_near_paper(name: &str, found: usize, paper: usize) {
    let rel = (found as f64 - paper as f64).abs() / paper as f64;
    assert!(
        rel <= 0.15,
        "{name}: {found} triangles, the paper has {paper} ({:.1} % off)",
        rel * 100.0
    );
}
