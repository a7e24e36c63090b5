//! Environmental programs: what answers cpfg's `?E` communication modules (open
//! L-systems).
//!
//! Issues 3 and 26, after Měch & Prusinkiewicz, "Visual models of plants interacting
//! with their environment" (SIGGRAPH 96), which the cpfg corpus's `07-Open` and
//! `20-EnviroPgms` models use. In cpfg the environment is a separate process started
//! from the model's `.e` file (`executable: honda81 density.spec`): after every
//! derivation step cpfg interprets the string, sends each `?E(x, …)` module's turtle
//! position and parameters to it, and writes the answers back into the module's
//! parameters before the next step. sylva runs the same exchange in-process (see
//! `LSystem::derive_full`) with the programs built in here, one file each:
//!
//! | program | file | what it answers |
//! |---|---|---|
//! | `honda81` | [`honda81`] | competition for space: colliding sensors resolved by vigor |
//! | `clover` | [`clover`] | light from above over a grid lit by an image, shaded by registered leaves |
//! | `ecosystem` | [`ecosystem`] | plants as circles on the ground: a plant overlapping a larger one dies |
//! | `chiba` | [`chiba`] | fraction of sky light a leaf receives, shaded by the other leaves |
//! | `obcheck` | [`obcheck`] | whether a sensor is free of the obstacles of a data file, and how far they are |
//!
//! Nobody outside vlab has the programs' sources, so each is defined precisely in its
//! file (and in `docs/environments.md`) from the literature and from how the corpus
//! models use their modules.
//!
//! # The `.e` file and the program's spec file
//!
//! A `.e` file's `executable:` line is `NAME [flags] SPECFILE`: the program (its path
//! dropped), then its command line; the spec file is the last argument that is neither
//! a flag (`-x`) nor a flag's value (`-e enviro.e` takes one value). The spec file holds
//! `key: value` lines ([`Spec`]); each program documents its keys. Unknown keys are
//! listed as ignored; a bad value is an error naming `file:line` and why. The recipe's
//! `[generator.environment]` ([`Overrides`]) overrides the spec file's values.
//!
//! # Budget and robustness
//!
//! Every program counts its work in the units of [`Environment::respond_within`] and
//! stops with `Err` when the derivation's work budget is used up. No input makes a
//! program panic or answer NaN: sensors at non-finite positions get the program's
//! "nothing here" answer, and an empty sensor list is answered with nothing.

pub mod chiba;
pub mod clover;
pub mod ecosystem;
pub mod honda81;
pub mod image;
pub mod obcheck;

use crate::input::{excerpt, SideFiles};
use glam::DVec3;
use std::path::{Path, PathBuf};

pub use chiba::Chiba;
pub use clover::Clover;
pub use ecosystem::Ecosystem;
pub use honda81::Honda81;
pub use obcheck::Obcheck;

/// Programs sylva has built in, by the name a cpfg `.e` file's `executable:` gives.
pub const PROGRAMS: &[&str] = &["honda81", "clover", "ecosystem", "chiba", "obcheck"];

/// Default collision radius of `honda81`, in model units (a unit turtle step is 1).
pub const DEFAULT_RADIUS: f64 = honda81::DEFAULT_RADIUS;

/// An environmental program answering `?E` modules.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// Collision between sensors, resolved by vigor ([`honda81`]).
    Honda81(Honda81),
    /// Light over a grid, shaded by leaves ([`clover`]).
    Clover(Clover),
    /// Circles competing for space ([`ecosystem`]).
    Ecosystem(Ecosystem),
    /// Sky light intercepted by leaves ([`chiba`]).
    Chiba(Chiba),
    /// Obstacle checking ([`obcheck`]).
    Obcheck(Obcheck),
}

/// One `?E` module as the environment sees it.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Turtle position at the module.
    pub position: DVec3,
    /// The module's parameters; the environment overwrites the ones it answers.
    pub values: Vec<f64>,
}

