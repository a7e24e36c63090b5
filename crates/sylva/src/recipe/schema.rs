//! The recipe schema as data (issue 40): every key a recipe can hold, with its
//! [`Section`], value [`Kind`] (range or names), default, [`Unit`] and a one-line doc, so
//! a front end (the editor, the Blender panel) can draw a checkbox, slider or dropdown per
//! key, and `docs/recipe.md` can be checked against it (`tests/recipe_schema.rs`).
//!
//! Ranges are those [`Recipe::set`](super::Recipe::set) enforces on one key; a limit that
//! depends on other keys (a budget, `kill_distance < influence_radius`) is said in words
//! in the `limits` field of [`Key`]. Free-form tables (`generator.define`, least-cost volumes and
//! iterations) are [`Kind::Table`] or lists of it; their keys are in
//! `docs/least-cost.md` and `docs/lsystem.md`. Model names follow the references of
//! `docs/references.md` (WeberPenn1995, Runions2007, Xu2015, …).
//!
//! ```
//! use sylva::recipe::schema::{schema, GeneratorKind, Kind, Section};
//! // The controls of a Weber–Penn tree: every key of its generator, then the mesher's.
//! for key in schema().iter().filter(|k| k.section == Section::Generator(GeneratorKind::WeberPenn)) {
//!     let control = match key.kind {
//!         Kind::Bool => "checkbox",
//!         Kind::Integer { .. } | Kind::Float { .. } => "slider",
//!         Kind::Mode(names) => { assert!(!names.is_empty()); "dropdown" }
//!         _ => "text field",
//!     };
//!     println!("{} ({control}, default {:?}): {}", key.key, key.default_value(), key.doc);
//! }
//! let sides = sylva::recipe::schema::find("mesh.sides", None).unwrap();
//! assert_eq!(sides.kind, Kind::Integer { min: 3, max: 1024 });
//! assert_eq!(sides.default_value(), Some(toml::Value::Integer(8)));
//! ```

use crate::named::mode;
use std::ops::Bound::{self, Excluded, Included, Unbounded};

mode! {
    /// `generator.type`: which generator a recipe uses (the [`super::Generator`] variant).
    GeneratorKind, key "generator.type", default Lsystem {
        /// A cpfg-syntax L-system ([`super::LsystemGenerator`]).
        Lsystem = "lsystem",
        /// A skeleton read from a file ([`super::ImportGenerator`]).
        Import = "import",
        /// WeberPenn1995 parametric trees.
        WeberPenn = "weber-penn",
        /// Runions2007 space colonization.
        SpaceColonization = "space-colonization",
        /// Xu2015 least-cost-path trees.
        LeastCost = "least-cost",
    }
}

impl super::Generator {
    /// The generator's type as a [`GeneratorKind`].
    pub fn generator_kind(&self) -> GeneratorKind {
        match self {
            super::Generator::Lsystem(_) => GeneratorKind::Lsystem,
            super::Generator::Import(_) => GeneratorKind::Import,
            super::Generator::WeberPenn(_) => GeneratorKind::WeberPenn,
            super::Generator::SpaceColonization(_) => GeneratorKind::SpaceColonization,
            super::Generator::LeastCost(_) => GeneratorKind::LeastCost,
        }
    }
}

/// The table a key belongs to (a heading of `docs/recipe.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Section {
    /// Top-level keys (`name`, `description`, `seed`).
    Top,
    /// `[input]`: limits on the files a run reads.
    Input,
    /// `[generator]` of one generator type: its keys apply to that type only.
    Generator(GeneratorKind),
    /// `[mesh]`: the mesher and the keys every mesher shares.
    Mesh,
    /// `[mesh.tube]`.
    MeshTube,
    /// `[mesh.hull]`.
    MeshHull,
    /// `[mesh.sweep]`.
    MeshSweep,
    /// `[mesh.leaf]`.
    MeshLeaf,
    /// `[mesh.quad]`.
    MeshQuad,
    /// `[fit.decollide]`.
    FitDecollide,
    /// `[fit.clear]`.
    FitClear,
    /// `[refine]`.
    Refine,
    /// `[textures]`.
    Textures,
    /// `[leaves]`.
    Leaves,
    /// `[wind]`.
    Wind,
    /// `[lod]`.
    Lod,
    /// `[output]`.
    Output,
}

impl Section {
    /// Every section, in the order of `docs/recipe.md`.
    pub const ALL: &'static [Section] = &[
        Section::Top,
        Section::Input,
        Section::Generator(GeneratorKind::Lsystem),
        Section::Generator(GeneratorKind::Import),
        Section::Generator(GeneratorKind::WeberPenn),
        Section::Generator(GeneratorKind::SpaceColonization),
        Section::Generator(GeneratorKind::LeastCost),
        Section::Mesh,
        Section::MeshTube,
        Section::MeshHull,
        Section::MeshSweep,
        Section::MeshLeaf,
        Section::MeshQuad,
        Section::FitDecollide,
        Section::FitClear,
        Section::Refine,
        Section::Textures,
        Section::Leaves,
        Section::Wind,
        Section::Lod,
        Section::Output,
    ];

    /// The TOML table's dotted name (`mesh.tube`; `""` for the top level).
    pub fn table(self) -> &'static str {
        match self {
            Section::Top => "",
            Section::Input => "input",
            Section::Generator(_) => "generator",
            Section::Mesh => "mesh",
            Section::MeshTube => "mesh.tube",
            Section::MeshHull => "mesh.hull",
            Section::MeshSweep => "mesh.sweep",
            Section::MeshLeaf => "mesh.leaf",
            Section::MeshQuad => "mesh.quad",
            Section::FitDecollide => "fit.decollide",
            Section::FitClear => "fit.clear",
            Section::Refine => "refine",
            Section::Textures => "textures",
            Section::Leaves => "leaves",
            Section::Wind => "wind",
            Section::Lod => "lod",
            Section::Output => "output",
        }
    }

    /// The generator type the section is for (`None` outside `[generator]`).
    pub fn generator(self) -> Option<GeneratorKind> {
        match self {
            Section::Generator(g) => Some(g),
            _ => None,
        }
    }
}

/// The value a key takes. Numeric ranges are the ones [`super::Recipe::set`] enforces;
/// integers are whole numbers in `min..=max` (the type's limit where the recipe sets none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kind {
    /// `true` or `false`.
    Bool,
    /// A whole number in `min..=max`.
    Integer {
        /// The smallest value accepted.
        min: i64,
        /// The largest value accepted.
        max: i64,
    },
    /// A finite number between two bounds (inclusive, exclusive or none).
    Float {
        /// The lower bound.
        min: Bound<f64>,
        /// The upper bound.
        max: Bound<f64>,
    },
    /// One of these names (the serde names of the key's enum).
    Mode(&'static [&'static str]),
    /// Free text.
    String,
    /// A file or folder name, relative to the recipe (to `presets/` for presets).
    Path,
    /// An array of `item`s, `min_len..=max_len` long.
    List {
        /// What each element is.
        item: &'static Kind,
        /// The fewest elements.
        min_len: usize,
        /// The most elements.
        max_len: usize,
    },
    /// A table of its own structure, described in the key's doc (not broken into keys).
    Table,
}

