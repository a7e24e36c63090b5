//! Graphs for least-cost-path trees: volumes, Poisson-disc nodes, Yao-k edges, lattices
//! and the graph file format (Xu2015 §3.2, §4.2 and Fig. 4.2 steps 1A–1H; Xu2015-spec
//! §2.1–§2.2).
//!
//! # Volumes
//!
//! A [`Volume`] is a union of [`Primitive`]s (Xu2015 §4.4.1): boxes, spheres,
//! hemispheres, sphere portions (spherical sectors: apex at `center`, half-angle about
//! `axis`), cylinders, cones, ellipsoids and half-ellipsoids, each with its own axis
//! (a tilted trunk is a cylinder with a tilted axis, Fig. 4.5). Each primitive has an
//! approximate signed distance (exact for spheres, a bound for the others); the union's
//! is the minimum. `sdf ≤ 0` is "inside", and the level-1 endpoint shell of MIG
//! (§4.2) is `−d_e ≤ sdf ≤ 0`.
//!
//! # Poisson-disc nodes (Fig. 4.2, 1A–1F)
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
//!
//! # Yao-k graph (1G; §3.2, Figs. 3.2–3.5)
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
//!
//! # Lattices (BCM, §3.3.1, Figs. 3.3–3.4)
//!
//! [`lattice`] builds the 6-connected (3D) or 4-connected (2D) lattice inside a volume,
//! optionally jittered by up to `jitter·spacing` per axis, with both edge directions.
//!
//! # Graph file format
//!
//! [`Graph::write`] / [`Graph::read`]: little-endian binary,
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
use glam::{DQuat, DVec3, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// No node / no edge.
pub const NONE: u32 = u32::MAX;

fn up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// One volume primitive (a `[[generator.volume]]` entry, tagged by `shape`). Lengths in
/// metres, angles in degrees; `axis` is the primitive's local up (need not be unit
/// length, default `[0, 1, 0]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum Primitive {
    /// An axis-aligned box (the MGV graph volume: a cube or a square in 2D).
    Box {
        /// Centre.
        center: [f64; 3],
        /// Edge lengths along x, y, z.
        size: [f64; 3],
    },
    /// A ball.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
    },
    /// The half of a ball on the `axis` side of its centre.
    Hemisphere {
        /// Centre of the flat face.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Direction of the dome.
        #[serde(default = "up")]
        axis: [f64; 3],
    },
    /// A "portion of sphere" (spherical sector): the points within `radius` of the apex
    /// `center` whose direction is within `half_angle` of `axis` (180° = full ball).
    Sector {
        /// Apex (the centre of the sphere).
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Half-angle in degrees, in (0, 180].
        half_angle: f64,
        /// Direction of the sector's axis.
        #[serde(default = "up")]
        axis: [f64; 3],
    },
    /// A solid cylinder from `base` along `axis`.
    Cylinder {
        /// Centre of the bottom disc.
        base: [f64; 3],
        /// Length along the axis.
        height: f64,
        /// Radius.
        radius: f64,
        /// Direction of the cylinder (a tilted trunk, Fig. 4.5).
        #[serde(default = "up")]
        axis: [f64; 3],
    },
    /// A solid cone with its base disc at `base` and apex at `base + height·axis`.
    Cone {
        /// Centre of the base disc.
        base: [f64; 3],
        /// Height along the axis.
        height: f64,
        /// Base radius.
        radius: f64,
        /// Direction from base to apex.
        #[serde(default = "up")]
        axis: [f64; 3],
    },
    /// An ellipsoid with semi-axes `radii` (x, y, z in the local frame, y along `axis`).
    Ellipsoid {
        /// Centre.
        center: [f64; 3],
        /// Semi-axes.
        radii: [f64; 3],
        /// Local y direction.
        #[serde(default = "up")]
        axis: [f64; 3],
    },
    /// The half of an ellipsoid on the `axis` side of its centre (the MGV crown volume,
    /// §5.3.2).
    HalfEllipsoid {
        /// Centre of the flat face.
        center: [f64; 3],
        /// Semi-axes (y along `axis`).
        radii: [f64; 3],
        /// Local y direction.
        #[serde(default = "up")]
        axis: [f64; 3],
    },
}

