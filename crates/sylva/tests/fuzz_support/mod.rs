//! Fuzzing support shared by `tests/fuzz_*.rs` and `examples/fuzz_campaign.rs`
//! (issue 27, `docs/robustness.md`): a seed corpus for every reader, structure-aware
//! generators, byte and token mutators, the reader calls themselves and a wall-clock
//! watchdog, so a hang is a failure and not a stuck test.
//!
//! Everything is seeded: the same seed gives the same inputs on every machine.
//!
//! [`classes`] holds the generators of issue 39's failure classes (long lines, deep
//! nesting, degenerate and many-root skeletons, absurd numbers, raised budgets,
//! duplicated glTF primitives, hostile model folders) and their in-process runner.

#![allow(dead_code)]

pub mod classes;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// SplitMix64: small, seedable, good enough to drive mutations.
#[derive(Debug, Clone)]
pub struct Rng(pub u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    pub fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 <= p
    }
    pub fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
    /// A run of 1 to `max` items of a sequence of `n > 0` (shorter where it would pass
    /// the end): its start first, then its length, drawn uniformly.
    pub fn run(&mut self, n: usize, max: usize) -> std::ops::Range<usize> {
        let i = self.below(n);
        let k = (1 + self.below(max)).min(n - i);
        i..i + k
    }
    pub fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The readers under test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Target {
    /// An L-system file (`.l`): preprocess, parse, derive, homomorphism, turtle.
    Lsystem,
    /// A recipe (`.toml`).
    Recipe,
    /// `--set key=value` overrides of a preset (first line: the preset's name).
    Set,
    /// An LST skeleton.
    Lst,
    /// A CPFG turtle string (`.str`).
    Str,
    /// A sylva JSON skeleton.
    Json,
    /// An OBJ control mesh for `check` and `subdivide`.
    Obj,
    /// A glTF (`.gltf`) or GLB for `check` (GLB when the bytes start with `glTF`).
    Gltf,
}

impl Target {
    pub const ALL: [Target; 8] = [
        Target::Lsystem,
        Target::Recipe,
        Target::Set,
        Target::Lst,
        Target::Str,
        Target::Json,
        Target::Obj,
        Target::Gltf,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Target::Lsystem => "lsystem",
            Target::Recipe => "recipe",
            Target::Set => "set",
            Target::Lst => "lst",
            Target::Str => "str",
            Target::Json => "json",
            Target::Obj => "obj",
            Target::Gltf => "gltf",
        }
    }

    /// The file extension the input is written with.
    pub fn ext(self, input: &[u8]) -> &'static str {
        match self {
            Target::Lsystem => "l",
            Target::Recipe => "toml",
            Target::Set => "set",
            Target::Lst => "lst",
            Target::Str => "str",
            Target::Json => "json",
            Target::Obj => "obj",
            Target::Gltf if input.starts_with(b"glTF") => "glb",
            Target::Gltf => "gltf",
        }
    }
}

/// The repository root (two folders above this crate).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// One seed input: where it came from (for messages) and its bytes.
#[derive(Debug, Clone)]
pub struct Seed {
    pub name: String,
    pub bytes: Vec<u8>,
    /// For L-systems from a cpfg model folder: the folder, so the mutated file can be
    /// read with its view, function and surface files.
    pub folder: Option<PathBuf>,
}

/// Seed inputs for every target.
#[derive(Debug, Clone, Default)]
pub struct Corpus {
    pub seeds: Vec<(Target, Seed)>,
}

impl Corpus {
    pub fn of(&self, t: Target) -> Vec<&Seed> {
        self.seeds.iter().filter(|(k, _)| *k == t).map(|(_, s)| s).collect()
    }
}

/// Presets that are cheap to grow, one per generator kind, used as `--set` bases.
pub const SET_BASES: [&str; 6] =
    ["lsys-binary-tree", "lsys-honda-a", "wp-palm", "colonize-shrub", "mig-a", "mgv-a"];

/// Builds the corpus: the presets' `.l` files and recipes, up to `cpfg_models` models of
/// `../shared/corpus/cpfg` (when present), and skeletons, strings and meshes that sylva
/// itself writes for a small tree, plus hand-written edge cases.
pub fn corpus(cpfg_models: usize) -> Corpus {
    let root = repo_root();
    let mut c = Corpus::default();
    let mut push = |t: Target, name: String, bytes: Vec<u8>, folder: Option<PathBuf>| {
        c.seeds.push((t, Seed { name, bytes, folder }))
    };
    let mut names: Vec<PathBuf> = std::fs::read_dir(root.join("presets/lsystem"))
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    names.sort();
    for p in names.iter().filter(|p| p.extension().is_some_and(|e| e == "l")) {
        if let Ok(b) = std::fs::read(p) {
            push(Target::Lsystem, p.display().to_string(), b, None);
        }
    }
    let mut recipes: Vec<PathBuf> = std::fs::read_dir(root.join("presets"))
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    recipes.sort();
    for p in recipes.iter().filter(|p| p.extension().is_some_and(|e| e == "toml")) {
        let stem = p.file_stem().unwrap_or_default().to_string_lossy();
        if stem.starts_with("curves-") {
            continue;
        }
        if let Ok(b) = std::fs::read(p) {
            push(Target::Recipe, p.display().to_string(), b, None);
        }
    }
    let cpfg = root.join("../shared/corpus/cpfg");
    let mut models: Vec<PathBuf> = std::fs::read_dir(&cpfg)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
        .unwrap_or_default();
    models.sort();
    for dir in models.into_iter().take(cpfg_models) {
        let mut ls: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).collect())
            .unwrap_or_default();
        ls.sort();
        for p in ls {
            let ext = p.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
            let Ok(b) = std::fs::read(&p) else { continue };
            if b.len() > 200_000 {
                continue;
            }
            match ext.as_str() {
                "l" => push(Target::Lsystem, p.display().to_string(), b, Some(dir.clone())),
                "str" => push(Target::Str, p.display().to_string(), b, None),
                _ => {}
            }
        }
    }
    for base in SET_BASES {
        push(Target::Set, format!("set:{base}"), format!("{base}\n").into_bytes(), None);
    }
    // What sylva writes for a small tree: the round trip of every skeleton format.
    if let Ok(loaded) = sylva::recipe::load(
        "lsys-binary-tree",
        &[
            ("generator.iterations".into(), toml::Value::Integer(4)),
            ("output.textures".into(), toml::Value::String("none".into())),
        ],
    ) {
        if let Ok(grown) = sylva::pipeline::grow(&loaded) {
            push(
                Target::Lst,
                "binary-tree.lst".into(),
                sylva::export::skeleton::to_lst(&grown.skeleton).into(),
                None,
            );
            push(
                Target::Json,
                "binary-tree.skel.json".into(),
                sylva::export::skeleton::to_json(&grown.skeleton).into(),
                None,
            );
            let dir = std::env::temp_dir().join(format!("sylva-fuzz-seed-{}", std::process::id()));
            let _ = std::fs::create_dir_all(&dir);
            for ext in ["obj", "glb", "gltf"] {
                let p = dir.join(format!("seed.{ext}"));
                if sylva::export::write(&grown.model, &p).is_ok() {
                    if let Ok(b) = std::fs::read(&p) {
                        let t = if ext == "obj" { Target::Obj } else { Target::Gltf };
                        // Small meshes only: the checker is quadratic-free but debug is slow.
                        if b.len() < 600_000 {
                            push(t, format!("binary-tree.{ext}"), b, None);
                        }
                    }
                }
            }
            let _ = std::fs::remove_dir_all(&dir);
        }
        if let Ok(ls) = sylva::lsystem::LSystem::parse(
            "t.l",
            "Lsystem: 1\nAxiom: F(1)[+(30)F(0.5)A(1,2)]-(20)F(2)\nendlsystem\n",
            &[],
        ) {
            if let Ok(m) = ls.derive(&sylva::lsystem::DeriveOptions { steps: 0, budget: 100, seed: 0 }) {
                push(
                    Target::Str,
                    "small.str".into(),
                    sylva::import::cpfg_str::format(&ls.symbols, &m).into(),
                    None,
                );
            }
        }
    }
    push(Target::Lst, "sample.lst".into(), LST_SAMPLE.as_bytes().to_vec(), None);
    push(Target::Obj, "cube.obj".into(), OBJ_CUBE.as_bytes().to_vec(), None);
    push(Target::Obj, "tetra.obj".into(), OBJ_TETRA.as_bytes().to_vec(), None);
    push(
        Target::Str,
        "turtle.str".into(),
        b"F(1)+(30)[-(30)F(0.5)]A(1,2)\n!(0.2)F(2)[&(10)F]\n".to_vec(),
        None,
    );
    push(Target::Json, "fork.skel.json".into(), JSON_FORK.as_bytes().to_vec(), None);
    c
}

