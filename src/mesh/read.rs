//! Mesh files → meshes: the readers behind `surfc render MESHFILE`, for the formats surfc
//! writes that a picture is wanted of — OBJ (tobj), binary or ASCII STL (stl_io), PLY
//! (ply-rs-bw), OFF (here), GLB (gltf) and 3MF (the zip crate and a small scanner of the
//! model part's tags). Each object, group, node or 3MF object becomes one named mesh; where
//! the file has no names the meshes are named after the format. Normals are not read (the
//! renderer shades by facets). GLB scenes are placed by their node transforms and turned
//! back from glTF's +Y up to surfc's +Z up. Lengths come back in millimetres, the default
//! unit of `.surf` lengths (`write::Unit`): GLB's metres and a 3MF model's `unit` are
//! converted, the formats without a unit are read as they are. Never panics: a file that
//! does not parse is a [`ReadError`] naming it.

use std::io::{BufReader, Cursor, Read};
use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3};

use super::Mesh;
use super::write::{Format, Unit};

/// A mesh file that could not be read: the file or the command line is at fault.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot read `{}`: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot read `{}` as {format}: {message}", path.display())]
    Parse {
        path: PathBuf,
        format: Format,
        message: String,
    },
    #[error("`{}`: surfc cannot read {format} files; it reads obj, stl, ply, off, glb and 3mf", path.display())]
    Unsupported { path: PathBuf, format: Format },
}

/// Reads the meshes of a mesh file whose format its extension names.
pub fn read_mesh_file(path: &Path, format: Format) -> Result<Vec<(String, Mesh)>, ReadError> {
    if matches!(format, Format::Msh | Format::Vtu) {
        return Err(ReadError::Unsupported {
            path: path.to_path_buf(),
            format,
        });
    }
    let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_mesh(&bytes, format).map_err(|message| ReadError::Parse {
        path: path.to_path_buf(),
        format,
        message,
    })
}

/// Reads the meshes of a mesh file's bytes; Err says why they are not a file of `format`.
pub fn read_mesh(bytes: &[u8], format: Format) -> Result<Vec<(String, Mesh)>, String> {
    let meshes = match format {
        Format::Obj => read_obj(bytes)?,
        Format::Stl => read_stl(bytes)?,
        Format::Ply => read_ply(bytes)?,
        Format::Off => read_off(bytes)?,
        Format::Glb => read_glb(bytes)?,
        Format::ThreeMf => read_3mf(bytes)?,
        Format::Msh | Format::Vtu => return Err(format!("{format} files are not read")),
    };
    for (name, mesh) in &meshes {
        let count = mesh.vertices.len();
        if let Some(t) = mesh
            .triangles
            .iter()
            .position(|t| t.iter().any(|&i| i as usize >= count))
        {
            return Err(format!(
                "`{name}`: triangle {t} uses a vertex past the {count} vertices"
            ));
        }
        if let Some(v) = mesh.vertices.iter().position(|v| !v.is_finite()) {
            return Err(format!("`{name}`: vertex {v} is not finite"));
        }
    }
    Ok(meshes)
}

/// A mesh from positions and triangles, without normals.
fn mesh(vertices: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        vertices,
        normals: Vec::new(),
        triangles,
        sides: Vec::new(),
    }
}

/// A vertex index that fits the mesh's u32 indices.
fn index(i: impl TryInto<u32>) -> Result<u32, String> {
    i.try_into()
        .map_err(|_| "a vertex index does not fit 32 bits".to_owned())
}

/// A polygon's vertices as a fan of triangles (no triangle for fewer than three).
fn fan(polygon: &[u32], triangles: &mut Vec<[u32; 3]>) {
    for k in 2..polygon.len() {
        triangles.push([polygon[0], polygon[k - 1], polygon[k]]);
    }
}

fn read_obj(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut BufReader::new(bytes), &options, |_| {
        // Materials do not change a picture's shading: read none.
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| e.to_string())?;
    models
        .into_iter()
        .map(|model| {
            let m = model.mesh;
            let vertices = m
                .positions
                .chunks_exact(3)
                .map(|p| DVec3::new(p[0], p[1], p[2]))
                .collect();
            let triangles = m
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect();
            Ok((model.name, mesh(vertices, triangles)))
        })
        .collect()
}

fn read_stl(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    let read = stl_io::read_stl(&mut Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let vertices = read
        .vertices
        .iter()
        .map(|v| DVec3::new(v[0].into(), v[1].into(), v[2].into()))
        .collect();
    let triangles = read
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.vertices;
            Ok([index(a)?, index(b)?, index(c)?])
        })
        .collect::<Result<_, String>>()?;
    Ok(vec![("stl".to_owned(), mesh(vertices, triangles))])
}

