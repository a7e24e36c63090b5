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
//! Instances and compression (issue 23, [`ExportOptions`]): each shape of
//! [`Model::shapes`] with instances is written once, on a node carrying
//! `EXT_mesh_gpu_instancing` (TRANSLATION, ROTATION, SCALE; extension used, not
//! required), or merged into ordinary parts with
//! [`InstancingFallback::Merged`]. [`Compression::Quantize`] writes
//! `KHR_mesh_quantization` (integer positions decoded by the node's transform, 8-bit
//! normals and tangents, 16-bit UVs where they lie in [0, 1]); [`Compression::Meshopt`]
//! also compresses every geometry view with `EXT_meshopt_compression` into a fallback
//! buffer without data. Both extensions are then required. docs/textures.md says which
//! readers honour them.
//!
//! Rig, wind and levels of detail (issue 24). A model with a [`crate::model::Rig`] or
//! with [`Model::lods`] is laid out differently (a model with neither keeps the layout
//! above, byte for byte): each level becomes one node at the scene root holding one mesh
//! with one primitive per non-empty part (a skinned mesh's node must be a root: the
//! validator's `NODE_SKINNED_MESH_NON_ROOT`), named `sylva` without levels, else
//! `sylva_LOD0`, `sylva_LOD1`, …
//!
//! - Levels: the LOD0 node carries `MSFT_lod` (`ids`: the nodes of LOD1…n; in
//!   `extensionsUsed`, not required) and `extras.MSFT_screencoverage`, one coverage per
//!   level, LOD0's ([`Model::lod0_coverage`]) first. With [`LodLayout::Msft`] only LOD0
//!   is in the scene; with [`LodLayout::Scene`] every level is. A level without triangles
//!   is a node without a mesh. Without a rig, quantized positions share one grid per
//!   level (the level node's transform decodes it), and instanced shapes hang under the
//!   LOD0 node.
//! - Rig: a node per joint, `joint_<i>` in [`crate::model::Rig::joints`] order, children
//!   following [`crate::model::Joint::parent`], translation `head − parent.head` (a root
//!   joint: `head`), rotation the identity (omitted); the root joints hang under one
//!   node `sylva_rig` at the scene root (one common root for the skin, in the scene with
//!   every level). One skin `sylva_rig`: every joint in rig order, inverse bind matrices
//!   (`MAT4 FLOAT`, the translations by `−head`) and `skeleton` the root joint (or
//!   `sylva_rig` where there are several). Every level node with a mesh has the skin and
//!   no transform. Every primitive has `JOINTS_0` (`UNSIGNED_BYTE` for up to 256 joints,
//!   else `UNSIGNED_SHORT`) and `WEIGHTS_0` (`FLOAT`): a joint listed twice is merged,
//!   weights are renormalized in `f32`, a zero weight has joint 0; a part without skin
//!   weights is bound wholly to joint 0. Instances are merged into parts (as
//!   [`InstancingFallback::Merged`]): a skinned mesh ignores node transforms.
//!   Compression keeps positions `FLOAT` in a rigged model (a skinned mesh cannot decode
//!   them with its node's transform); normals, tangents and UVs are quantized as usual,
//!   and meshopt compresses every view, the rig's and the clip's included.
//! - Clip ([`crate::model::Clip`]): one animation named after it, with one shared
//!   `FLOAT` time accessor (with `min`/`max`) and, per joint, a `LINEAR` sampler of unit
//!   quaternions (`VEC4 FLOAT`) and a channel on the joint's `rotation`. Every joint is
//!   animated, identity or not.
//! - Wind channels, where a part or shape has them (in either layout;
//!   [`crate::model::VertexAttributes`], per mesh position, fetched through each glTF
//!   vertex's position index): `_WIND` (`VEC4
//!   FLOAT`: trunk weight, branch weight, leaf flutter, phase) and `_PIVOT` (`VEC4
//!   FLOAT`: the branch anchor xyz in model space, the branch level w). With
//!   [`ExportOptions::wind_colors`], for shaders that cannot read custom attributes,
//!   also:
//!   - `COLOR_0`, `VEC4 UNSIGNED_BYTE` normalized, each value clamped to \[0, 1\] and
//!     stored as `round(255 · x)`: R = phase (`_WIND.w`), G = leaf flutter (`_WIND.z`),
//!     B = branch weight (`_WIND.y`), A = trunk weight (`_WIND.x`). Readers that use
//!     vertex colours (three.js does) tint the material by it.
//!   - `TEXCOORD_1`, `VEC2 FLOAT`: (trunk weight, branch weight), unclamped. A part
//!     without UVs then gets a `TEXCOORD_0` of zeros (glTF numbers sets without gaps).
//!
//! Output is deterministic: the same model gives byte-identical output.