/// The Pieterse2012 sample (Fig. 4.6) shape.
pub const LST_SAMPLE: &str =
    "LST 0.1\nCylinder(0.5, 0.4, 5)\nMovRel3f(0, 5, 0)\nSB()\nRotRel3f(0.5, 0, 0, 1)\n\
Cylinder(0.3, 0.2, 3)\nMovRel3f(0, 3, 0)\nSB()\nRotRel3f(-0.6, 1, 0, 0)\nCylinder(0.1, 0.05, 1)\nEB()\nEB()\n\
SB()\nRotRel3f(-0.7, 0, 0, 1)\nCylinder(0.3, 0.2, 2)\nEB()\nCylinder(0.4, 0.3, 4)\n";

pub const OBJ_CUBE: &str = "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n\
vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
f 1/1 4/4 3/3 2/2\nf 5/1 6/2 7/3 8/4\nf 1/1 2/2 6/3 5/4\nf 2/1 3/2 7/3 6/4\nf 3/1 4/2 8/3 7/4\nf 4/1 1/2 5/3 8/4\n\
t crease 2/1 0 1 2.5\nt corner 1/1 6 3\n";

pub const OBJ_TETRA: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";

pub const JSON_FORK: &str = r#"{"format":"sylva-skeleton","version":1,"nodes":[
{"position":[0,0,0],"radius":0.1,"parent":null},
{"position":[0,1,0],"radius":0.08,"parent":0,"up":[1,0,0],"order":0},
{"position":[0,2,0],"radius":0.05,"parent":1},
{"position":[0.7,1.7,0],"radius":0.04,"parent":1,"order":1,"material":2}],
"organs":[{"kind":"leaf","node":2,"position":[0,2,0],"heading":[0,1,0],"up":[1,0,0],"size":0.2},
{"kind":"polygon","vertices":[[0,0,0],[1,0,0],[0,1,0]],"node":3,"position":[0.7,1.7,0],"heading":[1,0,0],"up":[0,0,1],"size":1}]}"#;

// ---------------------------------------------------------------------------------------
// Mutators

/// Values that break parsers and the arithmetic behind them.
pub const NASTY_NUMBERS: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e308",
    "-1e308",
    "1e-308",
    "3.4e38",
    "3.5e38",
    "1e39",
    "nan",
    "inf",
    "-inf",
    "4294967295",
    "4294967296",
    "65535",
    "65536",
    "2147483647",
    "9223372036854775807",
    "18446744073709551615",
    "99999999999999999999999",
    "1e9",
    "1e6",
    "100000",
    "1e-30",
    "0.0000001",
    "-1e-300",
    "1.",
    ".5",
    "1e",
    "0x10",
    "",
    "1,2",
    "2.5e+400",
];

/// Tokens of the formats: inserting them makes structurally new inputs.
const LSYS_TOKENS: &[&str] = &[
    "[",
    "]",
    "F",
    "f",
    "+",
    "-",
    "&",
    "^",
    "/",
    "\\",
    "|",
    "$",
    "%",
    "!",
    "#",
    ";",
    ",",
    "{",
    "}",
    ".",
    "~l",
    "@O",
    "@o",
    "?P(0,0,0)",
    "?E(1)",
    "?(2,0.5)",
    "A",
    "B(x)",
    "A(x,y)",
    "-->",
    "<",
    ">",
    ":",
    "*",
    "(",
    ")",
    "x",
    "x*2",
    "1/0",
    "x^1e9",
    "ran(1)",
    "nran(0,1)",
    "func(1,x)",
    "stop(1)",
    "while (1) { x = x + 1; }",
    "{ x = x * 2; }",
    "array q[16777216];",
    "array q[4096][4096];",
    "Lsystem: 1\n",
    "Lsystem: 2\n",
    "endlsystem\n",
    "Axiom: ",
    "derivation length: ",
    "decomposition\n",
    "homomorphism\n",
    "maximum depth: ",
    "ignore: ",
    "consider: ",
    "#define ",
    "#include \"x\"",
    "#if 1\n",
    "#endif\n",
    "#define A A A\n",
    "\n",
    " ",
    "A --> AA\n",
    "A --> A[A]A\n",
    "F --> FF\n",
    "A --> B\nB --> A\n",
    "ring L-system: 1\n",
    "Start: {}\n",
    "StartEach: { }\n",
];

const LST_TOKENS: &[&str] = &[
    "SB()",
    "EB()",
    "MovRel3f(0, 1, 0)",
    "RotRel3f(0.5, 0, 0, 1)",
    "Cylinder(1, 0.5, 2)",
    "(",
    ")",
    ",",
    "\n",
    " ",
    "LST 0.1\n",
    "Cylinder(0,0,0)",
    "MovRel3f(1e308,0,0)",
    "RotRel3f(1e300,1,1,1)",
    "Cylinder(1e30,1e30,1e30)",
    "SB() SB() SB() SB()",
    "EB() EB()",
];

