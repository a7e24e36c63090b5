//! The document being edited: a [`Loaded`] recipe (the recipe and where its files are),
//! the preset or file it started from, undo/redo, and the keys that differ from the
//! start (what "save" writes). No UI and no GPU: the panel and the tests drive it.
//!
//! Every change goes through [`Recipe::set`], the path of the CLI's `--set`, so a value
//! out of range is an error naming the key and leaves the recipe as it was. A run of
//! changes to one key (a slider being dragged) is one undo step.
//!
//! An L-system recipe's grammar file (`generator.file`) is held as text too
//! ([`Grammar`]): an edit is laid over the file ([`Loaded::with_overlay`]) once the
//! typing pauses, so the worker grows the edited text while `#include`s and the model
//! folder's other files still come from where the recipe is. Grammar edits are not
//! recipe undo steps (the text editor has its own undo).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use sylva::recipe::{Generator, Loaded, Origin, Recipe};

/// Where the document started: what "reset" returns to and what "save" compares with.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// An embedded preset, by name.
    Preset(String),
    /// A recipe or model file on disk.
    File(PathBuf),
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Preset(name) => f.write_str(name),
            Source::File(path) => write!(f, "{}", path.display()),
        }
    }
}

/// One undo step: the recipe before a change and the key the change set.
#[derive(Debug, Clone)]
struct Step {
    before: Recipe,
    key: Option<String>,
}

/// The text of an L-system recipe's grammar file, as the editor holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct Grammar {
    /// The file name the recipe gives (`generator.file`).
    pub file: String,
    /// The name the engine's messages give the file (a path on disk, `presets/…`).
    pub name: String,
    /// The text as read or last saved (Revert returns to it; slider ranges come from it).
    pub original: String,
    /// The text being edited (the grammar editor's buffer).
    pub text: String,
    /// The text laid over the file, which the worker grows.
    applied: String,
    /// When the buffer was last typed into while it differs from `applied`.
    typed_at: Option<Instant>,
}

impl Grammar {
    /// Whether the buffer differs from what was read or last saved.
    pub fn modified(&self) -> bool {
        self.text != self.original
    }

    /// Whether the buffer holds typing not yet given to the worker.
    pub fn pending(&self) -> bool {
        self.text != self.applied
    }
}

/// How long the grammar editor waits after the last keystroke before it regrows.
pub const GRAMMAR_DEBOUNCE: Duration = Duration::from_millis(250);

/// The recipe being edited and its history.
#[derive(Debug, Clone)]
pub struct Document {
    source: Source,
    start: Loaded,
    loaded: Loaded,
    table: toml::Table,
    undo: Vec<Step>,
    redo: Vec<Recipe>,
    /// Whether the next change to the same key joins the last undo step (a drag).
    joining: bool,
    revision: u64,
    /// The L-system grammar, when the generator is an L-system whose file could be read.
    grammar: Option<Grammar>,
    /// Why the generator's grammar file could not be read.
    grammar_error: Option<String>,
    /// The files under the recipe changed (a grammar edit): the worker must start a new
    /// session rather than update the current one.
    files_changed: bool,
}

/// The most undo steps kept.
pub const MAX_UNDO: usize = 500;

impl Document {
    /// A document from `what`: a preset name, a `.toml` recipe or a model file (`.l`,
    /// `.lst`, `.str`, `.json`); `None` is the default tree. Errors are the engine's
    /// messages (an unknown preset lists the way to see them).
    pub fn open(what: Option<&str>) -> Result<Document, String> {
        let what = what.unwrap_or(sylva::presets::DEFAULT_PRESET);
        let (source, loaded) = if sylva::presets::get(what).is_some() {
            (Source::Preset(what.to_string()), Loaded::preset(what))
        } else if Path::new(what).exists() {
            (Source::File(PathBuf::from(what)), Loaded::from_file(what))
        } else {
            return Err(format!(
                "`{what}` is neither a preset (`sylva presets` lists them) nor a file that exists"
            ));
        };
        let loaded = loaded.map_err(|e| e.to_string())?;
        Document::from_loaded(source, loaded)
    }

