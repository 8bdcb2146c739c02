//! glTF 2.0 binary (GLB) writing and reading for the head: one scene, one node `head`, one
//! mesh `head` with one indexed triangle primitive (POSITION, NORMAL, COLOR_0).
//!
//! The writer builds the JSON by hand in a fixed order with Rust's shortest round-trip float
//! formatting, so the same mesh always gives the same bytes. The reader is strict about the
//! container (magic, version, lengths, 4-byte alignment, chunk types) and reads back any
//! primitive laid out the way glTF allows for these attributes.

use crate::HeadAsset;
use crate::error::Error;
use crate::json::{Json, quote};
use std::fmt::Write;

const MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;
const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const TRIANGLES: u32 = 4;

/// Serialises the head as a GLB. `copyright` goes to `asset.copyright`; `extras` (key, text)
/// pairs go, in order, to `asset.extras` as strings. Indices are `u16` when the vertex count
/// allows, else `u32`.
pub fn write(head: &HeadAsset, copyright: &str, extras: &[(&str, &str)]) -> Vec<u8> {
    let n = head.positions.len();
    let mut bin: Vec<u8> = Vec::new();
    let mut views: Vec<(usize, usize, u32)> = Vec::new(); // offset, length, target
    let mut push_view = |bin: &mut Vec<u8>, bytes: Vec<u8>, target: u32| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push((bin.len(), bytes.len(), target));
        bin.extend_from_slice(&bytes);
    };
    push_view(&mut bin, float_bytes(head.positions.iter().flatten()), ARRAY_BUFFER);
    push_view(&mut bin, float_bytes(head.normals.iter().flatten()), ARRAY_BUFFER);
    push_view(&mut bin, float_bytes(head.colors.iter().flatten()), ARRAY_BUFFER);
    let short = n <= u16::MAX as usize + 1;
    let indices = head.triangles.iter().flatten();
    let index_bytes: Vec<u8> = if short {
        indices.flat_map(|&i| (i as u16).to_le_bytes()).collect()
    } else {
        indices.flat_map(|&i| i.to_le_bytes()).collect()
    };
    push_view(&mut bin, index_bytes, ELEMENT_ARRAY_BUFFER);
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }

    let (lo, hi) = position_bounds(&head.positions);
    let vec3 = |v: [f32; 3]| format!("[{},{},{}]", v[0], v[1], v[2]);
    let mut json = String::new();
    json.push_str("{\"asset\":{\"version\":\"2.0\",\"generator\":");
    json.push_str(&quote(concat!("bevy_hair head_asset ", env!("CARGO_PKG_VERSION"))));
    json.push_str(",\"copyright\":");
    json.push_str(&quote(copyright));
    if !extras.is_empty() {
        json.push_str(",\"extras\":{");
        for (k, (key, value)) in extras.iter().enumerate() {
            let comma = if k > 0 { "," } else { "" };
            let _ = write!(json, "{comma}{}:{}", quote(key), quote(value));
        }
        json.push('}');
    }
    json.push_str("},\"scene\":0,\"scenes\":[{\"name\":\"head\",\"nodes\":[0]}]");
    json.push_str(",\"nodes\":[{\"name\":\"head\",\"mesh\":0}]");
    json.push_str(",\"meshes\":[{\"name\":\"head\",\"primitives\":[{\"attributes\":");
    json.push_str("{\"POSITION\":0,\"NORMAL\":1,\"COLOR_0\":2},\"indices\":3,\"material\":0,\"mode\":4}]}]");
    json.push_str(",\"materials\":[{\"name\":\"head\",\"pbrMetallicRoughness\":");
    json.push_str("{\"baseColorFactor\":[1,1,1,1],\"metallicFactor\":0,\"roughnessFactor\":0.8}}]");
    let _ = write!(
        json,
        ",\"accessors\":[\
         {{\"bufferView\":0,\"componentType\":{FLOAT},\"count\":{n},\"type\":\"VEC3\",\"min\":{},\"max\":{}}},\
         {{\"bufferView\":1,\"componentType\":{FLOAT},\"count\":{n},\"type\":\"VEC3\"}},\
         {{\"bufferView\":2,\"componentType\":{FLOAT},\"count\":{n},\"type\":\"VEC4\"}},\
         {{\"bufferView\":3,\"componentType\":{},\"count\":{},\"type\":\"SCALAR\"}}]",
        vec3(lo),
        vec3(hi),
        if short { UNSIGNED_SHORT } else { UNSIGNED_INT },
        head.triangles.len() * 3,
    );
    json.push_str(",\"bufferViews\":[");
    for (k, (offset, length, target)) in views.iter().enumerate() {
        let comma = if k > 0 { "," } else { "" };
        let _ =
            write!(json, "{comma}{{\"buffer\":0,\"byteOffset\":{offset},\"byteLength\":{length},\"target\":{target}}}");
    }
    let _ = write!(json, "],\"buffers\":[{{\"byteLength\":{}}}]}}", bin.len());
    while !json.len().is_multiple_of(4) {
        json.push(' ');
    }

    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
    out.extend_from_slice(json.as_bytes());
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

