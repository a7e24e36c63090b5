//! Rigid motions of a subtree: where a moved node and its capsule land, the collisions a
//! moved subtree would have, and applying a motion to nodes, organs and the BVH.

use super::detect::{capsule, capsule_box, collide, Bvh, Capsule, Topology};
use crate::skeleton::{OrganKind, Skeleton};
use glam::{DQuat, DVec3, Vec3};

/// A rigid motion of a subtree: rotation by `rot` about `pivot` (the subtree's base
/// node, which stays put), then translation by `shift`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Motion {
    pub(super) pivot: DVec3,
    pub(super) rot: DQuat,
    pub(super) shift: DVec3,
}

impl Motion {
    pub(super) fn rotation(pivot: DVec3, rot: DQuat) -> Self {
        Motion { pivot, rot, shift: DVec3::ZERO }
    }
    pub(super) fn of(&self, s: &Skeleton, node: usize) -> DVec3 {
        self.point(s.position[node].as_dvec3())
    }
    fn point(&self, p: DVec3) -> DVec3 {
        self.pivot + self.shift + self.rot * (p - self.pivot)
    }
}

/// The capsule of internode `m` of the subtree at `c` once the subtree is moved by `mv`
/// (the subtree's base node, `mv.pivot`, stays put).
pub(super) fn moved_capsule(s: &Skeleton, c: usize, m: usize, mv: &Motion) -> Capsule {
    let pm = s.parent[m] as usize;
    Capsule {
        a: if m == c { mv.pivot } else { mv.of(s, pm) },
        b: mv.of(s, m),
        r: s.radius[m].max(s.radius[pm]) as f64,
    }
}

/// Collisions (at most `limit`) between the subtree at `c`, moved by `mv` (its base
/// node stays put), and every internode outside it, with the candidate pairs examined
/// (the search stops once they are over `pair_limit`).
#[allow(clippy::too_many_arguments)]
pub(super) fn subtree_hits(
    s: &Skeleton,
    topo: &Topology,
    bvh: &Bvh,
    c: usize,
    mv: &Motion,
    clearance: f64,
    limit: usize,
    pair_limit: u64,
) -> (usize, u64) {
    let (mut hits, mut examined) = (0, 0u64);
    for &m in topo.subtree(c) {
        let m = m as usize;
        let cm = moved_capsule(s, c, m, mv);
        hits += capsule_hits(s, topo, bvh, c, (m, &cm), clearance, limit - hits, (&mut examined, pair_limit));
        if hits >= limit || examined > pair_limit {
            break;
        }
    }
    (hits, examined)
}

/// Collisions (at most `limit`) of internode `m`, moved to the capsule `cm`, with every
/// internode outside the subtree at `c`. Candidate pairs examined are added to
/// `examined`; the query stops once they are over `pair_limit`.
#[allow(clippy::too_many_arguments)]
pub(super) fn capsule_hits(
    s: &Skeleton,
    topo: &Topology,
    bvh: &Bvh,
    c: usize,
    (m, cm): (usize, &Capsule),
    clearance: f64,
    limit: usize,
    (examined, pair_limit): (&mut u64, u64),
) -> usize {
    let mut hits = 0;
    bvh.visit(&capsule_box(cm, clearance), |j| {
        *examined += 1;
        if topo.contains(c, j) {
            return *examined <= pair_limit;
        }
        if collide(s, topo, (m, cm), (j, &capsule(s, j)), clearance) {
            hits += 1;
        }
        hits < limit && *examined <= pair_limit
    });
    hits
}

/// Moves the organs hanging on `node`: points (position, polygon outline) by `point`,
/// directions (heading, up) by `dir`.
pub(super) fn move_organs(
    s: &mut Skeleton,
    topo: &Topology,
    node: usize,
    point: impl Fn(Vec3) -> Vec3,
    dir: impl Fn(Vec3) -> Vec3,
) {
    for &k in &topo.organ_list[topo.organ_offsets[node] as usize..topo.organ_offsets[node + 1] as usize] {
        let org = &mut s.organs[k as usize];
        org.position = point(org.position);
        org.heading = dir(org.heading);
        org.up = dir(org.up);
        if let OrganKind::Polygon(vs) = &mut org.kind {
            for v in vs.iter_mut() {
                *v = point(*v);
            }
        }
    }
}

/// Moves the subtree at `c` by `mv` (positions, `up` vectors, organs) and updates the
/// BVH.
pub(super) fn apply(s: &mut Skeleton, topo: &Topology, bvh: &mut Bvh, c: usize, mv: &Motion, clearance: f64) {
    let rot_f = mv.rot.as_quat();
    for &m in topo.subtree(c) {
        let m = m as usize;
        s.position[m] = mv.of(s, m).as_vec3();
        let up = rot_f * s.up[m];
        if up.is_finite() {
            s.up[m] = up;
        }
        move_organs(s, topo, m, |p| mv.point(p.as_dvec3()).as_vec3(), |d| rot_f * d);
    }
    for &m in topo.subtree(c) {
        bvh.update(m as usize, capsule_box(&capsule(s, m as usize), clearance));
    }
}