const JSON_TOKENS: &[&str] = &[
    "{",
    "}",
    "[",
    "]",
    ",",
    ":",
    "null",
    "true",
    "\"parent\"",
    "\"position\"",
    "\"radius\"",
    "\"nodes\"",
    "\"organs\"",
    "\"up\"",
    "\"order\"",
    "\"material\"",
    "\"kind\"",
    "\"vertices\"",
    "\"polygon\"",
    "\"surface\"",
    "\"name\"",
    "\"leaf\"",
    "0",
    "1",
    "-1",
    "[0,0,0]",
    "[1e38,1e38,1e38]",
    "{\"position\":[0,1,0],\"radius\":1,\"parent\":0}",
    "[[[[[[[[[[[[[[[[",
    "\"\\u0000\"",
];

const OBJ_TOKENS: &[&str] = &[
    "v 0 0 0\n",
    "v 1e38 1e38 1e38\n",
    "vt 0 0\n",
    "vn 0 0 1\n",
    "f 1 2 3\n",
    "f 1 2 3 4\n",
    "f -1 -2 -3\n",
    "f 1/1/1 2/2/2 3/3/3\n",
    "f 1 1 1\n",
    "f 4294967295 1 2\n",
    "t crease 2/1 0 1 1e30\n",
    "t corner 1/1 0 -1\n",
    "t crease 4294967295/1 0 1\n",
    "t interpolateboundary 1/0 2\n",
    "t creasemethod 0/0/1 chaikin\n",
    "f 1 2\n",
    "#",
    "/",
    "\n",
    " ",
];

const TOML_TOKENS: &[&str] = &[
    "[mesh]\n",
    "[generator]\n",
    "[refine]\n",
    "levels = 6\n",
    "sides = 1024\n",
    "method = \"quad\"\n",
    "method = \"hull\"\n",
    "method = \"sweep\"\n",
    "iterations = 40\n",
    "max_modules = 1\n",
    "type = \"import\"\n",
    "file = \"x.lst\"\n",
    "file = \"../../../../etc/passwd\"\n",
    "=",
    "\"",
    "[",
    "]",
    "\n",
    "seed = -1\n",
    "bark_size = 4096\n",
    "preview_size = 8192\n",
    "decollide = true\n",
    "clear = true\n",
    "[fit.clear]\n",
    "max_rounds = 1000\n",
    "[lod]\n",
    "levels = [30000, 8000]\n",
    "[wind]\n",
    "preset = \"storm\"\n",
];

/// Interesting `--set` keys (besides the base recipe's own).
pub const SET_KEYS: &[&str] = &[
    "generator.iterations",
    "generator.max_modules",
    "generator.angle",
    "generator.step",
    "generator.width",
    "generator.width_factor",
    "generator.view",
    "mesh.method",
    "mesh.sides",
    "mesh.tips",
    "mesh.base",
    "mesh.decollide",
    "mesh.clear",
    "refine.levels",
    "refine.scheme",
    "refine.limit",
    "seed",
    "output.preview_size",
    "output.textures",
    "output.compress",
    "textures.bark_size",
    "textures.atlas_size",
    "textures.scale",
    "leaves.mode",
    "leaves.per_card",
    "wind.preset",
    "wind.max_joints",
    "wind.fps",
    "wind.clip_seconds",
    "lod.levels",
    "lod.impostor",
    "fit.decollide.max_rounds",
    "fit.clear.max_rounds",
    "fit.clear.max_pairs",
    "fit.clear.max_faces",
    "mesh.tube.segments",
    "mesh.hull.max_segments",
    "generator.levels",
    "generator.points",
    "generator.radius",
    "generator.kill_distance",
    "generator.influence_radius",
    "generator.segment_length",
    "generator.max_iterations",
    "generator.shape",
    "generator.scale",
    "generator.n",
    "generator.nodes",
    "generator.k",
    "generator.ratio",
    "generator.base_size",
    "generator.leaves",
    "generator.define.N",
    "generator.environment.program",
    "generator.environment.radius",
];

const SET_VALUES: &[&str] = &[
    "0",
    "1",
    "-1",
    "2",
    "3",
    "6",
    "7",
    "12",
    "64",
    "1024",
    "65536",
    "4294967295",
    "9223372036854775807",
    "1e9",
    "1e30",
    "-1e30",
    "0.5",
    "nan",
    "inf",
    "-inf",
    "true",
    "false",
    "\"\"",
    "\"x\"",
    "[1, 2, 3]",
    "[]",
    "{}",
    "{a = 1}",
    "tube",
    "hull",
    "sweep",
    "quad",
    "none",
    "auto",
    "flat",
    "round",
    "storm",
    "cards",
    "instanced",
    "honda81",
    "catmull-clark",
    "loop",
    "\"meshopt\"",
    "[30000, 8000, 2000]",
    "1e-9",
    "0.000001",
    "100000000",
    "=",
    "x=y",
    "[[[[[[[[[[",
    "\"\\u0000\"",
];

/// Mutations stop growing an input past this many bytes (a mutated input is not meant
/// to test the machine's memory, only the readers' budgets).
pub const MAX_INPUT: usize = 1 << 21;

/// Splits text into tokens: runs of identifier characters, numbers, whitespace, and
/// single other characters.
fn tokens(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let class = |c: u8| -> u8 {
            if c.is_ascii_alphabetic() || c == b'_' {
                0
            } else if c.is_ascii_digit() || c == b'.' {
                1
            } else if c.is_ascii_whitespace() {
                2
            } else {
                3
            }
        };
        let k = class(c);
        let mut j = i + 1;
        if k != 3 {
            while j < b.len() && (class(b[j]) == k || (k == 0 && class(b[j]) == 1)) {
                j += 1;
            }
        } else {
            while j < b.len() && !text.is_char_boundary(j) {
                j += 1;
            }
        }
        out.push(&text[i..j]);
        i = j;
    }
    out
}

fn token_pool(t: Target) -> &'static [&'static str] {
    match t {
        Target::Lsystem => LSYS_TOKENS,
        Target::Lst => LST_TOKENS,
        Target::Json => JSON_TOKENS,
        Target::Obj => OBJ_TOKENS,
        Target::Recipe => TOML_TOKENS,
        Target::Str => LSYS_TOKENS,
        Target::Set => SET_VALUES,
        Target::Gltf => JSON_TOKENS,
    }
}

/// The indices of the tokens whose first byte passes `first` (digits: the numbers;
/// letters: the identifiers).
fn starting_with<S: AsRef<str>>(toks: &[S], first: fn(&u8) -> bool) -> Vec<usize> {
    (0..toks.len()).filter(|&i| toks[i].as_ref().as_bytes().first().is_some_and(first)).collect()
}

