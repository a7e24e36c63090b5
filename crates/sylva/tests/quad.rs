//! The quad mesher (Skjermo2008 junction paper, Skjermo2008-spec §2 and §10 properties 1–4, 7, 9,
//! 11): all-quad closed 2-manifold cages on the seed's cases and on hard cases, every
//! embedded preset, Catmull–Clark refinement staying manifold, and a property test over
//! random skeletons.

#[path = "common/cage_topo.rs"]
mod cage_topo;
#[path = "common/preset_skeletons.rs"]
mod preset_skeletons;
#[path = "common/random_tree.rs"]
mod random_tree;
#[path = "common/skeletons.rs"]
mod skeletons;
use skeletons::{chain, seg, whorl};

use cage_topo::{refined, Topo};
use glam::Vec3;
use preset_skeletons::{named_preset_skeleton, par_map_presets};
use proptest::prelude::*;
use random_tree::random_tree;
use sylva::mesh::check::{check_mesh, skeleton_collisions, CheckOptions};
use sylva::mesh::quad::{quad_mesh, FallbackReason, QuadMesh, QuadOptions};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Mesh, Skeleton, NO_PARENT};

// ---------------------------------------------------------------------------------------
// Mesh checks

/// A closed, consistently oriented 2-manifold of quads (no boundary edge), genus 0 in
/// every component; else a description of the first problem.
fn try_check(m: &Mesh) -> Result<Topo, String> {
    cage_topo::try_check(m, 4, true)
}

fn check(name: &str, m: &Mesh) -> Topo {
    cage_topo::check(name, m, 4, true)
}

fn catmull_clark(m: &Mesh, levels: u32) -> Mesh {
    refined(m, Scheme::CatmullClark, levels)
}

/// Components expected from the report: one per tree plus one per detached or
/// separated subtree.
fn expected_components(sk: &Skeleton, q: &QuadMesh) -> usize {
    let ch = sk.children();
    let trees = (0..sk.len()).filter(|&i| sk.parent[i] == NO_PARENT && !ch.of(i).is_empty()).count();
    let detached = q
        .fallbacks
        .iter()
        .filter(|f| {
            matches!(
                f.reason,
                FallbackReason::Detached | FallbackReason::ChainLimit | FallbackReason::Separated
            )
        })
        .count();
    trees + detached
}

/// Meshes, checks everything that holds for any input, refines one level and checks
/// again; returns the result.
fn full_check(name: &str, sk: &Skeleton, opts: &QuadOptions) -> QuadMesh {
    let q = quad_mesh(sk, opts).unwrap_or_else(|e| panic!("{name}: {e}"));
    let t = check(name, &q.mesh);
    assert_eq!(t.components, q.components, "{name}: components vs report");
    assert_eq!(t.components, expected_components(sk, &q), "{name}: unreported detached pieces");
    assert!(q.mesh.signed_volume() > 0.0, "{name}: inward-facing (volume ≤ 0)");
    let uv = q.mesh.uvs.as_ref().expect("UVs");
    assert_eq!(uv.indices.len(), q.mesh.face_indices.len());
    assert!(uv.values.iter().all(|v| v.is_finite() && v.x >= 0.0 && v.x <= 1.0 && v.y >= 0.0));
    let fine = catmull_clark(&q.mesh, 1);
    let tf = check(&format!("{name} CC 1"), &fine);
    // Skjermo2008-spec property 11: V′ = V + E + F, still closed and all-quad.
    assert_eq!(tf.vertices, t.vertices + t.edges + t.faces, "{name}: V' = V + E + F");
    assert_eq!(tf.faces, 4 * t.faces);
    assert!(fine.signed_volume() > 0.0, "{name}: refined volume");
    q
}

// ---------------------------------------------------------------------------------------
// Skeleton builders

fn y_fork() -> Skeleton {
    skeletons::y_fork(0.15, 0.12)
}

// ---------------------------------------------------------------------------------------
// The seed's counts (Skjermo2008-spec §10 properties 2–4)

#[test]
fn unbranched_chain_has_4_k_plus_1_vertices() {
    for k in 1..=8usize {
        let pts: Vec<Vec3> = (0..=k)
            .map(|i| Vec3::new((i as f32 * 0.9).sin() * 0.4, i as f32, (i as f32 * 0.5).cos() * 0.3))
            .collect();
        // The seed's cage: no support rings (tested below).
        let seed = QuadOptions { support: 0.0, ..Default::default() };
        let q = full_check(&format!("chain {k}"), &chain(&pts, 0.1), &seed);
        let t = check("chain", &q.mesh);
        assert_eq!(t.vertices, 4 * (k + 1), "V = 4(k+1)");
        assert_eq!(t.faces, 4 * k + 2, "F = 4k + 2");
        assert_eq!(t.edges, 2 * t.faces, "E = 2F");
        assert_eq!(t.vertices, t.faces + 2, "V = F + 2");
        assert!(q.fallbacks.is_empty());
    }
}

