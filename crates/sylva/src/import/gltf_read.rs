//! A small glTF 2.0 reader for checking meshes: `.glb` and `.gltf` (buffers as base64
//! data URIs or files beside the document) → one indexed [`Mesh`] per triangle
//! primitive, positions and indices only.
//!
//! It exists for `sylva check` (issue 5 item 5) and for tests that read back what the
//! exporters wrote; it is not a general glTF importer (no node transforms, no sparse
//! accessors, no Draco). glTF stores one vertex per distinct (position, normal, UV)
//! tuple, so a seam splits vertices; [`weld`] merges vertices with bit-identical
//! positions to recover the surface's topology before checking it.

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use glam::Vec3;
use gltf_json as json;
use json::validation::Checked::Valid;
use std::collections::HashMap;
use std::path::Path;

/// A triangle primitive read from a glTF file.
#[derive(Debug, Clone)]
pub struct GltfMesh {
    /// `mesh-name` or `mesh-name/primitive-index` when a mesh has several primitives.
    pub name: String,
    /// Positions and triangles (empty when [`GltfMesh::same_as`] is set).
    pub mesh: Mesh,
    /// `Some(i)` when this primitive has the same triangles as the `i`-th primitive
    /// returned (the same POSITION and index accessors, or accessors with equal
    /// contents): its `mesh` is then left empty, so a file that draws one primitive
    /// hundreds of times is read, and checked, once.
    pub same_as: Option<usize>,
}

fn bad(path: &Path, why: impl Into<String>) -> Error {
    Error::InvalidGeometry { what: path.display().to_string(), why: why.into() }
}

/// Reads every triangle primitive of a `.glb` or `.gltf` file.
pub fn read_gltf(path: &Path) -> Result<Vec<GltfMesh>> {
    let bytes = crate::input::read_input(path, crate::input::DEFAULT_MAX_BYTES)?;
    let (json_bytes, glb_bin) =
        if bytes.starts_with(b"glTF") { split_glb(path, &bytes)? } else { (&bytes[..], None) };
    let root: json::Root =
        serde_json::from_slice(json_bytes).map_err(|e| bad(path, format!("not a glTF document: {e}")))?;
    let mut buffers = Vec::with_capacity(root.buffers.len());
    for (i, b) in root.buffers.iter().enumerate() {
        let data = match (&b.uri, glb_bin) {
            (None, Some(bin)) if i == 0 => bin.to_vec(),
            (None, _) => return Err(bad(path, format!("buffer {i} has no uri and no GLB chunk"))),
            (Some(uri), _) => {
                if let Some(pos) = uri.find(";base64,").filter(|_| uri.starts_with("data:")) {
                    base64_decode(&uri[pos + 8..])
                        .ok_or_else(|| bad(path, format!("buffer {i}: bad base64")))?
                } else {
                    let rel = Path::new(uri);
                    // The uri is the file's text: quoted clipped (a broken data URI is the
                    // whole buffer in base64).
                    let uri = crate::diagnostic::quote(uri);
                    if uri.starts_with("data:") {
                        return Err(bad(
                            path,
                            format!("buffer {i}: uri `{uri}` is a data URI without `;base64,` (the only kind read)"),
                        ));
                    }
                    if rel.is_absolute() || uri.contains(':') {
                        return Err(bad(
                            path,
                            format!("buffer {i}: uri `{uri}` is not a relative file name"),
                        ));
                    }
                    let file = path.parent().unwrap_or(Path::new(".")).join(rel);
                    // A regular file of at most byteLength + 4 bytes (not a device or a pipe,
                    // which could be read forever).
                    let meta = std::fs::metadata(&file)
                        .map_err(|source| Error::Read { path: file.clone(), source })?;
                    if !meta.is_file() {
                        return Err(bad(path, format!("buffer {i}: `{uri}` is not a regular file")));
                    }
                    if meta.len() > b.byte_length.0.saturating_add(4).max(1 << 20) {
                        return Err(bad(
                            path,
                            format!(
                                "buffer {i}: `{uri}` holds {} bytes, byteLength says {}",
                                meta.len(),
                                b.byte_length.0
                            ),
                        ));
                    }
                    let most = b.byte_length.0.saturating_add(4).max(1 << 20);
                    crate::input::read_input(&file, most.min(crate::input::DEFAULT_MAX_BYTES))?
                }
            }
        };
        if (data.len() as u64) < b.byte_length.0 {
            return Err(bad(
                path,
                format!("buffer {i} holds {} bytes, byteLength says {}", data.len(), b.byte_length.0),
            ));
        }
        buffers.push(data);
    }
    let mut out: Vec<GltfMesh> = Vec::new();
    // Primitives already read, by their (POSITION, indices) accessors and by a hash of
    // their contents: a repeated primitive is read once.
    let mut by_accessors: HashMap<(usize, Option<usize>), usize> = HashMap::new();
    let mut by_contents: HashMap<u64, Vec<usize>> = HashMap::new();
    for (mi, m) in root.meshes.iter().enumerate() {
        let mesh_name = m.name.clone().unwrap_or_else(|| format!("mesh {mi}"));
        for (pi, p) in m.primitives.iter().enumerate() {
            let name = if m.primitives.len() > 1 { format!("{mesh_name}/{pi}") } else { mesh_name.clone() };
            if p.mode != Valid(json::mesh::Mode::Triangles) {
                continue;
            }
            let pos = p
                .attributes
                .get(&Valid(json::mesh::Semantic::Positions))
                .ok_or_else(|| bad(path, format!("{name}: no POSITION attribute")))?;
            let accessors = (pos.value(), p.indices.as_ref().map(|ix| ix.value()));
            if let Some(&first) = by_accessors.get(&accessors) {
                out.push(GltfMesh { name, mesh: Mesh::new(), same_as: Some(first) });
                continue;
            }
            let ctx = |why: String| bad(path, format!("{name}: {why}"));
            let floats = read_accessor(&root, &buffers, pos.value()).map_err(ctx)?;
            if floats.1 != 3 {
                return Err(bad(path, format!("{name}: POSITION is not VEC3")));
            }
            let positions: Vec<Vec3> =
                floats.0.chunks_exact(3).map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)).collect();
            if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
                return Err(bad(path, format!("{name}: POSITION {k} is not finite")));
            }
            let indices: Vec<u32> = match &p.indices {
                Some(ix) => {
                    let (vals, n) = read_accessor(&root, &buffers, ix.value()).map_err(ctx)?;
                    if n != 1 {
                        return Err(bad(path, format!("{name}: indices are not SCALAR")));
                    }
                    vals.into_iter().map(|v| v as u32).collect()
                }
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&v) = indices.iter().find(|&&v| v as usize >= positions.len()) {
                return Err(bad(
                    path,
                    format!("{name}: index {v} is out of range ({} vertices)", positions.len()),
                ));
            }
            if !indices.len().is_multiple_of(3) {
                return Err(bad(path, format!("{name}: {} indices is not a multiple of 3", indices.len())));
            }
            let hash = contents_hash(&positions, &indices);
            let earlier = by_contents.entry(hash).or_default();
            let same = earlier.iter().copied().find(|&i| {
                let m = &out[i].mesh;
                m.positions == positions && m.face_indices == indices
            });
            if let Some(first) = same {
                by_accessors.insert(accessors, first);
                out.push(GltfMesh { name, mesh: Mesh::new(), same_as: Some(first) });
                continue;
            }
            earlier.push(out.len());
            by_accessors.insert(accessors, out.len());
            let mut mesh = Mesh::new();
            mesh.positions = positions;
            for t in indices.chunks_exact(3) {
                mesh.push_face(t);
            }
            out.push(GltfMesh { name, mesh, same_as: None });
        }
    }
    Ok(out)
}

