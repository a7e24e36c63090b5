//! The tube mesher: one generalized cylinder around each axis of a [`Skeleton`].
//!
//! The baseline "cylinder model" MacMurchy2004 and McLoughlin2021 compare against, with the
//! tube features McLoughlin2021 §4.2 plans but never builds: per-node widths, a user-set
//! side count, and UVs with vertical segmentation so square bark texels do not stretch.
//! Its steps, each in its file: axes (`axes.rs`), rotation-minimizing frames (`frames.rs`,
//! Wang2008), rings and caps (`emit.rs`, after an exact counting pass); `docs/meshers.md`
//! ("tube") describes each rule. Output: triangles, counter-clockwise seen from outside,
//! face-varying UVs and normals; every axis with closed ends is a closed 2-manifold.
//! Cost: O(nodes × sides), no allocation per ring.

mod axes;
mod emit;
mod frames;

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::skeleton::Skeleton;
use axes::{build_axes, has_faces};
use emit::{count_axis, Counts, Emitter};
use frames::axis_frames;

/// Fewest sides a tube may have.
pub const MIN_SIDES: u32 = 3;
/// Most sides a tube may have.
pub const MAX_SIDES: u32 = 1024;

/// How the free end (tip) of every axis is closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TipStyle {
    /// A hemisphere of the tip radius: `clamp(sides / 4, 1, 8)` extra rings converging
    /// to one apex vertex. It extends the axis by its tip radius.
    #[default]
    Round,
    /// A flat fan to a centre vertex.
    Flat,
    /// No cap: the tube is open at its tip.
    Open,
}

/// How the start (base) of every axis is closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BaseStyle {
    /// A flat fan to a centre vertex, with its own (split) normal.
    #[default]
    Flat,
    /// No cap: the tube is open at its base.
    Open,
}

/// Options of [`tube_mesh`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TubeOptions {
    /// Vertices per ring, in `3..=1024` (default 8).
    #[serde(skip)]
    pub sides: u32,
    /// How axis tips are closed (default [`TipStyle::Round`]).
    #[serde(skip)]
    pub tips: TipStyle,
    /// How axis bases are closed (default [`BaseStyle::Flat`]).
    pub bases: BaseStyle,
}

impl Default for TubeOptions {
    fn default() -> Self {
        TubeOptions { sides: 8, tips: TipStyle::Round, bases: BaseStyle::Flat }
    }
}

/// The result of [`tube_mesh`]: the mesh and what went into it.
#[derive(Debug, Clone, PartialEq)]
pub struct TubeMesh {
    /// Triangles with face-varying UVs and normals.
    pub mesh: Mesh,
    /// Number of axes that produced geometry.
    pub axes: usize,
    /// Number of side rings (one per kept axis node, including radius-0 points; cap
    /// rings not counted).
    pub rings: usize,
    /// Number of triangles in `mesh`.
    pub triangles: usize,
}

