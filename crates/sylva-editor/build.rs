//! Makes the preset picker's pictures: every `docs/presets/<name>.png` (the preset
//! catalogue, written by tools/regen-previews.sh) box-filtered down to
//! `THUMB_SIDE`² RGBA and embedded through `$OUT_DIR/thumbnails.rs`. Without the
//! catalogue (the crate built outside its repository) the table is empty and the picker
//! shows names only.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The side of a thumbnail, pixels (keep in step with `thumbnails::SIDE`).
const THUMB_SIDE: usize = 64;

fn main() {
    let manifest =
        PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let catalogue = manifest.join("../../docs/presets");
    println!("cargo::rerun-if-changed={}", catalogue.display());
    let mut entries = Vec::new();
    if let Ok(dir) = std::fs::read_dir(&catalogue) {
        let mut paths: Vec<PathBuf> = dir.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        for path in paths {
            if path.extension().is_none_or(|e| e != "png") {
                continue;
            }
            let name =
                path.file_stem().and_then(|s| s.to_str()).expect("preset file names are UTF-8").to_string();
            match thumbnail(&path) {
                Ok(rgba) => {
                    let file = out.join(format!("{name}.rgba"));
                    std::fs::write(&file, rgba).expect("OUT_DIR is writable");
                    entries.push((name, file));
                }
                Err(e) => println!("cargo::warning=preset picture {} skipped: {e}", path.display()),
            }
        }
    }
    // By name, for the binary search (paths sort "mig-k-literal.png" before "mig-k.png").
    entries.sort();
    let mut table = std::fs::File::create(out.join("thumbnails.rs")).expect("OUT_DIR is writable");
    writeln!(table, "/// (preset name, {THUMB_SIDE}² RGBA pixels), by name.").unwrap();
    writeln!(table, "pub static THUMBNAILS: &[(&str, &[u8])] = &[").unwrap();
    for (name, file) in &entries {
        writeln!(table, "    ({name:?}, include_bytes!({:?})),", file.display().to_string()).unwrap();
    }
    writeln!(table, "];").unwrap();
}

/// The PNG at `path` as `THUMB_SIDE`² RGBA: each output pixel averages the square of
/// source pixels it covers (the source is cropped to a centred square first).
fn thumbnail(path: &Path) -> Result<Vec<u8>, String> {
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("picture too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Indexed => return Err("indexed colour after expansion".into()),
    };
    let (w, h) = (info.width as usize, info.height as usize);
    let side = w.min(h);
    if side < THUMB_SIDE {
        return Err(format!("{w}x{h} is smaller than {THUMB_SIDE}²"));
    }
    let (x0, y0) = ((w - side) / 2, (h - side) / 2);
    let mut out = Vec::with_capacity(THUMB_SIDE * THUMB_SIDE * 4);
    for ty in 0..THUMB_SIDE {
        for tx in 0..THUMB_SIDE {
            let (ya, yb) = (y0 + ty * side / THUMB_SIDE, y0 + (ty + 1) * side / THUMB_SIDE);
            let (xa, xb) = (x0 + tx * side / THUMB_SIDE, x0 + (tx + 1) * side / THUMB_SIDE);
            let mut sum = [0u32; 4];
            for y in ya..yb {
                for x in xa..xb {
                    let p = &buf[(y * w + x) * channels..][..channels];
                    let rgba = match channels {
                        1 => [p[0], p[0], p[0], 255],
                        2 => [p[0], p[0], p[0], p[1]],
                        3 => [p[0], p[1], p[2], 255],
                        _ => [p[0], p[1], p[2], p[3]],
                    };
                    for (s, v) in sum.iter_mut().zip(rgba) {
                        *s += u32::from(v);
                    }
                }
            }
            let n = ((yb - ya) * (xb - xa)) as u32;
            out.extend(sum.map(|s| ((s + n / 2) / n) as u8));
        }
    }
    Ok(out)
}
