//! Graphs for least-cost-path trees (Xu2015 §3.2, §4.2 and Fig. 4.2 steps 1A–1H;
//! Xu2015-spec §2.1–§2.2): volumes (`volume.rs`), Poisson-disc nodes (`sample.rs`), Yao-k
//! edges (`yao.rs`), lattices (`lattice.rs`), and the CSR [`Graph`] with its file format,
//! [`Graph::write`] / [`Graph::read`], little-endian binary:
//!
//! ```text
//! magic "SYLVAGRF" | version u32 = 1 | dims u32 | n u32 | m u32 | root u32
//! key u64 (hash of the build parameters) | spacing f32
//! positions n×3 f32 | offsets (n+1) u32 | targets m u32
//! ```
//!
//! A reader checks the magic, version, sizes, that offsets are non-decreasing and end at
//! `m`, that targets are `< n`, and that positions are finite.

use crate::error::{Error, Result};
use glam::{DVec3, Vec3};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use std::path::Path;

mod lattice;
mod sample;
mod volume;
mod yao;

pub use self::lattice::lattice;
pub(crate) use self::sample::huge_capacity;
pub use self::sample::{poisson, spatial_sort, Samples, MAX_SAMPLING_CELLS};
pub use self::volume::{auto_spacing, resolve_spacing, Primitive, Volume};
pub use self::yao::{check_sectors, sector, yao, MAX_SECTORS};

/// No node / no edge.
pub use crate::geometry::NONE;

/// A directed graph in compressed-row form with `f32` node positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Graph {
    /// 2 or 3.
    pub dims: u8,
    /// Node positions.
    pub position: Vec<Vec3>,
    /// Out-edges of node `u` are `targets[offsets[u]..offsets[u + 1]]`.
    pub offsets: Vec<u32>,
    /// Edge targets.
    pub targets: Vec<u32>,
    /// The root node (bottom centre).
    pub root: u32,
    /// The Poisson spacing `d` (the lattice spacing for lattices).
    pub spacing: f32,
    /// Nodes that could not be placed (see [`poisson`]).
    pub shortfall: usize,
}

impl Graph {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when the graph has no node.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Out-neighbours of `u`.
    pub fn out(&self, u: u32) -> &[u32] {
        &self.targets[self.offsets[u as usize] as usize..self.offsets[u as usize + 1] as usize]
    }

    /// Index of the first out-edge of `u` (edge ids are positions in `targets`).
    pub fn first_edge(&self, u: u32) -> usize {
        self.offsets[u as usize] as usize
    }

    /// Number of edges.
    pub fn edge_count(&self) -> usize {
        self.targets.len()
    }

    /// Bytes held by the graph's arrays.
    pub fn bytes(&self) -> usize {
        self.position.len() * 12 + self.offsets.len() * 4 + self.targets.len() * 4
    }

    /// Nodes reachable from `from` through out-edges (breadth-first), as flags.
    pub fn reachable(&self, from: &[u32]) -> Vec<bool> {
        let mut seen = vec![false; self.len()];
        let mut queue: Vec<u32> = Vec::new();
        for &s in from {
            if !seen[s as usize] {
                seen[s as usize] = true;
                queue.push(s);
            }
        }
        let mut head = 0;
        while head < queue.len() {
            let u = queue[head];
            head += 1;
            for &v in self.out(u) {
                if !seen[v as usize] {
                    seen[v as usize] = true;
                    queue.push(v);
                }
            }
        }
        seen
    }

