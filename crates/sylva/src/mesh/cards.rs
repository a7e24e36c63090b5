//! Leaf cards (issue 23, `leaves.mode = "cards"`): every leaf organ (a turtle polygon or
//! a leaf quad) becomes one quad showing a cell of the leaf atlas, standing on the
//! organ's base along its heading in the plane of its blade, with a back face of its
//! own (reversed winding, reversed normal) instead of a double-sided material. The
//! card's length is the leaf's own (its extent along the heading); its width follows the
//! atlas cell, so the drawn outline keeps the leaf's proportions. UVs run base→tip along
//! +v ([`AtlasCell::base`] → [`AtlasCell::tip`]).
//!
//! Seed 002 §3 / anchors (ez-tree, SpeedTree): alpha-cut leaf cards.

use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Organ, OrganKind, Skeleton};
use crate::texture::leaf::AtlasCell;
use glam::{Vec2, Vec3};

/// Whether `organ` is a leaf that a card replaces (polygons and leaf quads; spheres,
/// discs and named surfaces keep their geometry).
pub fn is_card_leaf(organ: &Organ) -> bool {
    matches!(organ.kind, OrganKind::Leaf | OrganKind::Polygon(_))
}

/// The blade frame and length of a leaf organ: (base, heading, side, normal, length).
fn frame(o: &Organ) -> Option<(Vec3, Vec3, Vec3, Vec3, f32)> {
    let h = o.heading.try_normalize()?;
    let u = (o.up - h * o.up.dot(h)).try_normalize().unwrap_or_else(|| h.any_orthonormal_vector());
    let x = h.cross(u);
    let length = match &o.kind {
        OrganKind::Polygon(v) => v.iter().map(|p| (*p - o.position).dot(h)).fold(0.0f32, f32::max),
        _ => o.size,
    };
    (length.is_finite() && length > 0.0).then_some((o.position, h, x, u, length))
}

/// One card (two faces: front and back) per card leaf of `skeleton`, textured by `cell`.
pub fn leaf_cards(skeleton: &Skeleton, cell: &AtlasCell) -> Mesh {
    let mut m = Mesh::new();
    let mut uvs = FaceVarying::default();
    let mut normals = FaceVarying::default();
    // The drawn leaf spans base → tip of the cell; the card spans the whole cell.
    // Texture units are square in the square atlas, so model units per texture unit are
    // length / span on both axes.
    let span = (cell.tip.y - cell.base.y).max(1e-6);
    let cell_w = cell.max.x - cell.min.x;
    let below = (cell.base.y - cell.min.y) / span;
    let above = (cell.max.y - cell.tip.y) / span;
    let half = 0.5 * cell_w / span;
    let corners_uv = [
        Vec2::new(cell.min.x, cell.min.y),
        Vec2::new(cell.max.x, cell.min.y),
        Vec2::new(cell.max.x, cell.max.y),
        Vec2::new(cell.min.x, cell.max.y),
    ];
    for o in skeleton.organs.iter().filter(|o| is_card_leaf(o)) {
        let Some((base, h, x, n, len)) = frame(o) else { continue };
        let b = base - h * (below * len);
        let t = base + h * ((1.0 + above) * len);
        let w = x * (half * len);
        let quad = [b - w, b + w, t + w, t - w];
        let first = m.positions.len() as u32;
        m.positions.extend_from_slice(&quad);
        let uv0 = uvs.values.len() as u32;
        uvs.values.extend_from_slice(&corners_uv);
        let n0 = normals.values.len() as u32;
        normals.values.extend_from_slice(&[n, -n]);
        // Front (counter-clockwise seen from +n) and back (reversed).
        for (order, side) in [([0u32, 1, 2, 3], 0u32), ([0, 3, 2, 1], 1)] {
            m.face_indices.extend(order.iter().map(|&k| first + k));
            m.face_offsets.push(m.face_indices.len() as u32);
            uvs.indices.extend(order.iter().map(|&k| uv0 + k));
            normals.indices.extend([n0 + side; 4]);
        }
    }
    m.uvs = Some(uvs);
    m.normals = Some(normals);
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::NO_PARENT;
    use crate::texture::leaf::{leaf_atlas, LeafShape};

    #[test]
    fn a_card_stands_on_its_leaf_with_uvs_along_the_midrib() {
        let mut sk = Skeleton::new();
        sk.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let hexagon: Vec<Vec3> = (0..6)
            .map(|k| {
                let t = k as f32 / 5.0;
                Vec3::new(0.1 * (std::f32::consts::PI * t).sin(), 1.0 + 0.4 * t, 0.0)
            })
            .collect();
        sk.organs.push(Organ {
            kind: OrganKind::Polygon(hexagon),
            node: 0,
            position: Vec3::new(0.0, 1.0, 0.0),
            heading: Vec3::Y,
            up: Vec3::Z,
            size: 0.4,
            material: 0,
        });
        sk.organs.push(Organ { kind: OrganKind::Sphere, ..sk.organs[0].clone() });
        let atlas = leaf_atlas(96, [0.1, 0.3, 0.1], 1);
        let cell = atlas.cell(LeafShape::Ovate);
        let m = leaf_cards(&sk, cell);
        // One card (front + back) for the polygon; the sphere is not a card.
        assert_eq!((m.vertex_count(), m.face_count()), (4, 2));
        let uv = m.uvs.as_ref().unwrap();
        let n = m.normals.as_ref().unwrap();
        // Front faces +up, back faces −up.
        assert_eq!(n.values, vec![Vec3::Z, -Vec3::Z]);
        let f = m.face(0);
        let [a, b, c] = [f[0], f[1], f[2]].map(|i| m.positions[i as usize]);
        assert!(((b - a).cross(c - a).normalize() - Vec3::Z).length() < 1e-5, "front winding");
        // The UV base→tip direction maps onto the heading: +v is +y here.
        let corner = |k: usize| (m.positions[m.face_indices[k] as usize], uv.values[uv.indices[k] as usize]);
        let ((p0, t0), (p3, t3)) = (corner(0), corner(3));
        assert!((p3 - p0).normalize().dot(Vec3::Y) > 0.9999 && t3.y > t0.y && (t3.x - t0.x).abs() < 1e-6);
        // The drawn leaf (base → tip of the cell) spans the polygon's 0.4 along the heading.
        let per_v = (p3.y - p0.y) / (t3.y - t0.y);
        assert!(((cell.tip.y - cell.base.y) * per_v - 0.4).abs() < 1e-4);
    }
}