/// Values of the recipe's `[generator.environment]` that override the spec file's.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Overrides {
    /// `honda81`'s collision radius; `chiba`'s default leaf radius.
    pub radius: Option<f64>,
    /// `clover`'s and `chiba`'s leaf transmittance, in \[0, 1\].
    pub transmittance: Option<f64>,
    /// `clover`'s input image, relative to the model folder.
    pub image: Option<String>,
    /// `chiba`'s number of sky directions.
    pub directions: Option<f64>,
    /// `obcheck`'s obstacle file, relative to the model folder.
    pub obstacles: Option<String>,
}

/// One `key: value` line of a spec file.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecEntry {
    /// The key, trimmed and lower-cased.
    pub key: String,
    /// The value, trimmed.
    pub value: String,
    /// Its line, counted from 1.
    pub line: usize,
}

/// An environmental program's spec file: `key: value` lines. Blank lines and lines
/// starting with `#` or `/*` are comments; other lines without `:` are counted in one
/// note of [`Spec::notes`] as ignored, by line number only: the spec file is named by
/// a model folder, not by the user, so its text is never repeated (issue 39: a private
/// key named as a spec file came out line by line). Keys and values are quoted
/// clipped ([`excerpt`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Spec {
    /// The file's name, as errors show it.
    pub file: String,
    /// Its entries, in file order.
    pub entries: Vec<SpecEntry>,
    /// Lines that are not `key: value`, one note each.
    pub notes: Vec<String>,
}

impl Spec {
    /// Parses spec text read from `file` (the name errors show).
    pub fn parse(file: &str, text: &str) -> Spec {
        let mut spec = Spec { file: file.to_string(), entries: Vec::new(), notes: Vec::new() };
        let mut plain: Vec<usize> = Vec::new();
        for (k, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with("/*") {
                continue;
            }
            match line.split_once(':') {
                Some((key, value)) => spec.entries.push(SpecEntry {
                    key: key.trim().to_ascii_lowercase(),
                    value: value.trim().to_string(),
                    line: k + 1,
                }),
                None => plain.push(k + 1),
            }
        }
        if let Some(first) = plain.first() {
            let shown: Vec<String> = plain.iter().take(5).map(usize::to_string).collect();
            let more = if plain.len() > 5 { ", …" } else { "" };
            spec.notes.push(if plain.len() == 1 {
                format!("{file}:{first}: a line that is not `key: value` (ignored)")
            } else {
                format!(
                    "{file}: {} lines are not `key: value` (lines {}{more}; ignored)",
                    plain.len(),
                    shown.join(", ")
                )
            });
        }
        spec
    }

    /// Reads and parses the spec file at `path` (a regular file of at most the default
    /// input limit, [`crate::input::read_input`]); `Err` says which file and why.
    pub fn read(path: &Path) -> Result<Spec, String> {
        let bytes = crate::input::read_input(path, crate::input::DEFAULT_MAX_BYTES)
            .map_err(|e| format!("the spec file: {e}"))?;
        Ok(Spec::parse(&path.display().to_string(), &String::from_utf8_lossy(&bytes)))
    }

    /// Reads and parses the spec file at `path` through the model folder's `files`
    /// (confined to it, within its input limit); `what` says where it is named.
    pub fn read_in(files: &SideFiles, path: &Path, what: &str) -> Result<Spec, crate::Error> {
        let text = files.read_text(path, what)?;
        Ok(Spec::parse(&path.display().to_string(), &text))
    }

    /// The last entry with `key` (lower case), as cpfg's readers let later lines win.
    pub fn get(&self, key: &str) -> Option<&SpecEntry> {
        self.entries.iter().rev().find(|e| e.key == key)
    }

    /// Notes for the entries `program` does not know (and the non-`key: value` lines).
    pub fn unknown(&self, program: &str) -> Vec<String> {
        let known = known_keys(program);
        let mut out = self.notes.clone();
        for e in &self.entries {
            if !known.contains(&e.key.as_str()) {
                out.push(format!(
                    "{}:{}: `{}` is not a {program} key (ignored)",
                    self.file,
                    e.line,
                    excerpt(&e.key)
                ));
            }
        }
        out
    }

