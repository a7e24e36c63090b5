//! Images, textures, samplers and PBR metallic-roughness materials (glTF2 §3.8–§3.9):
//! PNG in a buffer view or a relative `uri`, repeat for bark, clamp for the leaf atlas.

use super::{base64_into, pad4};
use crate::error::Result;
use crate::export::TextureMode;
use crate::model::Model;
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use json::Index;

/// The glTF texture index of each model image (`None` for [`TextureMode::None`]).
pub(super) type TextureIndex = Vec<Option<Index<json::Texture>>>;

/// Adds the model's images, one texture per image and the two samplers (repeat, clamp);
/// returns the texture of each image.
pub(super) fn push_textures(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: Index<json::Buffer>,
    model: &Model,
    mode: &TextureMode,
    glb: bool,
) -> Result<TextureIndex> {
    if model.images.is_empty() || matches!(mode, TextureMode::None) {
        return Ok(vec![None; model.images.len()]);
    }
    use json::texture::{MagFilter, MinFilter, WrappingMode};
    let sampler = |root: &mut json::Root, wrap: WrappingMode| {
        root.push(json::texture::Sampler {
            mag_filter: Some(Valid(MagFilter::Linear)),
            min_filter: Some(Valid(MinFilter::LinearMipmapLinear)),
            name: None,
            wrap_s: Valid(wrap),
            wrap_t: Valid(wrap),
            extensions: None,
            extras: Default::default(),
        })
    };
    let uses = |repeat: bool| model.images.iter().any(|i| i.repeat == repeat);
    let repeat = uses(true).then(|| sampler(root, WrappingMode::Repeat));
    let clamp = uses(false).then(|| sampler(root, WrappingMode::ClampToEdge));
    let pngs: Vec<Vec<u8>> = match mode {
        TextureMode::Embed => {
            use rayon::prelude::*;
            model.images.par_iter().map(|i| i.image.to_png()).collect::<Result<_>>()?
        }
        _ => Vec::new(),
    };
    let mut out = Vec::with_capacity(model.images.len());
    for (k, im) in model.images.iter().enumerate() {
        let (uri, buffer_view, mime_type) = match mode {
            TextureMode::Files { prefix } => (Some(format!("{prefix}{}.png", im.name)), None, None),
            _ if glb => {
                let start = bin.len();
                bin.extend_from_slice(&pngs[k]);
                let view = root.push(json::buffer::View {
                    buffer,
                    byte_length: USize64::from(pngs[k].len()),
                    byte_offset: Some(USize64::from(start)),
                    byte_stride: None,
                    name: None,
                    target: None,
                    extensions: None,
                    extras: Default::default(),
                });
                bin.resize(pad4(bin.len()), 0);
                (None, Some(view), Some(json::image::MimeType("image/png".into())))
            }
            _ => {
                let mut uri = String::from("data:image/png;base64,");
                base64_into(&pngs[k], &mut uri);
                (Some(uri), None, None)
            }
        };
        let source = root.push(json::Image {
            buffer_view,
            mime_type,
            name: Some(im.name.clone()),
            uri,
            extensions: None,
            extras: Default::default(),
        });
        out.push(Some(root.push(json::Texture {
            name: Some(im.name.clone()),
            sampler: if im.repeat { repeat } else { clamp },
            source,
            extensions: None,
            extras: Default::default(),
        })));
    }
    Ok(out)
}

/// The texture a material map `image` is written with: only where the part has UVs
/// and the image was written.
pub(super) fn map_texture(
    image: Option<u32>,
    has_uvs: bool,
    texture_of: &TextureIndex,
) -> Option<Index<json::Texture>> {
    image.filter(|_| has_uvs).and_then(|i| texture_of.get(i as usize).copied().flatten())
}

/// The glTF material of `m`; maps only where the part has UVs and the image was written.
pub(super) fn material(
    m: &crate::model::Material,
    has_uvs: bool,
    texture_of: &TextureIndex,
) -> json::Material {
    let tex = |i: Option<u32>| map_texture(i, has_uvs, texture_of);
    let info =
        |index| json::texture::Info { index, tex_coord: 0, extensions: None, extras: Default::default() };
    let base = tex(m.maps.base_color);
    let orm = tex(m.maps.occlusion_roughness_metallic);
    let alpha_mode = if m.alpha_cutoff.is_some() && base.is_some() {
        json::material::AlphaMode::Mask
    } else if m.base_color[3] < 1.0 {
        json::material::AlphaMode::Blend
    } else {
        json::material::AlphaMode::Opaque
    };
    // With a colour map the map carries the colour; with an ORM map it carries the roughness.
    let factor = if base.is_some() { [1.0, 1.0, 1.0, m.base_color[3]] } else { m.base_color };
    json::Material {
        name: Some(m.name.clone()),
        alpha_cutoff: (alpha_mode == json::material::AlphaMode::Mask)
            .then(|| json::material::AlphaCutoff(m.alpha_cutoff.unwrap_or(0.5).clamp(0.0, 1.0))),
        alpha_mode: Valid(alpha_mode),
        double_sided: m.double_sided,
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(factor.map(|c| c.clamp(0.0, 1.0))),
            base_color_texture: base.map(info),
            metallic_factor: json::material::StrengthFactor(m.metallic.clamp(0.0, 1.0)),
            roughness_factor: json::material::StrengthFactor(if orm.is_some() {
                1.0
            } else {
                m.roughness.clamp(0.0, 1.0)
            }),
            metallic_roughness_texture: orm.map(info),
            ..Default::default()
        },
        normal_texture: tex(m.maps.normal).map(|index| json::material::NormalTexture {
            index,
            scale: 1.0,
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        }),
        occlusion_texture: orm.map(|index| json::material::OcclusionTexture {
            index,
            strength: json::material::StrengthFactor(1.0),
            tex_coord: 0,
            extensions: None,
            extras: Default::default(),
        }),
        ..Default::default()
    }
}
