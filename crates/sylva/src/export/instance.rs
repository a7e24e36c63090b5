//! Instanced organs (issue 23, `leaves.mode = "instanced"`): one shape and a transform
//! per copy instead of every copy's vertices.
//!
//! [`card_instances`] turns a leaf-card mesh as [`crate::mesh::cards::leaf_cards`] writes it
//! (per card four corners — base − w, base + w, tip + w, tip − w — and two quads, front
//! then back) into one card shape and one transform per card. The shape lives in its own
//! space: base at the origin, heading +Y, front normal +Z, length 1 and the first card's
//! width-to-length ratio across X, so `[−a/2, a/2] × [0, 1]`; UVs and normals as the cards
//! have them. Each transform maps the shape onto its card exactly: the columns are the
//! card's width axis, length axis and normal (an orthonormal rotation) times the scales,
//! and the translation is the middle of the card's base edge.
//!
//! Writers that cannot instance (OBJ, PLY, the glTF writer with
//! `output.instancing_fallback = "merged"`) flatten the model with [`Model::flattened`],
//! which appends one part per shape holding every copy ([`Model::merged_instances`]).

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::model::{Instance, Model, Part};
use crate::skeleton::NO_PARENT;
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::borrow::Cow;

/// How far (relative to the card's size) a card's fourth corner may lie from the
/// rectangle the other three span.
const RECTANGLE_TOLERANCE: f32 = 1e-4;

/// One card shape and the transform of each card of `mesh` (see the [module docs](self)).
///
/// `mesh` must hold cards exactly as the card mesher writes them: `4 n` positions, `2 n`
/// quads (front `[0, 1, 2, 3]`, back `[0, 3, 2, 1]` of each card's four positions),
/// UVs with the same four values on every card, and rectangular, non-degenerate cards.
/// Anything else is an error saying which card and why; nothing panics.
pub fn card_instances(mesh: &Mesh) -> std::result::Result<(Mesh, Vec<Mat4>), String> {
    mesh.validate()?;
    let cards = mesh.positions.len() / 4;
    if cards == 0 || mesh.positions.len() != 4 * cards || mesh.face_count() != 2 * cards {
        return Err(format!(
            "{} positions and {} faces are not cards (4 positions and 2 quads each)",
            mesh.positions.len(),
            mesh.face_count()
        ));
    }
    let uvs = mesh.uvs.as_ref().filter(|c| c.indices.len() == mesh.face_indices.len());
    // The four UVs of card k, in corner order.
    let card_uvs = |k: usize| -> Option<[Vec2; 4]> {
        let ch = uvs?;
        let start = *mesh.face_offsets.get(2 * k)? as usize;
        let idx = ch.indices.get(start..start + 4)?;
        let mut out = [Vec2::ZERO; 4];
        for (o, &i) in out.iter_mut().zip(idx) {
            *o = *ch.values.get(i as usize)?;
        }
        Some(out)
    };
    let first_uvs = card_uvs(0);
    let mut transforms = Vec::with_capacity(cards);
    let mut aspect = 0.0f32;
    for k in 0..cards {
        let base = 4 * k as u32;
        let front = [base, base + 1, base + 2, base + 3];
        let back = [base, base + 3, base + 2, base + 1];
        if mesh.face(2 * k) != front || mesh.face(2 * k + 1) != back {
            return Err(format!(
                "card {k}: its faces are not the quads [0 1 2 3] and [0 3 2 1] of its corners"
            ));
        }
        let same_uvs = match (card_uvs(k), first_uvs) {
            (Some(a), Some(b)) => a.iter().zip(&b).all(|(p, q)| (*p - *q).length() <= 1e-6),
            (a, b) => a.is_none() && b.is_none(),
        };
        if !same_uvs {
            return Err(format!("card {k}: its UVs differ from the first card's"));
        }
        let c = &mesh.positions[4 * k..4 * k + 4];
        let (along, across) = (c[3] - c[0], c[1] - c[0]);
        let (length, width) = (along.length(), across.length());
        if !(length.is_finite() && width.is_finite() && length > 1e-12 && width > 1e-12) {
            return Err(format!("card {k} is degenerate (length {length}, width {width})"));
        }
        if (c[2] - (c[1] + along)).length() > RECTANGLE_TOLERANCE * (length + width) {
            return Err(format!("card {k} is not a rectangle"));
        }
        if k == 0 {
            aspect = width / length;
        }
        let y = along / length;
        let x = (across - y * y.dot(across)).normalize();
        let z = x.cross(y);
        let scale = Vec3::new(width / aspect, length, length);
        let origin = 0.5 * (c[0] + c[1]);
        transforms.push(Mat4::from_cols(
            (x * scale.x).extend(0.0),
            (y * scale.y).extend(0.0),
            (z * scale.z).extend(0.0),
            origin.extend(1.0),
        ));
    }
    let h = 0.5 * aspect;
    let mut shape = Mesh::new();
    shape.positions = vec![
        Vec3::new(-h, 0.0, 0.0),
        Vec3::new(h, 0.0, 0.0),
        Vec3::new(h, 1.0, 0.0),
        Vec3::new(-h, 1.0, 0.0),
    ];
    shape.push_face(&[0, 1, 2, 3]);
    shape.push_face(&[0, 3, 2, 1]);
    if let Some(values) = first_uvs {
        shape.uvs = Some(FaceVarying { values: values.to_vec(), indices: vec![0, 1, 2, 3, 0, 3, 2, 1] });
    }
    if mesh.normals.is_some() {
        shape.normals =
            Some(FaceVarying { values: vec![Vec3::Z, -Vec3::Z], indices: vec![0, 0, 0, 0, 1, 1, 1, 1] });
    }
    Ok((shape, transforms))
}

