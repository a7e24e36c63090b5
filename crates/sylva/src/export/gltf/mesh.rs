//! Meshes and primitives: unified vertices, exact position bounds, `KHR_mesh_quantization`
//! grids, tangents, and instanced nodes with `EXT_mesh_gpu_instancing` (glTF2 §3.7).

use super::rig::Channels;
use super::textures::{map_texture, material, TextureIndex};
use super::{node, put_u32, Doc, Layout, INSTANCING};
use crate::error::{Error, Result};
use crate::export::VertexData;
use crate::model::Part;
use gltf_json as json;
use json::validation::Checked::Valid;
use json::Index;

/// How quantized positions decode: `p = offset + q · step` (the node's translation and
/// uniform scale, `KHR_mesh_quantization`).
#[derive(Debug, Clone, Copy)]
pub(super) struct Dequant {
    pub(super) offset: glam::Vec3,
    pub(super) step: f32,
}

/// Writes one part's mesh (one primitive, with `channels`) and its material; returns the
/// mesh and, for quantized positions, how they decode (for the node that shows the mesh).
pub(super) fn push_mesh(
    doc: &mut Doc,
    part: &Part,
    data: &VertexData,
    texture_of: &TextureIndex,
    channels: &Channels,
) -> Result<(Index<json::Mesh>, Option<Dequant>)> {
    let positions = if doc.quantize() {
        let (lo, hi) = position_bounds(data);
        Positions::Grid(grid(lo, hi))
    } else {
        Positions::Float
    };
    let primitive = push_primitive(doc, part, data, texture_of, positions, channels)?;
    Ok(push_primitives(doc, part.name.clone(), vec![primitive], positions))
}

/// Writes a mesh called `name` of `primitives`, whose positions are written as
/// `positions` says; returns the mesh and, for quantized positions, how they decode.
pub(super) fn push_primitives(
    doc: &mut Doc,
    name: String,
    primitives: Vec<json::mesh::Primitive>,
    positions: Positions,
) -> (Index<json::Mesh>, Option<Dequant>) {
    let mesh = doc.root.push(json::Mesh {
        name: Some(name),
        primitives,
        extensions: None,
        extras: Default::default(),
        weights: None,
    });
    let dequant = match positions {
        Positions::Grid(d) => Some(d),
        Positions::Float => None,
    };
    (mesh, dequant)
}

/// How a primitive's positions are written.
#[derive(Debug, Clone, Copy)]
pub(super) enum Positions {
    /// `FLOAT`.
    Float,
    /// `UNSIGNED_SHORT` on this grid (`KHR_mesh_quantization`).
    Grid(Dequant),
}

/// The bounds of a part's output vertices.
pub(super) fn position_bounds(data: &VertexData) -> (glam::Vec3, glam::Vec3) {
    let (mut lo, mut hi) = (glam::Vec3::splat(f32::INFINITY), glam::Vec3::splat(f32::NEG_INFINITY));
    for k in &data.unified.vertices {
        lo = lo.min(data.position(k));
        hi = hi.max(data.position(k));
    }
    (lo, hi)
}

/// The uniform unsigned 16-bit grid over the box `lo`–`hi`.
pub(super) fn grid(lo: glam::Vec3, hi: glam::Vec3) -> Dequant {
    let extent = (hi - lo).max_element();
    let step = if extent > 0.0 { extent / 65535.0 } else { 1.0 };
    Dequant { offset: lo, step }
}

