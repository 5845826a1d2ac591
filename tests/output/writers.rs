//! The mesh writers, checked by reading their files back with independent readers (tobj,
//! stl_io, ply-rs-bw, gltf, and a hand-written OFF parser): same vertices (exactly where the
//! format is exact), same triangles with the same winding, shared positions written once,
//! and atomic file replacement.

use crate::output_fixtures;

use std::collections::BTreeSet;
use std::fs;
use std::io::{self, BufReader, Cursor, Write};
use std::path::Path;

use glam::DVec3;
use output_fixtures::{grid_patch, icosphere, no_triangles, shared_pair, tricky_numbers};
use surfc::mesh::write::{
    Format, GLB_ROOT_NODE, InvalidMesh, WriteError, write_3mf, write_atomic, write_glb,
    write_mesh_file, write_msh, write_obj, write_off, write_ply, write_stl, write_vtu,
};
use surfc::mesh::{Mesh, NamedMesh, Side};

fn bytes(
    write: fn(&mut dyn Write, &[NamedMesh]) -> io::Result<()>,
    meshes: &[NamedMesh],
) -> Vec<u8> {
    let mut out = Vec::new();
    write(&mut out, meshes).expect("writing to memory succeeds");
    out
}

fn bits(v: DVec3) -> [u64; 3] {
    v.to_array().map(f64::to_bits)
}

fn f32s(v: DVec3) -> [f32; 3] {
    v.to_array().map(|x| x as f32)
}

/// The number of distinct positions (by bit pattern) over all meshes.
fn distinct_positions(meshes: &[NamedMesh]) -> usize {
    meshes
        .iter()
        .flat_map(|m| m.mesh.vertices.iter().map(|&v| bits(v)))
        .collect::<BTreeSet<_>>()
        .len()
}

/// The set of meshes every format is checked with.
struct Cases {
    sphere: Mesh,
    patch: Mesh,
    left: Mesh,
    right: Mesh,
    empty: Mesh,
}

impl Cases {
    fn new() -> Cases {
        let (left, right) = shared_pair(6);
        Cases {
            sphere: icosphere(2, 2.0),
            patch: grid_patch(5),
            left,
            right,
            empty: no_triangles(),
        }
    }

    fn named(&self) -> Vec<NamedMesh<'_>> {
        vec![
            NamedMesh {
                name: "sphere",
                mesh: &self.sphere,
            },
            NamedMesh {
                name: "patch",
                mesh: &self.patch,
            },
            NamedMesh {
                name: "left",
                mesh: &self.left,
            },
            NamedMesh {
                name: "nothing",
                mesh: &self.empty,
            },
            NamedMesh {
                name: "right",
                mesh: &self.right,
            },
        ]
    }
}

/// The normal an OBJ holds for each position (by bits): the mesh's own where every mesh
/// using the position agrees, else the normalised sum over the meshes (docs/formats.md).
fn obj_normals(meshes: &[NamedMesh]) -> std::collections::HashMap<[u64; 3], DVec3> {
    let mut all: std::collections::HashMap<[u64; 3], Vec<DVec3>> = Default::default();
    for m in meshes {
        for (v, n) in m.mesh.vertices.iter().zip(&m.mesh.normals) {
            all.entry(bits(*v)).or_default().push(*n);
        }
    }
    all.into_iter()
        .map(|(k, normals)| {
            let agree = normals.iter().all(|n| bits(*n) == bits(normals[0]));
            let sum: DVec3 = normals.iter().sum();
            let n = if agree {
                normals[0]
            } else {
                sum.try_normalize().unwrap_or(normals[0])
            };
            (k, n)
        })
        .collect()
}

/// Reads an OBJ with tobj (positions as f64) and checks every object against its mesh:
/// exact corner positions and their normals, triangle by triangle, in the written winding.
fn check_obj_with_tobj(text: &[u8], meshes: &[NamedMesh]) {
    let normals = obj_normals(meshes);
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut BufReader::new(text), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .expect("tobj reads the OBJ");
    let drawn: Vec<&NamedMesh> = meshes
        .iter()
        .filter(|m| !m.mesh.triangles.is_empty())
        .collect();
    assert_eq!(
        models.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(),
        drawn.iter().map(|m| m.name).collect::<Vec<_>>()
    );
    for (model, named) in models.iter().zip(drawn) {
        let m = &model.mesh;
        assert_eq!(m.indices.len(), 3 * named.mesh.triangles.len());
        assert_eq!(m.normal_indices.len(), m.indices.len());
        let read = |list: &[f64], i: u32| {
            let i = 3 * i as usize;
            DVec3::new(list[i], list[i + 1], list[i + 2])
        };
        for (k, tri) in named.mesh.triangles.iter().enumerate() {
            for (j, &v) in tri.iter().enumerate() {
                let p = read(&m.positions, m.indices[3 * k + j]);
                let n = read(&m.normals, m.normal_indices[3 * k + j]);
                let position = named.mesh.vertices[v as usize];
                assert_eq!(bits(p), bits(position));
                assert_eq!(bits(n), bits(normals[&bits(position)]));
            }
        }
    }
}

