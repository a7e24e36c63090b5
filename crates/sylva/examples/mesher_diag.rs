//! Where a joint mesher's self-intersections come from (issue 5, a developer tool).
//!
//! Grows a preset's skeleton, runs `decollide` (as the pipeline does for the joint
//! meshers), meshes it with `hull`, `sweep` or `quad`, refines the control mesh to level
//! 2 (Loop, or Catmull–Clark for `quad`: the level the issue's acceptance checks) and
//! groups the self-intersecting face pairs by the skeleton joint they lie at (each face
//! is given to the internode nearest its centre, in radii; a pair is counted at the
//! node the two internodes share, or at the first one's parent). It prints the joints
//! with the most pairs and their children (radius, length, angle to the parent,
//! grandchildren count). With `--joint N` it also renders the refined faces within
//! `--radius R` of node `N` (intersecting ones red) and the control faces there, from
//! three sides, to `DIR/joint-{0,1,2}.png` and `DIR/control-{0,1,2}.png`.
//!
//! ```text
//! cargo run --release -p sylva --example mesher_diag -- mgv-c quad
//! cargo run --release -p sylva --example mesher_diag -- mgv-c quad --joint 921 --radius 0.15 --out /tmp
//! cargo run --release -p sylva --example mesher_diag -- lsys-abop-a hull --control
//! ```
//!
//! `--control` groups the control mesh's own intersections instead of level 2's;
//! `--clear` runs the pipeline's mesh clearing (`sylva::fit::clear`) first and
//! diagnoses what it leaves; `--describe N,M` prints those nodes' children;
//! `--raw` meshes the generator's skeleton without de-collision; `--decollide` lists
//! the skeleton collisions `decollide` leaves, with the chains from their common
//! ancestor, and stops. For
//! `quad` and `sweep` it also lists the crossing pairs by the nodes their faces were
//! made for (`QuadMesh::face_node`; `SweepMesh::face_owner`: a strip's internode, named
//! by its end node, or the junction node) with the steps to their common ancestor
//! (`--pairs` prints the first pairs); for `quad` it prints the mesher's time.
//!
//! Every knob of the meshers, of de-collision and of clearing is a recipe key, set as in
//! `sylva grow` with `--set KEY=VALUE` (`docs/recipe.md`: `[mesh.hull]`, `[mesh.sweep]`,
//! `[mesh.quad]`, `[fit.decollide]`, `[fit.clear]`), e.g.
//! `--set mesh.quad.support=0 --set fit.decollide.max_rounds=4 --set fit.clear.patience=2`.
//! Debugging output: `--radius-scale F` scales every radius after `decollide`;
//! `--chain N` lists node N's ancestors with their control faces; `--faces-of N` the
//! control faces made for node N; `--big-faces` the control faces far from their
//! internode; `--pair-faces` the corners of the first crossing faces; `--nearest` each
//! crossing face's nearest internode.

use glam::Vec3;
use std::collections::{BTreeMap, HashMap, HashSet};
use sylva::fit::clear::clear_crossings;
use sylva::fit::decollide::decollide;
use sylva::mesh::check::{check_mesh, CheckOptions};
use sylva::mesh::hull::{hull_mesh, HullOptions};
use sylva::mesh::quad::{quad_mesh, QuadOptions};
use sylva::mesh::sweep::{sweep_mesh, SweepOptions};
use sylva::mesh::Mesher;
use sylva::model::{Material, Model, Part};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Mesh, Skeleton, NO_PARENT};

