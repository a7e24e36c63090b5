//! Sessions (issue 40): how long an update takes after one setting changed, on the
//! quaking aspen with its default recipe (1024² bark maps and leaf atlas).
//!
//! Each measured update toggles one setting between two values, so every iteration is a
//! real change: a leaf setting (`leaves.alpha_cutoff`), a wind setting
//! (`wind.strength`, with `wind.preset = "breeze"`), a generator setting
//! (`generator.ratio`), and the same recipe again. `first_grow` is a new session's
//! first run (textures drawn). Run with `cargo bench -p sylva --bench session`.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use sylva::recipe::{load, parse_set, Recipe};
use sylva::session::Session;

fn recipe(sets: &[&str]) -> Recipe {
    let parsed: Vec<_> = sets.iter().map(|kv| parse_set(kv).expect("a valid --set")).collect();
    load("wp-quaking-aspen", &parsed).expect("the preset loads").recipe
}

/// Times updates that alternate between `a` and `b` on one warmed session.
fn toggle(c: &mut Criterion, name: &str, a: &[&str], b: &[&str]) {
    let (ra, rb) = (recipe(a), recipe(b));
    let mut session = Session::new(load("wp-quaking-aspen", &[]).expect("loads"));
    session.update(rb.clone()).expect("grows");
    session.update(ra.clone()).expect("grows");
    let mut flip = false;
    c.bench_function(name, |bench| {
        bench.iter(|| {
            flip = !flip;
            let next = if flip { rb.clone() } else { ra.clone() };
            black_box(session.update(next).expect("updates").report.triangles)
        })
    });
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("session");
    g.sample_size(10);
    g.bench_function("first_grow", |b| {
        b.iter(|| {
            let mut s = Session::new(load("wp-quaking-aspen", &[]).expect("loads"));
            black_box(s.run().expect("grows").report.triangles)
        })
    });
    g.finish();
    toggle(c, "session/leaf_setting", &["leaves.alpha_cutoff=0.5"], &["leaves.alpha_cutoff=0.3"]);
    toggle(
        c,
        "session/wind_setting",
        &["wind.preset=\"breeze\"", "wind.strength=1"],
        &["wind.preset=\"breeze\"", "wind.strength=1.5"],
    );
    toggle(c, "session/generator_setting", &["generator.ratio=0.015"], &["generator.ratio=0.016"]);
    toggle(c, "session/same_recipe", &[], &[]);
}

criterion_group!(benches, bench);
criterion_main!(benches);