/// The `v` lines of an OBJ parsed with `str::parse`.
fn obj_positions(text: &str) -> Vec<DVec3> {
    text.lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let xyz: Vec<f64> = l
                .split(' ')
                .map(|t| t.parse().expect("a coordinate"))
                .collect();
            assert_eq!(xyz.len(), 3);
            DVec3::new(xyz[0], xyz[1], xyz[2])
        })
        .collect()
}

#[test]
fn obj_reads_back_exactly_with_tobj() {
    let cases = Cases::new();
    let meshes = cases.named();
    let text = bytes(write_obj, &meshes);
    check_obj_with_tobj(&text, &meshes);
}

#[test]
fn obj_coordinates_round_trip_through_str_parse() {
    let tricky = tricky_numbers();
    let meshes = [NamedMesh {
        name: "tricky",
        mesh: &tricky,
    }];
    let text = String::from_utf8(bytes(write_obj, &meshes)).expect("OBJ is UTF-8");
    let read: BTreeSet<_> = obj_positions(&text).into_iter().map(bits).collect();
    let written: BTreeSet<_> = tricky.vertices.iter().map(|&v| bits(v)).collect();
    assert_eq!(read, written);
    // Integers are written one way: with `.0`.
    assert!(text.contains("v 2.0 -0.0 "), "{text}");
    check_obj_with_tobj(text.as_bytes(), &meshes);
}

#[test]
fn obj_shares_positions_between_meshes_with_one_normal_each() {
    let (left, right) = shared_pair(6);
    let meshes = [
        NamedMesh {
            name: "left",
            mesh: &left,
        },
        NamedMesh {
            name: "right",
            mesh: &right,
        },
    ];
    let text = String::from_utf8(bytes(write_obj, &meshes)).expect("OBJ is UTF-8");
    let positions = obj_positions(&text);
    // The polygon x = 0 has 7 vertices, written once.
    assert_eq!(
        positions.len(),
        left.vertices.len() + right.vertices.len() - 7
    );
    assert_eq!(positions.len(), distinct_positions(&meshes));
    // One normal per position, as readers that take normals for point data need.
    let normals = text.lines().filter(|l| l.starts_with("vn ")).count();
    assert_eq!(normals, positions.len());
    // Each object is an `o` and a `g` of its name.
    for name in ["left", "right"] {
        assert!(text.contains(&format!("\no {name}\ng {name}\n")), "{text}");
    }

    // The faces of both objects that touch x = 0 use the same `v` indices there.
    let mut on_polygon: Vec<BTreeSet<usize>> = Vec::new();
    for object in text.split("\no ").skip(1) {
        let used: BTreeSet<usize> = object
            .lines()
            .filter_map(|l| l.strip_prefix("f "))
            .flat_map(|l| l.split(' '))
            .map(|corner| corner.split("//").next().unwrap_or("").parse::<usize>())
            .map(|v| v.expect("a vertex index"))
            .filter(|&v| positions[v - 1].x == 0.0)
            .collect();
        on_polygon.push(used);
    }
    assert_eq!(on_polygon.len(), 2);
    assert_eq!(on_polygon[0].len(), 7);
    assert_eq!(on_polygon[0], on_polygon[1]);
    check_obj_with_tobj(text.as_bytes(), &meshes);
}

/// Parses an OFF file without any of the writer's code: (positions, triangles).
fn parse_off(text: &str) -> (Vec<DVec3>, Vec<[usize; 3]>) {
    let mut tokens = text.split_whitespace();
    assert_eq!(tokens.next(), Some("OFF"));
    let mut number = || tokens.next().expect("a number");
    let vertices: usize = number().parse().expect("vertex count");
    let faces: usize = number().parse().expect("face count");
    let _edges: usize = number().parse().expect("edge count");
    let mut coordinate = || number().parse::<f64>().expect("a coordinate");
    let positions: Vec<DVec3> = (0..vertices)
        .map(|_| DVec3::new(coordinate(), coordinate(), coordinate()))
        .collect();
    let mut tokens = text
        .split_whitespace()
        .skip(4 + 3 * vertices)
        .map(|t| t.parse::<usize>().expect("an index"));
    let triangles: Vec<[usize; 3]> = (0..faces)
        .map(|_| {
            assert_eq!(tokens.next(), Some(3));
            [0; 3].map(|_| tokens.next().expect("a corner"))
        })
        .collect();
    assert_eq!(tokens.next(), None);
    (positions, triangles)
}

