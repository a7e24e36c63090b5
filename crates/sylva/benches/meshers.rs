//! Control-mesh throughput of the three meshers (issue 5): skeleton nodes per second for
//! `tube`, `hull` and `quad` on the same deterministic ~10 k-node tree (3 children per
//! branch, 8 levels, 3 internodes per branch, wobbling directions and tapering radii).
//!
//! Run with `cargo bench -p sylva --bench meshers`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use std::hint::black_box;
use sylva::mesh::hull::{hull_mesh, HullOptions};
use sylva::mesh::quad::{quad_mesh, QuadOptions};
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::{Skeleton, NO_PARENT};

/// A deterministic tree of `depth` levels with `segs` internodes per branch.
fn tree(depth: u32, segs: u32) -> Skeleton {
    let mut s = Skeleton::new();
    let root = s.push(Vec3::ZERO, 0.3, NO_PARENT, Vec3::X, 0);
    let mut stack = vec![(root, Vec3::Y, 2.0f32, 0.3f32, 0u32)];
    let mut h = 1u32;
    while let Some((node, dir, len, r, level)) = stack.pop() {
        let mut at = node;
        let mut p = s.position[node as usize];
        let mut d = dir;
        for k in 0..segs {
            h = h.wrapping_mul(1_103_515_245).wrapping_add(12345);
            let wob =
                Vec3::new(((h >> 8) % 100) as f32 / 500.0 - 0.1, 0.0, ((h >> 16) % 100) as f32 / 500.0 - 0.1);
            d = (d + wob).normalize();
            p += d * (len / segs as f32);
            let rr = r * (1.0 - 0.25 * (k + 1) as f32 / segs as f32);
            at = s.push(p, rr, at, d.any_orthonormal_vector(), level as u16);
        }
        if level + 1 < depth {
            let side = d.any_orthonormal_vector();
            let other = d.cross(side);
            for (k, w) in [0.8f32, -0.7, 0.3].iter().enumerate() {
                let nd = (d + side * *w + other * (k as f32 - 1.0) * 0.5).normalize();
                stack.push((at, nd, len * 0.75, r * 0.65, level + 1));
            }
        }
    }
    s
}

fn bench(c: &mut Criterion) {
    let sk = tree(8, 3);
    let n = sk.len() as u64;
    let tube = tube_mesh(&sk, &TubeOptions::default()).expect("tube");
    let hull = hull_mesh(&sk, &HullOptions::default()).expect("hull");
    let quad = quad_mesh(&sk, &QuadOptions::default()).expect("quad");
    eprintln!(
        "workload: {n} nodes; tube {} faces, hull {} faces, quad {} faces ({} fallbacks)",
        tube.mesh.face_count(),
        hull.mesh.face_count(),
        quad.mesh.face_count(),
        quad.fallbacks.len()
    );
    let mut g = c.benchmark_group("meshers");
    g.sample_size(20);
    g.throughput(Throughput::Elements(n));
    g.bench_function("tube", |b| b.iter(|| black_box(tube_mesh(&sk, &TubeOptions::default()).unwrap())));
    g.bench_function("hull", |b| b.iter(|| black_box(hull_mesh(&sk, &HullOptions::default()).unwrap())));
    g.bench_function("quad", |b| b.iter(|| black_box(quad_mesh(&sk, &QuadOptions::default()).unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