use super::{
    validate_model, Compression, ExportOptions, InstancingFallback, LodLayout, TextureMode, VertexData,
    GENERATOR,
};
use crate::error::{Error, Result};
use crate::model::{Clip, Model, Part, Rig};
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

/// An empty document with sylva's `asset`.
fn new_root() -> json::Root {
    json::Root {
        asset: json::Asset {
            generator: Some(GENERATOR.to_owned()),
            version: "2.0".to_owned(),
            copyright: None,
            extensions: None,
            extras: Default::default(),
            min_version: None,
        },
        ..Default::default()
    }
}

/// The error for a model without a triangle to write.
fn no_triangles() -> Error {
    Error::InvalidGeometry {
        what: "model".into(),
        why: "no triangles to export (every part is empty)".into(),
    }
}

/// `value` as glTF `extras`.
fn raw_json(value: serde_json::Value) -> Result<Box<json::extras::RawValue>> {
    json::extras::RawValue::from_string(value.to_string())
        .map_err(|e| Error::InvalidGeometry { what: "model".into(), why: format!("glTF extras: {e}") })
}

/// Adds the scene `sylva` of `nodes` (its `extras` the model's provenance) as the
/// default scene.
fn push_scene(root: &mut json::Root, model: &Model, nodes: Vec<Index<json::Node>>) -> Result<()> {
    let extras = match &model.provenance {
        Some(p) => Some(raw_json(serde_json::json!({ "sylva": { "recipe": p.recipe, "seed": p.seed } }))?),
        None => None,
    };
    let scene = root.push(json::Scene { name: Some("sylva".to_owned()), nodes, extensions: None, extras });
    root.scene = Some(scene);
    Ok(())
}

/// The shapes with instances and triangles, with their instances' transforms.
fn instanced_shapes(model: &Model) -> Vec<(&Part, VertexData<'_>, Vec<glam::Mat4>)> {
    model
        .shapes
        .iter()
        .enumerate()
        .filter(|(_, s)| s.mesh.triangle_count() > 0)
        .map(|(k, s)| {
            let t: Vec<glam::Mat4> =
                model.instances.iter().filter(|i| i.shape as usize == k).map(|i| i.transform).collect();
            (s, VertexData::new(&s.mesh), t)
        })
        .filter(|(_, _, t)| !t.is_empty())
        .collect()
}

