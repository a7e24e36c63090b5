//! The model: what the pipeline hands the exporters and the real-time stages (issue 22).
//! Plain data; this module imports no stage (only the geometry and skeleton types).
//!
//! Parts (a mesh with a material each, a material per face where a part mixes them,
//! extra per-vertex channels, skin weights), organ shapes and their instances, an
//! optional rig, LOD levels and the branch curves (a cubic Bézier chain per axis, the
//! input of Skjermo2008's GPU deformer, Skjermo2008-spec §3). Each type says which stage fills it.

use crate::geometry::Mesh;
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{Mat4, Quat, Vec3};

/// Surface appearance of a part.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Material name, as written to the output file.
    pub name: String,
    /// Linear RGBA base colour.
    pub base_color: [f32; 4],
    /// Metallic factor in \[0, 1\].
    pub metallic: f32,
    /// Roughness factor in \[0, 1\].
    pub roughness: f32,
    /// Render both faces (for open leaf blades).
    pub double_sided: bool,
    /// Texture maps (indices into [`Model::images`]); used where the part has UVs.
    pub maps: MaterialMaps,
    /// Alpha-cut (glTF `alphaMode: MASK`) at this coverage, for leaf cards.
    pub alpha_cutoff: Option<f32>,
}

/// A material's texture maps, as indices into [`Model::images`]. Filled by the texture
/// stage (issue 23).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MaterialMaps {
    /// Base colour (sRGB; RGBA where the alpha cuts the outline).
    pub base_color: Option<u32>,
    /// Tangent-space normal map.
    pub normal: Option<u32>,
    /// Occlusion (R), roughness (G), metallic (B).
    pub occlusion_roughness_metallic: Option<u32>,
}

impl MaterialMaps {
    /// Whether the material has any map.
    pub fn any(&self) -> bool {
        self.base_color.is_some() || self.normal.is_some() || self.occlusion_roughness_metallic.is_some()
    }
}

/// A texture of the model: embedded in glTF or written beside the model as
/// `<model>_<name>.png`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelImage {
    /// Name (`bark_albedo`, `leaf_atlas`, …): letters, digits and `_` only.
    pub name: String,
    /// The pixels, shared: a model's copy (a session keeps one per stage) shares its
    /// images instead of copying megabytes of pixels.
    pub image: std::sync::Arc<crate::image::Image>,
    /// Repeat (bark tiles) rather than clamp (the leaf atlas) outside \[0, 1\].
    pub repeat: bool,
}

/// What made a model: written to glTF's scene `extras` (and OBJ / PLY comments).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Provenance {
    /// The recipe as TOML text.
    pub recipe: String,
    /// The recipe's seed.
    pub seed: u64,
}

impl Material {
    /// A brown, rough bark material.
    pub fn bark() -> Self {
        Material {
            name: "bark".into(),
            base_color: [0.30, 0.19, 0.11, 1.0],
            metallic: 0.0,
            roughness: 0.9,
            double_sided: false,
            maps: MaterialMaps::default(),
            alpha_cutoff: None,
        }
    }

    /// A green, double-sided leaf material.
    pub fn leaf() -> Self {
        Material {
            name: "leaf".into(),
            base_color: [0.18, 0.42, 0.10, 1.0],
            metallic: 0.0,
            roughness: 0.7,
            double_sided: true,
            maps: MaterialMaps::default(),
            alpha_cutoff: None,
        }
    }
}

impl Default for Material {
    /// The bark material.
    fn default() -> Self {
        Material::bark()
    }
}

/// A named mesh with a material. Filled by the pipeline's finishing step (bark: the
/// refined cage; leaves: the organ mesher), by `curves` and by `sylva subdivide`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Part {
    /// Part name (`bark`, `leaves`, …), written as the node / group name.
    pub name: String,
    /// Its geometry.
    pub mesh: Mesh,
    /// Its material (every face's, unless [`Part::face_materials`] says otherwise).
    pub material: Material,
    /// Where a part mixes materials: one material index per face (0 is
    /// [`Part::material`], `k > 0` is `extra_materials[k − 1]`). Empty: one material.
    pub face_materials: Vec<u32>,
    /// The materials beyond the first that [`Part::face_materials`] refers to.
    pub extra_materials: Vec<Material>,
    /// Per-vertex channels beyond position, UV and normal (wind, pivots, levels).
    pub attributes: VertexAttributes,
    /// Per-vertex skinning, when the model has a [`Rig`].
    pub skin: Option<SkinWeights>,
}