/// Support rings (`QuadOptions::support`): a tube of one face per internode lets
/// Catmull–Clark cut the corner of a bend by a fraction of the internode's length; with
/// a support ring before each bend the refined surface stays within about its radius of
/// the skeleton. A zig-zag of 20-radius internodes bent by 45°–90°: one ring (4
/// vertices) per long internode, and the level-2 surface's farthest point from the axis
/// polyline within 2 ρ (measured: 0.94, 1.01 and 1.91 ρ at 45°, 60° and 90°; a 90°
/// miter's corners lie 1.41 ρ out), under 1/1.8 of the distance without them (2.90,
/// 3.39, 3.52 ρ). (Bends past 90° are the seed's backward boxes.)
#[test]
fn support_rings_hold_bends_under_refinement() {
    for bend in [45.0f32, 60.0, 90.0] {
        let (b, mut dir, mut at) = (bend.to_radians(), Vec3::Y, Vec3::ZERO);
        let mut pts = vec![at];
        for i in 0..4 {
            at += dir * 2.0;
            pts.push(at);
            let turn = if i % 2 == 0 { b } else { -b };
            dir = Vec3::new(
                dir.x * turn.cos() - dir.y * turn.sin(),
                dir.x * turn.sin() + dir.y * turn.cos(),
                0.0,
            );
        }
        let sk = chain(&pts, 0.1);
        let off = |opts: &QuadOptions| {
            let q = full_check(&format!("zig-zag {bend}°"), &sk, opts);
            let o = SubdivideOptions {
                refine: RefineOptions { scheme: Scheme::CatmullClark, levels: 2, ..Default::default() },
                ..Default::default()
            };
            let fine = subdivide(&q.mesh, &[], &o).unwrap();
            let far = fine
                .positions
                .iter()
                .map(|&p| {
                    pts.windows(2)
                        .map(|w| {
                            let (a, ab) = (w[0], w[1] - w[0]);
                            let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                            p.distance(a + ab * t)
                        })
                        .fold(f32::MAX, f32::min)
                })
                .fold(0.0f32, f32::max);
            (q, far / 0.1)
        };
        let (seed, seed_far) = off(&QuadOptions { support: 0.0, ..Default::default() });
        let (q, far) = off(&QuadOptions::default());
        assert_eq!(
            q.mesh.positions.len(),
            seed.mesh.positions.len() + 4 * 4,
            "{bend}°: one ring per internode"
        );
        assert!(far <= 2.0, "{bend}°: the refined surface reaches {far} ρ from the axis");
        assert!(seed_far > 1.8 * far, "{bend}°: without support rings {seed_far} ρ, with {far} ρ");
    }
}

/// Issue 26 (Skjermo2008): a support ring keeps its end ring's corner orientation. Seen
/// along the internode, each support-ring corner points where the end ring's corner of
/// the same index does, also where the bend turns out of the plane of the previous one
/// (projecting the end ring's up vector instead left them 4.7°–9.6° off at 46°–67°).
#[test]
fn support_rings_keep_the_end_rings_corners_on_bends_out_of_a_plane() {
    // A chain of 2 m internodes whose bends (46°–67°) each turn in another plane.
    let turns = [(46f32, 0f32), (52.0, 70.0), (58.0, 150.0), (63.0, 235.0), (67.0, 300.0), (55.0, 20.0)];
    let (mut dir, mut at) = (Vec3::Y, Vec3::ZERO);
    let mut pts = vec![at];
    for (bend, azimuth) in turns {
        at += dir * 2.0;
        pts.push(at);
        let (u, v) = dir.any_orthonormal_pair();
        let (b, a) = (bend.to_radians(), azimuth.to_radians());
        let side = u * a.cos() + v * a.sin();
        dir = (dir * b.cos() + side * b.sin()).normalize();
    }
    pts.push(at + dir * 2.0);
    let sk = chain(&pts, 0.1);
    let q = full_check("out-of-plane bends", &sk, &QuadOptions::default());
    assert!(q.merged.is_empty() && q.fallbacks.is_empty(), "{:?} {:?}", q.merged, q.fallbacks);
    let p = &q.mesh.positions;
    // Rings are four consecutive vertices: the end ring of each internode (at its node),
    // then its support ring (on its axis, short of the node).
    let rings: Vec<[Vec3; 4]> = p.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect();
    let centre = |r: &[Vec3; 4]| (r[0] + r[1] + r[2] + r[3]) / 4.0;
    let mut worst = 0.0f32;
    let mut supports = 0;
    for w in pts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let d = (b - a).normalize();
        let on_axis = |c: Vec3| {
            let t = (c - a).dot(d);
            (c - a - d * t).length() < 1e-4 && t > 0.05 && t < (b - a).length() - 0.05
        };
        let Some(m) = rings.iter().find(|r| on_axis(centre(r))) else { continue };
        let e = rings.iter().find(|r| centre(r).distance(b) < 1e-4).expect("an end ring at the node");
        supports += 1;
        let (mc, ec) = (centre(m), centre(e));
        for k in 0..4 {
            let s = (m[k] - mc).normalize();
            let o = e[k] - ec;
            let t = (o - d * o.dot(d)).normalize();
            assert!(s.dot(d).abs() < 1e-4, "the support ring is perpendicular to its internode");
            worst = worst.max(s.dot(t).clamp(-1.0, 1.0).acos().to_degrees());
        }
    }
    assert_eq!(supports, pts.len() - 1, "one support ring per internode");
    assert!(worst < 0.5, "a support ring's corners are {worst}° off its end ring's");
}

