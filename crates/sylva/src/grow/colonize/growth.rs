//! The colonization iteration (Runions2007 §3, Fig. 3): association of attraction points
//! with their closest node, one new node per attracted node, kills. Each new node asks a
//! `kiddo` k-d tree over the live points (Morton-ordered) for those within the influence
//! radius, which gives the paper's association and kill sets at every iteration
//! (`docs/colonize.md`, "Neighbour queries").

use super::params::bad;
use super::{ColonizeParams, DUPLICATE_ANGLE_DEG};
use crate::error::{Error, Result};
use crate::geometry::NONE;
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::RngExt;
use rand_pcg::Pcg64;

/// The k-d tree is rebuilt from the live points when more than 1/REBUILD of its points are dead.
const REBUILD: usize = 4;

/// The growing tree and its attraction points.
pub(super) struct Growth {
    // Nodes.
    pub(super) pos: Vec<DVec3>,
    pub(super) parent: Vec<u32>,
    /// Growth direction before perturbation (duplicate test), per node.
    dir0: Vec<DVec3>,
    pub(super) first_child: Vec<u32>,
    pub(super) next_sibling: Vec<u32>,
    /// Per node: sum of unit directions to its attractors, and their count.
    sum: Vec<DVec3>,
    count: Vec<u32>,
    // Attraction points.
    /// The attraction points, in Morton order (see [`spatial_order`]).
    pub(super) pts: Vec<Point>,
    /// Live points in increasing index order (compacted once per iteration).
    pub(super) live: Vec<u32>,
    /// k-d tree over a subset of the points (item = index into `tree_items`).
    tree: Option<ImmutableKdTree<f64, 3>>,
    tree_items: Vec<u32>,
    tree_dead: usize,
    // Parameters.
    di2: f64,
    dk2: f64,
    step: f64,
    max_nodes: usize,
    // Results.
    pub(super) iterations: u32,
    pub(super) stalled: bool,
}

impl Growth {
    pub(super) fn new(p: &ColonizeParams, pts: Vec<DVec3>) -> Result<Growth> {
        let n = pts.len();
        let mut g = Growth {
            pos: Vec::new(),
            parent: Vec::new(),
            dir0: Vec::new(),
            first_child: Vec::new(),
            next_sibling: Vec::new(),
            sum: Vec::new(),
            count: Vec::new(),
            live: (0..n as u32).collect(),
            pts: spatial_order(&pts)
                .into_iter()
                .map(|i| Point { p: pts[i as usize], best: f64::INFINITY, closest: NONE, alive: true })
                .collect(),
            tree: None,
            tree_items: Vec::new(),
            tree_dead: 0,
            di2: p.influence_radius * p.influence_radius,
            dk2: p.kill_distance * p.kill_distance,
            step: p.segment_length,
            max_nodes: p.max_nodes,
            iterations: 0,
            stalled: false,
        };
        g.rebuild_tree()?;
        Ok(g)
    }