    /// A document from a recipe already loaded.
    pub fn from_loaded(source: Source, loaded: Loaded) -> Result<Document, String> {
        let table = loaded.recipe.to_table().map_err(|e| e.to_string())?;
        let mut doc = Document {
            source,
            start: loaded.clone(),
            loaded,
            table,
            undo: Vec::new(),
            redo: Vec::new(),
            joining: false,
            revision: 0,
            grammar: None,
            grammar_error: None,
            files_changed: false,
        };
        doc.sync_grammar();
        Ok(doc)
    }

    /// Where the document started.
    pub fn source(&self) -> &Source {
        &self.source
    }

    /// The recipe with its origin (what the worker grows).
    pub fn loaded(&self) -> &Loaded {
        &self.loaded
    }

    /// The recipe.
    pub fn recipe(&self) -> &Recipe {
        &self.loaded.recipe
    }

    /// Counts every change, undo and redo (the editor regrows when it moves).
    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// The recipe as a TOML table (kept in step with the recipe; the panel reads the
    /// current values from it).
    pub fn table(&self) -> &toml::Table {
        &self.table
    }

    /// The value of the dotted `key` in the recipe, `None` when the recipe leaves it
    /// out (then the schema's default applies).
    pub fn value(&self, key: &str) -> Option<&toml::Value> {
        lookup(&self.table, key)
    }

    /// Sets the dotted `key` (see [`Recipe::set`]); `joining` makes it part of the last
    /// undo step when that step set the same key (a slider drag). An error leaves the
    /// recipe as it was and says which key and why.
    pub fn set(&mut self, key: &str, value: toml::Value, joining: bool) -> Result<(), String> {
        if self.value(key) == Some(&value) {
            return Ok(());
        }
        let mut next = self.loaded.recipe.clone();
        next.set(key, value).map_err(|e| e.to_string())?;
        if next == self.loaded.recipe {
            // The same recipe (a value that rounds to the stored one, such as 0.6 into
            // an f32 key holding 0.6000000238): nothing to undo or regrow.
            return Ok(());
        }
        let join = joining && self.joining && self.undo.last().is_some_and(|s| s.key.as_deref() == Some(key));
        if !join {
            self.push_undo(Some(key.to_string()));
        }
        self.joining = joining;
        self.replace(next)
    }

    /// Ends a run of joined changes (the drag stopped).
    pub fn end_join(&mut self) {
        self.joining = false;
    }

    /// Replaces the recipe (a file reloaded, a reset) as one undo step.
    pub fn set_recipe(&mut self, recipe: Recipe) -> Result<(), String> {
        self.push_undo(None);
        self.joining = false;
        self.replace(recipe)
    }

    /// A new random seed (one undo step).
    pub fn new_seed(&mut self, seed: u64) -> Result<(), String> {
        self.set("seed", toml::Value::Integer((seed & (i64::MAX as u64)) as i64), false)
    }

    /// Back to the recipe the document started from.
    pub fn reset(&mut self) -> Result<(), String> {
        let start = self.start.recipe.clone();
        self.set_recipe(start)
    }

    /// Undoes the last step; `false` when there is none.
    pub fn undo(&mut self) -> bool {
        let Some(step) = self.undo.pop() else { return false };
        self.redo.push(self.loaded.recipe.clone());
        self.joining = false;
        self.replace(step.before).is_ok()
    }

    /// Redoes the last undone step; `false` when there is none.
    pub fn redo(&mut self) -> bool {
        let Some(next) = self.redo.pop() else { return false };
        self.undo.push(Step { before: self.loaded.recipe.clone(), key: None });
        self.joining = false;
        self.replace(next).is_ok()
    }

