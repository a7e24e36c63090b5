//! What the renderer draws around and over the trees for a viewer (issue 41 item 2):
//! line overlays (a skeleton, a mesher's cage, any segments in one colour), the ground
//! disc with its contact shadow, and the wireframe's colour. All of it is off by default
//! ([`super::RenderOptions`]), so a plain render is unchanged.
//!
//! - **Lines** are world-space segments drawn as a `LineList` in one colour, either
//!   depth-tested against the trees (pulled 0.15 % of their distance towards the eye, so
//!   edges lying on a surface win over it) or on top of everything ([`Lines::on_top`]).
//! - **Ground**: a disc in the plane of the tree's base (y = 0 where the model spans it,
//!   else its lowest point) under each instance, a flat colour fading into the background
//!   at its rim, darkened by a soft elliptical blob sized from the model's horizontal
//!   extent and darkest at the trunk: a contact shadow, not a shadow map.

use glam::Vec3;
use sylva::Mesh;

/// One overlay: segments in one colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Lines {
    /// The segments' end points, world space.
    pub segments: Vec<[Vec3; 2]>,
    /// Colour (sRGB).
    pub color: [u8; 3],
    /// Drawn over everything (`true`), or hidden where a tree is in front of it.
    pub on_top: bool,
}

/// Most segments one render draws over all its overlays.
pub const MAX_SEGMENTS: usize = 20_000_000;

impl Lines {
    /// `segments` in `color`, depth-tested.
    pub fn new(segments: Vec<[Vec3; 2]>, color: [u8; 3]) -> Lines {
        Lines { segments, color, on_top: false }
    }

    /// The edges of `mesh`'s faces (each polygon's sides, every shared edge once) in
    /// `color`, depth-tested: a control cage drawn as its faces' outlines. Faces or
    /// corners that do not index the mesh are left out.
    pub fn mesh_edges(mesh: &Mesh, color: [u8; 3]) -> Lines {
        let mut seen = std::collections::HashSet::new();
        let mut segments = Vec::new();
        for w in mesh.face_offsets.windows(2) {
            // A malformed face (offsets out of order or past the indices) is skipped.
            let Some(face) = mesh.face_indices.get(w[0] as usize..w[1] as usize) else { continue };
            for (k, &a) in face.iter().enumerate() {
                let b = face[(k + 1) % face.len()];
                let (Some(&pa), Some(&pb)) = (mesh.positions.get(a as usize), mesh.positions.get(b as usize))
                else {
                    continue;
                };
                if a != b && seen.insert((a.min(b), a.max(b))) {
                    segments.push([pa, pb]);
                }
            }
        }
        Lines::new(segments, color)
    }
}

/// One overlay vertex as the line pipeline reads it (28 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct LineVertex {
    pub position: [f32; 3],
    /// Linear colour, alpha 1.
    pub color: [f32; 4],
}

/// Checks the overlays' points (finite) and their total size.
pub(crate) fn check(lines: &[Lines]) -> Result<(), String> {
    let total: usize = lines.iter().map(|l| l.segments.len()).sum();
    if total > MAX_SEGMENTS {
        return Err(format!("the overlays hold {total} segments; at most {MAX_SEGMENTS} are drawn at once"));
    }
    for (i, l) in lines.iter().enumerate() {
        if let Some(k) = l.segments.iter().position(|s| !(s[0].is_finite() && s[1].is_finite())) {
            return Err(format!("overlay {i}: segment {k} has a point that is not finite"));
        }
    }
    Ok(())
}

/// The vertices of the depth-tested overlays, then of those on top; the number of
/// depth-tested vertices.
pub(crate) fn vertices(lines: &[Lines]) -> (Vec<LineVertex>, u32) {
    let mut out = Vec::new();
    let mut tested = 0;
    for on_top in [false, true] {
        for l in lines.iter().filter(|l| l.on_top == on_top) {
            let color = l.color.map(|c| srgb_to_linear(c as f32 / 255.0));
            let color = [color[0], color[1], color[2], 1.0];
            for s in &l.segments {
                out.extend(s.iter().map(|p| LineVertex { position: p.to_array(), color }));
            }
        }
        if !on_top {
            tested = out.len() as u32;
        }
    }
    (out, tested)
}

