//! glTF 2.0 writer (Khronos glTF 2.0 specification): binary `.glb` and self-contained
//! `.gltf` (JSON with the buffer embedded as a base64 data URI).
//!
//! Layout: one scene holding one root node (`sylva`) with a child node per non-empty
//! part, named after the part. Each part becomes one mesh with one `TRIANGLES` primitive
//! (faces fan-triangulated) with `POSITION` (with exact `min`/`max`), `NORMAL` (always:
//! the part's normals normalized, or smooth area-weighted normals when it has none),
//! `TEXCOORD_0` (when the part has UVs), indices (`UNSIGNED_SHORT` where the primitive
//! has fewer than 65,536 vertices, else `UNSIGNED_INT`) and a metallic-roughness PBR
//! material named after the part's [`crate::Material`]. All data lives in one buffer,
//! one tightly packed, 4-byte aligned buffer view per accessor, with `ARRAY_BUFFER` /
//! `ELEMENT_ARRAY_BUFFER` targets. Face-varying UVs and normals are unified into glTF
//! vertices by [`super::unify`].
//!
//! Textures (issue 23): the model's images become glTF `images` — PNG in a buffer view
//! ([`TextureMode::Embed`]) or a relative `uri` to a file the caller writes beside the
//! model ([`TextureMode::Files`]) — with one `texture` each and a sampler that repeats
//! (bark tiles) or clamps (the leaf atlas). A material with maps gets
//! `baseColorTexture`, `normalTexture`, `occlusionTexture` and `metallicRoughnessTexture`
//! (its factors then 1, metallic its own) where its part has UVs; an alpha cut-off gives
//! `alphaMode: MASK`. The scene's `extras` hold the recipe (TOML) and seed.
//!
//! UVs: a [`crate::Mesh`] stores texture coordinates with the origin at the bottom left
//! (OpenGL / OBJ convention, v up); glTF puts it at the top left, so `v` is written as
//! `1 − v`.
//!
//! Output is deterministic: the same model gives byte-identical output.

use super::{validate_model, TextureMode, VertexData, GENERATOR};
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
    glb_unchecked(model, &TextureMode::Embed)
}

/// Encodes `model` as glTF 2.0 JSON (`.gltf`) with its buffer embedded as a base64
/// `data:application/octet-stream;base64,` URI, so the one file is self-contained.
///
/// Errors as [`to_glb`].
pub fn to_gltf_json(model: &Model) -> Result<String> {
    validate_model(model)?;
    gltf_json_unchecked(model, &TextureMode::Embed)
}