/// One to `max_ops` token-level mutations of `text`: insert, delete, duplicate or swap
/// tokens, replace numbers by nasty ones, nest brackets deeply, repeat a line.
pub fn mutate_text(rng: &mut Rng, text: &str, t: Target, max_ops: usize) -> String {
    let mut toks: Vec<String> = tokens(text).into_iter().map(str::to_string).collect();
    let ops = 1 + rng.below(max_ops.max(1));
    for _ in 0..ops {
        let n = toks.len();
        if toks.iter().map(String::len).sum::<usize>() > MAX_INPUT {
            break;
        }
        match rng.below(12) {
            0 if n > 0 => {
                let i = rng.below(n);
                toks.remove(i);
            }
            1 if n > 0 => {
                // Delete a run.
                toks.drain(rng.run(n, 16));
            }
            2 if n > 0 => {
                // Duplicate a run (a repeated production, a doubled successor).
                let run = rng.run(n, 24);
                let i = run.start;
                let run: Vec<String> = toks[run].to_vec();
                let len: usize = run.iter().map(String::len).sum::<usize>().max(1);
                let times = if rng.chance(0.1) { 2 + rng.below(200) } else { 1 };
                let times = times.min(MAX_INPUT / len).max(1);
                for _ in 0..times {
                    toks.splice(i..i, run.iter().cloned());
                }
            }
            3 | 4 => {
                let nums: Vec<usize> = starting_with(&toks, u8::is_ascii_digit);
                if let Some(&i) = (!nums.is_empty()).then(|| rng.pick(&nums)) {
                    toks[i] = if rng.chance(0.5) {
                        rng.pick(NASTY_NUMBERS).to_string()
                    } else {
                        let v: f64 = toks[i].parse().unwrap_or(1.0);
                        let f = [10.0, 100.0, 1e4, -1.0, 0.0, 1e-9, 2.0, 1e12][rng.below(8)];
                        format!("{}", v * f)
                    };
                }
            }
            5 | 6 => {
                let i = rng.below(n + 1);
                toks.insert(i, rng.pick(token_pool(t)).to_string());
            }
            7 => {
                // Deep brackets.
                let i = rng.below(n + 1);
                let depth = [8, 100, 1000, 20_000][rng.below(4)];
                let (o, c) = match t {
                    Target::Json | Target::Gltf => ("[", "]"),
                    Target::Lst => ("SB() ", "EB() "),
                    _ => ("[", "]"),
                };
                let mut s = o.repeat(depth);
                if rng.chance(0.7) {
                    s.push_str(&c.repeat(depth));
                }
                toks.insert(i, s);
            }
            8 if n > 1 => {
                let (a, b) = (rng.below(n), rng.below(n));
                toks.swap(a, b);
            }
            9 if n > 0 => {
                // Replace an identifier by another of the file.
                let ids: Vec<usize> = starting_with(&toks, u8::is_ascii_alphabetic);
                if ids.len() > 1 {
                    let a = *rng.pick(&ids);
                    let b = *rng.pick(&ids);
                    toks[a] = toks[b].clone();
                }
            }
            10 if n > 0 => {
                // Repeat a whole line (a production) many times.
                let joined: String = toks.concat();
                let lines: Vec<&str> = joined.split_inclusive('\n').collect();
                if !lines.is_empty() {
                    let li = rng.below(lines.len());
                    let times = [2, 10, 1000][rng.below(3)].min(MAX_INPUT / lines[li].len().max(1)).max(1);
                    let mut out = String::new();
                    for (k, l) in lines.iter().enumerate() {
                        out.push_str(l);
                        if k == li {
                            for _ in 0..times {
                                out.push_str(l);
                            }
                        }
                    }
                    toks = tokens(&out).into_iter().map(str::to_string).collect();
                }
            }
            _ if rng.chance(0.3) => {
                let s: String = toks.concat();
                let b = mutate_bytes(rng, s.as_bytes(), 1);
                toks = vec![String::from_utf8_lossy(&b).into_owned()];
            }
            _ => {
                // Replace a number by a nearby one (a step count, an angle, a radius).
                let nums: Vec<usize> = starting_with(&toks, u8::is_ascii_digit);
                if !nums.is_empty() {
                    let i = *rng.pick(&nums);
                    let v: f64 = toks[i].parse().unwrap_or(1.0);
                    toks[i] = format!("{}", (v * (0.5 + rng.unit() * 2.0) * 1000.0).round() / 1000.0);
                }
            }
        }
    }
    let mut out = toks.concat();
    if out.len() > MAX_INPUT {
        let mut k = MAX_INPUT;
        while !out.is_char_boundary(k) {
            k -= 1;
        }
        out.truncate(k);
    }
    out
}

/// Byte-level mutations: flip bits, insert, delete, duplicate and overwrite bytes with
/// boundary values.
pub fn mutate_bytes(rng: &mut Rng, data: &[u8], max_ops: usize) -> Vec<u8> {
    let mut b = data.to_vec();
    let ops = 1 + rng.below(max_ops.max(1));
    for _ in 0..ops {
        let n = b.len();
        match rng.below(7) {
            0 if n > 0 => {
                let i = rng.below(n);
                b[i] ^= 1 << rng.below(8);
            }
            1 => {
                let i = rng.below(n + 1);
                b.insert(i, rng.next() as u8);
            }
            2 if n > 0 => {
                b.drain(rng.run(n, 64));
            }
            3 if n > 0 => {
                let run = rng.run(n, 64);
                let i = run.start;
                let run = b[run].to_vec();
                b.splice(i..i, run);
            }
            4 if n >= 4 => {
                // A little-endian boundary u32 (GLB lengths, counts).
                let i = rng.below(n - 3);
                let v: u32 = *rng.pick(&[0, 1, 0x7fff_ffff, 0xffff_ffff, 0x8000_0000, 0xffff, 12, 20]);
                b[i..i + 4].copy_from_slice(&v.to_le_bytes());
            }
            5 if n > 0 => {
                let i = rng.below(n);
                b[i] = *rng.pick(&[0u8, 0xff, b'(', b')', b'[', b']', b'{', b'}', b'"', b'\n', b'-', b'9']);
            }
            _ if n > 0 => {
                b.truncate(rng.below(n));
            }
            _ => {}
        }
    }
    b
}

/// Mutates a glTF or GLB seed: JSON-aware edits of the document (numbers, indices,
/// counts, offsets) and byte edits of the binary chunk.
pub fn mutate_gltf(rng: &mut Rng, data: &[u8]) -> Vec<u8> {
    let glb = data.starts_with(b"glTF") && data.len() >= 20;
    if !glb {
        return mutate_text(rng, &String::from_utf8_lossy(data), Target::Gltf, 4).into_bytes();
    }
    let json_len = u32::from_le_bytes([data[12], data[13], data[14], data[15]]) as usize;
    if 20 + json_len > data.len() || rng.chance(0.2) {
        return mutate_bytes(rng, data, 4);
    }
    let json = String::from_utf8_lossy(&data[20..20 + json_len]).into_owned();
    let bin = &data[20 + json_len..];
    let mut j = json;
    for _ in 0..1 + rng.below(3) {
        // Replace a number of the document by a nasty one (counts, offsets, indices).
        let toks: Vec<&str> = tokens(&j);
        let nums: Vec<usize> = starting_with(&toks, u8::is_ascii_digit);
        if nums.is_empty() {
            break;
        }
        let i = *rng.pick(&nums);
        let v = *rng.pick(&[
            "0",
            "1",
            "3",
            "4294967295",
            "18446744073709551615",
            "9007199254740993",
            "100000000",
            "2",
            "-1",
            "5126",
            "5125",
            "5123",
            "5121",
            "4",
        ]);
        let mut out = String::new();
        for (k, t) in toks.iter().enumerate() {
            out.push_str(if k == i { v } else { t });
        }
        j = out;
    }
    let mut bin = bin.to_vec();
    if rng.chance(0.3) && bin.len() > 8 {
        let tail = mutate_bytes(rng, &bin[8..], 2);
        bin.truncate(8);
        bin.extend(tail);
    }
    glb_container(j.into_bytes(), &bin)
}

