//! The hull mesher (Pieterse2012, Pieterse2012-spec §2.3–2.7 and §7): trimming, simplification,
//! branch segments, convex-hull joints, UVs, robustness on hard cases and on every
//! embedded preset, and the mesh staying a 2-manifold through Loop subdivision.

#[path = "common/cage_topo.rs"]
mod cage_topo;
#[path = "common/checks.rs"]
mod checks;
#[path = "common/det_tree.rs"]
mod det_tree;
#[path = "common/preset_skeletons.rs"]
mod preset_skeletons;
#[path = "common/random_tree.rs"]
mod random_tree;
#[path = "common/skeletons.rs"]
mod skeletons;
use cage_topo::{refined, Topo};
use det_tree::tree;
use preset_skeletons::{named_preset_skeleton, par_map_presets};
use skeletons::{chain, seg, whorl};

use glam::{DVec3, Vec3};
use std::collections::{HashMap, HashSet};
use sylva::mesh::check::{check_mesh, CheckOptions};
use sylva::mesh::hull::{hull_mesh, pair_offsets, simplify, HullMesh, HullOptions, JointKind};
use sylva::refine::Scheme;
use sylva::{Mesh, Skeleton, NO_PARENT};

// ---------------------------------------------------------------------------------------
// Mesh checks

/// A valid, consistently oriented 2-manifold of triangles, genus 0 in every component
/// (boundary loops allowed); returns its counts.
fn check(name: &str, m: &Mesh) -> Topo {
    cage_topo::check(name, m, 3, false)
}

fn face_area(m: &Mesh, f: usize) -> f64 {
    let [a, b, c] = [0, 1, 2].map(|k| m.positions[m.face(f)[k] as usize].as_dvec3());
    (b - a).cross(c - a).length() * 0.5
}

fn loop2(m: &Mesh) -> Mesh {
    refined(m, Scheme::Loop, 2)
}

/// Meshes with and without caps and checks everything that holds for any input.
fn full_check(name: &str, sk: &Skeleton, sides: u32, refine: bool) -> HullMesh {
    let open =
        hull_mesh(sk, &HullOptions { sides, ..Default::default() }).unwrap_or_else(|e| panic!("{name}: {e}"));
    let t = check(name, &open.mesh);
    assert_eq!(t.boundary_loops, open.open_loops, "{name}: open loops");
    let capped = hull_mesh(sk, &HullOptions { sides, caps: true, ..Default::default() }).unwrap();
    let tc = check(&format!("{name} capped"), &capped.mesh);
    assert_eq!(tc.boundary_loops, 0, "{name}: capped mesh has holes");
    assert_eq!(capped.open_loops, 0);
    assert_eq!(tc.euler, 2 * tc.components as i64);
    if capped.mesh.face_count() > 0 {
        assert!(capped.mesh.signed_volume() > 0.0, "{name}: inward-facing (volume ≤ 0)");
    }
    // Components: one per tree, plus one per loop of each fallback joint, minus one per
    // fallback joint (its pieces were one before).
    let uv = open.mesh.uvs.as_ref().unwrap();
    assert!(uv.values.iter().all(|v| v.is_finite()), "{name}: UV not finite");
    assert_eq!(uv.indices.len(), open.mesh.face_indices.len());
    if refine && open.mesh.face_count() > 0 {
        let fine = loop2(&open.mesh);
        let tf = check(&format!("{name} Loop 2"), &fine);
        assert_eq!(tf.faces, 16 * t.faces);
        assert_eq!(tf.boundary_loops, t.boundary_loops);
        assert_eq!(tf.euler, t.euler);
        let finec = loop2(&capped.mesh);
        check(&format!("{name} capped Loop 2"), &finec);
    }
    open
}

// ---------------------------------------------------------------------------------------
// Skeleton builders

fn y_fork() -> Skeleton {
    skeletons::y_fork(0.12, 0.15)
}

// ---------------------------------------------------------------------------------------
// Pieterse2012-spec §7 properties

/// Property 4: trimming offsets (special cases, symmetry, continuity, tightness).
#[test]
fn trimming_offsets_follow_the_geometry() {
    let eps = 1e-6;
    let (a, b) = (DVec3::Y, DVec3::X);
    let (oa, ob) = pair_offsets(a, 0.4, b, 0.25, eps).unwrap();
    assert!((oa - 0.25).abs() < 1e-12 && (ob - 0.4).abs() < 1e-12, "90°: offA = rB, offB = rA");
    assert_eq!(pair_offsets(a, 0.4, -a, 0.25, eps), Some((0.0, 0.0)), "180°: 0");
    assert_eq!(pair_offsets(a, 0.4, a, 0.25, eps), None, "aligned");
    assert_eq!(pair_offsets(a, 0.4, DVec3::new(1e-4, 1.0, 0.0).normalize(), 0.25, eps), None);
    // Continuity across 90°.
    let dir = |deg: f64| DVec3::new(deg.to_radians().sin(), deg.to_radians().cos(), 0.0);
    let below = pair_offsets(a, 0.4, dir(90.0 - 1e-7), 0.25, eps).unwrap();
    let above = pair_offsets(a, 0.4, dir(90.0 + 1e-7), 0.25, eps).unwrap();
    assert!((below.0 - above.0).abs() < 1e-6 && (below.1 - above.1).abs() < 1e-6);
    // Continuity towards 180°.
    let near = pair_offsets(a, 0.4, dir(180.0 - 1e-6), 0.25, eps).unwrap();
    assert!(near.0 < 1e-6 && near.1 < 1e-6);

    // Tightness by sampling solid half-infinite cylinders.
    let inside = |p: DVec3, axis: DVec3, r: f64| {
        let t = p.dot(axis);
        t >= 0.0 && (p - axis * t).length() <= r
    };
    for &deg in &[20.0, 45.0, 70.0, 90.0, 110.0, 135.0, 160.0] {
        for &(ra, rb) in &[(0.5, 0.5), (0.5, 0.2), (0.2, 0.5), (1.0, 0.1)] {
            let b = dir(deg);
            let (oa, ob) = pair_offsets(a, ra, b, rb, eps).unwrap();
            if (ra - rb) == 0.0 {
                assert!((oa - ob).abs() < 1e-12, "equal radii must give equal offsets");
            }
            for (axis, r, off, other, ro) in [(a, ra, oa, b, rb), (b, rb, ob, a, ra)] {
                let (u, w) = axis.any_orthonormal_pair();
                let disc = |t: f64| {
                    let mut v = Vec::new();
                    for i in 0..=40 {
                        for j in 0..=40 {
                            let x = (i as f64 / 20.0 - 1.0) * r;
                            let y = (j as f64 / 20.0 - 1.0) * r;
                            if x * x + y * y <= r * r {
                                v.push(axis * t + u * x + w * y);
                            }
                        }
                    }
                    v
                };
                for t in [off * 1.0001 + 1e-9, off * 1.05 + 1e-3, off * 2.0 + 0.1] {
                    assert!(
                        disc(t).iter().all(|&p| !inside(p, other, ro)),
                        "{deg}° r {ra}/{rb}: a point beyond the offset {off} at {t} is inside the other tube"
                    );
                }
                if off > 1e-3 {
                    // The extreme point lies in the plane of the two axes: scan that
                    // chord of the cross-section finely.
                    let v = (other - axis * other.dot(axis)).normalize();
                    let chord =
                        |t: f64| (0..=4000).map(move |i| axis * t + v * ((i as f64 / 2000.0 - 1.0) * r));
                    assert!(
                        chord(off * 0.99).any(|p| inside(p, other, ro)),
                        "{deg}° r {ra}/{rb}: offset {off} is not tight"
                    );
                }
            }
        }
    }
}