impl Part {
    /// A part of one material and no extra channels.
    pub fn new(name: impl Into<String>, mesh: Mesh, material: Material) -> Self {
        Part { name: name.into(), mesh, material, ..Default::default() }
    }
}

/// Per-vertex channels, parallel to a mesh's positions; each is empty or holds one value
/// per vertex. Filled by the wind and LOD stages (issue 24); the skeleton node of each
/// vertex by the meshers that know it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VertexAttributes {
    /// Wind weights: trunk, branch, leaf and phase (the `_WIND` channel).
    pub wind: Vec<[f32; 4]>,
    /// The anchor of the vertex's branch (xyz) and its branch level (w): `_PIVOT`.
    pub pivot: Vec<[f32; 4]>,
    /// Branch order (0 trunk) of the vertex's branch.
    pub level: Vec<u16>,
    /// The skeleton node each vertex belongs to.
    pub node: Vec<u32>,
}

impl VertexAttributes {
    /// Whether no channel holds data.
    pub fn is_empty(&self) -> bool {
        self.wind.is_empty() && self.pivot.is_empty() && self.level.is_empty() && self.node.is_empty()
    }

    /// Checks that every non-empty channel has `vertices` values, all finite.
    pub fn validate(&self, vertices: usize) -> Result<(), String> {
        let lens = [
            ("wind", self.wind.len()),
            ("pivot", self.pivot.len()),
            ("level", self.level.len()),
            ("node", self.node.len()),
        ];
        for (name, n) in lens {
            if n != 0 && n != vertices {
                return Err(format!("{name} channel has {n} values for {vertices} vertices"));
            }
        }
        if self.wind.iter().chain(&self.pivot).flatten().any(|x| !x.is_finite()) {
            return Err("a wind or pivot value is not finite".into());
        }
        Ok(())
    }
}

/// Skinning of one part: up to four joints per vertex with weights summing to 1.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SkinWeights {
    /// Joint indices (into [`Rig::joints`]) per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Weights per vertex, parallel to `joints`.
    pub weights: Vec<[f32; 4]>,
}

/// A joint of a [`Rig`]: a skeleton node that moves its subtree.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// The skeleton node the joint sits on.
    pub node: u32,
    /// The parent joint (index into [`Rig::joints`]), `None` for a root joint.
    pub parent: Option<u32>,
    /// The joint's position in model space at bind time.
    pub head: Vec3,
}

/// A skeletal rig for animation (filled by the wind stage, issue 24): joints chosen from
/// the skeleton's axes, parent joints before their children.
///
/// Bind pose: every joint's rest rotation is the identity, so a joint's rest transform
/// in model space is a translation to its `head` (its local translation is
/// `head − parent.head`) and its inverse bind matrix is the translation by `−head`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Rig {
    /// The joints, parents first.
    pub joints: Vec<Joint>,
}

/// A looping animation of a [`Rig`] (the wind stage's baked clip): joint-local
/// rotations sampled at common times, played with linear interpolation (slerp).
/// The last sample equals the first, so the clip loops without a jump.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Clip {
    /// Name of the clip (`wind`).
    pub name: String,
    /// Sample times in seconds, increasing, from 0 to the clip's length.
    pub times: Vec<f32>,
    /// Per joint (parallel to [`Rig::joints`]), per sample: the joint's rotation relative
    /// to its parent joint (unit quaternions; identity is the bind pose).
    pub rotations: Vec<Vec<Quat>>,
}

impl Clip {
    /// The clip's length in seconds (the last sample's time).
    pub fn duration(&self) -> f32 {
        self.times.last().copied().unwrap_or(0.0)
    }

