//! Magnetic curves against Xu2015 Table 7.1 (issue 8: "at least 20× faster than the
//! seed's times"): each composition of the table, generated from its preset and
//! rendered at the preset's output size (600 px wide), as PNG (rasterize + encode) and
//! as SVG text. No file I/O.
//!
//! | Table 7.1 image | preset | curves | seed (1.8 GHz P4) |
//! |---|---|---|---|
//! | Space-filling example | `curves-space-filling` | 312 | 1.5 s |
//! | Stylized tree | `curves-klimt-tree` | 72 | 0.7 s |
//! | Perlin curves | `curves-perlin` | 272 | 1.0 s |
//! | Hair | `curves-hair` | 376 | 4.3 s (with loading the face and hairline images) |
//! | Window | `curves-window` | 7 | 0.05 s |
//!
//! Run with `cargo bench -p sylva --bench curves`; the last lines print each
//! composition's best and median time (generation + PNG) and the speed-up over the
//! seed.

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use std::time::{Duration, Instant};
use sylva::curves;

const TABLE_7_1: [(&str, usize, f64); 5] = [
    ("curves-space-filling", 312, 1.5),
    ("curves-klimt-tree", 72, 0.7),
    ("curves-perlin", 272, 1.0),
    ("curves-hair", 376, 4.3),
    ("curves-window", 7, 0.05),
];

fn generate_and_png(c: &curves::Composition) -> usize {
    let g = c.generate().expect("preset generates");
    curves::png_bytes(&g.drawing, c.spec.size).expect("renders").len()
}

fn generate_and_svg(c: &curves::Composition) -> usize {
    let g = c.generate().expect("preset generates");
    curves::svg_string(&g.drawing, c.spec.size).expect("renders").len()
}

fn table_7_1(cr: &mut Criterion) {
    let mut group = cr.benchmark_group("curves");
    group.sample_size(20).measurement_time(Duration::from_secs(4));
    for (name, _, _) in TABLE_7_1 {
        let comp = curves::load_preset(name, &[]).expect("preset loads");
        group.bench_function(format!("{name}/generate"), |b| b.iter(|| black_box(comp.generate().unwrap())));
        group.bench_function(format!("{name}/generate+png"), |b| {
            b.iter(|| black_box(generate_and_png(&comp)))
        });
        group.bench_function(format!("{name}/generate+svg"), |b| {
            b.iter(|| black_box(generate_and_svg(&comp)))
        });
    }
    group.finish();
    // A plain summary against the seed: generation + 600 px PNG, best and median of 21
    // runs (the best is the least disturbed by other work on a shared machine).
    println!("\nTable 7.1 comparison (generation + 600 px PNG, 21 runs):");
    println!(
        "{:<24} {:>7} {:>9} {:>10} {:>12} {:>9} {:>11}",
        "preset", "curves", "seed (s)", "best (ms)", "median (ms)", "speed-up", "(median)"
    );
    for (name, n, seed) in TABLE_7_1 {
        let comp = curves::load_preset(name, &[]).expect("preset loads");
        let curves = comp.generate().unwrap().stats.curves;
        assert_eq!(curves, n, "{name} should draw {n} curves");
        let mut times: Vec<f64> = (0..21)
            .map(|_| {
                let t = Instant::now();
                black_box(generate_and_png(&comp));
                t.elapsed().as_secs_f64()
            })
            .collect();
        times.sort_by(f64::total_cmp);
        let (best, median) = (times[0], times[times.len() / 2]);
        println!(
            "{name:<24} {curves:>7} {seed:>9.2} {:>10.1} {:>12.1} {:>8.0}× {:>10.0}×",
            best * 1e3,
            median * 1e3,
            seed / best,
            seed / median
        );
    }
}

criterion_group!(benches, table_7_1);
criterion_main!(benches);
