//! glTF 2.0 writer (glTF2): binary `.glb` and self-contained `.gltf` (JSON with the buffer
//! embedded as a base64 data URI). One scene, a node per part (or per level of detail with
//! a rig or LODs), one primitive per part with exact bounds, PBR materials and textures,
//! `EXT_mesh_gpu_instancing`, `KHR_mesh_quantization`, `EXT_meshopt_compression`,
//! `MSFT_lod`, a skin and a looping clip, and the `_WIND` / `_PIVOT` channels. The layout,
//! attribute by attribute, is `docs/gltf.md`; `document.rs`, `mesh.rs`, `rig.rs`,
//! `textures.rs` and `compress.rs` write the parts of it. Face-varying UVs and normals are
//! unified into glTF vertices by [`super::unify`]; `v` is written as `1 − v`.
//!
//! Output is deterministic: the same model gives byte-identical output.

use super::{validate_model, Compression, ExportOptions, InstancingFallback, VertexData};
use crate::error::{Error, Result};
use crate::model::{Model, Part};
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use json::Index;

mod compress;
mod document;
mod mesh;
mod rig;
mod textures;

use self::compress::meshopt_encode;
use self::document::{build_levels, instanced_shapes, new_root, no_triangles, push_scene};
use self::mesh::{push_instanced_node, push_mesh};
use self::rig::Channels;
use self::textures::push_textures;

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
    to_glb_with(model, &ExportOptions::default())
}

/// [`to_glb`] written as `options` say (textures, instancing fallback, compression).
pub fn to_glb_with(model: &Model, options: &ExportOptions) -> Result<Vec<u8>> {
    validate_model(model)?;
    glb_unchecked(model, options)
}

/// Encodes `model` as glTF 2.0 JSON (`.gltf`) with its buffer embedded as a base64
/// `data:application/octet-stream;base64,` URI, so the one file is self-contained.
///
/// Errors as [`to_glb`].
pub fn to_gltf_json(model: &Model) -> Result<String> {
    to_gltf_json_with(model, &ExportOptions::default())
}

/// [`to_gltf_json`] written as `options` say.
pub fn to_gltf_json_with(model: &Model, options: &ExportOptions) -> Result<String> {
    validate_model(model)?;
    gltf_json_unchecked(model, options)
}

