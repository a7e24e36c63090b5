//! Magnetic curves: a charged particle traced in the plane under the Lorentz force
//! `F = q v × B` with `B = B_z ẑ` (Xu2015 §7.2.1–§7.2.3; Xu2015-spec §3.1–§3.4).
//!
//! # Dynamics and the integrator
//!
//! With `B = B_z ẑ` the acceleration is `(q B_z / m)(v_y, −v_x)`: the velocity turns at
//! the angular rate `ω = q B_z / m`, **clockwise** for `ω > 0` (x right, y up), and its
//! length never changes. A constant `ω` traces a circle of radius `|v| / |ω| =
//! m|v| / (|q||B|)` (§7.2.2).
//!
//! [`Integrator::Exact`] (the default) is an exponential integrator: over one step of
//! length `dt` it freezes `ω` at its midpoint value `ω(t + dt/2, x + v·dt/2)` and
//! moves the particle along the exact circular arc of that `ω`: `v` is rotated by
//! `−ω·dt` and `x` advances by `dt · v ⊗ (sin θ/θ − i(1 − cos θ)/θ)` (complex product,
//! `θ = ω·dt`). It is exact for piecewise-constant `q·B` (every point of a constant-`q`,
//! uniform-`B` path lies on the analytic circle to rounding, however many turns), keeps
//! `|v|` constant to rounding for any `q(t)` and `B(x)`, and is second-order accurate
//! when `ω` varies. [`Integrator::Euler`] is the seed's forward Euler (`v += (q/m)(v×B)dt`
//! then `x += v·dt`), kept as the faithful mode: each step multiplies `|v|` by
//! `√(1 + (ω·dt)²)`, so circles spiral outwards. [`Integrator::Renormalized`] is Euler
//! with `|v|` reset after each step (first order, no drift in speed).
//!
//! Defaults follow Xu2015-spec §3.1: `m = |v| = B = dt = 1`, in pixel units, so a curve of
//! duration `T` is about `T` pixels long.
//!
//! # Charge profiles
//!
//! [`Profile`] gives `q(t)` (Fig. 7.1, §7.2.4): constant, power law `(t + t₀)^−α`,
//! spiral `(T − t)^−α` (the fire's `(T − t)^{+α}` is a negative `α`), triangle, square
//! and sine waves (amplitudes are **peak to peak**: "amplitude 1, mean 0.5" spans
//! `[0, 1]`), and user expressions in `t` and `T` (the cpfg expression language of
//! [`crate::lsystem::expr`]; its trigonometry takes **degrees**). A [`Charge`] scales a
//! profile and may flip its sign at a given time (hair waves, fire).
//!
//! # Branching
//!
//! [`grow_branching`] releases children at equal arc-length intervals along a parent,
//! each starting with the parent's tangent and a random (or alternating, or split ±)
//! charge sign, recursively (§7.2.3, Fig. 7.2).
//!
//! All work is bounded by a [`Budget`] of integration steps.

use crate::error::{Error, Result};
use crate::lsystem::expr::{self, Evaluator, Expr, Scope};
use crate::lsystem::source::Source;
use glam::DVec2;
use rand::RngExt;
use rand_pcg::Pcg64;
use serde::Deserialize;

use crate::noise::Perlin;

/// Default limit on integration steps for one composition (all particles, all
/// attempts together).
pub const DEFAULT_MAX_STEPS: u64 = 20_000_000;

/// How the particle's state is advanced over one time step (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Integrator {
    /// Exact circular arc per step with the midpoint `ω`: constant speed, exact circles.
    #[default]
    Exact,
    /// The seed's forward Euler: speed (and radius) drift outwards.
    Euler,
    /// Forward Euler with the speed renormalized after every step.
    Renormalized,
}

