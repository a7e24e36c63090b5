//! glTF 2.0 writer (Khronos glTF 2.0 specification): binary `.glb` and self-contained
//! `.gltf` (JSON with the buffer embedded as a base64 data URI).
//!
//! Layout: one scene holding one root node (`sylva`) with a child node per non-empty
//! part, named after the part. Each part becomes one mesh with one `TRIANGLES` primitive
//! (faces fan-triangulated) with `POSITION` (with exact `min`/`max`), `NORMAL` (always:
//! the part's normals normalized, or smooth area-weighted normals when it has none),
//! `TEXCOORD_0` (when the part has UVs), `UNSIGNED_INT` indices and a metallic-roughness
//! PBR material named after the part's [`crate::Material`]. All data lives in one buffer,
//! one tightly packed, 4-byte aligned buffer view per accessor, with `ARRAY_BUFFER` /
//! `ELEMENT_ARRAY_BUFFER` targets. Face-varying UVs and normals are unified into glTF
//! vertices by [`super::unify`].
//!
//! UVs: a [`crate::Mesh`] stores texture coordinates with the origin at the bottom left
//! (OpenGL / OBJ convention, v up); glTF puts it at the top left, so `v` is written as
//! `1 − v`.
//!
//! Output is deterministic: the same model gives byte-identical output.

use super::{validate_model, VertexData, GENERATOR};
use crate::error::{Error, Result};
use crate::model::{Model, Part};
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use json::Index;

/// GLB magic `glTF`.
const GLB_MAGIC: u32 = 0x4654_6C67;
/// GLB chunk type `JSON`.
const CHUNK_JSON: u32 = 0x4E4F_534A;
/// GLB chunk type `BIN\0`.
const CHUNK_BIN: u32 = 0x004E_4942;
/// Prefix of the embedded buffer's data URI in `.gltf` output.
pub const DATA_URI_PREFIX: &str = "data:application/octet-stream;base64,";

/// Encodes `model` as a binary glTF 2.0 file (`.glb`).
///
/// The model is validated first ([`super::validate_model`]); invalid geometry, a model
/// without triangles, or one whose buffer exceeds GLB's 4 GiB limit is
/// [`Error::InvalidGeometry`].
pub fn to_glb(model: &Model) -> Result<Vec<u8>> {
    validate_model(model)?;
    glb_unchecked(model)
}

/// Encodes `model` as glTF 2.0 JSON (`.gltf`) with its buffer embedded as a base64
/// `data:application/octet-stream;base64,` URI, so the one file is self-contained.
///
/// Errors as [`to_glb`].
pub fn to_gltf_json(model: &Model) -> Result<String> {
    validate_model(model)?;
    gltf_json_unchecked(model)
}

/// [`to_glb`] for a model already validated.
pub(crate) fn glb_unchecked(model: &Model) -> Result<Vec<u8>> {
    let (root, bin) = build(model)?;
    let json = root.to_vec().map_err(json_error)?;
    let json_len = pad4(json.len());
    let bin_len = pad4(bin.len());
    let total = 12 + 8 + json_len + 8 + bin_len;
    let too_big = || Error::InvalidGeometry {
        what: "model".into(),
        why: format!("{total} bytes exceed the 4 GiB limit of a GLB file; export .gltf instead"),
    };
    let total32 = u32::try_from(total).map_err(|_| too_big())?;
    let mut out = Vec::with_capacity(total);
    put_u32(&mut out, GLB_MAGIC);
    put_u32(&mut out, 2);
    put_u32(&mut out, total32);
    // Chunk lengths are at most `total`, which fits in u32.
    put_u32(&mut out, json_len as u32);
    put_u32(&mut out, CHUNK_JSON);
    out.extend_from_slice(&json);
    out.resize(out.len() + json_len - json.len(), b' ');
    put_u32(&mut out, bin_len as u32);
    put_u32(&mut out, CHUNK_BIN);
    out.extend_from_slice(&bin);
    out.resize(out.len() + bin_len - bin.len(), 0);
    debug_assert_eq!(out.len(), total);
    Ok(out)
}

/// [`to_gltf_json`] for a model already validated.
pub(crate) fn gltf_json_unchecked(model: &Model) -> Result<String> {
    let (mut root, bin) = build(model)?;
    if let Some(buffer) = root.buffers.first_mut() {
        buffer.uri = Some(data_uri(&bin));
    }
    root.to_string().map_err(json_error)
}