#[test]
fn off_reads_back_exactly_with_shared_positions() {
    let cases = Cases::new();
    let tricky = tricky_numbers();
    let mut meshes = cases.named();
    meshes.push(NamedMesh {
        name: "tricky",
        mesh: &tricky,
    });
    let text = String::from_utf8(bytes(write_off, &meshes)).expect("OFF is UTF-8");
    let (positions, triangles) = parse_off(&text);
    assert_eq!(positions.len(), distinct_positions(&meshes));
    let expected: Vec<[[u64; 3]; 3]> = meshes
        .iter()
        .flat_map(|m| {
            m.mesh
                .triangles
                .iter()
                .map(|t| t.map(|i| bits(m.mesh.vertices[i as usize])))
        })
        .collect();
    let read: Vec<[[u64; 3]; 3]> = triangles
        .iter()
        .map(|t| t.map(|i| bits(positions[i])))
        .collect();
    assert_eq!(read, expected);
}

#[test]
fn stl_reads_back_with_stl_io_to_f32_precision() {
    let cases = Cases::new();
    let meshes = cases.named();
    let data = bytes(write_stl, &meshes);
    assert!(!data.starts_with(b"solid"));
    let read = stl_io::read_stl(&mut Cursor::new(&data)).expect("stl_io reads the STL");
    let triangles: Vec<(&Mesh, [u32; 3])> = meshes
        .iter()
        .flat_map(|m| m.mesh.triangles.iter().map(move |&t| (m.mesh, t)))
        .collect();
    assert_eq!(read.faces.len(), triangles.len());
    for (face, (mesh, tri)) in read.faces.iter().zip(triangles) {
        let corners = tri.map(|i| mesh.vertices[i as usize]);
        for (j, corner) in corners.iter().enumerate() {
            let v = read.vertices[face.vertices[j]];
            assert_eq!([v[0], v[1], v[2]], f32s(*corner));
        }
        let geometric = (corners[1] - corners[0])
            .cross(corners[2] - corners[0])
            .normalize();
        let n = face.normal;
        let n = DVec3::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2]));
        assert!(
            n.dot(geometric) > 1.0 - 1e-6,
            "facet normal {n} vs {geometric}"
        );
    }
}

#[test]
fn ply_reads_back_exactly_with_ply_rs() {
    let cases = Cases::new();
    let tricky = tricky_numbers();
    let mut meshes = cases.named();
    meshes.push(NamedMesh {
        name: "tricky",
        mesh: &tricky,
    });
    let data = bytes(write_ply, &meshes);
    let (vertices, faces) = crate::sharp_edges::ply_vertices_and_faces(&data);
    let expected: Vec<[([u64; 3], [u64; 3]); 3]> = meshes
        .iter()
        .flat_map(|m| {
            m.mesh.triangles.iter().map(|t| {
                t.map(|i| {
                    let i = i as usize;
                    (bits(m.mesh.vertices[i]), bits(m.mesh.normals[i]))
                })
            })
        })
        .collect();
    let read: Vec<[([u64; 3], [u64; 3]); 3]> = faces
        .iter()
        .map(|f| {
            assert_eq!(f.len(), 3);
            [0, 1, 2].map(|j| {
                let (p, n) = vertices[f[j] as usize];
                (bits(p), bits(n))
            })
        })
        .collect();
    assert_eq!(read, expected);
    // Only vertices equal in position and normal are merged: the polygon shared by `left`
    // and `right` has two normals there, so its 7 positions stay 14 vertices in PLY.
    let distinct: BTreeSet<([u64; 3], [u64; 3])> = meshes
        .iter()
        .flat_map(|m| {
            let normals = m.mesh.normals.iter().map(|&n| bits(n));
            m.mesh.vertices.iter().map(|&v| bits(v)).zip(normals)
        })
        .collect();
    assert_eq!(vertices.len(), distinct.len());
    assert!(distinct.len() >= distinct_positions(&meshes) + 7);
}

/// The GLB read by the gltf crate: its document and its binary chunk, which every buffer must
/// be and which must hold every buffer's bytes (what `gltf::import_slice` checks of a GLB
/// without images; that function needs the crate's `import` feature, which builds an image
/// decoder).
fn import_glb(bytes: &[u8]) -> (gltf::Document, Vec<u8>) {
    let glb = gltf::Gltf::from_slice(bytes).expect("gltf reads the GLB");
    let blob = glb.blob.clone().unwrap_or_default();
    for buffer in glb.document.buffers() {
        assert!(
            matches!(buffer.source(), gltf::buffer::Source::Bin),
            "a buffer outside the GLB"
        );
        assert!(
            buffer.length() <= blob.len(),
            "the binary chunk is shorter than its buffer"
        );
    }
    (glb.document, blob)
}