fn v3(a: [f64; 3]) -> DVec3 {
    DVec3::from_array(a)
}

fn check_vec(key: &str, v: [f64; 3], unit: bool) -> Result<()> {
    if v.iter().any(|x| !x.is_finite() || x.abs() > 1e6) {
        return Err(Error::Recipe(format!("`{key}` must be finite numbers of magnitude ≤ 1e6, got {v:?}")));
    }
    if unit && v3(v).length() < 1e-9 {
        return Err(Error::Recipe(format!("`{key}` must not be the zero vector")));
    }
    Ok(())
}

fn check_len(key: &str, v: f64) -> Result<()> {
    if !v.is_finite() || v <= 0.0 || v > 1e6 {
        return Err(Error::Recipe(format!("`{key}` must be in (0, 1e6], got {v}")));
    }
    Ok(())
}

impl Primitive {
    /// Checks every number; errors name the key under `prefix` (e.g. `generator.volume[1]`).
    pub fn validate(&self, prefix: &str) -> Result<()> {
        let k = |f: &str| format!("{prefix}.{f}");
        match self {
            Primitive::Box { center, size } => {
                check_vec(&k("center"), *center, false)?;
                for s in size {
                    check_len(&k("size"), *s)?;
                }
            }
            Primitive::Sphere { center, radius } => {
                check_vec(&k("center"), *center, false)?;
                check_len(&k("radius"), *radius)?;
            }
            Primitive::Hemisphere { center, radius, axis } => {
                check_vec(&k("center"), *center, false)?;
                check_len(&k("radius"), *radius)?;
                check_vec(&k("axis"), *axis, true)?;
            }
            Primitive::Sector { center, radius, half_angle, axis } => {
                check_vec(&k("center"), *center, false)?;
                check_len(&k("radius"), *radius)?;
                check_vec(&k("axis"), *axis, true)?;
                if !(half_angle.is_finite() && *half_angle > 0.0 && *half_angle <= 180.0) {
                    return Err(Error::Recipe(format!(
                        "`{}` must be in (0, 180] degrees, got {half_angle}",
                        k("half_angle")
                    )));
                }
            }
            Primitive::Cylinder { base, height, radius, axis }
            | Primitive::Cone { base, height, radius, axis } => {
                check_vec(&k("base"), *base, false)?;
                check_len(&k("height"), *height)?;
                check_len(&k("radius"), *radius)?;
                check_vec(&k("axis"), *axis, true)?;
            }
            Primitive::Ellipsoid { center, radii, axis }
            | Primitive::HalfEllipsoid { center, radii, axis } => {
                check_vec(&k("center"), *center, false)?;
                for r in radii {
                    check_len(&k("radii"), *r)?;
                }
                check_vec(&k("axis"), *axis, true)?;
            }
        }
        Ok(())
    }

    /// Origin and rotation (local → world, local y = axis) of the primitive.
    fn frame(&self) -> (DVec3, DQuat) {
        let (o, a) = match self {
            Primitive::Box { center, .. } | Primitive::Sphere { center, .. } => (*center, up()),
            Primitive::Hemisphere { center, axis, .. }
            | Primitive::Sector { center, axis, .. }
            | Primitive::Ellipsoid { center, axis, .. }
            | Primitive::HalfEllipsoid { center, axis, .. } => (*center, *axis),
            Primitive::Cylinder { base, axis, .. } | Primitive::Cone { base, axis, .. } => (*base, *axis),
        };
        let a = v3(a).normalize_or(DVec3::Y);
        (v3(o), DQuat::from_rotation_arc(DVec3::Y, a))
    }

    /// Local bounding box (in the primitive's frame).
    fn local_bounds(&self) -> (DVec3, DVec3) {
        match self {
            Primitive::Box { size, .. } => (-v3(*size) / 2.0, v3(*size) / 2.0),
            Primitive::Sphere { radius: r, .. } | Primitive::Sector { radius: r, .. } => {
                (DVec3::splat(-r), DVec3::splat(*r))
            }
            Primitive::Hemisphere { radius: r, .. } => (DVec3::new(-r, 0.0, -r), DVec3::splat(*r)),
            Primitive::Cylinder { height, radius: r, .. } | Primitive::Cone { height, radius: r, .. } => {
                (DVec3::new(-r, 0.0, -r), DVec3::new(*r, *height, *r))
            }
            Primitive::Ellipsoid { radii, .. } => (-v3(*radii), v3(*radii)),
            Primitive::HalfEllipsoid { radii, .. } => (DVec3::new(-radii[0], 0.0, -radii[2]), v3(*radii)),
        }
    }

