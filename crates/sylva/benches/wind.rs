//! The wind stage (issue 24): choosing the rig and skinning every vertex, and baking a
//! 4-second clip at 30 fps, for the aspen and the black tupelo (Weber–Penn presets with
//! their default leaves). Run with `cargo bench -p sylva --bench wind`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use sylva::wind::{bake_clip, rig_model, JointPlan, WindOptions};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("wind");
    g.sample_size(10);
    let breeze = WindOptions::preset("breeze").expect("preset");
    for preset in ["wp-quaking-aspen", "wp-black-tupelo"] {
        let loaded = sylva::recipe::load(preset, &[]).expect("preset loads");
        let grown = sylva::pipeline::grow(&loaded).expect("grows");
        let model = grown.model;
        let plan = JointPlan::new(&model.curves, 64);
        eprintln!(
            "{preset}: {} curve segments, {} joints, {} vertices",
            plan.wind.branches.len(),
            plan.rig.joints.len(),
            model.vertex_count()
        );
        g.bench_function(format!("{preset}/bake_clip_4s_30fps"), |b| {
            b.iter(|| black_box(bake_clip(&plan, &breeze, 4.0, 30)))
        });
        g.bench_function(format!("{preset}/plan_and_skin"), |b| {
            b.iter(|| {
                let mut m = model.clone();
                let plan = JointPlan::new(&m.curves, 64);
                rig_model(&mut m, &plan, 0.5);
                black_box(m)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
