//! glTF export of a rig, its wind clip, the wind shader channels and levels of detail
//! (issue 24), on hand-made models: the Khronos validator, the JSON layout, the binary
//! data read back, three.js playing the clip and Blender importing the rig.

mod common;

use common::gltf_validator::assert_valid_gltf;
use common::rig_tools::{blender_rig, threejs_wind};
use glam::{Mat4, Quat, Vec2, Vec3};
use serde_json::Value;
use std::path::PathBuf;
use sylva::export::gltf::{to_glb, to_glb_with};
use sylva::export::{self, Compression, ExportOptions, LodLayout};
use sylva::geometry::FaceVarying;
use sylva::model::{Clip, Instance, Joint, Lod, Rig, SkinWeights};
use sylva::{Error, Material, Mesh, Model, Part};

/// A fresh, empty scratch folder for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sylva-rig-export-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Sides of the tubes.
const SIDES: usize = 6;
/// The clip's length in seconds.
const DURATION: f32 = 2.0;

/// An open vertical tube of radius 0.1 with a ring at each height, quads between rings,
/// and UVs with a seam (column `SIDES` repeats column 0's positions), so glTF splits
/// the seam's vertices.
fn tube(heights: &[f32]) -> Mesh {
    let mut m = Mesh::new();
    let mut uv = FaceVarying::<Vec2>::default();
    for (r, &y) in heights.iter().enumerate() {
        for i in 0..SIDES {
            let a = i as f32 / SIDES as f32 * std::f32::consts::TAU;
            m.positions.push(Vec3::new(0.1 * a.cos(), y, 0.1 * a.sin()));
        }
        for i in 0..=SIDES {
            uv.values.push(Vec2::new(i as f32 / SIDES as f32, r as f32 / (heights.len() - 1) as f32));
        }
    }
    for r in 0..heights.len() - 1 {
        for i in 0..SIDES {
            let p = |r: usize, i: usize| (r * SIDES + i % SIDES) as u32;
            let t = |r: usize, i: usize| (r * (SIDES + 1) + i) as u32;
            m.push_face(&[p(r, i), p(r + 1, i), p(r + 1, i + 1), p(r, i + 1)]);
            uv.indices.extend([t(r, i), t(r + 1, i), t(r + 1, i + 1), t(r, i + 1)]);
        }
    }
    m.uvs = Some(uv);
    m
}

/// A quad in the XY plane from `(x0, y0)` to `(x1, y1)`.
fn quad(x0: f32, y0: f32, x1: f32, y1: f32) -> Mesh {
    let mut m = Mesh::new();
    m.positions =
        vec![Vec3::new(x0, y0, 0.0), Vec3::new(x1, y0, 0.0), Vec3::new(x1, y1, 0.0), Vec3::new(x0, y1, 0.0)];
    m.push_face(&[0, 1, 2, 3]);
    m
}

/// The rig: joints at heights 0 (root), 0.7 and 1.4 on the y axis, a chain.
fn rig() -> Rig {
    Rig {
        joints: vec![
            Joint { node: 0, parent: None, head: Vec3::ZERO },
            Joint { node: 2, parent: Some(0), head: Vec3::new(0.0, 0.7, 0.0) },
            Joint { node: 4, parent: Some(1), head: Vec3::new(0.0, 1.4, 0.0) },
        ],
    }
}