/// [`build`] for a model with a rig or levels of detail (see the module docs): one node
/// per level at the scene root, holding one mesh with a primitive per non-empty part;
/// the rig's joints under a `sylva_rig` node, its skin and its clip.
fn build_levels(model: &Model, options: &ExportOptions, glb: bool) -> Result<(json::Root, Vec<u8>)> {
    let rig = model.rig.as_ref();
    let levels: Vec<Vec<(&Part, VertexData)>> = std::iter::once(&model.parts)
        .chain(model.lods.iter().map(|l| &l.parts))
        .map(|parts| {
            parts
                .iter()
                .filter(|p| p.mesh.triangle_count() > 0)
                .map(|p| (p, VertexData::new(&p.mesh)))
                .collect()
        })
        .collect();
    // Empty for a rigged model, whose instances are merged.
    let shapes = instanced_shapes(model);
    if levels[0].is_empty() && shapes.is_empty() {
        return Err(no_triangles());
    }
    let level_name =
        |k: usize| if model.lods.is_empty() { "sylva".to_owned() } else { format!("sylva_LOD{k}") };
    let mut doc = Doc::new(new_root(), Vec::new(), options.compress);
    let texture_of = push_textures(&mut doc.root, &mut doc.bin, doc.buffer, model, &options.textures, glb)?;
    // `UNSIGNED_BYTE` joint indices where they fit.
    let small_joints = rig.map(|r| r.joints.len() <= 256);

    // One mesh per level; without a rig, quantized positions share one grid per level
    // (decoded by the level node's transform).
    let mut meshes: Vec<(Option<Index<json::Mesh>>, Option<Dequant>)> = Vec::with_capacity(levels.len());
    for (k, parts) in levels.iter().enumerate() {
        if parts.is_empty() {
            meshes.push((None, None));
            continue;
        }
        let positions = if doc.quantize() && rig.is_none() {
            let bounds = parts.iter().map(|(_, d)| position_bounds(d));
            let (lo, hi) = bounds.reduce(|(a, b), (c, d)| (a.min(c), b.max(d))).unwrap_or_default();
            Positions::Grid(grid(lo, hi))
        } else {
            Positions::Float
        };
        let mut primitives = Vec::with_capacity(parts.len());
        for (part, data) in parts {
            let skin = small_joints.map(|small| Skinning { entries: skin_entries(part), small });
            let channels = Channels { skin, ..Channels::wind(part, options) };
            primitives.push(push_primitive(&mut doc, part, data, &texture_of, positions, &channels)?);
        }
        let mesh = doc.root.push(json::Mesh {
            name: Some(level_name(k)),
            primitives,
            extensions: None,
            extras: Default::default(),
            weights: None,
        });
        let dequant = match positions {
            Positions::Grid(d) => Some(d),
            Positions::Float => None,
        };
        meshes.push((Some(mesh), dequant));
    }

    let rigged = rig.map(|r| push_rig(&mut doc, r, model.clip.as_ref())).transpose()?;

    // Instanced shapes (a model with levels but no rig) hang under LOD0's node.
    let mut children = Vec::with_capacity(shapes.len());
    for (shape, data, transforms) in &shapes {
        let (mesh, dequant) = push_mesh(&mut doc, shape, data, &texture_of, &Channels::wind(shape, options))?;
        children.push(push_instanced_node(&mut doc, shape, mesh, dequant, transforms, meshes[0].1)?);
    }

    // The level nodes, LOD0 first; LOD0 names the others with MSFT_lod.
    let base = doc.root.nodes.len();
    let ids: Vec<Index<json::Node>> = (1..levels.len()).map(|k| Index::new((base + k) as u32)).collect();
    for (k, &(mesh, dequant)) in meshes.iter().enumerate() {
        let kids = (k == 0 && !children.is_empty()).then(|| children.clone());
        let mut n = node(level_name(k), mesh, kids);
        if let Some(d) = dequant {
            n.translation = Some(d.offset.to_array());
            n.scale = Some([d.step; 3]);
        }
        if mesh.is_some() {
            n.skin = rigged.map(|(_, skin)| skin);
        }
        if k == 0 && !ids.is_empty() {
            let mut others = serde_json::Map::new();
            let ids: Vec<usize> = ids.iter().map(|i| i.value()).collect();
            others.insert(MSFT_LOD.into(), serde_json::json!({ "ids": ids }));
            n.extensions = Some(json::extensions::scene::Node { others });
            // One coverage per level, LOD0's included; f32s written at their shortest.
            let coverage: Vec<serde_json::Value> = std::iter::once(model.lod0_coverage)
                .chain(model.lods.iter().map(|l| l.screen_coverage))
                .map(|c| c.to_string().parse::<f64>().ok().and_then(serde_json::Number::from_f64).into())
                .collect();
            n.extras = Some(raw_json(serde_json::json!({ "MSFT_screencoverage": coverage }))?);
        }
        let index = doc.root.push(n);
        debug_assert_eq!(index.value(), base + k);
    }
    if !ids.is_empty() {
        doc.use_extension(MSFT_LOD, false);
    }
    let mut scene = vec![Index::new(base as u32)];
    if options.lod_layout == LodLayout::Scene {
        scene.extend(&ids);
    }
    scene.extend(rigged.map(|(top, _)| top));
    let mut root = doc.finish()?;
    push_scene(&mut root.0, model, scene)?;
    Ok(root)
}

/// The rig: a node per joint (`joint_<i>`, in rig order, its translation `head −
/// parent.head`, rotation the identity), the root joints under one `sylva_rig` node, the
/// skin (inverse bind matrices the translations by `−head`) and, with a clip, its
/// animation. Returns the `sylva_rig` node and the skin.
fn push_rig(doc: &mut Doc, rig: &Rig, clip: Option<&Clip>) -> Result<(Index<json::Node>, Index<json::Skin>)> {
    use json::accessor::Type as T;
    let ibm = rig.joints.iter().map(|j| glam::Mat4::from_translation(-j.head).to_cols_array());
    let ibm = doc.floats(ibm, T::Mat4, Layout::Data { stride: 64 }, None)?;
    let base = doc.root.nodes.len();
    let index = |j: usize| Index::<json::Node>::new((base + j) as u32);
    let mut children = vec![Vec::new(); rig.joints.len()];
    for (j, joint) in rig.joints.iter().enumerate() {
        if let Some(p) = joint.parent {
            children[p as usize].push(index(j));
        }
    }
    for (j, (joint, kids)) in rig.joints.iter().zip(children).enumerate() {
        let mut n = node(format!("joint_{j}"), None, (!kids.is_empty()).then_some(kids));
        let t = joint.parent.map_or(joint.head, |p| joint.head - rig.joints[p as usize].head);
        n.translation = Some(t.to_array());
        let pushed = doc.root.push(n);
        debug_assert_eq!(pushed, index(j));
    }
    let roots: Vec<Index<json::Node>> =
        (0..rig.joints.len()).filter(|&j| rig.joints[j].parent.is_none()).map(index).collect();
    let skeleton = if roots.len() == 1 { roots[0] } else { Index::new(doc.root.nodes.len() as u32) };
    let top = doc.root.push(node("sylva_rig".to_owned(), None, Some(roots)));
    let skin = doc.root.push(json::Skin {
        extensions: None,
        extras: Default::default(),
        inverse_bind_matrices: Some(ibm),
        joints: (0..rig.joints.len()).map(index).collect(),
        name: Some("sylva_rig".to_owned()),
        skeleton: Some(skeleton),
    });
    if let Some(clip) = clip {
        push_clip(doc, clip, &(0..rig.joints.len()).map(index).collect::<Vec<_>>())?;
    }
    Ok((top, skin))
}