    /// Each joint's rotation at time `t` (clamped to the clip), slerped between samples.
    pub fn sample(&self, t: f32) -> Vec<Quat> {
        let n = self.times.len().min(self.rotations.iter().map(Vec::len).min().unwrap_or(0));
        if n < 2 {
            return self.rotations.iter().map(|r| r.first().copied().unwrap_or(Quat::IDENTITY)).collect();
        }
        let b = self.times[..n].partition_point(|&x| x <= t).clamp(1, n - 1);
        let (ta, tb) = (self.times[b - 1], self.times[b]);
        let f = if tb > ta { ((t - ta) / (tb - ta)).clamp(0.0, 1.0) } else { 0.0 };
        self.rotations.iter().map(|r| r[b - 1].slerp(r[b], f).normalize()).collect()
    }

    /// Each joint's model-space transform at time `t`: `parent · T(head − parent.head) · R`
    /// (the skinning matrix of a joint is this times its inverse bind matrix `T(−head)`).
    pub fn pose(&self, rig: &Rig, t: f32) -> Vec<Mat4> {
        let rot = self.sample(t);
        let mut out: Vec<Mat4> = Vec::with_capacity(rig.joints.len());
        for (j, joint) in rig.joints.iter().enumerate() {
            let r = rot.get(j).copied().unwrap_or(Quat::IDENTITY);
            let m = match joint.parent {
                Some(p) => {
                    let p = p as usize;
                    out[p] * Mat4::from_rotation_translation(r, joint.head - rig.joints[p].head)
                }
                None => Mat4::from_rotation_translation(r, joint.head),
            };
            out.push(m);
        }
        out
    }
}

/// A placed copy of an organ shape (a leaf, a flower): exporters can weld, instance or
/// merge them. Filled by the organ stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// Index into [`Model::shapes`].
    pub shape: u32,
    /// Shape space → model space.
    pub transform: Mat4,
    /// The skeleton node the organ hangs on (or [`crate::NO_PARENT`]).
    pub node: u32,
}

/// One level of detail beyond the model's own parts (LOD0): its parts and when to show
/// it. Filled by the LOD stage (issue 24).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Lod {
    /// The level's parts (bark and leaves as LOD0's; an impostor's billboards).
    pub parts: Vec<Part>,
    /// Smallest screen coverage (0–1 of the view's height) at which the level shows.
    pub screen_coverage: f32,
}

/// One cubic Bézier segment of a branch axis with the radius at its two ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSegment {
    /// The control points P0…P3; P0 and P3 lie on the axis.
    pub points: [Vec3; 4],
    /// Radius at P0 and at P3 (metres).
    pub radii: [f32; 2],
}

impl CurveSegment {
    /// The point at parameter `t` in \[0, 1\].
    pub fn eval(&self, t: f32) -> Vec3 {
        crate::geometry::cubic_bezier(&self.points, t)
    }
}

/// One axis of the tree as a chain of cubic Bézier segments (Skjermo2008's deformer input).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BranchCurve {
    /// The segments, base to tip; each starts where the previous one ends.
    pub segments: Vec<CurveSegment>,
    /// The axis this one grows out of (index into [`BranchCurves::axes`]), `None` for a root.
    pub parent: Option<u32>,
    /// Branch order: 0 for a trunk.
    pub order: u16,
    /// The skeleton nodes of the axis, base to tip.
    pub nodes: Vec<u32>,
}

/// Every axis of the tree as a Bézier chain with radii. Weber–Penn keeps its own
/// curves; other generators get chains fitted through their skeleton by
/// [`BranchCurves::fit`]. Filled by the pipeline after the fitting stage.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BranchCurves {
    /// The axes, parents first.
    pub axes: Vec<BranchCurve>,
}

