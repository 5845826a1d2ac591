//! Pictures and mesh files of a 1.3 M-triangle sphere (an icosahedron subdivided 8 times): the
//! renderer should draw it at 800×600 in about a second, and the writers stream it quickly.

#[path = "../tests/output/output_fixtures.rs"]
mod output_fixtures;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use surfc::mesh::NamedMesh;
use surfc::mesh::render::{RenderOptions, render};
use surfc::mesh::write::Format;

fn pictures_and_files(c: &mut Criterion) {
    let sphere = output_fixtures::icosphere(8, 2.0);
    let meshes = [NamedMesh {
        name: "sphere",
        mesh: &sphere,
    }];
    let mut group = c.benchmark_group("big_sphere");
    group.sample_size(10);
    group.throughput(Throughput::Elements(sphere.triangles.len() as u64));
    group.bench_function("render_800x600", |b| {
        b.iter(|| render(&meshes, &RenderOptions::default()))
    });
    for format in [Format::Obj, Format::Glb] {
        group.bench_function(format!("write_{format}"), |b| {
            b.iter(|| {
                let mut out = std::io::BufWriter::new(std::io::sink());
                format.write(&mut out, &meshes)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, pictures_and_files);
criterion_main!(benches);