/// The clip as one animation: one shared `FLOAT` time accessor (with its bounds), and per
/// joint a `LINEAR` sampler of unit quaternions and a `rotation` channel.
fn push_clip(doc: &mut Doc, clip: &Clip, joints: &[Index<json::Node>]) -> Result<()> {
    use json::accessor::Type as T;
    use json::animation::{Channel, Interpolation, Property, Sampler, Target};
    let (first, last) = (clip.times.first().copied().unwrap_or(0.0), clip.duration());
    let bounds = Some((json::Value::from(vec![first]), json::Value::from(vec![last])));
    let input = doc.floats(clip.times.iter().map(|&t| [t]), T::Scalar, Layout::Data { stride: 4 }, bounds)?;
    let (mut samplers, mut channels) = (Vec::new(), Vec::new());
    for (rotations, &node) in clip.rotations.iter().zip(joints) {
        let quats = rotations.iter().map(|q| q.normalize().to_array());
        let output = doc.floats(quats, T::Vec4, Layout::Data { stride: 16 }, None)?;
        let sampler = Index::new(samplers.len() as u32);
        samplers.push(Sampler {
            extensions: None,
            extras: Default::default(),
            input,
            interpolation: Valid(Interpolation::Linear),
            output,
        });
        channels.push(Channel {
            sampler,
            target: Target {
                extensions: None,
                extras: Default::default(),
                node,
                path: Valid(Property::Rotation),
            },
            extensions: None,
            extras: Default::default(),
        });
    }
    doc.root.push(json::Animation {
        extensions: None,
        extras: Default::default(),
        channels,
        name: Some(clip.name.clone()),
        samplers,
    });
    Ok(())
}

/// Skinning of one primitive: a cleaned-up entry per mesh position ([`skin_entry`]) and
/// whether the joint indices are written as `UNSIGNED_BYTE`.
struct Skinning {
    entries: Vec<([u16; 4], [f32; 4])>,
    small: bool,
}

/// What a primitive carries beyond position, normal, UV and tangent: skinning, and the
/// wind channels (per mesh position; empty when absent).
struct Channels<'a> {
    skin: Option<Skinning>,
    wind: &'a [[f32; 4]],
    pivot: &'a [[f32; 4]],
    /// Also pack the wind into `COLOR_0` and `TEXCOORD_1`.
    wind_colors: bool,
}

impl<'a> Channels<'a> {
    /// The wind channels of `part` (no skinning).
    fn wind(part: &'a Part, options: &ExportOptions) -> Self {
        Channels {
            skin: None,
            wind: &part.attributes.wind,
            pivot: &part.attributes.pivot,
            wind_colors: options.wind_colors,
        }
    }
}

/// A part's skin entries per mesh position; a part without skin weights is bound wholly
/// to joint 0.
fn skin_entries(part: &Part) -> Vec<([u16; 4], [f32; 4])> {
    match &part.skin {
        Some(s) => s.joints.iter().zip(&s.weights).map(|(&j, &w)| skin_entry(j, w)).collect(),
        None => vec![([0; 4], [1.0, 0.0, 0.0, 0.0]); part.mesh.positions.len()],
    }
}