impl std::fmt::Display for Kind {
    /// The values in words, as the doc tables give them: `0..=8`, `[0, 1]`, `(0, 100]`,
    /// `≥ 0`, `flat or open`, `4 × [0, 3]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Kind::Bool => f.write_str("true or false"),
            Kind::Integer { min, max } if *max >= U32 => write!(f, "≥ {min}"),
            Kind::Integer { min, max } => write!(f, "{min}..={max}"),
            Kind::Float { min, max } => match (min, max) {
                (Unbounded, Unbounded) => f.write_str("any number"),
                (Included(a), Unbounded) => write!(f, "≥ {a}"),
                (Excluded(a), Unbounded) => write!(f, "> {a}"),
                (Unbounded, Included(b)) => write!(f, "≤ {b}"),
                (Unbounded, Excluded(b)) => write!(f, "< {b}"),
                (a, b) => {
                    let (open, a) = match a {
                        Included(a) => ('[', a),
                        Excluded(a) => ('(', a),
                        Unbounded => unreachable!(),
                    };
                    let (close, b) = match b {
                        Included(b) => (']', b),
                        Excluded(b) => (')', b),
                        Unbounded => unreachable!(),
                    };
                    write!(f, "{open}{a}, {b}{close}")
                }
            },
            Kind::Mode(names) => f.write_str(&crate::named::one_of(names)),
            Kind::String => f.write_str("text"),
            Kind::Path => f.write_str("a file name"),
            Kind::List { item, min_len, max_len } if min_len == max_len => write!(f, "{min_len} × {item}"),
            Kind::List { item, max_len, .. } if *max_len < usize::MAX => {
                write!(f, "at most {max_len} × {item}")
            }
            Kind::List { item, .. } => write!(f, "a list of {item}"),
            Kind::Table => f.write_str("a table"),
        }
    }
}

/// The unit of a numeric key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Unit {
    /// Metres (model units for L-systems).
    Metres,
    /// Degrees.
    Degrees,
    /// Pixels.
    Pixels,
    /// Bytes.
    Bytes,
    /// Seconds.
    Seconds,
    /// Per second (frames per second).
    PerSecond,
}

impl Unit {
    /// The unit's symbol (`m`, `°`, `px`, `B`, `s`, `1/s`).
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Metres => "m",
            Unit::Degrees => "°",
            Unit::Pixels => "px",
            Unit::Bytes => "B",
            Unit::Seconds => "s",
            Unit::PerSecond => "1/s",
        }
    }
}

/// A key's default.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DefaultValue {
    /// This value, as TOML text (`8`, `'tube'`, `[1.0, 2.0]`).
    Toml(&'static str),
    /// No value: the key is absent until set, and its doc says what absence means
    /// (`auto`, the file's own setting, …).
    Unset,
    /// No default: a recipe of this section must give it.
    Required,
}

/// When a key is used (a front end may hide it otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum When {
    /// The mode `key` is one of `names`.
    Is {
        /// The mode's dotted key.
        key: &'static str,
        /// The names under which this key is used.
        names: &'static [&'static str],
    },
    /// The optional table is given (setting any of its keys gives it).
    Table(&'static str),
}

/// One key of the schema.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Key {
    /// The dotted key (`mesh.sides`).
    pub key: &'static str,
    /// Its table, and for `generator.*` the generator type.
    pub section: Section,
    /// The values it takes.
    pub kind: Kind,
    /// Its default.
    pub default: DefaultValue,
    /// The unit of a number.
    pub unit: Option<Unit>,
    /// One line saying what it does.
    pub doc: &'static str,
    /// Conditions under which it is used (all must hold; empty: always).
    pub when: &'static [When],
    /// Limits that depend on other keys, in words (budgets, orderings), checked too.
    pub limits: Option<&'static str>,
}

impl Key {
    /// The default as a TOML value (`None` when [`DefaultValue::Unset`] or
    /// [`DefaultValue::Required`]).
    pub fn default_value(&self) -> Option<toml::Value> {
        match self.default {
            DefaultValue::Toml(text) => {
                let mut t: toml::Table = toml::from_str(&format!("v = {text}")).ok()?;
                t.remove("v")
            }
            DefaultValue::Unset | DefaultValue::Required => None,
        }
    }

    /// The key relative to its section's table (`sides` for `mesh.sides`).
    pub fn name(&self) -> &'static str {
        let table = self.section.table();
        if table.is_empty() {
            self.key
        } else {
            &self.key[table.len() + 1..]
        }
    }

    const fn when(mut self, when: &'static [When]) -> Key {
        self.when = when;
        self
    }

    const fn limits(mut self, limits: &'static str) -> Key {
        self.limits = Some(limits);
        self
    }
}

/// Every key of every section, in the order of `docs/recipe.md`.
pub fn schema() -> &'static [Key] {
    KEYS
}

/// The schema key `key` names (for `generator.*` keys, of the generator `generator`;
/// `None` picks the first section that has it). A key inside a list or a free-form
/// table, as error messages name them (`generator.n_taper[2]`,
/// `generator.define.R1`, `generator.iterations[0].rotation.rule`), finds the list's or
/// table's key, so a front end can point at the control an error is about.
pub fn find(key: &str, generator: Option<GeneratorKind>) -> Option<&'static Key> {
    let fits = |k: &Key| generator.is_none() || k.section.generator().is_none_or(|g| Some(g) == generator);
    let exact = |name: &str| KEYS.iter().find(|k| k.key == name && fits(k));
    let key = key.trim();
    if let Some(k) = exact(key) {
        return Some(k);
    }
    if let Some((list, _)) = key.split_once('[') {
        return exact(list).filter(|k| matches!(k.kind, Kind::List { .. }));
    }
    let mut prefix = key;
    while let Some((head, _)) = prefix.rsplit_once('.') {
        if let Some(k) = exact(head) {
            return (k.kind == Kind::Table).then_some(k);
        }
        prefix = head;
    }
    None
}

/// The keys of `section`, in order.
pub fn keys_of(section: Section) -> impl Iterator<Item = &'static Key> {
    KEYS.iter().filter(move |k| k.section == section)
}

const fn k(
    key: &'static str,
    section: Section,
    kind: Kind,
    default: DefaultValue,
    unit: Option<Unit>,
    doc: &'static str,
) -> Key {
    Key { key, section, kind, default, unit, doc, when: &[], limits: None }
}

const fn int(min: i64, max: i64) -> Kind {
    Kind::Integer { min, max }
}
/// `min..=max`.
const fn range(min: f64, max: f64) -> Kind {
    Kind::Float { min: Included(min), max: Included(max) }
}
/// `[min, ∞)`.
const fn at_least(min: f64) -> Kind {
    Kind::Float { min: Included(min), max: Unbounded }
}
/// `(min, max]`.
const fn above_to(min: f64, max: f64) -> Kind {
    Kind::Float { min: Excluded(min), max: Included(max) }
}
/// `[min, max)`.
const fn from_below(min: f64, max: f64) -> Kind {
    Kind::Float { min: Included(min), max: Excluded(max) }
}
/// Any finite number.
const ANY: Kind = Kind::Float { min: Unbounded, max: Unbounded };
const fn list(item: &'static Kind, min_len: usize, max_len: usize) -> Kind {
    Kind::List { item, min_len, max_len }
}
const fn t(text: &'static str) -> DefaultValue {
    DefaultValue::Toml(text)
}

