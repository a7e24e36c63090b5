//! The LOD chain (issue 24 item 4): building LOD0–LOD2 at 30,000 / 8,000 / 2,000
//! triangles plus the impostor (crossed billboards and its hemi-octahedral atlas) from an
//! already grown aspen, as `pipeline::lod_stage` does after meshing. Run with
//! `cargo bench -p sylva --bench lod`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("lod");
    g.sample_size(10);
    let budgets = [30000i64, 8000, 2000].map(toml::Value::Integer).to_vec();
    for (name, impostor) in [("levels_and_impostor", true), ("levels_only", false)] {
        let sets = vec![
            ("lod.levels".to_string(), toml::Value::Array(budgets.clone())),
            ("lod.impostor".to_string(), toml::Value::Boolean(impostor)),
        ];
        let loaded = sylva::recipe::load("wp-quaking-aspen", &sets).expect("preset loads");
        let mut plain = loaded.clone();
        plain.recipe.lod = Default::default();
        let full = sylva::pipeline::grow(&plain).expect("grows");
        eprintln!("wp-quaking-aspen: {} triangles before the chain", full.model.triangle_count());
        g.bench_function(format!("wp-quaking-aspen/{name}"), |b| {
            b.iter(|| {
                let mut model = full.model.clone();
                let mut report = sylva::pipeline::Report::default();
                let levels = sylva::pipeline::lod_stage(
                    &loaded,
                    &full.skeleton,
                    &Default::default(),
                    &mut model,
                    &mut report,
                )
                .expect("chain builds");
                black_box((model, levels))
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
