//! From grown nodes to a [`Skeleton`]: pipe-model radii (Runions2007 §5, Shinozaki1964),
//! branch orders (the child carrying the largest pipe keeps the order), up vectors by
//! parallel transport, and leaf organs on the last nodes of every tip
//! (`docs/colonize.md`, "Output conventions").

use super::growth::Growth;
use super::params::bad;
use super::{ColonizeParams, MAX_LEAVES};
use crate::error::Result;
use crate::geometry::NONE;
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DQuat, DVec3};
use rand::RngExt;
use rand_pcg::Pcg64;

impl Growth {
    /// Radii, orders, up vectors and leaves; returns the skeleton and its tip count.
    pub(super) fn skeleton(&self, p: &ColonizeParams, rng: &mut Pcg64) -> Result<(Skeleton, usize)> {
        let n = self.pos.len();
        // Pipe model, bottom-up in f64.
        let e = p.pipe_exponent;
        let tip_w = p.tip_radius.powf(e);
        let mut w = vec![0.0f64; n];
        for i in (0..n).rev() {
            if self.first_child[i] == NONE {
                w[i] = tip_w;
            }
            let par = self.parent[i];
            if par != NONE {
                w[par as usize] += w[i];
            }
        }
        // Incoming unit directions (root: towards its first child, else +Y).
        let mut t_in = vec![DVec3::Y; n];
        for (i, t) in t_in.iter_mut().enumerate().skip(1) {
            let par = self.parent[i] as usize;
            *t = (self.pos[i] - self.pos[par]).try_normalize().unwrap_or(DVec3::Y);
        }
        if n > 1 && self.first_child[0] != NONE {
            t_in[0] = t_in[self.first_child[0] as usize];
        }
        // Orders, parent-first: the main child keeps the order.
        let mut order = vec![0u16; n];
        for i in 0..n {
            let mut main = NONE;
            let mut ch = self.first_child[i];
            while ch != NONE {
                let c = ch as usize;
                let better = main == NONE || {
                    let m = main as usize;
                    w[c] > w[m] || (w[c] == w[m] && t_in[c].dot(t_in[i]) > t_in[m].dot(t_in[i]))
                };
                if better {
                    main = ch;
                }
                ch = self.next_sibling[c];
            }
            let mut ch = self.first_child[i];
            while ch != NONE {
                let c = ch as usize;
                order[c] = if ch == main { order[i] } else { order[i].saturating_add(1) };
                ch = self.next_sibling[c];
            }
        }
        // Up vectors by parallel transport.
        let mut up = vec![DVec3::X; n];
        if n > 0 {
            up[0] = perpendicular(t_in[0]);
        }
        for i in 1..n {
            let par = self.parent[i] as usize;
            let rot = DQuat::from_rotation_arc(t_in[par], t_in[i]);
            let u = rot * up[par];
            let u = u - t_in[i] * u.dot(t_in[i]);
            up[i] = u.try_normalize().unwrap_or_else(|| perpendicular(t_in[i]));
        }
        let mut sk = Skeleton::new();
        sk.position.reserve(n);
        for i in 0..n {
            let par = if self.parent[i] == NONE { NO_PARENT } else { self.parent[i] };
            sk.push(self.pos[i].as_vec3(), w[i].powf(1.0 / e) as f32, par, up[i].as_vec3(), order[i]);
        }
        let tips = (1..n).filter(|&i| self.first_child[i] == NONE).count();
        self.leaves(p, &t_in, &up, &mut sk, rng)?;
        Ok((sk, tips))
    }

    /// Leaf organs on the last `leaves.nodes` nodes of every tip.
    fn leaves(
        &self,
        p: &ColonizeParams,
        t_in: &[DVec3],
        up: &[DVec3],
        sk: &mut Skeleton,
        rng: &mut Pcg64,
    ) -> Result<()> {
        let l = &p.leaves;
        let n = self.pos.len();
        if l.count == 0 || l.nodes == 0 || l.size <= 0.0 || n < 2 {
            return Ok(());
        }
        let mut leafy = vec![false; n];
        let mut total = 0usize;
        for tip in 1..n {
            if self.first_child[tip] != NONE {
                continue;
            }
            let mut v = tip;
            for k in 0..l.nodes {
                if self.parent[v] == NONE {
                    break;
                }
                // Beyond the tip, only unbranched nodes (one child).
                if k > 0 && (self.next_sibling[self.first_child[v] as usize] != NONE) {
                    break;
                }
                if !leafy[v] {
                    leafy[v] = true;
                    total += l.count as usize;
                }
                v = self.parent[v] as usize;
            }
        }
        if total > MAX_LEAVES {
            return bad(
                "leaves.count",
                format!("would place {total} leaves, over the budget of {MAX_LEAVES}; lower generator.leaves.count or generator.leaves.nodes"),
            );
        }
        sk.organs.reserve(total);
        const GOLDEN: f64 = 2.399_963_229_728_653; // π (3 − √5)
        let alpha = l.angle.to_radians();
        for i in 0..n {
            if !leafy[i] {
                continue;
            }
            let t = t_in[i];
            let u = up[i];
            let b = t.cross(u);
            let par = self.parent[i] as usize;
            let seg = (self.pos[i] - self.pos[par]).length();
            let phase = rng.random::<f64>() * std::f64::consts::TAU;
            for k in 0..l.count {
                let phi = phase + GOLDEN * k as f64;
                let side = u * phi.cos() + b * phi.sin();
                let heading = t * alpha.cos() + side * alpha.sin();
                let x = t.cross(side);
                let mut normal = x.cross(heading);
                if normal.y < 0.0 {
                    normal = -normal;
                }
                let along = seg * k as f64 / l.count as f64;
                let jitter = 1.0 + l.size_variation * (2.0 * rng.random::<f64>() - 1.0);
                sk.organs.push(Organ {
                    kind: OrganKind::Leaf,
                    node: i as u32,
                    position: (self.pos[i] - t * along).as_vec3(),
                    heading: heading.as_vec3(),
                    up: normal.as_vec3(),
                    size: (l.size * jitter) as f32,
                    material: 0,
                });
            }
        }
        Ok(())
    }
}

/// A stable unit vector perpendicular to the unit vector `t`.
pub(super) fn perpendicular(t: DVec3) -> DVec3 {
    let a = if t.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
    (a - t * a.dot(t)).try_normalize().unwrap_or(DVec3::Z)
}
