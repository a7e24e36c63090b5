//! cpfg's tropisms (issue 46): how cpfg 6.6 bends the turtle for a view file's
//! `tropism:` / `torque:` lines and for its old single tropism (`tropism direction:`,
//! `initial elasticity:`, `elasticity increment:`), learnt from its source
//! (AlgorithmicBotany/vlab `cpfg/movements.c`, `interpret.c`, `turtle.c`; Mech2004 for
//! the view-file syntax). They differ from ABOP §2.2's single rule in three ways:
//!
//! - the `tropism:`/`torque:` lines act **before** each `F`, `G`, `f` and `g`, all
//!   together: with V = Σ eᵢ cos γᵢ Tᵢ (+ for γᵢ ≠ 0 the term eᵢ sin γᵢ Tᵢ × (H × Tᵢ) /
//!   ‖H × Tᵢ‖), the heading turns toward V by the angle min(‖H × V‖, 1) about H × V, and
//!   the up vector is then the one before the last `F` carried by the smallest rotation
//!   from that `F`'s heading to the new one; torques turn U about U × D by
//!   −min(‖U × D‖, 1), D the projection of their summed direction perpendicular to H
//!   (× ‖Σ eᵢ Tᵢ‖), as cpfg's quaternion code does;
//! - the old tropism acts **after** each move: with s = e (T · U) the heading turns toward
//!   U by asin s, then with s = e (T · L) toward L (cpfg's own `bend`, not normalised, and
//!   never clamped at the target);
//! - both act on `f`/`g` and on zero-length moves too.
//!
//! Directions here are in sylva's frame; the frame's U is minus cpfg's (cpfg's up is
//! −(H × L)), which the formulas below account for.

use glam::{DQuat, DVec3};

/// One `tropism:` or `torque:` line, ready for the turtle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Movement {
    /// `torque:` (turns U about H) rather than `tropism:` (turns H).
    pub torque: bool,
    /// T in sylva's frame, a unit vector times the intensity `I:` (clamped to ±1).
    pub direction: [f64; 3],
    /// γ (`A:`) in degrees: 0 bends toward T, 90 toward the plane perpendicular to T.
    pub angle: f64,
    /// The initial elasticity `E:`.
    pub elasticity: f64,
}

/// The old single tropism of `tropism direction:` (sylva's frame, unit),
/// `initial elasticity:` and `elasticity increment:` (what a bare `_` adds).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OldTropism {
    /// T, a unit vector in sylva's frame.
    pub direction: [f64; 3],
    /// The initial elasticity.
    pub elasticity: f64,
    /// What a bare `_` adds to the elasticity.
    pub increment: f64,
}

/// cpfg's tropisms of a model, as its view file gives them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CpfgTropisms {
    /// `tropism:` and `torque:` lines in file order (`@Ts(i, e)` sets the i-th
    /// elasticity, 1-based), at most [`super::MAX_TROPISMS`].
    pub movements: Vec<Movement>,
    /// The old single tropism, if the view file has one.
    pub old: Option<OldTropism>,
}

/// The turtle's frame as the movements need it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame {
    pub h: DVec3,
    pub l: DVec3,
    pub u: DVec3,
    /// The heading and up vector when the last `F`/`G` ended.
    pub prev_h: DVec3,
    pub prev_u: DVec3,
}

/// Rotates `v` about the unit `axis` by `angle` (right-handed).
fn rotate(v: DVec3, axis: DVec3, angle: f64) -> DVec3 {
    DQuat::from_axis_angle(axis, angle) * v
}

