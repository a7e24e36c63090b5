//! `EXT_meshopt_compression`: every geometry view encoded with meshoptimizer into a
//! fallback buffer without data (meshoptimizer, glTF2).

use super::Layout;
use crate::error::{Error, Result};

/// With `output.compress = "meshopt"`: the `EXT_meshopt_compression` encoding of a
/// view's bytes (vertex codec version 0, the extension's; index codec version 1, header
/// `0xe1`) and the extension's `byteStride`, `count` and `mode` (the caller adds
/// `buffer`, `byteOffset` and `byteLength`).
pub(super) fn meshopt_encode(
    bytes: &[u8],
    count: usize,
    layout: Layout,
) -> Result<(Vec<u8>, serde_json::Map<String, serde_json::Value>)> {
    let failed = |e: meshopt::Error| Error::InvalidGeometry {
        what: "model".into(),
        why: format!("meshopt compression failed: {e:?}"),
    };
    let (encoded, stride, mode) = match layout {
        Layout::Vertices { stride } | Layout::Instances { stride } | Layout::Data { stride } => {
            let encoded = match stride {
                4 => meshopt_attributes::<4>(bytes),
                8 => meshopt_attributes::<8>(bytes),
                12 => meshopt_attributes::<12>(bytes),
                16 => meshopt_attributes::<16>(bytes),
                64 => meshopt_attributes::<64>(bytes),
                _ => {
                    return Err(Error::InvalidGeometry {
                        what: "model".into(),
                        why: format!("meshopt: no attribute codec for {stride}-byte elements"),
                    })
                }
            };
            (encoded.map_err(failed)?, stride, "ATTRIBUTES")
        }
        Layout::Triangles { size } => {
            let indices: Vec<u32> = match size {
                2 => bytes.chunks_exact(2).map(|c| u16::from_le_bytes([c[0], c[1]]) as u32).collect(),
                _ => bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect(),
            };
            let vertices = indices.iter().max().map_or(0, |&m| m as usize + 1);
            // meshopt's default index codec is version 1; its header byte is 0xe1.
            let encoded = meshopt::encoding::encode_index_buffer(&indices, vertices).map_err(failed)?;
            if encoded.first() != Some(&0xe1) {
                return Err(Error::InvalidGeometry {
                    what: "model".into(),
                    why: "meshopt wrote an index stream EXT_meshopt_compression cannot read".into(),
                });
            }
            (encoded, size, "TRIANGLES")
        }
    };
    let mut ext = serde_json::Map::new();
    ext.insert("byteStride".into(), stride.into());
    ext.insert("count".into(), count.into());
    ext.insert("mode".into(), mode.into());
    Ok((encoded, ext))
}

/// `bytes` as elements of `N` bytes through meshopt's attribute codec, version 0 (the one
/// `EXT_meshopt_compression` specifies).
fn meshopt_attributes<const N: usize>(bytes: &[u8]) -> std::result::Result<Vec<u8>, meshopt::Error> {
    let (elements, _) = bytes.as_chunks::<N>();
    meshopt::encoding::encode_vertex_buffer_level(elements, 2, Some(0))
}
