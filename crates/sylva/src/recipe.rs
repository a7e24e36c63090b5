//! Recipes: one TOML document naming a generator and its parameters, the mesher and
//! the output. Every preset is a recipe; every CLI flag maps to a recipe key
//! (`--set mesh.sides=6`). The key reference is `docs/recipe.md`.
//!
//! Unknown keys are errors that name the key with its full path: the recipe is
//! deserialized, serialized back, and any input key missing from the round trip is
//! reported.
//!
//! Every mode is a type ([`modes`]): `mesh.method` is a [`MeshMethod`], `output.textures`
//! an [`crate::export::TextureMode`], and so on, written as the same names. A recipe is
//! made by [`Recipe::preset`], [`Recipe::from_toml`], [`Recipe::from_file`],
//! [`Recipe::default`], the typed `with_*` builders and [`Recipe::set`] (the CLI's
//! `--set`), all through [`Recipe::check`] ([`build`]); [`Loaded`] adds where its files
//! come from, a model folder, the embedded presets or memory
//! ([`Loaded::from_lsystem_source`]).

pub mod build;
pub mod modes;

pub use modes::{
    LeafMode, LeafNormals, MeshBase, MeshMethod, RefineBoundary, RefineScheme, ViewFiles, WindPreset,
};

use crate::error::{Error, Result};
use crate::export::{Compression, InstancingFallback, LodLayout, TextureMode};
use crate::fit::clear::ClearOptions;
use crate::fit::decollide::DecollideOptions;
use crate::mesh::hull::HullOptions;
use crate::mesh::quad::QuadOptions;
use crate::mesh::sweep::{SweepOptions, SweepTips};
use crate::mesh::tube::{TipStyle, TubeOptions};
use crate::mesh::Mesher;
use crate::refine::Scheme;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A whole recipe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Recipe {
    /// Name of the recipe (a preset's name).
    #[serde(default)]
    pub name: String,
    /// One-line description.
    #[serde(default)]
    pub description: String,
    /// Seed of every random choice.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// The generator and its parameters.
    pub generator: Generator,
    /// The mesher.
    #[serde(default)]
    pub mesh: MeshSection,
    /// The skeleton passes before meshing (`[fit.decollide]`, `[fit.clear]`).
    #[serde(default)]
    pub fit: FitSection,
    /// Subdivision of the mesher's control mesh.
    #[serde(default)]
    pub refine: RefineSection,
    /// Procedural textures (`[textures]`).
    #[serde(default)]
    pub textures: crate::texture::TextureOptions,
    /// How leaves are written (`[leaves]`).
    #[serde(default)]
    pub leaves: LeavesSection,
    /// Wind, rig and clip (`[wind]`, issue 24); left out of the file's metadata while
    /// `preset = "none"` and every key is at its default.
    #[serde(default, skip_serializing_if = "WindSection::is_off")]
    pub wind: WindSection,
    /// Levels of detail (`[lod]`, issue 24); left out of the file's metadata while off.
    #[serde(default, skip_serializing_if = "LodSection::is_off")]
    pub lod: LodSection,
    /// Input limits (`[input]`, issue 39); left out of the file's metadata at its default.
    #[serde(default, skip_serializing_if = "InputSection::is_default")]
    pub input: InputSection,
    /// Output files.
    #[serde(default)]
    pub output: OutputSection,
}

/// `[input]`: limits on the files a run reads (issue 39, [`crate::input`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InputSection {
    /// The most bytes one input file may hold (the recipe, the model and every file it
    /// names); a larger file is refused before it is read.
    pub max_bytes: u64,
}

impl Default for InputSection {
    fn default() -> Self {
        InputSection { max_bytes: crate::input::DEFAULT_MAX_BYTES }
    }
}

impl InputSection {
    /// `true` at the default limit (the section is then left out of written metadata).
    pub fn is_default(&self) -> bool {
        *self == InputSection::default()
    }
}

/// `[wind]`: the wind of Skjermo2008 (Skjermo2008-spec §4) as a skinned rig with a looping clip and
/// per-vertex shader channels. `preset = "none"` (the default) writes no rig.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WindSection {
    /// `none` (no wind data), `calm`, `breeze` or `storm`.
    pub preset: WindPreset,
    /// Multiplier of the preset's mean wind, `0..=100`.
    pub strength: f64,
    /// Direction the wind blows toward, degrees about +y (0 = +x, 90 = +z).
    pub direction: f64,
    /// Multiplier of the preset's gust amplitudes (all four waves), `0..=100`.
    pub gustiness: f64,
    /// Multiplier of the two short waves' amplitudes (fast, small-scale motion), `0..=100`.
    pub turbulence: f64,
    /// Stiffness factor κ per branch order, trunk first (the last serves deeper orders);
    /// larger bends more. Empty: the preset's.
    pub stiffness: Vec<f64>,
    /// Leaf flutter weight written to the `_WIND` channel's leaf component, `0..=1`.
    pub leaf_flutter: f64,
    /// Each level reads its parent's points of the previous step (the seed's lag).
    pub legacy_lag: bool,
    /// Most joints in the rig, `1..=1024` (game engines cap bones; 64 by default).
    pub max_joints: u32,
    /// Length of the looping clip in seconds, `0.5..=60`.
    pub clip_seconds: f64,
    /// Clip samples per second, `1..=120`.
    pub fps: u32,
}

impl Default for WindSection {
    fn default() -> Self {
        WindSection {
            preset: WindPreset::None,
            strength: 1.0,
            direction: 0.0,
            gustiness: 1.0,
            turbulence: 1.0,
            stiffness: Vec::new(),
            leaf_flutter: 0.5,
            legacy_lag: false,
            max_joints: 64,
            clip_seconds: 4.0,
            fps: 30,
        }
    }
}

impl WindSection {
    /// The table at its defaults (no wind).
    pub fn is_off(&self) -> bool {
        *self == WindSection::default()
    }

    /// Whether the model gets a rig, clip and wind channels.
    pub fn enabled(&self) -> bool {
        self.preset != WindPreset::None
    }

    /// Checks the keys; errors name them.
    pub fn check(&self) -> Result<()> {
        let bad = |k: &str, why: String| Err(Error::Recipe(format!("`wind.{k}` {why}")));
        for (k, v) in
            [("strength", self.strength), ("gustiness", self.gustiness), ("turbulence", self.turbulence)]
        {
            if !(0.0..=100.0).contains(&v) {
                return bad(k, format!("must be in 0..=100, got {v}"));
            }
        }
        if !self.direction.is_finite() {
            return bad("direction", format!("must be a finite number of degrees, got {}", self.direction));
        }
        if let Some(k) = self.stiffness.iter().find(|k| !(0.0..=100.0).contains(*k)) {
            return bad("stiffness", format!("values must be in 0..=100, got {k}"));
        }
        if self.stiffness.len() > 64 {
            return bad("stiffness", format!("has {} values; at most 64", self.stiffness.len()));
        }
        if !(0.0..=1.0).contains(&self.leaf_flutter) {
            return bad("leaf_flutter", format!("must be in 0..=1, got {}", self.leaf_flutter));
        }
        if !(1..=1024).contains(&self.max_joints) {
            return bad("max_joints", format!("must be in 1..=1024, got {}", self.max_joints));
        }
        if !(0.5..=60.0).contains(&self.clip_seconds) {
            return bad("clip_seconds", format!("must be in 0.5..=60, got {}", self.clip_seconds));
        }
        if !(1..=120).contains(&self.fps) {
            return bad("fps", format!("must be in 1..=120, got {}", self.fps));
        }
        Ok(())
    }

    /// The wind module's options this table gives (`None` for `preset = "none"`).
    pub fn options(&self) -> Option<crate::wind::WindOptions> {
        let mut w = self.preset.options()?;
        let preset_dir = w.mean.try_normalize().map_or(0.0, |d| d.y.atan2(d.x).to_degrees());
        let turn = glam::DMat2::from_angle((self.direction - preset_dir).to_radians());
        w.mean = turn * w.mean * self.strength;
        for (i, wave) in w.waves.iter_mut().enumerate() {
            wave.direction = turn * wave.direction;
            wave.amplitude *= self.gustiness * if i >= 2 { self.turbulence } else { 1.0 };
        }
        if !self.stiffness.is_empty() {
            w.stiffness = self.stiffness.clone();
        }
        w.legacy_lag = self.legacy_lag;
        Some(w)
    }
}

