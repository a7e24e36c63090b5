//! sylva against real cpfg (issue 46): every corpus folder with a `cpfg-reference/`
//! (`../shared/corpus/cpfg`, what cpfg 6.6 wrote in batch mode, see the corpus README) is
//! derived as sylva derives it, for the model's derivation length, and compared with
//!
//! - `derived.flat.str`, module by module: names exact, parameters within 1e-5 relative
//!   (cpfg prints `%g`, six significant digits);
//! - `geometry.segments.csv`, the cylinders and cones cpfg's turtle drew, after the axis
//!   mapping sylva (x, y, z) = cpfg (z, y, −x): the same count, and every end point
//!   within 1e-4 of the bounding box diagonal. cpfg wrote them through its rayshade
//!   output, which leaves out internodes of squared length ≤ 0.00001; sylva's segments
//!   are filtered the same way before the comparison.
//!
//! Every model must match, or be listed in [`EXCEPTIONS`] (string, geometry or both, with
//! the reason; the same table is in docs/cpfg-compatibility.md, "Matching real cpfg");
//! a listed model that now matches fails the test too, so the list only shrinks.
//! Stochastic models (their string changes with the seed) are in [`STOCHASTIC`]: they
//! are grown with cpfg's generator (`seed48`/`drand48`, cpfg's call order; issue 46
//! item 9), the default for a model folder, and are held to the same rule.
//! `cargo test -p sylva --test cpfg_reference -- --nocapture` prints the table. Without the
//! corpus the test is skipped, unless `SYLVA_REQUIRE_CPFG_CORPUS` is set (`.ci/run` sets it).

#[path = "common/cpfg_corpus.rs"]
mod cpfg_corpus;

use cpfg_corpus::corpus;
use glam::DVec3;
use std::path::Path;
use sylva::recipe::Generator;

/// Relative tolerance of parameters (cpfg's `%g` keeps six significant digits).
const PARAM_TOLERANCE: f64 = 1e-5;
/// Tolerance of segment end points, as a fraction of the bounding box diagonal.
const POINT_TOLERANCE: f64 = 1e-4;

/// What differs from cpfg, per model: (folder, string differs, geometry differs, why).
/// A model not listed must match both; a listed one must still differ where listed.
const EXCEPTIONS: &[(&str, bool, bool, &str)] = &[(
    "10-manuals__11-CPFG__BackgroundScene",
    false,
    true,
    "cpfg also draws the view file's background scene (a cylinder and a cone); sylva draws the plant only",
)];

/// Stochastic models: (folder, why their string depends on the seed). They are
/// compared under cpfg's generator (`generator.random = "auto"` gives it to a model
/// folder, issue 46 item 9) with the model's own seeds, and must match like the others.
const STOCHASTIC: &[(&str, &str)] = &[
    ("10-manuals__11-CPFG__RandomMoss", "stochastic productions"),
    ("10-manuals__15-VlabTools__LeafRandom", "nran() in #defines used by productions"),
    ("11-CPFG__02-Mod-vis-3D__08-leaf-pos", "nran() in a #define used by productions"),
];

/// Folders with a `cpfg-reference/` that holds no derived string, with the reason.
const NO_REFERENCE: &[(&str, &str)] =
    &[("10-manuals__11-CPFG__Sedge", "cpfg 6.6 crashes on the model; only summary.json was written")];

/// One module as compared: a single character of the name with its parameters, so that
/// both sides split the same way whatever the module names are (`@o(1)` is `@`, `o(1)`).
#[derive(Debug, Clone, PartialEq)]
struct Token {
    ch: char,
    params: Vec<f64>,
}

impl std::fmt::Display for Token {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.ch)?;
        if !self.params.is_empty() {
            let p: Vec<String> = self.params.iter().map(|v| format!("{v}")).collect();
            write!(f, "({})", p.join(","))?;
        }
        Ok(())
    }
}

/// cpfg's flat string as tokens (blanks ignored).
fn tokens_of_text(text: &str) -> Result<Vec<Token>, String> {
    let chars: Vec<char> = text.chars().filter(|c| !c.is_whitespace()).collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let ch = chars[i];
        i += 1;
        let mut params = Vec::new();
        if chars.get(i) == Some(&'(') {
            let close = chars[i..].iter().position(|&c| c == ')').ok_or("unclosed `(`")? + i;
            let inner: String = chars[i + 1..close].iter().collect();
            for p in inner.split(',').filter(|p| !p.is_empty()) {
                params.push(p.parse::<f64>().map_err(|e| format!("parameter `{p}`: {e}"))?);
            }
            i = close + 1;
        }
        out.push(Token { ch, params });
    }
    Ok(out)
}

