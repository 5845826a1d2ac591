//! Coherent nets (the paper's Sects. 3.9 and 3.11): meshes that share a curve, written by
//! `surfc mesh` into one OBJ and read back by an independent reader (tobj), share the
//! curve's vertices exactly, so that in the file every edge of a shared polygon is used by the
//! triangles of each surface that shares it (one of each where a surface is meshed on one
//! side, two where on both), and nowhere else is an edge in more than two triangles.

use crate::common::cli;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Key = [u64; 3];
type Edge = (usize, usize);

/// The objects of an OBJ file: name → triangles over file-wide vertex ids (vertices matched by
/// their exact coordinates).
fn read_obj(path: &Path) -> BTreeMap<String, Vec<[usize; 3]>> {
    let (models, _) = tobj::load_obj(
        path,
        &tobj::LoadOptions {
            triangulate: false,
            single_index: false,
            ..Default::default()
        },
    )
    .expect("tobj reads the file");
    let mut ids: BTreeMap<Key, usize> = BTreeMap::new();
    let mut objects = BTreeMap::new();
    for m in models {
        let p = &m.mesh.positions;
        let mut id = |i: u32| {
            let i = 3 * i as usize;
            let key = [p[i].to_bits(), p[i + 1].to_bits(), p[i + 2].to_bits()];
            let next = ids.len();
            *ids.entry(key).or_insert(next)
        };
        let tris: Vec<[usize; 3]> = m
            .mesh
            .indices
            .chunks(3)
            .map(|t| [id(t[0]), id(t[1]), id(t[2])])
            .collect();
        objects.insert(m.name, tris);
    }
    objects
}

fn edges(tris: &[[usize; 3]]) -> BTreeMap<Edge, usize> {
    let mut count = BTreeMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    count
}

/// Meshes `file` into one OBJ and returns its objects.
fn mesh_to_obj(example: &str) -> BTreeMap<String, Vec<[usize; 3]>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // A directory of its own: two tests of one example run at once in this process.
    let dir = tempfile::tempdir().expect("a temporary directory");
    let out = dir.path().join(format!("{example}.obj"));
    let file = root.join("examples").join(format!("{example}.surf"));
    let run = cli::surfc(
        &[
            "mesh",
            file.to_str().unwrap(),
            "-q",
            "-o",
            out.to_str().unwrap(),
        ],
        root,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    read_obj(&out)
}

/// Edges of `a` that `b` uses too: the polygons the two surfaces share.
fn shared(a: &BTreeMap<Edge, usize>, b: &BTreeMap<Edge, usize>) -> BTreeSet<Edge> {
    a.keys().filter(|e| b.contains_key(e)).copied().collect()
}

#[test]
fn two_surfaces_share_their_seam_and_are_meshed_on_both_sides_of_it() {
    let objects = mesh_to_obj("two_surfaces");
    let sup = edges(&objects["superellipsoid"]);
    let cyl = edges(&objects["cylinder"]);
    let seam = shared(&sup, &cyl);
    // The seam: a closed polygon of the intersection curve, vertex for vertex in both meshes.
    assert!(seam.len() > 50, "{} shared edges", seam.len());
    for e in &seam {
        assert_eq!((sup[e], cyl[e]), (2, 2), "seam edge {e:?}");
    }
    let mut all = sup.clone();
    for (e, n) in &cyl {
        *all.entry(*e).or_insert(0) += n;
    }
    for (e, n) in &all {
        assert!(seam.contains(e) || *n <= 2, "edge {e:?} in {n} triangles");
    }
}

#[test]
fn g2_set_is_one_net() {
    let objects = mesh_to_obj("g2_set");
    let pieces: Vec<(&str, BTreeMap<Edge, usize>)> = ["cylinder", "roof", "blend", "closure"]
        .into_iter()
        .map(|n| (n, edges(&objects[n])))
        .collect();
    // Neighbours share their curve, each meshed on one side of it: one triangle of each.
    for (a, b) in [
        ("cylinder", "blend"),
        ("roof", "blend"),
        ("cylinder", "closure"),
    ] {
        let ea = &pieces.iter().find(|p| p.0 == a).unwrap().1;
        let eb = &pieces.iter().find(|p| p.0 == b).unwrap().1;
        let common = shared(ea, eb);
        assert!(
            common.len() > 20,
            "{a} and {b} share {} edges",
            common.len()
        );
        for e in &common {
            assert_eq!((ea[e], eb[e]), (1, 1), "{a}/{b} edge {e:?}");
        }
    }
    // The whole net: no edge in more than two triangles, and the only boundary left is the
    // roof's edge (one loop): the pieces close up along every shared curve.
    let mut all: BTreeMap<Edge, usize> = BTreeMap::new();
    for (_, e) in &pieces {
        for (k, n) in e {
            *all.entry(*k).or_insert(0) += n;
        }
    }
    assert!(all.values().all(|&n| n <= 2));
    let boundary: Vec<Edge> = all
        .iter()
        .filter(|(_, n)| **n == 1)
        .map(|(e, _)| *e)
        .collect();
    let mut degree: BTreeMap<usize, usize> = BTreeMap::new();
    for (a, b) in &boundary {
        *degree.entry(*a).or_insert(0) += 1;
        *degree.entry(*b).or_insert(0) += 1;
    }
    assert!(
        degree.values().all(|&d| d == 2),
        "the boundary is a union of loops"
    );
    let roof_only: usize = boundary
        .iter()
        .filter(|e| pieces[1].1.contains_key(e))
        .count();
    assert_eq!(roof_only, boundary.len(), "every open edge is the roof's");
    // Topologically a disc: the roof, with the cylinder standing on it and closed on top.
    let triangles: usize = ["cylinder", "roof", "blend", "closure"]
        .iter()
        .map(|n| objects[*n].len())
        .sum();
    let vertices: BTreeSet<usize> = objects.values().flatten().flatten().copied().collect();
    let euler = vertices.len() as i64 - all.len() as i64 + triangles as i64;
    assert_eq!(euler, 1);
}