#[test]
fn glb_imports_with_gltf_to_f32_precision() {
    let cases = Cases::new();
    let meshes = cases.named();
    let data = bytes(write_glb, &meshes);
    assert_eq!(data.len() % 4, 0);
    assert_eq!(
        u32::from_le_bytes([data[8], data[9], data[10], data[11]]) as usize,
        data.len()
    );
    let (document, blob) = import_glb(&data);
    // The scene is one root node, turned from z up to glTF's y up, holding the meshes.
    let scene = document.default_scene().expect("a default scene");
    let roots: Vec<_> = scene.nodes().collect();
    assert_eq!(roots.len(), 1);
    assert_eq!(roots[0].name(), Some(GLB_ROOT_NODE));
    let (_, rotation, scale) = roots[0].transform().decomposed();
    // Millimetres, the default unit, to glTF's metres.
    assert_eq!(scale, [0.001; 3]);
    // The rotation takes the model's +z to +y and +y to −z.
    let q = glam::Quat::from_array(rotation);
    assert!((q * glam::Vec3::Z).distance(glam::Vec3::Y) < 1e-6);
    assert!((q * glam::Vec3::Y).distance(-glam::Vec3::Z) < 1e-6);
    let nodes: Vec<_> = roots[0].children().collect();
    assert_eq!(
        nodes.iter().map(|n| n.name()).collect::<Vec<_>>(),
        meshes.iter().map(|m| Some(m.name)).collect::<Vec<_>>()
    );
    // One material, double-sided, on every primitive.
    assert_eq!(document.materials().count(), 1);
    let material = document.materials().next().expect("a material");
    assert!(material.double_sided());
    for (node, named) in nodes.iter().zip(&meshes) {
        let Some(mesh) = node.mesh() else {
            assert!(named.mesh.triangles.is_empty(), "{} lost", named.name);
            continue;
        };
        assert_eq!(mesh.name(), Some(named.name));
        let primitives: Vec<_> = mesh.primitives().collect();
        assert_eq!(primitives.len(), 1);
        let primitive = &primitives[0];
        assert_eq!(primitive.mode(), gltf::mesh::Mode::Triangles);
        assert_eq!(primitive.material().index(), Some(0));
        // The data are the model's own coordinates: only the node turns them.
        assert_eq!(
            node.transform().decomposed(),
            ([0.0; 3], [0.0, 0.0, 0.0, 1.0], [1.0; 3])
        );
        let reader = primitive.reader(|_| Some(&blob[..]));
        let positions: Vec<[f32; 3]> = reader.read_positions().expect("positions").collect();
        let normals: Vec<[f32; 3]> = reader.read_normals().expect("normals").collect();
        let indices: Vec<u32> = reader.read_indices().expect("indices").into_u32().collect();
        let expected: Vec<[f32; 3]> = named.mesh.vertices.iter().map(|&v| f32s(v)).collect();
        assert_eq!(positions, expected);
        let expected: Vec<[f32; 3]> = named.mesh.normals.iter().map(|&v| f32s(v)).collect();
        assert_eq!(normals, expected);
        let triangles: Vec<[u32; 3]> = indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        assert_eq!(triangles, named.mesh.triangles);
        // The bounds the specification requires, from the f32 values.
        let bounds = primitive.bounding_box();
        for k in 0..3 {
            let column = positions.iter().map(|p| p[k]);
            assert_eq!(bounds.min[k], column.clone().fold(f32::INFINITY, f32::min));
            assert_eq!(bounds.max[k], column.fold(f32::NEG_INFINITY, f32::max));
        }
    }
}

#[test]
fn no_meshes_and_empty_meshes_make_valid_files() {
    let empty = no_triangles();
    let lone = [NamedMesh {
        name: "nothing",
        mesh: &empty,
    }];
    for meshes in [&[][..], &lone[..]] {
        let (document, _) = import_glb(&bytes(write_glb, meshes));
        assert_eq!(document.meshes().count(), 0);
        let stl = bytes(write_stl, meshes);
        let read = stl_io::read_stl(&mut Cursor::new(&stl)).expect("stl_io reads the STL");
        assert!(read.faces.is_empty());
        let off = String::from_utf8(bytes(write_off, meshes)).expect("UTF-8");
        assert_eq!(parse_off(&off).1.len(), 0);
    }
}

