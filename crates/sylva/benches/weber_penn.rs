//! Weber–Penn throughput (issue 6, "Speed"): the paper's quaking aspen (preset
//! `wp-quaking-aspen`, seed 1) with its leaves, grown, tube-meshed (8 sides), its leaves
//! meshed as organs, and written as GLB bytes with a bark and a leaves part: the whole
//! recipe-to-file work minus the disk write, on one thread. The stages are timed
//! separately too.
//!
//! Run with `cargo bench -p sylva --bench weber_penn`. The target: under 50 ms
//! for the whole job (when no Weber–Penn peer can run side by side). Before the
//! criterion groups it prints each stage's CPU time (Linux), steadier than wall time on
//! a shared machine.

use criterion::{criterion_group, criterion_main, Criterion};
use std::collections::HashMap;
use std::hint::black_box;
use sylva::export::gltf::to_glb;
use sylva::grow::weber_penn::{grow, WeberPennParams};
use sylva::mesh::organs::organ_mesh;
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::model::{Material, Model, Part};

/// The aspen's parameters, read from the embedded preset's `[generator]` table.
fn aspen() -> WeberPennParams {
    let text = sylva::presets::get("wp-quaking-aspen").expect("embedded preset").recipe;
    let mut table: toml::Table = toml::from_str(text).expect("preset parses");
    let mut g = table.remove("generator").expect("a generator table");
    if let Some(t) = g.as_table_mut() {
        t.remove("type");
    }
    g.try_into().expect("weber-penn parameters")
}

/// Grow + tube mesh + organ mesh + GLB bytes.
fn whole(p: &WeberPennParams) -> Vec<u8> {
    let tree = grow(p, 1).expect("grows");
    let tube = tube_mesh(&tree.skeleton, &TubeOptions::default()).expect("meshes");
    let (leaves, _) = organ_mesh(&tree.skeleton, &HashMap::new());
    let model = Model {
        parts: vec![
            Part { name: "bark".into(), mesh: tube.mesh, material: Material::bark(), ..Default::default() },
            Part { name: "leaves".into(), mesh: leaves, material: Material::leaf(), ..Default::default() },
        ],
        ..Default::default()
    };
    to_glb(&model).expect("writes")
}

/// This thread's CPU time in nanoseconds (Linux `schedstat`), if available: on a shared
/// machine it is steadier than wall time.
fn cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat").ok()?.split_whitespace().next()?.parse().ok()
}

/// Prints the CPU time of each stage, averaged over `runs` runs.
fn cpu_report(p: &WeberPennParams, runs: u32) {
    let mut t = [0u64; 4];
    for _ in 0..runs {
        let (Some(a), tree) = (cpu_ns(), grow(p, 1).expect("grows")) else { return };
        let b = cpu_ns().unwrap_or(a);
        let tube = tube_mesh(&tree.skeleton, &TubeOptions::default()).expect("meshes");
        let c = cpu_ns().unwrap_or(b);
        let (leaves, _) = organ_mesh(&tree.skeleton, &HashMap::new());
        let d = cpu_ns().unwrap_or(c);
        let model = Model {
            parts: vec![
                Part {
                    name: "bark".into(),
                    mesh: tube.mesh,
                    material: Material::bark(),
                    ..Default::default()
                },
                Part {
                    name: "leaves".into(),
                    mesh: leaves,
                    material: Material::leaf(),
                    ..Default::default()
                },
            ],
            ..Default::default()
        };
        black_box(to_glb(&model).expect("writes"));
        let e = cpu_ns().unwrap_or(d);
        for (k, v) in [b - a, c - b, d - c, e - d].into_iter().enumerate() {
            t[k] += v;
        }
    }
    let ms = |x: u64| x as f64 / runs as f64 / 1e6;
    eprintln!(
        "CPU time per run: grow {:.2} ms, tube {:.2} ms, organs {:.2} ms, GLB {:.2} ms, total {:.2} ms",
        ms(t[0]),
        ms(t[1]),
        ms(t[2]),
        ms(t[3]),
        ms(t.iter().sum())
    );
}

fn bench(c: &mut Criterion) {
    let p = aspen();
    let tree = grow(&p, 1).expect("grows");
    let glb = whole(&p);
    eprintln!(
        "workload: stems per level {:?}, {} leaves, {} nodes, GLB {} bytes",
        tree.report.stems_per_level,
        tree.report.leaves,
        tree.report.nodes,
        glb.len()
    );
    cpu_report(&p, 20);
    let mut g = c.benchmark_group("weber_penn_aspen");
    g.sample_size(20);
    g.bench_function("grow", |b| b.iter(|| black_box(grow(&p, 1).expect("grows"))));
    g.bench_function("tube_mesh", |b| {
        b.iter(|| black_box(tube_mesh(&tree.skeleton, &TubeOptions::default()).expect("meshes")))
    });
    g.bench_function("organ_mesh", |b| b.iter(|| black_box(organ_mesh(&tree.skeleton, &HashMap::new()))));
    g.bench_function("grow_mesh_glb", |b| b.iter(|| black_box(whole(&p))));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
