//! Reading recipes: where a recipe's files come from ([`Origin`], [`Loaded`]), the
//! CLI's `--set` ([`parse_set`], [`set_key`]), a TOML table to a checked [`Recipe`] with
//! every unknown key and bad value named by its full path ([`from_table`]), and
//! [`load`], which tells a preset name from a recipe or model file.

use super::*;

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
    /// Files whose text is given here instead of read from the origin, by the name the
    /// recipe gives them (an editor's unsaved grammar, [`Loaded::with_overlay`]); empty
    /// for every recipe read from a file or a preset.
    pub overlay: BTreeMap<String, String>,
}

impl Loaded {
    /// Reads a file the recipe names, from the [`Loaded::overlay`], the embedded
    /// presets, disk or memory. Returns the display name used in messages and the text.
    pub fn read(&self, file: &str) -> Result<(String, String)> {
        if let Some(text) = self.overlay.get(file) {
            return Ok((self.display_name(file), text.clone()));
        }
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

    /// `self` with `text` read in place of the file `file` ([`Loaded::read`]), whatever
    /// the origin holds: the editor grows an edited grammar before it is saved. Only
    /// `read` sees the overlay: the file's `#include`s, and on disk its model folder's
    /// view, function and surface files, still come from the origin, and messages name
    /// the file as they would the original.
    pub fn with_overlay(mut self, file: &str, text: &str) -> Loaded {
        self.overlay.insert(file.to_string(), text.to_string());
        self
    }

    /// The name messages give the file `file` of this origin (what [`Loaded::read`]
    /// returns with the text).
    fn display_name(&self, file: &str) -> String {
        match &self.origin {
            Origin::Preset(_) => format!("presets/{file}"),
            Origin::Folder(dir) => dir.join(file).display().to_string(),
            Origin::Memory(_) => file.to_string(),
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
    "generator.random",
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
    "leaves.place",
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
pub(super) fn toml_error(text: &str, e: &toml::de::Error) -> String {
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

/// The key of a recipe file that starts it from an embedded preset.
pub const PRESET_KEY: &str = "preset";

/// A recipe file's table with its `preset = "name"` resolved: the preset's recipe with
/// the file's keys laid over it, table by table (a file's `generator` table of another
/// `type` replaces the preset's whole), and the preset's name, whose embedded files the
/// recipe's file names then resolve in. A table without the key is returned as it is.
///
/// Errors: `preset` that is not a string or names no tree preset.
pub fn over_preset(mut table: toml::Table) -> Result<(toml::Table, Option<String>)> {
    let Some(value) = table.remove(PRESET_KEY) else { return Ok((table, None)) };
    let name = value.as_str().ok_or_else(|| {
        Error::Recipe(format!("`{PRESET_KEY}` must be a preset's name (text), not {}", value.type_str()))
    })?;
    let preset = crate::presets::get(name).filter(|p| !p.is_curves()).ok_or_else(|| {
        Error::Recipe(format!(
            "`{PRESET_KEY}`: no tree preset is called `{}` (`sylva presets` lists them)",
            crate::diagnostic::quote(name)
        ))
    })?;
    let mut base: toml::Table =
        toml::from_str(preset.recipe).map_err(|e| Error::Recipe(format!("preset `{name}`: {e}")))?;
    let other_generator = |base: &toml::Table| {
        let kind = |t: &toml::Table| {
            t.get("generator").and_then(|g| g.get("type")).and_then(|v| v.as_str()).map(str::to_string)
        };
        kind(&table).is_some_and(|k| Some(k) != kind(base))
    };
    if other_generator(&base) {
        base.remove("generator");
    }
    lay_over(&mut base, table);
    Ok((base, Some(name.to_string())))
}

/// `top`'s keys laid over `base`: tables merge key by key, any other value replaces.
fn lay_over(base: &mut toml::Table, top: toml::Table) {
    for (k, v) in top {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => lay_over(b, t),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// Loads the recipe for `what`: an embedded preset name, a `.toml` recipe file (which
/// may start from a preset with `preset = "name"`, [`over_preset`]), or a bare model
/// file (`.l`) that gets the default recipe. `sets` are `--set` overrides.
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
        let in_file = |e| match e {
            Error::Recipe(m) => Error::Recipe(format!("{}: {m}", path.display())),
            e => e,
        };
        let (table, origin) = match over_preset(table).map_err(in_file)? {
            (table, Some(name)) => (table, Origin::Preset(name)),
            (table, None) => (table, Origin::Folder(dir)),
        };
        let recipe = from_table(table, sets).map_err(in_file)?;
        return Ok(Loaded { recipe, origin, overlay: BTreeMap::new() });
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
        return Ok(Loaded {
            recipe: from_table(table, sets)?,
            origin: Origin::Folder(dir),
            overlay: BTreeMap::new(),
        });
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
        return Ok(Loaded {
            recipe: from_table(table, sets)?,
            origin: Origin::Folder(dir),
            overlay: BTreeMap::new(),
        });
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
        return Ok(Loaded {
            recipe: from_table(table, sets)?,
            origin: Origin::Preset(what.to_string()),
            overlay: BTreeMap::new(),
        });
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
