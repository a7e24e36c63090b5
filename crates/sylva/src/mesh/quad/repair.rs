//! The quad mesher's repair (beyond the seed): nodes whose boxes or bands intersect are
//! rebuilt with longer boxes, then detached, within a work budget (Skjermo2008-spec §2;
//! `docs/meshers.md`, "quad", "Repair").

use super::Repairs;
use crate::geometry::Mesh;
use crate::geometry::NONE;
use crate::skeleton::{Skeleton, NO_PARENT};
use rayon::prelude::*;

/// One repair round (see the module docs, "Repair"): refines `mesh` `levels` times with
/// Catmull–Clark, searches the refined faces of each branching node's neighbourhood —
/// the faces made for the node, its children and its grandchildren — for crossings, and
/// records in `repairs` what to change. Returns whether anything changed and the work
/// spent (the refined triangles grouped plus [`crate::mesh::check`]'s search units), or
/// `None` when that is more than `max_work`. After the first round only the junctions
/// that crossed and those a change can have moved are searched again (see the end of
/// this function).
pub(super) fn repair(
    sk: &Skeleton,
    mesh: &Mesh,
    owner: &[u32],
    lead: &[u32],
    levels: u32,
    repairs: &mut Repairs,
    max_work: u64,
) -> Option<(bool, u64)> {
    use crate::mesh::check::group_crossings_within;
    use crate::refine::{subdivide_traced, RefineOptions, Scheme, SubdivideOptions};
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::CatmullClark, levels, ..Default::default() },
        ..Default::default()
    };
    // The refinement itself: one unit per refined face, checked before it is made.
    let refined = (mesh.face_count() as u64).saturating_mul(4u64.pow(levels));
    if refined > max_work {
        return None;
    }
    let Ok((fine, up)) = subdivide_traced(mesh, &[], &opts) else { return Some((false, refined)) };
    let parent = |o: u32| if o == NONE { NONE } else { sk.parent[o as usize] };
    let branching = |j: u32| j != NONE && lead[j as usize] != NONE;
    // The junctions each control face is searched with: its node's, its parent's and its
    // grandparent's, where that node branches (and, after the first round, is due).
    let due = |j: u32| branching(j) && (repairs.dirty.is_empty() || repairs.dirty[j as usize]);
    let keys: Vec<[u32; 3]> = (0..mesh.face_count())
        .into_par_iter()
        .map(|f| {
            let o = owner[f];
            let (p, g) = (parent(o), parent(parent(o)));
            [o, p, g].map(|j| if due(j) { j } else { NONE })
        })
        .collect();
    let mut tris: Vec<(u32, [u32; 3], u32)> = Vec::with_capacity(fine.face_count() * 3);
    for f in 0..fine.face_count() {
        let v = fine.face(f);
        for key in keys[up[f] as usize] {
            if key != NONE {
                tris.push((key, [v[0], v[1], v[2]], f as u32));
                tris.push((key, [v[0], v[2], v[3]], f as u32));
            }
        }
    }
    // The child of `j` on the way to `o` (`None` for `j` itself).
    let path = |o: u32, j: u32| {
        if o == j {
            None
        } else if parent(o) == j {
            Some(o)
        } else {
            Some(parent(o))
        }
    };
    let mut touched: Vec<u32> = Vec::new();
    let (crossings, searched) = group_crossings_within(&fine.positions, tris, 64, max_work - refined)?;
    // Next round: the junctions that crossed (they may hold more than the pairs listed)
    // and those whose searched faces a change can have moved.
    let mut dirty = vec![false; sk.len()];
    for (j, fa, fb) in crossings {
        dirty[j as usize] = true;
        let (oa, ob) = (owner[up[fa as usize] as usize], owner[up[fb as usize] as usize]);
        let (ca, cb) = (path(oa, j), path(ob, j));
        if let Some(c) = ca.filter(|_| ca == cb) {
            // Inside one child's subtree: its own junction's business, unless the child's
            // own faces (its first tube, its elbow) fold and it has no junction (or one
            // already unboxed).
            let boxed = branching(c) && !repairs.unboxed[c as usize];
            if oa != c || ob != c || boxed || c == lead[j as usize] {
                continue;
            }
        }
        // The thinner side child is separated (the other one when that one already is);
        // when both are, a grandchild on the way that is a side child of its own parent.
        let thinner = |v: &mut Vec<u32>| {
            v.sort_by(|&a, &b| sk.radius[a as usize].total_cmp(&sk.radius[b as usize]).then(b.cmp(&a)))
        };
        let mut side: Vec<u32> = [ca, cb].into_iter().flatten().filter(|&c| c != lead[j as usize]).collect();
        thinner(&mut side);
        let mut deeper: Vec<u32> = [oa, ob]
            .into_iter()
            .filter(|&o| o != j && parent(o) != j && lead[parent(o) as usize] != o)
            .collect();
        thinner(&mut deeper);
        let free = |c: &&u32| !repairs.separated[**c as usize];
        match side.iter().find(free).or_else(|| deeper.iter().find(free)) {
            Some(&c) => {
                repairs.separated[c as usize] = true;
                touched.push(c);
            }
            None if !side.is_empty() => {}
            None if !repairs.unboxed[j as usize] => {
                repairs.unboxed[j as usize] = true;
                touched.push(j);
            }
            None => {}
        }
    }
    // A change at junction `j` (a child separated, or `j` unboxed) rebuilds `j`'s box,
    // which turns to its remaining side children, and sections carry their up vector
    // down the tree: everything below `j` may move. `j`, the two junctions above it
    // (which search `j`'s faces) and `j`'s whole subtree are searched again (parents
    // precede children, so one pass marks the subtrees).
    let mut below = vec![false; sk.len()];
    for &t in &touched {
        let j = if repairs.unboxed[t as usize] { t } else { parent(t) };
        below[j as usize] = true;
        for k in [parent(j), parent(parent(j))] {
            if k != NONE {
                dirty[k as usize] = true;
            }
        }
    }
    for c in 0..sk.len() {
        let p = sk.parent[c];
        below[c] |= p != NO_PARENT && below[p as usize];
        dirty[c] |= below[c];
    }
    repairs.dirty = dirty;
    Some((!touched.is_empty(), refined + searched))
}