fn read_ply(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::{DefaultElement, Property};

    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let scalar = |e: &DefaultElement, key: &str| -> Result<f64, String> {
        Ok(match e.get(key) {
            Some(Property::Double(x)) => *x,
            Some(Property::Float(x)) => f64::from(*x),
            Some(Property::Int(x)) => f64::from(*x),
            Some(Property::UInt(x)) => f64::from(*x),
            Some(Property::Short(x)) => f64::from(*x),
            Some(Property::UShort(x)) => f64::from(*x),
            Some(Property::Char(x)) => f64::from(*x),
            Some(Property::UChar(x)) => f64::from(*x),
            _ => return Err(format!("a vertex has no number `{key}`")),
        })
    };
    let empty = Vec::new();
    let vertices = ply
        .payload
        .get("vertex")
        .unwrap_or(&empty)
        .iter()
        .map(|e| {
            Ok(DVec3::new(
                scalar(e, "x")?,
                scalar(e, "y")?,
                scalar(e, "z")?,
            ))
        })
        .collect::<Result<Vec<_>, String>>()?;
    let mut triangles = Vec::new();
    for face in ply.payload.get("face").unwrap_or(&empty) {
        let list = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"));
        let polygon: Vec<u32> = match list {
            Some(Property::ListInt(l)) => l.iter().map(|&i| index(i)).collect::<Result<_, _>>()?,
            Some(Property::ListUInt(l)) => l.clone(),
            Some(Property::ListShort(l)) => {
                l.iter().map(|&i| index(i)).collect::<Result<_, _>>()?
            }
            Some(Property::ListUShort(l)) => l.iter().map(|&i| u32::from(i)).collect(),
            Some(Property::ListChar(l)) => l.iter().map(|&i| index(i)).collect::<Result<_, _>>()?,
            Some(Property::ListUChar(l)) => l.iter().map(|&i| u32::from(i)).collect(),
            _ => return Err("a face has no list `vertex_indices`".to_owned()),
        };
        fan(&polygon, &mut triangles);
    }
    Ok(vec![("ply".to_owned(), mesh(vertices, triangles))])
}

fn read_off(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    let text = std::str::from_utf8(bytes).map_err(|e| e.to_string())?;
    // Words, with `#` comments left out.
    let mut words = text
        .lines()
        .flat_map(|l| l.split('#').next().unwrap_or("").split_whitespace());
    if words.next() != Some("OFF") {
        return Err("the file does not start with `OFF`".to_owned());
    }
    let mut number = |what: &str| -> Result<&str, String> {
        words
            .next()
            .ok_or_else(|| format!("the file ends before {what}"))
    };
    let count = |w: &str| w.parse::<usize>().map_err(|e| format!("`{w}`: {e}"));
    let vertex_count = count(number("the vertex count")?)?;
    let face_count = count(number("the face count")?)?;
    number("the edge count")?;
    let mut vertices = Vec::with_capacity(vertex_count.min(1 << 20));
    for _ in 0..vertex_count {
        let mut xyz = [0.0; 3];
        for x in &mut xyz {
            let w = number("a vertex")?;
            *x = w.parse().map_err(|e| format!("`{w}`: {e}"))?;
        }
        vertices.push(DVec3::from_array(xyz));
    }
    let mut triangles = Vec::with_capacity(face_count.min(1 << 20));
    for _ in 0..face_count {
        let n = count(number("a face")?)?;
        let polygon = (0..n)
            .map(|_| index(count(number("a face")?)?))
            .collect::<Result<Vec<u32>, String>>()?;
        fan(&polygon, &mut triangles);
    }
    Ok(vec![("off".to_owned(), mesh(vertices, triangles))])
}