impl BranchCurves {
    /// Fits one Bézier chain per skeleton axis (an axis follows each node's child of the
    /// same branch order, the thickest if several, else its first child; other children
    /// start axes of their own): the segments interpolate the nodes, with
    /// Catmull–Rom tangents (the chord at the ends) so the chain is C¹ along the axis.
    /// The radii are the nodes' radii.
    pub fn fit(skeleton: &Skeleton) -> BranchCurves {
        let children = skeleton.children();
        let mut out = BranchCurves::default();
        // (start node, parent axis) of axes still to trace, in order.
        let mut queue: std::collections::VecDeque<(u32, Option<u32>)> = (0..skeleton.len() as u32)
            .filter(|&n| skeleton.parent[n as usize] == NO_PARENT)
            .map(|n| (n, None))
            .collect();
        while let Some((start, parent)) = queue.pop_front() {
            let axis = out.axes.len() as u32;
            let mut nodes = vec![start];
            loop {
                let last = *nodes.last().unwrap() as usize;
                let kids = children.of(last);
                // The axis goes on into the child of its own order (the thickest such,
                // then the first), else into the first child.
                let own = skeleton.order[last];
                let next = kids
                    .iter()
                    .copied()
                    .filter(|&k| skeleton.order[k as usize] == own)
                    .reduce(
                        |a, b| if skeleton.radius[b as usize] > skeleton.radius[a as usize] { b } else { a },
                    )
                    .or_else(|| kids.first().copied());
                let Some(next) = next else { break };
                for &k in kids.iter().filter(|&&k| k != next) {
                    queue.push_back((k, Some(axis)));
                }
                nodes.push(next);
            }
            // A side axis starts at its parent node, so its first segment leaves the parent's axis.
            let base = skeleton.parent[start as usize];
            if base != NO_PARENT {
                nodes.insert(0, base);
            }
            let p = |i: usize| skeleton.position[nodes[i] as usize];
            let tangent = |i: usize| {
                let (a, b) = (i.saturating_sub(1), (i + 1).min(nodes.len() - 1));
                (p(b) - p(a)) / (b - a).max(1) as f32
            };
            let segments = (0..nodes.len().saturating_sub(1))
                .map(|i| {
                    let (a, b) = (p(i), p(i + 1));
                    CurveSegment {
                        points: [a, a + tangent(i) / 3.0, b - tangent(i + 1) / 3.0, b],
                        radii: [skeleton.radius[nodes[i] as usize], skeleton.radius[nodes[i + 1] as usize]],
                    }
                })
                .collect();
            let order = skeleton.order[start as usize];
            out.axes.push(BranchCurve { segments, parent, order, nodes });
        }
        out
    }
}

impl BranchCurves {
    /// Where axis `axis` hangs on its parent axis: the parent's segment index and the
    /// parameter on it. For chains that follow their nodes (fitted curves) the segment
    /// ending at the axis's base node (parameter 1); else (a generator's own Béziers,
    /// Weber–Penn's) the sample nearest the axis's first point, over 33 samples per
    /// segment. `None` for a root axis or an axis without segments.
    pub fn attach(&self, axis: usize) -> Option<(usize, f32)> {
        let a = self.axes.get(axis)?;
        let parent = self.axes.get(a.parent? as usize)?;
        if parent.nodes.len() == parent.segments.len() + 1 {
            let base = a.nodes.first();
            if let Some(k) = parent.nodes.iter().skip(1).position(|n| Some(n) == base) {
                return Some((k, 1.0));
            }
        }
        let p0 = a.segments.first()?.points[0];
        let mut best = (f32::INFINITY, 0usize, 1.0f32);
        for (k, s) in parent.segments.iter().enumerate() {
            for i in 0..=32 {
                let t = i as f32 / 32.0;
                let d = s.eval(t).distance_squared(p0);
                if d < best.0 {
                    best = (d, k, t);
                }
            }
        }
        (best.0.is_finite()).then_some((best.1, best.2))
    }
}