/// Skin weights of a tube vertex at height `y`, some unnormalized and some with a
/// joint listed twice (the writer cleans both up).
fn skin_at(y: f32) -> ([u16; 4], [f32; 4]) {
    if y < 0.25 {
        ([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
    } else if y < 0.75 {
        ([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0])
    } else if y < 1.25 {
        ([1, 2, 0, 0], [0.6, 0.4, 0.0, 0.0])
    } else if y < 1.75 {
        ([2, 2, 1, 0], [0.3, 0.3, 0.2, 0.0])
    } else {
        ([2, 1, 0, 0], [3.0, 0.0, 0.0, 0.0])
    }
}

/// Skin weights for every position of `mesh` by height.
fn skin_of(mesh: &Mesh) -> SkinWeights {
    let (joints, weights) = mesh.positions.iter().map(|p| skin_at(p.y)).unzip();
    SkinWeights { joints, weights }
}

/// A part of `mesh` skinned by height, with wind (trunk y/2, branch y/4, leaf 0.5, phase
/// 0.25) and pivot (origin, level 0) channels.
fn skinned_part(name: &str, mesh: Mesh, material: Material) -> Part {
    let mut part = Part::new(name, mesh, material);
    part.skin = Some(skin_of(&part.mesh));
    part.attributes.wind = part.mesh.positions.iter().map(|p| [p.y / 2.0, p.y / 4.0, 0.5, 0.25]).collect();
    part.attributes.pivot =
        part.mesh.positions.iter().map(|p| [0.0, 0.0, 0.0, (p.y > 1.0) as u8 as f32]).collect();
    part
}

/// The clip: joint 0 still, joints 1 and 2 swaying about z by 0.2 and 0.3 rad, five
/// samples over [`DURATION`] (the last equals the first).
fn clip() -> Clip {
    let times: Vec<f32> = (0..5).map(|i| i as f32 * DURATION / 4.0).collect();
    let sway = |amp: f32| -> Vec<Quat> {
        times
            .iter()
            .map(|t| Quat::from_rotation_z(amp * (std::f32::consts::TAU * t / DURATION).sin()))
            .collect()
    };
    Clip {
        name: "wind".into(),
        rotations: vec![vec![Quat::IDENTITY; times.len()], sway(0.2), sway(0.3)],
        times,
    }
}

/// The hand-made tree: a skinned bark tube (height 2) with wind channels, a skinned leaf
/// quad at the top, an unskinned stub near the base (bound to joint 0), the rig and the
/// clip; LOD1 a coarser skinned tube, LOD2 an unskinned billboard.
fn rigged_model() -> Model {
    let bark = skinned_part("bark", tube(&[0.0, 0.5, 1.0, 1.5, 2.0]), Material::bark());
    let leaves = skinned_part("leaves", quad(-0.2, 1.8, 0.2, 2.2), Material::leaf());
    let stub = Part::new("stub", quad(0.1, 0.1, 0.3, 0.2), Material::bark());
    let lod1 = skinned_part("bark", tube(&[0.0, 1.0, 2.0]), Material::bark());
    let lod2 = Part::new("billboard", quad(-0.5, 0.0, 0.5, 2.1), Material::leaf());
    Model {
        parts: vec![bark, leaves, stub],
        rig: Some(rig()),
        clip: Some(clip()),
        lods: vec![
            Lod { parts: vec![lod1], screen_coverage: 0.1 },
            Lod { parts: vec![lod2], screen_coverage: 0.02 },
        ],
        lod0_coverage: 0.4,
        ..Default::default()
    }
}

/// Export options.
fn options(layout: LodLayout, wind_colors: bool, compress: Compression) -> ExportOptions {
    ExportOptions { lod_layout: layout, wind_colors, compress, ..Default::default() }
}

/// A GLB split into its JSON and binary chunk.
fn split_glb(glb: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |o: usize| u32::from_le_bytes(glb[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&glb[..4], b"glTF");
    let json_len = u32_at(12);
    let json: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin_len = u32_at(bin_at);
    (json, glb[bin_at + 8..bin_at + 8 + bin_len].to_vec())
}

/// An uncompressed accessor's components as `f64` (normalized integers as integers).
fn read_accessor(json: &Value, bin: &[u8], accessor: usize) -> Vec<Vec<f64>> {
    let a = &json["accessors"][accessor];
    let view = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    assert_eq!(view["buffer"], 0, "uncompressed data only");
    let count = a["count"].as_u64().unwrap() as usize;
    let n = match a["type"].as_str().unwrap() {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT4" => 16,
        t => panic!("type {t}"),
    };
    let ct = a["componentType"].as_u64().unwrap();
    let size = match ct {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    };
    let stride = view["byteStride"].as_u64().map_or(n * size, |s| s as usize);
    let start =
        view["byteOffset"].as_u64().unwrap_or(0) as usize + a["byteOffset"].as_u64().unwrap_or(0) as usize;
    (0..count)
        .map(|i| {
            (0..n)
                .map(|c| {
                    let o = start + i * stride + c * size;
                    let b = &bin[o..o + size];
                    match ct {
                        5120 => b[0] as i8 as f64,
                        5121 => b[0] as f64,
                        5122 => i16::from_le_bytes([b[0], b[1]]) as f64,
                        5123 => u16::from_le_bytes([b[0], b[1]]) as f64,
                        5125 => u32::from_le_bytes(b.try_into().unwrap()) as f64,
                        5126 => f32::from_le_bytes(b.try_into().unwrap()) as f64,
                        _ => panic!("component type {ct}"),
                    }
                })
                .collect()
        })
        .collect()
}

/// The index of the node called `name`.
fn node_named(json: &Value, name: &str) -> usize {
    json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["name"] == name)
        .unwrap_or_else(|| panic!("no node {name}"))
}

/// The default scene's root nodes.
fn scene_nodes(json: &Value) -> Vec<u64> {
    json["scenes"][0]["nodes"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap()).collect()
}

#[test]
fn rigged_lod_files_are_valid_in_every_layout_and_compression() {
    let dir = scratch("valid");
    let model = rigged_model();
    let mut paths = Vec::new();
    for layout in [LodLayout::Msft, LodLayout::Scene] {
        for colors in [false, true] {
            for compress in [Compression::None, Compression::Quantize, Compression::Meshopt] {
                let o = options(layout, colors, compress);
                let path = dir.join(format!("tree-{layout:?}-{colors}-{compress:?}.glb"));
                export::write_with_options(&model, &path, &o).unwrap();
                paths.push(path);
            }
        }
    }
    let gltf = dir.join("tree.gltf");
    export::write_with_options(&model, &gltf, &options(LodLayout::Msft, true, Compression::None)).unwrap();
    paths.push(gltf);
    // A rig without LODs, and LODs without a rig.
    let no_lods = Model { lods: Vec::new(), ..rigged_model() };
    let no_rig = Model {
        rig: None,
        clip: None,
        parts: strip_skins(&model.parts),
        lods: strip_lod_skins(&model.lods),
        ..rigged_model()
    };
    // Two root joints (the skeleton is then sylva_rig), and a clip of one sample.
    let mut two_roots = rigged_model();
    two_roots.rig.as_mut().unwrap().joints.push(Joint {
        node: 9,
        parent: None,
        head: Vec3::new(0.5, 0.0, 0.0),
    });
    let c = two_roots.clip.as_mut().unwrap();
    c.rotations.push(vec![Quat::IDENTITY; c.times.len()]);
    let mut one_sample = rigged_model();
    let c = one_sample.clip.as_mut().unwrap();
    c.times.truncate(1);
    c.rotations.iter_mut().for_each(|r| r.truncate(1));
    for (name, m) in
        [("no-lods", &no_lods), ("no-rig", &no_rig), ("two-roots", &two_roots), ("one-sample", &one_sample)]
    {
        for compress in [Compression::None, Compression::Meshopt] {
            let path = dir.join(format!("{name}-{compress:?}.glb"));
            export::write_with_options(m, &path, &options(LodLayout::Msft, true, compress)).unwrap();
            paths.push(path);
        }
    }
    assert_valid_gltf(&paths);
    let _ = std::fs::remove_dir_all(&dir);
}

/// `parts` without skin weights.
fn strip_skins(parts: &[Part]) -> Vec<Part> {
    parts.iter().map(|p| Part { skin: None, ..p.clone() }).collect()
}

/// `lods` without skin weights.
fn strip_lod_skins(lods: &[Lod]) -> Vec<Lod> {
    lods.iter().map(|l| Lod { parts: strip_skins(&l.parts), ..l.clone() }).collect()
}

#[test]
fn json_has_the_skin_clip_lods_and_wind_channels() {
    for layout in [LodLayout::Msft, LodLayout::Scene] {
        let glb = to_glb_with(&rigged_model(), &options(layout, true, Compression::None)).unwrap();
        let (json, _) = split_glb(&glb);
        let nodes = json["nodes"].as_array().unwrap();
        let lod = [0, 1, 2].map(|k| node_named(&json, &format!("sylva_LOD{k}")));
        let rig = node_named(&json, "sylva_rig");
        let joints = [0, 1, 2].map(|j| node_named(&json, &format!("joint_{j}")));

        // Skin: every joint in order, MAT4 inverse bind matrices, the root joint as skeleton.
        let skins = json["skins"].as_array().unwrap();
        assert_eq!(skins.len(), 1);
        let skin = &skins[0];
        let skin_joints: Vec<usize> =
            skin["joints"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as usize).collect();
        assert_eq!(skin_joints, joints.to_vec());
        assert_eq!(skin["skeleton"], joints[0]);
        let ibm = &json["accessors"][skin["inverseBindMatrices"].as_u64().unwrap() as usize];
        assert_eq!(
            (ibm["type"].as_str(), ibm["componentType"].as_u64(), ibm["count"].as_u64()),
            (Some("MAT4"), Some(5126), Some(3))
        );

        // Joint hierarchy: the chain under sylva_rig, translations head − parent.head.
        assert_eq!(nodes[rig]["children"], serde_json::json!([joints[0]]));
        assert_eq!(nodes[joints[0]]["children"], serde_json::json!([joints[1]]));
        assert_eq!(nodes[joints[1]]["children"], serde_json::json!([joints[2]]));
        let t: Vec<f32> = nodes[joints[2]]["translation"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap() as f32)
            .collect();
        assert_eq!(t, [0.0, 0.7, 0.0], "head − parent.head");
        assert!(nodes[joints[1]].get("rotation").is_none(), "identity rotation omitted");

        // Animation: one per clip, a channel and a sampler per joint, on rotation.
        let anims = json["animations"].as_array().unwrap();
        assert_eq!(anims.len(), 1);
        assert_eq!(anims[0]["name"], "wind");
        let channels = anims[0]["channels"].as_array().unwrap();
        assert_eq!(channels.len(), 3);
        assert_eq!(anims[0]["samplers"].as_array().unwrap().len(), 3);
        for (c, &j) in channels.iter().zip(&joints) {
            assert_eq!(c["target"]["path"], "rotation");
            assert_eq!(c["target"]["node"], j);
        }
        let input = &json["accessors"][anims[0]["samplers"][0]["input"].as_u64().unwrap() as usize];
        assert_eq!((input["min"][0].as_f64(), input["max"][0].as_f64()), (Some(0.0), Some(DURATION as f64)));

        // Levels: one node per level, MSFT_lod on LOD0 with a coverage per level.
        assert_eq!(nodes[lod[0]]["extensions"]["MSFT_lod"]["ids"], serde_json::json!([lod[1], lod[2]]));
        assert_eq!(nodes[lod[0]]["extras"]["MSFT_screencoverage"], serde_json::json!([0.4, 0.1, 0.02]));
        let used = json["extensionsUsed"].as_array().unwrap();
        assert!(used.contains(&Value::from("MSFT_lod")));
        assert!(json
            .get("extensionsRequired")
            .is_none_or(|r| !r.as_array().unwrap().contains(&Value::from("MSFT_lod"))));
        for &k in &lod {
            assert_eq!(nodes[k]["skin"], 0, "every level is skinned");
            assert!(nodes[k].get("translation").is_none() && nodes[k].get("children").is_none());
        }
        let scene = scene_nodes(&json);
        assert!(scene.contains(&(lod[0] as u64)) && scene.contains(&(rig as u64)));
        let lod1_in_scene = scene.contains(&(lod[1] as u64)) && scene.contains(&(lod[2] as u64));
        assert_eq!(lod1_in_scene, layout == LodLayout::Scene, "{layout:?}: {scene:?}");
        assert!(!scene.contains(&(joints[0] as u64)), "joints hang under sylva_rig");

        // Primitives: one per non-empty part; all skinned; bark and leaves have wind.
        let lod0 = &json["meshes"][nodes[lod[0]]["mesh"].as_u64().unwrap() as usize];
        assert_eq!(lod0["name"], "sylva_LOD0");
        let prims = lod0["primitives"].as_array().unwrap();
        assert_eq!(prims.len(), 3);
        for (p, wind) in prims.iter().zip([true, true, false]) {
            let a = &p["attributes"];
            assert!(a.get("JOINTS_0").is_some() && a.get("WEIGHTS_0").is_some(), "{a}");
            for key in ["_WIND", "_PIVOT", "COLOR_0", "TEXCOORD_1"] {
                assert_eq!(a.get(key).is_some(), wind, "{key}: {a}");
            }
            let joints = &json["accessors"][a["JOINTS_0"].as_u64().unwrap() as usize];
            assert_eq!(
                (joints["componentType"].as_u64(), joints["type"].as_str()),
                (Some(5121), Some("VEC4"))
            );
        }
        let color = &json["accessors"][prims[0]["attributes"]["COLOR_0"].as_u64().unwrap() as usize];
        assert_eq!(
            (color["componentType"].as_u64(), color["normalized"].as_bool()),
            (Some(5121), Some(true))
        );
        let wind = &json["accessors"][prims[0]["attributes"]["_WIND"].as_u64().unwrap() as usize];
        assert_eq!((wind["componentType"].as_u64(), wind["type"].as_str()), (Some(5126), Some("VEC4")));
    }
}

#[test]
fn without_wind_colors_there_is_no_color_or_second_uv() {
    let glb = to_glb_with(&rigged_model(), &options(LodLayout::Msft, false, Compression::None)).unwrap();
    let (json, _) = split_glb(&glb);
    let a = &json["meshes"][0]["primitives"][0]["attributes"];
    assert!(a.get("_WIND").is_some() && a.get("_PIVOT").is_some(), "{a}");
    assert!(a.get("COLOR_0").is_none() && a.get("TEXCOORD_1").is_none(), "{a}");
}

#[test]
fn binary_channels_follow_each_vertex_position() {
    let model = rigged_model();
    let glb = to_glb_with(&model, &options(LodLayout::Msft, true, Compression::None)).unwrap();
    let (json, bin) = split_glb(&glb);
    let lod0 = node_named(&json, "sylva_LOD0");
    let mesh = &json["meshes"][json["nodes"][lod0]["mesh"].as_u64().unwrap() as usize];
    let read =
        |p: &Value, key: &str| read_accessor(&json, &bin, p["attributes"][key].as_u64().unwrap() as usize);
    for (k, p) in mesh["primitives"].as_array().unwrap().iter().enumerate() {
        let positions = read(p, "POSITION");
        let (joints, weights) = (read(p, "JOINTS_0"), read(p, "WEIGHTS_0"));
        for (v, pos) in positions.iter().enumerate() {
            let y = pos[1] as f32;
            // Weights sum to 1 in f32, zero weights have joint 0, no joint twice.
            let sum = weights[v].iter().fold(0f32, |a, &w| a + w as f32);
            assert!((sum - 1.0).abs() <= 4e-7, "vertex {v}: {:?}", weights[v]);
            let used: Vec<f64> = (0..4).filter(|&c| weights[v][c] > 0.0).map(|c| joints[v][c]).collect();
            for c in 0..4 {
                if weights[v][c] == 0.0 {
                    assert_eq!(joints[v][c], 0.0, "vertex {v}: {:?} {:?}", joints[v], weights[v]);
                }
            }
            let mut dedup = used.clone();
            dedup.dedup();
            assert_eq!(dedup.len(), used.len());
            if k == 2 {
                assert_eq!(
                    (joints[v].clone(), weights[v].clone()),
                    (vec![0.0; 4], vec![1.0, 0.0, 0.0, 0.0]),
                    "stub"
                );
                continue;
            }
            // The skin and wind of the vertex's own position.
            let (j, w) = skin_at(y);
            let want: f32 = (0..4).filter(|&c| j[c] == 2).map(|c| w[c]).sum::<f32>() / w.iter().sum::<f32>();
            let got: f64 = (0..4).filter(|&c| joints[v][c] == 2.0).map(|c| weights[v][c]).sum();
            assert!(
                (got - want as f64).abs() < 1e-6,
                "vertex {v} at y {y}: joint 2 weight {got}, want {want}"
            );
            let wind = read(p, "_WIND");
            assert_eq!(wind[v], vec![(y / 2.0) as f64, (y / 4.0) as f64, 0.5, 0.25], "vertex {v}");
            let color = read(p, "COLOR_0");
            let unorm = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as f64;
            assert_eq!(color[v], vec![unorm(0.25), unorm(0.5), unorm(y / 4.0), unorm(y / 2.0)], "vertex {v}");
            assert_eq!(read(p, "TEXCOORD_1")[v], vec![(y / 2.0) as f64, (y / 4.0) as f64]);
            assert_eq!(read(p, "_PIVOT")[v][3], (y > 1.0) as u8 as f64);
        }
    }
    // The bark tube's UV seam splits vertices: more glTF vertices than positions.
    let bark = &mesh["primitives"][0];
    let count = json["accessors"][bark["attributes"]["POSITION"].as_u64().unwrap() as usize]["count"]
        .as_u64()
        .unwrap();
    assert_eq!(count as usize, 5 * (SIDES + 1));
    // Inverse bind matrices: translations by −head, column-major.
    let skin = &json["skins"][0];
    let ibm = read_accessor(&json, &bin, skin["inverseBindMatrices"].as_u64().unwrap() as usize);
    for (m, joint) in ibm.iter().zip(&rig().joints) {
        let want = Mat4::from_translation(-joint.head).to_cols_array().map(|x| x as f64);
        assert_eq!(m.as_slice(), want.as_slice());
    }
    // Rotations: unit quaternions, the clip's.
    let anim = &json["animations"][0];
    for (j, s) in anim["samplers"].as_array().unwrap().iter().enumerate() {
        let out = read_accessor(&json, &bin, s["output"].as_u64().unwrap() as usize);
        assert_eq!(out.len(), 5);
        for (q, want) in out.iter().zip(&clip().rotations[j]) {
            let want = want.normalize().to_array();
            assert!((0..4).all(|c| (q[c] - want[c] as f64).abs() < 1e-7), "{q:?} vs {want:?}");
        }
    }
}

#[test]
fn quantized_rigged_positions_stay_float_and_unrigged_levels_share_a_grid() {
    let rigged =
        to_glb_with(&rigged_model(), &options(LodLayout::Msft, false, Compression::Quantize)).unwrap();
    let (json, _) = split_glb(&rigged);
    for m in json["meshes"].as_array().unwrap() {
        for p in m["primitives"].as_array().unwrap() {
            let pos = &json["accessors"][p["attributes"]["POSITION"].as_u64().unwrap() as usize];
            assert_eq!(pos["componentType"], 5126, "skinned positions are FLOAT");
            let n = &json["accessors"][p["attributes"]["NORMAL"].as_u64().unwrap() as usize];
            assert_eq!(n["componentType"], 5120, "normals stay quantized");
        }
    }
    let model = rigged_model();
    let unrigged = Model {
        rig: None,
        clip: None,
        parts: strip_skins(&model.parts),
        lods: strip_lod_skins(&model.lods),
        ..model
    };
    let glb = to_glb_with(&unrigged, &options(LodLayout::Msft, false, Compression::Quantize)).unwrap();
    let (json, _) = split_glb(&glb);
    assert!(json.get("skins").is_none() && json.get("animations").is_none());
    let lod0 = &json["nodes"][node_named(&json, "sylva_LOD0")];
    assert!(lod0["scale"].is_array() && lod0["translation"].is_array(), "the level's grid: {lod0}");
    let p = &json["meshes"][lod0["mesh"].as_u64().unwrap() as usize]["primitives"][0];
    assert_eq!(
        json["accessors"][p["attributes"]["POSITION"].as_u64().unwrap() as usize]["componentType"],
        5123
    );
    assert!(p["attributes"].get("JOINTS_0").is_none());
}

#[test]
fn instances_are_merged_with_a_rig_and_hang_under_lod0_without_one() {
    let dir = scratch("instances");
    let mut model = rigged_model();
    model.shapes = vec![Part::new("leaf", quad(0.0, 0.0, 0.1, 0.2), Material::leaf())];
    model.instances = (0..3)
        .map(|i| Instance {
            shape: 0,
            transform: Mat4::from_translation(Vec3::new(0.1 * i as f32, 1.0 + 0.3 * i as f32, 0.0)),
            node: 0,
        })
        .collect();
    let glb = to_glb_with(&model, &options(LodLayout::Msft, false, Compression::None)).unwrap();
    let (json, _) = split_glb(&glb);
    assert!(!json.to_string().contains("EXT_mesh_gpu_instancing"), "merged with a rig");
    let lod0 =
        &json["meshes"][json["nodes"][node_named(&json, "sylva_LOD0")]["mesh"].as_u64().unwrap() as usize];
    assert_eq!(lod0["primitives"].as_array().unwrap().len(), 4, "bark, leaves, stub, merged leaf");
    std::fs::write(dir.join("rigged-instances.glb"), &glb).unwrap();

    let unrigged = Model {
        rig: None,
        clip: None,
        parts: strip_skins(&model.parts),
        lods: strip_lod_skins(&model.lods),
        ..model.clone()
    };
    let mut paths = vec![dir.join("rigged-instances.glb")];
    for compress in [Compression::None, Compression::Quantize, Compression::Meshopt] {
        let glb = to_glb_with(&unrigged, &options(LodLayout::Scene, false, compress)).unwrap();
        let (json, _) = split_glb(&glb);
        let lod0 = node_named(&json, "sylva_LOD0");
        let leaf = node_named(&json, "leaf");
        assert_eq!(json["nodes"][lod0]["children"], serde_json::json!([leaf]), "{compress:?}");
        assert!(json["nodes"][leaf]["extensions"].get("EXT_mesh_gpu_instancing").is_some());
        if compress != Compression::None {
            // The level's grid is undone by the instanced node: the first leaf stays at
            // (0, 1, 0) in the world.
            let n = |k: usize, key: &str| -> Vec<f32> {
                json["nodes"][k][key].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as f32).collect()
            };
            let (t0, s0) = (Vec3::from_slice(&n(lod0, "translation")), n(lod0, "scale")[0]);
            let (t1, s1) = (Vec3::from_slice(&n(leaf, "translation")), n(leaf, "scale")[0]);
            let world = t0 + s0 * t1;
            assert!((world - Vec3::new(0.0, 1.0, 0.0)).length() < 1e-4, "{world}");
            assert!((s0 * s1 - 1.0).abs() < 1e-4);
        }
        let path = dir.join(format!("lod-instances-{compress:?}.glb"));
        std::fs::write(&path, &glb).unwrap();
        paths.push(path);
    }
    assert_valid_gltf(&paths);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_model_without_rig_or_lods_keeps_the_plain_layout() {
    let model = rigged_model();
    let plain = Model { rig: None, clip: None, lods: Vec::new(), parts: strip_skins(&model.parts), ..model };
    let (json, _) = split_glb(&to_glb(&plain).unwrap());
    assert!(json.get("skins").is_none() && json.get("animations").is_none());
    assert!(!json.to_string().contains("MSFT_lod"));
    let scene = scene_nodes(&json);
    assert_eq!(scene.len(), 1);
    let top = &json["nodes"][scene[0] as usize];
    assert_eq!(top["name"], "sylva");
    assert_eq!(top["children"].as_array().unwrap().len(), 3, "a node per part");
    // The wind channels are written in the plain layout too.
    assert!(json["meshes"][0]["primitives"][0]["attributes"].get("_WIND").is_some());

    // Without channels, the file is what it was before issue 24: no extra attribute.
    let bare = Model {
        parts: plain.parts.iter().map(|p| Part { attributes: Default::default(), ..p.clone() }).collect(),
        ..plain.clone()
    };
    let (json, _) = split_glb(&to_glb(&bare).unwrap());
    for m in json["meshes"].as_array().unwrap() {
        let keys: Vec<&String> = m["primitives"][0]["attributes"].as_object().unwrap().keys().collect();
        assert!(keys.iter().all(|k| ["POSITION", "NORMAL", "TEXCOORD_0"].contains(&k.as_str())), "{keys:?}");
    }
    // LOD0's coverage is written only with levels.
    let covered = Model { lod0_coverage: 0.9, ..bare.clone() };
    assert_eq!(to_glb(&bare).unwrap(), to_glb(&covered).unwrap());
}

#[test]
fn obj_and_ply_write_lod0_only() {
    let dir = scratch("objply");
    let model = rigged_model();
    let lod0_faces: usize = model.parts.iter().map(|p| p.mesh.face_count()).sum();
    let lod0_tris: usize = model.parts.iter().map(|p| p.mesh.triangle_count()).sum();
    export::write(&model, &dir.join("t.obj")).unwrap();
    let obj = std::fs::read_to_string(dir.join("t.obj")).unwrap();
    assert_eq!(obj.lines().filter(|l| l.starts_with("f ")).count(), lod0_faces);
    export::write(&model, &dir.join("t.ply")).unwrap();
    let ply = std::fs::read(dir.join("t.ply")).unwrap();
    let header = String::from_utf8_lossy(&ply[..ply.windows(10).position(|w| w == b"end_header").unwrap()])
        .into_owned();
    let faces: usize =
        header.lines().find_map(|l| l.strip_prefix("element face ")).unwrap().trim().parse().unwrap();
    assert!(faces == lod0_faces || faces == lod0_tris, "{header}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The error message of exporting `model`, which must be invalid geometry.
fn invalid(model: &Model) -> String {
    let e = to_glb(model).unwrap_err();
    assert!(matches!(e, Error::InvalidGeometry { .. }), "{e}");
    e.to_string()
}

#[test]
fn bad_rigs_skins_and_clips_are_refused() {
    let check = |edit: &dyn Fn(&mut Model), words: &[&str]| {
        let mut m = rigged_model();
        edit(&mut m);
        let e = invalid(&m);
        assert!(words.iter().all(|w| e.contains(w)), "{e} lacks {words:?}");
    };
    check(
        &|m| {
            let _ = m.parts[0].skin.as_mut().unwrap().joints.pop();
        },
        &["part 'bark'", "positions"],
    );
    check(&|m| m.parts[1].skin.as_mut().unwrap().joints[0] = [0, 7, 0, 0], &["part 'leaves'", "joint 7"]);
    check(
        &|m| m.parts[0].skin.as_mut().unwrap().weights[3] = [1.0, -0.5, 0.0, 0.0],
        &["part 'bark'", "negative"],
    );
    check(
        &|m| m.parts[0].skin.as_mut().unwrap().weights[3] = [f32::NAN, 0.0, 0.0, 0.0],
        &["part 'bark'", "non-finite"],
    );
    check(&|m| m.parts[0].skin.as_mut().unwrap().weights[3] = [0.0; 4], &["part 'bark'", "sum to zero"]);
    check(&|m| m.lods[0].parts[0].skin.as_mut().unwrap().weights.clear(), &["LOD 1 part 'bark'"]);
    check(
        &|m| {
            let _ = m.parts[0].attributes.wind.pop();
        },
        &["part 'bark'", "wind"],
    );
    check(&|m| m.rig = None, &["no rig"]);
    check(&|m| m.rig.as_mut().unwrap().joints[1].parent = Some(2), &["rig", "joint 1", "before"]);
    check(&|m| m.rig.as_mut().unwrap().joints.clear(), &["rig", "no joints"]);
    check(
        &|m| {
            let _ = m.clip.as_mut().unwrap().rotations.pop();
        },
        &["clip 'wind'", "2 joints"],
    );
    check(
        &|m| {
            let _ = m.clip.as_mut().unwrap().rotations[1].pop();
        },
        &["clip 'wind'", "joint 1"],
    );
    check(&|m| m.clip.as_mut().unwrap().times[2] = 0.1, &["clip 'wind'", "increase"]);
    check(&|m| m.clip.as_mut().unwrap().times[0] = f32::NAN, &["clip 'wind'", "not finite"]);
    check(
        &|m| m.clip.as_mut().unwrap().rotations[2][1] = Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
        &["clip 'wind'", "joint 2"],
    );
    check(
        &|m| {
            m.rig = None;
            m.parts = strip_skins(&m.parts);
            m.lods = strip_lod_skins(&m.lods);
        },
        &["clip 'wind'", "no rig"],
    );
    check(&|m| m.lods[1].screen_coverage = f32::NAN, &["LOD 2", "coverage"]);
}

#[test]
fn three_js_plays_the_wind_clip() {
    let dir = scratch("threejs");
    for (name, o) in [
        ("plain", options(LodLayout::Msft, false, Compression::None)),
        ("scene-colors", options(LodLayout::Scene, true, Compression::None)),
        ("meshopt", options(LodLayout::Msft, true, Compression::Meshopt)),
    ] {
        let path = dir.join(format!("{name}.glb"));
        export::write_with_options(&rigged_model(), &path, &o).unwrap();
        let Some(r) = threejs_wind(&path, None) else { return };
        println!("three.js {name}: {}", r.json);
        assert_eq!(r.joints, 3, "{name}: {}", r.json);
        assert_eq!(r.clips, vec!["wind".to_owned()], "{name}");
        assert!((r.duration - DURATION as f64).abs() < 1e-6, "{name}: {}", r.json);
        assert!((r.height - 2.2).abs() < 1e-5, "{name}: the leaf quad tops the tree: {}", r.json);
        // Joints 1 and 2 turn by 0.2 and 0.3 rad at T/4: the tip swings by tenths of a metre.
        assert!(r.tip_move > 0.2, "{name}: the tip moves: {}", r.json);
        assert!(r.base_move <= 1e-6, "{name}: the base stays: {}", r.json);
        // And by what the model's own pose says: a top corner of the leaf quad, on joint 2.
        let (rig, clip) = (rig(), clip());
        let at = |t: f32, p: Vec3| {
            (clip.pose(&rig, t)[2] * Mat4::from_translation(-rig.joints[2].head)).transform_point3(p)
        };
        let moved = |p: Vec3| at(DURATION / 4.0, p).distance(at(0.0, p)) as f64;
        let want = [moved(Vec3::new(0.2, 2.2, 0.0)), moved(Vec3::new(-0.2, 2.2, 0.0))];
        assert!(want.iter().any(|w| (w - r.tip_move).abs() < 1e-5), "{name}: {want:?} vs {}", r.json);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn blender_imports_the_rig_and_the_clip() {
    let dir = scratch("blender");
    let paths: Vec<PathBuf> = [LodLayout::Msft, LodLayout::Scene]
        .iter()
        .map(|&layout| {
            let path = dir.join(format!("{layout:?}.glb"));
            export::write_with_options(&rigged_model(), &path, &options(layout, true, Compression::None))
                .unwrap();
            path
        })
        .collect();
    let Some(reports) = blender_rig(&paths) else { return };
    for r in reports {
        println!("Blender: {}", r.json);
        assert_eq!((r.armatures, r.bones), (1, 3), "{}", r.json);
        assert!(r.actions >= 1, "{}", r.json);
        let frame = 1.0 / r.fps;
        let (start, end) = (r.start.unwrap(), r.end.unwrap());
        assert!(start.abs() <= frame, "the clip starts at 0: {}", r.json);
        assert!((end - DURATION as f64).abs() <= frame, "the clip spans {DURATION} s: {}", r.json);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
