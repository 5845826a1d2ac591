//! Pictures of meshes: named meshes + view → a raster [`Picture`] (PNG) or an SVG drawing,
//! in the manner of the paper's figures: flat-shaded triangles with their edges drawn,
//! hidden surfaces removed, both sides of open surfaces shown.
//!
//! The model, shared by both outputs: an orthographic projection along the view direction
//! (azimuth and elevation in degrees, z up); the projected bounding box of all vertices fitted
//! into the picture with a margin; per triangle a flat colour, Lambert shading of the mesh's
//! base colour (front side) or back tint (back side) by a light fixed relative to the viewer;
//! edges as thin dark lines that fade out where triangles get too small on screen for lines
//! to mean anything. The raster uses a z-buffer with supersampling; the SVG sorts triangles
//! by depth (painter's algorithm). Everything is deterministic: no randomness, a fixed pixel
//! rule, output bytes a function of the input alone. Triangles with a non-finite corner are
//! left out.

mod png;
mod raster;
mod svg;

use std::fmt;
use std::num::ParseFloatError;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};

use super::NamedMesh;
use super::write::{WriteError, write_atomic};

pub use png::write_png;
pub use raster::render;
pub use svg::write_svg;

/// The largest width or height of a picture, in pixels.
pub const MAX_SIDE: u32 = 16384;

/// Where the viewer stands, seen from the scene's centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Angle about the z axis from +x towards +y, in degrees. Default 30.
    pub azimuth_deg: f64,
    /// Angle above the xy plane, in degrees, within −90..=90. Default 25.
    pub elevation_deg: f64,
}

impl Default for View {
    fn default() -> View {
        View {
            azimuth_deg: 30.0,
            elevation_deg: 25.0,
        }
    }
}

/// How to draw a picture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Width in pixels. Default 800.
    pub width: u32,
    /// Height in pixels. Default 600.
    pub height: u32,
    /// The view direction. Default azimuth 30°, elevation 25°.
    pub view: View,
    /// Empty border on every side, as a fraction of the smaller side. Default 0.05.
    pub margin: f64,
    /// Samples per pixel along each axis for the raster (1 = none; clamped to 1..=4).
    /// Default 2.
    pub supersampling: u32,
    /// Whether to draw triangle edges. Default true.
    pub edges: bool,
}

impl Default for RenderOptions {
    fn default() -> RenderOptions {
        RenderOptions {
            width: 800,
            height: 600,
            view: View::default(),
            margin: 0.05,
            supersampling: 2,
            edges: true,
        }
    }
}

/// An RGB picture, 8 bits per channel, rows top to bottom.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Picture {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Picture {
    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, row by row from the top, three bytes (R, G, B) each.
    pub fn rgb(&self) -> &[u8] {
        &self.rgb
    }

    /// The colour at column `x`, row `y` (from the top), or None outside the picture.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        Some([self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]])
    }
}

/// A picture file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PictureFormat {
    Png,
    Svg,
}

impl PictureFormat {
    /// The format of a path, by its extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<PictureFormat, PictureError> {
        let extension = path.extension().map(|e| e.to_string_lossy().into_owned());
        match extension.as_deref().map(str::to_ascii_lowercase).as_deref() {
            Some("png") => Ok(PictureFormat::Png),
            Some("svg") => Ok(PictureFormat::Svg),
            _ => Err(PictureError::UnknownExtension {
                path: path.to_path_buf(),
                extension,
            }),
        }
    }
}

