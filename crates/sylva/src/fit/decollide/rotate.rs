//! Rotation: moving the lighter subtree of a distant crossing rigidly about its base
//! joint by the smallest trial angle that clears it (or removes the most collisions),
//! and the trade of collisions between candidate subtrees.

use super::detect::{capsule, collide, collisions, gap, Bvh, Topology};
use super::motion::{apply, moved_capsule, subtree_hits, Motion};
use super::resort::stub_motions;
use super::{rounds, DecollideOptions, Work};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DQuat, DVec3};
use rayon::prelude::*;

/// A subtree rotation to try (about the subtree root's parent node).
#[derive(Clone, Copy)]
struct Trial {
    rot: DQuat,
}

/// Trials of one subtree evaluated together (in parallel); only those up to the first
/// that clears are charged, so the work counted does not depend on this.
const TRIAL_CHUNK: usize = 8;

/// Moves subtrees to separate the pairs that thinning left; returns rotations applied.
/// Also returns the work spent (capsule queries) against the round's bound
/// ([`DecollideOptions::work_per_node`]); the candidate pairs the queries examine are
/// charged to `global` directly, and the pass stops once that is over its budget.
pub(super) fn rotate_pairs(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    o: &DecollideOptions,
    global: &Work,
) -> (usize, usize) {
    let mut bvh = Bvh::build(s, o.clearance);
    let mut moved = 0;
    let (mut work, budget) = (0usize, o.work_per_node.saturating_mul(s.len()));
    // Lightest first: order the pairs by the smaller subtree either side could move.
    let mut queue: Vec<(usize, [usize; 2])> = pairs
        .iter()
        .map(|&[a, b]| {
            let w = joints_above(s, topo, a, 1)
                .into_iter()
                .chain(joints_above(s, topo, b, 1))
                .map(|c| topo.size(c))
                .min()
                .unwrap_or(usize::MAX);
            (w, [a, b])
        })
        .collect();
    queue.sort_unstable();
    for (_, [a, b]) in queue {
        if global.over() {
            break;
        }
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        let Some((d, pa, pb)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        if d >= (ca.r + cb.r) * (1.0 + o.clearance) {
            continue; // already separated by an earlier move
        }
        let cands = rotation_candidates(s, topo, [a, b], pa - pb, o);
        // Smallest clearing rotation of the lightest candidate that has one.
        let mut done = false;
        let mut tried: Vec<(usize, DVec3, usize, Vec<Trial>)> = Vec::new();
        for &(w, c, away) in &cands {
            if work > budget || global.over() {
                break;
            }
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            let (current, examined) = subtree_hits(
                s,
                topo,
                &bvh,
                c,
                &Motion::rotation(pivot, DQuat::IDENTITY),
                o.clearance,
                usize::MAX,
                global.left(),
            );
            work += w;
            global.charge_u64(examined.saturating_add(w as u64));
            if current == 0 || global.over() {
                continue;
            }
            let trials = trials_for(s, c, away, &o.angles);
            // The first trial that clears, in order (evaluated a chunk at a time); the
            // pairs of the trials up to it are charged.
            let (mut first, mut charged, left) = (None, 0u64, global.left());
            for (n, chunk) in trials.chunks(TRIAL_CHUNK).enumerate() {
                let limit = left - charged;
                let res: Vec<(usize, u64)> = chunk
                    .par_iter()
                    .map(|t| {
                        subtree_hits(s, topo, &bvh, c, &Motion::rotation(pivot, t.rot), o.clearance, 1, limit)
                    })
                    .collect();
                for (k, &(h, p)) in res.iter().enumerate() {
                    charged = charged.saturating_add(p);
                    if charged > left {
                        break;
                    }
                    if h == 0 {
                        first = Some(n * TRIAL_CHUNK + k);
                        break;
                    }
                }
                if first.is_some() || charged > left {
                    break;
                }
            }
            let trials_run = first.map_or(trials.len(), |k| k + 1);
            work += w * trials_run;
            global.charge_u64(charged.saturating_add((w * trials_run) as u64));
            if global.over() {
                break;
            }
            if let Some(k) = first {
                apply(s, topo, &mut bvh, c, &Motion::rotation(pivot, trials[k].rot), o.clearance);
                moved += 1;
                done = true;
                break;
            }
            tried.push((c, away, current, trials));
        }
        if done || work > budget || global.over() {
            continue;
        }
        // None clears: keep the trial that removes the most collisions (of the two
        // lightest candidates), so the total only ever falls.
        let mut best: Option<(usize, usize, DQuat)> = None; // (reduction, root, rotation)
        for (c, _, current, trials) in tried.into_iter().take(2) {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            let left = global.left();
            let res: Vec<(usize, u64)> = trials
                .par_iter()
                .map(|t| {
                    subtree_hits(
                        s,
                        topo,
                        &bvh,
                        c,
                        &Motion::rotation(pivot, t.rot),
                        o.clearance,
                        current,
                        left,
                    )
                })
                .collect();
            let hits: Vec<usize> = res.iter().map(|r| r.0).collect();
            work += topo.size(c) * trials.len();
            global.charge_u64(
                res.iter().fold((topo.size(c) * trials.len()) as u64, |a, r| a.saturating_add(r.1)),
            );
            if global.over() {
                break;
            }
            if let Some((k, &h)) = hits.iter().enumerate().min_by_key(|&(k, &h)| (h, k)) {
                if h < current && best.is_none_or(|(r, ..)| current - h > r) {
                    best = Some((current - h, c, trials[k].rot));
                }
            }
        }
        if let Some((_, c, rot)) = best {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            apply(s, topo, &mut bvh, c, &Motion::rotation(pivot, rot), o.clearance);
            moved += 1;
        }
    }
    (moved, work)
}

/// The subtrees that may be rotated to separate internodes `a` and `b` (`away` points
/// from `b`'s closest point to `a`'s), lightest first, as (size, root, direction away
/// from the other): the nearest joints above each internode that do not also carry the
/// other internode (moving both rigidly would not separate them), of at most
/// [`DecollideOptions::max_moved`] nodes.
fn rotation_candidates(
    s: &Skeleton,
    topo: &Topology,
    [a, b]: [usize; 2],
    away: DVec3,
    o: &DecollideOptions,
) -> Vec<(usize, usize, DVec3)> {
    let mut cands: Vec<(usize, usize, DVec3)> = Vec::new();
    for (x, y, away) in [(a, b, away), (b, a, -away)] {
        for c in joints_above(s, topo, x, o.candidates) {
            if !topo.contains(c, y) && !topo.contains(c, s.parent[y] as usize) {
                cands.push((topo.size(c), c, away));
            }
        }
    }
    cands.sort_unstable_by_key(|&(w, c, _)| (w, c));
    cands.dedup_by_key(|&mut (_, c, _)| c);
    cands.retain(|&(w, ..)| w <= o.max_moved);
    cands
}

/// Moves per pair [`trade`] follows up, fewest new collisions first.
const TRADE_TRIALS: usize = 4;

/// Rounds of thinning and rotation [`trade`] runs after each move.
const TRADE_ROUNDS: usize = 3;

/// A move [`trade`] follows up makes at most this many new collisions.
const TRADE_HITS: usize = 40;

/// The very last resort, for pairs every other step left (session 11:
/// `wp-ca-black-oak`'s trunk against a 3 k-node limb of its clone trunk, which every
/// rotation swings through 2–150 twigs of the dense crown; `wp-sassafras`'s stub whose
/// every lengthening meets a third internode). Of the moves the rounds and the stub
/// resort try (the rotations of the candidate subtrees, the stub motions), those that
/// clear the pair but make at most [`TRADE_HITS`] new collisions elsewhere are sorted
/// by how many; the first [`TRADE_TRIALS`] are applied in turn to a copy of the
/// skeleton, the normal rounds (thinning, rotation) run on the copy for at most
/// [`TRADE_ROUNDS`], and the first copy that ends with fewer collisions in the whole
/// skeleton than before is kept. Returns the pairs so traded, and adds the rotations
/// applied to `rotations`.
pub(super) fn trade(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    o: &DecollideOptions,
    rotations: &mut usize,
    work: &Work,
) -> usize {
    work.charge(s.len());
    let mut total = collisions(s, topo, o.clearance, work).len();
    let mut traded = 0;
    for &[a, b] in pairs {
        if work.over() {
            break;
        }
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        if total == 0 || !collide(s, topo, (a, &ca), (b, &cb), o.clearance) {
            continue;
        }
        let Some((_, pa, pb)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        let mut moves: Vec<(usize, Motion)> = Vec::new();
        for (_, c, away) in rotation_candidates(s, topo, [a, b], pa - pb, o) {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            moves.extend(
                trials_for(s, c, away, &o.angles).into_iter().map(|t| (c, Motion::rotation(pivot, t.rot))),
            );
        }
        moves.extend(stub_motions(s, topo, [a, b], o.clearance).into_iter().map(|(_, x, mv, _)| (x, mv)));
        let bvh = Bvh::build(s, o.clearance);
        work.charge(s.len() + moves.iter().map(|&(c, _)| topo.size(c)).sum::<usize>());
        let left = work.left();
        let res: Vec<(Option<(usize, usize)>, u64)> = moves
            .par_iter()
            .enumerate()
            .map(|(k, &(c, mv))| {
                // The one of the two that moves with `c`, against the other.
                let (mover, other) = if topo.contains(c, a) { (a, b) } else { (b, a) };
                let cm = moved_capsule(s, c, mover, &mv);
                if collide(s, topo, (mover, &cm), (other, &capsule(s, other)), o.clearance) {
                    return (None, 0);
                }
                let (hits, examined) = subtree_hits(s, topo, &bvh, c, &mv, o.clearance, TRADE_HITS + 1, left);
                ((hits <= TRADE_HITS).then_some((hits, k)), examined)
            })
            .collect();
        work.charge_u64(res.iter().fold(0u64, |a, r| a.saturating_add(r.1)));
        if work.over() {
            break;
        }
        let mut scored: Vec<(usize, usize)> = res.into_iter().filter_map(|r| r.0).collect();
        scored.sort_unstable();
        for &(_, k) in scored.iter().take(TRADE_TRIALS) {
            let (c, mv) = moves[k];
            if work.over() {
                break;
            }
            let mut copy = s.clone();
            let mut copy_bvh = Bvh::build(&copy, o.clearance);
            apply(&mut copy, topo, &mut copy_bvh, c, &mv, o.clearance);
            work.charge(2 * s.len());
            let moved =
                usize::from(mv.shift == DVec3::ZERO) + rounds(&mut copy, topo, o, TRADE_ROUNDS, work).1;
            work.charge(s.len());
            let n = collisions(&copy, topo, o.clearance, work).len();
            if work.over() {
                break;
            }
            if n < total {
                *s = copy;
                total = n;
                *rotations += moved;
                traded += 1;
                break;
            }
        }
    }
    traded
}

/// The first `k` joints at or above internode `x`: nodes `c` (with a parent) whose
/// parent has several children or starts a new branch order, nearest first.
fn joints_above(s: &Skeleton, topo: &Topology, x: usize, k: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut c = topo.joint_up[x];
    while c != NO_PARENT && out.len() < k {
        out.push(c as usize);
        c = topo.joint_up[s.parent[c as usize] as usize];
    }
    out
}

/// The rotations tried for the subtree at `c`, smallest angle first: about the axis
/// that swings it along `away` (in the plane of the two branches), the axis that swings
/// it out of that plane, and its parent's axis; both senses each.
fn trials_for(s: &Skeleton, c: usize, away: DVec3, angles: &[f64]) -> Vec<Trial> {
    let p = s.parent[c] as usize;
    let dir = (s.position[c].as_dvec3() - s.position[p].as_dvec3()).normalize_or_zero();
    let any_perp = |v: DVec3| {
        let t = if v.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        v.cross(t).normalize_or_zero()
    };
    let mut in_plane = dir.cross(away).normalize_or_zero();
    if in_plane == DVec3::ZERO {
        in_plane = any_perp(dir);
    }
    let out_of_plane = dir.cross(in_plane).normalize_or_zero();
    let parent_axis = match s.parent[p] {
        NO_PARENT => DVec3::ZERO,
        g => (s.position[p].as_dvec3() - s.position[g as usize].as_dvec3()).normalize_or_zero(),
    };
    let axes: Vec<DVec3> =
        [in_plane, out_of_plane, parent_axis].into_iter().filter(|a| a.length_squared() > 0.5).collect();
    let mut out = Vec::new();
    for &deg in angles {
        for &axis in &axes {
            for sign in [1.0, -1.0] {
                out.push(Trial { rot: DQuat::from_axis_angle(axis, sign * deg.to_radians()) });
            }
        }
    }
    out
}