    fn rebuild_tree(&mut self) -> Result<()> {
        self.tree_items.clear();
        self.tree_items.extend(self.live.iter().copied().filter(|&i| self.pts[i as usize].alive));
        self.tree_dead = 0;
        if self.tree_items.is_empty() {
            self.tree = None;
            return Ok(());
        }
        let coords: Vec<[f64; 3]> =
            self.tree_items.iter().map(|&i| self.pts[i as usize].p.to_array()).collect();
        let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&coords).map_err(|e| {
            Error::InvalidGeometry { what: "space colonization".into(), why: format!("k-d tree: {e:?}") }
        })?;
        self.tree = Some(tree);
        Ok(())
    }

    pub(super) fn add_node(&mut self, pos: DVec3, parent: u32, dir0: DVec3) -> Result<u32> {
        let i = self.pos.len();
        if i >= self.max_nodes {
            return bad(
                "max_nodes",
                format!(
                    "budget of {} nodes is exhausted; raise generator.max_nodes or lower \
                     generator.points / raise generator.segment_length",
                    self.max_nodes
                ),
            );
        }
        self.pos.push(pos);
        self.parent.push(parent);
        self.dir0.push(dir0);
        self.first_child.push(NONE);
        self.next_sibling.push(NONE);
        self.sum.push(DVec3::ZERO);
        self.count.push(0);
        if parent != NONE {
            // Append at the end of the parent's child list (keeps creation order).
            let p = parent as usize;
            match self.first_child[p] {
                NONE => self.first_child[p] = i as u32,
                mut c => {
                    while self.next_sibling[c as usize] != NONE {
                        c = self.next_sibling[c as usize];
                    }
                    self.next_sibling[c as usize] = i as u32;
                }
            }
        }
        Ok(i as u32)
    }

    /// Associates the points near nodes `from..` with them, or kills them.
    pub(super) fn visit_new_nodes(&mut self, from: usize) -> Result<()> {
        let Some(tree) = &self.tree else { return Ok(()) };
        let (di2, dk2) = (self.di2, self.dk2);
        let mut dead = 0usize;
        for k in from..self.pos.len() {
            let q = self.pos[k];
            let (pts, items) = (&mut self.pts, &self.tree_items);
            tree.query(&q.to_array()).within::<SquaredEuclidean<f64>>(di2).unsorted().visit(|r| {
                let pt = &mut pts[items[r.item as usize] as usize];
                if !pt.alive {
                    return;
                }
                let d2 = (pt.p - q).length_squared();
                if d2 <= dk2 {
                    pt.alive = false;
                    dead += 1;
                } else if d2 <= di2 && d2 < pt.best {
                    pt.best = d2;
                    pt.closest = k as u32;
                }
            });
        }
        self.tree_dead += dead;
        if self.tree_dead * REBUILD > self.tree_items.len() {
            self.live.retain(|&i| self.pts[i as usize].alive);
            self.rebuild_tree()?;
        }
        Ok(())
    }

    pub(super) fn run(&mut self, p: &ColonizeParams, top: f64, rng: &mut Pcg64) -> Result<()> {
        // Root and straight trunk.
        self.add_node(DVec3::ZERO, NONE, DVec3::Y)?;
        let trunk = p.trunk_segments() as usize;
        for k in 0..trunk {
            let q = DVec3::new(0.0, self.step * (k + 1) as f64, 0.0);
            self.add_node(q, k as u32, DVec3::Y)?;
        }
        self.visit_new_nodes(0)?;
        let mut leader = self.pos.len() as u32 - 1;
        let mut reached = false;
        let tropism = DVec3::from_array(p.tropism).normalize_or_zero() * p.tropism_weight;
        let dup_cos = DUPLICATE_ANGLE_DEG.to_radians().cos();
        let mut touched: Vec<u32> = Vec::new();
        loop {
            self.live.retain(|&i| self.pts[i as usize].alive);
            if self.live.is_empty() || self.iterations >= p.max_iterations {
                break;
            }
            // Association: sum of unit directions per node, in point index order.
            touched.clear();
            for &i in &self.live {
                let pt = &self.pts[i as usize];
                let c = pt.closest;
                if c == NONE {
                    continue;
                }
                let c = c as usize;
                let v = (pt.p - self.pos[c]) / pt.best.sqrt();
                if self.count[c] == 0 {
                    touched.push(c as u32);
                    self.sum[c] = DVec3::ZERO;
                }
                self.sum[c] += v;
                self.count[c] += 1;
            }
            let first_new = self.pos.len();
            if touched.is_empty() {
                if reached || self.pos[leader as usize].y > top {
                    self.stalled = true;
                    break;
                }
                // No point near any node yet: extend the leader straight up.
                let q = self.pos[leader as usize] + DVec3::Y * self.step;
                leader = self.add_node(q, leader, DVec3::Y)?;
            } else {
                reached = true;
                touched.sort_unstable();
                for &c in &touched {
                    let c = c as usize;
                    let (s, n) = (self.sum[c], self.count[c]);
                    self.count[c] = 0;
                    let len = s.length();
                    if len.is_nan() || len <= 1e-9 * n as f64 {
                        continue; // attractors on opposite sides cancel: no direction
                    }
                    let mut d = s / len;
                    if tropism != DVec3::ZERO {
                        let t = d + tropism;
                        let l = t.length();
                        if l.is_nan() || l <= 1e-9 {
                            continue;
                        }
                        d = t / l;
                    }
                    let mut ch = self.first_child[c];
                    let mut dup = false;
                    while ch != NONE {
                        if self.dir0[ch as usize].dot(d) > dup_cos {
                            dup = true;
                            break;
                        }
                        ch = self.next_sibling[ch as usize];
                    }
                    if dup {
                        continue;
                    }
                    let mut g = d;
                    if p.perturbation > 0.0 {
                        g = (d + random_unit(rng) * p.perturbation).try_normalize().unwrap_or(d);
                    }
                    let q = self.pos[c] + g * self.step;
                    self.add_node(q, c as u32, d)?;
                }
                if self.pos.len() == first_new {
                    self.stalled = true;
                    break;
                }
            }
            self.iterations += 1;
            self.visit_new_nodes(first_new)?;
        }
        self.live.retain(|&i| self.pts[i as usize].alive);
        Ok(())
    }
}

/// One attraction point and its association.
pub(super) struct Point {
    pub(super) p: DVec3,
    /// Squared distance to `closest`.
    best: f64,
    /// Closest node within the influence radius, or `NONE`.
    pub(super) closest: u32,
    pub(super) alive: bool,
}

/// Indices of `pts` sorted along a Morton (Z-order) curve over their bounds (ties by
/// index), so points near in space are near in memory and in the k-d tree's items.
pub(super) fn spatial_order(pts: &[DVec3]) -> Vec<u32> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let scale = (hi - lo).max(DVec3::splat(1e-300));
    let spread = |v: f64| -> u64 {
        let mut x = ((v.clamp(0.0, 1.0)) * 1_048_575.0) as u64; // 20 bits
        x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        x = (x | (x << 2)) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, u32)> = pts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let u = (*p - lo) / scale;
            (spread(u.x) | (spread(u.y) << 1) | (spread(u.z) << 2), i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// A uniformly distributed random unit vector.
pub(super) fn random_unit(rng: &mut Pcg64) -> DVec3 {
    let z = 2.0 * rng.random::<f64>() - 1.0;
    let phi = std::f64::consts::TAU * rng.random::<f64>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), z, s * phi.sin())
}
