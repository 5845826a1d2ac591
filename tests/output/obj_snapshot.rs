//! The whole OBJ file of a coarse sphere, locked by insta: the writer's layout (`o`, `v`,
//! `vn`, `f a//a`), the shortest round-trip coordinates, and the marcher's determinism all
//! show in one small file. The mesh is checked before its bytes are locked.

use surfc::mesh::NamedMesh;
use surfc::mesh::check::{Expect, check};
use surfc::mesh::write::Format;
use surfc::pipeline::mesh_source;

const SOURCE: &str = "surface sphere = x^2 + y^2 + z^2 - 4;\n\
                      mesh coarse = sphere { step: 1; start: (1, 1, 1); uniform: true; }\n";

fn coarse_obj() -> String {
    let meshed = mesh_source(SOURCE).expect("the coarse sphere meshes");
    let m = &meshed[0];
    let (_, bad) = check(
        &m.mesh,
        None,
        &Expect {
            closed: true,
            euler: Some(2),
            components: Some(1),
            ..Expect::default()
        },
    );
    assert!(bad.is_empty(), "{bad:?}");
    assert!(m.report.triangles < 200, "{} triangles", m.report.triangles);
    let mut out = Vec::new();
    Format::Obj
        .write(
            &mut out,
            &[NamedMesh {
                name: &m.name,
                mesh: &m.mesh,
            }],
        )
        .unwrap();
    String::from_utf8(out).unwrap()
}

#[test]
fn coarse_sphere_obj() {
    let obj = coarse_obj();
    // Every coordinate read back is the computed one, to the bit.
    let meshed = mesh_source(SOURCE).unwrap();
    let read: Vec<f64> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .flat_map(|l| l.split(' ').map(|c| c.parse::<f64>().unwrap()))
        .collect();
    let computed: Vec<f64> = meshed[0]
        .mesh
        .vertices
        .iter()
        .flat_map(|v| [v.x, v.y, v.z])
        .collect();
    assert_eq!(read, computed);
    assert_eq!(obj, coarse_obj(), "the same input gives the same bytes");
    insta::assert_snapshot!(obj);
}
