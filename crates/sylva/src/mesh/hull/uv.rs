//! UVs of hull joint faces: each face unfolds its third corner from a neighbour across
//! its longest edge that has UVs (Pieterse2012 §4.3.3; Pieterse2012-spec §2.7).

use super::{Emit, Geo, LoopRef};
use glam::{DVec2, DVec3, Vec2};
use std::collections::HashMap;

/// UV corners for a hull joint's faces by propagation (Pieterse2012 §4.3.3): each face takes
/// its neighbour across its longest edge that has UVs (branch faces always do), copies
/// the two shared corners and unfolds the third. New UV values are appended to `e`.
pub(super) fn joint_uvs(
    e: &mut Emit,
    geo: &[Geo],
    loops: &[LoopRef],
    faces: &[[u32; 3]],
    s: u32,
) -> Vec<[u32; 3]> {
    // Directed edges as the branch faces use them → their UV indices.
    let mut branch_edge: HashMap<(u32, u32), (u32, u32)> = HashMap::new();
    for l in loops {
        let g = &geo[l.slot as usize];
        for j in 0..s {
            let (vj, vn) = (g.loop_vertex(l.at_end, j, s), g.loop_vertex(l.at_end, (j + 1) % s, s));
            let (uj, un) = (g.loop_uv(l.at_end, j, s), g.loop_uv(l.at_end, j + 1, s));
            if l.at_end {
                branch_edge.insert((vn, vj), (un, uj));
            } else {
                branch_edge.insert((vj, vn), (uj, un));
            }
        }
    }
    let mut joint_edge: HashMap<(u32, u32), (usize, usize)> = HashMap::new();
    for (f, t) in faces.iter().enumerate() {
        for k in 0..3 {
            joint_edge.insert((t[k], t[(k + 1) % 3]), (f, k));
        }
    }
    let pos = |v: u32| e.positions[v as usize].as_dvec3();
    let mut done: Vec<Option<[u32; 3]>> = vec![None; faces.len()];
    loop {
        let mut progress = false;
        for f in 0..faces.len() {
            if done[f].is_some() {
                continue;
            }
            let t = faces[f];
            let mut order = [0usize, 1, 2];
            let len = |k: usize| pos(t[k]).distance_squared(pos(t[(k + 1) % 3]));
            order.sort_by(|&x, &y| len(y).total_cmp(&len(x)).then(x.cmp(&y)));
            for k in order {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let shared = if let Some(&(ub, ua)) = branch_edge.get(&(b, a)) {
                    Some((ua, ub))
                } else if let Some(&(g, gk)) = joint_edge.get(&(b, a)) {
                    // Face g has edge b→a at corner gk: b at gk, a at gk + 1.
                    done[g].map(|uv| (uv[(gk + 1) % 3], uv[gk]))
                } else {
                    None
                };
                let Some((ua, ub)) = shared else { continue };
                let c = t[(k + 2) % 3];
                let uc = unfold(pos(a), pos(b), pos(c), e.uvs[ua as usize], e.uvs[ub as usize]);
                let ic = e.uvs.len() as u32;
                e.uvs.push(uc);
                let mut uv = [0u32; 3];
                uv[k] = ua;
                uv[(k + 1) % 3] = ub;
                uv[(k + 2) % 3] = ic;
                done[f] = Some(uv);
                progress = true;
                break;
            }
        }
        if !progress {
            break;
        }
    }
    // Unreachable faces (none for a connected joint): a degenerate UV triangle.
    done.into_iter()
        .map(|d| {
            d.unwrap_or_else(|| {
                let i = e.uvs.len() as u32;
                e.uvs.push(Vec2::ZERO);
                [i, i, i]
            })
        })
        .collect()
}

/// The UV of `c` when triangle `(a, b, c)` is unfolded onto the edge `ua → ub`:
/// the same edge parameter and relative height, counter-clockwise in UV.
pub(super) fn unfold(a: DVec3, b: DVec3, c: DVec3, ua: Vec2, ub: Vec2) -> Vec2 {
    let e = b - a;
    let l2 = e.length_squared();
    if l2.is_nan() || l2 <= 1e-300 {
        return ua;
    }
    let t = (c - a).dot(e) / l2;
    let h = ((c - a) - e * t).length() / l2.sqrt();
    let (ua, ub) = (ua.as_dvec2(), ub.as_dvec2());
    let ed = ub - ua;
    let perp = DVec2::new(-ed.y, ed.x);
    let r = ua + ed * t + perp * h;
    if r.is_finite() {
        r.as_vec2()
    } else {
        ua.as_vec2()
    }
}