fn read_glb(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| e.to_string())?;
    let blob = gltf.blob.as_deref();
    let document = &gltf.document;
    // glTF's +Y up back to +Z up (the inverse of surfc's root rotation), and its metres to
    // millimetres.
    let to_mm = 1.0 / Unit::Millimetre.metres();
    let y_up_to_z_up = DMat4::from_cols_array(&[
        1.0, 0.0, 0.0, 0.0, //
        0.0, 0.0, 1.0, 0.0, //
        0.0, -1.0, 0.0, 0.0, //
        0.0, 0.0, 0.0, 1.0,
    ]) * DMat4::from_scale(DVec3::splat(to_mm));
    let mut meshes = Vec::new();
    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => Vec::new(),
    };
    // Depth-first over the node tree; a node graph is a forest (gltf validates it), but a
    // bound on the work keeps a malformed file from running away.
    let mut stack: Vec<(gltf::Node, DMat4)> =
        roots.into_iter().map(|n| (n, y_up_to_z_up)).collect();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1 + 4 * document.nodes().len() {
            return Err("the node graph has a cycle".to_owned());
        }
        let local = node.transform().matrix().map(|c| c.map(f64::from));
        let transform = parent * DMat4::from_cols_array_2d(&local);
        if let Some(gltf_mesh) = node.mesh() {
            let name = node.name().or(gltf_mesh.name()).unwrap_or("glb").to_owned();
            let mut vertices = Vec::new();
            let mut triangles = Vec::new();
            for primitive in gltf_mesh.primitives() {
                if primitive.mode() != gltf::mesh::Mode::Triangles {
                    continue;
                }
                let reader = primitive.reader(|b| match b.source() {
                    gltf::buffer::Source::Bin => blob,
                    gltf::buffer::Source::Uri(_) => None,
                });
                let base = index(vertices.len())?;
                let Some(positions) = reader.read_positions() else {
                    continue;
                };
                let before = vertices.len();
                vertices.extend(
                    positions
                        .map(|p| transform.transform_point3(DVec3::from_array(p.map(f64::from)))),
                );
                let count = index(vertices.len() - before)?;
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(indices) => indices.into_u32().collect(),
                    None => (0..count).collect(),
                };
                for t in indices.chunks_exact(3) {
                    if t.iter().any(|&i| i >= count) {
                        return Err(format!("mesh `{name}`: an index past its vertices"));
                    }
                    triangles.push([base + t[0], base + t[1], base + t[2]]);
                }
            }
            meshes.push((name, mesh(vertices, triangles)));
        }
        // Children pushed in reverse come off the stack in file order.
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, transform)));
    }
    Ok(meshes)
}

fn read_3mf(bytes: &[u8]) -> Result<Vec<(String, Mesh)>, String> {
    let mut archive = zip::ZipArchive::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let model_name = (0..archive.len())
        .filter_map(|i| archive.name_for_index(i).map(str::to_owned))
        .find(|n| n.eq_ignore_ascii_case(super::write::THREEMF_MODEL_PATH))
        .or_else(|| {
            archive
                .file_names()
                .find(|n| n.to_ascii_lowercase().ends_with(".model"))
                .map(str::to_owned)
        })
        .ok_or("the package has no 3D model part")?;
    let mut text = String::new();
    archive
        .by_name(&model_name)
        .map_err(|e| e.to_string())?
        .read_to_string(&mut text)
        .map_err(|e| format!("{model_name}: {e}"))?;
    let mut meshes = Vec::new();
    let mut current: Option<(String, Mesh)> = None;
    // Millimetres per unit of the model (3MF's default unit is the millimetre).
    let mut scale = 1.0;
    for tag in Tags(&text) {
        match tag.name {
            "model" if !tag.end => {
                if let Some(name) = tag.attribute("unit") {
                    let unit = Unit::from_threemf_name(name.trim())
                        .ok_or_else(|| format!("unknown unit `{name}`"))?;
                    scale = unit.metres() / Unit::Millimetre.metres();
                }
            }
            "object" => {
                if !tag.end {
                    let name = tag
                        .attribute("name")
                        .or_else(|| tag.attribute("id").map(|id| format!("object {id}")))
                        .unwrap_or_else(|| "3mf".to_owned());
                    meshes.extend(current.replace((name, Mesh::default())));
                }
                if tag.end || tag.empty {
                    meshes.extend(current.take());
                }
            }
            "vertex" => {
                let (name, mesh) = current.as_mut().ok_or("a vertex outside an object")?;
                let xyz: [f64; 3] = numbers(&tag, ["x", "y", "z"], name, "vertex")?;
                mesh.vertices.push(DVec3::from_array(xyz));
            }
            "triangle" => {
                let (name, mesh) = current.as_mut().ok_or("a triangle outside an object")?;
                let corners: [u32; 3] = numbers(&tag, ["v1", "v2", "v3"], name, "triangle")?;
                mesh.triangles.push(corners);
            }
            _ => {}
        }
    }
    // Objects without a mesh (components only) draw nothing.
    meshes.retain(|(_, m)| !m.triangles.is_empty());
    if scale != 1.0 {
        for (_, mesh) in &mut meshes {
            for v in &mut mesh.vertices {
                *v *= scale;
            }
        }
    }
    Ok(meshes)
}

/// The three numbers a tag holds in the attributes `keys`; Err names the object and what is
/// wrong.
fn numbers<T: std::str::FromStr>(
    tag: &Tag,
    keys: [&str; 3],
    object: &str,
    what: &str,
) -> Result<[T; 3], String>
where
    T::Err: std::fmt::Display,
{
    let mut values = Vec::with_capacity(3);
    for key in keys {
        let value = tag
            .attribute(key)
            .ok_or_else(|| format!("`{object}`: a {what} without `{key}`"))?;
        let number = value
            .trim()
            .parse()
            .map_err(|e| format!("`{object}`: `{value}`: {e}"))?;
        values.push(number);
    }
    values
        .try_into()
        .map_err(|_| format!("`{object}`: a {what} without three numbers"))
}