/// Pairs mapped back to the skeleton at most (the nearest-internode search is brute force).
const MAX_PAIRS: usize = 5_000;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1));
    let takes_value = |a: &str| {
        matches!(
            a,
            "--joint"
                | "--radius"
                | "--out"
                | "--describe"
                | "--set"
                | "--radius-scale"
                | "--chain"
                | "--faces-of"
        )
    };
    let has = |name: &str| args.iter().any(|a| a == name);
    let positional: Vec<&String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| !a.starts_with("--") && (*i == 0 || !takes_value(&args[i - 1])))
        .map(|(_, a)| a)
        .collect();
    let Some(preset) = positional.first() else {
        eprintln!(
            "usage: mesher_diag PRESET [hull|sweep|quad] [--set KEY=VALUE]... [--control] [--clear] [--raw] [--decollide] [--joint N] [--radius R] [--out DIR]"
        );
        std::process::exit(2);
    };
    let mesher = positional.get(1).map_or("quad", |s| s.as_str());
    let control_only = has("--control");
    let joint: Option<usize> = flag("--joint").map(|s| s.parse()).transpose()?;
    let radius: f32 = flag("--radius").map(|s| s.parse()).transpose()?.unwrap_or(0.15);
    let out = flag("--out").cloned().unwrap_or_else(|| std::env::temp_dir().display().to_string());

    if !matches!(mesher, "hull" | "sweep" | "quad") {
        return Err(format!("unknown mesher {mesher:?}: hull, sweep or quad").into());
    }
    // The recipe: the preset, the mesher named on the command line, then every `--set`.
    let mut sets = vec![sylva::recipe::parse_set(&format!("mesh.method=\"{mesher}\""))?];
    for (i, a) in args.iter().enumerate() {
        if a == "--set" {
            let kv = args.get(i + 1).ok_or("`--set` needs KEY=VALUE")?;
            sets.push(sylva::recipe::parse_set(kv)?);
        }
    }
    let loaded = sylva::recipe::load(preset, &sets)?;
    let recipe = &loaded.recipe;
    let mut sk = sylva::pipeline::skeleton(&loaded, &mut Default::default())?.skeleton;
    let dopts = recipe.fit.decollide.clone();
    let d = if has("--raw") {
        let left = sylva::mesh::check::skeleton_collisions(&sk, 0.01);
        sylva::fit::decollide::DecollideReport {
            before: left.len(),
            after: left.len(),
            unresolved: left,
            ..Default::default()
        }
    } else {
        decollide(&mut sk, &dopts)?
    };
    println!(
        "{preset}: {} nodes, skeleton collisions {} -> {} ({} rounds, {} rotations, {} thinned, {} tips pulled back, {} stubs moved or bent, {} traded, {:.0} ms)",
        sk.len(),
        d.before,
        d.after,
        d.rounds,
        d.rotations,
        d.thinned,
        d.retracted,
        d.extended,
        d.traded,
        d.elapsed.as_secs_f64() * 1e3
    );
    if let Some(f) = flag("--radius-scale").map(|s| s.parse::<f32>()).transpose()? {
        sk.radius.iter_mut().for_each(|r| *r *= f);
    }
    if has("--decollide") {
        // A fingerprint of the de-collided skeleton, to tell whether a change to the
        // pass changed its result (`DefaultHasher`: compare runs of one toolchain).
        let mut h = std::collections::hash_map::DefaultHasher::new();
        for (p, r) in sk.position.iter().zip(&sk.radius) {
            std::hash::Hash::hash(&[p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), r.to_bits()], &mut h);
        }
        println!("skeleton fingerprint {:016x}", std::hash::Hasher::finish(&h));
        describe_unresolved(&sk, &d.unresolved);
        return Ok(());
    }
    // The mesher's options as the pipeline builds them from `[mesh]` and `[mesh.<method>]`.
    let (mut hull_opts, mut sweep_opts, mut quad_opts) =
        (HullOptions::default(), SweepOptions::default(), QuadOptions::default());
    match recipe.mesh.mesher() {
        Mesher::Hull(o) => hull_opts = o,
        Mesher::Sweep(o) => sweep_opts = o,
        Mesher::Quad(o) => quad_opts = o,
        Mesher::Tube(_) | Mesher::Leaf(_) => unreachable!("the mesher was checked above"),
    }
    // One meshing: the control mesh, its scheme and (quad and sweep) the node each face is for.
    let run = |sk: &Skeleton, verbose: bool| -> sylva::Result<(Mesh, Scheme, Vec<u32>)> {
        Ok(match mesher {
            "hull" => {
                let h = hull_mesh(sk, &hull_opts)?;
                if verbose {
                    println!(
                        "hull: {} fallbacks, {} collapsed, {} clamped",
                        h.fallbacks.len(),
                        h.collapsed.len(),
                        h.clamped.len()
                    );
                }
                (h.mesh, Scheme::Loop, Vec::new())
            }
            "sweep" => {
                let w = sweep_mesh(sk, &sweep_opts)?;
                if verbose {
                    println!("sweep: {} fallbacks, {} general junctions", w.fallbacks.len(), w.general.len());
                }
                // A strip's faces go to its internode (its child node), a junction's to
                // the junction node.
                let node = w.face_owner.iter().map(|o| if o[1] != u32::MAX { o[1] } else { o[0] }).collect();
                (w.mesh, Scheme::Loop, node)
            }
            _ => {
                let t = std::time::Instant::now();
                let q = quad_mesh(sk, &quad_opts)?;
                if verbose {
                    println!("quad_mesh: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
                    let mut by: BTreeMap<String, usize> = BTreeMap::new();
                    for f in &q.fallbacks {
                        *by.entry(format!("{:?}", f.reason)).or_default() += 1;
                    }
                    println!(
                        "quad: fallbacks {by:?}, cases {:?}, repair rounds {}",
                        q.cases, q.repair_rounds
                    );
                }
                (q.mesh, Scheme::CatmullClark, q.face_node)
            }
        })
    };
    if has("--clear") {
        let co = recipe.fit.clear.clone();
        let (_, r) = clear_crossings(&mut sk, &co, |s| run(s, false).map(|(m, scheme, _)| (m, scheme)))?;
        println!(
            "clear: {:?} -> {:?} in {} rounds, {} thinned, {:.1} s; unresolved internodes {:?}",
            r.before,
            r.after,
            r.rounds,
            r.thinned,
            r.elapsed.as_secs_f64(),
            r.unresolved
        );
    }
    if let Some(list) = flag("--describe") {
        let ch = sk.children();
        for n in list.split(',').filter_map(|x| x.parse::<usize>().ok()).filter(|&n| n < sk.len()) {
            println!(
                "node {n} (parent {}) at {:.3}: {}",
                sk.parent[n] as i64,
                sk.position[n],
                describe(&sk, &ch, n)
            );
        }
    }
    let (mesh, scheme, face_node) = run(&sk, true)?;
    let listed = CheckOptions { max_listed: MAX_PAIRS, ..Default::default() };
    let t0 = std::time::Instant::now();
    let c = check_mesh(&mesh, &listed);
    let (fine, report) = if control_only {
        (mesh.clone(), c.clone())
    } else {
        let opts = SubdivideOptions {
            refine: RefineOptions { scheme, levels: 2, ..Default::default() },
            ..Default::default()
        };
        let t1 = std::time::Instant::now();
        let fine = subdivide(&mesh, &[], &opts)?;
        let t2 = std::time::Instant::now();
        let r = check_mesh(&fine, &listed);
        println!(
            "times: control check {:.0} ms, level-2 refine {:.0} ms ({} faces), level-2 check {:.0} ms",
            (t1 - t0).as_secs_f64() * 1e3,
            (t2 - t1).as_secs_f64() * 1e3,
            fine.face_count(),
            t2.elapsed().as_secs_f64() * 1e3
        );
        (fine, r)
    };
    println!(
        "self-intersecting pairs: control {:?}, level 2 {}",
        c.intersection_count,
        if control_only { "(not refined)".to_string() } else { format!("{:?}", report.intersection_count) }
    );

    if let Some(n) = flag("--chain").map(|s| s.parse::<usize>()).transpose()? {
        // Node `n`'s ancestors, with the number of control faces made for each.
        let mut owned = vec![0usize; sk.len()];
        face_node.iter().for_each(|&o| owned[o as usize] += 1);
        let ch = sk.children();
        for a in ancestors(&sk, n) {
            println!("  chain {a} at {:.3}: {} faces, {} children", sk.position[a], owned[a], ch.of(a).len());
        }
    }
    if let Some(n) = flag("--faces-of").map(|s| s.parse::<u32>()).transpose()? {
        // The control faces made for node `n`: corners relative to its parent node.
        let at = sk.position[sk.parent[n as usize] as usize];
        for f in (0..mesh.face_count()).filter(|&f| face_node.get(f) == Some(&n)) {
            let c: Vec<String> =
                mesh.face(f).iter().map(|&v| format!("{:.3}", mesh.positions[v as usize] - at)).collect();
            println!("  face {f} of node {n}: {}", c.join(" "));
        }
    }
    if !face_node.is_empty() && has("--big-faces") {
        // Control faces with a corner over 6 radii from the internode of the node they
        // were made for.
        let mut big: Vec<(f32, usize, u32)> = (0..mesh.face_count())
            .filter_map(|f| {
                let n = face_node[f] as usize;
                let p = sk.parent[n];
                let a = if p == NO_PARENT { sk.position[n] } else { sk.position[p as usize] };
                let b = sk.position[n];
                let far = mesh
                    .face(f)
                    .iter()
                    .map(|&v| {
                        let q = mesh.positions[v as usize];
                        let ab = b - a;
                        let t = ((q - a).dot(ab) / ab.length_squared().max(1e-20)).clamp(0.0, 1.0);
                        q.distance(a + ab * t)
                    })
                    .fold(0.0f32, f32::max);
                let x = far / sk.radius[n].max(1e-9);
                (x > 6.0).then_some((x, f, n as u32))
            })
            .collect();
        big.sort_by(|a, b| b.0.total_cmp(&a.0));
        println!("control faces with a corner over 6 radii from their internode: {}", big.len());
        for (x, f, n) in big.iter().take(12) {
            println!("  face {f} of node {n} (parent {}): {x:.1} radii off", sk.parent[*n as usize] as i64);
        }
    }
    if !face_node.is_empty() {
        // The nodes the quad mesher made each crossing face for, and their parents.
        let shift = if control_only { 0 } else { 4 };
        let mut seen: BTreeMap<(u32, u32), usize> = BTreeMap::new();
        for pair in &report.intersections {
            let (a, b) = (face_node[pair[0] >> shift], face_node[pair[1] >> shift]);
            *seen.entry((a.min(b), a.max(b))).or_default() += 1;
        }
        if has("--pairs") {
            for pair in report.intersections.iter().take(12) {
                let (a, b) = (pair[0] >> shift, pair[1] >> shift);
                println!(
                    "  pair: control face {a} (node {}) at {:.3} x control face {b} (node {}) at {:.3}",
                    face_node[a],
                    centroid(&fine, pair[0]),
                    face_node[b],
                    centroid(&fine, pair[1])
                );
            }
        }
        let par = |o: u32| if o == NO_PARENT { NO_PARENT } else { sk.parent[o as usize] };
        for ((a, b), n) in seen.iter().take(20) {
            let (a_, b_) = (*a as usize, *b as usize);
            let lca = common_ancestor_steps(&ancestors(&sk, a_), &ancestors(&sk, b_));
            let gap = if par(*a) == NO_PARENT || par(*b) == NO_PARENT {
                f32::NAN
            } else {
                sampled_gap(&sk, a_, b_) / (capsule_radius(&sk, a_) + capsule_radius(&sk, b_))
            };
            println!(
                "faces of nodes {a} (parent {}) and {b} (parent {}): {n} pairs; steps to common ancestor {lca:?}; axis gap/(ra+rb) {gap:.2}",
                par(*a),
                par(*b)
            );
        }
    }
    if has("--pair-faces") {
        // The corners of the first crossing pairs' faces (of the searched mesh).
        for pair in report.intersections.iter().take(4) {
            for f in pair {
                let c: Vec<String> =
                    fine.face(*f).iter().map(|&v| format!("{:.4}", fine.positions[v as usize])).collect();
                println!("  face {f}: {}", c.join(" "));
            }
        }
    }
    if has("--nearest") {
        // Each crossing face's nearest internode and its distance from that axis, in
        // radii (1 = on the capsule's surface).
        let off = |i: usize, p: Vec3| {
            let a = sk.position[sk.parent[i] as usize];
            let ab = sk.position[i] - a;
            let t = ((p - a).dot(ab) / ab.length_squared().max(1e-20)).clamp(0.0, 1.0);
            (a + ab * t - p).length() / sk.radius[i].max(1e-6)
        };
        for pair in report.intersections.iter().take(16) {
            let (pa, pb) = (centroid(&fine, pair[0]), centroid(&fine, pair[1]));
            let (a, b) = (nearest_internode(&sk, pa), nearest_internode(&sk, pb));
            println!(
                "  pair at {pa:.3}: internode {a} ({:.2} r off its axis) x internode {b} ({:.2} r off)",
                off(a, pa),
                off(b, pb)
            );
        }
    }
    let mut joints: BTreeMap<u32, usize> = BTreeMap::new();
    for pair in &report.intersections {
        let a = nearest_internode(&sk, centroid(&fine, pair[0]));
        let b = nearest_internode(&sk, centroid(&fine, pair[1]));
        let (pa, pb) = (sk.parent[a], sk.parent[b]);
        // The node the two internodes share, else the first one's base.
        let at = if pb as usize == a {
            a as u32
        } else if pa as usize == b {
            b as u32
        } else {
            pa
        };
        *joints.entry(at).or_default() += 1;
    }
    let mut ranked: Vec<(u32, usize)> = joints.into_iter().collect();
    ranked.sort_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(&y.0)));
    let ch = sk.children();
    for &(j, n) in ranked.iter().take(20) {
        println!("joint {j}: {n} pairs; {}", describe(&sk, &ch, j as usize));
    }
    if let Some(j) = joint {
        if j >= sk.len() {
            return Err(format!("--joint {j}: the skeleton has {} nodes", sk.len()).into());
        }
        let hits: HashSet<usize> = report.intersections.iter().flat_map(|p| [p[0], p[1]]).collect();
        let c = sk.position[j];
        render(&fine, &hits, c, radius, &format!("{out}/joint"))?;
        render(&mesh, &HashSet::new(), c, radius, &format!("{out}/control"))?;
        println!("wrote {out}/joint-{{0,1,2}}.png and {out}/control-{{0,1,2}}.png");
    }
    Ok(())
}

