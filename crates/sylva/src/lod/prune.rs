//! The screen-size rule's pruning: lateral subtrees thinner than a radius are dropped
//! from the skeleton, and their organs move to the nearest node that stays, so the
//! leaves (and the crown's silhouette) stay where they were.

use crate::skeleton::{Skeleton, NO_PARENT};

/// A pruned skeleton and where its nodes came from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Pruned {
    /// The skeleton without the pruned subtrees (parent-first, re-indexed).
    pub skeleton: Skeleton,
    /// The original node of each kept node (`original[new] = old`).
    pub original: Vec<u32>,
}

/// The continuation of each node: among its children of its own branch order the
/// thickest (the first on ties), `NO_PARENT` where there is none. Every other child
/// starts a lateral subtree.
fn continuations(sk: &Skeleton) -> Vec<u32> {
    let n = sk.len();
    let mut next = vec![NO_PARENT; n];
    for i in 0..n {
        let p = sk.parent[i];
        if p == NO_PARENT || p as usize >= i || sk.order[i] != sk.order[p as usize] {
            continue;
        }
        let c = &mut next[p as usize];
        if *c == NO_PARENT || sk.radius[i] > sk.radius[*c as usize] {
            *c = i as u32;
        }
    }
    next
}

/// Drops every lateral subtree (a child that does not continue its parent's axis, with
/// all its descendants) whose thickest node has a radius below `min_radius`; roots and
/// axis continuations always stay. Organs on dropped nodes move to the nearest kept
/// ancestor (their positions do not change); organs on no node keep `NO_PARENT`.
/// Kept nodes keep their explicit start radii ([`Skeleton::start_radius()`]).
/// `min_radius ≤ 0` (or NaN) keeps everything. O(nodes + organs).
pub fn prune(sk: &Skeleton, min_radius: f32) -> Pruned {
    let n = sk.len();
    let next = continuations(sk);
    // Thickest radius in each subtree (children come after their parents).
    let mut thickest = sk.radius.clone();
    for i in (0..n).rev() {
        let p = sk.parent[i];
        if p != NO_PARENT && (p as usize) < i {
            thickest[p as usize] = thickest[p as usize].max(thickest[i]);
        }
    }
    // The kept node standing for each node: itself, or its nearest kept ancestor.
    let mut stand = vec![NO_PARENT; n];
    let mut out = Pruned::default();
    for i in 0..n {
        let p = sk.parent[i];
        let parent_ok = p != NO_PARENT && (p as usize) < i;
        let keep = if !parent_ok {
            true
        } else {
            let ps = stand[p as usize];
            let parent_kept = ps != NO_PARENT && out.original[ps as usize] == p;
            let lateral = next[p as usize] != i as u32;
            parent_kept && !(lateral && thickest[i] < min_radius)
        };
        if keep {
            let parent = if parent_ok { stand[p as usize] } else { NO_PARENT };
            let k = out.skeleton.push(sk.position[i], sk.radius[i], parent, sk.up[i], sk.order[i]);
            out.skeleton.material[k as usize] = sk.material[i];
            if !sk.start_radius.is_empty() {
                // Kept nodes keep their parents, so each internode keeps its start radius.
                out.skeleton.set_start_radius(k as usize, sk.start_radius.get(i).copied().flatten());
            }
            out.original.push(i as u32);
            stand[i] = k;
        } else {
            stand[i] = stand[p as usize];
        }
    }
    out.skeleton.organs = sk
        .organs
        .iter()
        .map(|o| {
            let mut o = o.clone();
            if let Some(&s) = stand.get(o.node as usize) {
                o.node = s;
            }
            o
        })
        .collect();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::{Organ, OrganKind};
    use glam::Vec3;

    /// A trunk 0-1-2 with a thin lateral 3-4 off node 1 and a thick lateral 5 off 1.
    fn tree() -> Skeleton {
        let mut s = Skeleton::new();
        let a = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
        let b = s.push(Vec3::Y, 0.15, a, Vec3::X, 0);
        s.push(Vec3::Y * 2.0, 0.1, b, Vec3::X, 0);
        let d = s.push(Vec3::new(0.5, 1.5, 0.0), 0.01, b, Vec3::X, 1);
        s.push(Vec3::new(1.0, 1.8, 0.0), 0.005, d, Vec3::X, 1);
        s.push(Vec3::new(-0.5, 1.5, 0.0), 0.05, b, Vec3::X, 1);
        let leaf = |node: u32| Organ {
            kind: OrganKind::Leaf,
            node,
            position: Vec3::new(1.0, 1.8, 0.0),
            heading: Vec3::Y,
            up: Vec3::Z,
            size: 0.1,
            material: 0,
        };
        s.organs = vec![leaf(4), leaf(2), leaf(NO_PARENT)];
        s
    }

    #[test]
    fn thin_laterals_go_and_their_leaves_move_down() {
        let p = prune(&tree(), 0.02);
        p.skeleton.validate().unwrap();
        assert_eq!(p.original, vec![0, 1, 2, 5]);
        assert_eq!(p.skeleton.parent, vec![NO_PARENT, 0, 1, 1]);
        // The leaf of node 4 hangs on node 1 now, at the same place.
        assert_eq!(p.skeleton.organs[0].node, 1);
        assert_eq!(p.skeleton.organs[0].position, Vec3::new(1.0, 1.8, 0.0));
        assert_eq!(p.skeleton.organs[1].node, 2);
        assert_eq!(p.skeleton.organs[2].node, NO_PARENT);
        // The trunk's thin tip stays: it continues the axis.
        let all = prune(&tree(), 1.0);
        assert_eq!(all.original, vec![0, 1, 2]);
        assert_eq!(prune(&tree(), 0.0).skeleton, tree());
    }

    /// Issue 26: the explicit start radii of the kept internodes survive pruning.
    #[test]
    fn start_radii_are_carried_over() {
        let mut s = tree();
        s.set_start_radius(2, Some(0.12));
        s.set_start_radius(4, Some(0.008));
        s.set_start_radius(5, Some(0.07));
        let p = prune(&s, 0.02);
        p.skeleton.validate().unwrap();
        assert_eq!(p.original, vec![0, 1, 2, 5]);
        assert_eq!(p.skeleton.start_radius, vec![None, None, Some(0.12), Some(0.07)]);
        assert_eq!(p.skeleton.start_radius(3), Some(0.07));
        assert_eq!(prune(&s, 0.0).skeleton, s);
    }
}
