//! The new formats read back by the readers their users have: meshio (OBJ, gmsh MSH, VTK
//! VTU), trimesh (OBJ, 3MF) and lib3mf (3MF, the 3MF consortium's reference library, in
//! strict mode and without a warning), run by `python3` on files the writers made. Each block
//! must come back apart from the others, under its name (or index, where the reader keeps no
//! name), with the same triangles: the same corners bit for bit (every one of these formats
//! is exact text; lib3mf holds 32-bit floats, so to f32 there) in the same winding.
//!
//! Without python3, meshio, trimesh, lxml or lib3mf the tests say so on stderr and pass,
//! unless `SURFC_REQUIRE_PY_READERS=1` (as `.ci/run` sets), under which they fail.

use crate::output_fixtures;

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::process::Command;

use output_fixtures::{grid_patch, icosphere, no_triangles, shared_pair, tricky_numbers};
use surfc::mesh::write::{Format, write_mesh_file};
use surfc::mesh::{Mesh, NamedMesh};

/// A triangle as the bit patterns of its corners, turned so that its smallest corner comes
/// first (a reader may start a triangle at another corner; the winding must stay).
type Corners = [[u64; 3]; 3];

fn canonical(mut t: Corners) -> Corners {
    let first = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
    t.rotate_left(first);
    t
}

/// A block's triangles as sorted canonical corner triples.
fn triangle_set(triangles: impl Iterator<Item = Corners>) -> Vec<Corners> {
    let mut set: Vec<Corners> = triangles.map(canonical).collect();
    set.sort_unstable();
    set
}

fn expected(mesh: &Mesh) -> Vec<Corners> {
    expected_rounded(mesh, |x| x)
}

/// [`expected`] with every coordinate passed through `round` (a reader's precision).
fn expected_rounded(mesh: &Mesh, round: fn(f64) -> f64) -> Vec<Corners> {
    triangle_set(mesh.triangles.iter().map(|t| {
        t.map(|i| {
            mesh.vertices[i as usize]
                .to_array()
                .map(|x| round(x).to_bits())
        })
    }))
}

/// Whether python3 can import lib3mf; if not, says so loudly, and fails under
/// `SURFC_REQUIRE_PY_READERS=1`.
fn lib3mf_available() -> bool {
    modules_available(&["lib3mf"], "the 3MF is NOT checked by lib3mf")
}

/// Whether the Python readers can run; if not, says so loudly, and fails under
/// `SURFC_REQUIRE_PY_READERS=1`.
fn python_readers_available() -> bool {
    modules_available(
        &["meshio", "trimesh", "lxml", "networkx"],
        "the MSH, VTU, 3MF and OBJ files are NOT checked by independent readers",
    )
}

/// Whether python3 can import `modules`; if not, says so loudly (`unchecked`: what goes
/// unchecked then), and fails under `SURFC_REQUIRE_PY_READERS=1`.
fn modules_available(modules: &[&str], unchecked: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {}", modules.join(", "))])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        let names = modules.join(", ");
        let required = std::env::var("SURFC_REQUIRE_PY_READERS").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "SURFC_REQUIRE_PY_READERS=1 but python3 with {names} is not available"
        );
        // Straight to the stderr handle: libtest captures `eprintln!` of passing tests, and
        // this must be seen.
        let _ = writeln!(
            std::io::stderr(),
            "\n*** SKIPPED: python3 with {names} is not available; {unchecked}. `pip install {}` \
             (or run .ci/run) to check them. ***\n",
            modules.join(" ")
        );
    }
    ok
}

/// One block as a reader found it.
struct Block {
    name: Option<String>,
    index: Option<usize>,
    triangles: Vec<Corners>,
}

/// Runs tests/readers/read_mesh.py: the number of points the reader found (if it says) and
/// the blocks.
fn read_with(reader: &str, format: Format, path: &Path) -> (Option<usize>, Vec<Block>) {
    let json = read_json(reader, format, path);
    blocks_of(&json)
}