/// The collisions `decollide` left: per pair, the steps from each internode to their
/// common ancestor, the radii, the axis gap in units of the radius sum (sampled), and
/// the subtree sizes at the nearest branching above each internode.
fn describe_unresolved(sk: &Skeleton, pairs: &[[usize; 2]]) {
    let ch = sk.children();
    let size = |c: usize| {
        let (mut n, mut stack) = (0usize, vec![c]);
        while let Some(x) = stack.pop() {
            n += 1;
            stack.extend(ch.of(x).iter().map(|&k| k as usize));
        }
        n
    };
    let joint_above = |mut c: usize| {
        while sk.parent[c] != NO_PARENT {
            let p = sk.parent[c] as usize;
            if ch.of(p).len() > 1 || sk.order[c] != sk.order[p] {
                return c;
            }
            c = p;
        }
        c
    };
    for &[a, b] in pairs.iter().take(40) {
        let (ca, cb) = (ancestors(sk, a), ancestors(sk, b));
        let lca = common_ancestor_steps(&ca, &cb);
        let gap = sampled_gap(sk, a, b);
        let r = |i: usize| capsule_radius(sk, i);
        let len = |i: usize| sk.position[i].distance(sk.position[sk.parent[i] as usize]);
        // Internodes strictly between the two (through their common ancestor).
        let between: f32 = lca.map_or(0.0, |(i, j)| {
            let side = |chain: &[usize], k: usize| {
                chain.get(1..k).unwrap_or(&[]).iter().map(|&x| len(x)).sum::<f32>()
            };
            side(&ca, i) + side(&cb, j)
        });
        let (ja, jb) = (joint_above(a), joint_above(b));
        println!(
            "{a} (order {}, r {:.4}) x {b} (order {}, r {:.4}): gap/(ra+rb) {:.2}, lengths {:.3}/{:.3}, path between {:.3}, steps to common ancestor {lca:?}, joint above {ja} ({} nodes) / {jb} ({} nodes)",
            sk.order[a],
            r(a),
            sk.order[b],
            r(b),
            gap / (r(a) + r(b)),
            len(a),
            len(b),
            between,
            size(ja),
            size(jb)
        );
        // The two chains from the common ancestor down to each internode.
        if let Some((i, j)) = lca {
            for (name, chain, k) in [("a", &ca, i), ("b", &cb, j)] {
                for &x in chain[..=k].iter().rev() {
                    let dir = match sk.parent[x] {
                        NO_PARENT => Vec3::ZERO,
                        p => (sk.position[x] - sk.position[p as usize]).normalize_or_zero(),
                    };
                    println!(
                        "    {name} {x}: pos {:.3?} dir {:.2?} r {:.4} order {} children {}",
                        sk.position[x],
                        dir,
                        sk.radius[x],
                        sk.order[x],
                        ch.of(x).len()
                    );
                }
            }
        }
    }
}