/// `[lod]`: the chain of levels of detail (issue 24). Empty `levels` and no impostor
/// (the default) write the model alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LodSection {
    /// Triangle budget of each level, LOD0 first, decreasing (`--lod 30000,8000,2000`).
    pub levels: Vec<u32>,
    /// A last level of crossed billboards textured from an octahedral impostor atlas.
    pub impostor: bool,
    /// Views per side of the hemi-octahedral impostor atlas, `2..=16`.
    pub atlas_frames: u32,
    /// Edge of the impostor atlas in pixels, `64..=4096`.
    pub atlas_size: u32,
}

impl Default for LodSection {
    fn default() -> Self {
        LodSection { levels: Vec::new(), impostor: false, atlas_frames: 8, atlas_size: 1024 }
    }
}

impl LodSection {
    /// The table at its defaults (no LOD chain).
    pub fn is_off(&self) -> bool {
        *self == LodSection::default()
    }

    /// Whether a chain is built.
    pub fn enabled(&self) -> bool {
        !self.levels.is_empty() || self.impostor
    }

    /// Checks the keys; errors name them.
    pub fn check(&self) -> Result<()> {
        let bad = |k: &str, why: String| Err(Error::Recipe(format!("`lod.{k}` {why}")));
        if self.levels.len() > 8 {
            return bad("levels", format!("has {} budgets; at most 8", self.levels.len()));
        }
        if let Some(b) = self.levels.iter().find(|&&b| !LOD_BUDGETS.contains(&b)) {
            return bad(
                "levels",
                format!(
                    "budgets must be in {}..={} triangles, got {b}",
                    LOD_BUDGETS.start(),
                    LOD_BUDGETS.end()
                ),
            );
        }
        if self.levels.windows(2).any(|w| w[1] >= w[0]) {
            return bad("levels", format!("budgets must decrease, got {:?}", self.levels));
        }
        if !(2..=16).contains(&self.atlas_frames) {
            return bad("atlas_frames", format!("must be in 2..=16, got {}", self.atlas_frames));
        }
        if !(64..=4096).contains(&self.atlas_size) {
            return bad("atlas_size", format!("must be in 64..=4096, got {}", self.atlas_size));
        }
        Ok(())
    }
}

/// The triangle budgets `lod.levels` (and `--lod`) accept.
pub const LOD_BUDGETS: std::ops::RangeInclusive<u32> = 12..=10_000_000;

/// `[leaves]`: how leaf organs are written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LeavesSection {
    /// `cards` (a textured, alpha-cut quad per leaf, from the leaf atlas; the default for
    /// games), `instanced` (the cards as one shape and an instance per card) or
    /// `geometry` (the leaf polygons as the generator drew them).
    pub mode: LeafMode,
    /// The atlas shape the cards show: `auto` (`None`: ovate, or the preset's), `ovate`,
    /// `lanceolate`, `lobed`, `compound`, `needles` or `cluster`.
    #[serde(with = "crate::texture::auto")]
    pub shape: Option<crate::texture::leaf::LeafShape>,
    /// Alpha cut-off of the cards (glTF `alphaCutoff`), in (0, 1).
    pub alpha_cutoff: f32,
    /// Leaves per card, `0..=64`: 1 is a card per leaf, more groups the leaves of a twig
    /// onto one card showing a twig of leaves (the atlas's cluster cell, or the needle
    /// tuft); 0 (`auto`) groups them on trees with more than
    /// [`AUTO_CLUSTER_LEAVES`] card leaves of a shape a twig card can show.
    pub per_card: u32,
    /// Leaf normals: `flat` (each leaf's own) or `crown` (bent toward the crown's outward
    /// direction for soft canopy shading, [`crate::mesh::cards::bend_toward_crown`]).
    pub normals: LeafNormals,
    /// Add leaves to the skeleton ([`crate::fit::leaves`], McLoughlin2021 §4.2): `level` (on
    /// every internode of level ≥ `start_level`) or `terminal` (Bloomenthal's
    /// configurations on terminal apices). Unset (or `none`): only the generator's own
    /// leaves.
    #[serde(skip_serializing_if = "Option::is_none", deserialize_with = "place_or_none")]
    pub place: Option<crate::fit::leaves::Placement>,
    /// Lowest branch level that gets leaves with `place = "level"` (unset: the two
    /// highest levels).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub start_level: Option<u16>,
    /// Leaves per internode (`level`) or per configuration (`terminal`), 1..=64 (unset: 2
    /// and 5).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub per_node: Option<u32>,
    /// Leaf length in metres (unset: 0.8 × the mean length of the leafy internodes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub size: Option<f32>,
}

impl LeavesSection {
    /// The leaf placement `place` asks for (`None`: none). Errors name the key.
    pub fn placement(&self, seed: u64) -> Result<Option<crate::fit::leaves::LeafPlacement>> {
        use crate::fit::leaves::{LeafPlacement, Placement};
        if let Some(n) = self.per_node.filter(|n| !(1..=64).contains(n)) {
            return Err(Error::Recipe(format!("`leaves.per_node` must be in 1..=64, got {n}")));
        }
        if let Some(size) = self.size.filter(|s| !(s.is_finite() && *s >= 0.0)) {
            return Err(Error::Recipe(format!("`leaves.size` must be a finite length ≥ 0, got {size}")));
        }
        let Some(placement) = self.place else { return Ok(None) };
        let per_node = self.per_node.unwrap_or(if placement == Placement::Level { 2 } else { 5 });
        let size = self.size.unwrap_or(0.0);
        Ok(Some(LeafPlacement { placement, start_level: self.start_level, per_node, size, seed }))
    }
}

/// `leaves.place`: `none` (or no key) is `None`, `level` and `terminal` the placements.
fn place_or_none<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<crate::fit::leaves::Placement>, D::Error> {
    use crate::fit::leaves::Placement;
    /// The names `leaves.place` takes.
    #[derive(Deserialize)]
    #[serde(rename_all = "lowercase")]
    enum Place {
        None,
        Level,
        Terminal,
    }
    Ok(match Place::deserialize(d)? {
        Place::None => None,
        Place::Level => Some(Placement::Level),
        Place::Terminal => Some(Placement::Terminal),
    })
}

/// Above this many card leaves `leaves.per_card = 0` groups leaves onto twig cards.
pub const AUTO_CLUSTER_LEAVES: usize = 4000;

impl Default for LeavesSection {
    fn default() -> Self {
        LeavesSection {
            mode: LeafMode::Cards,
            shape: None,
            alpha_cutoff: 0.5,
            per_card: 0,
            normals: LeafNormals::Flat,
            place: None,
            start_level: None,
            per_node: None,
            size: None,
        }
    }
}

impl LeavesSection {
    /// Checks the keys; errors name them.
    pub fn check(&self) -> Result<()> {
        if !(self.alpha_cutoff > 0.0 && self.alpha_cutoff < 1.0) {
            return Err(Error::Recipe(format!(
                "`leaves.alpha_cutoff` must be in (0, 1), got {}",
                self.alpha_cutoff
            )));
        }
        if self.per_card > 64 {
            return Err(Error::Recipe(format!("`leaves.per_card` must be in 0..=64, got {}", self.per_card)));
        }
        self.placement(0)?;
        Ok(())
    }

    /// Leaves per card and the atlas shape the cards show, for a tree with `leaves` card
    /// leaves: an explicit `per_card` is kept; `auto` (0) is 1 up to
    /// [`AUTO_CLUSTER_LEAVES`] and else enough to bring the cards near 2,500, at most 8,
    /// for ovate and needle trees (other shapes stay one card per leaf). Groups of ovate
    /// leaves show the cluster cell, groups of needles the needle tuft.
    pub fn cards(&self, leaves: usize) -> (usize, crate::texture::leaf::LeafShape) {
        use crate::texture::leaf::LeafShape;
        let shape = self.leaf_shape();
        let groupable = matches!(shape, LeafShape::Ovate | LeafShape::Cluster | LeafShape::Needles);
        let per_card = match self.per_card {
            0 if groupable && leaves > AUTO_CLUSTER_LEAVES => leaves.div_ceil(2500).clamp(2, 8),
            0 => 1,
            n => n as usize,
        };
        let shape = match shape {
            LeafShape::Ovate if per_card > 1 => LeafShape::Cluster,
            s => s,
        };
        (per_card, shape)
    }

    /// The shape the cards show (`auto` is ovate).
    pub fn leaf_shape(&self) -> crate::texture::leaf::LeafShape {
        self.shape.unwrap_or(crate::texture::leaf::LeafShape::Ovate)
    }
}

fn default_seed() -> u64 {
    1
}

