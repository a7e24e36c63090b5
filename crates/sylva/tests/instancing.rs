//! Instanced leaves and compressed glTF (issue 23): `leaves.mode = "instanced"` against
//! cards on the aspen — the instances reproduce the cards, the `.glb` validates and is
//! smaller — and `output.compress` (`KHR_mesh_quantization`, `EXT_meshopt_compression`).

mod common;

use common::gltf_validator::{assert_threejs_loads, assert_valid_gltf};
use glam::{Mat4, Quat, Vec3};
use std::path::PathBuf;
use std::sync::OnceLock;
use sylva::export::{self, Compression, ExportOptions, InstancingFallback};
use sylva::recipe;

fn set(key: &str, value: &str) -> (String, toml::Value) {
    (key.to_string(), toml::Value::String(value.to_string()))
}

fn grow(sets: &[(String, toml::Value)]) -> sylva::Model {
    let loaded = recipe::load("wp-quaking-aspen", sets).unwrap();
    sylva::pipeline::grow(&loaded).unwrap().model
}

/// The aspen with leaf cards and with instanced leaves (grown once for all tests).
fn aspens() -> &'static (sylva::Model, sylva::Model) {
    static ASPENS: OnceLock<(sylva::Model, sylva::Model)> = OnceLock::new();
    ASPENS.get_or_init(|| (grow(&[]), grow(&[set("leaves.mode", "instanced")])))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sylva-instancing-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Writes `model` to `name` as `options` say; returns the path and its size.
fn write(model: &sylva::Model, name: &str, options: &ExportOptions) -> (PathBuf, u64) {
    let path = scratch(name);
    export::write_with_options(model, &path, options).unwrap();
    let size = std::fs::metadata(&path).unwrap().len();
    (path, size)
}

