//! Generators for the failure classes of issue 39 (`docs/robustness.md`): long lines,
//! deep nesting, degenerate and many-root skeletons, absurd numbers in `--set`, raised
//! budgets, duplicated glTF primitives and hostile model folders (paths and symlinks
//! to a canary file outside the folder, `/dev/zero`, FIFOs). The kill-during-write
//! fault lane lives in `examples/fuzz_campaign.rs` (it needs the CLI).
//!
//! Each generator returns a [`Case`]: the input, the reader (or CLI lane) it goes to,
//! the `--set` lines that go with it and, for hostile folders, the folder to build.
//! [`materialize`] writes a case to disk, [`run_case`] runs it in-process and reports
//! everything a run said (the error rendered as the CLI would print it, warnings) so
//! the caller can check it for panics, canary bytes and its size.

use super::{Depth, Rng, Target, SET_BASES};
use std::path::{Path, PathBuf};

/// The classes of issue 39's "What still fails".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Class {
    /// A 100k–300k-character line with the error far in (item 1).
    LongLine,
    /// 10³–10⁵ nested parentheses, unary minus signs, brackets, arrays (item 2).
    DeepNesting,
    /// Coincident, zero-length, reversing, jittered and absurdly sized skeletons of
    /// 10²–10⁴ nodes (items 5, 6).
    Degenerate,
    /// 10²–10⁴ separate cylinders with `generator.gap = new-root`, or JSON roots (item 4).
    ManyRoots,
    /// 1e9, 1e30, -1, 0, NaN text, floats where integers go, for numeric keys (item 15).
    AbsurdNumbers,
    /// Work and memory budgets raised to 10⁹–10¹² (item 3).
    RaisedBudgets,
    /// glTF with one primitive repeated 100–200 times, or 10⁵ triangles on 256
    /// vertices, for `check` (item 7).
    DupGltf,
    /// Model folders whose side files point outside the folder or at special files
    /// (items 9, 14).
    Hostile,
}

impl Class {
    /// Every class, in the order the campaign cycles through them.
    pub const ALL: [Class; 8] = [
        Class::LongLine,
        Class::DeepNesting,
        Class::Degenerate,
        Class::ManyRoots,
        Class::AbsurdNumbers,
        Class::RaisedBudgets,
        Class::DupGltf,
        Class::Hostile,
    ];

    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Class::LongLine => "long-line",
            Class::DeepNesting => "deep-nesting",
            Class::Degenerate => "degenerate",
            Class::ManyRoots => "many-roots",
            Class::AbsurdNumbers => "absurd-numbers",
            Class::RaisedBudgets => "raised-budgets",
            Class::DupGltf => "dup-gltf",
            Class::Hostile => "hostile-folder",
        }
    }
}

/// A special file put where an input is expected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Special {
    /// A symlink to `/dev/zero`.
    DevZero,
    /// A symlink to `/dev/urandom`.
    DevUrandom,
    /// A FIFO with no writer (opening it for reading blocks).
    Fifo,
}

/// One entry of a model folder.
#[derive(Debug, Clone)]
pub enum Entry {
    /// A regular file. `{ABS}` in it is replaced by the canary's absolute path, `{REL}`
    /// by its path relative to the model folder (`../outside/secret.txt`).
    File(Vec<u8>),
    /// A symlink to the canary file outside the folder.
    LinkToCanary,
    /// A symlink to the folder holding the canary (`outside/`).
    LinkToOutside,
    /// A special file.
    Special(Special),
}

/// A model folder to build.
#[derive(Debug, Clone)]
pub struct Model {
    /// The folder's entries by file name.
    pub entries: Vec<(String, Entry)>,
    /// The file handed to sylva, relative to the folder.
    pub input: String,
}

/// One generated input.
#[derive(Debug, Clone)]
pub struct Case {
    /// Its class.
    pub class: Class,
    /// The reader it goes to (`Set`: `bytes` is the base preset then one `key=value` a
    /// line, as in the `--set` lane).
    pub target: Target,
    /// What it is, for reports.
    pub what: String,
    /// The input file (unused when `model` is set).
    pub bytes: Vec<u8>,
    /// `--set key=value` overrides that go with it.
    pub sets: Vec<String>,
    /// A model folder to build instead of a single file.
    pub model: Option<Model>,
    /// The canary's unique content (`CANARY-<hex>`) for hostile folders: no message
    /// and no output may contain it.
    pub canary: Option<String>,
    /// The case involves `/dev/zero`, `/dev/urandom` or a FIFO: only safe in-process
    /// under an address-space limit and a watchdog.
    pub special: bool,
}

impl Case {
    fn new(class: Class, target: Target, what: String, bytes: Vec<u8>) -> Self {
        Case { class, target, what, bytes, sets: Vec::new(), model: None, canary: None, special: false }
    }

    /// The file name the input gets (`input.lst`, `input.skel.json`, …).
    pub fn file_name(&self) -> String {
        match self.target {
            Target::Json => "input.skel.json".into(),
            t => format!("input.{}", t.ext(&self.bytes)),
        }
    }
}

/// A log-uniform integer in `lo..=hi`.
pub fn log_uniform(rng: &mut Rng, lo: usize, hi: usize) -> usize {
    let (a, b) = ((lo.max(1) as f64).ln(), (hi.max(lo).max(1) as f64).ln());
    ((a + rng.unit() * (b - a)).exp().round() as usize).clamp(lo, hi)
}

/// A fresh input of class `c`.
pub fn generate(rng: &mut Rng, c: Class) -> Case {
    match c {
        Class::LongLine => long_line(rng),
        Class::DeepNesting => deep_nesting(rng),
        Class::Degenerate => degenerate(rng),
        Class::ManyRoots => many_roots(rng),
        Class::AbsurdNumbers => absurd_numbers(rng),
        Class::RaisedBudgets => raised_budgets(rng),
        Class::DupGltf => dup_gltf(rng),
        Class::Hostile => hostile(rng),
    }
}

// ---------------------------------------------------------------------------------------
// Long lines

/// The longest single `--set` argument that still fits one `execve` argument
/// (`MAX_ARG_STRLEN` = 128 KiB), so the CLI lane can pass it.
pub const MAX_SET_ARG: usize = 125_000;