/// Meshes every axis of `skeleton` as one generalized cylinder (see the module docs).
///
/// Errors: [`Error::InvalidGeometry`] when `opts.sides` is outside `3..=1024` or the
/// mesh would need more than `u32` indices; [`Error::Skeleton`] when the skeleton
/// fails [`Skeleton::validate`]. Deterministic; O(nodes × sides).
pub fn tube_mesh(skeleton: &Skeleton, opts: &TubeOptions) -> Result<TubeMesh> {
    if !(MIN_SIDES..=MAX_SIDES).contains(&opts.sides) {
        return Err(Error::InvalidGeometry {
            what: "tube mesher".into(),
            why: format!("sides = {}; it must be in {MIN_SIDES}..={MAX_SIDES}", opts.sides),
        });
    }
    skeleton.validate()?;
    let axes = build_axes(skeleton);
    let sides = opts.sides;
    let round_rings = round_cap_rings(sides);

    // Counting pass: exact sizes of every buffer.
    let mut total = Counts::default();
    for a in 0..axes.count() {
        total.add(&count_axis(axes.axis(a), sides, opts, round_rings));
    }
    let limit = u32::MAX as u64;
    if total.vertices >= limit
        || total.uvs >= limit
        || total.normals >= limit
        || total.triangles.saturating_mul(3) >= limit
    {
        return Err(Error::InvalidGeometry {
            what: "tube mesher".into(),
            why: format!(
                "the tube mesh would have {} vertices and {} triangles, more than u32 \
                 indices allow; use fewer sides or a smaller skeleton",
                total.vertices, total.triangles
            ),
        });
    }

    let mut e = Emitter::with_capacity(&total, sides);
    let mut frames = Vec::new();
    let mut axis_count = 0;
    for a in 0..axes.count() {
        crate::cancel::check()?;
        let st = axes.axis(a);
        if !has_faces(st) {
            continue;
        }
        let texel = axis_frames(st, skeleton, &mut frames);
        e.axis(st, &frames, texel, opts, round_rings);
        axis_count += 1;
    }
    let mesh = e.finish();
    debug_assert_eq!(mesh.positions.len() as u64, total.vertices);
    debug_assert_eq!(mesh.face_count() as u64, total.triangles);
    let triangles = mesh.face_count();
    let rings = total.rings as usize;
    Ok(TubeMesh { mesh, axes: axis_count, rings, triangles })
}