/// sylva's derived string as the same tokens.
fn tokens_of_string(l: &sylva::lsystem::LSystem, m: &sylva::lsystem::ModuleString) -> Vec<Token> {
    let mut out = Vec::with_capacity(m.len());
    for i in 0..m.len() {
        let (sym, params) = m.module(i);
        let name: Vec<char> = l.symbols.name(sym).chars().collect();
        for (k, &ch) in name.iter().enumerate() {
            let last = k + 1 == name.len();
            out.push(Token { ch, params: if last { params.to_vec() } else { Vec::new() } });
        }
    }
    out
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= PARAM_TOLERANCE * a.abs().max(b.abs()).max(1.0)
}

/// The first difference between two token lists, if any.
fn first_string_difference(sylva: &[Token], cpfg: &[Token]) -> Option<String> {
    for (k, (s, c)) in sylva.iter().zip(cpfg).enumerate() {
        let same = s.ch == c.ch
            && s.params.len() == c.params.len()
            && s.params.iter().zip(&c.params).all(|(a, b)| close(*a, *b));
        if !same {
            return Some(format!("module {k}: sylva `{s}`, cpfg `{c}`"));
        }
    }
    (sylva.len() != cpfg.len()).then(|| format!("sylva {} modules, cpfg {}", sylva.len(), cpfg.len()))
}

/// cpfg's cylinders and cones, mapped to sylva's axes.
fn cpfg_segments(csv: &str) -> Result<Vec<[DVec3; 2]>, String> {
    let map = |x: f64, y: f64, z: f64| DVec3::new(z, y, -x);
    let mut out = Vec::new();
    for (n, line) in csv.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 10 || !(f[0] == "cylinder" || f[0] == "cone") {
            continue;
        }
        let v: Vec<f64> = f[2..10]
            .iter()
            .map(|s| s.trim().parse::<f64>().map_err(|e| format!("line {}: `{s}`: {e}", n + 1)))
            .collect::<Result<_, _>>()?;
        out.push([map(v[1], v[2], v[3]), map(v[5], v[6], v[7])]);
    }
    Ok(out)
}

