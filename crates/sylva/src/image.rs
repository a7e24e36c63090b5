//! The one 8-bit image type: procedural textures ([`crate::texture`]), impostor atlases
//! ([`crate::lod`]), the CPU preview ([`crate::preview`]), the GPU renderer's read-back
//! and the curves rasterizer ([`crate::curves::render`]) all hold an [`Image`] — RGB or
//! RGBA bytes, rows top to bottom — and encode it to PNG with [`Image::encode_png`] (the
//! one still-image PNG writer; animations stream frames through `preview::animation`).
//!
//! Plain data: this module imports only `error`. Sampling follows the mesh convention
//! (origin bottom left, v up, repeating), as the exporters' glTF samplers do.

use crate::error::{Error, Result};

/// An 8-bit image, rows top to bottom (image convention), `channels` bytes per pixel.
///
/// [`crate::preview::render`] and the GPU renderer return 4-channel (RGBA) images;
/// bark maps are RGB. [`Image::pixel`], [`Image::texel`] and [`Image::sample`] read
/// either as RGBA (alpha 255, or 1, for RGB).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// 3 (RGB) or 4 (RGBA).
    pub channels: u8,
    /// `width · height · channels` bytes, row-major from the top row.
    pub data: Vec<u8>,
}

impl Image {
    /// A black (transparent) image.
    pub fn new(width: u32, height: u32, channels: u8) -> Self {
        Image { width, height, channels, data: vec![0; width as usize * height as usize * channels as usize] }
    }

    /// A 4-channel image of `rgba` (`width · height · 4` bytes, row-major from the top
    /// row; [`Image::check`] tells whether the length fits).
    pub fn from_rgba(width: u32, height: u32, rgba: Vec<u8>) -> Self {
        Image { width, height, channels: 4, data: rgba }
    }