const U32: i64 = u32::MAX as i64;
const BIG: i64 = i64::MAX;
const M: Option<Unit> = Some(Unit::Metres);
const DEG: Option<Unit> = Some(Unit::Degrees);
const PX: Option<Unit> = Some(Unit::Pixels);
const B: Option<Unit> = Some(Unit::Bytes);
const N: Option<Unit> = None;
const REQ: DefaultValue = DefaultValue::Required;
const UNSET: DefaultValue = DefaultValue::Unset;

use GeneratorKind::{Import, LeastCost, Lsystem, SpaceColonization, WeberPenn};
use Section::*;

const LS: Section = Generator(Lsystem);
const IM: Section = Generator(Import);
const WP: Section = Generator(WeberPenn);
const SC: Section = Generator(SpaceColonization);
const LC: Section = Generator(LeastCost);

/// A Weber–Penn per-level array: four numbers, levels 0–3.
const fn wp4(item: &'static Kind) -> Kind {
    list(item, 4, 4)
}
const WP_ANY: Kind = ANY;
const WP_NONNEG: Kind = at_least(0.0);
const WP_THOUSAND: Kind = range(0.0, 1000.0);
const WP_TAPER: Kind = range(0.0, 3.0);
const WP_CURVE_V: Kind = Kind::Float { min: Excluded(-90.0), max: Unbounded };
const WP_SPLITS: Kind = range(0.0, 64.0);
const WP_RES: Kind = int(1, 1000);
const WP_BRANCHES: Kind = int(0, 1_000_000);

/// Colonization lengths are finite with magnitude at most 10⁵ m.
const SC_LEN: Kind = range(-1e5, 1e5);
const SC_POS: Kind = above_to(0.0, 1e5);
const SC_NONNEG: Kind = range(0.0, 1e5);
const SC_ANY: Kind = ANY;

/// Least-cost numbers are finite with magnitude at most 10⁶.
const LC_COORD: Kind = range(-1e6, 1e6);
const LC_POINT: Kind = list(&LC_COORD, 3, 3);

const ENVELOPE: &str = "generator.envelope.shape";
const MIG: &[When] = &[When::Is { key: "generator.method", names: &["mig"] }];
const MGV: &[When] = &[When::Is { key: "generator.method", names: &["mgv"] }];
const BCM: &[When] = &[When::Is { key: "generator.method", names: &["bcm"] }];
const MIG_BCM: &[When] = &[When::Is { key: "generator.method", names: &["mig", "bcm"] }];
const MIG_REFINE: &[When] =
    &[When::Is { key: "generator.method", names: &["mig"] }, When::Table("generator.refine")];

