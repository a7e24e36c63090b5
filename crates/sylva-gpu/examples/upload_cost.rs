//! What replacing the editor's tree costs after a change, stage by stage: the session's
//! rerun, the clone of the tree the worker hands over, and the upload to the GPU — with
//! the pipelines shared only (`Renderer::with_device_sharing`) and with the previous
//! tree's buffers and textures reused where unchanged (`Renderer::with_device_reusing`,
//! what the editor does) — for a first upload and for replacements after a leaf change
//! (issue 41's latency).
//!
//! ```text
//! cargo run --release -p sylva-gpu --example upload_cost [-- PRESET]
//! ```

use std::time::Instant;
use sylva::recipe::Loaded;
use sylva::Session;
use sylva_gpu::render::Renderer;
use sylva_gpu::Gpu;

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let preset = std::env::args().nth(1).unwrap_or_else(|| "wp-quaking-aspen".into());
    let gpu = Gpu::new()?;
    println!("adapter: {}", gpu.adapter_name());
    let mut session = Session::new(Loaded::preset(&preset)?);
    let t = Instant::now();
    session.run()?;
    println!("grow: {:.1} ms", ms(t));
    let t = Instant::now();
    let tree = session.tree().expect("grown").clone();
    println!("clone of the tree: {:.1} ms", ms(t));
    let t = Instant::now();
    let r = Renderer::with_device_sharing(&gpu.adapter, &gpu.device, &gpu.queue, &tree.model, None)?;
    println!("first upload (pipelines made): {:.1} ms", ms(t));
    let t = Instant::now();
    r.prepare(wgpu::TextureFormat::Rgba8UnormSrgb, true);
    println!("prepare (pipelines compiled): {:.1} ms", ms(t));
    let cache = r.shader_cache();
    for round in 0..3 {
        let mut recipe = session.recipe().clone();
        recipe.leaves.alpha_cutoff = if round % 2 == 0 { 0.4 } else { 0.5 };
        let t = Instant::now();
        session.update(recipe)?;
        let rerun = ms(t);
        let t = Instant::now();
        let tree = session.tree().expect("grown").clone();
        let clone = ms(t);
        let t = Instant::now();
        let flat = tree.model.flattened();
        let flatten = ms(t);
        drop(flat);
        let t = Instant::now();
        let r2 =
            Renderer::with_device_sharing(&gpu.adapter, &gpu.device, &gpu.queue, &tree.model, Some(&cache))?;
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).ok();
        let upload = ms(t);
        drop(r2);
        let t = Instant::now();
        let r3 = Renderer::with_device_reusing(&gpu.adapter, &gpu.device, &gpu.queue, &tree.model, Some(&r))?;
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).ok();
        let reusing = ms(t);
        println!(
            "leaf change {round}: rerun {rerun:.1} ms, clone {clone:.1} ms, flattened {flatten:.1} ms, \
             upload (pipelines shared) {upload:.1} ms, upload reusing the previous tree {reusing:.1} ms ({:?})",
            r3.reuse()
        );
    }
    Ok(())
}
