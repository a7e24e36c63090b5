//! Typed constructors of [`Recipe`] and [`Loaded`] (issue 40): a preset, TOML text, a
//! file, the default, typed `with_*` builders and [`Recipe::set`] for any dotted key.
//! Every one ends in [`Recipe::check`] (most through [`from_table`], the path of the CLI's
//! `--set`), so a recipe built through them is valid; a hand-built one is checked again
//! when a session runs it.
//!
//! A [`Recipe`] alone does not know where its files are: [`Loaded`] pairs it with an
//! [`Origin`], the embedded presets, a folder on disk or files held in memory
//! ([`Loaded::from_lsystem_source`]).

use super::{
    from_table, load, read::toml_error, Generator, LeafMode, Loaded, MeshMethod, Origin, Recipe,
    RefineScheme, WindPreset,
};
use crate::error::{Error, Result};
use crate::export::TextureMode;
use std::collections::BTreeMap;
use std::path::Path;

/// The file name an L-system given as text has in its [`Origin::Memory`]
/// ([`Loaded::from_lsystem_source`]).
pub const MEMORY_LSYSTEM: &str = "model.l";

impl Default for Recipe {
    /// The default preset's recipe ([`crate::presets::DEFAULT_PRESET`], the L-system tree
    /// `sylva grow` makes without arguments).
    fn default() -> Self {
        Recipe::preset(crate::presets::DEFAULT_PRESET).expect("the default preset is a valid recipe")
    }
}

impl Recipe {
    /// The recipe of the embedded preset `name` (`sylva presets`). Its files are inside the
    /// presets: grow it through [`Loaded::preset`] or `Loaded::new(recipe,
    /// Origin::Preset(name))`.
    pub fn preset(name: &str) -> Result<Recipe> {
        Ok(Loaded::preset(name)?.recipe)
    }

    /// A recipe from the text of a TOML recipe (`preset = "name"` starts it from that
    /// preset, [`super::over_preset`]). Errors name the key (or the line and column of a
    /// syntax error).
    pub fn from_toml(text: &str) -> Result<Recipe> {
        let table: toml::Table = toml::from_str(text).map_err(|e| Error::Recipe(toml_error(text, &e)))?;
        from_table(super::over_preset(table)?.0, &[])
    }

    /// The recipe of a file: a `.toml` recipe, or a model file (`.l`, `.lst`, `.str`,
    /// `.json`) with the default recipe around it, as `sylva grow FILE` reads it. Returns
    /// a [`Loaded`] rather than a bare recipe because the file names in it resolve
    /// relative to the file's folder ([`Origin::Folder`]).
    pub fn from_file(path: impl AsRef<Path>) -> Result<Loaded> {
        Loaded::from_file(path)
    }

    /// The recipe as a TOML table, every key written except those left out at their
    /// defaults (the form a file's metadata holds).
    pub fn to_table(&self) -> Result<toml::Table> {
        match toml::Value::try_from(self) {
            Ok(toml::Value::Table(t)) => Ok(t),
            Ok(_) => Err(Error::Recipe("a recipe is not a TOML table".into())),
            Err(e) => Err(Error::Recipe(e.to_string())),
        }
    }

    /// The recipe as TOML text; [`Recipe::from_toml`] reads it back to the same recipe.
    pub fn to_toml(&self) -> Result<String> {
        toml::to_string(&self.to_table()?).map_err(|e| Error::Recipe(e.to_string()))
    }

    /// Sets the dotted `key` to `value` as `--set key=value` does: the recipe is written
    /// as TOML, the key set, and the whole read back and checked, so an unknown key or a
    /// bad value is an error naming it and leaves the recipe unchanged.
    ///
    /// ```
    /// let mut recipe = sylva::recipe::Recipe::preset("lsys-honda-a")?;
    /// recipe.set("mesh.sides", 6)?;
    /// recipe.set("leaves.mode", "geometry")?;
    /// assert_eq!(recipe.leaves.mode, sylva::recipe::LeafMode::Geometry);
    /// assert!(recipe.set("leaves.mode", "sprites").is_err());
    /// # Ok::<(), sylva::Error>(())
    /// ```
    pub fn set(&mut self, key: &str, value: impl Into<toml::Value>) -> Result<()> {
        let key = key.trim();
        let mut next = from_table(self.to_table()?, &[(key.to_string(), value.into())])?;
        // `from_table` marks every generator key of its table as given; the round trip
        // wrote them all, so keep this recipe's own list and add the key set.
        if let (Generator::Lsystem(new), Generator::Lsystem(old)) = (&mut next.generator, &self.generator) {
            let mut explicit = old.explicit.clone();
            if let Some(k) = key.strip_prefix("generator.").and_then(|k| k.split('.').next()) {
                if !explicit.iter().any(|e| e == k.trim()) {
                    explicit.push(k.trim().to_string());
                }
            }
            new.explicit = explicit;
        }
        *self = next;
        Ok(())
    }

    /// [`Recipe::set`] from `key=value` text, the CLI's `--set` ([`super::parse_set`]).
    pub fn set_text(&mut self, key_value: &str) -> Result<()> {
        let (k, v) = super::parse_set(key_value)?;
        self.set(&k, v)
    }

    /// This recipe after `change`, checked ([`Recipe::check`]).
    fn checked(mut self, change: impl FnOnce(&mut Recipe)) -> Result<Recipe> {
        change(&mut self);
        self.check()?;
        Ok(self)
    }

    /// The recipe with `seed` (every random choice).
    pub fn with_seed(mut self, seed: u64) -> Recipe {
        self.seed = seed;
        self
    }

