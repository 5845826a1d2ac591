//! `surfc mesh --threads N` writes the same bytes for any N (issue 14, M3): every gallery
//! file and a fine sphere, meshed with 1, 2 and 8 threads, in a text and a binary format.
//! The blocks of a file are meshed on the pool's threads, the crossing check and the report
//! run beside the surface evaluations, and the OBJ text is formatted in chunks: any of them
//! taking its results in thread order instead of file order shows here.
//!
//! The components of one block are marched several at once: a scene of six is checked too.
//!
//! `examples/intersecting_patches.surf` takes about a minute (its `dist` products); it runs
//! with `SURFC_THREADS_ALL=1`. `SURFC_THREADS_STEP` sets the sphere's step (default 0.02,
//! 335 k triangles; the fine sphere is 0.01).

mod common;

use std::path::Path;

use common::cli::{scratch, surfc};

const THREADS: [&str; 3] = ["1", "2", "8"];

/// Meshes `file` into `dir` once per thread count and format; asserts success and equal
/// bytes, and returns the size of the OBJ.
fn same_bytes(file: &Path, dir: &Path, formats: &[&str]) -> usize {
    let mut size = 0;
    for format in formats {
        let mut first: Option<Vec<u8>> = None;
        for n in THREADS {
            let out = dir.join(format!("out-{n}.{format}"));
            let out = out.to_str().expect("a UTF-8 path");
            let run = surfc(
                &[
                    "mesh",
                    file.to_str().expect("a UTF-8 path"),
                    "-o",
                    out,
                    "--threads",
                    n,
                    "-q",
                ],
                dir,
            );
            assert_eq!(
                run.code,
                0,
                "{} with --threads {n}: {}",
                file.display(),
                run.stderr
            );
            let bytes = std::fs::read(out).expect("the mesh file was written");
            assert!(!bytes.is_empty());
            match &first {
                None => first = Some(bytes),
                Some(one) => assert!(
                    *one == bytes,
                    "{}: --threads {n} wrote other bytes ({} against {} with 1 thread) in {format}",
                    file.display(),
                    bytes.len(),
                    one.len()
                ),
            }
        }
        if *format == "obj" {
            size = first.map_or(0, |b| b.len());
        }
    }
    size
}

#[test]
fn every_gallery_file_is_the_same_bytes_for_any_thread_count() {
    let all = std::env::var_os("SURFC_THREADS_ALL").is_some_and(|v| v != "0");
    let dir = scratch("threads-gallery");
    let mut files: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/examples"))
        .expect("the gallery")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "surf"))
        .collect();
    files.sort();
    let mut meshed = 0;
    for file in &files {
        if !all
            && file
                .file_stem()
                .is_some_and(|s| s == "intersecting_patches")
        {
            continue;
        }
        assert!(same_bytes(file, &dir, &["obj", "glb"]) > 0);
        meshed += 1;
    }
    // The gallery has a dozen files; a glob that found none would check nothing.
    assert!(meshed >= 10, "{meshed} gallery files");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_fine_sphere_is_the_same_bytes_for_any_thread_count() {
    let step = std::env::var("SURFC_THREADS_STEP").unwrap_or_else(|_| "0.02".into());
    let dir = scratch("threads-sphere");
    let file = dir.join("sphere.surf");
    std::fs::write(
        &file,
        format!(
            "surface sphere = x^2 + y^2 + z^2 - 4;\nmesh sphere = sphere {{ step: {step}; start: (1, 1, 1); }}\n"
        ),
    )
    .expect("the sphere file");
    let size = same_bytes(&file, &dir, &["obj", "glb", "off"]);
    // At 0.02 the sphere has ≈ 335 k triangles: several chunks of OBJ lines.
    assert!(size > 1_000_000, "{size} bytes of OBJ");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Four balls and two tori in a box, one product (no creases): six components, meshed by
/// the component search with several marches at once (`survey::ahead`); and the same
/// shapes through `offset` (a `dist` surface, whose oracle remembers its last foot point:
/// each march starts on a fresh one, so the marches run ahead give the same bits).
const SCENE: &str = "
fn ball(cx, cy, cz, r) = (x - cx)^2 + (y - cy)^2 + (z - cz)^2 - r^2;
fn ring(r, a) = (sqrt(x^2 + y^2) - r)^2 + z^2 - a^2;
surface s = ball(2, 0, 0, 0.9) * ball(-2, 1, 0, 0.7) * ball(-2.2, -0.5, -2.5, 0.75)
  * ball(2.5, 2.5, -2, 0.55) * translate(ring(1, 0.3), (0, -2.5, 0))
  * translate(rotate(ring(0.9, 0.2), axis: (1, 0, 0), angle: pi / 2), (0.5, 0.3, 2.5));
mesh scene = s { step: STEP; box: (-4, -4, -4) .. (4, 4, 4); }
surface u = ball(1.8, 0, 0, 0.5) * ball(-1.8, 0, 0, 0.5) * ring(0.6, 0.15);
mesh shells = offset(u, 0.05) { step: 0.1; box: (-2.5, -2.5, -2.5) .. (2.5, 2.5, 2.5); }
";

#[test]
fn components_marched_at_once_are_the_same_bytes_for_any_thread_count() {
    let step = std::env::var("SURFC_THREADS_SCENE_STEP").unwrap_or_else(|_| "0.05".into());
    let dir = scratch("threads-components");
    let file = dir.join("scene.surf");
    std::fs::write(&file, SCENE.replace("STEP", &step)).expect("the scene file");
    assert!(same_bytes(&file, &dir, &["obj", "glb"]) > 0);
    // What was meshed: every component, each closed, in both blocks. The scene's four balls
    // (χ = 2 each) and two tori (χ = 0); `shells` offsets two balls and a torus outwards by
    // less than their gaps.
    let file = file.to_str().expect("a UTF-8 path");
    let run = surfc(&["mesh", file, "-o", "s.obj", "--json", "-q"], &dir);
    assert_eq!(run.code, 0, "{}", run.stderr);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let json: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    let meshes = json["meshes"].as_array().expect("meshes");
    let facts: Vec<(i64, i64, i64)> = meshes
        .iter()
        .map(|m| {
            let n = |k: &str| m[k].as_i64().unwrap_or(-1);
            (n("components"), n("euler_characteristic"), n("boundary_edges"))
        })
        .collect();
    assert_eq!(facts, vec![(6, 8, 0), (3, 4, 0)], "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn zero_threads_is_a_usage_error() {
    let dir = scratch("threads-zero");
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/sphere.surf");
    let run = surfc(&["mesh", file, "-o", "s.obj", "--threads", "0"], &dir);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("--threads"), "{}", run.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}
