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
mod check;
pub mod modes;
mod read;
pub mod schema;
#[cfg(test)]
mod tests;

pub use modes::{
    LeafMode, LeafNormals, MeshBase, MeshMethod, RandomSource, RefineBoundary, RefineScheme, ViewFiles,
    WindPreset,
};
pub use read::{from_table, load, over_preset, parse_set, set_key, Loaded, Origin, PRESET_KEY};
pub use schema::schema;

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
    /// The random generator: `auto` (cpfg's for L-system files, sylva's for presets),
    /// `cpfg` or `sylva` (issue 46). Left out of written metadata at `auto`.
    #[serde(default, skip_serializing_if = "RandomSource::is_auto")]
    pub random: RandomSource,
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
