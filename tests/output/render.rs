//! Pictures of meshes: deterministic bytes, a fitted sphere covering its disc, back faces
//! shown, hidden surfaces removed, edges drawn, PNG and SVG files that decode.
//!
//! Set SURFC_RENDER_DIR to a directory to keep the pictures the tests draw, to look at them.

use crate::output_fixtures;

use std::fs;
use std::path::Path;

use glam::DVec3;
use output_fixtures::{grid_patch, icosphere};
use surfc::mesh::render::{
    Picture, PictureError, RenderOptions, View, render, write_picture_file, write_png, write_svg,
};
use surfc::mesh::{Mesh, NamedMesh};

fn named<'a>(name: &'a str, mesh: &'a Mesh) -> NamedMesh<'a> {
    NamedMesh { name, mesh }
}

fn options(width: u32, height: u32, azimuth_deg: f64, elevation_deg: f64) -> RenderOptions {
    RenderOptions {
        width,
        height,
        view: View {
            azimuth_deg,
            elevation_deg,
        },
        ..RenderOptions::default()
    }
}

/// Saves a picture for a human to look at when SURFC_RENDER_DIR is set.
fn keep(name: &str, meshes: &[NamedMesh], options: &RenderOptions) {
    if let Some(dir) = std::env::var_os("SURFC_RENDER_DIR") {
        for ext in ["png", "svg"] {
            let path = Path::new(&dir).join(format!("{name}.{ext}"));
            write_picture_file(&path, meshes, options).expect("picture written");
        }
    }
}

fn png_bytes(picture: &Picture) -> Vec<u8> {
    let mut out = Vec::new();
    write_png(&mut out, picture).expect("PNG to memory");
    out
}

fn svg_text(meshes: &[NamedMesh], options: &RenderOptions) -> String {
    let mut out = Vec::new();
    write_svg(&mut out, meshes, options).expect("SVG to memory");
    String::from_utf8(out).expect("SVG is UTF-8")
}

fn is_background(c: [u8; 3]) -> bool {
    c == [255, 255, 255]
}

/// Pixels that are not background, and their centroid.
fn covered(picture: &Picture) -> (usize, [f64; 2]) {
    let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
    for y in 0..picture.height() {
        for x in 0..picture.width() {
            if picture.pixel(x, y).is_some_and(|c| !is_background(c)) {
                n += 1;
                sx += f64::from(x) + 0.5;
                sy += f64::from(y) + 0.5;
            }
        }
    }
    (n, [sx / n.max(1) as f64, sy / n.max(1) as f64])
}

#[test]
fn pictures_are_deterministic() {
    let sphere = icosphere(3, 2.0);
    let patch = grid_patch(8);
    let meshes = [named("sphere", &sphere), named("patch", &patch)];
    let o = options(320, 240, 30.0, 25.0);
    let first = render(&meshes, &o);
    let second = render(&meshes, &o);
    assert_eq!(first, second);
    assert_eq!(png_bytes(&first), png_bytes(&second));
    assert_eq!(svg_text(&meshes, &o), svg_text(&meshes, &o));
    keep("sphere_and_patch", &meshes, &o);
}

#[test]
fn a_sphere_covers_its_fitted_disc() {
    let sphere = icosphere(4, 2.0);
    let meshes = [named("sphere", &sphere)];
    for (az, el) in [(30.0, 25.0), (-100.0, 70.0), (0.0, -90.0)] {
        let o = options(400, 300, az, el);
        let picture = render(&meshes, &o);
        // The disc's diameter fills the height less the margins: 300 − 2·0.05·300 pixels.
        let radius = (300.0 - 2.0 * o.margin * 300.0) / 2.0;
        let disc = std::f64::consts::PI * radius * radius;
        let (n, [cx, cy]) = covered(&picture);
        let ratio = n as f64 / disc;
        assert!((0.97..1.02).contains(&ratio), "covered {n} of {disc:.0}");
        assert!(
            (cx - 200.0).abs() < 0.5 && (cy - 150.0).abs() < 0.5,
            "centre {cx} {cy}"
        );
        // Nothing outside the disc (a pixel's half diagonal of slack).
        for y in 0..300 {
            for x in 0..400 {
                let d = (f64::from(x) + 0.5 - 200.0).hypot(f64::from(y) + 0.5 - 150.0);
                if d > radius + 0.75 {
                    assert_eq!(picture.pixel(x, y), Some([255; 3]), "({x}, {y})");
                }
            }
        }
    }
    keep("sphere", &meshes, &options(400, 300, 30.0, 25.0));
}

/// Whether a colour leans warm (the back tint of the first mesh) rather than blue (its front).
fn warm(c: [u8; 3]) -> bool {
    c[0] > c[2]
}