/// One vertex's joints and weights as the glTF validator wants them: a joint listed twice
/// gets the sum of its weights, the non-zero weights come first and sum to 1 in `f32`
/// (to 1e-7 per weight, summed in order), and a zero weight has joint index 0.
fn skin_entry(joints: [u16; 4], weights: [f32; 4]) -> ([u16; 4], [f32; 4]) {
    let (mut j, mut w, mut n) = ([0u16; 4], [0f32; 4], 0);
    for (&jj, &ww) in joints.iter().zip(&weights) {
        if ww.is_nan() || ww <= 0.0 {
            continue;
        }
        match j[..n].iter().position(|&x| x == jj) {
            Some(k) => w[k] += ww,
            None => {
                (j[n], w[n]) = (jj, ww);
                n += 1;
            }
        }
    }
    let sum: f32 = w.iter().sum();
    if n == 0 || !sum.is_finite() {
        return ([0; 4], [1.0, 0.0, 0.0, 0.0]);
    }
    for x in &mut w[..n] {
        *x /= sum;
    }
    let largest = (0..n).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
    for _ in 0..4 {
        let err = 1.0 - w.iter().fold(0f32, |a, &x| a + x);
        if err.abs() <= 1e-7 * n as f32 {
            break;
        }
        w[largest] += err;
    }
    for k in 0..4 {
        if w[k] <= 0.0 {
            (j[k], w[k]) = (0, 0.0);
        }
    }
    (j, w)
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

/// How quantized positions decode: `p = offset + q · step` (the node's translation and
/// uniform scale, `KHR_mesh_quantization`).
#[derive(Debug, Clone, Copy)]
struct Dequant {
    offset: glam::Vec3,
    step: f32,
}

/// Writes one part's mesh (one primitive, with `channels`) and its material; returns the
/// mesh and, for quantized positions, how they decode (for the node that shows the mesh).
fn push_mesh(
    doc: &mut Doc,
    part: &Part,
    data: &VertexData,
    texture_of: &TextureIndex,
    channels: &Channels,
) -> Result<(Index<json::Mesh>, Option<Dequant>)> {
    let positions = if doc.quantize() {
        let (lo, hi) = position_bounds(data);
        Positions::Grid(grid(lo, hi))
    } else {
        Positions::Float
    };
    let primitive = push_primitive(doc, part, data, texture_of, positions, channels)?;
    let mesh = doc.root.push(json::Mesh {
        name: Some(part.name.clone()),
        primitives: vec![primitive],
        extensions: None,
        extras: Default::default(),
        weights: None,
    });
    let dequant = match positions {
        Positions::Grid(d) => Some(d),
        Positions::Float => None,
    };
    Ok((mesh, dequant))
}

/// How a primitive's positions are written.
#[derive(Debug, Clone, Copy)]
enum Positions {
    /// `FLOAT`.
    Float,
    /// `UNSIGNED_SHORT` on this grid (`KHR_mesh_quantization`).
    Grid(Dequant),
}

/// The bounds of a part's output vertices.
fn position_bounds(data: &VertexData) -> (glam::Vec3, glam::Vec3) {
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
    for k in &data.unified.vertices {
        lo = lo.min(data.position(k));
        hi = hi.max(data.position(k));
    }
    (lo, hi)
}

/// The uniform unsigned 16-bit grid over the box `lo`–`hi`.
fn grid(lo: glam::Vec3, hi: glam::Vec3) -> Dequant {
    let extent = (hi - lo).max_element();
    let step = if extent > 0.0 { extent / 65535.0 } else { 1.0 };
    Dequant { offset: lo, step }
}

/// Writes one part's primitive (positions as `positions` says, `channels` beyond the
/// usual attributes) and its material.
fn push_primitive(
    doc: &mut Doc,
    part: &Part,
    data: &VertexData,
    texture_of: &TextureIndex,
    positions: Positions,
    channels: &Channels,
) -> Result<json::mesh::Primitive> {
    use json::accessor::{ComponentType as C, Type as T};
    use json::mesh::Semantic;
    let verts = &data.unified.vertices;
    let count = verts.len();
    let mut attributes = std::collections::BTreeMap::new();
    let quantize = doc.quantize();
    let vertices = |stride| Layout::Vertices { stride };

    // POSITION, with its bounds.
    let (lo, hi) = position_bounds(data);
    let bounds = |v: glam::Vec3| json::Value::from(v.to_array().to_vec());
    if let Positions::Grid(Dequant { offset, step }) = positions {
        // Unsigned 16-bit on a uniform grid (padded to 8 bytes).
        let mut bytes = Vec::with_capacity(8 * count);
        let (mut qlo, mut qhi) = ([u16::MAX; 3], [0u16; 3]);
        for k in verts {
            let q = ((data.position(k) - offset) / step)
                .round()
                .clamp(glam::Vec3::ZERO, glam::Vec3::splat(65535.0));
            for (c, x) in q.to_array().into_iter().enumerate() {
                let x = x as u16;
                qlo[c] = qlo[c].min(x);
                qhi[c] = qhi[c].max(x);
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            bytes.extend_from_slice(&[0, 0]);
        }
        let view = doc.view(&bytes, count, vertices(8))?;
        let (min, max) = (json::Value::from(qlo.to_vec()), json::Value::from(qhi.to_vec()));
        let acc = doc.accessor(view, count, C::U16, T::Vec3, false, Some(min), Some(max));
        attributes.insert(Valid(Semantic::Positions), acc);
    } else {
        let positions = verts.iter().map(|k| data.position(k).to_array());
        let acc = doc.floats(positions, T::Vec3, vertices(12), Some((bounds(lo), bounds(hi))))?;
        attributes.insert(Valid(Semantic::Positions), acc);
    }

    // NORMAL, always unit length (8-bit normalized when quantized).
    if quantize {
        let bytes: Vec<u8> =
            verts.iter().flat_map(|k| snorm8(data.normal(k).extend(0.0).to_array())).collect();
        let view = doc.view(&bytes, count, vertices(4))?;
        let acc = doc.accessor(view, count, C::I8, T::Vec3, true, None, None);
        attributes.insert(Valid(Semantic::Normals), acc);
    } else {
        let normals = verts.iter().map(|k| data.normal(k).to_array());
        let acc = doc.floats(normals, T::Vec3, vertices(12), None)?;
        attributes.insert(Valid(Semantic::Normals), acc);
    }

    // TEXCOORD_0, v flipped to glTF's top-left origin; 16-bit normalized when quantized
    // and every UV lies in [0, 1] (repeating bark UVs stay float).
    if data.has_uvs() {
        let uvs: Vec<[f32; 2]> = verts.iter().map(|k| data.uv(k)).map(|uv| [uv.x, 1.0 - uv.y]).collect();
        if quantize && uvs.iter().flatten().all(|x| (0.0..=1.0).contains(x)) {
            let bytes: Vec<u8> =
                uvs.iter().flatten().flat_map(|&x| ((x * 65535.0).round() as u16).to_le_bytes()).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            let acc = doc.accessor(view, count, C::U16, T::Vec2, true, None, None);
            attributes.insert(Valid(Semantic::TexCoords(0)), acc);
        } else {
            let acc = doc.floats(uvs.into_iter(), T::Vec2, vertices(8), None)?;
            attributes.insert(Valid(Semantic::TexCoords(0)), acc);
        }
    }

    // TANGENT where a normal map will be read (so no runtime has to guess one).
    if map_texture(part.material.maps.normal, data.has_uvs(), texture_of).is_some() {
        let t = tangents(part, data);
        let acc = if quantize {
            let bytes: Vec<u8> = t.iter().flat_map(|&v| snorm8(v)).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            doc.accessor(view, count, C::I8, T::Vec4, true, None, None)
        } else {
            doc.floats(t.into_iter(), T::Vec4, vertices(16), None)?
        };
        attributes.insert(Valid(Semantic::Tangents), acc);
    }

    // Skinning: JOINTS_0 (8- or 16-bit) and WEIGHTS_0 per mesh position.
    let at = |k: &super::VertexKey| k.position as usize;
    if let Some(skin) = &channels.skin {
        let none = ([0u16; 4], [1.0, 0.0, 0.0, 0.0]);
        let entry = |k: &super::VertexKey| skin.entries.get(at(k)).copied().unwrap_or(none);
        let acc = if skin.small {
            let bytes: Vec<u8> = verts.iter().flat_map(|k| entry(k).0.map(|j| j as u8)).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            doc.accessor(view, count, C::U8, T::Vec4, false, None, None)
        } else {
            let bytes: Vec<u8> = verts.iter().flat_map(|k| entry(k).0).flat_map(u16::to_le_bytes).collect();
            let view = doc.view(&bytes, count, vertices(8))?;
            doc.accessor(view, count, C::U16, T::Vec4, false, None, None)
        };
        attributes.insert(Valid(Semantic::Joints(0)), acc);
        let acc = doc.floats(verts.iter().map(|k| entry(k).1), T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Weights(0)), acc);
    }

    // The wind channels: `_WIND`, `_PIVOT` and, packed for shaders, COLOR_0 / TEXCOORD_1.
    let value = |ch: &[[f32; 4]], k: &super::VertexKey| ch.get(at(k)).copied().unwrap_or([0.0; 4]);
    if !channels.wind.is_empty() {
        let wind = verts.iter().map(|k| value(channels.wind, k));
        let acc = doc.floats(wind, T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Extras("WIND".into())), acc);
        if channels.wind_colors {
            let unorm8 = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
            let bytes: Vec<u8> = verts
                .iter()
                .flat_map(|k| {
                    let w = value(channels.wind, k);
                    [w[3], w[2], w[1], w[0]].map(unorm8)
                })
                .collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            let acc = doc.accessor(view, count, C::U8, T::Vec4, true, None, None);
            attributes.insert(Valid(Semantic::Colors(0)), acc);
            let trunk_branch = verts.iter().map(|k| value(channels.wind, k)).map(|w| [w[0], w[1]]);
            let acc = doc.floats(trunk_branch, T::Vec2, vertices(8), None)?;
            attributes.insert(Valid(Semantic::TexCoords(1)), acc);
            // glTF numbers texture coordinate sets without gaps: a part without UVs gets
            // zero TEXCOORD_0, so the wind stays in set 1 on every primitive.
            if !data.has_uvs() {
                let acc = doc.floats(verts.iter().map(|_| [0.0f32; 2]), T::Vec2, vertices(8), None)?;
                attributes.insert(Valid(Semantic::TexCoords(0)), acc);
            }
        }
    }
    if !channels.pivot.is_empty() {
        let pivot = verts.iter().map(|k| value(channels.pivot, k));
        let acc = doc.floats(pivot, T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Extras("PIVOT".into())), acc);
    }

    // Indices: every face fan-triangulated, u16 where every index fits.
    let short = count < 65_536;
    let mut bytes = Vec::with_capacity(part.mesh.triangle_count() * if short { 6 } else { 12 });
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
            put(&mut bytes, first);
            put(&mut bytes, pair[0]);
            put(&mut bytes, pair[1]);
        }
    }
    let size = if short { 2 } else { 4 };
    let index_count = bytes.len() / size;
    let view = doc.view(&bytes, index_count, Layout::Triangles { size })?;
    let indices =
        doc.accessor(view, index_count, if short { C::U16 } else { C::U32 }, T::Scalar, false, None, None);

    let material = doc.root.push(material(&part.material, data.has_uvs(), texture_of));
    Ok(json::mesh::Primitive {
        attributes,
        extensions: None,
        extras: Default::default(),
        indices: Some(indices),
        material: Some(material),
        mode: Valid(json::mesh::Mode::Triangles),
        targets: None,
    })
}