/// A hash of a primitive's positions (their bits) and indices, to find repeated ones.
fn contents_hash(positions: &[Vec3], indices: &[u32]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    positions.len().hash(&mut h);
    for p in positions {
        p.to_array().map(f32::to_bits).hash(&mut h);
    }
    indices.hash(&mut h);
    h.finish()
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk.
fn split_glb<'a>(path: &Path, b: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>)> {
    let u32_at = |o: usize| b.get(o..o + 4).map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as usize);
    let (Some(version), Some(total)) = (u32_at(4), u32_at(8)) else {
        return Err(bad(path, "GLB header truncated"));
    };
    if version != 2 || total > b.len() {
        return Err(bad(path, format!("GLB version {version}, length {total} of {} bytes", b.len())));
    }
    let mut at = 12;
    let mut chunks = Vec::new();
    while at + 8 <= total {
        let (len, kind) = (u32_at(at).unwrap_or(0), u32_at(at + 4).unwrap_or(0));
        let data = b.get(at + 8..at + 8 + len).ok_or_else(|| bad(path, "GLB chunk runs past the end"))?;
        chunks.push((kind, data));
        at += 8 + len;
    }
    match chunks.as_slice() {
        [(0x4E4F_534A, json), rest @ ..] => {
            Ok((json, rest.first().filter(|c| c.0 == 0x004E_4942).map(|c| c.1)))
        }
        _ => Err(bad(path, "GLB does not start with a JSON chunk")),
    }
}