#[test]
fn every_writer_rejects_what_it_cannot_write() {
    let mut nan = grid_patch(2);
    nan.vertices[4].y = f64::NAN;
    let mut index = grid_patch(2);
    index.triangles[3][1] = 99;
    let mut normals = grid_patch(2);
    normals.normals.pop();
    let tricky = tricky_numbers();
    for format in Format::ALL {
        let write = |mesh: &Mesh| {
            let mut out = Vec::new();
            let meshes = [NamedMesh { name: "m", mesh }];
            let error = format
                .write(&mut out, &meshes)
                .expect_err("the mesh cannot be written");
            assert!(out.is_empty(), "{format} wrote before failing");
            assert_eq!(error.kind(), io::ErrorKind::InvalidData);
            let inner = error.into_inner().expect("a typed error");
            inner
                .downcast::<InvalidMesh>()
                .map(|e| *e)
                .expect("an InvalidMesh")
        };
        assert!(matches!(
            write(&nan),
            InvalidMesh::NonFiniteVertex { vertex: 4, ref mesh, .. } if mesh == "m"
        ));
        assert!(matches!(
            write(&index),
            InvalidMesh::IndexOutOfRange {
                triangle: 3,
                index: 99,
                vertices: 9,
                ..
            }
        ));
        let mut out = Vec::new();
        let named = [NamedMesh {
            name: "m",
            mesh: &normals,
        }];
        // Only the formats that store normals need them.
        let result = format.write(&mut out, &named);
        assert_eq!(
            result.is_err(),
            matches!(format, Format::Obj | Format::Ply | Format::Glb)
        );
        let named = [NamedMesh {
            name: "m",
            mesh: &tricky,
        }];
        let result = format.write(&mut Vec::new(), &named);
        assert_eq!(
            result.is_err(),
            matches!(format, Format::Stl | Format::Glb),
            "{format}: f64::MAX fits only 64-bit formats"
        );
        // Sides, which only the formats with normals write, must name a vertex and be finite.
        let normals_stored = matches!(format, Format::Obj | Format::Ply | Format::Glb);
        let mut side = grid_patch(2);
        side.sides = vec![
            Side {
                vertex: 4,
                normal: DVec3::Z,
            },
            Side {
                vertex: 40,
                normal: DVec3::X,
            },
        ];
        if normals_stored {
            assert!(matches!(
                write(&side),
                InvalidMesh::SideOutOfRange {
                    vertex: 40,
                    vertices: 9,
                    ..
                }
            ));
            side.sides[1] = Side {
                vertex: 4,
                normal: DVec3::new(0.0, f64::INFINITY, 0.0),
            };
            assert!(matches!(
                write(&side),
                InvalidMesh::NonFiniteNormal { vertex: 4, .. }
            ));
        } else {
            assert!(
                format
                    .write(
                        &mut Vec::new(),
                        &[NamedMesh {
                            name: "m",
                            mesh: &side
                        }]
                    )
                    .is_ok()
            );
        }
    }
}

// ---- files ----

fn sphere_file(dir: &Path, format: Format) -> (std::path::PathBuf, Mesh) {
    let path = dir.join(format!("out.{}", format.extension()));
    (path, icosphere(1, 1.0))
}

#[test]
fn files_are_written_whole_in_every_format() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    for format in Format::ALL {
        let (path, mesh) = sphere_file(dir.path(), format);
        let meshes = [NamedMesh {
            name: "ball",
            mesh: &mesh,
        }];
        write_mesh_file(&path, format, &meshes).expect("written");
        assert_eq!(Format::from_path(&path), Ok(format));
        assert_eq!(
            fs::read(&path).expect("readable"),
            bytes(format_writer(format), &meshes)
        );
    }
    // Nothing but the outputs is left in the directory.
    assert_eq!(
        fs::read_dir(dir.path()).expect("listable").count(),
        Format::ALL.len()
    );
}

fn format_writer(format: Format) -> fn(&mut dyn Write, &[NamedMesh]) -> io::Result<()> {
    match format {
        Format::Obj => write_obj,
        Format::Stl => write_stl,
        Format::Ply => write_ply,
        Format::Off => write_off,
        Format::Glb => write_glb,
        Format::ThreeMf => write_3mf,
        Format::Msh => write_msh,
        Format::Vtu => write_vtu,
    }
}