const KEYS: &[Key] = &[
    // Top level.
    k("name", Top, Kind::String, t("''"), N, "recipe name (a preset's name)"),
    k("description", Top, Kind::String, t("''"), N, "one-line description"),
    k("seed", Top, int(0, BIG), t("1"), N, "seed of every random choice"),
    // [input]
    k("input.max_bytes", Input, int(1, BIG), t("1073741824"), B, "the most bytes one input file may hold"),
    // [generator] type = "lsystem"
    k("generator.type", LS, Kind::Mode(GeneratorKind::NAMES), REQ, N, "the generator: `lsystem` here"),
    k("generator.file", LS, Kind::Path, REQ, N, "the `.l` file, relative to the recipe"),
    k("generator.iterations", LS, int(0, U32), UNSET, N, "derivation steps (unset: the file's `derivation length`)"),
    k("generator.angle", LS, ANY, t("45.0"), DEG, "default turning angle of `+ - & ^ / \\`"),
    k("generator.step", LS, ANY, t("1.0"), M, "default length of `F f G g`"),
    k("generator.width", LS, at_least(0.0), t("0.1"), M, "initial line width, a diameter"),
    k("generator.width_factor", LS, ANY, t("0.7"), N, "a bare `!` multiplies the width by it, a bare `#` divides"),
    k("generator.max_modules", LS, int(1, 500_000_000), t("50000000"), N, "module budget of every derived string"),
    k("generator.max_nodes", LS, int(1, BIG), t("1000000"), N, "skeleton node budget of the turtle"),
    k(
        "generator.define",
        LS,
        Kind::Table,
        t("{}"),
        N,
        "a table: `NAME = value` overrides the file's `#define NAME value` (numbers or strings)",
    ),
    k("generator.view", LS, Kind::Mode(super::ViewFiles::NAMES), t("'auto'"), N, "read the cpfg model folder's view, function and surface files"),
    k("generator.random", LS, Kind::Mode(super::RandomSource::NAMES), t("'auto'"), N, "random generator: `cpfg`'s drand48 streams and call order, `sylva`'s portable one, `auto` (cpfg for L-system files, sylva for presets)"),
    k("generator.environment.program", LS, Kind::String, UNSET, N, "the environmental program answering `?E` (`honda81`, `clover`, `ecosystem`, `chiba`, `obcheck`)"),
    k("generator.environment.radius", LS, ANY, UNSET, M, "`honda81`'s collision radius, `chiba`'s default leaf radius"),
    k("generator.environment.transmittance", LS, ANY, UNSET, N, "the fraction of light a leaf lets through, in [0, 1]"),
    k("generator.environment.image", LS, Kind::Path, UNSET, N, "`clover`'s light image, relative to the model folder"),
    k("generator.environment.directions", LS, ANY, UNSET, N, "`chiba`'s number of sky directions (1–4096)"),
    k("generator.environment.obstacles", LS, Kind::Path, UNSET, N, "`obcheck`'s obstacle file, relative to the model folder"),
    k("generator.allow_paths", LS, list(&Kind::Path, 0, usize::MAX), t("[]"), N, "folders besides the model's own whose files the model may name"),
    // [generator] type = "import"
    k("generator.type", IM, Kind::Mode(GeneratorKind::NAMES), REQ, N, "the generator: `import` here"),
    k("generator.file", IM, Kind::Path, REQ, N, "the `.lst`, `.str` or `.json` skeleton file"),
    k("generator.gap", IM, Kind::Mode(&["bridge", "strict", "new-root"]), t("'bridge'"), N, "LST cylinders that do not start at the current node"),
    k("generator.angle", IM, ANY, t("45.0"), DEG, "turtle angle of `.str` files"),
    k("generator.step", IM, ANY, t("1.0"), M, "turtle step of `.str` files"),
    k("generator.width", IM, at_least(0.0), t("0.1"), M, "initial line width (a diameter) of `.str` files"),
    k("generator.max_nodes", IM, int(1, BIG), t("1000000"), N, "skeleton node budget of the readers"),
    // [generator] type = "weber-penn" (WeberPenn1995 Table 1)
    k("generator.type", WP, Kind::Mode(GeneratorKind::NAMES), REQ, N, "the generator: `weber-penn` here"),
    k("generator.shape", WP, int(0, 8), t("7"), N, "Shape: envelope of level-1 lengths along the trunk (0 conical … 8 pruning envelope)"),
    k("generator.base_size", WP, range(0.0, 1.0), t("0.4"), N, "BaseSize: fraction of the trunk without branches"),
    k("generator.scale", WP, above_to(0.0, 1e5), t("13.0"), M, "Scale: tree size").limits("at least `scale_v`"),
    k("generator.scale_v", WP, at_least(0.0), t("3.0"), M, "ScaleV: ± variation of `scale`").limits("at most `scale`"),
    k("generator.z_scale", WP, above_to(0.0, 1000.0), t("1.0"), N, "ZScale: vertical stretch of the finished tree"),
    k("generator.z_scale_v", WP, at_least(0.0), t("0.0"), N, "ZScaleV: variation of `z_scale`").limits("below `z_scale`"),
    k("generator.levels", WP, int(1, 4), t("3"), N, "Levels: stem levels (1 = a trunk only)"),
    k("generator.ratio", WP, range(0.0, 1000.0), t("0.015"), N, "Ratio: trunk radius / trunk length"),
    k("generator.ratio_power", WP, ANY, t("1.2"), N, "RatioPower: child radius = parent radius · (child / parent length)^RatioPower"),
    k("generator.lobes", WP, int(0, 1000), t("5"), N, "Lobes: lobes of the trunk's cross-section"),
    k("generator.lobe_depth", WP, at_least(0.0), t("0.07"), N, "LobeDepth: relative depth of the lobes"),
    k("generator.flare", WP, Kind::Float { min: Excluded(-1.0), max: Unbounded }, t("0.6"), N, "Flare: extra trunk radius at the base"),
    k("generator.base_splits", WP, int(0, 64), t("0"), N, "0BaseSplits: clones at the end of the trunk's first segment"),
    k("generator.n_scale", WP, wp4(&WP_THOUSAND), t("[1.0, 1.0, 1.0, 1.0]"), N, "nScale: level 0 is 0Scale, a factor on the trunk radius (others unused)").limits("`n_scale_v[0]` at most `n_scale[0]`"),
    k("generator.n_scale_v", WP, wp4(&WP_NONNEG), t("[0.2, 0.0, 0.0, 0.0]"), N, "nScaleV: variation of `n_scale` (level 0 only)").limits("`n_scale_v[0]` at most `n_scale[0]`"),
    k("generator.n_length", WP, wp4(&WP_THOUSAND), t("[1.0, 0.3, 0.6, 0.0]"), N, "nLength: trunk length / scale; largest child length / parent length"),
    k("generator.n_length_v", WP, wp4(&WP_NONNEG), t("[0.0, 0.0, 0.0, 0.0]"), N, "nLengthV: variation of `n_length`"),
    k("generator.n_taper", WP, wp4(&WP_TAPER), t("[1.0, 1.0, 1.0, 1.0]"), N, "nTaper: 0–1 conical, 1–2 spherical end, 2–3 periodic"),
    k("generator.n_curve_res", WP, wp4(&WP_RES), t("[3, 5, 3, 1]"), N, "nCurveRes: segments per stem").limits("levels above `levels` are unchecked; with `n_seg_splits` within the 2,000,000-stem budget"),
    k("generator.n_curve", WP, wp4(&WP_ANY), t("[0.0, -40.0, -40.0, 0.0]"), DEG, "nCurve: total curvature of a stem"),
    k("generator.n_curve_v", WP, wp4(&WP_CURVE_V), t("[20.0, 50.0, 75.0, 0.0]"), DEG, "nCurveV: random curvature; negative: a helix leaning −nCurveV from the axis"),
    k("generator.n_curve_back", WP, wp4(&WP_ANY), t("[0.0, 0.0, 0.0, 0.0]"), DEG, "nCurveBack: curvature of the second half of a stem"),
    k("generator.n_seg_splits", WP, wp4(&WP_SPLITS), t("[0.0, 0.0, 0.0, 0.0]"), N, "nSegSplits: clones per segment end (fractions accumulate)").limits("the clones of one stem within the 2,000,000-stem budget"),
    k("generator.n_split_angle", WP, wp4(&WP_ANY), t("[0.0, 0.0, 0.0, 0.0]"), DEG, "nSplitAngle: angle between a split's clones"),
    k("generator.n_split_angle_v", WP, wp4(&WP_ANY), t("[0.0, 0.0, 0.0, 0.0]"), DEG, "nSplitAngleV: variation of `n_split_angle`"),
    k("generator.n_branches", WP, list(&WP_BRANCHES, 4, 4), t("[1, 50, 30, 10]"), N, "nBranches: children of the trunk (level 1) or most children of a stem; level 0 unused").limits("the stems they make within the 2,000,000-stem budget"),
    k("generator.n_down_angle", WP, wp4(&WP_ANY), t("[0.0, 60.0, 45.0, 45.0]"), DEG, "nDownAngle: angle between a child and its parent"),
    k("generator.n_down_angle_v", WP, wp4(&WP_ANY), t("[0.0, -50.0, 10.0, 10.0]"), DEG, "nDownAngleV: variation of `n_down_angle`; negative: along the parent"),
    k("generator.n_rotate", WP, wp4(&WP_ANY), t("[0.0, 140.0, 140.0, 77.0]"), DEG, "nRotate: rotation about the parent between children; negative: alternating"),
    k("generator.n_rotate_v", WP, wp4(&WP_ANY), t("[0.0, 0.0, 0.0, 0.0]"), DEG, "nRotateV: variation of `n_rotate`"),
    k("generator.leaves", WP, int(-1_000_000, 1_000_000), t("25"), N, "Leaves: leaves per last-level stem; negative: a fan at each tip").limits("the leaves it makes within the 2,000,000-leaf budget"),
    k("generator.leaf_shape", WP, int(0, 8), t("0"), N, "LeafShape: 0 ellipse, 1 ovate, 2 linear, 3 cordate, 4 maple, 5 palmate, 6 spiky oak, 7 rounded oak, 8 triangle"),
    k("generator.leaf_scale", WP, range(0.0, 1000.0), t("0.17"), M, "LeafScale: leaf length"),
    k("generator.leaf_scale_x", WP, range(0.0, 1000.0), t("1.0"), N, "LeafScaleX: leaf width / leaf length"),
    k("generator.leaf_bend", WP, range(0.0, 1.0), t("0.3"), N, "LeafBend: how far leaves turn outward and up"),
    k("generator.leaf_quality", WP, above_to(0.0, 1.0), t("1.0"), N, "LeafQuality (Arbaro): fewer, larger leaves of the same area"),
    k("generator.attraction_up", WP, ANY, t("0.5"), N, "AttractionUp: bending of stems of level ≥ 2 toward the sky"),
    k("generator.prune_ratio", WP, range(0.0, 1.0), t("0.0"), N, "PruneRatio: how much of the pruning applies"),
    k("generator.prune_width", WP, at_least(0.0), t("0.5"), N, "PruneWidth: envelope radius / tree height at its widest"),
    k("generator.prune_width_peak", WP, range(0.0, 1.0), t("0.5"), N, "PruneWidthPeak: height of the widest point in the crown"),
    k("generator.prune_power_low", WP, at_least(0.0), t("0.5"), N, "PrunePowerLow: curvature of the envelope below its peak"),
    k("generator.prune_power_high", WP, at_least(0.0), t("0.5"), N, "PrunePowerHigh: curvature of the envelope above its peak"),
    // [generator] type = "space-colonization" (Runions2007)
    k("generator.type", SC, Kind::Mode(GeneratorKind::NAMES), REQ, N, "the generator: `space-colonization` here"),
    k("generator.envelope.shape", SC, Kind::Mode(&["sphere", "ellipsoid", "cone", "cylinder", "mesh"]), t("'ellipsoid'"), N, "the crown volume the attraction points fill"),
    k("generator.envelope.center_height", SC, SC_LEN, t("6.5"), M, "height of the centre above the ground")
        .when(&[When::Is { key: ENVELOPE, names: &["sphere", "ellipsoid"] }]),
    k("generator.envelope.radius", SC, SC_POS, t("4.0"), M, "radius (of the base disc for a cone)")
        .when(&[When::Is { key: ENVELOPE, names: &["sphere", "cone", "cylinder"] }]),
    k("generator.envelope.radii", SC, list(&SC_POS, 3, 3), t("[4.0, 3.5, 4.0]"), M, "semi-axes along x, y (up) and z")
        .when(&[When::Is { key: ENVELOPE, names: &["ellipsoid"] }]),
    k("generator.envelope.base_height", SC, SC_LEN, t("3.0"), M, "height of the bottom disc above the ground")
        .when(&[When::Is { key: ENVELOPE, names: &["cone", "cylinder"] }]),
    k("generator.envelope.height", SC, SC_POS, t("7.0"), M, "height from the bottom disc to the apex or top")
        .when(&[When::Is { key: ENVELOPE, names: &["cone", "cylinder"] }]),
    k("generator.envelope.file", SC, Kind::Path, REQ, N, "a closed OBJ mesh, metres, +Y up")
        .when(&[When::Is { key: ENVELOPE, names: &["mesh"] }]),
    k("generator.points", SC, int(0, 5_000_000), t("4000"), N, "attraction points"),
    k("generator.influence_radius", SC, SC_POS, t("1.5"), M, "a point attracts its closest node only within it").limits("above `kill_distance`"),
    k("generator.kill_distance", SC, SC_POS, t("0.4"), M, "a node this close removes a point").limits("at least `segment_length` / 2 and below `influence_radius`"),
    k("generator.segment_length", SC, SC_POS, t("0.2"), M, "length of every internode").limits("at most 2 × `kill_distance`"),
    k("generator.tropism", SC, list(&SC_ANY, 3, 3), t("[0.0, -1.0, 0.0]"), N, "tropism direction (normalized)"),
    k("generator.tropism_weight", SC, SC_NONNEG, t("0.0"), N, "weight of the tropism in each growth direction"),
    k("generator.perturbation", SC, SC_NONNEG, t("0.05"), N, "weight of a random unit vector in each growth direction"),
    k("generator.trunk_height", SC, SC_NONNEG, t("3.0"), M, "straight trunk grown before colonization").limits("its segments below `max_nodes`"),
    k("generator.max_iterations", SC, int(1, 1_000_000), t("1000"), N, "most growth iterations"),
    k("generator.max_nodes", SC, int(1, 50_000_000), t("2000000"), N, "node budget").limits("above the trunk's segments"),
    k("generator.pipe_exponent", SC, range(1.0, 4.0), t("2.5"), N, "pipe-model exponent of the radii"),
    k("generator.tip_radius", SC, SC_POS, t("0.008"), M, "radius of every tip"),
    k("generator.leaves.count", SC, int(0, 64), t("3"), N, "leaves per leafy node (0: none)"),
    k("generator.leaves.nodes", SC, int(0, U32), t("3"), N, "leafy nodes per tip, counted back from the tip"),
    k("generator.leaves.size", SC, SC_NONNEG, t("0.15"), M, "leaf length (the quad is half as wide)"),
    k("generator.leaves.size_variation", SC, from_below(0.0, 1.0), t("0.2"), N, "each leaf is `size × (1 ± size_variation)`"),
    k("generator.leaves.angle", SC, range(0.0, 180.0), t("50.0"), DEG, "angle between the branch and the midrib"),
    // [generator] type = "least-cost" (Xu2015)
    k("generator.type", LC, Kind::Mode(GeneratorKind::NAMES), REQ, N, "the generator: `least-cost` here"),
    k("generator.method", LC, Kind::Mode(&["mig", "mgv", "bcm"]), t("'mgv'"), N, "MIG (Ch. 4), MGV (Ch. 5) or BCM (§3.3.1)"),
    k("generator.dims", LC, int(2, 3), t("3"), N, "3, or 2 for a flat tree in the z = 0 plane (MGV only)").limits("3 with `method = \"mig\"`"),
    k("generator.nodes", LC, int(2, BIG), t("30000"), N, "graph nodes K").limits("at most `max_nodes`"),
    k("generator.spacing", LC, range(0.0, 1e6), t("0.0"), M, "Poisson spacing d; 0: from the volume and `nodes`"),
    k("generator.sectors", LC, int(3, 32), t("8"), N, "Yao sectors k").limits("8, 16, 24 or 32 in 3D"),
    k("generator.volume", LC, list(&Kind::Table, 1, usize::MAX), t("[{ shape = 'box', center = [0.0, 5.0, 0.0], size = [10.0, 10.0, 10.0] }]"), N, "the graph volume: a list of primitive tables (`docs/least-cost.md`)"),
    k("generator.root", LC, LC_POINT, UNSET, M, "the root (unset: the bottom centre of the volume)"),
    k("generator.roots", LC, list(&LC_POINT, 0, usize::MAX), t("[]"), M, "several competing roots on one graph (a forest)").limits("excludes `root` and `refine`; not with BCM"),
    k("generator.graph_cache", LC, Kind::Path, UNSET, N, "a graph file to reuse or write"),
    k("generator.max_nodes", LC, int(1, 50_000_000), t("5000000"), N, "node budget over all graphs").limits("at least `nodes`"),
    k("generator.endpoints", LC, int(0, BIG), t("12"), N, "MIG: level-1 endpoints b (BCM: first-round endpoints)").limits("1..=`nodes` with MIG, at least 1 with BCM"),
    k("generator.shell", LC, range(0.0, 1e6), t("0.0"), M, "MIG: endpoint shell thickness d_e; 0: 3·d").when(MIG_BCM),
    k("generator.sub_nodes", LC, int(2, 1_000_000), t("200"), N, "MIG: nodes k per subgraph").when(MIG),
    k("generator.sub_radius", LC, range(1e-6, 1e6), t("2.0"), M, "MIG: subgraph radius r at level 2").when(MIG),
    k("generator.shrink", LC, range(0.01, 1.0), t("0.7"), N, "MIG: subgraph radius ratio a per level").when(MIG),
    k("generator.sub_shell", LC, range(0.01, 1.0), t("0.5"), N, "MIG: subgraph endpoints lie beyond (1 − sub_shell)·r").when(MIG),
    k("generator.levels", LC, list(&Kind::Table, 0, 16), t("[]"), N, "MIG: the tables of levels 2, 3, … (`docs/least-cost.md`)").when(MIG),
    k("generator.refine.count", LC, int(1, 64), t("6"), N, "MIG refinement: sphere centres").when(MIG_REFINE),
    k("generator.refine.spacing", LC, range(0.0, 1e6), t("0.0"), M, "MIG refinement: Poisson spacing of the centres; 0: from the volume").when(MIG_REFINE),
    k("generator.refine.radius", LC, range(0.0, 1e6), t("0.0"), M, "MIG refinement: sphere radius; 0: 0.6 × the spacing").when(MIG_REFINE),
    k("generator.refine.quota", LC, int(0, BIG), t("0"), N, "MIG refinement: endpoints per subvolume; 0: spread `endpoints`").when(MIG_REFINE).limits("at most `nodes`"),
    k("generator.refine.cone", LC, range(0.01, 1.0), t("0.5"), N, "MIG refinement: cone radius at the centre / `radius`").when(MIG_REFINE),
    k("generator.refine.trunk", LC, int(0, BIG), UNSET, N, "MIG refinement: index in `volume` of the trunk primitive").when(MIG_REFINE).limits("a `cylinder` or `cone` of `volume`"),
    k("generator.refine.attach", LC, Kind::Mode(crate::grow::least_cost::refine::Attach::NAMES), t("'nearest'"), N, "MIG refinement: where a cone meets the trunk's axis").when(MIG_REFINE),
    k("generator.iterations", LC, list(&Kind::Table, 0, 32), t("[]"), N, "MGV: the iteration tables (`docs/least-cost.md`)").when(MGV),
    k("generator.axis", LC, Kind::Mode(crate::grow::least_cost::mgv::AxisRule::NAMES), t("'edge'"), N, "MGV: rotation axis").when(MGV),
    k("generator.epsilon", LC, range(0.0, 10.0), t("0.0"), N, "MGV: weight floor ε·d_E").when(MGV),
    k("generator.thickness", LC, Kind::Mode(crate::grow::least_cost::Thickness::NAMES), t("'power'"), N, "thickness rule: `w = c·s^ζ` or the pipe model"),
    k("generator.zeta", LC, range(0.0, 4.0), t("0.3"), N, "ζ of `w = c·s^ζ`"),
    k("generator.radius_scale", LC, range(0.0, 1e3), t("0.05"), N, "c of `w = c·s^ζ`"),
    k("generator.min_radius", LC, range(1e-6, 1e3), t("0.01"), M, "smallest radius (tips)"),
    k("generator.pipe_exponent", LC, range(1.0, 4.0), t("2.0"), N, "pipe-model exponent e of `r_p^e = Σ r_c^e`"),
    k("generator.smooth", LC, range(0.0, 1.0), t("0.0"), N, "smoothing strength (0: off)"),
    k("generator.smooth_iterations", LC, int(0, 100), t("3"), N, "smoothing passes"),
    k("generator.bcm.weights", LC, Kind::Mode(crate::grow::least_cost::bcm::Weights::NAMES), t("'random'"), N, "BCM: random or spatial lattice weights").when(BCM),
    k("generator.bcm.beta", LC, range(0.0, 10.0), t("1.0"), N, "BCM: β of `W = 1 + v^β`").when(BCM),
    k("generator.bcm.low", LC, range(0.0, 1e6), t("0.0"), N, "BCM: v is uniform in [low, low + range)").when(BCM),
    k("generator.bcm.range", LC, range(1e-6, 1e6), t("100.0"), N, "BCM: width of v's interval").when(BCM),
    k("generator.bcm.jitter", LC, range(0.0, 0.45), t("0.0"), N, "BCM: lattice jitter, a fraction of the spacing").when(BCM),
    k("generator.bcm.rounds", LC, int(1, 20), t("2"), N, "BCM: rounds in all").when(BCM),
    k("generator.bcm.cheapen", LC, range(1e-3, 1.0), t("0.3"), N, "BCM: factor on the tree's edge weights before a later round").when(BCM),
    k("generator.bcm.near", LC, int(1, 1000), t("3"), N, "BCM: later endpoints lie within this many lattice steps of the tree").when(BCM),
    k("generator.bcm.later_endpoints", LC, int(0, BIG), t("0"), N, "BCM: endpoints per later round; 0: 2 × `endpoints`").when(BCM),
    k("generator.bcm.min_root_distance", LC, range(0.0, 1e6), t("0.0"), M, "BCM: later endpoints lie farther than this from the root").when(BCM),
    k("generator.leaves.kind", LC, Kind::Mode(&["none", "leaf", "needles"]), t("'none'"), N, "organs at the tips"),
    k("generator.leaves.count", LC, int(1, 64), t("1"), N, "organs per tip"),
    k("generator.leaves.size", LC, range(1e-6, 1e3), t("0.15"), M, "organ length"),
    k("generator.leaves.size_variation", LC, range(0.0, 0.99), t("0.3"), N, "sizes uniform in `size·(1 ± size_variation)`"),
    k("generator.leaves.spread", LC, range(0.0, 180.0), t("60.0"), DEG, "needles: largest angle from up"),
    // [mesh]
    k("mesh.method", Mesh, Kind::Mode(super::MeshMethod::NAMES), t("'tube'"), N, "the mesher"),
    k("mesh.sides", Mesh, int(3, 1024), t("8"), N, "vertices per ring"),
    k("mesh.tips", Mesh, Kind::Mode(&["round", "flat", "open"]), t("'round'"), N, "branch ends"),
    k("mesh.base", Mesh, Kind::Mode(super::MeshBase::NAMES), t("'flat'"), N, "the trunk's base: cut flat at the root or each mesher's own end"),
    k("mesh.decollide", Mesh, Kind::Bool, UNSET, N, "pull apart branches that pass through each other (unset: on for the joint meshers up to 50,000 nodes)"),
    k("mesh.clear", Mesh, Kind::Bool, UNSET, N, "thin the skeleton where the meshed surface crosses itself (unset: with `decollide`)"),
    k("mesh.prune_overlaps", Mesh, Kind::Bool, UNSET, N, "cut off every branch passing through another (unset: off)"),
    k("mesh.max_memory", Mesh, int(1, super::REFINE_MAX_MEMORY_LIMIT as i64), t("4294967296"), B, "memory budget of the mesh stage"),
    k("mesh.tube.bases", MeshTube, Kind::Mode(&["flat", "open"]), t("'flat'"), N, "how each axis starts"),
    k("mesh.hull.margin", MeshHull, range(0.0, 10.0), t("0.05"), N, "trim margin m of the joints"),
    k("mesh.hull.aligned_epsilon", MeshHull, from_below(0.0, 1.0), t("1e-6"), N, "axes with cos α > 1 − ε are aligned"),
    k("mesh.hull.segment_factor", MeshHull, Kind::Float { min: Excluded(0.0), max: Unbounded }, t("1.0"), N, "branch segment length over half the mean circumference"),
    k("mesh.hull.max_segments", MeshHull, int(1, 65536), t("32"), N, "most segments per branch"),
    k("mesh.hull.max_straightening", MeshHull, at_least(0.0), t("1.0"), N, "largest straightening (in radii) a collapsed short branch may cause (`inf`: no limit)"),
    k("mesh.sweep.tip_size", MeshSweep, range(0.0, 100.0), t("1.0"), N, "tip cone height over the tip width"),
    k("mesh.sweep.max_children", MeshSweep, int(2, 64), t("4"), N, "most children the coplanar template takes"),
    k("mesh.sweep.coplanar_deg", MeshSweep, from_below(0.0, 90.0), t("20.0"), DEG, "largest angle of a branch from the fitted branching plane"),
    k("mesh.sweep.general_junctions", MeshSweep, Kind::Bool, t("true"), N, "mesh other junctions with the general (projected hull) junction"),
    k("mesh.sweep.collar_ratio", MeshSweep, range(0.0, 3.0), t("1.75"), N, "radius of the asymmetric template's extra ring over the thin child's").limits("0 or 1..=3"),
    k("mesh.sweep.aligned_deg", MeshSweep, from_below(0.0, 90.0), t("3.0"), DEG, "axes closer than this are aligned"),
    k("mesh.sweep.asymmetric_ratio", MeshSweep, range(0.0, 1.0), t("0.3333333333333333"), N, "a child this thin against its partner makes the junction asymmetric"),
    k("mesh.sweep.repair_rounds", MeshSweep, int(0, U32), t("4"), N, "rounds of check and fall back where faces intersect"),
    k("mesh.sweep.u_mapping", MeshSweep, Kind::Mode(&["reflected", "wrapped"]), t("'reflected'"), N, "u around a ring"),
    k("mesh.sweep.v_mapping", MeshSweep, Kind::Mode(&["texel", "path"]), t("'texel'"), N, "v along the branches"),
    k("mesh.sweep.tile_v", MeshSweep, Kind::Bool, t("false"), N, "v runs 0 → 1 along every internode"),
    k("mesh.sweep.check_levels", MeshSweep, int(0, 3), t("2"), N, "Loop levels at which the repair checks the junctions"),
    k("mesh.sweep.min_radius", MeshSweep, range(1e-6, 1.0), t("0.005"), N, "smallest ring radius over the largest radius"),
    k("mesh.sweep.bend_rings", MeshSweep, Kind::Bool, t("true"), N, "extra rings near sharp bends"),
    k("mesh.leaf.midrib_depth", MeshLeaf, range(-1.0, 1.0), t("0.1"), N, "midrib offset along the turtle's up over the section width"),
    k("mesh.leaf.tip_size", MeshLeaf, above_to(0.0, 100.0), t("1.0"), N, "tip height over the tip width"),
    k("mesh.leaf.midrib_sharpness", MeshLeaf, range(0.0, 255.0), t("255.0"), N, "midrib crease sharpness"),
    k("mesh.leaf.tip_sharpness", MeshLeaf, range(0.0, 255.0), t("0.0"), N, "tip vertex sharpness"),
    k("mesh.leaf.mapping", MeshLeaf, Kind::Mode(&["cutout", "tiled"]), t("'cutout'"), N, "texture mapping"),
    k("mesh.leaf.min_width", MeshLeaf, range(1e-6, 1.0), t("0.01"), N, "smallest half-width over the largest radius"),
    k("mesh.quad.cs_scale", MeshQuad, above_to(0.0, 100.0), t("1.0"), N, "section corner distance over the node radius"),
    k("mesh.quad.box_length", MeshQuad, Kind::Mode(&["sum-squares", "first-child"]), t("'sum-squares'"), N, "junction box length rule"),
    k("mesh.quad.pull_back", MeshQuad, Kind::Bool, t("true"), N, "centre a case (d) box on its node"),
    k("mesh.quad.max_side_angle", MeshQuad, range(10.0, 89.0), t("80.0"), DEG, "largest angle of a child from its side face's normal"),
    k("mesh.quad.max_back_angle", MeshQuad, range(90.0, 150.0), t("120.0"), DEG, "the same limit for a child pointing back"),
    k("mesh.quad.max_chain", MeshQuad, int(0, 16), t("3"), N, "most chained boxes below one branching node"),
    k("mesh.quad.min_radius", MeshQuad, range(1e-6, 1.0), t("0.005"), N, "smallest corner distance over the largest radius"),
    k("mesh.quad.min_length", MeshQuad, range(1e-4, 10.0), t("0.1"), N, "shortest tube between two sections over the corner distance"),
    k("mesh.quad.elbow_angle", MeshQuad, range(0.0, 90.0), t("0.0"), DEG, "side children leaving more than this start with an elbow ring"),
    k("mesh.quad.support", MeshQuad, range(0.0, 10.0), t("1.0"), N, "support rings this many corner distances before each tube's end"),
    k("mesh.quad.repair_rounds", MeshQuad, int(0, 16), t("4"), N, "rounds of refine, search and separate"),
    k("mesh.quad.check_levels", MeshQuad, int(1, 3), t("2"), N, "Catmull–Clark levels the repair searches at"),
    k("mesh.quad.max_repair_work", MeshQuad, int(1, 100_000_000_000_000), t("2000000000"), N, "work budget of the repair"),
    // [fit.decollide]
    k("fit.decollide.clearance", FitDecollide, range(0.0, 1.0), t("0.08"), N, "capsules are pulled apart to (r_a + r_b)(1 + clearance)"),
    k("fit.decollide.near_joint_hops", FitDecollide, int(0, 64), t("3"), N, "internodes this close collide near a joint"),
    k("fit.decollide.near_joint_path", FitDecollide, range(0.0, 1000.0), t("4.0"), N, "branches joined through less than this many radius sums collide near a joint"),
    k("fit.decollide.min_thinning", FitDecollide, above_to(0.0, 1.0), t("0.3"), N, "a near-joint pair is thinned when the factor is at least this"),
    k("fit.decollide.far_thinning", FitDecollide, above_to(0.0, 1.0), t("0.8"), N, "a distant pair is thinned when this factor clears it"),
    k("fit.decollide.taper", FitDecollide, range(0.0, 100.0), t("0.1"), N, "radius slope allowed above a thinned node"),
    k("fit.decollide.angles", FitDecollide, list(&above_to(0.0, 180.0), 0, 64), t("[3.0, 6.0, 10.0, 15.0, 22.0, 30.0, 45.0, 60.0, 90.0]"), DEG, "rotation angles tried, smallest first"),
    k("fit.decollide.candidates", FitDecollide, int(0, 64), t("5"), N, "candidate subtrees tried per side of a pair"),
    k("fit.decollide.max_rounds", FitDecollide, int(0, 100), t("8"), N, "rounds of thinning and moving"),
    k("fit.decollide.max_moved", FitDecollide, int(0, BIG), t("4000"), N, "subtrees of more nodes are never rotated"),
    k("fit.decollide.work_per_node", FitDecollide, int(0, 100_000), t("200"), N, "capsule queries per node per round of rotation trials"),
    k("fit.decollide.min_radius", FitDecollide, range(0.0, 1.0), t("0.005"), N, "radius floor over the largest radius"),
    k("fit.decollide.max_work", FitDecollide, int(1, 100_000_000_000), t("50000000"), N, "work budget of the pass"),
    // [fit.clear]
    k("fit.clear.step", FitClear, Kind::Float { min: Excluded(0.0), max: Excluded(1.0) }, t("0.8"), N, "radius factor per round at a crossing"),
    k("fit.clear.min_factor", FitClear, above_to(0.0, 1.0), t("0.3"), N, "no radius goes below this fraction of its start"),
    k("fit.clear.taper", FitClear, range(0.0, 100.0), t("0.1"), N, "radius slope allowed above a thinned node"),
    k("fit.clear.max_rounds", FitClear, int(0, 100), t("8"), N, "rounds of mesh, refine, search and thin"),
    k("fit.clear.patience", FitClear, int(0, 100), t("2"), N, "stop after this many rounds without fewer crossings"),
    k("fit.clear.max_faces", FitClear, int(0, 64_000_000), t("4000000"), N, "refined meshes with more faces are not searched"),
    k("fit.clear.max_pairs", FitClear, int(1, 10_000_000), t("100000"), N, "most crossing pairs searched for per round"),
    k("fit.clear.min_radius", FitClear, range(0.0, 1.0), t("0.005"), N, "radius floor over the largest radius"),
    k("fit.clear.max_work", FitClear, int(1, 100_000_000_000), t("12000000"), N, "work budget of the pass"),
    // [refine]
    k("refine.scheme", Refine, Kind::Mode(super::RefineScheme::NAMES), t("'auto'"), N, "subdivision scheme of the bark control mesh"),
    k("refine.levels", Refine, int(0, 6), t("0"), N, "subdivision levels"),
    k("refine.limit", Refine, Kind::Bool, t("false"), N, "push the result to the limit surface"),
    k("refine.boundary", Refine, Kind::Mode(super::RefineBoundary::NAMES), t("'auto'"), N, "where open rims' vertices go"),
    k("refine.max_faces", Refine, int(1, super::REFINE_MAX_FACES_LIMIT as i64), t("20000000"), N, "face budget of the subdivision"),
    k("refine.max_memory", Refine, int(1, super::REFINE_MAX_MEMORY_LIMIT as i64), t("4294967296"), B, "memory budget of the subdivision"),
    // [textures]
    k("textures.bark_size", Textures, int(16, 4096), t("1024"), PX, "edge of the square bark maps"),
    k("textures.atlas_size", Textures, int(16, 4096), t("1024"), PX, "edge of the square leaf atlas"),
    k("textures.bark", Textures, Kind::Mode(&["auto", "smooth", "furrowed", "plated", "birch"]), t("'auto'"), N, "bark style (`auto`: the preset's)"),
    k("textures.scale", Textures, range(0.01, 100.0), t("1.0"), N, "bark texture repeats per unit of bark UV"),
    // [leaves]
    k("leaves.mode", Leaves, Kind::Mode(super::LeafMode::NAMES), t("'cards'"), N, "how leaf organs are written"),
    k("leaves.shape", Leaves, Kind::Mode(&["auto", "ovate", "lanceolate", "lobed", "compound", "needles", "cluster"]), t("'auto'"), N, "the leaf the cards show"),
    k("leaves.alpha_cutoff", Leaves, Kind::Float { min: Excluded(0.0), max: Excluded(1.0) }, t("0.5"), N, "glTF `alphaCutoff` of the cards"),
    k("leaves.per_card", Leaves, int(0, 64), t("0"), N, "leaves per card (0: auto)"),
    k("leaves.normals", Leaves, Kind::Mode(super::LeafNormals::NAMES), t("'flat'"), N, "leaf normals"),
    k("leaves.place", Leaves, Kind::Mode(&["none", "level", "terminal"]), UNSET, N, "add leaves to the skeleton (unset: the generator's only)"),
    k("leaves.start_level", Leaves, int(0, u16::MAX as i64), UNSET, N, "lowest branch order that gets leaves with `place = \"level\"`"),
    k("leaves.per_node", Leaves, int(1, 64), UNSET, N, "leaves per internode or configuration (unset: 2 or 5)"),
    k("leaves.size", Leaves, at_least(0.0), UNSET, M, "leaf length (unset: 0.8 × the mean leafy internode)"),
    // [wind]
    k("wind.preset", Wind, Kind::Mode(super::WindPreset::NAMES), t("'none'"), N, "the wind the rig and clip are made for"),
    k("wind.strength", Wind, range(0.0, 100.0), t("1.0"), N, "multiplier of the preset's mean wind"),
    k("wind.direction", Wind, ANY, t("0.0"), DEG, "direction the wind blows toward, about +y"),
    k("wind.gustiness", Wind, range(0.0, 100.0), t("1.0"), N, "multiplier of the gust waves' amplitudes"),
    k("wind.turbulence", Wind, range(0.0, 100.0), t("1.0"), N, "multiplier of the two short waves' amplitudes"),
    k("wind.stiffness", Wind, list(&range(0.0, 100.0), 0, 64), t("[]"), N, "bending factor per branch order (empty: the preset's)"),
    k("wind.leaf_flutter", Wind, range(0.0, 1.0), t("0.5"), N, "leaf component of the `_WIND` channel"),
    k("wind.legacy_lag", Wind, Kind::Bool, t("false"), N, "each level reads its parent's pose of the step before"),
    k("wind.max_joints", Wind, int(1, 1024), t("64"), N, "most joints in the rig"),
    k("wind.clip_seconds", Wind, range(0.5, 60.0), t("4.0"), Some(Unit::Seconds), "length of the looping clip"),
    k("wind.fps", Wind, int(1, 120), t("30"), Some(Unit::PerSecond), "clip samples per second"),
    // [lod]
    k("lod.levels", Lod, list(&int(12, 10_000_000), 0, 8), t("[]"), N, "triangle budget of each level, LOD0 first").limits("decreasing"),
    k("lod.impostor", Lod, Kind::Bool, t("false"), N, "a last level of crossed billboards from an impostor atlas"),
    k("lod.atlas_frames", Lod, int(2, 16), t("8"), N, "views per side of the impostor atlas"),
    k("lod.atlas_size", Lod, int(64, 4096), t("1024"), PX, "edge of the impostor atlas"),
    // [output]
    k("output.file", Output, Kind::Path, t("'tree.glb'"), N, "the model file; its extension picks the format"),
    k("output.preview", Output, Kind::Path, UNSET, N, "a preview PNG"),
    k("output.preview_size", Output, int(1, 8192), t("1024"), PX, "preview width and height"),
    k("output.textures", Output, Kind::Mode(&["embed", "files", "none"]), t("'embed'"), N, "where textures go"),
    k("output.instancing_fallback", Output, Kind::Mode(&["none", "merged"]), t("'none'"), N, "what readers without GPU instancing get"),
    k("output.lod_layout", Output, Kind::Mode(&["msft", "scene"]), t("'msft'"), N, "how levels of detail are written to glTF"),
    k("output.wind_colors", Output, Kind::Bool, t("false"), N, "also pack the wind channels into `COLOR_0` / `TEXCOORD_1`"),
    k("output.compress", Output, Kind::Mode(&["none", "quantize", "meshopt"]), t("'none'"), N, "glTF compression"),
];