/// Writes one part's primitive (positions as `positions` says, `channels` beyond the
/// usual attributes) and its material.
pub(super) fn push_primitive(
    doc: &mut Doc,
    part: &Part,
    data: &VertexData,
    texture_of: &TextureIndex,
    positions: Positions,
    channels: &Channels,
) -> Result<json::mesh::Primitive> {
    // A hero mesh's primitive takes a second to encode: a cancelled run stops between.
    crate::cancel::check()?;
    use json::accessor::{ComponentType as C, Type as T};
    use json::mesh::Semantic;
    let verts = &data.unified.vertices;
    let count = verts.len();
    let mut attributes = std::collections::BTreeMap::new();
    let quantize = doc.quantize();
    let vertices = |stride| Layout::Vertices { stride };

    // POSITION, with its bounds.
    let (lo, hi) = position_bounds(data);
    let bounds = |v: glam::Vec3| json::Value::from(v.to_array().to_vec());
    if let Positions::Grid(Dequant { offset, step }) = positions {
        // Unsigned 16-bit on a uniform grid (padded to 8 bytes).
        let mut bytes = Vec::with_capacity(8 * count);
        let (mut qlo, mut qhi) = ([u16::MAX; 3], [0u16; 3]);
        for k in verts {
            let q = ((data.position(k) - offset) / step)
                .round()
                .clamp(glam::Vec3::ZERO, glam::Vec3::splat(65535.0));
            for (c, x) in q.to_array().into_iter().enumerate() {
                let x = x as u16;
                qlo[c] = qlo[c].min(x);
                qhi[c] = qhi[c].max(x);
                bytes.extend_from_slice(&x.to_le_bytes());
            }
            bytes.extend_from_slice(&[0, 0]);
        }
        let view = doc.view(&bytes, count, vertices(8))?;
        let (min, max) = (json::Value::from(qlo.to_vec()), json::Value::from(qhi.to_vec()));
        let acc = doc.accessor(view, count, C::U16, T::Vec3, false, Some(min), Some(max));
        attributes.insert(Valid(Semantic::Positions), acc);
    } else {
        let positions = verts.iter().map(|k| data.position(k).to_array());
        let acc = doc.floats(positions, T::Vec3, vertices(12), Some((bounds(lo), bounds(hi))))?;
        attributes.insert(Valid(Semantic::Positions), acc);
    }

    // NORMAL, always unit length (8-bit normalized when quantized).
    if quantize {
        let bytes: Vec<u8> =
            verts.iter().flat_map(|k| snorm8(data.normal(k).extend(0.0).to_array())).collect();
        let view = doc.view(&bytes, count, vertices(4))?;
        let acc = doc.accessor(view, count, C::I8, T::Vec3, true, None, None);
        attributes.insert(Valid(Semantic::Normals), acc);
    } else {
        let normals = verts.iter().map(|k| data.normal(k).to_array());
        let acc = doc.floats(normals, T::Vec3, vertices(12), None)?;
        attributes.insert(Valid(Semantic::Normals), acc);
    }

    // TEXCOORD_0, v flipped to glTF's top-left origin; 16-bit normalized when quantized
    // and every UV lies in [0, 1] (repeating bark UVs stay float).
    if data.has_uvs() {
        let uvs: Vec<[f32; 2]> = verts.iter().map(|k| data.uv(k)).map(|uv| [uv.x, 1.0 - uv.y]).collect();
        if quantize && uvs.iter().flatten().all(|x| (0.0..=1.0).contains(x)) {
            let bytes: Vec<u8> =
                uvs.iter().flatten().flat_map(|&x| ((x * 65535.0).round() as u16).to_le_bytes()).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            let acc = doc.accessor(view, count, C::U16, T::Vec2, true, None, None);
            attributes.insert(Valid(Semantic::TexCoords(0)), acc);
        } else {
            let acc = doc.floats(uvs.into_iter(), T::Vec2, vertices(8), None)?;
            attributes.insert(Valid(Semantic::TexCoords(0)), acc);
        }
    }

    // TANGENT where a normal map will be read (so no runtime has to guess one).
    if map_texture(part.material.maps.normal, data.has_uvs(), texture_of).is_some() {
        let t = tangents(part, data);
        let acc = if quantize {
            let bytes: Vec<u8> = t.iter().flat_map(|&v| snorm8(v)).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            doc.accessor(view, count, C::I8, T::Vec4, true, None, None)
        } else {
            doc.floats(t.into_iter(), T::Vec4, vertices(16), None)?
        };
        attributes.insert(Valid(Semantic::Tangents), acc);
    }

    // Skinning: JOINTS_0 (8- or 16-bit) and WEIGHTS_0 per mesh position.
    let at = |k: &crate::export::VertexKey| k.position as usize;
    if let Some(skin) = &channels.skin {
        let none = ([0u16; 4], [1.0, 0.0, 0.0, 0.0]);
        let entry = |k: &crate::export::VertexKey| skin.entries.get(at(k)).copied().unwrap_or(none);
        let acc = if skin.small {
            let bytes: Vec<u8> = verts.iter().flat_map(|k| entry(k).0.map(|j| j as u8)).collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            doc.accessor(view, count, C::U8, T::Vec4, false, None, None)
        } else {
            let bytes: Vec<u8> = verts.iter().flat_map(|k| entry(k).0).flat_map(u16::to_le_bytes).collect();
            let view = doc.view(&bytes, count, vertices(8))?;
            doc.accessor(view, count, C::U16, T::Vec4, false, None, None)
        };
        attributes.insert(Valid(Semantic::Joints(0)), acc);
        let acc = doc.floats(verts.iter().map(|k| entry(k).1), T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Weights(0)), acc);
    }

    // The wind channels: `_WIND`, `_PIVOT` and, packed for shaders, COLOR_0 / TEXCOORD_1.
    let value = |ch: &[[f32; 4]], k: &crate::export::VertexKey| ch.get(at(k)).copied().unwrap_or([0.0; 4]);
    if !channels.wind.is_empty() {
        let wind = verts.iter().map(|k| value(channels.wind, k));
        let acc = doc.floats(wind, T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Extras("WIND".into())), acc);
        if channels.wind_colors {
            let unorm8 = |x: f32| (x.clamp(0.0, 1.0) * 255.0).round() as u8;
            let bytes: Vec<u8> = verts
                .iter()
                .flat_map(|k| {
                    let w = value(channels.wind, k);
                    [w[3], w[2], w[1], w[0]].map(unorm8)
                })
                .collect();
            let view = doc.view(&bytes, count, vertices(4))?;
            let acc = doc.accessor(view, count, C::U8, T::Vec4, true, None, None);
            attributes.insert(Valid(Semantic::Colors(0)), acc);
            let trunk_branch = verts.iter().map(|k| value(channels.wind, k)).map(|w| [w[0], w[1]]);
            let acc = doc.floats(trunk_branch, T::Vec2, vertices(8), None)?;
            attributes.insert(Valid(Semantic::TexCoords(1)), acc);
            // glTF numbers texture coordinate sets without gaps: a part without UVs gets
            // zero TEXCOORD_0, so the wind stays in set 1 on every primitive.
            if !data.has_uvs() {
                let acc = doc.floats(verts.iter().map(|_| [0.0f32; 2]), T::Vec2, vertices(8), None)?;
                attributes.insert(Valid(Semantic::TexCoords(0)), acc);
            }
        }
    }
    if !channels.pivot.is_empty() {
        let pivot = verts.iter().map(|k| value(channels.pivot, k));
        let acc = doc.floats(pivot, T::Vec4, vertices(16), None)?;
        attributes.insert(Valid(Semantic::Extras("PIVOT".into())), acc);
    }

    // Indices: every face fan-triangulated, u16 where every index fits.
    let short = count < 65_536;
    let mut bytes = Vec::with_capacity(part.mesh.triangle_count() * if short { 6 } else { 12 });
    let cv = &data.unified.corner_vertex;
    let put = |bin: &mut Vec<u8>, i: u32| {
        if short {
            bin.extend_from_slice(&(i as u16).to_le_bytes());
        } else {
            put_u32(bin, i);
        }
    };
    for w in part.mesh.face_offsets.windows(2) {
        let Some(face) = cv.get(w[0] as usize..w[1] as usize) else {
            continue;
        };
        let Some((&first, rest)) = face.split_first() else {
            continue;
        };
        for pair in rest.windows(2) {
            put(&mut bytes, first);
            put(&mut bytes, pair[0]);
            put(&mut bytes, pair[1]);
        }
    }
    let size = if short { 2 } else { 4 };
    let index_count = bytes.len() / size;
    let view = doc.view(&bytes, index_count, Layout::Triangles { size })?;
    let indices =
        doc.accessor(view, index_count, if short { C::U16 } else { C::U32 }, T::Scalar, false, None, None);

    let material = doc.root.push(material(&part.material, data.has_uvs(), texture_of));
    Ok(json::mesh::Primitive {
        attributes,
        extensions: None,
        extras: Default::default(),
        indices: Some(indices),
        material: Some(material),
        mode: Valid(json::mesh::Mode::Triangles),
        targets: None,
    })
}

