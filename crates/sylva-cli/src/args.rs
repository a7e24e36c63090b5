//! The flags several subcommands share ([`Common`]: what to grow, `-n`, `--seed`,
//! `--set`, `-q`), declared once and flattened into `grow`, `render` and `lsys derive`,
//! and the value parsers of the flags with a form of their own: whole numbers in a range
//! ([`whole_in`]), sizes (`WxH`, [`size`]), wind presets ([`wind`]) and LOD lists
//! ([`lod`]). Every message names the flag, what was typed and the form accepted.
//!
//! A parser that returns a [`FlagError`] has its message printed as sylva's other errors
//! are (exit 1, `main`); the others are clap's usage errors (exit 2).

use miette::Result;
use std::path::Path;
use sylva::diagnostic::quote;
use sylva::recipe::{self, Generator, Loaded, WindPreset};

/// The flags `grow`, `render` and `lsys derive` share.
#[derive(clap::Args, Debug, Clone)]
pub struct Common {
    /// Preset name (`sylva presets`), recipe file (.toml), L-system file (.l), or a
    /// skeleton file (.lst, CPFG string .str, sylva .skel.json). Default: the default
    /// preset.
    pub what: Option<String>,
    /// Derivation steps of an L-system (recipe key `generator.iterations`; default: the
    /// model's derivation length).
    #[arg(short = 'n', long, value_parser = whole_in::<u32>(0, u32::MAX as u64))]
    pub iterations: Option<u32>,
    /// Random seed (recipe key `seed`; `render --forest` also seeds its jitter with it).
    #[arg(long, value_parser = whole_in::<u64>(0, i64::MAX as u64))]
    pub seed: Option<u64>,
    /// Set any recipe key: `--set generator.angle=22.5 --set mesh.sides=6`
    /// (docs/recipe.md lists every key).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    /// Print nothing but errors and warnings (no summary, no progress).
    #[arg(short, long)]
    pub quiet: bool,
    /// Stop with an error once the run has taken this many seconds (0.01..=1000000;
    /// default: no limit): growing and writing the files, which are then left as they
    /// were. The recipe's work budgets (`*.max_work`, `max_modules`) bound the work
    /// itself, the same on every machine; this bounds the wall-clock time of a run whose
    /// budgets or sizes were raised. It stops at the next checkpoint (within about a
    /// second on ordinary trees, 2–3 s on meshes of tens of millions of triangles).
    #[arg(long, value_name = "SECONDS", value_parser = seconds)]
    pub time_limit: Option<f64>,
}

impl Common {
    /// The preset or file named, or the default preset.
    pub fn what(&self) -> &str {
        self.what.as_deref().unwrap_or(sylva::presets::DEFAULT_PRESET)
    }

    /// Loads the recipe with the `--set` pairs, then `--seed`, `-n` and `extra` (flags
    /// last, so they win over `--set`). `-n` on a generator without derivation steps is
    /// an error that says so, naming `-n` and what to use instead.
    pub fn load(&self, extra: &[(String, toml::Value)]) -> Result<Loaded> {
        let mut sets = Vec::new();
        for s in &self.sets {
            sets.push(recipe::parse_set(s)?);
        }
        if let Some(s) = self.seed {
            let s = i64::try_from(s)
                .map_err(|_| miette::miette!("--seed {s} is too large (max {})", i64::MAX))?;
            sets.push(("seed".into(), toml::Value::Integer(s)));
        }
        sets.extend_from_slice(extra);
        let what = self.what();
        let Some(n) = self.iterations else { return Ok(recipe::load(what, &sets)?) };
        let mut with_n = sets.clone();
        with_n.push(("generator.iterations".into(), toml::Value::Integer(n.into())));
        match recipe::load(what, &with_n) {
            Ok(loaded) => Ok(loaded),
            // Refused with `-n`: say why in the user's words if the generator has no steps.
            Err(e) => match recipe::load(what, &sets) {
                Ok(l) if !matches!(l.recipe.generator, Generator::Lsystem(_)) => {
                    Err(no_derivation_steps(what, n, &l.recipe.generator))
                }
                _ => Err(e.into()),
            },
        }
    }
}

/// The value parser of `--time-limit`: seconds in 0.01..=1,000,000.
pub fn seconds(s: &str) -> std::result::Result<f64, FlagError> {
    let shown = quote(s);
    match s.trim().parse::<f64>() {
        Ok(x) if (0.01..=1e6).contains(&x) => Ok(x),
        Ok(x) if x.is_finite() => {
            Err(FlagError(format!("--time-limit {shown}: out of range: use seconds in 0.01..=1000000")))
        }
        _ => Err(FlagError(format!("--time-limit {shown}: not a number of seconds (e.g. 30 or 2.5)"))),
    }
}

