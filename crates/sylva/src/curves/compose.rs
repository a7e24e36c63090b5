//! Compositions of magnetic curves: the `[curves]` table of a `kind = "curves"` preset,
//! its layers, and the builders that turn each layer into curves of a [`Drawing`]
//! (Xu2015 §7.2–§7.3: Figs. 7.1–7.7, 7.9, 7.10, 7.13, 7.14; Xu2015-spec §3.7).
//!
//! A composition is a canvas (y up, drawing units ≈ pixels), a default [`StyleSpec`] and
//! a list of layers drawn in order:
//!
//! | `type` | what it draws | seed |
//! |---|---|---|
//! | `particles` | listed particles, each optionally branching (children at equal intervals) | Figs. 7.1, 7.2, 7.9 |
//! | `grid` | one spiral per `(T, α)` cell, centred in its cell | Fig. 7.3 |
//! | `fill` | space filling with an occupancy grid and the `(T, α)` ladder | Figs. 7.4–7.7 |
//! | `hair` | strands released along a drawn hairline | Figs. 7.10, 7.12 |
//! | `fire` | chained particles cut where `v_x` changes sign (flame tips) | Fig. 7.13 |
//! | `meander` | one particle bouncing in a region, a new colour per re-entry | Fig. 7.14 |
//! | `lines` | drawn polylines (a face, a window frame) | — |
//! | `space` | 3D magnetic curves (a vector field **B**), drawn in projection | §8.1 |
//! | `sphere` | curves traced on a sphere's surface (B normal to it, from 3D noise) | §8.1 |
//!
//! Every layer may set `style` (merged over the composition's), `field` (uniform or
//! Perlin) and `mirror = true` (append the reflection about the canvas's vertical
//! centre line: the window frames). Unknown keys are errors naming the key.
//!
//! Thickness: a curve's width tapers linearly from `width · child_width^depth` to
//! `taper` times that; a branch starts at its parent's width at the release point and
//! blends to its own width over `join` widths with a smoothstep, so branches join
//! their parents without a step (§8.1 future work: "thickness as it relates to
//! branching").

use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::Deserialize;

use super::fill::{self, FillParams, Region, Root};
use super::magnetic::{
    self, advance, grow_branching, Branching, Budget, Charge, Field, Integrator, Particle, Profile, Signs,
    TraceOptions, UserExpr,
};
use super::noise::Perlin;
use super::render::{parse_color, Curve, Drawing, Paint, Rgba};
use super::space;

fn one() -> f64 {
    1.0
}
fn half() -> f64 {
    0.5
}

/// A charge profile as written in a preset (`charge = { type = "spiral", T = 650,
/// alpha = 0.8 }`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ChargeSpec {
    /// `q(t) = q`.
    Constant {
        /// The charge.
        q: f64,
    },
    /// `q(t) = (t + t0)^−α`.
    Power {
        /// α.
        alpha: f64,
        /// t₀ (default 1).
        #[serde(default = "one")]
        t0: f64,
    },
    /// `q(t) = (T − t)^−α`.
    Spiral {
        /// The duration T.
        #[serde(rename = "T")]
        t_end: f64,
        /// α (negative for the fire's `(T − t)^{|α|}`).
        alpha: f64,
    },
    /// Triangle wave (peak-to-peak amplitude).
    Triangle {
        /// Peak-to-peak amplitude.
        amplitude: f64,
        /// Mean.
        #[serde(default)]
        mean: f64,
        /// Period.
        period: f64,
        /// Phase, fraction of a period.
        #[serde(default)]
        phase: f64,
    },
    /// Square wave.
    Square {
        /// Peak-to-peak amplitude.
        amplitude: f64,
        /// Mean.
        #[serde(default)]
        mean: f64,
        /// Period.
        period: f64,
        /// Phase, fraction of a period.
        #[serde(default)]
        phase: f64,
    },
    /// Sine wave.
    Sine {
        /// Peak-to-peak amplitude.
        amplitude: f64,
        /// Mean.
        #[serde(default)]
        mean: f64,
        /// Period.
        period: f64,
        /// Phase, fraction of a period.
        #[serde(default)]
        phase: f64,
    },
    /// A cpfg expression in `t` and `T` (trigonometry in degrees).
    Expr {
        /// The expression.
        expr: String,
    },
}

impl ChargeSpec {
    /// Compiles to a [`Profile`] (user expressions are parsed here).
    pub fn profile(&self) -> Result<Profile> {
        Ok(match self {
            ChargeSpec::Constant { q } => Profile::Constant { q: *q },
            ChargeSpec::Power { alpha, t0 } => Profile::Power { alpha: *alpha, t0: *t0 },
            ChargeSpec::Spiral { t_end, alpha } => Profile::Spiral { t_end: *t_end, alpha: *alpha },
            ChargeSpec::Triangle { amplitude, mean, period, phase } => {
                Profile::Triangle { amplitude: *amplitude, mean: *mean, period: *period, phase: *phase }
            }
            ChargeSpec::Square { amplitude, mean, period, phase } => {
                Profile::Square { amplitude: *amplitude, mean: *mean, period: *period, phase: *phase }
            }
            ChargeSpec::Sine { amplitude, mean, period, phase } => {
                Profile::Sine { amplitude: *amplitude, mean: *mean, period: *period, phase: *phase }
            }
            ChargeSpec::Expr { expr } => Profile::Expr(UserExpr::compile(expr)?),
        })
    }
}

/// The magnetic field of a layer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum FieldSpec {
    /// `B_z = b` everywhere (2D); `B = vector` (3D layers).
    Uniform {
        /// `B_z` (default 1).
        #[serde(default = "one")]
        b: f64,
        /// The 3D field vector for `space` layers (default `[0, 0, b]`).
        #[serde(default)]
        vector: Option<[f64; 3]>,
    },
    /// `B_z = strength · 0.5 · (1 + noise(x/scale, y/scale))` (Fig. 7.5); in 3D each
    /// component is `bias + strength · noise` of an offset copy of the noise.
    Perlin {
        /// Feature size (the seed's 50).
        #[serde(default = "fifty")]
        scale: f64,
        /// Field strength (default 1).
        #[serde(default = "one")]
        strength: f64,
        /// Noise seed; default: the composition's seed plus the layer index.
        #[serde(default)]
        seed: Option<u64>,
        /// Constant added to the 3D field (default `[0, 0, 0]`).
        #[serde(default)]
        bias: Option<[f64; 3]>,
    },
}

fn fifty() -> f64 {
    50.0
}

impl Default for FieldSpec {
    fn default() -> Self {
        FieldSpec::Uniform { b: 1.0, vector: None }
    }
}

