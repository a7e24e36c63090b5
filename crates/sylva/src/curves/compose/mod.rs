//! Compositions of magnetic curves: the `[curves]` table of a `kind = "curves"` preset,
//! its layers, and the builders that turn each layer into curves of a [`Drawing`]
//! (Xu2015 §7.2–§7.3: Figs. 7.1–7.7, 7.9, 7.10, 7.13, 7.14; Xu2015-spec §3.7).
//!
//! A composition is a canvas (y up, drawing units ≈ pixels), a default style and a list
//! of layers drawn in order (`particles`, `grid`, `fill`, `hair`, `fire`, `meander`,
//! `lines`, `space`, `sphere`): `spec.rs` reads them (unknown keys are errors naming the
//! key), `layers.rs` builds each, `style.rs` gives the curves their tapered widths and
//! colours. `docs/curves.md` ("Layers", "Rendering") has every key and the width rule at
//! branchings (§8.1 future work).

use crate::error::{Error, Result};
use glam::DVec2;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

use super::fill::Region;
use super::magnetic::{Budget, Charge, TraceOptions};
use super::render::{parse_color, Drawing, Rgba};

mod layers;
mod spec;
mod style;

use self::layers::build_layer;
pub use self::spec::{
    ChargeSpec, ChildrenSpec, CurvesSpec, FieldSpec, FireSide, Generated, LayerSpec, ParticleSpec,
    PresetFile, RegionSpec, RootSpec, Stats, ViewSpec,
};
use self::style::style_curves;
pub use self::style::StyleSpec;

fn v2(a: [f64; 2]) -> DVec2 {
    DVec2::new(a[0], a[1])
}

fn check_finite(what: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::Recipe(format!("`{what}` = {v} must be a finite number")))
    }
}

fn check_positive(what: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::Recipe(format!("`{what}` = {v} must be a positive number")))
    }
}

fn heading(deg: f64) -> DVec2 {
    let r = deg.to_radians();
    DVec2::new(r.cos(), r.sin())
}

fn rotate(v: DVec2, deg: f64) -> DVec2 {
    DVec2::from_angle(deg.to_radians()).rotate(v)
}