#[test]
fn a_missing_or_unusable_directory_is_an_error_naming_the_path() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let mesh = grid_patch(2);
    let meshes = [NamedMesh {
        name: "m",
        mesh: &mesh,
    }];
    let missing = dir.path().join("no/such/dir/out.obj");
    let a_file = dir.path().join("file.txt");
    fs::write(&a_file, "text").expect("written");
    let under_a_file = a_file.join("out.obj");
    for path in [missing, under_a_file] {
        let error = write_mesh_file(&path, Format::Obj, &meshes).expect_err("cannot be written");
        assert!(
            matches!(error, WriteError::MissingDirectory { .. }),
            "{error}"
        );
        assert_eq!(error.path(), path);
        assert!(error.to_string().contains(&path.display().to_string()));
    }
    // A directory in the way is refused before anything is written: no temporary file.
    let in_the_way = dir.path().join("taken.obj");
    fs::create_dir(&in_the_way).expect("created");
    let error = write_mesh_file(&in_the_way, Format::Obj, &meshes).expect_err("cannot replace");
    assert!(matches!(error, WriteError::IsDirectory { .. }), "{error}");
    assert!(error.to_string().contains("taken.obj"));
    assert_eq!(fs::read_dir(dir.path()).expect("listable").count(), 2);
}

#[test]
fn a_failed_write_leaves_the_existing_file_untouched() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("keep.obj");
    fs::write(&path, "old contents\n").expect("written");

    // A writer that fails halfway through.
    let error = write_atomic(&path, |out| {
        out.write_all(&[b'x'; 100_000])?;
        Err(io::Error::other("the disk is full"))
    })
    .expect_err("the write fails");
    assert!(matches!(error, WriteError::Write { .. }));
    assert!(error.to_string().contains("keep.obj"), "{error}");
    assert_eq!(
        fs::read_to_string(&path).expect("readable"),
        "old contents\n"
    );

    // A mesh with a NaN coordinate is refused before anything is written.
    let mut mesh = grid_patch(2);
    mesh.vertices[0].z = f64::NAN;
    let meshes = [NamedMesh {
        name: "bad",
        mesh: &mesh,
    }];
    for format in Format::ALL {
        let error = write_mesh_file(&path, format, &meshes).expect_err("NaN is refused");
        assert!(matches!(
            error,
            WriteError::InvalidMesh {
                source: InvalidMesh::NonFiniteVertex { vertex: 0, .. },
                ..
            }
        ));
        assert!(error.to_string().contains("keep.obj") && error.to_string().contains("bad"));
    }
    assert_eq!(
        fs::read_to_string(&path).expect("readable"),
        "old contents\n"
    );
    assert_eq!(fs::read_dir(dir.path()).expect("listable").count(), 1);
}

#[cfg(unix)]
#[test]
fn a_replaced_file_keeps_its_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("mode.off");
    fs::write(&path, "old").expect("written");
    fs::set_permissions(&path, fs::Permissions::from_mode(0o640)).expect("chmod");
    let mesh = grid_patch(2);
    let meshes = [NamedMesh {
        name: "m",
        mesh: &mesh,
    }];
    write_mesh_file(&path, Format::Off, &meshes).expect("written");
    let mode = fs::metadata(&path).expect("metadata").permissions().mode();
    assert_eq!(mode & 0o777, 0o640);
    // A new file gets the mode any new file gets (the umask's), not a temporary file's 0o600.
    let fresh = dir.path().join("fresh.off");
    write_mesh_file(&fresh, Format::Off, &meshes).expect("written");
    let plain = dir.path().join("plain.txt");
    fs::write(&plain, "plain").expect("written");
    let mode = |p: &Path| fs::metadata(p).expect("metadata").permissions().mode() & 0o777;
    assert_eq!(mode(&fresh), mode(&plain));
}

#[test]
fn names_are_kept_where_the_format_allows_any_name() {
    let mesh = grid_patch(1);
    let name = "cap \"1\" é";
    let meshes = [NamedMesh { name, mesh: &mesh }];
    let (document, _) = import_glb(&bytes(write_glb, &meshes));
    let node = document.nodes().next().expect("a node");
    assert_eq!(node.name(), Some(name));
    // Line-based headers cannot hold whitespace in a name.
    let obj = String::from_utf8(bytes(write_obj, &meshes)).expect("UTF-8");
    assert!(obj.contains("\no cap_\"1\"_é\n"), "{obj}");
}

mod round_trip {
    use super::*;
    use proptest::prelude::*;

    fn finite() -> impl Strategy<Value = f64> {
        any::<f64>().prop_filter("finite", |x| x.is_finite())
    }