impl Common {
    /// Runs `f` with a cancellation token that `--time-limit` (when given) sets once its
    /// seconds have passed; a run it stopped becomes an error naming the flag and the
    /// limit. The timer thread ends with `f`.
    pub fn timed<R>(&self, f: impl FnOnce(&sylva::cancel::Cancel) -> sylva::Result<R>) -> Result<R> {
        let token = sylva::cancel::Cancel::new();
        let Some(limit) = self.time_limit else { return Ok(f(&token)?) };
        let timer = sylva::cancel::Timer::start(&token, std::time::Duration::from_secs_f64(limit))
            .map_err(|e| miette::miette!("--time-limit: cannot start its timer thread: {e}"))?;
        let result = sylva::cancel::scope(&token, || f(&token));
        let fired = timer.stop();
        // A stage the token stopped may return what it had so far (the derivation does):
        // once the timer fired, any result is the time-limit error.
        match result {
            _ if fired => Err(time_limit_passed(limit)),
            r => Ok(r?),
        }
    }
}

/// The error of a run stopped by `--time-limit SECONDS`.
pub fn time_limit_passed(limit: f64) -> miette::Report {
    miette::miette!(
        help = "raise --time-limit, or lower the work (generator.iterations, refine.levels, \
                a raised *.max_work budget)",
        "--time-limit {limit}: the run passed the limit of {limit} s and was stopped; nothing was written"
    )
}

/// The error of `-n N` on `what`, whose generator is not an L-system: what `-n` is, what
/// `what` is, and the key to use instead.
pub fn no_derivation_steps(what: &str, n: u32, generator: &Generator) -> miette::Report {
    let (kind, instead) = match generator {
        Generator::WeberPenn(_) => (
            "a Weber–Penn tree",
            "set the depth of its branching with `--set generator.levels=N` (1..=4)".to_string(),
        ),
        Generator::SpaceColonization(_) => (
            "a space-colonization tree",
            "bound its growth with `--set generator.max_iterations=N`".to_string(),
        ),
        Generator::LeastCost(_) => (
            "a least-cost-path tree",
            "its growth steps are the recipe's `generator.levels` (MIG) or `generator.iterations` (MGV) tables"
                .to_string(),
        ),
        Generator::Import(_) => ("a skeleton read from a file", "drop -n".to_string()),
        Generator::Lsystem(_) => ("an L-system", String::new()),
    };
    miette::miette!(
        "-n {n}: `-n` (derivation steps) applies to L-system recipes, and `{}` is {kind}, which has no derivation steps; {instead}",
        quote(what)
    )
}

/// A flag's value refused by its parser, with a message that names the flag and what
/// was typed: printed by `main` as sylva's other errors are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FlagError(pub String);

impl std::fmt::Display for FlagError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FlagError {}

/// Why a flag's value is not a whole number in its range.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BadNumber {
    /// Not a number at all.
    NotANumber,
    /// A number outside the range (however many digits it has).
    OutOfRange,
    /// A fraction inside the range.
    NotWhole,
    /// A whole number inside the range written as a float (`1e3`): the recipe refuses
    /// floats for whole-number keys, so the flags do too.
    Float,
}

impl BadNumber {
    /// The message, naming the range.
    pub fn say(self, lo: u64, hi: u64) -> String {
        let why = match self {
            BadNumber::NotANumber => "not a number",
            BadNumber::OutOfRange => "out of range",
            BadNumber::NotWhole => "not a whole number",
            BadNumber::Float => "written as a float (write it in digits)",
        };
        format!("{why}: use a whole number in {lo}..={hi}")
    }
}

/// `s` as a whole number in `lo..=hi`: digits, `_` allowed between them.
pub fn whole_number(s: &str, lo: u64, hi: u64) -> std::result::Result<u64, BadNumber> {
    let t = s.trim().replace('_', "");
    match t.parse::<u64>() {
        Ok(n) if (lo..=hi).contains(&n) => Ok(n),
        Ok(_) => Err(BadNumber::OutOfRange),
        Err(_) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => Err(BadNumber::OutOfRange),
        Err(_) => match t.parse::<f64>() {
            Ok(x) if x.is_finite() && (x < lo as f64 || x > hi as f64) => Err(BadNumber::OutOfRange),
            Ok(x) if x.is_finite() && x.fract() != 0.0 => Err(BadNumber::NotWhole),
            Ok(x) if x.is_finite() => Err(BadNumber::Float),
            _ => Err(BadNumber::NotANumber),
        },
    }
}

/// A clap value parser for a whole number in `lo..=hi` whose every message names the
/// range (clap names the flag): a number out of the range, however long, is "out of
/// range", not "invalid digit" or "too large to fit".
pub fn whole_in<T>(
    lo: u64,
    hi: u64,
) -> impl Fn(&str) -> std::result::Result<T, String> + Clone + Send + Sync + 'static
where
    T: TryFrom<u64> + Clone + Send + Sync + 'static,
{
    move |s: &str| {
        let n = whole_number(s, lo, hi).map_err(|e| e.say(lo, hi))?;
        T::try_from(n).map_err(|_| BadNumber::OutOfRange.say(lo, hi))
    }
}

/// An image size in pixels (`--size WIDTHxHEIGHT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Size {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