    /// Whether there is a step to undo / redo.
    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    /// See [`Document::can_undo`].
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// The dotted keys whose values differ from the start, with the current values
    /// (removed keys are not listed), in key order.
    pub fn changed(&self) -> Vec<(String, toml::Value)> {
        let start = self.start.recipe.to_table().unwrap_or_default();
        let mut out = Vec::new();
        diff(&start, &self.table, "", &mut out);
        out
    }

    /// The recipe to save: a preset's document writes `preset = "name"` and only the keys
    /// that differ from it (sylva reads such a file as the preset with those keys set);
    /// a file's document writes the whole recipe.
    pub fn to_toml(&self) -> Result<String, String> {
        match &self.source {
            Source::Preset(name) => {
                let mut text = format!("# sylva recipe: the preset `{name}` with these keys changed\n");
                text.push_str(&format!("preset = {}\n", toml::Value::String(name.clone())));
                let mut table = toml::Table::new();
                for (key, value) in self.changed() {
                    insert(&mut table, &key, value);
                }
                text.push_str(&toml::to_string(&table).map_err(|e| e.to_string())?);
                Ok(text)
            }
            Source::File(_) => self.recipe().to_toml().map_err(|e| e.to_string()),
        }
    }

    /// A file on disk changed (`--watch`): read it again and make it the current recipe
    /// (one undo step). The document keeps its origin folder.
    pub fn reload(&mut self) -> Result<(), String> {
        let Source::File(path) = &self.source else {
            return Err("a preset has no file to reload".into());
        };
        let loaded = Loaded::from_file(path).map_err(|e| e.to_string())?;
        self.start = loaded.clone();
        self.push_undo(None);
        self.loaded.origin = loaded.origin;
        // The grammar is read again from disk: unsaved edits give way to the file.
        self.loaded.overlay.clear();
        self.grammar = None;
        self.files_changed = true;
        self.replace(loaded.recipe)
    }

    /// The L-system grammar being edited, when the generator is an L-system.
    pub fn grammar(&self) -> Option<&Grammar> {
        self.grammar.as_ref()
    }

    /// Why the L-system's grammar file could not be read (the editor shows no text).
    pub fn grammar_error(&self) -> Option<&str> {
        self.grammar_error.as_deref()
    }

    /// The grammar editor's buffer. After changing it call [`Document::grammar_typed`]
    /// (typing, regrown after a pause) or [`Document::apply_grammar`] (at once).
    pub fn grammar_text_mut(&mut self) -> Option<&mut String> {
        self.grammar.as_mut().map(|g| &mut g.text)
    }

    /// The buffer was typed into at `at`: [`Document::apply_grammar_when_quiet`] gives it
    /// to the worker once [`GRAMMAR_DEBOUNCE`] has passed without typing.
    pub fn grammar_typed(&mut self, at: Instant) {
        if let Some(g) = self.grammar.as_mut() {
            g.typed_at = g.pending().then_some(at);
        }
    }

    /// Applies the buffer when it was last typed into [`GRAMMAR_DEBOUNCE`] or more before
    /// `now`. Returns how long until it will be due (the editor repaints then), `None`
    /// when nothing waits.
    pub fn apply_grammar_when_quiet(&mut self, now: Instant) -> Option<Duration> {
        let g = self.grammar.as_ref()?;
        if !g.pending() {
            return None;
        }
        let quiet = g.typed_at.map_or(GRAMMAR_DEBOUNCE, |t| now.saturating_duration_since(t));
        if quiet >= GRAMMAR_DEBOUNCE {
            self.apply_grammar();
            None
        } else {
            Some(GRAMMAR_DEBOUNCE - quiet)
        }
    }

    /// Lays the buffer over the grammar file now (the next submission regrows the
    /// tree from it in a new session). `false` when it was already applied.
    pub fn apply_grammar(&mut self) -> bool {
        let Some(g) = self.grammar.as_mut() else { return false };
        g.typed_at = None;
        if !g.pending() {
            return false;
        }
        g.applied = g.text.clone();
        if g.applied == g.original {
            self.loaded.overlay.remove(&g.file);
        } else {
            self.loaded.overlay.insert(g.file.clone(), g.applied.clone());
        }
        self.files_changed = true;
        self.revision += 1;
        true
    }

