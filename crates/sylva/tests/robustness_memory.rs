//! Issue 39, items 3 and 7: memory estimated before large allocations and reserved
//! fallibly (the subdivision), and the mesh checker's self-intersection search bounded
//! by a work budget with duplicate and degenerate faces reported up front.
//!
//! A counting global allocator measures the subdivision's real peak (and can refuse
//! large allocations, standing in for a system out of memory); every test takes one lock
//! so the counts are this test's alone.

use glam::{Vec2, Vec3};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};
use std::sync::Mutex;
use sylva::geometry::FaceVarying;
use sylva::mesh::check::{check_mesh, CheckOptions};
use sylva::refine::{
    peak_memory, subdivide, FvarInterpolation, RefineError, RefineOptions, Scheme, SubdivideOptions,
};
use sylva::Mesh;
#[path = "common/recipes.rs"]
mod recipes;

/// The system allocator, counting live bytes and their peak, refusing any single
/// allocation over `REFUSE_ABOVE`.
struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static REFUSE_ABOVE: AtomicUsize = AtomicUsize::new(usize::MAX);

fn add(n: usize) {
    let now = LIVE.fetch_add(n, SeqCst) + n;
    PEAK.fetch_max(now, SeqCst);
}

/// A new allocation of `l` made by `system`, counted; refused (null) over `REFUSE_ABOVE`.
fn counted(l: Layout, system: impl FnOnce() -> *mut u8) -> *mut u8 {
    if l.size() > REFUSE_ABOVE.load(SeqCst) {
        return std::ptr::null_mut();
    }
    let p = system();
    if !p.is_null() {
        add(l.size());
    }
    p
}

// SAFETY: every call is forwarded to `System`; the counters only observe.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        counted(l, || unsafe { System.alloc(l) })
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        counted(l, || unsafe { System.alloc_zeroed(l) })
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size(), SeqCst);
        // SAFETY: forwarded.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if new > REFUSE_ABOVE.load(SeqCst) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded.
        let q = unsafe { System.realloc(p, l, new) };
        if !q.is_null() {
            LIVE.fetch_sub(l.size(), SeqCst);
            add(new);
        }
        q
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// One test at a time: the counters are global.
static ONE: Mutex<()> = Mutex::new(());

fn lock() -> std::sync::MutexGuard<'static, ()> {
    ONE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Bytes allocated at the peak of `f` above what was live before it, and its result.
fn measure<R>(f: impl FnOnce() -> R) -> (usize, R) {
    let base = LIVE.load(SeqCst);
    PEAK.store(base, SeqCst);
    let r = f();
    (PEAK.load(SeqCst) - base, r)
}

/// The error of growing `what` with the settings `kv` (which must fail), and the bytes
/// allocated at the peak of the attempt.
fn grow_error(what: &str, kv: &[&str]) -> (String, usize) {
    let loaded = recipes::load(what, kv).unwrap();
    let (peak, r) = measure(|| sylva::pipeline::grow(&loaded));
    match r {
        Ok(_) => panic!("{what} with {kv:?} grew: expected an error"),
        Err(e) => (e.to_string(), peak),
    }
}

/// A `n × m` grid of quads in the plane (open: a boundary all round), with UVs split
/// along the middle column (a seam), optionally as triangles.
fn grid(n: u32, m: u32, triangles: bool, uvs: bool) -> Mesh {
    let mut mesh = Mesh::new();
    for j in 0..=m {
        for i in 0..=n {
            let z = ((i * 7 + j * 13) % 5) as f32 * 0.05;
            mesh.positions.push(Vec3::new(i as f32, j as f32, z));
        }
    }
    let v = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..m {
        for i in 0..n {
            let q = [v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)];
            if triangles {
                mesh.push_face(&[q[0], q[1], q[2]]);
                mesh.push_face(&[q[0], q[2], q[3]]);
            } else {
                mesh.push_face(&q);
            }
        }
    }
    if uvs {
        // One value per vertex, except that the right half's values are copies: the
        // middle column is a seam.
        let nv = mesh.positions.len() as u32;
        let mut values: Vec<Vec2> = mesh.positions.iter().map(|p| Vec2::new(p.x, p.y) / 8.0).collect();
        values.extend(mesh.positions.iter().map(|p| Vec2::new(p.x + 1.0, p.y) / 8.0));
        let indices = (0..mesh.face_count())
            .flat_map(|f| {
                let face = mesh.face(f).to_vec();
                let right = face.iter().all(|&x| x % (n + 1) >= n / 2);
                face.into_iter().map(move |x| if right { x + nv } else { x })
            })
            .collect();
        mesh.uvs = Some(FaceVarying { values, indices });
    }
    mesh
}