/// The value parser of `--size`: `WxH`, each side in 1..=[`sylva::preview::MAX_SIZE`].
pub fn size(s: &str) -> std::result::Result<Size, FlagError> {
    let shown = quote(s);
    let max = sylva::preview::MAX_SIZE;
    let bad = || FlagError(format!("--size {shown}: expected WIDTHxHEIGHT in pixels, e.g. 1920x1080"));
    let range = || FlagError(format!("--size {shown}: width and height must each be in 1..={max}"));
    let (w, h) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
    // A side that is all digits is a number, however long: too large, not malformed.
    let side = |t: &str| {
        let t = t.trim();
        match t.parse::<u32>() {
            Ok(n) if (1..=max).contains(&n) => Ok(n),
            Ok(_) => Err(range()),
            Err(_) if !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit()) => Err(range()),
            Err(_) => Err(bad()),
        }
    };
    Ok(Size { width: side(w)?, height: side(h)? })
}

/// The value parser of `--wind`: a [`WindPreset`] name.
pub fn wind(s: &str) -> std::result::Result<WindPreset, FlagError> {
    WindPreset::from_name(s.trim()).ok_or_else(|| {
        FlagError(format!(
            "--wind {}: not a wind preset; use {} (recipe key `{}`)",
            quote(s),
            recipe::modes::one_of(WindPreset::NAMES),
            WindPreset::KEY
        ))
    })
}

/// Levels of detail from `--lod 30000,8000,2000,impostor`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Lod {
    /// Triangle budgets, LOD0 first.
    pub levels: Vec<u32>,
    /// Whether the chain ends in an impostor.
    pub impostor: bool,
}

impl Lod {
    /// The recipe overrides (`lod.levels`, `lod.impostor`).
    pub fn overrides(&self) -> [(String, toml::Value); 2] {
        let levels = self.levels.iter().map(|&n| toml::Value::Integer(n.into())).collect();
        [
            ("lod.levels".into(), toml::Value::Array(levels)),
            ("lod.impostor".into(), toml::Value::Boolean(self.impostor)),
        ]
    }
}

/// The value parser of `--lod`: budgets in [`recipe::LOD_BUDGETS`], optionally ending in
/// `impostor`. An item that is not a number, one out of range and one that is not whole
/// get their own messages, each naming `--lod` and the range. The order of the budgets
/// is the recipe's check (`lod.levels`).
pub fn lod(spec: &str) -> std::result::Result<Lod, FlagError> {
    let mut levels = Vec::new();
    let mut impostor = false;
    let (lo, hi) = (u64::from(*recipe::LOD_BUDGETS.start()), u64::from(*recipe::LOD_BUDGETS.end()));
    let shown = quote(spec);
    for (i, item) in spec.split(',').map(str::trim).enumerate() {
        let k = i + 1;
        if item.eq_ignore_ascii_case("impostor") {
            impostor = true;
        } else if impostor {
            return Err(FlagError(format!("--lod {shown}: `impostor` must come last (item {k})")));
        } else {
            let n = whole_number(item, lo, hi).map_err(|e| match e {
                BadNumber::NotANumber => FlagError(format!(
                    "--lod {shown}: item {k} (`{}`) is neither a triangle budget (a whole number in {lo}..={hi}) nor `impostor`",
                    quote(item)
                )),
                e => FlagError(format!(
                    "--lod {shown}: item {k} (`{}`) is not a triangle budget: {}",
                    quote(item),
                    e.say(lo, hi)
                )),
            })?;
            levels.push(n as u32);
        }
    }
    Ok(Lod { levels, impostor })
}

/// Checks the output paths of a run before any work: each can be written
/// ([`sylva::fsutil::check_output`]: its folder exists and is writable, it is not a
/// folder) and no two name the same file. Each pair is the flag or key that named the
/// path, for the message, and the path.
pub fn check_outputs(outputs: &[(&str, &Path)]) -> Result<()> {
    let key = |p: &Path| {
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::canonicalize(dir).ok().map(|d| d.join(p.file_name().unwrap_or_default()))
    };
    for (i, (flag, p)) in outputs.iter().enumerate() {
        sylva::fsutil::check_output(p).map_err(|e| miette::miette!("{flag}: {e}"))?;
        if let Some((other, _)) = outputs[..i].iter().find(|(_, q)| key(q).is_some() && key(q) == key(p)) {
            return Err(miette::miette!(
                "{flag} {}: the same file as {other}; every output needs a name of its own",
                p.display()
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_winds_and_lods_parse_or_name_the_flag() {
        assert_eq!(size("640x480"), Ok(Size { width: 640, height: 480 }));
        assert_eq!(size(" 8X9 ").unwrap().to_string(), "8x9");
        assert!(size("12by5").unwrap_err().0.contains("--size 12by5: expected WIDTHxHEIGHT"));
        assert!(size("0x5").unwrap_err().0.contains("1..=8192"));
        assert_eq!(wind("storm"), Ok(WindPreset::Storm));
        let e = wind("gale").unwrap_err().0;
        assert!(e.contains("--wind gale") && e.contains("none, calm, breeze or storm"), "{e}");
        assert_eq!(lod("3000, 300,impostor"), Ok(Lod { levels: vec![3000, 300], impostor: true }));
        assert!(lod("impostor,3").unwrap_err().0.contains("must come last"));
        assert!(lod("1e12").unwrap_err().0.contains("out of range"));
    }
}