fn float_bytes<'a>(values: impl Iterator<Item = &'a f32>) -> Vec<u8> {
    values.flat_map(|v| v.to_le_bytes()).collect()
}

/// Component-wise min and max of the positions (zeros for none).
fn position_bounds(positions: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    if positions.is_empty() {
        return ([0.0; 3], [0.0; 3]);
    }
    positions.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
        (std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k])))
    })
}

/// The two chunks of a GLB, after the container checks.
#[derive(Clone, Debug, PartialEq)]
pub struct Chunks {
    /// The parsed JSON chunk.
    pub json: Json,
    /// The BIN chunk (empty if the file has none).
    pub bin: Vec<u8>,
}

fn u32_at(bytes: &[u8], at: usize) -> Result<u32, Error> {
    bytes
        .get(at..at + 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| Error::Glb(format!("truncated at byte {at}")))
}

/// Splits a GLB into its chunks, checking the header magic and version, that the header's
/// length is the file's, that chunk lengths are multiples of 4 and within the file, and
/// that the first chunk is JSON and the second (if any) BIN.
pub fn chunks(bytes: &[u8]) -> Result<Chunks, Error> {
    let bad = |m: String| Err(Error::Glb(m));
    if bytes.get(0..4) != Some(MAGIC) {
        return bad("the file does not start with `glTF`".into());
    }
    let version = u32_at(bytes, 4)?;
    if version != 2 {
        return bad(format!("version {version}, expected 2"));
    }
    let length = u32_at(bytes, 8)? as usize;
    if length != bytes.len() {
        return bad(format!("the header says {length} bytes, the file has {}", bytes.len()));
    }
    let mut at = 12;
    let mut found: Vec<(u32, &[u8])> = Vec::new();
    while at < bytes.len() {
        let chunk_length = u32_at(bytes, at)? as usize;
        let kind = u32_at(bytes, at + 4)?;
        if !chunk_length.is_multiple_of(4) {
            return bad(format!("chunk at byte {at} has length {chunk_length}, not a multiple of 4"));
        }
        let data = bytes.get(at + 8..at + 8 + chunk_length).ok_or_else(|| Error::Glb("chunk past the end".into()))?;
        found.push((kind, data));
        at += 8 + chunk_length;
    }
    let json = match found.first() {
        Some(&(CHUNK_JSON, data)) => {
            let text = std::str::from_utf8(data).map_err(|_| Error::Glb("the JSON chunk is not UTF-8".into()))?;
            Json::parse(text).map_err(Error::Glb)?
        }
        _ => return bad("the first chunk is not JSON".into()),
    };
    let bin = match found.get(1) {
        Some(&(CHUNK_BIN, data)) => data.to_vec(),
        Some(&(kind, _)) => return bad(format!("the second chunk has type {kind:#x}, not BIN")),
        None => Vec::new(),
    };
    Ok(Chunks { json, bin })
}

