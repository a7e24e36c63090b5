//! Writes the procedural textures (issue 23) to PNG files for a look: every bark style's
//! three maps and the leaf atlas, with the time each took.
//!
//! ```text
//! cargo run --release -p sylva --example texture_gallery -- OUT_DIR [SIZE] [SEED]
//! ```

use sylva::texture::bark::{bark_maps, BarkStyle};
use sylva::texture::leaf::leaf_atlas;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = std::path::PathBuf::from(args.first().ok_or("usage: texture_gallery OUT_DIR [SIZE] [SEED]")?);
    let size: u32 = args.get(1).map_or(Ok(1024), |s| s.parse())?;
    let seed: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    std::fs::create_dir_all(&out)?;
    for name in BarkStyle::NAMES {
        let t = std::time::Instant::now();
        let m = bark_maps(BarkStyle::from_name(name).ok_or("style")?, size, seed);
        let gen = t.elapsed();
        let t = std::time::Instant::now();
        let pngs = [m.albedo.to_png()?, m.normal.to_png()?, m.orm.to_png()?];
        let enc = t.elapsed();
        for (png, map) in pngs.iter().zip(["albedo", "normal", "orm"]) {
            std::fs::write(out.join(format!("bark-{name}-{map}.png")), png)?;
        }
        println!(
            "bark {name}: generated in {:.1} ms, encoded in {:.1} ms ({} KiB)",
            gen.as_secs_f64() * 1e3,
            enc.as_secs_f64() * 1e3,
            pngs.iter().map(Vec::len).sum::<usize>() / 1024
        );
    }
    let t = std::time::Instant::now();
    let atlas = leaf_atlas(size, [0.12, 0.32, 0.06], seed);
    let gen = t.elapsed();
    let png = atlas.image.to_png()?;
    std::fs::write(out.join("leaf-atlas.png"), &png)?;
    println!("leaf atlas: generated in {:.1} ms ({} KiB)", gen.as_secs_f64() * 1e3, png.len() / 1024);
    Ok(())
}
