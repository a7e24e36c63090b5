//! The last resorts after the rounds: pulling colliding tips back along their
//! internode, and bending and extending short stubs.

use super::detect::{capsule, capsule_box, collide, gap, Bvh, Capsule, Topology};
use super::motion::{apply, capsule_hits, move_organs, subtree_hits, Motion};
use super::Work;
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DQuat, DVec3};
use std::ops::ControlFlow;

/// Lengths (fractions of the internode) a colliding tip internode is shortened to,
/// mildest first.
const RETRACT: [f64; 5] = [0.9, 0.8, 0.7, 0.6, 0.5];

/// The two last resorts after the rounds, tried in this order.
#[derive(Debug, Clone, Copy)]
pub(super) enum Resort {
    /// Pull colliding tips back ([`retract_tip`]).
    RetractTips,
    /// Lengthen or bend short stubs ([`extend_stub`]).
    ExtendStubs,
}

impl Resort {
    /// Runs the resort on each pair of `pairs` that still collides (an earlier move may
    /// have cleared it), until the work budget runs out. Returns the pairs it changed:
    /// tips pulled back, or stubs moved and internodes bent.
    pub(super) fn run(
        self,
        s: &mut Skeleton,
        topo: &Topology,
        pairs: &[[usize; 2]],
        clearance: f64,
        work: &Work,
    ) -> usize {
        let mut cx = Ctx { topo, clearance, work, bvh: Bvh::build(s, clearance) };
        let mut moved = 0;
        for &[a, b] in pairs {
            if work.over() {
                break;
            }
            if !collide(s, topo, (a, &capsule(s, a)), (b, &capsule(s, b)), clearance) {
                continue;
            }
            let step = match self {
                Resort::RetractTips => retract_tip(s, &mut cx, [a, b]),
                Resort::ExtendStubs => extend_stub(s, &mut cx, [a, b]),
            };
            match step {
                ControlFlow::Continue(true) => moved += 1,
                ControlFlow::Continue(false) => {}
                ControlFlow::Break(()) => break,
            }
        }
        moved
    }
}

/// What a resort works with: the skeleton's topology, the clearance, the work budget
/// and the capsule tree, kept up to date with every move.
struct Ctx<'a> {
    topo: &'a Topology,
    clearance: f64,
    work: &'a Work,
    bvh: Bvh,
}

/// The last resort for what rotation left: a pair where one internode ends at a tip
/// (a node without children) is cleared by pulling that tip back along its internode,
/// by the mildest of [`RETRACT`] that leaves it with no collision (the shorter change
/// of the two when both are tips). This is what frees a closed figure such as the Koch
/// snowflake, whose last internode ends on its first and has no joint to rotate about.
/// Says whether it pulled a tip back (`Break` when the work budget ran out).
fn retract_tip(s: &mut Skeleton, cx: &mut Ctx, [a, b]: [usize; 2]) -> ControlFlow<(), bool> {
    let Ctx { topo, clearance, work, .. } = *cx;
    let mut best: Option<(usize, usize, DVec3)> = None; // (step, tip, new position)
    for x in [a, b] {
        if topo.child_count[x] != 0 {
            continue;
        }
        let base = s.position[s.parent[x] as usize].as_dvec3();
        let tip = s.position[x].as_dvec3();
        for (k, &f) in RETRACT.iter().enumerate() {
            if best.is_some_and(|(bk, ..)| bk <= k) {
                break;
            }
            let cm = Capsule { a: base, b: base + (tip - base) * f, r: capsule(s, x).r };
            let mut examined = 0u64;
            let hits =
                capsule_hits(s, topo, &cx.bvh, x, (x, &cm), clearance, 1, (&mut examined, work.left()));
            work.charge_u64(examined.saturating_add(1));
            if work.over() {
                return ControlFlow::Break(());
            }
            if hits == 0 {
                best = Some((k, x, cm.b));
                break;
            }
        }
    }
    let Some((_, x, to)) = best else { return ControlFlow::Continue(false) };
    let delta = (to - s.position[x].as_dvec3()).as_vec3();
    s.position[x] = to.as_vec3();
    move_organs(s, topo, x, |p| p + delta, |d| d);
    cx.bvh.update(x, capsule_box(&capsule(s, x), clearance));
    ControlFlow::Continue(true)
}

/// Moves tried by the stub resort (lengthening or bending a stub, bending a longer
/// internode), in clearance distances `(r_a + r_b)(1 + clearance)`, mildest first.
const EXTEND: [f64; 4] = [0.5, 1.0, 2.0, 3.0];

/// The largest bend, in degrees, a sideways move gives an internode that is no stub
/// (session 12: `wp-weeping-willow`'s limb whose joint sits against its clone trunk).
pub(super) const BEND_MAX_DEG: f64 = 20.0;

/// Internodes tried by the stub resort on each side of a pair: its own, and up to
/// `STUB_HOPS - 1` above it towards the other.
const STUB_HOPS: usize = 3;

