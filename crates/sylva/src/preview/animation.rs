//! The wind preview (issue 24, item 5): a model's looping clip drawn by the CPU preview
//! renderer ([`crate::preview`]) frame by frame, and written as an animated GIF or an
//! animated PNG (APNG), so a user sees the wind without a viewer (`--preview-wind`).
//!
//! The camera is fixed for the whole clip: it frames the rest pose's bounds grown by a
//! sixth of their largest extent on every side, so the swaying crown stays in the
//! picture. Frames are posed with
//! [`crate::wind::posed`] (linear blend skinning, as glTF readers do) at `fps` over one
//! clip length; the file loops forever.

use crate::error::{Error, Result};
use crate::model::Model;
use crate::preview::{render, Image, PreviewOptions};

/// Most frames an animation may hold.
pub const MAX_FRAMES: usize = 1200;

/// The frames of one loop of `model`'s clip at `fps`, rendered with `opts` (its `frame`
/// is replaced by the rest pose's bounds with room to sway). A model without a rig or clip
/// gives one frame.
///
/// Errors: an `fps` outside `1..=60`, more than [`MAX_FRAMES`] frames, or what
/// [`render`] reports.
pub fn wind_frames(model: &Model, opts: &PreviewOptions, fps: u32) -> Result<Vec<Image>> {
    if !(1..=60).contains(&fps) {
        return Err(Error::InvalidGeometry {
            what: "wind preview".into(),
            why: format!("{fps} frames per second; use 1..=60"),
        });
    }
    let flat = model.flattened();
    let mut opts = opts.clone();
    if let Some((lo, hi)) = flat.bounds() {
        // Room for the crown to sway: a sixth of the largest extent on every side.
        let pad = glam::Vec3::splat((hi - lo).max_element() / 6.0);
        opts.frame = Some((lo - pad, hi + pad));
    }
    let duration = model.clip.as_ref().map_or(0.0, |c| c.duration());
    let frames =
        if model.rig.is_some() && duration > 0.0 { (duration * fps as f32).round() as usize } else { 1 };
    if frames > MAX_FRAMES {
        return Err(Error::InvalidGeometry {
            what: "wind preview".into(),
            why: format!("{frames} frames ({duration} s at {fps} fps); at most {MAX_FRAMES}"),
        });
    }
    (0..frames.max(1))
        .map(|f| {
            let t = f as f32 / fps as f32;
            render(&crate::wind::posed(&flat, t), &opts)
        })
        .collect()
}

/// Writes `frames` as a looping animation at `fps`: an animated GIF for a `.gif` path,
/// an animated PNG for `.png` / `.apng`, atomically.
///
/// Errors: no frames, frames of different sizes, an unknown extension, or a failed write.
pub fn write_animation(frames: &[Image], fps: u32, path: &std::path::Path) -> Result<()> {
    let mut set = crate::fsutil::OutputSet::new(path);
    stage_animation(frames, fps, path, &mut set)?;
    set.commit()
}

/// [`write_animation`], staged into `set` (written to a temporary that reaches `path`
/// when the set is committed with the run's other outputs, [`crate::fsutil::OutputSet`]).
pub fn stage_animation(
    frames: &[Image],
    fps: u32,
    path: &std::path::Path,
    set: &mut crate::fsutil::OutputSet,
) -> Result<()> {
    let bad = |why: String| Error::InvalidGeometry { what: format!("animation {}", path.display()), why };
    let Some(first) = frames.first() else { return Err(bad("no frames".into())) };
    let size = (first.width, first.height);
    stage_animation_with(size, frames.len(), fps, path, set, |k| Ok::<_, Error>(frames[k].clone()))
}

/// Most bytes of pixels (RGBA, 4 per pixel) an animation or a frame sequence may have
/// in all its frames together: 16 GiB, e.g. 1200 frames of 1920×1080, 60 of 8192×8192
/// (issue 39: 1200 frames of 8192×8192 are 322 GB of pictures; frames are streamed to
/// the file one at a time, so this bounds the work and the output, not the memory).
pub const MAX_ANIMATION_BYTES: u64 = 16 << 30;

/// The bytes of pixels of `frames` RGBA frames of `width × height`, or an error saying
/// how much that is when it is over [`MAX_ANIMATION_BYTES`] (checked before any frame is
/// drawn).
pub fn animation_bytes(frames: u64, (width, height): (u32, u32)) -> std::result::Result<u64, String> {
    let frame = width as u64 * height as u64 * 4;
    let total = frames.saturating_mul(frame);
    if total > MAX_ANIMATION_BYTES {
        return Err(format!(
            "{frames} frames of {width}x{height} pixels ({frame} bytes each) are {total} bytes of pictures, \
             more than the limit of {MAX_ANIMATION_BYTES} bytes"
        ));
    }
    Ok(total)
}