    /// Writes the graph in the binary format of the module docs (atomically).
    pub fn write(&self, path: &Path, key: u64) -> Result<()> {
        crate::fsutil::write_atomic(path, |w| {
            w.write_all(b"SYLVAGRF")?;
            for v in [1u32, self.dims as u32, self.len() as u32, self.targets.len() as u32, self.root] {
                w.write_all(&v.to_le_bytes())?;
            }
            w.write_all(&key.to_le_bytes())?;
            w.write_all(&self.spacing.to_le_bytes())?;
            let mut buf = Vec::with_capacity(self.len() * 12);
            for p in &self.position {
                for c in p.to_array() {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
            w.write_all(&buf)?;
            buf.clear();
            for v in self.offsets.iter().chain(&self.targets) {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            w.write_all(&buf)
        })
    }

    /// Reads a graph written by [`Graph::write`]; returns it with its key.
    pub fn read(path: &Path) -> Result<(Graph, u64)> {
        // A cache sylva wrote: no size limit, but a regular file only.
        let bytes = crate::input::read_input(path, u64::MAX)?;
        let bad = |why: &str| Error::Recipe(format!("graph file {}: {why}", path.display()));
        let mut at = 0usize;
        let mut take = |n: usize| -> Result<&[u8]> {
            let s = bytes.get(at..at + n).ok_or_else(|| bad("truncated"))?;
            at += n;
            Ok(s)
        };
        if take(8)? != b"SYLVAGRF" {
            return Err(bad("not a sylva graph file (bad magic)"));
        }
        let mut u32s = [0u32; 5];
        for v in &mut u32s {
            *v = u32::from_le_bytes(take(4)?.try_into().map_err(|_| bad("truncated"))?);
        }
        let [version, dims, n, m, root] = u32s;
        if version != 1 {
            return Err(bad(&format!("version {version}, this sylva reads version 1")));
        }
        let key = u64::from_le_bytes(take(8)?.try_into().map_err(|_| bad("truncated"))?);
        let spacing = f32::from_le_bytes(take(4)?.try_into().map_err(|_| bad("truncated"))?);
        let (n, m) = (n as usize, m as usize);
        if !(dims == 2 || dims == 3) || (root as usize) >= n.max(1) {
            return Err(bad("bad header"));
        }
        let need =
            n.checked_mul(12).and_then(|a| a.checked_add((n + 1 + m) * 4)).ok_or_else(|| bad("bad sizes"))?;
        if bytes.len() != 8 + 20 + 8 + 4 + need {
            return Err(bad("size does not match the header"));
        }
        let f = |s: &[u8]| f32::from_le_bytes([s[0], s[1], s[2], s[3]]);
        let u = |s: &[u8]| u32::from_le_bytes([s[0], s[1], s[2], s[3]]);
        let pos_bytes = take(n * 12)?;
        let position: Vec<Vec3> =
            pos_bytes.chunks_exact(12).map(|c| Vec3::new(f(&c[0..4]), f(&c[4..8]), f(&c[8..12]))).collect();
        let offsets: Vec<u32> = take((n + 1) * 4)?.chunks_exact(4).map(u).collect();
        let targets: Vec<u32> = take(m * 4)?.chunks_exact(4).map(u).collect();
        if position.iter().any(|p| !p.is_finite())
            || offsets.windows(2).any(|w| w[0] > w[1])
            || offsets.first() != Some(&0)
            || offsets.last().map(|&l| l as usize) != Some(m)
            || targets.iter().any(|&t| t as usize >= n)
            || !spacing.is_finite()
        {
            return Err(bad("corrupt contents"));
        }
        Ok((Graph { dims: dims as u8, position, offsets, targets, root, spacing, shortfall: 0 }, key))
    }
}

/// Poisson nodes in `volume` joined as a Yao-`k` graph (Fig. 4.2 steps 1A–1G), with the
/// root (bottom centre unless given) as a node. `spacing = None` picks it from the
/// volume (see [`auto_spacing`]).
pub fn poisson_yao(
    volume: &Volume,
    count: usize,
    spacing: Option<f64>,
    root: Option<DVec3>,
    k: u32,
    dims: u8,
    seed: u64,
) -> Result<Graph> {
    check_sectors(k, dims)?;
    let d = resolve_spacing(volume, count, spacing, dims, seed)?;
    let root = root.unwrap_or_else(|| volume.bottom_center(dims));
    let mut rng = Pcg64::seed_from_u64(seed);
    let s = poisson(volume, count, d, Some(root), dims, &mut rng)?;
    let (pos, r) = spatial_sort(&s.points, d, 0);
    let mut g = yao(pos, k, dims, d as f32, r);
    g.shortfall = s.shortfall;
    Ok(g)
}

/// Hints the processor to fetch `v[i]` into the cache (a no-op off x86-64 or when `i`
/// is out of range; it changes no value).
#[inline(always)]
pub(crate) fn prefetch<T>(v: &[T], i: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(s) = v.get(i) {
        #[allow(unused_unsafe)]
        // SAFETY: a prefetch of a valid reference's address; it reads nothing.
        unsafe {
            std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>((s as *const T).cast());
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (v, i);
}

#[cfg(test)]
mod tests {
    use super::volume::{random_in, up};
    use super::*;

    fn cube(s: f64) -> Volume {
        Volume::new(vec![Primitive::Box { center: [0.0, s / 2.0, 0.0], size: [s, s, s] }])
    }

    #[test]
    fn sectors_follow_the_documented_rule() {
        assert_eq!(sector(Vec3::new(1.0, 1.0, 1.0), 8, 3), 7);
        assert_eq!(sector(Vec3::new(-1.0, -1.0, -1.0), 8, 3), 0);
        assert_eq!(sector(Vec3::new(0.0, 0.0, 0.0), 8, 3), 7, "ties go to the positive side");
        assert_eq!(sector(Vec3::new(1.0, -1.0, 0.0), 8, 3), 0b101);
        assert_eq!(sector(Vec3::new(1.0, 0.1, 0.0), 6, 2), 0);
        assert_eq!(sector(Vec3::new(-1.0, -0.1, 0.0), 6, 2), 3);
        assert_eq!(sector(Vec3::new(1.0, 1.0, 0.01), 16, 3), 7 * 2);
        assert_eq!(sector(Vec3::new(0.01, 1.0, 1.0), 16, 3), 7 * 2 + 1);
    }

    #[test]
    fn primitives_contain_their_centres_and_bounds_hold() {
        let prims = vec![
            Primitive::Sphere { center: [0.0, 1.0, 0.0], radius: 1.0 },
            Primitive::Cylinder { base: [0.0; 3], height: 2.0, radius: 0.5, axis: [0.3, 1.0, 0.0] },
            Primitive::Cone { base: [0.0; 3], height: 2.0, radius: 1.0, axis: up() },
            Primitive::Ellipsoid { center: [0.0; 3], radii: [1.0, 2.0, 0.5], axis: up() },
            Primitive::HalfEllipsoid { center: [0.0; 3], radii: [1.0, 2.0, 0.5], axis: up() },
            Primitive::Sector { center: [0.0; 3], radius: 1.0, half_angle: 45.0, axis: up() },
            Primitive::Hemisphere { center: [0.0; 3], radius: 1.0, axis: up() },
        ];
        let mut rng = Pcg64::seed_from_u64(9);
        for p in &prims {
            let (lo, hi) = p.bounds();
            let v = Volume::new(vec![p.clone()]);
            let m = v.measure(3, 1);
            let exact = p.analytic_volume();
            assert!((m - exact).abs() < 0.06 * exact, "{p:?}: {m} vs {exact}");
            for _ in 0..2000 {
                let q = random_in(&mut rng, lo - 0.5, hi - lo + 1.0, 3);
                if p.sdf(q) <= 0.0 {
                    assert!(q.cmpge(lo - 1e-9).all() && q.cmple(hi + 1e-9).all(), "{p:?} {q}");
                }
            }
        }
        let s = Primitive::Sector { center: [0.0; 3], radius: 1.0, half_angle: 45.0, axis: up() };
        assert!(s.sdf(DVec3::new(0.0, 0.5, 0.0)) < 0.0);
        assert!(s.sdf(DVec3::new(0.5, 0.1, 0.0)) > 0.0);
    }

    #[test]
    fn poisson_respects_spacing_and_count() {
        let v = cube(1.0);
        let mut rng = Pcg64::seed_from_u64(1);
        let s = poisson(&v, 500, 0.08, Some(DVec3::new(0.0, 0.0, 0.0)), 3, &mut rng).unwrap();
        assert_eq!(s.points.len(), 500);
        assert_eq!(s.shortfall, 0);
        for i in 0..s.points.len() {
            for j in 0..i {
                assert!(s.points[i].distance(s.points[j]) >= 0.08);
            }
        }
        // Too many nodes for the spacing: a shortfall, no hang.
        let s = poisson(&v, 100_000, 0.2, None, 3, &mut rng).unwrap();
        assert!(s.shortfall > 0 && s.points.len() < 300);
    }

    #[test]
    fn graph_file_round_trips_and_rejects_garbage() {
        let g = poisson_yao(&cube(1.0), 300, None, None, 8, 3, 4).unwrap();
        let dir = std::env::temp_dir().join(format!("sylva-graph-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("g.bin");
        g.write(&f, 77).unwrap();
        let (h, key) = Graph::read(&f).unwrap();
        assert_eq!(key, 77);
        assert_eq!(h, g);
        std::fs::write(&f, b"SYLVAGRF\x01\0\0\0").unwrap();
        assert!(Graph::read(&f).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