/// A charge profile `q(t)` on `t ∈ [0, duration]` (Xu2015 Fig. 7.1, §7.2.4).
#[derive(Debug, Clone, PartialEq)]
pub enum Profile {
    /// `q(t) = q`.
    Constant {
        /// The charge.
        q: f64,
    },
    /// `q(t) = (t + t0)^−α`: the radius grows with time (Fig. 7.1, first row, α = 0.7).
    Power {
        /// Exponent α.
        alpha: f64,
        /// Time offset t₀ > 0 that keeps `q(0)` finite.
        t0: f64,
    },
    /// `q(t) = (T − t)^−α` on `[0, T)`: a spiral that tightens towards its end
    /// (§7.2.4, Fig. 7.3). A negative α gives the fire's `(T − t)^{|α|}` (Fig. 7.13).
    Spiral {
        /// The curve's duration T.
        t_end: f64,
        /// Exponent α.
        alpha: f64,
    },
    /// A triangle wave starting at its minimum: `mean + amplitude/2 · (1 − 4|u − ½|)`,
    /// `u` the phase in `[0, 1)`.
    Triangle(Wave),
    /// A square wave: `mean + amplitude/2` for the first half period, `mean −
    /// amplitude/2` for the second.
    Square(Wave),
    /// `mean + amplitude/2 · sin(2π(t/period + phase))` (hair, Fig. 7.10 lower left).
    Sine(Wave),
    /// A user expression in `t` and `T` (the duration).
    Expr(UserExpr),
}

/// The numbers of a periodic profile ([`Profile::Triangle`], [`Profile::Square`],
/// [`Profile::Sine`]); a preset writes them inline (`charge = { type = "sine",
/// amplitude = 0.04, period = 90 }`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wave {
    /// Peak-to-peak amplitude.
    pub amplitude: f64,
    /// Mean value (default 0).
    #[serde(default)]
    pub mean: f64,
    /// Period (time units).
    pub period: f64,
    /// Phase offset as a fraction of the period (default 0).
    #[serde(default)]
    pub phase: f64,
}

impl Wave {
    /// The phase `u ∈ [0, 1)` at time `t`.
    fn phase_at(&self, t: f64) -> f64 {
        (t / self.period + self.phase).rem_euclid(1.0)
    }
}

/// A compiled user expression `q(t, T)` in the cpfg expression language.
#[derive(Debug, Clone, PartialEq)]
pub struct UserExpr {
    /// The expression text as written.
    pub text: String,
    expr: Expr,
}

impl UserExpr {
    /// Compiles `text` with the variables `t` (time) and `T` (duration). Syntax errors
    /// carry a caret excerpt of the expression.
    pub fn compile(text: &str) -> Result<Self> {
        let src = Source::new("charge expression", text, &[])?;
        let locals = ["t".to_string(), "T".to_string()];
        let scope = Scope { locals: &locals, globals: None };
        let expr = expr::compile(&src, 0, src.text.len(), &scope)?;
        Ok(UserExpr { text: text.to_string(), expr })
    }

    /// Evaluates the expression at `(t, T)`.
    pub fn eval(&self, ev: &mut Evaluator, t: f64, duration: f64) -> Result<f64> {
        ev.eval(&self.expr, &[t, duration]).map_err(|e| {
            Error::Recipe(format!(
                "charge expression `{}` failed at t = {t}: {:?} (division by zero or a non-finite value)",
                self.text, e.kind
            ))
        })
    }
}

impl Profile {
    /// The profile's natural duration (the spiral's `T`), if it has one.
    pub fn natural_duration(&self) -> Option<f64> {
        match self {
            Profile::Spiral { t_end, .. } => Some(*t_end),
            _ => None,
        }
    }

    /// Checks that every number is finite and every period, `T` and `t₀` positive;
    /// `what` names the profile in the message.
    pub fn validate(&self, what: &str) -> Result<()> {
        // Every number must be finite; the one that sets the time scale, positive.
        let (numbers, positive) = match self {
            Profile::Constant { q } => (vec![("q", *q)], None),
            Profile::Power { alpha, t0 } => (vec![("alpha", *alpha), ("t0", *t0)], Some(("t0", *t0))),
            Profile::Spiral { t_end, alpha } => (vec![("T", *t_end), ("alpha", *alpha)], Some(("T", *t_end))),
            Profile::Triangle(w) | Profile::Square(w) | Profile::Sine(w) => (
                vec![("amplitude", w.amplitude), ("mean", w.mean), ("period", w.period), ("phase", w.phase)],
                Some(("period", w.period)),
            ),
            Profile::Expr(_) => return Ok(()),
        };
        if let Some((name, v)) = numbers.into_iter().find(|(_, v)| !v.is_finite()) {
            return Err(Error::Recipe(format!("{what}: `{name}` = {v} is not a finite number")));
        }
        match positive {
            Some((name, v)) if v <= 0.0 => {
                Err(Error::Recipe(format!("{what}: `{name}` = {v} must be positive")))
            }
            _ => Ok(()),
        }
    }

