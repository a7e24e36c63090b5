//! The document's layout: the root, the scene, instanced shapes, and the levels of a
//! model with a rig or LODs (one node per level, `MSFT_lod`), glTF2 §3.5.

use super::mesh::{
    grid, position_bounds, push_instanced_node, push_mesh, push_primitive, push_primitives, Dequant,
    Positions,
};
use super::rig::{push_rig, skin_entries, Channels, Skinning};
use super::textures::push_textures;
use super::{node, Doc, MSFT_LOD};
use crate::error::{Error, Result};
use crate::export::{ExportOptions, LodLayout, VertexData, GENERATOR};
use crate::model::{Model, Part};
use gltf_json as json;
use json::Index;

/// An empty document with sylva's `asset`.
pub(super) fn new_root() -> json::Root {
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
pub(super) fn no_triangles() -> Error {
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
pub(super) fn push_scene(root: &mut json::Root, model: &Model, nodes: Vec<Index<json::Node>>) -> Result<()> {
    let extras = match &model.provenance {
        Some(p) => Some(raw_json(serde_json::json!({ "sylva": { "recipe": p.recipe, "seed": p.seed } }))?),
        None => None,
    };
    let scene = root.push(json::Scene { name: Some("sylva".to_owned()), nodes, extensions: None, extras });
    root.scene = Some(scene);
    Ok(())
}

/// The shapes with instances and triangles, with their instances' transforms.
pub(super) fn instanced_shapes(model: &Model) -> Vec<(&Part, VertexData<'_>, Vec<glam::Mat4>)> {
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
pub(super) fn build_levels(
    model: &Model,
    options: &ExportOptions,
    glb: bool,
) -> Result<(json::Root, Vec<u8>)> {
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
        let (mesh, dequant) = push_primitives(&mut doc, level_name(k), primitives, positions);
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
