//! The Rust side of the Python overhead figure (docs/python.md): the best wall time of
//! `sylva::pipeline::grow` for a preset over N runs (and the best sum of its stage
//! times), in milliseconds, to set beside
//! `Recipe.preset(name).grow()` timed the same way from Python
//! (`crates/sylva-py/tools/overhead.py` runs both, interleaved).
//!
//! `cargo run --release -p sylva-py --example grow_time -- wp-quaking-aspen 10`

fn main() -> sylva::Result<()> {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_else(|| "wp-quaking-aspen".into());
    let runs: usize = args.next().and_then(|n| n.parse().ok()).unwrap_or(10);
    let loaded = sylva::recipe::Loaded::preset(&name)?;
    sylva::pipeline::grow(&loaded)?;
    let (mut best, mut stages) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..runs {
        let t = std::time::Instant::now();
        let tree = sylva::pipeline::grow(&loaded)?;
        best = best.min(t.elapsed().as_secs_f64());
        stages = stages.min(tree.report.stage_times.iter().map(|(_, d)| d.as_secs_f64()).sum());
        drop(tree);
    }
    // The best wall time, then the best sum of the stage times, in milliseconds.
    println!("{:.3} {:.3}", best * 1e3, stages * 1e3);
    Ok(())
}
