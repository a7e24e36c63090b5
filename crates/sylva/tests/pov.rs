//! POV-Ray output (issue 26, MacMurchy2004 §A.3–A.4): `-o plant.pov` writes a scene and one
//! `mesh2` include per part, with normals and UVs, that POV-Ray 3.7 renders.
//!
//! The render check needs `povray` on PATH (Debian `povray`); without it the test says
//! so loudly and checks the files only, unless `SYLVA_REQUIRE_POVRAY=1` (as `.ci/run`
//! sets), which makes a missing POV-Ray a failure.

use std::path::{Path, PathBuf};
use std::process::Command;
use sylva::export::TextureMode;
use sylva::Model;

#[path = "common/folders.rs"]
mod folders;

fn tempdir(name: &str) -> PathBuf {
    folders::tempdir("pov", name)
}

/// `preset` grown and written to `dir/file` as a POV-Ray scene with `textures`: the
/// model, the scene's path and its text.
fn write_scene(dir: &Path, preset: &str, file: &str, textures: TextureMode) -> (Model, PathBuf, String) {
    let model = sylva::pipeline::grow(&sylva::recipe::load(preset, &[]).unwrap()).unwrap().model;
    let scene = dir.join(file);
    sylva::export::write_with(&model, &scene, &textures).unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    (model, scene, text)
}

/// The pixels of a render that are not sky: sky is blue-grey (blue ≥ red), bark and
/// leaves are not.
fn tree_pixels(rgba: &[u8]) -> usize {
    rgba.chunks(4).filter(|p| p[2] as i32 + 8 < p[0].max(p[1]) as i32).count()
}

/// Renders `scene` at `w`×`h` with POV-Ray; `None` when it is not installed (and not
/// required). Returns RGBA pixels.
fn povray(scene: &Path, w: u32, h: u32) -> Option<Vec<u8>> {
    let has = Command::new("povray").arg("--version").output().is_ok();
    if !has {
        let msg = "SKIPPED POV-Ray render: `povray` is not on PATH (apt install povray)";
        if std::env::var("SYLVA_REQUIRE_POVRAY").is_ok_and(|v| v == "1") {
            panic!("{msg} (SYLVA_REQUIRE_POVRAY=1 makes this an error)");
        }
        eprintln!("\n**********\n*** {msg}\n**********\n");
        return None;
    }
    let out = scene.with_extension("render.png");
    let o = Command::new("povray")
        .current_dir(scene.parent().unwrap())
        .arg(format!("+I{}", scene.file_name().unwrap().to_string_lossy()))
        .arg(format!("+O{}", out.file_name().unwrap().to_string_lossy()))
        .args([format!("+W{w}"), format!("+H{h}"), "-D".into(), "-P".into(), "+FN".into(), "-V".into()])
        .output()
        .unwrap();
    assert!(o.status.success(), "povray failed:\n{}", String::from_utf8_lossy(&o.stderr));
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (w, h));
    let channels = info.color_type.samples();
    let bytes = info.bit_depth as usize / 8;
    Some(
        buf[..info.buffer_size()]
            .chunks(channels * bytes)
            .flat_map(|p| {
                let c = |k: usize| p[k * bytes];
                [c(0), c(1.min(channels - 1)), c(2.min(channels - 1)), 255]
            })
            .collect(),
    )
}

/// The aspen (bark texture, alpha-cut leaf cards) as a POV-Ray scene: every include is
/// named by the scene, each is a `mesh2` with normals and UVs and as many index triples
/// as the part has triangles, the texture PNGs lie beside it, and POV-Ray renders the
/// tree in front of its sky (at 160×120 the slim aspen covers about a tenth of the
/// picture: more than 5 % must not be sky-coloured).
#[test]
fn aspen_scene_renders_in_povray() {
    let d = tempdir("aspen");
    let (model, scene, text) = write_scene(&d, "wp-quaking-aspen", "aspen.pov", TextureMode::Embed);
    assert!(text.contains("#version 3.7;"), "{text}");
    let incs = sylva::export::pov::includes(&model, "aspen");
    assert_eq!(incs.len(), model.flattened().parts.iter().filter(|p| p.mesh.face_count() > 0).count());
    let flat = model.flattened();
    for inc in &incs {
        assert!(text.contains(&format!("#include \"{}\"", inc.file)), "{}", inc.file);
        let s = std::fs::read_to_string(d.join(&inc.file)).unwrap();
        let tris = flat.parts[inc.part].mesh.triangle_count();
        for block in
            ["vertex_vectors", "normal_vectors", "uv_vectors", "face_indices", "normal_indices", "uv_indices"]
        {
            assert!(s.contains(&format!("{block} {{")), "{}: no {block}", inc.file);
        }
        assert!(s.contains(&format!("face_indices {{\n    {tris},")), "{}: {tris} triangles", inc.file);
        assert!(!s.contains("NaN") && !s.contains("inf"), "{}", inc.file);
    }
    assert!(text.contains("image_map { png \"aspen_"), "textured materials: {text}");
    for im in &model.images {
        assert!(d.join(format!("aspen_{}.png", im.name)).exists(), "{}", im.name);
    }
    if let Some(rgba) = povray(&scene, 160, 120) {
        let share = tree_pixels(&rgba) as f64 / (160.0 * 120.0);
        println!("POV-Ray: {:.1} % of the picture is the tree", share * 100.0);
        assert!(share > 0.05, "only {:.1} % of the picture is not sky", share * 100.0);
    }
    let _ = std::fs::remove_dir_all(&d);
}

/// A bare tree with flat colours when textures are
/// off, and a failing write leaves no include behind.
#[test]
fn flat_colours_and_no_half_written_scene() {
    let d = tempdir("flat");
    let (model, scene, text) = write_scene(&d, "lsys-honda-a", "honda.pov", TextureMode::None);
    assert!(text.contains("pigment { color rgbt <") && !text.contains("image_map"), "{text}");
    if let Some(rgba) = povray(&scene, 96, 72) {
        let tree = tree_pixels(&rgba);
        assert!(tree > 50, "{tree} tree pixels");
    }
    // The scene's folder does not exist: an error, and nothing written anywhere.
    let bad = d.join("missing").join("t.pov");
    assert!(sylva::export::write(&model, &bad).is_err());
    assert!(!d.join("missing").exists());
    let _ = std::fs::remove_dir_all(&d);
}