/// The skeleton generator, chosen by `generator.type`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Generator {
    /// A cpfg-syntax L-system interpreted by the 3D turtle.
    Lsystem(LsystemGenerator),
    /// A skeleton read from a file: LST (Pieterse2012), a CPFG turtle string `.str` (MacMurchy2004,
    /// interpreted by the turtle) or a sylva JSON skeleton.
    Import(ImportGenerator),
    /// Weber & Penn 1995 parametric trees (`docs/weber-penn.md`).
    WeberPenn(Box<crate::grow::weber_penn::WeberPennParams>),
    /// Space colonization, Runions, Lane & Prusinkiewicz 2007 (`docs/colonize.md`).
    SpaceColonization(crate::grow::colonize::ColonizeParams),
    /// Least-cost-path trees, MIG and MGV (Xu2015; `docs/least-cost.md`).
    LeastCost(Box<crate::grow::least_cost::LeastCostParams>),
}

/// `generator.type = "import"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImportGenerator {
    /// The `.lst`, `.str` or `.json` file, relative to the recipe.
    pub file: String,
    /// LST gaps between a cylinder and the current node: `bridge`, `strict` or `new-root`.
    #[serde(default)]
    pub gap: crate::import::lst::GapPolicy,
    /// Turtle angle for `.str` files, degrees.
    #[serde(default = "default_angle")]
    pub angle: f64,
    /// Turtle step for `.str` files.
    #[serde(default = "one")]
    pub step: f64,
    /// Initial line width (a diameter) for `.str` files.
    #[serde(default = "default_width")]
    pub width: f64,
    /// Node budget (issue 27): the most skeleton nodes the file may make; checked before
    /// the skeleton is allocated. Left out of written metadata at its default.
    #[serde(default = "default_max_nodes", skip_serializing_if = "is_default_max_nodes")]
    pub max_nodes: usize,
}

fn default_max_nodes() -> usize {
    crate::skeleton::DEFAULT_MAX_NODES
}

/// Whether `n` is the default node budget (left out of the recipe written to a file's
/// metadata, so files keep their old form).
fn is_default_max_nodes(n: &usize) -> bool {
    *n == crate::skeleton::DEFAULT_MAX_NODES
}

/// `generator.type = "lsystem"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LsystemGenerator {
    /// The `.l` file, relative to the recipe (or to `presets/` for presets).
    pub file: String,
    /// Derivation steps; overrides the file's `derivation length`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u32>,
    /// Default turning angle in degrees.
    #[serde(default = "default_angle")]
    pub angle: f64,
    /// Default step length in metres.
    #[serde(default = "one")]
    pub step: f64,
    /// Initial line width (a diameter) in metres.
    #[serde(default = "default_width")]
    pub width: f64,
    /// Factor of a bare `!` (a bare `#` divides by it).
    #[serde(default = "default_width_factor")]
    pub width_factor: f64,
    /// Module budget: the most modules any derived string may hold.
    #[serde(default = "default_budget")]
    pub max_modules: usize,
    /// Node budget (issue 27): the most skeleton nodes the turtle may draw (counted
    /// before the skeleton is allocated). Left out of written metadata at its default.
    #[serde(default = "default_max_nodes", skip_serializing_if = "is_default_max_nodes")]
    pub max_nodes: usize,
    /// Overrides of the file's `#define` constants (name → value).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub define: BTreeMap<String, toml::Value>,
    /// cpfg model folder files (view `.v`, functions, surfaces): `auto` reads them from
    /// the L-system's folder (files on disk only), `none` ignores them.
    #[serde(default)]
    pub view: ViewFiles,
    /// The environmental program that answers the model's `?E` modules
    /// (`[generator.environment]`); without it, the model folder's `.e` file names it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub environment: Option<EnvironmentConfig>,
    /// Folders besides the model's own whose files the model folder's files may name
    /// (`specifications`, view, `.e` and spec files, `#include`; issue 39): relative
    /// ones are relative to the recipe's folder. Empty (the default): the model folder
    /// only.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub allow_paths: Vec<String>,
    /// The `generator` keys the recipe (or `--set`) gave explicitly; a view file's
    /// settings apply only to the others.
    #[serde(skip)]
    pub explicit: Vec<String>,
}

/// `[generator.environment]`: an environmental program for open L-systems (`?E`
/// modules), built into sylva (`crate::lsystem::environment`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnvironmentConfig {
    /// The program's name, as a cpfg `.e` file's `executable:` gives it (`honda81`,
    /// `clover`, `ecosystem`, `chiba`, `obcheck`); without it, the model folder's `.e`
    /// file names it and the keys below override its spec file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program: Option<String>,
    /// Collision radius of `honda81` (default 0.5), default leaf radius of `chiba`
    /// (default 0.5), model units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius: Option<f64>,
    /// Leaf transmittance of `clover` (default 0.1) and `chiba` (default 0), in [0, 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmittance: Option<f64>,
    /// `clover`'s light image (SGI `.rgb` or PNG), relative to the model folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub image: Option<String>,
    /// `chiba`'s number of sky directions (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub directions: Option<f64>,
    /// `obcheck`'s obstacle file, relative to the model folder.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub obstacles: Option<String>,
}

fn default_angle() -> f64 {
    45.0
}
fn one() -> f64 {
    1.0
}
fn default_width() -> f64 {
    0.1
}
fn default_width_factor() -> f64 {
    0.7
}
fn default_budget() -> usize {
    crate::lsystem::DEFAULT_MODULE_BUDGET
}

/// `[mesh]`: how the skeleton becomes a surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeshSection {
    /// Mesher: `tube` (generalized cylinders, the default), `hull`, `sweep`, `quad` or
    /// `leaf`.
    #[serde(default)]
    pub method: MeshMethod,
    /// Vertices per ring.
    #[serde(default = "default_sides")]
    pub sides: u32,
    /// Branch ends: `round`, `flat` or `open`.
    #[serde(default)]
    pub tips: TipStyle,
    /// The trunk's base: `flat` (cut at the root's height and closed flat, so the tree
    /// stands on flat ground with every mesher; [`crate::mesh::ground`]) or `round` (each
    /// mesher's own end).
    #[serde(default)]
    pub base: MeshBase,
    /// Pull apart branches that pass through each other before meshing
    /// ([`crate::fit::decollide`]). Unset: on for the joint meshers (`hull`, `sweep`,
    /// `quad`) on skeletons of up to [`DECOLLIDE_AUTO_NODES`] nodes, off for `tube`
    /// (see [`MeshSection::decollides`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub decollide: Option<bool>,
    /// After meshing, thin the skeleton where the surface, refined as `[refine]` says,
    /// still crosses itself, and mesh again ([`crate::fit::clear`]). Unset: whenever
    /// the skeleton is de-collided (see [`MeshSection::clears_nodes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clear: Option<bool>,
    /// Cut off every branch that passes through another, with its whole subtree, before
    /// meshing ([`crate::fit::overlap`], McLoughlin2021 §4.2: the higher level goes). Unset:
    /// off.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub prune_overlaps: Option<bool>,
    /// `[mesh.tube]`: the tube mesher's options (`sides` and `tips` are `mesh.sides`
    /// and `mesh.tips`).
    #[serde(default)]
    pub tube: TubeOptions,
    /// `[mesh.hull]`: the hull mesher's options (`sides` is `mesh.sides`; caps follow
    /// `mesh.tips`).
    #[serde(default)]
    pub hull: HullOptions,
    /// `[mesh.sweep]`: the sweep mesher's options (caps and tips follow `mesh.tips`).
    #[serde(default)]
    pub sweep: SweepOptions,
    /// `[mesh.quad]`: the quad mesher's options.
    #[serde(default)]
    pub quad: QuadOptions,
    /// `[mesh.leaf]`: the leaf mesher's options (MacMurchy2004's leaf mode, `/L`). Left out
    /// of written metadata at its defaults (so the files of other meshers keep their
    /// bytes).
    #[serde(default, skip_serializing_if = "is_default_leaf")]
    pub leaf: crate::mesh::leaf::LeafOptions,
    /// Memory budget of the mesh stage in bytes (issue 39): the peak of the stages
    /// after meshing, estimated from the bark mesh ([`crate::mesh::memory`]), checked
    /// before meshing (from a lower bound) and after it (from the mesh). Left out of
    /// written metadata at its default ([`crate::mesh::memory::DEFAULT_MAX_MEMORY`],
    /// 4 GiB).
    #[serde(default = "default_mesh_max_memory", skip_serializing_if = "is_default_mesh_max_memory")]
    pub max_memory: u64,
}

fn default_mesh_max_memory() -> u64 {
    crate::mesh::memory::DEFAULT_MAX_MEMORY
}

/// Whether `n` is the default `mesh.max_memory` (left out of written metadata).
fn is_default_mesh_max_memory(n: &u64) -> bool {
    *n == crate::mesh::memory::DEFAULT_MAX_MEMORY
}

