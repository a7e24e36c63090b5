//! The quad cage builder: rings carried along internodes, the four cases of J §3.2,
//! SMART junction boxes with Eq. 4 lengths, side children, caps and UVs (Skjermo2008 J
//! §3.2–§3.5; Skjermo2008-spec §2; Felkel2004).

use super::{
    box_length, perp, quad_normal, unit_or, Builder, FallbackReason, QuadFallback, Ring, Task, ALIGNED_DEG,
    GAP_MARGIN, REVERSED_DEG,
};
use crate::geometry::NONE;
use crate::skeleton::NO_PARENT;
use glam::{Vec2, Vec3};
use std::f32::consts::TAU;

impl Builder<'_> {
    fn kids(&self, node: u32) -> &[u32] {
        &self.kids[self.offsets[node as usize] as usize..self.offsets[node as usize + 1] as usize]
    }

    fn pos(&self, node: u32) -> Vec3 {
        self.sk.position[node as usize]
    }

    /// Section corner distance of a node.
    fn rho(&self, node: u32) -> f32 {
        (self.sk.radius[node as usize] * self.opts.cs_scale).max(self.floor)
    }

    fn min_len(&self, rho: f32) -> f32 {
        self.opts.min_length * rho
    }

    pub(super) fn drain(&mut self) {
        while let Some(t) = self.stack.pop() {
            if crate::cancel::cancelled() {
                // quad_mesh returns `Error::Cancelled`; the partial cage is dropped.
                self.stack.clear();
                return;
            }
            match t {
                Task::Segment { ring, node } => self.segment(ring, node),
                Task::Detach { node } => self.detach(node),
                Task::Separate { node } => self.separate(node),
            }
        }
    }

    /// Children of `node` sorted by diameter (descending), then by alignment with `d`,
    /// then by index.
    fn sorted_kids(&self, node: u32, d: Vec3) -> Vec<u32> {
        let mut k = self.kids(node).to_vec();
        let p = self.pos(node);
        let dot = |c: u32| unit_or(self.pos(c) - p, Vec3::ZERO).dot(d);
        k.sort_by(|&a, &b| {
            let ra = self.sk.radius[a as usize];
            let rb = self.sk.radius[b as usize];
            rb.total_cmp(&ra).then(dot(b).total_cmp(&dot(a))).then(a.cmp(&b))
        });
        // A thickest child that points back (≥ 90°) would make the whole junction a
        // backward box with every other child — the forward continuation included — on
        // its sides. When a forward child is nearly as thick (≥ 3/4 of its radius), that
        // one leads instead.
        if k.len() > 1 && dot(k[0]) <= 0.0 {
            let r0 = self.sk.radius[k[0] as usize];
            if let Some(i) = k.iter().position(|&c| dot(c) > 0.0 && self.sk.radius[c as usize] >= 0.75 * r0) {
                let lead = k.remove(i);
                k.insert(0, lead);
            }
        }
        k
    }

    /// [`Self::sorted_kids`] less the children the repair separated (or, at an unboxed
    /// node, all but the first), which are queued as separate cages and reported.
    fn kids_for(&mut self, node: u32, d: Vec3) -> Vec<u32> {
        let mut k = self.sorted_kids(node, d);
        if k.len() < 2 {
            return k;
        }
        let first = k[0];
        self.lead[node as usize] = first;
        let unboxed = self.repairs.unboxed[node as usize];
        if unboxed {
            self.fallback(node, FallbackReason::Unboxed);
        }
        k.retain(|&c| {
            let keep = c == first || !(unboxed || self.repairs.separated[c as usize]);
            if !keep {
                self.fallback(c, FallbackReason::Separated);
                self.stack.push(Task::Separate { node: c });
            }
            keep
        });
        k
    }

    fn vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    fn uv(&mut self, uv: Vec2) -> u32 {
        self.uv_values.push(uv);
        (self.uv_values.len() - 1) as u32
    }

    fn ring_uvs(&mut self, tex_v: f32) -> [u32; 5] {
        [0, 1, 2, 3, 4].map(|k| self.uv(Vec2::new(k as f32 / 4.0, tex_v)))
    }

    fn quad(&mut self, v: [u32; 4], uv: [u32; 4]) {
        self.indices.extend_from_slice(&v);
        self.uv_indices.extend_from_slice(&uv);
        self.owner.push(self.cur);
    }

    /// `v` of a ring at `center` following `prev`.
    fn next_tex_v(prev: &Ring, center: Vec3, rho: f32) -> f32 {
        let c = TAU * 0.5 * (prev.rho + rho);
        prev.tex_v + center.distance(prev.center) / c.max(1e-12)
    }

    /// A square section perpendicular to `normal` at `center`, corner 0 along `up`
    /// projected into its plane.
    fn ring_perp(&mut self, center: Vec3, normal: Vec3, up: Vec3, rho: f32, tex_v: f32) -> Ring {
        let a = perp(up, normal);
        let b = normal.cross(a);
        let v = [a, b, -a, -b].map(|o| self.vertex(center + o * rho));
        Ring { v, uv: self.ring_uvs(tex_v), center, normal, up: a, rho, tex_v }
    }

    /// The normal-connection section (J §3.3): the square perpendicular to `d` at
    /// `center`, each corner projected along `d` onto the plane with normal `h` (tilt
    /// compensation: corners stay on the tube of direction `d`).
    fn ring_miter(&mut self, center: Vec3, d: Vec3, h: Vec3, up: Vec3, rho: f32, tex_v: f32) -> Ring {
        let a = perp(up, d);
        let b = d.cross(a);
        let cos = d.dot(h).max(0.2);
        let v = [a, b, -a, -b].map(|o| {
            let q = o * rho;
            self.vertex(center + q - d * (q.dot(h) / cos))
        });
        Ring { v, uv: self.ring_uvs(tex_v), center, normal: h, up: perp(a, h), rho, tex_v }
    }

    /// The tube of an internode from ring `r` to ring `e`: one band, or with
    /// [`QuadOptions::support`] two, through a support ring of the end ring's size and
    /// corner orientation ([`Self::corner_up`]) `g·ρ` before the end section's reach along the tube (a tilted
    /// section's corners reach `ρ·tan α` along it), where the tube has room for it with
    /// `g·ρ` to spare; the tube's taper and twist stay on the long first band. There is
    /// no support ring at the start: one there (after a box's side face or a section)
    /// made `lsys-abop-c`'s planar whorls cross 770 times at level 2 instead of 60, and
    /// `mig-e`'s 288 times instead of 54, while end rings alone took `mig-m` from 260 to
    /// 110 and `mig-b` from 396 to 158 (after `decollide`).
    fn tube(&mut self, r: &Ring, e: &Ring) {
        let g = self.opts.support;
        let axis = e.center - r.center;
        let len = axis.length();
        if g <= 0.0 || len <= 0.0 || !len.is_finite() {
            self.band(r, e);
            return;
        }
        let d = axis / len;
        // How far a section's corners reach along the tube: ρ·tan of its tilt.
        let reach = |s: &Ring| {
            let c = s.normal.dot(d).abs().max(0.2);
            s.rho * (1.0 - c * c).max(0.0).sqrt() / c
        };
        let a = reach(e) + g * e.rho;
        // The start section's reach, which the ring must clear too.
        if len < reach(r) + a + g * r.rho.max(e.rho) {
            self.band(r, e);
            return;
        }
        let t = 1.0 - a / len;
        let up = self.corner_up(e, d);
        let m = self.ring_perp(r.center + d * (len - a), d, up, e.rho, r.tex_v + (e.tex_v - r.tex_v) * t);
        self.band(r, &m);
        self.band(&m, e);
    }

    /// Corner 0's direction for a ring perpendicular to `d` whose corners follow ring
    /// `e`'s corners seen along `d`: the unit `a` maximising `Σ_k ĉ_k · R^k a`, with `ĉ_k`
    /// corner `k`'s direction from `e`'s centre projected off `d` and `R` the quarter
    /// turn about `d` (corner `k + 1` of [`Self::ring_perp`] is corner `k` turned by `R`),
    /// i.e. `normalize(ĉ₀ − d × ĉ₁ − ĉ₂ + d × ĉ₃)`. For a mitre section (the end of a
    /// bend, [`Self::ring_miter`]) that is exactly its perpendicular square's corner 0.
    /// Projecting `e.up` instead — the up corner projected into the tilted plane, then
    /// back off `d` — turns the ring by up to ~10° on a bend out of the corner's plane
    /// (4.7°–9.6° at 46°–67° bends), twisting the last band. `perp(e.up, d)` when the
    /// corners are degenerate.
    fn corner_up(&self, e: &Ring, d: Vec3) -> Vec3 {
        let c = e.v.map(|i| {
            let o = self.positions[i as usize] - e.center;
            (o - d * o.dot(d)).normalize_or_zero()
        });
        let a = c[0] - d.cross(c[1]) - c[2] + d.cross(c[3]);
        let a = a - d * a.dot(d);
        if a.length_squared() > 1e-12 {
            a.normalize()
        } else {
            perp(e.up, d)
        }
    }

    /// The four band quads from ring `a` to ring `b`.
    fn band(&mut self, a: &Ring, b: &Ring) {
        for k in 0..4 {
            let k1 = (k + 1) % 4;
            self.quad([a.v[k], a.v[k1], b.v[k1], b.v[k]], [a.uv[k], a.uv[k + 1], b.uv[k + 1], b.uv[k]]);
        }
    }

    /// Closes `r` with one quad facing along its normal (`outward`) or against it.
    fn cap(&mut self, r: &Ring, outward: bool) {
        let uv = [Vec2::new(1.0, 0.5), Vec2::new(0.5, 1.0), Vec2::new(0.0, 0.5), Vec2::new(0.5, 0.0)]
            .map(|p| self.uv(p));
        if outward {
            self.quad(r.v, uv);
        } else {
            self.quad([r.v[3], r.v[2], r.v[1], r.v[0]], [uv[3], uv[2], uv[1], uv[0]]);
        }
    }

    fn fallback(&mut self, node: u32, reason: FallbackReason) {
        self.fallbacks.push(QuadFallback { node, reason });
    }

    /// A root: a capped start ring, then its child (or a box for several children).
    pub(super) fn root(&mut self, root: u32) {
        self.cur = root;
        let kids = self.kids_for(root, Vec3::Y);
        let Some(&k0) = kids.first() else { return };
        let p = self.pos(root);
        let d0 = unit_or(self.pos(k0) - p, Vec3::Y);
        let rho = self.rho(root);
        let up = self.sk.up[k0 as usize];
        let ring = self.ring_perp(p, d0, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        if kids.len() == 1 {
            self.stack.push(Task::Segment { ring, node: k0 });
        } else {
            self.cases.boxes += 1;
            self.junction(ring, d0, root, &kids, 0);
        }
    }

    /// A detached subtree: a capped start ring at the parent node, then the child.
    fn detach(&mut self, node: u32) {
        self.cur = node;
        let parent = self.sk.parent[node as usize];
        let from = if parent == NO_PARENT { self.pos(node) } else { self.pos(parent) };
        let d = unit_or(self.pos(node) - from, Vec3::Y);
        let rho = if parent == NO_PARENT { self.rho(node) } else { self.rho(node).min(self.rho(parent)) };
        let up = self.sk.up[node as usize];
        let ring = self.ring_perp(from, d, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        self.stack.push(Task::Segment { ring, node });
    }

    /// A separated subtree (see [`FallbackReason::Separated`]): a capped start ring of
    /// the child's size on the child's axis, far enough out that it keeps
    /// `GAP_MARGIN × (ρ_axis + ρ_child)` from the parent node and from the parent's
    /// incoming and leading axes (each a half-line from the node), at most 3/4 of the way
    /// to the child.
    fn separate(&mut self, node: u32) {
        self.cur = node;
        let parent = self.sk.parent[node as usize];
        let pp = self.pos(parent);
        let to = self.pos(node) - pp;
        let dk = unit_or(to, Vec3::Y);
        let rho = self.rho(node);
        let rp = self.rho(parent);
        let mut t = GAP_MARGIN * (rp + rho);
        let gp = self.sk.parent[parent as usize];
        let lead = self.lead[parent as usize];
        let axes = [
            (gp != NO_PARENT).then(|| (unit_or(self.pos(gp) - pp, Vec3::ZERO), rp)),
            (lead != NONE && lead != node)
                .then(|| (unit_or(self.pos(lead) - pp, Vec3::ZERO), rp.max(self.rho(lead)))),
        ];
        for (a, ra) in axes.into_iter().flatten() {
            let c = dk.dot(a);
            if c > 0.0 {
                let sin = (1.0 - c * c).max(0.0).sqrt().max(0.05);
                t = t.max(GAP_MARGIN * (ra + rho) / sin);
            }
        }
        let t = t.min(0.75 * to.length());
        let up = self.sk.up[node as usize];
        let ring = self.ring_perp(pp + dk * t, dk, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        self.stack.push(Task::Segment { ring, node });
    }

    /// The internode from `r` to `node` and the structure at `node` (J §3.2 cases).
    fn segment(&mut self, r: Ring, node: u32) {
        self.cur = node;
        let p = self.pos(node);
        let rho = self.rho(node);
        let min_len = self.min_len(rho.max(r.rho));
        let v = p - r.center;
        let along = v.dot(r.normal);
        let short = along < min_len;
        let d = if short { r.normal } else { unit_or(v, r.normal) };
        let kids = self.kids_for(node, d);
        if short {
            let parent = self.sk.parent[node as usize];
            let internode = if parent == NO_PARENT { 0.0 } else { p.distance(self.pos(parent)) };
            if internode >= min_len {
                self.fallback(node, FallbackReason::Short);
            } else {
                self.merged.push(node);
            }
            // A lone child the start ring also faces away from (a hairpin) is not carried
            // on: carrying `r` past a turn back would skip node after node (`mgv-r`: a
            // 38-node chain became one tube from the root to a branch 4.8 m away). The
            // tube ends here and the child starts its own cage.
            let hairpin = match kids[..] {
                [k] => (self.pos(k) - r.center).dot(r.normal) < self.min_len(self.rho(k).max(r.rho)),
                _ => false,
            };
            if hairpin {
                self.fallback(kids[0], FallbackReason::Detached);
                self.stack.push(Task::Detach { node: kids[0] });
            }
            match kids.len() {
                _ if hairpin || kids.is_empty() => {
                    let c = r.center + r.normal * min_len;
                    let tv = Self::next_tex_v(&r, c, rho);
                    let e = self.ring_perp(c, r.normal, r.up, rho, tv);
                    self.tube(&r, &e);
                    self.cap(&e, true);
                    self.cases.end_caps += 1;
                }
                1 => self.stack.push(Task::Segment { ring: r, node: kids[0] }),
                _ => {
                    let d0 = unit_or(self.pos(kids[0]) - p, r.normal);
                    if d0.dot(r.normal) <= 0.0 {
                        self.cases.backward += 1;
                        let len = 2.0 * self.rho(kids[0]);
                        self.backward_box(r, node, &kids, len);
                    } else {
                        self.cases.boxes += 1;
                        self.junction(r, r.normal, node, &kids, 0);
                    }
                }
            }
            return;
        }
        if let [k] = kids[..] {
            // Merge: a section at `node` would cross the start ring inside the tube when
            // the internode is shorter than the two sections' tilts reach along it.
            let d0 = unit_or(self.pos(k) - p, d);
            let tilt = |c: f32| (1.0 - c * c).max(0.0).sqrt() / c.max(0.5);
            let half = ((1.0 + d.dot(d0).max(0.0)) * 0.5).sqrt();
            let reach = rho.max(r.rho) * (tilt(r.normal.dot(d)) + tilt(half)) + min_len;
            // Merged only when the child lies ahead of the start ring (see the hairpin
            // above); otherwise the node gets its own section.
            let ahead = (self.pos(k) - r.center).dot(r.normal) >= self.min_len(self.rho(k).max(r.rho));
            if along < reach && ahead {
                self.merged.push(node);
                self.stack.push(Task::Segment { ring: r, node: k });
                return;
            }
        }
        let Some(&k0) = kids.first() else {
            // (a) End cap.
            let tv = Self::next_tex_v(&r, p, rho);
            let e = self.ring_perp(p, d, r.up, rho, tv);
            self.tube(&r, &e);
            self.cap(&e, true);
            self.cases.end_caps += 1;
            return;
        };
        let d0 = unit_or(self.pos(k0) - p, d);
        let rho0 = self.rho(k0);
        if d0.dot(d) <= 0.0 {
            // (c) Connect backward (J §3.4): middle ring d₁ back from the node, end ring
            // r₁ beyond it; all children on the sides of the box between them.
            self.cases.backward += 1;
            let len = v.length();
            let mid = (len - 2.0 * rho0).max(0.5 * len);
            let m = if mid >= min_len {
                let c = r.center + d * mid;
                let tv = Self::next_tex_v(&r, c, rho);
                let m = self.ring_perp(c, d, r.up, rho, tv);
                self.tube(&r, &m);
                m
            } else {
                r
            };
            let box_len = (len + rho0 - m.center.distance(r.center)).max(min_len);
            self.backward_box(m, node, &kids, box_len);
            return;
        }
        let h = unit_or(d + d0, d);
        if kids.len() == 1 {
            // (b) Normal connection (J §3.3).
            self.cases.normal += 1;
            let tv = Self::next_tex_v(&r, p, rho);
            let e = self.ring_miter(p, d, h, r.up, rho, tv);
            self.tube(&r, &e);
            self.stack.push(Task::Segment { ring: e, node: k0 });
            return;
        }
        // (d) Connect branches (J §3.5): the end ring, pulled back by (l + x)/2.
        self.cases.boxes += 1;
        let lx = self.eq4(&kids, d, d0);
        // Pull back by (l + x)/2, but never to within `min_len` of the start ring.
        let back = if self.opts.pull_back { (0.5 * lx).min(along - min_len) } else { 0.0 };
        let e = if back >= 0.0 {
            let c = p - d * back;
            let tv = Self::next_tex_v(&r, c, rho);
            let up = self.box_up(r.up, d, h, p, &kids);
            let e = self.ring_miter(c, d, h, up, rho, tv);
            self.tube(&r, &e);
            e
        } else {
            r
        };
        self.junction(e, d, node, &kids, 0);
    }

    /// The elbow of a side child (see [`QuadOptions::elbow_angle`]): when `kid` leaves
    /// the side face `r` more than the elbow angle from its normal, a ring of the child's
    /// size perpendicular to the half direction of the face normal and the child, a short
    /// neck (`ρ_child·sin β + ρ_face/2`, β the ring's tilt, at most 0.3 of the way to the
    /// child) out of the face. Returns the ring the child's tube starts from.
    fn elbow(&mut self, r: Ring, kid: u32) -> Ring {
        let p = self.pos(kid);
        let to = p - r.center;
        let dk = unit_or(to, r.normal);
        if dk.dot(r.normal) >= self.cos_elbow {
            return r;
        }
        let rho = self.rho(kid);
        let h = unit_or(r.normal + dk, r.normal);
        // The ring is tilted by β = ∠(h, face normal): its low corners dip ρ·sin β back
        // towards the face, so the neck clears that plus half the face's size.
        let sin_b = h.cross(r.normal).length();
        let len = (rho * sin_b + 0.5 * r.rho).min(0.3 * to.length());
        if len < 2.0 * self.min_len(rho.max(r.rho)) {
            return r;
        }
        let c = r.center + h * len;
        let tv = Self::next_tex_v(&r, c, rho);
        let e = self.ring_perp(c, h, r.up, rho, tv);
        let at = std::mem::replace(&mut self.cur, kid);
        self.band(&r, &e);
        self.cur = at;
        self.cases.elbows += 1;
        e
    }

    /// Up vector of a junction box's base ring, turned about the internode so that the
    /// side faces look at the side children (`kids[1..]`) as squarely as possible: of 24
    /// turns over the square's 90° period, the one with the largest sum over side
    /// children of the cosine to their best face normal (a child sharing a face with an
    /// earlier one, which would need a chained box, counts −1). Of the four equivalent
    /// labellings of that square, the one closest to the incoming `up` is returned, so
    /// the band before the box twists by at most 45°. Without the turn a child may leave
    /// its face up to 45° further off its normal.
    fn box_up(&self, up: Vec3, d: Vec3, h: Vec3, p: Vec3, kids: &[u32]) -> Vec3 {
        let dirs: Vec<Vec3> = kids[1..].iter().map(|&k| unit_or(self.pos(k) - p, Vec3::ZERO)).collect();
        let cur = perp(up, d);
        let x = perp(cur, h);
        let y = h.cross(x);
        let score = |psi: f32| {
            let (sin, cos) = psi.sin_cos();
            // Face normals at ψ, ψ + 90°, ψ + 180°, ψ + 270°.
            let n0 = x * cos + y * sin;
            let n1 = h.cross(n0);
            let normals = [n0, n1, -n0, -n1];
            let mut used = [false; 4];
            let mut total = 0.0;
            for &dk in &dirs {
                let (best, dot) = (0..4).map(|k| (k, normals[k].dot(dk))).fold((0, f32::MIN), |a, v| {
                    if v.1 > a.1 {
                        v
                    } else {
                        a
                    }
                });
                total += if used[best] { -1.0 } else { dot };
                used[best] = true;
            }
            total
        };
        // ψ is the azimuth of face 0's normal about h, measured from `x`.
        let steps = 24;
        let psi = (0..steps)
            .map(|i| std::f32::consts::FRAC_PI_2 * i as f32 / steps as f32)
            .fold((0.0f32, f32::MIN), |a, psi| {
                let sc = score(psi);
                if sc > a.1 + 1e-6 {
                    (psi, sc)
                } else {
                    a
                }
            })
            .0;
        // Face 0's normal lies halfway between corners 0 and 1: corner 0 at ψ − 45°.
        let t = psi - std::f32::consts::FRAC_PI_4;
        let a = perp(x * t.cos() + y * t.sin(), d);
        let b = d.cross(a);
        [a, b, -a, -b].into_iter().fold(a, |best, c| if c.dot(cur) > best.dot(cur) { c } else { best })
    }

    /// `l + x` for `kids` (sorted) leaving a base of normal `n` towards `d0`.
    fn eq4(&self, kids: &[u32], n: Vec3, d0: Vec3) -> f32 {
        let dia: Vec<f32> = kids.iter().map(|&k| 2.0 * self.rho(k)).collect();
        let half = 0.5 * n.dot(d0).clamp(-1.0, 1.0).acos();
        box_length(self.opts.box_length, &dia, half)
    }

    /// A junction box on base ring `e` at branching node `node` (J §3.5): the box runs
    /// along the half direction of `base` (the parent's direction) and the first child;
    /// the first child continues from the box top, the others go to its sides.
    fn junction(&mut self, e: Ring, base: Vec3, node: u32, kids: &[u32], depth: u32) {
        let k0 = kids[0];
        let p = self.pos(node);
        let d0 = unit_or(self.pos(k0) - p, base);
        let mut h = if d0.dot(base) > 0.0 { unit_or(base + d0, base) } else { base };
        if h.dot(e.normal) < 0.1 {
            // The box top must face the same way as its base, or the sides fold.
            h = e.normal;
        }
        let rho0 = self.rho(k0);
        let mut lx = self.eq4(kids, base, d0).max(self.min_len(e.rho));
        // The first child must outrun its box (J §3.5); when it does not, shorten the box
        // to end before the child's node, down to a quarter of its Eq. 4 length.
        // Twice `min_len`: the child's tube then clears the short-node test with margin.
        let reach = (self.pos(k0) - e.center).dot(h) - 2.0 * self.min_len(rho0);
        if reach < lx {
            let floor = (0.25 * lx).max(self.min_len(e.rho));
            if reach >= floor {
                self.fallback(k0, FallbackReason::ShortBox);
            }
            lx = reach.max(floor);
        }
        let c = e.center + h * lx;
        let tv = Self::next_tex_v(&e, c, rho0);
        let t = self.ring_perp(c, h, e.up, rho0, tv);
        self.sides(&e, &t, node, &kids[1..], depth, (base, Some(d0)));
        self.stack.push(Task::Segment { ring: t, node: k0 });
    }

    /// The backward box (J §3.4) on base `m`, `len` long along its normal, top capped,
    /// every child on its sides.
    fn backward_box(&mut self, m: Ring, node: u32, kids: &[u32], len: f32) {
        let rho = self.rho(node);
        let c = m.center + m.normal * len;
        let tv = Self::next_tex_v(&m, c, rho);
        let top = self.ring_perp(c, m.normal, m.up, rho, tv);
        self.cap(&top, true);
        self.sides(&m, &top, node, kids, 0, (m.normal, None));
    }

    /// Side faces `[B_k, B_k+1, T_k+1, T_k]` of the box `b → t`: `kids` (sorted) are
    /// assigned to the face whose outward normal is most aligned with them; used faces
    /// start their children (a chained box for several), unused ones are closed.
    /// `dirs`: the parent internode's direction and the first child's (none for a
    /// backward box).
    fn sides(&mut self, b: &Ring, t: &Ring, node: u32, kids: &[u32], depth: u32, dirs: (Vec3, Option<Vec3>)) {
        let (parent_dir, first) = dirs;
        let mut faces = [[0u32; 4]; 4];
        let mut normals = [Vec3::ZERO; 4];
        for k in 0..4 {
            let k1 = (k + 1) % 4;
            faces[k] = [b.v[k], b.v[k1], t.v[k1], t.v[k]];
            normals[k] = quad_normal(faces[k].map(|i| self.positions[i as usize]));
        }
        let p = self.pos(node);
        let axis = unit_or(t.center - b.center, b.normal);
        let (cos_aligned, cos_reversed) = (ALIGNED_DEG.to_radians().cos(), REVERSED_DEG.to_radians().cos());
        let mut sets: [Vec<u32>; 4] = Default::default();
        for &kid in kids {
            let dk = unit_or(self.pos(kid) - p, Vec3::ZERO);
            let (best, dot) =
                (0..4)
                    .map(|k| (k, normals[k].dot(dk)))
                    .fold((0, f32::MIN), |a, x| if x.1 > a.1 { x } else { a });
            // Beyond `max_side_angle` a child runs along the box: it may still leave
            // through an elbow when it points back, or forward but clear of the first
            // child's direction (≥ ALIGNED_DEG away); inside the first child's tube or
            // the parent's, or along a backward box's capped top, it is detached.
            let back = dk.dot(axis) < 0.0 && -dk.dot(parent_dir) < cos_reversed;
            let clear = first.is_some_and(|f| f.dot(dk) < cos_aligned);
            let limit = if back || clear { self.cos_back } else { self.cos_side };
            if dot >= limit && dk != Vec3::ZERO {
                sets[best].push(kid);
            } else {
                self.fallback(kid, FallbackReason::Detached);
                self.stack.push(Task::Detach { node: kid });
            }
        }
        for k in 0..4 {
            let k1 = k + 1;
            let uv = [b.uv[k], b.uv[k1], t.uv[k1], t.uv[k]];
            if sets[k].is_empty() {
                self.quad(faces[k], uv);
                continue;
            }
            let corners = faces[k].map(|i| self.positions[i as usize]);
            let center = (corners[0] + corners[1] + corners[2] + corners[3]) * 0.25;
            let up = perp(corners[0] - center, normals[k]);
            let rho = corners.iter().map(|c| c.distance(center)).sum::<f32>() * 0.25;
            let ring = Ring {
                v: faces[k],
                uv: self.ring_uvs(b.tex_v),
                center,
                normal: normals[k],
                up,
                rho: rho.max(self.floor),
                tex_v: b.tex_v,
            };
            let set = std::mem::take(&mut sets[k]);
            if set.len() == 1 {
                let ring = self.elbow(ring, set[0]);
                self.stack.push(Task::Segment { ring, node: set[0] });
            } else if depth < self.opts.max_chain {
                self.cases.chained += 1;
                self.junction(ring, ring.normal, node, &set, depth + 1);
            } else {
                // Out of chained boxes: the first child takes the face, the rest detach.
                self.stack.push(Task::Segment { ring, node: set[0] });
                for &kid in &set[1..] {
                    self.fallback(kid, FallbackReason::ChainLimit);
                    self.stack.push(Task::Detach { node: kid });
                }
            }
        }
    }
}
