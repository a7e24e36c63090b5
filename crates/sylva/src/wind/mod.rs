//! Wind on the branch curves (issue 24, Skjermo2008 Th §3.2.1 and §4.3; Skjermo2008-spec §4, the
//! recommended formulation, properties 20–24).
//!
//! The tree is a hierarchy of cubic Bézier branches ([`WindRig`], one per segment of
//! [`BranchCurves`]: a segment's parent is the segment before it on its axis, or the
//! parent axis's segment that ends at the axis's base node; for a generator's own
//! Béziers, whose segments do not follow the nodes, the parent axis's segment and
//! parameter nearest the axis's first point). Each step, parents first:
//!
//! 1. the branch's rest control points are carried rigidly by its parent's *current*
//!    frame at the attach parameter (P₀ lands on the parent's animated curve);
//! 2. the force field is sampled at the branch tip P₃ — in (x, z) only, the same at every
//!    height: `F(x, z, t) = W̄ + Σᵢ Aᵢ Dᵢ sin(ωᵢ (Dᵢ·(x, z)) + φᵢ t)`, `ωᵢ = 2π/λᵢ`,
//!    `φᵢ = speedᵢ ωᵢ` (Finch-style waves returning forces);
//! 3. targets `Pₖ* = P̂ₖ + wₖ κ (L²/H) F` with `wₖ = (k/3)^γ` (`w₀ = 0`), `κ` the
//!    stiffness of the branch's order, `L` the branch's chord and `H` the tree's height.
//!    The factor `L²/H` is sylva's (the spec applies `κ F` to every branch alike): a
//!    branch of chord `L` then turns by about `κ F L / H`, so an axis bends the same
//!    however finely the generator cut it into segments, and `F` reads as a fraction of
//!    the tree's height (a trunk of stiffness κ sways its top by about `κ F H / 2`);
//!    with the spec's form a tree of 40 short segments bends forty times more than one
//!    of the same shape cut into a few;
//! 4. relaxation from the last step, `Pₖ ← Pₖ + β (Pₖ* − Pₖ)`;
//! 5. lengths re-projected, `Pₖ ← Pₖ₋₁ + ℓₖ normalize(Pₖ − Pₖ₋₁)` (rest lengths ℓₖ);
//! 6. joint angles between consecutive legs clamped below [`MAX_JOINT_DEG`].
//!
//! With no lag (default) every level reads its parent's already-updated points, so a
//! trunk gust reaches every tip in the same step; `legacy_lag` reads the parent's
//! points of the step before, as the seed's one-pass-per-level GPU update did (a level-k
//! branch answers k steps late: the "rubber band" the seed reports). Zero wind is the
//! rest pose exactly, bit for bit.

use crate::model::BranchCurves;
use glam::{DQuat, DVec2, DVec3};

pub mod clip;
pub mod rig;
pub mod samples;

pub use clip::{bake_clip, posed};
pub use rig::{rig_model, JointPlan};

/// Largest angle between consecutive control-polygon legs (the deformer needs < 90°).
pub const MAX_JOINT_DEG: f64 = 89.0;

/// One sine of the force field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindWave {
    /// Amplitude Aᵢ (the force's unit: metres of displacement at stiffness 1).
    pub amplitude: f64,
    /// Direction Dᵢ in the (x, z) plane (normalized when used).
    pub direction: DVec2,
    /// Wavelength λᵢ in metres.
    pub wavelength: f64,
    /// Speed at which the wave travels, metres per second.
    pub speed: f64,
}

/// The wind's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct WindOptions {
    /// Mean wind W̄ in (x, z).
    pub mean: DVec2,
    /// The sines.
    pub waves: Vec<WindWave>,
    /// Stiffness factor κ per branch order (trunk first; the last value serves deeper
    /// orders).
    pub stiffness: Vec<f64>,
    /// Weight exponent γ: `wₖ = (k/3)^γ`.
    pub gamma: f64,
    /// Relaxation β in (0, 1].
    pub beta: f64,
    /// Read each parent's points of the previous step (the seed's lag).
    pub legacy_lag: bool,
}

