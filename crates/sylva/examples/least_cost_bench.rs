//! Times MGV least-cost-path trees at the sizes of seed 004 Table 6.2 (graph nodes /
//! endpoints: 150 k / 7.5 k, 600 k / 19 k, 200 k / 4 k): graph, paths (Dijkstra and
//! endpoints), thickness + skeleton, total; best and median of `runs` runs.
//!
//! ```text
//! cargo run --release -p sylva --example least_cost_bench            # all three sizes, 5 runs
//! cargo run --release -p sylva --example least_cost_bench -- 600 1   # only 600 k, one run
//! ```
//!
//! The recipe is `bench/least-cost/mgv-bench.toml` (a 10 m cube, trunk, crown volume,
//! two rounds of surface endpoints); the endpoint counts are split 5 % / 32 % / 63 %
//! over iterations 2–4.

use rand::SeedableRng;
use sylva::grow::least_cost::{self as lc, graph, paths, LeastCostParams};
use sylva::recipe::{self, Generator};

fn params(nodes: usize, endpoints: usize) -> LeastCostParams {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../bench/least-cost/mgv-bench.toml");
    let loaded = recipe::load(path, &[]).expect("bench recipe loads");
    let Generator::LeastCost(p) = loaded.recipe.generator else { panic!("a least-cost recipe") };
    let mut p = *p;
    p.nodes = nodes;
    let split = [endpoints * 5 / 100, endpoints * 32 / 100];
    p.iterations[1].count = split[0];
    p.iterations[2].count = split[1];
    p.iterations[3].count = endpoints - split[0] - split[1];
    p
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let only: Option<usize> = args.first().and_then(|a| a.parse().ok());
    let runs: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(5);
    println!("threads: {}", rayon::current_num_threads());
    for (k, e) in [(150, 7500), (600, 19_000), (200, 4000)] {
        if only.is_some_and(|o| o != k) {
            continue;
        }
        let p = params(k * 1000, e);
        let mut totals = Vec::new();
        let mut last = None;
        for seed in 0..runs as u64 {
            let t = std::time::Instant::now();
            let tree = lc::grow(&p, seed + 1, None).expect("grows");
            totals.push(t.elapsed().as_secs_f64());
            last = Some(tree.report);
        }
        totals.sort_by(f64::total_cmp);
        // Graph stages separately: Poisson sampling, then the Yao build.
        let vol = p.graph_volume();
        let t = std::time::Instant::now();
        let m = vol.measure(3, 1);
        let d = graph::auto_spacing(m, p.nodes, 3);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        let s = graph::poisson(&vol, p.nodes, d, Some(vol.bottom_center(3)), 3, &mut rng).expect("samples");
        let t_poisson = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let (pos, root) = graph::spatial_sort(&s.points, d, 0);
        let g = graph::yao(pos, 8, 3, d as f32, root);
        let t_yao = t.elapsed().as_secs_f64();
        let t = std::time::Instant::now();
        let _ = paths::dijkstra(&g, &[g.root], None, &mut paths::Length);
        println!(
            "  graph stages: poisson {t_poisson:.3} s, sort + yao {t_yao:.3} s; one length-weight Dijkstra {:.3} s",
            t.elapsed().as_secs_f64()
        );
        let r = last.expect("at least one run");
        println!(
            "{k}k nodes / {e} endpoints: best {:.3} s, median {:.3} s | last run: graph {:.3} s, paths {:.3} s, skeleton {:.3} s; {} edges, graph {:.1} MiB, {} endpoints, {} tips, {} skeleton nodes, {} unreachable",
            totals[0],
            totals[totals.len() / 2],
            r.graph_time.as_secs_f64(),
            r.path_time.as_secs_f64(),
            r.skeleton_time.as_secs_f64(),
            r.graph_edges,
            r.graph_bytes as f64 / (1 << 20) as f64,
            r.endpoints,
            r.tips,
            r.nodes,
            r.unreachable
        );
    }
}