/// A GLB file: the 12-byte header, the JSON chunk (padded with spaces to 4 bytes) and
/// `rest` as it is (a [`bin_chunk`], or the bytes a mutation left of one); the header's
/// total length counts them all.
pub fn glb_container(mut json: Vec<u8>, rest: &[u8]) -> Vec<u8> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + rest.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&json);
    out.extend_from_slice(rest);
    out
}

/// A GLB BIN chunk: its 8-byte header and `bin` padded with zeros to 4 bytes.
pub fn bin_chunk(mut bin: Vec<u8>) -> Vec<u8> {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut out = Vec::with_capacity(8 + bin.len());
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

// ---------------------------------------------------------------------------------------
// Structure-aware generators

fn num(rng: &mut Rng) -> String {
    if rng.chance(0.15) {
        return rng.pick(NASTY_NUMBERS).to_string();
    }
    let v = (rng.unit() - 0.3) * [1.0, 10.0, 1000.0, 1e6][rng.below(4)];
    format!("{v}")
}

/// An LST file of random operations: mostly well formed, with nasty numbers, deep
/// nesting and unbalanced brackets now and then.
pub fn generate_lst(rng: &mut Rng, max_ops: usize) -> String {
    let mut s = String::from("LST 0.1\n");
    let n = rng.below(max_ops.max(1)) + 1;
    let mut depth = 0usize;
    for _ in 0..n {
        match rng.below(10) {
            0 | 1 => {
                s.push_str("SB()\n");
                depth += 1;
            }
            2 | 3 if depth > 0 || rng.chance(0.05) => {
                s.push_str("EB()\n");
                depth = depth.saturating_sub(1);
            }
            4 | 5 => s.push_str(&format!("MovRel3f({}, {}, {})\n", num(rng), num(rng), num(rng))),
            6 => s.push_str(&format!("RotRel3f({}, {}, {}, {})\n", num(rng), num(rng), num(rng), num(rng))),
            _ => {
                let (a, b, l) = (rng.unit(), rng.unit(), rng.unit() * 3.0);
                if rng.chance(0.8) {
                    s.push_str(&format!("Cylinder({a}, {b}, {l})\nMovRel3f(0, {l}, 0)\n"));
                } else {
                    s.push_str(&format!("Cylinder({}, {}, {})\n", num(rng), num(rng), num(rng)));
                }
            }
        }
    }
    if rng.chance(0.9) {
        for _ in 0..depth {
            s.push_str("EB()\n");
        }
    }
    s
}

/// A JSON skeleton with random parents (in range, forward, self, out of range),
/// random numbers and organs.
pub fn generate_json(rng: &mut Rng, max_nodes: usize) -> String {
    let n = rng.below(max_nodes.max(1)) + 1;
    let mut nodes = Vec::new();
    for i in 0..n {
        let parent = if i == 0 || rng.chance(0.05) {
            "null".to_string()
        } else if rng.chance(0.9) {
            (rng.below(i)).to_string()
        } else {
            [i, i + 1, n, 4294967294, 4294967295, 0].map(|v| v.to_string())[rng.below(6)].clone()
        };
        let p = if rng.chance(0.9) {
            format!("[{},{},{}]", rng.unit(), i as f64 * 0.5, rng.unit())
        } else {
            format!("[{},{},{}]", num(rng), num(rng), num(rng))
        };
        let r = if rng.chance(0.9) { format!("{}", rng.unit() * 0.1) } else { num(rng) };
        let mut node = format!("{{\"position\":{p},\"radius\":{r},\"parent\":{parent}");
        if rng.chance(0.3) {
            node.push_str(&format!(",\"up\":[{},{},{}]", num(rng), num(rng), num(rng)));
        }
        if rng.chance(0.2) {
            node.push_str(&format!(",\"order\":{}", rng.below(70000)));
        }
        node.push('}');
        nodes.push(node);
    }
    let mut organs = Vec::new();
    for _ in 0..rng.below(4) {
        let kind = *rng.pick(&["leaf", "sphere", "disc", "polygon", "surface", "cone"]);
        let extra = match kind {
            "polygon" => {
                let k = rng.below(6);
                let v: Vec<String> =
                    (0..k).map(|_| format!("[{},{},{}]", num(rng), num(rng), num(rng))).collect();
                format!(",\"vertices\":[{}]", v.join(","))
            }
            "surface" => ",\"name\":\"x\"".into(),
            _ => String::new(),
        };
        let node = if rng.chance(0.8) { rng.below(n).to_string() } else { "null".into() };
        organs.push(format!(
            "{{\"kind\":\"{kind}\"{extra},\"node\":{node},\"position\":[{},{},{}],\"heading\":[{},1,0],\"up\":[1,{},0],\"size\":{}}}",
            num(rng),
            num(rng),
            num(rng),
            num(rng),
            num(rng),
            num(rng)
        ));
    }
    format!(
        "{{\"format\":\"sylva-skeleton\",\"version\":1,\"nodes\":[{}],\"organs\":[{}]}}",
        nodes.join(","),
        organs.join(",")
    )
}

/// An L-system built from the language's pieces: productions with contexts,
/// conditions, statements, stochastic weights, decomposition, homomorphism and
/// recursion.
pub fn generate_lsystem(rng: &mut Rng) -> String {
    let syms = ["A", "B", "C", "F", "X"];
    let module = |rng: &mut Rng| -> String {
        let s = *rng.pick(&syms);
        match rng.below(3) {
            0 => s.to_string(),
            1 => format!("{s}(x)"),
            _ => format!("{s}({})", num(rng)),
        }
    };
    let successor = |rng: &mut Rng| -> String {
        let mut out = String::new();
        for _ in 0..1 + rng.below(8) {
            match rng.below(8) {
                0 => out.push('['),
                1 => out.push(']'),
                2 => out.push_str(&format!("+({})", num(rng))),
                3 => out.push_str("F(x*0.9)"),
                _ => {
                    let s = *rng.pick(&syms);
                    out.push_str(&format!("{s}(x+1)"));
                }
            }
        }
        out
    };
    let mut s = String::new();
    if rng.chance(0.3) {
        s.push_str(&format!("#define N {}\n", rng.below(12)));
    }
    s.push_str("Lsystem: 1\n");
    let steps = if rng.chance(0.1) { rng.pick(NASTY_NUMBERS).to_string() } else { rng.below(10).to_string() };
    s.push_str(&format!("derivation length: {steps}\n"));
    if rng.chance(0.2) {
        s.push_str("ignore: +-\n");
    }
    if rng.chance(0.2) {
        s.push_str("Start: { i = 0; }\n");
    }
    s.push_str(&format!("Axiom: {}{}\n", module(rng), module(rng)));
    for _ in 0..1 + rng.below(5) {
        let pred = format!("{}(x)", rng.pick(&syms));
        let ctx = match rng.below(5) {
            0 => format!("{} < ", module(rng)),
            _ => String::new(),
        };
        let rctx = if rng.chance(0.2) { format!(" > {}", module(rng)) } else { String::new() };
        let cond = match rng.below(4) {
            0 => " : x < 5".to_string(),
            1 => " : { i = i + 1; } x > 0".to_string(),
            _ => String::new(),
        };
        let prob = if rng.chance(0.15) { format!(" : {}", num(rng)) } else { String::new() };
        s.push_str(&format!("{ctx}{pred}{rctx}{cond} --> {}{prob}\n", successor(rng)));
    }
    if rng.chance(0.3) {
        s.push_str("decomposition\n");
        if rng.chance(0.5) {
            s.push_str(&format!("maximum depth: {}\n", [1, 5, 50, 10000][rng.below(4)]));
        }
        s.push_str(&format!("C(x) --> {}\n", successor(rng)));
    }
    if rng.chance(0.4) {
        s.push_str("homomorphism\n");
        if rng.chance(0.5) {
            s.push_str(&format!("maximum depth: {}\n", [1, 5, 50, 10000][rng.below(4)]));
        }
        s.push_str(&format!("X(x) --> {}\n", successor(rng)));
        s.push_str("A(x) --> F(x)\n");
    }
    s.push_str("endlsystem\n");
    s
}

/// An OBJ mesh: a grid of quads or triangles with random indices now and then.
pub fn generate_obj(rng: &mut Rng) -> String {
    let k = 2 + rng.below(5);
    let mut s = String::new();
    for i in 0..k {
        for j in 0..k {
            if rng.chance(0.05) {
                s.push_str(&format!("v {} {} {}\n", num(rng), num(rng), num(rng)));
            } else {
                s.push_str(&format!("v {i} {j} {}\n", rng.unit()));
            }
        }
    }
    let nv = (k * k) as i64;
    for i in 0..k - 1 {
        for j in 0..k - 1 {
            let a = (i * k + j + 1) as i64;
            let (b, c, d) = (a + 1, a + k as i64 + 1, a + k as i64);
            let quad = rng.chance(0.5);
            let mut f = |x: i64| {
                if rng.chance(0.03) {
                    [0, -1, nv + 1, -nv - 1, 4294967297][rng.below(5)]
                } else {
                    x
                }
            };
            if quad {
                s.push_str(&format!("f {} {} {} {}\n", f(a), f(b), f(c), f(d)));
            } else {
                s.push_str(&format!("f {} {} {}\nf {} {} {}\n", f(a), f(b), f(c), f(a), f(c), f(d)));
            }
        }
    }
    if rng.chance(0.3) {
        s.push_str(&format!("t crease 2/1 0 1 {}\n", num(rng)));
    }
    if rng.chance(0.2) {
        s.push_str(&format!("t corner 1/1 {} {}\n", rng.below(k * k + 2), num(rng)));
    }
    s
}

/// `--set` lines for a base preset: keys of the recipe and the list above, values from
/// the nasty list or scaled numbers.
pub fn generate_set(rng: &mut Rng, base: &str) -> String {
    let mut s = format!("{base}\n");
    // The base recipe's own keys with plausible (scaled) values most of the time, so
    // the generators and meshers run with them; any key with any value otherwise.
    let own = base_keys(base);
    for _ in 0..1 + rng.below(3) {
        if !own.is_empty() && rng.chance(0.7) {
            let (key, v) = rng.pick(&own).clone();
            let value = match v {
                toml::Value::Integer(i) => {
                    let f = [0i64, 1, 2, 3, 10, 100, 1000, -1][rng.below(8)];
                    format!("{}", i.saturating_mul(f).max(if rng.chance(0.8) { 0 } else { i64::MIN }))
                }
                toml::Value::Float(x) => {
                    format!("{:?}", x * [0.0, 0.5, 2.0, 10.0, 1000.0, -1.0, 1e-6][rng.below(7)])
                }
                toml::Value::Boolean(b) => format!("{}", !b),
                toml::Value::String(_) => rng.pick(SET_VALUES).to_string(),
                other => other.to_string(),
            };
            s.push_str(&format!("{key}={value}\n"));
            continue;
        }
        let key = *rng.pick(SET_KEYS);
        let value = if rng.chance(0.7) { rng.pick(SET_VALUES).to_string() } else { num(rng) };
        if rng.chance(0.01) {
            s.push_str(&format!("{key}\n"));
        } else {
            s.push_str(&format!("{key}={value}\n"));
        }
    }
    s
}

/// The scalar keys of a preset's recipe (`mesh.sides` = 8, …), for `--set` inputs.
pub fn base_keys(base: &str) -> Vec<(String, toml::Value)> {
    fn walk(prefix: &str, v: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
        match v {
            toml::Value::Table(t) => {
                for (k, v) in t {
                    let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                    walk(&key, v, out);
                }
            }
            toml::Value::Array(_) | toml::Value::Datetime(_) => {}
            other => out.push((prefix.to_string(), other.clone())),
        }
    }
    let mut out = Vec::new();
    if let Ok(l) = sylva::recipe::load(base, &[]) {
        if let Ok(v) = toml::Value::try_from(&l.recipe) {
            walk("", &v, &mut out);
        }
    }
    out.retain(|(k, _)| !k.starts_with("output.file") && k != "name" && k != "description");
    out
}

/// A fresh input for `t`: a mutated seed or (for some targets) a generated one.
pub fn next_input(rng: &mut Rng, corpus: &Corpus, t: Target) -> (String, Vec<u8>, Option<PathBuf>) {
    let seeds = corpus.of(t);
    let generated = match t {
        Target::Lst if rng.chance(0.4) => Some(generate_lst(rng, 60).into_bytes()),
        Target::Json if rng.chance(0.5) => Some(generate_json(rng, 40).into_bytes()),
        Target::Lsystem if rng.chance(0.3) || seeds.is_empty() => Some(generate_lsystem(rng).into_bytes()),
        Target::Obj if rng.chance(0.4) => Some(generate_obj(rng).into_bytes()),
        Target::Set => {
            let base = *rng.pick(&SET_BASES);
            Some(generate_set(rng, base).into_bytes())
        }
        _ => None,
    };
    if let Some(g) = generated {
        let g = if rng.chance(0.3) && t != Target::Set {
            mutate_text(rng, &String::from_utf8_lossy(&g), t, 2).into_bytes()
        } else {
            g
        };
        return (format!("generated {}", t.name()), g, None);
    }
    if seeds.is_empty() {
        return (format!("empty {}", t.name()), Vec::new(), None);
    }
    let seed = *rng.pick(&seeds);
    // Mostly one mutation, so that many inputs get past the syntax into the deeper
    // stages; sometimes several, sometimes raw bytes.
    let ops = if rng.chance(0.6) { 1 } else { 4 };
    let bytes = match t {
        Target::Gltf => mutate_gltf(rng, &seed.bytes),
        _ if rng.chance(0.05) => mutate_bytes(rng, &seed.bytes, ops),
        _ => mutate_text(rng, &String::from_utf8_lossy(&seed.bytes), t, ops).into_bytes(),
    };
    (seed.name.clone(), bytes, seed.folder.clone())
}

// ---------------------------------------------------------------------------------------
// Running the readers

/// How deep a run goes after the reader.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Depth {
    /// The reader and what it feeds directly (derivation and turtle for L-systems,
    /// the recipe check for `--set`, the mesh check for meshes), with module budgets
    /// lowered so debug builds stay fast. For `cargo test`.
    Reader,
    /// The whole pipeline (`pipeline::grow`) with the default budgets, as `sylva grow`
    /// runs it, writing the output. For the release campaign.
    Pipeline,
}