/// Property 5: simplification never moves end points, leaves no crossing branch,
/// is stable, and drops exactly the collapsed branches.
#[test]
fn simplification_never_moves_end_points_and_is_stable() {
    // Short internodes with laterals: joints too close together.
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.3);
    let mut at = seg(&mut s, r, Vec3::Y * 3.0, 0.3);
    for k in 0..6 {
        let y = 3.0 + 0.15 * (k + 1) as f32;
        let side = seg(
            &mut s,
            at,
            Vec3::new(0.0, y + 2.0, 0.0) + Vec3::new((k as f32).cos(), 0.0, (k as f32).sin()) * 2.0,
            0.1,
        );
        let _ = side;
        at = seg(&mut s, at, Vec3::Y * y, 0.28);
    }
    seg(&mut s, at, Vec3::Y * 6.0, 0.25);
    let opts = HullOptions::default();
    let g = simplify(&s, &opts).unwrap();
    assert!(!g.collapsed.is_empty(), "the fixture must collapse something");
    let internodes = s.parent.iter().filter(|&&p| p != NO_PARENT).count();
    assert_eq!(g.branches.len() + g.collapsed.len() + g.dropped.len(), internodes);
    let by_node: HashMap<u32, &_> = g.branches.iter().map(|b| (b.node, b)).collect();
    for b in &g.branches {
        assert_eq!(b.end, s.position[b.node as usize].as_dvec3(), "end point moved");
        assert_eq!(b.start, s.position[b.start_node as usize].as_dvec3());
        if b.parent != NO_PARENT {
            assert_eq!(b.start, by_node[&b.parent].end, "child does not start at its parent's end");
        } else {
            assert_eq!(b.start_node, 0, "root base moved");
        }
        let len = b.start.distance(b.end);
        assert!(b.start_offset + b.end_offset < len || g.clamped.contains(&b.node));
    }
    // Rerun on the simplified skeleton: nothing collapses.
    let mut t = Skeleton::new();
    let mut map = HashMap::new();
    map.insert(0u32, t.push(s.position[0], s.radius[0], NO_PARENT, s.up[0], 0));
    for b in &g.branches {
        let p = map[&b.start_node];
        let i = t.push(s.position[b.node as usize], s.radius[b.node as usize], p, s.up[b.node as usize], 0);
        map.insert(b.node, i);
    }
    // Keep the start radii as they were (min rule): radius of the start node already is.
    let g2 = simplify(&t, &opts).unwrap();
    assert!(g2.collapsed.is_empty(), "simplification is not stable: {:?}", g2.collapsed);
    assert_eq!(g2.branches.len(), g.branches.len());
    // The mesh is valid too.
    let m = full_check("short internodes", &s, 4, true);
    assert_eq!(m.collapsed, g.collapsed);
}

/// Property 6: N = max(1, round(L / (π r̄))).
#[test]
fn segment_count_formula() {
    for (len, r, n) in
        [(10.0f32, 1.0f32, 3u32), (1.0, 1.0, 1), (0.01, 1.0, 1), (100.0, 1.0, 32), (7.0, 0.5, 4)]
    {
        let s = chain(&[Vec3::ZERO, Vec3::Y * len], r);
        let m = hull_mesh(&s, &HullOptions::default()).unwrap();
        assert_eq!(m.branches.len(), 1);
        assert_eq!(m.branches[0].segments, n, "L {len} r {r}");
        assert_eq!(m.mesh.positions.len(), (n as usize + 1) * 4);
        assert_eq!(m.mesh.face_count(), 2 * n as usize * 4);
    }
    // The cap on segments.
    let s = chain(&[Vec3::ZERO, Vec3::Y * 1000.0], 0.001);
    let m = hull_mesh(&s, &HullOptions { max_segments: 50, ..Default::default() }).unwrap();
    assert_eq!(m.branches[0].segments, 50);
}