#[test]
fn back_faces_are_drawn_in_their_own_tint() {
    let patch = grid_patch(6);
    let sphere = icosphere(3, 1.0);
    let meshes = [named("patch", &patch)];
    let above = render(&meshes, &options(200, 200, 20.0, 50.0));
    let below = render(&meshes, &options(200, 200, 20.0, -50.0));
    let (seen_above, _) = covered(&above);
    let (seen_below, _) = covered(&below);
    assert!(seen_above > 10_000);
    // The open patch is drawn from both sides, not culled from below.
    assert!(
        seen_below as f64 > 0.8 * seen_above as f64,
        "{seen_below} vs {seen_above}"
    );
    let warm_share = |p: &Picture| {
        let warm = p
            .rgb()
            .chunks(3)
            .filter(|c| warm([c[0], c[1], c[2]]))
            .count();
        warm as f64 / covered(p).0 as f64
    };
    assert!(warm_share(&above) < 0.01, "{}", warm_share(&above));
    assert!(warm_share(&below) > 0.8, "{}", warm_share(&below));
    // A closed surface shows only its outside.
    let ball = render(&[named("ball", &sphere)], &options(200, 200, 20.0, -50.0));
    assert_eq!(warm_share(&ball), 0.0);
    keep("patch_below", &meshes, &options(400, 300, 20.0, -50.0));
}

/// A square in the plane z = height, seen from above, with normals up.
fn square(height: f64, half: f64) -> Mesh {
    let corners = [(-half, -half), (half, -half), (half, half), (-half, half)];
    Mesh {
        vertices: corners
            .iter()
            .map(|&(x, y)| DVec3::new(x, y, height))
            .collect(),
        normals: vec![DVec3::Z; 4],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        sides: Vec::new(),
    }
}

#[test]
fn the_nearer_surface_hides_the_farther_in_any_drawing_order() {
    let near = square(1.0, 1.0);
    let far = square(0.0, 2.0);
    // From straight above, the far square's rim frames the near one.
    let o = RenderOptions {
        edges: false,
        ..options(200, 200, 0.0, 90.0)
    };
    let near_first = render(&[named("a", &near), named("b", &far)], &o);
    let far_first = render(&[named("b", &far), named("a", &near)], &o);
    // Colours follow the position in the list; flat squares facing the light evenly, so a
    // list entry has one colour wherever it shows.
    let centre = |p: &Picture| p.pixel(100, 100).expect("inside");
    let rim = |p: &Picture| p.pixel(100, 12).expect("inside");
    assert_ne!(centre(&near_first), rim(&near_first));
    assert_eq!(
        centre(&near_first),
        rim(&far_first),
        "the near square shows in the middle"
    );
    assert_eq!(
        centre(&far_first),
        rim(&near_first),
        "the near square shows in the middle"
    );

    // The SVG draws the near square last, whatever the input order.
    let svg = svg_text(&[named("a", &near), named("b", &far)], &o);
    let fills: Vec<&str> = svg
        .lines()
        .filter(|l| l.starts_with("<path"))
        .filter_map(|l| l.split("fill=\"").nth(1))
        .filter_map(|f| f.split('"').next())
        .collect();
    assert_eq!(fills.len(), 4);
    let hex = |c: [u8; 3]| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
    assert_eq!(
        fills[2..],
        [hex(centre(&near_first)), hex(centre(&near_first))]
    );
    assert_eq!(fills[..2], [hex(rim(&near_first)), hex(rim(&near_first))]);
}

#[test]
fn edges_are_drawn_as_dark_lines() {
    // From straight above with azimuth −90°, x runs right and y up: the 2×2 grid's middle
    // lines cross the picture's centre.
    let patch = grid_patch(2);
    let meshes = [named("patch", &patch)];
    let o = options(200, 200, -90.0, 90.0);
    let picture = render(&meshes, &o);
    let luminance = |x, y| {
        let c = picture.pixel(x, y).expect("inside");
        c.iter().map(|&v| u32::from(v)).sum::<u32>() / 3
    };
    // The vertical middle line x = 0.5 at a quarter height runs between pixel columns 99 and
    // 100 and darkens both; a cell's inside beside it stays light.
    let line = (luminance(99, 55) + luminance(100, 55)) / 2;
    assert!(line < 140, "line: {line}");
    assert!(luminance(70, 55) > 180, "inside: {}", luminance(70, 55));
    let plain = render(&meshes, &RenderOptions { edges: false, ..o });
    let c = plain.pixel(100, 55).expect("inside");
    assert!(c.iter().map(|&v| u32::from(v)).sum::<u32>() / 3 > 180);
    keep("grid_from_above", &meshes, &options(400, 300, -90.0, 90.0));
}