/// A closed cube of six quads with one sharp crease.
fn cube() -> Mesh {
    let mut m = Mesh::new();
    for k in 0..8u32 {
        m.positions.push(Vec3::new((k & 1) as f32, ((k >> 1) & 1) as f32, ((k >> 2) & 1) as f32));
    }
    for f in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
        m.push_face(&f);
    }
    m.creases.push(sylva::geometry::Crease { a: 0, b: 1, sharpness: 2.5 });
    m
}

/// Issue 39 item 3: the refinement's memory is estimated before anything is allocated
/// (`refine::peak_memory`), as an upper bound of what the allocations measure and not
/// far above it — for both schemes, with and without UVs (linear and smooth), limit
/// positions and normals, creases and boundaries, at several levels.
#[test]
fn item_3_refinement_memory_estimate_bounds_the_measured_peak() {
    let _one = lock();
    use FvarInterpolation::{CornersPlus, Linear, Smooth};
    use Scheme::{CatmullClark, Loop};
    // (name, mesh, scheme, levels, limit positions and normals, UV interpolation)
    let cases: Vec<(&str, Mesh, Scheme, u32, bool, FvarInterpolation)> = vec![
        ("quad grid", grid(40, 30, false, false), CatmullClark, 3, false, Linear),
        ("quad grid, limit", grid(40, 30, false, false), CatmullClark, 3, true, Linear),
        ("quad grid, UVs", grid(40, 30, false, true), CatmullClark, 3, false, Linear),
        ("quad grid, smooth UVs, limit", grid(40, 30, false, true), CatmullClark, 3, true, CornersPlus),
        ("cube", cube(), CatmullClark, 6, false, Linear),
        ("cube, limit", cube(), CatmullClark, 6, true, Linear),
        ("triangle grid", grid(40, 30, true, false), Loop, 3, false, Linear),
        ("triangle grid, limit", grid(40, 30, true, false), Loop, 3, true, Linear),
        ("triangle grid, smooth UVs", grid(40, 30, true, true), Loop, 3, false, Smooth),
        ("triangle grid, 1 level", grid(60, 60, true, true), Loop, 1, false, Linear),
    ];
    for (name, mesh, scheme, levels, limit, uv) in cases {
        let opts = SubdivideOptions {
            refine: RefineOptions { scheme, levels, parallel: false, ..Default::default() },
            limit,
            uv,
        };
        let estimate = peak_memory(&mesh, &[], &opts).unwrap();
        let (measured, out) = measure(|| subdivide(&mesh, &[], &opts).unwrap());
        let faces = out.face_count();
        drop(out);
        println!(
            "{name}: {faces} faces, measured {measured} bytes ({:.0}/face), estimated {estimate} ({:.0}/face)",
            measured as f64 / faces as f64,
            estimate as f64 / faces as f64
        );
        assert!(estimate >= measured as u128, "{name}: estimate {estimate} < measured {measured}");
        assert!(
            estimate as f64 <= 1.6 * measured as f64,
            "{name}: estimate {estimate} is far above the measured {measured}"
        );
    }
}