    /// `q(t)` for a curve of the given duration. Returns a non-finite value only for
    /// the spiral at or past `T` (the trace ends there).
    pub fn at(&self, t: f64, duration: f64, ev: &mut Evaluator) -> Result<f64> {
        Ok(match self {
            Profile::Constant { q } => *q,
            Profile::Power { alpha, t0 } => (t + t0).powf(-alpha),
            Profile::Spiral { t_end, alpha } => {
                let r = t_end - t;
                if r <= 0.0 {
                    f64::INFINITY
                } else {
                    r.powf(-alpha)
                }
            }
            Profile::Triangle(w) => {
                let u = w.phase_at(t);
                w.mean + 0.5 * w.amplitude * (1.0 - 4.0 * (u - 0.5).abs())
            }
            Profile::Square(w) => {
                let u = w.phase_at(t);
                w.mean + if u < 0.5 { 0.5 * w.amplitude } else { -0.5 * w.amplitude }
            }
            Profile::Sine(w) => {
                let u = w.phase_at(t);
                w.mean + 0.5 * w.amplitude * (std::f64::consts::TAU * u).sin()
            }
            Profile::Expr(e) => e.eval(ev, t, duration)?,
        })
    }

    /// The same profile for a curve `factor` times as long: the spiral's `T` scales;
    /// waves, power laws and expressions are unchanged (an expression sees the new `T`).
    pub fn scaled_time(&self, factor: f64) -> Profile {
        match self {
            Profile::Spiral { t_end, alpha } => Profile::Spiral { t_end: t_end * factor, alpha: *alpha },
            p => p.clone(),
        }
    }
}

/// A charge: a profile times a signed scale, optionally flipping sign at a time.
#[derive(Debug, Clone, PartialEq)]
pub struct Charge {
    /// The profile `q(t)`.
    pub profile: Profile,
    /// Multiplies the profile; its sign is the winding (positive: clockwise).
    pub scale: f64,
    /// Time at which the sign flips (hair waves, fire's inflection at `T/2`).
    pub flip_at: Option<f64>,
}

impl Charge {
    /// `scale · profile` with no flip.
    pub fn new(profile: Profile, scale: f64) -> Self {
        Charge { profile, scale, flip_at: None }
    }

    /// `q(t)` including scale and flip.
    #[inline]
    pub fn at(&self, t: f64, duration: f64, ev: &mut Evaluator) -> Result<f64> {
        let q = self.scale * self.profile.at(t, duration, ev)?;
        Ok(match self.flip_at {
            Some(f) if t >= f => -q,
            _ => q,
        })
    }
}

/// The magnetic field `B_z(x, y)`.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    /// The same `B_z` everywhere.
    Uniform(f64),
    /// `B_z = strength · 0.5 · (1 + noise(x/scale, y/scale))`, in `[0, strength]`
    /// (§7.2.4, Fig. 7.5, with scale 50). The noise is evaluated exactly at the
    /// particle's position rather than interpolated from a lattice.
    Perlin {
        /// The seeded noise.
        noise: Perlin,
        /// Feature size in drawing units (the seed's 50).
        scale: f64,
        /// Largest field value.
        strength: f64,
    },
}

impl Field {
    /// `B_z` at `p`.
    #[inline]
    pub fn bz(&self, p: DVec2) -> f64 {
        match self {
            Field::Uniform(b) => *b,
            Field::Perlin { noise, scale, strength } => strength * 0.5 * (1.0 + noise.noise2(p / *scale)),
        }
    }

    /// The raw noise value in `[-1, 1]` at `p` (0 for a uniform field), used to colour
    /// curves (Fig. 7.6).
    pub fn noise(&self, p: DVec2) -> f64 {
        match self {
            Field::Uniform(_) => 0.0,
            Field::Perlin { noise, scale, .. } => noise.noise2(p / *scale),
        }
    }

    fn is_uniform(&self) -> bool {
        matches!(self, Field::Uniform(_))
    }
}