impl Model {
    /// Replaces the part called `name` (a card mesh, see [`card_instances`]) with a shape
    /// of the same name and material and one [`Instance`] per card. `nodes` gives each
    /// card's skeleton node where it has one entry per card, else every instance gets
    /// [`NO_PARENT`]. Returns `false` (and changes nothing) when there is no such part;
    /// a part that is not cards is [`Error::InvalidGeometry`].
    pub fn instance_cards(&mut self, name: &str, nodes: &[u32]) -> Result<bool> {
        let Some(at) = self.parts.iter().position(|p| p.name == name) else { return Ok(false) };
        let (mesh, transforms) = card_instances(&self.parts[at].mesh)
            .map_err(|why| Error::InvalidGeometry { what: format!("part '{name}'"), why })?;
        let part = self.parts.remove(at);
        let shape = self.shapes.len() as u32;
        let node = |k: usize| if nodes.len() == transforms.len() { nodes[k] } else { NO_PARENT };
        self.instances.extend(transforms.iter().enumerate().map(|(k, &transform)| Instance {
            shape,
            transform,
            node: node(k),
        }));
        self.shapes.push(Part { mesh, attributes: Default::default(), skin: None, ..part });
        Ok(true)
    }

    /// Every instance's shape placed in model space, merged into one part per shape that
    /// has instances (named, and with the material of, the shape), in shape order. Normals
    /// go through the inverse transpose and are renormalized; a mirroring transform
    /// reverses its faces' winding. Per-vertex channels of the shape are repeated for each
    /// copy. Instances of a missing shape are skipped ([`super::validate_model`] reports them).
    pub fn merged_instances(&self) -> Vec<Part> {
        let mut out = Vec::new();
        for (s, shape) in self.shapes.iter().enumerate() {
            let mine: Vec<&Instance> = self.instances.iter().filter(|i| i.shape as usize == s).collect();
            // An invalid shape is skipped rather than indexed out of range.
            if mine.is_empty() || shape.mesh.validate().is_err() {
                continue;
            }
            let src = &shape.mesh;
            let mut mesh = Mesh::new();
            let n = mine.len();
            mesh.positions.reserve(src.positions.len() * n);
            let mut normals = src.normals.as_ref().map(|_| FaceVarying::<Vec3>::default());
            let mut uvs = src.uvs.as_ref().map(|_| FaceVarying::<Vec2>::default());
            let mut attributes = crate::model::VertexAttributes::default();
            for inst in &mine {
                let m = inst.transform;
                let normal_m = Mat3::from_mat4(m).inverse().transpose();
                let flip = Mat3::from_mat4(m).determinant() < 0.0;
                let p0 = mesh.positions.len() as u32;
                let n0 = normals.as_ref().map_or(0, |d| d.values.len() as u32);
                let u0 = uvs.as_ref().map_or(0, |d| d.values.len() as u32);
                mesh.positions.extend(src.positions.iter().map(|&p| m.transform_point3(p)));
                for f in 0..src.face_count() {
                    let corners: Vec<usize> =
                        if flip { src.corners(f).rev().collect() } else { src.corners(f).collect() };
                    mesh.face_indices.extend(corners.iter().map(|&c| src.face_indices[c] + p0));
                    mesh.face_offsets.push(mesh.face_indices.len() as u32);
                    if let (Some(dst), Some(ch)) = (normals.as_mut(), &src.normals) {
                        dst.indices.extend(corners.iter().map(|&c| ch.indices[c] + n0));
                    }
                    if let (Some(dst), Some(ch)) = (uvs.as_mut(), &src.uvs) {
                        dst.indices.extend(corners.iter().map(|&c| ch.indices[c] + u0));
                    }
                }
                if let (Some(dst), Some(ch)) = (normals.as_mut(), &src.normals) {
                    dst.values.extend(ch.values.iter().map(|&v| (normal_m * v).normalize_or(v)));
                }
                if let (Some(dst), Some(ch)) = (uvs.as_mut(), &src.uvs) {
                    dst.values.extend_from_slice(&ch.values);
                }
                let a = &shape.attributes;
                attributes.wind.extend_from_slice(&a.wind);
                attributes.pivot.extend_from_slice(&a.pivot);
                attributes.level.extend_from_slice(&a.level);
                attributes.node.extend_from_slice(&a.node);
            }
            mesh.normals = normals;
            mesh.uvs = uvs;
            out.push(Part { mesh, attributes, skin: None, ..shape.clone() });
        }
        out
    }

