//! Textures drawn once per what they depend on: the bark maps by (style, size, seed),
//! the leaf atlas by (size, colour, seed) — never by the tree. A session keeps one
//! [`TextureCache`] across updates, so changing a leaf, wind or generator setting
//! redraws nothing (the aspen's maps are about 80 % of a default grow's CPU).

use super::bark::{bark_maps, BarkMaps, BarkStyle};
use super::leaf::leaf_atlas;
use crate::image::Image;
use std::sync::Arc;

/// What the bark maps depend on: style, edge in pixels, seed.
pub type BarkKey = (BarkStyle, u32, u64);

/// What the leaf atlas depends on: edge in pixels, linear RGB colour, seed.
pub type AtlasKey = (u32, [f32; 3], u64);

/// Drawn textures by what they depend on. At most [`TextureCache::CAPACITY`] of each
/// kind are kept (the oldest goes first), so a long editing session does not grow
/// without bound.
#[derive(Debug, Default)]
pub struct TextureCache {
    bark: Vec<(BarkKey, BarkMaps)>,
    atlas: Vec<(AtlasKey, Arc<Image>)>,
    drawn: usize,
}

impl TextureCache {
    /// Textures kept per kind.
    pub const CAPACITY: usize = 4;

    /// The bark maps and the leaf atlas's image for the keys given (`None`: not wanted),
    /// drawn in parallel where missing, shared with the cache. With this thread's cancellation token set
    /// ([`crate::cancel`]) a drawing stops early and is neither kept nor returned
    /// (`None`); the caller checks the token.
    pub fn get(
        &mut self,
        bark: Option<BarkKey>,
        atlas: Option<AtlasKey>,
    ) -> (Option<BarkMaps>, Option<Arc<Image>>) {
        let have_bark =
            bark.and_then(|k| self.bark.iter().find(|(key, _)| *key == k).map(|(_, m)| m.clone()));
        let have_atlas = atlas
            .and_then(|k| self.atlas.iter().find(|(key, _)| same_atlas(key, &k)).map(|(_, a)| a.clone()));
        let draw_bark = bark.filter(|_| have_bark.is_none());
        let draw_atlas = atlas.filter(|_| have_atlas.is_none());
        // The two drawings may run on other threads: they carry this thread's token.
        let token = crate::cancel::current();
        let (new_bark, new_atlas) = rayon::join(
            || {
                crate::cancel::scope_opt(token.as_ref(), || {
                    draw_bark.map(|(st, size, seed)| bark_maps(st, size, seed))
                })
            },
            || {
                crate::cancel::scope_opt(token.as_ref(), || {
                    draw_atlas.map(|(size, colour, seed)| Arc::new(leaf_atlas(size, colour, seed).image))
                })
            },
        );
        if crate::cancel::cancelled() {
            return (None, None);
        }
        let bark_out = match (draw_bark, new_bark) {
            (Some(k), Some(m)) => {
                self.drawn += 1;
                keep(&mut self.bark, k, m.clone());
                Some(m)
            }
            _ => have_bark,
        };
        let atlas_out = match (draw_atlas, new_atlas) {
            (Some(k), Some(a)) => {
                self.drawn += 1;
                keep(&mut self.atlas, k, a.clone());
                Some(a)
            }
            _ => have_atlas,
        };
        (bark_out, atlas_out)
    }

    /// How many textures (bark map sets and atlases) this cache has drawn.
    pub fn drawn(&self) -> usize {
        self.drawn
    }
}

/// Atlas keys compare their colours bit for bit (no NaN can reach here; the colour is
/// the leaf material's).
fn same_atlas(a: &AtlasKey, b: &AtlasKey) -> bool {
    a.0 == b.0 && a.2 == b.2 && a.1.map(f32::to_bits) == b.1.map(f32::to_bits)
}

fn keep<K, V>(list: &mut Vec<(K, V)>, key: K, value: V) {
    if list.len() >= TextureCache::CAPACITY {
        list.remove(0);
    }
    list.push((key, value));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn maps_are_drawn_once_per_style_size_and_seed() {
        let mut cache = TextureCache::default();
        let (a, none) = cache.get(Some((BarkStyle::Birch, 32, 7)), None);
        assert!(none.is_none());
        let (b, _) = cache.get(Some((BarkStyle::Birch, 32, 7)), None);
        assert_eq!(cache.drawn(), 1);
        assert_eq!(a, b);
        let (c, _) = cache.get(Some((BarkStyle::Birch, 32, 8)), None);
        assert_eq!(cache.drawn(), 2);
        assert_ne!(a, c);
        let (_, atlas) = cache.get(None, Some((48, [0.2, 0.5, 0.1], 1)));
        let (_, again) = cache.get(None, Some((48, [0.2, 0.5, 0.1], 1)));
        assert_eq!(cache.drawn(), 3);
        assert_eq!(atlas, again);
        for seed in 0..6 {
            cache.get(Some((BarkStyle::Smooth, 16, seed)), None);
        }
        assert!(cache.bark.len() <= TextureCache::CAPACITY);
    }

    #[test]
    fn a_cancelled_drawing_is_not_kept() {
        let token = crate::cancel::Cancel::new();
        token.cancel();
        let mut cache = TextureCache::default();
        let (maps, _) = crate::cancel::scope(&token, || cache.get(Some((BarkStyle::Plated, 64, 1)), None));
        assert!(maps.is_none());
        assert_eq!(cache.drawn(), 0);
    }
}