/// A unit vector's components as `BYTE` normalized (`round(f · 127)`).
fn snorm8(v: [f32; 4]) -> [u8; 4] {
    v.map(|x| ((x.clamp(-1.0, 1.0) * 127.0).round() as i8) as u8)
}

/// Translation, rotation (unit quaternion) and scale of `m`, or `None` where its
/// columns are not orthogonal (a shear, which `EXT_mesh_gpu_instancing` cannot store).
fn trs(m: glam::DMat4) -> Option<([f64; 3], [f64; 4], [f64; 3])> {
    let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let (lx, ly, lz) = (x.length(), y.length(), z.length());
    let orthogonal = |a: glam::DVec3, b: glam::DVec3, la: f64, lb: f64| a.dot(b).abs() <= 1e-4 * la * lb;
    let positive = lx > 0.0 && ly > 0.0 && lz > 0.0;
    if !(positive && orthogonal(x, y, lx, ly) && orthogonal(y, z, ly, lz) && orthogonal(x, z, lx, lz)) {
        return None;
    }
    let (s, r, t) = m.to_scale_rotation_translation();
    let r = r.normalize();
    r.is_finite().then_some((t.to_array(), r.to_array(), s.to_array()))
}

/// Whether the scale of `m` is the same along its three axes (to 1e-4).
fn uniform_scale(m: &glam::DMat4) -> bool {
    let l = [m.x_axis.truncate().length(), m.y_axis.truncate().length(), m.z_axis.truncate().length()];
    let (lo, hi) = (l.iter().copied().fold(f64::INFINITY, f64::min), l.iter().copied().fold(0.0, f64::max));
    hi - lo <= 1e-4 * hi
}