    /// The recipe with the mesher `method` (`mesh.method`); its `[mesh.<method>]` table
    /// keeps its options.
    pub fn with_mesher(mut self, method: MeshMethod) -> Recipe {
        self.mesh.method = method;
        self
    }

    /// The recipe with textures written as `mode` says (`output.textures`; the prefix of
    /// [`TextureMode::Files`] is ignored: files are named after the model).
    pub fn with_textures(mut self, mode: TextureMode) -> Recipe {
        self.output.textures = match mode {
            TextureMode::Files { .. } => TextureMode::Files { prefix: String::new() },
            m => m,
        };
        self
    }

    /// The recipe with leaves written as `mode` says (`leaves.mode`).
    pub fn with_leaf_mode(mut self, mode: LeafMode) -> Recipe {
        self.leaves.mode = mode;
        self
    }

    /// The recipe with the wind `preset` (`wind.preset`).
    pub fn with_wind(mut self, preset: WindPreset) -> Recipe {
        self.wind.preset = preset;
        self
    }

    /// The recipe subdivided by `scheme` (`refine.scheme`).
    pub fn with_refine_scheme(mut self, scheme: RefineScheme) -> Recipe {
        self.refine.scheme = scheme;
        self
    }

    /// The recipe with `levels` subdivision levels (`refine.levels`, at most 6).
    pub fn with_refine_levels(self, levels: u32) -> Result<Recipe> {
        self.checked(|r| r.refine.levels = levels)
    }

    /// The recipe with `sides` vertices per ring (`mesh.sides`, 3..=1024).
    pub fn with_sides(self, sides: u32) -> Result<Recipe> {
        self.checked(|r| r.mesh.sides = sides)
    }

    /// The recipe with `n` derivation steps (`generator.iterations`, the CLI's `-n`).
    /// Only L-systems have iterations: for another generator the error says so, naming
    /// the generator.
    pub fn with_iterations(self, n: u32) -> Result<Recipe> {
        if !matches!(self.generator, Generator::Lsystem(_)) {
            return Err(Error::Recipe(format!(
                "the `{}` generator has no iterations: `generator.iterations` (`-n`) is a key of L-system recipes",
                self.generator.kind()
            )));
        }
        self.checked(|r| {
            if let Generator::Lsystem(g) = &mut r.generator {
                g.iterations = Some(n);
                if !g.explicit.iter().any(|k| k == "iterations") {
                    g.explicit.push("iterations".into());
                }
            }
        })
    }
}

impl Generator {
    /// The generator's `generator.type` name (`lsystem`, `import`, `weber-penn`,
    /// `space-colonization`, `least-cost`).
    pub fn kind(&self) -> &'static str {
        match self {
            Generator::Lsystem(_) => "lsystem",
            Generator::Import(_) => "import",
            Generator::WeberPenn(_) => "weber-penn",
            Generator::SpaceColonization(_) => "space-colonization",
            Generator::LeastCost(_) => "least-cost",
        }
    }
}

impl Loaded {
    /// `recipe` with its files at `origin`, checked ([`Recipe::check`]).
    pub fn new(recipe: Recipe, origin: Origin) -> Result<Loaded> {
        recipe.check()?;
        Ok(Loaded { recipe, origin, overlay: BTreeMap::new() })
    }

    /// The embedded preset `name`.
    pub fn preset(name: &str) -> Result<Loaded> {
        if crate::presets::get(name).is_none() {
            return Err(Error::Recipe(format!("unknown preset `{}`", crate::diagnostic::quote(name))));
        }
        load(name, &[])
    }

    /// A recipe file (`.toml`) or a model file (`.l`, `.lst`, `.str`, `.json`) with the
    /// default recipe, its files resolving in the file's folder.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Loaded> {
        let path = path.as_ref();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if !["toml", "l", "lst", "str", "json"].contains(&ext.as_str()) {
            return Err(Error::Recipe(format!(
                "cannot tell what `{}` is: give a .toml recipe or a .l, .lst, .str or .json model",
                path.display()
            )));
        }
        load(&path.to_string_lossy(), &[])
    }

    /// An L-system given as text (cpfg syntax, as a `.l` file holds), with the default
    /// recipe around it: the file is [`MEMORY_LSYSTEM`] in an [`Origin::Memory`], so
    /// nothing is read from disk (an `#include` must be added with
    /// [`Loaded::with_files`]).
    ///
    /// ```
    /// let loaded = sylva::recipe::Loaded::from_lsystem_source(
    ///     "Lsystem: 1\nderivation length: 3\nAxiom: F\nF --> F[+F]F[-F]F\nendlsystem\n",
    /// )?;
    /// let tree = sylva::pipeline::grow(&loaded)?;
    /// assert!(tree.model.triangle_count() > 0);
    /// # Ok::<(), sylva::Error>(())
    /// ```
    pub fn from_lsystem_source(text: &str) -> Result<Loaded> {
        let mut table = toml::Table::new();
        table.insert("name".into(), toml::Value::String("model".into()));
        super::set_key(&mut table, "generator.type", toml::Value::String("lsystem".into()))?;
        super::set_key(&mut table, "generator.file", toml::Value::String(MEMORY_LSYSTEM.into()))?;
        let recipe = from_table(table, &[])?;
        let files = BTreeMap::from([(MEMORY_LSYSTEM.to_string(), text.to_string())]);
        Ok(Loaded { recipe, origin: Origin::Memory(files), overlay: BTreeMap::new() })
    }

    /// `recipe` with the files it names given in memory (name → text), checked.
    pub fn with_files(recipe: Recipe, files: impl IntoIterator<Item = (String, String)>) -> Result<Loaded> {
        Loaded::new(recipe, Origin::Memory(files.into_iter().collect()))
    }
}
