//! The wind's skinned rig (issue 24, item 2 and 3): joints chosen from the branch curves,
//! skin weights for every part, and the per-vertex shader channels `_WIND` / `_PIVOT`.
//!
//! **Joints.** Each axis of [`BranchCurves`] is cut into *runs* of consecutive segments
//! at least [`JointPlan::min_run`] long (short internodes merge). A run is a candidate
//! joint, scored by the length of everything that hangs from it (its own remaining axis
//! and every side axis beyond it). The highest-scoring runs are taken up to the joint
//! budget, never a run whose parent run was left out, so big limbs get joints first and
//! the chosen set is closed under parents. Each root axis also gets a *ground* joint at
//! its base that never moves (the trunk's first run joint hangs on it), so the base of the
//! trunk stays where it stands. A joint's head is its run's first control point; it
//! steers every segment of its axis up to the next chosen run (its *span*), and side
//! axes without a joint of their own ride on the joint of the segment they hang on.
//!
//! **Weights.** Each vertex is placed on its nearest branch segment (distance to the
//! segment's surface: axis distance minus radius, over samples one radius apart, from a
//! `kiddo` k-d tree). Bark blends smoothly across joints along an axis: within a blend
//! length `B = min(2 r, span / 4)` of a joint's head the vertex shares its weight with
//! the joint before (½ at the head, 0 at `B`, smoothstep), and the trunk's first joint
//! hands over from the ground joint (weight 1 at the base). Leaves, cards and other
//! organs ride rigidly on their twig's joint; an impostor's billboards on the ground
//! joint. At most three joints per vertex, weights summing to 1.
//!
//! **Shader channels** (docs/wind.md): `_WIND = (trunk, branch, leaf, phase)` with
//! `trunk = h²` for the vertex's height fraction `h` above the base, `branch` the
//! vertex's distance from its limb's base over the limb's reach (0 on the trunk; a limb
//! is a branch growing out of the trunk, with everything on it), `leaf` the recipe's
//! `leaf_flutter` on leaves (0 on bark) and `phase = fract(0.618034 · limb)` (0 on the
//! trunk); `_PIVOT = (limb base xyz, branch order)`.

