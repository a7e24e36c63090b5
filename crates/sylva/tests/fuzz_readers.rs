//! Bounded fuzzing of every reader in `cargo test` (issue 27, `docs/robustness.md`).
//!
//! Each test feeds a seeded stream of inputs — the presets and a few cpfg models mutated
//! token by token and byte by byte, and structure-aware generated files — through one
//! reader, each call under a wall-clock watchdog, and fails on a panic or a call still
//! running after the timeout. A test stops after its time budget (≈ 15 s in debug) or
//! its case count, whichever comes first; `SYLVA_FUZZ_CASES` and `SYLVA_FUZZ_SECONDS`
//! raise both for a longer local run, `SYLVA_FUZZ_SEED` picks another stream. Every
//! crash found is kept as a named test in `fuzz_regressions.rs`; the long campaign is
//! `examples/fuzz_campaign.rs`.

mod fuzz_support;

use fuzz_support::{campaign, Target};
use proptest::prelude::*;
use std::time::Duration;

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

fn fuzz(t: Target, cases: u64) {
    let seed = env_or("SYLVA_FUZZ_SEED", 27);
    let cases = env_or("SYLVA_FUZZ_CASES", cases) as usize;
    let budget = Duration::from_secs(env_or("SYLVA_FUZZ_SECONDS", 15));
    // Generous: one reader call takes milliseconds; a hang is what this catches.
    let timeout = Duration::from_secs(env_or("SYLVA_FUZZ_TIMEOUT", 20));
    let failures = campaign(t, seed, cases, timeout, budget);
    assert!(failures.is_empty(), "{} fuzz failure(s):\n\n{}", failures.len(), failures.join("\n\n"));
}

/// One `#[test]` per reader: `name: Target, cases;` runs [`fuzz`] on that target.
macro_rules! fuzz_tests {
    ($($name:ident: $target:ident, $cases:literal;)*) => {
        $(
            #[test]
            fn $name() {
                fuzz(Target::$target, $cases);
            }
        )*
    };
}

fuzz_tests! {
    fuzz_lsystem_files: Lsystem, 400;
    fuzz_recipes: Recipe, 300;
    fuzz_set_values: Set, 600;
    fuzz_lst: Lst, 1500;
    fuzz_cpfg_str: Str, 1500;
    fuzz_json_skeletons: Json, 1500;
    fuzz_obj: Obj, 600;
    fuzz_gltf: Gltf, 300;
}

/// Replays one input: `SYLVA_FUZZ_REPLAY=file SYLVA_FUZZ_TARGET=lst cargo test -p sylva
/// --test fuzz_readers replay -- --ignored --nocapture` (with `SYLVA_FUZZ_FOLDER` for an
/// L-system from a cpfg model folder, `SYLVA_FUZZ_DEEP=1` for the whole pipeline).
#[test]
#[ignore]
fn replay() {
    let path = std::env::var("SYLVA_FUZZ_REPLAY").expect("SYLVA_FUZZ_REPLAY=file");
    let name = std::env::var("SYLVA_FUZZ_TARGET").expect("SYLVA_FUZZ_TARGET=lsystem|recipe|…");
    let t = *Target::ALL.iter().find(|t| t.name() == name).expect("a target name");
    let bytes = std::fs::read(&path).expect("readable input");
    let folder = std::env::var("SYLVA_FUZZ_FOLDER").ok().map(std::path::PathBuf::from);
    let depth = if std::env::var("SYLVA_FUZZ_DEEP").is_ok() {
        fuzz_support::Depth::Pipeline
    } else {
        fuzz_support::Depth::Reader
    };
    let work = fuzz_support::scratch("replay");
    let t0 = std::time::Instant::now();
    let r = fuzz_support::run_input(t, &bytes, folder.as_deref(), &work, depth);
    println!("{:?} in {:.2} s", r, t0.elapsed().as_secs_f64());
}