impl WindOptions {
    /// No wind at all.
    pub fn calm() -> WindOptions {
        WindOptions::blowing(0.0, 0.0, 0.0)
    }

    /// A named preset: `calm`, `breeze` or `storm`.
    pub fn preset(name: &str) -> Option<WindOptions> {
        match name {
            "calm" => Some(WindOptions::calm()),
            "breeze" => Some(WindOptions::blowing(0.08, 0.06, 0.0)),
            "storm" => Some(WindOptions::blowing(0.4, 0.25, 0.0)),
            _ => None,
        }
    }

    /// Wind of mean strength `mean` and gust amplitude `gusts` blowing toward
    /// `direction_deg` (0 = +x, 90 = +z): four waves spread ±35° about the direction,
    /// wavelengths 7–37 m travelling at 3–6 m/s.
    pub fn blowing(mean: f64, gusts: f64, direction_deg: f64) -> WindOptions {
        let a = direction_deg.to_radians();
        let dir = |off: f64| DVec2::new((a + off.to_radians()).cos(), (a + off.to_radians()).sin());
        let waves =
            [(1.0, 0.0, 37.0, 6.0), (0.6, 25.0, 23.0, 5.0), (0.4, -35.0, 13.0, 4.0), (0.25, 10.0, 7.0, 3.0)]
                .iter()
                .map(|&(k, off, wavelength, speed)| WindWave {
                    amplitude: k * gusts,
                    direction: dir(off),
                    wavelength,
                    speed,
                })
                .collect();
        WindOptions {
            mean: dir(0.0) * mean,
            waves,
            stiffness: vec![0.35, 0.7, 1.0, 1.2],
            gamma: 1.5,
            beta: 0.35,
            legacy_lag: false,
        }
    }

    /// The force at `(x, z)` at time `t` (independent of height).
    pub fn force(&self, x: f64, z: f64, t: f64) -> DVec2 {
        let p = DVec2::new(x, z);
        let mut f = self.mean;
        for w in &self.waves {
            let d = w.direction.normalize_or_zero();
            let omega = std::f64::consts::TAU / w.wavelength.max(1e-9);
            f += d * (w.amplitude * (omega * d.dot(p) + w.speed * omega * t).sin());
        }
        f
    }

    /// `wₖ = (k/3)^γ` for control point `k` (0..=3).
    pub fn weight(&self, k: usize) -> f64 {
        (k as f64 / 3.0).powf(self.gamma)
    }

    /// The same wind with every wave's speed snapped so that it completes a whole number
    /// of cycles (at least one where its amplitude is not zero) in `seconds`: the force
    /// is then periodic with that period, so a clip of that length loops.
    pub fn looped(&self, seconds: f64) -> WindOptions {
        let mut w = self.clone();
        for wave in &mut w.waves {
            let cycles = (wave.speed * seconds / wave.wavelength.max(1e-9)).round();
            let cycles = if cycles == 0.0 && wave.amplitude != 0.0 { 1.0 } else { cycles };
            wave.speed = cycles * wave.wavelength / seconds;
        }
        w
    }

    fn kappa(&self, order: u16) -> f64 {
        self.stiffness.get(order as usize).or(self.stiffness.last()).copied().unwrap_or(1.0)
    }
}

/// One branch of the rig: a cubic Bézier and where it hangs.
#[derive(Debug, Clone, PartialEq)]
pub struct WindBranch {
    /// The parent branch (an index smaller than this one's), or `None` for a root.
    pub parent: Option<usize>,
    /// The parameter on the parent where this branch starts.
    pub attach: f64,
    /// Branch order (0 trunk), for the stiffness.
    pub order: u16,
    /// Depth in the branch hierarchy (0 for a root): the level of the lag.
    pub depth: u32,
    /// Rest control points.
    pub rest: [DVec3; 4],
    /// Rest leg lengths ℓ₁…ℓ₃.
    lengths: [f64; 3],
    /// How much of the force the branch takes: `L² / H` for its chord `L` and the tree's
    /// height `H` (see the module docs).
    pub reach: f64,
}

