//! Poisson-disc nodes (Xu2015 Fig. 4.2, steps 1A–1F).
//!
//! Faithful dart throwing accelerated by a background grid of cell size `d/√D`
//! (D = 2 or 3), so a cell holds at most one node and a dart is tested against the
//! nodes of the `5^D` surrounding cells only. Which cells are occupied is kept in a
//! bitmap (one bit per cell, small enough to stay in cache), read five cells of a row
//! at a time, so a dart touches node data only for the few occupied cells near it.
//! The cell array (≈ 150 MiB at 600 k nodes) is advised transparent huge pages, which
//! cuts the TLB misses of its random reads, and the parallel pre-test prefetches the
//! occupied cells near the dart six places ahead, so the cache misses of several
//! darts overlap (both hints: values never change).
//!
//! Darts are thrown in batches (up to 8 192, fewer near the end). All darts of a batch
//! are first tested in parallel against the nodes placed before the batch; a dart that
//! fails would also fail at its own turn, since nodes are only ever added. The
//! survivors are then tested in dart order against the nodes added earlier in the same
//! batch, which is needed only where a block of 4×4×4 cells near the dart got one.
//! The nodes (and the generator's final state) are exactly those of throwing the darts
//! one at a time, for any thread count. Darts are uniform in the volume's bounding
//! box, rejected outside the volume or within `d` of a node, until `K` nodes exist or an
//! attempt cap (`40·K + 10 000` darts) is reached; the shortfall is reported. The root
//! is inserted first, so it is always a node. When the spacing is not given it is
//! chosen from the volume (estimated by Monte Carlo) as `d = (0.35·V/K)^{1/3}` in 3D
//! (`(0.45·A/K)^{1/2}` in 2D), about 48 % (65 %) of the random-sequential-adsorption
//! jamming density, where darts still land quickly (inference). After sampling the
//! nodes are renumbered in grid-cell order, which makes neighbour search and Dijkstra
//! cache-friendly; the root's new id is kept.

use super::prefetch;
use super::volume::{random_in, Volume};
use crate::error::{Error, Result};
use glam::{DVec3, Vec3};
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Most cells of [`poisson`]'s background grid (cell size `spacing/√D` over the
/// volume's bounding box), checked before the grid is allocated (issue 27): 200 M cells
/// of 16 bytes. The presets need under 10 M (about 15 per node in a box).
pub const MAX_SAMPLING_CELLS: usize = 200_000_000;

/// Result of [`poisson`].
#[derive(Debug, Clone)]
pub struct Samples {
    /// The nodes; the root (if any) is `points[0]`.
    pub points: Vec<DVec3>,
    /// How many of the requested nodes could not be placed within the attempt cap.
    pub shortfall: usize,
}

