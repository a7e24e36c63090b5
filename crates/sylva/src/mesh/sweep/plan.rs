//! The sweep mesher's plan: everything that does not depend on which nodes fall back —
//! the collapsed graph, segment-length adjustment (MacMurchy2004 §5.2, Eqs. 5.1/5.2),
//! ring frames and twist (§5.5.1–§5.5.2), bend rings, junction planes and collars
//! (§5.5.3; MacMurchy2004-spec §2.2–§2.7). `docs/meshers.md` ("sweep") has the steps.

use super::{guarded_offsets, Kind, Plan, SweepOptions, UMapping, VMapping, SIDES};
use crate::geometry::NONE;
use crate::mesh::hull::{cap_hull, CapLoop};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DQuat, DVec3};

/// Loop cuts a bend's corner by about `L̄ sin(β/2) / 3` (`L̄` the mean length of the two
/// internodes): bend rings go where that exceeds this many radii.
const BEND_CUT: f64 = 0.5;

/// The skeleton graph with internodes shorter than float noise (or than 1e-3 of the
/// thinner radius) collapsed into their parent node.
pub(crate) struct Collapsed {
    /// Whether each node stands for itself (not collapsed).
    pub live: Vec<bool>,
    /// The live parent of each live node, `NONE` for roots and collapsed nodes.
    pub parent: Vec<u32>,
    /// The collapsed nodes, in order.
    pub collapsed: Vec<u32>,
}

/// Collapses zero-length internodes (step 1 of the module docs; shared with the leaf
/// mesher). `parent` is the skeleton's parent column, parents first.
pub(crate) fn collapse_short(parent: &[u32], pos: &[DVec3], rad: &[f64]) -> Collapsed {
    let n = parent.len();
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut collapsed = Vec::new();
    for i in 0..n {
        let p = parent[i];
        if p == NO_PARENT {
            continue;
        }
        let rp = rep[p as usize] as usize;
        let d = (pos[i] - pos[rp]).length();
        let tiny = 1e-6 * (pos[i].abs().max_element().max(pos[rp].abs().max_element())) + 1e-12;
        if d <= tiny.max(1e-3 * rad[i].min(rad[rp])) {
            rep[i] = rp as u32;
            collapsed.push(i as u32);
        }
    }
    let live: Vec<bool> = (0..n).map(|i| rep[i] == i as u32).collect();
    let parent = (0..n)
        .map(|i| if live[i] && parent[i] != NO_PARENT { rep[parent[i] as usize] } else { NONE })
        .collect();
    Collapsed { live, parent, collapsed }
}

/// `v` normalised, or `fallback` when `v` is (near) zero or not finite.
pub(crate) fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    let l = v.length();
    if l > 1e-12 && l.is_finite() {
        v / l
    } else {
        fallback
    }
}

/// The unit part of `seed` perpendicular to the unit `d` (any perpendicular when `seed`
/// is parallel to `d`).
pub(crate) fn perpendicular(seed: DVec3, d: DVec3) -> DVec3 {
    let u = seed - d * seed.dot(d);
    if u.length_squared() > 1e-12 {
        u.normalize()
    } else {
        d.any_orthonormal_vector()
    }
}

/// Least-variance direction of a set of unit vectors (the normal of the fitted plane).
pub(super) fn fit_normal(axes: &[DVec3]) -> DVec3 {
    let mut m = [[0.0f64; 3]; 3];
    for a in axes {
        let v = a.to_array();
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += v[i] * v[j];
            }
        }
    }
    // Shift by the trace so the smallest eigenvalue becomes the largest, then iterate.
    let t = m[0][0] + m[1][1] + m[2][2];
    let apply = |x: DVec3| {
        let a = x.to_array();
        DVec3::new(
            t * a[0] - (m[0][0] * a[0] + m[0][1] * a[1] + m[0][2] * a[2]),
            t * a[1] - (m[1][0] * a[0] + m[1][1] * a[1] + m[1][2] * a[2]),
            t * a[2] - (m[2][0] * a[0] + m[2][1] * a[1] + m[2][2] * a[2]),
        )
    };
    // Start from the largest row-pair cross product (exact for coplanar axes).
    let rows = [DVec3::from(m[0]), DVec3::from(m[1]), DVec3::from(m[2])];
    let cands = [rows[0].cross(rows[1]), rows[1].cross(rows[2]), rows[2].cross(rows[0])];
    let mut x =
        cands
            .iter()
            .copied()
            .fold(DVec3::ZERO, |b, c| if c.length_squared() > b.length_squared() { c } else { b });
    if x.length_squared() < 1e-24 {
        return DVec3::ZERO;
    }
    x = x.normalize();
    for _ in 0..32 {
        x = unit_or(apply(x), x);
    }
    x
}