/// Copies the files of folder `from` into a new folder `to`, unless `to` exists (a
/// scratch folder reused across runs).
fn copy_files_once(from: &Path, to: &Path) -> Result<(), String> {
    if !to.exists() {
        std::fs::create_dir_all(to).map_err(|e| e.to_string())?;
        if let Ok(rd) = std::fs::read_dir(from) {
            for e in rd.flatten().filter(|e| e.path().is_file()) {
                let _ = std::fs::copy(e.path(), to.join(e.file_name()));
            }
        }
    }
    Ok(())
}

/// Runs one input through its reader. `Ok(())` for a success or a clean error
/// (`Err` values of the engine are expected for broken inputs); panics propagate to the
/// caller (the watchdog catches them). `work` is a scratch folder for this run.
pub fn run_input(
    t: Target,
    bytes: &[u8],
    folder: Option<&Path>,
    work: &Path,
    depth: Depth,
) -> Result<String, String> {
    use sylva::recipe;
    let text = String::from_utf8_lossy(bytes);
    let deep = depth == Depth::Pipeline;
    let small = |sets: &mut Vec<(String, toml::Value)>| {
        if !deep {
            sets.push(("generator.max_modules".into(), toml::Value::Integer(200_000)));
        }
        sets.push(("output.textures".into(), toml::Value::String("none".into())));
    };
    let out = work.join("out.glb");
    let grow = |loaded: &recipe::Loaded| -> Result<String, String> {
        if deep {
            let g = sylva::pipeline::grow(loaded).map_err(|e| format!("{e}"))?;
            sylva::export::write(&g.model, &out).map_err(|e| format!("{e}"))?;
            Ok(format!("{} nodes", g.skeleton.len()))
        } else {
            let mut report = sylva::pipeline::Report::default();
            let g = sylva::pipeline::skeleton(loaded, &mut report).map_err(|e| format!("{e}"))?;
            g.skeleton.validate().map_err(|e| format!("generator returned an invalid skeleton: {e}"))?;
            Ok(format!("{} nodes", g.skeleton.len()))
        }
    };
    // The input written to `path` and loaded as a recipe or model (the file removed after).
    let load_and_grow = |path: &Path| -> Result<String, String> {
        std::fs::write(path, bytes).map_err(|e| e.to_string())?;
        let mut sets = Vec::new();
        small(&mut sets);
        let r = recipe::load(&path.display().to_string(), &sets).map_err(|e| format!("{e}"));
        let r = r.and_then(|loaded| grow(&loaded));
        let _ = std::fs::remove_file(path);
        r
    };
    match t {
        Target::Lsystem => {
            let dir = match folder {
                Some(f) => {
                    // The model folder's files beside the mutated model.
                    let copy = work.join("model");
                    copy_files_once(f, &copy)?;
                    copy
                }
                None => work.to_path_buf(),
            };
            load_and_grow(&dir.join("fuzz-input.l"))
        }
        Target::Recipe => {
            // The preset L-systems a recipe may name, beside it.
            copy_files_once(&repo_root().join("presets/lsystem"), &work.join("lsystem"))?;
            load_and_grow(&work.join("fuzz-recipe.toml"))
        }
        Target::Set => {
            let mut lines = text.lines();
            let base = lines.next().unwrap_or("lsys-binary-tree").trim().to_string();
            let mut sets = Vec::new();
            for l in lines {
                sets.push(recipe::parse_set(l).map_err(|e| format!("{e}"))?);
            }
            if !deep {
                sets.push(("output.textures".into(), toml::Value::String("none".into())));
            }
            let loaded = recipe::load(&base, &sets).map_err(|e| format!("{e}"))?;
            if deep {
                grow(&loaded)
            } else {
                // Growing every generator in debug is too slow for CI; L-systems only,
                // with a lowered module budget.
                match &loaded.recipe.generator {
                    recipe::Generator::Lsystem(_) => {
                        let mut s2 = sets.clone();
                        s2.push(("generator.max_modules".into(), toml::Value::Integer(200_000)));
                        let loaded = recipe::load(&base, &s2).map_err(|e| format!("{e}"))?;
                        grow(&loaded)
                    }
                    _ => Ok("recipe checked".into()),
                }
            }
        }
        Target::Lst => {
            use sylva::import::lst::{parse, GapPolicy, LstOptions};
            let mut last = Ok(String::new());
            for gap in [GapPolicy::Bridge, GapPolicy::Strict, GapPolicy::NewRoot] {
                let opts = LstOptions { gap, ..Default::default() };
                last = match parse("fuzz.lst", &text, &opts) {
                    Ok(sk) => {
                        sk.validate().map_err(|e| format!("LST reader returned an invalid skeleton: {e}"))?;
                        Ok(format!("{} nodes", sk.len()))
                    }
                    Err(e) => Err(e.message.clone()),
                };
            }
            if deep {
                return grow_file(work, "fuzz-input.lst", bytes, &grow);
            }
            last
        }
        Target::Json => {
            let r = sylva::import::skel_json::from_json(&text);
            if let Ok(sk) = &r {
                sk.validate().map_err(|e| format!("JSON reader returned an invalid skeleton: {e}"))?;
            }
            if deep {
                return grow_file(work, "fuzz-input.skel.json", bytes, &grow);
            }
            r.map(|s| format!("{} nodes", s.len())).map_err(|e| format!("{e}"))
        }
        Target::Str => {
            let r = sylva::import::cpfg_str::parse("fuzz.str", &text).map_err(|e| e.message.clone());
            if let Ok((symbols, string)) = &r {
                let source = sylva::lsystem::source::Source::new("fuzz.str", "", &[])
                    .map_err(|e| e.message.clone())?;
                if let Ok(sk) = sylva::lsystem::interpret(symbols, string, &Default::default(), &source) {
                    sk.validate().map_err(|e| format!("turtle returned an invalid skeleton: {e}"))?;
                }
            }
            if deep {
                return grow_file(work, "fuzz-input.str", bytes, &grow);
            }
            r.map(|(_, s)| format!("{} modules", s.len()))
        }
        Target::Obj => {
            let obj = sylva::mesh::obj_read::parse_obj(&text).map_err(|e| format!("{e}"))?;
            let opts = sylva::mesh::check::CheckOptions::default();
            let _ = sylva::mesh::check::check_mesh(&obj.mesh, &opts);
            // `sylva subdivide` with its defaults: two levels, 100 M faces at most.
            use sylva::refine::{RefineOptions, Scheme, SubdivideOptions};
            let tris =
                obj.mesh.face_count() > 0 && (0..obj.mesh.face_count()).all(|f| obj.mesh.face(f).len() == 3);
            let options = SubdivideOptions {
                refine: RefineOptions {
                    scheme: if tris { Scheme::Loop } else { Scheme::CatmullClark },
                    levels: if deep { 2 } else { 1 },
                    boundary: obj.boundary.unwrap_or_default(),
                    creasing: obj.creasing.unwrap_or_default(),
                    max_faces: if deep { sylva::refine::DEFAULT_MAX_FACES } else { 200_000 },
                    ..Default::default()
                },
                ..Default::default()
            };
            let m =
                sylva::refine::subdivide(&obj.mesh, &obj.corners, &options).map_err(|e| format!("{e}"))?;
            if deep {
                let model = sylva::Model {
                    parts: vec![sylva::Part { name: "m".into(), mesh: m.clone(), ..Default::default() }],
                    ..Default::default()
                };
                sylva::export::write(&model, &work.join("out.obj")).map_err(|e| format!("{e}"))?;
            }
            Ok(format!("{} faces", m.face_count()))
        }
        Target::Gltf => {
            let path = work.join(format!("fuzz-input.{}", t.ext(bytes)));
            std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
            let r = sylva::import::gltf_read::read_gltf(&path).map_err(|e| format!("{e}"));
            let _ = std::fs::remove_file(&path);
            let meshes = r?;
            let opts = sylva::mesh::check::CheckOptions::default();
            for mut g in meshes {
                sylva::import::gltf_read::weld(&mut g.mesh);
                let _ = sylva::mesh::check::check_mesh(&g.mesh, &opts);
            }
            Ok("checked".into())
        }
    }
}