/// A unit vector's components as `BYTE` normalized (`round(f · 127)`).
fn snorm8(v: [f32; 4]) -> [u8; 4] {
    v.map(|x| ((x.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8)
}

/// Translation, rotation (unit quaternion) and scale of `m`, or `None` where its
/// columns are not orthogonal (a shear, which `EXT_mesh_gpu_instancing` cannot store).
fn trs(m: glam::DMat4) -> Option<([f64; 3], [f64; 4], [f64; 3])> {
    let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let (lx, ly, lz) = (x.length(), y.length(), z.length());
    let orthogonal = |a: glam::DVec3, b: glam::DVec3, la: f64, lb: f64| a.dot(b).abs() <= 1e-4 * la * lb;
    let positive = lx > 0.0 && ly > 0.0 && lz > 0.0;
    if !(positive && orthogonal(x, y, lx, ly) && orthogonal(y, z, ly, lz) && orthogonal(x, z, lx, lz)) {
        return None;
    }
    let (s, r, t) = m.to_scale_rotation_translation();
    let r = r.normalize();
    r.is_finite().then_some((t.to_array(), r.to_array(), s.to_array()))
}

/// Whether the scale of `m` is the same along its three axes (to 1e-4).
fn uniform_scale(m: &glam::DMat4) -> bool {
    let l = [m.x_axis.truncate().length(), m.y_axis.truncate().length(), m.z_axis.truncate().length()];
    let (lo, hi) = (l.iter().copied().fold(f64::INFINITY, f64::min), l.iter().copied().fold(0.0, f64::max));
    hi - lo <= 1e-4 * hi
}

/// The node showing `mesh` (shape `shape`) once per transform with
/// `EXT_mesh_gpu_instancing`: `TRANSLATION`, `ROTATION` (unit quaternions) and `SCALE`
/// as `FLOAT` accessors. Where every instance scales uniformly the node's own transform
/// is the first instance's and the instances are relative to it, so a reader without
/// the extension, which draws the mesh once at the node, shows the first copy in its
/// place; otherwise the node has no transform. Quantized positions decode inside each
/// instance's transform. `parent`: the grid the parent node's transform decodes (a
/// level node of quantized positions), undone by this node's transform.
fn push_instanced_node(
    doc: &mut Doc,
    shape: &Part,
    mesh: Index<json::Mesh>,
    dequant: Option<Dequant>,
    transforms: &[glam::Mat4],
    parent: Option<Dequant>,
) -> Result<Index<json::Node>> {
    use glam::DMat4;
    let decode = dequant.map_or(DMat4::IDENTITY, |d| {
        DMat4::from_translation(d.offset.as_dvec3()) * DMat4::from_scale(glam::DVec3::splat(d.step as f64))
    });
    let all: Vec<DMat4> = transforms.iter().map(|m| m.as_dmat4()).collect();
    let base =
        all.first().copied().filter(|_| all.iter().all(uniform_scale)).and_then(|m| trs(m).map(|t| (m, t)));
    let inverse = base.map_or(DMat4::IDENTITY, |(m, _)| m.inverse());
    let bad = |k: usize| Error::InvalidGeometry {
        what: format!("instance {k} of shape '{}'", shape.name),
        why:
            "its transform is not translation × rotation × scale (EXT_mesh_gpu_instancing stores only those)"
                .into(),
    };
    let (mut t, mut r, mut s) = (Vec::new(), Vec::new(), Vec::new());
    for (k, m) in all.iter().enumerate() {
        let (tk, rk, sk) = trs(inverse * *m * decode).ok_or_else(|| bad(k))?;
        t.push(tk.map(|x| x as f32));
        r.push(rk.map(|x| x as f32));
        s.push(sk.map(|x| x as f32));
    }
    use json::accessor::Type as T;
    let (lo, hi) = t.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
        (std::array::from_fn(|c| lo[c].min(p[c])), std::array::from_fn(|c| hi[c].max(p[c])))
    });
    let bounds = Some((json::Value::from(lo.to_vec()), json::Value::from(hi.to_vec())));
    let translation = doc.floats(t.into_iter(), T::Vec3, Layout::Instances { stride: 12 }, bounds)?;
    let rotation = doc.floats(r.into_iter(), T::Vec4, Layout::Instances { stride: 16 }, None)?;
    let scale = doc.floats(s.into_iter(), T::Vec3, Layout::Instances { stride: 12 }, None)?;
    doc.use_extension(INSTANCING, false);
    let mut n = node(shape.name.clone(), Some(mesh), None);
    // The node's own transform: the first instance's, relative to the parent's grid.
    let own = match (base, parent) {
        (base, None) => base.map(|(_, t)| t),
        (base, Some(p)) => {
            let undo = DMat4::from_scale(glam::DVec3::splat(1.0 / p.step as f64))
                * DMat4::from_translation(-p.offset.as_dvec3());
            Some(trs(undo * base.map_or(DMat4::IDENTITY, |(m, _)| m)).ok_or_else(|| bad(0))?)
        }
    };
    if let Some((tt, rr, ss)) = own {
        n.translation = Some(tt.map(|x| x as f32));
        n.rotation = Some(json::scene::UnitQuaternion(rr.map(|x| x as f32)));
        n.scale = Some(ss.map(|x| x as f32));
    }
    let mut others = serde_json::Map::new();
    others.insert(
        INSTANCING.into(),
        serde_json::json!({ "attributes": {
            "TRANSLATION": translation.value(),
            "ROTATION": rotation.value(),
            "SCALE": scale.value(),
        }}),
    );
    n.extensions = Some(json::extensions::scene::Node { others });
    Ok(doc.root.push(n))
}

