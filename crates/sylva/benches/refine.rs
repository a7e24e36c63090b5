//! Uniform subdivision throughput in output faces per second (issue 4: "Faster than
//! OpenSubdiv"): Catmull–Clark on a 16,384-quad torus and Loop on a 32,768-triangle torus,
//! levels 2 and 3, positions + UVs (a seamed UV layout, linear UV interpolation), with one
//! and two threads. Each iteration does everything OpenSubdiv's `Far` does for the same
//! job: build the topology refiner from the mesh, refine it, refine the UV channel, and
//! interpolate positions and UVs.
//!
//! Run with `cargo bench -p sylva --bench refine`; `bench/compare-opensubdiv.sh` runs
//! OpenSubdiv on the same meshes.
//!
//! The `adaptive` group (issue 4 item 6; `cargo bench -p sylva --bench refine -- adaptive`)
//! compares adaptive Loop refinement (MacMurchy2004's flatness 0.25 rad, size 2e-5) with uniform
//! Loop refinement to the same deepest level on a tree control mesh — the bark of
//! `lsys-honda-a` (40,944 triangles, with UVs) — one thread, positions + UVs and the output
//! mesh in both cases. Reference (spec anchors): OpenSubdiv 3.6 `Far`, one
//! thread, ~6.5–7 M faces/s Catmull–Clark, ~5–12 M faces/s Loop.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::{Vec2, Vec3};
use std::hint::black_box;
use std::time::Duration;
use sylva::geometry::{FaceVarying, Mesh};
use sylva::refine::{FaceVaryingRefiner, FvarInterpolation, RefineOptions, Refiner, Scheme};

#[path = "../tests/common/meshes.rs"]
mod meshes;

/// [`meshes::torus`] (n×m quads or 2nm triangles) with a UV grid of (n+1)×(m+1) values,
/// so the UV layout has two seams.
fn torus(n: u32, m: u32, tris: bool) -> Mesh {
    let mut mesh = meshes::torus(n, m, tris);
    let uvs: Vec<Vec2> = (0..=n)
        .flat_map(|i| (0..=m).map(move |j| Vec2::new(i as f32 / n as f32, j as f32 / m as f32)))
        .collect();
    let t = |i: u32, j: u32| i * (m + 1) + j;
    let mut idx = Vec::new();
    for i in 0..n {
        for j in 0..m {
            let (ta, tb, tc, td) = (t(i, j), t(i, j + 1), t(i + 1, j + 1), t(i + 1, j));
            if tris {
                idx.extend_from_slice(&[ta, tb, tc, ta, tc, td]);
            } else {
                idx.extend_from_slice(&[ta, tb, tc, td]);
            }
        }
    }
    mesh.uvs = Some(FaceVarying { values: uvs, indices: idx });
    mesh
}

/// Everything one uniform refinement of positions + UVs costs.
fn refine(
    mesh: &Mesh,
    scheme: Scheme,
    levels: u32,
    parallel: bool,
) -> (Vec<Vec3>, Vec<Vec2>, FaceVaryingRefiner) {
    let opts = RefineOptions { scheme, levels, parallel, ..Default::default() };
    let refiner = Refiner::new(mesh, &[], &opts).expect("refines");
    let positions = refiner.interpolate(&mesh.positions).expect("positions");
    let uvs = mesh.uvs.as_ref().expect("uvs");
    let fvar = refiner.face_varying(&uvs.indices, FvarInterpolation::Linear).expect("uv topology");
    let values = fvar.interpolate_values(&uvs.values).expect("uvs");
    // The refined UV indices stay in the face-varying refiner (as in OpenSubdiv's levels).
    (positions, values, fvar)
}

fn bench(c: &mut Criterion) {
    let cases = [
        ("catmull-clark", Scheme::CatmullClark, torus(128, 128, false)),
        ("loop", Scheme::Loop, torus(128, 128, true)),
    ];
    let mut g = c.benchmark_group("refine");
    g.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));
    for (name, scheme, mesh) in &cases {
        for levels in [2u32, 3] {
            let faces =
                sylva::refine::output_face_count(*scheme, mesh.face_count(), mesh.face_indices.len(), levels);
            g.throughput(Throughput::Elements(faces as u64));
            for threads in [1usize, 2] {
                let id = BenchmarkId::new(format!("{name}/level{levels}"), format!("{threads}thread"));
                if threads == 1 {
                    // The calling thread, like OpenSubdiv's single-threaded Far.
                    g.bench_function(id, |b| b.iter(|| black_box(refine(mesh, *scheme, levels, false))));
                } else {
                    // One pool for all iterations: its workers (and their allocator arenas)
                    // persist, as they would in an application.
                    let pool =
                        rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
                    g.bench_function(id, |b| {
                        b.iter(|| pool.install(|| black_box(refine(mesh, *scheme, levels, true))))
                    });
                }
            }
        }
    }
    g.finish();
}

/// The bark of `lsys-honda-a` (the tube mesher's triangles and UVs), as grown by the preset.
fn honda_bark() -> Mesh {
    let loaded = sylva::recipe::load("lsys-honda-a", &[]).expect("preset");
    let grown = sylva::pipeline::grow(&loaded).expect("grows");
    let mut m = grown.model.parts.into_iter().find(|p| p.name == "bark").expect("bark part").mesh;
    m.normals = None;
    m
}

fn bench_adaptive(c: &mut Criterion) {
    use sylva::refine::adaptive::{adaptive_loop, AdaptiveOptions};
    use sylva::refine::{subdivide, SubdivideOptions};
    let bark = honda_bark();
    let mut g = c.benchmark_group("adaptive");
    g.sample_size(10).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(4));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("thread pool");
    for levels in [2u32, 3] {
        let uniform = SubdivideOptions {
            refine: RefineOptions { scheme: Scheme::Loop, levels, ..Default::default() },
            ..Default::default()
        };
        let adaptive =
            AdaptiveOptions { max_levels: levels, flatness: 0.25, min_area: 2e-5, ..Default::default() };
        g.bench_function(BenchmarkId::new("honda-bark/uniform", format!("level{levels}")), |b| {
            b.iter(|| pool.install(|| black_box(subdivide(&bark, &[], &uniform).expect("refines"))))
        });
        g.bench_function(BenchmarkId::new("honda-bark/adaptive", format!("level{levels}")), |b| {
            b.iter(|| pool.install(|| black_box(adaptive_loop(&bark, &[], &adaptive).expect("refines"))))
        });
    }
    g.finish();
}

criterion_group!(benches, bench, bench_adaptive);
criterion_main!(benches);
