//! Throughput of the grammar-to-mesh pipeline on a large tree (issue: derivation,
//! turtle interpretation and tube meshing, one core).
//!
//! The workload is the default ternary tree (ABOP Fig. 2.8) derived 11 steps:
//! about 1.6 M modules. Run with `cargo bench -p sylva --bench pipeline`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use sylva::lsystem::{interpret, DeriveOptions, LSystem, TurtleOptions};
use sylva::mesh::tube::{tube_mesh, TubeOptions};

const STEPS: u32 = 11;

fn lsystem() -> LSystem {
    let text = sylva::presets::file("lsystem/ternary-tree.l").expect("embedded preset");
    LSystem::parse("ternary-tree.l", text, &[]).expect("preset parses")
}

fn bench(c: &mut Criterion) {
    let ls = lsystem();
    let opts = DeriveOptions { steps: STEPS, budget: 50_000_000, seed: 1 };
    let derived = ls.derive(&opts).expect("derives");
    let turtle = TurtleOptions { angle: 18.95, ..Default::default() };
    let skeleton = interpret(&ls.symbols, &derived, &turtle, &ls.source).expect("interprets");
    let tube = tube_mesh(&skeleton, &TubeOptions::default()).expect("meshes");
    eprintln!(
        "workload: {} modules, {} skeleton nodes, {} triangles",
        derived.len(),
        skeleton.len(),
        tube.triangles
    );

    let mut g = c.benchmark_group("pipeline");
    g.sample_size(10);
    // Modules written by the whole derivation (every step's output).
    let mut written = 0u64;
    let mut cur = ls.derive(&DeriveOptions { steps: 0, ..opts }).expect("axiom");
    for n in 1..=STEPS {
        let next = ls.derive(&DeriveOptions { steps: n, ..opts }).expect("derives");
        written += next.len() as u64;
        cur = next;
    }
    drop(cur);
    g.throughput(Throughput::Elements(written));
    g.bench_function("derive_modules", |b| b.iter(|| black_box(ls.derive(&opts).expect("derives"))));
    g.throughput(Throughput::Elements(derived.len() as u64));
    g.bench_function("interpret_modules", |b| {
        b.iter(|| black_box(interpret(&ls.symbols, &derived, &turtle, &ls.source).expect("interprets")))
    });
    g.throughput(Throughput::Elements(tube.triangles as u64));
    g.bench_function("tube_triangles", |b| {
        b.iter(|| black_box(tube_mesh(&skeleton, &TubeOptions::default()).expect("meshes")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