/// Property 7: (N+1)·s vertices and 2Ns faces per branch; loops planar, orthogonal to
/// the axis, equidistant; interior-loop vertices have valence 6.
#[test]
fn branches_have_regular_loops() {
    for sides in [3u32, 4, 6, 9] {
        let s = tree(3, 3);
        let m = hull_mesh(&s, &HullOptions { sides, ..Default::default() }).unwrap();
        let mesh = &m.mesh;
        let mut valence = vec![HashSet::new(); mesh.positions.len()];
        for f in 0..mesh.face_count() {
            let t = mesh.face(f);
            for k in 0..3 {
                valence[t[k] as usize].insert(t[(k + 1) % 3]);
                valence[t[(k + 1) % 3] as usize].insert(t[k]);
            }
        }
        let su = sides as usize;
        let mut total_v = 0;
        for b in &m.branches {
            assert_eq!(b.faces.len(), 2 * b.segments as usize * su);
            total_v += (b.segments as usize + 1) * su;
            let start = s.position[b.start_node as usize].as_dvec3();
            let end = s.position[b.node as usize].as_dvec3();
            let d = (end - start).normalize();
            for i in 0..=b.segments as usize {
                let vs: Vec<DVec3> = (0..su)
                    .map(|j| mesh.positions[b.first_vertex as usize + i * su + j].as_dvec3())
                    .collect();
                let c = vs.iter().copied().sum::<DVec3>() / su as f64;
                let r0 = (vs[0] - c).length();
                for v in &vs {
                    assert!((v - c).dot(d).abs() < 1e-4, "loop not orthogonal to the axis");
                    assert!(((v - c).length() - r0).abs() < 1e-4, "loop not equidistant");
                }
                // Centre on the axis.
                let t = (c - start).dot(d);
                assert!(((c - start) - d * t).length() < 1e-4);
                if i > 0 && i < b.segments as usize {
                    for j in 0..su {
                        assert_eq!(
                            valence[b.first_vertex as usize + i * su + j].len(),
                            6,
                            "interior valence"
                        );
                    }
                }
            }
        }
        let caps = 0;
        assert_eq!(mesh.positions.len(), total_v + caps, "joints add no vertices");
    }
}

/// Properties 8–12: all triangles, no degenerate faces, boundary = base + tips, every
/// joint watertight with k(s+2) − 4 faces, totals and Euler characteristic 1 − L.
#[test]
fn joints_are_watertight_and_totals_match() {
    for sides in [3u32, 4, 5, 8] {
        for (name, s) in [("y fork", y_fork()), ("whorl 5", whorl(5, 0.9, 0.08, 0.0)), ("tree", tree(3, 2))] {
            let m = hull_mesh(&s, &HullOptions { sides, ..Default::default() }).unwrap();
            assert!(m.fallbacks.is_empty(), "{name}: fallbacks {:?}", m.fallbacks);
            let t = check(name, &m.mesh);
            let leaves = m.open_loops - 1;
            assert_eq!(t.boundary_loops, 1 + leaves);
            assert_eq!(t.components, 1);
            assert_eq!(t.euler, 1 - leaves as i64, "{name}: χ = 1 − L");
            let su = sides as usize;
            let mut f_expect = 0;
            let mut v_expect = 0;
            for b in &m.branches {
                f_expect += 2 * su * b.segments as usize;
                v_expect += su * (b.segments as usize + 1);
            }
            for j in &m.joints {
                let k = j.loops as usize;
                assert_eq!(j.faces.len(), k * (su + 2) - 4, "{name}: joint {} faces", j.node);
                if k > 2 {
                    assert_eq!(j.kind, JointKind::Hull);
                }
                f_expect += k * (su + 2) - 4;
            }
            assert_eq!(t.faces, f_expect);
            assert_eq!(t.vertices, v_expect);
            assert_eq!(2 * t.edges, 3 * t.faces + su * (1 + leaves), "E = (3F + s(1+L))/2");
            for f in 0..m.mesh.face_count() {
                assert!(face_area(&m.mesh, f) > 1e-9, "{name}: degenerate face {f}");
            }
            // Every joint face touches loop edges only through branch faces: each loop
            // edge has one branch face and one joint face (follows from the manifold check
            // plus the per-branch face ranges).
            for j in &m.joints {
                let jf: HashSet<usize> = (j.faces.start as usize..j.faces.end as usize).collect();
                let mut used = HashSet::new();
                for &f in &jf {
                    used.extend(m.mesh.face(f).iter().copied());
                }
                assert_eq!(used.len(), j.loops as usize * su, "{name}: joint uses exactly its loop vertices");
            }
        }
    }
}

/// Property 19: every corner has a finite UV; branch corners have u = j/s (the wrap
/// corner u = 1) and v = v₀ + i/2; chains through bands continue v.
#[test]
fn uvs_cover_every_corner_and_follow_the_branches() {
    let s = tree(3, 4);
    let m = hull_mesh(&s, &HullOptions::default()).unwrap();
    let uv = m.mesh.uvs.as_ref().unwrap();
    assert!(uv.values.iter().all(|v| v.is_finite()));
    let su = 4usize;
    let mut saw_wrap = false;
    for b in &m.branches {
        for f in b.faces.clone() {
            let f = f as usize;
            for (k, c) in m.mesh.corners(f).enumerate() {
                let v = m.mesh.face_indices[c] as usize - b.first_vertex as usize;
                let (i, j) = (v / su, v % su);
                let q = uv.values[uv.indices[c] as usize];
                let u_ok = (q.x - j as f32 / su as f32).abs() < 1e-6 || (j == 0 && q.x == 1.0);
                saw_wrap |= j == 0 && q.x == 1.0;
                assert!(u_ok, "branch {} corner {k}: u {} for column {j}", b.node, q.x);
                assert!((q.y as f64 - (b.v0 + i as f64 * 0.5)).abs() < 1e-4, "v {} for loop {i}", q.y);
            }
        }
    }
    assert!(saw_wrap);
    // Joint UV triangles: every face corner set, counter-clockwise or degenerate.
    for j in &m.joints {
        for f in j.faces.clone() {
            let c: Vec<_> = m.mesh.corners(f as usize).map(|c| uv.values[uv.indices[c] as usize]).collect();
            let area = (c[1] - c[0]).perp_dot(c[2] - c[0]);
            assert!(area > -1e-6, "joint {} face {f}: UV triangle is flipped ({area})", j.node);
        }
    }
    // A straight chain is one seamless chart: v is continuous through the band joints.
    let s = chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.1, 2.0, 0.0), Vec3::new(0.3, 3.0, 0.0)], 0.1);
    let m = hull_mesh(&s, &HullOptions::default()).unwrap();
    assert_eq!(m.joints.len(), 2);
    assert!(m.joints.iter().all(|j| j.kind == JointKind::Band));
    assert!(m.branches[1].v0 > m.branches[0].v0 + m.branches[0].segments as f64 * 0.5);
    let uv = m.mesh.uvs.as_ref().unwrap();
    // No seam except the u wrap: every vertex has at most 2 distinct UVs.
    let mut per_vertex: HashMap<u32, HashSet<(u32, u32)>> = HashMap::new();
    for (c, &v) in m.mesh.face_indices.iter().enumerate() {
        let q = uv.values[uv.indices[c] as usize];
        per_vertex.entry(v).or_default().insert((q.x.to_bits(), q.y.to_bits()));
    }
    assert!(per_vertex.values().all(|s| s.len() <= 2));
}

