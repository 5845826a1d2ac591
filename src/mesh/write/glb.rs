//! GLB: named meshes → one glTF 2.0 binary file. Each mesh is a node and a mesh of its name
//! with one triangle primitive: POSITION and NORMAL (f32 vec3; POSITION with the min/max the
//! specification requires) and u32 indices, drawn with one default material (light grey,
//! double-sided: an open surface is seen from both sides). A mesh without triangles is a node
//! without a mesh (glTF allows no empty accessors). Vertices are not shared between meshes:
//! each primitive owns its attribute arrays, and a vertex on a sharp edge is one vertex per
//! side (`split`), so that each face is shaded by its own normal.
//!
//! glTF is +Y up, surfc's models are +Z up: the mesh nodes are children of one root node
//! whose rotation (−90° about x) turns the model's z into glTF's y, and whose scale turns
//! the model's unit into glTF's metres (none for metres). The vertex data stay the model's
//! own coordinates.

use std::io::{self, Write};

use serde_json::{Value, json};

use super::split::{Split, split};
use super::{Format, InvalidMesh, NamedMesh, Unit, WriteOptions};

/// glTF bufferView targets.
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
/// glTF accessor component types.
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
/// glTF primitive mode: triangles.
const TRIANGLES: u32 = 4;
/// The root node's rotation, a unit quaternion (x, y, z, w): −90° about the x axis, which
/// takes the model's +z to glTF's +y (and +y to −z), right-handed as both are.
const Z_UP_TO_Y_UP: [f64; 4] = [
    -std::f64::consts::FRAC_1_SQRT_2,
    0.0,
    0.0,
    std::f64::consts::FRAC_1_SQRT_2,
];
/// The name of the root node that holds the meshes' nodes.
pub const ROOT_NODE: &str = "surfc (z up)";
/// GLB header and chunk type codes.
const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: &[u8; 4] = b"JSON";
const CHUNK_BIN: &[u8; 4] = b"BIN\0";

/// Writes the meshes as one GLB file (see the module comment), in millimetres (the default
/// [`Unit`]).
pub fn write_glb(out: &mut dyn Write, meshes: &[NamedMesh]) -> io::Result<()> {
    Format::Glb.write_with(out, meshes, &WriteOptions::default())
}

/// The bytes a mesh contributes to the binary chunk: positions, normals, indices.
fn sizes(mesh: &Split) -> [u64; 3] {
    let vertices = mesh.vertices.len() as u64;
    let triangles = mesh.triangles.len() as u64;
    [12 * vertices, 12 * vertices, 12 * triangles]
}