impl MeshSection {
    /// The mesher `method` names, with its `[mesh.<method>]` options and the shared
    /// `sides` and `tips` applied.
    pub fn mesher(&self) -> Mesher {
        self.mesher_for(self.method)
    }

    /// [`MeshSection::mesher`] for `method` instead of `self.method`.
    pub fn mesher_for(&self, method: MeshMethod) -> Mesher {
        let open = self.tips == TipStyle::Open;
        match method {
            MeshMethod::Tube => {
                Mesher::Tube(TubeOptions { sides: self.sides, tips: self.tips, ..self.tube.clone() })
            }
            MeshMethod::Hull => {
                Mesher::Hull(HullOptions { sides: self.sides, caps: !open, ..self.hull.clone() })
            }
            // `mesh.tips = "flat"` is the seed's Cap Front off: pruned, creased flat tips.
            MeshMethod::Sweep => Mesher::Sweep(SweepOptions {
                caps: !open,
                tips: if self.tips == TipStyle::Flat { SweepTips::Pruned } else { SweepTips::Cone },
                ..self.sweep.clone()
            }),
            MeshMethod::Quad => Mesher::Quad(self.quad.clone()),
            MeshMethod::Leaf => Mesher::Leaf(self.leaf.clone()),
        }
    }

    /// Whether the pipeline de-collides the skeleton: `decollide` when set, else true
    /// for the joint meshers, whose single watertight surface (and its subdivision) is
    /// only free of self-intersections on a collision-free skeleton, and false for
    /// `tube`, whose child tubes start inside their parents by design anyway.
    pub fn decollides(&self) -> bool {
        // A leaf is one open sheet: nothing to pull apart.
        self.decollide.unwrap_or(self.method.joins())
    }

    /// Whether the pipeline de-collides a skeleton of `nodes` nodes: as
    /// [`MeshSection::decollides`], except that the unset default skips skeletons of
    /// more than [`DECOLLIDE_AUTO_NODES`] nodes (the pass takes 15–20 s there; set
    /// `decollide = true` to run it anyway).
    pub fn decollides_nodes(&self, nodes: usize) -> bool {
        match self.decollide {
            Some(on) => on,
            None => self.decollides() && nodes <= DECOLLIDE_AUTO_NODES,
        }
    }

    /// Whether the pipeline runs the mesh-checked thinning on a skeleton of `nodes`
    /// nodes: `clear` when set (never for `tube`, whose child tubes start inside their
    /// parents by design), else whenever it de-collides the skeleton.
    pub fn clears_nodes(&self, nodes: usize) -> bool {
        self.method.joins() && self.clear.unwrap_or_else(|| self.decollides_nodes(nodes))
    }
}

/// Largest skeleton the unset `mesh.decollide` de-collides by default (the Weber–Penn
/// trees of 100 k nodes take 15–20 s in the pass on a 2-core machine).
pub const DECOLLIDE_AUTO_NODES: usize = 50_000;

fn default_sides() -> u32 {
    8
}

impl Default for MeshSection {
    fn default() -> Self {
        MeshSection {
            method: MeshMethod::Tube,
            sides: default_sides(),
            tips: TipStyle::Round,
            base: MeshBase::Flat,
            decollide: None,
            clear: None,
            prune_overlaps: None,
            tube: TubeOptions::default(),
            hull: HullOptions::default(),
            sweep: SweepOptions::default(),
            quad: QuadOptions::default(),
            leaf: Default::default(),
            max_memory: default_mesh_max_memory(),
        }
    }
}

/// `[fit]`: options of the skeleton passes between the generator and the mesher
/// ([`crate::fit`]); whether each runs is `mesh.decollide` / `mesh.clear`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitSection {
    /// `[fit.decollide]`: the skeleton de-collision's options.
    #[serde(default)]
    pub decollide: DecollideOptions,
    /// `[fit.clear]`: the mesh-checked thinning's options (its check level follows
    /// `refine.levels`).
    #[serde(default)]
    pub clear: ClearOptions,
}

/// `[refine]`: subdivision of the bark control mesh.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefineSection {
    /// `auto` (the mesher's own scheme: Catmull–Clark for `quad`, Loop for the
    /// others), `none`, `loop` (triangle meshes) or `catmull-clark`.
    #[serde(default)]
    pub scheme: RefineScheme,
    /// Subdivision levels (each multiplies the face count by 4).
    #[serde(default)]
    pub levels: u32,
    /// Push the result to the limit surface with exact limit normals.
    #[serde(default)]
    pub limit: bool,
    /// Where the mesh's boundary vertices go (open bases and tips): `auto` (the mesher's
    /// own rule: `fixed` for `hull`, Pieterse2012's default; `bspline` for the others), `fixed`
    /// (every boundary vertex stays put, so the rim stays the control polygon; Pieterse2012-spec
    /// §2.8), `bspline` (the rim refines as a cubic B-spline, `1/8, 3/4, 1/8`, with
    /// single-face corners pinned) or `edge-only` (B-spline, nothing pinned).
    #[serde(default, skip_serializing_if = "is_default_boundary")]
    pub boundary: RefineBoundary,
    /// Face budget of the subdivision (issue 27): a refinement that would make more
    /// faces is an error naming this key, checked before anything is allocated. Left
    /// out of written metadata at its default ([`DEFAULT_REFINE_MAX_FACES`]).
    #[serde(default = "default_refine_max_faces", skip_serializing_if = "is_default_refine_max_faces")]
    pub max_faces: usize,
    /// Memory budget of the subdivision in bytes (issue 39): a refinement whose
    /// estimated peak ([`crate::refine::peak_memory`]) is larger is an error naming this
    /// key, checked before the refined levels are allocated. Left out of written
    /// metadata at its default ([`crate::refine::DEFAULT_MAX_MEMORY`], 4 GiB).
    #[serde(default = "default_refine_max_memory", skip_serializing_if = "is_default_refine_max_memory")]
    pub max_memory: u64,
}

/// Largest `refine.max_memory` accepted (1 TiB).
pub const REFINE_MAX_MEMORY_LIMIT: u64 = 1 << 40;

fn default_refine_max_memory() -> u64 {
    crate::refine::DEFAULT_MAX_MEMORY
}

/// Whether `n` is the default `refine.max_memory` (left out of written metadata).
fn is_default_refine_max_memory(n: &u64) -> bool {
    *n == crate::refine::DEFAULT_MAX_MEMORY
}

/// Default of `refine.max_faces`: 20 M refined faces, about 3–4 GiB at the peak of the
/// refinement (the refiner's topology, positions, indices and UVs), so a run stays
/// under the 6 GiB the robustness campaign allows.
pub const DEFAULT_REFINE_MAX_FACES: usize = 20_000_000;

/// Largest `refine.max_faces` accepted.
pub const REFINE_MAX_FACES_LIMIT: usize = 1_000_000_000;

fn default_refine_max_faces() -> usize {
    DEFAULT_REFINE_MAX_FACES
}

/// Whether `n` is the default `refine.max_faces` (left out of written metadata).
fn is_default_refine_max_faces(n: &usize) -> bool {
    *n == DEFAULT_REFINE_MAX_FACES
}

/// Whether `o` is the default `[mesh.leaf]` table (left out of written metadata).
fn is_default_leaf(o: &crate::mesh::leaf::LeafOptions) -> bool {
    *o == crate::mesh::leaf::LeafOptions::default()
}

/// Whether `b` is the default `refine.boundary` (left out of written metadata, so the
/// recipes written before the key existed read back the same).
fn is_default_boundary(b: &RefineBoundary) -> bool {
    *b == RefineBoundary::Auto
}

impl Default for RefineSection {
    fn default() -> Self {
        RefineSection {
            scheme: RefineScheme::Auto,
            levels: 0,
            limit: false,
            max_faces: DEFAULT_REFINE_MAX_FACES,
            max_memory: default_refine_max_memory(),
            boundary: RefineBoundary::Auto,
        }
    }
}

