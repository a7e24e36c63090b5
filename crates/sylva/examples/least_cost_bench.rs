//! Times MGV least-cost-path trees at the sizes of Xu2015 Table 6.2 (graph nodes /
//! endpoints: 150 k / 7.5 k, 600 k / 19 k, 200 k / 4 k): graph, paths (Dijkstra and
//! endpoints), thickness + skeleton, total; best and median of `runs` runs, with the
//! process CPU time (user + system, all threads) next to the wall time.
//!
//! ```text
//! cargo run --release -p sylva --example least_cost_bench            # all three sizes, 5 runs
//! cargo run --release -p sylva --example least_cost_bench -- 600 1   # only 600 k, one run
//! cargo run --release -p sylva --example least_cost_bench -- check     # output fingerprints
//! cargo run --release -p sylva --example least_cost_bench -- stages 600 7
//! ```
//!
//! `stages N K` times each stage of the 600 k (or 150 k, 200 k) tree `K` times and
//! prints the minimum and the median wall time of each: Poisson sampling, the spatial
//! sort, the Yao build, and the MGV paths (all iterations, with the graph loaded from a
//! temporary graph file so that only the paths are timed). On a shared, loaded machine
//! the minimum of several runs is the steadier figure.
//!
//! `check` prints a fingerprint (FNV-1a over every bit) of the graph and of the grown
//! skeleton for a few sizes and seeds, with 1, 2 and 3 rayon threads, so that a speed
//! change can be shown not to change any output: run it on the old and the new build
//! and compare the lines.
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

/// CPU time of the whole process (all threads; user + system) from `/proc/self/stat`,
/// in seconds (10 ms resolution; `NaN` where that file does not exist).
fn cpu() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|x| x.parse::<f64>().ok());
    match (tick(11), tick(12)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// Runs `f`, returning its result with the wall and CPU seconds it took.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let (t, c) = (std::time::Instant::now(), cpu());
    let r = f();
    (r, t.elapsed().as_secs_f64(), cpu() - c)
}

/// FNV-1a over a stream of 32-bit words.
struct Fnv(u64);

impl Fnv {
    fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
    fn vec3s(&mut self, v: &[glam::Vec3]) {
        for p in v {
            p.to_array().iter().for_each(|c| self.word(c.to_bits()));
        }
    }
}

/// Fingerprints of the graph and the tree for each (size, seed) and thread count.
fn check() {
    for (nodes, endpoints) in [(20_000, 1000), (150_000, 7500), (600_000, 19_000)] {
        let p = params(nodes, endpoints);
        for seed in [1u64, 2] {
            for threads in [1, 2, 3] {
                let pool =
                    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a thread pool");
                let (g, t) = pool.install(|| {
                    let g = graph::poisson_yao(&p.graph_volume(), p.nodes, None, None, 8, 3, seed)
                        .expect("a graph");
                    (g, lc::grow(&p, seed, None).expect("grows"))
                });
                let mut hg = Fnv(0xcbf2_9ce4_8422_2325);
                hg.vec3s(&g.position);
                g.offsets.iter().chain(&g.targets).for_each(|&w| hg.word(w));
                hg.word(g.root);
                let mut ht = Fnv(0xcbf2_9ce4_8422_2325);
                let s = &t.skeleton;
                ht.vec3s(&s.position);
                ht.vec3s(&s.up);
                s.radius.iter().for_each(|r| ht.word(r.to_bits()));
                s.parent.iter().chain(&s.material).for_each(|&w| ht.word(w));
                s.order.iter().for_each(|&o| ht.word(o as u32));
                println!(
                    "{nodes} nodes seed {seed} threads {threads}: graph {:016x} ({} edges), tree {:016x} ({} nodes, {} tips)",
                    hg.0,
                    g.edge_count(),
                    ht.0,
                    s.len(),
                    t.report.tips
                );
            }
        }
    }
}

/// Minimum and median of `v` (sorted in place).
fn min_med(v: &mut [f64]) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[0], v[v.len() / 2])
}

