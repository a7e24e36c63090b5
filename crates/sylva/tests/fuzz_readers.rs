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

#[test]
fn fuzz_lsystem_files() {
    fuzz(Target::Lsystem, 400);
}

#[test]
fn fuzz_recipes() {
    fuzz(Target::Recipe, 300);
}

#[test]
fn fuzz_set_values() {
    fuzz(Target::Set, 600);
}

#[test]
fn fuzz_lst() {
    fuzz(Target::Lst, 1500);
}

#[test]
fn fuzz_cpfg_str() {
    fuzz(Target::Str, 1500);
}

#[test]
fn fuzz_json_skeletons() {
    fuzz(Target::Json, 1500);
}

#[test]
fn fuzz_obj() {
    fuzz(Target::Obj, 600);
}

#[test]
fn fuzz_gltf() {
    fuzz(Target::Gltf, 300);
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