/// [`to_glb`] for a model already validated.
pub(crate) fn glb_unchecked(model: &Model, options: &ExportOptions) -> Result<Vec<u8>> {
    let (root, bin) = build(model, options, true)?;
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
pub(crate) fn gltf_json_unchecked(model: &Model, options: &ExportOptions) -> Result<String> {
    let (mut root, bin) = build(model, options, false)?;
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

/// Builds the glTF document and its binary buffer (without a URI). `glb`: embedded
/// images go into the buffer (else into data URIs).
fn build(model: &Model, options: &ExportOptions, glb: bool) -> Result<(json::Root, Vec<u8>)> {
    let flat;
    // Skinned meshes ignore node transforms, so a rigged model's instances are merged.
    let model = if options.instancing_fallback == InstancingFallback::Merged || model.rig.is_some() {
        flat = model.flattened();
        flat.as_ref()
    } else {
        model
    };
    if model.rig.is_some() || !model.lods.is_empty() {
        return build_levels(model, options, glb);
    }
    let parts: Vec<(&Part, VertexData)> = model
        .parts
        .iter()
        .filter(|p| p.mesh.triangle_count() > 0)
        .map(|p| (p, VertexData::new(&p.mesh)))
        .collect();
    let shapes = instanced_shapes(model);
    if parts.is_empty() && shapes.is_empty() {
        return Err(no_triangles());
    }
    let bin_size: usize = parts
        .iter()
        .map(|(p, d)| {
            let per_vertex = if d.has_uvs() { 32 } else { 24 };
            let index_bytes = if d.unified.vertices.len() < 65_536 { 6 } else { 12 };
            d.unified.vertices.len() * per_vertex + pad4(p.mesh.triangle_count() * index_bytes)
        })
        .sum();
    let mut doc = Doc::new(new_root(), Vec::with_capacity(bin_size), options.compress);
    let mut children = Vec::with_capacity(parts.len() + shapes.len());
    let texture_of = push_textures(&mut doc.root, &mut doc.bin, doc.buffer, model, &options.textures, glb)?;

    for (part, data) in &parts {
        let (mesh, dequant) = push_mesh(&mut doc, part, data, &texture_of, &Channels::wind(part, options))?;
        let mut n = node(part.name.clone(), Some(mesh), None);
        if let Some(d) = dequant {
            n.translation = Some(d.offset.to_array());
            n.scale = Some([d.step; 3]);
        }
        children.push(doc.root.push(n));
    }
    for (shape, data, transforms) in &shapes {
        let (mesh, dequant) = push_mesh(&mut doc, shape, data, &texture_of, &Channels::wind(shape, options))?;
        children.push(push_instanced_node(&mut doc, shape, mesh, dequant, transforms, None)?);
    }

    let mut root = doc.finish()?;
    let top = root.0.push(node("sylva".to_owned(), None, Some(children)));
    push_scene(&mut root.0, model, vec![top])?;
    Ok(root)
}

/// `EXT_mesh_gpu_instancing`.
const INSTANCING: &str = "EXT_mesh_gpu_instancing";
/// `KHR_mesh_quantization`.
const QUANTIZATION: &str = "KHR_mesh_quantization";
/// `EXT_meshopt_compression`.
const MESHOPT: &str = "EXT_meshopt_compression";
/// `MSFT_lod`.
const MSFT_LOD: &str = "MSFT_lod";

/// The document being built, its binary buffer and how views are stored.
struct Doc {
    root: json::Root,
    bin: Vec<u8>,
    /// The buffer the GLB binary chunk (or the data URI) holds: buffer 0.
    buffer: Index<json::Buffer>,
    compress: Compression,
    /// Length of the (virtual) uncompressed fallback buffer of meshopt views.
    fallback_len: usize,
    /// Extensions used, and whether each is required.
    extensions: Vec<(&'static str, bool)>,
}

/// The layout of a buffer view's data, for `EXT_meshopt_compression`.
#[derive(Debug, Clone, Copy)]
enum Layout {
    /// Vertex attributes (`ARRAY_BUFFER`): elements of `stride` bytes.
    Vertices { stride: usize },
    /// Instance attributes (no target): elements of `stride` bytes.
    Instances { stride: usize },
    /// Other data read by element (no target, no `byteStride`): inverse bind matrices,
    /// animation times and rotations, elements of `stride` bytes.
    Data { stride: usize },
    /// A triangle list's indices of `size` (2 or 4) bytes each (`ELEMENT_ARRAY_BUFFER`).
    Triangles { size: usize },
}

impl Doc {
    fn new(root: json::Root, bin: Vec<u8>, compress: Compression) -> Self {
        let mut doc =
            Doc { root, bin, buffer: Index::new(0), compress, fallback_len: 0, extensions: Vec::new() };
        match compress {
            Compression::None => {}
            Compression::Quantize => doc.use_extension(QUANTIZATION, true),
            Compression::Meshopt => {
                doc.use_extension(QUANTIZATION, true);
                doc.use_extension(MESHOPT, true);
            }
        }
        doc
    }

    /// Whether attributes are quantized.
    fn quantize(&self) -> bool {
        self.compress != Compression::None
    }

    /// Records that the file uses `name` (and requires it, if `required`).
    fn use_extension(&mut self, name: &'static str, required: bool) {
        if !self.extensions.iter().any(|(n, _)| *n == name) {
            self.extensions.push((name, required));
        }
    }

    /// Adds a buffer view holding `bytes` (`count` elements laid out as `layout`):
    /// appended to the binary buffer (4-byte aligned), or with `output.compress =
    /// "meshopt"` compressed into it, the view itself pointing into the fallback buffer.
    fn view(&mut self, bytes: &[u8], count: usize, layout: Layout) -> Result<Index<json::buffer::View>> {
        use json::buffer::Target;
        let (target, stride) = match layout {
            Layout::Vertices { stride } => (Some(Valid(Target::ArrayBuffer)), Some(stride)),
            Layout::Instances { stride } | Layout::Data { stride } => (None, Some(stride)),
            Layout::Triangles { .. } => (Some(Valid(Target::ElementArrayBuffer)), None),
        };
        // A byteStride only where elements are padded (glTF requires it there).
        let byte_stride = match layout {
            Layout::Vertices { stride } | Layout::Instances { stride } | Layout::Data { stride }
                if stride * count != bytes.len() =>
            {
                return Err(Error::InvalidGeometry {
                    what: "model".into(),
                    why: format!("glTF view of {} bytes is not {count} × {stride}", bytes.len()),
                })
            }
            _ => stride.filter(|_| self.padded(layout)).map(json::buffer::Stride),
        };
        if self.compress == Compression::Meshopt {
            let (encoded, extension) = meshopt_encode(bytes, count, layout)?;
            let start = self.bin.len();
            self.bin.extend_from_slice(&encoded);
            self.bin.resize(pad4(self.bin.len()), 0);
            let offset = self.fallback_len;
            self.fallback_len = pad4(offset + bytes.len());
            let mut ext = extension;
            ext.insert("buffer".into(), 0.into());
            ext.insert("byteOffset".into(), start.into());
            ext.insert("byteLength".into(), encoded.len().into());
            let mut others = serde_json::Map::new();
            others.insert(MESHOPT.into(), serde_json::Value::Object(ext));
            return Ok(self.root.push(json::buffer::View {
                // The fallback buffer: pushed after the binary buffer, so index 1.
                buffer: Index::new(1),
                byte_length: USize64::from(bytes.len()),
                byte_offset: Some(USize64::from(offset)),
                byte_stride,
                name: None,
                target,
                extensions: Some(json::extensions::buffer::View { others }),
                extras: Default::default(),
            }));
        }
        let start = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let view = self.root.push(json::buffer::View {
            buffer: self.buffer,
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(start)),
            byte_stride,
            name: None,
            target,
            extensions: None,
            extras: Default::default(),
        });
        // Keep the next view 4-byte aligned.
        self.bin.resize(pad4(self.bin.len()), 0);
        Ok(view)
    }

    /// Whether views of `layout` carry padded elements (quantized VEC3 attributes), which
    /// need an explicit `byteStride`. Float attributes are tightly packed.
    fn padded(&self, layout: Layout) -> bool {
        matches!(layout, Layout::Vertices { .. }) && self.quantize()
    }

    /// Adds an accessor reading a whole buffer view.
    #[allow(clippy::too_many_arguments)]
    fn accessor(
        &mut self,
        view: Index<json::buffer::View>,
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        normalized: bool,
        min: Option<json::Value>,
        max: Option<json::Value>,
    ) -> Index<json::Accessor> {
        self.root.push(json::Accessor {
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
            normalized,
            sparse: None,
        })
    }

    /// `values` as one view of `f32` components and an accessor of `type_` over it.
    fn floats<const N: usize>(
        &mut self,
        values: impl Iterator<Item = [f32; N]>,
        type_: json::accessor::Type,
        layout: Layout,
        bounds: Option<(json::Value, json::Value)>,
    ) -> Result<Index<json::Accessor>> {
        let mut bytes = Vec::new();
        let mut count = 0;
        for v in values {
            put_f32s(&mut bytes, v);
            count += 1;
        }
        let view = self.view(&bytes, count, layout)?;
        let (min, max) = bounds.unzip();
        Ok(self.accessor(view, count, json::accessor::ComponentType::F32, type_, false, min, max))
    }

    /// Adds the buffers (the binary one; with meshopt the fallback buffer after it) and
    /// the extension lists; hands back the document and the binary buffer.
    fn finish(mut self) -> Result<(json::Root, Vec<u8>)> {
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        if self.compress == Compression::Meshopt {
            let mut others = serde_json::Map::new();
            others.insert(MESHOPT.into(), serde_json::json!({ "fallback": true }));
            self.root.push(json::Buffer {
                byte_length: USize64::from(self.fallback_len.max(1)),
                name: None,
                uri: None,
                extensions: Some(json::extensions::buffer::Buffer { others }),
                extras: Default::default(),
            });
        }
        for (name, required) in &self.extensions {
            self.root.extensions_used.push(name.to_string());
            if *required {
                self.root.extensions_required.push(name.to_string());
            }
        }
        Ok((self.root, self.bin))
    }
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
