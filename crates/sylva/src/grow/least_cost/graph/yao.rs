//! The Yao-k graph (Xu2015 step 1G; §3.2, Figs. 3.2–3.5; Yao1982).
//!
//! Around each node the space is split into `k` sectors and a **directed** edge goes to
//! the nearest other node of each non-empty sector (ties: the smaller node id). So the
//! out-degree is at most `k` and the in-degree is unbounded.
//!
//! - **3D** (`k = 8·m`, m = 1..4; Yao-8 by default): the octant of `d = q − p` by the
//!   signs of `(d.x, d.y, d.z)`, a zero component counting as positive (Xu2015-spec §2.2);
//!   for `m > 1` each octant is split into `m` equal azimuthal wedges of the angle
//!   `atan2(|d.z|, |d.x|) ∈ [0, π/2]`.
//! - **2D** (`3 ≤ k ≤ 32`): sector `j` holds the angles `atan2(d.y, d.x) ∈
//!   [2πj/k, 2π(j+1)/k)` (angles in `[0, 2π)`).
//!
//! The build searches a uniform grid (cell size `d`) around each node: first the whole
//! cube of Chebyshev radius 2 cells (row by row: a row of cells is one contiguous run of
//! node ids), then expanding shells. Each sector keeps the least `d² bits << 32 | id`
//! key. After shell `s`, every unseen node is at least `s·cell` away, so a
//! sector whose best candidate is that close is final. A sector with no candidate yet is
//! final when a summed-area table of the cell counts shows no node left in the
//! bounding box of the grid cells the sector can reach. Shells only visit cells inside
//! the union of the open sectors' boxes. Nodes are independent, so the build runs on
//! rayon in fixed chunks and is deterministic. Expected cost O(n).

use super::sample::huge_capacity;
use super::Graph;
use crate::error::{Error, Result};
use glam::Vec3;
use rayon::prelude::*;

/// The octant of `d` (the Yao-8 sector in 3D; ties to the positive side).
#[inline]
fn octant(d: Vec3) -> u32 {
    (d.x >= 0.0) as u32 | ((d.y >= 0.0) as u32) << 1 | ((d.z >= 0.0) as u32) << 2
}

/// The Yao sector of `d = q − p` among `k` (see the module docs).
#[inline]
pub fn sector(d: Vec3, k: u32, dims: u8) -> u32 {
    if dims == 2 {
        let mut a = d.y.atan2(d.x);
        if a < 0.0 {
            a += std::f32::consts::TAU;
        }
        ((a / std::f32::consts::TAU * k as f32) as u32).min(k - 1)
    } else {
        let oct = octant(d);
        let m = k / 8;
        if m <= 1 {
            return oct;
        }
        let a = d.z.abs().atan2(d.x.abs()) / std::f32::consts::FRAC_PI_2;
        oct * m + ((a * m as f32) as u32).min(m - 1)
    }
}

/// Checks a Yao `k` for `dims`.
pub fn check_sectors(k: u32, dims: u8) -> Result<()> {
    let ok = if dims == 2 { (3..=32).contains(&k) } else { k.is_multiple_of(8) && (8..=32).contains(&k) };
    if ok {
        Ok(())
    } else {
        Err(Error::Recipe(format!(
            "`generator.sectors` is {k}; use 3..=32 in 2D or 8, 16, 24 or 32 (octants split into wedges) in 3D"
        )))
    }
}

/// A uniform grid of node ids in cell order, with a summed-area table of cell counts.
struct CellGrid {
    lo: Vec3,
    cell: f32,
    n: [usize; 3],
    /// Nodes of cell `c`: `order[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    order: Vec<u32>,
    /// Summed-area table over (nx+1)(ny+1)(nz+1).
    sat: Vec<u32>,
}