// ---------------------------------------------------------------------------------------
// The failure classes of issue 39 (`fuzz_support::classes`), a few cases each. The
// tests that are not ignored check what holds whatever the fixes' state (no panic, no
// hang of the readers, the generators make what they say); the ignored ones check the
// fixed behaviour and name the issue item they wait for.

use fuzz_support::classes::{self, Case, CaseRun, Class};
use fuzz_support::{watchdog, Depth, Outcome, Rng};

/// Runs `cases` in-process at `depth`, each under the watchdog, and returns one line
/// per failure: a panic, a run over the timeout, or what `check` objects to.
fn run_cases(
    cases: Vec<Case>,
    depth: Depth,
    timeout_s: u64,
    check: fn(&Case, &CaseRun) -> Option<String>,
) -> Vec<String> {
    let timeout = Duration::from_secs(env_or("SYLVA_FUZZ_TIMEOUT", timeout_s));
    let mut failures = Vec::new();
    for (k, c) in cases.into_iter().enumerate() {
        let work = fuzz_support::scratch(&format!("class-{}", c.class.name()));
        let (c2, w2) = (c.clone(), work.clone());
        let outcome = watchdog(timeout, move || classes::run_case(&c2, &w2, depth, "glb"));
        let what = format!("{} case {k} ({}, {})", c.class.name(), c.target.name(), c.what);
        match outcome {
            Outcome::Done(run) => {
                if let Some(why) = check(&c, &run) {
                    let m: String = run.messages.chars().take(600).collect();
                    failures.push(format!("{what}: {why}\n  said: {m}"));
                }
            }
            Outcome::Panicked(m) => failures.push(format!("{what}: panic: {m}")),
            Outcome::TimedOut(d) => {
                failures.push(format!("{what}: still running after {:.1} s", d.as_secs_f64()))
            }
        }
        let _ = std::fs::remove_dir_all(&work);
    }
    failures
}

fn assert_none(failures: Vec<String>) {
    assert!(failures.is_empty(), "{} failure(s):\n\n{}", failures.len(), failures.join("\n\n"));
}

/// Runs cases `0..n` of `class` (case `k` made by `make` from its own seeded stream and
/// `k`) as [`run_cases`] does, and fails on any failure.
fn check_class(
    class: Class,
    n: u64,
    make: impl Fn(&mut Rng, u64) -> Case,
    depth: Depth,
    timeout_s: u64,
    check: fn(&Case, &CaseRun) -> Option<String>,
) {
    let cases = (0..n).map(|k| make(&mut seeded(class, k), k)).collect();
    assert_none(run_cases(cases, depth, timeout_s, check));
}

fn seeded(class: Class, k: u64) -> Rng {
    Rng::new(env_or("SYLVA_FUZZ_SEED", 39) ^ (class as u64) << 40 ^ k.wrapping_mul(0x9E37))
}

fn no_check(_: &Case, _: &CaseRun) -> Option<String> {
    None
}

fn must_fail(_: &Case, r: &CaseRun) -> Option<String> {
    r.result.is_ok().then(|| "the broken input was accepted".to_string())
}

fn clipped(c: &Case, r: &CaseRun) -> Option<String> {
    must_fail(c, r).or_else(|| {
        let n = r.result.as_ref().err().map_or(0, String::len);
        (n > classes::MAX_MESSAGE).then(|| format!("a message of {n} bytes (the excerpt is not clipped)"))
    })
}

fn no_leak(_: &Case, r: &CaseRun) -> Option<String> {
    (!r.canary_hits.is_empty()).then(|| format!("the canary file's content is in {:?}", r.canary_hits))
}

fn refused(c: &Case, r: &CaseRun) -> Option<String> {
    no_leak(c, r).or_else(|| r.result.is_ok().then(|| "a special file was read as a model".to_string()))
}

