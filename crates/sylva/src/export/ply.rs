//! Binary PLY writer (Stanford polygon file format, `binary_little_endian 1.0`).
//!
//! All parts go into one vertex list and one face list (PLY has no groups; a `comment`
//! line per part records its name and ranges). Each vertex has `float x y z nx ny nz s
//! t`, `uchar red green blue` (its part's base colour in sRGB, so viewers such as
//! MeshLab show bark and leaves apart) and `ushort part` (the index of its part):
//! face-varying UVs and normals are unified into vertices exactly as for glTF
//! ([`super::unify`]); a part without normals gets smooth area-weighted ones, one
//! without UVs gets `s = t = 0`. Faces are `property list uchar uint vertex_indices`,
//! kept as polygons; a face with more than 255 corners (more than a `uchar` count can
//! say) is fan-triangulated.

use super::{validate_io, VertexData, GENERATOR};
use crate::model::Model;
use std::io::Write;

/// Bytes per vertex record: eight `float`s, three `uchar`s and a `ushort`.
const VERTEX_BYTES: usize = 37;

/// Writes `model` as a binary little-endian PLY file to `out`.
///
/// The model is validated first ([`super::validate_model`]); invalid geometry or a
/// model without triangles is an `InvalidData` I/O error.
pub fn write_ply(model: &Model, out: &mut dyn Write) -> std::io::Result<()> {
    validate_io(model)?;
    write_ply_unchecked(model, out)
}

/// Number of PLY faces written for a face of `n` corners.
#[inline]
fn faces_for(n: usize) -> usize {
    if n <= 255 {
        1
    } else {
        n - 2
    }
}

/// [`write_ply`] for a model already validated.
pub(crate) fn write_ply_unchecked(model: &Model, out: &mut dyn Write) -> std::io::Result<()> {
    let flat = model.flattened();
    let model = flat.as_ref();
    let parts: Vec<(&str, VertexData, [u8; 3])> = model
        .parts
        .iter()
        .filter(|p| p.mesh.face_count() > 0)
        .map(|p| {
            let c = p.material.base_color;
            let srgb = |x: f32| crate::texture::to_byte(crate::texture::linear_to_srgb(x));
            (p.name.as_str(), VertexData::new(&p.mesh), [srgb(c[0]), srgb(c[1]), srgb(c[2])])
        })
        .collect();
    let face_counts: Vec<usize> = parts
        .iter()
        .map(|(_, d, _)| d.mesh.face_offsets.windows(2).map(|w| faces_for((w[1] - w[0]) as usize)).sum())
        .collect();
    let vertex_total: usize = parts.iter().map(|(_, d, _)| d.unified.vertices.len()).sum();
    let face_total: usize = face_counts.iter().sum();
    if u32::try_from(vertex_total).is_err() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{vertex_total} vertices do not fit PLY's uint indices"),
        ));
    }

    let mut header = String::with_capacity(512);
    use std::fmt::Write as _;
    let _ = writeln!(header, "ply\nformat binary_little_endian 1.0\ncomment generator {GENERATOR}");
    let (mut v0, mut f0) = (0usize, 0usize);
    if parts.len() > u16::MAX as usize {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("{} parts do not fit PLY's ushort part index", parts.len()),
        ));
    }
    for ((name, d, _), &faces) in parts.iter().zip(&face_counts) {
        let nv = d.unified.vertices.len();
        let _ =
            writeln!(header, "comment part {name:?} vertices {v0}..{} faces {f0}..{}", v0 + nv, f0 + faces);
        v0 += nv;
        f0 += faces;
    }
    let _ = write!(
        header,
        "element vertex {vertex_total}\n\
         property float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\n\
         property float s\nproperty float t\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty ushort part\n\
         element face {face_total}\n\
         property list uchar uint vertex_indices\n\
         end_header\n"
    );
    out.write_all(header.as_bytes())?;

    // Vertices, one reused buffer per part.
    let mut buf: Vec<u8> = Vec::new();
    for (index, (_, d, rgb)) in parts.iter().enumerate() {
        buf.clear();
        buf.reserve(d.unified.vertices.len() * VERTEX_BYTES);
        for k in &d.unified.vertices {
            let p = d.position(k);
            let n = d.normal(k);
            let t = d.uv(k);
            for x in [p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y] {
                buf.extend_from_slice(&x.to_le_bytes());
            }
            buf.extend_from_slice(rgb);
            buf.extend_from_slice(&(index as u16).to_le_bytes());
        }
        out.write_all(&buf)?;
    }

    // Faces.
    let mut base = 0u32;
    for (_, d, _) in &parts {
        buf.clear();
        buf.reserve(d.mesh.face_indices.len() * 4 + d.mesh.face_count());
        let cv = &d.unified.corner_vertex;
        for w in d.mesh.face_offsets.windows(2) {
            let Some(face) = cv.get(w[0] as usize..w[1] as usize) else {
                continue;
            };
            if let Ok(n) = u8::try_from(face.len()) {
                buf.push(n);
                for &v in face {
                    buf.extend_from_slice(&(v + base).to_le_bytes());
                }
            } else if let Some((&first, rest)) = face.split_first() {
                for pair in rest.windows(2) {
                    buf.push(3);
                    for v in [first, pair[0], pair[1]] {
                        buf.extend_from_slice(&(v + base).to_le_bytes());
                    }
                }
            }
        }
        out.write_all(&buf)?;
        // Fits: the total vertex count was checked against u32 above.
        base += d.unified.vertices.len() as u32;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Mesh;
    use crate::model::{Material, Part};
    use glam::Vec3;

    #[test]
    fn big_polygon_is_fanned_small_ones_kept() {
        let mut mesh = Mesh::new();
        let n = 300u32;
        mesh.positions = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * std::f32::consts::TAU;
                Vec3::new(a.cos(), 0.0, -a.sin())
            })
            .collect();
        mesh.push_face(&(0..n).collect::<Vec<_>>());
        mesh.push_face(&[0, 1, 2, 3]);
        let model = Model {
            parts: vec![Part { name: "disc".into(), mesh, material: Material::leaf(), ..Default::default() }],
            ..Default::default()
        };
        let mut out = Vec::new();
        write_ply(&model, &mut out).unwrap();
        let end = out.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let header = std::str::from_utf8(&out[..end]).unwrap();
        assert!(header.contains("element vertex 300\n"), "{header}");
        assert!(header.contains("element face 299\n"), "{header}");
        assert!(header.contains(
            "property uchar red\nproperty uchar green\nproperty uchar blue\nproperty ushort part\n"
        ));
        assert_eq!(out.len() - end, 300 * 37 + 298 * 13 + (1 + 16));
        // The first vertex's colour is the leaf material's, in sRGB, and its part is 0.
        let c =
            Material::leaf().base_color.map(|x| crate::texture::to_byte(crate::texture::linear_to_srgb(x)));
        assert_eq!(&out[end + 32..end + 37], &[c[0], c[1], c[2], 0, 0]);
    }
}