    /// The model with its instances merged into parts ([`Model::merged_instances`],
    /// appended after the parts) and no shapes or instances left; borrowed unchanged when
    /// it has no instances.
    pub fn flattened(&self) -> Cow<'_, Model> {
        if self.instances.is_empty() {
            return Cow::Borrowed(self);
        }
        let mut parts = self.parts.clone();
        parts.extend(self.merged_instances());
        Cow::Owned(Model { parts, shapes: Vec::new(), instances: Vec::new(), ..self.clone() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Material;

    /// Two cards of the card mesher's layout: one in the XY plane, one tilted and scaled.
    fn two_cards() -> Mesh {
        let mut m = Mesh::new();
        let mut uv = FaceVarying::default();
        let mut nr = FaceVarying::default();
        let uv4 = [Vec2::new(0.1, 0.2), Vec2::new(0.4, 0.2), Vec2::new(0.4, 0.7), Vec2::new(0.1, 0.7)];
        let frames = [
            (Vec3::new(1.0, 2.0, 3.0), Vec3::X, Vec3::Y, 0.5, 1.0),
            (Vec3::new(-2.0, 5.0, 0.5), Vec3::new(0.0, 0.6, 0.8), Vec3::new(1.0, 0.0, 0.0), 1.0, 2.0),
        ];
        for (k, (b, x, h, hw, len)) in frames.into_iter().enumerate() {
            let n = x.cross(h);
            let t = b + h * len;
            m.positions.extend([b - x * hw, b + x * hw, t + x * hw, t - x * hw]);
            uv.values.extend(uv4);
            nr.values.extend([n, -n]);
            let (p, u, q) = (4 * k as u32, 4 * k as u32, 2 * k as u32);
            for (order, side) in [([0u32, 1, 2, 3], 0u32), ([0, 3, 2, 1], 1)] {
                m.push_face(&order.map(|i| p + i));
                uv.indices.extend(order.map(|i| u + i));
                nr.indices.extend([q + side; 4]);
            }
        }
        m.uvs = Some(uv);
        m.normals = Some(nr);
        m
    }

    #[test]
    fn instances_reproduce_the_cards() {
        let cards = two_cards();
        let mut model = Model::from_parts(vec![Part::new("leaf_cards", cards.clone(), Material::leaf())]);
        assert!(model.instance_cards("leaf_cards", &[7, 9]).unwrap());
        assert!(model.parts.is_empty());
        assert_eq!((model.shapes.len(), model.instances.len()), (1, 2));
        assert_eq!(model.instances[1].node, 9);
        let shape = &model.shapes[0].mesh;
        assert_eq!(shape.positions[0], Vec3::new(-0.5, 0.0, 0.0));
        assert_eq!(shape.positions[2], Vec3::new(0.5, 1.0, 0.0));
        for t in model.instances.iter().map(|i| i.transform) {
            let r = Mat3::from_mat4(t);
            let s = Vec3::new(r.x_axis.length(), r.y_axis.length(), r.z_axis.length());
            assert!(r.determinant() > 0.0);
            assert!((s.x - s.y).abs() < 1e-6 && (s.y - s.z).abs() < 1e-6, "uniform scale {s}");
        }
        let merged = model.merged_instances();
        assert_eq!(merged.len(), 1);
        let m = &merged[0].mesh;
        assert_eq!(
            (m.face_indices.clone(), m.face_offsets.clone()),
            (cards.face_indices.clone(), cards.face_offsets.clone())
        );
        for (a, b) in m.positions.iter().zip(&cards.positions) {
            assert!((*a - *b).length() < 1e-5, "{a} vs {b}");
        }
        let (nm, nc) = (m.normals.as_ref().unwrap(), cards.normals.as_ref().unwrap());
        for c in 0..cards.face_indices.len() {
            let (a, b) = (nm.values[nm.indices[c] as usize], nc.values[nc.indices[c] as usize]);
            assert!((a - b).length() < 1e-5, "normal {a} vs {b}");
        }
        let (um, uc) = (m.uvs.as_ref().unwrap(), cards.uvs.as_ref().unwrap());
        for c in 0..cards.face_indices.len() {
            assert_eq!(um.values[um.indices[c] as usize], uc.values[uc.indices[c] as usize]);
        }
        let flat = model.flattened();
        assert!(flat.instances.is_empty() && flat.parts.len() == 1 && flat.parts[0].name == "leaf_cards");
    }

    #[test]
    fn bad_cards_are_errors_not_panics() {
        let mut m = two_cards();
        m.positions[2] += Vec3::splat(0.3);
        assert!(card_instances(&m).unwrap_err().contains("card 0 is not a rectangle"));
        let mut m = two_cards();
        m.positions[5] = m.positions[4];
        assert!(card_instances(&m).unwrap_err().contains("card 1 is degenerate"));
        let mut m = two_cards();
        m.positions.pop();
        assert!(card_instances(&m).is_err());
        assert!(card_instances(&Mesh::new()).is_err());
        let mut model =
            Model::from_parts(vec![Part::new("leaf_cards", crate::geometry::Mesh::new(), Material::leaf())]);
        assert!(model.instance_cards("leaf_cards", &[]).is_err());
        assert!(!model.instance_cards("other", &[]).unwrap());
    }

    #[test]
    fn mirroring_instances_keep_their_faces_outward() {
        let (shape, _) = card_instances(&two_cards()).unwrap();
        let mut model = Model::default();
        model.shapes.push(Part::new("s", shape, Material::leaf()));
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        model.instances.push(Instance { shape: 0, transform: mirror, node: NO_PARENT });
        let m = &model.merged_instances()[0].mesh;
        let f = m.face(0);
        let [a, b, c] = [f[0], f[1], f[2]].map(|i| m.positions[i as usize]);
        let n = m.normals.as_ref().unwrap();
        let normal = n.values[n.indices[0] as usize];
        assert!((b - a).cross(c - a).normalize().dot(normal) > 0.999, "winding follows the normal");
    }
}
