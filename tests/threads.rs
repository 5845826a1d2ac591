//! `surfc mesh --threads N` writes the same bytes for any N (issue 14, M3): every gallery
//! file and a fine sphere, meshed with 1, 2 and 8 threads, in a text and a binary format.
//! The blocks of a file are meshed on the pool's threads, the crossing check and the report
//! run beside the surface evaluations, and the OBJ text is formatted in chunks: any of them
//! taking its results in thread order instead of file order shows here.
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

#[test]
fn zero_threads_is_a_usage_error() {
    let dir = scratch("threads-zero");
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/sphere.surf");
    let run = surfc(&["mesh", file, "-o", "s.obj", "--threads", "0"], &dir);
    assert_eq!(run.code, 2, "{}", run.stderr);
    assert!(run.stderr.contains("--threads"), "{}", run.stderr);
    let _ = std::fs::remove_dir_all(&dir);
}
