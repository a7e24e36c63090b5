//! Space colonization growth time (issue 6: "a 100 k-point space colonization tree grows
//! in under 1 s", one core).
//!
//! The workload is the `colonize-broadleaf` preset (ellipsoid crown 9 × 7.2 × 9 m,
//! segment 0.2 m, influence 1.6 m, kill 0.4 m) with its attraction points raised to
//! 100 000, grown from seed 1: sampling, growth, pipe radii, up vectors and leaves. The
//! three presets as shipped are measured too. Run with
//! `cargo bench -p sylva --bench colonize`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::Duration;
use sylva::grow::colonize::{grow, ColonizeParams};

/// The `[generator]` table of a preset (minus `type`) as parameters.
fn preset(text: &str) -> ColonizeParams {
    let mut table: toml::Table = toml::from_str(text).expect("preset parses");
    let mut g = table.remove("generator").expect("a [generator] table");
    if let Some(t) = g.as_table_mut() {
        t.remove("type");
    }
    g.try_into().expect("preset parameters deserialize")
}

fn bench(c: &mut Criterion) {
    let broadleaf = preset(include_str!("../../../presets/colonize-broadleaf.toml"));
    let big = ColonizeParams { points: 100_000, ..broadleaf.clone() };
    let tree = grow(&big, 1).expect("grows");
    eprintln!("workload colonize_100k: {:?}", tree.report);

    let mut g = c.benchmark_group("colonize");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(10));
    g.bench_function("grow_100k_points", |b| b.iter(|| black_box(grow(&big, 1).expect("grows"))));
    for (name, text) in [
        ("broadleaf", include_str!("../../../presets/colonize-broadleaf.toml")),
        ("conifer", include_str!("../../../presets/colonize-conifer.toml")),
        ("shrub", include_str!("../../../presets/colonize-shrub.toml")),
    ] {
        let p = preset(text);
        g.bench_function(format!("grow_preset_{name}"), |b| {
            b.iter(|| black_box(grow(&p, 1).expect("grows")))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