/// A particle to trace.
#[derive(Debug, Clone, PartialEq)]
pub struct Particle {
    /// Start position.
    pub position: DVec2,
    /// Start velocity (its length is the speed, kept constant by the exact integrator).
    pub velocity: DVec2,
    /// Mass m > 0.
    pub mass: f64,
    /// The charge profile.
    pub charge: Charge,
    /// How long to trace (the spiral's `T` for spirals).
    pub duration: f64,
}

/// Integration settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceOptions {
    /// Time step (default 1: one pixel per step at unit speed).
    pub dt: f64,
    /// The integrator.
    pub integrator: Integrator,
    /// Stop when the radius of curvature `|v|/|ω|` falls below this (0: never). Spiral
    /// tips in a space-filling occupancy grid stop before they tighten below one cell
    /// (Xu2015-spec §3.5).
    pub min_radius: f64,
}

impl Default for TraceOptions {
    fn default() -> Self {
        TraceOptions { dt: 1.0, integrator: Integrator::Exact, min_radius: 0.0 }
    }
}

/// Why a trace ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// It ran for its whole duration.
    Duration,
    /// The visitor stopped it (it left a region, met its own trail, …); the refused
    /// step is not part of the trace.
    Stopped,
    /// The visitor aborted it (a crossing in space filling).
    Aborted,
    /// Its radius of curvature fell below [`TraceOptions::min_radius`].
    TightRadius,
    /// The charge became infinite or NaN (a spiral at its `T`).
    Singular,
}

/// What the visitor decides about one proposed step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Accept the step and go on.
    Continue,
    /// Refuse the step and end the trace normally.
    Stop,
    /// Refuse the step and mark the trace as aborted.
    Abort,
}

/// One proposed step, shown to the visitor before it is accepted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepView {
    /// Index the new point would get (≥ 1).
    pub index: usize,
    /// Time at the new point.
    pub t: f64,
    /// Position before the step.
    pub from: DVec2,
    /// Position after the step.
    pub to: DVec2,
    /// Velocity before the step.
    pub velocity_before: DVec2,
    /// Velocity after the step.
    pub velocity: DVec2,
    /// The angular rate `q B_z / m` used for the step.
    pub omega: f64,
}

/// A traced curve: points (the start first), the time and velocity at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Positions, one per accepted step plus the start.
    pub points: Vec<DVec2>,
    /// Time at each point.
    pub times: Vec<f64>,
    /// Velocity at each point.
    pub velocities: Vec<DVec2>,
    /// Why it ended.
    pub end: End,
}

impl Trace {
    /// Total polyline length.
    pub fn length(&self) -> f64 {
        self.points.windows(2).map(|w| w[0].distance(w[1])).sum()
    }
}

/// A limit on the total number of integration steps of a composition (particles ×
/// steps, failed attempts included).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Budget {
    /// The limit.
    pub limit: u64,
    /// Steps taken so far.
    pub used: u64,
}

impl Budget {
    /// A budget of `limit` steps.
    pub fn new(limit: u64) -> Self {
        Budget { limit, used: 0 }
    }

    /// Takes one step, or fails with a message naming the limit and how to raise it.
    #[inline]
    pub fn step(&mut self) -> Result<()> {
        if self.used >= self.limit {
            return Err(budget_error(self.limit));
        }
        self.used += 1;
        Ok(())
    }
}

/// The error of an exhausted step budget.
pub fn budget_error(limit: u64) -> Error {
    Error::Recipe(format!(
        "curves: more than {limit} integration steps (particles × steps, retries included); \
         raise `curves.max_steps` (`--set curves.max_steps=N`) or use fewer or shorter particles"
    ))
}

/// Checks a particle's numbers; `what` names it in the message.
pub fn validate_particle(p: &Particle, opts: &TraceOptions, what: &str) -> Result<()> {
    let bad = |why: String| Err(Error::Recipe(format!("{what}: {why}")));
    if !p.position.is_finite() || !p.velocity.is_finite() {
        return bad("start position and velocity must be finite".into());
    }
    if p.velocity.length_squared() == 0.0 {
        return bad("the start velocity is zero".into());
    }
    if !(p.mass.is_finite() && p.mass > 0.0) {
        return bad(format!("mass {} must be a positive number", p.mass));
    }
    if !(p.duration.is_finite() && p.duration >= 0.0) {
        return bad(format!("duration {} must be a non-negative number", p.duration));
    }
    if !p.charge.scale.is_finite() || p.charge.flip_at.is_some_and(|f| !f.is_finite()) {
        return bad("charge scale and flip time must be finite".into());
    }
    if !(opts.dt.is_finite() && opts.dt > 0.0) {
        return bad(format!("time step dt = {} must be a positive number", opts.dt));
    }
    if !(opts.min_radius.is_finite() && opts.min_radius >= 0.0) {
        return bad(format!("min_radius = {} must be ≥ 0", opts.min_radius));
    }
    p.charge.profile.validate(what)
}