fn names_a_key(_: &Case, r: &CaseRun) -> Option<String> {
    let m = r.result.as_ref().err()?;
    (!m.contains('.')).then(|| "the refusal names no key".to_string())
}

/// Every class's generator is deterministic: the same stream gives the same case.
#[test]
fn class_generators_are_deterministic() {
    for c in Class::ALL {
        for k in 0..3 {
            let a = classes::generate(&mut seeded(c, k), c);
            let b = classes::generate(&mut seeded(c, k), c);
            assert_eq!(a.bytes, b.bytes, "{c:?}");
            assert_eq!(a.sets, b.sets, "{c:?}");
            assert_eq!(a.what, b.what, "{c:?}");
        }
    }
}

/// Long lines (issue 39 item 1): every reader refuses a 100k–300k-character line with
/// an error far in, without panicking (the reader's error; the CLI's graphical
/// renderer is the campaign's CLI lane).
#[test]
fn class_long_lines_fail_cleanly() {
    check_class(Class::LongLine, 14, |r, _| classes::long_line(r), Depth::Reader, 60, must_fail);
}

/// Long lines, item 1's fix: the rendered message quotes a clipped excerpt, not the line.
#[test]
fn class_long_line_messages_are_clipped() {
    check_class(Class::LongLine, 21, |r, _| classes::long_line(r), Depth::Reader, 60, clipped);
}

/// Deep nesting at depths that fit today's stacks (≤ 500): no panic, no hang.
#[test]
fn class_deep_nesting_shallow() {
    let make = |r: &mut Rng, k: u64| classes::deep_nesting_at(r, 100 + 40 * k as usize);
    check_class(Class::DeepNesting, 12, make, Depth::Reader, 60, no_check);
}

/// Deep nesting, item 2's fix: 10³–10⁵ levels are read or refused with a located
/// error. Today this aborts the test process (stack overflow).
#[test]
fn class_deep_nesting_does_not_overflow() {
    check_class(Class::DeepNesting, 24, |r, _| classes::deep_nesting(r), Depth::Reader, 60, no_check);
}

/// Degenerate skeletons (coincident, zero-length, zig-zag, jittered, 1e30 and 1e-30)
/// are read into valid skeletons or refused with a located error.
#[test]
fn class_degenerate_skeletons_read_cleanly() {
    let make = |r: &mut Rng, _| {
        let n = classes::log_uniform(r, 100, 3000);
        classes::degenerate_n(r, n)
    };
    check_class(Class::Degenerate, 18, make, Depth::Reader, 60, no_check);
}

/// Degenerate skeletons through the meshers and passes, items 5 and 6's fix: they
/// grow or stop with a named error (the watchdog's limit is for debug builds).
#[test]
fn class_degenerate_skeletons_grow() {
    check_class(Class::Degenerate, 12, |r, _| classes::degenerate_n(r, 400), Depth::Pipeline, 120, no_check);
}

/// Many roots (LST with `generator.gap = new-root`, JSON): read cleanly.
#[test]
fn class_many_roots_read_cleanly() {
    let make = |r: &mut Rng, k: u64| classes::many_roots_n(r, 100 + 400 * k as usize);
    check_class(Class::ManyRoots, 8, make, Depth::Reader, 60, no_check);
}

/// Many roots through the meshers, item 4's fix (per-root work local to each root).
#[test]
fn class_many_roots_grow() {
    check_class(Class::ManyRoots, 4, |r, _| classes::many_roots_n(r, 2000), Depth::Pipeline, 120, no_check);
}

/// Absurd numbers in `--set` (1e9, 1e30, -1, 0, NaN text, floats for integers): the
/// recipe loads or is refused; L-systems derive under a small module budget.
#[test]
fn class_absurd_numbers_load_or_fail_cleanly() {
    check_class(Class::AbsurdNumbers, 40, |r, _| classes::absurd_numbers(r), Depth::Reader, 60, no_check);
}