    /// Replaces the grammar's text and applies it at once (a `#define` slider, Revert).
    pub fn set_grammar_text(&mut self, text: String) -> bool {
        let Some(g) = self.grammar.as_mut() else { return false };
        g.text = text;
        self.apply_grammar()
    }

    /// Where "Save grammar" writes by default: the file itself for a recipe on disk,
    /// else its base name in the working folder (a preset's file is built in).
    pub fn grammar_path(&self) -> Option<PathBuf> {
        let g = self.grammar.as_ref()?;
        Some(match &self.loaded.origin {
            Origin::Folder(dir) => dir.join(&g.file),
            Origin::Preset(_) | Origin::Memory(_) => {
                PathBuf::from(Path::new(&g.file).file_name().unwrap_or(g.file.as_ref()))
            }
        })
    }

    /// Writes the grammar's buffer to `path` (atomically). Saved to the grammar's own file
    /// ([`Document::grammar_path`] of a recipe on disk), the text becomes the original.
    pub fn save_grammar(&mut self, path: &Path) -> Result<(), String> {
        let own = self.grammar_path().filter(|_| matches!(self.loaded.origin, Origin::Folder(_)));
        let Some(g) = self.grammar.as_mut() else {
            return Err("the recipe's generator is not an L-system: there is no grammar to save".into());
        };
        sylva::fsutil::write_atomic(path, |w| w.write_all(g.text.as_bytes()))
            .map_err(|e| format!("cannot save the grammar to {}: {e}", path.display()))?;
        if own.as_deref() == Some(path) {
            g.original = g.text.clone();
        }
        Ok(())
    }

    /// Whether the files under the recipe changed since the last call (the editor then
    /// starts a new session for the next tree); clears the flag.
    pub fn take_files_changed(&mut self) -> bool {
        std::mem::take(&mut self.files_changed)
    }

    /// Reads the generator's grammar file when the generator names another file than
    /// the one held (or none is held); drops it when the generator is not an L-system.
    fn sync_grammar(&mut self) {
        let file = match &self.loaded.recipe.generator {
            Generator::Lsystem(g) => g.file.clone(),
            _ => {
                self.grammar = None;
                self.grammar_error = None;
                return;
            }
        };
        if self.grammar.as_ref().is_some_and(|g| g.file == file) {
            return;
        }
        if let Some(old) = self.grammar.take() {
            if self.loaded.overlay.remove(&old.file).is_some() {
                self.files_changed = true;
            }
        }
        match self.loaded.read(&file) {
            Ok((name, text)) => {
                self.grammar_error = None;
                self.grammar = Some(Grammar {
                    file,
                    name,
                    original: text.clone(),
                    applied: text.clone(),
                    text,
                    typed_at: None,
                });
            }
            Err(e) => self.grammar_error = Some(e.to_string()),
        }
    }

    /// The folder relative file names resolve in, for a document from a file.
    pub fn folder(&self) -> Option<&Path> {
        match &self.loaded.origin {
            Origin::Folder(p) => Some(p),
            _ => None,
        }
    }

    fn push_undo(&mut self, key: Option<String>) {
        self.undo.push(Step { before: self.loaded.recipe.clone(), key });
        if self.undo.len() > MAX_UNDO {
            self.undo.remove(0);
        }
        self.redo.clear();
    }

    fn replace(&mut self, recipe: Recipe) -> Result<(), String> {
        self.table = recipe.to_table().map_err(|e| e.to_string())?;
        self.loaded.recipe = recipe;
        self.revision += 1;
        self.sync_grammar();
        Ok(())
    }
}