/// Advances `(x, v)` by one step of angular rate `omega`.
#[inline]
pub fn advance(x: DVec2, v: DVec2, omega: f64, dt: f64, integrator: Integrator) -> (DVec2, DVec2) {
    match integrator {
        Integrator::Exact => {
            let theta = omega * dt;
            let (s, c) = theta.sin_cos();
            // v(t) = v₀·e^{−iωt}; ∫₀^dt v = dt·v₀·(sin θ/θ − i(1 − cos θ)/θ).
            let (a, b) = if theta.abs() < 1e-4 {
                let t2 = theta * theta;
                (1.0 - t2 / 6.0 + t2 * t2 / 120.0, -theta * (0.5 - t2 / 24.0))
            } else {
                (s / theta, -(1.0 - c) / theta)
            };
            let x1 = x + dt * DVec2::new(v.x * a - v.y * b, v.x * b + v.y * a);
            let v1 = DVec2::new(v.x * c + v.y * s, -v.x * s + v.y * c);
            (x1, v1)
        }
        Integrator::Euler => {
            let v1 = v + dt * omega * DVec2::new(v.y, -v.x);
            (x + v1 * dt, v1)
        }
        Integrator::Renormalized => {
            let v1 = v + dt * omega * DVec2::new(v.y, -v.x);
            let v1 = v1 * (v.length() / v1.length());
            (x + v1 * dt, v1)
        }
    }
}

/// Traces `p` through `field`, asking `visit` about every step (see [`Control`]).
///
/// The trace has `ceil(duration/dt)` steps at most; it ends early when the visitor
/// says so, when the radius of curvature falls below `opts.min_radius`, or when the
/// charge stops being finite. Every step is charged to `budget`; an exhausted budget is
/// an error. `seed` drives `ran()` in a user expression.
pub fn trace_with(
    p: &Particle,
    field: &Field,
    opts: &TraceOptions,
    budget: &mut Budget,
    seed: u64,
    mut visit: impl FnMut(&StepView) -> Control,
) -> Result<Trace> {
    validate_particle(p, opts, "particle")?;
    let dt = opts.dt;
    // Saturating float-to-int cast; the budget bounds the real work.
    let steps = (p.duration / dt - 1e-9).ceil().max(0.0) as u64;
    let mut ev = Evaluator::new(seed);
    let cap = (steps as usize + 1).min(1 << 16);
    let mut points = Vec::with_capacity(cap);
    let mut times = Vec::with_capacity(cap);
    let mut velocities = Vec::with_capacity(cap);
    let (mut x, mut v) = (p.position, p.velocity);
    points.push(x);
    times.push(0.0);
    velocities.push(v);
    let speed = v.length();
    let uniform = field.is_uniform();
    let inv_m = 1.0 / p.mass;
    let mut end = End::Duration;
    for k in 0..steps {
        budget.step()?;
        let t = k as f64 * dt;
        let omega = match opts.integrator {
            Integrator::Exact => {
                let tm = t + 0.5 * dt;
                let q = p.charge.at(tm, p.duration, &mut ev)?;
                let b = if uniform { field.bz(x) } else { field.bz(x + v * (0.5 * dt)) };
                q * b * inv_m
            }
            _ => p.charge.at(t, p.duration, &mut ev)? * field.bz(x) * inv_m,
        };
        if !omega.is_finite() {
            end = End::Singular;
            break;
        }
        if opts.min_radius > 0.0 && omega.abs() * opts.min_radius > v.length().max(speed) {
            end = End::TightRadius;
            break;
        }
        let (x1, v1) = advance(x, v, omega, dt, opts.integrator);
        if !x1.is_finite() || !v1.is_finite() {
            end = End::Singular;
            break;
        }
        let view = StepView {
            index: points.len(),
            t: t + dt,
            from: x,
            to: x1,
            velocity_before: v,
            velocity: v1,
            omega,
        };
        match visit(&view) {
            Control::Continue => {}
            Control::Stop => {
                end = End::Stopped;
                break;
            }
            Control::Abort => {
                end = End::Aborted;
                break;
            }
        }
        x = x1;
        v = v1;
        points.push(x);
        times.push(t + dt);
        velocities.push(v);
    }
    Ok(Trace { points, times, velocities, end })
}