/// A 100k–300k-character line with an error placed far in, for `.l`, `.lst`, `.str`,
/// `.skel.json`, recipes, `--set` values and OBJ.
pub fn long_line(rng: &mut Rng) -> Case {
    let len = 100_000 + rng.below(200_001);
    let targets =
        [Target::Lsystem, Target::Lst, Target::Str, Target::Json, Target::Recipe, Target::Set, Target::Obj];
    let t = *rng.pick(&targets);
    let variant = rng.below(3);
    let text = match (t, variant) {
        (Target::Lsystem, 0) => {
            // A long axiom with a bad module at its end.
            let body = "F(1)+(3)".repeat(len / 8);
            format!("Lsystem: 1\nderivation length: 1\nAxiom: {body}F(1,,2)\nendlsystem\n")
        }
        (Target::Lsystem, 1) => {
            // A long successor with an unbalanced parenthesis at its end.
            let body = "F(x*0.5)[+(10)A(x)]".repeat(len / 19);
            format!("Lsystem: 1\nderivation length: 2\nAxiom: A(1)\nA(x) --> {body}F(x\nendlsystem\n")
        }
        (Target::Lsystem, _) => {
            // A long expression in a #define with an operator error at its end.
            let body = "1+".repeat(len / 2);
            format!("#define N {body}*)\nLsystem: 1\nderivation length: 1\nAxiom: F(N)\nendlsystem\n")
        }
        (Target::Lst, 0) => format!("LST 0.1\nCylinder(1, 1, {}x)\n", "1".repeat(len)),
        (Target::Lst, 1) => format!("LST 0.1\nMovRel3f(0, 1, 0{})\n", ", 0".repeat(len / 3)),
        (Target::Lst, _) => {
            format!("LST 0.1\n{}Bogus(1)\n", "Cylinder(0.1, 0.1, 1) MovRel3f(0, 1, 0) ".repeat(len / 40))
        }
        (Target::Str, 0) => format!("{}F(1,,)\n", "F(1)+(30)".repeat(len / 9)),
        (Target::Str, 1) => format!("{}F(nan)\n", "F(1)[+(30)F(0.5)]".repeat(len / 17)),
        (Target::Str, _) => format!("{}F(1\n", "F(1)".repeat(len / 4)),
        (Target::Json, v) => {
            let node = r#"{"position":[0,1,0],"radius":0.1,"parent":0},"#;
            let n = len / node.len();
            let bad = match v {
                0 => r#"{"position":[0,1,0],"radius":"x","parent":0}"#,
                1 => r#"{"position":[0,1,0],"radius":0.1,"parent":0},,"#,
                _ => r#"{"position":[0,1,0],"radius":0.1,"parent":4294967295}"#,
            };
            format!(
                r#"{{"format":"sylva-skeleton","version":1,"nodes":[{{"position":[0,0,0],"radius":0.1,"parent":null}},{}{}]}}"#,
                node.repeat(n),
                bad
            )
        }
        (Target::Recipe, 0) => format!("name = \"{}\" bogus\n", "a".repeat(len)),
        (Target::Recipe, 1) => format!("[mesh]\nsides = {}\n", "9".repeat(len)),
        (Target::Recipe, _) => {
            format!("[generator]\ntype = \"lsystem\"\nfile = \"lsystem/binary-tree.l\"\n[lod]\nlevels = [{}\"x\"]\n", "1000, ".repeat(len / 6))
        }
        (Target::Set, v) => {
            let base = *rng.pick(&SET_BASES);
            let len = len.min(MAX_SET_ARG);
            let line = match v {
                0 => format!("generator.angle={}x", "1".repeat(len)),
                1 => format!("lod.levels=[{}x]", "1000, ".repeat(len / 6)),
                _ => format!("mesh.method=\"{}\"", "q".repeat(len)),
            };
            format!("{base}\n{line}\n")
        }
        (_, v) => {
            // OBJ: a face or vertex line with the error far in.
            let mut s = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
            match v {
                0 => s.push_str(&format!("f 1 2 3{} x\n", " 1".repeat(len / 2))),
                1 => s.push_str(&format!("v 0 0 {}q\n", "1".repeat(len))),
                _ => s.push_str(&format!("f{} 0\n", " 1 2 3".repeat(len / 6))),
            }
            s
        }
    };
    Case::new(Class::LongLine, t, format!("long line ({} chars, variant {variant})", len), text.into_bytes())
}

// ---------------------------------------------------------------------------------------
// Deep nesting

/// 10³–10⁵ nested parentheses, unary minus chains, brackets, nested TOML arrays in
/// `--set` and nested JSON arrays.
pub fn deep_nesting(rng: &mut Rng) -> Case {
    let d = log_uniform(rng, 1_000, 100_000);
    deep_nesting_at(rng, d)
}