/// Property 22: the same input gives byte-identical output.
#[test]
fn output_is_deterministic() {
    let s = tree(3, 3);
    let a = hull_mesh(&s, &HullOptions::default()).unwrap();
    let b = hull_mesh(&s, &HullOptions::default()).unwrap();
    assert_eq!(a, b);
    let bits = |m: &Mesh| m.positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&a.mesh), bits(&b.mesh));
    let dir = std::env::temp_dir().join(format!("sylva-hull-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for (k, m) in [a, b].into_iter().enumerate() {
        let model = sylva::Model {
            parts: vec![sylva::Part {
                name: "bark".into(),
                mesh: m.mesh,
                material: sylva::Material::bark(),
                ..Default::default()
            }],
            ..Default::default()
        };
        let sub = dir.join(format!("run{k}"));
        std::fs::create_dir_all(&sub).unwrap();
        let path = sub.join("tree.obj");
        sylva::export::write(&model, &path).unwrap();
        files.push(std::fs::read(&path).unwrap());
    }
    assert!(files[0] == files[1], "OBJ bytes differ between two runs");
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------
// Robustness (issue 5 item 4)

/// A root whose stems all leave within a narrow cone (`mig-k`'s root: four stems 3°–8°
/// from vertical, 3 m long) gets a virtual base loop: the joint is a dome over a flat
/// base at the root node, the mesh stays closed there, and its level-2 Loop surface does
/// not cross itself (without the base the hull of the four loops was a thin lens whose
/// faces crossed: 76 pairs at level 2 on `mig-k`).
#[test]
fn a_root_of_near_parallel_stems_gets_a_flat_base() {
    let mut s = Skeleton::new();
    let root = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.145);
    for (k, (tilt, r)) in [(7.0f32, 0.117), (8.0, 0.065), (3.0, 0.105), (8.0, 0.044)].iter().enumerate() {
        let (t, a) = (tilt.to_radians(), k as f32 * std::f32::consts::FRAC_PI_2 + 0.3);
        let d = Vec3::new(t.sin() * a.cos(), t.cos(), t.sin() * a.sin());
        let tip = seg(&mut s, root, d * 3.0, *r);
        seg(&mut s, tip, d * 3.0 + Vec3::new(0.2, 1.0, 0.0), *r * 0.8);
    }
    let h = full_check("near-parallel stems", &s, 4, true);
    assert!(h.fallbacks.is_empty(), "{:?}", h.fallbacks);
    let j = h.joints.iter().find(|j| j.node == root).expect("a joint at the root");
    assert_eq!((j.kind, j.loops), (JointKind::Hull, 5), "four stems and the base");
    // Closed at the root: the open loops are the four tips.
    assert_eq!(h.open_loops, 4);
    // The base is flat, through the root node, normal to the stems' mean direction:
    // nothing lies below it.
    let m = (1..5).map(|k| s.position[2 * k - 1].normalize()).sum::<Vec3>().normalize();
    let lowest = h.mesh.positions.iter().map(|p| p.dot(m)).fold(f32::MAX, f32::min);
    assert!(lowest.abs() < 1e-6, "the base lies at the root node: lowest {lowest}");
    for caps in [false, true] {
        let m = hull_mesh(&s, &HullOptions { caps, ..Default::default() }).unwrap().mesh;
        let r = check_mesh(&loop2(&m), &CheckOptions::default());
        assert_eq!(r.intersection_count, Some(0), "caps {caps}: the level-2 surface crosses itself");
    }
    // Stems spread wider than the cone (a flat whorl from a root) keep the plain hull.
    let mut w = Skeleton::new();
    let root = seg(&mut w, NO_PARENT, Vec3::ZERO, 0.1);
    for k in 0..3 {
        let a = k as f32 * std::f32::consts::TAU / 3.0;
        seg(&mut w, root, Vec3::new(a.cos(), 0.1, a.sin()) * 2.0, 0.05);
    }
    let h = full_check("flat root whorl", &w, 4, true);
    assert_eq!(h.joints[0].loops, 3);
}

