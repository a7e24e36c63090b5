//! The looping wind clip (issue 24, item 2): the wind of [`super::WindRig`] baked into
//! joint rotations, and the skinned pose of a model at a time of the clip (for the
//! preview animation and the tests).
//!
//! Every wave's speed is snapped to a whole number of cycles per clip
//! ([`WindOptions::looped`]), so the force is periodic with the clip's length `T`. The
//! rig is stepped (only the branches the joints read, and their ancestors) through whole
//! periods until the relaxation has forgotten the rest pose (at least 90 steps:
//! `(1 − β)⁹⁰ < 10⁻¹⁶` for the presets' β = 0.35), then one more period is sampled at
//! `fps`. Each joint's global rotation is the shortest arc from its span's rest chord to
//! the current chord; the clip stores it relative to the parent joint's. The sample at
//! `T` repeats the one at 0, so the clip loops without a jump.

use super::rig::JointPlan;
use super::WindOptions;
use crate::model::{Clip, Model, Part};
use glam::{DVec2, Mat4, Quat, Vec3};

/// Steps the relaxation must run before the clip is sampled.
const WARM_STEPS: usize = 90;

/// Bakes a looping clip of `seconds` at `fps` samples per second for the joints of `plan`.
pub fn bake_clip(plan: &JointPlan, wind: &WindOptions, seconds: f64, fps: u32) -> Clip {
    let seconds = if seconds.is_finite() && seconds > 0.0 { seconds } else { 1.0 };
    let frames = ((seconds * fps.max(1) as f64).round() as usize).max(1);
    let dt = seconds / frames as f64;
    let looped = wind.looped(seconds);
    let mut keep = vec![false; plan.wind.branches.len()];
    for &(f, l) in plan.spans.iter().flatten() {
        keep[f..=l].iter_mut().for_each(|k| *k = true);
    }
    let (mut rig, map) = plan.wind.subset(&keep);
    let warm = frames * WARM_STEPS.div_ceil(frames);
    for _ in 0..warm {
        rig.step(&looped, dt, DVec2::ZERO);
    }
    let joints = plan.rig.joints.len();
    let mut rotations: Vec<Vec<Quat>> = vec![Vec::with_capacity(frames + 1); joints];
    for f in 0..frames {
        if f > 0 {
            rig.step(&looped, dt, DVec2::ZERO);
        }
        let global = plan.global_rotations(&rig.points, &map);
        for (j, joint) in plan.rig.joints.iter().enumerate() {
            let local = match joint.parent {
                Some(p) => global[p as usize].inverse() * global[j],
                None => global[j],
            };
            rotations[j].push(local.normalize().as_quat());
        }
    }
    for r in &mut rotations {
        let first = r[0];
        r.push(first);
    }
    let times = (0..=frames).map(|f| (f as f64 * seconds / frames as f64) as f32).collect();
    Clip { name: "wind".into(), times, rotations }
}

/// The skinning matrix of each joint at time `t`: its posed transform times its inverse
/// bind matrix.
fn skinning(model: &Model, t: f32) -> Option<Vec<Mat4>> {
    let (rig, clip) = (model.rig.as_ref()?, model.clip.as_ref()?);
    let pose = clip.pose(rig, t);
    Some(pose.iter().zip(&rig.joints).map(|(m, j)| *m * Mat4::from_translation(-j.head)).collect())
}

/// Where the skinned vertex `v` of `part` goes under the matrices `m`.
fn skin_matrix(part: &Part, m: &[Mat4], v: usize) -> Mat4 {
    let Some(skin) = &part.skin else { return Mat4::IDENTITY };
    let (Some(j), Some(w)) = (skin.joints.get(v), skin.weights.get(v)) else { return Mat4::IDENTITY };
    let mut out = Mat4::ZERO;
    for k in 0..4 {
        if w[k] != 0.0 {
            out += m.get(j[k] as usize).copied().unwrap_or(Mat4::IDENTITY) * w[k];
        }
    }
    out
}

/// `model`'s LOD0 parts posed by its clip at time `t` (linear blend skinning, as glTF
/// readers do); the model unchanged where it has no rig or clip. Normals follow their
/// first vertex's matrix.
pub fn posed(model: &Model, t: f32) -> Model {
    let Some(m) = skinning(model, t) else { return model.clone() };
    let mut out = Model { parts: model.parts.clone(), images: model.images.clone(), ..Default::default() };
    for part in &mut out.parts {
        let mats: Vec<Mat4> = (0..part.mesh.positions.len()).map(|v| skin_matrix(part, &m, v)).collect();
        for (p, mat) in part.mesh.positions.iter_mut().zip(&mats) {
            *p = mat.transform_point3(*p);
        }
        if let Some(n) = part.mesh.normals.as_mut() {
            let mut owner = vec![usize::MAX; n.values.len()];
            for (&vi, &ni) in part.mesh.face_indices.iter().zip(&n.indices) {
                if let Some(o) = owner.get_mut(ni as usize) {
                    if *o == usize::MAX {
                        *o = vi as usize;
                    }
                }
            }
            for (value, &o) in n.values.iter_mut().zip(&owner) {
                if let Some(mat) = mats.get(o) {
                    *value = mat.transform_vector3(*value).try_normalize().unwrap_or(*value);
                }
            }
        }
    }
    out
}

