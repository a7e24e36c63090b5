//! Indexed polygon meshes: the plain data every stage reads and writes (architecture:
//! "Core types"). This module imports no stage.
//!
//! A [`Mesh`] is the control cage or final surface every mesher writes and every
//! refiner and exporter reads: positions, faces of any corner count stored as offsets
//! plus indices, and **face-varying** attributes (UVs, normals) with their own value
//! and index arrays, one index per face corner, so seams are exact (OpenSubdiv's
//! face-varying channels). Filled by the meshers (`mesh::*`), the organ mesher, the
//! refiners (`refine`) and the readers (`import::gltf_read`, `mesh::obj_read`).

use glam::{Vec2, Vec3};

/// "No element": the index every stage uses for a missing vertex, face, node or edge
/// (`u32::MAX`, never a valid index of a mesh with `u32` indices).
pub const NONE: u32 = u32::MAX;

/// The point at parameter `t` in \[0, 1\] of the cubic Bézier curve with control points
/// `p` (Bernstein form). Weber–Penn's stems and the model's branch curves both use it.
pub fn cubic_bezier(p: &[Vec3; 4], t: f32) -> Vec3 {
    let u = 1.0 - t;
    p[0] * (u * u * u) + p[1] * (3.0 * u * u * t) + p[2] * (3.0 * u * t * t) + p[3] * (t * t * t)
}

/// A face-varying channel: values plus one index per face corner.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaceVarying<T> {
    /// Distinct values.
    pub values: Vec<T>,
    /// One index into `values` per face corner, parallel to [`Mesh::face_indices`].
    pub indices: Vec<u32>,
}

/// A tagged crease edge between two vertices, with its sharpness (∞ = sharp).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crease {
    /// First vertex.
    pub a: u32,
    /// Second vertex.
    pub b: u32,
    /// Sharpness: 0 smooth, fractional semi-sharp, `f32::INFINITY` infinitely sharp.
    pub sharpness: f32,
}

/// An indexed polygon mesh with face-varying UVs and normals.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions in metres.
    pub positions: Vec<Vec3>,
    /// Start of each face in `face_indices`; has `faces + 1` entries, first is 0.
    pub face_offsets: Vec<u32>,
    /// Vertex indices of all faces, counter-clockwise seen from the front.
    pub face_indices: Vec<u32>,
    /// Texture coordinates per corner (u around, v along), if any.
    pub uvs: Option<FaceVarying<Vec2>>,
    /// Unit normals per corner, if any.
    pub normals: Option<FaceVarying<Vec3>>,
    /// Crease edges for subdivision.
    pub creases: Vec<Crease>,
}

impl Mesh {
    /// An empty mesh (with the leading face offset in place).
    pub fn new() -> Self {
        Self { face_offsets: vec![0], ..Default::default() }
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.face_offsets.len().saturating_sub(1)
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// The vertex indices of face `f`.
    pub fn face(&self, f: usize) -> &[u32] {
        &self.face_indices[self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize]
    }

    /// Range of corner indices (into `face_indices` and face-varying indices) of face `f`.
    pub fn corners(&self, f: usize) -> std::ops::Range<usize> {
        self.face_offsets[f] as usize..self.face_offsets[f + 1] as usize
    }

    /// Face `f` split into a fan from its first corner: `[first, k, k + 1]` corner
    /// indices (into `face_indices` and face-varying indices) per triangle, none for a
    /// face of fewer than three corners.
    pub fn fan(&self, f: usize) -> impl Iterator<Item = [usize; 3]> {
        let c = self.corners(f);
        (c.start + 1..c.end.saturating_sub(1)).map(move |k| [c.start, k, k + 1])
    }

    /// [`Mesh::fan`] of every face, in face order.
    pub fn fan_corners(&self) -> impl Iterator<Item = [usize; 3]> + '_ {
        (0..self.face_count()).flat_map(|f| self.fan(f))
    }

    /// Signed volume enclosed by the faces (each fanned from its first corner), in f64:
    /// positive for a closed mesh oriented counter-clockwise seen from outside; for an
    /// open mesh it is the volume of the cone from the origin over its faces.
    pub fn signed_volume(&self) -> f64 {
        (0..self.face_count())
            .map(|f| {
                let v = self.face(f);
                let p = |k: usize| self.positions[v[k] as usize].as_dvec3();
                (1..v.len().saturating_sub(1)).map(|k| p(0).dot(p(k).cross(p(k + 1))) / 6.0).sum::<f64>()
            })
            .sum()
    }

    /// Appends a face given its vertex indices.
    pub fn push_face(&mut self, vertices: &[u32]) {
        if self.face_offsets.is_empty() {
            self.face_offsets.push(0);
        }
        self.face_indices.extend_from_slice(vertices);
        self.face_offsets.push(self.face_indices.len() as u32);
    }

