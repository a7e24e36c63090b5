//! A side-by-side picture of one preset's leaf modes (issue 23): the generator's polygon
//! leaves (`leaves.mode = "geometry"`, no textures) beside the default alpha-cut cards
//! (cluster cards on large trees) and, third, the cards with crown normals, all drawn by
//! the CPU preview with one camera, and each mode's leaf triangles and `.glb` size.
//!
//! ```text
//! cargo run --release -p sylva --example leaves_compare -- wp-quaking-aspen docs/textures/wp-quaking-aspen-leaves.png
//! ```

use sylva::preview::{render, write_png, PreviewOptions};

fn grow(preset: &str, sets: &[(&str, &str)]) -> Result<sylva::Model, Box<dyn std::error::Error>> {
    let sets: Vec<(String, toml::Value)> =
        sets.iter().map(|(k, v)| (k.to_string(), toml::Value::String(v.to_string()))).collect();
    let loaded = sylva::recipe::load(preset, &sets)?;
    Ok(sylva::pipeline::grow(&loaded)?.model)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [preset, out] = args.as_slice() else {
        return Err("usage: leaves_compare PRESET OUT.png".into());
    };
    let modes: [(&str, &[(&str, &str)]); 3] = [
        ("geometry", &[("leaves.mode", "geometry"), ("output.textures", "none")]),
        ("cards", &[]),
        ("cards, crown normals", &[("leaves.normals", "crown")]),
    ];
    let models = modes.iter().map(|(_, sets)| grow(preset, sets)).collect::<Result<Vec<_>, _>>()?;
    let frame = models[0].bounds().ok_or("empty model")?;
    let size = 512u32;
    let opts = PreviewOptions { width: size, height: size, frame: Some(frame), ..Default::default() };
    let images = models.iter().map(|m| render(m, &opts)).collect::<Result<Vec<_>, _>>()?;
    let tmp = std::env::temp_dir().join(format!("leaves-compare-{}.glb", std::process::id()));
    for ((name, _), model) in modes.iter().zip(&models) {
        sylva::export::write(model, &tmp)?;
        let bytes = std::fs::metadata(&tmp)?.len();
        let leaf: usize =
            model.parts.iter().filter(|p| p.name != "bark").map(|p| p.mesh.triangle_count()).sum();
        println!("{preset} {name}: {leaf} leaf triangles, {bytes} bytes");
    }
    let _ = std::fs::remove_file(&tmp);
    // Side by side.
    write_png(&sylva::preview::Image::side_by_side(&images)?, std::path::Path::new(out))?;
    println!("wrote {out}");
    Ok(())
}