fn first_geometry_difference(sylva: &[[DVec3; 2]], cpfg: &[[DVec3; 2]]) -> Option<String> {
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for p in cpfg.iter().flatten() {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let diag = if cpfg.is_empty() { 1.0 } else { (hi - lo).length().max(1e-12) };
    let tol = POINT_TOLERANCE * diag;
    for (k, (s, c)) in sylva.iter().zip(cpfg).enumerate() {
        let d = s[0].distance(c[0]).max(s[1].distance(c[1]));
        if d > tol {
            return Some(format!(
                "segment {k}: sylva {:.4?}→{:.4?}, cpfg {:.4?}→{:.4?} (off by {:.2e} of the diagonal)",
                s[0].to_array(),
                s[1].to_array(),
                c[0].to_array(),
                c[1].to_array(),
                d / diag
            ));
        }
    }
    (sylva.len() != cpfg.len()).then(|| format!("sylva {} segments, cpfg {}", sylva.len(), cpfg.len()))
}

/// The model's L-system file, as `summary.json` names it.
fn model_file(dir: &Path) -> Option<String> {
    let summary = std::fs::read_to_string(dir.join("cpfg-reference/summary.json")).ok()?;
    let json: serde_json::Value = serde_json::from_str(&summary).ok()?;
    json.get("l")?.as_str().map(str::to_string)
}

/// What sylva grows from the model with the recipe seed `seed`: its derived string as
/// tokens and its drawn segments.
fn sylva_model(file: &Path, seed: u64) -> Result<(Vec<Token>, Vec<[DVec3; 2]>), String> {
    let sets = [("seed".to_string(), toml::Value::Integer(seed as i64))];
    let loaded = sylva::recipe::load(file.to_str().unwrap(), &sets).map_err(|e| e.to_string())?;
    let Generator::Lsystem(g) = &loaded.recipe.generator else { return Err("not an L-system".into()) };
    let mut d = sylva::pipeline::derive_lsystem(&loaded, g).map_err(|e| e.to_string())?;
    let tokens = tokens_of_string(&d.lsystem, &d.string);
    let shown =
        d.lsystem.interpretation(&d.string, &mut d.evaluator, g.max_modules).map_err(|e| e.message)?;
    let opts = sylva::pipeline::turtle_options(g, d.folder.as_ref());
    let mut segments = Vec::new();
    // The references' segments went through cpfg's rayshade output, which leaves out
    // internodes of squared length ≤ 0.00001 that its turtle draws (issue 46): compare
    // what that output would write.
    sylva::lsystem::interpret_with(&d.lsystem.symbols, &shown, &opts, &d.lsystem.source, &mut |a, b| {
        if cpfg_corpus::rayshade_writes(a, b) {
            segments.push([a, b])
        }
    })
    .map_err(|e| e.message)?;
    Ok((tokens, segments))
}

#[test]
fn corpus_models_match_real_cpfg() {
    let Some(root) = corpus() else {
        // CI has the corpus beside the repository and sets this (issue 46: mandatory there).
        assert!(
            std::env::var_os("SYLVA_REQUIRE_CPFG_CORPUS").is_none(),
            "SYLVA_REQUIRE_CPFG_CORPUS is set but the cpfg corpus is not at ../shared/corpus/cpfg"
        );
        return;
    };
    let mut dirs: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.join("cpfg-reference").is_dir())
        .collect();
    dirs.sort();
    let mut rows = Vec::new();
    let mut problems = Vec::new();
    let (mut det, mut det_string, mut det_geometry, mut det_both) = (0, 0, 0, 0);
    let (mut sto, mut sto_string, mut sto_geometry, mut sto_both) = (0, 0, 0, 0);
    for dir in &dirs {
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let reference = dir.join("cpfg-reference");
        let Ok(flat) = std::fs::read_to_string(reference.join("derived.flat.str")) else {
            match NO_REFERENCE.iter().find(|(n, _)| *n == name) {
                Some((_, why)) => rows.push(format!("| {name} | – | – | no reference: {why} |")),
                None => problems.push(format!("{name}: no derived.flat.str and not in NO_REFERENCE")),
            }
            continue;
        };
        let cpfg_tokens = tokens_of_text(&flat).unwrap_or_else(|e| panic!("{name}: derived.flat.str: {e}"));
        let csv = std::fs::read_to_string(reference.join("geometry.segments.csv")).unwrap_or_default();
        let cpfg_segs = cpfg_segments(&csv).unwrap_or_else(|e| panic!("{name}: geometry.segments.csv: {e}"));
        let file = model_file(dir).unwrap_or_else(|| panic!("{name}: summary.json names no `l`"));
        let grown = std::panic::catch_unwind(|| sylva_model(&dir.join(&file), 1));
        let (string_diff, geometry_diff) = match grown {
            Err(_) => (Some("PANIC".to_string()), Some("PANIC".to_string())),
            Ok(Err(e)) => {
                let e = e.lines().next().unwrap_or("").to_string();
                (Some(format!("does not grow: {e}")), Some("does not grow".to_string()))
            }
            Ok(Ok((tokens, segs))) => {
                (first_string_difference(&tokens, &cpfg_tokens), first_geometry_difference(&segs, &cpfg_segs))
            }
        };
        let stochastic = STOCHASTIC.iter().any(|(n, _)| *n == name);
        // A model is stochastic when another seed derives another string.
        let varies = match sylva_model(&dir.join(&file), 2) {
            Ok((tokens, _)) => match sylva_model(&dir.join(&file), 1) {
                Ok((base, _)) => first_string_difference(&tokens, &base).is_some(),
                Err(_) => false,
            },
            Err(_) => false,
        };
        let (s_ok, g_ok) = (string_diff.is_none(), geometry_diff.is_none());
        let mark = |ok: bool| if ok { "yes" } else { "no" };
        let first = string_diff.clone().or(geometry_diff.clone()).unwrap_or_default().replace('|', "\\|");
        if stochastic {
            sto += 1;
            sto_string += usize::from(s_ok);
            sto_geometry += usize::from(g_ok);
            sto_both += usize::from(s_ok && g_ok);
            rows.push(format!("| {name} (stochastic) | {} | {} | {first} |", mark(s_ok), mark(g_ok)));
            if !varies {
                problems.push(format!(
                    "{name} is listed as stochastic but its string does not vary with the seed"
                ));
            }
        } else {
            if varies {
                problems.push(format!("{name}: its string varies with the seed but it is not in STOCHASTIC"));
            }
            det += 1;
            det_string += usize::from(s_ok);
            det_geometry += usize::from(g_ok);
            det_both += usize::from(s_ok && g_ok);
            rows.push(format!("| {name} | {} | {} | {first} |", mark(s_ok), mark(g_ok)));
        }
        let listed = EXCEPTIONS.iter().find(|(n, ..)| *n == name);
        let (ls, lg) = listed.map(|&(_, s, g, _)| (s, g)).unwrap_or((false, false));
        if ls == s_ok || lg == g_ok {
            problems.push(format!(
                "{name}: string {}, geometry {}; the exceptions list it as string {}, geometry {} ({})",
                if s_ok { "matches" } else { "differs" },
                if g_ok { "matches" } else { "differs" },
                if ls { "differs" } else { "matches" },
                if lg { "differs" } else { "matches" },
                string_diff.or(geometry_diff).unwrap_or_default()
            ));
        }
    }
    println!(
        "\ndeterministic: {det} models, {det_string} strings match, {det_geometry} geometries match, {det_both} \
         both; stochastic: {sto} models, {sto_string} strings match, {sto_geometry} geometries match, \
         {sto_both} both\n"
    );
    println!("| model | string | geometry | first difference |\n|---|---|---|---|");
    for r in &rows {
        println!("{r}");
    }
    for (n, ..) in EXCEPTIONS {
        assert!(dirs.iter().any(|d| d.ends_with(n)), "exception {n} is not a corpus folder with a reference");
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