#[test]
fn hard_cases_give_a_manifold_or_a_reported_fallback() {
    let mut cases: Vec<(&str, Skeleton)> = Vec::new();
    cases.push(("whorl of 8", whorl(8, 1.0, 0.08, 0.0)));
    cases.push(("whorl of 12, flat", whorl(12, std::f32::consts::FRAC_PI_2, 0.05, 0.0)));
    cases.push(("whorl of 6, thick children", whorl(6, 0.8, 0.3, 0.0)));
    // Aligned child: continues the parent straight on, next to a lateral.
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    let a = seg(&mut s, r, Vec3::Y * 2.0, 0.2);
    seg(&mut s, a, Vec3::Y * 4.0, 0.18);
    seg(&mut s, a, Vec3::new(1.5, 3.5, 0.0), 0.1);
    cases.push(("aligned child", s));
    // A child thicker than its parent.
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.1);
    let a = seg(&mut s, r, Vec3::Y * 2.0, 0.1);
    seg(&mut s, a, Vec3::new(0.5, 4.0, 0.0), 0.4);
    seg(&mut s, a, Vec3::new(-1.5, 3.0, 0.0), 0.05);
    cases.push(("thick child", s));
    // Zero-length internodes (inside a chain, at a fork and as a tip).
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.1);
    let a = seg(&mut s, r, Vec3::Y, 0.1);
    let z = seg(&mut s, a, Vec3::Y, 0.1);
    seg(&mut s, z, Vec3::new(0.0, 2.0, 0.0), 0.1);
    seg(&mut s, z, Vec3::new(1.0, 2.0, 0.0), 0.05);
    seg(&mut s, z, Vec3::Y, 0.05);
    cases.push(("zero-length internode", s));
    cases.push(("3-node chain", chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(0.5, 2.0, 0.0)], 0.1)));
    cases.push(("single segment", chain(&[Vec3::ZERO, Vec3::Y], 0.1)));
    cases.push(("hairpin", chain(&[Vec3::ZERO, Vec3::Y * 2.0, Vec3::Y], 0.1)));
    cases.push((
        "right-angle bends",
        chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 1.0)], 0.1),
    ));
    // Two children in exactly the same direction (aligned: no solution).
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.1);
    let a = seg(&mut s, r, Vec3::Y, 0.1);
    seg(&mut s, a, Vec3::new(1.0, 2.0, 0.0), 0.05);
    seg(&mut s, a, Vec3::new(2.0, 3.0, 0.0), 0.05);
    seg(&mut s, a, Vec3::new(-1.0, 2.0, 0.0), 0.05);
    cases.push(("duplicate directions", s));
    // Non-planar junction with very short internodes and mixed radii.
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.3);
    let a = seg(&mut s, r, Vec3::Y * 0.2, 0.3);
    let b = seg(&mut s, a, Vec3::new(0.05, 0.35, 0.0), 0.25);
    seg(&mut s, b, Vec3::new(1.0, 1.0, 1.0), 0.1);
    seg(&mut s, b, Vec3::new(-1.0, 0.8, 0.5), 0.2);
    seg(&mut s, a, Vec3::new(0.2, 0.5, -1.0), 0.15);
    seg(&mut s, b, Vec3::new(0.0, 2.0, 0.1), 0.2);
    cases.push(("non-planar short", s));
    // Zero radii everywhere and a skeleton that is one point.
    cases.push(("zero radius", chain(&[Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 2.0, 0.0)], 0.0)));
    let mut s = whorl(4, 0.7, 0.1, 0.0);
    s.radius.iter_mut().for_each(|r| *r = 0.0);
    cases.push(("zero-radius whorl", s));
    cases.push(("one point", chain(&[Vec3::ONE, Vec3::ONE, Vec3::ONE], 0.1)));
    cases.push(("empty", Skeleton::new()));
    // Several children from the root node (stems without a trunk).
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    for d in [Vec3::new(1.0, 2.0, 0.0), Vec3::new(-1.0, 2.0, 0.3), Vec3::new(0.0, 2.0, -1.0)] {
        seg(&mut s, r, d, 0.1);
    }
    cases.push(("root whorl", s));
    // Children going backwards and sideways (obtuse and reflex).
    let mut s = Skeleton::new();
    let r = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
    let a = seg(&mut s, r, Vec3::Y * 2.0, 0.2);
    seg(&mut s, a, Vec3::new(1.0, 0.5, 0.0), 0.1);
    seg(&mut s, a, Vec3::new(-1.0, 0.3, 0.2), 0.1);
    seg(&mut s, a, Vec3::new(0.0, 3.0, 0.0), 0.15);
    cases.push(("drooping children", s));
    cases.push(("big tree", tree(4, 3)));
    for (name, s) in &cases {
        for sides in [3u32, 4, 7] {
            let m = full_check(&format!("{name} s={sides}"), s, sides, true);
            for j in &m.joints {
                assert_eq!(
                    j.kind == JointKind::Fallback || !j.detached.is_empty(),
                    m.fallbacks.contains(&j.node)
                );
            }
            if sides == 4 {
                println!(
                    "{name:>24}: {} branches, {} joints, fallbacks {:?}, collapsed {}, clamped {:?}, dropped {:?}",
                    m.branches.len(),
                    m.joints.len(),
                    m.fallbacks,
                    m.collapsed.len(),
                    m.clamped,
                    m.dropped
                );
            }
        }
    }
    // The cases that must not fall back.
    for name in [
        "whorl of 8",
        "whorl of 6, thick children",
        "aligned child",
        "thick child",
        "3-node chain",
        "root whorl",
    ] {
        let s = &cases.iter().find(|c| c.0 == name).unwrap().1;
        let m = hull_mesh(s, &HullOptions::default()).unwrap();
        assert!(m.fallbacks.is_empty(), "{name}: fallbacks {:?}", m.fallbacks);
    }
    // The ones that must: true alignment.
    for name in ["hairpin", "duplicate directions"] {
        let s = &cases.iter().find(|c| c.0 == name).unwrap().1;
        let m = hull_mesh(s, &HullOptions::default()).unwrap();
        assert_eq!(m.fallbacks, vec![1], "{name}");
    }
}