fn grow_file(
    work: &Path,
    name: &str,
    bytes: &[u8],
    grow: &dyn Fn(&sylva::recipe::Loaded) -> Result<String, String>,
) -> Result<String, String> {
    let path = work.join(name);
    std::fs::write(&path, bytes).map_err(|e| e.to_string())?;
    let sets = vec![("output.textures".to_string(), toml::Value::String("none".into()))];
    let r = sylva::recipe::load(&path.display().to_string(), &sets).map_err(|e| format!("{e}"));
    let r = r.and_then(|l| grow(&l));
    let _ = std::fs::remove_file(&path);
    r
}

// ---------------------------------------------------------------------------------------
// The watchdog

/// What a watched run did.
#[derive(Debug)]
pub enum Outcome<T> {
    /// It returned.
    Done(T),
    /// It panicked, with the message.
    Panicked(String),
    /// It was still running after the timeout (the thread is left behind).
    TimedOut(Duration),
}

/// Runs `f` on a thread with an 8 MiB stack (the main thread's) and waits at most
/// `timeout` for it.
pub fn watchdog<T: Send + 'static>(timeout: Duration, f: impl FnOnce() -> T + Send + 'static) -> Outcome<T> {
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    let spawned = std::thread::Builder::new().stack_size(8 << 20).spawn(move || {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
        let _ = tx.send(r);
    });
    if let Err(e) = spawned {
        return Outcome::Panicked(format!("cannot spawn the watched thread: {e}"));
    }
    match rx.recv_timeout(timeout) {
        Ok(Ok(v)) => Outcome::Done(v),
        Ok(Err(p)) => Outcome::Panicked(panic_message(&p)),
        Err(_) => Outcome::TimedOut(start.elapsed()),
    }
}

