//! The raster: named meshes → a [`Picture`] by a z-buffer over supersampled pixels.
//!
//! Pixel rule: a sample at the centre (x + ½, y + ½) belongs to a triangle when all three
//! edge functions are ≥ 0; of several triangles the one nearest the viewer wins, and at equal
//! depth the one drawn first (meshes and triangles in input order). Edge lines are drawn inside
//! each triangle, within half a line width of its sides, so a shared edge gets one full-width
//! line and hidden edges stay hidden. The supersampled image is averaged down to the picture.

use glam::DVec3;

use super::{
    BACKGROUND, Camera, EDGE, EDGE_HALF_WIDTH, Picture, RenderOptions, Rgb, edge_strength, mix,
    to_u8,
};
use crate::mesh::NamedMesh;

/// Largest supersampling factor along each axis.
const MAX_SUPERSAMPLING: u32 = 4;
/// Most samples the target may hold (7 bytes each); big pictures get less supersampling.
const MAX_SAMPLES: u64 = 1 << 25;

/// Draws the meshes (see the module comments of `render` and this module).
pub fn render(meshes: &[NamedMesh], options: &RenderOptions) -> Picture {
    let width = options.width.clamp(1, super::MAX_SIDE);
    let height = options.height.clamp(1, super::MAX_SIDE);
    let mut ss = options.supersampling.clamp(1, MAX_SUPERSAMPLING);
    while ss > 1 && u64::from(width * ss) * u64::from(height * ss) > MAX_SAMPLES {
        ss -= 1;
    }
    let camera = Camera::fit(
        meshes,
        options.view,
        f64::from(width),
        f64::from(height),
        options.margin,
    );
    let mut target = Target::new(width * ss, height * ss);
    let ssf = f64::from(ss);
    let mut projected = Vec::new();
    for (k, named) in meshes.iter().enumerate() {
        let mesh = named.mesh;
        projected.clear();
        projected.extend(mesh.vertices.iter().map(|&v| {
            let p = camera.project(v);
            DVec3::new(p.x * ssf, p.y * ssf, p.z)
        }));
        for &tri in &mesh.triangles {
            let Some(corners) = corners(&projected, tri) else {
                continue;
            };
            let world = corners_of(&mesh.vertices, tri);
            let normal = (world[1] - world[0]).cross(world[2] - world[0]);
            let fill = camera.shade(normal, k);
            let strength = if options.edges {
                edge_strength(area2(corners) / (ssf * ssf))
            } else {
                0.0
            };
            target.triangle(corners, fill, strength, EDGE_HALF_WIDTH * ssf);
        }
    }
    target.downsample(ss, width, height)
}

/// The projected corners of a triangle, or None if an index is out of range or a corner is
/// not finite.
fn corners(projected: &[DVec3], tri: [u32; 3]) -> Option<[DVec3; 3]> {
    let mut out = [DVec3::ZERO; 3];
    for (o, &i) in out.iter_mut().zip(&tri) {
        let p = *projected.get(i as usize)?;
        if !p.is_finite() {
            return None;
        }
        *o = p;
    }
    Some(out)
}

/// The world corners of a triangle whose indices `corners` has checked.
fn corners_of(vertices: &[DVec3], tri: [u32; 3]) -> [DVec3; 3] {
    tri.map(|i| vertices[i as usize])
}

/// Twice the signed area of the projected triangle (positive: clockwise on screen, as y
/// points down).
fn area2([a, b, c]: [DVec3; 3]) -> f64 {
    (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x)
}

/// The supersampled colour and depth buffers.
struct Target {
    width: u32,
    height: u32,
    colour: Vec<[u8; 3]>,
    /// Depth towards the viewer of the nearest triangle so far at each sample.
    depth: Vec<f32>,
}

impl Target {
    fn new(width: u32, height: u32) -> Target {
        let n = width as usize * height as usize;
        Target {
            width,
            height,
            colour: vec![to_u8(BACKGROUND); n],
            depth: vec![f32::NEG_INFINITY; n],
        }
    }