impl FieldSpec {
    fn field(&self, seed: u64) -> Result<Field> {
        match self {
            FieldSpec::Uniform { b, .. } => {
                check_finite("field.b", *b)?;
                Ok(Field::Uniform(*b))
            }
            FieldSpec::Perlin { scale, strength, seed: s, .. } => {
                check_positive("field.scale", *scale)?;
                check_finite("field.strength", *strength)?;
                Ok(Field::Perlin {
                    noise: Perlin::new(s.unwrap_or(seed)),
                    scale: *scale,
                    strength: *strength,
                })
            }
        }
    }

    fn field3(&self, seed: u64) -> Result<space::Field3> {
        match self {
            FieldSpec::Uniform { b, vector } => {
                let v = vector.map(DVec3::from_array).unwrap_or(DVec3::new(0.0, 0.0, *b));
                if !v.is_finite() {
                    return Err(Error::Recipe("field.vector must be finite".into()));
                }
                Ok(space::Field3::Uniform(v))
            }
            FieldSpec::Perlin { scale, strength, seed: s, bias } => {
                check_positive("field.scale", *scale)?;
                check_finite("field.strength", *strength)?;
                let bias = bias.map(DVec3::from_array).unwrap_or(DVec3::ZERO);
                if !bias.is_finite() {
                    return Err(Error::Recipe("field.bias must be finite".into()));
                }
                Ok(space::Field3::Perlin {
                    noise: Perlin::new(s.unwrap_or(seed)),
                    scale: *scale,
                    strength: *strength,
                    bias,
                })
            }
        }
    }
}

/// A region as written in a preset.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum RegionSpec {
    /// `min = [x, y]`, `max = [x, y]`.
    Rect {
        /// Lower-left corner.
        min: [f64; 2],
        /// Upper-right corner.
        max: [f64; 2],
    },
    /// `center = [x, y]`, `radii = [rx, ry]`.
    Ellipse {
        /// Centre.
        center: [f64; 2],
        /// Semi-axes.
        radii: [f64; 2],
    },
    /// `points = [[x, y], …]`.
    Polygon {
        /// Vertices.
        points: Vec<[f64; 2]>,
    },
}

impl RegionSpec {
    fn region(&self, what: &str) -> Result<Region> {
        let r = match self {
            RegionSpec::Rect { min, max } => Region::Rect { min: v2(*min), max: v2(*max) },
            RegionSpec::Ellipse { center, radii } => {
                Region::Ellipse { center: v2(*center), radii: v2(*radii) }
            }
            RegionSpec::Polygon { points } => Region::Polygon(points.iter().map(|p| v2(*p)).collect()),
        };
        r.validate(what)?;
        Ok(r)
    }
}

/// Drawing style; every key optional, merged layer over composition over defaults.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StyleSpec {
    /// Stroke width at a root curve's start (drawing units; default 3).
    pub width: Option<f64>,
    /// End width as a fraction of the start width (default 0.2; 1 = no taper).
    pub taper: Option<f64>,
    /// Width factor per branch generation (default 0.7).
    pub child_width: Option<f64>,
    /// Narrowest stroke (default 0.4).
    pub min_width: Option<f64>,
    /// Length of the blend from a parent's width, in parent widths (default 4).
    pub join: Option<f64>,
    /// Body colour `#rrggbb` (default `#202020`).
    pub color: Option<String>,
    /// Outline colour (no outline when absent).
    pub outline: Option<String>,
    /// Outline width on each side (default 1 when `outline` is set).
    pub outline_width: Option<f64>,
    /// Colours for `color_by = "depth" | "index" | "random"`.
    pub palette: Option<Vec<String>>,
    /// `solid` (default), `depth`, `index`, `random` (a palette entry, or uniform RGB
    /// when the palette is empty) or `noise` (Fig. 7.6: one channel from the local
    /// noise, the others 0).
    pub color_by: Option<String>,
    /// Channel for `color_by = "noise"`: `red`, `green`, `blue` or `random` per curve.
    pub noise_channel: Option<String>,
}

impl StyleSpec {
    fn over(&self, base: &StyleSpec) -> StyleSpec {
        StyleSpec {
            width: self.width.or(base.width),
            taper: self.taper.or(base.taper),
            child_width: self.child_width.or(base.child_width),
            min_width: self.min_width.or(base.min_width),
            join: self.join.or(base.join),
            color: self.color.clone().or_else(|| base.color.clone()),
            outline: self.outline.clone().or_else(|| base.outline.clone()),
            outline_width: self.outline_width.or(base.outline_width),
            palette: self.palette.clone().or_else(|| base.palette.clone()),
            color_by: self.color_by.clone().or_else(|| base.color_by.clone()),
            noise_channel: self.noise_channel.clone().or_else(|| base.noise_channel.clone()),
        }
    }

    fn resolve(&self, what: &str) -> Result<Style> {
        let width = self.width.unwrap_or(3.0);
        let taper = self.taper.unwrap_or(0.2);
        let child_width = self.child_width.unwrap_or(0.7);
        let min_width = self.min_width.unwrap_or(0.4);
        let join = self.join.unwrap_or(4.0);
        for (k, v) in [
            ("width", width),
            ("taper", taper),
            ("child_width", child_width),
            ("min_width", min_width),
            ("join", join),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::Recipe(format!("{what}: style.{k} = {v} must be a number ≥ 0")));
            }
        }
        let color = parse_color(self.color.as_deref().unwrap_or("#202020"), &format!("{what}: style.color"))?;
        let outline = match &self.outline {
            Some(c) => {
                let w = self.outline_width.unwrap_or(1.0);
                if !(w.is_finite() && w >= 0.0) {
                    return Err(Error::Recipe(format!("{what}: style.outline_width = {w} must be ≥ 0")));
                }
                Some((parse_color(c, &format!("{what}: style.outline"))?, w))
            }
            None => None,
        };
        let palette = self
            .palette
            .iter()
            .flatten()
            .map(|c| parse_color(c, &format!("{what}: style.palette")))
            .collect::<Result<Vec<_>>>()?;
        let color_by = match self.color_by.as_deref().unwrap_or("solid") {
            "solid" => ColorBy::Solid,
            "depth" => ColorBy::Depth,
            "index" => ColorBy::Index,
            "random" => ColorBy::Random,
            "noise" => ColorBy::Noise,
            other => {
                return Err(Error::Recipe(format!(
                    "{what}: style.color_by = `{other}`; use solid, depth, index, random or noise"
                )))
            }
        };
        if matches!(color_by, ColorBy::Depth | ColorBy::Index) && palette.is_empty() {
            return Err(Error::Recipe(format!("{what}: style.color_by = depth/index needs a style.palette")));
        }
        let channel = match self.noise_channel.as_deref().unwrap_or("red") {
            "red" => Some(0),
            "green" => Some(1),
            "blue" => Some(2),
            "random" => None,
            other => {
                return Err(Error::Recipe(format!(
                    "{what}: style.noise_channel = `{other}`; use red, green, blue or random"
                )))
            }
        };
        Ok(Style { width, taper, child_width, min_width, join, color, outline, palette, color_by, channel })
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ColorBy {
    Solid,
    Depth,
    Index,
    Random,
    Noise,
}

