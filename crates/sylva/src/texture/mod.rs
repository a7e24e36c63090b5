//! Procedural textures (issue 23): bark maps that tile around and along a branch and a
//! leaf atlas with alpha, generated in code from the recipe's seed — no image files are
//! shipped and nothing is downloaded. The exporters embed them (glTF `images`) or write
//! them beside the model; the CPU preview samples them.
//!
//! Plain data below the exporters: this module imports only `error`, `image` and
//! `noise` (and `glam`).
//!
//! - [`bark`]: albedo, tangent-space normal and occlusion-roughness-metallic maps in four
//!   styles (smooth, furrowed, plated, birch-like with lenticels).
//! - [`leaf`]: an atlas of leaf shapes (ovate, lanceolate, lobed, compound, needle tuft,
//!   and a cluster of ovate leaves for cluster cards) with veins and alpha, each cell's
//!   base at the bottom and tip at the top (UV base→tip along +v).

pub mod bark;
pub mod cache;
pub mod leaf;

pub use crate::image::Image;
pub use cache::TextureCache;

use crate::error::{Error, Result};

/// Linear → sRGB transfer (IEC 61966-2-1), for colour maps (glTF base colour textures
/// are sRGB; factors and the other maps are linear).
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// sRGB → linear transfer, the inverse of [`linear_to_srgb`].
pub fn srgb_to_linear(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// A linear value in \[0, 1\] as an sRGB byte, through a 4096-entry table (the
/// transfer's `powf` per channel would cost more than the noise of a bark map).
#[inline]
pub(crate) fn srgb_byte(lin: f32) -> u8 {
    static LUT: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    let lut = LUT.get_or_init(|| (0..4096).map(|i| to_byte(linear_to_srgb(i as f32 / 4095.0))).collect());
    lut[(lin.clamp(0.0, 1.0) * 4095.0 + 0.5) as usize]
}

/// A value in \[0, 1\] as a byte (rounded).
#[inline]
pub(crate) fn to_byte(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Which textures a recipe asks for and how large (`[textures]`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TextureOptions {
    /// Edge of the square bark maps in pixels (16–4096; default 1024).
    pub bark_size: u32,
    /// Edge of the square leaf atlas in pixels (16–4096; default 1024).
    pub atlas_size: u32,
    /// Bark style: `auto` (`None`: the generator's), `smooth`, `furrowed`, `plated` or
    /// `birch`.
    #[serde(with = "auto")]
    pub bark: Option<bark::BarkStyle>,
    /// Bark texture repeats per unit of the meshers' bark UVs (0.01–100; default 1):
    /// 2 draws the pattern at half the size. The meshers' UVs keep square texels where
    /// they can (one unit of u around a branch), so this is the one knob per tree.
    pub scale: f32,
}

impl Default for TextureOptions {
    fn default() -> Self {
        TextureOptions { bark_size: 1024, atlas_size: 1024, bark: None, scale: 1.0 }
    }
}

impl TextureOptions {
    /// Checks the ranges; errors name the key (`textures.bark_size` …).
    pub fn check(&self) -> Result<()> {
        for (k, v) in [("bark_size", self.bark_size), ("atlas_size", self.atlas_size)] {
            if !(16..=4096).contains(&v) {
                return Err(Error::Recipe(format!("`textures.{k}` must be in 16..=4096, got {v}")));
            }
        }
        if !(0.01..=100.0).contains(&self.scale) {
            return Err(Error::Recipe(format!("`textures.scale` must be in 0.01..=100, got {}", self.scale)));
        }
        Ok(())
    }
}

/// Serde of an optional mode written `auto` when unset (`leaves.shape`,
/// `textures.bark`): `None` is `auto`, `Some(v)` is `v`'s name.
pub mod auto {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Writes `auto` for `None`, else the value.
    pub fn serialize<T: Serialize, S: Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            None => s.serialize_str("auto"),
            Some(v) => v.serialize(s),
        }
    }

    /// Reads `auto` as `None`, else the value; an unknown name lists `auto` with the
    /// value's names.
    pub fn deserialize<'de, T, D>(d: D) -> Result<Option<T>, D::Error>
    where
        T: Deserialize<'de>,
        D: Deserializer<'de>,
    {
        use serde::de::{Error, IntoDeserializer};
        let name = String::deserialize(d)?;
        if name == "auto" {
            return Ok(None);
        }
        let inner: serde::de::value::StringDeserializer<serde::de::value::Error> = name.into_deserializer();
        T::deserialize(inner).map(Some).map_err(|e| {
            let why = e.to_string();
            D::Error::custom(match why.split_once("expected one of ") {
                Some((head, list)) => format!("{head}expected one of `auto`, {list}"),
                None => why
                    .replacen(", expected `", ", expected one of `auto`, `", 1)
                    .replacen("` or `", "`, `", 1),
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_table_matches_the_transfer() {
        for i in 0..=1000 {
            let x = i as f32 / 1000.0;
            let exact = to_byte(linear_to_srgb(x)) as i32;
            assert!((srgb_byte(x) as i32 - exact).abs() <= 1, "{x}");
        }
        assert_eq!((srgb_byte(-1.0), srgb_byte(2.0), srgb_byte(f32::NAN)), (0, 255, 0));
    }

    #[test]
    fn srgb_round_trips() {
        for i in 0..=20 {
            let x = i as f32 / 20.0;
            assert!((srgb_to_linear(linear_to_srgb(x)) - x).abs() < 1e-5);
        }
    }

    #[test]
    fn option_ranges_are_checked() {
        assert!(TextureOptions::default().check().is_ok());
        let e = TextureOptions { bark_size: 8, ..Default::default() }.check().unwrap_err();
        assert!(e.to_string().contains("textures.bark_size"), "{e}");
        let e = toml::from_str::<TextureOptions>("bark = \"mossy\"").unwrap_err().to_string();
        assert!(e.contains("mossy") && e.contains("`auto`, `smooth`, `furrowed`"), "{e}");
        let t: TextureOptions = toml::from_str("bark = \"birch\"").unwrap();
        assert_eq!(t.bark, Some(bark::BarkStyle::Birch));
        assert_eq!(
            toml::to_string(&TextureOptions::default()).unwrap().lines().nth(2),
            Some("bark = \"auto\"")
        );
    }
}
