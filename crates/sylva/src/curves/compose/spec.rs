//! The `[curves]` table as data: the composition, its layers, particles, charges,
//! fields, regions and views, read with serde so an unknown key is an error naming it
//! (Xu2015 §7.2–§7.3; Xu2015-spec §3.7).

use super::style::StyleSpec;
use super::{check_finite, check_positive, v2};
use crate::curves::fill::Region;
use crate::curves::magnetic::{self, Field, Integrator, Profile, Signs, UserExpr, Wave};
use crate::curves::render::Drawing;
use crate::curves::space;
use crate::error::{Error, Result};
use crate::noise::Perlin;
use glam::DVec3;
use serde::Deserialize;

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
    /// Triangle wave.
    Triangle(Wave),
    /// Square wave.
    Square(Wave),
    /// Sine wave.
    Sine(Wave),
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
            ChargeSpec::Triangle(w) => Profile::Triangle(*w),
            ChargeSpec::Square(w) => Profile::Square(*w),
            ChargeSpec::Sine(w) => Profile::Sine(*w),
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
    pub(super) fn field(&self, seed: u64) -> Result<Field> {
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

    pub(super) fn field3(&self, seed: u64) -> Result<space::Field3> {
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
    pub(super) fn region(&self, what: &str) -> Result<Region> {
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

/// Declares [`LayerSpec`]: each variant's own fields followed by the two every layer
/// has (`style`, `mirror`), and the accessors that match over all variants, so a new
/// layer type is written in one place.
macro_rules! layer_spec {
    ($($(#[$doc:meta])* $variant:ident = $kind:literal { $($fields:tt)* })*) => {
        /// One layer of a composition (see the module docs for the table of types).
        #[derive(Debug, Clone, PartialEq, Deserialize)]
        #[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
        pub enum LayerSpec {
            $(
                $(#[$doc])*
                $variant {
                    $($fields)*
                    /// Style, over the composition's.
                    #[serde(default)]
                    style: StyleSpec,
                    /// Mirror about the canvas centre line (3D layers: their projection).
                    #[serde(default)]
                    mirror: bool,
                },
            )*
        }

        impl LayerSpec {
            /// The layer's `type` name.
            pub fn kind(&self) -> &'static str {
                match self {
                    $(LayerSpec::$variant { .. } => $kind,)*
                }
            }

            /// The layer's style and whether it is mirrored.
            pub(super) fn common(&self) -> (&StyleSpec, bool) {
                match self {
                    $(LayerSpec::$variant { style, mirror, .. } => (style, *mirror),)*
                }
            }
        }
    };
}

layer_spec! {
        /// Listed particles.
        Particles = "particles" {
            /// The particles.
            particle: Vec<ParticleSpec>,
            /// Stop particles when they leave this region (default: no limit).
            region: Option<RegionSpec>,
            /// The field.
            #[serde(default)]
            field: FieldSpec,
        }
        /// A grid of spirals: one per (row `T`, column `α`) (Fig. 7.3).
        Grid = "grid" {
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
        }
        /// Space filling (Figs. 7.4–7.7).
        Fill = "fill" {
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
        }
        /// Hair strands from a drawn hairline (Figs. 7.10, 7.12).
        Hair = "hair" {
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
        }
        /// Cartoon flames (Fig. 7.13).
        Fire = "fire" {
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
        }
        /// One particle meandering in a region (Fig. 7.14); each re-entry gets a uniform
        /// random RGB colour unless the style sets `color_by`.
        Meander = "meander" {
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
        }
        /// Drawn polylines (no taper unless the style sets one).
        Lines = "lines" {
            /// Polylines `[[[x, y], …], …]`.
            lines: Vec<Vec<[f64; 2]>>,
            /// Close every polyline.
            #[serde(default)]
            closed: bool,
        }
        /// 3D magnetic curves with a vector field, branching, drawn in projection and
        /// exported as a skeleton (`sylva curves … -o tree.glb`).
        Space = "space" {
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
        }
        /// Curves traced on a sphere: B is normal to the surface, its value from 3D noise
        /// (or uniform), and particles move along great circles between turns.
        Sphere = "sphere" {
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
        }
}

fn thirty_five() -> f64 {
    35.0
}
fn yes() -> bool {
    true
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
pub(super) fn max_steps() -> u64 {
    magnetic::DEFAULT_MAX_STEPS
}
pub(super) fn max_curves() -> usize {
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
