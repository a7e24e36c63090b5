//! Joints: the convex hull of the loops meeting at a node, centrally projected onto the
//! unit sphere, caps removed and mapped back to the loop vertices (Pieterse2012 §4.2.3,
//! Algorithms 3–4; Pieterse2012-spec §2.6), a root's virtual base loop, and sliver flips.

use super::convex;
use super::{Geo, LoopRef};
use crate::skeleton::Skeleton;
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::f64::consts::TAU;

/// A virtual base loop for root node `j` whose stems (`loops`, all starting there) leave
/// within 60° of their mean direction `m`: a ring of the root's radius at the node in
/// the plane normal to `m`, facing away from the stems (a zero-length tube pointing
/// down `−m`, closed at once by a fan facing `−m`). Beyond the seed: the hull of stem
/// loops that all lie in one narrow cone is a thin lens whose two faces cross after
/// the loops are moved back from the sphere (`mig-k`'s four stems 3°–8° apart); with
/// the base the joint is a dome over a flat base at the node, and the root stays
/// closed as before. `None` when the stems are not in such a cone, or when a stem's
/// loop dips below the base plane.
pub(super) fn root_base(sk: &Skeleton, j: usize, geo: &[Geo], loops: &[LoopRef]) -> Option<Geo> {
    if loops.len() < 2 || loops.iter().any(|l| l.at_end) {
        return None;
    }
    let m = loops.iter().map(|l| geo[l.slot as usize].d).sum::<DVec3>().normalize_or_zero();
    if m == DVec3::ZERO {
        return None;
    }
    let mut r = sk.radius[j] as f64;
    for l in loops {
        let g = &geo[l.slot as usize];
        let (c, rl) = g.end_loop(false);
        let cos = g.d.dot(m);
        // The loop's lowest point above the base plane, with a margin of its radius.
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        if cos < 0.5 || (c - g.start).dot(m) - rl * sin < 0.25 * rl {
            return None;
        }
        r = r.max(g.r0);
    }
    if !(r.is_finite() && r > 0.0) {
        return None;
    }
    let d = -m;
    let up = sk.up[j].as_dvec3();
    let u = up - d * up.dot(d);
    let u = if u.length_squared() > 1e-12 { u.normalize() } else { d.any_orthonormal_vector() };
    Some(Geo {
        node: j as u32,
        start: sk.position[j].as_dvec3(),
        d,
        r0: r,
        r1: r,
        u,
        w: d.cross(u),
        base: true,
        ..Geo::default()
    })
}

/// Builds a hull joint (Pieterse2012 §4.2.3; Pieterse2012-spec §2.6): loops centrally projected onto
/// the unit sphere about the joint node, hull, caps removed, checked. `None` when the
/// joint cannot be meshed this way.
pub(super) fn hull_joint(geo: &[Geo], loops: &[LoopRef], s: u32, eps: f64) -> Option<Vec<[(u32, u32); 3]>> {
    let mut caps = Vec::with_capacity(loops.len());
    for l in loops {
        let g = &geo[l.slot as usize];
        let (a, off) = if l.at_end { (-g.d, g.off_e) } else { (g.d, g.off_s) };
        let (_, r) = g.end_loop(l.at_end);
        caps.push(CapLoop { axis: a, radius: r, offset: off, u: g.u, w: g.w, at_end: l.at_end });
    }
    cap_hull(&caps, s, eps)
}

/// One loop of `s` vertices taking part in a [`cap_hull`] joint about a node `O`: its
/// vertex `j` lies at `O + offset·axis' + radius·(cos φⱼ u + sin φⱼ w)` with
/// `φⱼ = 2πj/s`, where `axis'` is `axis` for a loop that starts a tube and `−axis` is
/// its direction of travel for one that ends a tube (`at_end`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct CapLoop {
    /// Unit axis pointing away from the node.
    pub axis: DVec3,
    /// Loop radius.
    pub radius: f64,
    /// Distance of the loop's centre from the node along `axis` (0 allowed).
    pub offset: f64,
    /// First in-plane unit vector (vertex 0).
    pub u: DVec3,
    /// Second in-plane unit vector (vertex at a quarter turn).
    pub w: DVec3,
    /// The loop ends its tube (its tube uses the loop's edges `j+1 → j`, the joint
    /// `j → j+1`); otherwise it starts one (the joint uses `j+1 → j`).
    pub at_end: bool,
}