/// The ground uniform of `mesh.wgsl` (`struct Ground`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GroundUniform {
    /// xyz: the disc's centre (model space, in the base plane, under the crown's
    /// centre), w: its radius.
    pub centre: [f32; 4],
    /// x, y: the crown shadow's half extents along x and z; z: its strength (0..1).
    pub crown: [f32; 4],
    /// x, y: the trunk's foot (x, z); z: the contact darkening's radius; w: its strength.
    pub trunk: [f32; 4],
    /// Linear colour of the ground.
    pub color: [f32; 4],
    /// Linear colour of the wireframe's edges.
    pub wire: [f32; 4],
}

/// The ground colour (sRGB): a dry, pale soil a little darker than the preview's
/// background, so the disc reads as a floor.
pub const GROUND_COLOR: [u8; 3] = [186, 180, 164];

/// The wireframe's colour (sRGB).
pub const WIRE_COLOR: [u8; 3] = [28, 34, 30];

/// The ground under a model with bounds `lo..hi` whose vertices are `points` (see the
/// [module docs](self)): the trunk's foot is the mean of the points in the lowest 5 % of
/// the height (the crown's centre without any).
pub(crate) fn ground(lo: Vec3, hi: Vec3, points: &[Vec3]) -> GroundUniform {
    let base = if lo.y <= 0.0 && hi.y >= 0.0 { 0.0 } else { lo.y };
    let half = ((hi - lo) * 0.5).max(Vec3::splat(1e-3));
    let centre = Vec3::new((lo.x + hi.x) * 0.5, base, (lo.z + hi.z) * 0.5);
    let crown = half.x.max(half.z);
    let radius = (crown * 1.8).max((hi.y - lo.y) * 0.6).max(1e-2);
    let foot = lo.y + (hi.y - lo.y) * 0.05;
    let (sum, n) =
        points.iter().filter(|p| p.y <= foot).fold((Vec3::ZERO, 0u32), |(s, n), p| (s + *p, n + 1));
    let trunk = if n > 0 { sum / n as f32 } else { centre };
    let lin = |c: [u8; 3]| {
        let c = c.map(|x| srgb_to_linear(x as f32 / 255.0));
        [c[0], c[1], c[2], 1.0]
    };
    GroundUniform {
        centre: [centre.x, centre.y, centre.z, radius],
        crown: [half.x * 1.1, half.z * 1.1, 0.45, 0.0],
        trunk: [trunk.x, trunk.z, crown * 0.15, 0.35],
        color: lin(GROUND_COLOR),
        wire: lin(WIRE_COLOR),
    }
}

/// The box the ground disc of a model with bounds `lo..hi` takes (for the depth range).
pub(crate) fn ground_box(lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let g = ground(lo, hi, &[]);
    let [x, y, z, r] = g.centre;
    (Vec3::new(x - r, y, z - r), Vec3::new(x + r, y, z + r))
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cage_quad_pair_has_seven_edges_and_bad_points_are_named() {
        let mut m = Mesh::new();
        m.positions = vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        m.face_indices = vec![0, 1, 2, 3, 1, 4, 5, 2];
        m.face_offsets = vec![0, 4, 8];
        let l = Lines::mesh_edges(&m, [255, 0, 0]);
        assert_eq!(l.segments.len(), 7, "two quads sharing one edge");
        let (v, tested) = vertices(&[l.clone(), Lines { on_top: true, ..l.clone() }]);
        assert_eq!((v.len(), tested), (28, 14));
        assert_eq!(v[0].color, [1.0, 0.0, 0.0, 1.0]);
        let bad = Lines::new(vec![[Vec3::ZERO, Vec3::NAN]], [0; 3]);
        assert_eq!(check(&[l, bad]).unwrap_err(), "overlay 1: segment 0 has a point that is not finite");
    }

    #[test]
    fn the_ground_lies_at_the_base_and_spans_the_crown() {
        let points = [Vec3::new(0.5, 0.0, 0.2), Vec3::new(0.7, 0.1, 0.2), Vec3::new(-2.0, 5.0, 0.0)];
        let g = ground(Vec3::new(-2.0, -0.1, -1.0), Vec3::new(2.0, 6.0, 1.0), &points);
        assert_eq!(g.centre[1], 0.0, "y = 0 when the model spans it");
        assert!(g.centre[3] >= 3.6 && g.crown[0] > g.crown[1]);
        assert!((g.trunk[0] - 0.6).abs() < 1e-6 && (g.trunk[1] - 0.2).abs() < 1e-6, "{:?}", g.trunk);
        let lifted = ground(Vec3::new(-1.0, 2.0, -1.0), Vec3::new(1.0, 5.0, 1.0), &[]);
        assert_eq!(lifted.centre[1], 2.0, "else the lowest point");
    }
}