/// With `output.compress = "meshopt"`: the `EXT_meshopt_compression` encoding of a
/// view's bytes (vertex codec version 0, the extension's; index codec version 1, header
/// `0xe1`) and the extension's `byteStride`, `count` and `mode` (the caller adds
/// `buffer`, `byteOffset` and `byteLength`).
fn meshopt_encode(
    bytes: &[u8],
    count: usize,
    layout: Layout,
) -> Result<(Vec<u8>, serde_json::Map<String, serde_json::Value>)> {
    let failed = |e: meshopt::Error| Error::InvalidGeometry {
        what: "model".into(),
        why: format!("meshopt compression failed: {e:?}"),
    };
    let (encoded, stride, mode) = match layout {
        Layout::Vertices { stride } | Layout::Instances { stride } | Layout::Data { stride } => {
            let encoded = match stride {
                4 => meshopt_attributes::<4>(bytes),
                8 => meshopt_attributes::<8>(bytes),
                12 => meshopt_attributes::<12>(bytes),
                16 => meshopt_attributes::<16>(bytes),
                64 => meshopt_attributes::<64>(bytes),
                _ => {
                    return Err(Error::InvalidGeometry {
                        what: "model".into(),
                        why: format!("meshopt: no attribute codec for {stride}-byte elements"),
                    })
                }
            };
            (encoded.map_err(failed)?, stride, "ATTRIBUTES")
        }
        Layout::Triangles { size } => {
            let indices: Vec<u32> = match size {
                2 => bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]]) as u32).collect(),
                _ => bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
            };
            let vertices = indices.iter().max().map_or(0, |&m| m as usize + 1);
            // meshopt's default index codec is version 1; its header byte is 0xe1.
            let encoded = meshopt::encoding::encode_index_buffer(&indices, vertices).map_err(failed)?;
            if encoded.first() != Some(&0xe1) {
                return Err(Error::InvalidGeometry {
                    what: "model".into(),
                    why: "meshopt wrote an index stream EXT_meshopt_compression cannot read".into(),
                });
            }
            (encoded, size, "TRIANGLES")
        }
    };
    let mut ext = serde_json::Map::new();
    ext.insert("byteStride".into(), stride.into());
    ext.insert("count".into(), count.into());
    ext.insert("mode".into(), mode.into());
    Ok((encoded, ext))
}

/// `bytes` as elements of `N` bytes through meshopt's attribute codec, version 0 (the one
/// `EXT_meshopt_compression` specifies).
fn meshopt_attributes<const N: usize>(bytes: &[u8]) -> std::result::Result<Vec<u8>, meshopt::Error> {
    let (elements, _) = bytes.as_chunks::<N>();
    meshopt::encoding::encode_vertex_buffer_level(elements, 2, Some(0))
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