impl CellGrid {
    pub(super) fn new(pos: &[Vec3], cell: f32) -> CellGrid {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in pos {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if pos.is_empty() {
            lo = Vec3::ZERO;
            hi = Vec3::ZERO;
        }
        let ext = hi - lo;
        let f = |e: f32| ((e / cell).floor() as usize + 1).max(1);
        let n = [f(ext.x), f(ext.y), f(ext.z)];
        let cells = n[0] * n[1] * n[2];
        let mut g = CellGrid { lo, cell, n, start: vec![0; cells + 1], order: Vec::new(), sat: Vec::new() };
        let ids: Vec<usize> = pos.iter().map(|p| g.cell_of(*p)).collect();
        for &c in &ids {
            g.start[c + 1] += 1;
        }
        for c in 0..cells {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        g.order = vec![0; pos.len()];
        for (i, &c) in ids.iter().enumerate() {
            g.order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let (sx, sy) = (n[0] + 1, n[1] + 1);
        let mut sat = vec![0u32; sx * sy * (n[2] + 1)];
        for z in 0..n[2] {
            for y in 0..n[1] {
                for x in 0..n[0] {
                    let c = (z * n[1] + y) * n[0] + x;
                    let count = g.start[c + 1] - g.start[c];
                    let at = |x: usize, y: usize, z: usize| (z * sy + y) * sx + x;
                    sat[at(x + 1, y + 1, z + 1)] = count
                        + sat[at(x, y + 1, z + 1)]
                        + sat[at(x + 1, y, z + 1)]
                        + sat[at(x + 1, y + 1, z)]
                        + sat[at(x, y, z)]
                        - sat[at(x, y, z + 1)]
                        - sat[at(x, y + 1, z)]
                        - sat[at(x + 1, y, z)];
                }
            }
        }
        g.sat = sat;
        g
    }

    fn coords(&self, p: Vec3) -> [usize; 3] {
        let c = |v: f32, m: usize| ((v / self.cell).floor().max(0.0) as usize).min(m - 1);
        let d = p - self.lo;
        [c(d.x, self.n[0]), c(d.y, self.n[1]), c(d.z, self.n[2])]
    }

    fn cell_of(&self, p: Vec3) -> usize {
        let [x, y, z] = self.coords(p);
        (z * self.n[1] + y) * self.n[0] + x
    }

    /// Nodes in the inclusive cell box `[lo, hi]` (empty when any lo > hi).
    fn count(&self, lo: [usize; 3], hi: [usize; 3]) -> u32 {
        if (0..3).any(|a| lo[a] > hi[a]) {
            return 0;
        }
        let (sx, sy) = (self.n[0] + 1, self.n[1] + 1);
        let at = |x: usize, y: usize, z: usize| self.sat[(z * sy + y) * sx + x];
        let (x0, y0, z0, x1, y1, z1) = (lo[0], lo[1], lo[2], hi[0] + 1, hi[1] + 1, hi[2] + 1);
        // Inclusion–exclusion with wrapping arithmetic: the true total is non-negative.
        at(x1, y1, z1)
            .wrapping_sub(at(x0, y1, z1))
            .wrapping_sub(at(x1, y0, z1))
            .wrapping_sub(at(x1, y1, z0))
            .wrapping_add(at(x0, y0, z1))
            .wrapping_add(at(x0, y1, z0))
            .wrapping_add(at(x1, y0, z0))
            .wrapping_sub(at(x0, y0, z0))
    }
}

/// Bounding box (in cell coordinates) of the cells sector `s` can reach from cell `c`.
fn sector_box(s: u32, k: u32, dims: u8, c: [usize; 3], n: [usize; 3]) -> ([usize; 3], [usize; 3]) {
    let full = |a: usize| (0usize, n[a] - 1);
    let pos = |a: usize| (c[a], n[a] - 1);
    let neg = |a: usize| (0usize, c[a]);
    let r = if dims == 2 {
        // Quadrants touched by the sector's angle range.
        let tau = std::f64::consts::TAU;
        let (a0, a1) = (tau * s as f64 / k as f64, tau * (s + 1) as f64 / k as f64);
        let (mut xp, mut xn, mut yp, mut yn) = (false, false, false, false);
        for q in 0..4 {
            let (q0, q1) = (tau * q as f64 / 4.0, tau * (q + 1) as f64 / 4.0);
            if a0 < q1 && a1 > q0 {
                // Quadrant q: 0 = (+x,+y), 1 = (−x,+y), 2 = (−x,−y), 3 = (+x,−y).
                if q == 0 || q == 3 {
                    xp = true;
                } else {
                    xn = true;
                }
                if q < 2 {
                    yp = true;
                } else {
                    yn = true;
                }
            }
        }
        // The whole axis when both signs are touched, else the touched side.
        let span = |a: usize, plus: bool, minus: bool| match (plus, minus) {
            (true, true) => full(a),
            (true, false) => pos(a),
            _ => neg(a),
        };
        [span(0, xp, xn), span(1, yp, yn), full(2)]
    } else {
        let oct = s / (k / 8).max(1);
        let ax = |a: usize, bit: u32| if oct & (1 << bit) != 0 { pos(a) } else { neg(a) };
        [ax(0, 0), ax(1, 1), ax(2, 2)]
    };
    ([r[0].0, r[1].0, r[2].0], [r[0].1, r[1].1, r[2].1])
}

/// Yao search cell size in units of the spacing (tuned: about one node per cell).
const YAO_CELL: f32 = 1.0;

/// Chebyshev radius (in cells) of the first, whole-cube pass of the Yao search: large
/// enough that it closes all sectors of most interior nodes (tuned at 150 k–600 k nodes).
const YAO_FIRST: usize = 2;

/// Maximum Yao `k` (sectors).
pub const MAX_SECTORS: usize = 32;

/// Out-edges of node `u` in the Yao-`k` graph over `pos` (see the module docs).
fn yao_node(pos: &[Vec3], grid: &CellGrid, u: usize, k: u32, dims: u8, out: &mut Vec<u32>) {
    let p = pos[u];
    let c = grid.coords(p);
    let n = grid.n;
    let ku = k as usize;
    let mut best = [u64::MAX; MAX_SECTORS];
    let mut open = [true; MAX_SECTORS];
    let octants = dims == 3 && k == 8;
    let mut boxes = [([0usize; 3], [0usize; 3]); MAX_SECTORS];
    for (s, b) in boxes.iter_mut().enumerate().take(ku) {
        *b = sector_box(s as u32, k, dims, c, n);
    }
    // The first pass visits the whole cube of Chebyshev radius `YAO_FIRST` at once (it
    // closes most sectors); later passes visit one ring each.
    let mut s = YAO_FIRST;
    let mut whole = true;
    loop {
        // Union box of the open sectors.
        let mut ulo = [usize::MAX; 3];
        let mut uhi = [0usize; 3];
        for j in 0..ku {
            if open[j] {
                for a in 0..3 {
                    ulo[a] = ulo[a].min(boxes[j].0[a]);
                    uhi[a] = uhi[a].max(boxes[j].1[a]);
                }
            }
        }
        // Visit the cells of Chebyshev ring s (the cube when `whole`) inside the union box.
        let r = |a: usize| {
            let lo = c[a].saturating_sub(s).max(ulo[a]);
            let hi = (c[a] + s).min(uhi[a]);
            (lo, hi)
        };
        let ((x0, x1), (y0, y1), (z0, z1)) = (r(0), r(1), r(2));
        if x0 <= x1 && y0 <= y1 && z0 <= z1 {
            // Nodes of the cells `row + a ..= row + b` are one contiguous run of `order`.
            // Each sector keeps the least key `d² bits << 32 | id` (non-negative f32 order
            // like their bits, so this is the nearest node, ties to the smaller id); a
            // closed sector's key is final, so updating it again changes nothing.
            let mut scan = |row: usize, a: usize, b: usize| {
                let run = &grid.order[grid.start[row + a] as usize..grid.start[row + b + 1] as usize];
                for &q in run {
                    if q as usize == u {
                        continue;
                    }
                    let d = pos[q as usize] - p;
                    let j = if octants { octant(d) } else { sector(d, k, dims) } as usize;
                    let key = (d.length_squared().to_bits() as u64) << 32 | q as u64;
                    best[j] = best[j].min(key);
                }
            };
            // The ring's cells at x = c ± s, where they lie inside the visited box.
            let x_ends = (c[0] >= s && (x0..=x1).contains(&(c[0] - s))) || (x0..=x1).contains(&(c[0] + s));
            for z in z0..=z1 {
                let zs = whole || z.abs_diff(c[2]) == s;
                if !(zs || s == 0 || x_ends) {
                    // Off the ring's z and x faces only its y faces hold cells: two rows,
                    // not a walk over every row between them (a thin, tall volume would
                    // otherwise cost O(s) per ring and O(s²) per node).
                    for y in [c[1].checked_sub(s), Some(c[1] + s)].into_iter().flatten() {
                        if (y0..=y1).contains(&y) {
                            scan((z * n[1] + y) * n[0], x0, x1);
                        }
                    }
                    continue;
                }
                for y in y0..=y1 {
                    let row = (z * n[1] + y) * n[0];
                    if zs || y.abs_diff(c[1]) == s || s == 0 {
                        scan(row, x0, x1);
                    } else {
                        if c[0] >= s && (x0..=x1).contains(&(c[0] - s)) {
                            scan(row, c[0] - s, c[0] - s);
                        }
                        if (x0..=x1).contains(&(c[0] + s)) {
                            scan(row, c[0] + s, c[0] + s);
                        }
                    }
                }
            }
        }
        whole = false;
        // Close sectors. An unseen node of sector j lies outside the visited cube of
        // cells [c − s, c + s], beyond one of the cube's faces on the sides the
        // sector's box reaches, so it is at least `bound` from p.
        let rel = p - grid.lo;
        let mut any_open = false;
        for j in 0..ku {
            if !open[j] {
                continue;
            }
            let found = best[j] != u64::MAX;
            if found {
                let (blo, bhi) = boxes[j];
                let mut bound = f32::INFINITY;
                for a in 0..3 {
                    if blo[a] < c[a] {
                        bound = bound.min(rel[a] - (c[a] as f32 - s as f32) * grid.cell);
                    }
                    if bhi[a] > c[a] {
                        bound = bound.min((c[a] + s + 1) as f32 * grid.cell - rel[a]);
                    }
                }
                // Guard against rounding: never claim more than the cells guarantee.
                let bound = bound.max(s as f32 * grid.cell) - 1e-6 * grid.cell;
                if f32::from_bits((best[j] >> 32) as u32) <= bound * bound {
                    open[j] = false;
                    continue;
                }
            }
            // Nodes left in the sector's box outside the visited cube? (Only asked for
            // sectors with no candidate yet, or far out, where it pays.)
            if found && s < 3 {
                any_open = true;
                continue;
            }
            let (blo, bhi) = boxes[j];
            let total = grid.count(blo, bhi);
            let clo = [0, 1, 2].map(|a| blo[a].max(c[a].saturating_sub(s)));
            let chi = [0, 1, 2].map(|a| bhi[a].min(c[a] + s));
            if total == grid.count(clo, chi) {
                open[j] = false;
                continue;
            }
            any_open = true;
        }
        if !any_open {
            break;
        }
        s += 1;
    }
    for &b in best.iter().take(ku) {
        if b != u64::MAX {
            out.push(b as u32);
        }
    }
}

/// Builds the Yao-`k` graph over `position` (1G; see the module docs), in parallel.
pub fn yao(position: Vec<Vec3>, k: u32, dims: u8, spacing: f32, root: u32) -> Graph {
    let cell = if spacing > 0.0 { spacing * YAO_CELL } else { 1.0 };
    let grid = CellGrid::new(&position, cell);
    const CHUNK: usize = 2048;
    let parts: Vec<(Vec<u32>, Vec<u32>)> = (0..position.len().div_ceil(CHUNK))
        .into_par_iter()
        .map(|ch| {
            let mut deg = Vec::with_capacity(CHUNK);
            let mut tg = Vec::with_capacity(CHUNK * 8);
            for u in ch * CHUNK..((ch + 1) * CHUNK).min(position.len()) {
                let before = tg.len();
                yao_node(&position, &grid, u, k, dims, &mut tg);
                deg.push((tg.len() - before) as u32);
            }
            (deg, tg)
        })
        .collect();
    let mut offsets = huge_capacity(position.len() + 1);
    offsets.push(0u32);
    let mut targets = huge_capacity(parts.iter().map(|p| p.1.len()).sum());
    for (deg, tg) in parts {
        for d in deg {
            let last = *offsets.last().unwrap_or(&0);
            offsets.push(last + d);
        }
        targets.extend_from_slice(&tg);
    }
    Graph { dims, position, offsets, targets, root, spacing, shortfall: 0 }
}