    /// An error about `e`: `file:line: key: why (got value)`.
    pub fn error(&self, e: &SpecEntry, why: &str) -> String {
        format!("{}:{}: `{}`: {why} (got `{}`)", self.file, e.line, excerpt(&e.key), excerpt(&e.value))
    }

    /// The entry's value as one finite number.
    pub fn number(&self, e: &SpecEntry) -> Result<f64, String> {
        match e.value.split_whitespace().collect::<Vec<_>>().as_slice() {
            [one] => {
                one.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| self.error(e, "not a number"))
            }
            _ => Err(self.error(e, "expected one number")),
        }
    }

    /// The number under `key` (the last entry with it), `default` when there is none;
    /// a value `ok` refuses is an error about the entry saying `why`.
    pub fn number_or(
        &self,
        key: &str,
        default: f64,
        ok: impl Fn(f64) -> bool,
        why: &str,
    ) -> Result<f64, String> {
        let Some(e) = self.get(key) else { return Ok(default) };
        let v = self.number(e)?;
        if ok(v) {
            Ok(v)
        } else {
            Err(self.error(e, why))
        }
    }

    /// The entry's value as `n` finite numbers separated by blanks, `x` or commas
    /// (`100x100`, `-50 -50`). Text after the numbers is returned as the second value
    /// (the corpus has `grid range: 100x100view.pnl`), for the caller to note.
    pub fn numbers(&self, e: &SpecEntry, n: usize) -> Result<(Vec<f64>, Option<String>), String> {
        let mut out = Vec::new();
        let mut rest = e.value.as_str();
        while out.len() < n {
            rest = rest
                .trim_start_matches(|c: char| c.is_whitespace() || c == ',' || (c == 'x' && !out.is_empty()));
            let len = number_prefix(rest);
            if len == 0 {
                return Err(self.error(e, &format!("expected {n} numbers")));
            }
            let v: f64 = rest[..len].parse().map_err(|_| self.error(e, &format!("expected {n} numbers")))?;
            if !v.is_finite() {
                return Err(self.error(e, "numbers must be finite"));
            }
            out.push(v);
            rest = &rest[len..];
        }
        let rest = rest.trim();
        Ok((out, (!rest.is_empty()).then(|| rest.to_string())))
    }

    /// The entry's value as on/off (also yes/no, true/false, 1/0).
    pub fn flag(&self, e: &SpecEntry) -> Result<bool, String> {
        match e.value.to_ascii_lowercase().as_str() {
            "on" | "yes" | "true" | "1" => Ok(true),
            "off" | "no" | "false" | "0" => Ok(false),
            _ => Err(self.error(e, "expected on or off")),
        }
    }
}

/// Length of the decimal number at the start of `s` (sign, digits, point, exponent).
fn number_prefix(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'-' || b[i] == b'+') {
        i += 1;
    }
    let start = i;
    while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
        i += 1;
    }
    if i == start {
        return 0;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
            j += 1;
        }
        if j < b.len() && b[j].is_ascii_digit() {
            while j < b.len() && b[j].is_ascii_digit() {
                j += 1;
            }
            i = j;
        }
    }
    i
}

/// The spec-file keys `program` reads (lower case).
pub fn known_keys(program: &str) -> &'static [&'static str] {
    match program {
        "honda81" => honda81::KEYS,
        "clover" => clover::KEYS,
        "ecosystem" => ecosystem::KEYS,
        "chiba" => chiba::KEYS,
        "obcheck" => obcheck::KEYS,
        _ => &[],
    }
}

/// What a `.e` file's `executable:` line says.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ExecutableLine {
    /// The program, without directories (`/bin/honda81` → `honda81`).
    pub program: String,
    /// Its arguments, in order.
    pub args: Vec<String>,
    /// The spec file: the last argument that is not a flag or a flag's value.
    pub spec: Option<String>,
}

