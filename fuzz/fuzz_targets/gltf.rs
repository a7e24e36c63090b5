//! A glTF or GLB file for `sylva check`.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = std::env::temp_dir().join(format!("sylva-fuzz-gltf-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join(if data.starts_with(b"glTF") { "in.glb" } else { "in.gltf" });
    if std::fs::write(&path, data).is_err() {
        return;
    }
    if let Ok(meshes) = sylva::import::gltf_read::read_gltf(&path) {
        for mut g in meshes {
            sylva::import::gltf_read::weld(&mut g.mesh);
            let _ = sylva::mesh::check::check_mesh(&g.mesh, &Default::default());
        }
    }
});