/// What the exporters write: named parts, plus what the real-time stages add. Filled by
/// `pipeline::grow` (parts and branch curves); the organ, wind and LOD stages fill the
/// rest (empty until they run).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Model {
    /// The parts, in output order (LOD0).
    pub parts: Vec<Part>,
    /// Organ shapes that [`Model::instances`] place, each in its own space.
    pub shapes: Vec<Part>,
    /// Placed organs.
    pub instances: Vec<Instance>,
    /// The rig, when the model is skinned.
    pub rig: Option<Rig>,
    /// Coarser levels of detail after LOD0, finest first.
    pub lods: Vec<Lod>,
    /// Smallest screen coverage at which LOD0 (the parts) shows, when there are
    /// [`Model::lods`].
    pub lod0_coverage: f32,
    /// The rig's looping animation (the wind clip), when the model is skinned.
    pub clip: Option<Clip>,
    /// The branch axes as Bézier chains with radii.
    pub curves: BranchCurves,
    /// Textures the materials refer to (texture stage, issue 23).
    pub images: Vec<ModelImage>,
    /// The recipe and seed that made the model, when a recipe did.
    pub provenance: Option<Provenance>,
}

impl Model {
    /// A model of these parts and nothing else.
    pub fn from_parts(parts: Vec<Part>) -> Self {
        Model { parts, ..Default::default() }
    }

    /// Total triangles over all parts.
    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.mesh.triangle_count()).sum()
    }

    /// Total vertices over all parts.
    pub fn vertex_count(&self) -> usize {
        self.parts.iter().map(|p| p.mesh.vertex_count()).sum()
    }

    /// Bounds over all parts.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.parts.iter().filter_map(|p| p.mesh.bounds()).reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A trunk of three nodes with a side branch of two nodes off its middle node.
    fn fork() -> Skeleton {
        let mut s = Skeleton::new();
        let up = Vec3::Z;
        let a = s.push(Vec3::ZERO, 0.2, NO_PARENT, up, 0);
        let b = s.push(Vec3::Y, 0.15, a, up, 0);
        s.push(Vec3::new(0.2, 2.0, 0.0), 0.1, b, up, 0);
        let d = s.push(Vec3::new(0.7, 1.5, 0.0), 0.05, b, up, 1);
        s.push(Vec3::new(1.2, 1.8, 0.0), 0.02, d, up, 1);
        s
    }

    #[test]
    fn fitted_chains_interpolate_the_nodes_and_are_c1() {
        let s = fork();
        let c = BranchCurves::fit(&s);
        assert_eq!(c.axes.len(), 2);
        assert_eq!(c.axes[0].nodes, vec![0, 1, 2]);
        assert_eq!(c.axes[1].nodes, vec![1, 3, 4], "a side axis starts at its parent node");
        assert_eq!((c.axes[0].parent, c.axes[1].parent), (None, Some(0)));
        assert_eq!(c.axes[1].order, 1);
        for axis in &c.axes {
            assert_eq!(axis.segments.len(), axis.nodes.len() - 1);
            for (i, seg) in axis.segments.iter().enumerate() {
                assert_eq!(seg.eval(0.0), s.position[axis.nodes[i] as usize]);
                assert!(seg.eval(1.0).distance(s.position[axis.nodes[i + 1] as usize]) < 1e-6);
                assert_eq!(
                    seg.radii,
                    [s.radius[axis.nodes[i] as usize], s.radius[axis.nodes[i + 1] as usize]]
                );
            }
            for w in axis.segments.windows(2) {
                // C¹: the incoming and outgoing handles at a knot are equal and opposite.
                let (a, b) = (w[0].points[3] - w[0].points[2], w[1].points[1] - w[1].points[0]);
                assert!((a - b).length() < 1e-6, "{a} vs {b}");
            }
        }
    }

    #[test]
    fn vertex_channels_must_match_the_vertex_count() {
        let mut a = VertexAttributes::default();
        assert!(a.is_empty() && a.validate(3).is_ok());
        a.level = vec![0, 1];
        assert!(a.validate(3).unwrap_err().contains("level channel has 2 values for 3 vertices"));
        a.level = vec![0, 1, 1];
        a.wind = vec![[0.0, 0.0, f32::NAN, 0.0]; 3];
        assert!(a.validate(3).unwrap_err().contains("not finite"));
    }
}
