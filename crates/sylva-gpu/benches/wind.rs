//! GPU wind step time per 10⁵ branches (issue 25: "GPU wind step time per 10⁵
//! branches"): the `lsys-honda-a` rig (fitted curves, 1,023 branches, 10 depth levels)
//! replicated into a forest of 98 trees (100,254 branches), stepped with the `storm`
//! preset without lag (one dispatch per level) and with the legacy lag (one dispatch over
//! a copy), on whatever adapter is present (its name is printed; none: the bench prints
//! why and does nothing). Each iteration submits one step and waits for it; the CPU
//! reference (`WindRig::step`, f64, one core) runs on the same forest for comparison.
//! Run with `cargo bench -p sylva-gpu --bench wind`.

use criterion::{criterion_group, criterion_main, Criterion};
use glam::DVec2;
use std::time::Duration;
use sylva::model::BranchCurves;
use sylva::wind::{WindOptions, WindRig};
use sylva_gpu::wind::forest;
use sylva_gpu::{Gpu, GpuWind};

fn honda() -> WindRig {
    let loaded = sylva::recipe::load("lsys-honda-a", &[]).expect("preset loads");
    let mut report = sylva::pipeline::Report::default();
    let generated = sylva::pipeline::skeleton(&loaded, &mut report).expect("preset grows");
    WindRig::new(&generated.curves.unwrap_or_else(|| BranchCurves::fit(&generated.skeleton)))
}

fn bench(c: &mut Criterion) {
    let Some(gpu) = Gpu::or_skip("wind bench") else { return };
    let tree = honda();
    let copies = 100_000usize.div_ceil(tree.branches.len());
    let rig = forest(&tree, copies, 20.0);
    let n = rig.branches.len();
    let storm = WindOptions::preset("storm").expect("preset");
    let lagging = WindOptions { legacy_lag: true, ..storm.clone() };
    let dt = 1.0 / 30.0;
    let mut g = c.benchmark_group("wind");
    g.sample_size(20);
    g.warm_up_time(Duration::from_secs(2));
    g.measurement_time(Duration::from_secs(8));
    let mut report = Vec::new();
    for (name, wind) in [("gpu_step_no_lag", &storm), ("gpu_step_legacy_lag", &lagging)] {
        let mut w = GpuWind::new(&gpu, &rig, wind);
        w.step(dt);
        w.finish();
        let id = format!("{name}/{n}_branches");
        g.bench_function(&id, |b| {
            b.iter(|| {
                w.step(dt);
                w.finish();
            })
        });
        report.push((name, w.levels()));
    }
    let mut cpu = rig.clone();
    g.bench_function(format!("cpu_step_f64/{n}_branches"), |b| b.iter(|| cpu.step(&storm, dt, DVec2::ZERO)));
    g.finish();
    eprintln!(
        "wind bench: {n} branches ({copies} × lsys-honda-a, {} levels) on {}; divide the times by {:.4} for 10⁵ branches",
        report[0].1,
        gpu.describe(),
        n as f64 / 1e5
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
