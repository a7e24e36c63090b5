//! A robust 3D convex hull for the hull mesher's joints (Pieterse2012 §4.2.3, printed as
//! "4.3.3.2 Convex Hull Construction – Randomized Incremental Algorithm"; Pieterse2012-spec §2.6
//! step 4).
//!
//! The algorithm is the seed's incremental one (Clarkson–Shor): a tetrahedron from four
//! non-coplanar points, then one point at a time, delete the faces the point sees and
//! fan the horizon to it. Two changes make it robust:
//!
//! - **Exact predicates.** Points are snapped to an integer grid of ±2²⁴ cells over
//!   their bounding box and every orientation test is an exact `i128` determinant, so the
//!   combinatorics (which faces a point sees) are always consistent: no epsilon, no
//!   "face both visible and invisible", no cracked horizons.
//! - **Coplanar points are kept.** A face is visible only when the point is *strictly*
//!   outside its plane. A point coplanar with a facet but outside it in that plane still
//!   sees the neighbouring face across the facet's rim (the dihedral angle there is
//!   convex), so it becomes a vertex; a point exactly on or inside the current hull is
//!   skipped and simply does not appear in the output (a point in the middle of a hull
//!   edge may stay as a flat vertex if it came before the edge's ends). Callers that
//!   need every point (the joint builder) check the result.
//!
//! The insertion order is a fixed pseudo-random permutation (seeded, so the output is
//! deterministic); the first four points are extremes (lowest point, farthest from it,
//! farthest from that line, farthest from that plane). Cost: O(n · F) with F = 2n − 4
//! faces, fine for joints of a few hundred points.

use glam::DVec3;

/// Grid half-extent: coordinates are snapped to integers in `[-2^24, 2^24]`.
const GRID: f64 = (1u64 << 24) as f64;

/// Why a hull could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HullError {
    /// Fewer than 4 points.
    TooFewPoints,
    /// A coordinate is NaN or infinite.
    NonFinite,
    /// All points are coincident, collinear or coplanar (after snapping to the grid).
    Flat,
    /// The horizon of a point was not a simple cycle (cannot happen with exact
    /// predicates; reported instead of panicking).
    BrokenHorizon,
}

/// Snapped integer point.
type P = [i64; 3];

fn sub(a: &P, b: &P) -> [i128; 3] {
    [(a[0] - b[0]) as i128, (a[1] - b[1]) as i128, (a[2] - b[2]) as i128]
}