/// Extra rings of a round tip cap (the apex not counted).
fn round_cap_rings(sides: u32) -> u32 {
    (sides / 4).clamp(1, 8)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::axes::continuation;
    use super::*;
    use crate::skeleton::NO_PARENT;
    use glam::Vec3;
    use std::collections::HashMap;
    use std::f32::consts::TAU;

    /// A chain of nodes with the given positions and radii, `up` per node.
    fn chain(points: &[Vec3], radii: &[f32], up: &[Vec3]) -> Skeleton {
        let mut s = Skeleton::new();
        let mut parent = NO_PARENT;
        for (i, &p) in points.iter().enumerate() {
            parent = s.push(p, radii[i.min(radii.len() - 1)], parent, up[i.min(up.len() - 1)], 0);
        }
        s
    }

    fn straight() -> Skeleton {
        chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0)], &[0.2, 0.15, 0.1], &[Vec3::X])
    }

    fn y_fork() -> Skeleton {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::X, 0);
        s.push(Vec3::new(0.0, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        s.push(Vec3::new(1.0, 2.0, 0.0), 0.05, a, Vec3::Z, 1);
        s
    }

    /// Every directed edge appears exactly once and its reverse exactly once: a closed,
    /// consistently oriented 2-manifold (per connected piece).
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for f in 0..m.face_count() {
            let face = m.face(f);
            for k in 0..face.len() {
                *edges.entry((face[k], face[(k + 1) % face.len()])).or_default() += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            assert_eq!(count, 1, "directed edge {a}->{b} used {count} times");
            assert_eq!(edges.get(&(b, a)), Some(&1), "edge {a}->{b} has no twin");
        }
    }

    fn assert_sane(m: &Mesh) {
        m.validate().unwrap();
        for f in 0..m.face_count() {
            assert_eq!(m.face(f).len(), 3);
        }
    }

    /// Signed volume by the divergence theorem (positive when faces point outward).
    fn volume(m: &Mesh) -> f32 {
        (0..m.face_count())
            .map(|f| {
                let v = m.face(f);
                let [a, b, c] = [0, 1, 2].map(|k| m.positions[v[k] as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn face_normal(m: &Mesh, f: usize) -> Vec3 {
        let v = m.face(f);
        let [a, b, c] = [0, 1, 2].map(|k| m.positions[v[k] as usize]);
        (b - a).cross(c - a)
    }

    /// Every corner normal is unit and on the outer side of its (non-degenerate) face.
    fn assert_normals_outward(m: &Mesh) {
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            let fnrm = face_normal(m, f);
            if fnrm.length() < 1e-9 {
                continue;
            }
            for c in m.corners(f) {
                let cn = n.values[n.indices[c] as usize];
                assert!((cn.length() - 1.0).abs() < 1e-4, "normal {cn} not unit");
                assert!(cn.dot(fnrm.normalize()) > 0.0, "face {f} corner normal {cn} vs {fnrm}");
            }
        }
    }

    fn mesh(s: &Skeleton, opts: &TubeOptions) -> TubeMesh {
        let t = tube_mesh(s, opts).unwrap();
        assert_sane(&t.mesh);
        assert_eq!(t.triangles, t.mesh.triangle_count());
        // The counting pass predicted every buffer exactly.
        let axes = build_axes(s);
        let mut c = Counts::default();
        for a in 0..axes.count() {
            c.add(&count_axis(axes.axis(a), opts.sides, opts, round_cap_rings(opts.sides)));
        }
        assert_eq!(c.vertices as usize, t.mesh.positions.len());
        assert_eq!(c.triangles as usize, t.triangles);
        assert_eq!(c.uvs as usize, t.mesh.uvs.as_ref().unwrap().values.len());
        assert_eq!(c.normals as usize, t.mesh.normals.as_ref().unwrap().values.len());
        t
    }

    #[test]
    fn straight_chain_is_one_closed_axis() {
        for tips in [TipStyle::Round, TipStyle::Flat] {
            let opts = TubeOptions { tips, ..Default::default() };
            let t = mesh(&straight(), &opts);
            assert_eq!(t.axes, 1);
            assert_eq!(t.rings, 3);
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            let vol = volume(&t.mesh);
            // Octagonal frustums are a bit smaller than the round ones.
            assert!(vol > 0.08 && vol < 0.16, "volume {vol}");
        }
        let t = mesh(&straight(), &TubeOptions { tips: TipStyle::Flat, ..Default::default() });
        // 3 rings × 8 + 2 cap centres; 2 bands × 16 + 2 fans × 8.
        assert_eq!(t.mesh.positions.len(), 26);
        assert_eq!(t.triangles, 48);
    }

    #[test]
    fn side_normals_point_away_from_the_axis() {
        let t = mesh(&straight(), &TubeOptions::default());
        let m = &t.mesh;
        let n = m.normals.as_ref().unwrap();
        for f in 0..m.face_count() {
            if face_normal(m, f).normalize().y.abs() > 0.999 {
                continue; // a flat base cap: its normal is the axis
            }
            for c in m.corners(f) {
                let p = m.positions[m.face_indices[c] as usize];
                let radial = Vec3::new(p.x, 0.0, p.z);
                if radial.length() > 1e-3 {
                    assert!(n.values[n.indices[c] as usize].dot(radial) > 0.0);
                }
            }
        }
    }

    #[test]
    fn uv_v_follows_arc_length_and_the_seam_is_exact() {
        let opts = TubeOptions { tips: TipStyle::Flat, ..Default::default() };
        let t = mesh(&straight(), &opts);
        let m = &t.mesh;
        let uv = m.uvs.as_ref().unwrap();
        let circumference = TAU * 0.2;
        let mut seen_seam = false;
        let mut at_zero = std::collections::HashSet::new();
        let mut at_one = Vec::new();
        for f in 0..m.face_count() {
            if face_normal(m, f).normalize().y.abs() > 0.5 {
                continue; // a flat cap
            }
            let us: Vec<f32> = m.corners(f).map(|c| uv.values[uv.indices[c] as usize].x).collect();
            let spread =
                us.iter().cloned().fold(f32::MIN, f32::max) - us.iter().cloned().fold(f32::MAX, f32::min);
            assert!(spread <= 1.0 / 8.0 + 1e-6, "face {f} wraps around the seam: {us:?}");
            for c in m.corners(f) {
                let p = m.positions[m.face_indices[c] as usize];
                let q = uv.values[uv.indices[c] as usize];
                assert!((q.y - p.y / circumference).abs() < 1e-5, "v {} at y {}", q.y, p.y);
                if q.x == 1.0 {
                    seen_seam = true;
                    at_one.push(m.face_indices[c]);
                }
                if q.x == 0.0 {
                    at_zero.insert(m.face_indices[c]);
                }
            }
        }
        assert!(seen_seam);
        // u = 1 corners sit on the very vertices of the u = 0 column: a UV seam only.
        assert!(at_one.iter().all(|v| at_zero.contains(v)));
    }

    #[test]
    fn y_fork_gives_two_closed_axes() {
        let s = y_fork();
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.axes, 2);
        assert_closed(&t.mesh);
        assert_normals_outward(&t.mesh);
        assert!(volume(&t.mesh) > 0.0);
        // The lateral axis starts at the branching node, inside the trunk.
        let axes = build_axes(&s);
        assert_eq!(axes.count(), 2);
        assert_eq!(axes.axis(0).len(), 3);
        assert_eq!(axes.axis(1)[0].pos, Vec3::Y);
        assert_eq!(axes.axis(1)[0].radius, 0.05);
        // An explicit start radius (issue 26, an LST cylinder's r0) starts the lateral.
        let mut s = s;
        s.set_start_radius(3, Some(0.08));
        assert_eq!(build_axes(&s).axis(1)[0].radius, 0.08);
        assert_closed(&mesh(&s, &TubeOptions::default()).mesh);
    }

    #[test]
    fn axis_prefers_same_order_then_radius_then_alignment() {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::X, 0);
        let thick_lateral = s.push(Vec3::new(1.0, 1.0, 0.0), 0.09, a, Vec3::X, 1);
        let bent = s.push(Vec3::new(0.5, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        let straight_on = s.push(Vec3::new(0.0, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        let c = s.children();
        assert_eq!(continuation(&s, &c, a as usize), straight_on);
        s.radius[bent as usize] = 0.06;
        assert_eq!(continuation(&s, &c, a as usize), bent);
        s.order[bent as usize] = 1;
        s.order[straight_on as usize] = 1;
        // None has order 0 now: the thickest child wins.
        assert_eq!(continuation(&s, &c, a as usize), thick_lateral);
    }

    #[test]
    fn bends_and_u_turns_stay_finite() {
        let bend = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], &[0.1], &[Vec3::Z]);
        let uturn =
            chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::Y, Vec3::ZERO], &[0.1], &[Vec3::X]);
        let hairpin = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.3, 0.0, 0.0)], &[0.1], &[Vec3::Z]);
        for s in [bend, uturn, hairpin] {
            for tips in [TipStyle::Round, TipStyle::Flat, TipStyle::Open] {
                let t = mesh(&s, &TubeOptions { tips, ..Default::default() });
                assert!(t.mesh.positions.iter().all(|p| p.is_finite()));
                if tips != TipStyle::Open {
                    assert_closed(&t.mesh);
                }
            }
        }
        // The mitred elbow keeps the tube's thickness: the inner and outer ring points
        // of the 90° bend lie on the bisector plane at r / cos 45°.
        let s = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)], &[0.1], &[Vec3::Z]);
        let t = mesh(&s, &TubeOptions { tips: TipStyle::Open, bases: BaseStyle::Open, sides: 4 });
        let far = t.mesh.positions[4..8].iter().map(|p| p.distance(Vec3::Y)).fold(0.0, f32::max);
        assert!((far - 0.1 * 2f32.sqrt()).abs() < 1e-5, "elbow radius {far}");
    }

    /// Direction of vertex 0 of ring `k` from its centre, for open tubes (rings are
    /// consecutive blocks of `sides` vertices).
    fn first_vertex_dir(m: &Mesh, sides: usize, k: usize, centre: Vec3) -> Vec3 {
        (m.positions[k * sides] - centre).normalize()
    }

    #[test]
    fn frames_do_not_twist() {
        let open = TubeOptions { sides: 6, tips: TipStyle::Open, bases: BaseStyle::Open };
        // A straight line with a different `up` at every node: RMF ignores all but the
        // first, so the seam stays put.
        let pts: Vec<Vec3> = (0..6).map(|i| Vec3::new(0.0, i as f32, 0.0)).collect();
        let ups = [Vec3::X, Vec3::X, Vec3::Z, -Vec3::X, Vec3::new(1.0, 0.0, 1.0), -Vec3::Z];
        let s = chain(&pts, &[0.1], &ups);
        let t = mesh(&s, &open);
        let d0 = first_vertex_dir(&t.mesh, 6, 0, pts[0]);
        assert!((d0 - Vec3::X).length() < 1e-5);
        for (k, &p) in pts.iter().enumerate() {
            assert!(first_vertex_dir(&t.mesh, 6, k, p).dot(d0) > 0.9999);
        }
        // A planar arc with `up` normal to its plane: the RMF normal stays that normal.
        let pts: Vec<Vec3> = (0..24)
            .map(|i| {
                let a = i as f32 * 0.25;
                Vec3::new(a.cos(), a.sin(), 0.0) * 2.0
            })
            .collect();
        let s = chain(&pts, &[0.1], &[Vec3::Z]);
        let t = mesh(&s, &open);
        for (k, &p) in pts.iter().enumerate() {
            let d = first_vertex_dir(&t.mesh, 6, k, p);
            assert!(d.dot(Vec3::Z) > 0.9999, "ring {k} twisted: {d}");
        }
        // A helix: successive first-vertex directions rotate only by the curve's turn.
        let pts: Vec<Vec3> = (0..40)
            .map(|i| {
                let a = i as f32 * 0.2;
                Vec3::new(a.cos(), i as f32 * 0.05, a.sin())
            })
            .collect();
        let s = chain(&pts, &[0.05], &[Vec3::Y]);
        let t = mesh(&s, &open);
        for k in 1..pts.len() {
            let a = first_vertex_dir(&t.mesh, 6, k - 1, pts[k - 1]);
            let b = first_vertex_dir(&t.mesh, 6, k, pts[k]);
            assert!(a.dot(b) > 0.97, "ring {k} turned by {}", a.dot(b).acos());
        }
    }

    #[test]
    fn side_counts_3_and_64_work() {
        for sides in [3, 64] {
            let opts = TubeOptions { sides, ..Default::default() };
            let t = mesh(&y_fork(), &opts);
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            assert!(volume(&t.mesh) > 0.0);
        }
    }

    #[test]
    fn zero_length_internodes_are_merged() {
        let s = chain(
            &[Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 2.0, 0.0)],
            &[0.1],
            &[Vec3::X],
        );
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.rings, 3);
        assert_closed(&t.mesh);
        // A skeleton that is all one point makes nothing, without NaN.
        let s = chain(&[Vec3::ONE, Vec3::ONE, Vec3::ONE], &[0.1], &[Vec3::X]);
        let t = tube_mesh(&s, &TubeOptions::default()).unwrap();
        assert_eq!(t.axes, 0);
        assert_eq!(t.triangles, 0);
        t.mesh.validate().unwrap();
    }

    #[test]
    fn zero_radius_ends_collapse_to_points() {
        let s = chain(
            &[Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 3.0, 0.0)],
            &[0.0, 0.1, 0.0, 0.1],
            &[Vec3::X],
        );
        for sides in [3, 8] {
            let t = mesh(&s, &TubeOptions { sides, ..Default::default() });
            assert_closed(&t.mesh);
            assert_normals_outward(&t.mesh);
            assert!(volume(&t.mesh) > 0.0);
        }
        // All radii zero: nothing to draw.
        let s = chain(&[Vec3::ZERO, Vec3::Y], &[0.0], &[Vec3::X]);
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!((t.axes, t.triangles), (0, 0));
    }

    #[test]
    fn runs_of_point_stations_leave_no_unused_vertex() {
        // Radii taper below f32 resolution over the last two nodes (and start at 0).
        let s = chain(
            &[
                Vec3::ZERO,
                Vec3::Y,
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0),
                Vec3::new(0.0, 4.0, 0.0),
            ],
            &[0.0, 0.1, 1e-9, 0.0],
            &[Vec3::X],
        );
        let t = mesh(&s, &TubeOptions::default());
        let r = crate::mesh::check::check_mesh(&t.mesh, &Default::default());
        assert!(r.is_closed_manifold(), "{r}");
    }

    #[test]
    fn degenerate_up_falls_back() {
        // `up` along the internode and zero `up`.
        for up in [Vec3::Y, Vec3::ZERO] {
            let s = chain(&[Vec3::ZERO, Vec3::Y], &[0.1], &[up]);
            let t = mesh(&s, &TubeOptions::default());
            assert_closed(&t.mesh);
        }
    }

    #[test]
    fn bad_input_is_rejected() {
        for sides in [0, 2, 1025] {
            let e = tube_mesh(&straight(), &TubeOptions { sides, ..Default::default() });
            assert!(matches!(e, Err(Error::InvalidGeometry { .. })), "sides {sides}");
        }
        let mut s = straight();
        s.radius[1] = f32::NAN;
        assert!(matches!(tube_mesh(&s, &TubeOptions::default()), Err(Error::Skeleton(_))));
        let mut s = straight();
        s.order.pop();
        assert!(matches!(tube_mesh(&s, &TubeOptions::default()), Err(Error::Skeleton(_))));
    }

    #[test]
    fn empty_skeleton_gives_an_empty_mesh() {
        let t = mesh(&Skeleton::new(), &TubeOptions::default());
        assert_eq!((t.axes, t.rings, t.triangles), (0, 0, 0));
    }

    #[test]
    fn output_is_deterministic() {
        let a = tube_mesh(&y_fork(), &TubeOptions::default()).unwrap();
        let b = tube_mesh(&y_fork(), &TubeOptions::default()).unwrap();
        assert_eq!(a, b);
    }

    /// A binary tree of `depth` levels with `segs` internodes per branch.
    pub(crate) fn binary_tree(depth: u32, segs: u32) -> Skeleton {
        let mut s = Skeleton::new();
        let root = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
        let mut stack = vec![(root, Vec3::Y, 1.0f32, 0.3f32, 0u16, 0u32)];
        while let Some((node, dir, len, r, order, level)) = stack.pop() {
            let mut at = node;
            let mut p = s.position[node as usize];
            for k in 0..segs {
                p += dir * (len / segs as f32);
                let rr = r * (1.0 - 0.3 * (k + 1) as f32 / segs as f32);
                at = s.push(p, rr, at, dir.any_orthonormal_vector(), order);
            }
            if level + 1 < depth {
                let side = dir.any_orthonormal_vector();
                let a = (dir + side * 0.6).normalize();
                let b = (dir - side * 0.5 + dir.cross(side) * 0.4).normalize();
                stack.push((at, a, len * 0.8, r * 0.7, order, level + 1));
                stack.push((at, b, len * 0.7, r * 0.6, order + 1, level + 1));
            }
        }
        s
    }

    #[test]
    fn binary_tree_is_closed() {
        let s = binary_tree(6, 3);
        let t = mesh(&s, &TubeOptions::default());
        assert_eq!(t.axes, 32);
        assert_closed(&t.mesh);
        assert_normals_outward(&t.mesh);
    }

    /// Throughput check: `cargo test --release -p sylva tube::tests::throughput -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn throughput() {
        let s = binary_tree(14, 4);
        let opts = TubeOptions::default();
        let _ = tube_mesh(&s, &opts).unwrap();
        let t0 = std::time::Instant::now();
        let runs = 5;
        let mut tris = 0;
        for _ in 0..runs {
            tris = tube_mesh(&s, &opts).unwrap().triangles;
        }
        let dt = t0.elapsed().as_secs_f64() / runs as f64;
        println!(
            "{} nodes, {tris} triangles, {:.1} ms, {:.1} M tri/s",
            s.len(),
            dt * 1e3,
            tris as f64 / dt / 1e6
        );
    }
}