    /// World bounding box.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let (o, q) = self.frame();
        let (lo, hi) = self.local_bounds();
        let mut b = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for c in 0..8 {
            let l = DVec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let w = o + q * l;
            b = (b.0.min(w), b.1.max(w));
        }
        b
    }

    /// Approximate signed distance (negative inside; exact for spheres, a bound-like
    /// approximation for the other shapes, good enough for inside tests and shells).
    pub fn sdf(&self, p: DVec3) -> f64 {
        let (o, q) = self.frame();
        self.sdf_local(q.inverse() * (p - o))
    }

    /// [`Primitive::sdf`] of a point already in the primitive's local frame.
    fn sdf_local(&self, l: DVec3) -> f64 {
        match self {
            Primitive::Box { size, .. } => {
                let d = l.abs() - v3(*size) / 2.0;
                d.max(DVec3::ZERO).length() + d.max_element().min(0.0)
            }
            Primitive::Sphere { radius, .. } => l.length() - radius,
            Primitive::Hemisphere { radius, .. } => (l.length() - radius).max(-l.y),
            Primitive::Sector { radius, half_angle, .. } => {
                let ball = l.length() - radius;
                let a = half_angle.to_radians();
                if a >= std::f64::consts::PI - 1e-12 {
                    return ball;
                }
                let len = l.length();
                if len < 1e-12 {
                    return ball;
                }
                let theta = (l.y / len).clamp(-1.0, 1.0).acos();
                let dt = theta - a;
                let ang = if dt >= std::f64::consts::FRAC_PI_2 { len } else { len * dt.sin() };
                ball.max(ang)
            }
            Primitive::Cylinder { height, radius, .. } => {
                let rho = (l.x * l.x + l.z * l.z).sqrt();
                let dr = rho - radius;
                let dh = (-l.y).max(l.y - height);
                DVec3::new(dr.max(0.0), dh.max(0.0), 0.0).length() + dr.max(dh).min(0.0)
            }
            Primitive::Cone { height, radius, .. } => {
                let rho = (l.x * l.x + l.z * l.z).sqrt();
                let slope = (radius * radius + height * height).sqrt();
                // Distance to the slanted side, measured perpendicular to it.
                let side = (rho * height + l.y * radius - radius * height) / slope;
                side.max(-l.y)
            }
            Primitive::Ellipsoid { radii, .. } => ellipsoid_sdf(l, v3(*radii)),
            Primitive::HalfEllipsoid { radii, .. } => ellipsoid_sdf(l, v3(*radii)).max(-l.y),
        }
    }

    /// Volume (area in 2D: the primitive's cross-section at z = 0 is not computed
    /// exactly; 2D graphs estimate their area by Monte Carlo instead).
    pub fn analytic_volume(&self) -> f64 {
        use std::f64::consts::PI;
        match self {
            Primitive::Box { size, .. } => size[0] * size[1] * size[2],
            Primitive::Sphere { radius: r, .. } => 4.0 / 3.0 * PI * r * r * r,
            Primitive::Hemisphere { radius: r, .. } => 2.0 / 3.0 * PI * r * r * r,
            Primitive::Sector { radius: r, half_angle, .. } => {
                2.0 / 3.0 * PI * r * r * r * (1.0 - half_angle.to_radians().cos())
            }
            Primitive::Cylinder { height, radius: r, .. } => PI * r * r * height,
            Primitive::Cone { height, radius: r, .. } => PI * r * r * height / 3.0,
            Primitive::Ellipsoid { radii: a, .. } => 4.0 / 3.0 * PI * a[0] * a[1] * a[2],
            Primitive::HalfEllipsoid { radii: a, .. } => 2.0 / 3.0 * PI * a[0] * a[1] * a[2],
        }
    }
}