impl Plan {
    /// Radius of the start ring of child `c` at node `j` (root, junction or fallback
    /// children; a chain node's ring is shared and has the node's radius): the
    /// internode's explicit start radius, else `min(r_j, r_c)`.
    pub(super) fn start_r(&self, j: usize, c: usize) -> f64 {
        self.rad0[c].unwrap_or(self.rad[j].min(self.rad[c]))
    }

    /// The `v` distance covered `x` metres into internode `p → i` of length `len`: `x`
    /// itself for path-length `v`, or `∫₀ˣ ds / r(s)` over the radius per unit of `u`
    /// for texel `v` (the radius runs linearly from `rad[p]` to `rad[i]`, as the rings').
    fn texel_len(&self, p: usize, i: usize, len: f64, x: f64) -> f64 {
        let Some(k) = self.texel else { return x };
        let (r0, r1) = (self.rad[p], self.rad[i]);
        let x = x.clamp(0.0, len.max(0.0));
        let dr = r1 - r0;
        let t = if len <= 0.0 || dr.abs() <= 1e-9 * r0 {
            x / r0
        } else {
            let rx = r0 + dr * (x / len);
            len / dr * (rx / r0).ln()
        };
        t / k
    }

    /// `v` (before `vmax`) `x` metres into internode `i` from its parent node.
    pub(super) fn v_start(&self, i: usize, x: f64) -> f64 {
        let p = self.par[i] as usize;
        self.path[p] + self.texel_len(p, i, self.len[i], x)
    }

    /// `v` (before `vmax`) `off` metres back from node `i` along its internode.
    pub(super) fn v_end(&self, i: usize, off: f64) -> f64 {
        match self.texel {
            None => self.path[i] - off,
            Some(_) => self.v_start(i, self.len[i] - off),
        }
    }

    pub(super) fn new(s: &Skeleton, opts: &SweepOptions) -> Plan {
        let n = s.len();
        let pos: Vec<DVec3> = s.position.iter().map(|p| p.as_dvec3()).collect();
        let rmax = s.radius.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
        let scale = pos.iter().fold(0.0f64, |a, p| a.max(p.abs().max_element()));
        let f = opts.min_radius;
        let rmin = if rmax > 0.0 { f * rmax } else { f * scale.max(1e-3) };
        let rad: Vec<f64> = s.radius.iter().map(|&r| (r as f64).max(rmin)).collect();
        let rad0: Vec<Option<f64>> =
            (0..n).map(|i| s.start_radius(i).map(|r| (r as f64).max(rmin))).collect();
        let up: Vec<DVec3> = s.up.iter().map(|u| u.as_dvec3()).collect();
        let Collapsed { mut live, parent: mut par, collapsed } = collapse_short(&s.parent, &pos, &rad);
        let mut plan = Plan {
            pos,
            rad,
            rad0,
            up,
            live: Vec::new(),
            par: Vec::new(),
            kids: Vec::new(),
            kind: Vec::new(),
            dir: Vec::new(),
            len: Vec::new(),
            path: Vec::new(),
            vmax: 1.0,
            texel: match opts.v_mapping {
                VMapping::Texel => Some(match opts.u_mapping {
                    UMapping::Reflected => 1.0,
                    UMapping::Wrapped => SIDES as f64,
                }),
                VMapping::Path => None,
            },
            off_start: Vec::new(),
            off_end: Vec::new(),
            normal: Vec::new(),
            h_in: Vec::new(),
            sorted: Vec::new(),
            forced: Vec::new(),
            general: Vec::new(),
            general_faces: Vec::new(),
            kid_u: Vec::new(),
            collar: Vec::new(),
            off_collar: Vec::new(),
            clamped: Vec::new(),
            collapsed,
            asymmetric: Vec::new(),
            bend_in: vec![0.0; n],
            bend_out: vec![0.0; n],
            mitre: vec![(1.0, DVec3::ZERO); n],
        };
        // Offsets; where an internode is too short for them, a chain node at one of its
        // ends is removed (its child re-attaches to its parent; end points never move)
        // and the offsets are computed again.
        for _round in 0..64 {
            let removed = plan.layout(&live, &par, opts);
            if removed.is_empty() {
                break;
            }
            for &r in &removed {
                live[r as usize] = false;
                plan.collapsed.push(r);
            }
            for i in 0..n {
                while par[i] != NONE && !live[par[i] as usize] {
                    par[i] = par[par[i] as usize];
                }
            }
        }
        plan.collapsed.sort_unstable();
        if opts.bend_rings {
            plan.bends();
        }
        plan.general_joints(opts);
        plan
    }