/// One XML tag: its name (without namespace prefix), whether it ends an element (`</a>`) or
/// is an empty element (`<a/>`), and its attribute text.
struct Tag<'a> {
    name: &'a str,
    end: bool,
    empty: bool,
    attributes: &'a str,
}

impl Tag<'_> {
    /// The unescaped value of an attribute (`key="…"` or `key='…'`).
    fn attribute(&self, key: &str) -> Option<String> {
        let mut rest = self.attributes;
        loop {
            let eq = rest.find('=')?;
            let name = rest[..eq].trim();
            let after = rest[eq + 1..].trim_start();
            let quote = after.chars().next()?;
            if quote != '"' && quote != '\'' {
                return None;
            }
            let end = after[1..].find(quote)? + 1;
            if name == key {
                return Some(unescape(&after[1..end]));
            }
            rest = &after[end + 1..];
        }
    }
}

/// The tags of an XML text in order, without comments, processing instructions and
/// declarations. Text between tags is skipped: 3MF meshes keep everything in attributes.
struct Tags<'a>(&'a str);

impl<'a> Iterator for Tags<'a> {
    type Item = Tag<'a>;
    fn next(&mut self) -> Option<Tag<'a>> {
        loop {
            let open = self.0.find('<')?;
            let rest = &self.0[open + 1..];
            if let Some(comment) = rest.strip_prefix("!--") {
                let end = comment.find("-->").map_or(comment.len(), |e| e + 3);
                self.0 = &comment[end..];
                continue;
            }
            let close = rest.find('>').unwrap_or(rest.len());
            let inner = &rest[..close];
            self.0 = rest.get(close + 1..).unwrap_or("");
            if inner.starts_with('?') || inner.starts_with('!') {
                continue;
            }
            let end = inner.starts_with('/');
            let empty = inner.ends_with('/');
            let inner = inner.trim_start_matches('/').trim_end_matches('/');
            let split = inner.find(char::is_whitespace).unwrap_or(inner.len());
            let qualified = &inner[..split];
            let name = qualified.rsplit(':').next().unwrap_or(qualified);
            return Some(Tag {
                name,
                end,
                empty,
                attributes: &inner[split..],
            });
        }
    }
}

/// XML attribute text with the predefined and numeric character references resolved (an
/// unknown reference is kept as written).
fn unescape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(amp) = rest.find('&') {
        out.push_str(&rest[..amp]);
        let after = &rest[amp + 1..];
        let Some(semi) = after.find(';') else {
            out.push_str(&rest[amp..]);
            return out;
        };
        let entity = &after[..semi];
        let c = match entity {
            "amp" => Some('&'),
            "lt" => Some('<'),
            "gt" => Some('>'),
            "quot" => Some('"'),
            "apos" => Some('\''),
            _ => entity
                .strip_prefix("#x")
                .and_then(|h| u32::from_str_radix(h, 16).ok())
                .or_else(|| entity.strip_prefix('#').and_then(|d| d.parse().ok()))
                .and_then(char::from_u32),
        };
        match c {
            Some(c) => out.push(c),
            None => {
                out.push('&');
                out.push_str(entity);
                out.push(';');
            }
        }
        rest = &after[semi + 1..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_and_attributes_of_a_model_part() {
        let text = r#"<?xml version="1.0"?><!-- <vertex x="9"/> --><m:object id="3" name="a &amp; b"><vertex x="1" y='2.5' z="-0.0"/></m:object>"#;
        let tags: Vec<Tag> = Tags(text).collect();
        let names: Vec<(&str, bool, bool)> =
            tags.iter().map(|t| (t.name, t.end, t.empty)).collect();
        assert_eq!(
            names,
            [
                ("object", false, false),
                ("vertex", false, true),
                ("object", true, false)
            ]
        );
        assert_eq!(tags[0].attribute("name").as_deref(), Some("a & b"));
        assert_eq!(tags[0].attribute("id").as_deref(), Some("3"));
        assert_eq!(tags[1].attribute("y").as_deref(), Some("2.5"));
        assert_eq!(tags[1].attribute("w"), None);
        assert_eq!(unescape("&#x41;&#66;&unknown;&"), "AB&unknown;&");
    }

    #[test]
    fn off_polygons_become_fans_and_bad_files_are_errors() {
        let (name, m) = read_off(b"OFF\n# square\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n")
            .expect("an OFF")
            .remove(0);
        assert_eq!(name, "off");
        assert_eq!(m.triangles, [[0, 1, 2], [0, 2, 3]]);
        assert!(read_off(b"OFF\n4 1 0\n0 0").is_err());
        assert!(read_off(b"PLY").is_err());
        assert!(read_mesh(b"OFF\n1 1 0\n0 0 0\n3 0 1 2\n", Format::Off).is_err());
    }
}