/// [`trace_with`] without a visitor.
pub fn trace(p: &Particle, field: &Field, opts: &TraceOptions, budget: &mut Budget) -> Result<Trace> {
    trace_with(p, field, opts, budget, 0, |_| Control::Continue)
}

/// Signed discrete curvature at each interior point of a polyline (Menger curvature
/// of three consecutive points: `1/R` of the circle through them, positive for a
/// counter-clockwise turn). The first and last points copy their neighbours; fewer
/// than three points give zeros.
pub fn curvature(points: &[DVec2]) -> Vec<f64> {
    let n = points.len();
    let mut k = vec![0.0; n];
    if n < 3 {
        return k;
    }
    for i in 1..n - 1 {
        let (a, b, c) = (points[i - 1], points[i], points[i + 1]);
        let d = (b - a).length() * (c - b).length() * (c - a).length();
        k[i] = if d > 0.0 { 2.0 * (b - a).perp_dot(c - b) / d } else { 0.0 };
    }
    k[0] = k[1];
    k[n - 1] = k[n - 2];
    k
}

/// How children's charge signs are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Signs {
    /// Each child's sign is a fair coin (§7.2.3).
    #[default]
    Random,
    /// Signs alternate +, −, +, … along the parent.
    Alternate,
    /// Each release point gets two children of opposite sign: the particle splits in
    /// two (§7.2.1).
    Split,
}

/// Recursive branching along a parent curve (§7.2.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Branching {
    /// Release points per curve (Fig. 7.2: 6).
    pub count: u32,
    /// Generations of children (1: children only, no grandchildren).
    pub depth: u32,
    /// Release window start, as a fraction of the parent's arc length.
    pub from: f64,
    /// Release window end, as a fraction of the parent's arc length.
    pub to: f64,
    /// Sign rule.
    pub signs: Signs,
    /// Children's duration (and spiral `T`) relative to their parent's.
    pub duration_scale: f64,
}

/// One curve of a branching structure.
#[derive(Debug, Clone, PartialEq)]
pub struct BranchCurve {
    /// The traced curve.
    pub trace: Trace,
    /// `(parent curve index, point index on the parent)`, `None` for the root.
    pub parent: Option<(usize, usize)>,
    /// Generation (0 for the root).
    pub depth: u32,
    /// The sign the charge was multiplied by.
    pub sign: f64,
}

/// Points at equal arc-length fractions `from + (to − from)·k/(count + 1)`, k = 1..count,
/// as point indices of `points`.
pub fn release_indices(points: &[DVec2], count: u32, from: f64, to: f64) -> Vec<usize> {
    if points.len() < 2 || count == 0 {
        return Vec::new();
    }
    let mut cum = Vec::with_capacity(points.len());
    let mut s = 0.0;
    cum.push(0.0);
    for w in points.windows(2) {
        s += w[0].distance(w[1]);
        cum.push(s);
    }
    let total = s;
    let (from, to) = (from.clamp(0.0, 1.0), to.clamp(0.0, 1.0));
    let mut out = Vec::with_capacity(count as usize);
    for k in 1..=count {
        let target = total * (from + (to - from) * k as f64 / (count as f64 + 1.0));
        let i = cum.partition_point(|&c| c < target).min(points.len() - 1);
        out.push(i);
    }
    out
}

