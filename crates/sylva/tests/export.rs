//! Exporter tests: glTF (checked by the Khronos validator), OBJ + MTL (read back by
//! `tobj`), binary PLY, determinism, and failures that must leave no file behind.

mod common;
#[path = "common/folders.rs"]
mod folders;

use common::gltf_validator::assert_valid_gltf;
use folders::names;
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};
use sylva::export::{self, gltf, obj, ply, Format};
use sylva::geometry::FaceVarying;
use sylva::{Error, Material, Mesh, Model, Part};

/// A fresh, empty scratch folder for one test.
fn scratch(test: &str) -> PathBuf {
    folders::tempdir("export", test)
}

/// The unit cube of six quads (counter-clockwise from outside). UVs: the four sides
/// share one strip whose ends meet at the seam along the edge 0–3 (u = 0 and u = 1),
/// plus one island per cap. With `normals`, flat per-face normals.
fn cube(normals: bool) -> Mesh {
    let mut m = Mesh::new();
    m.positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    let faces: [([u32; 4], [u32; 4], Vec3); 6] = [
        ([0, 3, 2, 1], [0, 1, 3, 2], Vec3::NEG_Z),
        ([1, 2, 6, 5], [2, 3, 5, 4], Vec3::X),
        ([4, 5, 6, 7], [6, 4, 5, 7], Vec3::Z),
        ([0, 4, 7, 3], [8, 6, 7, 9], Vec3::NEG_X), // u = 1 at positions 0 and 3: the seam
        ([3, 7, 6, 2], [10, 11, 12, 13], Vec3::Y),
        ([0, 1, 5, 4], [14, 15, 16, 17], Vec3::NEG_Y),
    ];
    let mut uv_values: Vec<Vec2> =
        (0..10).map(|i| Vec2::new((i / 2) as f32 * 0.25, (i % 2) as f32 * 0.5)).collect();
    uv_values.extend([(0.0, 0.5), (0.0, 1.0), (0.5, 1.0), (0.5, 0.5)].map(Vec2::from));
    uv_values.extend([(0.5, 0.5), (1.0, 0.5), (1.0, 1.0), (0.5, 1.0)].map(Vec2::from));
    let mut uv_indices = Vec::new();
    let mut n_indices = Vec::new();
    let mut n_values = Vec::new();
    for (f, (vertices, uvs, normal)) in faces.iter().enumerate() {
        m.push_face(vertices);
        uv_indices.extend_from_slice(uvs);
        n_indices.extend([f as u32; 4]);
        n_values.push(*normal);
    }
    m.uvs = Some(FaceVarying { values: uv_values, indices: uv_indices });
    if normals {
        m.normals = Some(FaceVarying { values: n_values, indices: n_indices });
    }
    m.validate().unwrap();
    m
}

/// A bent leaf blade of a triangle, a quad and a pentagon, with per-vertex UVs and no
/// normals (the exporters must compute them).
fn blade() -> Mesh {
    let mut m = Mesh::new();
    m.positions = vec![
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(-0.1, 2.1, 0.0),
        Vec3::new(0.1, 2.1, 0.0),
        Vec3::new(-0.15, 2.3, 0.05),
        Vec3::new(0.15, 2.3, 0.05),
        Vec3::new(-0.1, 2.5, 0.1),
        Vec3::new(0.1, 2.5, 0.1),
        Vec3::new(0.0, 2.6, 0.15),
    ];
    m.push_face(&[0, 2, 1]);
    m.push_face(&[1, 2, 4, 3]);
    m.push_face(&[3, 4, 6, 7, 5]);
    let uv: Vec<Vec2> = m.positions.iter().map(|p| Vec2::new(p.x + 0.5, (p.y - 2.0) / 0.6)).collect();
    m.uvs = Some(FaceVarying { indices: m.face_indices.clone(), values: uv });
    m.validate().unwrap();
    m
}

/// A quad with one shared normal and no UVs.
fn stem() -> Mesh {
    let mut m = Mesh::new();
    m.positions = vec![
        Vec3::new(0.4, 0.0, 0.5),
        Vec3::new(0.6, 0.0, 0.5),
        Vec3::new(0.6, 2.0, 0.5),
        Vec3::new(0.4, 2.0, 0.5),
    ];
    m.push_face(&[0, 1, 2, 3]);
    m.normals = Some(FaceVarying { values: vec![Vec3::Z], indices: vec![0; 4] });
    m
}