/// A resolved style.
#[derive(Debug, Clone, PartialEq)]
struct Style {
    width: f64,
    taper: f64,
    child_width: f64,
    min_width: f64,
    join: f64,
    color: Rgba,
    outline: Option<(Rgba, f64)>,
    palette: Vec<Rgba>,
    color_by: ColorBy,
    channel: Option<usize>,
}

/// Children released along a particle's curve (Fig. 7.2).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChildrenSpec {
    /// Release points per curve.
    pub count: u32,
    /// Generations (default 1).
    #[serde(default = "one_u32")]
    pub depth: u32,
    /// Release window start (fraction of arc length, default 0).
    #[serde(default)]
    pub from: f64,
    /// Release window end (default 1).
    #[serde(default = "one")]
    pub to: f64,
    /// `random` (default), `alternate` or `split` (two children of opposite charge).
    #[serde(default)]
    pub signs: Signs,
    /// Children's duration relative to the parent's (default 0.5).
    #[serde(default = "half")]
    pub scale: f64,
}

fn one_u32() -> u32 {
    1
}

/// One particle of a `particles` layer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticleSpec {
    /// Start `[x, y]`.
    pub start: [f64; 2],
    /// Start direction, degrees counter-clockwise from +x (default 90: up).
    #[serde(default = "ninety")]
    pub heading: f64,
    /// Charge profile.
    pub charge: ChargeSpec,
    /// Charge scale (default 1).
    #[serde(default = "one")]
    pub k: f64,
    /// Sign multiplier (default 1: clockwise for positive `q·B`).
    #[serde(default = "one")]
    pub sign: f64,
    /// Duration; required unless the profile is a spiral (whose `T` it defaults to).
    pub duration: Option<f64>,
    /// Flip the charge's sign at this fraction of the duration.
    pub flip_at: Option<f64>,
    /// Speed (default: the composition's).
    pub speed: Option<f64>,
    /// Translate the curve (with its children) so its bounding box is centred in
    /// `[x0, y0, x1, y1]`.
    pub center_in: Option<[f64; 4]>,
    /// Override the layer's `mirror` for this particle.
    pub mirror: Option<bool>,
    /// Children.
    pub children: Option<ChildrenSpec>,
    /// Style override.
    #[serde(default)]
    pub style: StyleSpec,
}

fn ninety() -> f64 {
    90.0
}

/// A root of a `fill` layer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RootSpec {
    /// Start `[x, y]` (inside the region).
    pub start: [f64; 2],
    /// Heading in degrees (default 90).
    #[serde(default = "ninety")]
    pub heading: f64,
    /// Its own charge; default: the ladder.
    pub charge: Option<ChargeSpec>,
    /// Charge scale for its own charge (default 1).
    #[serde(default = "one")]
    pub k: f64,
    /// Sign for its own charge (default 1).
    #[serde(default = "one")]
    pub sign: f64,
    /// Duration of its own charge (default: the spiral's T).
    pub duration: Option<f64>,
    /// Flip fraction for its own charge.
    pub flip_at: Option<f64>,
}

/// One side of a `fire` layer.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FireSide {
    /// Where this side starts (default: where the previous side ended, or the layer's
    /// `start`).
    pub start: Option<[f64; 2]>,
    /// Mean start heading of each tongue, degrees.
    pub heading: f64,
    /// Change of the heading from one tongue to the next, degrees (default 0).
    #[serde(default)]
    pub turn: f64,
    /// Uniform jitter of the heading, ± degrees (default 5).
    #[serde(default = "five")]
    pub spread: f64,
    /// Charge sign (default 1).
    #[serde(default = "one")]
    pub sign: f64,
    /// Particles (tongues) on this side (default 4).
    #[serde(default = "four")]
    pub tongues: u32,
}

fn five() -> f64 {
    5.0
}
fn four() -> u32 {
    4
}

/// Options of 3D (`space`, `sphere`) layers.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewSpec {
    /// Rotation about the vertical axis, degrees (default 30).
    #[serde(default = "thirty")]
    pub yaw: f64,
    /// Tilt towards the viewer, degrees (default 15).
    #[serde(default = "fifteen")]
    pub pitch: f64,
    /// Canvas position of the 3D origin `[x, y]` (default: bottom centre).
    pub origin: Option<[f64; 2]>,
    /// Drawing units per 3D unit (default 1).
    #[serde(default = "one")]
    pub zoom: f64,
}

fn thirty() -> f64 {
    30.0
}
fn fifteen() -> f64 {
    15.0
}

impl Default for ViewSpec {
    fn default() -> Self {
        ViewSpec { yaw: 30.0, pitch: 15.0, origin: None, zoom: 1.0 }
    }
}