/// A picture file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error(
        "cannot tell the picture format of `{}` from its extension{}; use .png or .svg",
        path.display(),
        extension.as_deref().map(|e| format!(" `.{e}`")).unwrap_or_default()
    )]
    UnknownExtension {
        path: PathBuf,
        extension: Option<String>,
    },
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Draws the meshes into `path` (PNG or SVG by its extension), atomically.
pub fn write_picture_file(
    path: &Path,
    meshes: &[NamedMesh],
    options: &RenderOptions,
) -> Result<(), PictureError> {
    match PictureFormat::from_path(path)? {
        PictureFormat::Png => {
            let picture = render(meshes, options);
            write_atomic(path, |out| write_png(out, &picture))?;
        }
        PictureFormat::Svg => write_atomic(path, |out| write_svg(out, meshes, options))?,
    }
    Ok(())
}

/// A `--size` that is not `WxH` with whole numbers in 1..=MAX_SIDE.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum SizeError {
    #[error("size `{0}` is not WIDTHxHEIGHT, e.g. 800x600")]
    NoSeparator(String),
    #[error("the {what} in size `{text}` is not a whole number of pixels")]
    NotANumber { text: String, what: &'static str },
    #[error("the {what} in size `{text}` must be within 1..={MAX_SIDE} pixels")]
    OutOfRange { text: String, what: &'static str },
}

/// Parses `WxH` (e.g. `800x600`; `X` and spaces around the numbers allowed).
pub fn parse_size(text: &str) -> Result<(u32, u32), SizeError> {
    let Some((w, h)) = text.split_once(['x', 'X']) else {
        return Err(SizeError::NoSeparator(text.to_owned()));
    };
    let side = |part: &str, what| {
        let n: u64 = part.trim().parse().map_err(|_| SizeError::NotANumber {
            text: text.to_owned(),
            what,
        })?;
        match u32::try_from(n) {
            Ok(n) if (1..=MAX_SIDE).contains(&n) => Ok(n),
            _ => Err(SizeError::OutOfRange {
                text: text.to_owned(),
                what,
            }),
        }
    };
    Ok((side(w, "width")?, side(h, "height")?))
}

/// A `--view` that is not `AZ,EL` with a finite azimuth and an elevation within ±90°.
#[derive(Debug, thiserror::Error, Clone, PartialEq, Eq)]
pub enum ViewError {
    #[error("view `{0}` is not AZIMUTH,ELEVATION in degrees, e.g. 30,25")]
    NoSeparator(String),
    #[error("the {what} in view `{text}` is not a number: {reason}")]
    NotANumber {
        text: String,
        what: &'static str,
        reason: String,
    },
    #[error("the {what} in view `{text}` must be finite")]
    NotFinite { text: String, what: &'static str },
    #[error("the elevation in view `{0}` must be within -90..=90 degrees")]
    Elevation(String),
}

/// Parses `AZ,EL` in degrees (e.g. `30,25` or `-45, 60`).
pub fn parse_view(text: &str) -> Result<View, ViewError> {
    let Some((az, el)) = text.split_once(',') else {
        return Err(ViewError::NoSeparator(text.to_owned()));
    };
    let angle = |part: &str, what| {
        let value: f64 =
            part.trim()
                .parse()
                .map_err(|e: ParseFloatError| ViewError::NotANumber {
                    text: text.to_owned(),
                    what,
                    reason: e.to_string(),
                })?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(ViewError::NotFinite {
                text: text.to_owned(),
                what,
            })
        }
    };
    let view = View {
        azimuth_deg: angle(az, "azimuth")?,
        elevation_deg: angle(el, "elevation")?,
    };
    if view.elevation_deg.abs() > 90.0 {
        return Err(ViewError::Elevation(text.to_owned()));
    }
    Ok(view)
}

impl fmt::Display for View {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{}", self.azimuth_deg, self.elevation_deg)
    }
}

// ---- the model shared by the raster and the SVG ----

/// Colours are linear mixes of sRGB values in 0..=1.
type Rgb = [f32; 3];