/// Node `n` and its ancestors up to the root.
fn ancestors(sk: &Skeleton, mut n: usize) -> Vec<usize> {
    let mut chain = vec![n];
    while sk.parent[n] != NO_PARENT {
        n = sk.parent[n] as usize;
        chain.push(n);
    }
    chain
}

/// Steps from each of two ancestor chains to their first common node.
fn common_ancestor_steps(ca: &[usize], cb: &[usize]) -> Option<(usize, usize)> {
    let i = ca.iter().position(|x| cb.contains(x))?;
    Some((i, cb.iter().position(|y| *y == ca[i])?))
}

/// An internode's capsule radius (the larger of its two end radii).
fn capsule_radius(sk: &Skeleton, i: usize) -> f32 {
    sk.radius[i].max(sk.radius[sk.parent[i] as usize])
}

/// The gap between the axes of internodes `a` and `b` (sampled at 33 points each).
fn sampled_gap(sk: &Skeleton, a: usize, b: usize) -> f32 {
    let seg = |i: usize, t: f32| {
        let p = sk.position[sk.parent[i] as usize];
        p + (sk.position[i] - p) * t
    };
    let mut gap = f32::MAX;
    for i in 0..=32 {
        for j in 0..=32 {
            gap = gap.min(seg(a, i as f32 / 32.0).distance(seg(b, j as f32 / 32.0)));
        }
    }
    gap
}