/// Inigo Quilez's ellipsoid distance bound.
fn ellipsoid_sdf(p: DVec3, r: DVec3) -> f64 {
    let k0 = (p / r).length();
    let k1 = (p / (r * r)).length();
    if k1 < 1e-12 {
        return -r.min_element();
    }
    k0 * (k0 - 1.0) / k1
}

/// A union of primitives (with their local frames cached).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Volume {
    parts: Vec<Primitive>,
    /// Per part: origin and world → local rotation.
    frames: Vec<(DVec3, DQuat)>,
}

impl Volume {
    /// A volume of the given primitives.
    pub fn new(parts: Vec<Primitive>) -> Self {
        let frames = parts
            .iter()
            .map(|p| {
                let (o, q) = p.frame();
                (o, q.inverse())
            })
            .collect();
        Volume { parts, frames }
    }

    /// The primitives.
    pub fn parts(&self) -> &[Primitive] {
        &self.parts
    }

    /// Signed distance of the union (the minimum over the parts; +∞ when empty).
    pub fn sdf(&self, p: DVec3) -> f64 {
        self.parts
            .iter()
            .zip(&self.frames)
            .map(|(q, (o, r))| q.sdf_local(*r * (p - *o)))
            .fold(f64::INFINITY, f64::min)
    }

    /// True when `p` is inside (or on) the volume.
    pub fn contains(&self, p: DVec3) -> bool {
        self.parts.iter().zip(&self.frames).any(|(q, (o, r))| q.sdf_local(*r * (p - *o)) <= 0.0)
    }

    /// Bounding box of the union.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.parts
            .iter()
            .map(Primitive::bounds)
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |a, b| {
                (a.0.min(b.0), a.1.max(b.1))
            })
    }

    /// Bounding box restricted to the z = 0 plane in 2D.
    fn bounds_dims(&self, dims: u8) -> (DVec3, DVec3) {
        let (mut lo, mut hi) = self.bounds();
        if dims == 2 {
            lo.z = 0.0;
            hi.z = 0.0;
        }
        (lo, hi)
    }

    /// Volume (3D) or area of the z = 0 section (2D), estimated by Monte Carlo with
    /// 20 000 samples in the bounding box (deterministic in `seed`).
    pub fn measure(&self, dims: u8, seed: u64) -> f64 {
        let (lo, hi) = self.bounds_dims(dims);
        let ext = hi - lo;
        let full = if dims == 2 { ext.x * ext.y } else { ext.x * ext.y * ext.z };
        if full.is_nan() || full <= 0.0 {
            return 0.0;
        }
        let mut rng = Pcg64::seed_from_u64(seed ^ 0x6d65_6173_7572_6521);
        let n = 20_000;
        let mut inside = 0usize;
        for _ in 0..n {
            let p = random_in(&mut rng, lo, ext, dims);
            if self.contains(p) {
                inside += 1;
            }
        }
        full * inside as f64 / n as f64
    }

    /// The bottom centre of the bounding box (the default root, §3.3).
    pub fn bottom_center(&self, dims: u8) -> DVec3 {
        let (lo, hi) = self.bounds_dims(dims);
        if dims == 2 {
            DVec3::new((lo.x + hi.x) / 2.0, lo.y, 0.0)
        } else {
            DVec3::new((lo.x + hi.x) / 2.0, lo.y, (lo.z + hi.z) / 2.0)
        }
    }
}

fn random_in(rng: &mut Pcg64, lo: DVec3, ext: DVec3, dims: u8) -> DVec3 {
    let x = lo.x + ext.x * rng.random::<f64>();
    let y = lo.y + ext.y * rng.random::<f64>();
    let z = if dims == 2 { 0.0 } else { lo.z + ext.z * rng.random::<f64>() };
    DVec3::new(x, y, z)
}

/// `spacing`, or when `None` the [`auto_spacing`] of `count` nodes in `volume` (its
/// measure estimated with `seed`). Errors when the volume is empty.
pub fn resolve_spacing(
    volume: &Volume,
    count: usize,
    spacing: Option<f64>,
    dims: u8,
    seed: u64,
) -> Result<f64> {
    match spacing {
        Some(d) => Ok(d),
        None => {
            let m = volume.measure(dims, seed);
            if m.is_nan() || m <= 0.0 {
                return Err(Error::Recipe("the graph volume is empty".into()));
            }
            Ok(auto_spacing(m, count, dims))
        }
    }
}

