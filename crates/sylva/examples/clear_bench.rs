//! Times the mesh clearing (`sylva::fit::clear`, issue 44 item 1) of a preset with each
//! junction mesher, and hashes what it grows so a speedup can be shown to leave the
//! output as it was (a developer tool).
//!
//! For each mesher named (default `hull sweep quad`) it grows the preset `--runs` times
//! (default 3) in two configurations: `plain` (`mesh.method=M`, textures off: the
//! command of BENCHMARKS.md's "mesh clearing" rows) and `golden` (the keys of
//! `tests/data/golden.sha256`'s `hull`/`sweep`/`quad` rows: refinement level 1). It
//! prints the fit stage's and the clearing's times, the clearing's report and the
//! SHA-256 of the `.glb`, and for `golden` whether it matches the committed hash.
//!
//! ```text
//! cargo run --release -p sylva --example clear_bench -- wp-quaking-aspen
//! cargo run --release -p sylva --example clear_bench -- wp-quaking-aspen quad --runs 1 --only plain
//! RAYON_NUM_THREADS=1 cargo run --release -p sylva --example clear_bench -- wp-quaking-aspen
//! ```

use sha2::{Digest, Sha256};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let positional: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| !a.starts_with("--") && (*i == 0 || !args[i - 1].starts_with("--")))
        .map(|(_, a)| a)
        .collect();
    let Some(preset) = positional.first() else {
        eprintln!("usage: clear_bench PRESET [hull|sweep|quad]... [--runs N] [--only plain|golden]");
        std::process::exit(2);
    };
    let mut meshers: Vec<&str> = positional[1..].iter().map(|s| s.as_str()).collect();
    if meshers.is_empty() {
        meshers = vec!["hull", "sweep", "quad"];
    }
    let runs: usize = flag("--runs").map(|s| s.parse()).transpose()?.unwrap_or(3);
    let only = flag("--only");
    let golden_file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden.sha256");
    let golden = std::fs::read_to_string(golden_file)?;
    for mesher in meshers {
        let scheme = if mesher == "quad" { "catmull-clark" } else { "loop" };
        let configs: [(&str, Vec<String>); 2] = [
            ("plain", vec![format!("mesh.method=\"{mesher}\""), "output.textures=\"none\"".into()]),
            (
                "golden",
                vec![
                    format!("mesh.method=\"{mesher}\""),
                    format!("refine.scheme=\"{scheme}\""),
                    "refine.levels=1".into(),
                ],
            ),
        ];
        for (name, keys) in &configs {
            if only.as_deref().is_some_and(|o| o != *name) {
                continue;
            }
            let sets = keys.iter().map(|k| sylva::recipe::parse_set(k)).collect::<Result<Vec<_>, _>>()?;
            let loaded = sylva::recipe::load(preset, &sets)?;
            for run in 0..runs {
                let t = std::time::Instant::now();
                let grown = sylva::pipeline::grow(&loaded);
                let total = t.elapsed();
                let bytes = match &grown {
                    Ok(g) => sylva::export::gltf::to_glb(&g.model)?,
                    Err(e) => format!("error: {e}").into_bytes(),
                };
                let hash: String = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect();
                let verdict = if *name == "golden" {
                    let line = format!("{mesher} {preset} {hash}");
                    if golden.lines().any(|l| l == line) {
                        " (= golden)"
                    } else {
                        " (NOT golden)"
                    }
                } else {
                    ""
                };
                let Ok(g) = grown else {
                    println!("{mesher} {name} run {run}: error, sha {hash}{verdict}");
                    continue;
                };
                let fit =
                    g.report.stage_times.iter().find(|(s, _)| *s == "fit").map(|x| x.1).unwrap_or_default();
                let c = g.report.clear.clone().unwrap_or_default();
                println!(
                    "{mesher} {name} run {run}: grow {:.0} ms, fit {:.0} ms, clear {:.0} ms ({:?} -> {:?} pairs, {} rounds, {} thinned; triangles searched {:?}; junction groups reused/searched {:?}), {} triangles, sha {}{verdict}",
                    total.as_secs_f64() * 1e3,
                    fit.as_secs_f64() * 1e3,
                    c.elapsed.as_secs_f64() * 1e3,
                    c.before,
                    c.after,
                    c.rounds,
                    c.thinned,
                    c.searched.iter().map(|[n, s]| format!("{s}/{n}")).collect::<Vec<_>>(),
                    c.groups_reused,
                    g.report.triangles,
                    &hash[..16],
                );
            }
        }
    }
    Ok(())
}