/// `[output]`: where the results go.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputSection {
    /// The model file; its extension picks the format (`.glb`, `.gltf`, `.obj`, `.ply`).
    #[serde(default = "default_file")]
    pub file: String,
    /// A preview PNG, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<String>,
    /// Preview width and height in pixels.
    #[serde(default = "default_preview_size")]
    pub preview_size: u32,
    /// Where textures go: `embed` (in the `.glb`/`.gltf`), `files` (PNGs beside the
    /// model) or `none` (flat colours). OBJ always writes files unless `none`. (The
    /// recipe's [`TextureMode::Files`] has an empty prefix: [`OutputSection::export_options`]
    /// names the files after the model.)
    #[serde(default)]
    pub textures: TextureMode,
    /// What glTF readers without `EXT_mesh_gpu_instancing` get where leaves are
    /// instanced: `none` (the instances; such a reader draws one leaf) or `merged` (every
    /// leaf merged into one mesh, no extension).
    #[serde(default, skip_serializing_if = "is_default")]
    pub instancing_fallback: InstancingFallback,
    /// glTF compression: `none`, `quantize` (`KHR_mesh_quantization`) or `meshopt`
    /// (quantized, then `EXT_meshopt_compression`); both extensions are required.
    #[serde(default, skip_serializing_if = "is_default")]
    pub compress: Compression,
    /// glTF levels of detail: `msft` (the coarser levels are nodes outside the scene that
    /// LOD0's `MSFT_lod` names; plain viewers show LOD0) or `scene` (every level a node
    /// of the scene, named `_LOD0 … _LODn` for engines that group by name).
    #[serde(default, skip_serializing_if = "is_default")]
    pub lod_layout: LodLayout,
    /// Also write the wind channels packed into `COLOR_0` / `TEXCOORD_1` (docs/wind.md);
    /// readers that apply vertex colours then tint the model.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub wind_colors: bool,
}

impl OutputSection {
    /// The writer's options this table gives for a model written to `path` (texture
    /// files named after the model's stem). Every value is valid by its type, so this
    /// does not fail today; the `Result` is kept for callers.
    pub fn export_options(&self, path: &std::path::Path) -> Result<crate::export::ExportOptions> {
        Ok(crate::export::ExportOptions {
            textures: self.textures.for_path(path),
            instancing_fallback: self.instancing_fallback,
            compress: self.compress,
            lod_layout: self.lod_layout,
            wind_colors: self.wind_colors,
        })
    }
}

/// Whether `v` is its type's default (an `[output]` key at its default is left out of
/// the recipe written to a file's metadata).
fn is_default<T: Default + PartialEq>(v: &T) -> bool {
    *v == T::default()
}

fn default_file() -> String {
    "tree.glb".into()
}
fn default_preview_size() -> u32 {
    1024
}

impl Default for OutputSection {
    fn default() -> Self {
        OutputSection {
            file: default_file(),
            preview: None,
            preview_size: default_preview_size(),
            textures: TextureMode::Embed,
            instancing_fallback: InstancingFallback::None,
            compress: Compression::None,
            lod_layout: LodLayout::Msft,
            wind_colors: false,
        }
    }
}

/// Where a recipe came from, which decides how its relative file names resolve.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// An embedded preset: files resolve inside `presets/`.
    Preset(String),
    /// A file on disk: files resolve relative to this folder.
    Folder(PathBuf),
    /// Memory: the recipe's files (the L-system, `.str` strings, `#include`d files) by
    /// the names the recipe gives them ([`Loaded::from_lsystem_source`],
    /// [`Loaded::with_files`]). Nothing is read from disk; `.lst` and `.json` imports and
    /// a model folder's view and function files need a [`Origin::Folder`].
    Memory(BTreeMap<String, String>),
}

/// A recipe together with its origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Loaded {
    /// The recipe.
    pub recipe: Recipe,
    /// Where it came from.
    pub origin: Origin,
}

