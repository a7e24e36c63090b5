//! Leaf cards (issue 23, `leaves.mode = "cards"`): every leaf organ (a turtle polygon or
//! a leaf quad) becomes one quad showing a cell of the leaf atlas, standing on the
//! organ's base along its heading in the plane of its blade, with a back face of its
//! own (reversed winding, reversed normal) instead of a double-sided material. The
//! card's length is the leaf's own (its extent along the heading); its width follows the
//! atlas cell, so the drawn outline keeps the leaf's proportions. UVs run base→tip along
//! +v ([`AtlasCell::base`] → [`AtlasCell::tip`]).
//!
//! McLoughlin2021 §3 / anchors (ez-tree, SpeedTree): alpha-cut leaf cards.

use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Organ, OrganKind, Skeleton};
use crate::texture::leaf::AtlasCell;
use glam::{Vec2, Vec3};

/// Whether `organ` is a leaf that a card replaces (polygons and leaf quads; spheres,
/// discs and named surfaces keep their geometry).
pub fn is_card_leaf(organ: &Organ) -> bool {
    matches!(organ.kind, OrganKind::Leaf | OrganKind::Polygon(_))
}

/// A leaf organ's points in the plane of its blade: its outline (polygons) or its base
/// and tip (leaf quads).
fn leaf_points(o: &Organ) -> Vec<Vec3> {
    match &o.kind {
        OrganKind::Polygon(v) => v.clone(),
        _ => vec![o.position, o.position + o.heading.normalize_or_zero() * o.size],
    }
}

/// A card's frame fitted to a group of leaves: base point, heading, side, normal, and
/// the extents (along the heading from the base; across, as min and max).
struct CardFrame {
    base: Vec3,
    h: Vec3,
    x: Vec3,
    n: Vec3,
    length: f32,
    across: (f32, f32),
}

/// The frame of one card for `leaves` (one or more leaf organs): the heading is their
/// mean heading, the normal their mean up (the first leaf's where the ups cancel), the
/// base the first leaf's base, and the extents those of every leaf point.
fn card_frame(leaves: &[&Organ]) -> Option<CardFrame> {
    let first = leaves.first()?;
    let h = leaves.iter().map(|o| o.heading.normalize_or_zero()).sum::<Vec3>().try_normalize()?;
    let flat = |u: Vec3| (u - h * u.dot(h)).try_normalize();
    let mean_up: Vec3 = leaves.iter().map(|o| o.up.normalize_or_zero()).sum();
    let n = if mean_up.length() > 0.3 * leaves.len() as f32 { flat(mean_up) } else { None }
        .or_else(|| flat(first.up))
        .unwrap_or_else(|| h.any_orthonormal_vector());
    let x = h.cross(n);
    let base = first.position;
    let (mut lo, mut hi, mut left, mut right) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for p in leaves.iter().flat_map(|o| leaf_points(o)) {
        let d = p - base;
        let (a, b) = (d.dot(h), d.dot(x));
        lo = lo.min(a);
        hi = hi.max(a);
        left = left.min(b);
        right = right.max(b);
    }
    let length =
        if leaves.len() == 1 && !matches!(first.kind, OrganKind::Polygon(_)) { first.size } else { hi - lo };
    let ok = length.is_finite() && length > 0.0 && left.is_finite() && right.is_finite();
    ok.then_some(CardFrame { base: base + h * lo, h, x, n, length, across: (left, right) })
}

/// Groups the card leaves of `skeleton` `per_card` at a time: leaves on the same
/// unbranched run of nodes (a twig between forks), in node order, split into runs of
/// nearly equal size of at most `per_card` leaves. `per_card = 1` is one group per leaf.
pub fn leaf_groups(skeleton: &Skeleton, per_card: usize) -> Vec<Vec<usize>> {
    let leaves: Vec<usize> =
        (0..skeleton.organs.len()).filter(|&i| is_card_leaf(&skeleton.organs[i])).collect();
    if per_card <= 1 {
        return leaves.into_iter().map(|i| vec![i]).collect();
    }
    // The run a node belongs to: its parent's when it is the parent's only child.
    let n = skeleton.len();
    let mut children = vec![0u32; n];
    for &p in &skeleton.parent {
        if (p as usize) < n {
            children[p as usize] += 1;
        }
    }
    let mut run = (0..n as u32).collect::<Vec<u32>>();
    for i in 0..n {
        let p = skeleton.parent[i] as usize;
        if p < n && children[p] == 1 {
            run[i] = run[p];
        }
    }
    let mut keyed: Vec<(u32, u32, usize)> = leaves
        .into_iter()
        .map(|i| {
            let node = skeleton.organs[i].node;
            (run.get(node as usize).copied().unwrap_or(u32::MAX), node, i)
        })
        .collect();
    keyed.sort_unstable();
    let mut groups = Vec::new();
    for chunk in keyed.chunk_by(|a, b| a.0 == b.0) {
        let k = chunk.len().div_ceil(per_card);
        let (size, extra) = (chunk.len() / k, chunk.len() % k);
        let mut at = 0;
        for g in 0..k {
            let len = size + usize::from(g < extra);
            groups.push(chunk[at..at + len].iter().map(|e| e.2).collect());
            at += len;
        }
    }
    groups
}