#[test]
fn fork_and_backward_counts() {
    // One fork with two leaf children (case d): V = 20, F = 18, E = 36 — the seed's
    // construction, without elbows.
    let seed = QuadOptions { elbow_angle: 90.0, support: 0.0, ..Default::default() };
    let q = full_check("Y fork", &y_fork(), &seed);
    let t = check("Y fork", &q.mesh);
    assert_eq!((t.vertices, t.faces, t.edges), (20, 18, 36));
    assert_eq!(q.cases.boxes, 1);
    assert_eq!(q.cases.elbows, 0);
    assert!(q.fallbacks.is_empty(), "{:?}", q.fallbacks);
    // Without pull-back the counts are the same.
    let q = full_check("Y fork, no pull-back", &y_fork(), &QuadOptions { pull_back: false, ..seed.clone() });
    assert_eq!(check("", &q.mesh).vertices, 20);
    // Each elbow adds one ring (4 vertices) and one band (4 faces).
    let q = full_check("Y fork, elbows", &y_fork(), &QuadOptions { support: 0.0, ..Default::default() });
    let t = check("Y fork, elbows", &q.mesh);
    let e = q.cases.elbows;
    assert_eq!((t.vertices, t.faces, t.edges), (20 + 4 * e, 18 + 4 * e, 36 + 8 * e));
    // A single backward child (case c): V = 16, F = 14.
    for angle in [90.0f32, 90.1, 120.0, 135.0, 150.0] {
        let a = angle.to_radians();
        let s =
            chain(&[Vec3::ZERO, Vec3::Y * 3.0, Vec3::Y * 3.0 + Vec3::new(a.sin(), a.cos(), 0.0) * 2.0], 0.2);
        let q = full_check(&format!("backward {angle}"), &s, &seed);
        let t = check("backward", &q.mesh);
        assert_eq!((t.vertices, t.faces), (16, 14), "backward {angle}°");
        assert_eq!(q.cases.backward, 1);
        assert!(q.fallbacks.is_empty());
    }
}

/// Skjermo2008-spec property 6: the case table.
#[test]
fn case_selection() {
    for (angle, kids, want) in [
        (0.0f32, 1usize, "b"),
        (45.0, 1, "b"),
        (89.9, 1, "b"),
        (90.0, 1, "c"),
        (90.1, 1, "c"),
        (135.0, 1, "c"),
        (0.0, 0, "a"),
        (45.0, 3, "d"),
        (89.9, 3, "d"),
        (135.0, 3, "c"),
    ] {
        let mut s = Skeleton::new();
        let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
        let n = seg(&mut s, r, Vec3::Y * 4.0, 0.2);
        for k in 0..kids {
            let a = angle.to_radians();
            let az = k as f32 * 2.1;
            let d = Vec3::new(a.sin() * az.cos(), a.cos(), a.sin() * az.sin());
            // The first child is the thickest.
            seg(&mut s, n, Vec3::Y * 4.0 + d * 3.0, 0.15 - 0.02 * k as f32);
        }
        let q = full_check(&format!("{angle}° × {kids}"), &s, &QuadOptions::default());
        let c = q.cases;
        let got = if c.backward > 0 {
            "c"
        } else if c.boxes > 0 {
            "d"
        } else if c.normal > 0 {
            "b"
        } else {
            "a"
        };
        assert_eq!(got, want, "{angle}° with {kids} children: {c:?}");
    }
}

// ---------------------------------------------------------------------------------------
// Hard cases: closed, outward, fallbacks reported