impl Loaded {
    /// Reads a file the recipe names, from the embedded presets, from disk or from
    /// memory. Returns the display name used in messages and the text.
    pub fn read(&self, file: &str) -> Result<(String, String)> {
        match &self.origin {
            Origin::Preset(name) => match crate::presets::file(file) {
                Some(text) => Ok((format!("presets/{file}"), text.to_string())),
                None => Err(Error::Recipe(format!("preset `{name}` names a missing file `{file}`"))),
            },
            Origin::Folder(dir) => {
                let path = dir.join(file);
                let text = crate::input::read_input_to_string(&path, self.recipe.input.max_bytes)?;
                Ok((path.display().to_string(), text))
            }
            Origin::Memory(files) => match files.get(file) {
                Some(text) => Ok((file.to_string(), text.clone())),
                None => Err(Error::Recipe(format!(
                    "the recipe names `{}`, which is not among the files given in memory ({})",
                    crate::diagnostic::quote(file),
                    files
                        .keys()
                        .map(|k| format!("`{}`", crate::diagnostic::quote(k)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))),
            },
        }
    }
}

/// Parses `key=value` (the CLI's `--set`). The value is read as TOML when it parses
/// (`3`, `22.5`, `true`, `"x"`, `[1, 2]`), else taken as a bare string.
///
/// A value that starts like a TOML array, table or string (`[`, `{`, `"`) must parse:
/// its syntax error names the key and the column in the value, with a clipped excerpt.
/// Messages quote the key and the value clipped ([`crate::diagnostic::quote`]).
pub fn parse_set(kv: &str) -> Result<(String, toml::Value)> {
    use crate::diagnostic::{caret_excerpt, clip_quoted, quote};
    let Some((k, v)) = kv.split_once('=') else {
        return Err(Error::Recipe(format!("`--set {}` is not of the form key=value", quote(kv))));
    };
    let key = k.trim();
    if key.is_empty() || key.split('.').any(|p| p.trim().is_empty()) {
        return Err(Error::Recipe(format!("`--set {}`: bad key `{}`", quote(kv), quote(key))));
    }
    let v = v.trim();
    const PREFIX: &str = "v = ";
    let value = match toml::from_str::<toml::Table>(&format!("{PREFIX}{v}")) {
        Ok(mut t) => t.remove("v").unwrap_or_else(|| toml::Value::String(v.to_string())),
        Err(e) if v.starts_with(['[', '{', '"']) => {
            let at = e.span().map_or(0, |r| r.start.saturating_sub(PREFIX.len()));
            let (_, col, excerpt) = caret_excerpt(v, at);
            return Err(Error::Recipe(format!(
                "`--set {}=…`: the value is not valid TOML at column {col}: {}\n{excerpt}",
                quote(key),
                clip_quoted(e.message().trim())
            )));
        }
        Err(_) => toml::Value::String(v.to_string()),
    };
    Ok((key.to_string(), value))
}

/// Sets a dotted key in a TOML table, creating intermediate tables.
pub fn set_key(table: &mut toml::Table, key: &str, value: toml::Value) -> Result<()> {
    let parts: Vec<&str> = key.split('.').map(str::trim).collect();
    let mut t = table;
    for (i, p) in parts.iter().enumerate() {
        if i + 1 == parts.len() {
            t.insert(p.to_string(), value);
            return Ok(());
        }
        let entry = t.entry(p.to_string()).or_insert_with(|| toml::Value::Table(toml::Table::new()));
        t = match entry {
            toml::Value::Table(t) => t,
            _ => {
                return Err(Error::Recipe(format!(
                    "cannot set `{}`: `{}` is a value, not a table",
                    crate::diagnostic::quote(key),
                    crate::diagnostic::quote(&parts[..=i].join("."))
                )))
            }
        };
    }
    Ok(())
}

/// Builds a recipe from a TOML table after applying `sets`, rejecting unknown keys.
pub fn from_table(mut table: toml::Table, sets: &[(String, toml::Value)]) -> Result<Recipe> {
    for (k, v) in sets {
        set_key(&mut table, k, v.clone())?;
    }
    let recipe: Recipe = serde_path_to_error::deserialize(toml::Value::Table(table.clone())).map_err(
        |e: serde_path_to_error::Error<toml::de::Error>| {
            let mut path = e.path().to_string();
            let mut why = e.into_inner().message().trim().to_string();
            // `generator` is an internally tagged enum: serde reads its table through a
            // buffer the path tracker cannot see into, so the key inside is found by
            // reading the table again as the variant its `type` names.
            if path == "generator" {
                if let Some((inner, w)) = table.get("generator").and_then(generator_key_error) {
                    (path, why) = (format!("generator.{inner}"), w);
                }
            }
            // A mode's unknown name: `` `leaves.mode` is `x`; use cards, instanced or geometry ``.
            if let Some(hint) = modes::variant_hint(&why).filter(|_| path != ".") {
                if path == "generator" {
                    path = "generator.type".into(); // the tag names no known generator
                }
                let hint = crate::diagnostic::clip_quoted(&hint);
                return Error::Recipe(format!("`{}` {hint}", crate::diagnostic::quote(&path)));
            }
            let why = type_hint(&crate::diagnostic::clip_quoted(&why));
            if path == "." {
                Error::Recipe(why)
            } else {
                Error::Recipe(format!("`{}`: {why}", crate::diagnostic::quote(&path)))
            }
        },
    )?;
    let mut recipe = recipe;
    if let (Generator::Lsystem(g), Some(toml::Value::Table(gt))) =
        (&mut recipe.generator, table.get("generator"))
    {
        g.explicit = gt.keys().cloned().collect();
    }
    let back = toml::Value::try_from(&recipe).map_err(|e| Error::Recipe(e.to_string()))?;
    if let toml::Value::Table(back) = back {
        let mut unknown = Vec::new();
        unknown_keys(&table, &back, "", &mut unknown);
        if let Some(k) = unknown.first() {
            return Err(Error::Recipe(format!("unknown key `{}`", crate::diagnostic::quote(k))));
        }
    }
    recipe.check()?;
    Ok(recipe)
}

/// The key inside a `[generator]` table whose value fails to read, and why: the table
/// read again (without its `type`) as the variant `type` names, with the path tracked.
/// `None` when the table reads (the error is elsewhere) or `type` is not known.
fn generator_key_error(generator: &toml::Value) -> Option<(String, String)> {
    fn read<T: serde::de::DeserializeOwned>(v: toml::Value) -> Option<(String, String)> {
        let e = serde_path_to_error::deserialize::<_, T>(v).err()?;
        let path = e.path().to_string();
        (path != ".").then(|| (path, e.into_inner().message().trim().to_string()))
    }
    let mut t = generator.as_table()?.clone();
    let ty = t.remove("type")?;
    let v = toml::Value::Table(t);
    match ty.as_str()? {
        "lsystem" => read::<LsystemGenerator>(v),
        "import" => read::<ImportGenerator>(v),
        "weber-penn" => read::<crate::grow::weber_penn::WeberPennParams>(v),
        "space-colonization" => read::<crate::grow::colonize::ColonizeParams>(v),
        "least-cost" => read::<crate::grow::least_cost::LeastCostParams>(v),
        _ => None,
    }
}

/// serde's type names in a message said in words: `expected u32` becomes `expected a
/// whole number in 0..=4294967295 (u32)`, `expected f64` `expected a number (f64)`.
fn type_hint(why: &str) -> String {
    let mut out = why.to_string();
    for (ty, words) in [
        ("u8", format!("a whole number in 0..={}", u8::MAX)),
        ("u16", format!("a whole number in 0..={}", u16::MAX)),
        ("u32", format!("a whole number in 0..={}", u32::MAX)),
        ("u64", format!("a whole number in 0..={}", u64::MAX)),
        ("usize", format!("a whole number in 0..={}", usize::MAX)),
        ("i32", format!("a whole number in {}..={}", i32::MIN, i32::MAX)),
        ("i64", format!("a whole number in {}..={}", i64::MIN, i64::MAX)),
        ("f32", "a number".to_string()),
        ("f64", "a number".to_string()),
    ] {
        let pat = format!("expected {ty}");
        let whole_word = |k: &usize| !out[k + pat.len()..].starts_with(char::is_alphanumeric);
        if let Some(k) = out.find(&pat).filter(whole_word) {
            out.replace_range(k..k + pat.len(), &format!("expected {words} ({ty})"));
            break;
        }
    }
    out
}

/// Keys the recipe leaves out when it is written at their defaults (so files' metadata
/// keeps its old form): missing from the round trip, they are still known. The `[wind]`
/// and `[lod]` tables check their own keys (`deny_unknown_fields`).
const SKIPPED_AT_DEFAULT: &[&str] = &[
    "input",
    "generator.allow_paths",
    "fit.decollide.max_work",
    "mesh.leaf",
    "refine.boundary",
    "generator.max_nodes",
    "refine.max_faces",
    "refine.max_memory",
    "mesh.max_memory",
    "mesh.quad.max_repair_work",
    "fit.clear.max_work",
    "wind",
    "lod",
    "output.preview",
    "output.instancing_fallback",
    "output.compress",
    "output.lod_layout",
    "output.wind_colors",
];

/// Keys of `input` that do not survive the round trip into `back`.
fn unknown_keys(input: &toml::Table, back: &toml::Table, prefix: &str, out: &mut Vec<String>) {
    for (k, v) in input {
        let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        if path == "generator.define" {
            continue; // free-form: any constant name
        }
        match (v, back.get(k)) {
            (_, None) if SKIPPED_AT_DEFAULT.contains(&path.as_str()) => {}
            (_, None) => out.push(path),
            (toml::Value::Table(a), Some(toml::Value::Table(b))) => unknown_keys(a, b, &path, out),
            _ => {}
        }
    }
}

/// A TOML syntax error in `text`, as toml writes it (`TOML parse error at line L, column
/// C`, the line with a caret, the message), except that a line longer than a few hundred
/// characters is shown clipped around the error and quoted pieces of the message are
/// clipped (toml prints the whole line, however long).
fn toml_error(text: &str, e: &toml::de::Error) -> String {
    use crate::diagnostic::{caret_excerpt, clip_quoted, EXCERPT_SIDE};
    let full = e.to_string();
    let Some(span) = e.span() else { return clip_quoted(full.trim()).into_owned() };
    let at = span.start.min(text.len());
    let start = text[..at].rfind('\n').map_or(0, |k| k + 1);
    let line = text[start..].split('\n').next().unwrap_or("");
    if line.len() <= 2 * EXCERPT_SIDE && full.len() <= 8 * EXCERPT_SIDE {
        return full.trim().to_string();
    }
    let (line, col, excerpt) = caret_excerpt(text, at);
    format!("TOML parse error at line {line}, column {col}\n{excerpt}\n{}", clip_quoted(e.message().trim()))
}

/// Loads the recipe for `what`: an embedded preset name, a `.toml` recipe file, or a
/// bare model file (`.l`) that gets the default recipe. `sets` are `--set` overrides.
pub fn load(what: &str, sets: &[(String, toml::Value)]) -> Result<Loaded> {
    let path = Path::new(what);
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if ext == "toml" {
        // The recipe's own limit is known only once it is read: `--set input.max_bytes`
        // applies to it, the recipe file's key does not.
        let limit = sets
            .iter()
            .find(|(k, _)| k == crate::input::MAX_BYTES_KEY)
            .and_then(|(_, v)| v.as_integer())
            .and_then(|v| u64::try_from(v).ok())
            .filter(|&v| v > 0)
            .unwrap_or(crate::input::DEFAULT_MAX_BYTES);
        let text = crate::input::read_input_to_string(path, limit)?;
        let table: toml::Table = toml::from_str(&text)
            .map_err(|e| Error::Recipe(format!("{}: {}", path.display(), toml_error(&text, &e))))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let recipe = from_table(table, sets).map_err(|e| match e {
            Error::Recipe(m) => Error::Recipe(format!("{}: {m}", path.display())),
            e => e,
        })?;
        return Ok(Loaded { recipe, origin: Origin::Folder(dir) });
    }
    if ["lst", "str", "json"].contains(&ext.as_str()) {
        if !path.exists() {
            return Err(Error::Read {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        let mut table = toml::Table::new();
        let stem = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let name = stem.split('.').next().unwrap_or("").to_string();
        table.insert("name".into(), toml::Value::String(name));
        set_key(&mut table, "generator.type", toml::Value::String("import".into()))?;
        set_key(&mut table, "generator.file", toml::Value::String(stem))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        return Ok(Loaded { recipe: from_table(table, sets)?, origin: Origin::Folder(dir) });
    }
    if ext == "l" {
        let mut table = toml::Table::new();
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        table.insert("name".into(), toml::Value::String(name));
        let file = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        set_key(&mut table, "generator.type", toml::Value::String("lsystem".into()))?;
        set_key(&mut table, "generator.file", toml::Value::String(file))?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        if !path.exists() {
            return Err(Error::Read {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        return Ok(Loaded { recipe: from_table(table, sets)?, origin: Origin::Folder(dir) });
    }
    if let Some(p) = crate::presets::get(what).filter(|p| p.is_curves()) {
        return Err(Error::Recipe(format!(
            "`{}` is a magnetic-curves composition, not a tree: render it with `sylva curves {} -o out.svg`",
            p.name, p.name
        )));
    }
    if let Some(p) = crate::presets::get(what) {
        let table: toml::Table =
            toml::from_str(p.recipe).map_err(|e| Error::Recipe(format!("preset {what}: {e}")))?;
        return Ok(Loaded { recipe: from_table(table, sets)?, origin: Origin::Preset(what.to_string()) });
    }
    if path.exists() || what.contains('/') || what.contains('.') {
        if !path.exists() {
            return Err(Error::Read {
                path: path.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            });
        }
        return Err(Error::Recipe(format!(
            "cannot tell what `{what}` is: give a preset name, a .toml recipe or a .l model"
        )));
    }
    Err(Error::Recipe(format!("unknown preset `{what}`")))
}

impl Recipe {
    /// The scheme `[refine]` subdivides the bark with: `None` for `scheme = "none"`;
    /// `auto` is the mesher's ([`Mesher::scheme`]).
    pub fn refine_scheme(&self) -> Option<Scheme> {
        match self.refine.scheme {
            RefineScheme::None => None,
            RefineScheme::Loop => Some(Scheme::Loop),
            RefineScheme::CatmullClark => Some(Scheme::CatmullClark),
            RefineScheme::Auto => Some(self.mesh.mesher().scheme()),
        }
    }

    /// The boundary rule `[refine] boundary` names (`auto`: [`BoundaryInterpolation::Fixed`]
    /// for the hull mesher, Pieterse2012's default, else the B-spline rim).
    ///
    /// [`BoundaryInterpolation::Fixed`]: crate::refine::BoundaryInterpolation::Fixed
    pub fn refine_boundary(&self) -> crate::refine::BoundaryInterpolation {
        use crate::refine::BoundaryInterpolation as B;
        match self.refine.boundary {
            RefineBoundary::Auto if self.mesh.method == MeshMethod::Hull => B::Fixed,
            RefineBoundary::Auto | RefineBoundary::Bspline => B::EdgeAndCorner,
            RefineBoundary::Fixed => B::Fixed,
            RefineBoundary::EdgeOnly => B::EdgeOnly,
        }
    }

    /// Checks value ranges that serde cannot express.
    pub fn check(&self) -> Result<()> {
        let bad = |k: &str, why: String| Err(Error::Recipe(format!("`{k}` {why}")));
        if self.input.max_bytes == 0 {
            return bad(crate::input::MAX_BYTES_KEY, "must be at least 1".into());
        }
        match &self.generator {
            Generator::Lsystem(g) => {
                for (k, v) in [
                    ("generator.angle", g.angle),
                    ("generator.step", g.step),
                    ("generator.width", g.width),
                    ("generator.width_factor", g.width_factor),
                ] {
                    if !v.is_finite() {
                        return bad(k, format!("must be a finite number, got {v}"));
                    }
                }
                if g.width < 0.0 {
                    return bad("generator.width", format!("must be ≥ 0, got {}", g.width));
                }
                if g.max_modules == 0 {
                    return bad("generator.max_modules", "must be at least 1".into());
                }
                if let Err(why) = crate::lsystem::derive::check_module_budget(g.max_modules) {
                    return bad("generator.max_modules", why);
                }
                if g.max_nodes == 0 {
                    return bad("generator.max_nodes", "must be at least 1".into());
                }
                if let Some(p) = g.allow_paths.iter().find(|p| p.trim().is_empty()) {
                    return bad("generator.allow_paths", format!("names an empty folder `{p}`"));
                }
                for (k, v) in &g.define {
                    if matches!(v, toml::Value::Table(_) | toml::Value::Array(_)) {
                        return bad(&format!("generator.define.{k}"), "must be a number or a string".into());
                    }
                }
            }
            // Both generators validate their own parameters (naming the key) when they run.
            Generator::SpaceColonization(g) => g.validate()?,
            Generator::WeberPenn(g) => g.validate()?,
            Generator::LeastCost(g) => g.validate()?,
            Generator::Import(g) => {
                for (k, v) in
                    [("generator.angle", g.angle), ("generator.step", g.step), ("generator.width", g.width)]
                {
                    if !v.is_finite() {
                        return bad(k, format!("must be a finite number, got {v}"));
                    }
                }
                if g.width < 0.0 {
                    return bad("generator.width", format!("must be ≥ 0, got {}", g.width));
                }
                if g.max_nodes == 0 {
                    return bad("generator.max_nodes", "must be at least 1".into());
                }
            }
        }
        // The shared keys first: each mesher's table is checked with them filled in.
        if !(3..=1024).contains(&self.mesh.sides) {
            return bad("mesh.sides", format!("must be in 3..=1024, got {}", self.mesh.sides));
        }
        self.mesh.mesher().check()?;
        // The other meshers' tables too: a bad value is a mistake even where unused.
        for &method in MeshMethod::ALL {
            self.mesh.mesher_for(method).check()?;
        }
        self.fit.decollide.check()?;
        self.fit.clear.check()?;
        if self.refine.levels > 6 {
            return bad(
                "refine.levels",
                format!("is {}; at most 6 (each level multiplies faces by 4)", self.refine.levels),
            );
        }
        if !(1..=REFINE_MAX_FACES_LIMIT).contains(&self.refine.max_faces) {
            return bad(
                "refine.max_faces",
                format!("must be in 1..={REFINE_MAX_FACES_LIMIT}, got {}", self.refine.max_faces),
            );
        }
        if !(1..=REFINE_MAX_MEMORY_LIMIT).contains(&self.mesh.max_memory) {
            return bad(
                "mesh.max_memory",
                format!("must be in 1..={REFINE_MAX_MEMORY_LIMIT} bytes, got {}", self.mesh.max_memory),
            );
        }
        if !(1..=REFINE_MAX_MEMORY_LIMIT).contains(&self.refine.max_memory) {
            return bad(
                "refine.max_memory",
                format!("must be in 1..={REFINE_MAX_MEMORY_LIMIT} bytes, got {}", self.refine.max_memory),
            );
        }
        self.textures.check()?;
        self.leaves.check()?;
        self.wind.check()?;
        self.lod.check()?;
        if !(1..=8192).contains(&self.output.preview_size) {
            return bad(
                "output.preview_size",
                format!("must be in 1..=8192, got {}", self.output.preview_size),
            );
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The keys of the `docs/recipe.md` table under the heading `heading`.
    fn documented_keys(heading: &str) -> Vec<String> {
        let doc = include_str!("../../../docs/recipe.md");
        let start = doc.find(heading).unwrap_or_else(|| panic!("docs/recipe.md has no {heading}"));
        doc[start..]
            .lines()
            .skip(1)
            .take_while(|l| !l.starts_with('#'))
            .filter_map(|l| l.strip_prefix("| `"))
            .filter_map(|l| l.split('`').next())
            .map(str::to_string)
            .collect()
    }

    /// Every field of the `[mesh.*]`, `[fit.*]`, `[textures]` and `[leaves]` tables is documented, every documented
    /// key is accepted by `--set` with its default value, and an unknown key is an error.
    #[test]
    fn mesher_and_fit_tables_match_their_docs() {
        fn table_of(r: &Recipe, table: &str) -> toml::Value {
            match table {
                "mesh.tube" => toml::Value::try_from(&r.mesh.tube),
                "mesh.hull" => toml::Value::try_from(&r.mesh.hull),
                "mesh.sweep" => toml::Value::try_from(&r.mesh.sweep),
                "mesh.quad" => toml::Value::try_from(&r.mesh.quad),
                "fit.decollide" => toml::Value::try_from(&r.fit.decollide),
                "textures" => toml::Value::try_from(&r.textures),
                "leaves" => toml::Value::try_from(&r.leaves),
                "wind" => toml::Value::try_from(&r.wind),
                "lod" => toml::Value::try_from(&r.lod),
                _ => toml::Value::try_from(&r.fit.clear),
            }
            .unwrap()
        }
        let tables: [(&str, &str, toml::Value); 10] = [
            ("mesh.tube", "### `[mesh.tube]`", toml::Value::try_from(TubeOptions::default()).unwrap()),
            ("mesh.hull", "### `[mesh.hull]`", toml::Value::try_from(HullOptions::default()).unwrap()),
            ("mesh.sweep", "### `[mesh.sweep]`", toml::Value::try_from(SweepOptions::default()).unwrap()),
            ("mesh.quad", "### `[mesh.quad]`", toml::Value::try_from(QuadOptions::default()).unwrap()),
            (
                "fit.decollide",
                "### `[fit.decollide]`",
                toml::Value::try_from(DecollideOptions::default()).unwrap(),
            ),
            ("fit.clear", "### `[fit.clear]`", toml::Value::try_from(ClearOptions::default()).unwrap()),
            (
                "textures",
                "## `[textures]`",
                toml::Value::try_from(crate::texture::TextureOptions::default()).unwrap(),
            ),
            ("leaves", "## `[leaves]`", toml::Value::try_from(LeavesSection::default()).unwrap()),
            ("wind", "## `[wind]`", toml::Value::try_from(WindSection::default()).unwrap()),
            ("lod", "## `[lod]`", toml::Value::try_from(LodSection::default()).unwrap()),
        ];
        for (table, heading, written) in tables {
            let mut defaults = written.clone();
            // The budget keys left out of written metadata at their defaults (issue 27)
            // are fields and documented too.
            let skipped = [
                (
                    "mesh.quad.max_repair_work",
                    toml::Value::Integer(crate::mesh::quad::DEFAULT_REPAIR_WORK as i64),
                ),
                ("fit.clear.max_work", toml::Value::Integer(crate::fit::clear::DEFAULT_CLEAR_WORK as i64)),
                (
                    "fit.decollide.max_work",
                    toml::Value::Integer(crate::fit::decollide::DEFAULT_DECOLLIDE_WORK as i64),
                ),
            ];
            for (key, v) in skipped {
                if let Some(field) = key.strip_prefix(table).and_then(|k| k.strip_prefix('.')) {
                    defaults.as_table_mut().unwrap().insert(field.into(), v);
                }
            }
            let mut fields: Vec<String> = defaults.as_table().unwrap().keys().cloned().collect();
            // Optional keys (unset by default, so never written) are documented too.
            let optional = ["leaves.place", "leaves.start_level", "leaves.per_node", "leaves.size"];
            fields.extend(
                optional.iter().filter_map(|k| k.strip_prefix(table)?.strip_prefix('.')).map(str::to_string),
            );
            let mut documented = documented_keys(heading);
            documented.sort();
            let mut sorted = fields.clone();
            sorted.sort();
            assert_eq!(documented, sorted, "{table}: documented keys vs fields");
            for (k, v) in defaults.as_table().unwrap() {
                let l = load("lsys-honda-a", &[(format!("{table}.{k}"), v.clone())])
                    .unwrap_or_else(|e| panic!("{table}.{k} = {v}: {e}"));
                assert_eq!(table_of(&l.recipe, table), written, "{table}.{k}: the table is at its defaults");
            }
            let e = load("lsys-honda-a", &sets(&[&format!("{table}.no_such_key=1")])).unwrap_err();
            assert!(e.to_string().contains("no_such_key"), "{table}: {e}");
        }
        // Out of range: the error names the key.
        for (kv, key) in [
            ("fit.decollide.clearance=2", "fit.decollide.clearance"),
            ("fit.decollide.max_rounds=1000", "fit.decollide.max_rounds"),
            ("fit.clear.step=1.5", "fit.clear.step"),
            ("fit.clear.max_pairs=0", "fit.clear.max_pairs"),
            ("fit.clear.max_work=0", "fit.clear.max_work"),
            ("fit.decollide.max_work=0", "fit.decollide.max_work"),
            ("mesh.quad.max_repair_work=0", "max_repair_work"),
            ("refine.max_faces=0", "refine.max_faces"),
            ("refine.max_memory=0", "refine.max_memory"),
            ("generator.max_nodes=0", "generator.max_nodes"),
            ("mesh.quad.support=-1", "mesh.quad.support"),
            ("textures.bark_size=8", "textures.bark_size"),
            ("textures.bark=\"mossy\"", "textures.bark"),
            ("leaves.mode=\"sprites\"", "leaves.mode"),
            ("leaves.shape=\"round\"", "leaves.shape"),
            ("leaves.alpha_cutoff=1", "leaves.alpha_cutoff"),
            ("leaves.place=\"all\"", "leaves.place"),
            ("leaves.per_node=0", "leaves.per_node"),
            ("leaves.size=-1", "leaves.size"),
            ("output.textures=\"inline\"", "output.textures"),
        ] {
            let e = load("lsys-honda-a", &sets(&[kv])).unwrap_err();
            assert!(e.to_string().contains(key), "{kv}: {e}");
        }
    }

    fn sets(kv: &[&str]) -> Vec<(String, toml::Value)> {
        kv.iter().map(|s| parse_set(s).unwrap()).collect()
    }

    #[test]
    fn every_preset_loads() {
        for p in crate::presets::all().into_iter().filter(|p| !p.is_curves()) {
            let l = load(p.name, &[]).unwrap_or_else(|e| panic!("{}: {e}", p.name));
            assert_eq!(l.recipe.name, p.name, "recipe name matches the file name");
        }
    }

    #[test]
    fn set_overrides_and_types() {
        let l = load("lsys-honda-a", &sets(&["generator.angle=22.5", "mesh.sides=6", "seed=7"])).unwrap();
        let Generator::Lsystem(g) = &l.recipe.generator else { panic!("an L-system recipe") };
        assert_eq!(g.angle, 22.5);
        assert_eq!(l.recipe.mesh.sides, 6);
        assert_eq!(l.recipe.seed, 7);
        let l = load("lsys-honda-a", &sets(&["generator.define.R1=0.5"])).unwrap();
        let Generator::Lsystem(g) = &l.recipe.generator else { panic!("an L-system recipe") };
        assert_eq!(g.define.get("R1"), Some(&toml::Value::Float(0.5)));
    }

    #[test]
    fn decollide_defaults_to_the_joint_meshers() {
        assert!(!load("lsys-honda-a", &[]).unwrap().recipe.mesh.decollides(), "tube: off");
        for m in ["hull", "sweep", "quad"] {
            let l = load("lsys-honda-a", &sets(&[&format!("mesh.method=\"{m}\"")])).unwrap();
            assert!(l.recipe.mesh.decollides(), "{m}: on");
        }
        let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\"", "mesh.decollide=false"])).unwrap();
        assert!(!l.recipe.mesh.decollides());
        let l = load("lsys-honda-a", &sets(&["mesh.decollide=true"])).unwrap();
        assert!(l.recipe.mesh.decollides());
        assert!(l.recipe.mesh.decollides_nodes(10 * DECOLLIDE_AUTO_NODES), "explicit: any size");
        // Unset: the joint meshers skip very large skeletons.
        let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\""])).unwrap();
        assert!(l.recipe.mesh.decollides_nodes(DECOLLIDE_AUTO_NODES));
        assert!(!l.recipe.mesh.decollides_nodes(DECOLLIDE_AUTO_NODES + 1));
        // Mesh clearing follows de-collision unless set, and never runs for tubes.
        assert!(l.recipe.mesh.clears_nodes(100) && !l.recipe.mesh.clears_nodes(DECOLLIDE_AUTO_NODES + 1));
        let l = load("lsys-honda-a", &sets(&["mesh.method=\"hull\"", "mesh.clear=false"])).unwrap();
        assert!(l.recipe.mesh.decollides_nodes(100) && !l.recipe.mesh.clears_nodes(100));
        let l =
            load("lsys-honda-a", &sets(&["mesh.method=\"quad\"", "mesh.decollide=false", "mesh.clear=true"]))
                .unwrap();
        assert!(l.recipe.mesh.clears_nodes(10 * DECOLLIDE_AUTO_NODES), "explicit: any size");
        assert!(!load("lsys-honda-a", &sets(&["mesh.clear=true"])).unwrap().recipe.mesh.clears_nodes(100));
    }

    #[test]
    fn unknown_keys_are_named() {
        let e = load("lsys-honda-a", &sets(&["generator.angel=3"])).unwrap_err();
        assert!(e.to_string().contains("unknown key `generator.angel`"), "{e}");
        let e = load("lsys-honda-a", &sets(&["colour=3"])).unwrap_err();
        assert!(e.to_string().contains("unknown key `colour`"), "{e}");
        // Keys at the defaults the written recipe leaves out are still known.
        for (k, v) in [
            ("output.compress", "\"none\""),
            ("output.instancing_fallback", "\"none\""),
            ("output.lod_layout", "\"msft\""),
            ("output.wind_colors", "false"),
            ("wind.preset", "\"none\""),
            ("lod.impostor", "false"),
        ] {
            let set = parse_set(&format!("{k}={v}")).unwrap();
            load("lsys-honda-a", &[set]).unwrap_or_else(|e| panic!("{k} = {v}: {e}"));
        }
        let e = load("lsys-honda-a", &sets(&["wind.gusts=1"])).unwrap_err();
        assert!(e.to_string().contains("gusts"), "{e}");
        let e = load("lsys-honda-a", &sets(&["mesh.sides=2"])).unwrap_err();
        assert!(e.to_string().contains("mesh.sides"), "{e}");
        let e = load("lsys-honda-a", &sets(&["mesh.sides=many"])).unwrap_err();
        assert!(e.to_string().contains("sides") || e.to_string().contains("integer"), "{e}");
        assert!(parse_set("novalue").is_err());
        let e = load("lsys-honda-a", &sets(&["mesh.decollide=3"])).unwrap_err();
        assert!(e.to_string().contains("decollide") || e.to_string().contains("bool"), "{e}");
        assert!(load("no-such-preset", &[]).unwrap_err().to_string().contains("unknown preset"));
        assert!(load("missing.l", &[]).unwrap_err().to_string().contains("missing.l"));
    }
}