/// Flags of the environmental programs' command lines that take a value.
const FLAGS_WITH_VALUE: &[&str] = &["-e"];

/// Parses the first `executable:` line of a `.e` file; `None` without one.
pub fn executable_line(e_text: &str) -> Option<ExecutableLine> {
    let line = e_text.lines().find_map(|l| l.trim().strip_prefix("executable:"))?;
    let mut words = line.split_whitespace();
    let program = Path::new(words.next()?).file_name()?.to_string_lossy().into_owned();
    let args: Vec<String> = words.map(str::to_string).collect();
    let mut spec = None;
    let mut k = 0;
    while k < args.len() {
        let a = &args[k];
        if a.starts_with('-') && a.len() > 1 {
            k += if FLAGS_WITH_VALUE.contains(&a.as_str()) { 2 } else { 1 };
            continue;
        }
        spec = Some(a.clone());
        k += 1;
    }
    Some(ExecutableLine { program, args, spec })
}

/// For the model folder reader: the spec file the `.e` file (`e_name`, text `e_text`,
/// in the model folder `files`) names, when it names one. Unknown keys of the spec file
/// and a missing spec file are noted in `ignored` (the pipeline reports a missing one
/// as an error when the program is used). A spec file outside the folder, or one that
/// is not a regular file or is over the input limit, is an error
/// ([`crate::input::is_refusal`]).
pub fn spec_file_in(
    files: &SideFiles,
    e_name: &str,
    e_text: &str,
    ignored: &mut Vec<String>,
) -> Result<Option<PathBuf>, crate::Error> {
    let Some(exe) = executable_line(e_text) else { return Ok(None) };
    let Some(spec) = exe.spec else { return Ok(None) };
    let at = format!("{}: `executable:`", excerpt(e_name));
    let path = files.resolve(&spec, &at)?;
    if !path.exists() {
        ignored.push(format!("missing spec file {} (named by {})", excerpt(&spec), excerpt(e_name)));
        return Ok(Some(path));
    }
    let s = Spec::read_in(files, &path, &at)?;
    if PROGRAMS.contains(&exe.program.as_str()) {
        ignored.extend(s.unknown(&exe.program));
    }
    Ok(Some(path))
}

/// A leaf transmittance in [0, 1]: the recipe's override, else the spec's
/// `transmittance:`, else `default`; `program` names the key's owner in errors.
pub(crate) fn transmittance(
    spec: &Spec,
    over: &Overrides,
    default: f64,
    program: &str,
) -> Result<f64, String> {
    if let Some(t) = over.transmittance {
        if !(0.0..=1.0).contains(&t) {
            return Err(format!("{program}: transmittance must be in [0, 1], got {t}"));
        }
        return Ok(t);
    }
    spec.number_or(
        "transmittance",
        default,
        |t| (0.0..=1.0).contains(&t),
        "the transmittance must be in [0, 1]",
    )
}

/// A coordinate axis, for the programs that need "up".
pub(crate) fn axis(spec: &Spec, key: &str, default: usize) -> Result<usize, String> {
    match spec.get(key) {
        None => Ok(default),
        Some(e) => match e.value.to_ascii_lowercase().trim_start_matches('+') {
            "x" => Ok(0),
            "y" => Ok(1),
            "z" => Ok(2),
            _ => Err(spec.error(e, "expected x, y or z")),
        },
    }
}

impl Environment {
    /// The program called `name` (as in a `.e` file's `executable:` line, path and
    /// arguments removed) with its default settings, and `radius` where the program
    /// uses one. `Err` names the programs sylva has.
    pub fn by_name(name: &str, radius: Option<f64>) -> Result<Environment, String> {
        let over = Overrides { radius, ..Overrides::default() };
        Environment::configure(name, None, &over, Path::new("."), &mut Vec::new())
    }

