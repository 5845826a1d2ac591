//! SVG: named meshes → an SVG drawing of the same picture as the raster, one filled path per
//! triangle, by the painter's algorithm: triangles sorted by the depth of their centroids and
//! drawn from the farthest to the nearest.
//!
//! Limits of depth sorting: a triangle is drawn wholly in front of or behind another, so
//! triangles that cross, or long triangles whose centroid order differs from their order
//! where they overlap, can show the wrong one in front. Marched meshes have small, similar
//! triangles, for which this rarely shows; the PNG (z-buffer) is exact. Every triangle is
//! written, so files grow with the mesh (about 80 bytes a triangle).

use std::fmt::Write as _;
use std::io::{self, Write};

use super::{
    BACKGROUND, Camera, EDGE, EDGE_HALF_WIDTH, RenderOptions, Rgb, edge_strength, mix, to_u8,
};
use crate::mesh::NamedMesh;

/// One triangle to draw.
struct Face {
    depth: f64,
    corners: [[f64; 2]; 3],
    fill: Rgb,
    strength: f32,
}

/// Writes the meshes as an SVG drawing (see the module comment).
pub fn write_svg(
    out: &mut dyn Write,
    meshes: &[NamedMesh],
    options: &RenderOptions,
) -> io::Result<()> {
    let width = options.width.clamp(1, super::MAX_SIDE);
    let height = options.height.clamp(1, super::MAX_SIDE);
    let camera = Camera::fit(
        meshes,
        options.view,
        f64::from(width),
        f64::from(height),
        options.margin,
    );
    let mut faces = Vec::new();
    for (k, named) in meshes.iter().enumerate() {
        let mesh = named.mesh;
        for tri in &mesh.triangles {
            let Some(world) = tri
                .iter()
                .map(|&i| mesh.vertices.get(i as usize).copied())
                .collect::<Option<Vec<_>>>()
            else {
                continue;
            };
            let p = [0, 1, 2].map(|j| camera.project(world[j]));
            if !p.iter().all(|p| p.is_finite()) {
                continue;
            }
            let area2 =
                (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
            if area2 == 0.0 {
                continue;
            }
            let normal = (world[1] - world[0]).cross(world[2] - world[0]);
            faces.push(Face {
                depth: (p[0].z + p[1].z + p[2].z) / 3.0,
                corners: p.map(|p| [p.x, p.y]),
                fill: camera.shade(normal, k),
                strength: if options.edges {
                    edge_strength(area2)
                } else {
                    0.0
                },
            });
        }
    }
    // Farthest first; the stable sort keeps input order among equal depths.
    faces.sort_by(|a, b| a.depth.total_cmp(&b.depth));

    writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#)?;
    writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}">"#
    )?;
    writeln!(
        out,
        r#"<rect width="{width}" height="{height}" fill="{}"/>"#,
        hex(BACKGROUND)
    )?;
    // The stroke hides the hairline seams anti-aliasing leaves between adjacent polygons; a
    // faded edge is stroked in a mix of fill and edge colour.
    writeln!(
        out,
        r#"<g stroke="{}" stroke-width="{}" stroke-linejoin="round">"#,
        hex(EDGE),
        2.0 * EDGE_HALF_WIDTH
    )?;
    let mut line = String::with_capacity(128);
    for face in &faces {
        line.clear();
        let [a, b, c] = face.corners;
        let _ = write!(
            line,
            r#"<path d="M{:.2} {:.2}L{:.2} {:.2}L{:.2} {:.2}Z" fill="{}""#,
            a[0],
            a[1],
            b[0],
            b[1],
            c[0],
            c[1],
            hex(face.fill)
        );
        if face.strength < 1.0 {
            let _ = write!(
                line,
                r#" stroke="{}""#,
                hex(mix(face.fill, EDGE, face.strength))
            );
        }
        line.push_str("/>\n");
        out.write_all(line.as_bytes())?;
    }
    writeln!(out, "</g>")?;
    writeln!(out, "</svg>")?;
    Ok(())
}

fn hex(c: Rgb) -> String {
    let [r, g, b] = to_u8(c);
    format!("#{r:02x}{g:02x}{b:02x}")
}