/// cpfg's `movement_adjust`, before each `F`, `G`, `f`, `g`: `e` are the current
/// elasticities of `movements`.
pub(super) fn before_move(f: &mut Frame, movements: &[Movement], e: &[f64]) {
    if movements.is_empty() {
        return;
    }
    let mut des = DVec3::ZERO;
    let mut twist = DVec3::ZERO;
    for (m, &e) in movements.iter().zip(e) {
        let t = DVec3::from_array(m.direction);
        if m.torque {
            twist += e * t;
            continue;
        }
        let (sin, cos) = m.angle.to_radians().sin_cos();
        des += cos * e * t;
        if sin != 0.0 {
            let (mut v, mut len) = (f.h.cross(t), f.h.cross(t).length());
            if len < 1e-7 {
                // H = T: rotate about L (cpfg's left is sylva's).
                v = f.l;
                len = 1.0;
            }
            des += (e * sin / len) * t.cross(v);
        }
    }
    let rot = f.h.cross(des);
    let len = rot.length();
    if len >= 1e-6 {
        f.h = rotate(f.h, rot / len, len.min(1.0));
        // cpfg's `adjust_up_and_left`: U follows the smallest rotation from the heading
        // the last `F` ended with.
        let r = f.h.cross(f.prev_h);
        let rl = r.length();
        if rl > 1e-6 {
            let mut angle = rl.min(1.0).asin();
            if f.h.dot(f.prev_h) < 0.0 {
                angle = std::f64::consts::PI - angle;
            }
            f.u = rotate(f.prev_u, -r / rl, angle);
        }
        f.l = f.u.cross(f.h);
    }
    if twist != DVec3::ZERO {
        let strength = twist.length();
        let dir = twist / strength;
        let v = f.h.cross(dir);
        if v.length_squared() > 1e-8 {
            // The twist direction projected on the plane perpendicular to H, scaled.
            let want = v.cross(f.h) * strength;
            // cpfg's `rotate_to_vector` on its up vector (minus sylva's): its quaternion
            // turns −U about −U × `want` by −min(‖−U × want‖, 1).
            let cu = -f.u;
            let axis = cu.cross(want);
            let al = axis.length();
            if al >= 1e-7 {
                f.u = -rotate(cu, axis / al, -al.min(1.0));
                f.l = f.u.cross(f.h);
            }
            f.prev_h = f.h;
            f.prev_u = f.u;
        }
    }
}

/// cpfg's `bend`, after each move, for the old tropism with elasticity `e` and unit
/// direction `t`.
pub(super) fn after_move(f: &mut Frame, t: DVec3, e: f64) {
    if e == 0.0 {
        return;
    }
    // cpfg's up vector is −U.
    let cu = -f.u;
    let s = (e * t.dot(cu)).clamp(-1.0, 1.0);
    let c = (1.0 - s * s).sqrt();
    let h1 = c * f.h + s * cu;
    let cu1 = c * cu - s * f.h;
    let s = (e * t.dot(f.l)).clamp(-1.0, 1.0);
    let c = (1.0 - s * s).sqrt();
    let h2 = c * h1 + s * f.l;
    let l1 = c * f.l - s * h1;
    f.h = h2;
    f.u = -cu1;
    f.l = l1;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(h: DVec3) -> Frame {
        let l = DVec3::Z;
        let u = h.cross(l).normalize();
        Frame { h, l, u, prev_h: h, prev_u: u }
    }

    #[test]
    fn a_tropism_turns_toward_its_direction_by_e_sin() {
        let tilt = 5f64.to_radians();
        let mut f = frame(DVec3::new(tilt.sin(), tilt.cos(), 0.0));
        let m = Movement { torque: false, direction: [0.0, 1.0, 0.0], angle: 0.0, elasticity: 0.2 };
        before_move(&mut f, &[m], &[0.2]);
        let now = f.h.x.atan2(f.h.y);
        assert!((now - (tilt - 0.2 * tilt.sin())).abs() < 1e-12, "{}", now.to_degrees());
    }

    #[test]
    fn the_old_tropism_bends_toward_up_then_left() {
        // Heading +Y, T = −U (cpfg's up): the heading turns by asin(e) toward −U.
        let mut f = frame(DVec3::Y);
        let t = -f.u;
        after_move(&mut f, t, 0.5);
        assert!((f.h.dot(t) - 0.5).abs() < 1e-12);
        assert!((f.h.length() - 1.0).abs() < 1e-12);
    }
}