#[test]
fn png_and_svg_files_decode() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let sphere = icosphere(2, 1.5);
    let patch = grid_patch(4);
    let meshes = [named("sphere", &sphere), named("patch", &patch)];
    let o = options(160, 120, 30.0, 25.0);

    let png_path = dir.path().join("picture.png");
    write_picture_file(&png_path, &meshes, &o).expect("PNG written");
    let decoder = png::Decoder::new(std::io::BufReader::new(
        fs::File::open(&png_path).expect("opened"),
    ));
    let mut reader = decoder.read_info().expect("a PNG header");
    let mut pixels = vec![0; reader.output_buffer_size().expect("a size")];
    let frame = reader.next_frame(&mut pixels).expect("a PNG frame");
    assert_eq!((frame.width, frame.height), (160, 120));
    assert_eq!(frame.color_type, png::ColorType::Rgb);
    assert_eq!(&pixels[..frame.buffer_size()], render(&meshes, &o).rgb());

    let svg_path = dir.path().join("picture.svg");
    write_picture_file(&svg_path, &meshes, &o).expect("SVG written");
    let svg = fs::read_to_string(&svg_path).expect("read");
    let paths = check_svg(&svg, 160.0, 120.0);
    let triangles = sphere.triangles.len() + patch.triangles.len();
    // Triangles seen exactly edge-on are left out; from this view there are none.
    assert_eq!(paths, triangles);

    let error = write_picture_file(&dir.path().join("picture.jpg"), &meshes, &o)
        .expect_err("JPEG is not offered");
    assert!(matches!(error, PictureError::UnknownExtension { .. }));
    assert!(error.to_string().contains("picture.jpg"));
    let error = write_picture_file(&dir.path().join("missing/picture.png"), &meshes, &o)
        .expect_err("no such directory");
    assert!(error.to_string().contains("missing"), "{error}");
}

/// Checks an SVG's structure without the writer's code: an XML declaration, one `svg` root
/// whose tags nest properly, path coordinates inside the picture. Returns the number of paths.
fn check_svg(svg: &str, width: f64, height: f64) -> usize {
    let body = svg
        .strip_prefix(r#"<?xml version="1.0" encoding="UTF-8"?>"#)
        .expect("an XML declaration");
    let mut open: Vec<&str> = Vec::new();
    let mut paths = 0;
    let mut rest = body;
    while let Some(start) = rest.find('<') {
        assert!(rest[..start].trim().is_empty(), "text between tags");
        let end = rest[start..].find('>').expect("a closed tag") + start;
        let tag = &rest[start + 1..end];
        rest = &rest[end + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(open.pop(), Some(name), "tags nest");
            continue;
        }
        let name = tag.split_whitespace().next().expect("a tag name");
        let quotes = tag.matches('"').count();
        assert_eq!(quotes % 2, 0, "attribute quotes pair up: {tag}");
        if name == "path" {
            paths += 1;
            let d = tag
                .split("d=\"")
                .nth(1)
                .and_then(|d| d.split('"').next())
                .expect("a path");
            let numbers: Vec<f64> = d
                .split(['M', 'L', 'Z', ' '])
                .filter(|t| !t.is_empty())
                .map(|t| t.parse().expect("a coordinate"))
                .collect();
            assert_eq!(numbers.len(), 6);
            for xy in numbers.chunks(2) {
                assert!((0.0..=width).contains(&xy[0]) && (0.0..=height).contains(&xy[1]));
            }
        }
        if !tag.ends_with('/') {
            if open.is_empty() {
                assert_eq!(name, "svg", "the root is svg");
            }
            open.push(name);
        }
    }
    assert!(
        rest.trim().is_empty() && open.is_empty(),
        "the root is closed"
    );
    paths
}

#[test]
fn nothing_to_draw_gives_a_blank_picture_and_bad_vertices_are_skipped() {
    let o = options(64, 48, 30.0, 25.0);
    let blank = render(&[], &o);
    assert!(blank.rgb().iter().all(|&b| b == 255));
    assert_eq!((blank.width(), blank.height()), (64, 48));
    let mut bad = grid_patch(3);
    bad.vertices[5] = DVec3::new(f64::NAN, 0.0, f64::INFINITY);
    bad.triangles.push([0, 1, 99]);
    let picture = render(&[named("bad", &bad)], &o);
    let (n, _) = covered(&picture);
    assert!(n > 500, "the good triangles are drawn: {n}");
    let svg = svg_text(&[named("bad", &bad)], &o);
    let skipped = bad
        .triangles
        .iter()
        .filter(|t| t.iter().any(|&i| i == 5 || i == 99))
        .count();
    assert_eq!(check_svg(&svg, 64.0, 48.0), bad.triangles.len() - skipped);
}

#[test]
fn the_fit_ignores_where_the_meshes_are_and_how_big() {
    let sphere = icosphere(3, 1.0);
    let mut moved = sphere.clone();
    for v in &mut moved.vertices {
        *v = *v * 8.0 + DVec3::new(5.0, -3.0, 2.0);
    }
    let o = options(200, 150, 40.0, 20.0);
    let (n, [cx, cy]) = covered(&render(&[named("s", &sphere)], &o));
    let (m, [mx, my]) = covered(&render(&[named("s", &moved)], &o));
    assert!(n.abs_diff(m) <= n / 500, "{n} vs {m} pixels");
    assert!((cx - mx).abs() < 0.05 && (cy - my).abs() < 0.05);
}