/// The node showing `mesh` (shape `shape`) once per transform with
/// `EXT_mesh_gpu_instancing`: `TRANSLATION`, `ROTATION` (unit quaternions) and `SCALE`
/// as `FLOAT` accessors. Where every instance scales uniformly the node's own transform
/// is the first instance's and the instances are relative to it, so a reader without
/// the extension, which draws the mesh once at the node, shows the first copy in its
/// place; otherwise the node has no transform. Quantized positions decode inside each
/// instance's transform. `parent`: the grid the parent node's transform decodes (a
/// level node of quantized positions), undone by this node's transform.
pub(super) fn push_instanced_node(
    doc: &mut Doc,
    shape: &Part,
    mesh: Index<json::Mesh>,
    dequant: Option<Dequant>,
    transforms: &[glam::Mat4],
    parent: Option<Dequant>,
) -> Result<Index<json::Node>> {
    use glam::DMat4;
    let decode = dequant.map_or(DMat4::IDENTITY, |d| {
        DMat4::from_translation(d.offset.as_dvec3()) * DMat4::from_scale(glam::DVec3::splat(d.step as f64))
    });
    let all: Vec<DMat4> = transforms.iter().map(|m| m.as_dmat4()).collect();
    let base =
        all.first().copied().filter(|_| all.iter().all(uniform_scale)).and_then(|m| trs(m).map(|t| (m, t)));
    let inverse = base.map_or(DMat4::IDENTITY, |(m, _)| m.inverse());
    let bad = |k: usize| Error::InvalidGeometry {
        what: format!("instance {k} of shape '{}'", shape.name),
        why:
            "its transform is not translation × rotation × scale (EXT_mesh_gpu_instancing stores only those)"
                .into(),
    };
    let (mut t, mut r, mut s) = (Vec::new(), Vec::new(), Vec::new());
    for (k, m) in all.iter().enumerate() {
        let (tk, rk, sk) = trs(inverse * *m * decode).ok_or_else(|| bad(k))?;
        t.push(tk.map(|x| x as f32));
        r.push(rk.map(|x| x as f32));
        s.push(sk.map(|x| x as f32));
    }
    use json::accessor::Type as T;
    let (lo, hi) = t.iter().fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |(lo, hi), p| {
        (std::array::from_fn(|c| lo[c].min(p[c])), std::array::from_fn(|c| hi[c].max(p[c])))
    });
    let bounds = Some((json::Value::from(lo.to_vec()), json::Value::from(hi.to_vec())));
    let translation = doc.floats(t.into_iter(), T::Vec3, Layout::Instances { stride: 12 }, bounds)?;
    let rotation = doc.floats(r.into_iter(), T::Vec4, Layout::Instances { stride: 16 }, None)?;
    let scale = doc.floats(s.into_iter(), T::Vec3, Layout::Instances { stride: 12 }, None)?;
    doc.use_extension(INSTANCING, false);
    let mut n = node(shape.name.clone(), Some(mesh), None);
    // The node's own transform: the first instance's, relative to the parent's grid.
    let own = match (base, parent) {
        (base, None) => base.map(|(_, t)| t),
        (base, Some(p)) => {
            let undo = DMat4::from_scale(glam::DVec3::splat(1.0 / p.step as f64))
                * DMat4::from_translation(-p.offset.as_dvec3());
            Some(trs(undo * base.map_or(DMat4::IDENTITY, |(m, _)| m)).ok_or_else(|| bad(0))?)
        }
    };
    if let Some((tt, rr, ss)) = own {
        n.translation = Some(tt.map(|x| x as f32));
        n.rotation = Some(json::scene::UnitQuaternion(rr.map(|x| x as f32)));
        n.scale = Some(ss.map(|x| x as f32));
    }
    let mut others = serde_json::Map::new();
    others.insert(
        INSTANCING.into(),
        serde_json::json!({ "attributes": {
            "TRANSLATION": translation.value(),
            "ROTATION": rotation.value(),
            "SCALE": scale.value(),
        }}),
    );
    n.extensions = Some(json::extensions::scene::Node { others });
    Ok(doc.root.push(n))
}