/// Absurd numbers, item 15's fix: a refused value names its whole key.
#[test]
fn class_absurd_numbers_name_their_key() {
    let mut failures = Vec::new();
    for k in 0..60 {
        let c = classes::absurd_numbers(&mut seeded(Class::AbsurdNumbers, k));
        let text = String::from_utf8_lossy(&c.bytes).into_owned();
        let mut lines = text.lines();
        let base = lines.next().unwrap_or_default();
        let lines: Vec<&str> = lines.collect();
        let keys: Vec<&str> = lines.iter().filter_map(|l| l.split_once('=').map(|(k, _)| k)).collect();
        let sets: Result<Vec<_>, _> = lines.iter().map(|l| sylva::recipe::parse_set(l)).collect();
        let r = sets.and_then(|s| sylva::recipe::load(base, &s).map(|_| ()));
        if let Err(e) = r {
            let m = format!("{e}");
            // The whole key, or for an unknown key the table that does not exist.
            let named = |k: &&str| {
                m.contains(*k)
                    || (m.contains("unknown key")
                        && k.match_indices('.')
                            .any(|(at, _)| at > 0 && m.contains(&format!("`{}`", &k[..at]))))
            };
            if !keys.iter().any(named) {
                failures.push(format!("{}: {lines:?}: {m}", c.what));
            }
        }
    }
    assert_none(failures);
}

/// Raised budgets (10⁹–10¹²): the recipe loads or names the key it refuses. Growing
/// them is the campaign's (release, 10 s, 6 GiB).
#[test]
fn class_raised_budgets_load_or_fail_cleanly() {
    check_class(Class::RaisedBudgets, 30, |r, _| classes::raised_budgets(r), Depth::Reader, 60, names_a_key);
}

/// glTF with a primitive repeated, or many triangles on few vertices: read, welded and
/// checked (small sizes; the campaign runs the sizes).
#[test]
fn class_dup_gltf_reads_and_checks() {
    let mut cases = Vec::new();
    for k in 0..3 {
        cases.push(classes::dup_gltf_sized(&mut seeded(Class::DupGltf, k), 4 + k as usize, 0));
        cases.push(classes::dup_gltf_sized(&mut seeded(Class::DupGltf, k), 0, 1500));
    }
    assert_none(run_cases(cases, Depth::Reader, 60, |_, r| {
        r.result.as_ref().err().map(|m| format!("a valid glTF was refused: {m}"))
    }));
}

/// The glTF sizes, item 7's fix (`sylva check` speed).
#[test]
fn class_dup_gltf_full_size() {
    check_class(Class::DupGltf, 4, |r, _| classes::dup_gltf(r), Depth::Reader, 120, no_check);
}

/// Hostile model folders (absolute, `../` and symlinked side files, `#include`) without
/// special files: no panic, no hang.
#[test]
fn class_hostile_folders_run_cleanly() {
    check_class(Class::Hostile, 16, |r, _| classes::hostile_with(r, false), Depth::Reader, 60, no_check);
}

/// Hostile model folders, item 14's fix: no byte of the canary file outside the folder
/// reaches a message or an output.
#[test]
fn class_hostile_folders_do_not_leak() {
    check_class(Class::Hostile, 40, |r, _| classes::hostile_with(r, false), Depth::Reader, 60, no_leak);
}

/// Special files behind inputs and side files, item 9's fix: `/dev/zero`,
/// `/dev/urandom` and FIFOs are refused (not read to the memory limit, not waited on).
#[test]
fn class_special_files_are_refused() {
    let cases = (0..30)
        .map(|k| classes::hostile_with(&mut seeded(Class::Hostile, k), true))
        .filter(|c| c.special)
        .collect();
    assert_none(run_cases(cases, Depth::Reader, 30, refused));
}

// ---------------------------------------------------------------------------------------
// Structure-aware proptest generators (shrinking to a minimal failing file).