pub(super) fn write(out: &mut dyn Write, meshes: &[NamedMesh], unit: Unit) -> io::Result<()> {
    let splits: Vec<Split> = meshes.iter().map(|m| split(m.mesh)).collect();
    let drawn = |m: &Split| !m.triangles.is_empty();
    let mut nodes = Vec::new();
    let mut gltf_meshes = Vec::new();
    let mut accessors = Vec::new();
    let mut views = Vec::new();
    let mut offset = 0u64;
    for (named, mesh) in meshes.iter().zip(&splits) {
        if !drawn(mesh) {
            nodes.push(json!({ "name": named.name }));
            continue;
        }
        let (lo, hi) = mesh.vertices.iter().fold(
            ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]),
            |(lo, hi), v| {
                let v = v.to_array().map(|x| x as f32);
                (
                    [0, 1, 2].map(|i| lo[i].min(v[i])),
                    [0, 1, 2].map(|i| hi[i].max(v[i])),
                )
            },
        );
        let first = accessors.len();
        let targets = [ARRAY_BUFFER, ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER];
        for (k, (size, target)) in sizes(mesh).into_iter().zip(targets).enumerate() {
            views.push(json!({
                "buffer": 0, "byteOffset": offset, "byteLength": size, "target": target
            }));
            offset += size;
            let view = first + k;
            accessors.push(match k {
                0 => json!({
                    "bufferView": view, "componentType": FLOAT, "count": mesh.vertices.len(),
                    "type": "VEC3", "min": lo, "max": hi
                }),
                1 => json!({
                    "bufferView": view, "componentType": FLOAT, "count": mesh.vertices.len(),
                    "type": "VEC3"
                }),
                _ => json!({
                    "bufferView": view, "componentType": UNSIGNED_INT,
                    "count": 3 * mesh.triangles.len(), "type": "SCALAR"
                }),
            });
        }
        nodes.push(json!({ "name": named.name, "mesh": gltf_meshes.len() }));
        gltf_meshes.push(json!({
            "name": named.name,
            "primitives": [{
                "attributes": { "POSITION": first, "NORMAL": first + 1 },
                "indices": first + 2,
                "material": 0,
                "mode": TRIANGLES
            }]
        }));
    }

    // glTF forbids empty arrays: leave out what is empty.
    let mut document = serde_json::Map::new();
    document.insert(
        "asset".into(),
        json!({ "version": "2.0", "generator": "surfc" }),
    );
    if !nodes.is_empty() {
        let root = nodes.len();
        let mut node = json!({
            "name": ROOT_NODE,
            "rotation": Z_UP_TO_Y_UP,
            "children": (0..root).collect::<Vec<_>>()
        });
        if unit != Unit::Metre {
            node["scale"] = json!([unit.metres(), unit.metres(), unit.metres()]);
        }
        nodes.push(node);
        document.insert("scene".into(), json!(0));
        document.insert("scenes".into(), json!([{ "nodes": [root] }]));
    }
    let materials = if gltf_meshes.is_empty() {
        Vec::new()
    } else {
        vec![json!({
            "name": "surfc default",
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                "metallicFactor": 0.0,
                "roughnessFactor": 0.6
            },
            "doubleSided": true
        })]
    };
    for (key, list) in [
        ("materials", materials),
        ("nodes", nodes),
        ("meshes", gltf_meshes),
        ("accessors", accessors),
        ("bufferViews", views),
    ] {
        if !list.is_empty() {
            document.insert(key.into(), Value::Array(list));
        }
    }
    if offset > 0 {
        document.insert("buffers".into(), json!([{ "byteLength": offset }]));
    }
    let mut text = serde_json::to_vec(&Value::Object(document)).map_err(io::Error::other)?;
    // Chunks are 4-byte aligned: JSON padded with spaces, BIN with zeros (ours is aligned).
    while text.len() % 4 != 0 {
        text.push(b' ');
    }
    let bin_chunk = if offset > 0 { 8 + offset } else { 0 };
    let total = 12 + 8 + text.len() as u64 + bin_chunk;
    let too_large = |count| InvalidMesh::TooLarge {
        format: Format::Glb,
        what: "bytes",
        count,
        limit: u64::from(u32::MAX),
    };
    let total = u32::try_from(total).map_err(|_| too_large(total))?;
    let json_len = u32::try_from(text.len()).map_err(|_| too_large(text.len() as u64))?;

    out.write_all(MAGIC)?;
    out.write_all(&2u32.to_le_bytes())?;
    out.write_all(&total.to_le_bytes())?;
    out.write_all(&json_len.to_le_bytes())?;
    out.write_all(CHUNK_JSON)?;
    out.write_all(&text)?;
    if offset == 0 {
        return Ok(());
    }
    // `total` fits in u32, so the binary chunk does too.
    out.write_all(&u32::try_from(offset).unwrap_or(u32::MAX).to_le_bytes())?;
    out.write_all(CHUNK_BIN)?;
    let mut bytes = Vec::with_capacity(1 << 16);
    for mesh in splits.iter().filter(|m| drawn(m)) {
        for list in [&mesh.vertices, &mesh.normals] {
            for v in list.iter() {
                for x in v.to_array() {
                    bytes.extend_from_slice(&(x as f32).to_le_bytes());
                }
                if bytes.len() >= 1 << 16 {
                    flush(&mut bytes, out)?;
                }
            }
        }
        for tri in mesh.triangles.iter() {
            for i in tri {
                bytes.extend_from_slice(&i.to_le_bytes());
            }
            if bytes.len() >= 1 << 16 {
                flush(&mut bytes, out)?;
            }
        }
    }
    flush(&mut bytes, out)
}

/// Writes out the bytes gathered so far.
fn flush(bytes: &mut Vec<u8>, out: &mut dyn Write) -> io::Result<()> {
    out.write_all(bytes)?;
    bytes.clear();
    Ok(())
}
