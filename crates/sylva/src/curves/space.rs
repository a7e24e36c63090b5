//! Beyond the seed (Xu2015 §8.1, "the idea of magnetic curves extends
//! straightforwardly to three dimensions … and to create 2D curves on the surfaces of
//! complex structures"): magnetic curves in 3D with a vector field **B**, branching
//! 3D curves turned into a [`Skeleton`] so they mesh, refine and export like any tree,
//! and curves traced on a sphere's surface.
//!
//! # 3D integrator
//!
//! `dv/dt = (q/m) v × B = ω × v` with `ω = −(q/m) B`. Over one step [`advance3`]
//! freezes `ω` at its midpoint value and moves along the exact helix: `v` rotates
//! about `ω̂` by `|ω|·dt` (Rodrigues), and `x` advances by
//! `v∥·dt + v⊥·sin θ/|ω| + (ω̂ × v⊥)(1 − cos θ)/|ω|`. With `B = B_z ẑ` this is exactly the
//! 2D integrator of [`super::magnetic`]; speed is preserved to rounding.
//!
//! # On a sphere
//!
//! [`trace_on_sphere`] keeps the particle on a sphere of radius R with the field
//! normal to the surface (`B_n`, e.g. a 3D noise texture, "magnetic fields could be
//! textures on the surfaces of objects"): each step turns the tangent velocity about
//! the normal by `−ω·dt/2`, walks the great circle of arc `|v|·dt/R` (parallel-
//! transporting the velocity), and turns by `−ω·dt/2` again (Strang splitting,
//! second order). The particle never leaves the sphere and `|v|` never changes.

use crate::error::{Error, Result};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64;

use super::magnetic::{release_indices, Budget, Charge};
use crate::lsystem::expr::Evaluator;
use crate::noise::Perlin;

/// A 3D magnetic field.
#[derive(Debug, Clone, PartialEq)]
pub enum Field3 {
    /// The same vector everywhere.
    Uniform(DVec3),
    /// `B = bias + strength · (n(p/s), n(p/s + o₁), n(p/s + o₂))`: three decorrelated
    /// samples of one seeded Perlin noise.
    Perlin {
        /// The noise.
        noise: Perlin,
        /// Feature size.
        scale: f64,
        /// Strength.
        strength: f64,
        /// Constant part.
        bias: DVec3,
    },
}

const OFFSET_1: DVec3 = DVec3::new(31.416, 47.853, 12.793);
const OFFSET_2: DVec3 = DVec3::new(-71.11, 23.917, 89.201);

impl Field3 {
    /// **B** at `p`.
    #[inline]
    pub fn b(&self, p: DVec3) -> DVec3 {
        match self {
            Field3::Uniform(v) => *v,
            Field3::Perlin { noise, scale, strength, bias } => {
                let q = p / *scale;
                *bias
                    + *strength
                        * DVec3::new(noise.noise3(q), noise.noise3(q + OFFSET_1), noise.noise3(q + OFFSET_2))
            }
        }
    }

    /// The scalar field used on surfaces: `B_n = v.z` for a uniform field, else
    /// `bias.z + strength · 0.5 · (1 + noise(p/s))` (in `[bias.z, bias.z + strength]`).
    #[inline]
    pub fn normal_value(&self, p: DVec3) -> f64 {
        match self {
            Field3::Uniform(v) => v.z,
            Field3::Perlin { noise, scale, strength, bias } => {
                bias.z + strength * 0.5 * (1.0 + noise.noise3(p / *scale))
            }
        }
    }
}

/// A particle in 3D.
#[derive(Debug, Clone, PartialEq)]
pub struct Particle3 {
    /// Start position.
    pub position: DVec3,
    /// Start velocity.
    pub velocity: DVec3,
    /// Mass m > 0.
    pub mass: f64,
    /// Charge profile.
    pub charge: Charge,
    /// Duration.
    pub duration: f64,
}

/// A traced 3D curve, possibly a branch of another.
#[derive(Debug, Clone, PartialEq)]
pub struct Curve3 {
    /// Positions.
    pub points: Vec<DVec3>,
    /// Velocities.
    pub velocities: Vec<DVec3>,
    /// `(parent curve, point index on it)`, `None` for roots.
    pub parent: Option<(usize, usize)>,
    /// Generation.
    pub depth: u32,
}