    /// This image with 4 channels: RGB pixels gain alpha 255, an RGBA image is returned
    /// as it is.
    pub fn into_rgba(self) -> Image {
        if self.channels != 3 {
            return self;
        }
        let data = self.data.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255]).collect();
        Image::from_rgba(self.width, self.height, data)
    }

    /// Checks that the image is not empty, has 3 or 4 channels and as many bytes as its
    /// size says; the error names `what` (e.g. "preview image", "texture `bark`").
    pub fn check(&self, what: &str) -> Result<()> {
        let bad = |why: String| Error::InvalidGeometry { what: what.into(), why };
        if !matches!(self.channels, 3 | 4) {
            return Err(bad(format!("{} channels; 3 (RGB) or 4 (RGBA) expected", self.channels)));
        }
        let expected = self.width as u64 * self.height as u64 * self.channels as u64;
        if self.width == 0 || self.height == 0 || self.data.len() as u64 != expected {
            return Err(bad(format!(
                "{}×{} image has {} bytes, expected {expected}",
                self.width,
                self.height,
                self.data.len()
            )));
        }
        Ok(())
    }

    /// The pixel at column `x`, row `y` (0 = top) as RGBA bytes (alpha 255 for an RGB
    /// image), or `None` outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> Option<[u8; 4]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let c = self.channels as usize;
        let i = (y as usize * self.width as usize + x as usize) * c;
        let p = self.data.get(i..i + c)?;
        Some([p[0], p[1], p[2], if c == 4 { p[3] } else { 255 }])
    }

    /// `images` side by side, left to right, in one image (a comparison strip).
    ///
    /// Errors: no images, or images of different heights or channel counts, or one
    /// whose buffer does not match its size ([`Image::check`]).
    pub fn side_by_side(images: &[Image]) -> Result<Image> {
        let bad = |why: String| Error::InvalidGeometry { what: "side-by-side image".into(), why };
        let Some(first) = images.first() else { return Err(bad("no images".into())) };
        let (h, c) = (first.height, first.channels);
        for (k, im) in images.iter().enumerate() {
            im.check(&format!("side-by-side image {k}"))?;
            if (im.height, im.channels) != (h, c) {
                return Err(bad(format!(
                    "image {k} is {} rows of {} channels, image 0 is {h} of {c}",
                    im.height, im.channels
                )));
            }
        }
        let width = images.iter().map(|im| im.width).sum();
        let mut data = Vec::with_capacity(width as usize * h as usize * c as usize);
        for y in 0..h as usize {
            for im in images {
                let row = im.width as usize * c as usize;
                data.extend_from_slice(&im.data[y * row..(y + 1) * row]);
            }
        }
        Ok(Image { width, height: h, channels: c, data })
    }

    /// Encodes the image as an 8-bit PNG (RGB or RGBA as it is stored) into `w`, with
    /// fast DEFLATE (textures and previews are regenerated, not archived).
    pub fn encode_png(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        self.encode_png_with(w, png::Compression::Fast)
    }

    /// [`Image::encode_png`] at another `compression` (the curves writer takes the
    /// fastest, the docs' pictures the highest).
    pub fn encode_png_with(
        &self,
        w: &mut dyn std::io::Write,
        compression: png::Compression,
    ) -> std::io::Result<()> {
        let mut enc = png::Encoder::new(w, self.width, self.height);
        enc.set_color(if self.channels == 4 { png::ColorType::Rgba } else { png::ColorType::Rgb });
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(compression);
        let mut writer = enc.write_header().map_err(std::io::Error::other)?;
        writer.write_image_data(&self.data).map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    }

    /// [`Image::encode_png`] into memory.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        let mut out = Vec::new();
        self.encode_png(&mut out).map_err(|e| Error::InvalidGeometry {
            what: "texture".into(),
            why: format!("PNG encoding failed: {e}"),
        })?;
        Ok(out)
    }

    /// The texel at (x, y), wrapped, as RGBA in \[0, 1\] (alpha 1 for RGB images).
    pub fn texel(&self, x: i64, y: i64) -> [f32; 4] {
        let (w, h) = (self.width.max(1) as i64, self.height.max(1) as i64);
        let (x, y) = (x.rem_euclid(w) as u32, y.rem_euclid(h) as u32);
        match self.pixel(x, y) {
            Some(p) => p.map(|v| v as f32 / 255.0),
            None => [0.0; 4],
        }
    }

    /// Bilinear sample at texture coordinate (u, v) with the mesh convention (origin
    /// bottom left, v up), repeating outside \[0, 1\].
    pub fn sample(&self, u: f32, v: f32) -> [f32; 4] {
        let x = u * self.width as f32 - 0.5;
        let y = (1.0 - v) * self.height as f32 - 0.5;
        if !x.is_finite() || !y.is_finite() {
            return [0.0; 4];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (xi, yi) = (x0 as i64, y0 as i64);
        let (a, b, c, d) =
            (self.texel(xi, yi), self.texel(xi + 1, yi), self.texel(xi, yi + 1), self.texel(xi + 1, yi + 1));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sampling_wraps_and_interpolates() {
        let mut im = Image::new(2, 1, 3);
        im.data = vec![0, 0, 0, 255, 255, 255];
        // The centre of the left texel is u = 0.25; halfway to the right one is u = 0.5.
        assert!(im.sample(0.25, 0.5)[0] < 1e-6);
        assert!((im.sample(0.5, 0.5)[0] - 0.5).abs() < 1e-6);
        // u = 1.0 lies between the right texel and the wrapped left one.
        assert!((im.sample(1.0, 0.5)[0] - 0.5).abs() < 1e-6);
        assert_eq!(im.sample(0.75, 0.5)[3], 1.0);
        let png = im.to_png().unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }

    #[test]
    fn pixels_read_rgb_and_rgba_alike() {
        let rgb = Image { width: 2, height: 1, channels: 3, data: vec![1, 2, 3, 4, 5, 6] };
        assert_eq!(rgb.pixel(1, 0), Some([4, 5, 6, 255]));
        assert_eq!(rgb.pixel(2, 0), None);
        let rgba = rgb.clone().into_rgba();
        assert_eq!((rgba.channels, rgba.data.len()), (4, 8));
        assert_eq!(rgba.pixel(1, 0), Some([4, 5, 6, 255]));
        assert_eq!(rgba.clone().into_rgba(), rgba);
        assert_eq!(rgb.texel(-1, 0), rgba.texel(1, 0));
    }

    #[test]
    fn side_by_side_joins_rows() {
        let a = Image::from_rgba(1, 2, vec![1, 1, 1, 1, 2, 2, 2, 2]);
        let b = Image::from_rgba(2, 2, (10..26).collect());
        let ab = Image::side_by_side(&[a.clone(), b.clone()]).unwrap();
        assert_eq!((ab.width, ab.height, ab.channels), (3, 2, 4));
        assert_eq!(ab.pixel(0, 1), a.pixel(0, 1));
        assert_eq!(ab.pixel(2, 1), b.pixel(1, 1));
        assert!(Image::side_by_side(&[]).is_err());
        assert!(Image::side_by_side(&[a, Image::new(1, 3, 4)]).is_err());
    }

    #[test]
    fn check_names_what_is_wrong() {
        assert!(Image::new(2, 2, 4).check("x").is_ok());
        let e = Image::from_rgba(2, 2, vec![0; 3]).check("preview image").unwrap_err().to_string();
        assert!(e.contains("preview image") && e.contains("2×2 image has 3 bytes, expected 16"), "{e}");
        let e = Image::new(1, 1, 2).check("texture `t`").unwrap_err().to_string();
        assert!(e.contains("texture `t`") && e.contains("2 channels"), "{e}");
        assert!(Image::new(0, 3, 4).check("x").is_err());
    }

    #[test]
    fn png_round_trips_both_layouts() {
        for channels in [3u8, 4] {
            let mut im = Image::new(3, 2, channels);
            im.data.iter_mut().enumerate().for_each(|(i, v)| *v = (i * 7) as u8);
            let png = im.to_png().unwrap();
            let mut reader = png::Decoder::new(std::io::Cursor::new(png)).read_info().unwrap();
            let mut buf = vec![0; reader.output_buffer_size().unwrap()];
            let info = reader.next_frame(&mut buf).unwrap();
            assert_eq!((info.width, info.height), (3, 2));
            assert_eq!(&buf[..info.buffer_size()], &im.data[..]);
        }
    }
}