    /// Bend rings and mitres of the chain nodes ([`SweepOptions::bend_rings`]). The
    /// extra ring sits `r (0.5 + 1.5 tan(β/2))`, at least `1.5 r`, from the node, so
    /// that the mitre's inner point (`r tan(β/2)` back along either internode) lies
    /// between it and the node; it takes at most 45% of the internode's length left
    /// between its offsets, and a side without room for `1.1 r tan(β/2)` gets none.
    /// The mitre is stretched only when both sides have their ring.
    fn bends(&mut self) {
        let free = |p: &Plan, c: usize| p.len[c] - p.off_start[c] - p.off_end[c];
        for i in 0..self.live.len() {
            if !self.live[i] || self.kind[i] != Kind::Chain || self.par[i] == NONE {
                continue;
            }
            let c = self.kids[i][0] as usize;
            let (din, dout) = (self.dir[i], self.dir[c]);
            let beta = din.dot(dout).clamp(-1.0, 1.0).acos();
            let r = self.rad[i];
            let mean = 0.5 * (self.len[i] + self.len[c]);
            if mean * (0.5 * beta).sin() / 3.0 <= BEND_CUT * r {
                continue;
            }
            let t = (0.5 * beta).tan().min(4.0);
            let want = (r * (0.5 + 1.5 * t)).max(1.5 * r);
            let least = (1.1 * r * t).max(0.25 * r);
            let side = |room: f64| {
                let s = want.min(0.45 * room);
                if s >= least {
                    s
                } else {
                    0.0
                }
            };
            self.bend_in[i] = side(free(self, i));
            self.bend_out[i] = side(free(self, c));
            if self.bend_in[i] > 0.0 && self.bend_out[i] > 0.0 {
                let axis = unit_or(din + dout, din);
                let across = din - dout;
                let across = across - axis * across.dot(axis);
                if across.length_squared() > 1e-18 {
                    let f = (1.0 / (0.5 * beta).cos().max(0.5)).min(2.0);
                    self.mitre[i] = (f, across.normalize());
                }
            }
        }
    }

    /// Faces of every general junction (module docs, step 5b); a junction whose hull
    /// fails its checks falls back.
    fn general_joints(&mut self, opts: &SweepOptions) {
        let n = self.live.len();
        self.general_faces = vec![Vec::new(); n];
        for j in 0..n {
            if self.live[j] && self.general[j] && !self.forced[j] && !self.make_general(j, opts) {
                self.forced[j] = true;
            }
        }
    }

    /// Turns junction `j` into a general junction: children's ring frames transported
    /// from the trunk's, hull faces computed. False (and `j` unchanged) when the hull
    /// fails its checks.
    pub(super) fn make_general(&mut self, j: usize, opts: &SweepOptions) -> bool {
        let eps = 1.0 - opts.aligned_deg.to_radians().cos();
        let h = self.h_in[j];
        let u = perpendicular(self.normal[j], h);
        let r = self.rad[j];
        let mut loops = vec![CapLoop {
            axis: -h,
            radius: r,
            offset: if self.par[j] != NONE { self.off_end[j] } else { 0.0 },
            u,
            w: h.cross(u),
            at_end: true,
        }];
        let mut frames = Vec::with_capacity(self.sorted[j].len());
        for &c in &self.sorted[j] {
            let c = c as usize;
            let d = self.dir[c];
            let uc = perpendicular(DQuat::from_rotation_arc(h, d) * u, d);
            frames.push((c, uc));
            let (radius, offset) = if self.collar[c] > 0.0 {
                (self.collar[c], self.off_collar[c])
            } else {
                (self.start_r(j, c), self.off_start[c])
            };
            loops.push(CapLoop { axis: d, radius, offset, u: uc, w: d.cross(uc), at_end: false });
        }
        match cap_hull(&loops, SIDES as u32, eps) {
            Some(f) => {
                self.general_faces[j] = f;
                self.general[j] = true;
                for (c, uc) in frames {
                    self.kid_u[c] = uc;
                }
                true
            }
            None => false,
        }
    }

