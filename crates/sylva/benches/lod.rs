//! The LOD chain (issue 24 item 4): building LOD0–LOD2 at 30,000 / 8,000 / 2,000
//! triangles plus the impostor (crossed billboards and its hemi-octahedral atlas) from an
//! already grown aspen, as `pipeline::lod_stage` does after meshing. Run with
//! `cargo bench -p sylva --bench lod`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

#[path = "../examples/support/lod_chain.rs"]
mod lod_chain;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("lod");
    g.sample_size(10);
    for (name, impostor) in [("levels_and_impostor", true), ("levels_only", false)] {
        let (loaded, full) = lod_chain::grow_without_chain("wp-quaking-aspen", impostor).expect("grows");
        eprintln!("wp-quaking-aspen: {} triangles before the chain", full.model.triangle_count());
        g.bench_function(format!("wp-quaking-aspen/{name}"), |b| {
            b.iter(|| {
                let mut model = full.model.clone();
                let levels = lod_chain::build_chain(&loaded, &full, &mut model).expect("chain builds");
                black_box((model, levels))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