/// The last resort for a stub: a pair left where one of its internodes, or one of
/// those joining them in the tree ([`STUB_HOPS`] per side, its own included), is
/// shorter than twice the pair's clearance distance `(r_a + r_b)(1 + clearance)` and
/// carries a subtree with one of the two in it (or is one of the two, a tip), is
/// cleared by moving that subtree by the mildest of [`EXTEND`] (times that distance)
/// that leaves it with no collision: along the stub (lengthening it), or else away
/// from the other internode (bending it). Rotation cannot free such a stub, whose far
/// end stays within its own length of the joint where its sibling starts, and thinning
/// cannot either once both are at the radius floor (Weber–Penn stems whose first
/// internode is a few millimetres long: `wp-sassafras` kept 6 such pairs,
/// `wp-european-larch` 23). A longer internode among those candidates is bent away
/// the same way, by steps that turn it by at most [`BEND_MAX_DEG`]; at one step stubs
/// come first, then the lightest subtree (see [`stub_motions`]). Moves ignore
/// [`DecollideOptions::max_moved`]: they are translations of a few radii, which keep a
/// subtree's shape. Says whether it moved a stub or bent an internode (`Break` when the work budget ran out).
fn extend_stub(s: &mut Skeleton, cx: &mut Ctx, [a, b]: [usize; 2]) -> ControlFlow<(), bool> {
    let Ctx { topo, clearance, work, .. } = *cx;
    // Mildest step first; at one step, stubs (in the order tried), then the bends
    // of the lightest subtrees.
    let mut best: Option<((usize, usize), usize, Motion)> = None; // (rank, stub, motion)
    for (k, x, mv, weight) in stub_motions(s, topo, [a, b], clearance) {
        if best.is_some_and(|(bk, ..)| bk <= (k, weight)) {
            continue;
        }
        let (hits, examined) = subtree_hits(s, topo, &cx.bvh, x, &mv, clearance, 1, work.left());
        work.charge_u64(examined.saturating_add(topo.size(x) as u64));
        if work.over() {
            return ControlFlow::Break(());
        }
        if hits == 0 {
            best = Some(((k, weight), x, mv));
        }
    }
    let Some((_, x, mv)) = best else { return ControlFlow::Continue(false) };
    apply(s, topo, &mut cx.bvh, x, &mv, clearance);
    ControlFlow::Continue(true)
}

/// The stub motions [`extend_stub`] tries for the pair `a`, `b`, as (step in
/// [`EXTEND`], stub, motion, weight), in the order tried: for the pair's own internodes
/// and those joining them ([`STUB_HOPS`] per side) whose subtree carries one of
/// the two but not the other (a tip among them too: its end moves), each step moves the
/// internode's subtree along it, then away from the other internode, when it is
/// shorter than twice the pair's clearance distance (a stub; weight 0); a longer one
/// only away, while that bends it by at most [`BEND_MAX_DEG`] (weight: 1 + the nodes
/// it moves, so the lighter side bends first).
pub(super) fn stub_motions(
    s: &Skeleton,
    topo: &Topology,
    [a, b]: [usize; 2],
    clearance: f64,
) -> Vec<(usize, usize, Motion, usize)> {
    let (ca, cb) = (capsule(s, a), capsule(s, b));
    let reach = (ca.r + cb.r) * (1.0 + clearance);
    // From b's closest point towards a's.
    let apart = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY).map_or(DVec3::ZERO, |(_, pa, pb)| pa - pb);
    let mut cands = Vec::new();
    for (start, other) in [(a, b), (b, a)] {
        let mut x = start;
        for _ in 0..STUB_HOPS {
            if s.parent[x] == NO_PARENT || topo.contains(x, other) {
                break;
            }
            cands.push(x);
            x = s.parent[x] as usize;
        }
    }
    let mut out = Vec::new();
    let max_bend = BEND_MAX_DEG.to_radians().tan();
    for x in cands {
        let base = s.position[s.parent[x] as usize].as_dvec3();
        let axis = s.position[x].as_dvec3() - base;
        let len = axis.length();
        if len.is_nan() || len <= 0.0 {
            continue;
        }
        let stub = len < 2.0 * reach;
        // Along the stub, or (a stub aligned with the other, which no lengthening
        // frees) away from the other internode; a longer internode only bends away,
        // by at most `BEND_MAX_DEG`.
        let along = axis / len;
        let away = if topo.contains(x, a) { apart } else { -apart };
        let away = away - along * away.dot(along);
        let away = if away.length() > 1e-9 * len { away.normalize() } else { along.any_orthonormal_vector() };
        let weight = if stub { 0 } else { 1 + topo.size(x) };
        let shift = |dir: DVec3| Motion { pivot: base, rot: DQuat::IDENTITY, shift: dir };
        for (k, &e) in EXTEND.iter().enumerate() {
            if stub {
                out.push((k, x, shift(along * (e * reach)), weight));
            } else if e * reach > len * max_bend {
                break;
            }
            out.push((k, x, shift(away * (e * reach)), weight));
        }
    }
    out
}