/// Poisson-disc dart throwing in `volume` (Fig. 4.2 steps 1A–1F; see the module docs):
/// up to `count` nodes at least `spacing` apart, the `root` (when given) first.
pub fn poisson(
    volume: &Volume,
    count: usize,
    spacing: f64,
    root: Option<DVec3>,
    dims: u8,
    rng: &mut Pcg64,
) -> Result<Samples> {
    let (mut lo, mut hi) = volume.bounds_dims(dims);
    if let Some(r) = root {
        lo = lo.min(r);
        hi = hi.max(r);
    }
    let cell = spacing / (dims as f64).sqrt();
    let ext = hi - lo;
    let n = |e: f64| ((e / cell).floor() as usize + 1).max(1);
    let (nx, ny, nz) = (n(ext.x), n(ext.y), if dims == 2 { 1 } else { n(ext.z) });
    let cells = nx.checked_mul(ny).and_then(|a| a.checked_mul(nz)).unwrap_or(usize::MAX);
    // Checked before the grid (16 bytes a cell) is allocated: at most 3.2 GB.
    if cells > MAX_SAMPLING_CELLS {
        return Err(Error::Recipe(format!(
            "the graph volume needs {cells} sampling cells at spacing {spacing}, more than the limit of \
             {MAX_SAMPLING_CELLS} (16 bytes each): make the volume (`generator.volume`) smaller, or the \
             spacing (`generator.spacing`) larger or the node count (`generator.nodes`) smaller"
        )));
    }
    // The grid is padded by two cells on every side (none along z in 2D), so the
    // neighbour offsets never leave it.
    let pz = if dims == 2 { 0 } else { 2 };
    let (gx, gy) = (nx + 4, ny + 4);
    let padded = gx * gy * (nz + 2 * pz);
    // Occupancy is one bit per cell (a few MiB at most, so it stays in cache); an
    // occupied cell holds its node's position in f32 (a quick conservative test that
    // avoids fetching the f64 node) and the node's id. Cells are only read where their
    // bit is set, so the cell array needs no initialisation (zeroed pages are mapped
    // lazily).
    let mut bits = vec![0u64; padded / 64 + 2];
    let mut grid = vec![[0u32; 4]; padded];
    huge_pages(&grid);
    let put = |p: Vec3, id: u32| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), id];
    let mut pts: Vec<DVec3> = Vec::with_capacity(count);
    let idx = |p: DVec3| -> usize {
        let c = |v: f64, m: usize| ((v / cell).floor().max(0.0) as usize).min(m - 1);
        let (x, y) = (c(p.x - lo.x, nx), c(p.y - lo.y, ny));
        let z = if dims == 2 { 0 } else { c(p.z - lo.z, nz) };
        ((z + pz) * gy + y + 2) * gx + x + 2
    };
    let d2 = spacing * spacing;
    // Neighbour cells that can hold a node closer than d (cell = d/√D: the squared gap
    // Σ max(|δ|−1, 0)² cells must be below D), as rows of five cells along x: the row's
    // offset to its first cell (dx = −2) and a 5-bit mask of the cells that count.
    let zr = pz as isize;
    let mut rows: Vec<(isize, u64, isize)> = Vec::new();
    for dz in -zr..=zr {
        for dy in -2isize..=2 {
            let mut mask = 0u64;
            for dx in -2isize..=2 {
                let gap: isize = [dx, dy, dz].iter().map(|v| (v.abs() - 1).max(0).pow(2)).sum();
                if (dx, dy, dz) != (0, 0, 0) && gap < dims as isize {
                    mask |= 1 << (dx + 2);
                }
            }
            if mask != 0 {
                rows.push(((dz * gy as isize + dy) * gx as isize - 2, mask, dy * dy + dz * dz));
            }
        }
    }
    // Nearest rows first: a dart that meets a node usually meets it there, so a rejected
    // dart reads fewer cells (each occupied cell read is a likely cache miss). The test
    // is a pure conjunction over the rows, so the order does not change its result.
    rows.sort_by_key(|r| r.2);
    let rows: Vec<(isize, u64)> = rows.into_iter().map(|(off, mask, _)| (off, mask)).collect();
    let occupied = |bits: &[u64], i: usize| bits[i >> 6] >> (i & 63) & 1 != 0;
    // Five bits of cells `i .. i + 5` (the bitmap has a spare word at the end).
    let five = |bits: &[u64], i: usize| {
        let (w, sh) = (i >> 6, i & 63);
        let two = (bits[w + 1] as u128) << 64 | bits[w] as u128;
        (two >> sh) as u64 & 0x1f
    };
    if let Some(r) = root {
        let at = idx(r);
        grid[at] = put(r.as_vec3(), 0);
        bits[at >> 6] |= 1 << (at & 63);
        pts.push(r);
    }
    let (lo2, hi2) = ((d2 * (1.0 - 1e-5)) as f32, (d2 * (1.0 + 1e-5)) as f32);
    // Is the dart `p` in cell `at` at least d from every node in the grid?
    let free = |bits: &[u64], grid: &[[u32; 4]], pts: &[DVec3], at: usize, p: DVec3| {
        let pf = p.as_vec3();
        rows.iter().all(|&(off, mask)| {
            let first = (at as isize + off) as usize;
            let mut hits = five(bits, first) & mask;
            while hits != 0 {
                let [x, y, z, c] = grid[first + hits.trailing_zeros() as usize];
                hits &= hits - 1;
                let d =
                    Vec3::new(f32::from_bits(x), f32::from_bits(y), f32::from_bits(z)).distance_squared(pf);
                // Decide in f32 unless the distance is within rounding of d; then in f64.
                if d < lo2 || (d < hi2 && pts[c as usize].distance_squared(p) < d2) {
                    return false;
                }
            }
            true
        })
    };
    // Blocks of 4×4×4 cells (4×4 in 2D) stamped with the batch that last added a node
    // in them.
    let (bx, by) = (gx / 4 + 1, gy / 4 + 1);
    let mut stamp = vec![0u32; bx * by * ((nz + 2 * pz) / 4 + 1)];
    let cell_xyz = |at: usize| (at % gx, at / gx % gy, at / (gx * gy));
    let cap = 40usize.saturating_mul(count).saturating_add(10_000);
    let mut attempts = 0usize;
    let mut darts: Vec<DVec3> = Vec::new();
    let mut pass: Vec<bool> = Vec::new();
    let mut batch = 0u32;
    while pts.len() < count && attempts < cap {
        // Batches are exactly equivalent to throwing the darts one by one: a dart that
        // meets a node of the grid as it was before the batch would meet it at its own
        // turn too, so the parallel pre-test only removes darts the serial test would
        // reject; the survivors are then tested in dart order against the nodes added
        // by earlier darts of the same batch (only where one was added nearby).
        let b = (2 * (count - pts.len())).clamp(256, 8192).min(cap - attempts);
        let saved = rng.clone();
        darts.clear();
        darts.extend((0..b).map(|_| random_in(rng, lo, ext, dims)));
        let pre = |p: &DVec3| {
            let at = idx(*p);
            !occupied(&bits, at) && volume.contains(*p) && free(&bits, &grid, &pts, at, *p)
        };
        // Each test waits on the cache misses of the occupied cells near its dart; to
        // overlap them, the cells of the dart `AHEAD` places further on are prefetched
        // first (a hint: the results are those of the plain loop).
        let touch = |p: &DVec3| {
            let at = idx(*p);
            if occupied(&bits, at) {
                return;
            }
            for &(off, mask) in &rows {
                let first = (at as isize + off) as usize;
                let mut hits = five(&bits, first) & mask;
                while hits != 0 {
                    prefetch(&grid, first + hits.trailing_zeros() as usize);
                    hits &= hits - 1;
                }
            }
        };
        const AHEAD: usize = 6;
        let run = |d: &[DVec3], out: &mut [bool]| {
            for (i, o) in out.iter_mut().enumerate() {
                if let Some(q) = d.get(i + AHEAD) {
                    touch(q);
                }
                *o = pre(&d[i]);
            }
        };
        pass.clear();
        pass.resize(b, false);
        if b >= 2048 {
            darts.par_chunks(1024).zip(pass.par_chunks_mut(1024)).for_each(|(d, out)| run(d, out));
        } else {
            run(&darts, &mut pass);
        }
        batch += 1;
        let mut used = b;
        for (i, p) in darts.iter().enumerate() {
            if !pass[i] {
                continue;
            }
            let at = idx(*p);
            let (x, y, z) = cell_xyz(at);
            let (z0, z1) = ((z.saturating_sub(pz)) / 4, (z + pz) / 4);
            let near = (z0..=z1).any(|bz| {
                ((y - 2) / 4..=(y + 2) / 4).any(|by_| {
                    ((x - 2) / 4..=(x + 2) / 4).any(|bx_| stamp[(bz * by + by_) * bx + bx_] == batch)
                })
            });
            if near && (occupied(&bits, at) || !free(&bits, &grid, &pts, at, *p)) {
                continue;
            }
            grid[at] = put(p.as_vec3(), pts.len() as u32);
            bits[at >> 6] |= 1 << (at & 63);
            stamp[((z / 4) * by + y / 4) * bx + x / 4] = batch;
            pts.push(*p);
            if pts.len() == count {
                used = i + 1;
                break;
            }
        }
        attempts += used;
        if used < b {
            // Leave the generator where the serial loop would have left it.
            *rng = saved;
            for _ in 0..used {
                random_in(rng, lo, ext, dims);
            }
        }
    }
    Ok(Samples { shortfall: count - pts.len().min(count), points: pts })
}