/// Reads accessor `index`: its component values as `f64` (floats, or unsigned integers for
/// indices), `count × components` of them, checked against its buffer view and the BIN chunk.
fn accessor(chunks: &Chunks, index: usize, expected_type: &str) -> Result<Vec<f64>, Error> {
    let bad = |m: String| Error::Glb(format!("accessor {index}: {m}"));
    let json = &chunks.json;
    let a = json.get("accessors").and_then(|a| a.at(index)).ok_or_else(|| bad("missing".into()))?;
    let field = |key: &str| a.get(key).and_then(Json::as_usize).ok_or_else(|| bad(format!("no `{key}`")));
    let kind = a.get("type").and_then(Json::as_str).ok_or_else(|| bad("no `type`".into()))?;
    if kind != expected_type {
        return Err(bad(format!("type {kind}, expected {expected_type}")));
    }
    let components = match kind {
        "SCALAR" => 1,
        "VEC3" => 3,
        "VEC4" => 4,
        _ => return Err(bad(format!("unsupported type {kind}"))),
    };
    let (count, component_type) = (field("count")?, field("componentType")? as u32);
    let size = match component_type {
        FLOAT | UNSIGNED_INT => 4,
        UNSIGNED_SHORT => 2,
        _ => return Err(bad(format!("unsupported componentType {component_type}"))),
    };
    let view_index = field("bufferView")?;
    let view = json.get("bufferViews").and_then(|v| v.at(view_index)).ok_or_else(|| bad("no buffer view".into()))?;
    let view_field = |key: &str| view.get(key).and_then(Json::as_usize);
    if view_field("buffer") != Some(0) {
        return Err(bad("the buffer view is not in the BIN chunk".into()));
    }
    let stride = view_field("byteStride").unwrap_or(components * size);
    if stride < components * size {
        return Err(bad(format!("byteStride {stride} is shorter than an element")));
    }
    let start = view_field("byteOffset").unwrap_or(0) + a.get("byteOffset").and_then(Json::as_usize).unwrap_or(0);
    let view_end =
        view_field("byteOffset").unwrap_or(0) + view_field("byteLength").ok_or_else(|| bad("no byteLength".into()))?;
    let end = if count == 0 { start } else { start + stride * (count - 1) + components * size };
    if end > view_end || view_end > chunks.bin.len() || !start.is_multiple_of(size) {
        return Err(bad(format!("bytes {start}..{end} do not fit its view (..{view_end}) and the BIN chunk")));
    }
    let mut values = Vec::with_capacity(count * components);
    for e in 0..count {
        for c in 0..components {
            let at = start + e * stride + c * size;
            let b = &chunks.bin[at..at + size];
            values.push(match component_type {
                FLOAT => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                UNSIGNED_INT => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                _ => u16::from_le_bytes([b[0], b[1]]) as f64,
            });
        }
    }
    Ok(values)
}