    /// The program `name` configured from its spec file (when there is one) and the
    /// recipe's overrides; data files (images, obstacles) are read from inside `dir`
    /// ([`Environment::configure_in`] with `dir` as the model folder and the default
    /// input limit). Notes on what was not used (a missing image) are appended to
    /// `notes`. `Err` names the file, line and why, or the programs sylva has.
    pub fn configure(
        name: &str,
        spec: Option<&Spec>,
        over: &Overrides,
        dir: &Path,
        notes: &mut Vec<String>,
    ) -> Result<Environment, String> {
        let files = SideFiles::new(dir, &[], crate::input::DEFAULT_MAX_BYTES);
        Environment::configure_in(name, spec, over, &files, notes)
    }

    /// [`Environment::configure`] reading the data files through the model folder's
    /// `files`: confined to its folders and within its input limit.
    pub fn configure_in(
        name: &str,
        spec: Option<&Spec>,
        over: &Overrides,
        dir: &SideFiles,
        notes: &mut Vec<String>,
    ) -> Result<Environment, String> {
        let empty = Spec { file: "(no spec file)".into(), entries: Vec::new(), notes: Vec::new() };
        let spec = spec.unwrap_or(&empty);
        Ok(match name {
            "honda81" => Environment::Honda81(Honda81::configure(spec, over)?),
            "clover" => Environment::Clover(Clover::configure(spec, over, dir, notes)?),
            "ecosystem" => Environment::Ecosystem(Ecosystem::configure(spec, over)?),
            "chiba" => Environment::Chiba(Chiba::configure(spec, over)?),
            "obcheck" => Environment::Obcheck(Obcheck::configure(spec, over, dir)?),
            other => {
                return Err(format!(
                    "environmental program `{other}` is not built into sylva (it has: {})",
                    PROGRAMS.join(", ")
                ))
            }
        })
    }

    /// The program's name.
    pub fn name(&self) -> &'static str {
        match self {
            Environment::Honda81(_) => "honda81",
            Environment::Clover(_) => "clover",
            Environment::Ecosystem(_) => "ecosystem",
            Environment::Chiba(_) => "chiba",
            Environment::Obcheck(_) => "obcheck",
        }
    }

    /// Forgets what earlier exchanges left (`clover`'s registered leaves), so a new
    /// derivation starts from the program's initial state.
    pub fn reset(&self) {
        if let Environment::Clover(c) = self {
            c.reset();
        }
    }

    /// Answers every sensor: writes the program's responses into `sensors[i].values`.
    pub fn respond(&self, sensors: &mut [Sensor]) {
        let _ = self.respond_within(sensors, u64::MAX);
    }

    /// [`Environment::respond`] doing at most `work` units of work (one per sensor and
    /// one per neighbour, grid cell, sky direction test or obstacle visited): `Ok(work
    /// done)`, or `Err(work)` when that was not enough, with the sensors left
    /// unanswered.
    pub fn respond_within(&self, sensors: &mut [Sensor], work: u64) -> Result<u64, u64> {
        match self {
            Environment::Honda81(h) => h.respond(sensors, work),
            Environment::Clover(c) => c.respond(sensors, work),
            Environment::Ecosystem(e) => e.respond(sensors, work),
            Environment::Chiba(c) => c.respond(sensors, work),
            Environment::Obcheck(o) => o.respond(sensors, work),
        }
    }
}

/// A work counter: [`Work::add`] fails once more than `limit` units were spent.
pub(crate) struct Work {
    pub used: u64,
    pub limit: u64,
}

impl Work {
    pub(crate) fn new(limit: u64) -> Work {
        Work { used: 0, limit }
    }

    /// Spends `n` units; `Err(limit)` past the limit.
    pub(crate) fn add(&mut self, n: u64) -> Result<(), u64> {
        self.used = self.used.saturating_add(n);
        if self.used > self.limit {
            Err(self.limit)
        } else {
            Ok(())
        }
    }
}

