//! Derivation throughput of a context-sensitive L-system (issue 3: ≥ 5 M modules/s on
//! one core for a model of at least 1 M modules), and the time to grow the whole cpfg
//! corpus (issue 3: under 10 s).
//!
//! The workload is a bracketed tree whose internodes take the sum of their children's
//! widths through a right context with a branch (`I(w) > [I(a)]I(b)`), the pipe model
//! of the Lilac corpus model: every internode is context-matched in every step.
//! Run with `cargo bench -p sylva --bench lsystem`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use sylva::lsystem::{DeriveOptions, LSystem};

const MODEL: &str = "Lsystem: 1
ignore: +-/
Axiom: I(1)A
A --> I(1)/(137)[+A]-A
I(w) > [I(a)]I(b) --> I(a+b)
endlsystem
";

const STEPS: u32 = 18;

fn bench(c: &mut Criterion) {
    let ls = LSystem::parse("pipe.l", MODEL, &[]).expect("parses");
    let opts = DeriveOptions { steps: STEPS, budget: 50_000_000, seed: 1 };
    let out = ls.derive(&opts).expect("derives");
    let written: u64 = (1..=STEPS)
        .map(|n| ls.derive(&DeriveOptions { steps: n, ..opts }).expect("derives").len() as u64)
        .sum();
    eprintln!("workload: {} modules after {STEPS} steps, {written} written over all steps", out.len());
    let mut g = c.benchmark_group("lsystem");
    g.sample_size(10);
    g.throughput(Throughput::Elements(written));
    g.bench_function("context_derive_modules", |b| b.iter(|| black_box(ls.derive(&opts).expect("derives"))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