    /// Graph, offsets and junction set-up for the live nodes; returns the chain nodes to
    /// remove because an internode next to them is too short for its offsets.
    fn layout(&mut self, live: &[bool], par: &[u32], opts: &SweepOptions) -> Vec<u32> {
        let n = live.len();
        let pos = &self.pos;
        let mut kids = vec![Vec::new(); n];
        for i in 0..n {
            if live[i] && par[i] != NONE {
                kids[par[i] as usize].push(i as u32);
            }
        }
        let mut dir = vec![DVec3::ZERO; n];
        let mut len = vec![0.0; n];
        let mut path = vec![0.0; n];
        let mut vmax = 0.0f64;
        for i in 0..n {
            if live[i] && par[i] != NONE {
                let p = par[i] as usize;
                let e = pos[i] - pos[p];
                len[i] = e.length();
                dir[i] = unit_or(e, DVec3::Y);
                path[i] = path[p] + self.texel_len(p, i, len[i], len[i]);
                vmax = vmax.max(path[i]);
            }
        }
        self.kind = (0..n)
            .map(|i| match (par[i] == NONE, kids[i].len()) {
                (_, k) if k >= 2 => Kind::Junction,
                (true, _) => Kind::Root,
                (false, 0) => Kind::Tip,
                (false, _) => Kind::Chain,
            })
            .collect();
        self.live = live.to_vec();
        self.par = par.to_vec();
        self.kids = kids;
        self.dir = dir;
        self.len = len;
        self.path = path;
        // Texel `v` is not normalized: one unit of `v` is one unit of `u`.
        self.vmax = if self.texel.is_some() {
            1.0
        } else if vmax > 0.0 {
            vmax
        } else {
            1.0
        };
        self.off_start = vec![0.0; n];
        self.off_end = vec![0.0; n];
        self.normal = vec![DVec3::ZERO; n];
        self.h_in = vec![DVec3::ZERO; n];
        self.sorted = vec![Vec::new(); n];
        self.forced = vec![false; n];
        self.general = vec![false; n];
        self.kid_u = vec![DVec3::ZERO; n];
        self.collar = vec![0.0; n];
        self.off_collar = vec![0.0; n];
        self.clamped.clear();
        self.asymmetric.clear();
        for j in 0..n {
            if self.live[j] && matches!(self.kind[j], Kind::Junction | Kind::Chain) {
                self.node(j, opts);
            }
        }
        // Both ends of an internode share 90% of its length (MacMurchy2004-spec §2.2 guard). A thin
        // child without room for its extra ring loses it first (symmetric template).
        for c in 0..n {
            let sum = self.off_start[c] + self.off_end[c];
            if self.collar[c] > 0.0 && sum > 0.9 * self.len[c] {
                self.off_start[c] = self.off_collar[c];
                self.collar[c] = 0.0;
            }
            let sum = self.off_start[c] + self.off_end[c];
            if self.live[c] && self.par[c] != NONE && sum > 0.9 * self.len[c] {
                let f = 0.9 * self.len[c] / sum;
                self.off_start[c] *= f;
                self.off_end[c] *= f;
                self.clamped.push(c as u32);
            }
        }
        self.clamped.sort_unstable();
        self.clamped.dedup();
        // Clamped internodes next to a junction: remove a chain node to make room.
        let mut remove = Vec::new();
        for &c in &self.clamped {
            let c = c as usize;
            let p = self.par[c];
            let near_junction =
                self.kind[c] == Kind::Junction || (p != NONE && self.kind[p as usize] == Kind::Junction);
            if !near_junction {
                continue;
            }
            if self.kind[c] == Kind::Chain {
                remove.push(c as u32);
            } else if p != NONE && self.kind[p as usize] == Kind::Chain {
                remove.push(p);
            }
        }
        remove.sort_unstable();
        remove.dedup();
        remove
    }