/// The animated state of every branch's control points.
#[derive(Debug, Clone, PartialEq)]
pub struct WindRig {
    /// The branches, parents first.
    pub branches: Vec<WindBranch>,
    /// Current control points, parallel to `branches`.
    pub points: Vec<[DVec3; 4]>,
    /// Seconds simulated.
    pub time: f64,
}

fn bezier(p: &[DVec3; 4], t: f64) -> DVec3 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

fn tangent(p: &[DVec3; 4], t: f64) -> DVec3 {
    let s = 1.0 - t;
    let d = (p[1] - p[0]) * (3.0 * s * s) + (p[2] - p[1]) * (6.0 * s * t) + (p[3] - p[2]) * (3.0 * t * t);
    d.try_normalize().unwrap_or((p[3] - p[0]).normalize_or_zero())
}

impl WindRig {
    /// One branch per segment of `curves`, at rest.
    pub fn new(curves: &BranchCurves) -> WindRig {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for s in curves.axes.iter().flat_map(|a| &a.segments) {
            for p in s.points {
                lo = lo.min(p.y as f64);
                hi = hi.max(p.y as f64);
            }
        }
        let height = if hi > lo { hi - lo } else { 1.0 };
        let mut branches: Vec<WindBranch> = Vec::new();
        // Per axis: the branch index of each of its segments.
        let mut of_axis: Vec<Vec<usize>> = Vec::with_capacity(curves.axes.len());
        for (a, axis) in curves.axes.iter().enumerate() {
            let mut ids = Vec::with_capacity(axis.segments.len());
            // The branch and parameter on the parent axis where this axis hangs.
            let hang = curves.attach(a).and_then(|(seg, t)| {
                let ids = of_axis.get(axis.parent? as usize)?;
                ids.get(seg).map(|&b| (b, t as f64))
            });
            for (k, s) in axis.segments.iter().enumerate() {
                let (parent, attach) = if k == 0 {
                    (hang.map(|h| h.0), hang.map_or(1.0, |h| h.1))
                } else {
                    (ids.last().copied(), 1.0)
                };
                let depth = parent.map_or(0, |p: usize| branches[p].depth + 1);
                let rest = s.points.map(|p| p.as_dvec3());
                let lengths = [1, 2, 3].map(|i| (rest[i] - rest[i - 1]).length());
                let reach = (rest[3] - rest[0]).length_squared() / height;
                ids.push(branches.len());
                branches.push(WindBranch { parent, attach, order: axis.order, depth, rest, lengths, reach });
            }
            of_axis.push(ids);
        }
        let points = branches.iter().map(|b| b.rest).collect();
        WindRig { branches, points, time: 0.0 }
    }

    /// The rig restricted to the branches `keep` marks and their ancestors, and where each
    /// old branch went (`None` where dropped). Parents stay before children, so stepping
    /// the subset moves its branches exactly as stepping the whole rig would.
    pub fn subset(&self, keep: &[bool]) -> (WindRig, Vec<Option<usize>>) {
        let n = self.branches.len();
        let mut kept: Vec<bool> = (0..n).map(|i| keep.get(i).copied().unwrap_or(false)).collect();
        for i in (0..n).rev() {
            if kept[i] {
                if let Some(p) = self.branches[i].parent {
                    kept[p] = true;
                }
            }
        }
        let mut map = vec![None; n];
        let mut out = WindRig { branches: Vec::new(), points: Vec::new(), time: self.time };
        for i in (0..n).filter(|&i| kept[i]) {
            map[i] = Some(out.branches.len());
            let mut b = self.branches[i].clone();
            b.parent = b.parent.and_then(|p| map[p]);
            out.branches.push(b);
            out.points.push(self.points[i]);
        }
        (out, map)
    }

    /// The rig back at rest.
    pub fn reset(&mut self) {
        for (p, b) in self.points.iter_mut().zip(&self.branches) {
            *p = b.rest;
        }
        self.time = 0.0;
    }