#[test]
fn bad_options_and_skeletons_are_errors() {
    let s = y_fork();
    for sides in [0, 2, 1025] {
        assert!(hull_mesh(&s, &HullOptions { sides, ..Default::default() }).is_err());
    }
    assert!(hull_mesh(&s, &HullOptions { margin: f64::NAN, ..Default::default() }).is_err());
    assert!(hull_mesh(&s, &HullOptions { segment_factor: 0.0, ..Default::default() }).is_err());
    let mut bad = y_fork();
    bad.radius[2] = f32::NAN;
    assert!(matches!(hull_mesh(&bad, &HullOptions::default()), Err(sylva::Error::Skeleton(_))));
}

// ---------------------------------------------------------------------------------------
// Every preset

#[test]
fn every_preset_meshes_into_a_valid_manifold() {
    println!("| preset | nodes | vertices | faces | boundary loops | fallbacks | collapsed | ms |");
    println!("|---|---|---|---|---|---|---|---|");
    // The presets mesh in parallel; rows are printed in order.
    let rows: Vec<String> = par_map_presets(
        |_| true,
        |name, sk| {
            let t0 = std::time::Instant::now();
            let full = hull_mesh(sk, &HullOptions::default()).unwrap_or_else(|e| panic!("{}: {e}", name));
            let ms = t0.elapsed().as_secs_f64() * 1e3;
            let (v_full, f_full) = (full.mesh.positions.len(), full.mesh.face_count());
            // Very large trees are checked with coarse branches (2 segments at most): the
            // joints, which are what can go wrong, are the same.
            let big = f_full > 1_000_000;
            let coarse = HullOptions { max_segments: 2, ..Default::default() };
            let m = if big { hull_mesh(sk, &coarse).unwrap() } else { full };
            let t = check(name, &m.mesh);
            assert_eq!(t.boundary_loops, m.open_loops, "{}", name);
            if m.mesh.face_count() < 400_000 {
                let capped = hull_mesh(
                    sk,
                    &HullOptions { caps: true, ..if big { coarse } else { Default::default() } },
                )
                .unwrap();
                let tc = check(name, &capped.mesh);
                assert_eq!(tc.boundary_loops, 0);
                if capped.mesh.face_count() > 0 {
                    assert!(capped.mesh.signed_volume() > 0.0, "{}: volume", name);
                }
            }
            if m.mesh.face_count() < 60_000 && m.mesh.face_count() > 0 {
                check(&format!("{} Loop 2", name), &loop2(&m.mesh));
            }
            format!(
                "| {} | {} | {} | {} | {} | {} | {} | {ms:.1} |",
                name,
                sk.len(),
                v_full,
                f_full,
                t.boundary_loops,
                m.fallbacks.len(),
                m.collapsed.len()
            )
        },
    );
    for row in &rows {
        println!("{row}");
    }
    let meshed = rows.len();
    assert!(meshed > 0);
}

/// Throughput: `cargo test --release -p sylva --test hull -- --ignored --nocapture`.
#[test]
#[ignore]
fn throughput() {
    let s = tree(7, 4);
    let t0 = std::time::Instant::now();
    let m = hull_mesh(&s, &HullOptions::default()).unwrap();
    let dt = t0.elapsed().as_secs_f64();
    println!(
        "{} nodes → {} vertices, {} faces, {} joints in {:.1} ms ({:.0} nodes/s)",
        s.len(),
        m.mesh.positions.len(),
        m.mesh.face_count(),
        m.joints.len(),
        dt * 1e3,
        s.len() as f64 / dt
    );
    for k in [2usize, 5, 10, 20, 50, 100, 200] {
        let w = whorl(k, 1.2, 0.2 / (k as f32).sqrt(), 0.0);
        let t0 = std::time::Instant::now();
        let m = hull_mesh(&w, &HullOptions::default()).unwrap();
        println!("whorl {k}: {:.2} ms, fallbacks {}", t0.elapsed().as_secs_f64() * 1e3, m.fallbacks.len());
    }
}

/// Diagnostic: why joints of a preset fall back (`HULL_PRESET=name`).
#[test]
#[ignore]
fn fallback_reasons() {
    let (name, sk) = named_preset_skeleton("HULL_PRESET", "wp-european-larch");
    let m = hull_mesh(&sk, &HullOptions::default()).unwrap();
    let graph = simplify(&sk, &HullOptions::default()).unwrap();
    let aligned: HashSet<u32> = graph.aligned.iter().copied().collect();
    let a = m.fallbacks.iter().filter(|j| aligned.contains(j)).count();
    let mut ks: HashMap<u32, usize> = HashMap::new();
    for j in m.joints.iter().filter(|j| j.kind == JointKind::Fallback && !aligned.contains(&j.node)) {
        *ks.entry(j.loops).or_default() += 1;
    }
    println!("{name}: {} fallbacks, {a} aligned; others by k: {ks:?}", m.fallbacks.len());
}

// ---------------------------------------------------------------------------------------
// Random skeletons (issue 5 acceptance: ≥ 99 % valid, every fallback reported)

/// One random tree (see `common/random_tree.rs`) meshed with caps: `Err` when the mesh is
/// not a valid closed manifold; `Ok((fallbacks, intersects))` otherwise, where
/// `intersects` says the mesh crosses itself although the skeleton does not.
fn random_case(seed: u64) -> Result<(usize, bool), String> {
    use sylva::mesh::check::skeleton_collisions;
    let sk = random_tree::random_tree(seed, 60);
    let h = hull_mesh(&sk, &HullOptions { caps: true, ..Default::default() })
        .map_err(|e| format!("error: {e}"))?;
    let r = checks::closed_oriented_manifold(&h.mesh, true)?;
    let intersects = r.intersection_count.unwrap_or(0) > 0 && skeleton_collisions(&sk, 0.01).is_empty();
    Ok((h.fallbacks.len(), intersects))
}