    fn triangle_soup() -> impl Strategy<Value = Mesh> {
        proptest::collection::vec([finite(), finite(), finite()], 3..30).prop_map(|points| {
            let vertices: Vec<DVec3> = points.iter().map(|&p| DVec3::from_array(p)).collect();
            let n = vertices.len() as u32;
            Mesh {
                normals: vec![DVec3::Z; vertices.len()],
                triangles: (0..n - 2).map(|i| [i, i + 1, i + 2]).collect(),
                vertices,
                sides: Vec::new(),
            }
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Any finite f64 coordinate comes back bit for bit from OBJ (through tobj) and OFF.
        #[test]
        fn text_formats_give_back_every_finite_coordinate(mesh in triangle_soup()) {
            let meshes = [NamedMesh { name: "soup", mesh: &mesh }];
            check_obj_with_tobj(&bytes(write_obj, &meshes), &meshes);
            let off = String::from_utf8(bytes(write_off, &meshes)).expect("UTF-8");
            let (positions, triangles) = parse_off(&off);
            for (tri, read) in mesh.triangles.iter().zip(&triangles) {
                for j in 0..3 {
                    prop_assert_eq!(bits(positions[read[j]]), bits(mesh.vertices[tri[j] as usize]));
                }
            }
        }
    }
}

/// `surfc render MESHFILE`'s readers give back the triangles written: corner for corner,
/// exactly for the text and f64 formats, to f32 rounding for STL and GLB (GLB through its
/// node rotation and back, so the model is z-up again).
#[test]
fn surfc_reads_back_the_formats_it_draws() {
    use surfc::mesh::read::read_mesh;

    let sphere = icosphere(2, 2.0);
    let meshes = [NamedMesh {
        name: "sphere",
        mesh: &sphere,
    }];
    for format in [
        Format::Obj,
        Format::Ply,
        Format::Off,
        Format::ThreeMf,
        Format::Stl,
        Format::Glb,
    ] {
        let data = bytes(format_writer(format), &meshes);
        let read = read_mesh(&data, format).unwrap_or_else(|e| panic!("{format}: {e}"));
        assert_eq!(read.len(), 1, "{format}");
        let (name, mesh) = &read[0];
        if matches!(format, Format::Obj | Format::Glb | Format::ThreeMf) {
            assert_eq!(name, "sphere", "{format}");
        }
        assert_eq!(mesh.triangles.len(), sphere.triangles.len(), "{format}");
        let tolerance = if matches!(format, Format::Stl | Format::Glb) {
            1e-6
        } else {
            0.0
        };
        for (t, (got, want)) in mesh.triangles.iter().zip(&sphere.triangles).enumerate() {
            for k in 0..3 {
                let a = mesh.vertices[got[k] as usize];
                let b = sphere.vertices[want[k] as usize];
                assert!(
                    a.distance(b) <= tolerance,
                    "{format}: triangle {t} corner {k}: {a} read, {b} written"
                );
            }
        }
    }
}

// ---- units ----

/// `--unit`: 3MF records it as its `unit`, GLB scales the model to glTF's metres on the root
/// node (none for metres) and keeps the vertex data; surfc's reader gives millimetres back.
#[test]
fn units_are_recorded_by_3mf_and_glb() {
    use surfc::mesh::read::read_mesh;
    use surfc::mesh::write::{Unit, WriteOptions};

    let sphere = icosphere(1, 2.0);
    let meshes = [NamedMesh {
        name: "sphere",
        mesh: &sphere,
    }];
    for unit in Unit::ALL {
        let options = WriteOptions {
            unit,
            written: None,
        };
        let write = |format: Format| {
            let mut out = Vec::new();
            format
                .write_with(&mut out, &meshes, &options)
                .expect("written");
            out
        };
        let to_mm = unit.metres() / Unit::Millimetre.metres();

        let glb = write(Format::Glb);
        let (document, blob) = import_glb(&glb);
        let root = document
            .default_scene()
            .and_then(|s| s.nodes().next())
            .expect("a root node");
        let (_, _, scale) = root.transform().decomposed();
        assert_eq!(scale, [unit.metres() as f32; 3], "{unit}");
        let json = String::from_utf8_lossy(&glb[20..]).into_owned();
        assert_eq!(json.contains("\"scale\""), unit != Unit::Metre, "{unit}");
        let node = root.children().next().expect("the mesh's node");
        let primitive = node
            .mesh()
            .expect("a mesh")
            .primitives()
            .next()
            .expect("one");
        let positions: Vec<[f32; 3]> = primitive
            .reader(|_| Some(&blob[..]))
            .read_positions()
            .expect("positions")
            .collect();
        let expected: Vec<[f32; 3]> = sphere.vertices.iter().map(|&v| f32s(v)).collect();
        assert_eq!(
            positions, expected,
            "{unit}: the vertex data are the model's own"
        );

        let package = write(Format::ThreeMf);
        let mut archive = zip::ZipArchive::new(Cursor::new(&package)).expect("a zip");
        let mut model = String::new();
        std::io::Read::read_to_string(
            &mut archive.by_name("3D/3dmodel.model").expect("the model"),
            &mut model,
        )
        .expect("UTF-8");
        assert!(
            model.contains(&format!("<model unit=\"{}\"", unit.threemf_name())),
            "{unit}"
        );

        for (format, data, tolerance) in
            [(Format::Glb, &glb, 1e-6), (Format::ThreeMf, &package, 0.0)]
        {
            let read = read_mesh(data, format).expect("read");
            for (got, want) in read[0].1.vertices.iter().zip(&sphere.vertices) {
                let want = *want * to_mm;
                assert!(
                    got.distance(want) <= tolerance * want.length(),
                    "{unit} {format}: {got} read, {want} mm written"
                );
            }
        }
    }
}

// ---- the 3MF package ----

/// The extra fields of every local and central header of a zip archive, as (id, data).
fn zip_extra_fields(zip: &[u8]) -> Vec<(u16, Vec<u8>)> {
    let u16_at = |i: usize| u16::from_le_bytes([zip[i], zip[i + 1]]);
    let u32_at = |i: usize| u32::from_le_bytes([zip[i], zip[i + 1], zip[i + 2], zip[i + 3]]);
    let fields = |mut at: usize, end: usize, out: &mut Vec<(u16, Vec<u8>)>| {
        while at + 4 <= end {
            let (id, size) = (u16_at(at), usize::from(u16_at(at + 2)));
            out.push((id, zip[at + 4..at + 4 + size].to_vec()));
            at += 4 + size;
        }
    };
    // The end of central directory record: its last 22 bytes (surfc writes no comment).
    let end = zip.len() - 22;
    assert_eq!(
        u32_at(end),
        0x0605_4b50,
        "an end of central directory record"
    );
    let entries = usize::from(u16_at(end + 10));
    let mut at = u32_at(end + 16) as usize;
    let mut out = Vec::new();
    for _ in 0..entries {
        assert_eq!(u32_at(at), 0x0201_4b50, "a central directory header");
        let (name, extra, comment) = (
            usize::from(u16_at(at + 28)),
            usize::from(u16_at(at + 30)),
            usize::from(u16_at(at + 32)),
        );
        let local = u32_at(at + 42) as usize;
        assert_eq!(u32_at(local), 0x0403_4b50, "a local header");
        let (local_name, local_extra) = (
            usize::from(u16_at(local + 26)),
            usize::from(u16_at(local + 28)),
        );
        fields(
            local + 30 + local_name,
            local + 30 + local_name + local_extra,
            &mut out,
        );
        fields(at + 46 + name, at + 46 + name + extra, &mut out);
        at += 46 + name + extra + comment;
    }
    out
}

/// The package is plain zip: no zip64 record (id 1) anywhere, which miniz (PrusaSlicer),
/// libzip and lib3mf refused when the zip crate wrote two of them for the model part.
#[test]
fn the_3mf_package_has_no_zip64_records() {
    let cases = Cases::new();
    let package = bytes(write_3mf, &cases.named());
    let fields = zip_extra_fields(&package);
    assert!(
        fields.iter().all(|(id, _)| *id != 1),
        "zip64 records: {fields:?}"
    );
    let archive = zip::ZipArchive::new(Cursor::new(&package)).expect("a zip");
    assert_eq!(archive.len(), 3);
}

/// The count of bytes written (for the progress line) ends at the file's size; for 3MF,
/// whose package is put together in memory, at the model part's size before compression.
#[test]
fn the_bytes_written_are_counted() {
    use std::sync::atomic::{AtomicU64, Ordering};
    use surfc::mesh::write::{WriteOptions, write_mesh_file_with};

    let dir = tempfile::tempdir().expect("a temporary directory");
    let sphere = icosphere(4, 1.0);
    let meshes = [NamedMesh {
        name: "sphere",
        mesh: &sphere,
    }];
    for format in Format::ALL {
        let path = dir.path().join(format!("counted.{}", format.extension()));
        let written = AtomicU64::new(0);
        let options = WriteOptions {
            written: Some(&written),
            ..WriteOptions::default()
        };
        write_mesh_file_with(&path, format, &meshes, &options).expect("written");
        let expected = if format == Format::ThreeMf {
            let file = fs::File::open(&path).expect("the package");
            let mut archive = zip::ZipArchive::new(file).expect("a zip");
            archive
                .by_name("3D/3dmodel.model")
                .expect("the model")
                .size()
        } else {
            fs::metadata(&path).expect("the file").len()
        };
        assert_eq!(written.load(Ordering::Relaxed), expected, "{format}");
    }
}