/// A JSON serialization failure (not expected: all numbers are finite).
fn json_error(e: json::Error) -> Error {
    Error::InvalidGeometry { what: "model".into(), why: format!("glTF JSON encoding failed: {e}") }
}

/// Rounds up to a multiple of 4.
fn pad4(n: usize) -> usize {
    n.div_ceil(4) * 4
}

#[inline]
fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

#[inline]
fn put_f32s<const N: usize>(out: &mut Vec<u8>, v: [f32; N]) {
    for x in v {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

/// Builds the glTF document and its binary buffer (without a URI).
fn build(model: &Model) -> Result<(json::Root, Vec<u8>)> {
    let parts: Vec<(&Part, VertexData)> = model
        .parts
        .iter()
        .filter(|p| p.mesh.triangle_count() > 0)
        .map(|p| (p, VertexData::new(&p.mesh)))
        .collect();
    if parts.is_empty() {
        return Err(Error::InvalidGeometry {
            what: "model".into(),
            why: "no triangles to export (every part is empty)".into(),
        });
    }
    let bin_size: usize = parts
        .iter()
        .map(|(p, d)| {
            let per_vertex = if d.has_uvs() { 32 } else { 24 };
            d.unified.vertices.len() * per_vertex + p.mesh.triangle_count() * 12
        })
        .sum();
    let mut bin: Vec<u8> = Vec::with_capacity(bin_size);
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some(GENERATOR.to_owned()),
            version: "2.0".to_owned(),
            copyright: None,
            extensions: None,
            extras: Default::default(),
            min_version: None,
        },
        ..Default::default()
    };
    let buffer = Index::<json::Buffer>::new(0);
    let mut children = Vec::with_capacity(parts.len());

    for (part, data) in &parts {
        let verts = &data.unified.vertices;
        let count = verts.len();
        let mut attributes = std::collections::BTreeMap::new();

        // POSITION, with its bounds.
        let start = bin.len();
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        for k in verts {
            let p = data.position(k);
            lo = lo.min(p);
            hi = hi.max(p);
            put_f32s(&mut bin, p.to_array());
        }
        let view = push_view(&mut root, buffer, start, bin.len(), json::buffer::Target::ArrayBuffer);
        let bounds = |v: glam::Vec3| Some(json::Value::from(v.to_array().to_vec()));
        let acc = push_accessor(
            &mut root,
            view,
            count,
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            bounds(lo),
            bounds(hi),
        );
        attributes.insert(Valid(json::mesh::Semantic::Positions), acc);

        // NORMAL, always unit length.
        let start = bin.len();
        for k in verts {
            put_f32s(&mut bin, data.normal(k).to_array());
        }
        let view = push_view(&mut root, buffer, start, bin.len(), json::buffer::Target::ArrayBuffer);
        let acc = push_accessor(
            &mut root,
            view,
            count,
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            None,
            None,
        );
        attributes.insert(Valid(json::mesh::Semantic::Normals), acc);

        // TEXCOORD_0, v flipped to glTF's top-left origin.
        if data.has_uvs() {
            let start = bin.len();
            for k in verts {
                let uv = data.uv(k);
                put_f32s(&mut bin, [uv.x, 1.0 - uv.y]);
            }
            let view = push_view(&mut root, buffer, start, bin.len(), json::buffer::Target::ArrayBuffer);
            let acc = push_accessor(
                &mut root,
                view,
                count,
                json::accessor::ComponentType::F32,
                json::accessor::Type::Vec2,
                None,
                None,
            );
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), acc);
        }

        // Indices: every face fan-triangulated, u32.
        let start = bin.len();
        let cv = &data.unified.corner_vertex;
        for w in part.mesh.face_offsets.windows(2) {
            let Some(face) = cv.get(w[0] as usize..w[1] as usize) else {
                continue;
            };
            let Some((&first, rest)) = face.split_first() else {
                continue;
            };
            for pair in rest.windows(2) {
                put_u32(&mut bin, first);
                put_u32(&mut bin, pair[0]);
                put_u32(&mut bin, pair[1]);
            }
        }
        let index_count = (bin.len() - start) / 4;
        let view = push_view(&mut root, buffer, start, bin.len(), json::buffer::Target::ElementArrayBuffer);
        let indices = push_accessor(
            &mut root,
            view,
            index_count,
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
            None,
        );

        let m = &part.material;
        let material = root.push(json::Material {
            name: Some(m.name.clone()),
            alpha_mode: Valid(if m.base_color[3] < 1.0 {
                json::material::AlphaMode::Blend
            } else {
                json::material::AlphaMode::Opaque
            }),
            double_sided: m.double_sided,
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor(
                    m.base_color.map(|c| c.clamp(0.0, 1.0)),
                ),
                metallic_factor: json::material::StrengthFactor(m.metallic.clamp(0.0, 1.0)),
                roughness_factor: json::material::StrengthFactor(m.roughness.clamp(0.0, 1.0)),
                ..Default::default()
            },
            ..Default::default()
        });
        let mesh = root.push(json::Mesh {
            name: Some(part.name.clone()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: Default::default(),
                indices: Some(indices),
                material: Some(material),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            extensions: None,
            extras: Default::default(),
            weights: None,
        });
        children.push(root.push(node(part.name.clone(), Some(mesh), None)));
    }
    debug_assert_eq!(bin.len(), bin_size);

    let top = root.push(node("sylva".to_owned(), None, Some(children)));
    let scene = root.push(json::Scene {
        name: Some("sylva".to_owned()),
        nodes: vec![top],
        extensions: None,
        extras: Default::default(),
    });
    root.scene = Some(scene);
    root.push(json::Buffer {
        byte_length: USize64::from(bin.len()),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });
    Ok((root, bin))
}

