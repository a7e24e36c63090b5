//! The sweep mesher's mesh from a plan and the fallback set: rings, strips, junction
//! templates (coplanar, general, asymmetric), caps and tips (MacMurchy2004 §5.5.3, §A.3)
//! and UVs (§6.3, MacMurchy2004-spec §2.12).

use super::plan::{perpendicular, unit_or};
use super::{Kind, Plan, Ring, SweepOptions, SweepTips, UMapping, SIDES};
use crate::geometry::NONE;
use crate::geometry::{Crease, FaceVarying, Mesh};
use glam::{DQuat, DVec3, Vec2};
use std::f64::consts::FRAC_PI_3;

/// Mesh under construction.
struct Build<'a> {
    plan: &'a Plan,
    opts: &'a SweepOptions,
    mesh: Mesh,
    uv: FaceVarying<Vec2>,
    owner: Vec<[u32; 2]>,
    max_twist: f64,
    open_loops: usize,
}

impl Build<'_> {
    fn ring(&mut self, c: DVec3, d: DVec3, u: DVec3, r: f64, v: f64) -> Ring {
        let first = self.mesh.positions.len() as u32;
        let ring = Ring { c, d, u: perpendicular(u, d), r, v, first, parity: 0, tile: 0.0 };
        for k in 0..SIDES {
            self.mesh.positions.push(ring.vertex(k).as_vec3());
        }
        ring
    }

    /// Stretches `ring`'s vertices by `f` along `across` (a unit vector in its plane): a
    /// bend's mitre.
    fn stretch(&mut self, ring: &Ring, across: DVec3, f: f64) {
        for k in 0..SIDES {
            let p = ring.vertex(k);
            let x = (p - ring.c).dot(across);
            self.mesh.positions[ring.index(k) as usize] = (p + across * (x * (f - 1.0))).as_vec3();
        }
    }

    fn tri(&mut self, v: [u32; 3], uv: [Vec2; 3], owner: [u32; 2]) {
        self.mesh.push_face(&v);
        for t in uv {
            self.uv.indices.push(self.uv.values.len() as u32);
            self.uv.values.push(t);
        }
        self.owner.push(owner);
    }

    fn ring_uv(&self, ring: &Ring, k: usize) -> Vec2 {
        let v = if self.opts.tile_v { ring.tile } else { (ring.v / self.plan.vmax) as f32 };
        Vec2::new(self.u(ring, k), v)
    }

    /// `u` of vertex `k` of `ring`; `k = 6` is the wrap column (`u = 1` when wrapped).
    pub(super) fn u(&self, ring: &Ring, k: usize) -> f32 {
        match self.opts.u_mapping {
            UMapping::Reflected => ((k + ring.parity as usize) % 2) as f32,
            UMapping::Wrapped => k as f32 / SIDES as f32,
        }
    }

    /// UV of global vertex `g` on one of `rings`.
    fn vertex_uv(&self, rings: &[Ring], g: u32) -> Vec2 {
        for r in rings {
            if g >= r.first && g < r.first + SIDES as u32 {
                return self.ring_uv(r, (g - r.first) as usize);
            }
        }
        Vec2::ZERO
    }

    /// The 12-triangle strip from `a` (start) to `b` (end) with the least twist; sets
    /// `b`'s `u` parity from `a`'s (connected vertices share `u`) and `b` as an end ring
    /// for Tile V.
    fn strip(&mut self, a: &Ring, b: &mut Ring, owner: [u32; 2]) {
        self.strip_part(a, b, owner, (0.0, 1.0));
    }

    /// [`Build::strip`] for a part of an internode: with Tile V, `v` runs over `tiles`
    /// (the parts' fractions of the internode) instead of `0 → 1`.
    fn strip_part(&mut self, a: &Ring, b: &mut Ring, owner: [u32; 2], tiles: (f32, f32)) {
        let t = DQuat::from_rotation_arc(a.d, b.d) * a.u;
        let alpha = t.dot(b.w()).atan2(t.dot(b.u));
        let o = (alpha / FRAC_PI_3).round();
        self.max_twist = self.max_twist.max((alpha - o * FRAC_PI_3).abs().to_degrees());
        let o = o.rem_euclid(6.0) as usize;
        b.parity = ((a.parity as usize + o) % 2) as u8;
        b.tile = 1.0;
        let (va, vb) = if self.opts.tile_v {
            tiles
        } else {
            ((a.v / self.plan.vmax) as f32, (b.v / self.plan.vmax) as f32)
        };
        for k in 0..SIDES {
            let (a0, a1) = (a.index(k), a.index(k + 1));
            let (b0, b1) = (b.index(k + o), b.index(k + 1 + o));
            let (u0, u1) = (self.u(a, k), self.u(a, k + 1));
            let (ua0, ua1, ub0, ub1) =
                (Vec2::new(u0, va), Vec2::new(u1, va), Vec2::new(u0, vb), Vec2::new(u1, vb));
            self.tri([a0, a1, b1], [ua0, ua1, ub1], owner);
            self.tri([a0, b1, b0], [ua0, ub1, ub0], owner);
        }
    }

    /// Flat fan over a ring without new vertices; `start` caps the start of a tube.
    fn flat_cap(&mut self, ring: &Ring, start: bool, owner: [u32; 2], crease: bool) {
        let disc = |k: usize| {
            let a = k as f32 * std::f32::consts::FRAC_PI_3;
            Vec2::new(0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin())
        };
        for k in 1..SIDES - 1 {
            let (x, y) = if start { (k + 1, k) } else { (k, k + 1) };
            self.tri([ring.index(0), ring.index(x), ring.index(y)], [disc(0), disc(x), disc(y)], owner);
        }
        if crease {
            for k in 0..SIDES {
                self.mesh.creases.push(Crease {
                    a: ring.index(k),
                    b: ring.index(k + 1),
                    sharpness: f32::INFINITY,
                });
            }
        }
    }

    /// End of a tip's tube (seed §A.3): a cone ("Cap Front"; `len` is the internode's
    /// length, for Tile V) or a flat creased cap ("pruned").
    fn tip(&mut self, ring: &Ring, len: f64, owner: [u32; 2]) {
        if self.opts.tips == SweepTips::Pruned {
            self.flat_cap(ring, false, owner, true);
            return;
        }
        let h = self.opts.tip_size * 2.0 * ring.r;
        let h = h.max(0.05 * ring.r);
        let apex = self.mesh.positions.len() as u32;
        self.mesh.positions.push((ring.c + ring.d * h).as_vec3());
        let va = if self.opts.tile_v {
            (1.0 + h / len.max(1e-12)) as f32
        } else {
            let h = self.plan.texel.map_or(h, |k| h / (ring.r * k));
            ((ring.v + h) / self.plan.vmax) as f32
        };
        for k in 0..SIDES {
            let (u0, u1) = (self.ring_uv(ring, k), Vec2::new(self.u(ring, k + 1), self.ring_uv(ring, k).y));
            let ua = Vec2::new(0.5 * (u0.x + u1.x), va);
            self.tri([ring.index(k), ring.index(k + 1), apex], [u0, u1, ua], owner);
        }
    }

    /// Start-of-tube base at a root: open or capped.
    fn base(&mut self, ring: &Ring, owner: [u32; 2]) {
        if self.opts.caps {
            self.flat_cap(ring, true, owner, true);
        } else {
            self.open_loops += 1;
        }
    }

    /// The general junction at node `j` (module docs, step 5b): the faces found by
    /// [`cap_hull`] on `trunk` followed by `kids`, mapped to their ring vertices.
    fn general_junction(&mut self, j: u32, trunk: &Ring, kids: &[Ring], faces: &[[(u32, u32); 3]]) {
        let mut rings = vec![*trunk];
        rings.extend_from_slice(kids);
        for f in faces {
            let t = f.map(|(l, k)| rings[l as usize].index(k as usize));
            let uv =
                [self.vertex_uv(&rings, t[0]), self.vertex_uv(&rings, t[1]), self.vertex_uv(&rings, t[2])];
            self.tri(t, uv, [j, NONE]);
        }
    }

    /// The junction template at node `j` (module docs, step 5). `trunk` ends the
    /// incoming tube (or is the base ring of a root junction); `kids` are the children's
    /// start rings in sorted order.
    fn junction(&mut self, j: u32, trunk: &Ring, kids: &[Ring]) {
        let owner = [j, NONE];
        let mut rings = vec![*trunk];
        rings.extend_from_slice(kids);
        let mut tris: Vec<[u32; 3]> = Vec::new();
        // Zip chain `p` of ring `rp` with chain `q` of ring `rq`, front to back.
        let mut zip = |rp: &Ring, p: [usize; 4], p_trunk: bool, rq: &Ring, q: [usize; 4], q_trunk: bool| {
            let (mut i, mut k) = (0, 0);
            let dist = |a: DVec3, b: DVec3| (a - b).length_squared();
            while i < 3 || k < 3 {
                let adv_p = if i == 3 {
                    false
                } else if k == 3 {
                    true
                } else {
                    dist(rp.vertex(p[i + 1]), rq.vertex(q[k])) <= dist(rp.vertex(p[i]), rq.vertex(q[k + 1]))
                };
                let (ring, trunk_ring, x, y, apex) = if adv_p {
                    let t = (rp, p_trunk, p[i], p[i + 1], rq.index(q[k]));
                    i += 1;
                    t
                } else {
                    let t = (rq, q_trunk, q[k], q[k + 1], rp.index(p[i]));
                    k += 1;
                    t
                };
                // Trunk ring edges run k → k+1, child ring edges k+1 → k (opposite to
                // their tubes).
                let forward = (x + 1) % SIDES == y % SIDES;
                let (from, to) = if forward == trunk_ring { (x, y) } else { (y, x) };
                tris.push([ring.index(from), ring.index(to), apex]);
            }
        };
        const LEFT: [usize; 4] = [0, 1, 2, 3];
        const RIGHT: [usize; 4] = [0, 5, 4, 3];
        let n = kids.len();
        zip(trunk, LEFT, true, &kids[0], LEFT, false);
        for i in 0..n - 1 {
            zip(&kids[i], RIGHT, false, &kids[i + 1], LEFT, false);
        }
        zip(trunk, RIGHT, true, &kids[n - 1], RIGHT, false);
        // Front (vertex 0) and back (vertex 3) holes.
        for side in [0usize, 3] {
            let mut cycle: Vec<u32> = vec![trunk.index(side)];
            cycle.extend(kids.iter().map(|r| r.index(side)));
            let (a, b) = (cycle[0], cycle[1]);
            let used = tris.iter().any(|t| (0..3).any(|e| t[e] == a && t[(e + 1) % 3] == b));
            if used {
                cycle[1..].reverse();
            }
            let pts: Vec<DVec3> = cycle.iter().map(|&g| self.mesh.positions[g as usize].as_dvec3()).collect();
            for [x, y, z] in max_min_angle(&pts) {
                tris.push([cycle[x], cycle[y], cycle[z]]);
            }
        }
        for t in tris {
            let uv =
                [self.vertex_uv(&rings, t[0]), self.vertex_uv(&rings, t[1]), self.vertex_uv(&rings, t[2])];
            self.tri(t, uv, owner);
        }
    }
}