/// One LST operation with arbitrary (often nasty) numbers.
fn lst_op() -> impl Strategy<Value = String> {
    let n = prop_oneof![
        4 => -10.0f64..10.0,
        1 => prop::sample::select(vec![0.0, -0.0, 1e308, -1e308, 3.4e38, 1e-308, 1e30, -1.0]),
    ];
    prop_oneof![
        Just("SB()".to_string()),
        Just("EB()".to_string()),
        (n.clone(), n.clone(), n.clone()).prop_map(|(x, y, z)| format!("MovRel3f({x:e}, {y:e}, {z:e})")),
        (n.clone(), n.clone(), n.clone(), n.clone())
            .prop_map(|(a, x, y, z)| format!("RotRel3f({a:e}, {x:e}, {y:e}, {z:e})")),
        (n.clone(), n.clone(), n).prop_map(|(a, b, l)| format!("Cylinder({a:e}, {b:e}, {l:e})")),
    ]
}

/// A JSON node with a parent anywhere (before, after, itself, far out of range).
fn json_node(i: usize) -> impl Strategy<Value = String> {
    let coord =
        prop_oneof![4 => -5.0f32..5.0, 1 => prop::sample::select(vec![0.0f32, 3.4e38, -3.4e38, 1e-38])];
    let parent = prop_oneof![
        4 => (0..i.max(1) as u32).prop_map(|p| p.to_string()),
        1 => Just("null".to_string()),
        1 => prop::sample::select(vec![i as u32, i as u32 + 1, 4294967294, 4294967295]).prop_map(|p| p.to_string()),
    ];
    (coord.clone(), coord.clone(), coord, -1.0f32..1.0, parent).prop_map(move |(x, y, z, r, p)| {
        let p = if i == 0 { "null".to_string() } else { p };
        format!("{{\"position\":[{x:e},{y:e},{z:e}],\"radius\":{r:e},\"parent\":{p}}}")
    })
}

fn json_doc() -> impl Strategy<Value = String> {
    (1usize..24).prop_flat_map(|n| {
        (0..n).map(json_node).collect::<Vec<_>>().prop_map(|nodes| {
            format!("{{\"format\":\"sylva-skeleton\",\"version\":1,\"nodes\":[{}]}}", nodes.join(","))
        })
    })
}

fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases: env_or("SYLVA_FUZZ_CASES", cases as u64) as u32,
        failure_persistence: None,
        rng_algorithm: prop::test_runner::RngAlgorithm::ChaCha,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config(300))]

    /// Any sequence of LST operations is read into a valid skeleton or refused with a
    /// located error, under every gap policy, and a valid skeleton meshes.
    #[test]
    fn lst_operations_read_or_fail_cleanly(ops in prop::collection::vec(lst_op(), 0..40)) {
        let text = format!("LST 0.1\n{}\n", ops.join("\n"));
        for gap in [sylva::import::lst::GapPolicy::Bridge, sylva::import::lst::GapPolicy::Strict, sylva::import::lst::GapPolicy::NewRoot] {
            let opts = sylva::import::lst::LstOptions { gap, ..Default::default() };
            match sylva::import::lst::parse("p.lst", &text, &opts) {
                Ok(sk) => {
                    prop_assert!(sk.validate().is_ok(), "{:?}", sk.validate());
                    if sk.len() > 1 {
                        let _ = sylva::mesh::tube::tube_mesh(&sk, &Default::default());
                    }
                }
                Err(e) => prop_assert!(e.message.starts_with("p.lst:"), "{}", e.message),
            }
        }
    }

    /// Any JSON skeleton document is read into a valid skeleton or refused.
    #[test]
    fn json_documents_read_or_fail_cleanly(doc in json_doc()) {
        if let Ok(sk) = sylva::import::skel_json::from_json(&doc) {
            prop_assert!(sk.validate().is_ok());
            let _ = sylva::mesh::tube::tube_mesh(&sk, &Default::default());
        }
    }
}