/// The convex-hull joint of Pieterse2012 §4.2.3 for any loops about one node, shared by the
/// hull and the sweep meshers: every loop vertex is centrally projected onto the unit
/// sphere (each loop a small circle about its axis, shrunk so that no two circles come
/// closer than 20 % of their axes' angle), the exact hull of [`convex`] is built, the
/// caps (faces with all three corners on one loop, `s − 2` each) are removed and the
/// rest is checked: every point on the hull, `k(s + 2) − 4` faces, each directed edge
/// once and every loop edge in the orientation its tube needs. Faces are
/// `(loop index, vertex index)` triples, counter-clockwise seen from outside. `None`
/// when two axes are within `eps` (`1 − cos`) of each other or a check fails.
pub(crate) fn cap_hull(loops: &[CapLoop], s: u32, eps: f64) -> Option<Vec<[(u32, u32); 3]>> {
    let k = loops.len();
    let su = s as usize;
    if k < 2 || s < 3 {
        return None;
    }
    // Outward axis and angular radius of the loop seen from O (central projection).
    let mut ax = Vec::with_capacity(k);
    let mut th = Vec::with_capacity(k);
    for l in loops {
        let t = l.radius.atan2(l.offset).min(1.3);
        if t.is_nan() || t <= 1e-9 || !l.axis.is_finite() {
            return None;
        }
        ax.push(l.axis);
        th.push(t);
    }
    for x in 0..k {
        for y in x + 1..k {
            if ax[x].dot(ax[y]) > 1.0 - eps {
                return None; // aligned (Pieterse2012 §4.1.3 case 3)
            }
        }
    }
    // Shrink circles so every loop is a clean cap: θi + θj ≤ 0.8·∠(ai, aj).
    let mut theta = th.clone();
    for x in 0..k {
        for y in 0..k {
            if x == y {
                continue;
            }
            let gamma = ax[x].dot(ax[y]).clamp(-1.0, 1.0).acos();
            let sum = th[x] + th[y];
            if sum > 0.8 * gamma {
                theta[x] = theta[x].min(th[x] * 0.8 * gamma / sum);
            }
        }
    }
    let mut pts = Vec::with_capacity(k * su);
    for (x, l) in loops.iter().enumerate() {
        let (st, ct) = theta[x].sin_cos();
        for j in 0..s {
            let ph = TAU * j as f64 / s as f64;
            pts.push(ax[x] * ct + (l.u * ph.cos() + l.w * ph.sin()) * st);
        }
    }
    let tris = convex::convex_hull(&pts).ok()?;
    // Every point on the hull (Pieterse2012-spec §2.6 step 4, property 13).
    let mut used = vec![false; pts.len()];
    for t in &tris {
        for &v in t {
            used[v as usize] = true;
        }
    }
    if used.iter().any(|u| !u) {
        return None;
    }
    // Remove the loop caps (step 5): s − 2 faces per loop.
    let mut caps = vec![0usize; k];
    let mut out = Vec::with_capacity(tris.len());
    for t in &tris {
        let l = t.map(|v| v / s);
        if l[0] == l[1] && l[1] == l[2] {
            caps[l[0] as usize] += 1;
        } else {
            out.push(t.map(|v| (v / s, v % s)));
        }
    }
    if caps.iter().any(|&c| c != su - 2) || out.len() != k * (su + 2) - 4 {
        return None;
    }
    // Each loop edge once, in the orientation that matches its tube.
    let mut directed = HashMap::with_capacity(out.len() * 3);
    for t in &out {
        for e in 0..3 {
            let (a, b) = (t[e], t[(e + 1) % 3]);
            if directed.insert((a.0 * s + a.1, b.0 * s + b.1), ()).is_some() {
                return None;
            }
        }
    }
    for (x, l) in loops.iter().enumerate() {
        let x = x as u32;
        for j in 0..s {
            let (p, q) = (x * s + j, x * s + (j + 1) % s);
            let want = if l.at_end { (p, q) } else { (q, p) };
            if !directed.contains_key(&want) {
                return None;
            }
        }
    }
    Some(out)
}

