//! Solids whose operands share face planes (issue 42): L, T and U brackets of boxes, stacked
//! blocks, boxes side by side, the same parts moved and turned — meshed right, every face one
//! face, no crease where operands coincide. Checked against an exact reference that never
//! looks at a mesh: a union of axis-aligned boxes cut into the cells between its distinct
//! coordinates, each cell in or out, gives the exact area, volume, face planes, corners and
//! creases of the solid.

use crate::common;

use glam::{DMat3, DVec3};
use surfc::mesh::check::Expect;
use surfc::pipeline::{Meshed, mesh_source};

/// An axis-aligned box (lo, hi).
type Aabb = (DVec3, DVec3);

/// The union of axis-aligned boxes, cut at every distinct coordinate into cells.
struct Cells {
    coords: [Vec<f64>; 3],
    inside: Vec<bool>,
}

impl Cells {
    fn new(boxes: &[Aabb]) -> Cells {
        let coords: [Vec<f64>; 3] = std::array::from_fn(|k| {
            let mut c: Vec<f64> = boxes.iter().flat_map(|b| [b.0[k], b.1[k]]).collect();
            c.sort_by(f64::total_cmp);
            c.dedup();
            c
        });
        let n = [
            coords[0].len() - 1,
            coords[1].len() - 1,
            coords[2].len() - 1,
        ];
        let mut inside = vec![false; n[0] * n[1] * n[2]];
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    let c = DVec3::new(
                        0.5 * (coords[0][i] + coords[0][i + 1]),
                        0.5 * (coords[1][j] + coords[1][j + 1]),
                        0.5 * (coords[2][k] + coords[2][k + 1]),
                    );
                    inside[(i * n[1] + j) * n[2] + k] = boxes
                        .iter()
                        .any(|b| c.cmpgt(b.0).all() && c.cmplt(b.1).all());
                }
            }
        }
        Cells { coords, inside }
    }

    fn n(&self) -> [usize; 3] {
        std::array::from_fn(|k| self.coords[k].len() - 1)
    }

    /// Whether cell (i, j, k) is inside (cells outside the grid are not).
    fn at(&self, c: [i64; 3]) -> bool {
        let n = self.n();
        if (0..3).any(|k| c[k] < 0 || c[k] >= n[k] as i64) {
            return false;
        }
        let [i, j, k] = c.map(|x| x as usize);
        self.inside[(i * n[1] + j) * n[2] + k]
    }

    fn volume(&self) -> f64 {
        let n = self.n();
        let mut v = 0.0;
        for i in 0..n[0] {
            for j in 0..n[1] {
                for k in 0..n[2] {
                    if self.at([i as i64, j as i64, k as i64]) {
                        v += (0..3)
                            .map(|a| {
                                let x = [i, j, k][a];
                                self.coords[a][x + 1] - self.coords[a][x]
                            })
                            .product::<f64>();
                    }
                }
            }
        }
        v
    }

    /// The boundary's area: cell faces between a cell inside and one outside.
    fn area(&self) -> f64 {
        let n = self.n();
        let mut area = 0.0;
        for i in -1..=n[0] as i64 {
            for j in -1..=n[1] as i64 {
                for k in -1..=n[2] as i64 {
                    let c = [i, j, k];
                    for axis in 0..3 {
                        let mut d = c;
                        d[axis] += 1;
                        if self.at(c) != self.at(d) {
                            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
                            let side = |t: usize, x: i64| {
                                self.coords[t][x as usize + 1] - self.coords[t][x as usize]
                            };
                            area += side(a, c[a]) * side(b, c[b]);
                        }
                    }
                }
            }
        }
        area
    }

    /// The grid point (i, j, k)'s place.
    fn point(&self, g: [usize; 3]) -> DVec3 {
        DVec3::new(
            self.coords[0][g[0]],
            self.coords[1][g[1]],
            self.coords[2][g[2]],
        )
    }

    /// The eight cells around grid point g, inside or not (bit 0: x above, 1: y, 2: z).
    fn around(&self, g: [usize; 3]) -> [bool; 8] {
        std::array::from_fn(|m| {
            let c = [0, 1, 2].map(|a| g[a] as i64 - 1 + ((m >> a) & 1) as i64);
            self.at(c)
        })
    }

    /// The solid's corners: grid points where the boundary is not a plane or an edge —
    /// where the normals of the boundary around the point span space.
    fn corners(&self) -> Vec<DVec3> {
        let n = self.n();
        let mut out = Vec::new();
        for i in 0..=n[0] {
            for j in 0..=n[1] {
                for k in 0..=n[2] {
                    let a = self.around([i, j, k]);
                    // The axes along which the boundary around the point has a face.
                    let mut normals = [false; 3];
                    for m in 0..8 {
                        for axis in 0..3 {
                            if a[m] != a[m ^ (1 << axis)] {
                                normals[axis] = true;
                            }
                        }
                    }
                    if normals.iter().all(|&x| x) {
                        out.push(self.point([i, j, k]));
                    }
                }
            }
        }
        out
    }
}