/// Centre of face `f`.
fn centroid(m: &Mesh, f: usize) -> Vec3 {
    let v = m.face(f);
    v.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / v.len() as f32
}

/// The internode (named by its child node) nearest `p`, distance measured in radii.
fn nearest_internode(sk: &Skeleton, p: Vec3) -> usize {
    let mut best = (f32::MAX, 0);
    for i in 0..sk.len() {
        let par = sk.parent[i];
        if par == NO_PARENT {
            continue;
        }
        let a = sk.position[par as usize];
        let ab = sk.position[i] - a;
        let t = ((p - a).dot(ab) / ab.length_squared().max(1e-20)).clamp(0.0, 1.0);
        let d = (a + ab * t - p).length() / sk.radius[i].max(1e-6);
        if d < best.0 {
            best = (d, i);
        }
    }
    best.1
}

/// A node's radius, incoming internode and children (radius, length, angle to the
/// incoming direction, grandchildren).
fn describe(sk: &Skeleton, ch: &sylva::skeleton::Children, j: usize) -> String {
    let par = sk.parent[j];
    let (dir, len) = if par == NO_PARENT {
        (Vec3::Y, 0.0)
    } else {
        let v = sk.position[j] - sk.position[par as usize];
        (v.normalize_or_zero(), v.length())
    };
    let kids: Vec<String> = ch
        .of(j)
        .iter()
        .map(|&k| {
            let v = sk.position[k as usize] - sk.position[j];
            let ang = dir.dot(v.normalize_or_zero()).clamp(-1.0, 1.0).acos().to_degrees();
            format!(
                "[{k} r={:.3} len={:.3} {ang:.0}° kids={}]",
                sk.radius[k as usize],
                v.length(),
                ch.of(k as usize).len()
            )
        })
        .collect();
    format!("r={:.3}, internode {len:.3}; children {}", sk.radius[j], kids.join(" "))
}