/// Advances `(x, v)` by one exact helical step of angular velocity `omega` (a vector:
/// `v` turns about it, right-handed).
#[inline]
pub fn advance3(x: DVec3, v: DVec3, omega: DVec3, dt: f64) -> (DVec3, DVec3) {
    let w = omega.length();
    if w * dt < 1e-12 {
        return (x + v * dt, v);
    }
    let a = omega / w;
    let theta = w * dt;
    let (s, c) = theta.sin_cos();
    let v_par = a * a.dot(v);
    let v_perp = v - v_par;
    let axv = a.cross(v_perp);
    let (f1, f2) = if theta.abs() < 1e-4 {
        let t2 = theta * theta;
        (dt * (1.0 - t2 / 6.0), dt * theta * (0.5 - t2 / 24.0))
    } else {
        (s / w, (1.0 - c) / w)
    };
    let x1 = x + v_par * dt + v_perp * f1 + axv * f2;
    let v1 = v_par + v_perp * c + axv * s;
    (x1, v1)
}

fn check3(p: &Particle3, dt: f64) -> Result<()> {
    if !(p.position.is_finite() && p.velocity.is_finite() && p.velocity.length_squared() > 0.0) {
        return Err(Error::Recipe(
            "3D particle: start position and a non-zero velocity must be finite".into(),
        ));
    }
    if !(p.mass.is_finite() && p.mass > 0.0 && dt.is_finite() && dt > 0.0) {
        return Err(Error::Recipe("3D particle: mass and dt must be positive".into()));
    }
    if !(p.duration.is_finite() && p.duration >= 0.0 && p.charge.scale.is_finite()) {
        return Err(Error::Recipe("3D particle: duration and charge scale must be finite".into()));
    }
    p.charge.profile.validate("3D particle")
}

/// Traces a 3D particle for its duration (or until its charge stops being finite).
pub fn trace3(p: &Particle3, field: &Field3, dt: f64, budget: &mut Budget, seed: u64) -> Result<Curve3> {
    check3(p, dt)?;
    let steps = (p.duration / dt - 1e-9).ceil().max(0.0) as u64;
    let mut ev = Evaluator::new(seed);
    let cap = (steps as usize + 1).min(1 << 16);
    let mut points = Vec::with_capacity(cap);
    let mut velocities = Vec::with_capacity(cap);
    let (mut x, mut v) = (p.position, p.velocity);
    points.push(x);
    velocities.push(v);
    for k in 0..steps {
        budget.step()?;
        let tm = (k as f64 + 0.5) * dt;
        let q = p.charge.at(tm, p.duration, &mut ev)?;
        let omega = -(q / p.mass) * field.b(x + v * (0.5 * dt));
        if !omega.is_finite() {
            break;
        }
        let (x1, v1) = advance3(x, v, omega, dt);
        if !x1.is_finite() || !v1.is_finite() {
            break;
        }
        x = x1;
        v = v1;
        points.push(x);
        velocities.push(v);
    }
    Ok(Curve3 { points, velocities, parent: None, depth: 0 })
}

/// Branching in 3D.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Branching3 {
    /// Release points per curve.
    pub count: u32,
    /// Generations.
    pub depth: u32,
    /// Release window start (arc-length fraction).
    pub from: f64,
    /// Release window end.
    pub to: f64,
    /// Children's duration relative to the parent's.
    pub duration_scale: f64,
    /// Angle (radians) between a child's start direction and the parent's tangent,
    /// about a uniformly random axis perpendicular to the tangent.
    pub tilt: f64,
}