/// What tests/readers/read_mesh.py prints.
fn read_json(reader: &str, format: Format, path: &Path) -> serde_json::Value {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/readers/read_mesh.py");
    let output = Command::new("python3")
        .arg(&script)
        .args([reader, format.extension()])
        .arg(path)
        .output()
        .expect("python3 runs");
    assert!(
        output.status.success(),
        "{reader} could not read the {format} file:\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("the script prints JSON")
}

/// The number of points the reader found (if it says) and the blocks.
fn blocks_of(json: &serde_json::Value) -> (Option<usize>, Vec<Block>) {
    let points = json["points"].as_u64().map(|n| n as usize);
    let blocks = json["blocks"]
        .as_array()
        .expect("blocks")
        .iter()
        .map(|b| Block {
            name: b["name"].as_str().map(str::to_owned),
            index: b["index"].as_u64().map(|k| k as usize),
            triangles: triangle_set(b["triangles"].as_array().expect("triangles").iter().map(
                |t| {
                    let corner = |k: usize| {
                        let p = &t[k];
                        [0, 1, 2].map(|j| p[j].as_u64().expect("a coordinate's bits"))
                    };
                    [corner(0), corner(1), corner(2)]
                },
            )),
        })
        .collect();
    (points, blocks)
}

/// The meshes every format is checked with: closed, open, two sharing a polygon, one
/// without triangles, one with hard numbers.
struct Cases {
    meshes: Vec<(&'static str, Mesh)>,
}

impl Cases {
    fn new() -> Cases {
        let (left, right) = shared_pair(6);
        Cases {
            meshes: vec![
                ("sphere", icosphere(2, 2.0)),
                ("patch", grid_patch(5)),
                ("left", left),
                ("nothing", no_triangles()),
                ("right", right),
                ("tricky", tricky_numbers()),
            ],
        }
    }

    fn named(&self) -> Vec<NamedMesh<'_>> {
        self.meshes
            .iter()
            .map(|(name, mesh)| NamedMesh { name, mesh })
            .collect()
    }

    /// The number of distinct positions over all meshes (what a shared vertex list holds).
    fn distinct_positions(&self) -> usize {
        let mut all: Vec<[u64; 3]> = self
            .meshes
            .iter()
            .flat_map(|(_, m)| m.vertices.iter().map(|v| v.to_array().map(f64::to_bits)))
            .collect();
        all.sort_unstable();
        all.dedup();
        all.len()
    }
}

/// Writes the cases in `format` and checks what `reader` finds: every mesh with triangles is
/// one block, found by name or by its index among the meshes, with the same triangles.
fn check(reader: &str, format: Format, shared_points: bool) {
    if !python_readers_available() {
        return;
    }
    let cases = Cases::new();
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join(format!("cases.{}", format.extension()));
    write_mesh_file(&path, format, &cases.named()).expect("written");
    let (points, blocks) = read_with(reader, format, &path);

    let drawn: Vec<(usize, &str, &Mesh)> = cases
        .meshes
        .iter()
        .enumerate()
        .filter(|(_, (_, m))| !m.triangles.is_empty())
        .map(|(k, (name, mesh))| (k, *name, mesh))
        .collect();
    assert_eq!(blocks.len(), drawn.len(), "{reader}/{format}: the blocks");
    let mut found: BTreeMap<usize, &Block> = BTreeMap::new();
    for block in &blocks {
        let k = match (&block.name, block.index) {
            (_, Some(index)) => index,
            (Some(name), None) => cases
                .meshes
                .iter()
                .position(|(n, _)| n == name)
                .unwrap_or_else(|| panic!("{reader}/{format}: an unknown block `{name}`")),
            (None, None) => panic!("{reader}/{format}: a block without name or index"),
        };
        assert!(
            found.insert(k, block).is_none(),
            "{reader}/{format}: block {k} twice"
        );
    }
    for (k, name, mesh) in drawn {
        let block = found
            .get(&k)
            .unwrap_or_else(|| panic!("{reader}/{format}: `{name}` is missing"));
        let want = expected(mesh);
        assert_eq!(
            block.triangles.len(),
            want.len(),
            "{reader}/{format}: the triangle count of `{name}`"
        );
        if let Some(k) = (0..want.len()).find(|&k| block.triangles[k] != want[k]) {
            panic!(
                "{reader}/{format}: `{name}` differs at triangle {k} (sorted): {:?} read, {:?} written",
                block.triangles[k], want[k]
            );
        }
    }
    if shared_points {
        // Shared polygons stay shared: one point per distinct position.
        assert_eq!(
            points,
            Some(cases.distinct_positions()),
            "{reader}/{format}"
        );
    }
}

#[test]
fn meshio_reads_obj_blocks_apart_with_one_normal_per_point() {
    check("meshio", Format::Obj, true);
}

#[test]
fn trimesh_reads_obj_objects_by_name() {
    check("trimesh", Format::Obj, false);
}

#[test]
fn meshio_reads_msh_physical_groups_by_name() {
    check("meshio", Format::Msh, true);
}

#[test]
fn meshio_reads_vtu_blocks_from_cell_data() {
    check("meshio", Format::Vtu, true);
}

#[test]
fn trimesh_reads_3mf_objects_by_name() {
    check("trimesh", Format::ThreeMf, false);
}

/// lib3mf, strict, reads every object of the cases under its name with the same triangles
/// (to f32), one build item each, and the unit written; no warning. The case with hard
/// numbers is left out: lib3mf refuses coordinates beyond 10⁹ (its own limit; the format's
/// numbers are doubles).
#[test]
fn lib3mf_reads_3mf_strictly_without_warnings() {
    use surfc::mesh::write::{Unit, WriteOptions, write_mesh_file_with};

    if !lib3mf_available() {
        return;
    }
    let mut cases = Cases::new();
    cases.meshes.retain(|(name, _)| *name != "tricky");
    let dir = tempfile::tempdir().expect("a temporary directory");
    for unit in [Unit::Millimetre, Unit::Inch] {
        let path = dir.path().join(format!("cases-{unit}.3mf"));
        let options = WriteOptions {
            unit,
            written: None,
        };
        write_mesh_file_with(&path, Format::ThreeMf, &cases.named(), &options).expect("written");
        let json = read_json("lib3mf", Format::ThreeMf, &path);
        assert_eq!(json["unit"], unit.threemf_name());
        let (_, blocks) = blocks_of(&json);
        let drawn: Vec<&(&str, Mesh)> = cases
            .meshes
            .iter()
            .filter(|(_, m)| !m.triangles.is_empty())
            .collect();
        assert_eq!(blocks.len(), drawn.len());
        assert_eq!(json["build_items"].as_u64(), Some(drawn.len() as u64));
        for ((name, mesh), block) in drawn.iter().zip(&blocks) {
            assert_eq!(block.name.as_deref(), Some(*name));
            let want = expected_rounded(mesh, |x| f64::from(x as f32));
            assert!(block.triangles == want, "lib3mf: `{name}` differs");
        }
    }
}

/// lib3mf, strict, reads the 3MF of the CAD part and of the torus without a warning, finds
/// each object manifold and oriented (closed, every edge walked once each way), and gets the
/// triangles written.
#[test]
fn lib3mf_finds_the_parts_closed_and_oriented() {
    if !lib3mf_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("a temporary directory");
    for (name, meshed) in [
        ("plate", crate::parts::plate()),
        ("torus", crate::parts::torus()),
    ] {
        let path = dir.path().join(format!("{name}.3mf"));
        let meshes = crate::parts::named(meshed);
        write_mesh_file(&path, Format::ThreeMf, &meshes).expect("written");
        let json = read_json("lib3mf", Format::ThreeMf, &path);
        let (_, blocks) = blocks_of(&json);
        assert_eq!(blocks.len(), meshes.len(), "{name}");
        for (named, (block, raw)) in meshes.iter().zip(
            blocks
                .iter()
                .zip(json["blocks"].as_array().expect("blocks")),
        ) {
            assert_eq!(raw["manifold"], true, "{name}: `{}`", named.name);
            let want = expected_rounded(named.mesh, |x| f64::from(x as f32));
            assert!(block.triangles == want, "{name}: `{}` differs", named.name);
        }
    }
}