    /// Draws one triangle: flat `fill`, edge lines of the given strength (0..=1) and half
    /// width (in samples).
    fn triangle(&mut self, corners: [DVec3; 3], fill: Rgb, strength: f32, half_width: f64) {
        let [a, mut b, mut c] = corners;
        let mut area = area2([a, b, c]);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        // Make every edge function positive inside.
        if area < 0.0 {
            std::mem::swap(&mut b, &mut c);
            area = -area;
        }
        let lo = a.min(b).min(c);
        let hi = a.max(b).max(c);
        // Samples whose centre lies in [lo, hi], clipped to the target.
        let first = |lo: f64| (lo - 0.5).ceil().max(0.0);
        let last = |hi: f64, size: u32| (hi - 0.5).floor().min(f64::from(size) - 1.0);
        let (x0, x1) = (first(lo.x), last(hi.x, self.width));
        let (y0, y1) = (first(lo.y), last(hi.y, self.height));
        if x0 > x1 || y0 > y1 {
            return;
        }
        // Edge k is the side opposite corner k; its function is that corner's barycentric
        // coordinate times `area`, and its value over the side's length the distance to it.
        let edges = [(b, c), (c, a), (a, b)].map(|(p, q)| Edge::new(p, q));
        let depths = [a.z, b.z, c.z];
        let fill_u8 = to_u8(fill);
        let (x0, x1, y0, y1) = (x0 as u32, x1 as u32, y0 as u32, y1 as u32);
        for y in y0..=y1 {
            let py = f64::from(y) + 0.5;
            let row = y as usize * self.width as usize;
            for x in x0..=x1 {
                let px = f64::from(x) + 0.5;
                let e = edges.map(|edge| edge.at(px, py));
                if e[0] < 0.0 || e[1] < 0.0 || e[2] < 0.0 {
                    continue;
                }
                let z = ((e[0] * depths[0] + e[1] * depths[1] + e[2] * depths[2]) / area) as f32;
                let i = row + x as usize;
                if z <= self.depth[i] {
                    continue;
                }
                self.depth[i] = z;
                self.colour[i] = if strength > 0.0 {
                    let distance = (0..3)
                        .map(|k| e[k] * edges[k].inverse_length)
                        .fold(f64::INFINITY, f64::min);
                    let line = (half_width + 0.5 - distance).clamp(0.0, 1.0) as f32;
                    if line > 0.0 {
                        to_u8(mix(fill, EDGE, line * strength))
                    } else {
                        fill_u8
                    }
                } else {
                    fill_u8
                };
            }
        }
    }

    /// Averages `ss`×`ss` blocks of samples into a picture.
    fn downsample(&self, ss: u32, width: u32, height: u32) -> Picture {
        let mut rgb = Vec::with_capacity(3 * width as usize * height as usize);
        let n = ss * ss;
        for y in 0..height {
            for x in 0..width {
                let mut sum = [0u32; 3];
                for sy in 0..ss {
                    let row = (y * ss + sy) as usize * self.width as usize;
                    for sx in 0..ss {
                        let c = self.colour[row + (x * ss + sx) as usize];
                        for k in 0..3 {
                            sum[k] += u32::from(c[k]);
                        }
                    }
                }
                rgb.extend(sum.map(|s| ((s + n / 2) / n) as u8));
            }
        }
        Picture { width, height, rgb }
    }
}

/// The edge function of the directed side p → q: positive on the triangle's side.
#[derive(Clone, Copy)]
struct Edge {
    p: DVec3,
    d: DVec3,
    inverse_length: f64,
}

impl Edge {
    fn new(p: DVec3, q: DVec3) -> Edge {
        let d = q - p;
        let length = d.x.hypot(d.y);
        let inverse_length = if length > 0.0 { 1.0 / length } else { 0.0 };
        Edge {
            p,
            d,
            inverse_length,
        }
    }

    fn at(&self, x: f64, y: f64) -> f64 {
        self.d.x * (y - self.p.y) - self.d.y * (x - self.p.x)
    }
}