use super::WindRig;
use crate::model::{BranchCurves, Joint, Model, Part, Rig, SkinWeights};
use glam::{DVec3, Vec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use std::num::NonZeroUsize;

/// Where each wind branch (one curve segment) sits on its axis.
#[derive(Debug, Clone)]
struct Segments {
    /// The axis of each branch.
    axis: Vec<u32>,
    /// The segment's index on its axis.
    index: Vec<u32>,
    /// Arc offset (sum of chords) of the segment's start along its axis.
    start: Vec<f32>,
    /// The segment's chord length.
    len: Vec<f32>,
    /// The segment's radii at P0 and P3.
    radii: Vec<[f32; 2]>,
    /// Each axis's first branch (`usize::MAX` for an axis without segments).
    first_of_axis: Vec<usize>,
}

/// A chosen set of joints over the branch curves, and which joint steers each segment.
#[derive(Debug, Clone)]
pub struct JointPlan {
    /// The rig (ground joints first, then run joints, parents before children).
    pub rig: Rig,
    /// The rest-pose wind rig over every curve segment.
    pub wind: WindRig,
    /// Per joint: the first and last wind branch of its span (`None` for ground joints).
    pub spans: Vec<Option<(usize, usize)>>,
    /// The joint steering each wind branch.
    pub joint_of: Vec<u32>,
    /// The shortest run (metres) a joint steers: short internodes merge into runs.
    pub min_run: f32,
    segments: Segments,
    curves: BranchCurves,
}

/// `0` below 0, `1` above `b`, Hermite smoothstep between.
fn smoothstep(b: f32, x: f32) -> f32 {
    if b <= 0.0 {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    let t = (x / b).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl JointPlan {
    /// Chooses at most `max_joints` joints (at least one) over `curves`.
    pub fn new(curves: &BranchCurves, max_joints: usize) -> JointPlan {
        let wind = WindRig::new(curves);
        let n = wind.branches.len();
        let mut seg = Segments {
            axis: Vec::with_capacity(n),
            index: Vec::with_capacity(n),
            start: Vec::with_capacity(n),
            len: Vec::with_capacity(n),
            radii: Vec::with_capacity(n),
            first_of_axis: Vec::with_capacity(curves.axes.len()),
        };
        for (a, axis) in curves.axes.iter().enumerate() {
            seg.first_of_axis.push(if axis.segments.is_empty() { usize::MAX } else { seg.axis.len() });
            let mut s = 0.0f32;
            for (k, c) in axis.segments.iter().enumerate() {
                let len = c.points[0].distance(c.points[3]);
                seg.axis.push(a as u32);
                seg.index.push(k as u32);
                seg.start.push(s);
                seg.len.push(len);
                seg.radii.push(c.radii);
                s += len;
            }
        }
        debug_assert_eq!(seg.axis.len(), n);

        // Runs of at least `min_run` along each axis.
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in curves.axes.iter().flat_map(|a| &a.segments) {
            for p in c.points {
                lo = lo.min(p.y);
                hi = hi.max(p.y);
            }
        }
        let height = if hi > lo { hi - lo } else { 1.0 };
        let min_run = height / 12.0;
        let mut run_of = vec![0usize; n];
        let mut runs: Vec<(usize, usize)> = Vec::new(); // (first, last) branch
        for (a, axis) in curves.axes.iter().enumerate() {
            let first = seg.first_of_axis[a];
            let mut acc = 0.0f32;
            for k in 0..axis.segments.len() {
                let b = first + k;
                if k == 0 || acc >= min_run {
                    runs.push((b, b));
                    acc = 0.0;
                }
                let r = runs.len() - 1;
                runs[r].1 = b;
                run_of[b] = r;
                acc += seg.len[b];
            }
        }
        // Length hanging from each branch (itself and everything beyond it).
        let mut hanging: Vec<f64> = seg.len.iter().map(|&l| l as f64).collect();
        for b in (0..n).rev() {
            if let Some(p) = wind.branches[b].parent {
                hanging[p] += hanging[b];
            }
        }
        let roots: Vec<usize> = (0..curves.axes.len())
            .filter(|&a| curves.axes[a].parent.is_none() && seg.first_of_axis[a] != usize::MAX)
            .collect();
        let max_joints = max_joints.max(1);
        let grounds = roots.len().min(max_joints);
        let mut order: Vec<usize> = (0..runs.len()).collect();
        order.sort_by(|&x, &y| {
            hanging[runs[y].0].total_cmp(&hanging[runs[x].0]).then(runs[x].0.cmp(&runs[y].0))
        });
        let mut chosen = vec![false; runs.len()];
        let mut taken = 0;
        for r in order {
            if taken + grounds >= max_joints {
                break;
            }
            let first = runs[r].0;
            let parent_ok = match wind.branches[first].parent {
                Some(p) => chosen[run_of[p]],
                None => roots.iter().take(grounds).any(|&a| seg.first_of_axis[a] == first),
            };
            if parent_ok {
                chosen[r] = true;
                taken += 1;
            }
        }

        // Ground joints, then chosen runs by first branch (parents first).
        let mut rig = Rig::default();
        let mut spans = Vec::new();
        let mut ground_of_axis = vec![0u32; curves.axes.len()];
        for (g, &a) in roots.iter().take(grounds).enumerate() {
            let axis = &curves.axes[a];
            rig.joints.push(Joint { node: axis.nodes[0], parent: None, head: axis.segments[0].points[0] });
            spans.push(None);
            ground_of_axis[a] = g as u32;
        }
        let mut joint_of_run = vec![u32::MAX; runs.len()];
        let mut joint_of = vec![0u32; n];
        for b in 0..n {
            let r = run_of[b];
            let a = seg.axis[b] as usize;
            if chosen[r] && runs[r].0 == b {
                let parent = match wind.branches[b].parent {
                    Some(p) => joint_of[p],
                    None => ground_of_axis[a],
                };
                joint_of_run[r] = rig.joints.len() as u32;
                let c = &curves.axes[a].segments[seg.index[b] as usize];
                let nodes = &curves.axes[a].nodes;
                let segs = curves.axes[a].segments.len().max(1);
                let node = nodes.get(seg.index[b] as usize * nodes.len().saturating_sub(1) / segs).copied();
                rig.joints.push(Joint {
                    node: node.unwrap_or(crate::skeleton::NO_PARENT),
                    parent: Some(parent),
                    head: c.points[0],
                });
                // The span runs to the next chosen run on this axis, or the axis's end.
                let axis_end = seg.first_of_axis[a] + curves.axes[a].segments.len() - 1;
                let mut last = b;
                while last < axis_end && !(chosen[run_of[last + 1]] && run_of[last + 1] != r) {
                    last += 1;
                }
                spans.push(Some((b, last)));
            }
            joint_of[b] = if chosen[r] {
                joint_of_run[r]
            } else {
                match wind.branches[b].parent {
                    Some(p) => joint_of[p],
                    None => ground_of_axis[a],
                }
            };
        }
        JointPlan { rig, wind, spans, joint_of, min_run, segments: seg, curves: curves.clone() }
    }

    /// The joint whose span starts right after branch `b`'s span on the same axis.
    fn next_joint(&self, j: usize) -> Option<(usize, usize)> {
        let (_, last) = self.spans[j]?;
        let next = last + 1;
        if next >= self.joint_of.len() || self.segments.axis[next] != self.segments.axis[last] {
            return None;
        }
        let k = self.joint_of[next] as usize;
        Some((k, self.spans[k]?.0))
    }

    /// Span length of joint `j` along its axis.
    fn span_len(&self, j: usize) -> f32 {
        match self.spans[j] {
            Some((f, l)) => self.segments.start[l] + self.segments.len[l] - self.segments.start[f],
            None => 0.0,
        }
    }

    /// Blend length at the head of joint `j`.
    fn blend(&self, j: usize) -> f32 {
        let Some((f, _)) = self.spans[j] else { return 0.0 };
        (2.0 * self.segments.radii[f][0]).min(0.25 * self.span_len(j))
    }
}

/// Nearest-segment lookup over samples along every segment.
struct Locator {
    tree: Option<ImmutableKdTree<f32, 3>>,
    /// Per sample: branch, parameter, radius.
    samples: Vec<(u32, f32, f32)>,
    points: Vec<[f32; 3]>,
}

impl Locator {
    fn new(plan: &JointPlan) -> Locator {
        let (mut samples, mut points) = (Vec::new(), Vec::new());
        let mut b = 0u32;
        for axis in &plan.curves.axes {
            for c in &axis.segments {
                let len = c.points[0].distance(c.points[3]);
                let r = 0.5 * (c.radii[0] + c.radii[1]);
                let step = r.max(len / 16.0).max(1e-6);
                let k = ((len / step).ceil() as usize).clamp(1, 16);
                for i in 0..=k {
                    let t = i as f32 / k as f32;
                    samples.push((b, t, c.radii[0] + (c.radii[1] - c.radii[0]) * t));
                    points.push(c.eval(t).to_array());
                }
                b += 1;
            }
        }
        let tree = if points.is_empty() { None } else { ImmutableKdTree::new_from_slice(&points).ok() };
        Locator { tree, samples, points }
    }

    /// The nearest segment's branch and parameter for `p`.
    fn find(&self, p: Vec3) -> Option<(usize, f32)> {
        let tree = self.tree.as_ref()?;
        let k = NonZeroUsize::new(8.min(self.points.len()))?;
        let found = tree.query(&p.to_array()).nearest_n::<SquaredEuclidean<f32>>(k).execute();
        found
            .iter()
            .map(|r| {
                let (b, t, rad) = self.samples[r.item as usize];
                (r.distance.sqrt() - rad, b, t)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)))
            .map(|(_, b, t)| (b as usize, t))
    }
}

/// How a part is bound: blended along axes (bark), rigid on the twig's joint (organs) or
/// rigid on the ground joint (an impostor).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Binding {
    Blend,
    Twig,
    Ground,
}

fn binding(part: &Part) -> Binding {
    if part.name == "bark" {
        Binding::Blend
    } else if part.name.contains("impostor") || part.material.name.contains("impostor") {
        Binding::Ground
    } else {
        Binding::Twig
    }
}

/// Per-limb data for the shader channels.
struct Limbs {
    /// The limb (index among limbs) of each axis; `None` on the trunk.
    of_axis: Vec<Option<u32>>,
    /// Base point and reach of each limb.
    base: Vec<(Vec3, f32)>,
    /// The lowest point of the tree and its height.
    floor: f32,
    height: f32,
    /// Base of the first root axis.
    root: Vec3,
}

impl Limbs {
    fn new(curves: &BranchCurves) -> Limbs {
        let mut of_axis: Vec<Option<u32>> = Vec::with_capacity(curves.axes.len());
        let mut base: Vec<(Vec3, f32)> = Vec::new();
        for axis in &curves.axes {
            let limb = match axis.parent {
                None => None,
                Some(p) => {
                    let pa = &curves.axes[p as usize];
                    if pa.parent.is_none() || pa.order == 0 {
                        let b = axis.segments.first().map_or(Vec3::ZERO, |s| s.points[0]);
                        base.push((b, 0.0));
                        Some(base.len() as u32 - 1)
                    } else {
                        of_axis[p as usize]
                    }
                }
            };
            if let Some(l) = limb {
                let (b, reach) = &mut base[l as usize];
                for s in &axis.segments {
                    *reach = reach.max(s.points[3].distance(*b));
                }
            }
            of_axis.push(limb);
        }
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in curves.axes.iter().flat_map(|a| &a.segments) {
            for p in c.points {
                lo = lo.min(p.y);
                hi = hi.max(p.y);
            }
        }
        let root = curves.axes.iter().find_map(|a| a.segments.first()).map_or(Vec3::ZERO, |s| s.points[0]);
        Limbs { of_axis, base, floor: lo.min(hi), height: (hi - lo).max(1e-6), root }
    }
}

/// One vertex's binding: joints, weights, `_WIND`, `_PIVOT`, branch order, skeleton node.
type VertexBinding = ([u16; 4], [f32; 4], [f32; 4], [f32; 4], u16, u32);

/// Binds one part: skin weights and wind channels per position.
fn bind_part(plan: &JointPlan, loc: &Locator, limbs: &Limbs, part: &mut Part, leaf_flutter: f32) {
    let how = binding(part);
    let positions = &part.mesh.positions;
    let seg = &plan.segments;
    let per_vertex: Vec<VertexBinding> = positions
        .par_iter()
        .map(|&p| {
            let Some((b, t)) = loc.find(p) else {
                return (
                    [0; 4],
                    [1.0, 0.0, 0.0, 0.0],
                    [0.0; 4],
                    [limbs.root.x, limbs.root.y, limbs.root.z, 0.0],
                    0,
                    0,
                );
            };
            let a = seg.axis[b] as usize;
            let axis = &plan.curves.axes[a];
            let j = plan.joint_of[b] as usize;
            let mut w: Vec<(u16, f32)> = Vec::with_capacity(3);
            match how {
                Binding::Ground => w.push((0, 1.0)),
                Binding::Twig => w.push((j as u16, 1.0)),
                Binding::Blend => {
                    let s = seg.start[b] + t * seg.len[b];
                    let (mut wp, mut wn) = (0.0, 0.0);
                    let (mut pj, mut nj) = (None, None);
                    if let (Some((f, _)), Some(parent)) = (plan.spans[j], plan.rig.joints[j].parent) {
                        if seg.axis[f] as usize == a {
                            let d = s - seg.start[f];
                            let ground = plan.spans[parent as usize].is_none();
                            wp = if ground {
                                1.0 - smoothstep((3.0 * seg.radii[f][0]).min(0.25 * plan.span_len(j)), d)
                            } else {
                                0.5 * (1.0 - smoothstep(plan.blend(j), d))
                            };
                            pj = Some(parent as u16);
                        }
                    }
                    if let Some((k, f)) = plan.next_joint(j) {
                        wn = 0.5 * (1.0 - smoothstep(plan.blend(k), seg.start[f] - s));
                        nj = Some(k as u16);
                    }
                    let wj = (1.0 - wp - wn).max(0.0);
                    w.push((j as u16, wj));
                    if let Some(pj) = pj {
                        w.push((pj, wp));
                    }
                    if let Some(nj) = nj {
                        w.push((nj, wn));
                    }
                }
            }
            w.retain(|x| x.1 > 0.0);
            w.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
            let total: f32 = w.iter().map(|x| x.1).sum();
            let (mut joints, mut weights) = ([0u16; 4], [0f32; 4]);
            if total > 0.0 {
                for (i, (jj, ww)) in w.iter().take(4).enumerate() {
                    joints[i] = *jj;
                    weights[i] = ww / total;
                }
            } else {
                joints[0] = j as u16;
                weights[0] = 1.0;
            }
            // Shader channels.
            let h = ((p.y - limbs.floor) / limbs.height).clamp(0.0, 1.0);
            let limb = limbs.of_axis[a];
            let (branch, phase, pivot) = match limb {
                Some(l) => {
                    let (base, reach) = limbs.base[l as usize];
                    let f = if reach > 0.0 { (p.distance(base) / reach).clamp(0.0, 1.0) } else { 0.0 };
                    (f, (l as f32 * 0.618_034).fract(), base)
                }
                None => (0.0, 0.0, limbs.root),
            };
            let leaf = if how == Binding::Blend { 0.0 } else { leaf_flutter };
            let segs = axis.segments.len().max(1) as f32;
            let at = ((seg.index[b] as f32 + t) / segs * axis.nodes.len().saturating_sub(1) as f32).round()
                as usize;
            let node = axis.nodes.get(at).copied().unwrap_or(crate::skeleton::NO_PARENT);
            (
                joints,
                weights,
                [h * h, branch, leaf, phase],
                [pivot.x, pivot.y, pivot.z, axis.order as f32],
                axis.order,
                node,
            )
        })
        .collect();
    let mut skin = SkinWeights::default();
    let attrs = &mut part.attributes;
    attrs.wind.clear();
    attrs.pivot.clear();
    attrs.level.clear();
    attrs.node.clear();
    for (j, w, wind, pivot, level, node) in per_vertex {
        skin.joints.push(j);
        skin.weights.push(w);
        attrs.wind.push(wind);
        attrs.pivot.push(pivot);
        attrs.level.push(level);
        attrs.node.push(node);
    }
    part.skin = Some(skin);
}

/// Gives `model` the plan's rig, and skin weights and wind channels to every part of
/// every level (instanced organs are merged first: a skinned mesh cannot be instanced).
pub fn rig_model(model: &mut Model, plan: &JointPlan, leaf_flutter: f32) {
    if !model.instances.is_empty() {
        let flat = model.flattened().into_owned();
        *model = flat;
    }
    let loc = Locator::new(plan);
    let limbs = Limbs::new(&plan.curves);
    for part in model.parts.iter_mut().chain(model.lods.iter_mut().flat_map(|l| l.parts.iter_mut())) {
        bind_part(plan, &loc, &limbs, part, leaf_flutter);
    }
    model.rig = Some(plan.rig.clone());
}

impl JointPlan {
    /// The global rotation of every joint for the wind rig's current points (`points`
    /// indexed through `map`, old branch → subset branch): the shortest arc from the rest
    /// chord of the joint's span to its current chord; ground joints stay still.
    pub(crate) fn global_rotations(&self, points: &[[DVec3; 4]], map: &[Option<usize>]) -> Vec<glam::DQuat> {
        self.spans
            .iter()
            .map(|span| {
                let Some((f, l)) = *span else { return glam::DQuat::IDENTITY };
                let (Some(fi), Some(li)) = (map[f], map[l]) else { return glam::DQuat::IDENTITY };
                let rest = self.wind.branches[l].rest[3] - self.wind.branches[f].rest[0];
                let now = points[li][3] - points[fi][0];
                match (rest.try_normalize(), now.try_normalize()) {
                    (Some(a), Some(b)) if a != b => glam::DQuat::from_rotation_arc(a, b),
                    _ => glam::DQuat::IDENTITY,
                }
            })
            .collect()
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::geometry::Mesh;
    use crate::model::Material;
    use crate::skeleton::{Skeleton, NO_PARENT};

    /// A trunk of six unit segments with a side branch at nodes 2 and 4.
    pub(crate) fn skeleton() -> Skeleton {
        let mut s = Skeleton::new();
        let mut prev = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
        for k in 1..=6 {
            prev = s.push(Vec3::new(0.0, k as f32, 0.0), 0.3 - 0.04 * k as f32, prev, Vec3::X, 0);
            if k == 2 || k == 4 {
                let a = s.push(Vec3::new(1.0, k as f32 + 0.6, 0.0), 0.05, prev, Vec3::Y, 1);
                s.push(Vec3::new(2.0, k as f32 + 1.0, 0.2), 0.03, a, Vec3::Y, 1);
            }
        }
        s
    }

    #[test]
    fn joints_are_parent_closed_within_budget_and_big_limbs_first() {
        let curves = BranchCurves::fit(&skeleton());
        for budget in [1, 2, 3, 5, 64] {
            let plan = JointPlan::new(&curves, budget);
            assert!(plan.rig.joints.len() <= budget.max(1), "budget {budget}");
            for (i, j) in plan.rig.joints.iter().enumerate() {
                if let Some(p) = j.parent {
                    assert!((p as usize) < i, "parents first");
                }
            }
            assert_eq!(plan.spans[0], None, "joint 0 is the ground joint");
        }
        let plan = JointPlan::new(&curves, 3);
        // Ground, then the trunk's first run: limbs come after the trunk they hang on.
        assert_eq!(plan.rig.joints[1].parent, Some(0));
        assert_eq!(plan.rig.joints[1].head, Vec3::ZERO);
    }

    #[test]
    fn bark_weights_blend_and_sum_to_one_and_the_base_is_grounded() {
        let s = skeleton();
        let curves = BranchCurves::fit(&s);
        let plan = JointPlan::new(&curves, 64);
        let mesh = crate::mesh::tube::tube_mesh(&s, &crate::mesh::tube::TubeOptions::default()).unwrap().mesh;
        let mut model = Model::from_parts(vec![Part::new("bark", mesh, Material::bark())]);
        rig_model(&mut model, &plan, 0.5);
        let part = &model.parts[0];
        let skin = part.skin.as_ref().unwrap();
        assert_eq!(skin.joints.len(), part.mesh.positions.len());
        let mut blended = 0;
        for ((p, j), w) in part.mesh.positions.iter().zip(&skin.joints).zip(&skin.weights) {
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{w:?}");
            assert!(j.iter().all(|&j| (j as usize) < plan.rig.joints.len()));
            if w[1] > 0.0 {
                blended += 1;
            }
            if p.y <= 1e-6 {
                assert_eq!((j[0], w[0]), (0, 1.0), "the base rides on the ground joint");
            }
        }
        assert!(blended > 0, "some vertices blend across joints");
        let wind = &part.attributes.wind;
        assert!(wind.iter().all(|w| (0.0..=1.0).contains(&w[0]) && w[2] == 0.0));
        assert!(part.attributes.validate(part.mesh.positions.len()).is_ok());
    }

    #[test]
    fn leaves_ride_rigidly_and_carry_the_flutter() {
        let s = skeleton();
        let plan = JointPlan::new(&BranchCurves::fit(&s), 64);
        let mut leaf = Mesh::new();
        leaf.positions = vec![Vec3::new(2.0, 3.0, 0.2), Vec3::new(2.1, 3.0, 0.2), Vec3::new(2.0, 3.1, 0.2)];
        leaf.face_indices = vec![0, 1, 2];
        leaf.face_offsets = vec![0, 3];
        let mut model = Model::from_parts(vec![Part::new("leaves", leaf, Material::leaf())]);
        rig_model(&mut model, &plan, 0.7);
        let part = &model.parts[0];
        let skin = part.skin.as_ref().unwrap();
        assert!(skin.weights.iter().all(|w| *w == [1.0, 0.0, 0.0, 0.0]));
        assert!(part.attributes.wind.iter().all(|w| w[2] == 0.7 && w[1] > 0.5), "{:?}", part.attributes.wind);
        assert!(part.attributes.pivot.iter().all(|p| p[3] == 1.0), "level 1");
    }
}