/// Times each stage `runs` times (see the module docs).
fn stages(k: usize, runs: usize) {
    let e = match k {
        150 => 7500,
        200 => 4000,
        _ => 19_000,
    };
    let mut p = params(k * 1000, e);
    let vol = p.graph_volume();
    let d = graph::auto_spacing(vol.measure(3, 1), p.nodes, 3);
    let (mut tp, mut ts, mut ty, mut tt) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..runs {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        let (s, a, ca) = timed(|| {
            graph::poisson(&vol, p.nodes, d, Some(vol.bottom_center(3)), 3, &mut rng).expect("samples")
        });
        let ((pos, root), b, cb) = timed(|| graph::spatial_sort(&s.points, d, 0));
        let (_, c, cc) = timed(|| graph::yao(pos, 8, 3, d as f32, root));
        tp.push((a, ca));
        ts.push((b, cb));
        ty.push((c, cc));
    }
    let file = std::env::temp_dir().join(format!("sylva-bench-{}-{k}.bin", std::process::id()));
    p.graph_cache = file.to_string_lossy().into_owned();
    lc::grow(&p, 1, None).expect("grows");
    let (mut tg, mut tk) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        let (t, _, c) = timed(|| lc::grow(&p, 1, None).expect("grows"));
        tt.push((t.report.path_time.as_secs_f64(), c));
        tg.push((t.report.graph_time.as_secs_f64(), f64::NAN));
        tk.push((t.report.skeleton_time.as_secs_f64(), f64::NAN));
    }
    let _ = std::fs::remove_file(&file);
    for (name, v) in [
        ("poisson", &mut tp),
        ("sort", &mut ts),
        ("yao", &mut ty),
        ("paths (cpu: whole tree from the loaded graph)", &mut tt),
        ("graph load", &mut tg),
        ("skeleton", &mut tk),
    ] {
        let (lo, med) = min_med(&mut v.iter().map(|x| x.0).collect::<Vec<_>>());
        let (clo, cmed) = min_med(&mut v.iter().map(|x| x.1).collect::<Vec<_>>());
        println!("{k}k {name}: wall min {lo:.3} s, median {med:.3} s; cpu min {clo:.2} s, median {cmed:.2} s ({runs} runs)");
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().is_some_and(|a| a == "check") {
        check();
        return;
    }
    if args.first().is_some_and(|a| a == "stages") {
        let k = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(600);
        stages(k, args.get(2).and_then(|a| a.parse().ok()).unwrap_or(5));
        return;
    }
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
            let (tree, wall, cpu) = timed(|| lc::grow(&p, seed + 1, None).expect("grows"));
            totals.push((wall, cpu));
            last = Some(tree.report);
        }
        totals.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Graph stages separately: Poisson sampling, the spatial sort, the Yao build, and
        // one length-weight Dijkstra from the root.
        let vol = p.graph_volume();
        let m = vol.measure(3, 1);
        let d = graph::auto_spacing(m, p.nodes, 3);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        let (s, tp, cp) = timed(|| {
            graph::poisson(&vol, p.nodes, d, Some(vol.bottom_center(3)), 3, &mut rng).expect("samples")
        });
        let ((pos, root), ts, cs) = timed(|| graph::spatial_sort(&s.points, d, 0));
        let (g, ty, cy) = timed(|| graph::yao(pos, 8, 3, d as f32, root));
        let (_, tj, cj) = timed(|| paths::dijkstra(&g, &[g.root], None, &mut paths::Length));
        println!(
            "  stages, wall (cpu) s: poisson {tp:.3} ({cp:.2}), sort {ts:.3} ({cs:.2}), yao {ty:.3} ({cy:.2}); one length-weight Dijkstra {tj:.3} ({cj:.2})"
        );
        let r = last.expect("at least one run");
        let (best, med) = (totals[0], totals[totals.len() / 2]);
        println!(
            "{k}k nodes / {e} endpoints: best {:.3} s (cpu {:.2} s), median {:.3} s | last run: graph {:.3} s, paths {:.3} s, skeleton {:.3} s; {} edges, graph {:.1} MiB, {} endpoints, {} tips, {} skeleton nodes, {} unreachable",
            best.0,
            best.1,
            med.0,
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