/// Triangulates the polygon `pts` (in order) into `len − 2` triangles maximising the
/// smallest angle (dynamic programming over diagonals); corners keep the polygon order.
pub(super) fn max_min_angle(pts: &[DVec3]) -> Vec<[usize; 3]> {
    let m = pts.len();
    if m < 3 {
        return Vec::new();
    }
    let min_angle = |a: usize, b: usize, c: usize| {
        let ang = |p: DVec3, q: DVec3, r: DVec3| {
            let (u, v) = (q - p, r - p);
            let d = u.length() * v.length();
            if d > 0.0 {
                (u.dot(v) / d).clamp(-1.0, 1.0).acos()
            } else {
                0.0
            }
        };
        ang(pts[a], pts[b], pts[c]).min(ang(pts[b], pts[c], pts[a])).min(ang(pts[c], pts[a], pts[b]))
    };
    let mut best = vec![vec![f64::INFINITY; m]; m];
    let mut split = vec![vec![0usize; m]; m];
    for gap in 2..m {
        for i in 0..m - gap {
            let j = i + gap;
            best[i][j] = f64::NEG_INFINITY;
            for k in i + 1..j {
                let q = best[i][k].min(best[k][j]).min(min_angle(i, k, j));
                if q > best[i][j] {
                    best[i][j] = q;
                    split[i][j] = k;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(m - 2);
    let mut stack = vec![(0, m - 1)];
    while let Some((i, j)) = stack.pop() {
        if j < i + 2 {
            continue;
        }
        let k = split[i][j];
        out.push([i, k, j]);
        stack.push((i, k));
        stack.push((k, j));
    }
    out
}

/// Builds the control mesh of `plan` with the nodes in `fallback` capped separately:
/// the mesh, each face's owner nodes, the largest twist and the open loops. Errors:
/// [`crate::Error::Cancelled`] when the thread's token is cancelled (checked per node).
pub(super) fn build(
    plan: &Plan,
    opts: &SweepOptions,
    fallback: &[bool],
) -> crate::error::Result<(Mesh, Vec<[u32; 2]>, f64, usize)> {
    let n = plan.pos.len();
    let mut b = Build {
        plan,
        opts,
        mesh: Mesh::new(),
        uv: FaceVarying::default(),
        owner: Vec::new(),
        max_twist: 0.0,
        open_loops: 0,
    };
    // Start ring of each internode (indexed by its child node).
    let mut start: Vec<Option<Ring>> = vec![None; n];
    let nodeown =
        |j: usize| if matches!(plan.kind[j], Kind::Junction | Kind::Chain) { j as u32 } else { NONE };
    for i in 0..n {
        if !plan.live[i] {
            continue;
        }
        crate::cancel::check()?;
        let fb = fallback[i];
        let kind = plan.kind[i];
        let r = plan.rad[i];
        // End ring of the internode into i, and its tube.
        let mut end: Option<Ring> = None;
        if plan.par[i] != NONE {
            let Some(mut a) = start[i] else { continue };
            let owner = [nodeown(plan.par[i] as usize), nodeown(i)];
            let d = plan.dir[i];
            // Bend rings (step 4b): after a bent chain parent, and before this node when
            // it is one.
            let p = plan.par[i] as usize;
            let after = if plan.kind[p] == Kind::Chain && !fallback[p] { plan.bend_out[p] } else { 0.0 };
            let before = if kind == Kind::Chain && !fb { plan.bend_in[i] } else { 0.0 };
            let len = plan.len[i];
            let mut tile = 0.0f32;
            for x in [after, len - before].into_iter().filter(|&x| x > 0.0 && x < len) {
                let ux = DQuat::from_rotation_arc(a.d, d) * a.u;
                let rx = plan.rad[p] + (r - plan.rad[p]) * (x / len);
                let mut ring = b.ring(plan.pos[p] + d * x, d, ux, rx, plan.v_start(i, x));
                let t = (x / len) as f32;
                b.strip_part(&a, &mut ring, owner, (tile, t));
                tile = t;
                a = ring;
            }
            let ut = DQuat::from_rotation_arc(a.d, d) * a.u;
            let mut e = match kind {
                Kind::Tip => b.ring(plan.pos[i], d, ut, r, plan.path[i]),
                Kind::Chain if !fb => {
                    let c = plan.kids[i][0] as usize;
                    let axis = unit_or(d + plan.dir[c], d);
                    let ua = DQuat::from_rotation_arc(a.d, axis) * a.u;
                    let ring = b.ring(plan.pos[i], axis, ua, r, plan.path[i]);
                    let (f, across) = plan.mitre[i];
                    if f > 1.0 {
                        b.stretch(&ring, across, f);
                    }
                    ring
                }
                Kind::Junction if !fb => {
                    let off = plan.off_end[i];
                    b.ring(plan.pos[i] - d * off, d, plan.normal[i], r, plan.v_end(i, off))
                }
                _ => {
                    let off = plan.off_end[i];
                    b.ring(plan.pos[i] - d * off, d, ut, r, plan.v_end(i, off))
                }
            };
            b.strip_part(&a, &mut e, owner, (tile, 1.0));
            if kind == Kind::Tip {
                b.tip(&e, plan.len[i], owner);
            } else if fb {
                b.flat_cap(&e, false, [i as u32, NONE], false);
            }
            end = Some(e);
        }
        // Start rings of the children.
        let kids = &plan.kids[i];
        if kids.is_empty() {
            continue;
        }
        let own = [nodeown(i), NONE];
        match kind {
            Kind::Root => {
                let c = kids[0] as usize;
                let d = plan.dir[c];
                let ring = b.ring(plan.pos[i], d, plan.up[i], plan.start_r(i, c), 0.0);
                b.base(&ring, [NONE, NONE]);
                start[c] = Some(ring);
            }
            Kind::Chain if !fb => start[kids[0] as usize] = end,
            Kind::Junction if !fb => {
                let h = plan.h_in[i];
                let nrm = plan.normal[i];
                let trunk = match end {
                    Some(e) => e,
                    None => {
                        let ring = b.ring(plan.pos[i], h, nrm, r, 0.0);
                        b.base(&ring, [NONE, NONE]);
                        ring
                    }
                };
                let mut rings = Vec::with_capacity(kids.len());
                for &c in &plan.sorted[i] {
                    let c = c as usize;
                    let (off, d, u) = (plan.off_start[c], plan.dir[c], plan.kid_u[c]);
                    let mut ring =
                        b.ring(plan.pos[i] + d * off, d, u, plan.start_r(i, c), plan.v_start(c, off));
                    // Every junction ring has vertex 0 on the normal: the child takes
                    // the trunk's `u` parity.
                    ring.parity = trunk.parity;
                    if plan.collar[c] > 0.0 {
                        // Asymmetric template: the extra ring takes the child's place in
                        // the junction, a strip joins it to the child's own ring.
                        let oc = plan.off_collar[c];
                        let mut extra =
                            b.ring(plan.pos[i] + d * oc, d, u, plan.collar[c], plan.v_start(c, oc));
                        extra.parity = trunk.parity;
                        b.strip(&extra, &mut ring, own);
                        ring.tile = 0.0;
                        rings.push(extra);
                    } else {
                        rings.push(ring);
                    }
                    start[c] = Some(ring);
                }
                if plan.general[i] {
                    b.general_junction(i as u32, &trunk, &rings, &plan.general_faces[i]);
                } else {
                    b.junction(i as u32, &trunk, &rings);
                }
            }
            _ => {
                // Fallback: every child its own tube, capped at its offset.
                let seed = end.map(|e| e.u).unwrap_or(plan.up[i]);
                let from = end.map(|e| e.d).unwrap_or(plan.h_in[i]);
                for &c in kids {
                    let c = c as usize;
                    let off = plan.off_start[c];
                    let d = plan.dir[c];
                    let u = DQuat::from_rotation_arc(unit_or(from, d), d) * seed;
                    let ring = b.ring(plan.pos[i] + d * off, d, u, plan.start_r(i, c), plan.v_start(c, off));
                    b.flat_cap(&ring, true, own, false);
                    start[c] = Some(ring);
                }
            }
        }
    }
    let mut mesh = b.mesh;
    mesh.uvs = Some(b.uv);
    Ok((mesh, b.owner, b.max_twist, b.open_loops))
}
