//! Control-mesh throughput of the three meshers (issue 5): skeleton nodes per second for
//! `tube`, `hull` and `quad` on the same deterministic ~10 k-node tree (3 children per
//! branch, 8 levels, 3 internodes per branch, wobbling directions and tapering radii).
//!
//! Also the Pieterse2012 experiment (its Fig. 5.x timing): hull joint construction time
//! versus the number of branches meeting at one joint, 2 to 200 (a trunk and `n`
//! children on a Fibonacci sphere), whose log–log slope the bench prints.
//!
//! Run with `cargo bench -p sylva --bench meshers`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use std::hint::black_box;
use sylva::mesh::hull::{hull_mesh, HullOptions};
use sylva::mesh::quad::{quad_mesh, QuadOptions};
use sylva::mesh::sweep::{sweep_mesh, SweepOptions};
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::{Skeleton, NO_PARENT};

#[path = "../tests/common/det_tree.rs"]
mod det_tree;
use det_tree::tree;

fn bench(c: &mut Criterion) {
    let sk = tree(8, 3);
    let n = sk.len() as u64;
    let tube = tube_mesh(&sk, &TubeOptions::default()).expect("tube");
    let hull = hull_mesh(&sk, &HullOptions::default()).expect("hull");
    let quad = quad_mesh(&sk, &QuadOptions::default()).expect("quad");
    eprintln!(
        "workload: {n} nodes; tube {} faces, hull {} faces, quad {} faces ({} fallbacks)",
        tube.mesh.face_count(),
        hull.mesh.face_count(),
        quad.mesh.face_count(),
        quad.fallbacks.len()
    );
    let mut g = c.benchmark_group("meshers");
    g.sample_size(20);
    g.throughput(Throughput::Elements(n));
    g.bench_function("tube", |b| b.iter(|| black_box(tube_mesh(&sk, &TubeOptions::default()).unwrap())));
    g.bench_function("hull", |b| b.iter(|| black_box(hull_mesh(&sk, &HullOptions::default()).unwrap())));
    g.bench_function("quad", |b| b.iter(|| black_box(quad_mesh(&sk, &QuadOptions::default()).unwrap())));
    let quad_plain = QuadOptions { repair_rounds: 0, ..Default::default() };
    g.bench_function("quad (no repair)", |b| b.iter(|| black_box(quad_mesh(&sk, &quad_plain).unwrap())));
    let no_repair = SweepOptions { repair_rounds: 0, ..Default::default() };
    g.bench_function("sweep (no repair)", |b| b.iter(|| black_box(sweep_mesh(&sk, &no_repair).unwrap())));
    g.bench_function("sweep", |b| b.iter(|| black_box(sweep_mesh(&sk, &SweepOptions::default()).unwrap())));
    g.finish();
}

/// A trunk ending in one joint with `n` children spread on a Fibonacci sphere cap
/// (upper 80 % of directions, so none runs back into the trunk).
fn star(n: usize) -> Skeleton {
    let mut s = Skeleton::new();
    let root = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
    let joint = s.push(Vec3::Y, 0.1, root, Vec3::X, 0);
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    for i in 0..n {
        let y = 1.0 - 1.6 * (i as f32 + 0.5) / n as f32;
        let r = (1.0 - y * y).sqrt();
        let d = Vec3::new(r * (golden * i as f32).cos(), y, r * (golden * i as f32).sin());
        // Thin enough that neighbouring children do not overlap at the joint.
        let radius = (0.1 * 2.0 / (n as f32).sqrt()).min(0.08);
        s.push(Vec3::Y + d, radius, joint, d.any_orthonormal_vector(), 1);
    }
    s
}

fn joint_time(c: &mut Criterion) {
    let mut g = c.benchmark_group("hull joint");
    g.sample_size(20);
    let sizes = [2usize, 5, 10, 20, 50, 100, 200];
    let mut times = Vec::new();
    for &n in &sizes {
        let sk = star(n);
        let opts = HullOptions { caps: true, ..Default::default() };
        g.bench_function(format!("{n} branches"), |b| b.iter(|| black_box(hull_mesh(&sk, &opts).unwrap())));
        // A plain median for the growth rate printed below.
        let mut t: Vec<f64> = (0..21)
            .map(|_| {
                let t0 = std::time::Instant::now();
                black_box(hull_mesh(&sk, &opts).unwrap());
                t0.elapsed().as_secs_f64()
            })
            .collect();
        t.sort_by(f64::total_cmp);
        times.push(t[10]);
    }
    g.finish();
    let (lx, ly): (Vec<f64>, Vec<f64>) =
        sizes.iter().zip(&times).skip(2).map(|(&n, &t)| ((n as f64).ln(), t.ln())).unzip();
    let (mx, my) = (lx.iter().sum::<f64>() / lx.len() as f64, ly.iter().sum::<f64>() / ly.len() as f64);
    let slope = lx.iter().zip(&ly).map(|(x, y)| (x - mx) * (y - my)).sum::<f64>()
        / lx.iter().map(|x| (x - mx).powi(2)).sum::<f64>();
    println!("\nhull joint construction (median of 21, whole star mesh):");
    for (n, t) in sizes.iter().zip(&times) {
        println!("  {n:>4} branches: {:>9.3} ms", t * 1e3);
    }
    println!("  log-log slope for 10..200 branches: {slope:.2} (time ~ n^{slope:.2})");
}

criterion_group!(benches, bench, joint_time);
criterion_main!(benches);