/// A node with no transform.
fn node(
    name: String,
    mesh: Option<Index<json::Mesh>>,
    children: Option<Vec<Index<json::Node>>>,
) -> json::Node {
    json::Node {
        name: Some(name),
        mesh,
        children,
        camera: None,
        extensions: None,
        extras: Default::default(),
        matrix: None,
        rotation: None,
        scale: None,
        translation: None,
        skin: None,
        weights: None,
    }
}

/// Adds a tightly packed buffer view over `bin[start..end]`.
fn push_view(
    root: &mut json::Root,
    buffer: Index<json::Buffer>,
    start: usize,
    end: usize,
    target: json::buffer::Target,
) -> Index<json::buffer::View> {
    root.push(json::buffer::View {
        buffer,
        byte_length: USize64::from(end - start),
        byte_offset: Some(USize64::from(start)),
        byte_stride: None,
        name: None,
        target: Some(Valid(target)),
        extensions: None,
        extras: Default::default(),
    })
}

/// Adds an accessor reading a whole buffer view.
fn push_accessor(
    root: &mut json::Root,
    view: Index<json::buffer::View>,
    count: usize,
    component: json::accessor::ComponentType,
    type_: json::accessor::Type,
    min: Option<json::Value>,
    max: Option<json::Value>,
) -> Index<json::Accessor> {
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

/// `data:application/octet-stream;base64,…` for `bytes`.
fn data_uri(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(DATA_URI_PREFIX.len() + bytes.len().div_ceil(3) * 4);
    s.push_str(DATA_URI_PREFIX);
    base64_into(bytes, &mut s);
    s
}

/// Appends the standard, padded base64 encoding (RFC 4648 §4) of `bytes` to `out`.
pub fn base64_into(bytes: &[u8], out: &mut String) {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let sym = |n: u32, shift: u32| ALPHABET[((n >> shift) & 63) as usize] as char;
    let mut chunks = bytes.chunks_exact(3);
    for c in &mut chunks {
        let n = (c[0] as u32) << 16 | (c[1] as u32) << 8 | c[2] as u32;
        out.extend([sym(n, 18), sym(n, 12), sym(n, 6), sym(n, 0)]);
    }
    match *chunks.remainder() {
        [a] => {
            let n = (a as u32) << 16;
            out.extend([sym(n, 18), sym(n, 12), '=', '=']);
        }
        [a, b] => {
            let n = (a as u32) << 16 | (b as u32) << 8;
            out.extend([sym(n, 18), sym(n, 12), sym(n, 6), '=']);
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b64(bytes: &[u8]) -> String {
        let mut s = String::new();
        base64_into(bytes, &mut s);
        s
    }

    #[test]
    fn base64_matches_rfc4648_vectors() {
        assert_eq!(b64(b""), "");
        assert_eq!(b64(b"f"), "Zg==");
        assert_eq!(b64(b"fo"), "Zm8=");
        assert_eq!(b64(b"foo"), "Zm9v");
        assert_eq!(b64(b"foob"), "Zm9vYg==");
        assert_eq!(b64(b"fooba"), "Zm9vYmE=");
        assert_eq!(b64(b"foobar"), "Zm9vYmFy");
        assert_eq!(b64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn empty_model_is_an_error() {
        let e = to_glb(&Model::default()).unwrap_err();
        assert!(matches!(e, Error::InvalidGeometry { .. }), "{e}");
    }
}