    /// Number of triangles after fan-triangulating every face.
    pub fn triangle_count(&self) -> usize {
        (0..self.face_count()).map(|f| self.face(f).len().saturating_sub(2)).sum()
    }

    /// Axis-aligned bounds (min, max) of the positions; `None` when empty.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    /// Appends `other` to this mesh, offsetting its indices. Face-varying channels are
    /// kept only when both meshes (or an empty `self`) have them.
    pub fn append(&mut self, other: &Mesh) {
        let was_empty = self.face_count() == 0 && self.positions.is_empty();
        let base = self.positions.len() as u32;
        let corner_base = self.face_indices.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        if self.face_offsets.is_empty() {
            self.face_offsets.push(0);
        }
        self.face_offsets.extend(other.face_offsets.iter().skip(1).map(|o| o + corner_base));
        self.face_indices.extend(other.face_indices.iter().map(|i| i + base));
        fn merge<T: Clone>(
            mine: &mut Option<FaceVarying<T>>,
            theirs: &Option<FaceVarying<T>>,
            was_empty: bool,
        ) {
            match (mine.as_mut(), theirs) {
                (Some(m), Some(t)) => {
                    let vb = m.values.len() as u32;
                    m.values.extend_from_slice(&t.values);
                    m.indices.extend(t.indices.iter().map(|i| i + vb));
                }
                (None, Some(t)) if was_empty => *mine = Some(t.clone()),
                _ => *mine = None,
            }
        }
        merge(&mut self.uvs, &other.uvs, was_empty);
        merge(&mut self.normals, &other.normals, was_empty);
        self.creases.extend(other.creases.iter().map(|c| Crease { a: c.a + base, b: c.b + base, ..*c }));
    }

    /// Checks that indices are in range, faces have ≥ 3 corners, face-varying channels
    /// have one index per corner, and every number is finite. Returns a description of
    /// the first problem found.
    pub fn validate(&self) -> Result<(), String> {
        let nv = self.positions.len() as u32;
        if self.face_offsets.first().copied().unwrap_or(0) != 0 {
            return Err("face offsets do not start at 0".into());
        }
        if *self.face_offsets.last().unwrap_or(&0) as usize != self.face_indices.len() {
            return Err("last face offset does not match the index count".into());
        }
        for f in 0..self.face_count() {
            let face = self.face(f);
            if face.len() < 3 {
                return Err(format!("face {f} has {} corners (need at least 3)", face.len()));
            }
            if let Some(&v) = face.iter().find(|&&v| v >= nv) {
                return Err(format!("face {f} refers to vertex {v}, but there are {nv}"));
            }
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!("vertex {i} has a non-finite position"));
        }
        fn check<T>(
            name: &str,
            ch: &Option<FaceVarying<T>>,
            corners: usize,
            finite: impl Fn(&T) -> bool,
        ) -> Result<(), String> {
            if let Some(c) = ch {
                if c.indices.len() != corners {
                    return Err(format!(
                        "{name} channel has {} indices for {corners} corners",
                        c.indices.len()
                    ));
                }
                if c.indices.iter().any(|&i| i as usize >= c.values.len()) {
                    return Err(format!("{name} index out of range"));
                }
                if let Some(i) = c.values.iter().position(|v| !finite(v)) {
                    return Err(format!("{name} value {i} is not finite"));
                }
            }
            Ok(())
        }
        let corners = self.face_indices.len();
        check("uv", &self.uvs, corners, |v: &Vec2| v.is_finite())?;
        check("normal", &self.normals, corners, |v: &Vec3| v.is_finite())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        let mut m = Mesh::new();
        m.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        m.push_face(&[0, 1, 2, 3]);
        m
    }

    #[test]
    fn append_offsets_indices() {
        let mut a = quad();
        a.append(&quad());
        assert_eq!(a.face_count(), 2);
        assert_eq!(a.face(1), &[4, 5, 6, 7]);
        assert_eq!(a.triangle_count(), 4);
        a.validate().unwrap();
    }

    #[test]
    fn signed_volume_of_a_cube() {
        // A 2 × 1 × 1 box of quads, outward: volume 2; flipped: −2.
        let mut m = Mesh::new();
        for i in 0..8u32 {
            m.positions.push(Vec3::new((i & 1) as f32 * 2.0, ((i >> 1) & 1) as f32, (i >> 2) as f32));
        }
        for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
            m.push_face(&f);
        }
        assert!((m.signed_volume() - 2.0).abs() < 1e-12, "{}", m.signed_volume());
        for f in 0..m.face_count() {
            let r = m.corners(f);
            m.face_indices[r].reverse();
        }
        assert!((m.signed_volume() + 2.0).abs() < 1e-12);
    }

    #[test]
    fn validate_catches_bad_index() {
        let mut m = quad();
        m.face_indices[2] = 9;
        assert!(m.validate().unwrap_err().contains("vertex 9"));
    }
}
