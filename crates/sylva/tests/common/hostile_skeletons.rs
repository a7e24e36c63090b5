//! Generators of hostile skeletons (issue 39, items 4–6): degenerate geometry and
//! many-root forests at 10²–10⁴ nodes, as the text of `.skel.json` and `.lst` files, for
//! the robustness tests and the fuzz suite. Every generator is deterministic (a fixed
//! LCG, no `rand`), so a failing case is reproduced by its name and size.

#![allow(dead_code)]

use std::fmt::Write;

/// A tiny deterministic generator (64-bit LCG), uniform in [lo, hi).
pub struct Lcg(u64);

impl Lcg {
    /// Seeded.
    pub fn new(seed: u64) -> Self {
        Lcg(seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407))
    }

    /// The next value in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// An index below `n` (n > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.range(0.0, n as f64) as usize).min(n - 1)
    }
}

/// A `.skel.json` text of the nodes `(position, radius, parent)`.
pub fn skel_json(nodes: &[([f64; 3], f64, Option<usize>)]) -> String {
    let mut s = String::from("{\"format\": \"sylva-skeleton\", \"version\": 1, \"nodes\": [\n");
    for (k, (p, r, parent)) in nodes.iter().enumerate() {
        let parent = parent.map_or("null".to_string(), |p| p.to_string());
        let sep = if k + 1 < nodes.len() { "," } else { "" };
        writeln!(
            s,
            "{{\"position\": [{}, {}, {}], \"radius\": {r}, \"parent\": {parent}}}{sep}",
            p[0], p[1], p[2]
        )
        .unwrap();
    }
    s.push_str("]}\n");
    s
}

/// `n` nodes all at the origin, each the child of the one before (every internode of
/// zero length, every node coincident).
pub fn coincident_chain(n: usize) -> String {
    skel_json(&(0..n).map(|i| ([0.0; 3], 0.1, i.checked_sub(1))).collect::<Vec<_>>())
}

/// `n` nodes at the origin, all children of the first (a star of zero-length internodes).
pub fn coincident_star(n: usize) -> String {
    skel_json(&(0..n).map(|i| ([0.0; 3], 0.1, (i > 0).then_some(0))).collect::<Vec<_>>())
}

/// A chain of `n` nodes that goes up 1 m and straight back down, over and over: every
/// internode reverses its parent's.
pub fn zigzag(n: usize) -> String {
    skel_json(&(0..n).map(|i| ([0.0, (i % 2) as f64, 0.0], 0.05, i.checked_sub(1))).collect::<Vec<_>>())
}

/// A random tree of `n` nodes whose every real internode (up to 1 m) is followed by
/// `zeros` zero-length ones.
pub fn zero_length_chains(n: usize, zeros: usize, seed: u64) -> String {
    let mut g = Lcg::new(seed);
    let mut nodes: Vec<([f64; 3], f64, Option<usize>)> = vec![([0.0; 3], 0.1, None)];
    while nodes.len() < n {
        let p = g.below(nodes.len());
        let q = nodes[p].0;
        let d = [g.range(-1.0, 1.0), g.range(0.2, 1.0), g.range(-1.0, 1.0)];
        nodes.push(([q[0] + d[0], q[1] + d[1], q[2] + d[2]], 0.02, Some(p)));
        for _ in 0..zeros {
            if nodes.len() >= n {
                break;
            }
            let last = nodes.len() - 1;
            nodes.push((nodes[last].0, 0.02, Some(last)));
        }
    }
    skel_json(&nodes)
}

/// A 1 m trunk ending in a chain of `n - 2` zero-length internodes.
pub fn zero_length_tail(n: usize) -> String {
    let mut nodes: Vec<([f64; 3], f64, Option<usize>)> =
        vec![([0.0; 3], 0.1, None), ([0.0, 1.0, 0.0], 0.1, Some(0))];
    while nodes.len() < n {
        nodes.push(([0.0, 1.0, 0.0], 0.05, Some(nodes.len() - 1)));
    }
    skel_json(&nodes)
}

/// A random tree of `n` nodes within `spread` metres of the origin (radius 0.05): many
/// near-coincident nodes.
pub fn near_coincident(n: usize, spread: f64, seed: u64) -> String {
    let mut g = Lcg::new(seed);
    let mut nodes: Vec<([f64; 3], f64, Option<usize>)> = vec![([0.0; 3], 0.1, None)];
    for i in 1..n {
        let p = [g.range(-spread, spread), g.range(-spread, spread), g.range(-spread, spread)];
        nodes.push((p, 0.05, Some(g.below(i))));
    }
    skel_json(&nodes)
}

/// A random tree of `n` nodes with internodes of about 1 m and every radius `radius`.
pub fn radius_tree(n: usize, radius: f64, seed: u64) -> String {
    let mut g = Lcg::new(seed);
    let mut nodes: Vec<([f64; 3], f64, Option<usize>)> = vec![([0.0; 3], radius, None)];
    for i in 1..n {
        let p = g.below(i);
        let q = nodes[p].0;
        nodes.push((
            [q[0] + g.range(-1.0, 1.0), q[1] + g.range(0.1, 1.0), q[2] + g.range(-1.0, 1.0)],
            radius,
            Some(p),
        ));
    }
    skel_json(&nodes)
}

/// An LST file of `n` separate upright cylinders (radius 5 → 4 cm, 1 m tall) on a grid
/// 0.5 m apart: read with `generator.gap = "new-root"`, a forest of `n` roots.
pub fn many_roots_lst(n: usize) -> String {
    let side = (n as f64).sqrt().ceil().max(1.0) as usize;
    let mut s = String::from("LST 0.1\n");
    for k in 0..n {
        s.push_str("Cylinder(0.05, 0.04, 1)\n");
        if (k + 1) % side == 0 {
            writeln!(s, "MovRel3f({}, 0, 0.5)", -((side - 1) as f64) * 0.5).unwrap();
        } else {
            s.push_str("MovRel3f(0.5, 0, 0)\n");
        }
    }
    s
}

/// Every generator at `n` nodes, by name (for the fuzz suite).
pub fn all(n: usize, seed: u64) -> Vec<(&'static str, String)> {
    vec![
        ("coincident-chain.skel.json", coincident_chain(n)),
        ("coincident-star.skel.json", coincident_star(n)),
        ("zigzag.skel.json", zigzag(n)),
        ("zero-length-chains.skel.json", zero_length_chains(n, 9, seed)),
        ("zero-length-tail.skel.json", zero_length_tail(n)),
        ("near-coincident.skel.json", near_coincident(n, 1e-4, seed)),
        ("huge-radius.skel.json", radius_tree(n, 1e30, seed)),
        ("many-roots.lst", many_roots_lst(n)),
    ]
}