/// The spacing `d` that puts `count` nodes in a region of measure `measure` at about
/// 48 % (3D) / 65 % (2D) of the dart-throwing jamming density (see the module docs).
pub fn auto_spacing(measure: f64, count: usize, dims: u8) -> f64 {
    if dims == 2 {
        (0.45 * measure / count.max(1) as f64).sqrt()
    } else {
        (0.35 * measure / count.max(1) as f64).cbrt()
    }
}

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
    fn new(pos: &[Vec3], cell: f32) -> CellGrid {
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
        let x = if xp && xn {
            full(0)
        } else if xp {
            pos(0)
        } else {
            neg(0)
        };
        let y = if yp && yn {
            full(1)
        } else if yp {
            pos(1)
        } else {
            neg(1)
        };
        [x, y, full(2)]
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

/// The lattice graph of BCM (§3.3.1): nodes on a lattice of `spacing` inside `volume`,
/// each jittered by up to `jitter·spacing` per axis, 6-connected (3D) or 4-connected
/// (2D) with both edge directions. The root is the node nearest the bottom centre.
pub fn lattice(volume: &Volume, spacing: f64, jitter: f64, dims: u8, seed: u64) -> Result<Graph> {
    let (lo, hi) = volume.bounds_dims(dims);
    let n = |e: f64| (e / spacing).floor() as usize + 1;
    let (nx, ny, nz) = (n(hi.x - lo.x), n(hi.y - lo.y), if dims == 2 { 1 } else { n(hi.z - lo.z) });
    let cells = nx.saturating_mul(ny).saturating_mul(nz);
    if cells > super::MAX_NODES * 4 {
        return Err(Error::Recipe(format!(
            "the lattice would have {cells} sites: make the spacing larger (at most {} sites)",
            super::MAX_NODES * 4
        )));
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut id = vec![NONE; cells];
    let mut pos = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let p = lo + DVec3::new(x as f64, y as f64, z as f64) * spacing;
                if volume.contains(p) {
                    let mut j = DVec3::new(
                        rng.random::<f64>() * 2.0 - 1.0,
                        rng.random::<f64>() * 2.0 - 1.0,
                        if dims == 2 { 0.0 } else { rng.random::<f64>() * 2.0 - 1.0 },
                    );
                    j *= jitter * spacing;
                    id[(z * ny + y) * nx + x] = pos.len() as u32;
                    pos.push((p + j).as_vec3());
                }
            }
        }
    }
    if pos.is_empty() {
        return Err(Error::Recipe("the lattice has no site inside the volume".into()));
    }
    let mut offsets = vec![0u32];
    let mut targets = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if id[(z * ny + y) * nx + x] == NONE {
                    continue;
                }
                let mut nb = |xx: isize, yy: isize, zz: isize| {
                    if xx >= 0
                        && yy >= 0
                        && zz >= 0
                        && (xx as usize) < nx
                        && (yy as usize) < ny
                        && (zz as usize) < nz
                    {
                        let t = id[(zz as usize * ny + yy as usize) * nx + xx as usize];
                        if t != NONE {
                            targets.push(t);
                        }
                    }
                };
                let (x, y, z) = (x as isize, y as isize, z as isize);
                nb(x - 1, y, z);
                nb(x + 1, y, z);
                nb(x, y - 1, z);
                nb(x, y + 1, z);
                if dims == 3 {
                    nb(x, y, z - 1);
                    nb(x, y, z + 1);
                }
                offsets.push(targets.len() as u32);
            }
        }
    }
    let bc = volume.bottom_center(dims).as_vec3();
    let root = (0..pos.len())
        .min_by(|&a, &b| pos[a].distance_squared(bc).total_cmp(&pos[b].distance_squared(bc)))
        .unwrap_or(0) as u32;
    Ok(Graph { dims, position: pos, offsets, targets, root, spacing: spacing as f32, shortfall: 0 })
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