/// Asks the kernel to back `v` with transparent huge pages (Linux `madvise`; a hint
/// that changes no value, ignored elsewhere or where the kernel declines). Randomly
/// accessed arrays of many MiB (the Poisson cell array, Dijkstra's node state) miss the
/// TLB on almost every access with 4 KiB pages.
pub(crate) fn huge_pages<T>(v: &[T]) {
    advise_huge(v.as_ptr() as usize, std::mem::size_of_val(v));
}

/// An empty vector with room for `n` items whose buffer is advised huge pages (see
/// [`huge_pages`]) before anything is written to it.
pub(crate) fn huge_capacity<T>(n: usize) -> Vec<T> {
    let v = Vec::with_capacity(n);
    advise_huge(v.as_ptr() as usize, n * std::mem::size_of::<T>());
    v
}

fn advise_huge(start: usize, bytes: usize) {
    #[cfg(target_os = "linux")]
    {
        if bytes < 4 << 20 {
            return;
        }
        let (lo, hi) = (start.next_multiple_of(4096), (start + bytes) / 4096 * 4096);
        // SAFETY: madvise with MADV_HUGEPAGE only changes how the kernel backs these
        // whole pages inside one allocation; their contents are unchanged.
        unsafe {
            libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = (start, bytes);
}

/// Renumbers `points` in cell order of a grid of cell size `cell` (z, then y, then x;
/// ties by the original index) and returns them with the new index of `points[keep]`.
pub fn spatial_sort(points: &[DVec3], cell: f64, keep: usize) -> (Vec<Vec3>, u32) {
    let mut lo = DVec3::splat(f64::INFINITY);
    for p in points {
        lo = lo.min(*p);
    }
    let key = |p: DVec3| {
        let c = ((p - lo) / cell).floor();
        (c.z as u64) << 42 | (c.y as u64 & 0x1f_ffff) << 21 | (c.x as u64 & 0x1f_ffff)
    };
    let mut idx: Vec<(u64, u32)> = points.iter().enumerate().map(|(i, p)| (key(*p), i as u32)).collect();
    idx.sort_unstable();
    let mut new_keep = 0;
    let mut pos = huge_capacity(points.len());
    pos.extend(idx.iter().enumerate().map(|(new, &(_, old))| {
        if old as usize == keep {
            new_keep = new as u32;
        }
        points[old as usize].as_vec3()
    }));
    (pos, new_keep)
}