#[test]
fn hard_cases_are_closed_outward_manifolds() {
    let o = QuadOptions::default();
    let mut cases: Vec<(String, Skeleton)> = vec![
        (
            "single chain".into(),
            chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.2, 2.0, 0.0), Vec3::new(0.5, 3.0, 0.1)], 0.1),
        ),
        ("Y fork".into(), y_fork()),
    ];
    for n in [3usize, 6, 8, 12] {
        cases.push((format!("{n}-whorl"), whorl(n, 1.0, 0.1, 0.0)));
        cases.push((format!("{n}-whorl non-planar"), whorl(n, 1.0, 0.1, 0.35)));
    }
    // A child aligned with the parent next to a thicker lateral.
    let mut s = chain(&[Vec3::ZERO, Vec3::Y * 2.0], 0.2);
    seg(&mut s, 1, Vec3::new(1.5, 3.5, 0.0), 0.18);
    seg(&mut s, 1, Vec3::Y * 4.0, 0.1);
    cases.push(("aligned child".into(), s));
    // Two children both aligned with the parent.
    let mut s = chain(&[Vec3::ZERO, Vec3::Y * 2.0], 0.2);
    seg(&mut s, 1, Vec3::Y * 4.0, 0.15);
    seg(&mut s, 1, Vec3::Y * 3.0, 0.1);
    cases.push(("two aligned children".into(), s));
    // A child thicker than its parent.
    let mut s = chain(&[Vec3::ZERO, Vec3::Y * 2.0], 0.1);
    seg(&mut s, 1, Vec3::new(0.5, 4.0, 0.0), 0.3);
    seg(&mut s, 1, Vec3::new(-1.5, 3.0, 0.0), 0.25);
    cases.push(("thicker child".into(), s));
    // Bends beyond 90°, and a full reversal.
    for deg in [100.0f32, 150.0, 180.0] {
        let a = deg.to_radians();
        let mut s = chain(&[Vec3::ZERO, Vec3::Y * 2.0], 0.2);
        seg(&mut s, 1, Vec3::Y * 2.0 + Vec3::new(a.sin(), a.cos(), 0.0) * 1.5, 0.15);
        seg(&mut s, 1, Vec3::Y * 2.0 + Vec3::new(-a.sin(), a.cos(), 0.3) * 1.5, 0.1);
        cases.push((format!("{deg}° bend with a sibling"), s));
    }
    // Very short internodes, zero-length internodes and zero radii.
    let pts: Vec<Vec3> =
        (0..40).map(|i| Vec3::new((i as f32 * 0.4).sin() * 0.02, i as f32 * 0.01, 0.0)).collect();
    cases.push(("very short internodes".into(), chain(&pts, 0.1)));
    let mut s = chain(&[Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::Y * 2.0], 0.1);
    seg(&mut s, 2, Vec3::Y, 0.05);
    seg(&mut s, 2, Vec3::new(0.5, 1.2, 0.0), 0.0);
    cases.push(("zero-length internodes".into(), s));
    // A child shorter than its box.
    let mut s = chain(&[Vec3::ZERO, Vec3::Y * 2.0], 0.3);
    seg(&mut s, 1, Vec3::new(0.05, 2.1, 0.0), 0.3);
    seg(&mut s, 1, Vec3::new(0.6, 2.3, 0.0), 0.2);
    cases.push(("child shorter than its box".into(), s));
    // A branching root and two trees.
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    for k in 0..3 {
        let a = k as f32 * 2.0;
        seg(&mut s, r, Vec3::new(a.cos(), 2.0, a.sin()), 0.1);
    }
    let r2 = seg(&mut s, NO_PARENT, Vec3::X * 5.0, 0.2);
    seg(&mut s, r2, Vec3::new(5.0, 2.0, 0.0), 0.1);
    cases.push(("branching root and a second tree".into(), s));

    for (name, sk) in &cases {
        let q = full_check(name, sk, &o);
        println!(
            "{name}: {} faces, {} intersecting face pairs, cases {:?}, fallbacks {:?}",
            q.mesh.face_count(),
            intersecting_faces(&q.mesh).len(),
            q.cases,
            q.fallbacks
        );
    }
    // A thin child aligned with its thicker aligned sibling is detached and reported;
    // so is a child reversed onto its parent.
    let q = quad_mesh(&cases.iter().find(|c| c.0 == "two aligned children").unwrap().1, &o).unwrap();
    assert!(
        q.fallbacks.iter().any(|f| f.node == 3 && f.reason == FallbackReason::Detached),
        "{:?}",
        q.fallbacks
    );
    let q = quad_mesh(&cases.iter().find(|c| c.0 == "180° bend with a sibling").unwrap().1, &o).unwrap();
    assert!(
        q.fallbacks.iter().any(|f| f.node == 2 && f.reason == FallbackReason::Detached),
        "{:?}",
        q.fallbacks
    );
    // A child shorter than its box is reported.
    let q = quad_mesh(&cases.iter().find(|c| c.0 == "child shorter than its box").unwrap().1, &o).unwrap();
    assert!(
        q.fallbacks
            .iter()
            .any(|f| f.node == 2 && matches!(f.reason, FallbackReason::Short | FallbackReason::ShortBox)),
        "{:?}",
        q.fallbacks
    );
    // A whorl of 12 needs chained boxes.
    let q = quad_mesh(&whorl(12, 1.0, 0.1, 0.0), &o).unwrap();
    assert!(q.cases.chained > 0);
}

#[test]
fn output_is_deterministic() {
    let s = whorl(7, 0.9, 0.1, 0.2);
    let a = quad_mesh(&s, &QuadOptions::default()).unwrap();
    let b = quad_mesh(&s, &QuadOptions::default()).unwrap();
    assert_eq!(a, b);
}

// ---------------------------------------------------------------------------------------
// Every preset