/// The sphere with six holes (Sect. 3.8): its six boundary loops are exactly the six circles'
/// polygons (sampled with `segments: 60`, projected onto the sphere), vertex for vertex, to the
/// bit.
#[test]
fn six_holes_keep_their_circles_exactly() {
    use glam::DVec3;
    use surfc::mesh::topology::topology;
    use surfc::solve::curve::{circle_segments, project_onto};
    use surfc::solve::tolerance::SurfacePointTolerance;
    use surfc::surface::{NativeSurface, ValueGrad};

    let source = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/sphere_six_holes.surf"),
    )
    .unwrap();
    let meshed = surfc::pipeline::mesh_source(&source).expect("meshes");
    let m = &meshed[0];
    let loops = topology(&m.mesh).boundary_loops;
    assert_eq!(loops.len(), 6);
    let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let found: BTreeSet<Vec<Key>> = loops
        .iter()
        .map(|l| {
            let mut k: Vec<Key> = l
                .iter()
                .map(|&i| key(m.mesh.vertices[i as usize]))
                .collect();
            k.sort();
            k
        })
        .collect();
    // The circles of the file, projected with surfacepoint onto x² + y² + z² − 4, as the
    // command does (the compiled sphere and this closure agree to the last bit on this
    // formula: both compute x·x + y·y + z·z − 4 and 2x, 2y, 2z).
    let mut sphere = NativeSurface(|p: DVec3| ValueGrad {
        value: p.x * p.x + p.y * p.y + p.z * p.z - 4.0,
        gradient: 2.0 * p,
    });
    let (a, rho) = (1.6f64, (4.0f64 - 1.6 * 1.6).sqrt());
    let mut expected = BTreeSet::new();
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        for sign in [1.0, -1.0] {
            let circle = circle_segments(sign * a * axis, -sign * axis, rho, 60).unwrap();
            let on = project_onto(
                &mut sphere,
                &circle,
                m.step,
                &SurfacePointTolerance::default(),
            )
            .unwrap();
            let mut k: Vec<Key> = on.points.iter().map(|&v| key(v)).collect();
            k.sort();
            expected.insert(k);
        }
    }
    assert_eq!(found, expected);
}

/// The G2 set written to one OBJ is oriented as one surface: every edge is in one or two
/// triangles, and every edge in two is used once in each direction — across the curves the
/// pieces share too, where the closure (whose ∇f points into the cylinder) is flipped.
#[test]
fn g2_set_is_oriented_as_one() {
    let objects = mesh_to_obj("g2_set");
    let mut directed: BTreeMap<Edge, usize> = BTreeMap::new();
    for t in objects.values().flatten() {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
        }
    }
    let mut checked = 0;
    for (&(a, b), &n) in &directed {
        let back = directed.get(&(b, a)).copied().unwrap_or(0);
        assert!(n + back <= 2, "edge {a}-{b} in {} triangles", n + back);
        if n + back == 2 {
            assert_eq!((n, back), (1, 1), "edge {a}-{b} used twice the same way");
            checked += 1;
        }
    }
    assert!(checked > 1000, "{checked} interior edge directions");

    // The report says which mesh was flipped: the closure, against its own ∇f.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::env::temp_dir().join(format!("surfc-net-json-{}.obj", std::process::id()));
    let file = root.join("examples/g2_set.surf");
    let run = cli::surfc(
        &[
            "mesh",
            file.to_str().unwrap(),
            "-q",
            "--json",
            "-o",
            out.to_str().unwrap(),
        ],
        root,
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let _ = std::fs::remove_file(&out);
    let json: serde_json::Value = serde_json::from_slice(&run.stdout).expect("JSON");
    let flipped: BTreeMap<String, bool> = json["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            (
                m["name"].as_str().unwrap().to_string(),
                m["flipped"].as_bool().unwrap(),
            )
        })
        .collect();
    let expected: BTreeMap<String, bool> = [
        ("cylinder", false),
        ("roof", false),
        ("blend", false),
        ("closure", true),
    ]
    .into_iter()
    .map(|(n, f)| (n.to_string(), f))
    .collect();
    assert_eq!(flipped, expected);
}