/// The value at dotted `key` in `table`.
pub fn lookup<'a>(table: &'a toml::Table, key: &str) -> Option<&'a toml::Value> {
    let mut parts = key.split('.');
    let mut value = table.get(parts.next()?)?;
    for part in parts {
        value = value.as_table()?.get(part)?;
    }
    Some(value)
}

fn insert(table: &mut toml::Table, key: &str, value: toml::Value) {
    match key.split_once('.') {
        None => {
            table.insert(key.to_string(), value);
        }
        Some((head, rest)) => {
            let entry =
                table.entry(head.to_string()).or_insert_with(|| toml::Value::Table(Default::default()));
            if let toml::Value::Table(t) = entry {
                insert(t, rest, value);
            }
        }
    }
}

fn diff(start: &toml::Table, now: &toml::Table, prefix: &str, out: &mut Vec<(String, toml::Value)>) {
    for (k, v) in now {
        let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        match (start.get(k), v) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => diff(a, b, &key, out),
            (Some(a), b) if a == b => {}
            _ => out.push((key, v.clone())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_undo_redo_and_joined_drags() {
        let mut doc = Document::open(Some("wp-quaking-aspen")).unwrap();
        let sides = doc.value("mesh.sides").cloned();
        doc.set("mesh.sides", toml::Value::Integer(6), false).unwrap();
        assert_eq!(doc.recipe().mesh.sides, 6);
        // A drag: three values, one undo step.
        for v in [0.5, 0.6, 0.7] {
            doc.set("leaves.alpha_cutoff", toml::Value::Float(v), true).unwrap();
        }
        doc.end_join();
        assert!(doc.undo());
        assert_eq!(doc.recipe().mesh.sides, 6, "the drag was one step");
        assert!(doc.undo());
        assert_eq!(doc.value("mesh.sides").cloned(), sides);
        assert!(!doc.undo());
        assert!(doc.redo());
        assert_eq!(doc.recipe().mesh.sides, 6);
    }

    #[test]
    fn a_value_equal_after_rounding_is_no_change() {
        let mut doc = Document::open(Some("wp-quaking-aspen")).unwrap();
        doc.set("leaves.alpha_cutoff", toml::Value::Float(0.6), false).unwrap();
        let (rev, steps) = (doc.revision(), doc.undo.len());
        // The key is an f32: the table now holds 0.6000000238418579, and 0.6 again is
        // the same recipe (an editor slider rounding to its decimals sends it).
        assert_ne!(doc.value("leaves.alpha_cutoff"), Some(&toml::Value::Float(0.6)));
        doc.set("leaves.alpha_cutoff", toml::Value::Float(0.6), false).unwrap();
        assert_eq!((doc.revision(), doc.undo.len()), (rev, steps));
    }

    #[test]
    fn a_bad_value_names_the_key_and_changes_nothing() {
        let mut doc = Document::open(None).unwrap();
        let before = doc.revision();
        let e = doc.set("mesh.sides", toml::Value::Integer(2), false).unwrap_err();
        assert!(e.contains("mesh.sides"), "{e}");
        assert_eq!(doc.revision(), before);
        assert!(!doc.can_undo());
    }

    #[test]
    fn a_preset_saves_only_what_changed_and_reads_back() {
        let mut doc = Document::open(Some("wp-quaking-aspen")).unwrap();
        doc.set("mesh.sides", toml::Value::Integer(6), false).unwrap();
        doc.new_seed(99).unwrap();
        assert_eq!(doc.changed().len(), 2, "{:?}", doc.changed());
        let text = doc.to_toml().unwrap();
        assert!(text.contains("preset = \"wp-quaking-aspen\""), "{text}");
        let back = Recipe::from_toml(&text).unwrap();
        assert_eq!(back.mesh.sides, 6);
        assert_eq!(back.seed, 99);
        doc.reset().unwrap();
        assert!(doc.changed().is_empty());
    }

    /// A bare `.l` model in a fresh folder (removed by the caller).
    fn model(tag: &str, text: &str) -> (PathBuf, PathBuf) {
        let dir = std::env::temp_dir().join(format!("sylva-edit-doc-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("plant.l");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    const MODEL: &str = "#define N 3\nLsystem: 1\nderivation length: N\nAxiom: F\nF --> F[+F]F\nendlsystem\n";

    #[test]
    fn grammar_typing_is_applied_once_quiet_and_saved() {
        let (dir, path) = model("typing", MODEL);
        let mut doc = Document::open(Some(path.to_str().unwrap())).unwrap();
        let g = doc.grammar().expect("an L-system's grammar is held");
        assert_eq!((g.file.as_str(), g.text.as_str()), ("plant.l", MODEL));
        assert_eq!(g.name, path.display().to_string(), "the name the engine's messages give");
        assert!(!doc.take_files_changed());
        let rev = doc.revision();
        // Typing: nothing is given to the worker until the text has been quiet.
        let t0 = Instant::now();
        doc.grammar_text_mut().unwrap().push_str("// more\n");
        doc.grammar_typed(t0);
        let wait = doc.apply_grammar_when_quiet(t0 + Duration::from_millis(100)).expect("waiting");
        assert_eq!(wait, GRAMMAR_DEBOUNCE - Duration::from_millis(100));
        assert_eq!(doc.revision(), rev);
        assert_eq!(doc.loaded().read("plant.l").unwrap().1, MODEL, "still the file's text");
        assert_eq!(doc.apply_grammar_when_quiet(t0 + GRAMMAR_DEBOUNCE), None);
        assert_eq!(doc.revision(), rev + 1);
        assert!(doc.take_files_changed(), "a grammar edit starts a new session");
        assert!(!doc.take_files_changed());
        let edited = format!("{MODEL}// more\n");
        assert_eq!(doc.loaded().read("plant.l").unwrap(), (path.display().to_string(), edited.clone()));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), MODEL, "nothing written yet");
        // A recipe change keeps the edited grammar.
        doc.set("mesh.sides", toml::Value::Integer(5), false).unwrap();
        assert_eq!(doc.loaded().read("plant.l").unwrap().1, edited);
        assert!(doc.grammar().unwrap().modified());
        // Save grammar writes the file; the text is then the original.
        assert_eq!(doc.grammar_path().as_deref(), Some(path.as_path()));
        doc.save_grammar(&path).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), edited);
        assert!(!doc.grammar().unwrap().modified());
        // A reload (`--watch`) reads the file again and drops unsaved edits.
        doc.set_grammar_text(MODEL.replace("N 3", "N 2"));
        doc.take_files_changed();
        doc.reload().unwrap();
        assert!(doc.take_files_changed());
        assert_eq!(doc.grammar().unwrap().text, edited);
        assert!(doc.loaded().overlay.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_preset_grammar_is_read_from_the_presets_and_saved_elsewhere() {
        let mut doc = Document::open(Some("lsys-honda-a")).unwrap();
        let g = doc.grammar().expect("honda's grammar");
        assert_eq!(g.name, "presets/lsystem/honda.l");
        assert!(g.text.contains("#define R1 0.75"));
        assert_eq!(doc.grammar_path(), Some(PathBuf::from("honda.l")), "a preset's file is built in");
        let e = doc.save_grammar(Path::new("/no-such-folder/honda.l")).unwrap_err();
        assert!(e.contains("/no-such-folder/honda.l"), "{e}");
        // Another generator: no grammar.
        let mut wp = Document::open(Some("wp-quaking-aspen")).unwrap();
        assert!(wp.grammar().is_none() && wp.grammar_error().is_none());
        assert!(!wp.set_grammar_text("x".into()));
    }

    #[test]
    fn unknown_input_is_an_error() {
        let e = Document::open(Some("no-such-tree")).unwrap_err();
        assert!(e.contains("no-such-tree"), "{e}");
    }
}