/// Reads an accessor as f64 values with its component count (1 for SCALAR, 3 for VEC3).
fn read_accessor(root: &json::Root, buffers: &[Vec<u8>], index: usize) -> Result<(Vec<f64>, usize), String> {
    use json::accessor::{ComponentType, Type};
    let a = root.accessors.get(index).ok_or(format!("accessor {index} does not exist"))?;
    let n = match a.type_ {
        Valid(Type::Scalar) => 1,
        Valid(Type::Vec2) => 2,
        Valid(Type::Vec3) => 3,
        Valid(Type::Vec4) => 4,
        _ => return Err(format!("accessor {index}: unsupported type")),
    };
    let (size, read): (usize, fn(&[u8]) -> f64) = match a.component_type {
        Valid(json::accessor::GenericComponentType(ComponentType::F32)) => {
            (4, |s| f32::from_le_bytes([s[0], s[1], s[2], s[3]]) as f64)
        }
        Valid(json::accessor::GenericComponentType(ComponentType::U32)) => {
            (4, |s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]) as f64)
        }
        Valid(json::accessor::GenericComponentType(ComponentType::U16)) => {
            (2, |s| u16::from_le_bytes([s[0], s[1]]) as f64)
        }
        Valid(json::accessor::GenericComponentType(ComponentType::U8)) => (1, |s| s[0] as f64),
        _ => return Err(format!("accessor {index}: unsupported component type")),
    };
    let view_index =
        a.buffer_view.as_ref().ok_or(format!("accessor {index}: no buffer view (sparse?)"))?.value();
    let view = root.buffer_views.get(view_index).ok_or(format!("buffer view {view_index} does not exist"))?;
    let buf = buffers.get(view.buffer.value()).ok_or(format!("buffer view {view_index}: no such buffer"))?;
    // Every offset and length is checked in u64 before anything is read or allocated:
    // a count or offset near 2⁶⁴ must not wrap around into a small number.
    let past = || format!("accessor {index}: {} elements run past its buffer view", a.count.0);
    let view_start = view.byte_offset.map_or(0, |o| o.0);
    let start = view_start.checked_add(a.byte_offset.map_or(0, |o| o.0)).ok_or_else(past)?;
    let elem = (size * n) as u64;
    let stride = view.byte_stride.map_or(elem, |s| s.0 as u64);
    if stride < elem {
        return Err(format!(
            "accessor {index}: byteStride {stride} is shorter than an element ({elem} bytes)"
        ));
    }
    let end = view_start.checked_add(view.byte_length.0).ok_or_else(past)?.min(buf.len() as u64);
    let count = a.count.0;
    if count > 0 {
        let last = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(start))
            .and_then(|x| x.checked_add(elem));
        if last.is_none_or(|l| l > end) {
            return Err(past());
        }
    }
    let (count, start, stride) = (count as usize, start as usize, stride as usize);
    let mut out = Vec::with_capacity(count * n);
    for i in 0..count {
        for c in 0..n {
            let o = start + i * stride + c * size;
            out.push(read(&buf[o..o + size]));
        }
    }
    Ok((out, n))
}

/// Decodes standard base64 (padding optional); `None` on a bad character.
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let bytes: Vec<u8> = s.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()).collect();
    let mut out = Vec::with_capacity(bytes.len() * 3 / 4);
    for chunk in bytes.chunks(4) {
        let mut acc = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * i);
        }
        let produced = match chunk.len() {
            4 => 3,
            3 => 2,
            2 => 1,
            _ => return None,
        };
        for k in 0..produced {
            out.push((acc >> (16 - 8 * k)) as u8);
        }
    }
    Some(out)
}

/// Merges vertices with bit-identical positions (glTF splits them at UV and normal
/// seams), keeping the first; faces are re-indexed. Returns the number merged.
pub fn weld(mesh: &mut Mesh) -> usize {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let mut remap = Vec::with_capacity(mesh.positions.len());
    let mut kept = Vec::with_capacity(mesh.positions.len());
    for p in &mesh.positions {
        let key = p.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() });
        let id = *first.entry(key).or_insert_with(|| {
            kept.push(*p);
            kept.len() as u32 - 1
        });
        remap.push(id);
    }
    let merged = mesh.positions.len() - kept.len();
    mesh.positions = kept;
    for v in &mut mesh.face_indices {
        if let Some(&r) = remap.get(*v as usize) {
            *v = r;
        }
    }
    mesh.uvs = None;
    mesh.normals = None;
    merged
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_every_padding() {
        for (enc, dec) in
            [("", &b""[..]), ("Zg==", b"f"), ("Zm8=", b"fo"), ("Zm9v", b"foo"), ("Zm9vYg", b"foob")]
        {
            assert_eq!(base64_decode(enc).unwrap(), dec);
        }
        assert!(base64_decode("Zm9v!").is_none());
    }

    /// Campaign finding (stop 51, readers run 15263): a data URI that lost its `;base64,`
    /// was quoted whole — a 114 KB message. Now it is named as such and clipped.
    #[test]
    fn a_broken_data_uri_is_named_and_clipped() {
        let dir = std::env::temp_dir().join(format!("sylva-gltf-uri-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("broken.gltf");
        let uri = format!("data:application/octet-stream;base64{}", "QUJD".repeat(30_000));
        let doc =
            format!(r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"uri":"{uri}","byteLength":90000}}]}}"#);
        std::fs::write(&file, doc).unwrap();
        let e = read_gltf(&file).unwrap_err().to_string();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(e.contains("data URI without `;base64,`"), "{e}");
        assert!(e.len() < 1000, "a message of {} bytes", e.len());
    }
}