fn cross(u: &[i128; 3], v: &[i128; 3]) -> [i128; 3] {
    [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
}

fn dot(u: &[i128; 3], v: &[i128; 3]) -> i128 {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// Exact orientation: positive when `d` is on the side of plane `(a, b, c)` that the
/// counter-clockwise normal `(b − a) × (c − a)` points to.
fn orient(a: &P, b: &P, c: &P, d: &P) -> i128 {
    dot(&cross(&sub(b, a), &sub(c, a)), &sub(d, a))
}

/// The convex hull of `points` as triangles (indices into `points`), counter-clockwise
/// seen from outside. Points inside the hull or exactly on it (not extreme after grid
/// snapping) do not appear. Deterministic.
pub fn convex_hull(points: &[DVec3]) -> Result<Vec<[u32; 3]>, HullError> {
    let n = points.len();
    if n < 4 {
        return Err(HullError::TooFewPoints);
    }
    if points.iter().any(|p| !p.is_finite()) {
        return Err(HullError::NonFinite);
    }
    let (lo, hi) = points.iter().fold((points[0], points[0]), |(l, h), p| (l.min(*p), h.max(*p)));
    let centre = (lo + hi) * 0.5;
    let ext = (hi - lo).max_element() * 0.5;
    if !ext.is_finite() || ext <= 0.0 {
        return Err(HullError::Flat);
    }
    let scale = GRID / ext;
    let q: Vec<P> = points
        .iter()
        .map(|p| {
            let v = (*p - centre) * scale;
            [v.x.round() as i64, v.y.round() as i64, v.z.round() as i64]
        })
        .collect();

    // Initial tetrahedron from extremes.
    let i0 = (0..n).min_by_key(|&i| (q[i], i)).unwrap_or(0);
    let d2 = |i: usize| {
        let d = sub(&q[i], &q[i0]);
        dot(&d, &d)
    };
    let i1 = (0..n).max_by_key(|&i| (d2(i), std::cmp::Reverse(i))).unwrap_or(0);
    if d2(i1) == 0 {
        return Err(HullError::Flat);
    }
    let e01 = sub(&q[i1], &q[i0]);
    let c2 = |i: usize| {
        let c = cross(&e01, &sub(&q[i], &q[i0]));
        dot(&c, &c)
    };
    let i2 = (0..n).max_by_key(|&i| (c2(i), std::cmp::Reverse(i))).unwrap_or(0);
    if c2(i2) == 0 {
        return Err(HullError::Flat);
    }
    let o3 = |i: usize| orient(&q[i0], &q[i1], &q[i2], &q[i]).abs();
    let i3 = (0..n).max_by_key(|&i| (o3(i), std::cmp::Reverse(i))).unwrap_or(0);
    if o3(i3) == 0 {
        return Err(HullError::Flat);
    }

    let mut h = Builder { q: &q, faces: Vec::new(), nbr: Vec::new(), alive: Vec::new() };
    h.tetrahedron([i0 as u32, i1 as u32, i2 as u32, i3 as u32]);

    // Remaining points in a fixed pseudo-random order (xorshift64*, Fisher–Yates).
    let mut order: Vec<u32> = (0..n as u32).filter(|&i| ![i0, i1, i2, i3].contains(&(i as usize))).collect();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for k in (1..order.len()).rev() {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        let r = state.wrapping_mul(0x2545_F491_4F6C_DD1D);
        order.swap(k, (r % (k as u64 + 1)) as usize);
    }
    let mut stamp = vec![0u32; 0];
    let mut start_of = vec![u32::MAX; n];
    let mut end_of = vec![u32::MAX; n];
    for (round, &p) in order.iter().enumerate() {
        let round = round as u32 + 1;
        h.insert(p, round, &mut stamp, &mut start_of, &mut end_of)?;
    }
    Ok((0..h.faces.len()).filter(|&f| h.alive[f]).map(|f| h.faces[f]).collect())
}

/// Triangles with adjacency: `nbr[f][e]` is the face across edge `e` of face `f`, the
/// edge from `faces[f][e]` to `faces[f][(e + 1) % 3]`.
struct Builder<'a> {
    q: &'a [P],
    faces: Vec<[u32; 3]>,
    nbr: Vec<[u32; 3]>,
    alive: Vec<bool>,
}

impl Builder<'_> {
    fn sees(&self, f: usize, p: u32) -> bool {
        let [a, b, c] = self.faces[f];
        let q = self.q;
        orient(&q[a as usize], &q[b as usize], &q[c as usize], &q[p as usize]) > 0
    }

    fn tetrahedron(&mut self, v: [u32; 4]) {
        // Faces opposite each vertex, oriented so the opposite vertex is behind them.
        let tris = [
            [v[1], v[2], v[3], v[0]],
            [v[0], v[3], v[2], v[1]],
            [v[0], v[1], v[3], v[2]],
            [v[0], v[2], v[1], v[3]],
        ];
        for t in tris {
            let (a, mut b, mut c, d) = (t[0], t[1], t[2], t[3]);
            let q = self.q;
            if orient(&q[a as usize], &q[b as usize], &q[c as usize], &q[d as usize]) > 0 {
                std::mem::swap(&mut b, &mut c);
            }
            self.faces.push([a, b, c]);
            self.nbr.push([u32::MAX; 3]);
            self.alive.push(true);
        }
        // Adjacency by brute force over the 4 faces.
        for f in 0..4 {
            for e in 0..3 {
                let (a, b) = (self.faces[f][e], self.faces[f][(e + 1) % 3]);
                for g in 0..4 {
                    if g == f {
                        continue;
                    }
                    for k in 0..3 {
                        if self.faces[g][k] == b && self.faces[g][(k + 1) % 3] == a {
                            self.nbr[f][e] = g as u32;
                        }
                    }
                }
            }
        }
    }

    fn insert(
        &mut self,
        p: u32,
        round: u32,
        stamp: &mut Vec<u32>,
        start_of: &mut [u32],
        end_of: &mut [u32],
    ) -> Result<(), HullError> {
        stamp.resize(self.faces.len(), 0);
        let visible: Vec<usize> =
            (0..self.faces.len()).filter(|&f| self.alive[f] && self.sees(f, p)).collect();
        for &f in &visible {
            stamp[f] = round;
        }
        if visible.is_empty() {
            return Ok(()); // inside or on the hull
        }
        // Horizon edges: edges of visible faces whose neighbour is not visible.
        let mut horizon = Vec::new();
        for &f in &visible {
            for e in 0..3 {
                let g = self.nbr[f][e];
                if g == u32::MAX {
                    return Err(HullError::BrokenHorizon);
                }
                if stamp[g as usize] != round {
                    horizon.push((self.faces[f][e], self.faces[f][(e + 1) % 3], f as u32, g));
                }
            }
        }
        let first_new = self.faces.len() as u32;
        let mut ok = true;
        for (k, &(a, b, f, g)) in horizon.iter().enumerate() {
            let nf = first_new + k as u32;
            if start_of[a as usize] != u32::MAX || end_of[b as usize] != u32::MAX {
                ok = false; // a pinched horizon: not a simple cycle
            }
            start_of[a as usize] = nf;
            end_of[b as usize] = nf;
            self.faces.push([a, b, p]);
            self.nbr.push([g, u32::MAX, u32::MAX]);
            self.alive.push(true);
            if let Some(slot) = self.nbr[g as usize].iter_mut().find(|s| **s == f) {
                *slot = nf;
            }
        }
        for k in 0..horizon.len() {
            let nf = first_new as usize + k;
            let [a, b, _] = self.faces[nf];
            let after = start_of[b as usize];
            let before = end_of[a as usize];
            if after == u32::MAX || before == u32::MAX {
                ok = false;
            }
            self.nbr[nf][1] = after;
            self.nbr[nf][2] = before;
        }
        for &(a, b, _, _) in &horizon {
            start_of[a as usize] = u32::MAX;
            end_of[b as usize] = u32::MAX;
        }
        for &f in &visible {
            self.alive[f] = false;
        }
        if ok {
            Ok(())
        } else {
            Err(HullError::BrokenHorizon)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    fn check_closed(tris: &[[u32; 3]]) {
        let mut directed = HashMap::new();
        for t in tris {
            for e in 0..3 {
                *directed.entry((t[e], t[(e + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &c) in &directed {
            assert_eq!(c, 1);
            assert_eq!(directed.get(&(b, a)), Some(&1));
        }
    }

    fn volume(points: &[DVec3], tris: &[[u32; 3]]) -> f64 {
        tris.iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| points[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn coplanar_facet_points_in_convex_position_are_all_kept() {
        // Two parallel octagons (each a coplanar facet, like a joint's loops) and an
        // apex: every point is extreme, so every point must be a vertex.
        let mut pts = Vec::new();
        for ring in 0..2 {
            for j in 0..8 {
                let a = (j as f64 + 0.5 * ring as f64) * std::f64::consts::TAU / 8.0;
                pts.push(DVec3::new(a.cos(), ring as f64, a.sin()));
            }
        }
        pts.push(DVec3::new(0.1, -1.0, 0.0));
        let tris = convex_hull(&pts).unwrap();
        check_closed(&tris);
        let used: std::collections::HashSet<u32> = tris.iter().flatten().copied().collect();
        assert_eq!(used.len(), pts.len());
        assert_eq!(tris.len(), 2 * pts.len() - 4);
        assert!(volume(&pts, &tris) > 0.0);
        // A point in the middle of a hull edge is not extreme: depending on the insertion
        // order it is skipped or kept as a flat vertex; the hull is closed either way.
        let mut cube: Vec<DVec3> = (0..8)
            .map(|i| DVec3::new((i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64))
            .collect();
        cube.push(DVec3::new(0.5, 1.0, 0.0));
        let tris = convex_hull(&cube).unwrap();
        check_closed(&tris);
        assert!((volume(&cube, &tris) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn interior_and_duplicate_points_are_skipped() {
        let mut pts = vec![
            DVec3::ZERO,
            DVec3::X,
            DVec3::Y,
            DVec3::Z,
            DVec3::splat(0.1),
            DVec3::X, // duplicate
        ];
        pts.push(DVec3::new(0.2, 0.2, 0.0)); // on the bottom facet, inside it
        let tris = convex_hull(&pts).unwrap();
        check_closed(&tris);
        assert_eq!(tris.len(), 4);
        assert!(volume(&pts, &tris) > 0.0);
    }

    #[test]
    fn flat_and_bad_input_fail_cleanly() {
        let square = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0), DVec3::splat(0.0)];
        assert_eq!(convex_hull(&square), Err(HullError::Flat));
        assert_eq!(convex_hull(&[DVec3::ZERO; 3]), Err(HullError::TooFewPoints));
        assert_eq!(convex_hull(&[DVec3::ONE; 6]), Err(HullError::Flat));
        let line: Vec<DVec3> = (0..6).map(|i| DVec3::X * i as f64).collect();
        assert_eq!(convex_hull(&line), Err(HullError::Flat));
        let nan = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(f64::NAN, 0.0, 1.0)];
        assert_eq!(convex_hull(&nan), Err(HullError::NonFinite));
    }

    #[test]
    fn sphere_points_are_all_vertices() {
        // Cocircular rings on a sphere (the joint case): many coplanar quadruples.
        let mut pts = Vec::new();
        for ring in 0..7 {
            let th = 0.3 + ring as f64 * 0.4;
            for j in 0..12 {
                let ph = j as f64 * std::f64::consts::TAU / 12.0;
                pts.push(DVec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()));
            }
        }
        let tris = convex_hull(&pts).unwrap();
        check_closed(&tris);
        assert_eq!(tris.len(), 2 * pts.len() - 4);
        assert!(volume(&pts, &tris) > 0.0);
        // Deterministic.
        assert_eq!(convex_hull(&pts).unwrap(), tris);
    }
}