/// The skinned position of vertex `v` of LOD0 part `part` at time `t`.
pub fn posed_vertex(model: &Model, part: usize, v: usize, t: f32) -> Option<Vec3> {
    let m = skinning(model, t)?;
    let p = model.parts.get(part)?;
    Some(skin_matrix(p, &m, v).transform_point3(*p.mesh.positions.get(v)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{BranchCurves, Material};
    use crate::wind::rig::{rig_model, JointPlan};

    fn rigged(wind: &WindOptions) -> (Model, JointPlan) {
        let s = crate::wind::rig::tests::skeleton();
        let plan = JointPlan::new(&BranchCurves::fit(&s), 64);
        let mesh = crate::mesh::tube::tube_mesh(&s, &crate::mesh::tube::TubeOptions::default()).unwrap().mesh;
        let mut model = Model::from_parts(vec![Part::new("bark", mesh, Material::bark())]);
        rig_model(&mut model, &plan, 0.5);
        model.clip = Some(bake_clip(&plan, wind, 2.0, 30));
        (model, plan)
    }

    #[test]
    fn the_clip_loops_and_the_base_stays() {
        let storm = WindOptions::preset("storm").unwrap();
        let (model, plan) = rigged(&storm);
        let clip = model.clip.as_ref().unwrap();
        assert_eq!(clip.times.len(), 61);
        assert_eq!(clip.duration(), 2.0);
        let rig = model.rig.as_ref().unwrap();
        let (a, b) = (clip.pose(rig, 0.0), clip.pose(rig, clip.duration()));
        for (x, y) in a.iter().zip(&b) {
            assert!(x.abs_diff_eq(*y, 1e-6));
        }
        // A true loop: one more simulated period lands on the first sample (no jump).
        let looped = storm.looped(2.0);
        let mut keep = vec![false; plan.wind.branches.len()];
        for &(f, l) in plan.spans.iter().flatten() {
            keep[f..=l].iter_mut().for_each(|k| *k = true);
        }
        let (mut r, map) = plan.wind.subset(&keep);
        for _ in 0..(90usize.div_ceil(60) * 60) {
            r.step(&looped, 2.0 / 60.0, DVec2::ZERO);
        }
        let g0 = plan.global_rotations(&r.points, &map);
        for _ in 0..60 {
            r.step(&looped, 2.0 / 60.0, DVec2::ZERO);
        }
        let g1 = plan.global_rotations(&r.points, &map);
        for (x, y) in g0.iter().zip(&g1) {
            assert!(x.angle_between(*y) < 1e-6, "{x} vs {y}");
        }
        // The tips move, the base does not.
        let part = &model.parts[0];
        let (mut tip, mut base) = (0, 0);
        for (i, p) in part.mesh.positions.iter().enumerate() {
            if p.y > part.mesh.positions[tip].y {
                tip = i;
            }
            if p.y < part.mesh.positions[base].y {
                base = i;
            }
        }
        let moved = |v: usize| {
            (posed_vertex(&model, 0, v, 0.5).unwrap() - posed_vertex(&model, 0, v, 0.0).unwrap()).length()
        };
        let mut tip_move = 0.0f32;
        for k in 0..20 {
            let t = k as f32 * 0.1;
            tip_move =
                tip_move.max((posed_vertex(&model, 0, tip, t).unwrap() - part.mesh.positions[tip]).length());
        }
        assert!(tip_move > 0.01, "{tip_move}");
        assert!(moved(base) < 1e-6);
    }

    #[test]
    fn calm_is_the_bind_pose() {
        let (model, _) = rigged(&WindOptions::calm());
        let clip = model.clip.as_ref().unwrap();
        assert!(clip.rotations.iter().flatten().all(|q| *q == Quat::IDENTITY));
        let posed = posed(&model, 0.7);
        for (a, b) in posed.parts[0].mesh.positions.iter().zip(&model.parts[0].mesh.positions) {
            assert!(a.abs_diff_eq(*b, 1e-5), "{a} vs {b}");
        }
    }
}