fn part(name: &str, mesh: Mesh, material: Material) -> Part {
    Part::new(name, mesh, material)
}

/// Cube (UVs + normals), blade (UVs, no normals), stem (normals, no UVs) and an empty
/// part that every writer must skip.
fn model() -> Model {
    Model {
        parts: vec![
            part("cube", cube(true), Material::bark()),
            part("blade", blade(), Material::leaf()),
            part("stem", stem(), Material::bark()),
            part("empty", Mesh::new(), Material::leaf()),
        ],
        ..Default::default()
    }
}

/// A `side × side` grid of quads: more than 65,535 vertices for `side` ≥ 256.
fn grid(side: u32) -> Mesh {
    let mut m = Mesh::new();
    let n = side + 1;
    m.positions = (0..n * n).map(|i| Vec3::new((i % n) as f32, 0.0, -((i / n) as f32)) * 0.01).collect();
    for j in 0..side {
        for i in 0..side {
            let a = j * n + i;
            m.push_face(&[a, a + 1, a + n + 1, a + n]);
        }
    }
    m
}

/// Splits a GLB into its JSON and BIN chunks, checking the header and the padding.
fn glb_chunks(glb: &[u8]) -> (&[u8], &[u8]) {
    let u32_at = |o: usize| u32::from_le_bytes(glb[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&glb[0..4], b"glTF");
    assert_eq!(u32_at(4), 2);
    assert_eq!(u32_at(8), glb.len());
    let json_len = u32_at(12);
    assert_eq!(&glb[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let json = &glb[20..20 + json_len];
    let b = 20 + json_len;
    let bin_len = u32_at(b);
    assert_eq!(bin_len % 4, 0);
    assert_eq!(&glb[b + 4..b + 8], b"BIN\0");
    assert_eq!(b + 8 + bin_len, glb.len());
    (json, &glb[b + 8..])
}

fn accessor_count(root: &gltf_json::Root, i: gltf_json::Index<gltf_json::Accessor>) -> u64 {
    root.accessors[i.value()].count.0
}

#[test]
fn glb_and_gltf_pass_the_khronos_validator() {
    let dir = scratch("validator");
    let glb = dir.join("tree.glb");
    let gltf_path = dir.join("tree.gltf");
    let big = dir.join("big.glb");
    export::write(&model(), &glb).unwrap();
    export::write(&model(), &gltf_path).unwrap();
    let big_model = Model { parts: vec![part("grid", grid(300), Material::leaf())], ..Default::default() };
    export::write(&big_model, &big).unwrap();
    assert_valid_gltf(&[&glb, &gltf_path, &big]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn glb_layout_and_contents() {
    let glb = gltf::to_glb(&model()).unwrap();
    let (json, bin) = glb_chunks(&glb);
    let root = gltf_json::Root::from_slice(json).unwrap();
    assert_eq!(root.asset.version, "2.0");
    assert_eq!(root.asset.generator.as_deref(), Some(concat!("sylva ", env!("CARGO_PKG_VERSION"))));
    assert_eq!(root.buffers.len(), 1);
    assert_eq!(root.buffers[0].byte_length.0 as usize, bin.len());
    assert!(root.buffers[0].uri.is_none());

    // One scene, one root node with a child per non-empty part.
    assert_eq!(root.scenes.len(), 1);
    let top = &root.nodes[root.scenes[0].nodes[0].value()];
    let names: Vec<&str> = top
        .children
        .as_ref()
        .unwrap()
        .iter()
        .map(|c| root.nodes[c.value()].name.as_deref().unwrap())
        .collect();
    assert_eq!(names, ["cube", "blade", "stem"]);
    assert_eq!(root.meshes.len(), 3);
    let materials: Vec<&str> = root.materials.iter().map(|m| m.name.as_deref().unwrap()).collect();
    assert_eq!(materials, ["bark", "leaf", "bark"]);
    assert!(root.materials[1].double_sided);

    use gltf_json::mesh::Semantic;
    use gltf_json::validation::Checked::Valid;
    let prim = |m: usize| &root.meshes[m].primitives[0];
    // Cube: flat normals split every corner: 24 vertices, 12 triangles.
    let cube = prim(0);
    assert_eq!(accessor_count(&root, cube.attributes[&Valid(Semantic::Positions)]), 24);
    assert_eq!(accessor_count(&root, cube.indices.unwrap()), 36);
    assert!(cube.attributes.contains_key(&Valid(Semantic::TexCoords(0))));
    let pos = &root.accessors[cube.attributes[&Valid(Semantic::Positions)].value()];
    assert_eq!(pos.min.as_ref().unwrap(), &gltf_json::Value::from(vec![0.0, 0.0, 0.0]));
    assert_eq!(pos.max.as_ref().unwrap(), &gltf_json::Value::from(vec![1.0, 1.0, 1.0]));
    // Blade: no normals given, but NORMAL written; 1 + 2 + 3 triangles.
    let blade = prim(1);
    assert!(blade.attributes.contains_key(&Valid(Semantic::Normals)));
    assert_eq!(accessor_count(&root, blade.attributes[&Valid(Semantic::Positions)]), 8);
    assert_eq!(accessor_count(&root, blade.indices.unwrap()), 18);
    // Stem: no UVs, no TEXCOORD_0.
    assert!(!prim(2).attributes.contains_key(&Valid(Semantic::TexCoords(0))));
    use gltf_json::accessor::{ComponentType, GenericComponentType};
    // Indices are 16-bit: every primitive here has far fewer than 65,536 vertices.
    for a in &root.accessors {
        if a.type_ == Valid(gltf_json::accessor::Type::Scalar) {
            assert!(matches!(a.component_type, Valid(GenericComponentType(ComponentType::U16))));
        }
    }
    for v in &root.buffer_views {
        assert_eq!(v.byte_offset.unwrap().0 % 4, 0);
        assert!(v.target.is_some());
    }
}

#[test]
fn gltf_embeds_the_glb_buffer_as_base64() {
    let text = gltf::to_gltf_json(&model()).unwrap();
    let root = gltf_json::Root::from_str(&text).unwrap();
    let uri = root.buffers[0].uri.as_deref().unwrap();
    let glb = gltf::to_glb(&model()).unwrap();
    let (_, bin) = glb_chunks(&glb);
    let mut expected = String::from(gltf::DATA_URI_PREFIX);
    gltf::base64_into(bin, &mut expected);
    assert_eq!(uri, expected);
}

#[test]
fn big_mesh_uses_u32_indices() {
    let model = Model { parts: vec![part("grid", grid(300), Material::leaf())], ..Default::default() };
    let glb = gltf::to_glb(&model).unwrap();
    let (json, bin) = glb_chunks(&glb);
    let root = gltf_json::Root::from_slice(json).unwrap();
    let prim = &root.meshes[0].primitives[0];
    let indices = &root.accessors[prim.indices.unwrap().value()];
    assert_eq!(indices.count.0, 300 * 300 * 6);
    // The last index refers to a vertex above 65,535.
    let view = &root.buffer_views[indices.buffer_view.unwrap().value()];
    let end = (view.byte_offset.unwrap().0 + view.byte_length.0) as usize;
    let max = bin[view.byte_offset.unwrap().0 as usize..end]
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
        .max()
        .unwrap();
    assert_eq!(max, 301 * 301 - 1);
}

#[test]
fn seams_split_and_shared_corners_merge() {
    // Without normals, only the UV seam and the cap islands split the cube's corners:
    // 10 strip UVs + 8 cap UVs = 18 vertices.
    let u = export::unify(&cube(false));
    assert_eq!(u.vertices.len(), 18);
    assert_eq!(u.corner_vertex.len(), 24);
    // Position 0 appears with three UVs: strip start, strip end (seam), bottom cap.
    assert_eq!(u.vertices.iter().filter(|k| k.position == 0).count(), 3);
    // Position 1 is shared by two side faces with one UV, plus the bottom cap.
    assert_eq!(u.vertices.iter().filter(|k| k.position == 1).count(), 2);
    let model = Model { parts: vec![part("cube", cube(false), Material::bark())], ..Default::default() };
    let glb = gltf::to_glb(&model).unwrap();
    let root = gltf_json::Root::from_slice(glb_chunks(&glb).0).unwrap();
    assert_eq!(root.accessors[0].count.0, 18);
}

#[test]
fn obj_reads_back_with_tobj() {
    let dir = scratch("obj");
    let path = dir.join("tree.obj");
    let model = model();
    export::write(&model, &path).unwrap();
    assert_eq!(names(&dir), ["tree.mtl", "tree.obj"]);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("mtllib tree.mtl\n"));
    assert!(text.contains("f 1/1/1 4/2/1 3/4/1 2/3/1\n"), "{text}");
    // Blade: no normals of its own, so smooth ones per position (vn 7…14) and `s 1`.
    assert!(text.contains("f 9/19/7 11/21/9 10/20/8\n"), "{text}");
    assert!(text.contains("f 17//15 18//15 19//15 20//15\n"), "{text}"); // stem: v//vn
    assert!(text.contains("o blade\ng blade\n") && text.contains("s 1\n"), "{text}");

    let options = tobj::LoadOptions { single_index: false, triangulate: false, ..Default::default() };
    let (models, materials) = tobj::load_obj(&path, &options).unwrap();
    let materials = materials.unwrap();
    let expected: Vec<&Part> = model.parts.iter().filter(|p| p.mesh.face_count() > 0).collect();
    assert_eq!(models.len(), expected.len());
    for (m, p) in models.iter().zip(&expected) {
        assert_eq!(m.name, p.name);
        let mesh = &m.mesh;
        assert_eq!(mesh.positions.len() / 3, p.mesh.vertex_count(), "{}", p.name);
        assert_eq!(mesh.indices.len(), p.mesh.face_indices.len(), "{}", p.name);
        let faces =
            if mesh.face_arities.is_empty() { mesh.indices.len() / 3 } else { mesh.face_arities.len() };
        assert_eq!(faces, p.mesh.face_count(), "{}", p.name);
        let arities: Vec<u32> = (0..p.mesh.face_count()).map(|f| p.mesh.face(f).len() as u32).collect();
        if !mesh.face_arities.is_empty() {
            assert_eq!(mesh.face_arities, arities);
        }
        // (tobj invents indices for corners without them when the file has any, so
        // only the parts that have a channel are compared.)
        if let Some(uvs) = &p.mesh.uvs {
            assert_eq!(mesh.texcoords.len() / 2, uvs.values.len(), "{}", p.name);
        }
        // Normals round-trip: the part's own, or the smooth ones per position that the
        // writer adds where it has none (so a refined mesh imports smooth).
        let want: Vec<Vec3> = match &p.mesh.normals {
            Some(n) => n.values.clone(),
            None => export::smooth_normals(&p.mesh),
        };
        assert_eq!(mesh.normals.len() / 3, want.len(), "{}", p.name);
        for (k, n) in want.iter().enumerate() {
            assert_eq!(mesh.normals[3 * k..3 * k + 3], n.to_array(), "{} normal {k}", p.name);
        }
        assert_eq!(mesh.normal_indices.len(), mesh.indices.len(), "{}: every corner has a normal", p.name);
        // Every corner's position round-trips exactly.
        for (k, &i) in mesh.indices.iter().enumerate() {
            let i = i as usize * 3;
            let expected = p.mesh.positions[p.mesh.face_indices[k] as usize];
            assert_eq!(mesh.positions[i..i + 3], expected.to_array(), "{} corner {k}", p.name);
        }
        let mat = &materials[mesh.material_id.unwrap()];
        assert_eq!(mat.name, p.material.name);
        let [r, g, b, _] = p.material.base_color;
        assert_eq!(mat.diffuse, Some([r, g, b]));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn mtl_has_each_material_once() {
    let mut out = Vec::new();
    obj::write_mtl(&model(), &mut out).unwrap();
    let text = String::from_utf8(out).unwrap();
    assert_eq!(text.matches("newmtl ").count(), 2, "{text}");
    for key in ["\nKd 0.3 0.19 0.11\n", "\nKa ", "\nKs ", "\nNs ", "\nd 1\n"] {
        assert!(text.contains(key), "{key:?} missing in\n{text}");
    }
}

/// Parses a binary PLY header: (vertex count, face count, header length).
fn ply_header(bytes: &[u8]) -> (usize, usize, usize) {
    let end = bytes.windows(11).position(|w| w == b"end_header\n").expect("end_header") + 11;
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    let mut lines = header.lines();
    assert_eq!(lines.next(), Some("ply"));
    assert_eq!(lines.next(), Some("format binary_little_endian 1.0"));
    let mut vertices = None;
    let mut faces = None;
    let mut properties = Vec::new();
    for line in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["element", "vertex", n] => vertices = Some(n.parse().unwrap()),
            ["element", "face", n] => faces = Some(n.parse().unwrap()),
            ["property", rest @ ..] => properties.push(rest.join(" ")),
            ["comment", ..] | ["end_header"] => {}
            other => panic!("unexpected header line {other:?}"),
        }
    }
    assert_eq!(
        properties,
        [
            "float x",
            "float y",
            "float z",
            "float nx",
            "float ny",
            "float nz",
            "float s",
            "float t",
            "uchar red",
            "uchar green",
            "uchar blue",
            "ushort part",
            "list uchar uint vertex_indices"
        ]
    );
    assert!(header.contains("comment generator sylva "));
    (vertices.unwrap(), faces.unwrap(), end)
}

#[test]
fn ply_header_and_counts_match() {
    let dir = scratch("ply");
    let path = dir.join("tree.ply");
    let model = model();
    export::write(&model, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let (nv, nf, header_len) = ply_header(&bytes);
    // Unified vertices: cube 24, blade 8, stem 4.
    assert_eq!(nv, 24 + 8 + 4);
    assert_eq!(nf, 6 + 3 + 1);
    // Walk the body: every vertex 37 bytes, every face a count and that many indices.
    let mut at = header_len + nv * 37;
    let mut arities = Vec::new();
    for _ in 0..nf {
        let k = bytes[at] as usize;
        for c in 0..k {
            let o = at + 1 + 4 * c;
            let v = u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
            assert!(v < nv);
        }
        arities.push(k);
        at += 1 + 4 * k;
    }
    assert_eq!(at, bytes.len());
    assert_eq!(arities, [4, 4, 4, 4, 4, 4, 3, 4, 5, 4]);
    // Every normal is unit length, including the blade's computed ones.
    for v in 0..nv {
        let f = |i: usize| {
            let o = header_len + v * 37 + i * 4;
            f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
        };
        let n = Vec3::new(f(3), f(4), f(5));
        assert!((n.length() - 1.0).abs() < 1e-5, "vertex {v}: {n}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn same_model_gives_identical_bytes() {
    let a = model();
    let b = model();
    assert_eq!(gltf::to_glb(&a).unwrap(), gltf::to_glb(&b).unwrap());
    assert_eq!(gltf::to_gltf_json(&a).unwrap(), gltf::to_gltf_json(&b).unwrap());
    let obj_of = |m: &Model| {
        let mut out = Vec::new();
        obj::write_obj(m, &mut out, "x.mtl").unwrap();
        obj::write_mtl(m, &mut out).unwrap();
        out
    };
    assert_eq!(obj_of(&a), obj_of(&b));
    let ply_of = |m: &Model| {
        let mut out = Vec::new();
        ply::write_ply(m, &mut out).unwrap();
        out
    };
    assert_eq!(ply_of(&a), ply_of(&b));
    // And through the files.
    let dir = scratch("determinism");
    let (one, two) = (dir.join("one"), dir.join("two"));
    std::fs::create_dir_all(&one).unwrap();
    std::fs::create_dir_all(&two).unwrap();
    for name in ["tree.glb", "tree.gltf", "tree.obj", "tree.ply"] {
        export::write(&a, &one.join(name)).unwrap();
        export::write(&b, &two.join(name)).unwrap();
    }
    assert_eq!(names(&one), ["tree.glb", "tree.gltf", "tree.mtl", "tree.obj", "tree.ply"]);
    for name in names(&one) {
        let bytes = |d: &Path| std::fs::read(d.join(&name)).unwrap();
        assert!(bytes(&one) == bytes(&two), "{name} differs");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn unwritable_path_is_an_error_naming_it() {
    for ext in ["glb", "gltf", "obj", "ply"] {
        let path = PathBuf::from(format!("/nonexistent-sylva-dir/x.{ext}"));
        let e = export::write(&model(), &path).unwrap_err();
        assert!(matches!(e, Error::Write { .. }), "{e}");
        let shown = e.to_string();
        assert!(shown.contains("/nonexistent-sylva-dir/x."), "{shown}");
        assert!(!path.exists());
        assert!(!path.with_extension("mtl").exists());
    }
}

#[test]
fn unknown_extension_is_a_clear_error() {
    let dir = scratch("unknown");
    let path = dir.join("tree.xyz");
    let e = export::write(&model(), &path).unwrap_err();
    assert!(matches!(e, Error::UnknownFormat { .. }), "{e}");
    let shown = e.to_string();
    assert!(shown.contains("tree.xyz") && shown.contains(".glb, .gltf, .obj, .ply"), "{shown}");
    assert!(names(&dir).is_empty());
    assert!(Format::from_path(Path::new("TREE.GLB")).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn nan_position_is_an_error_and_writes_nothing() {
    let dir = scratch("nan");
    let mut model = model();
    model.parts[1].mesh.positions[2].y = f32::NAN;
    for ext in ["glb", "gltf", "obj", "ply"] {
        let e = export::write(&model, &dir.join(format!("tree.{ext}"))).unwrap_err();
        assert!(matches!(e, Error::InvalidGeometry { .. }), "{e}");
        let shown = e.to_string();
        assert!(shown.contains("blade") && shown.contains("vertex 2"), "{shown}");
    }
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
    assert!(gltf::to_glb(&model).is_err());
    assert!(gltf::to_gltf_json(&model).is_err());
    assert!(obj::write_obj(&model, &mut Vec::new(), "x.mtl").is_err());
    assert!(ply::write_ply(&model, &mut Vec::new()).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn model_without_triangles_is_an_error() {
    let model = Model { parts: vec![part("empty", Mesh::new(), Material::bark())], ..Default::default() };
    let dir = scratch("empty");
    for ext in ["glb", "gltf", "obj", "ply"] {
        let e = export::write(&model, &dir.join(format!("tree.{ext}"))).unwrap_err();
        assert!(matches!(e, Error::InvalidGeometry { .. }), "{e}");
        assert!(e.to_string().contains("no triangles"), "{e}");
    }
    assert!(names(&dir).is_empty());
    assert!(gltf::to_glb(&Model::default()).is_err());
    assert!(ply::write_ply(&Model::default(), &mut Vec::new()).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A model whose bark (the cube, with UVs) has the three bark maps and whose blade is an
/// alpha-cut card on a 4th image, written every way (issue 23).
fn textured() -> Model {
    use sylva::model::{MaterialMaps, ModelImage, Provenance};
    use sylva::texture::{bark, leaf};
    let maps = bark::bark_maps(bark::BarkStyle::Plated, 32, 1);
    let atlas = leaf::leaf_atlas(48, [0.1, 0.3, 0.1], 1);
    let mut model = model();
    model.images = vec![
        ModelImage { name: "bark_albedo".into(), image: maps.albedo, repeat: true },
        ModelImage { name: "bark_normal".into(), image: maps.normal, repeat: true },
        ModelImage { name: "bark_orm".into(), image: maps.orm, repeat: true },
        ModelImage { name: "leaf_atlas".into(), image: atlas.image.into(), repeat: false },
    ];
    model.parts[0].material.maps =
        MaterialMaps { base_color: Some(0), normal: Some(1), occlusion_roughness_metallic: Some(2) };
    model.parts[1].material.maps.base_color = Some(3);
    model.parts[1].material.alpha_cutoff = Some(0.5);
    // The stem has no UVs: its material's maps must not be written.
    model.parts[2].material.maps.base_color = Some(0);
    model.provenance = Some(Provenance { recipe: "seed = 3\n".into(), seed: 3 });
    model
}

#[test]
fn textures_are_embedded_written_beside_or_left_out() {
    use gltf_json::mesh::Semantic;
    use gltf_json::validation::Checked::Valid;
    let dir = scratch("textures");
    let model = textured();
    let (glb, gltf_path, files, none, big) =
        (dir.join("t.glb"), dir.join("t.gltf"), dir.join("f.glb"), dir.join("n.glb"), dir.join("big.glb"));
    export::write(&model, &glb).unwrap();
    export::write(&model, &gltf_path).unwrap();
    export::write_with(&model, &files, &export::TextureMode::for_output("files", &files).unwrap()).unwrap();
    export::write_with(&model, &none, &export::TextureMode::None).unwrap();
    let mut big_model =
        Model { parts: vec![part("grid", grid(300), Material::bark())], ..Default::default() };
    big_model.images = model.images[..3].to_vec();
    big_model.parts[0].material.maps = model.parts[0].material.maps;
    export::write(&big_model, &big).unwrap();
    export::write(&model, &dir.join("t.obj")).unwrap();
    assert_eq!(
        names(&dir),
        [
            "big.glb",
            "f.glb",
            "f_bark_albedo.png",
            "f_bark_normal.png",
            "f_bark_orm.png",
            "f_leaf_atlas.png",
            "n.glb",
            "t.glb",
            "t.gltf",
            "t.mtl",
            "t.obj",
            "t_bark_albedo.png",
            "t_bark_normal.png",
            "t_bark_orm.png",
            "t_leaf_atlas.png",
        ]
    );
    assert_valid_gltf(&[&glb, &gltf_path, &files, &none, &big]);

    let bytes = std::fs::read(&glb).unwrap();
    let root = gltf_json::Root::from_slice(glb_chunks(&bytes).0).unwrap();
    assert_eq!((root.images.len(), root.textures.len(), root.samplers.len()), (4, 4, 2));
    assert!(root.images.iter().all(|i| i.buffer_view.is_some() && i.uri.is_none()));
    let bark = &root.materials[0];
    assert!(bark.normal_texture.is_some() && bark.occlusion_texture.is_some());
    assert!(bark.pbr_metallic_roughness.base_color_texture.is_some());
    assert!(bark.pbr_metallic_roughness.metallic_roughness_texture.is_some());
    let card = &root.materials[1];
    assert_eq!(card.alpha_mode, Valid(gltf_json::material::AlphaMode::Mask));
    assert_eq!(card.alpha_cutoff.map(|c| c.0), Some(0.5));
    assert!(root.materials[2].pbr_metallic_roughness.base_color_texture.is_none(), "stem has no UVs");
    // The normal-mapped primitive carries tangents; the card does not need them.
    let attrs = |m: usize| &root.meshes[m].primitives[0].attributes;
    assert!(attrs(0).contains_key(&Valid(Semantic::Tangents)));
    assert!(!attrs(1).contains_key(&Valid(Semantic::Tangents)));
    // The recipe and seed ride in the scene's extras.
    let extras = root.scenes[0].extras.as_ref().unwrap().get();
    assert!(extras.contains("\"seed\":3") && extras.contains("seed = 3"), "{extras}");

    let text = std::fs::read_to_string(&gltf_path).unwrap();
    assert!(text.contains("data:image/png;base64,"));
    let bytes = std::fs::read(&files).unwrap();
    let root = gltf_json::Root::from_slice(glb_chunks(&bytes).0).unwrap();
    assert_eq!(root.images[0].uri.as_deref(), Some("f_bark_albedo.png"));
    let bytes = std::fs::read(&none).unwrap();
    let root = gltf_json::Root::from_slice(glb_chunks(&bytes).0).unwrap();
    assert!(root.images.is_empty() && root.materials[0].normal_texture.is_none());
    let bytes = std::fs::read(&big).unwrap();
    let root = gltf_json::Root::from_slice(glb_chunks(&bytes).0).unwrap();
    use gltf_json::accessor::{ComponentType, GenericComponentType};
    let idx = &root.accessors[root.meshes[0].primitives[0].indices.unwrap().value()];
    assert!(matches!(idx.component_type, Valid(GenericComponentType(ComponentType::U32))), "90,601 vertices");
    let mtl = std::fs::read_to_string(dir.join("t.mtl")).unwrap();
    assert!(mtl.contains("map_Kd t_bark_albedo.png") && mtl.contains("norm t_bark_normal.png"), "{mtl}");
    assert!(mtl.contains("map_d t_leaf_atlas.png"), "{mtl}");
    std::fs::remove_dir_all(&dir).unwrap();
}