/// Streams `count` frames of `width × height` into an animation at `path` staged in
/// `set` (a GIF for `.gif`, an animated PNG for `.png` / `.apng`): frame `k` is made by
/// `frame(k)` when the encoder needs it and dropped once it is encoded, so memory does
/// not grow with the frame count. An error from `frame` is returned as it is (the
/// temporary is removed; nothing reaches `path`).
///
/// Errors: no frames, a frame of another size, more pixels than
/// [`MAX_ANIMATION_BYTES`], an unknown extension, `frame`'s error, or a failed write.
pub fn stage_animation_with<E: From<Error>>(
    (w, h): (u32, u32),
    count: usize,
    fps: u32,
    path: &std::path::Path,
    set: &mut crate::fsutil::OutputSet,
    mut frame: impl FnMut(usize) -> std::result::Result<Image, E>,
) -> std::result::Result<(), E> {
    let bad = |why: String| Error::InvalidGeometry { what: format!("animation {}", path.display()), why };
    if count == 0 {
        return Err(bad("no frames".into()).into());
    }
    animation_bytes(count as u64, (w, h)).map_err(|why| E::from(bad(why)))?;
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let fps = fps.clamp(1, 100);
    let io = |e: &dyn std::fmt::Display| std::io::Error::other(e.to_string());
    // The first error of `frame` (or a frame of the wrong size), kept whole; the
    // encoder sees a plain I/O error and stops.
    let mut failed: Option<E> = None;
    // Frames are RGBA (GIF and APNG both take RGBA here); an RGB frame gains alpha 255.
    let mut next = |k: usize| -> std::io::Result<Image> {
        let checked = frame(k).map(Image::into_rgba).and_then(|f| {
            if (f.width, f.height) != (w, h) {
                return Err(bad(format!("frame {k} is {}x{}, not {w}x{h}", f.width, f.height)).into());
            }
            f.check(&format!("frame {k} of animation {}", path.display()))?;
            Ok(f)
        });
        checked.map_err(|e| {
            failed = Some(e);
            std::io::Error::other("a frame failed")
        })
    };
    let staged = match ext.as_str() {
        "gif" => {
            let (gw, gh) = (
                u16::try_from(w).map_err(|_| E::from(bad(format!("{w} pixels is too wide for GIF"))))?,
                u16::try_from(h).map_err(|_| E::from(bad(format!("{h} pixels is too tall for GIF"))))?,
            );
            set.stage(path, |out| {
                let mut enc = gif::Encoder::new(out, gw, gh, &[]).map_err(|e| io(&e))?;
                enc.set_repeat(gif::Repeat::Infinite).map_err(|e| io(&e))?;
                for k in 0..count {
                    let mut rgba = next(k)?.data;
                    let mut frame = gif::Frame::from_rgba_speed(gw, gh, &mut rgba, 10);
                    frame.delay = (100 / fps) as u16;
                    enc.write_frame(&frame).map_err(|e| io(&e))?;
                }
                Ok(())
            })
        }
        "png" | "apng" => set.stage(path, |out| {
            let mut enc = png::Encoder::new(out, w, h);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            let frames = u32::try_from(count).map_err(|e| io(&e))?;
            enc.set_animated(frames, 0).map_err(|e| io(&e))?;
            enc.set_frame_delay(1, fps as u16).map_err(|e| io(&e))?;
            let mut writer = enc.write_header().map_err(|e| io(&e))?;
            for k in 0..count {
                writer.write_image_data(&next(k)?.data).map_err(|e| io(&e))?;
            }
            writer.finish().map_err(|e| io(&e))
        }),
        _ => return Err(bad(format!("`.{ext}` is not an animation format; use .gif or .png (APNG)")).into()),
    };
    match failed {
        Some(e) => Err(e),
        None => staged.map_err(E::from),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(v: u8) -> Image {
        Image::from_rgba(4, 3, vec![v; 48])
    }

    #[test]
    fn gif_and_apng_are_written_and_bad_input_is_refused() {
        let dir = std::env::temp_dir().join(format!("sylva-anim-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let frames = [frame(10), frame(200)];
        let gif = dir.join("a.gif");
        write_animation(&frames, 15, &gif).unwrap();
        assert_eq!(&std::fs::read(&gif).unwrap()[..6], b"GIF89a");
        let png = dir.join("a.png");
        write_animation(&frames, 15, &png).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert!(bytes.windows(4).any(|w| w == b"acTL"), "an animated PNG");
        assert!(write_animation(&[], 15, &gif).is_err());
        assert!(write_animation(&[frame(1), Image::from_rgba(2, 2, vec![0; 16])], 15, &gif).is_err());
        let e = write_animation(&frames, 15, &dir.join("a.bmp")).unwrap_err();
        assert!(e.to_string().contains(".bmp"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