/// Grows a 3D branching structure: the root curve, then `count` children per curve at
/// equal arc-length intervals with random charge signs, tilted off the parent's
/// tangent, for `depth` generations. Parents come first.
pub fn grow3(
    root: &Particle3,
    field: &Field3,
    dt: f64,
    branching: &Branching3,
    rng: &mut Pcg64,
    budget: &mut Budget,
    max_curves: usize,
) -> Result<Vec<Curve3>> {
    if !(branching.duration_scale.is_finite() && branching.duration_scale > 0.0 && branching.tilt.is_finite())
    {
        return Err(Error::Recipe("children: scale must be positive and tilt finite".into()));
    }
    if branching.depth > 0 && branching.count as usize >= max_curves {
        return Err(Error::Recipe(format!(
            "children: count = {} exceeds the curve limit {max_curves}; raise `curves.max_curves`",
            branching.count
        )));
    }
    let mut out = vec![trace3(root, field, dt, budget, 0)?];
    let mut particles = vec![root.clone()];
    let mut next = 0;
    while next < out.len() {
        if out[next].depth < branching.depth {
            let idx = release_indices_3d(&out[next].points, branching.count, branching.from, branching.to);
            for i in idx {
                if out.len() >= max_curves {
                    return Err(Error::Recipe(format!(
                        "curves: 3D branching makes more than {max_curves} curves; raise `curves.max_curves`"
                    )));
                }
                let parent = &particles[next];
                let t = out[next].velocities[i];
                let speed = t.length();
                let tn = t / speed;
                let a = tn.any_orthonormal_vector();
                let b = tn.cross(a);
                let roll = rng.random::<f64>() * std::f64::consts::TAU;
                let axis = a * roll.cos() + b * roll.sin();
                let dir = glam::DQuat::from_axis_angle(axis, branching.tilt) * tn;
                let sign = if rng.random::<f64>() < 0.5 { 1.0 } else { -1.0 };
                let child = Particle3 {
                    position: out[next].points[i],
                    velocity: dir * speed,
                    mass: parent.mass,
                    charge: Charge {
                        profile: parent.charge.profile.scaled_time(branching.duration_scale),
                        scale: parent.charge.scale.abs() * sign,
                        flip_at: parent.charge.flip_at.map(|f| f * branching.duration_scale),
                    },
                    duration: parent.duration * branching.duration_scale,
                };
                let mut c = trace3(&child, field, dt, budget, out.len() as u64)?;
                c.parent = Some((next, i));
                c.depth = out[next].depth + 1;
                out.push(c);
                particles.push(child);
            }
        }
        next += 1;
    }
    Ok(out)
}

fn release_indices_3d(points: &[DVec3], count: u32, from: f64, to: f64) -> Vec<usize> {
    // Arc length is all release_indices needs: unroll the 3D polyline onto a line.
    let mut s = 0.0;
    let flat: Vec<glam::DVec2> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            if i > 0 {
                s += points[i - 1].distance(*p);
            }
            glam::DVec2::new(s, 0.0)
        })
        .collect();
    release_indices(&flat, count, from, to)
}

/// How 3D curves become a skeleton.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkeletonOptions {
    /// Metres per curve unit (default 0.01: a 650-unit curve is 6.5 m).
    pub scale: f64,
    /// Radius at the root's base, metres (default 0.12).
    pub radius: f64,
    /// Tip radius as a fraction of the base radius of the same curve (default 0.15).
    pub taper: f64,
    /// A child's base radius as a fraction of its parent's radius at the release point
    /// (default 0.8), so thickness joins smoothly at branch points.
    pub child_ratio: f64,
    /// Keep every n-th point as a node (default 4).
    pub every: usize,
}

impl Default for SkeletonOptions {
    fn default() -> Self {
        SkeletonOptions { scale: 0.01, radius: 0.12, taper: 0.15, child_ratio: 0.8, every: 4 }
    }
}

/// Turns 3D curves (parents before children) into a parent-first [`Skeleton`]: one
/// chain of nodes per curve, a child's first node hanging on the parent's node at or
/// before its release point, radii tapering along each curve from the parent's radius
/// there (times `child_ratio`), orientation references propagated along each chain.
pub fn to_skeleton(curves: &[Curve3], opts: &SkeletonOptions) -> Result<Skeleton> {
    if !(opts.scale.is_finite() && opts.scale > 0.0 && opts.radius.is_finite() && opts.radius >= 0.0) {
        return Err(Error::Recipe("skeleton: scale must be positive and radius ≥ 0".into()));
    }
    let every = opts.every.max(1);
    let mut sk = Skeleton::new();
    // For each curve: (point index, node index, radius) of every kept point.
    let mut kept: Vec<Vec<(usize, u32, f32)>> = Vec::with_capacity(curves.len());
    for (ci, c) in curves.iter().enumerate() {
        let n = c.points.len();
        if n < 2 {
            kept.push(Vec::new());
            continue;
        }
        let (attach, r0) = match c.parent {
            Some((p, at)) if p < ci => {
                let list = &kept[p];
                match list.partition_point(|e| e.0 <= at).checked_sub(1).map(|k| list[k]) {
                    Some((_, node, r)) => (node, r * opts.child_ratio as f32),
                    None => (NO_PARENT, opts.radius as f32),
                }
            }
            _ => (NO_PARENT, opts.radius as f32),
        };
        let mut total = 0.0;
        let cum: Vec<f64> = std::iter::once(0.0)
            .chain(c.points.windows(2).map(|w| {
                total += w[0].distance(w[1]);
                total
            }))
            .collect();
        let total = total.max(1e-12);
        let mut list = Vec::new();
        let mut prev = attach;
        let mut up = DVec3::ZERO;
        let start = if attach == NO_PARENT { 0 } else { every.min(n - 1) };
        let mut i = start;
        loop {
            let tangent = c.velocities.get(i).copied().unwrap_or(DVec3::Y).normalize_or(DVec3::Y);
            let projected = up - tangent * tangent.dot(up);
            up = if projected.length_squared() > 1e-12 {
                projected.normalize()
            } else {
                tangent.any_orthonormal_vector()
            };
            let u = cum[i] / total;
            let r = r0 * (1.0 - u as f32 * (1.0 - opts.taper as f32));
            let pos = (c.points[i] * opts.scale).as_vec3();
            if !pos.is_finite() {
                return Err(Error::InvalidGeometry {
                    what: "3D curves".into(),
                    why: "a curve point is not finite".into(),
                });
            }
            let node = sk.push(pos, r.max(0.0), prev, up.as_vec3(), c.depth.min(u16::MAX as u32) as u16);
            list.push((i, node, r));
            prev = node;
            if i == n - 1 {
                break;
            }
            i = (i + every).min(n - 1);
        }
        kept.push(list);
    }
    sk.validate()?;
    Ok(sk)
}