/// 128 random trees in CI (`HULL_CASES=1000 cargo test -p sylva --test hull
/// random_skeletons -- --nocapture` for more): at least 99 % valid closed manifolds, no
/// panic, no error. Self-intersections that the skeleton does not explain are counted
/// and bounded separately (≤ 2 %): 1000 cases gave 1000 valid meshes, 13 of them with
/// such intersections (docs/meshers.md).
#[test]
fn random_skeletons_give_valid_meshes() {
    let n: u64 = std::env::var("HULL_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(128);
    let mut bad = Vec::new();
    let (mut fallbacks, mut intersecting) = (0, Vec::new());
    for seed in 0..n {
        match random_case(seed) {
            Ok((f, i)) => {
                fallbacks += f;
                if i {
                    intersecting.push(seed);
                }
            }
            Err(e) => bad.push((seed, e)),
        }
    }
    println!("hull: {} intersect without skeleton collisions: {intersecting:?}", intersecting.len());
    assert!(intersecting.len() as f64 <= 0.02 * n as f64, "{} of {n} intersect", intersecting.len());
    println!(
        "hull: {} of {n} random trees valid, {fallbacks} reported fallbacks; failures {:?}",
        n as usize - bad.len(),
        &bad[..bad.len().min(5)]
    );
    assert!(
        bad.len() as f64 <= 0.01 * n as f64,
        "{} of {n} failed: {:?}",
        bad.len(),
        &bad[..bad.len().min(5)]
    );
}

/// Session 10: a collapse may not straighten a bend through another branch. A 0.25
/// stub at a right angle to the trunk, too short for its trims, carries a child that
/// turns straight up again: collapsing it would run that child's tube straight from the
/// trunk, 5 of its radii off the stub's end point and through a twig that the real
/// path clears. By default the stub is kept (clamped) and the child starts at its end;
/// with the seed's rule (`INFINITY`), or without the twig, it is collapsed. The meshes
/// are valid.
#[test]
fn a_collapse_does_not_straighten_a_bend() {
    let bend = |twig: bool| {
        let mut s = Skeleton::new();
        let root = seg(&mut s, NO_PARENT, Vec3::ZERO, 0.2);
        let a = seg(&mut s, root, Vec3::Y * 3.0, 0.2);
        seg(&mut s, a, Vec3::new(-2.0, 4.0, 0.0), 0.1);
        let stub = seg(&mut s, a, Vec3::new(0.25, 3.0, 0.0), 0.05);
        let up = seg(&mut s, stub, Vec3::new(0.25, 5.0, 0.0), 0.05);
        seg(&mut s, stub, Vec3::new(2.25, 3.2, 0.0), 0.05);
        if twig {
            let r2 = seg(&mut s, NO_PARENT, Vec3::new(0.1, 3.5, -1.0), 0.01);
            seg(&mut s, r2, Vec3::new(0.1, 3.5, 1.0), 0.01);
        }
        (s, a, stub, up)
    };
    let (s, a, stub, up) = bend(true);
    let child =
        |g: &sylva::mesh::hull::BranchGraph| g.branches.iter().find(|b| b.node == up).unwrap().start_node;
    let seed = simplify(&s, &HullOptions { max_straightening: f64::INFINITY, ..Default::default() }).unwrap();
    assert!(seed.collapsed.contains(&stub), "the seed's rule collapses the stub: {:?}", seed.collapsed);
    let kept = simplify(&s, &HullOptions::default()).unwrap();
    assert!(!kept.collapsed.contains(&stub) && kept.clamped.contains(&stub), "{kept:?}");
    assert_eq!((child(&seed), child(&kept)), (a, stub));
    let (free, ..) = bend(false);
    let g = simplify(&free, &HullOptions::default()).unwrap();
    assert!(g.collapsed.contains(&stub), "nothing in the way: collapsed as the seed does");
    let m = full_check("stub at a bend", &s, 4, true);
    assert!(m.clamped.contains(&stub));
    assert!(hull_mesh(&s, &HullOptions { max_straightening: -1.0, ..Default::default() }).is_err());
}

// ---------------------------------------------------------------------------------------
// Truncated cones (issue 26: Pieterse2012-spec §2.1, §2.5)

/// Volume of a truncated cone of height `h` and end radii `r0`, `r1`.
fn frustum_volume(h: f64, r0: f64, r1: f64) -> f64 {
    std::f64::consts::PI * h * (r0 * r0 + r0 * r1 + r1 * r1) / 3.0
}

/// Parses `text` as LST and meshes it with caps (a closed surface), `sides` per loop;
/// checks the mesh is a closed, consistently oriented 2-manifold and returns its volume
/// by the divergence theorem.
fn capped_lst_volume(name: &str, text: &str, sides: u32) -> f64 {
    let sk = sylva::import::lst::parse(name, text, &Default::default()).unwrap();
    let h = hull_mesh(&sk, &HullOptions { sides, caps: true, ..Default::default() }).unwrap();
    let t = check(name, &h.mesh);
    assert_eq!(t.boundary_loops, 0, "{name}: capped mesh has holes");
    assert_eq!(t.components, 1, "{name}: pieces");
    assert!(h.fallbacks.is_empty(), "{name}: fallbacks {:?}", h.fallbacks);
    checks::closed_oriented_manifold(&h.mesh, true).unwrap_or_else(|e| panic!("{name}: {e}"));
    h.mesh.signed_volume()
}

/// An LST `Cylinder(0.5, 0.1, 4)` is a truncated cone: the hull mesh's volume is the
/// frustum's within 5 % (a cylinder of the end radius has under a tenth of it), and its
/// loops shrink linearly from 0.5 at the base to 0.1 at the tip.
#[test]
fn an_lst_cone_is_meshed_as_a_truncated_cone() {
    let text = "LST 0.1\nCylinder(0.5, 0.1, 4) MovRel3f(0, 4, 0)\n";
    let want = frustum_volume(4.0, 0.5, 0.1);
    let got = capped_lst_volume("cone.lst", text, 64);
    assert!((got / want - 1.0).abs() < 0.05, "volume {got}, frustum {want}");
    // Every vertex lies on the cone r(y) = 0.5 − 0.1 y (the loops are inscribed).
    let sk = sylva::import::lst::parse("cone.lst", text, &Default::default()).unwrap();
    let h = hull_mesh(&sk, &HullOptions { sides: 8, ..Default::default() }).unwrap();
    for p in &h.mesh.positions {
        let r = (p.x * p.x + p.z * p.z).sqrt();
        assert!((r - (0.5 - 0.1 * p.y)).abs() < 1e-5, "vertex {p} off the cone");
    }
}

/// A cylinder whose start radius differs from the radius of the node it starts at (the
/// second one: 0.8 on top of a 0.5 end) keeps it: the two frusta's volumes add up.
#[test]
fn an_lst_chain_keeps_each_cylinders_start_radius() {
    let text = "LST 0.1\nCylinder(1, 0.5, 2) MovRel3f(0, 2, 0)\nCylinder(0.8, 0.2, 3) MovRel3f(0, 3, 0)\n";
    let want = frustum_volume(2.0, 1.0, 0.5) + frustum_volume(3.0, 0.8, 0.2);
    let got = capped_lst_volume("chain.lst", text, 64);
    assert!((got / want - 1.0).abs() < 0.05, "volume {got}, frusta {want}");
    // A fork whose lateral starts fatter than it ends, at an angle.
    let text = "LST 0.1\nCylinder(0.4, 0.3, 3) MovRel3f(0, 3, 0)\nSB() RotRel3f(0.8, 0, 0, 1) \
                Cylinder(0.25, 0.05, 3) MovRel3f(0, 3, 0) EB()\nCylinder(0.3, 0.2, 3) MovRel3f(0, 3, 0)\n";
    let sk = sylva::import::lst::parse("fork.lst", text, &Default::default()).unwrap();
    let g = simplify(&sk, &HullOptions::default()).unwrap();
    let lateral = g.branches.iter().find(|b| b.node == 2).unwrap();
    assert_eq!((lateral.start_radius, lateral.end_radius), (0.25, 0.05f32 as f64));
    full_check("fork.lst", &sk, 8, true);
}

/// Start radii are validated like radii, and a column of the wrong length is an error.
#[test]
fn bad_start_radii_are_errors() {
    let mut sk = y_fork();
    sk.set_start_radius(1, Some(-0.1));
    assert!(hull_mesh(&sk, &HullOptions::default()).is_err());
    sk.set_start_radius(1, Some(f32::NAN));
    assert!(hull_mesh(&sk, &HullOptions::default()).is_err());
    sk.set_start_radius(1, None);
    hull_mesh(&sk, &HullOptions::default()).unwrap();
    sk.start_radius.pop();
    assert!(hull_mesh(&sk, &HullOptions::default()).is_err());
    // `push` keeps a present column in step; a root's entry is ignored.
    let mut sk = y_fork();
    sk.set_start_radius(0, Some(9.0));
    let n = sk.push(Vec3::new(0.0, 3.0, 0.0), 0.01, 2, Vec3::X, 0) as usize;
    assert_eq!((sk.start_radius.len(), sk.start_radius(n), sk.start_radius(0)), (n + 1, None, None));
    sk.validate().unwrap();
}

/// Pieterse2012-spec property 17 through the pipeline: a hull mesh left open at its base and tips
/// (`mesh.tips = "open"`) and Loop-refined keeps its rims on the control mesh's rims
/// (`refine.boundary = "auto"` is `Fixed` for hull); with `bspline` the rims move off.
#[test]
fn open_hull_rims_stay_fixed_under_refinement() {
    let lst = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/yggdrasil-sample.lst");
    let grow = |levels: i64, boundary: &str| {
        let sets = [
            ("mesh.method".to_string(), toml::Value::String("hull".into())),
            ("mesh.tips".to_string(), toml::Value::String("open".into())),
            ("mesh.clear".to_string(), toml::Value::Boolean(false)),
            ("mesh.decollide".to_string(), toml::Value::Boolean(false)),
            ("refine.levels".to_string(), toml::Value::Integer(levels)),
            ("refine.boundary".to_string(), toml::Value::String(boundary.into())),
        ];
        let loaded = sylva::recipe::load(lst, &sets).unwrap();
        sylva::pipeline::grow(&loaded).unwrap().model.parts.remove(0).mesh
    };
    let rim_edges = |m: &sylva::Mesh| -> Vec<[u32; 2]> {
        let t =
            sylva::refine::Topology::from_faces(m.vertex_count(), &m.face_offsets, &m.face_indices).unwrap();
        (0..t.edge_count()).filter(|&e| t.is_boundary_edge(e)).map(|e| t.edge(e)).collect()
    };
    let control = grow(0, "auto");
    let segments: Vec<(glam::Vec3, glam::Vec3)> = rim_edges(&control)
        .iter()
        .map(|&[a, b]| (control.positions[a as usize], control.positions[b as usize]))
        .collect();
    assert!(!segments.is_empty(), "the open hull mesh has rims");
    let off_rim = |m: &sylva::Mesh| -> f32 {
        rim_edges(m)
            .iter()
            .flatten()
            .map(|&v| {
                let p = m.positions[v as usize];
                segments
                    .iter()
                    .map(|&(a, b)| {
                        let t = ((p - a).dot(b - a) / (b - a).length_squared().max(1e-30)).clamp(0.0, 1.0);
                        p.distance(a + t * (b - a))
                    })
                    .fold(f32::INFINITY, f32::min)
            })
            .fold(0.0, f32::max)
    };
    let scale = control.bounds().map_or(1.0, |(lo, hi)| (hi - lo).length());
    let fixed = off_rim(&grow(2, "auto"));
    assert!(fixed < 1e-5 * scale, "auto (Fixed) rims moved {fixed} off the control rims (size {scale})");
    let bspline = off_rim(&grow(2, "bspline"));
    assert!(bspline > 1e-3 * scale, "bspline rims should shrink off the control polygon, moved {bspline}");
}