/// [`deep_nesting`] at a given depth.
pub fn deep_nesting_at(rng: &mut Rng, d: usize) -> Case {
    let kind = rng.below(12);
    let (t, text) = match kind {
        0 => (Target::Lsystem, format!("Lsystem: 1\nderivation length: 1\nAxiom: F({}1{})\nendlsystem\n", "(".repeat(d), ")".repeat(d))),
        1 => (Target::Lsystem, format!("Lsystem: 1\nderivation length: 1\nAxiom: F({}1)\nendlsystem\n", "-".repeat(d))),
        2 => (
            Target::Lsystem,
            format!("Lsystem: 1\nderivation length: 2\nAxiom: A(1)\nA(x) --> F({}x{})A(x)\nendlsystem\n", "-(".repeat(d), ")".repeat(d)),
        ),
        3 => (Target::Lsystem, format!("Lsystem: 1\nderivation length: 1\nAxiom: {}F{}\nendlsystem\n", "[".repeat(d), "]".repeat(d))),
        4 => (Target::Lsystem, format!("#define N {}1{}\nLsystem: 1\nderivation length: 1\nAxiom: F(N)\nendlsystem\n", "(".repeat(d), ")".repeat(d))),
        5 => (
            Target::Lsystem,
            format!("Lsystem: 1\nderivation length: 1\nAxiom: A(1)\nA(x) : {{ y = {}x{}; }} y > 0 --> F(y)\nendlsystem\n", "(".repeat(d), ")".repeat(d)),
        ),
        6 => (Target::Str, format!("F({}1{})\n", "(".repeat(d), ")".repeat(d))),
        7 => (Target::Str, format!("{}F(1){}\n", "[".repeat(d), "]".repeat(d))),
        8 => (
            Target::Json,
            format!(r#"{{"format":"sylva-skeleton","version":1,"nodes":{}{}}}"#, "[".repeat(d), "]".repeat(d)),
        ),
        9 => {
            let base = *rng.pick(&SET_BASES);
            let (k, v) = if rng.chance(0.5) {
                ("lod.levels", format!("{}{}", "[".repeat(d.min(MAX_SET_ARG / 2)), "]".repeat(d.min(MAX_SET_ARG / 2))))
            } else {
                ("generator.define.N", format!("\"{}1{}\"", "(".repeat(d.min(MAX_SET_ARG / 2)), ")".repeat(d.min(MAX_SET_ARG / 2))))
            };
            (Target::Set, format!("{base}\n{k}={v}\n"))
        }
        10 => (Target::Recipe, format!("name = \"deep\"\nx = {}{}\n", "[".repeat(d), "]".repeat(d))),
        _ => (Target::Lst, format!("LST 0.1\nCylinder({}1{}, 1, 1)\n{}Cylinder(0.1, 0.1, 1)\n{}", "(".repeat(d), ")".repeat(d), "SB() ".repeat(d), "EB() ".repeat(d))),
    };
    Case::new(Class::DeepNesting, t, format!("deep nesting (depth {d}, kind {kind})"), text.into_bytes())
}

// ---------------------------------------------------------------------------------------
// Degenerate and many-root skeletons

/// Meshers and passes a skeleton case goes through (`--set` lines).
fn mesher_sets(rng: &mut Rng) -> Vec<String> {
    let mut sets =
        vec![format!("mesh.method={}", rng.pick(&["tube", "hull", "sweep", "quad", "sweep", "hull"]))];
    if rng.chance(0.3) {
        sets.push("mesh.decollide=true".into());
    }
    if rng.chance(0.2) {
        sets.push("mesh.clear=true".into());
    }
    sets
}

/// LST and JSON skeletons of 10²–10⁴ nodes that are all coincident, zero-length
/// chains, reversing zig-zags, near-coincident (1e-7 jitter) or absurdly sized
/// (widths and lengths 1e30, 1e-30).
pub fn degenerate(rng: &mut Rng) -> Case {
    let n = log_uniform(rng, 100, 10_000);
    degenerate_n(rng, n)
}

/// [`degenerate`] with `n` nodes.
pub fn degenerate_n(rng: &mut Rng, n: usize) -> Case {
    let kind = rng.below(6);
    let names = ["coincident", "zero-length chain", "zig-zag", "jitter 1e-7", "huge 1e30", "tiny 1e-30"];
    let json = rng.chance(0.4);
    let (t, text) = if json {
        let mut nodes = Vec::with_capacity(n);
        for i in 0..n {
            let parent = if i == 0 {
                "null".to_string()
            } else if rng.chance(0.9) {
                (i - 1).to_string()
            } else {
                rng.below(i).to_string()
            };
            let (p, r) = match kind {
                0 => ([0.0, 0.0, 0.0], 0.1),
                1 => ([0.0, (i / 10) as f64, 0.0], 0.1),
                2 => ([0.0, (i % 2) as f64, 0.0], 0.1),
                3 => ([1e-7 * rng.unit(), 1e-7 * rng.unit(), 1e-7 * rng.unit()], 0.1),
                4 => ([0.0, i as f64 * 1e30 / n as f64, 0.0], 1e30),
                _ => ([0.0, i as f64 * 1e-30, 0.0], 1e-30),
            };
            nodes.push(format!(
                r#"{{"position":[{:e},{:e},{:e}],"radius":{:e},"parent":{parent}}}"#,
                p[0], p[1], p[2], r
            ));
        }
        (
            Target::Json,
            format!(r#"{{"format":"sylva-skeleton","version":1,"nodes":[{}]}}"#, nodes.join(",\n")),
        )
    } else {
        let mut s = String::from("LST 0.1\n");
        for i in 0..n {
            if rng.chance(0.05) {
                s.push_str("SB()\n");
            }
            match kind {
                0 => s.push_str("Cylinder(0.1, 0.1, 0)\n"),
                1 => {
                    if i % 10 == 0 {
                        s.push_str("Cylinder(0.1, 0.1, 1)\nMovRel3f(0, 1, 0)\n");
                    } else {
                        s.push_str("Cylinder(0.1, 0.1, 0)\n");
                    }
                }
                2 => s.push_str(
                    "Cylinder(0.1, 0.1, 1)\nMovRel3f(0, 1, 0)\nRotRel3f(3.14159265358979, 1, 0, 0)\n",
                ),
                3 => {
                    let l = 1e-7 * rng.unit();
                    s.push_str(&format!(
                        "RotRel3f({}, {}, {}, 1)\nCylinder(0.1, 0.1, {l:e})\nMovRel3f(0, {l:e}, 0)\n",
                        rng.unit() * 6.0,
                        rng.unit(),
                        rng.unit()
                    ));
                }
                4 => {
                    let l = 1e30 / n as f64;
                    s.push_str(&format!("Cylinder(1e30, 1e30, {l:e})\nMovRel3f(0, {l:e}, 0)\n"));
                }
                _ => s.push_str("Cylinder(1e-30, 1e-30, 1e-30)\nMovRel3f(0, 1e-30, 0)\n"),
            }
            if s.ends_with("SB()\n") || rng.chance(0.05) {
                s.push_str("EB()\n");
            }
        }
        // Balance what is left open.
        let open = s.matches("SB()").count().saturating_sub(s.matches("EB()").count());
        s.push_str(&"EB()\n".repeat(open));
        (Target::Lst, s)
    };
    let mut c = Case::new(
        Class::Degenerate,
        t,
        format!("degenerate {} skeleton, {n} nodes, {}", if json { "JSON" } else { "LST" }, names[kind]),
        text.into_bytes(),
    );
    c.sets = mesher_sets(rng);
    if kind >= 4 && rng.chance(0.5) {
        // The sizes of the issue: `generator.width = 1e30` with the sweep mesher.
        c.sets.push(format!("generator.width={}", if kind == 4 { "1e30" } else { "1e-30" }));
    }
    c
}

/// 10²–10⁴ separate cylinders with `generator.gap = new-root` (LST), or as many JSON
/// roots.
pub fn many_roots(rng: &mut Rng) -> Case {
    let n = log_uniform(rng, 100, 10_000);
    many_roots_n(rng, n)
}

/// [`many_roots`] with `n` roots.
pub fn many_roots_n(rng: &mut Rng, n: usize) -> Case {
    let side = (n as f64).sqrt().ceil() as usize;
    let json = rng.chance(0.3);
    let (t, text) = if json {
        let mut nodes = Vec::with_capacity(2 * n);
        for i in 0..n {
            let (x, z) = ((i % side) as f64 * 3.0, (i / side) as f64 * 3.0);
            nodes.push(format!(r#"{{"position":[{x},0,{z}],"radius":0.1,"parent":null}}"#));
            nodes.push(format!(r#"{{"position":[{x},1,{z}],"radius":0.08,"parent":{}}}"#, 2 * i));
        }
        (
            Target::Json,
            format!(r#"{{"format":"sylva-skeleton","version":1,"nodes":[{}]}}"#, nodes.join(",\n")),
        )
    } else {
        let mut s = String::from("LST 0.1\n");
        let mut at = (0usize, 0usize);
        for i in 0..n {
            let (x, z) = (i % side, i / side);
            let (dx, dz) = (x as f64 - at.0 as f64, z as f64 - at.1 as f64);
            if i > 0 {
                s.push_str(&format!("MovRel3f({}, 0, {})\n", dx * 3.0, dz * 3.0));
            }
            at = (x, z);
            s.push_str("Cylinder(0.1, 0.08, 1)\n");
        }
        (Target::Lst, s)
    };
    let mut c = Case::new(
        Class::ManyRoots,
        t,
        format!("{n} separate {} roots", if json { "JSON" } else { "LST" }),
        text.into_bytes(),
    );
    c.sets = mesher_sets(rng);
    if t == Target::Lst {
        c.sets.push("generator.gap=new-root".into());
    }
    c
}

// ---------------------------------------------------------------------------------------
// Absurd numbers and raised budgets

/// Numeric recipe keys (besides each base preset's own numeric keys, which
/// [`numeric_keys`] adds).
pub const NUMERIC_KEYS: &[&str] = &[
    "seed",
    "generator.iterations",
    "generator.angle",
    "generator.step",
    "generator.width",
    "generator.width_factor",
    "generator.max_modules",
    "generator.max_nodes",
    "generator.environment.radius",
    "generator.environment.transmittance",
    "generator.environment.directions",
    "mesh.sides",
    "mesh.hull.margin",
    "mesh.hull.aligned_epsilon",
    "mesh.hull.segment_factor",
    "mesh.hull.max_segments",
    "mesh.hull.max_straightening",
    "mesh.sweep.tip_size",
    "mesh.sweep.max_children",
    "mesh.sweep.coplanar_deg",
    "mesh.sweep.collar_ratio",
    "mesh.sweep.repair_rounds",
    "mesh.sweep.check_levels",
    "mesh.sweep.min_radius",
    "mesh.quad.cs_scale",
    "mesh.quad.max_side_angle",
    "mesh.quad.max_chain",
    "mesh.quad.support",
    "mesh.quad.repair_rounds",
    "mesh.quad.check_levels",
    "mesh.quad.max_repair_work",
    "fit.decollide.clearance",
    "fit.decollide.near_joint_hops",
    "fit.decollide.candidates",
    "fit.decollide.max_rounds",
    "fit.decollide.max_moved",
    "fit.decollide.work_per_node",
    "fit.decollide.max_work",
    "fit.clear.step",
    "fit.clear.max_rounds",
    "fit.clear.patience",
    "fit.clear.max_faces",
    "fit.clear.max_pairs",
    "fit.clear.max_work",
    "refine.levels",
    "refine.max_faces",
    "textures.bark_size",
    "textures.atlas_size",
    "textures.scale",
    "leaves.per_card",
    "leaves.alpha_cutoff",
    "leaves.per_node",
    "leaves.size",
    "wind.strength",
    "wind.gustiness",
    "wind.max_joints",
    "wind.clip_seconds",
    "wind.fps",
    "lod.atlas_frames",
    "lod.atlas_size",
    "output.preview_size",
];

/// The absurd values: huge, negative, zero, NaN text, floats where integers go.
pub const ABSURD_VALUES: &[&str] = &[
    "1e9",
    "1e30",
    "-1",
    "0",
    "\"nan\"",
    "nan",
    "inf",
    "-inf",
    "1.5",
    "1e12",
    "-1e30",
    "1000000000",
    "1000000000000",
    "4294967297",
    "9223372036854775807",
    "1e308",
    "0.0",
    "-0.0",
    "1e-30",
    "\"1e9\"",
];

/// The base's own numeric keys and [`NUMERIC_KEYS`].
pub fn numeric_keys(base: &str) -> Vec<String> {
    let mut keys: Vec<String> = super::base_keys(base)
        .into_iter()
        .filter(|(_, v)| matches!(v, toml::Value::Integer(_) | toml::Value::Float(_)))
        .map(|(k, _)| k)
        .collect();
    for k in NUMERIC_KEYS {
        if !keys.iter().any(|x| x == k) {
            keys.push(k.to_string());
        }
    }
    keys
}

/// `--set` lines giving one or two numeric keys of a base preset absurd values.
pub fn absurd_numbers(rng: &mut Rng) -> Case {
    let base = *rng.pick(&SET_BASES);
    let keys = numeric_keys(base);
    let mut lines = String::new();
    for _ in 0..1 + rng.below(2) {
        let k = rng.pick(&keys).clone();
        lines.push_str(&format!("{k}={}\n", rng.pick(ABSURD_VALUES)));
    }
    Case::new(
        Class::AbsurdNumbers,
        Target::Set,
        format!("absurd numbers on {base}"),
        format!("{base}\n{lines}").into_bytes(),
    )
}

/// The work and memory budgets.
pub const BUDGET_KEYS: &[&str] = &[
    "generator.max_modules",
    "generator.max_nodes",
    "refine.max_faces",
    "fit.decollide.max_work",
    "fit.clear.max_work",
    "mesh.quad.max_repair_work",
];

/// The wall-clock bound a raised-budgets run gets (the CLI's `--time-limit`; in-process,
/// a cancellation token fired after it). A budget raised 1000× is work the user asked
/// for: the budgets keep it finite and its memory checked; the time limit is how a user
/// bounds its time. A run stops at the first checkpoint after the limit, up to about
/// 2.5 s later on an 18-million-triangle mesh (mig-a at `refine.levels = 3`, whose
/// export passes take that long), so 6 s keeps such a run under the campaign's 10 s line:
/// it ends with the time-limit error, not the campaign's kill.
pub const RAISED_TIME_LIMIT_S: f64 = 6.0;

/// `f` under a cancellation token fired after `seconds`; `Err(Cancelled)` when it fired
/// becomes the message the CLI's `--time-limit` prints.
pub fn with_time_limit<R>(seconds: f64, f: impl FnOnce() -> sylva::Result<R>) -> Result<R, String> {
    let token = sylva::cancel::Cancel::new();
    let timer = sylva::cancel::Timer::start(&token, std::time::Duration::from_secs_f64(seconds))
        .map_err(|e| format!("harness: cannot start the timer: {e}"))?;
    let r = sylva::cancel::scope(&token, f);
    let fired = timer.stop();
    // A run that finished (its files written) just as the limit passed keeps its result.
    match r {
        Err(_) if fired => Err(format!("--time-limit {seconds}: stopped at the time limit")),
        r => r.map_err(|e| render(&e)),
    }
}

/// Budgets raised to 10⁹–10¹², with settings that make the work large (more
/// derivation steps, `refine.levels` up to 6, the quad mesher, clearing).
pub fn raised_budgets(rng: &mut Rng) -> Case {
    let base = *rng.pick(&SET_BASES);
    let mut lines = String::new();
    for _ in 0..1 + rng.below(3) {
        let k = *rng.pick(BUDGET_KEYS);
        let v = match rng.below(4) {
            0 => "1000000000".to_string(),
            1 => "100000000000".to_string(),
            2 => "1000000000000".to_string(),
            _ => format!("{}", 1_000_000_000u64 * (1 + rng.below(1000)) as u64),
        };
        lines.push_str(&format!("{k}={v}\n"));
    }
    match rng.below(5) {
        0 => lines.push_str(&format!("refine.levels={}\n", 3 + rng.below(4))),
        1 => lines.push_str("mesh.method=quad\nmesh.clear=true\n"),
        2 if base.starts_with("lsys") => {
            lines.push_str(&format!("generator.iterations={}\n", 10 + rng.below(20)));
        }
        3 => lines.push_str("mesh.method=sweep\nmesh.decollide=true\n"),
        _ => {}
    }
    Case::new(
        Class::RaisedBudgets,
        Target::Set,
        format!("raised budgets on {base}"),
        format!("{base}\n{lines}").into_bytes(),
    )
}

// ---------------------------------------------------------------------------------------
// glTF with duplicated primitives

/// A GLB of one mesh: `vertices` positions, `tris` triangles, listed `copies` times
/// as primitives of the mesh (all on the same accessors).
pub fn glb(positions: &[[f32; 3]], tris: &[[u32; 3]], copies: usize) -> Vec<u8> {
    let mut bin = Vec::new();
    for p in positions {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let pos_len = bin.len();
    for t in tris {
        for i in t {
            bin.extend_from_slice(&i.to_le_bytes());
        }
    }
    let idx_len = bin.len() - pos_len;
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let prim = r#"{"attributes":{"POSITION":0},"indices":1,"mode":4}"#;
    let prims = vec![prim; copies.max(1)].join(",");
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{}}}],"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":{pos_len},"target":34962}},{{"buffer":0,"byteOffset":{pos_len},"byteLength":{idx_len},"target":34963}}],"accessors":[{{"bufferView":0,"componentType":5126,"count":{},"type":"VEC3","min":[{},{},{}],"max":[{},{},{}]}},{{"bufferView":1,"componentType":5125,"count":{},"type":"SCALAR"}}],"meshes":[{{"name":"dup","primitives":[{prims}]}}],"nodes":[{{"mesh":0}}],"scenes":[{{"nodes":[0]}}],"scene":0}}"#,
        bin.len(),
        positions.len(),
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        tris.len() * 3
    );
    super::glb_container(json.into_bytes(), &super::bin_chunk(bin))
}