/// Writes `v` into parameter `k` of `values` (appending when the module is shorter:
/// the exchange drops answers beyond the module's arity).
pub(crate) fn answer(values: &mut Vec<f64>, k: usize, v: f64) {
    while values.len() <= k {
        values.push(0.0);
    }
    values[k] = v;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn executable_lines_name_program_and_spec() {
        let e = executable_line("executable: clover -e enviro.e enviro.spec\ncommunication type: memory\n")
            .unwrap();
        assert_eq!((e.program.as_str(), e.spec.as_deref()), ("clover", Some("enviro.spec")));
        let e = executable_line("# x\nexecutable: /usr/bin/honda81 density.spec\n").unwrap();
        assert_eq!((e.program.as_str(), e.spec.as_deref()), ("honda81", Some("density.spec")));
        let e = executable_line("executable: honda81 -e d.spec\n").unwrap();
        assert_eq!(e.spec, None, "-e takes its value");
        let e = executable_line("executable: obcheck -v obs.spec\n").unwrap();
        assert_eq!(e.spec.as_deref(), Some("obs.spec"));
        assert_eq!(executable_line("communication type: pipes\n"), None);
    }

    #[test]
    fn spec_files_parse_keys_numbers_and_errors() {
        let s = Spec::parse(
            "e.spec",
            "verbose: off\ngrid range: 100x100view.pnl\nGrid Size: 4 x 8\nnonsense\nradius: x\n",
        );
        assert_eq!(s.entries.len(), 4);
        assert_eq!(s.notes.len(), 1);
        assert!(s.notes[0].contains("e.spec:4:") && !s.notes[0].contains("nonsense"), "{:?}", s.notes);
        let (v, rest) = s.numbers(s.get("grid range").unwrap(), 2).unwrap();
        assert_eq!((v, rest.as_deref()), (vec![100.0, 100.0], Some("view.pnl")));
        let (v, rest) = s.numbers(s.get("grid size").unwrap(), 2).unwrap();
        assert_eq!((v, rest), (vec![4.0, 8.0], None));
        let e = s.number(s.get("radius").unwrap()).unwrap_err();
        assert!(e.contains("e.spec:5:") && e.contains("radius") && e.contains("not a number"), "{e}");
        let u = s.unknown("clover");
        assert!(u.iter().any(|n| n.contains("radius")) && u.iter().any(|n| n.contains("e.spec:4:")), "{u:?}");
        let many = Spec::parse("k.spec", &"SECRET-LINE\n".repeat(9));
        assert_eq!(many.notes.len(), 1);
        assert!(many.notes[0].contains("9 lines") && !many.notes[0].contains("SECRET"), "{:?}", many.notes);
        let e = s.numbers(s.get("verbose").unwrap(), 2).unwrap_err();
        assert!(e.contains("e.spec:1:"), "{e}");
    }

    #[test]
    fn unknown_programs_are_errors_naming_all_five() {
        let e = Environment::by_name("lightning", None).unwrap_err();
        assert!(e.contains("`lightning`"), "{e}");
        for p in PROGRAMS {
            assert!(e.contains(p), "{e}");
        }
        for p in PROGRAMS {
            // Every program answers an empty sensor list and strange sensors without panicking.
            let Ok(env) = Environment::by_name(p, None) else {
                assert_eq!(*p, "obcheck", "only obcheck needs a data file");
                continue;
            };
            assert_eq!(env.name(), *p);
            env.respond(&mut []);
            let mut s = vec![
                Sensor { position: DVec3::NAN, values: vec![] },
                Sensor {
                    position: DVec3::splat(f64::INFINITY),
                    values: vec![f64::NEG_INFINITY, f64::INFINITY],
                },
                Sensor { position: DVec3::splat(1e300), values: vec![1e300, -1e300] },
                Sensor { position: DVec3::ZERO, values: vec![1.0, 1e300] },
                Sensor { position: DVec3::ZERO, values: vec![2.0, 1e300] },
            ];
            env.respond(&mut s);
            assert!(s.iter().all(|s| s.values.iter().all(|v| !v.is_nan())), "{p}: {s:?}");
        }
    }
}