/// A particle on a sphere centred at the origin.
#[derive(Debug, Clone, PartialEq)]
pub struct SphereParticle {
    /// Sphere radius.
    pub radius: f64,
    /// Unit start direction from the centre (the start point is `radius · normal`).
    pub normal: DVec3,
    /// Start direction, tangent to the sphere (projected if not).
    pub direction: DVec3,
    /// Speed.
    pub speed: f64,
    /// Mass.
    pub mass: f64,
    /// Charge.
    pub charge: Charge,
    /// Duration.
    pub duration: f64,
}

/// Traces a particle on a sphere (see the module docs); `B_n` comes from
/// [`Field3::normal_value`].
pub fn trace_on_sphere(
    p: &SphereParticle,
    field: &Field3,
    dt: f64,
    budget: &mut Budget,
    seed: u64,
) -> Result<Curve3> {
    let n0 = p.normal.normalize_or(DVec3::ZERO);
    let d0 = p.direction - n0 * n0.dot(p.direction);
    if !(p.radius.is_finite() && p.radius > 0.0 && n0 != DVec3::ZERO && d0.length_squared() > 1e-18) {
        return Err(Error::Recipe(
            "sphere particle: needs a positive radius and a tangent start direction".into(),
        ));
    }
    if !(p.speed.is_finite()
        && p.speed > 0.0
        && p.mass.is_finite()
        && p.mass > 0.0
        && dt.is_finite()
        && dt > 0.0)
    {
        return Err(Error::Recipe("sphere particle: speed, mass and dt must be positive".into()));
    }
    p.charge.profile.validate("sphere particle")?;
    let steps = (p.duration / dt - 1e-9).ceil().max(0.0) as u64;
    let mut ev = Evaluator::new(seed);
    let (mut n, mut u) = (n0, d0.normalize());
    let mut points = vec![n * p.radius];
    let mut velocities = vec![u * p.speed];
    let phi = p.speed * dt / p.radius;
    let (sp, cp) = phi.sin_cos();
    for k in 0..steps {
        budget.step()?;
        let q = p.charge.at((k as f64 + 0.5) * dt, p.duration, &mut ev)?;
        let omega = q * field.normal_value(n * p.radius) / p.mass;
        if !omega.is_finite() {
            break;
        }
        // Half turn about the outward normal (clockwise seen from outside for ω > 0).
        let half = glam::DQuat::from_axis_angle(n, -0.5 * omega * dt);
        u = half * u;
        // Great-circle step with parallel transport of the heading.
        let n1 = n * cp + u * sp;
        let u1 = u * cp - n * sp;
        n = n1.normalize();
        u = (u1 - n * n.dot(u1)).normalize_or(u1);
        let half = glam::DQuat::from_axis_angle(n, -0.5 * omega * dt);
        u = half * u;
        points.push(n * p.radius);
        velocities.push(u * p.speed);
    }
    Ok(Curve3 { points, velocities, parent: None, depth: 0 })
}