/// Reads the first primitive of the first mesh back into a [`HeadAsset`]. It must be an
/// indexed triangle list with float POSITION, NORMAL and COLOR_0 (VEC4) of one length.
pub fn read(bytes: &[u8]) -> Result<HeadAsset, Error> {
    let chunks = chunks(bytes)?;
    let primitive = chunks
        .json
        .get("meshes")
        .and_then(|m| m.at(0))
        .and_then(|m| m.get("primitives"))
        .and_then(|p| p.at(0))
        .ok_or_else(|| Error::Glb("no mesh primitive".into()))?;
    let mode = primitive.get("mode").and_then(Json::as_usize).unwrap_or(TRIANGLES as usize);
    if mode != TRIANGLES as usize {
        return Err(Error::Glb(format!("primitive mode {mode}, expected triangles (4)")));
    }
    let attribute = |name: &str| {
        primitive
            .get("attributes")
            .and_then(|a| a.get(name))
            .and_then(Json::as_usize)
            .ok_or_else(|| Error::Glb(format!("no {name} attribute")))
    };
    let index_accessor =
        primitive.get("indices").and_then(Json::as_usize).ok_or_else(|| Error::Glb("no indices".into()))?;
    let positions = accessor(&chunks, attribute("POSITION")?, "VEC3")?;
    let normals = accessor(&chunks, attribute("NORMAL")?, "VEC3")?;
    let colors = accessor(&chunks, attribute("COLOR_0")?, "VEC4")?;
    let indices = accessor(&chunks, index_accessor, "SCALAR")?;
    let n = positions.len() / 3;
    if normals.len() != 3 * n || colors.len() != 4 * n {
        return Err(Error::Glb("POSITION, NORMAL and COLOR_0 differ in length".into()));
    }
    if !indices.len().is_multiple_of(3) || indices.iter().any(|&i| i as usize >= n) {
        return Err(Error::Glb("indices are not whole triangles over the vertices".into()));
    }
    Ok(HeadAsset {
        positions: positions.chunks(3).map(|c| [c[0] as f32, c[1] as f32, c[2] as f32]).collect(),
        normals: normals.chunks(3).map(|c| [c[0] as f32, c[1] as f32, c[2] as f32]).collect(),
        colors: colors.chunks(4).map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32]).collect(),
        triangles: indices.chunks(3).map(|c| [c[0] as u32, c[1] as u32, c[2] as u32]).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> HeadAsset {
        HeadAsset {
            positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.5]],
            normals: vec![[0.0, 1.0, 0.0]; 4],
            colors: vec![[0.0, 0.0, 0.0, 1.0], [1.0; 4], [1.0; 4], [0.25, 0.5, 0.75, 1.0]],
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        }
    }

    /// Reads a little-endian u32 (test helper independent of the reader).
    fn le(bytes: &[u8], at: usize) -> usize {
        u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize
    }

    #[test]
    fn the_container_is_well_formed() {
        let bytes = write(&tetrahedron(), "test \"copyright\"", &[("source", "unit test")]);
        assert_eq!(&bytes[0..4], b"glTF");
        assert_eq!(le(&bytes, 4), 2, "version");
        assert_eq!(le(&bytes, 8), bytes.len(), "total length");
        let json_len = le(&bytes, 12);
        assert_eq!(&bytes[16..20], b"JSON");
        assert_eq!(json_len % 4, 0);
        let bin_at = 20 + json_len;
        let bin_len = le(&bytes, bin_at);
        assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
        assert_eq!(bin_len % 4, 0);
        assert_eq!(bin_at + 8 + bin_len, bytes.len());
        // 4 vertices × (12 + 12 + 16) bytes, then 12 u16 indices (24 bytes).
        assert_eq!(bin_len, 4 * 40 + 24);
        assert_eq!(bytes.len() % 4, 0);
    }

    #[test]
    fn output_parses_back_exactly() {
        let head = tetrahedron();
        let bytes = write(&head, "CC0", &[]);
        assert_eq!(read(&bytes).unwrap(), head);
        let chunks = chunks(&bytes).unwrap();
        let accessors = chunks.json.get("accessors").unwrap().as_array().unwrap();
        let counts: Vec<usize> = accessors.iter().map(|a| a.get("count").unwrap().as_usize().unwrap()).collect();
        assert_eq!(counts, [4, 4, 4, 12]);
        assert_eq!(accessors[3].get("componentType").unwrap().as_usize(), Some(UNSIGNED_SHORT as usize));
        let max = accessors[0].get("max").unwrap().as_array().unwrap();
        assert_eq!(max.iter().map(|m| m.as_f64().unwrap()).collect::<Vec<_>>(), [1.0, 1.0, 1.5]);
        let node = chunks.json.get("nodes").unwrap().at(0).unwrap();
        assert_eq!(node.get("name").unwrap().as_str(), Some("head"));
        assert_eq!(chunks.json.get("asset").unwrap().get("copyright").unwrap().as_str(), Some("CC0"));
        assert_eq!(write(&head, "CC0", &[]), bytes, "deterministic");
    }

    #[test]
    fn big_meshes_use_u32_indices() {
        let n = 70_000u32;
        let head = HeadAsset {
            positions: (0..n).map(|i| [i as f32, 0.0, 0.0]).collect(),
            normals: vec![[0.0, 1.0, 0.0]; n as usize],
            colors: vec![[1.0; 4]; n as usize],
            triangles: vec![[0, 1, n - 1]],
        };
        let bytes = write(&head, "", &[]);
        assert_eq!(read(&bytes).unwrap().triangles, [[0, 1, n - 1]]);
    }

    #[test]
    fn broken_files_are_refused() {
        let bytes = write(&tetrahedron(), "", &[]);
        let mut wrong_magic = bytes.clone();
        wrong_magic[0] = b'x';
        assert!(read(&wrong_magic).unwrap_err().to_string().contains("glTF"));
        let truncated = &bytes[..bytes.len() - 4];
        assert!(read(truncated).unwrap_err().to_string().contains("the header says"));
        let mut misaligned = bytes.clone();
        misaligned[12] += 1; // JSON chunk length no longer a multiple of 4
        assert!(read(&misaligned).unwrap_err().to_string().contains("multiple of 4"));
    }
}