/// Base colours: (front side, back side) of mesh k is `PALETTE[k % len]`. Light, distinct
/// hues, each back tint far from its front.
const PALETTE: [(Rgb, Rgb); 6] = [
    ([0.78, 0.86, 0.97], [0.98, 0.84, 0.66]),
    ([0.97, 0.89, 0.74], [0.80, 0.74, 0.92]),
    ([0.78, 0.92, 0.79], [0.96, 0.78, 0.86]),
    ([0.97, 0.80, 0.82], [0.76, 0.91, 0.89]),
    ([0.86, 0.82, 0.98], [0.94, 0.92, 0.68]),
    ([0.74, 0.92, 0.93], [0.97, 0.82, 0.72]),
];
/// The background.
const BACKGROUND: Rgb = [1.0, 1.0, 1.0];
/// The colour of triangle edges.
const EDGE: Rgb = [0.16, 0.18, 0.23];
/// Shading = AMBIENT + DIFFUSE · max(0, n·light).
const AMBIENT: f32 = 0.5;
const DIFFUSE: f32 = 0.5;
/// The light, in the viewer's frame (right, up, towards the viewer): from the upper left,
/// in front.
const LIGHT: [f64; 3] = [-0.3, 0.45, 0.85];
/// Half the width of an edge line, in pixels of the final picture.
const EDGE_HALF_WIDTH: f64 = 0.55;
/// Edges fade out between these on-screen triangle sizes (√(2·area), in pixels): below the
/// first, lines would cover the triangle; above the second they are drawn fully.
const EDGE_FADE: (f64, f64) = (3.0, 10.0);

/// The orthographic camera fitted to the meshes: world → picture coordinates.
struct Camera {
    right: DVec3,
    up: DVec3,
    /// Unit vector from the scene towards the viewer: depth grows towards the viewer.
    toward: DVec3,
    /// The light direction in world coordinates.
    light: DVec3,
    /// Pixels per world unit.
    scale: f64,
    /// Projected centre of the bounding box, in (right, up) coordinates.
    centre: DVec2,
    /// The picture's centre, in pixels.
    middle: DVec2,
}

impl Camera {
    /// A camera looking from `view` with the projected bounding box of all finite vertices
    /// fitted into a `width`×`height` picture (pixels of size 1) with the given margin.
    fn fit(meshes: &[NamedMesh], view: View, width: f64, height: f64, margin: f64) -> Camera {
        let (az, el) = (
            view.azimuth_deg.to_radians(),
            view.elevation_deg.to_radians(),
        );
        let toward = DVec3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let right = DVec3::new(-az.sin(), az.cos(), 0.0);
        let up = toward.cross(right);
        let light = DVec3::from(LIGHT).normalize();
        let light = light.x * right + light.y * up + light.z * toward;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for v in meshes.iter().flat_map(|m| &m.mesh.vertices) {
            if v.is_finite() {
                let p = DVec2::new(v.dot(right), v.dot(up));
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (DVec2::ZERO, DVec2::ZERO);
        }
        let margin = margin.clamp(0.0, 0.45) * width.min(height);
        let room = DVec2::new(width, height) - 2.0 * margin;
        let extent = hi - lo;
        let fits = |room: f64, extent: f64| {
            if extent > 0.0 {
                room / extent
            } else {
                f64::INFINITY
            }
        };
        let scale = fits(room.x, extent.x).min(fits(room.y, extent.y));
        // A single point (or nothing) has no size: any scale will do.
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            1.0
        };
        Camera {
            right,
            up,
            toward,
            light,
            scale,
            centre: (lo + hi) / 2.0,
            middle: DVec2::new(width, height) / 2.0,
        }
    }

    /// Picture coordinates (x right, y down, in pixels) and depth (towards the viewer).
    fn project(&self, p: DVec3) -> DVec3 {
        let s = (DVec2::new(p.dot(self.right), p.dot(self.up)) - self.centre) * self.scale;
        DVec3::new(self.middle.x + s.x, self.middle.y - s.y, p.dot(self.toward))
    }