/// Meshes `source` (one block) and checks it against the union of `boxes` moved by `place`
/// (p ↦ rot·p + shift): closed with χ 2 per component, every triangle ≥ 30°, every vertex
/// on a face plane of the solid, every triangle inside one face plane (no triangle spans a
/// crease), every corner of the solid a mesh vertex, and the area and volume exact.
fn assert_boxes(source: &str, boxes: &[Aabb], place: (DMat3, DVec3), components: i64) {
    let m: Meshed = match mesh_source(source) {
        Ok(mut m) if m.len() == 1 => m.remove(0),
        Ok(m) => panic!("expected one mesh, got {}", m.len()),
        Err(d) => panic!("does not mesh: {d:?}\n{source}"),
    };
    let expect = Expect {
        components: Some(components as usize),
        min_angle_deg: 30.0,
        ..common::closed(2 * components)
    };
    common::assert_closed(&m, &expect);
    let (rot, shift) = place;
    let back = rot.transpose();
    let local: Vec<DVec3> = m
        .mesh
        .vertices
        .iter()
        .map(|&v| back * (v - shift))
        .collect();
    let cells = Cells::new(boxes);
    let scale = cells
        .coords
        .iter()
        .flatten()
        .fold(1.0f64, |a, &c| a.max(c.abs()));
    let tol = 1e-9 * scale;
    let on_plane = |p: DVec3, axis: usize| {
        cells.coords[axis]
            .iter()
            .find(|&&c| (p[axis] - c).abs() <= tol)
            .copied()
    };
    let mut area = 0.0;
    let mut volume = 0.0;
    for t in &m.mesh.triangles {
        let p = t.map(|k| local[k as usize]);
        let flat = (0..3).any(|axis| {
            on_plane(p[0], axis).is_some_and(|c| p.iter().all(|q| (q[axis] - c).abs() <= tol))
        });
        assert!(flat, "triangle {p:?} spans a crease\n{source}");
        area += 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        volume += p[0].dot(p[1].cross(p[2])) / 6.0;
    }
    for c in cells.corners() {
        assert!(
            local.iter().any(|v| v.distance(c) <= tol),
            "corner {c} is not a vertex\n{source}"
        );
    }
    let (ea, ev) = (cells.area(), cells.volume());
    assert!(
        (area - ea).abs() <= 1e-9 * ea,
        "area {area}, exact {ea}\n{source}"
    );
    assert!(
        (volume - ev).abs() <= 1e-9 * ev,
        "volume {volume}, exact {ev}\n{source}"
    );
}

fn aabb(lo: [f64; 3], hi: [f64; 3]) -> Aabb {
    (DVec3::from(lo), DVec3::from(hi))
}

fn box_text(b: &Aabb) -> String {
    format!(
        "box(({}, {}, {}), ({}, {}, {}))",
        b.0.x, b.0.y, b.0.z, b.1.x, b.1.y, b.1.z
    )
}

fn union_text(boxes: &[Aabb]) -> String {
    let parts: Vec<String> = boxes.iter().map(box_text).collect();
    format!("union({})", parts.join(", "))
}

const IDENTITY: (DMat3, DVec3) = (DMat3::IDENTITY, DVec3::ZERO);