    /// Offsets, plane, order and template checks at a junction or chain node.
    fn node(&mut self, j: usize, opts: &SweepOptions) {
        let kids = self.kids[j].clone();
        let has_trunk = self.par[j] != NONE;
        let h_in = if has_trunk {
            self.dir[j]
        } else {
            let sum: DVec3 = kids.iter().map(|&c| self.dir[c as usize]).sum();
            unit_or(sum, self.dir[kids[0] as usize])
        };
        self.h_in[j] = h_in;
        let rj = self.rad[j];
        // Participants: trunk first (outward axis −H), then the children.
        let mut axes = vec![-h_in];
        let mut radii = vec![rj];
        let mut maxes = vec![if has_trunk { 0.9 * self.len[j] } else { 0.0 }];
        for &c in &kids {
            axes.push(self.dir[c as usize]);
            radii.push(self.start_r(j, c as usize));
            maxes.push(0.9 * self.len[c as usize]);
        }
        let k = axes.len();
        // Asymmetric rule (MacMurchy2004 §5.5.3): a child whose radius is ≤ ratio × its
        // largest partner's is thin; it gets the extra ring, which its partners must clear.
        let junction = kids.len() >= 2;
        let thin: Vec<bool> = (0..k)
            .map(|i| {
                let other = (0..k).filter(|&m| m != i).map(|m| radii[m]).fold(0.0, f64::max);
                junction && i > 0 && radii[i] <= opts.asymmetric_ratio * other * (1.0 + 1e-6)
            })
            .collect();
        if thin.iter().any(|&t| t) {
            self.asymmetric.push(j as u32);
        }
        let collar: Vec<f64> = (0..k)
            .map(|i| {
                let rho = (opts.collar_ratio * radii[i]).min(0.9 * rj);
                if thin[i] && rho > 1.05 * radii[i] {
                    rho
                } else {
                    0.0
                }
            })
            .collect();
        let eff: Vec<f64> = (0..k).map(|i| if collar[i] > 0.0 { collar[i] } else { radii[i] }).collect();
        let mut off: Vec<f64> = (0..k).map(|i| (0.25 * eff[i]).min(maxes[i])).collect();
        let mut clamped = false;
        let mut aligned = false;
        let cos_aligned = opts.aligned_deg.to_radians().cos();
        for a in 0..k {
            for b in a + 1..k {
                let c = axes[a].dot(axes[b]).clamp(-1.0, 1.0);
                if c > cos_aligned {
                    aligned = true;
                }
                if let Some((da, db, cl)) = guarded_offsets(eff[a], eff[b], c.acos(), maxes[a], maxes[b]) {
                    off[a] = off[a].max(da);
                    off[b] = off[b].max(db);
                    clamped |= cl;
                }
            }
        }
        if !has_trunk {
            off[0] = 0.0;
        }
        if clamped {
            for (i, &d) in off.iter().enumerate() {
                if d >= maxes[i] && maxes[i] > 0.0 {
                    self.clamped.push(if i == 0 { j as u32 } else { kids[i - 1] });
                }
            }
        }
        self.off_end[j] = off[0];
        for (i, &c) in kids.iter().enumerate() {
            let c = c as usize;
            self.off_start[c] = off[i + 1];
            // The extra ring sits at the template offset (computed for its radius), the
            // child's own ring one extra-ring radius further out, when there is room.
            let rho = collar[i + 1];
            if rho > 0.0 && off[i + 1] + rho <= maxes[i + 1] {
                self.collar[c] = rho;
                self.off_collar[c] = off[i + 1];
                self.off_start[c] = off[i + 1] + rho;
            }
        }
        if !junction {
            return;
        }
        // Branching plane (MacMurchy2004-spec §2.3): least-variance normal, toward the node's up.
        let mut n = fit_normal(&axes);
        let mut force = aligned;
        if n == DVec3::ZERO {
            force = true;
            n = perpendicular(self.up[j], h_in);
        }
        let refv = perpendicular(self.up[j], h_in);
        let sgn = n.dot(refv);
        if sgn < 0.0 || (sgn == 0.0 && n.dot(DVec3::new(0.31, 0.57, 0.76)) < 0.0) {
            n = -n;
        }
        let tol = opts.coplanar_deg.to_radians().sin();
        let general = kids.len() > opts.max_children || axes.iter().any(|a| a.dot(n).abs() > tol);
        if general && !opts.general_junctions {
            force = true;
        }
        self.normal[j] = n;
        self.general[j] = general && !force;
        // Children's ring frames: vertex-forward (vertex 0 on +N) for the coplanar
        // template (a general junction replaces them in `make_general`).
        for &c in &kids {
            let d = self.dir[c as usize];
            self.kid_u[c as usize] = perpendicular(n, d);
        }
        // Children by increasing signed angle about N from the trunk heading.
        let mut by: Vec<(f64, u32)> = kids
            .iter()
            .map(|&c| {
                let h = self.dir[c as usize];
                (n.dot(h_in.cross(h)).atan2(h_in.dot(h)), c)
            })
            .collect();
        by.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        self.sorted[j] = by.iter().map(|x| x.1).collect();
        self.forced[j] = force;
    }
}