/// Issue 39 item 3: `refine.levels = 6` with the face budget raised to 10⁹ asked for
/// gigabytes and aborted ("memory allocation of 1006252032 bytes failed"). Now the
/// estimate stops it first with an error naming the levels and the bytes, having
/// allocated nothing of the refinement; with the limit raised past what the system
/// gives, the failed reservation is an error naming the bytes, not an abort.
#[test]
fn item_3_levels_6_over_the_memory_budget_fail_before_allocating() {
    let _one = lock();
    // 4,800 quads: 6 levels make 19.7 M faces, about 1.7 GB at the peak.
    let mesh = grid(80, 60, false, true);
    let opts = |max_memory| SubdivideOptions {
        refine: RefineOptions {
            scheme: Scheme::CatmullClark,
            levels: 6,
            max_faces: 1_000_000_000,
            max_memory,
            ..Default::default()
        },
        ..Default::default()
    };
    let (peak, r) = measure(|| subdivide(&mesh, &[], &opts(1 << 30)));
    match r {
        Err(RefineError::Memory { levels: 6, faces, bytes, limit }) => {
            assert_eq!(faces, 4800 * 4096);
            assert!(bytes > 1 << 30 && limit == 1 << 30, "{bytes} {limit}");
        }
        other => panic!("expected the memory budget error, got {other:?}"),
    }
    assert!(peak < 16 << 20, "{peak} bytes were allocated before the error");
    let msg = subdivide(&mesh, &[], &opts(1 << 30)).unwrap_err().to_string();
    assert!(msg.contains("6 levels") && msg.contains("bytes") && msg.contains("memory limit"), "{msg}");

    // A system that refuses anything over 64 MiB: the estimate passes (no limit), the
    // first big reservation fails, and that is an error.
    REFUSE_ABOVE.store(64 << 20, SeqCst);
    let r = subdivide(&mesh, &[], &opts(u64::MAX));
    REFUSE_ABOVE.store(usize::MAX, SeqCst);
    match r {
        Err(RefineError::OutOfMemory { what, bytes }) => {
            assert!(bytes > 64 << 20, "{what}: {bytes}");
            let msg = RefineError::OutOfMemory { what, bytes }.to_string();
            assert!(msg.contains(&bytes.to_string()), "{msg}");
        }
        other => panic!("expected an out-of-memory error, got {other:?}"),
    }
}

/// Issue 39 item 3 through the pipeline: the error names `refine.max_memory`,
/// `refine.levels` and the bytes.
#[test]
fn item_3_pipeline_memory_error_names_the_keys() {
    let _one = lock();
    let sets =
        ["refine.levels=6", "refine.max_faces=1000000000", "refine.max_memory=50000000", "mesh.clear=false"];
    let (msg, peak) = grow_error("lsys-binary-tree", &sets);
    assert!(
        msg.contains("refine.max_memory") && msg.contains("refine.levels") && msg.contains("bytes"),
        "{msg}"
    );
    assert!(peak < 400 << 20, "{peak} bytes allocated before the error");
}

/// A glTF-like mesh of `triangles` triangles over only `vertices` vertices spread in a
/// box (every triangle's box overlaps nearly every other: the quadratic case).
fn tangle(vertices: u32, triangles: usize) -> Mesh {
    let mut m = Mesh::new();
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    for _ in 0..vertices {
        let mut c = || (next() % 20_000) as f32 / 10_000.0 - 1.0;
        let p = Vec3::new(c(), 5.0 * c() + 5.0, c());
        m.positions.push(p);
    }
    for _ in 0..triangles {
        let t = [0, 1, 2].map(|_| (next() % vertices as u64) as u32);
        m.push_face(&t);
    }
    m
}

/// Issue 39 item 7: 125,000 triangles over 256 vertices took 66–120 s in the
/// self-intersection search (every box overlaps every other). The search now counts
/// the candidate pairs it looks at and stops at its budget with a report that says so;
/// degenerate triangles are reported up front and not searched. The same input with a
/// budget too small to finish, and one without, end the same way on every run.
#[test]
fn item_7_tangled_triangles_stop_at_the_pair_budget() {
    let _one = lock();
    let mesh = tangle(256, 125_000);
    // With the defaults the search stops at its 100,000th crossing pair, after a few
    // hundred triangles (it used to finish a block of 16,384 first).
    let r = check_mesh(&mesh, &CheckOptions::default());
    assert!(r.intersections_truncated && !r.search_stopped, "{r}");
    assert!(r.pairs_searched < 100_000_000, "{}", r.pairs_searched);
    // Without that limit, the work budget stops it.
    let opts = CheckOptions { max_pairs: 20_000_000, max_intersections: usize::MAX, ..Default::default() };
    let r = check_mesh(&mesh, &opts);
    assert!(r.search_stopped, "{r}");
    // It stops within one part (at most 64 triangles, each with at most all the others
    // as candidates) past the budget.
    let over = r.pairs_searched - 20_000_000;
    assert!(r.pairs_searched > 20_000_000 && over <= 64 * 125_000, "{}", r.pairs_searched);
    assert!(!r.is_valid());
    let text = r.to_string();
    assert!(
        text.contains("self-intersection search stopped after") && text.contains("--max-pairs"),
        "{text}"
    );
    assert!(r.degenerate_face_count > 0, "random triangles over 256 vertices repeat some");
    // Deterministic: the same stop, the same pairs, on any thread count.
    let again = sylva::refine::with_threads(1, || check_mesh(&mesh, &opts)).unwrap();
    assert_eq!(again, r);
}

