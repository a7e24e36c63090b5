//! Light images for environmental programs: SGI `.rgb` (the format of vlab's
//! `light.rgb`) and PNG, read as one intensity in \[0, 1\] per pixel.
//!
//! SGI image format (Paul Haeberli, "The SGI Image File Format", version 1.0, 1992):
//! a 512-byte big-endian header (magic 474, storage 0 = verbatim or 1 = RLE, bytes per
//! channel 1 or 2, dimension, x size, y size, z size = channels, …), then the pixel
//! data channel by channel, rows bottom to top. Verbatim data is stored plainly; RLE
//! data has a table of row offsets and lengths (y size × z size 4-byte entries each)
//! and every row is a run of packets: a count byte (or 2-byte value) whose low 7 bits
//! are the count (0 ends the row) and whose high bit says the count values follow
//! literally, else the next value repeats count times. PNG is decoded with the `png`
//! crate. Intensity is the mean of the first three channels (the grey channel for one
//! or two channels; alpha is ignored) divided by the largest value (255 or 65535).

use std::path::Path;

/// The most pixels an image may have (a guard against corrupt sizes).
pub const MAX_PIXELS: usize = 1 << 26;

/// An intensity image, rows from bottom to top (y up, as SGI stores them).
#[derive(Debug, Clone, PartialEq)]
pub struct Intensity {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` intensities in \[0, 1\], row `y` (from the bottom) at `y × width`.
    pub values: Vec<f32>,
}

impl Intensity {
    /// The intensity at pixel (x, y), y from the bottom.
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.values[y.min(self.height - 1) * self.width + x.min(self.width - 1)]
    }
}

/// Reads an SGI or PNG image (told apart by their magic numbers); `Err` names the file
/// and what is wrong.
pub fn read(path: &Path) -> Result<Intensity, String> {
    let bytes = crate::input::read_input(path, crate::input::DEFAULT_MAX_BYTES)
        .map_err(|e| format!("cannot read the image: {e}"))?;
    decode(&bytes).map_err(|why| format!("{}: {why}", path.display()))
}

/// Decodes SGI or PNG bytes.
pub fn decode(bytes: &[u8]) -> Result<Intensity, String> {
    if bytes.starts_with(&[0x89, b'P', b'N', b'G']) {
        decode_png(bytes)
    } else if bytes.len() >= 2 && u16::from_be_bytes([bytes[0], bytes[1]]) == 474 {
        decode_sgi(bytes)
    } else {
        Err("not an SGI (.rgb) or PNG image".into())
    }
}

fn be16(b: &[u8], at: usize) -> Result<u16, String> {
    b.get(at..at + 2)
        .map(|s| u16::from_be_bytes([s[0], s[1]]))
        .ok_or_else(|| "truncated SGI file".to_string())
}

fn be32(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4)
        .map(|s| u32::from_be_bytes([s[0], s[1], s[2], s[3]]))
        .ok_or_else(|| "truncated SGI file".to_string())
}

/// Decodes an SGI image (verbatim or RLE, 1 or 2 bytes per channel, 1–4 channels).
pub fn decode_sgi(b: &[u8]) -> Result<Intensity, String> {
    if b.len() < 512 {
        return Err("truncated SGI header (512 bytes expected)".into());
    }
    let storage = b[2];
    let bpc = b[3] as usize;
    let dimension = be16(b, 4)?;
    let xsize = be16(b, 6)? as usize;
    let mut ysize = be16(b, 8)? as usize;
    let mut zsize = be16(b, 10)? as usize;
    match dimension {
        1 => {
            ysize = 1;
            zsize = 1;
        }
        2 => zsize = 1,
        3 => {}
        d => return Err(format!("SGI dimension {d} (1, 2 or 3 expected)")),
    }
    if storage > 1 {
        return Err(format!("SGI storage {storage} (0 verbatim or 1 RLE expected)"));
    }
    if bpc != 1 && bpc != 2 {
        return Err(format!("SGI bytes per channel {bpc} (1 or 2 expected)"));
    }
    if xsize == 0 || ysize == 0 || zsize == 0 {
        return Err("SGI image has no pixels".into());
    }
    if xsize.saturating_mul(ysize) > MAX_PIXELS {
        return Err(format!("SGI image of {xsize}×{ysize} pixels is too large"));
    }
    let used = zsize.min(3);
    let channels = if zsize == 2 || zsize == 1 { 1 } else { used };
    let max = if bpc == 1 { 255.0 } else { 65535.0 };
    let mut sum = vec![0f32; xsize * ysize];
    let mut row = vec![0u32; xsize];
    for z in 0..channels {
        for y in 0..ysize {
            if storage == 0 {
                let start = 512 + ((z * ysize + y) * xsize) * bpc;
                let data = b.get(start..start + xsize * bpc).ok_or("truncated SGI pixel data")?;
                for (x, v) in row.iter_mut().enumerate() {
                    *v = if bpc == 1 {
                        data[x] as u32
                    } else {
                        u16::from_be_bytes([data[2 * x], data[2 * x + 1]]) as u32
                    };
                }
            } else {
                let k = y + z * ysize;
                let start = be32(b, 512 + 4 * k)? as usize;
                let len = be32(b, 512 + 4 * ysize * zsize + 4 * k)? as usize;
                let data = b.get(start..start.saturating_add(len)).ok_or("SGI RLE row outside the file")?;
                rle_row(data, bpc, &mut row)?;
            }
            for (x, v) in row.iter().enumerate() {
                sum[y * xsize + x] += *v as f32 / max;
            }
        }
    }
    let values = sum.into_iter().map(|s| (s / channels as f32).clamp(0.0, 1.0)).collect();
    Ok(Intensity { width: xsize, height: ysize, values })
}

/// Expands one RLE row into `row` (missing values stay 0; extra values are an error).
fn rle_row(data: &[u8], bpc: usize, row: &mut [u32]) -> Result<(), String> {
    row.iter_mut().for_each(|v| *v = 0);
    let get = |i: usize| -> Result<u32, String> {
        let at = i * bpc;
        match bpc {
            1 => data.get(at).map(|&v| v as u32),
            _ => data.get(at..at + 2).map(|s| u16::from_be_bytes([s[0], s[1]]) as u32),
        }
        .ok_or_else(|| "truncated SGI RLE row".to_string())
    };
    let (mut i, mut x) = (0usize, 0usize);
    loop {
        let packet = get(i)?;
        i += 1;
        let count = (packet & 0x7f) as usize;
        if count == 0 {
            return Ok(());
        }
        if x + count > row.len() {
            return Err("SGI RLE row longer than the image width".into());
        }
        if packet & 0x80 != 0 {
            for slot in &mut row[x..x + count] {
                *slot = get(i)?;
                i += 1;
            }
        } else {
            let v = get(i)?;
            i += 1;
            row[x..x + count].iter_mut().for_each(|s| *s = v);
        }
        x += count;
    }
}

/// Decodes a PNG image (any colour type; palettes are expanded).
pub fn decode_png(bytes: &[u8]) -> Result<Intensity, String> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| format!("bad PNG: {e}"))?;
    let (w, h) = {
        let info = reader.info();
        (info.width as usize, info.height as usize)
    };
    if w == 0 || h == 0 || w.saturating_mul(h) > MAX_PIXELS {
        return Err(format!("PNG image of {w}×{h} pixels is empty or too large"));
    }
    let size = reader.output_buffer_size().ok_or("PNG image too large")?;
    let mut buf = vec![0; size];
    let info = reader.next_frame(&mut buf).map_err(|e| format!("bad PNG: {e}"))?;
    let (color, depth) = (info.color_type, info.bit_depth);
    let samples = color.samples();
    let bytes_per = if depth == png::BitDepth::Sixteen { 2 } else { 1 };
    if depth != png::BitDepth::Eight && depth != png::BitDepth::Sixteen {
        return Err(format!("PNG bit depth {depth:?} after expansion (8 or 16 expected)"));
    }
    let max = if bytes_per == 1 { 255.0 } else { 65535.0 };
    let channels = if samples <= 2 { 1 } else { 3 };
    let mut values = vec![0f32; w * h];
    for y in 0..h {
        let line = &buf[y * info.line_size..];
        for x in 0..w {
            let mut s = 0.0;
            for c in 0..channels {
                let at = (x * samples + c) * bytes_per;
                let v = if bytes_per == 1 {
                    line[at] as f32
                } else {
                    u16::from_be_bytes([line[at], line[at + 1]]) as f32
                };
                s += v / max;
            }
            // PNG rows run top to bottom; flip to bottom-up.
            values[(h - 1 - y) * w + x] = (s / channels as f32).clamp(0.0, 1.0);
        }
    }
    Ok(Intensity { width: w, height: h, values })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(storage: u8, bpc: u8, x: u16, y: u16, z: u16) -> Vec<u8> {
        let mut h = vec![0u8; 512];
        h[0..2].copy_from_slice(&474u16.to_be_bytes());
        h[2] = storage;
        h[3] = bpc;
        h[4..6].copy_from_slice(&3u16.to_be_bytes());
        h[6..8].copy_from_slice(&x.to_be_bytes());
        h[8..10].copy_from_slice(&y.to_be_bytes());
        h[10..12].copy_from_slice(&z.to_be_bytes());
        h
    }

    #[test]
    fn verbatim_sgi_rgb_and_grey() {
        // 2×1 RGB: (255,255,255) and (0,0,51).
        let mut b = header(0, 1, 2, 1, 3);
        b.extend([255, 0, 255, 0, 255, 51]);
        let img = decode(&b).unwrap();
        assert_eq!((img.width, img.height), (2, 1));
        assert_eq!(img.values[0], 1.0);
        assert!((img.values[1] - 51.0 / 255.0 / 3.0).abs() < 1e-6);
        // 16-bit grey with alpha: alpha ignored.
        let mut b = header(0, 2, 1, 1, 2);
        b.extend([0x80, 0x00, 0, 0]);
        assert!((decode(&b).unwrap().values[0] - 32768.0 / 65535.0).abs() < 1e-6);
    }

    #[test]
    fn rle_sgi_rows_bottom_up() {
        // 3×2 grey, RLE: bottom row 3×10 (repeat), top row literal 1,2,3.
        let mut b = header(1, 1, 3, 2, 1);
        let table = 512 + 2 * 4 * 2;
        let row0 = vec![0x03, 10, 0x00];
        let row1 = vec![0x83, 1, 2, 3, 0x00];
        let (s0, s1) = (table, table + row0.len());
        for s in [s0, s1] {
            b.extend((s as u32).to_be_bytes());
        }
        for l in [row0.len(), row1.len()] {
            b.extend((l as u32).to_be_bytes());
        }
        b.extend(&row0);
        b.extend(&row1);
        let img = decode(&b).unwrap();
        let px: Vec<u32> = img.values.iter().map(|v| (v * 255.0).round() as u32).collect();
        assert_eq!(px, vec![10, 10, 10, 1, 2, 3]);
        assert_eq!((img.at(0, 1) * 255.0).round(), 1.0, "row 1 is the upper row");
        // Broken files are errors, not panics.
        for cut in [10, 520, b.len() - 3] {
            assert!(decode(&b[..cut]).is_err(), "cut at {cut}");
        }
        let mut long = b.clone();
        long[table] = 0x05; // a run past the width
        assert!(decode(&long).is_err());
    }

    #[test]
    fn png_grey_is_flipped_to_bottom_up() {
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, 1, 2);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&[255, 0]).unwrap(); // top white, bottom black
        }
        let img = decode(&out).unwrap();
        assert_eq!(img.values, vec![0.0, 1.0]);
        assert!(decode(b"hello").is_err());
    }
}