fn uniform(rng: &mut Pcg64, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// A curve before styling.
struct Raw {
    points: Vec<DVec2>,
    parent: Option<(usize, usize)>,
    depth: u32,
    magnetic: bool,
    style: Option<StyleSpec>,
    /// Fixed colour (meander re-entries).
    color: Option<Rgba>,
}

impl Raw {
    fn new(points: Vec<DVec2>, parent: Option<(usize, usize)>, depth: u32) -> Self {
        Raw { points, parent, depth, magnetic: true, style: None, color: None }
    }
}

/// Generates the drawing of a composition.
pub(crate) fn generate(spec: &CurvesSpec, seed: u64, name: &str) -> Result<Generated> {
    for (k, v) in [
        ("width", spec.width),
        ("height", spec.height),
        ("dt", spec.dt),
        ("speed", spec.speed),
        ("mass", spec.mass),
    ] {
        check_positive(&format!("curves.{k}"), v)?;
    }
    let background = match spec.background.as_deref() {
        None => Some([255, 255, 255, 255]),
        Some("none") => None,
        Some(c) => Some(parse_color(c, "curves.background")?),
    };
    let mut budget = Budget::new(spec.max_steps);
    let mut drawing = Drawing { width: spec.width, height: spec.height, background, curves: Vec::new() };
    let mut curves3d = Vec::new();
    let mut stats = Stats::default();
    for (li, layer) in spec.layer.iter().enumerate() {
        let what = format!("{name}: layer {} ({})", li + 1, layer.kind());
        let layer_seed = seed.wrapping_add(li as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed;
        let mut rng = Pcg64::seed_from_u64(layer_seed);
        let noise_seed = seed.wrapping_add(li as u64);
        let (style_spec, mirror) = layer.common();
        let style_spec = style_spec.over(&spec.style);
        let ctx = Ctx { spec, what: &what, noise_seed };
        let (raws, field) = build_layer(layer, &ctx, &mut rng, &mut budget, &mut stats, &mut curves3d)?;
        let count = drawing.curves.len();
        let magnetic_before = drawing.magnetic_count();
        if count + raws.len() * if mirror { 2 } else { 1 } > spec.max_curves {
            return Err(Error::Recipe(format!(
                "{what}: more than {} curves; raise `curves.max_curves`",
                spec.max_curves
            )));
        }
        let styled = style_curves(&raws, &style_spec, &what, field.as_ref(), &mut rng, count)?;
        drawing.curves.extend(styled);
        let mirrored: Vec<bool> = mirror_flags(layer, &raws, mirror);
        if mirrored.iter().any(|&m| m) {
            // Mirror copies keep their parents' indices shifted to the copies.
            let mut index_of = vec![usize::MAX; raws.len()];
            let mut copies = Vec::new();
            for (i, m) in mirrored.iter().enumerate() {
                if *m {
                    index_of[i] = drawing.curves.len() + copies.len();
                    let mut c = drawing.curves[count + i].clone();
                    for p in &mut c.points {
                        p.x = spec.width - p.x;
                    }
                    c.parent = c.parent.and_then(|(p, k)| {
                        let local = p.checked_sub(count)?;
                        let mapped = *index_of.get(local)?;
                        (mapped != usize::MAX).then_some((mapped, k))
                    });
                    copies.push(c);
                }
            }
            drawing.curves.extend(copies);
        }
        stats.curves += drawing.magnetic_count() - magnetic_before;
    }
    stats.steps = budget.used;
    Ok(Generated { drawing, curves3d, stats })
}

/// Which raw curves of a layer get a mirrored copy.
fn mirror_flags(layer: &LayerSpec, raws: &[Raw], mirror: bool) -> Vec<bool> {
    if let LayerSpec::Particles { particle, .. } = layer {
        // Per-particle overrides: map each raw curve to its particle via its root.
        let mut root_of = vec![0usize; raws.len()];
        let mut next_root = 0;
        for (i, r) in raws.iter().enumerate() {
            root_of[i] = match r.parent {
                Some((p, _)) => root_of[p],
                None => {
                    let k = next_root;
                    next_root += 1;
                    k
                }
            };
        }
        return root_of.iter().map(|&k| particle.get(k).and_then(|p| p.mirror).unwrap_or(mirror)).collect();
    }
    vec![mirror; raws.len()]
}

struct Ctx<'a> {
    spec: &'a CurvesSpec,
    what: &'a str,
    noise_seed: u64,
}

impl Ctx<'_> {
    fn opts(&self) -> TraceOptions {
        TraceOptions { dt: self.spec.dt, integrator: self.spec.integrator, min_radius: 0.0 }
    }

    fn canvas(&self) -> Region {
        Region::Rect { min: DVec2::ZERO, max: DVec2::new(self.spec.width, self.spec.height) }
    }

    fn err(&self, why: impl std::fmt::Display) -> Error {
        Error::Recipe(format!("{}: {why}", self.what))
    }

    /// Refuses `n` curves of one kind (`strands`, `tongues`, …) when they alone exceed
    /// `curves.max_curves`, before any is traced.
    fn check_count(&self, n: u64, kind: &str) -> Result<()> {
        let limit = self.spec.max_curves;
        if n > limit as u64 {
            return Err(
                self.err(format!("{n} {kind} exceed the curve limit {limit}; raise `curves.max_curves`"))
            );
        }
        Ok(())
    }

    /// Charge and duration from a spec, scale and optional flip fraction.
    fn charge(
        &self,
        spec: &ChargeSpec,
        k: f64,
        duration: Option<f64>,
        flip_at: Option<f64>,
    ) -> Result<(Charge, f64)> {
        let profile = spec.profile().map_err(|e| match e {
            Error::Recipe(m) => self.err(m),
            e => e,
        })?;
        profile.validate(self.what)?;
        let duration = duration
            .or(profile.natural_duration())
            .ok_or_else(|| self.err("this charge profile needs a `duration`"))?;
        if !(duration.is_finite() && duration >= 0.0) {
            return Err(self.err(format!("duration {duration} must be a number ≥ 0")));
        }
        check_finite("k", k).map_err(|e| self.err(e))?;
        let flip_at = match flip_at {
            Some(f) if !f.is_finite() => return Err(self.err(format!("flip_at = {f} must be finite"))),
            Some(f) => Some(f * duration),
            None => None,
        };
        Ok((Charge { profile, scale: k, flip_at }, duration))
    }
}
