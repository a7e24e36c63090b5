//! The rig and its clip: joints, inverse bind matrices, skins with four weights per
//! vertex and the looping animation channels (glTF2 §3.7–§3.11).

use super::{node, Doc, Layout};
use crate::error::Result;
use crate::export::ExportOptions;
use crate::model::{Clip, Part, Rig};
use gltf_json as json;
use json::validation::Checked::Valid;
use json::Index;

/// The rig: a node per joint (`joint_<i>`, in rig order, its translation `head −
/// parent.head`, rotation the identity), the root joints under one `sylva_rig` node, the
/// skin (inverse bind matrices the translations by `−head`) and, with a clip, its
/// animation. Returns the `sylva_rig` node and the skin.
pub(super) fn push_rig(
    doc: &mut Doc,
    rig: &Rig,
    clip: Option<&Clip>,
) -> Result<(Index<json::Node>, Index<json::Skin>)> {
    use json::accessor::Type as T;
    let ibm = rig.joints.iter().map(|j| glam::Mat4::from_translation(-j.head).to_cols_array());
    let ibm = doc.floats(ibm, T::Mat4, Layout::Data { stride: 64 }, None)?;
    let base = doc.root.nodes.len();
    let index = |j: usize| Index::<json::Node>::new((base + j) as u32);
    let mut children = vec![Vec::new(); rig.joints.len()];
    for (j, joint) in rig.joints.iter().enumerate() {
        if let Some(p) = joint.parent {
            children[p as usize].push(index(j));
        }
    }
    for (j, (joint, kids)) in rig.joints.iter().zip(children).enumerate() {
        let mut n = node(format!("joint_{j}"), None, (!kids.is_empty()).then_some(kids));
        let t = joint.parent.map_or(joint.head, |p| joint.head - rig.joints[p as usize].head);
        n.translation = Some(t.to_array());
        let pushed = doc.root.push(n);
        debug_assert_eq!(pushed, index(j));
    }
    let roots: Vec<Index<json::Node>> =
        (0..rig.joints.len()).filter(|&j| rig.joints[j].parent.is_none()).map(index).collect();
    let skeleton = if roots.len() == 1 { roots[0] } else { Index::new(doc.root.nodes.len() as u32) };
    let top = doc.root.push(node("sylva_rig".to_owned(), None, Some(roots)));
    let skin = doc.root.push(json::Skin {
        extensions: None,
        extras: Default::default(),
        inverse_bind_matrices: Some(ibm),
        joints: (0..rig.joints.len()).map(index).collect(),
        name: Some("sylva_rig".to_owned()),
        skeleton: Some(skeleton),
    });
    if let Some(clip) = clip {
        push_clip(doc, clip, &(0..rig.joints.len()).map(index).collect::<Vec<_>>())?;
    }
    Ok((top, skin))
}

/// The clip as one animation: one shared `FLOAT` time accessor (with its bounds), and per
/// joint a `LINEAR` sampler of unit quaternions and a `rotation` channel.
fn push_clip(doc: &mut Doc, clip: &Clip, joints: &[Index<json::Node>]) -> Result<()> {
    use json::accessor::Type as T;
    use json::animation::{Channel, Interpolation, Property, Sampler, Target};
    let (first, last) = (clip.times.first().copied().unwrap_or(0.0), clip.duration());
    let bounds = Some((json::Value::from(vec![first]), json::Value::from(vec![last])));
    let input = doc.floats(clip.times.iter().map(|&t| [t]), T::Scalar, Layout::Data { stride: 4 }, bounds)?;
    let (mut samplers, mut channels) = (Vec::new(), Vec::new());
    for (rotations, &node) in clip.rotations.iter().zip(joints) {
        let quats = rotations.iter().map(|q| q.normalize().to_array());
        let output = doc.floats(quats, T::Vec4, Layout::Data { stride: 16 }, None)?;
        let sampler = Index::new(samplers.len() as u32);
        samplers.push(Sampler {
            extensions: None,
            extras: Default::default(),
            input,
            interpolation: Valid(Interpolation::Linear),
            output,
        });
        channels.push(Channel {
            sampler,
            target: Target {
                extensions: None,
                extras: Default::default(),
                node,
                path: Valid(Property::Rotation),
            },
            extensions: None,
            extras: Default::default(),
        });
    }
    doc.root.push(json::Animation {
        extensions: None,
        extras: Default::default(),
        channels,
        name: Some(clip.name.clone()),
        samplers,
    });
    Ok(())
}

/// Skinning of one primitive: a cleaned-up entry per mesh position ([`skin_entry`]) and
/// whether the joint indices are written as `UNSIGNED_BYTE`.
pub(super) struct Skinning {
    pub(super) entries: Vec<([u16; 4], [f32; 4])>,
    pub(super) small: bool,
}

/// What a primitive carries beyond position, normal, UV and tangent: skinning, and the
/// wind channels (per mesh position; empty when absent).
pub(super) struct Channels<'a> {
    pub(super) skin: Option<Skinning>,
    pub(super) wind: &'a [[f32; 4]],
    pub(super) pivot: &'a [[f32; 4]],
    /// Also pack the wind into `COLOR_0` and `TEXCOORD_1`.
    pub(super) wind_colors: bool,
}

impl<'a> Channels<'a> {
    /// The wind channels of `part` (no skinning).
    pub(super) fn wind(part: &'a Part, options: &ExportOptions) -> Self {
        Channels {
            skin: None,
            wind: &part.attributes.wind,
            pivot: &part.attributes.pivot,
            wind_colors: options.wind_colors,
        }
    }
}

/// A part's skin entries per mesh position; a part without skin weights is bound wholly
/// to joint 0.
pub(super) fn skin_entries(part: &Part) -> Vec<([u16; 4], [f32; 4])> {
    match &part.skin {
        Some(s) => s.joints.iter().zip(&s.weights).map(|(&j, &w)| skin_entry(j, w)).collect(),
        None => vec![([0; 4], [1.0, 0.0, 0.0, 0.0]); part.mesh.positions.len()],
    }
}

/// One vertex's joints and weights as the glTF validator wants them: a joint listed twice
/// gets the sum of its weights, the non-zero weights come first and sum to 1 in `f32`
/// (to 1e-7 per weight, summed in order), and a zero weight has joint index 0.
fn skin_entry(joints: [u16; 4], weights: [f32; 4]) -> ([u16; 4], [f32; 4]) {
    let (mut j, mut w, mut n) = ([0u16; 4], [0f32; 4], 0);
    for (&jj, &ww) in joints.iter().zip(&weights) {
        if ww.is_nan() || ww <= 0.0 {
            continue;
        }
        match j[..n].iter().position(|&x| x == jj) {
            Some(k) => w[k] += ww,
            None => {
                (j[n], w[n]) = (jj, ww);
                n += 1;
            }
        }
    }
    let sum: f32 = w.iter().sum();
    if n == 0 || !sum.is_finite() {
        return ([0; 4], [1.0, 0.0, 0.0, 0.0]);
    }
    for x in &mut w[..n] {
        *x /= sum;
    }
    let largest = (0..n).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
    for _ in 0..4 {
        let err = 1.0 - w.iter().fold(0f32, |a, &x| a + x);
        if err.abs() <= 1e-7 * n as f32 {
            break;
        }
        w[largest] += err;
    }
    for k in 0..4 {
        if w[k] <= 0.0 {
            (j[k], w[k]) = (0, 0.0);
        }
    }
    (j, w)
}