/// Unit tangents (xyz along +u) with handedness (w: ±1, the bitangent cross(N, T)·w runs
/// along +v of the mesh, up in the image — the normal maps' +Y) per output vertex, from
/// the UV gradients of the triangles around it, made orthogonal to the vertex normal.
/// Vertices without a usable UV gradient get any vector orthogonal to their normal.
fn tangents(part: &Part, data: &VertexData) -> Vec<[f32; 4]> {
    use glam::Vec3;
    let verts = &data.unified.vertices;
    let (mut t_acc, mut b_acc) = (vec![Vec3::ZERO; verts.len()], vec![Vec3::ZERO; verts.len()]);
    let cv = &data.unified.corner_vertex;
    for w in part.mesh.face_offsets.windows(2) {
        let Some(face) = cv.get(w[0] as usize..w[1] as usize) else { continue };
        let Some((&a, rest)) = face.split_first() else { continue };
        for pair in rest.windows(2) {
            let [ia, ib, ic] = [a, pair[0], pair[1]].map(|i| i as usize);
            let (pa, pb, pc) =
                (data.position(&verts[ia]), data.position(&verts[ib]), data.position(&verts[ic]));
            let (ua, ub, uc) = (data.uv(&verts[ia]), data.uv(&verts[ib]), data.uv(&verts[ic]));
            let (e1, e2) = (pb - pa, pc - pa);
            let (d1, d2) = (ub - ua, uc - ua);
            let det = d1.x * d2.y - d2.x * d1.y;
            if !det.is_finite() || det.abs() < 1e-20 {
                continue;
            }
            let r = 1.0 / det;
            let t = (e1 * d2.y - e2 * d1.y) * r;
            let b = (e2 * d1.x - e1 * d2.x) * r;
            if !(t.is_finite() && b.is_finite()) {
                continue;
            }
            for i in [ia, ib, ic] {
                t_acc[i] += t;
                b_acc[i] += b;
            }
        }
    }
    verts
        .iter()
        .enumerate()
        .map(|(i, k)| {
            let n = data.normal(k);
            let t = (t_acc[i] - n * n.dot(t_acc[i]))
                .try_normalize()
                .unwrap_or_else(|| n.any_orthonormal_vector());
            let w = if n.cross(t).dot(b_acc[i]) < 0.0 { -1.0 } else { 1.0 };
            [t.x, t.y, t.z, w]
        })
        .collect()
}