/// The issue's L-bracket (two boxes sharing the planes x = 0, y = 0, y = 1 and z = 0), the
/// same L with the upright starting at z = 0.2 (faces flush over part of their extent), and
/// two blocks side by side (one 2×1×1 block: the shared face is inside, no crease there), at
/// the issue's steps.
#[test]
fn flush_brackets_and_blocks_at_the_issues_steps() {
    let parts: [&[Aabb]; 3] = [
        &[
            aabb([0.0, 0.0, 0.0], [2.0, 1.0, 0.3]),
            aabb([0.0, 0.0, 0.0], [0.3, 1.0, 1.5]),
        ],
        &[
            aabb([0.0, 0.0, 0.0], [2.0, 1.0, 0.3]),
            aabb([0.0, 0.0, 0.2], [0.3, 1.0, 1.5]),
        ],
        &[
            aabb([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
            aabb([1.0, 0.0, 0.0], [2.0, 1.0, 1.0]),
        ],
    ];
    for boxes in parts {
        for step in [0.05, 0.1, 0.3] {
            let source = format!(
                "surface s = {};\nmesh s = s {{ step: {step}; box: (-0.5, -0.5, -0.5) .. (2.5, 1.5, 2); }}\n",
                union_text(boxes)
            );
            assert_boxes(&source, boxes, IDENTITY, 1);
        }
    }
    // The block's shared face x = 1 holds no crease: its only creases are the block's 12.
    let m = &mesh_source(
        "surface s = union(box((0, 0, 0), (1, 1, 1)), box((1, 0, 0), (2, 1, 1)));\n\
         mesh s = s { step: 0.1; box: (-0.5, -0.5, -0.5) .. (2.5, 1.5, 1.5); }\n",
    )
    .unwrap_or_else(|d| panic!("{d:?}"))[0];
    assert_eq!(m.creases.map(|c| (c.creases, c.corners)), Some((12, 8)));
}

/// T and U brackets, stacked blocks partly flush, a block on a plate flush with its edge:
/// each exact, at step 0.05.
#[test]
fn t_and_u_brackets_and_stacked_blocks() {
    let parts: [&[Aabb]; 4] = [
        &[
            aabb([-1.0, 0.0, 0.0], [1.0, 1.0, 0.3]),
            aabb([-0.15, 0.0, 0.0], [0.15, 1.0, 1.2]),
        ],
        &[
            aabb([-1.0, 0.0, 0.0], [1.0, 1.0, 0.3]),
            aabb([-1.0, 0.0, 0.0], [-0.7, 1.0, 0.9]),
            aabb([0.7, 0.0, 0.0], [1.0, 1.0, 0.9]),
        ],
        &[
            aabb([0.0, 0.0, 0.0], [2.0, 1.5, 0.5]),
            aabb([0.0, 0.0, 0.5], [1.2, 1.0, 1.0]),
            aabb([0.4, 0.0, 1.0], [1.2, 0.6, 1.4]),
        ],
        &[
            aabb([0.0, 0.0, 0.0], [2.0, 1.0, 0.2]),
            aabb([1.4, 0.3, 0.2], [2.0, 0.7, 0.8]),
        ],
    ];
    for boxes in parts {
        let source = format!(
            "surface s = {};\nmesh s = s {{ step: 0.05; box: (-1.5, -0.5, -0.5) .. (2.5, 2, 2); }}\n",
            union_text(boxes)
        );
        assert_boxes(&source, boxes, IDENTITY, 1);
    }
}

/// The L written so that rounding makes its shared faces differ by ulps: each box moved into
/// place by `translate` from a box about the origin, and the whole L turned about a skew
/// axis. The faces are one face by their values and gradients, not by the text.
#[test]
fn moved_and_turned_copies_are_one_face_too() {
    let boxes = [
        aabb([0.0, 0.0, 0.0], [2.0, 1.0, 0.3]),
        aabb([0.0, 0.0, 0.0], [0.3, 1.0, 1.5]),
    ];
    let moved = "union(translate(box((-1, -0.5, -0.15), (1, 0.5, 0.15)), (1, 0.5, 0.15)), \
                 translate(box((-0.15, -0.5, -0.75), (0.15, 0.5, 0.75)), (0.15, 0.5, 0.75)))";
    let source = format!(
        "surface s = {moved};\nmesh s = s {{ step: 0.1; box: (-0.5, -0.5, -0.5) .. (2.5, 1.5, 2); }}\n"
    );
    assert_boxes(&source, &boxes, IDENTITY, 1);
    let axis = DVec3::new(1.0, 1.0, 1.0).normalize();
    let angle = 0.7;
    let source = format!(
        "surface s = rotate({moved}, axis: (1, 1, 1), angle: {angle});\n\
         mesh s = s {{ step: 0.1; box: (-2.5, -2.5, -2.5) .. (2.5, 2.5, 2.5); }}\n"
    );
    assert_boxes(
        &source,
        &boxes,
        (DMat3::from_axis_angle(axis, angle), DVec3::ZERO),
        1,
    );
}
