//! The preset picker's pictures: the preset catalogue (`docs/presets/*.png`, written by
//! tools/regen-previews.sh) reduced to [`SIDE`]² at build time (build.rs) and uploaded
//! to egui the first time the picker opens.

use std::collections::HashMap;

include!(concat!(env!("OUT_DIR"), "/thumbnails.rs"));

/// The side of a thumbnail, pixels.
pub const SIDE: usize = 64;

/// The RGBA pixels of preset `name`'s picture, if the build had one.
pub fn pixels(name: &str) -> Option<&'static [u8]> {
    THUMBNAILS.binary_search_by(|(n, _)| n.cmp(&name)).ok().map(|i| THUMBNAILS[i].1)
}

/// The pictures as egui textures, made on first use.
#[derive(Default)]
pub struct Thumbnails {
    textures: HashMap<&'static str, egui::TextureHandle>,
}

impl std::fmt::Debug for Thumbnails {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Thumbnails").field("uploaded", &self.textures.len()).finish()
    }
}

impl Thumbnails {
    /// The texture of preset `name`'s picture (`None`: the build had none).
    pub fn get(&mut self, ctx: &egui::Context, name: &'static str) -> Option<egui::TextureHandle> {
        if let Some(t) = self.textures.get(name) {
            return Some(t.clone());
        }
        let rgba = pixels(name)?;
        let image = egui::ColorImage::from_rgba_unmultiplied([SIDE, SIDE], rgba);
        let t = ctx.load_texture(format!("preset {name}"), image, egui::TextureOptions::LINEAR);
        self.textures.insert(name, t.clone());
        Some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every tree preset has a picture in the picker (a new preset needs
    /// tools/regen-previews.sh), each the right size and not one flat colour.
    #[test]
    fn every_tree_preset_has_a_picture() {
        for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
            let rgba = pixels(p.name).unwrap_or_else(|| panic!("no picture for preset {}", p.name));
            assert_eq!(rgba.len(), SIDE * SIDE * 4, "{}", p.name);
            let first = &rgba[..4];
            assert!(rgba.chunks(4).any(|px| px != first), "{} is one flat colour", p.name);
        }
        assert!(THUMBNAILS.windows(2).all(|w| w[0].0 < w[1].0), "the table is sorted by name");
    }
}
