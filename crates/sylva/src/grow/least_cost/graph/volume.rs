//! Volumes (Xu2015 §4.4.1, Fig. 4.5).
//!
//! A [`Volume`] is a union of [`Primitive`]s (Xu2015 §4.4.1): boxes, spheres,
//! hemispheres, sphere portions (spherical sectors: apex at `center`, half-angle about
//! `axis`), cylinders, cones, ellipsoids and half-ellipsoids, each with its own axis
//! (a tilted trunk is a cylinder with a tilted axis, Fig. 4.5). Each primitive has an
//! approximate signed distance (exact for spheres, a bound for the others); the union's
//! is the minimum. `sdf ≤ 0` is "inside", and the level-1 endpoint shell of MIG
//! (§4.2) is `−d_e ≤ sdf ≤ 0`.

use crate::error::{Error, Result};
use glam::{DQuat, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

pub(super) fn up() -> [f64; 3] {
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
    pub(super) fn bounds_dims(&self, dims: u8) -> (DVec3, DVec3) {
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

pub(super) fn random_in(rng: &mut Pcg64, lo: DVec3, ext: DVec3, dims: u8) -> DVec3 {
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