/// One layer of a composition (see the module docs for the table of types).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum LayerSpec {
    /// Listed particles.
    Particles {
        /// The particles.
        particle: Vec<ParticleSpec>,
        /// Stop particles when they leave this region (default: no limit).
        region: Option<RegionSpec>,
        /// The field.
        #[serde(default)]
        field: FieldSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror about the canvas centre line.
        #[serde(default)]
        mirror: bool,
    },
    /// A grid of spirals: one per (row `T`, column `α`) (Fig. 7.3).
    Grid {
        /// Rows, top to bottom.
        #[serde(rename = "T")]
        t: Vec<f64>,
        /// Columns, left to right.
        alpha: Vec<f64>,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Start heading, degrees (default 0).
        #[serde(default)]
        heading: f64,
        /// Charge sign (default 1).
        #[serde(default = "one")]
        sign: f64,
        /// The field.
        #[serde(default)]
        field: FieldSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// Space filling (Figs. 7.4–7.7).
    Fill {
        /// Roots (default: one at the region's bottom centre heading up).
        #[serde(default)]
        root: Vec<RootSpec>,
        /// Every curve stays here (default: the canvas).
        region: Option<RegionSpec>,
        /// Release points only here (default: anywhere in the region).
        release_region: Option<RegionSpec>,
        /// `[[T, α], …]`, largest first (default: Fig. 7.3's diagonal).
        ladder: Option<Vec<[f64; 2]>>,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Release spacing (default 25).
        release_every: Option<f64>,
        /// No releases in this first arc length of a curve (default 10).
        release_skip: Option<f64>,
        /// Occupancy cell size (default 2).
        cell: Option<f64>,
        /// Own-cell re-entry window in steps (default 8).
        recent: Option<u32>,
        /// Peel-off length from the parent (default 12).
        peel: Option<f64>,
        /// Smallest radius of curvature (default 3).
        min_radius: Option<f64>,
        /// Shortest kept curve (default 8).
        min_length: Option<f64>,
        /// Stop after this many curves (default: the composition's max_curves).
        max_curves: Option<usize>,
        /// `random` (default), `alternate` or `split` (try both signs).
        #[serde(default)]
        signs: Signs,
        /// The field.
        #[serde(default)]
        field: FieldSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// Hair strands from a drawn hairline (Figs. 7.10, 7.12).
    Hair {
        /// The hairline polyline `[[x, y], …]`.
        hairline: Vec<[f64; 2]>,
        /// Number of strands, at equal arc-length spacing along the hairline.
        strands: u32,
        /// Charge profile of every strand.
        charge: ChargeSpec,
        /// Random `[min, max]` of the spiral's T per strand.
        #[serde(rename = "T_range")]
        t_range: Option<[f64; 2]>,
        /// Random `[min, max]` of the spiral's α per strand.
        alpha_range: Option<[f64; 2]>,
        /// Random `[min, max]` duration for non-spiral profiles.
        duration_range: Option<[f64; 2]>,
        /// Random `[min, max]` fraction of the duration at which q flips (waves).
        flip_range: Option<[f64; 2]>,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Start heading in degrees; default: the hairline's left normal (draw the
        /// hairline left to right over the head and the strands grow outwards).
        heading: Option<f64>,
        /// Strands whose start x exceeds this turn the other way and lean the other
        /// way (default: the canvas centre).
        parting: Option<f64>,
        /// Extra heading away from the parting, degrees (default 0).
        #[serde(default)]
        lean: f64,
        /// Uniform heading jitter, ± degrees (default 5).
        #[serde(default = "five")]
        spread: f64,
        /// Sign for strands right of the parting (left ones get the opposite; default 1).
        #[serde(default = "one")]
        sign: f64,
        /// Stop strands when they leave this region.
        region: Option<RegionSpec>,
        /// The field.
        #[serde(default)]
        field: FieldSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// Cartoon flames (Fig. 7.13).
    Fire {
        /// Start of the first tongue.
        start: [f64; 2],
        /// Charge of each tongue (the seed: `(T − t)^{+α}`, a spiral with negative α).
        charge: ChargeSpec,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Flip the sign at this fraction of T (default 0.5).
        #[serde(default = "half")]
        flip_at: f64,
        /// Sides, drawn one after the other, each continuing from the last tip unless
        /// it has its own `start`.
        side: Vec<FireSide>,
        /// The field.
        #[serde(default)]
        field: FieldSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// One particle meandering in a region (Fig. 7.14).
    Meander {
        /// Start.
        start: [f64; 2],
        /// Heading, degrees (default 0).
        #[serde(default)]
        heading: f64,
        /// Fixed charge.
        q: f64,
        /// Duration.
        duration: f64,
        /// The region (default: the canvas).
        region: Option<RegionSpec>,
        /// The field (a Perlin field for interesting curves).
        #[serde(default)]
        field: FieldSpec,
        /// Style (each re-entry gets a uniform random RGB colour unless `color_by` is
        /// set).
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// Drawn polylines.
    Lines {
        /// Polylines `[[[x, y], …], …]`.
        lines: Vec<Vec<[f64; 2]>>,
        /// Close every polyline.
        #[serde(default)]
        closed: bool,
        /// Style (no taper unless set).
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
    /// 3D magnetic curves with a vector field, branching, drawn in projection and
    /// exported as a skeleton (`sylva curves … -o tree.glb`).
    Space {
        /// The root particle's start `[x, y, z]` (default origin).
        #[serde(default)]
        start: [f64; 3],
        /// The root's initial direction (default `[0, 1, 0]`: up).
        direction: Option<[f64; 3]>,
        /// Charge profile.
        charge: ChargeSpec,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Duration (default: the spiral's T).
        duration: Option<f64>,
        /// Children.
        children: Option<ChildrenSpec>,
        /// Children's start direction leans off the parent's tangent by this angle,
        /// degrees, about a random axis (default 35).
        #[serde(default = "thirty_five")]
        tilt: f64,
        /// The field (`uniform` with `vector`, or `perlin` with `bias`).
        #[serde(default)]
        field: FieldSpec,
        /// Projection.
        #[serde(default)]
        view: ViewSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror (of the projection).
        #[serde(default)]
        mirror: bool,
    },
    /// Curves traced on a sphere: B is normal to the surface, its value from 3D noise
    /// (or uniform), and particles move along great circles between turns.
    Sphere {
        /// Sphere radius.
        radius: f64,
        /// Number of particles, started at random points with random headings.
        particles: u32,
        /// Charge profile.
        charge: ChargeSpec,
        /// Charge scale (default 1).
        #[serde(default = "one")]
        k: f64,
        /// Duration (default: the spiral's T).
        duration: Option<f64>,
        /// Draw only the hemisphere facing the viewer (default true).
        #[serde(default = "yes")]
        cull: bool,
        /// The field: `uniform` (B_n = b) or `perlin` (B_n = strength·0.5(1+noise)).
        #[serde(default)]
        field: FieldSpec,
        /// Projection.
        #[serde(default)]
        view: ViewSpec,
        /// Style.
        #[serde(default)]
        style: StyleSpec,
        /// Mirror.
        #[serde(default)]
        mirror: bool,
    },
}

fn thirty_five() -> f64 {
    35.0
}
fn yes() -> bool {
    true
}

impl LayerSpec {
    /// The layer's `type` name.
    pub fn kind(&self) -> &'static str {
        match self {
            LayerSpec::Particles { .. } => "particles",
            LayerSpec::Grid { .. } => "grid",
            LayerSpec::Fill { .. } => "fill",
            LayerSpec::Hair { .. } => "hair",
            LayerSpec::Fire { .. } => "fire",
            LayerSpec::Meander { .. } => "meander",
            LayerSpec::Lines { .. } => "lines",
            LayerSpec::Space { .. } => "space",
            LayerSpec::Sphere { .. } => "sphere",
        }
    }

    fn common(&self) -> (&StyleSpec, bool) {
        match self {
            LayerSpec::Particles { style, mirror, .. }
            | LayerSpec::Grid { style, mirror, .. }
            | LayerSpec::Fill { style, mirror, .. }
            | LayerSpec::Hair { style, mirror, .. }
            | LayerSpec::Fire { style, mirror, .. }
            | LayerSpec::Meander { style, mirror, .. }
            | LayerSpec::Lines { style, mirror, .. }
            | LayerSpec::Space { style, mirror, .. }
            | LayerSpec::Sphere { style, mirror, .. } => (style, *mirror),
        }
    }
}

/// The `[curves]` table of a preset.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurvesSpec {
    /// Canvas width in drawing units (default 800).
    #[serde(default = "w800")]
    pub width: f64,
    /// Canvas height (default 800).
    #[serde(default = "w800")]
    pub height: f64,
    /// Background `#rrggbb`, or `none` for transparent (default white).
    pub background: Option<String>,
    /// Default output width in pixels (default 600).
    #[serde(default = "px600")]
    pub size: u32,
    /// Time step (default 1).
    #[serde(default = "one")]
    pub dt: f64,
    /// Particle speed (default 1).
    #[serde(default = "one")]
    pub speed: f64,
    /// Particle mass (default 1).
    #[serde(default = "one")]
    pub mass: f64,
    /// `exact` (default), `euler` (the seed's) or `renormalized`.
    #[serde(default)]
    pub integrator: Integrator,
    /// Limit on integration steps, all particles and retries together.
    #[serde(default = "max_steps")]
    pub max_steps: u64,
    /// Limit on the number of curves.
    #[serde(default = "max_curves")]
    pub max_curves: usize,
    /// Default style.
    #[serde(default)]
    pub style: StyleSpec,
    /// The layers, drawn in order (`[[curves.layer]]`).
    #[serde(default)]
    pub layer: Vec<LayerSpec>,
}

fn w800() -> f64 {
    800.0
}
fn px600() -> u32 {
    600
}
fn max_steps() -> u64 {
    magnetic::DEFAULT_MAX_STEPS
}
fn max_curves() -> usize {
    100_000
}

/// A whole `kind = "curves"` preset file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PresetFile {
    /// Must be `"curves"`.
    pub kind: String,
    /// Name (a preset's file stem).
    #[serde(default)]
    pub name: String,
    /// One-line description.
    #[serde(default)]
    pub description: String,
    /// Seed of every random choice (default 1).
    #[serde(default = "seed1")]
    pub seed: u64,
    /// The composition.
    pub curves: CurvesSpec,
}

fn seed1() -> u64 {
    1
}

/// Numbers about one generation.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Stats {
    /// Magnetic curves drawn.
    pub curves: usize,
    /// Integration steps taken (retries included).
    pub steps: u64,
    /// Space-filling attempts (placed + failed).
    pub attempts: usize,
    /// Space-filling positions abandoned.
    pub abandoned: usize,
}

/// Everything a composition produces.
#[derive(Debug, Clone, PartialEq)]
pub struct Generated {
    /// The 2D drawing.
    pub drawing: Drawing,
    /// 3D curves of `space` and `sphere` layers (for skeleton export).
    pub curves3d: Vec<space::Curve3>,
    /// Statistics.
    pub stats: Stats,
}

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

/// Builds one layer's raw curves; returns the 2D field for noise colouring.
fn build_layer(
    layer: &LayerSpec,
    ctx: &Ctx,
    rng: &mut Pcg64,
    budget: &mut Budget,
    stats: &mut Stats,
    curves3d: &mut Vec<space::Curve3>,
) -> Result<(Vec<Raw>, Option<Field>)> {
    let spec = ctx.spec;
    let opts = ctx.opts();
    match layer {
        LayerSpec::Particles { particle, region, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let region = region.as_ref().map(|r| r.region(&format!("{}: region", ctx.what))).transpose()?;
            let mut raws = Vec::new();
            for (pi, p) in particle.iter().enumerate() {
                let (mut charge, duration) = ctx.charge(&p.charge, p.k, p.duration, p.flip_at)?;
                check_finite("sign", p.sign).map_err(|e| ctx.err(e))?;
                charge.scale *= p.sign;
                let speed = p.speed.unwrap_or(spec.speed);
                let particle = Particle {
                    position: v2(p.start),
                    velocity: heading(p.heading) * speed,
                    mass: spec.mass,
                    charge,
                    duration,
                };
                magnetic::validate_particle(&particle, &opts, &format!("{}: particle {}", ctx.what, pi + 1))?;
                let branching = match &p.children {
                    Some(c) => Branching {
                        count: c.count,
                        depth: c.depth,
                        from: c.from,
                        to: c.to,
                        signs: c.signs,
                        duration_scale: c.scale,
                    },
                    None => Branching {
                        count: 0,
                        depth: 0,
                        from: 0.0,
                        to: 1.0,
                        signs: Signs::Random,
                        duration_scale: 1.0,
                    },
                };
                let grown = match &region {
                    None => {
                        grow_branching(&particle, &field, &opts, &branching, rng, budget, spec.max_curves)?
                    }
                    Some(r) => {
                        grow_in_region(&particle, &field, &opts, &branching, r, rng, budget, spec.max_curves)?
                    }
                };
                let base = raws.len();
                let mut group: Vec<Raw> = grown
                    .into_iter()
                    .map(|b| {
                        let mut r = Raw::new(b.trace.points, b.parent.map(|(q, i)| (q + base, i)), b.depth);
                        r.style = Some(p.style.clone());
                        r
                    })
                    .collect();
                if let Some([x0, y0, x1, y1]) = p.center_in {
                    let (lo, hi) = bounds(group.iter().flat_map(|r| r.points.iter()));
                    let shift = DVec2::new(0.5 * (x0 + x1), 0.5 * (y0 + y1)) - 0.5 * (lo + hi);
                    if shift.is_finite() {
                        for r in &mut group {
                            for q in &mut r.points {
                                *q += shift;
                            }
                        }
                    }
                }
                raws.extend(group);
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Grid { t, alpha, k, heading: h, sign, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            if t.is_empty() || alpha.is_empty() {
                return Err(ctx.err("a grid needs at least one T and one alpha"));
            }
            let (cw, ch) = (spec.width / alpha.len() as f64, spec.height / t.len() as f64);
            let mut raws = Vec::new();
            for (row, &tv) in t.iter().enumerate() {
                for (col, &a) in alpha.iter().enumerate() {
                    let (charge, duration) =
                        ctx.charge(&ChargeSpec::Spiral { t_end: tv, alpha: a }, k * sign, None, None)?;
                    let particle = Particle {
                        position: DVec2::ZERO,
                        velocity: heading(*h) * spec.speed,
                        mass: spec.mass,
                        charge,
                        duration,
                    };
                    let tr = magnetic::trace(&particle, &field, &opts, budget)?;
                    let mut pts = tr.points;
                    // Row 0 is the top row.
                    let centre = DVec2::new((col as f64 + 0.5) * cw, spec.height - (row as f64 + 0.5) * ch);
                    let (lo, hi) = bounds(pts.iter());
                    let shift = centre - 0.5 * (lo + hi);
                    for p in &mut pts {
                        *p += shift;
                    }
                    raws.push(Raw::new(pts, None, 0));
                }
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Fill {
            root,
            region,
            release_region,
            ladder,
            k,
            release_every,
            release_skip,
            cell,
            recent,
            peel,
            min_radius,
            min_length,
            max_curves,
            signs,
            field,
            ..
        } => {
            let field = field.field(ctx.noise_seed)?;
            let region = match region {
                Some(r) => r.region(&format!("{}: region", ctx.what))?,
                None => ctx.canvas(),
            };
            let d = FillParams::default();
            let params = FillParams {
                ladder: ladder.as_ref().map(|l| l.iter().map(|p| (p[0], p[1])).collect()).unwrap_or(d.ladder),
                k: *k,
                speed: spec.speed,
                mass: spec.mass,
                release_every: release_every.unwrap_or(d.release_every),
                release_skip: release_skip.unwrap_or(d.release_skip),
                release_region: release_region
                    .as_ref()
                    .map(|r| r.region(&format!("{}: release_region", ctx.what)))
                    .transpose()?,
                region: region.clone(),
                cell: cell.unwrap_or(d.cell),
                recent: recent.unwrap_or(d.recent),
                peel: peel.unwrap_or(d.peel),
                min_radius: min_radius.unwrap_or(d.min_radius),
                min_length: min_length.unwrap_or(d.min_length),
                max_curves: max_curves.unwrap_or(spec.max_curves).min(spec.max_curves),
                signs: *signs,
                dt: spec.dt,
                integrator: spec.integrator,
            };
            let roots = if root.is_empty() {
                let (lo, hi) = region.bounds();
                vec![Root {
                    position: DVec2::new(0.5 * (lo.x + hi.x), lo.y),
                    direction: DVec2::Y,
                    charge: None,
                }]
            } else {
                root.iter()
                    .map(|r| {
                        let charge = match &r.charge {
                            Some(c) => {
                                let (mut ch, d) = ctx.charge(c, r.k, r.duration, r.flip_at)?;
                                ch.scale *= r.sign;
                                Some((ch, d))
                            }
                            None => None,
                        };
                        Ok(Root { position: v2(r.start), direction: heading(r.heading), charge })
                    })
                    .collect::<Result<Vec<_>>>()?
            };
            let res = fill::space_fill(&roots, &params, &field, rng, budget).map_err(|e| match e {
                Error::Recipe(m) => ctx.err(m),
                e => e,
            })?;
            stats.attempts += res.attempts.len();
            stats.abandoned += res.abandoned;
            let raws = res.curves.into_iter().map(|c| Raw::new(c.trace.points, c.parent, c.depth)).collect();
            Ok((raws, Some(field)))
        }
        LayerSpec::Hair {
            hairline,
            strands,
            charge,
            t_range,
            alpha_range,
            duration_range,
            flip_range,
            k,
            heading: fixed_heading,
            parting,
            lean,
            spread,
            sign,
            region,
            field,
            ..
        } => {
            let field = field.field(ctx.noise_seed)?;
            let region = region.as_ref().map(|r| r.region(&format!("{}: region", ctx.what))).transpose()?;
            let line: Vec<DVec2> = hairline.iter().map(|p| v2(*p)).collect();
            if line.len() < 2 || line.iter().any(|p| !p.is_finite()) {
                return Err(ctx.err("the hairline needs at least two finite points"));
            }
            let parting = parting.unwrap_or(0.5 * spec.width);
            if *strands as usize > spec.max_curves {
                return Err(ctx.err(format!(
                    "{strands} strands exceed the curve limit {}; raise `curves.max_curves`",
                    spec.max_curves
                )));
            }
            let mut raws = Vec::new();
            for s in 0..*strands {
                let (pos, tangent) = along(&line, (s as f64 + 0.5) / *strands as f64);
                let right = pos.x >= parting;
                let side = if right { 1.0 } else { -1.0 };
                let mut cs = charge.clone();
                if let ChargeSpec::Spiral { t_end, alpha } = &mut cs {
                    if let Some([a, b]) = t_range {
                        *t_end = uniform(rng, *a, *b);
                    }
                    if let Some([a, b]) = alpha_range {
                        *alpha = uniform(rng, *a, *b);
                    }
                }
                let duration = duration_range.map(|[a, b]| uniform(rng, a, b));
                let flip = flip_range.map(|[a, b]| uniform(rng, a, b));
                let (mut ch, duration) = ctx.charge(&cs, *k, duration, flip)?;
                ch.scale *= sign * side;
                let base = match fixed_heading {
                    Some(h) => heading(*h),
                    None => tangent.perp(),
                };
                let jitter = uniform(rng, -spread, *spread);
                let dir = rotate(base, -side * lean + jitter);
                let particle = Particle {
                    position: pos,
                    velocity: dir * spec.speed,
                    mass: spec.mass,
                    charge: ch,
                    duration,
                };
                let tr = match &region {
                    None => magnetic::trace(&particle, &field, &opts, budget)?,
                    Some(r) => magnetic::trace_with(&particle, &field, &opts, budget, s as u64, |v| {
                        if r.contains(v.to) {
                            magnetic::Control::Continue
                        } else {
                            magnetic::Control::Stop
                        }
                    })?,
                };
                raws.push(Raw::new(tr.points, None, 0));
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Fire { start, charge, k, flip_at, side, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let (base_charge, duration) = ctx.charge(charge, *k, None, Some(*flip_at))?;
            let total: u64 = side.iter().map(|sd| sd.tongues as u64).sum();
            if total > spec.max_curves as u64 {
                return Err(ctx.err(format!(
                    "{total} tongues exceed the curve limit {}; raise `curves.max_curves`",
                    spec.max_curves
                )));
            }
            let mut raws = Vec::new();
            let mut at = v2(*start);
            {
                for sd in side {
                    if let Some(s) = sd.start {
                        at = v2(s);
                    }
                    if !at.is_finite() {
                        return Err(ctx.err("a fire start is not finite"));
                    }
                    for i in 0..sd.tongues {
                        let h = sd.heading + sd.turn * i as f64 + uniform(rng, -sd.spread, sd.spread);
                        let mut ch = base_charge.clone();
                        ch.scale *= sd.sign;
                        let v0 = heading(h) * spec.speed;
                        let particle =
                            Particle { position: at, velocity: v0, mass: spec.mass, charge: ch, duration };
                        // The seed: terminate when v_x reaches 0 (a sign change of v_x).
                        let mut ref_sign = v0.x.signum() * (v0.x.abs() > 1e-9) as i32 as f64;
                        let tr = magnetic::trace_with(&particle, &field, &opts, budget, i as u64, |v| {
                            if ref_sign == 0.0 {
                                ref_sign = v.velocity.x.signum();
                                return magnetic::Control::Continue;
                            }
                            if v.velocity.x * ref_sign <= 0.0 {
                                magnetic::Control::Stop
                            } else {
                                magnetic::Control::Continue
                            }
                        })?;
                        at = *tr.points.last().unwrap_or(&at);
                        raws.push(Raw::new(tr.points, None, 0));
                    }
                }
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Meander { start, heading: h, q, duration, region, field, style, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let region = match region {
                Some(r) => r.region(&format!("{}: region", ctx.what))?,
                None => ctx.canvas(),
            };
            check_finite("q", *q).map_err(|e| ctx.err(e))?;
            check_finite("duration", *duration).map_err(|e| ctx.err(e))?;
            let x0 = v2(*start);
            if !region.contains(x0) {
                return Err(ctx.err("the start lies outside the region"));
            }
            let random_colors = style.color_by.is_none() && style.color.is_none();
            let mut raws = Vec::new();
            let (mut x, mut v) = (x0, heading(*h) * spec.speed);
            let mut current = vec![x];
            let steps = (duration / spec.dt).ceil().max(0.0) as u64;
            let new_color = |rng: &mut Pcg64| -> Rgba {
                let mut c = [0, 0, 0, 255];
                for ch in &mut c[..3] {
                    *ch = (rng.random::<f64>() * 255.0).round() as u8;
                }
                c
            };
            let mut color = new_color(rng);
            for _ in 0..steps {
                budget.step()?;
                let omega = q * field.bz(x + v * (0.5 * spec.dt)) / spec.mass;
                let (x1, v1) = advance(x, v, omega, spec.dt, spec.integrator);
                if !region.contains(x1) {
                    // §7.3: reverse the velocity at the border; the re-entry starts a
                    // new curve with a new random colour.
                    v = -v;
                    if raws.len() >= spec.max_curves {
                        return Err(ctx.err(format!(
                            "more than {} re-entries; raise `curves.max_curves` or shorten `duration`",
                            spec.max_curves
                        )));
                    }
                    if current.len() >= 2 {
                        let mut r = Raw::new(std::mem::take(&mut current), None, 0);
                        if random_colors {
                            r.color = Some(color);
                        }
                        raws.push(r);
                        color = new_color(rng);
                    }
                    current = vec![x];
                    continue;
                }
                x = x1;
                v = v1;
                current.push(x);
            }
            if current.len() >= 2 {
                let mut r = Raw::new(current, None, 0);
                if random_colors {
                    r.color = Some(color);
                }
                raws.push(r);
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Lines { lines, closed, .. } => {
            let mut raws = Vec::new();
            for l in lines {
                let mut pts: Vec<DVec2> = l.iter().map(|p| v2(*p)).collect();
                if pts.iter().any(|p| !p.is_finite()) {
                    return Err(ctx.err("a line has a non-finite point"));
                }
                if *closed && pts.len() > 2 {
                    pts.push(pts[0]);
                }
                let mut r = Raw::new(pts, None, 0);
                r.magnetic = false;
                raws.push(r);
            }
            Ok((raws, None))
        }
        LayerSpec::Space { start, direction, charge, k, duration, children, tilt, field, view, .. } => {
            let field3 = field.field3(ctx.noise_seed)?;
            let (ch, duration) = ctx.charge(charge, *k, *duration, None)?;
            let dir = direction.map(DVec3::from_array).unwrap_or(DVec3::Y);
            let root = space::Particle3 {
                position: DVec3::from_array(*start),
                velocity: dir.normalize_or(DVec3::Y) * spec.speed,
                mass: spec.mass,
                charge: ch,
                duration,
            };
            let branching = space::Branching3 {
                count: children.as_ref().map_or(0, |c| c.count),
                depth: children.as_ref().map_or(0, |c| c.depth),
                from: children.as_ref().map_or(0.0, |c| c.from),
                to: children.as_ref().map_or(1.0, |c| c.to),
                duration_scale: children.as_ref().map_or(0.5, |c| c.scale),
                tilt: tilt.to_radians(),
            };
            let curves = space::grow3(&root, &field3, spec.dt, &branching, rng, budget, spec.max_curves)
                .map_err(|e| match e {
                    Error::Recipe(m) => ctx.err(m),
                    e => e,
                })?;
            let proj = Projection::new(view, spec);
            let raws = curves
                .iter()
                .map(|c| Raw::new(c.points.iter().map(|p| proj.apply(*p)).collect(), c.parent, c.depth))
                .collect();
            curves3d.extend(curves);
            Ok((raws, None))
        }
        LayerSpec::Sphere { radius, particles, charge, k, duration, cull, field, view, .. } => {
            check_positive("radius", *radius).map_err(|e| ctx.err(e))?;
            let field3 = field.field3(ctx.noise_seed)?;
            let (ch, duration) = ctx.charge(charge, *k, *duration, None)?;
            let proj = Projection::new(view, spec);
            if *particles as usize > spec.max_curves {
                return Err(ctx.err(format!(
                    "{particles} particles exceed the curve limit {}; raise `curves.max_curves`",
                    spec.max_curves
                )));
            }
            let mut raws = Vec::new();
            for i in 0..*particles {
                // A uniform random point and tangent direction on the sphere.
                let z = uniform(rng, -1.0, 1.0);
                let phi = uniform(rng, 0.0, std::f64::consts::TAU);
                let rxy = (1.0 - z * z).max(0.0).sqrt();
                let n = DVec3::new(rxy * phi.cos(), rxy * phi.sin(), z);
                let a = n.any_orthonormal_vector();
                let b = n.cross(a);
                let ang = uniform(rng, 0.0, std::f64::consts::TAU);
                let mut c = ch.clone();
                if rng.random::<f64>() < 0.5 {
                    c.scale = -c.scale;
                }
                let sp = space::SphereParticle {
                    radius: *radius,
                    normal: n,
                    direction: a * ang.cos() + b * ang.sin(),
                    speed: spec.speed,
                    mass: spec.mass,
                    charge: c,
                    duration,
                };
                let curve = space::trace_on_sphere(&sp, &field3, spec.dt, budget, i as u64)?;
                // Split into runs on the visible hemisphere.
                let mut run = Vec::new();
                for p in &curve.points {
                    let visible = !*cull || proj.facing(*p);
                    if visible {
                        run.push(proj.apply(*p));
                    } else if run.len() >= 2 {
                        raws.push(Raw::new(std::mem::take(&mut run), None, 0));
                    } else {
                        run.clear();
                    }
                }
                if run.len() >= 2 {
                    raws.push(Raw::new(run, None, 0));
                }
                curves3d.push(curve);
            }
            Ok((raws, Some(Field::Uniform(1.0))))
        }
    }
}

/// Branching with every curve stopped at a region's border.
#[allow(clippy::too_many_arguments)]
fn grow_in_region(
    root: &Particle,
    field: &Field,
    opts: &TraceOptions,
    branching: &Branching,
    region: &Region,
    rng: &mut Pcg64,
    budget: &mut Budget,
    max_curves: usize,
) -> Result<Vec<magnetic::BranchCurve>> {
    let mut all = grow_branching(root, field, opts, branching, rng, budget, max_curves)?;
    // Cut each curve at its first point outside the region; children released past
    // the cut are dropped with their descendants.
    let mut keep = vec![true; all.len()];
    let mut cut = vec![usize::MAX; all.len()];
    for i in 0..all.len() {
        if let Some((p, at)) = all[i].parent {
            if !keep[p] || at >= cut[p] {
                keep[i] = false;
                continue;
            }
        }
        let n = all[i].trace.points.iter().position(|q| !region.contains(*q)).unwrap_or(usize::MAX);
        cut[i] = n;
        if n < 2 {
            keep[i] = false;
        }
    }
    let mut index = vec![usize::MAX; all.len()];
    let mut out = Vec::new();
    for (i, mut c) in all.drain(..).enumerate() {
        if !keep[i] {
            continue;
        }
        if cut[i] != usize::MAX {
            c.trace.points.truncate(cut[i]);
            c.trace.times.truncate(cut[i]);
            c.trace.velocities.truncate(cut[i]);
        }
        c.parent = c.parent.map(|(p, k)| (index[p], k));
        index[i] = out.len();
        out.push(c);
    }
    Ok(out)
}

/// Bounding box of points.
fn bounds<'a>(pts: impl Iterator<Item = &'a DVec2>) -> (DVec2, DVec2) {
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    (lo, hi)
}

/// The point and unit tangent at arc-length fraction `f` of a polyline.
fn along(line: &[DVec2], f: f64) -> (DVec2, DVec2) {
    let total: f64 = line.windows(2).map(|w| w[0].distance(w[1])).sum();
    let mut target = f.clamp(0.0, 1.0) * total;
    for w in line.windows(2) {
        let l = w[0].distance(w[1]);
        if target <= l && l > 0.0 {
            return (w[0].lerp(w[1], target / l), (w[1] - w[0]) / l);
        }
        target -= l;
    }
    let n = line.len();
    (line[n - 1], (line[n - 1] - line[n - 2]).normalize_or(DVec2::X))
}

/// An orthographic view of 3D curves onto the canvas.
struct Projection {
    right: DVec3,
    up: DVec3,
    toward: DVec3,
    origin: DVec2,
    zoom: f64,
}

impl Projection {
    fn new(view: &ViewSpec, spec: &CurvesSpec) -> Self {
        let (yaw, pitch) = (view.yaw.to_radians(), view.pitch.to_radians());
        // Camera looking along −toward; +Y stays up on the canvas.
        let toward = DVec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos());
        let right = DVec3::Y.cross(toward).normalize_or(DVec3::X);
        let up = toward.cross(right);
        let origin = view.origin.map(v2).unwrap_or(DVec2::new(0.5 * spec.width, 0.05 * spec.height));
        Projection { right, up, toward, origin, zoom: if view.zoom.is_finite() { view.zoom } else { 1.0 } }
    }

    fn apply(&self, p: DVec3) -> DVec2 {
        self.origin + self.zoom * DVec2::new(p.dot(self.right), p.dot(self.up))
    }

    fn facing(&self, p: DVec3) -> bool {
        p.dot(self.toward) >= 0.0
    }
}

/// Applies widths and colours to a layer's raw curves. `offset` is the index of the
/// layer's first curve in the drawing (parents are layer-local in `raws`).
fn style_curves(
    raws: &[Raw],
    layer_style: &StyleSpec,
    what: &str,
    field: Option<&Field>,
    rng: &mut Pcg64,
    offset: usize,
) -> Result<Vec<Curve>> {
    let base = layer_style.resolve(what)?;
    let mut out: Vec<Curve> = Vec::with_capacity(raws.len());
    for (i, r) in raws.iter().enumerate() {
        let style = match &r.style {
            Some(s) => s.over(layer_style).resolve(what)?,
            None => base.clone(),
        };
        let n = r.points.len();
        let mut cum = Vec::with_capacity(n);
        let mut s = 0.0;
        for (j, p) in r.points.iter().enumerate() {
            if j > 0 {
                s += r.points[j - 1].distance(*p);
            }
            cum.push(s);
        }
        let total = s.max(1e-12);
        let (w0, taper) = if r.magnetic {
            (style.width * style.child_width.powi(r.depth as i32), style.taper)
        } else {
            (style.width, if layer_style.taper.is_some() { style.taper } else { 1.0 })
        };
        let attach = r.parent.and_then(|(p, k)| out.get(p).and_then(|c| c.widths.get(k)).copied());
        let mut widths = Vec::with_capacity(n);
        for &c in &cum {
            let u = c / total;
            let mut w = w0 * (1.0 - u * (1.0 - taper));
            if let Some(wa) = attach {
                // Blend from the parent's width with a smoothstep over `join` widths.
                let l = (style.join * wa).max(1e-9);
                let x = (c / l).min(1.0);
                let sm = x * x * (3.0 - 2.0 * x);
                w = wa * (1.0 - sm) + w * sm;
            }
            widths.push(w.max(style.min_width));
        }
        let paint = match (r.color, style.color_by) {
            (Some(c), _) => Paint::Solid(c),
            (None, ColorBy::Solid) => Paint::Solid(style.color),
            (None, ColorBy::Depth) => Paint::Solid(style.palette[r.depth as usize % style.palette.len()]),
            (None, ColorBy::Index) => Paint::Solid(style.palette[i % style.palette.len()]),
            (None, ColorBy::Random) => {
                if style.palette.is_empty() {
                    let c = [rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>()];
                    Paint::Solid([
                        (c[0] * 255.0).round() as u8,
                        (c[1] * 255.0).round() as u8,
                        (c[2] * 255.0).round() as u8,
                        255,
                    ])
                } else {
                    let k = ((rng.random::<f64>() * style.palette.len() as f64) as usize)
                        .min(style.palette.len() - 1);
                    Paint::Solid(style.palette[k])
                }
            }
            (None, ColorBy::Noise) => {
                let channel = style.channel.unwrap_or_else(|| ((rng.random::<f64>() * 3.0) as usize).min(2));
                let colors = r
                    .points
                    .iter()
                    .map(|p| {
                        let v = field.map_or(0.0, |f| f.noise(*p));
                        let mut c = [0u8, 0, 0, 255];
                        // Perlin values rarely leave ±0.6: stretch them so the channel
                        // spans most of [0, 255].
                        c[channel] = (0.5 * (1.0 + 1.6 * v) * 255.0).round().clamp(0.0, 255.0) as u8;
                        c
                    })
                    .collect();
                Paint::PerPoint(colors)
            }
        };
        out.push(Curve {
            points: r.points.clone(),
            widths,
            paint,
            outline: style.outline,
            magnetic: r.magnetic,
            parent: r.parent.map(|(p, k)| (p + offset, k)),
            depth: r.depth,
        });
    }
    Ok(out)
}