    /// Advances the wind by `dt` seconds. `impulse` adds a force to the branches whose
    /// depth is 0 (trunk roots) for this step only, as a game event would.
    pub fn step(&mut self, wind: &WindOptions, dt: f64, impulse: DVec2) {
        self.time += dt;
        let before = if wind.legacy_lag { Some(self.points.clone()) } else { None };
        for i in 0..self.branches.len() {
            let b = &self.branches[i];
            // 1. Carry the rest pose with the parent's current (or, lagging, last) frame.
            let carried = match b.parent {
                None => b.rest,
                Some(p) => {
                    let parent_now = before.as_ref().map_or(&self.points[p], |old| &old[p]);
                    let parent_rest = &self.branches[p].rest;
                    let (c_rest, c_now) = (bezier(parent_rest, b.attach), bezier(parent_now, b.attach));
                    let (t_rest, t_now) = (tangent(parent_rest, b.attach), tangent(parent_now, b.attach));
                    if c_rest == c_now && t_rest == t_now {
                        b.rest
                    } else {
                        let r = DQuat::from_rotation_arc(t_rest, t_now);
                        // P₀ keeps its rest offset from the attach point (zero for fitted
                        // chains, whose axes start on their parent's curve).
                        b.rest.map(|x| c_now + r * (x - c_rest))
                    }
                }
            };
            // 2. The force at the current tip, in (x, z).
            let tip = self.points[i][3];
            let mut f = wind.force(tip.x, tip.z, self.time);
            if b.depth == 0 {
                f += impulse;
            }
            let f = DVec3::new(f.x, 0.0, f.y) * (wind.kappa(b.order) * b.reach);
            // 3.–4. Targets and relaxation; P₀ is the attach point.
            let mut p = self.points[i];
            p[0] = carried[0];
            for k in 1..4 {
                let target = carried[k] + f * wind.weight(k);
                p[k] += (target - p[k]) * wind.beta;
            }
            // 5. Rest lengths (left alone where already exact, so rest stays rest).
            for k in 1..4 {
                let d = p[k] - p[k - 1];
                let (len, rest) = (d.length(), b.lengths[k - 1]);
                if len != rest {
                    let dir = d
                        .try_normalize()
                        .unwrap_or_else(|| (carried[k] - carried[k - 1]).normalize_or_zero());
                    p[k] = p[k - 1] + dir * rest;
                }
            }
            // 6. Joint angles below MAX_JOINT_DEG (or the rest pose's own, if larger).
            for k in 1..3 {
                let (a, c) = (p[k] - p[k - 1], p[k + 1] - p[k]);
                let rest = (b.rest[k] - b.rest[k - 1]).angle_between(b.rest[k + 1] - b.rest[k]);
                let max = MAX_JOINT_DEG.to_radians().max(rest);
                let angle = a.angle_between(c);
                if angle > max && a.length() > 0.0 && c.length() > 0.0 {
                    let axis = a.cross(c).try_normalize().unwrap_or_else(|| a.any_orthonormal_vector());
                    let dir = DQuat::from_axis_angle(axis, max) * a.normalize();
                    p[k + 1] = p[k] + dir * b.lengths[k];
                }
            }
            self.points[i] = p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::samples::{chain, small_tree as tree};
    use super::*;

    #[test]
    fn property_20_zero_wind_is_the_rest_pose_exactly() {
        let mut rig = tree();
        let calm = WindOptions::calm();
        for _ in 0..10_000 {
            rig.step(&calm, 1.0 / 30.0, DVec2::ZERO);
        }
        for (p, b) in rig.points.iter().zip(&rig.branches) {
            assert_eq!(*p, b.rest);
        }
    }

    #[test]
    fn property_21_storm_keeps_the_spacing() {
        let mut rig = tree();
        let storm = WindOptions::preset("storm").unwrap();
        let mut moved = 0.0f64;
        for _ in 0..10_000 {
            rig.step(&storm, 1.0 / 30.0, DVec2::ZERO);
        }
        for (p, b) in rig.points.iter().zip(&rig.branches) {
            for k in 1..4 {
                assert!(((p[k] - p[k - 1]).length() - b.lengths[k - 1]).abs() < 1e-5);
            }
            moved = moved.max((p[3] - b.rest[3]).length());
            assert!(p.iter().all(|x| x.is_finite()));
        }
        assert!(moved > 0.01, "the storm moves the tips ({moved})");
    }

    #[test]
    fn property_22_force_ignores_height_and_weights_grow_to_the_tip() {
        let w = WindOptions::preset("breeze").unwrap();
        // The force is a function of (x, z, t) alone: the API takes no height, and the
        // rig samples it at P₃ (the tip), checked through a rig whose tip alone is moved.
        assert_eq!(w.force(1.0, 2.0, 0.5), w.force(1.0, 2.0, 0.5));
        assert_ne!(w.force(1.0, 2.0, 0.5), w.force(4.0, 2.0, 0.5));
        assert_eq!(w.weight(0), 0.0);
        assert!((0..3).all(|k| w.weight(k) <= w.weight(k + 1)));
        assert_eq!(w.weight(3), 1.0);
        // A branch lifted by 10 m (same x, z) feels the same first step.
        let mut a = chain(1);
        let mut b = chain(1);
        for p in b.points[0].iter_mut().chain(b.branches[0].rest.iter_mut()) {
            p.y += 10.0;
        }
        a.step(&w, 0.1, DVec2::ZERO);
        b.step(&w, 0.1, DVec2::ZERO);
        for k in 0..4 {
            let (da, db) = (a.points[0][k] - a.branches[0].rest[k], b.points[0][k] - b.branches[0].rest[k]);
            assert!((da - db).length() < 1e-9, "{da} {db}");
        }
    }

    #[test]
    fn property_23_no_lag_moves_every_level_in_the_same_step_legacy_k_steps_later() {
        let still = WindOptions::calm();
        let push = DVec2::new(0.5, 0.0);
        for (legacy, expect) in [(false, [1, 1, 1, 1]), (true, [1, 2, 3, 4])] {
            let mut rig = chain(4);
            let wind = WindOptions { legacy_lag: legacy, ..still.clone() };
            let depth: Vec<u32> = rig.branches.iter().map(|b| b.depth).collect();
            assert_eq!(depth, vec![0, 1, 2, 3]);
            // The first step at which each level's tip leaves its rest position.
            let mut first = [0usize; 4];
            for step in 1..=6 {
                rig.step(&wind, 0.1, if step == 1 { push } else { DVec2::ZERO });
                for (k, f) in first.iter_mut().enumerate() {
                    if *f == 0 && rig.points[k][3] != rig.branches[k].rest[3] {
                        *f = step;
                    }
                }
            }
            assert_eq!(first, expect, "legacy_lag = {legacy}");
        }
    }

    #[test]
    fn property_24_each_child_starts_on_its_parents_animated_curve() {
        let mut rig = tree();
        let storm = WindOptions::preset("storm").unwrap();
        for _ in 0..200 {
            rig.step(&storm, 1.0 / 30.0, DVec2::ZERO);
            for (i, b) in rig.branches.iter().enumerate() {
                if let Some(p) = b.parent {
                    let on = bezier(&rig.points[p], b.attach);
                    assert!((rig.points[i][0] - on).length() < 1e-9);
                }
            }
        }
        // Every branch but the root hangs on another, across axes too.
        assert_eq!(rig.branches.iter().filter(|b| b.parent.is_none()).count(), 1);
        assert_eq!(rig.branches.len(), 7, "three trunk segments and two two-segment sides");
    }

    #[test]
    fn joint_angles_stay_below_the_limit() {
        let mut rig = tree();
        let storm = WindOptions { beta: 1.0, ..WindOptions::blowing(3.0, 2.0, 30.0) };
        for _ in 0..300 {
            rig.step(&storm, 1.0 / 30.0, DVec2::ZERO);
        }
        for p in &rig.points {
            for k in 1..3 {
                let angle = (p[k] - p[k - 1]).angle_between(p[k + 1] - p[k]).to_degrees();
                assert!(angle <= MAX_JOINT_DEG + 1e-6, "{angle}");
            }
        }
    }
}