/// A closed UV sphere of `rings × sectors` vertices (poles included).
pub fn sphere(rings: usize, sectors: usize) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut p = vec![[0.0, 1.0, 0.0]];
    for r in 1..rings {
        let th = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..sectors {
            let ph = std::f32::consts::TAU * s as f32 / sectors as f32;
            p.push([th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()]);
        }
    }
    p.push([0.0, -1.0, 0.0]);
    let last = (p.len() - 1) as u32;
    let at = |r: usize, s: usize| (1 + (r - 1) * sectors + s % sectors) as u32;
    let mut t = Vec::new();
    for s in 0..sectors {
        t.push([0, at(1, s + 1), at(1, s)]);
        t.push([last, at(rings - 1, s), at(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..sectors {
            t.push([at(r, s), at(r, s + 1), at(r + 1, s + 1)]);
            t.push([at(r, s), at(r + 1, s + 1), at(r + 1, s)]);
        }
    }
    (p, t)
}

/// A GLB for `check`: one primitive (a sphere of ~500 triangles) repeated 100–200
/// times, or one primitive of about 10⁵ triangles indexing 256 vertices.
pub fn dup_gltf(rng: &mut Rng) -> Case {
    if rng.chance(0.5) {
        let copies = 100 + rng.below(101);
        dup_gltf_sized(rng, copies, 0)
    } else {
        let tris = 100_000 + rng.below(30_000);
        dup_gltf_sized(rng, 0, tris)
    }
}

/// [`dup_gltf`] with `copies` repeats of a sphere, or (`copies` = 0) `tris`
/// random triangles on 256 vertices.
pub fn dup_gltf_sized(rng: &mut Rng, copies: usize, tris: usize) -> Case {
    let bytes = if copies > 0 {
        let (p, t) = sphere(16, 16);
        glb(&p, &t, copies)
    } else {
        let p: Vec<[f32; 3]> =
            (0..256).map(|_| [rng.unit() as f32, rng.unit() as f32, rng.unit() as f32]).collect();
        let t: Vec<[u32; 3]> = (0..tris)
            .map(|_| {
                let a = rng.below(256) as u32;
                let b = (a + 1 + rng.below(254) as u32) % 256;
                let mut c = rng.below(256) as u32;
                while c == a || c == b {
                    c = (c + 1) % 256;
                }
                [a, b, c]
            })
            .collect();
        glb(&p, &t, 1)
    };
    let what = if copies > 0 {
        format!("glTF: a 480-triangle primitive repeated {copies} times")
    } else {
        format!("glTF: {tris} triangles on 256 vertices")
    };
    Case::new(Class::DupGltf, Target::Gltf, what, bytes)
}

// ---------------------------------------------------------------------------------------
// Hostile model folders

/// The canary file's name and folder, outside the model folder (no canary bytes in
/// either, so a message may name the path).
pub const OUTSIDE: &str = "outside";
/// The canary file in [`OUTSIDE`].
pub const CANARY_FILE: &str = "secret.txt";

/// The canary file's content for a token: lines of every shape a reader might echo
/// (no colon, `key: value`, a comment, an L-system line).
pub fn canary_text(token: &str) -> String {
    format!(
        "{token}\n{token}: {token}\n/* {token} */\n# {token}\nAxiom: {token}\nfunction: {token}\n{token} {token}\n\
-----BEGIN {token} PRIVATE KEY-----\n{token}\n"
    )
}

const PLANT_L: &str = "Lsystem: 1\nderivation length: 3\nAxiom: A\nA --> F[+A][-A]\nendlsystem\n";

/// Where a hostile reference points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Ref {
    Abs,
    Rel,
    Link,
    Special(Special),
}

fn pick_ref(rng: &mut Rng, special: bool) -> Ref {
    match rng.below(if special { 6 } else { 3 }) {
        0 => Ref::Abs,
        1 => Ref::Rel,
        2 => Ref::Link,
        3 => Ref::Special(Special::DevZero),
        4 => Ref::Special(Special::Fifo),
        _ => Ref::Special(Special::DevUrandom),
    }
}

/// A reference to the canary or a special file under an in-folder name `name`.
fn reference(
    rng: &mut Rng,
    special: bool,
    uses_special: &mut bool,
    entries: &mut Vec<(String, Entry)>,
    name: &str,
) -> String {
    match pick_ref(rng, special) {
        Ref::Abs => "{ABS}".to_string(),
        Ref::Rel => "{REL}".to_string(),
        Ref::Link => {
            let e = if rng.chance(0.8) { Entry::LinkToCanary } else { Entry::LinkToOutside };
            entries.push((name.to_string(), e));
            name.to_string()
        }
        Ref::Special(s) => {
            *uses_special = true;
            entries.push((name.to_string(), Entry::Special(s)));
            name.to_string()
        }
    }
}

/// A hostile model folder (any of the references).
pub fn hostile(rng: &mut Rng) -> Case {
    let special = rng.chance(0.35);
    hostile_with(rng, special)
}

/// A hostile model folder; with `special`, links to `/dev/zero`, `/dev/urandom` and
/// FIFOs too.
pub fn hostile_with(rng: &mut Rng, special: bool) -> Case {
    let token = format!("CANARY-{:016x}{:08x}", rng.next(), rng.next() as u32);
    let mut entries: Vec<(String, Entry)> = Vec::new();
    let mut uses_special = false;
    // A special file named only by `plant.v`'s text is read only when that text is the
    // view the run uses (the specifications may name another view, or plant.v may be
    // replaced by a link).
    let mut view_special = false;
    let mut what = Vec::new();
    // The input itself a special file: a generic input (any reader) or the `.l`.
    if special && rng.chance(0.3) {
        let ext = *rng.pick(&["l", "lst", "str", "skel.json", "obj", "glb", "gltf", "toml"]);
        let s = *rng.pick(&[Special::DevZero, Special::DevUrandom, Special::Fifo]);
        let name = format!("input.{ext}");
        entries.push((name.clone(), Entry::Special(s)));
        let target = match ext {
            "l" => Target::Lsystem,
            "lst" => Target::Lst,
            "str" => Target::Str,
            "skel.json" => Target::Json,
            "obj" => Target::Obj,
            "toml" => Target::Recipe,
            _ => Target::Gltf,
        };
        let mut c = Case::new(Class::Hostile, target, format!("input {name} is {s:?}"), Vec::new());
        c.model = Some(Model { entries, input: name });
        c.special = true;
        c.canary = Some(token);
        return c;
    }
    let mut plant = String::new();
    let mut spec_args: Vec<String> = Vec::new();
    let mut view_name = "plant.v".to_string();
    let mut view = String::from("angle factor: 16\ninitial line width: 0.1\n");
    let vectors = 1 + rng.below(3);
    for _ in 0..vectors {
        match rng.below(9) {
            0 => {
                let r = reference(rng, special, &mut uses_special, &mut entries, "view.v");
                view_name = r;
                what.push("specifications: view");
            }
            1 => {
                let flag = *rng.pick(&["-m", "-M", "-m2"]);
                let r = reference(rng, special, &mut uses_special, &mut entries, "colours.map");
                spec_args.push(format!("{flag} {r}"));
                what.push("specifications: colours");
            }
            2 => {
                let r = reference(rng, special, &mut uses_special, &mut entries, "env.e");
                spec_args.push(format!("-e {r}"));
                what.push("specifications: -e");
            }
            3 => {
                // An environment file in the folder whose spec file is hostile.
                let r = reference(rng, special, &mut uses_special, &mut entries, "field.spec");
                entries
                    .push(("field.e".into(), Entry::File(format!("executable: honda81 {r}\n").into_bytes())));
                spec_args.push("-e field.e".into());
                what.push(".e spec path");
            }
            4 => {
                let key = *rng.pick(&["function:", "function set:", "curve:"]);
                let r = reference(rng, special, &mut view_special, &mut entries, "f.func");
                view.push_str(&format!("{key} {r}\n"));
                what.push("view: function/curve");
            }
            5 => {
                let key = *rng.pick(&["surface: l", "line: L"]);
                let r = reference(rng, special, &mut view_special, &mut entries, "leaf.s");
                view.push_str(&format!("{key} {r} 1\n"));
                what.push("view: surface");
            }
            6 => {
                let r = reference(rng, special, &mut view_special, &mut entries, "c.con");
                view.push_str(&format!("contour: 1 {r}\n"));
                what.push("view: contour");
            }
            7 => {
                let r = reference(rng, special, &mut uses_special, &mut entries, "inc.h");
                plant.push_str(&format!("#include \"{r}\"\n"));
                what.push("#include");
            }
            _ => {
                // The view file itself a link (no specifications needed).
                let r = pick_ref(rng, special);
                let e = match r {
                    Ref::Special(s) => {
                        uses_special = true;
                        Entry::Special(s)
                    }
                    _ => Entry::LinkToCanary,
                };
                entries.retain(|(n, _)| n != "plant.v");
                entries.push(("plant.v".into(), e));
                view_name = "plant.v".into();
                what.push("plant.v link");
            }
        }
    }
    plant.push_str(PLANT_L);
    if !entries.iter().any(|(n, _)| n == "plant.v") {
        entries.push(("plant.v".into(), Entry::File(view.into_bytes())));
        uses_special |= view_special && view_name == "plant.v";
    }
    entries.push(("plant.l".into(), Entry::File(plant.into_bytes())));
    entries.push((
        "specifications".into(),
        Entry::File(
            format!("model:\n\tgenerate:\n\t\tcpfg {} plant.l {view_name}\n", spec_args.join(" "))
                .into_bytes(),
        ),
    ));
    let mut c = Case::new(
        Class::Hostile,
        Target::Lsystem,
        format!("hostile folder: {}", what.join(", ")),
        Vec::new(),
    );
    c.model = Some(Model { entries, input: "plant.l".into() });
    c.special = uses_special;
    c.canary = Some(token);
    c
}

// ---------------------------------------------------------------------------------------
// Building and running cases

/// What [`materialize`] built.
#[derive(Debug, Clone)]
pub struct Built {
    /// The input file.
    pub input: PathBuf,
    /// The folder holding the canary (to be left out of output scans).
    pub outside: Option<PathBuf>,
}

/// Writes `c` under `dir` (a fresh folder): the input file, or the model folder
/// `dir/model` with the canary in `dir/outside`.
pub fn materialize(c: &Case, dir: &Path) -> std::io::Result<Built> {
    std::fs::create_dir_all(dir)?;
    let Some(m) = &c.model else {
        let input = dir.join(c.file_name());
        std::fs::write(&input, &c.bytes)?;
        return Ok(Built { input, outside: None });
    };
    let outside = dir.join(OUTSIDE);
    std::fs::create_dir_all(&outside)?;
    let canary = outside.join(CANARY_FILE);
    std::fs::write(&canary, canary_text(c.canary.as_deref().unwrap_or("CANARY-0")))?;
    let canary = std::fs::canonicalize(&canary)?;
    let model = dir.join("model");
    std::fs::create_dir_all(&model)?;
    for (name, e) in &m.entries {
        let p = model.join(name);
        // A name listed twice: the later entry replaces the earlier one.
        if std::fs::symlink_metadata(&p).is_ok() {
            std::fs::remove_file(&p)?;
        }
        match e {
            Entry::File(b) => {
                let text = String::from_utf8_lossy(b)
                    .replace("{ABS}", &canary.display().to_string())
                    .replace("{REL}", &format!("../{OUTSIDE}/{CANARY_FILE}"));
                std::fs::write(&p, text)?;
            }
            Entry::LinkToCanary => std::os::unix::fs::symlink(&canary, &p)?,
            Entry::LinkToOutside => std::os::unix::fs::symlink(canary.parent().unwrap_or(&canary), &p)?,
            Entry::Special(Special::DevZero) => std::os::unix::fs::symlink("/dev/zero", &p)?,
            Entry::Special(Special::DevUrandom) => std::os::unix::fs::symlink("/dev/urandom", &p)?,
            Entry::Special(Special::Fifo) => {
                let cpath = std::ffi::CString::new(p.as_os_str().as_encoded_bytes()).expect("path");
                // SAFETY: mkfifo with a valid NUL-terminated path.
                if unsafe { libc::mkfifo(cpath.as_ptr(), 0o600) } != 0 {
                    return Err(std::io::Error::last_os_error());
                }
            }
        }
    }
    Ok(Built { input: model.join(&m.input), outside: Some(outside) })
}

/// The largest message a run may print: an excerpt is a few hundred characters, so
/// anything this long copies a whole line or a file.
pub const MAX_MESSAGE: usize = 64 * 1024;

/// What an in-process run of a case said and did.
#[derive(Debug, Clone)]
pub struct CaseRun {
    /// `Ok(summary)` or `Err(message)`, the message rendered as the CLI prints it
    /// (narrated: source excerpts included).
    pub result: Result<String, String>,
    /// Every message: the rendered error and the warnings.
    pub messages: String,
    /// The canary's bytes found in a message or an output file (where).
    pub canary_hits: Vec<String>,
}

/// Renders an error the way a report handler does, excerpts included (the narratable
/// handler: the graphical one is the CLI's, behind miette's `fancy` feature).
pub fn render(d: &dyn miette::Diagnostic) -> String {
    let mut s = String::new();
    if miette::NarratableReportHandler::new().render_report(&mut s, d).is_err() {
        s = format!("{d}");
    }
    s
}

/// Runs `c` in-process under `work` (the caller's scratch folder): builds it, reads it
/// with its reader and (with [`Depth::Pipeline`]) grows and writes it, to `out.<ext>`
/// with `ext` from `out_ext`. Panics propagate.
pub fn run_case(c: &Case, work: &Path, depth: Depth, out_ext: &str) -> CaseRun {
    let dir = work.join("case");
    let _ = std::fs::remove_dir_all(&dir);
    let mut warnings: Vec<String> = Vec::new();
    let result = match materialize(c, &dir) {
        Err(e) => Err(format!("harness: cannot build the case: {e}")),
        Ok(built) => run_built(c, &built, work, depth, out_ext, &mut warnings),
    };
    let mut messages = match &result {
        Ok(m) | Err(m) => m.clone(),
    };
    for w in &warnings {
        messages.push('\n');
        messages.push_str(w);
    }
    let mut canary_hits = Vec::new();
    if let Some(token) = &c.canary {
        if messages.contains(token.as_str()) {
            canary_hits.push("a message".into());
        }
        let skip = dir.join(OUTSIDE);
        for f in files_under(work) {
            if f.starts_with(&skip) || f.starts_with(dir.join("model")) {
                continue;
            }
            if file_contains(&f, token.as_bytes()) {
                canary_hits.push(f.display().to_string());
            }
        }
    }
    CaseRun { result, messages, canary_hits }
}

fn run_built(
    c: &Case,
    built: &Built,
    work: &Path,
    depth: Depth,
    out_ext: &str,
    warnings: &mut Vec<String>,
) -> Result<String, String> {
    use sylva::recipe;
    let deep = depth == Depth::Pipeline;
    let out = work.join(format!("out.{out_ext}"));
    let mut sets = Vec::new();
    let set_lines: Vec<String> = if c.target == Target::Set {
        String::from_utf8_lossy(&c.bytes).lines().skip(1).map(str::to_string).chain(c.sets.clone()).collect()
    } else {
        c.sets.clone()
    };
    for l in &set_lines {
        sets.push(recipe::parse_set(l).map_err(|e| render(&e))?);
    }
    sets.push(("output.textures".into(), toml::Value::String("none".into())));
    let grow =
        |what: &str, sets: &[(String, toml::Value)], warnings: &mut Vec<String>| -> Result<String, String> {
            let loaded = recipe::load(what, sets).map_err(|e| render(&e))?;
            if deep {
                let grow_and_write = || {
                    let g = sylva::pipeline::grow(&loaded)?;
                    sylva::export::write(&g.model, &out)?;
                    Ok(g)
                };
                // Raised budgets run under the time limit, growing and writing (the
                // CLI's `--time-limit` covers both too).
                let g = if c.class == Class::RaisedBudgets {
                    with_time_limit(RAISED_TIME_LIMIT_S, grow_and_write)?
                } else {
                    grow_and_write().map_err(|e: sylva::Error| render(&e))?
                };
                warnings.extend(g.report.warnings.iter().cloned());
                Ok(format!("{} nodes", g.skeleton.len()))
            } else if c.class == Class::RaisedBudgets {
                Ok("recipe checked".into())
            } else {
                let mut report = sylva::pipeline::Report::default();
                let g = sylva::pipeline::skeleton(&loaded, &mut report).map_err(|e| render(&e))?;
                warnings.extend(report.warnings.iter().cloned());
                g.skeleton.validate().map_err(|e| format!("generator returned an invalid skeleton: {e}"))?;
                Ok(format!("{} nodes", g.skeleton.len()))
            }
        };
    let small = |sets: &mut Vec<(String, toml::Value)>| {
        if !deep {
            sets.push(("generator.max_modules".into(), toml::Value::Integer(200_000)));
        }
    };
    let path = built.input.display().to_string();
    match c.target {
        Target::Set => {
            let base = String::from_utf8_lossy(&c.bytes)
                .lines()
                .next()
                .unwrap_or("lsys-binary-tree")
                .trim()
                .to_string();
            if !deep && c.class != Class::RaisedBudgets {
                let loaded = recipe::load(&base, &sets).map_err(|e| render(&e))?;
                if !matches!(loaded.recipe.generator, recipe::Generator::Lsystem(_)) {
                    return Ok("recipe checked".into());
                }
            }
            small(&mut sets);
            grow(&base, &sets, warnings)
        }
        Target::Lsystem | Target::Recipe => {
            small(&mut sets);
            grow(&path, &sets, warnings)
        }
        Target::Lst | Target::Json | Target::Str => {
            if !deep && c.model.is_none() {
                // The reader alone (fast in debug), then the recipe route.
                let text = String::from_utf8_lossy(&c.bytes);
                match c.target {
                    Target::Lst => {
                        use sylva::import::lst::{parse, GapPolicy, LstOptions};
                        let gap = if c.sets.iter().any(|s| s.contains("new-root")) {
                            GapPolicy::NewRoot
                        } else {
                            GapPolicy::Bridge
                        };
                        let sk = parse("input.lst", &text, &LstOptions { gap, ..Default::default() })
                            .map_err(|e| render(&*e))?;
                        sk.validate().map_err(|e| format!("LST reader returned an invalid skeleton: {e}"))?;
                        return Ok(format!("{} nodes", sk.len()));
                    }
                    Target::Json => {
                        let sk = sylva::import::skel_json::from_json(&text).map_err(|e| render(&e))?;
                        sk.validate()
                            .map_err(|e| format!("JSON reader returned an invalid skeleton: {e}"))?;
                        return Ok(format!("{} nodes", sk.len()));
                    }
                    _ => {}
                }
            }
            grow(&path, &sets, warnings)
        }
        Target::Obj => {
            let obj = sylva::mesh::obj_read::read_obj(&built.input).map_err(|e| render(&e))?;
            let _ = sylva::mesh::check::check_mesh(&obj.mesh, &Default::default());
            Ok(format!("{} faces", obj.mesh.face_count()))
        }
        Target::Gltf => {
            let meshes = sylva::import::gltf_read::read_gltf(&built.input).map_err(|e| render(&e))?;
            let mut faces = 0;
            for mut g in meshes {
                sylva::import::gltf_read::weld(&mut g.mesh);
                faces += g.mesh.face_count();
                let _ = sylva::mesh::check::check_mesh(&g.mesh, &Default::default());
            }
            Ok(format!("checked {faces} faces"))
        }
    }
}

/// Every regular file under `dir` (symlinks not followed).
pub fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let Ok(ft) = e.file_type() else { continue };
            if ft.is_dir() {
                stack.push(e.path());
            } else if ft.is_file() {
                out.push(e.path());
            }
        }
    }
    out.sort();
    out
}

/// Whether the regular file `f` contains `needle` (read in chunks; at most 2 GiB).
pub fn file_contains(f: &Path, needle: &[u8]) -> bool {
    use std::io::Read;
    let Ok(mut file) = std::fs::File::open(f) else { return false };
    let mut buf = vec![0u8; 1 << 20];
    let mut carry: Vec<u8> = Vec::new();
    let mut total = 0usize;
    loop {
        let Ok(n) = file.read(&mut buf) else { return false };
        if n == 0 || total > 1 << 31 {
            return false;
        }
        total += n;
        carry.extend_from_slice(&buf[..n]);
        if carry.windows(needle.len()).any(|w| w == needle) {
            return true;
        }
        let keep = needle.len().saturating_sub(1).min(carry.len());
        carry.drain(..carry.len() - keep);
    }
}
