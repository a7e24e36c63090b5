//! SVG output for 2D drawings: every filled shape of a [`Picture`] becomes one
//! `<path>` (vector paths, not pixels), painted in order over an optional background
//! rectangle. Used by the magnetic curves of Xu2015 ch. 7 ([`crate::curves`]).
//!
//! The document's `viewBox` is the picture in drawing units (y down); `width` and
//! `height` give the displayed size in pixels. Coordinates are written with two
//! decimals, colours as `#rrggbb` with a `fill-opacity` only when not opaque, so the
//! output is deterministic and compact. Files are written through
//! [`crate::fsutil::write_atomic`].

use super::render::{pixel_size, Picture, Rgba};
use crate::error::Result;
use crate::fsutil::write_atomic;
use std::fmt::Write as _;
use std::path::Path;

/// Writes `x` rounded to two decimals, without trailing zeros (`-0` becomes `0`).
/// Hand-rolled: formatting dominates the writer's time otherwise.
fn num(out: &mut String, x: f32) {
    let r = (x as f64 * 100.0).round();
    if !r.is_finite() || r.abs() > 1e17 {
        out.push('0');
        return;
    }
    let r = r as i64;
    let n = r.unsigned_abs();
    if r < 0 {
        out.push('-');
    }
    let (int, frac) = (n / 100, n % 100);
    let mut digits = [0u8; 20];
    let mut k = digits.len();
    let mut v = int;
    loop {
        k -= 1;
        digits[k] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    for &d in &digits[k..] {
        out.push(d as char);
    }
    if frac != 0 {
        out.push('.');
        out.push((b'0' + (frac / 10) as u8) as char);
        if frac % 10 != 0 {
            out.push((b'0' + (frac % 10) as u8) as char);
        }
    }
}

fn hex(c: Rgba) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The SVG document for `picture`, displayed `width_px` pixels wide (the height follows
/// the aspect ratio). One `<path>` per shape.
pub fn to_svg(picture: &Picture, width_px: u32) -> Result<String> {
    let (w, h) = pixel_size(picture, width_px)?;
    let mut out =
        String::with_capacity(64 + picture.shapes.iter().map(|s| s.polygon.len() * 14 + 48).sum::<usize>());
    let _ = writeln!(out, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = write!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{w}" height="{h}" viewBox="0 0 "#
    );
    num(&mut out, picture.width as f32);
    out.push(' ');
    num(&mut out, picture.height as f32);
    out.push_str("\">\n");
    let _ = writeln!(out, "<!-- {} -->", crate::export::GENERATOR);
    if let Some(bg) = picture.background {
        let _ = write!(out, r#"<rect x="0" y="0" width="100%" height="100%" fill="{}""#, hex(bg));
        if bg[3] != 255 {
            let _ = write!(out, r#" fill-opacity="{:.3}""#, bg[3] as f64 / 255.0);
        }
        out.push_str("/>\n");
    }
    for s in &picture.shapes {
        if s.polygon.is_empty() {
            continue;
        }
        out.push_str("<path d=\"M");
        for (i, p) in s.polygon.iter().enumerate() {
            if i == 1 {
                out.push('L');
            } else if i > 1 {
                out.push(' ');
            }
            num(&mut out, p.x);
            out.push(' ');
            num(&mut out, p.y);
        }
        let _ = write!(out, "Z\" fill=\"{}\"", hex(s.color));
        if s.color[3] != 255 {
            let _ = write!(out, r#" fill-opacity="{:.3}""#, s.color[3] as f64 / 255.0);
        }
        out.push_str("/>\n");
    }
    out.push_str("</svg>\n");
    Ok(out)
}

/// Writes `picture` as an SVG file, atomically (no partial file on failure).
pub fn write(picture: &Picture, path: &Path, width_px: u32) -> Result<()> {
    let text = to_svg(picture, width_px)?;
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curves::render::Shape;
    use glam::Vec2;

    #[test]
    fn paths_and_numbers() {
        let pic = Picture {
            width: 10.0,
            height: 5.0,
            background: Some([255, 255, 255, 255]),
            shapes: vec![Shape {
                polygon: vec![Vec2::new(0.0, 0.0), Vec2::new(1.25, -0.001), Vec2::new(3.5, 2.0)],
                color: [255, 0, 16, 128],
            }],
        };
        let s = to_svg(&pic, 200).unwrap();
        assert!(s.contains(r#"width="200" height="100" viewBox="0 0 10 5""#), "{s}");
        assert!(s.contains(r##"<path d="M0 0L1.25 0 3.5 2Z" fill="#ff0010" fill-opacity="0.502"/>"##), "{s}");
        assert_eq!(s.matches("<path").count(), 1);
        let mut t = String::new();
        for x in [0.0f32, -0.001, 1.005, -12.5, 100.0, 0.07, -0.3, 123456.78] {
            num(&mut t, x);
            t.push(' ');
        }
        assert_eq!(t, "0 0 1 -12.5 100 0.07 -0.3 123456.78 ");
    }
}