/// Issue 39 item 7: one primitive drawn 150 times took 32–118 s. Duplicate faces (the
/// same corner positions in the same order, even through vertices of their own) are
/// reported and left out of the search, so the search costs what one copy costs; a back
/// face (the reverse order, a leaf card's) is not a duplicate.
#[test]
fn item_7_repeated_copies_are_reported_and_searched_once() {
    let _one = lock();
    let one = grid(30, 30, true, false);
    let single = check_mesh(&one, &CheckOptions::default());
    let mut many = Mesh::new();
    for _ in 0..150 {
        many.append(&one);
    }
    let r = check_mesh(&many, &CheckOptions::default());
    assert_eq!(r.duplicate_face_count, 149 * one.face_count());
    assert_eq!(r.intersection_count, single.intersection_count);
    assert!(!r.search_stopped);
    assert!(r.pairs_searched <= single.pairs_searched, "{} > {}", r.pairs_searched, single.pairs_searched);
    assert!(r.notes().iter().any(|p| p.contains("duplicate face")), "{:?}", r.notes());
    assert!(r.to_string().contains(&format!("note: {} duplicate face(s)", 149 * one.face_count())), "{r}");
    // A back face is not a duplicate.
    let mut two_sided = one.clone();
    let mut back = one.clone();
    for f in 0..back.face_count() {
        back.face_indices[back.face_offsets[f] as usize..back.face_offsets[f + 1] as usize].reverse();
    }
    two_sided.append(&back);
    assert_eq!(check_mesh(&two_sided, &CheckOptions::default()).duplicate_face_count, 0);
}

/// Issue 39, the campaign's abort (`lsys-honda-a -n 19` under 6 GB): the mesh stage's
/// estimate ([`sylva::mesh::memory::DOWNSTREAM_FACTOR`] times the bark's bytes) bounds
/// the measured peak of growing and exporting a tree, and is not far above it, on a
/// bare binary tree and on a leafy Weber–Penn tree.
#[test]
fn mesh_stage_memory_estimate_bounds_grow_and_export() {
    let _one = lock();
    let cases = [("lsys-honda-a", Some(14)), ("wp-quaking-aspen", None), ("lsys-binary-tree", None)];
    for (what, n) in cases {
        let sets: Vec<_> =
            n.map(|n| ("generator.iterations".to_string(), toml::Value::Integer(n))).into_iter().collect();
        let loaded = sylva::recipe::load(what, &sets).unwrap();
        let (peak, bark) = measure(|| {
            let grown = sylva::pipeline::grow(&loaded).unwrap();
            let glb = sylva::export::gltf::to_glb(&grown.model).unwrap();
            assert!(!glb.is_empty());
            let bark = grown.model.parts.iter().find(|p| p.name == "bark").unwrap();
            sylva::mesh::memory::mesh_bytes(&bark.mesh)
        });
        let estimate = sylva::mesh::memory::downstream_peak(bark, &loaded.recipe.textures);
        eprintln!("{what}: bark {bark} bytes, measured peak {peak}, ratio {:.2}", peak as f64 / bark as f64);
        assert!(
            peak as u128 <= estimate,
            "{what}: peak {peak} over the estimate {estimate} (bark {bark} bytes)"
        );
        assert!(estimate <= 3 * peak as u128, "{what}: estimate {estimate} over 3 × the peak {peak}");
    }
}

/// The mesh stage's budget stops a skeleton too large for it before meshing, with an
/// error naming `mesh.max_memory` and what to lower; a raised budget lets it through.
#[test]
fn mesh_stage_memory_budget_is_checked_before_meshing() {
    let _one = lock();
    // A 1,000-internode tree in 100 kB.
    let (msg, peak) = grow_error("lsys-honda-a", &["generator.iterations=10", "mesh.max_memory=100000"]);
    assert!(
        msg.contains("mesh.max_memory") && msg.contains("at least") && msg.contains("generator.iterations"),
        "{msg}"
    );
    assert!(peak < 50 << 20, "{peak} bytes allocated before the error");
    assert!(recipes::grow("lsys-honda-a", &["generator.iterations=10"]).is_ok());
}