fn glb_json(bytes: &[u8]) -> serde_json::Value {
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

/// The little-endian `f32` values of accessor `a` of a `.glb` (tightly packed floats).
fn floats(glb: &[u8], json: &serde_json::Value, a: u64) -> Vec<f32> {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin = &glb[20 + len + 8..];
    let acc = &json["accessors"][a as usize];
    let view = &json["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let n = view["byteLength"].as_u64().unwrap() as usize;
    bin[start..start + n].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
}

fn card_part(model: &sylva::Model) -> &sylva::Part {
    model.parts.iter().find(|p| p.name == "leaf_cards").expect("the cards model has leaf cards")
}

#[test]
fn instanced_leaves_reproduce_the_cards() {
    let (cards, instanced) = aspens();
    let card_mesh = &card_part(cards).mesh;
    assert!(instanced.parts.iter().all(|p| p.name != "leaf_cards"), "the cards became instances");
    assert_eq!(instanced.shapes.len(), 1);
    assert_eq!(instanced.shapes[0].name, "leaf_cards");
    assert_eq!(
        instanced.shapes[0].material,
        card_part(cards).material,
        "the shape keeps the textured material"
    );
    assert_eq!(instanced.instances.len() * 2, card_mesh.face_count(), "one instance per card");
    assert!(instanced.instances.iter().all(|i| i.node != sylva::NO_PARENT), "each instance knows its node");
    let merged = instanced.merged_instances();
    assert_eq!(merged.len(), 1);
    let m = &merged[0].mesh;
    assert_eq!(m.face_indices, card_mesh.face_indices);
    assert_eq!(m.positions.len(), card_mesh.positions.len());
    let worst = m.positions.iter().zip(&card_mesh.positions).map(|(a, b)| a.distance(*b)).fold(0.0, f32::max);
    println!("{} instances; worst corner distance {worst:e} m", instanced.instances.len());
    assert!(worst < 1e-5, "merged instances lie {worst} m from the cards");
    // Everything but the cards is the same model.
    let rest =
        |m: &sylva::Model| m.parts.iter().filter(|p| p.name != "leaf_cards").cloned().collect::<Vec<_>>();
    assert_eq!(rest(cards), rest(instanced));
    assert_eq!(cards.images, instanced.images);
}

#[test]
fn instanced_glb_validates_is_smaller_and_places_every_card() {
    let (cards, instanced) = aspens();
    let (cards_path, cards_size) = write(cards, "cards.glb", &ExportOptions::default());
    let (path, size) = write(instanced, "instanced.glb", &ExportOptions::default());
    let merged_opts = ExportOptions { instancing_fallback: InstancingFallback::Merged, ..Default::default() };
    let (merged_path, merged_size) = write(instanced, "merged.glb", &merged_opts);
    println!("aspen .glb: cards {cards_size} B, instanced {size} B, instanced with merged fallback {merged_size} B");
    assert!(size < cards_size, "instanced {size} B against cards {cards_size} B");
    assert!(
        merged_size.abs_diff(cards_size) * 100 < cards_size,
        "merged {merged_size} B, cards {cards_size} B"
    );
    assert_valid_gltf(&[&path, &merged_path, &cards_path]);
    assert_threejs_loads(&[&path, &merged_path]);

    let glb = std::fs::read(&path).unwrap();
    let json = glb_json(&glb);
    assert_eq!(json["extensionsUsed"], serde_json::json!(["EXT_mesh_gpu_instancing"]));
    assert!(json.get("extensionsRequired").is_none(), "instancing is not required");
    let nodes = json["nodes"].as_array().unwrap();
    let inst: Vec<&serde_json::Value> =
        nodes.iter().filter(|n| n["extensions"]["EXT_mesh_gpu_instancing"].is_object()).collect();
    assert_eq!(inst.len(), 1);
    let node = inst[0];
    assert_eq!(node["name"], "leaf_cards");
    let v3 = |v: &serde_json::Value| {
        Vec3::from_slice(
            &v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect::<Vec<_>>(),
        )
    };
    let q =
        node["rotation"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect::<Vec<_>>();
    let node_m = Mat4::from_scale_rotation_translation(
        v3(&node["scale"]),
        Quat::from_slice(&q),
        v3(&node["translation"]),
    );
    let attrs = &node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"];
    let t = floats(&glb, &json, attrs["TRANSLATION"].as_u64().unwrap());
    let r = floats(&glb, &json, attrs["ROTATION"].as_u64().unwrap());
    let s = floats(&glb, &json, attrs["SCALE"].as_u64().unwrap());
    assert_eq!(t.len() / 3, instanced.instances.len());
    // The shape's positions as written (float, shape space).
    let mesh = &json["meshes"][node["mesh"].as_u64().unwrap() as usize];
    let pos = floats(&glb, &json, mesh["primitives"][0]["attributes"]["POSITION"].as_u64().unwrap());
    let shape: Vec<Vec3> = pos.chunks_exact(3).map(Vec3::from_slice).collect();
    let cards_mesh = &card_part(cards).mesh;
    let mut worst = 0.0f32;
    for k in 0..t.len() / 3 {
        let rot = Quat::from_slice(&r[4 * k..4 * k + 4]);
        assert!((rot.length() - 1.0).abs() < 1e-5, "unit quaternion");
        let m = node_m
            * Mat4::from_scale_rotation_translation(
                Vec3::from_slice(&s[3 * k..]),
                rot,
                Vec3::from_slice(&t[3 * k..]),
            );
        // The shape's first two vertices are the card's base corners.
        for (c, p) in shape.iter().take(2).enumerate() {
            worst = worst.max(m.transform_point3(*p).distance(cards_mesh.positions[4 * k + c]));
        }
    }
    println!("glTF instances: worst base corner {worst:e} m");
    assert!(worst < 1e-4, "instances in the file lie {worst} m from the cards");
}

#[test]
fn obj_and_ply_merge_the_instances() {
    let (cards, instanced) = aspens();
    let mut a = Vec::new();
    let mut b = Vec::new();
    export::ply::write_ply(cards, &mut a).unwrap();
    export::ply::write_ply(instanced, &mut b).unwrap();
    let header = |x: &[u8]| {
        String::from_utf8_lossy(&x[..x.windows(10).position(|w| w == b"end_header").unwrap()]).into_owned()
    };
    assert_eq!(header(&a), header(&b), "same vertex and face counts, same part ranges");
    assert_eq!(a.len(), b.len());
    let mut obj = Vec::new();
    export::obj::write_obj(instanced, &mut obj, "t.mtl").unwrap();
    let text = String::from_utf8(obj).unwrap();
    assert!(text.contains("o leaf_cards"));
    let faces = text.split("o leaf_cards").nth(1).unwrap().lines().filter(|l| l.starts_with("f ")).count();
    assert_eq!(faces, card_part(cards).mesh.face_count());
}

#[test]
fn compressed_glb_validates_and_is_smaller() {
    let (cards, instanced) = aspens();
    let mut sizes = Vec::new();
    let mut paths = Vec::new();
    for (name, model) in [("cards", cards), ("instanced", instanced)] {
        for compress in [Compression::None, Compression::Quantize, Compression::Meshopt] {
            let opts = ExportOptions { compress, ..Default::default() };
            let (path, size) = write(model, &format!("{name}-{compress:?}.glb"), &opts);
            sizes.push((name, compress, size));
            paths.push(path);
        }
    }
    for (name, c, size) in &sizes {
        println!("aspen {name} compress={c:?}: {size} B");
    }
    for w in sizes.chunks(3) {
        assert!(w[1].2 < w[0].2 && w[2].2 < w[1].2, "each step is smaller: {w:?}");
    }
    // The JSON form too: the data URI buffer, and the fallback buffer without a URI.
    let opts = ExportOptions { compress: Compression::Meshopt, ..Default::default() };
    let (gltf_path, _) = write(instanced, "instanced-meshopt.gltf", &opts);
    assert_valid_gltf(&[&gltf_path]);
    assert_valid_gltf(&paths);
    // three.js decodes every variant (instances, quantization, meshopt) to the same
    // world-space boxes as the uncompressed cards, to the quantization step.
    if let Some(reports) = assert_threejs_loads(&paths) {
        let boxes: Vec<&serde_json::Value> = reports.iter().map(|r| &r["bounds"]).collect();
        for (b, path) in boxes.iter().zip(&paths) {
            for name in ["bark", "leaf_cards"] {
                let (x, y) = (&boxes[0][name], &b[name]);
                let pairs = x
                    .as_array()
                    .unwrap()
                    .iter()
                    .flat_map(|v| v.as_array().unwrap())
                    .zip(y.as_array().unwrap().iter().flat_map(|v| v.as_array().unwrap()));
                for (p, q) in pairs {
                    let d = (p.as_f64().unwrap() - q.as_f64().unwrap()).abs();
                    assert!(d < 1e-3, "{}: {name} box {y} against {x}", path.display());
                }
            }
        }
        assert_eq!(reports[4]["instances"], instanced.instances.len());
    }
    let glb = std::fs::read(&paths[2]).unwrap();
    let json = glb_json(&glb);
    let required = json["extensionsRequired"].as_array().unwrap();
    assert!(
        required.contains(&"KHR_mesh_quantization".into())
            && required.contains(&"EXT_meshopt_compression".into())
    );
}

#[test]
fn bad_output_keys_are_clear_errors() {
    for (key, value) in
        [("output.compress", "zip"), ("output.instancing_fallback", "both"), ("leaves.mode", "instances")]
    {
        let e = recipe::load("lsys-honda-a", &[set(key, value)]).unwrap_err().to_string();
        assert!(e.contains(key.split('.').nth(1).unwrap()) && e.contains(value), "{key}: {e}");
    }
}