pub fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic)".into()
    }
}

/// A short, printable excerpt of an input for failure messages.
pub fn excerpt(bytes: &[u8]) -> String {
    let s = String::from_utf8_lossy(bytes);
    let s: String = s.chars().take(3000).collect();
    format!("{s:?}")
}

/// A fresh scratch folder under the system temp folder.
pub fn scratch(tag: &str) -> PathBuf {
    static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let k = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let d = std::env::temp_dir().join(format!("sylva-fuzz-{tag}-{}-{k}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp folder");
    d
}

/// Runs `cases` inputs for target `t` from `seed` through the reader, each under the
/// watchdog; returns the failures (panics and timeouts) with their inputs.
pub fn campaign(t: Target, seed: u64, cases: usize, timeout: Duration, budget: Duration) -> Vec<String> {
    let corpus = std::sync::Arc::new(corpus(12));
    let mut rng = Rng::new(seed ^ (t as u64) << 32);
    let work = scratch(t.name());
    let mut failures = Vec::new();
    let start = Instant::now();
    for case in 0..cases {
        if start.elapsed() > budget {
            break;
        }
        let (origin, bytes, folder) = next_input(&mut rng, &corpus, t);
        if let Ok(p) = std::env::var("SYLVA_FUZZ_LAST") {
            // Debugging a crash that kills the process: the input about to run.
            let _ = std::fs::write(format!("{p}.{}", t.name()), &bytes);
            if let Some(f) = &folder {
                let _ = std::fs::write(format!("{p}.{}.folder", t.name()), f.display().to_string());
            }
            eprintln!("{} case {case} from {origin}", t.name());
        }
        let (b2, w2) = (bytes.clone(), work.clone());
        let outcome = watchdog(timeout, move || run_input(t, &b2, folder.as_deref(), &w2, Depth::Reader));
        match outcome {
            Outcome::Done(_) => {}
            Outcome::Panicked(m) => failures.push(format!(
                "{} case {case} (from {origin}): panic: {m}\ninput: {}",
                t.name(),
                excerpt(&bytes)
            )),
            Outcome::TimedOut(d) => failures.push(format!(
                "{} case {case} (from {origin}): still running after {:.1} s\ninput: {}",
                t.name(),
                d.as_secs_f64(),
                excerpt(&bytes)
            )),
        }
        if failures.len() >= if std::env::var("SYLVA_FUZZ_LAST").is_ok() { 1 } else { 3 } {
            break;
        }
    }
    let _ = std::fs::remove_dir_all(&work);
    failures
}

/// Case `j` of the new-class lane of seed `seed`: class `j mod 8`
/// ([`classes::Class::ALL`]), drawn from its own random stream so any case can be
/// replayed alone.
pub fn case_of(seed: u64, j: u64) -> classes::Case {
    let c = classes::Class::ALL[(j % classes::Class::ALL.len() as u64) as usize];
    let mut rng = Rng::new(seed.wrapping_mul(1_000_003).wrapping_add(j) ^ 0x3939_0000_0000_0039);
    classes::generate(&mut rng, c)
}