/// Grows a branching structure from `root`: the root curve, then `count` children per
/// curve at equal arc-length intervals, for `depth` generations. Children start at the
/// release point with the parent's velocity there; their charge is the parent's profile
/// scaled in time by `duration_scale` with a sign chosen by `branching.signs` (drawn
/// from `rng`). Curves are returned parents first.
pub fn grow_branching(
    root: &Particle,
    field: &Field,
    opts: &TraceOptions,
    branching: &Branching,
    rng: &mut Pcg64,
    budget: &mut Budget,
    max_curves: usize,
) -> Result<Vec<BranchCurve>> {
    if !(branching.duration_scale.is_finite() && branching.duration_scale > 0.0) {
        return Err(Error::Recipe(format!(
            "children: duration_scale = {} must be a positive number",
            branching.duration_scale
        )));
    }
    if branching.depth > 0 && branching.count as usize >= max_curves {
        return Err(Error::Recipe(format!(
            "children: count = {} exceeds the curve limit {max_curves}; raise `curves.max_curves`",
            branching.count
        )));
    }
    let mut out =
        vec![BranchCurve { trace: trace(root, field, opts, budget)?, parent: None, depth: 0, sign: 1.0 }];
    let mut particles = vec![root.clone()];
    let mut next = 0;
    while next < out.len() {
        let (depth, parent_particle) = (out[next].depth, particles[next].clone());
        if depth < branching.depth {
            let idx = release_indices(&out[next].trace.points, branching.count, branching.from, branching.to);
            for (k, &i) in idx.iter().enumerate() {
                let signs: &[f64] = match branching.signs {
                    Signs::Random => {
                        if rng.random::<f64>() < 0.5 {
                            &[1.0]
                        } else {
                            &[-1.0]
                        }
                    }
                    Signs::Alternate => {
                        if k % 2 == 0 {
                            &[1.0]
                        } else {
                            &[-1.0]
                        }
                    }
                    Signs::Split => &[1.0, -1.0],
                };
                for &sign in signs {
                    if out.len() >= max_curves {
                        return Err(Error::Recipe(format!(
                            "curves: branching makes more than {max_curves} curves; raise `curves.max_curves` \
                             or lower children.count / children.depth"
                        )));
                    }
                    let tr = &out[next].trace;
                    let child = Particle {
                        position: tr.points[i],
                        velocity: tr.velocities[i],
                        mass: parent_particle.mass,
                        charge: Charge {
                            profile: parent_particle.charge.profile.scaled_time(branching.duration_scale),
                            scale: parent_particle.charge.scale.abs() * sign,
                            flip_at: parent_particle.charge.flip_at.map(|f| f * branching.duration_scale),
                        },
                        duration: parent_particle.duration * branching.duration_scale,
                    };
                    let trace = trace(&child, field, opts, budget)?;
                    out.push(BranchCurve { trace, parent: Some((next, i)), depth: depth + 1, sign });
                    particles.push(child);
                }
            }
        }
        next += 1;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(profile: Profile, duration: f64) -> Particle {
        Particle {
            position: DVec2::ZERO,
            velocity: DVec2::X,
            mass: 1.0,
            charge: Charge::new(profile, 1.0),
            duration,
        }
    }

    #[test]
    fn positive_omega_turns_clockwise() {
        let p = unit(Profile::Constant { q: 0.1 }, 10.0);
        let tr = trace(&p, &Field::Uniform(1.0), &TraceOptions::default(), &mut Budget::new(100)).unwrap();
        assert!(tr.points.last().unwrap().y < 0.0);
    }

    #[test]
    fn euler_drifts_outwards() {
        let p = unit(Profile::Constant { q: 0.05 }, 2000.0);
        let opts = TraceOptions { integrator: Integrator::Euler, ..Default::default() };
        let tr = trace(&p, &Field::Uniform(1.0), &opts, &mut Budget::new(10_000)).unwrap();
        assert!(tr.velocities.last().unwrap().length() > 1.5);
    }

    #[test]
    fn budget_is_enforced() {
        let p = unit(Profile::Constant { q: 0.05 }, 2000.0);
        let e = trace(&p, &Field::Uniform(1.0), &TraceOptions::default(), &mut Budget::new(100)).unwrap_err();
        assert!(e.to_string().contains("max_steps"), "{e}");
    }

    #[test]
    fn expression_profile() {
        let e = UserExpr::compile("0.01 * (1 + t / T)").unwrap();
        let mut ev = Evaluator::new(0);
        assert!((e.eval(&mut ev, 50.0, 100.0).unwrap() - 0.015).abs() < 1e-12);
        assert!(UserExpr::compile("t +").is_err());
        assert!(UserExpr::compile("x").is_err());
        let z = UserExpr::compile("1 / (t - t)").unwrap();
        assert!(z.eval(&mut ev, 1.0, 2.0).is_err());
    }
}