/// Twice the area and the longest edge's squared length of triangle `f`.
pub(super) fn tri_shape(f: [u32; 3], pos: &[Vec3]) -> (f64, f64) {
    let [a, b, c] = f.map(|v| pos[v as usize].as_dvec3());
    let area2 = (b - a).cross(c - a).length();
    let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
    (area2, longest)
}

/// True for a sliver by the mesh checker's rule ([`crate::tolerance::is_sliver`]).
pub(super) fn is_sliver(f: [u32; 3], pos: &[Vec3]) -> bool {
    let (area2, longest) = tri_shape(f, pos);
    crate::tolerance::is_sliver(0.5 * area2, longest)
}

/// Removes slivers from a joint's triangles by edge flips. A hull face on the sphere
/// can become a sliver when its vertices move back to their loops: on a planar tree
/// every loop has a vertex in the same plane, and the vertices of loops along one
/// straight axis end up collinear. For a sliver (a, b, c) with longest edge ab and c on
/// it, the joint face across ab, (b, a, d), is replaced together with it by (b, c, d) and
/// (c, a, d): the same surface, the orientation kept, ab gone. A flip is made only when
/// both new faces are proper (not slivers, facing like the old neighbour) and cd is not
/// already an edge; loop edges (one joint face) are never flipped. At most 4 flips per
/// face, so it always ends.
pub(super) fn flip_slivers(faces: &mut [[u32; 3]], pos: &[Vec3]) {
    let mut budget = 4 * faces.len();
    'outer: while budget > 0 {
        let mut edge: HashMap<(u32, u32), usize> = HashMap::with_capacity(faces.len() * 3);
        for (i, f) in faces.iter().enumerate() {
            for e in 0..3 {
                edge.insert((f[e], f[(e + 1) % 3]), i);
            }
        }
        for i in 0..faces.len() {
            if !is_sliver(faces[i], pos) {
                continue;
            }
            let f = faces[i];
            // Rotate so (a, b) is the longest edge.
            let len = |x: u32, y: u32| pos[x as usize].distance_squared(pos[y as usize]);
            let r = (0..3).max_by(|&x, &y| len(f[x], f[(x + 1) % 3]).total_cmp(&len(f[y], f[(y + 1) % 3])));
            let r = r.unwrap_or(0);
            let (a, b, c) = (f[r], f[(r + 1) % 3], f[(r + 2) % 3]);
            let Some(&g) = edge.get(&(b, a)) else { continue };
            let Some(d) = faces[g].into_iter().find(|&v| v != a && v != b) else { continue };
            if d == c || edge.contains_key(&(c, d)) || edge.contains_key(&(d, c)) {
                continue;
            }
            let (t1, t2) = ([b, c, d], [c, a, d]);
            let normal = |t: [u32; 3]| {
                let [p, q, s] = t.map(|v| pos[v as usize].as_dvec3());
                (q - p).cross(s - p)
            };
            let old = normal(faces[g]);
            if is_sliver(t1, pos)
                || is_sliver(t2, pos)
                || normal(t1).dot(old) <= 0.0
                || normal(t2).dot(old) <= 0.0
            {
                continue;
            }
            faces[i] = t1;
            faces[g] = t2;
            budget -= 1;
            continue 'outer;
        }
        break;
    }
}