/// [`to_glb`] for a model already validated.
pub(crate) fn glb_unchecked(model: &Model, textures: &TextureMode) -> Result<Vec<u8>> {
    let (root, bin) = build(model, textures, true)?;
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
pub(crate) fn gltf_json_unchecked(model: &Model, textures: &TextureMode) -> Result<String> {
    let (mut root, bin) = build(model, textures, false)?;
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
fn build(model: &Model, textures: &TextureMode, glb: bool) -> Result<(json::Root, Vec<u8>)> {
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
            let index_bytes = if d.unified.vertices.len() < 65_536 { 6 } else { 12 };
            d.unified.vertices.len() * per_vertex + pad4(p.mesh.triangle_count() * index_bytes)
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
    let texture_of = push_textures(&mut root, &mut bin, buffer, model, textures, glb)?;
    let image_bytes = bin.len();

    for (part, data) in &parts {
        let verts = &data.unified.vertices;
        let count = verts.len();
        let mut attributes = std::collections::BTreeMap::new();

        // POSITION, with its bounds.
        let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
        for k in verts {
            lo = lo.min(data.position(k));
            hi = hi.max(data.position(k));
        }
        let bounds = |v: glam::Vec3| Some(json::Value::from(v.to_array().to_vec()));
        let positions = verts.iter().map(|k| data.position(k).to_array());
        let acc = push_floats(
            &mut root,
            &mut bin,
            buffer,
            positions,
            json::accessor::Type::Vec3,
            bounds(lo),
            bounds(hi),
        );
        attributes.insert(Valid(json::mesh::Semantic::Positions), acc);

        // NORMAL, always unit length.
        let normals = verts.iter().map(|k| data.normal(k).to_array());
        let acc = push_floats(&mut root, &mut bin, buffer, normals, json::accessor::Type::Vec3, None, None);
        attributes.insert(Valid(json::mesh::Semantic::Normals), acc);

        // TEXCOORD_0, v flipped to glTF's top-left origin.
        if data.has_uvs() {
            let uvs = verts.iter().map(|k| data.uv(k)).map(|uv| [uv.x, 1.0 - uv.y]);
            let acc = push_floats(&mut root, &mut bin, buffer, uvs, json::accessor::Type::Vec2, None, None);
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), acc);
        }

        // TANGENT where a normal map will be read (so no runtime has to guess one).
        if map_texture(part.material.maps.normal, data.has_uvs(), &texture_of).is_some() {
            let t = tangents(part, data).into_iter();
            let acc = push_floats(&mut root, &mut bin, buffer, t, json::accessor::Type::Vec4, None, None);
            attributes.insert(Valid(json::mesh::Semantic::Tangents), acc);
        }

        // Indices: every face fan-triangulated, u16 where every index fits.
        let start = bin.len();
        let short = count < 65_536;
        let cv = &data.unified.corner_vertex;
        let put = |bin: &mut Vec<u8>, i: u32| {
            if short {
                bin.extend_from_slice(&(i as u16).to_le_bytes());
            } else {
                put_u32(bin, i);
            }
        };
        for w in part.mesh.face_offsets.windows(2) {
            let Some(face) = cv.get(w[0] as usize..w[1] as usize) else {
                continue;
            };
            let Some((&first, rest)) = face.split_first() else {
                continue;
            };
            for pair in rest.windows(2) {
                put(&mut bin, first);
                put(&mut bin, pair[0]);
                put(&mut bin, pair[1]);
            }
        }
        let index_count = (bin.len() - start) / if short { 2 } else { 4 };
        let view = push_view(&mut root, buffer, start, bin.len(), json::buffer::Target::ElementArrayBuffer);
        // Keep the next view 4-byte aligned.
        bin.resize(pad4(bin.len()), 0);
        let indices = push_accessor(
            &mut root,
            view,
            index_count,
            if short { json::accessor::ComponentType::U16 } else { json::accessor::ComponentType::U32 },
            json::accessor::Type::Scalar,
            None,
            None,
        );

        let material = root.push(material(&part.material, data.has_uvs(), &texture_of));
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
    debug_assert!(bin.len() - image_bytes >= bin_size);

    let top = root.push(node("sylva".to_owned(), None, Some(children)));
    let extras = match &model.provenance {
        Some(p) => {
            let v = serde_json::json!({ "sylva": { "recipe": p.recipe, "seed": p.seed } });
            Some(json::extras::RawValue::from_string(v.to_string()).map_err(|e| Error::InvalidGeometry {
                what: "model".into(),
                why: format!("glTF extras: {e}"),
            })?)
        }
        None => None,
    };
    let scene =
        root.push(json::Scene { name: Some("sylva".to_owned()), nodes: vec![top], extensions: None, extras });
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

/// The glTF texture index of each model image (`None` for [`TextureMode::None`]).
type TextureIndex = Vec<Option<Index<json::Texture>>>;

/// Adds the model's images, one texture per image and the two samplers (repeat, clamp);
/// returns the texture of each image.
fn push_textures(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: Index<json::Buffer>,
    model: &Model,
    mode: &TextureMode,
    glb: bool,
) -> Result<TextureIndex> {
    if model.images.is_empty() || matches!(mode, TextureMode::None) {
        return Ok(vec![None; model.images.len()]);
    }
    use json::texture::{MagFilter, MinFilter, WrappingMode};
    let sampler = |root: &mut json::Root, wrap: WrappingMode| {
        root.push(json::texture::Sampler {
            mag_filter: Some(Valid(MagFilter::Linear)),
            min_filter: Some(Valid(MinFilter::LinearMipmapLinear)),
            name: None,
            wrap_s: Valid(wrap),
            wrap_t: Valid(wrap),
            extensions: None,
            extras: Default::default(),
        })
    };
    let uses = |repeat: bool| model.images.iter().any(|i| i.repeat == repeat);
    let repeat = uses(true).then(|| sampler(root, WrappingMode::Repeat));
    let clamp = uses(false).then(|| sampler(root, WrappingMode::ClampToEdge));
    let pngs: Vec<Vec<u8>> = match mode {
        TextureMode::Embed => {
            use rayon::prelude::*;
            model.images.par_iter().map(|i| i.image.to_png()).collect::<Result<_>>()?
        }
        _ => Vec::new(),
    };
    let mut out = Vec::with_capacity(model.images.len());
    for (k, im) in model.images.iter().enumerate() {
        let (uri, buffer_view, mime_type) = match mode {
            TextureMode::Files { prefix } => (Some(format!("{prefix}{}.png", im.name)), None, None),
            _ if glb => {
                let start = bin.len();
                bin.extend_from_slice(&pngs[k]);
                let view = root.push(json::buffer::View {
                    buffer,
                    byte_length: USize64::from(pngs[k].len()),
                    byte_offset: Some(USize64::from(start)),
                    byte_stride: None,
                    name: None,
                    target: None,
                    extensions: None,
                    extras: Default::default(),
                });
                bin.resize(pad4(bin.len()), 0);
                (None, Some(view), Some(json::image::MimeType("image/png".into())))
            }
            _ => {
                let mut uri = String::from("data:image/png;base64,");
                base64_into(&pngs[k], &mut uri);
                (Some(uri), None, None)
            }
        };
        let source = root.push(json::Image {
            buffer_view,
            mime_type,
            name: Some(im.name.clone()),
            uri,
            extensions: None,
            extras: Default::default(),
        });
        out.push(Some(root.push(json::Texture {
            name: Some(im.name.clone()),
            sampler: if im.repeat { repeat } else { clamp },
            source,
            extensions: None,
            extras: Default::default(),
        })));
    }
    Ok(out)
}

/// The texture a material map `image` is written with: only where the part has UVs
/// and the image was written.
fn map_texture(image: Option<u32>, has_uvs: bool, texture_of: &TextureIndex) -> Option<Index<json::Texture>> {
    image.filter(|_| has_uvs).and_then(|i| texture_of.get(i as usize).copied().flatten())
}

/// Appends `values` to `bin` as one tightly packed `ARRAY_BUFFER` view of `f32`
/// components with an accessor of `type_` over it.
fn push_floats<const N: usize>(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: Index<json::Buffer>,
    values: impl Iterator<Item = [f32; N]>,
    type_: json::accessor::Type,
    min: Option<json::Value>,
    max: Option<json::Value>,
) -> Index<json::Accessor> {
    let start = bin.len();
    let mut count = 0;
    for v in values {
        put_f32s(bin, v);
        count += 1;
    }
    let view = push_view(root, buffer, start, bin.len(), json::buffer::Target::ArrayBuffer);
    push_accessor(root, view, count, json::accessor::ComponentType::F32, type_, min, max)
}

/// The glTF material of `m`; maps only where the part has UVs and the image was written.
fn material(m: &crate::model::Material, has_uvs: bool, texture_of: &TextureIndex) -> json::Material {
    let tex = |i: Option<u32>| map_texture(i, has_uvs, texture_of);
    let info =
        |index| json::texture::Info { index, tex_coord: 0, extensions: None, extras: Default::default() };
    let base = tex(m.maps.base_color);
    let orm = tex(m.maps.occlusion_roughness_metallic);
    let alpha_mode = if m.alpha_cutoff.is_some() && base.is_some() {
        json::material::AlphaMode::Mask
    } else if m.base_color[3] < 1.0 {
        json::material::AlphaMode::Blend
    } else {
        json::material::AlphaMode::Opaque
    };
    // With a colour map the map carries the colour; with an ORM map it carries the roughness.
    let factor = if base.is_some() { [1.0, 1.0, 1.0, m.base_color[3]] } else { m.base_color };
    json::Material {
        name: Some(m.name.clone()),
        alpha_cutoff: (alpha_mode == json::material::AlphaMode::Mask)
            .then(|| json::material::AlphaCutoff(m.alpha_cutoff.unwrap_or(0.5).clamp(0.0, 1.0))),
        alpha_mode: Valid(alpha_mode),
        double_sided: m.double_sided,
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(factor.map(|c| c.clamp(0.0, 1.0))),
            base_color_texture: base.map(info),
            metallic_factor: json::material::StrengthFactor(m.metallic.clamp(0.0, 1.0)),
            roughness_factor: json::material::StrengthFactor(if orm.is_some() {
                1.0
            } else {
                m.roughness.clamp(0.0, 1.0)
            }),
            metallic_roughness_texture: orm.map(info),
            ..Default::default()
        },
        normal_texture: tex(m.maps.normal).map(|index| json::material::NormalTexture {
            index,
            scale: 1.0,
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        }),
        occlusion_texture: orm.map(|index| json::material::OcclusionTexture {
            index,
            strength: json::material::StrengthFactor(1.0),
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        }),
        ..Default::default()
    }
}

/// Unit tangents (xyz along +u) with handedness (w: ±1, the bitangent cross(N, T)·w runs
/// along +v of the mesh, up in the image — the normal maps' +Y) per output vertex, from
/// the UV gradients of the triangles around it, made orthogonal to the vertex normal.
/// Vertices without a usable UV gradient get any vector orthogonal to their normal.
fn tangents(part: &Part, data: &VertexData) -> Vec<[f32; 4]> {
    use glam::Vec3;
    let verts = &data.unified.vertices;
    let (mut t_acc, mut b_acc) = (vec![Vec3::ZERO; verts.len()], vec![Vec3::ZERO; verts.len()]);
    let cv = &data.unified.corner_vertex;
    for w in part.mesh.face_offsets.windows(2) {
        let Some(face) = cv.get(w[0] as usize..w[1] as usize) else { continue };
        let Some((&a, rest)) = face.split_first() else { continue };
        for pair in rest.windows(2) {
            let [ia, ib, ic] = [a, pair[0], pair[1]].map(|i| i as usize);
            let (pa, pb, pc) =
                (data.position(&verts[ia]), data.position(&verts[ib]), data.position(&verts[ic]));
            let (ua, ub, uc) = (data.uv(&verts[ia]), data.uv(&verts[ib]), data.uv(&verts[ic]));
            let (e1, e2) = (pb - pa, pc - pa);
            let (d1, d2) = (ub - ua, uc - ua);
            let det = d1.x * d2.y - d2.x * d1.y;
            if !det.is_finite() || det.abs() < 1e-20 {
                continue;
            }
            let r = 1.0 / det;
            let t = (e1 * d2.y - e2 * d1.y) * r;
            let b = (e2 * d1.x - e1 * d2.x) * r;
            if !(t.is_finite() && b.is_finite()) {
                continue;
            }
            for i in [ia, ib, ic] {
                t_acc[i] += t;
                b_acc[i] += b;
            }
        }
    }
    verts
        .iter()
        .enumerate()
        .map(|(i, k)| {
            let n = data.normal(k);
            let t = (t_acc[i] - n * n.dot(t_acc[i]))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(b_acc[i]) < 0.0 { -1.0 } else { 1.0 };
            [t.x, t.y, t.z, w]
        })
        .collect()
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