    /// The flat colour of a triangle with geometric normal `normal` (unnormalised; oriented
    /// by the winding) of mesh number `mesh`.
    fn shade(&self, normal: DVec3, mesh: usize) -> Rgb {
        let (front, back) = PALETTE[mesh % PALETTE.len()];
        let facing = normal.dot(self.toward);
        let (base, n) = if facing >= 0.0 {
            (front, normal)
        } else {
            (back, -normal)
        };
        let lambert = n.normalize_or_zero().dot(self.light).max(0.0) as f32;
        let intensity = AMBIENT + DIFFUSE * lambert;
        base.map(|c| (c * intensity).min(1.0))
    }
}

/// How strongly to draw the edges of a triangle with on-screen (final-pixel) doubled area
/// `area2`: 0 (none) to 1 (fully).
fn edge_strength(area2: f64) -> f32 {
    let size = area2.abs().sqrt();
    let (lo, hi) = EDGE_FADE;
    ((size - lo) / (hi - lo)).clamp(0.0, 1.0) as f32
}

fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [0, 1, 2].map(|i| a[i] + (b[i] - a[i]) * t)
}

fn to_u8(c: Rgb) -> [u8; 3] {
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_or_say_what_is_wrong() {
        assert_eq!(parse_size("800x600"), Ok((800, 600)));
        assert_eq!(parse_size(" 64 X 48 "), Ok((64, 48)));
        assert_eq!(parse_size("800"), Err(SizeError::NoSeparator("800".into())));
        assert_eq!(
            parse_size("axb"),
            Err(SizeError::NotANumber {
                text: "axb".into(),
                what: "width"
            })
        );
        assert_eq!(
            parse_size("10x-5"),
            Err(SizeError::NotANumber {
                text: "10x-5".into(),
                what: "height"
            })
        );
        assert_eq!(
            parse_size("0x10"),
            Err(SizeError::OutOfRange {
                text: "0x10".into(),
                what: "width"
            })
        );
        assert!(matches!(
            parse_size("10x99999999999"),
            Err(SizeError::OutOfRange { what: "height", .. })
        ));
    }

    #[test]
    fn views_parse_or_say_what_is_wrong() {
        assert_eq!(
            parse_view("-45, 60"),
            Ok(View {
                azimuth_deg: -45.0,
                elevation_deg: 60.0
            })
        );
        assert_eq!(parse_view("30,25"), Ok(View::default()));
        assert_eq!(parse_view("30"), Err(ViewError::NoSeparator("30".into())));
        assert!(matches!(
            parse_view("north,25"),
            Err(ViewError::NotANumber {
                what: "azimuth",
                ..
            })
        ));
        assert!(matches!(
            parse_view("0,inf"),
            Err(ViewError::NotFinite {
                what: "elevation",
                ..
            })
        ));
        assert_eq!(parse_view("0,91"), Err(ViewError::Elevation("0,91".into())));
    }

    #[test]
    fn the_camera_frame_is_right_handed_with_z_up() {
        let meshes: [NamedMesh; 0] = [];
        for (az, el) in [(0.0, 0.0), (30.0, 25.0), (-120.0, 90.0), (200.0, -90.0)] {
            let view = View {
                azimuth_deg: az,
                elevation_deg: el,
            };
            let c = Camera::fit(&meshes, view, 100.0, 100.0, 0.05);
            assert!((c.right.cross(c.up) - c.toward).length() < 1e-12);
            assert!(c.up.z >= -1e-12, "z points up on screen");
        }
    }

    #[test]
    fn picture_formats_follow_extensions() {
        assert_eq!(
            PictureFormat::from_path(Path::new("a.PNG")).ok(),
            Some(PictureFormat::Png)
        );
        assert_eq!(
            PictureFormat::from_path(Path::new("a.svg")).ok(),
            Some(PictureFormat::Svg)
        );
        assert!(PictureFormat::from_path(Path::new("a.jpg")).is_err());
    }
}