#[test]
fn every_preset_meshes_into_a_closed_manifold() {
    println!("| preset | nodes | vertices | faces | components | fallbacks (detached/chain/short box/short/separated/unboxed) | merged | repair rounds | ms |");
    println!("|---|---|---|---|---|---|---|---|---|");
    // The presets mesh in parallel; rows are printed in order.
    let rows: Vec<(String, usize)> = par_map_presets(
        |p| !p.is_curves(),
        |name, sk| {
            let t0 = std::time::Instant::now();
            let q = quad_mesh(sk, &QuadOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", name));
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let t = check(name, &q.mesh);
            assert_eq!(t.components, expected_components(sk, &q), "{}", name);
            if t.faces > 0 {
                assert!(q.mesh.signed_volume() > 0.0, "{}: volume", name);
                check(&format!("{} CC 1", name), &catmull_clark(&q.mesh, 1));
            }
            let by = |r: FallbackReason| q.fallbacks.iter().filter(|f| f.reason == r).count();
            let row = format!(
                "| {} | {} | {} | {} | {} | {} ({}/{}/{}/{}/{}/{}) | {} | {} | {ms:.1} |",
                name,
                sk.len(),
                t.vertices,
                t.faces,
                t.components,
                q.fallbacks.len(),
                by(FallbackReason::Detached),
                by(FallbackReason::ChainLimit),
                by(FallbackReason::ShortBox),
                by(FallbackReason::Short),
                by(FallbackReason::Separated),
                by(FallbackReason::Unboxed),
                q.merged.len(),
                q.repair_rounds
            );
            (row, q.fallbacks.len())
        },
    );
    for (row, _) in &rows {
        println!("{row}");
    }
    let meshed = rows.len();
    let total_fallbacks: usize = rows.iter().map(|r| r.1).sum();
    println!("{meshed} presets meshed, {total_fallbacks} fallbacks in all");
    assert!(meshed > 0);
}

// ---------------------------------------------------------------------------------------
// Random skeletons

/// Checks one random skeleton; `Err` describes a case that is not a valid outward
/// manifold with every detached piece reported. Panics (a test failure) on a panic or
/// an error from the mesher.
fn random_case(seed: u64) -> Result<(), String> {
    let sk = random_tree(seed, 60);
    let q = quad_mesh(&sk, &QuadOptions::default()).map_err(|e| format!("error: {e}"))?;
    let t = try_check(&q.mesh)?;
    if t.components != expected_components(&sk, &q) {
        return Err(format!("{} components, {} expected", t.components, expected_components(&sk, &q)));
    }
    if q.mesh.signed_volume() <= 0.0 {
        return Err("volume ≤ 0".into());
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
    /// Never panics, never errors on a valid skeleton, the cage is an all-quad closed
    /// manifold and every detached piece is reported (≥ 99% asked; the topology holds
    /// by construction, so any failure is shown). 256 cases keep CI fast; `random_rate`
    /// with 1000 seeds was run by hand: 1000 of 1000 valid (and 20 000 of 20 000).
    #[test]
    fn random_skeletons_give_closed_manifolds(seed in any::<u64>()) {
        let r = random_case(seed);
        prop_assert!(r.is_ok(), "seed {}: {:?}", seed, r);
    }
}

/// The ≥ 99% rate over many seeds: `QUAD_CASES=1000 cargo test -p sylva --test quad
/// -- --ignored --nocapture random_rate`.
#[test]
#[ignore]
fn random_rate() {
    let n: u64 = std::env::var("QUAD_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(1000);
    let mut bad = Vec::new();
    for seed in 0..n {
        if let Err(e) = random_case(seed) {
            bad.push((seed, e));
        }
    }
    println!(
        "{} of {n} random skeletons valid; failures: {:?}",
        n as usize - bad.len(),
        &bad[..bad.len().min(10)]
    );
    assert!(bad.len() as f64 <= 0.01 * n as f64);
}

/// Diagnostic: why children of a preset detach (`QUAD_PRESET=name`).
#[test]
#[ignore]
fn detach_reasons() {
    let (_, sk) = named_preset_skeleton("QUAD_PRESET", "lsys-abop-a");
    let sk = &sk;
    let q = quad_mesh(sk, &QuadOptions::default()).unwrap();
    let ch = sk.children();
    for f in q.fallbacks.iter().filter(|f| f.reason == FallbackReason::Detached).take(12) {
        let k = f.node as usize;
        let p = sk.parent[k] as usize;
        let gp = sk.parent[p];
        let dir = |a: usize, b: usize| (sk.position[b] - sk.position[a]).normalize_or_zero();
        let din = if gp == NO_PARENT { Vec3::Y } else { dir(gp as usize, p) };
        let sib: Vec<String> = ch
            .of(p)
            .iter()
            .map(|&s| {
                let s = s as usize;
                format!(
                    "{s}: r {:.4} len {:.4} ∠in {:.1}°",
                    sk.radius[s],
                    sk.position[s].distance(sk.position[p]),
                    din.angle_between(dir(p, s)).to_degrees()
                )
            })
            .collect();
        let fb: Vec<_> =
            q.fallbacks.iter().filter(|f| f.node as usize == p || f.node as usize == gp as usize).collect();
        let gsib: Vec<u32> = if gp == NO_PARENT { vec![] } else { ch.of(gp as usize).to_vec() };
        println!("detached {k} at {p} (r {:.4}) parent {gp} kids {gsib:?} fb {fb:?}: {sib:?}", sk.radius[p]);
    }
}

/// UVs: `u = k/4` around each ring with the seam at `u = 1`, `v` increasing along the
/// branch by length over circumference.
#[test]
fn uvs_wrap_around_and_grow_along() {
    let k = 4;
    let pts: Vec<Vec3> = (0..=k).map(|i| Vec3::Y * i as f32).collect();
    let q = quad_mesh(&chain(&pts, 0.1), &QuadOptions { support: 0.0, ..Default::default() }).unwrap();
    let uv = q.mesh.uvs.as_ref().unwrap();
    let at = |c: usize| uv.values[uv.indices[c] as usize];
    // Faces: root cap, 4 bands of 4 quads, tip cap.
    for f in 1..=4 * k {
        let c = q.mesh.corners(f);
        let (a, b, t1, t0) = (at(c.start), at(c.start + 1), at(c.start + 2), at(c.start + 3));
        let side = (f - 1) % 4;
        assert!((a.x - side as f32 / 4.0).abs() < 1e-6 && (b.x - (side + 1) as f32 / 4.0).abs() < 1e-6);
        assert_eq!((t0.x, t1.x), (a.x, b.x));
        // One unit of length on a tube of corner distance 0.1: Δv = 1 / (2π·0.1).
        let dv = 1.0 / (std::f32::consts::TAU * 0.1);
        assert!((t0.y - a.y - dv).abs() < 1e-4, "face {f}: Δv {}", t0.y - a.y);
        assert_eq!(a.y, b.y);
    }
    // The seam: u = 1 appears only on the last side of each band.
    assert!(uv.values.iter().any(|v| v.x == 1.0));
}

/// `mesh.method = "quad"` through the recipe and the pipeline: the bark is an all-quad
/// closed manifold after Catmull–Clark, and fallbacks become one warning.
#[test]
fn recipe_and_pipeline_select_the_quad_mesher() {
    let s = |v: &str| toml::Value::String(v.into());
    let sets = vec![
        ("mesh.method".to_string(), s("quad")),
        ("refine.scheme".to_string(), s("catmull-clark")),
        ("refine.levels".to_string(), toml::Value::Integer(1)),
        // De-collision (on by default for quad) removes every fallback of this preset;
        // keep the raw skeleton so the fallback warning is exercised.
        ("mesh.decollide".to_string(), toml::Value::Boolean(false)),
        // The mesher's own end: a flat base cuts the quads it crosses into n-gons.
        ("mesh.base".to_string(), s("round")),
    ];
    let loaded = sylva::recipe::load("lsys-honda-c", &sets).unwrap();
    let grown = sylva::pipeline::grow(&loaded).unwrap();
    let bark = &grown.model.parts[0].mesh;
    let t = check("honda-c pipeline", bark);
    let q = quad_mesh(&grown.skeleton, &QuadOptions::default()).unwrap();
    assert_eq!(t.components, q.components);
    assert_eq!(bark.face_count(), 4 * q.mesh.face_count());
    assert!(!q.fallbacks.is_empty());
    assert!(
        grown.report.warnings.iter().any(|w| w.starts_with("quad mesher:")),
        "{:?}",
        grown.report.warnings
    );
    let bad = vec![("mesh.method".to_string(), s("quads"))];
    let Err(err) = sylva::recipe::load("lsys-honda-c", &bad) else { panic!("unknown mesher accepted") };
    assert!(err.to_string().contains("tube, hull, sweep, quad"), "{err}");
}

/// Does segment `p → q` cross triangle `t` (Möller–Trumbore, strict interior)?
fn segment_hits_triangle(p: glam::DVec3, q: glam::DVec3, t: [glam::DVec3; 3]) -> bool {
    let dir = q - p;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = dir.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-14 {
        return false;
    }
    let f = 1.0 / a;
    let s = p - t[0];
    let u = f * s.dot(h);
    let qv = s.cross(e1);
    let v = f * dir.dot(qv);
    let w = f * e2.dot(qv);
    let eps = 1e-9;
    u > eps && v > eps && u + v < 1.0 - eps && w > eps && w < 1.0 - eps
}

/// Pairs of faces that share no vertex and intersect (each quad as two triangles, an
/// edge of one crossing the other).
fn intersecting_faces(m: &Mesh) -> Vec<(usize, usize)> {
    let tris = |f: usize| {
        let q = m.face(f);
        let p = |k: usize| m.positions[q[k] as usize].as_dvec3();
        [[p(0), p(1), p(2)], [p(0), p(2), p(3)]]
    };
    let mut out = Vec::new();
    for a in 0..m.face_count() {
        for b in a + 1..m.face_count() {
            if m.face(a).iter().any(|v| m.face(b).contains(v)) {
                continue;
            }
            let hit = tris(a).iter().any(|ta| {
                tris(b).iter().any(|tb| {
                    (0..3).any(|k| segment_hits_triangle(ta[k], ta[(k + 1) % 3], *tb))
                        || (0..3).any(|k| segment_hits_triangle(tb[k], tb[(k + 1) % 3], *ta))
                })
            });
            if hit {
                out.push((a, b));
            }
        }
    }
    out
}

/// Skjermo2008-spec property 10: forks that follow Da Vinci/Murray (α = 3, Murray's angles for
/// each child) with children longer than their box give a cage whose non-adjacent faces
/// do not intersect.
#[test]
fn murray_forks_do_not_self_intersect() {
    let mut worst = Vec::new();
    for i in 0..60 {
        let d0 = 0.4f64;
        let ratio = 0.25 + 0.75 * (i as f64 / 59.0); // d2 / d1
                                                     // Murray (α = 3): d0³ = d1³ + d2³.
        let d1 = d0 / (1.0 + ratio.powi(3)).cbrt();
        let d2 = d1 * ratio;
        let cx = (d0.powi(4) + d1.powi(4) - d2.powi(4)) / (2.0 * d0 * d0 * d1 * d1);
        let cy = (d0.powi(4) + d2.powi(4) - d1.powi(4)) / (2.0 * d0 * d0 * d2 * d2);
        let (x, y) = (cx.clamp(-1.0, 1.0).acos(), cy.clamp(-1.0, 1.0).acos());
        let az = i as f64 * 0.7;
        let plane = glam::DVec3::new(az.cos(), 0.0, az.sin());
        let mut s = Skeleton::new();
        let r = seg(&mut s, NO_PARENT, Vec3::ZERO, (d0 / 2.0) as f32);
        let n = seg(&mut s, r, Vec3::Y * 4.0, (d0 / 2.0) as f32);
        let dir1 = glam::DVec3::Y * x.cos() + plane * x.sin();
        let dir2 = glam::DVec3::Y * y.cos() - plane * y.sin();
        seg(&mut s, n, Vec3::Y * 4.0 + (dir1 * 4.0).as_vec3(), (d1 / 2.0) as f32);
        seg(&mut s, n, Vec3::Y * 4.0 + (dir2 * 4.0).as_vec3(), (d2 / 2.0) as f32);
        let q = full_check(&format!("Murray fork {i}"), &s, &QuadOptions::default());
        let hits = intersecting_faces(&q.mesh);
        if !hits.is_empty() {
            worst.push((i, x.to_degrees(), y.to_degrees(), hits.len()));
        }
    }
    assert!(worst.is_empty(), "self-intersecting Murray forks (case, x°, y°, pairs): {worst:?}");
    // The check itself sees intersections: two crossing trees.
    let mut s = chain(&[Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)], 0.1);
    let r = seg(&mut s, NO_PARENT, Vec3::new(0.0, 1.0, -1.0), 0.1);
    seg(&mut s, r, Vec3::new(0.0, 1.0, 1.0), 0.1);
    assert!(!intersecting_faces(&quad_mesh(&s, &QuadOptions::default()).unwrap().mesh).is_empty());
}

/// Skjermo2008-spec property 5: children in non-increasing diameter order, the first child's
/// subtree finished before any sibling (seen in the vertex order: the first child's end
/// ring comes before the second child's).
#[test]
fn first_child_subtree_is_meshed_first() {
    let mut s = chain(&[Vec3::ZERO, Vec3::Y * 3.0], 0.2);
    // Node 2 is thinner but listed first; node 3 is the first child by diameter.
    let thin = seg(&mut s, 1, Vec3::new(-1.2, 5.2, 0.3), 0.1);
    let thick = seg(&mut s, 1, Vec3::new(1.0, 5.5, 0.0), 0.15);
    let grand = seg(&mut s, thick, Vec3::new(1.5, 7.5, 0.0), 0.12);
    let q = quad_mesh(&s, &QuadOptions::default()).unwrap();
    let ring_of = |node: u32| {
        let p = s.position[node as usize];
        (0..q.mesh.positions.len() / 4)
            .min_by(|&a, &b| {
                let c = |r: usize| (0..4).map(|k| q.mesh.positions[4 * r + k]).sum::<Vec3>() / 4.0;
                c(a).distance(p).total_cmp(&c(b).distance(p))
            })
            .unwrap()
    };
    assert!(ring_of(thick) < ring_of(grand), "thick child before its child");
    assert!(ring_of(grand) < ring_of(thin), "the thick child's subtree before the thin sibling");
}

/// Elbows (`QuadOptions::elbow_angle`): a side child leaving its side face obliquely
/// starts from the face seen nearly edge-on; without an elbow its first tube is a
/// twisted blade that folds into its sibling under Catmull–Clark. Forks with the first
/// child at 25° and a second child at 30°–75° from the parent, at four azimuths and three
/// box orientations: with elbows (the default) none self-intersects at level 2; without
/// them some do.
#[test]
fn elbows_keep_oblique_side_children_clean_after_refinement() {
    let level2 = |sk: &Skeleton, opts: &QuadOptions| {
        let q = quad_mesh(sk, opts).unwrap();
        let o = SubdivideOptions {
            refine: RefineOptions { scheme: Scheme::CatmullClark, levels: 2, ..Default::default() },
            ..Default::default()
        };
        let fine = subdivide(&q.mesh, &[], &o).unwrap();
        (check_mesh(&fine, &CheckOptions::default()).intersection_count.unwrap(), q.cases.elbows)
    };
    // The repair would separate what the elbows leave crossing: off, to test the elbows.
    let on = QuadOptions { repair_rounds: 0, ..Default::default() };
    let off = QuadOptions { elbow_angle: 90.0, ..on.clone() };
    let (mut without, mut elbows, mut asserted) = (0, 0, 0);
    for upx in [0.0f32, 0.4, 1.0] {
        let up = Vec3::new(upx, 0.0, 1.0).normalize();
        for side in [30.0f32, 45.0, 60.0, 75.0] {
            for az in [0.0f32, 45.0, 90.0, 180.0] {
                let mut s = Skeleton::new();
                let r = s.push(Vec3::ZERO, 0.2, NO_PARENT, up, 0);
                let a = s.push(Vec3::Y * 3.0, 0.2, r, up, 0);
                let t = 25f32.to_radians();
                s.push(Vec3::Y * 3.0 + Vec3::new(t.sin(), t.cos(), 0.0) * 2.0, 0.16, a, up, 1);
                let (sa, az) = (side.to_radians(), (180.0 + az).to_radians());
                let dir = Vec3::new(sa.sin() * az.cos(), sa.cos(), sa.sin() * az.sin());
                s.push(Vec3::Y * 3.0 + dir * 2.0, 0.14, a, up, 1);
                let (with, e) = level2(&s, &on);
                // A side child within a few degrees of the first child overlaps it in the
                // skeleton itself (a sibling collision): no mesher keeps those apart.
                if skeleton_collisions(&s, 0.01).is_empty() {
                    assert_eq!(
                        with, 0,
                        "side child at {side}°, azimuth {az}, up {up}: level-2 intersections"
                    );
                    asserted += 1;
                }
                elbows += e;
                without += level2(&s, &off).0;
            }
        }
    }
    assert!(elbows > 0, "no elbow was built");
    assert!(asserted >= 40, "only {asserted} of 48 forks are collision-free");
    assert!(without > 0, "the forks do not exercise the elbows");
}

/// The repair (module docs, "Repair"): narrow forks whose tubes cross only after
/// Catmull–Clark are clean at level 2 with the default options, because the crossing
/// side child is separated (and reported); without the repair some of them cross.
#[test]
fn repair_separates_narrow_forks_that_cross_after_refinement() {
    let level2 = |sk: &Skeleton, opts: &QuadOptions| {
        let q = quad_mesh(sk, opts).unwrap();
        assert_eq!(q.face_node.len(), q.mesh.face_count());
        assert!(q.face_node.iter().all(|&n| (n as usize) < sk.len()));
        let o = SubdivideOptions {
            refine: RefineOptions { scheme: Scheme::CatmullClark, levels: 2, ..Default::default() },
            ..Default::default()
        };
        let fine = subdivide(&q.mesh, &[], &o).unwrap();
        (check_mesh(&fine, &CheckOptions::default()).intersection_count.unwrap(), q)
    };
    let off = QuadOptions { repair_rounds: 0, ..Default::default() };
    let mut crossed = 0;
    // Short, thick internodes (8–12 radii, as in the `mgv-*` trees), both children on
    // one side of the parent, 15–25° apart.
    for t0 in [45.0f32, 70.0] {
        for t1 in [t0 - 15.0, t0 - 25.0] {
            for az in [0.0f32, 20.0] {
                for ratio in [0.8f32, 1.0] {
                    let mut s = Skeleton::new();
                    let r = s.push(Vec3::ZERO, 0.03, NO_PARENT, Vec3::Z, 0);
                    let a = s.push(Vec3::Y * 0.25, 0.03, r, Vec3::Z, 0);
                    let dir = |t: f32, az: f32| {
                        let (t, z) = (t.to_radians(), az.to_radians());
                        Vec3::new(t.sin() * z.cos(), t.cos(), t.sin() * z.sin())
                    };
                    let k0 = s.push(Vec3::Y * 0.25 + dir(t0, 0.0) * 0.37, 0.024, a, Vec3::Z, 0);
                    let k1 = s.push(Vec3::Y * 0.25 + dir(t1, az) * 0.3, 0.024 * ratio, a, Vec3::Z, 1);
                    let name = format!("fork at {t0}° and {t1}° (azimuth {az}°), ratio {ratio}");
                    let (with, q) = level2(&s, &QuadOptions::default());
                    assert_eq!(with, 0, "{name}: level-2 intersections after the repair");
                    check(&name, &q.mesh);
                    let (without, q0) = level2(&s, &off);
                    assert_eq!(q0.repair_rounds, 0);
                    assert!(q0.fallbacks.iter().all(|f| f.reason != FallbackReason::Separated));
                    if without > 0 {
                        crossed += 1;
                        assert!(q.repair_rounds > 0, "{name}: crossed, yet no repair round");
                        assert!(
                            q.fallbacks
                                .iter()
                                .any(|f| (f.node == k1 || f.node == k0)
                                    && f.reason == FallbackReason::Separated),
                            "{name}: crossed, yet no child separated: {:?}",
                            q.fallbacks
                        );
                        assert_eq!(q.components, 2, "{name}: the separated child is its own piece");
                    } else {
                        assert_eq!(q.mesh, q0.mesh, "{name}: clean without the repair, yet changed");
                    }
                }
            }
        }
    }
    assert!(crossed > 0, "no fork crossed without the repair: the test does not exercise it");
}

/// A chain that turns back on itself must not be carried past the turn. The merge rule
/// skips a node whose section would lie too close to its start ring, and before session
/// 9 it also skipped a node whose child lies *behind* that ring: the ring was carried
/// through the hairpin, every later node lay behind it too, and the whole chain became
/// one tube from the root to the tip (`mgv-r`: 38 nodes, a straight tube 4.8 m through
/// the crown). Here a short first internode is merged, the chain bends 67° and then 92°
/// back, and runs on for 3 m: every node owns faces, every face made for a node lies
/// near that node's internode, and the level-2 surface does not cross itself.
#[test]
fn a_hairpin_is_not_carried_past() {
    let mut s = Skeleton::new();
    let up = Vec3::Z;
    let mut at = s.push(Vec3::ZERO, 0.05, NO_PARENT, up, 0);
    let turn = |deg: f32| Vec3::new(deg.to_radians().sin(), deg.to_radians().cos(), 0.0);
    let mut p = Vec3::ZERO;
    for (dir, len) in [
        (turn(0.0), 0.03),
        (turn(67.0), 0.12),
        (turn(159.0), 0.47),
        (turn(165.0), 1.0),
        (turn(170.0), 1.0),
        (turn(170.0), 1.0),
    ] {
        p += dir * len;
        at = s.push(p, 0.05, at, up, 0);
    }
    let q = full_check("hairpin", &s, &QuadOptions::default());
    for n in 3..s.len() {
        assert!(q.face_node.iter().any(|&o| o as usize == n), "node {n} owns no face: skipped");
    }
    for (f, &o) in q.face_node.iter().enumerate() {
        let o = o as usize;
        let a = s.position[s.parent[o].min(o as u32) as usize];
        let b = s.position[o];
        let far = q.mesh.face(f).iter().map(|&v| {
            let x = q.mesh.positions[v as usize];
            let t = ((x - a).dot(b - a) / (b - a).length_squared().max(1e-12)).clamp(0.0, 1.0);
            x.distance(a + (b - a) * t)
        });
        let far = far.fold(0.0f32, f32::max);
        assert!(far < 0.5, "face {f} of node {o} reaches {far} m from its internode");
    }
    let fine = catmull_clark(&q.mesh, 2);
    assert_eq!(check_mesh(&fine, &CheckOptions::default()).intersection_count, Some(0));
}
