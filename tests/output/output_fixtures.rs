//! Meshes built by hand for the writer and render tests: a closed icosphere, an open grid
//! patch, two patches sharing a polygon of bit-identical vertices, a mesh without triangles,
//! and a mesh whose coordinates are hard to print.

#![allow(dead_code)]

use std::collections::HashMap;

use glam::DVec3;
use surfc::mesh::Mesh;

/// A sphere of radius `r` about the origin: an icosahedron subdivided `levels` times, vertices
/// projected onto the sphere, normals outward, triangles counter-clockwise seen from outside.
pub fn icosphere(levels: u32, r: f64) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut unit: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, unit: &mut Vec<DVec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                unit.push(((unit[a as usize] + unit[b as usize]) / 2.0).normalize());
                (unit.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(4 * triangles.len());
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut unit);
            let bc = midpoint(b, c, &mut unit);
            let ca = midpoint(c, a, &mut unit);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    Mesh {
        vertices: unit.iter().map(|u| *u * r).collect(),
        normals: unit,
        triangles,
        sides: Vec::new(),
    }
}

/// The height of the test patches over the plane.
fn height(x: f64, y: f64) -> f64 {
    0.3 * (2.0 * x).sin() * (1.5 * y).cos()
}

/// A grid patch z = height(x, y) + tilt·x over grid columns `columns` (x = i/n) and rows
/// 0..=n (y = j/n), normals from the gradient, triangles counter-clockwise seen from +z.
/// Patches built from adjacent column ranges share their common column bit for bit.
fn patch(columns: std::ops::RangeInclusive<i32>, n: i32, tilt: f64) -> Mesh {
    let mut mesh = Mesh::default();
    let (i0, i1) = (*columns.start(), *columns.end());
    for i in columns {
        for j in 0..=n {
            let (x, y) = (f64::from(i) / f64::from(n), f64::from(j) / f64::from(n));
            // The shared column x = 0 is computed the same way in every patch.
            let z = if i == 0 {
                height(x, y)
            } else {
                height(x, y) + tilt * x
            };
            let dx = 0.6 * (2.0 * x).cos() * (1.5 * y).cos() + tilt;
            let dy = -0.45 * (2.0 * x).sin() * (1.5 * y).sin();
            mesh.vertices.push(DVec3::new(x, y, z));
            mesh.normals.push(DVec3::new(-dx, -dy, 1.0).normalize());
        }
    }
    let rows = (n + 1) as u32;
    let at = |i: i32, j: i32| (i - i0) as u32 * rows + j as u32;
    for i in i0..i1 {
        for j in 0..n {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            mesh.triangles.push([a, b, c]);
            mesh.triangles.push([a, c, d]);
        }
    }
    mesh
}

/// An open patch with a boundary: an n×n grid over [0, 1]².
pub fn grid_patch(n: i32) -> Mesh {
    patch(0..=n, n, 0.0)
}

/// Two patches over [−1, 0]×[0, 1] and [0, 1]×[0, 1] that share the polygon x = 0 (n + 1
/// bit-identical vertices) but have different normals there.
pub fn shared_pair(n: i32) -> (Mesh, Mesh) {
    (patch(-n..=0, n, 0.0), patch(0..=n, n, 0.5))
}

/// A mesh with vertices but no triangles.
pub fn no_triangles() -> Mesh {
    Mesh {
        vertices: vec![DVec3::new(1.0, 2.0, 3.0)],
        normals: vec![DVec3::Z],
        triangles: vec![],
        sides: Vec::new(),
    }
}

/// Triangles whose coordinates are hard to print exactly: integers, negative zero, tiny,
/// huge and subnormal numbers, and sums with no short decimal form.
pub fn tricky_numbers() -> Mesh {
    let values = [
        2.0,
        -0.0,
        0.1 + 0.2,
        1.0 / 3.0,
        1e-7,
        -2.5e-300,
        1e20,
        123456789.125,
        f64::MIN_POSITIVE,
        5e-324,
        f64::MAX,
        -1.0,
    ];
    let mut mesh = Mesh::default();
    for (k, w) in values.windows(3).enumerate() {
        mesh.vertices.push(DVec3::new(w[0], w[1], w[2]));
        mesh.normals
            .push(DVec3::new(w[1], w[2], w[0]).normalize_or(DVec3::Z));
        if k >= 2 {
            let k = k as u32;
            mesh.triangles.push([k - 2, k - 1, k]);
        }
    }
    mesh
}