/// One card (two faces: front and back) per group of card leaves of `skeleton`
/// ([`leaf_groups`]), textured by `cell`. A single leaf's card is as long as the leaf and
/// as wide as the cell's proportions make it; a group's card covers every leaf of the
/// group (the texture keeps square texels, so the longer of the two extents decides).
/// Also returns the skeleton node of each card's first leaf (a group without a usable
/// frame gets no card, so this is the one list parallel to the cards).
pub fn leaf_cards(skeleton: &Skeleton, cell: &AtlasCell, per_card: usize) -> (Mesh, Vec<u32>) {
    let mut m = Mesh::new();
    let mut nodes = Vec::new();
    let mut uvs = FaceVarying::default();
    let mut normals = FaceVarying::default();
    // The drawn leaf spans base → tip of the cell; the card spans the whole cell.
    // Texture units are square in the square atlas, so model units per texture unit are
    // length / span on both axes.
    let span = (cell.tip.y - cell.base.y).max(1e-6);
    let cell_w = cell.max.x - cell.min.x;
    let (below, above) = (cell.base.y - cell.min.y, cell.max.y - cell.tip.y);
    let corners_uv = [
        Vec2::new(cell.min.x, cell.min.y),
        Vec2::new(cell.max.x, cell.min.y),
        Vec2::new(cell.max.x, cell.max.y),
        Vec2::new(cell.min.x, cell.max.y),
    ];
    for group in leaf_groups(skeleton, per_card) {
        let organs: Vec<&Organ> = group.iter().map(|&i| &skeleton.organs[i]).collect();
        let Some(f) = card_frame(&organs) else { continue };
        nodes.push(organs[0].node);
        // Model units per texture unit; a group's card also covers its leaves' width.
        let (left, right) = f.across;
        let mut scale = f.length / span;
        let mut centre = 0.0;
        if organs.len() > 1 {
            scale = scale.max((right - left) / cell_w);
            centre = 0.5 * (left + right);
        }
        let b = f.base + f.x * centre - f.h * (below * scale);
        let t = f.base + f.x * centre + f.h * ((span + above) * scale);
        let w = f.x * (0.5 * cell_w * scale);
        let quad = [b - w, b + w, t + w, t - w];
        let first = m.positions.len() as u32;
        m.positions.extend_from_slice(&quad);
        let uv0 = uvs.values.len() as u32;
        uvs.values.extend_from_slice(&corners_uv);
        let n0 = normals.values.len() as u32;
        normals.values.extend_from_slice(&[f.n, -f.n]);
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
    (m, nodes)
}

/// How far [`bend_toward_crown`] turns a leaf's normal toward the crown's outward
/// direction (0: flat, 1: fully outward).
pub const CROWN_BEND: f32 = 0.7;

/// Bends the normals of a leaf mesh toward the crown's outward direction for soft,
/// volume-like canopy shading (`leaves.normals = "crown"`): each corner's normal becomes
/// `normalize(lerp(n, normalize(p − c), CROWN_BEND))`, where `n` is the face's own
/// normal (a back face keeps its own side) and `c` the centre of the leaves' bounding
/// box. Corners that shared a normal at one position still share one, so welded leaves
/// stay welded.
pub fn bend_toward_crown(mesh: &mut Mesh) {
    let Some((lo, hi)) = mesh.bounds() else { return };
    let Some(normals) = mesh.normals.as_mut() else { return };
    let centre = 0.5 * (lo + hi);
    let mut bent: std::collections::HashMap<(u32, u32), u32> = std::collections::HashMap::new();
    let mut values = Vec::with_capacity(normals.values.len());
    for (c, &p) in mesh.face_indices.iter().enumerate() {
        let old = normals.indices[c];
        let k = *bent.entry((p, old)).or_insert_with(|| {
            let n = normals.values[old as usize];
            let out = (mesh.positions[p as usize] - centre).try_normalize().unwrap_or(n);
            values.push(n.lerp(out, CROWN_BEND).try_normalize().unwrap_or(n));
            (values.len() - 1) as u32
        });
        normals.indices[c] = k;
    }
    normals.values = values;
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
        let (m, nodes) = leaf_cards(&sk, cell, 1);
        assert_eq!(nodes, vec![0]);
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

    #[test]
    fn crown_normals_lean_outward_and_keep_their_side() {
        let mut sk = Skeleton::new();
        sk.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        for x in [-1.0f32, 1.0] {
            sk.organs.push(Organ {
                kind: OrganKind::Leaf,
                node: 0,
                position: Vec3::new(x, 0.0, 0.0),
                heading: Vec3::Y,
                up: Vec3::Z,
                size: 0.2,
                material: 0,
            });
        }
        let atlas = leaf_atlas(96, [0.1, 0.3, 0.1], 1);
        let (mut m, _) = leaf_cards(&sk, atlas.cell(LeafShape::Ovate), 1);
        bend_toward_crown(&mut m);
        m.validate().unwrap();
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            let front = f % 2 == 0;
            for c in m.corners(f) {
                let (p, v) = (m.positions[m.face_indices[c] as usize], n.values[n.indices[c] as usize]);
                assert!((v.length() - 1.0).abs() < 1e-5);
                // Outward in x (the two cards sit left and right of the centre) …
                assert!(v.x * p.x > 0.0, "{p} {v}");
                // … and still on the face's own side.
                assert_eq!(v.z > 0.0, front, "{p} {v}");
            }
        }
    }
}