/// The faces of `m` whose centre lies within `r` of `c` and that `keep` accepts, as a
/// compact mesh.
fn crop(m: &Mesh, c: Vec3, r: f32, keep: &dyn Fn(usize) -> bool) -> Mesh {
    let mut out = Mesh::new();
    let mut map = HashMap::new();
    for f in 0..m.face_count() {
        if centroid(m, f).distance(c) < r && keep(f) {
            let v: Vec<u32> = m
                .face(f)
                .iter()
                .map(|&i| {
                    *map.entry(i).or_insert_with(|| {
                        out.positions.push(m.positions[i as usize]);
                        (out.positions.len() - 1) as u32
                    })
                })
                .collect();
            out.push_face(&v);
        }
    }
    out
}

/// Renders the crop around `c` from three azimuths, `hits` in red.
fn render(
    m: &Mesh,
    hits: &HashSet<usize>,
    c: Vec3,
    r: f32,
    stem: &str,
) -> Result<(), Box<dyn std::error::Error>> {
    let material = |rgb: [f32; 3]| Material {
        base_color: [rgb[0], rgb[1], rgb[2], 1.0],
        double_sided: true,
        ..Material::bark()
    };
    let model = Model {
        parts: vec![
            Part {
                name: "clear".into(),
                mesh: crop(m, c, r, &|f| !hits.contains(&f)),
                material: material([0.6; 3]),
                ..Default::default()
            },
            Part {
                name: "hits".into(),
                mesh: crop(m, c, r, &|f| hits.contains(&f)),
                material: material([0.9, 0.05, 0.05]),
                ..Default::default()
            },
        ],
        ..Default::default()
    };
    for (i, az) in [0.0f32, 90.0, 180.0].into_iter().enumerate() {
        let opts = sylva::preview::PreviewOptions {
            width: 400,
            height: 400,
            view: Some(sylva::preview::ViewAngles { azimuth_deg: az, elevation_deg: 20.0 }),
            ..Default::default()
        };
        let img = sylva::preview::render(&model, &opts)?;
        sylva::preview::write_png(&img, std::path::Path::new(&format!("{stem}-{i}.png")))?;
    }
    Ok(())
}
