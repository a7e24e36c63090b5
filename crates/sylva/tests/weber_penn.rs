//! Weber–Penn generator (issue 6): properties checked against the paper's definitions
//! (Weber & Penn 1995) — stem lengths and ShapeRatio, child counts, down and rotate
//! angles, taper profiles, pruning, segment splits — plus determinism, the skeleton's
//! structure, leaves, and every `presets/wp-*.toml` growing and meshing.

mod common;
#[path = "common/edges.rs"]
mod edges;

use edges::check_closed_manifold;
use glam::Vec3;
use std::collections::HashMap;
use sylva::grow::weber_penn::*;
use sylva::mesh::organs::organ_mesh;
use sylva::mesh::tube::{tube_mesh, TubeOptions};
use sylva::skeleton::{OrganKind, NO_PARENT};

const EPS: f64 = 1e-4;

/// A tree with every random variation off, so lengths and angles are exact.
fn exact() -> WeberPennParams {
    WeberPennParams {
        shape: 3,
        base_size: 0.2,
        scale: 10.0,
        scale_v: 0.0,
        levels: 2,
        ratio: 0.02,
        flare: 0.0,
        n_scale_v: [0.0; 4],
        n_length: [1.0, 0.5, 0.4, 0.0],
        n_length_v: [0.0; 4],
        n_curve_res: [4, 3, 2, 1],
        n_curve: [0.0; 4],
        n_curve_v: [0.0; 4],
        n_curve_back: [0.0; 4],
        n_branches: [1, 20, 6, 0],
        n_down_angle: [0.0, 50.0, 40.0, 30.0],
        n_down_angle_v: [0.0; 4],
        n_rotate: [0.0, 140.0, 140.0, 140.0],
        n_rotate_v: [0.0; 4],
        leaves: 0,
        attraction_up: 0.0,
        prune_ratio: 0.0,
        ..Default::default()
    }
}

/// Paper coordinates (+Z up) of a sylva point (+Y up).
fn paper(p: Vec3) -> (f64, f64, f64) {
    (p.x as f64, -p.z as f64, p.y as f64)
}

/// The originals (not clones) of one level.
fn originals(t: &WeberPennTree, level: u8) -> Vec<(usize, &Stem)> {
    t.stems.iter().enumerate().filter(|(_, s)| s.level == level && s.clone_of.is_none()).collect()
}

/// The original a record belongs to.
fn original_of(t: &WeberPennTree, i: usize) -> usize {
    t.stems[i].clone_of.map_or(i, |o| o as usize)
}

/// The original stem whose axis a child's base lies on.
fn parent_original(t: &WeberPennTree, s: &Stem) -> Option<usize> {
    s.parent_stem.map(|p| original_of(t, p as usize))
}

/// Direction of a stem's first segment.
fn first_dir(s: &Stem) -> Vec3 {
    (s.curve[0].points[3] - s.curve[0].points[0]).normalize()
}

#[test]
fn stem_lengths_follow_shape_ratio_for_every_shape() {
    for shape in 0..=8 {
        let p = WeberPennParams { shape, levels: 3, prune_width_peak: 0.3, ..exact() };
        let t = grow(&p, 5).unwrap();
        let trunk = &t.stems[0];
        let l0 = trunk.length as f64;
        assert!((l0 - 10.0).abs() < EPS, "trunk length = Scale·0Length");
        let base = p.base_size * 10.0;
        let mut offsets = Vec::new();
        for (_, s) in originals(&t, 1) {
            let offset = s.offset as f64;
            offsets.push(offset);
            let ratio = (l0 - offset) / (l0 - base);
            let want = l0 * p.n_length[1] * shape_ratio(shape, ratio, &p);
            assert!(
                (s.length as f64 - want).abs() < EPS * l0,
                "shape {shape}: length {} want {want}",
                s.length
            );
        }
        // 20 children spaced evenly above the bare base; zero-length ones are not grown.
        let grown = offsets.len();
        let expected = (0..20)
            .map(|k| base + (k as f64 + 0.5) * (l0 - base) / 20.0)
            .filter(|o| shape_ratio(shape, (l0 - o) / (l0 - base), &p) * l0 * 0.5 > 1e-4)
            .count();
        assert_eq!(grown, expected, "shape {shape}");
        for o in &offsets {
            let k = (o - base) / ((l0 - base) / 20.0) - 0.5;
            assert!((k - k.round()).abs() < 1e-6, "shape {shape}: offset {o} is not on the even spacing");
        }
        // Level 2: length = length_child_max · (length_parent − 0.6·offset).
        for (_, s) in originals(&t, 2) {
            let parent = &t.stems[parent_original(&t, s).unwrap()];
            let want = p.n_length[2] * (parent.length as f64 - 0.6 * s.offset as f64);
            assert!((s.length as f64 - want).abs() < EPS * 10.0, "level 2 length {} want {want}", s.length);
        }
    }
}

#[test]
fn child_counts_follow_n_branches() {
    let p = WeberPennParams {
        levels: 3,
        shape: 7,
        n_branches: [1, 30, 17, 0],
        leaves: 13,
        leaf_quality: 0.8,
        ..exact()
    };
    let t = grow(&p, 11).unwrap();
    let mut children: HashMap<usize, usize> = HashMap::new();
    for s in t.stems.iter().filter(|s| s.clone_of.is_none() && s.level > 0) {
        *children.entry(parent_original(&t, s).unwrap()).or_default() += 1;
    }
    assert_eq!(children.get(&0), Some(&30), "the trunk bears exactly 1Branches");
    assert_eq!(t.report.stems_per_level, [1, 30, t.report.stems_per_level[2], 0]);
    // Level 2: stems = nBranches·(0.2 + 0.8·(L/L_parent)/length_child_max), rounded with
    // the error carried between stems.
    let l0 = t.stems[0].length as f64;
    let (mut sum_x, mut sum_n) = (0.0, 0usize);
    for (i, s) in originals(&t, 1) {
        let x = 17.0 * (0.2 + 0.8 * (s.length as f64 / l0) / p.n_length[1]);
        let n = children.get(&i).copied().unwrap_or(0);
        assert!(n == x.floor() as usize || n == x.ceil() as usize, "stem {i}: {n} children for {x}");
        sum_x += x;
        sum_n += n;
    }
    assert!((sum_n as f64 - sum_x).abs() <= 1.0, "{sum_n} children for {sum_x}");
    assert_eq!(sum_n, t.report.stems_per_level[2]);
    // Leaves: Leaves·ShapeRatio(4, offset/L_parent)·LeafQuality per last-level stem.
    let mut leaves: HashMap<usize, usize> = HashMap::new();
    for o in &t.skeleton.organs {
        let owner =
            t.stems.iter().position(|s| s.nodes.contains(&o.node)).expect("a leaf hangs on a stem node");
        assert_eq!(t.stems[owner].level, 2, "leaves hang on the last level");
        *leaves.entry(original_of(&t, owner)).or_default() += 1;
    }
    let (mut sum_x, mut sum_n) = (0.0, 0usize);
    for (i, s) in originals(&t, 2) {
        let parent = &t.stems[parent_original(&t, s).unwrap()];
        let x = 13.0 * shape_ratio(4, s.offset as f64 / parent.length as f64, &p) * 0.8;
        let n = leaves.get(&i).copied().unwrap_or(0);
        assert!(n == x.floor() as usize || n == x.ceil() as usize, "stem {i}: {n} leaves for {x}");
        sum_x += x;
        sum_n += n;
    }
    assert!((sum_n as f64 - sum_x).abs() <= 1.0);
    assert_eq!(sum_n, t.report.leaves);
}

/// Paper azimuth (degrees) of a sylva direction.
fn azimuth(d: Vec3) -> f64 {
    let (x, y, _) = paper(d);
    y.atan2(x).to_degrees()
}

#[test]
fn down_and_rotate_angles() {
    let p = exact();
    let t = grow(&p, 2).unwrap();
    let kids = originals(&t, 1);
    assert_eq!(kids.len(), 20);
    let mut prev: Option<f64> = None;
    for (_, s) in &kids {
        let down = first_dir(s).angle_between(Vec3::Y).to_degrees() as f64;
        assert!((down - 50.0).abs() < 1e-3, "down angle {down}");
        let a = azimuth(first_dir(s));
        if let Some(b) = prev {
            let d = (a - b).rem_euclid(360.0);
            assert!((d - 140.0).abs() < 1e-3, "rotate step {d}");
        }
        prev = Some(a);
    }
    // Negative nRotate: children alternate by ±(180 + nRotate).
    let t = grow(&WeberPennParams { n_rotate: [0.0, -60.0, 0.0, 0.0], ..exact() }, 2).unwrap();
    let az: Vec<f64> = originals(&t, 1).iter().map(|(_, s)| azimuth(first_dir(s))).collect();
    for (k, w) in az.windows(2).enumerate() {
        let d = (w[1] - w[0]).rem_euclid(360.0);
        let want = if k % 2 == 0 { 240.0 } else { 120.0 };
        assert!((d - want).abs() < 1e-3, "alternating step {k}: {d}");
    }
    // Negative nDownAngleV: the angle varies along the parent,
    // nDownAngle + nDownAngleV·(1 − 2·ShapeRatio(0, (L − offset)/(L − base))).
    let p = WeberPennParams { n_down_angle_v: [0.0, -30.0, 0.0, 0.0], ..exact() };
    let t = grow(&p, 2).unwrap();
    let l0 = t.stems[0].length as f64;
    for (_, s) in originals(&t, 1) {
        let ratio = (l0 - s.offset as f64) / (l0 * (1.0 - p.base_size));
        let want = 50.0 - 30.0 * (1.0 - 2.0 * shape_ratio(0, ratio, &p));
        let down = first_dir(s).angle_between(Vec3::Y).to_degrees() as f64;
        assert!((down - want).abs() < 1e-3, "varying down angle {down} want {want}");
    }
}

#[test]
fn taper_profiles() {
    let (r, len) = (0.5, 10.0);
    for z in [0.0, 0.3, 0.77, 1.0] {
        // 0 ≤ nTaper ≤ 1: conical, radius·(1 − nTaper·z).
        for taper in [0.0, 0.4, 1.0] {
            let want = r * (1.0 - taper * z);
            assert!((taper_radius(taper, r, len, z) - want).abs() < 1e-12, "taper {taper} at {z}");
        }
    }
    // 1 < nTaper < 2: a cone to radius·(nTaper − 1) that ends in a sphere of that radius.
    let taper = 1.5;
    for i in 0..=1000 {
        let z = i as f64 / 1000.0;
        let tz = r * (1.0 - 0.5 * z);
        let from_tip = (1.0 - z) * len;
        let got = taper_radius(taper, r, len, z);
        if from_tip >= tz {
            assert!((got - tz).abs() < 1e-12, "cone part at {z}");
        } else {
            // On the circle of radius tz centred tz from the tip.
            assert!(((from_tip - tz).powi(2) + got * got - tz * tz).abs() < 1e-9, "sphere at {z}");
        }
    }
    assert_eq!(taper_radius(1.5, r, len, 1.0), 0.0, "spherical end closes at the tip");
    // nTaper = 2: a cylinder with a hemispherical end.
    assert!((taper_radius(2.0, r, len, 0.5) - r).abs() < 1e-12);
    assert_eq!(taper_radius(2.0, r, len, 1.0), 0.0);
    // 2 < nTaper ≤ 3: periodic, pinched to (1 − (nTaper − 2))·r every 2r from the tip,
    // full radius halfway between.
    for taper in [2.5, 3.0] {
        let depth = taper - 2.0;
        for k in 1..9 {
            let pinch = 1.0 - (2.0 * r * k as f64) / len;
            let bulge = 1.0 - (2.0 * r * k as f64 + r) / len;
            assert!((taper_radius(taper, r, len, pinch) - (1.0 - depth) * r).abs() < 1e-6, "pinch {k}");
            assert!((taper_radius(taper, r, len, bulge) - r).abs() < 1e-9, "bulge {k}");
        }
    }
    // The skeleton's radii are the stem's profile (straight trunk: distance = height).
    for taper in [0.6, 1.0, 1.5, 2.0, 2.5] {
        let p = WeberPennParams { levels: 1, n_taper: [taper, 1.0, 1.0, 1.0], flare: 0.5, ..exact() };
        let t = grow(&p, 1).unwrap();
        let trunk = &t.stems[0];
        for n in trunk.nodes.clone() {
            let pos = t.skeleton.position[n as usize];
            let want = trunk.radius_at(pos.y as f64) as f32;
            let got = t.skeleton.radius[n as usize];
            // The periodic profile has square-root pinches, where the f32 fields of
            // `Stem` move the value by more than rounding.
            let tol = if taper > 2.0 { 2e-3 } else { 1e-5 };
            assert!(
                (got - want).abs() <= tol * (1.0 + want),
                "taper {taper}: node {n} radius {got} want {want}"
            );
        }
        // Flare: 1 + Flare·(100^1 − 1)/100 at the ground, none above 1/8 of the trunk.
        let unflared = |d: f64| taper_radius(taper, trunk.radius_base as f64, trunk.length as f64, d / 10.0);
        assert!((trunk.radius_at(0.0) - unflared(0.0) * (1.0 + 0.5 * 0.99)).abs() < 1e-9);
        assert!((trunk.radius_at(1.3) - unflared(1.3)).abs() < 1e-9);
        if taper > 2.0 {
            assert!(trunk.nodes.len() > 40, "periodic taper adds nodes to show the bulges");
        }
    }
}

#[test]
fn pruning_keeps_every_point_inside_the_envelope() {
    let p = WeberPennParams {
        levels: 3,
        shape: 4,
        n_length: [1.0, 0.8, 0.6, 0.0],
        n_curve: [0.0, 30.0, -20.0, 0.0],
        n_curve_v: [10.0, 60.0, 60.0, 0.0],
        n_seg_splits: [0.0, 0.3, 0.0, 0.0],
        n_split_angle: [0.0, 30.0, 0.0, 0.0],
        n_down_angle_v: [0.0, 20.0, 10.0, 0.0],
        prune_ratio: 1.0,
        prune_width: 0.4,
        prune_width_peak: 0.6,
        prune_power_low: 0.3,
        prune_power_high: 0.5,
        ..exact()
    };
    let t = grow(&p, 7).unwrap();
    let scale = t.report.scale_tree;
    let mut tested = 0;
    for s in t.stems.iter().filter(|s| s.level >= 1) {
        for b in &s.curve {
            let (x, y, z) = paper(b.points[3]);
            let r = (x * x + y * y).sqrt();
            let ratio = (scale - z) / (scale * (1.0 - p.base_size));
            assert!(
                r / scale < p.prune_width * shape_ratio(8, ratio, &p) + 1e-5,
                "level-{} point ({x}, {y}, {z}) is outside the envelope",
                s.level
            );
            tested += 1;
        }
    }
    assert!(tested > 100);
    // Pruning did shorten stems, and PruneRatio blends the lengths.
    let free = grow(&WeberPennParams { prune_ratio: 0.0, ..p.clone() }, 7).unwrap();
    let half = grow(&WeberPennParams { prune_ratio: 0.5, ..p.clone() }, 7).unwrap();
    let len1 = |t: &WeberPennTree| -> Vec<f32> { originals(t, 1).iter().map(|(_, s)| s.length).collect() };
    let (a, b, c) = (len1(&free), len1(&half), len1(&t));
    assert_eq!(a.len(), b.len());
    assert!(a.iter().zip(&b).any(|(x, y)| y < x), "some level-1 stem was pruned");
    for (x, y) in a.iter().zip(&b) {
        assert!(y <= x, "pruning only shortens");
    }
    assert!(c.iter().sum::<f32>() < b.iter().sum::<f32>());
}

#[test]
fn segment_splitting_counts() {
    // One clone per segment end: 2^(CurveRes − 1) paths.
    let p = WeberPennParams {
        levels: 1,
        n_curve_res: [5, 1, 1, 1],
        n_seg_splits: [1.0, 0.0, 0.0, 0.0],
        n_split_angle: [20.0, 0.0, 0.0, 0.0],
        ..exact()
    };
    let t = grow(&p, 3).unwrap();
    assert_eq!(t.report.clones_per_level[0], 15);
    assert_eq!(t.stems.len(), 16);
    t.skeleton.validate().unwrap();
    assert_eq!(t.skeleton.stats().tips, 16);
    // Two clones per segment end: 3^(CurveRes − 1).
    let t = grow(
        &WeberPennParams { n_curve_res: [4, 1, 1, 1], n_seg_splits: [2.0, 0.0, 0.0, 0.0], ..p.clone() },
        3,
    )
    .unwrap();
    assert_eq!(t.report.clones_per_level[0], 26);
    // BaseSplits: clones at the end of the first segment, evenly spread about the vertical.
    let t = grow(
        &WeberPennParams {
            base_splits: 2,
            n_seg_splits: [0.0; 4],
            n_split_angle: [30.0, 0.0, 0.0, 0.0],
            ..p.clone()
        },
        3,
    )
    .unwrap();
    assert_eq!(t.report.clones_per_level[0], 2);
    let az: Vec<f64> =
        t.stems.iter().map(|s| azimuth(s.curve.last().unwrap().points[3] - s.curve[0].points[0])).collect();
    let mut steps: Vec<f64> = vec![(az[1] - az[0]).rem_euclid(360.0), (az[2] - az[0]).rem_euclid(360.0)];
    steps.sort_by(f64::total_cmp);
    assert!((steps[0] - 120.0).abs() < 1.0 && (steps[1] - 240.0).abs() < 1.0, "base splits spread {steps:?}");
    // Fractional splits: the error is carried, so splits = nSegSplits × split points (±1).
    let p = WeberPennParams { n_curve_res: [10, 1, 1, 1], n_seg_splits: [0.35, 0.0, 0.0, 0.0], ..p };
    let t = grow(&p, 9).unwrap();
    let events: usize = t.stems.iter().map(|s| s.curve.len() - 1).sum();
    let clones = t.report.clones_per_level[0] as f64;
    assert!((clones - 0.35 * events as f64).abs() <= 1.0, "{clones} clones at {events} split points");
    // Clones start at a segment end of the stem they split from and share its taper.
    for (i, s) in t.stems.iter().enumerate().skip(1) {
        let from = &t.stems[s.parent_stem.unwrap() as usize];
        assert_eq!(s.clone_of, Some(0));
        assert!(from.curve.iter().any(|b| b.points[3].distance(s.curve[0].points[0]) < 1e-5), "clone {i}");
        let base = t.skeleton.parent[s.nodes.start as usize];
        let want = t.stems[0].radius_at(s.start as f64) as f32;
        assert!((t.skeleton.radius[base as usize] - want).abs() < 1e-5);
    }
}

#[test]
fn helix_for_negative_curve_v() {
    let p = WeberPennParams { n_curve_v: [0.0, -30.0, 0.0, 0.0], ..exact() };
    let t = grow(&p, 4).unwrap();
    for (_, s) in originals(&t, 1) {
        assert_eq!(s.curve.len(), 3 * 8, "eight Bézier steps per helix turn, one turn per segment");
        for seg in s.curve.chunks(8) {
            let axis = (seg[7].points[3] - seg[0].points[0]).normalize();
            for b in seg {
                let lean = (b.points[3] - b.points[0]).angle_between(axis).to_degrees();
                // A chord of 1/8 turn leans atan(tan 30° · sin(π/8)/(π/8)) from the axis.
                let want = (30f32.to_radians().tan() * (std::f32::consts::PI / 8.0).sin()
                    / (std::f32::consts::PI / 8.0))
                    .atan()
                    .to_degrees();
                assert!((lean - want).abs() < 0.05, "helix chord leans {lean}, want {want}");
            }
        }
    }
}

#[test]
fn skeleton_structure() {
    let p = WeberPennParams {
        levels: 3,
        leaves: 8,
        n_seg_splits: [0.2, 0.3, 0.0, 0.0],
        n_split_angle: [20.0, 30.0, 0.0, 0.0],
        n_curve_v: [20.0, 40.0, 40.0, 0.0],
        ..exact()
    };
    let t = grow(&p, 21).unwrap();
    let sk = &t.skeleton;
    sk.validate().unwrap();
    assert_eq!(t.report.nodes, sk.len());
    assert_eq!(sk.stats().roots, 1);
    // Records own disjoint node ranges covering every node.
    let mut owner = vec![usize::MAX; sk.len()];
    for (i, s) in t.stems.iter().enumerate() {
        for n in s.nodes.clone() {
            assert_eq!(owner[n as usize], usize::MAX);
            owner[n as usize] = i;
            assert_eq!(sk.order[n as usize], s.level as u16, "order = level");
        }
    }
    assert!(owner.iter().all(|o| *o != usize::MAX));
    // Every record but the trunk starts on a node of the record it grows from, exactly
    // at the curve's first point: children on the parent's axis, clones at a split.
    for (i, s) in t.stems.iter().enumerate().skip(1) {
        let base = sk.parent[s.nodes.start as usize];
        assert_ne!(base, NO_PARENT);
        assert_eq!(owner[base as usize], s.parent_stem.unwrap() as usize, "record {i}");
        assert!(sk.position[base as usize].distance(s.curve[0].points[0]) < 1e-5, "record {i}");
        // Inside a record, nodes chain.
        for n in s.nodes.start + 1..s.nodes.end {
            assert_eq!(owner[sk.parent[n as usize] as usize], i);
        }
        // The child's base radius is limited by the parent's radius there.
        assert!(s.radius_base <= sk.radius[base as usize] + 1e-6 || s.clone_of.is_some());
    }
    // Leaves are polygons hanging on last-level nodes, of the leaf's length.
    assert!(!sk.organs.is_empty());
    for o in &sk.organs {
        let OrganKind::Polygon(v) = &o.kind else { panic!("leaves are polygons") };
        assert!(v.len() >= 3);
        assert_eq!(sk.order[o.node as usize], 2);
        let extent = v.iter().map(|q| (*q - o.position).dot(o.heading)).fold(0f32, f32::max);
        assert!((extent - p.leaf_scale as f32).abs() < 1e-4, "leaf length {extent}");
        assert!(o.heading.is_normalized() && o.up.is_normalized());
    }
}

#[test]
fn negative_leaves_make_fans_at_the_tips() {
    let p = WeberPennParams { levels: 2, leaves: -5, leaf_bend: 0.0, n_branches: [1, 7, 0, 0], ..exact() };
    let t = grow(&p, 8).unwrap();
    let tips: Vec<Vec3> =
        t.stems.iter().filter(|s| s.level == 1).map(|s| s.curve.last().unwrap().points[3]).collect();
    // |Leaves|·ShapeRatio(4, offset/L_parent), rounded, at every tip.
    let l0 = t.stems[0].length as f64;
    let want: usize = t
        .stems
        .iter()
        .filter(|s| s.level == 1)
        .map(|s| (5.0 * shape_ratio(4, s.offset as f64 / l0, &p) + 0.5).floor() as usize)
        .sum();
    assert_eq!(t.report.leaves, want);
    assert!(want > tips.len());
    for o in &t.skeleton.organs {
        assert!(tips.iter().any(|tip| tip.distance(o.position) < 1e-5), "a fan leaf sits on a tip");
    }
}

#[test]
fn deterministic_in_the_seed() {
    let p = WeberPennParams { n_seg_splits: [0.3, 0.2, 0.1, 0.0], ..WeberPennParams::default() };
    let a = grow(&p, 42).unwrap();
    let b = grow(&p, 42).unwrap();
    assert_eq!(a.skeleton, b.skeleton);
    assert_eq!(a.stems, b.stems);
    let c = grow(&p, 43).unwrap();
    assert_ne!(a.skeleton.position, c.skeleton.position);
}

#[test]
fn z_scale_stretches_the_tree_vertically() {
    let p = WeberPennParams { levels: 3, ..exact() };
    let a = grow(&p, 6).unwrap().skeleton.stats().bounds;
    let b = grow(&WeberPennParams { z_scale: 2.0, ..p }, 6).unwrap().skeleton.stats().bounds;
    assert!(((b.1.y - b.0.y) / (a.1.y - a.0.y) - 2.0).abs() < 1e-4);
    assert!((b.1.x - a.1.x).abs() < 1e-4 && (b.0.z - a.0.z).abs() < 1e-4);
}

#[test]
fn bad_parameters_and_budgets_name_the_key() {
    let err = |p: WeberPennParams| grow(&p, 1).unwrap_err().to_string();
    let e = err(WeberPennParams { levels: 4, n_branches: [1, 3000, 3000, 3000], ..exact() });
    assert!(e.contains("generator.n_branches[") && e.contains("2000000"), "{e}");
    let e = err(WeberPennParams { levels: 2, n_branches: [1, 100_000, 0, 0], leaves: 100_000, ..exact() });
    assert!(e.contains("generator.leaves"), "{e}");
    let e = err(WeberPennParams { n_curve_res: [200, 3, 1, 1], n_seg_splits: [1.0; 4], ..exact() });
    assert!(e.contains("generator.n_seg_splits[0]"), "{e}");
    let e = err(WeberPennParams { n_down_angle: [0.0, f64::INFINITY, 0.0, 0.0], ..exact() });
    assert!(e.contains("generator.n_down_angle[1]"), "{e}");
    let e = err(WeberPennParams { n_taper: [3.5, 1.0, 1.0, 1.0], ..exact() });
    assert!(e.contains("generator.n_taper[0]"), "{e}");
    let e = err(WeberPennParams { n_curve_res: [0, 1, 1, 1], ..exact() });
    assert!(e.contains("generator.n_curve_res[0]"), "{e}");
    let e = err(WeberPennParams { shape: 9, ..exact() });
    assert!(e.contains("generator.shape"), "{e}");
    // Odd but legal values grow without panicking.
    for p in [
        WeberPennParams { scale_v: 10.0, scale: 10.0, ..WeberPennParams::default() },
        WeberPennParams { base_size: 1.0, prune_ratio: 1.0, ..exact() },
        WeberPennParams { n_length: [0.0; 4], ..exact() },
        WeberPennParams { ratio: 0.0, ratio_power: -2.0, ..exact() },
        WeberPennParams { levels: 1, leaves: -7, ..exact() },
        WeberPennParams { levels: 4, n_taper: [3.0, 2.0, 1.5, 0.0], n_curve_v: [-89.0; 4], ..exact() },
    ] {
        let t = grow(&p, 1).unwrap();
        t.skeleton.validate().unwrap();
    }
}

/// The `[generator]` table of a preset file, without `type`.
fn generator_table(text: &str) -> (toml::Table, toml::Table) {
    let mut t: toml::Table = toml::from_str(text).unwrap();
    let toml::Value::Table(mut g) = t.remove("generator").expect("a [generator] table") else { panic!() };
    assert_eq!(g.remove("type").and_then(|v| v.as_str().map(str::to_string)).as_deref(), Some("weber-penn"));
    (t, g)
}

#[test]
fn every_wp_preset_deserializes_grows_and_meshes() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../presets");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n.starts_with("wp-") && n.ends_with(".toml")
        })
        .collect();
    files.sort();
    assert!(files.len() >= 10, "only {} wp- presets", files.len());
    for f in files {
        let stem = f.file_stem().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&f).unwrap();
        let (top, g) = generator_table(&text);
        assert_eq!(top.get("name").and_then(|v| v.as_str()), Some(stem.as_str()));
        assert!(top.get("description").and_then(|v| v.as_str()).is_some_and(|d| !d.is_empty()));
        let p: WeberPennParams =
            toml::Value::Table(g.clone()).try_into().unwrap_or_else(|e| panic!("{stem}: {e}"));
        // Every key survives a serialize round trip (the recipe loader's unknown-key test).
        let back = toml::Value::try_from(&p).unwrap();
        for k in g.keys() {
            assert!(back.get(k).is_some(), "{stem}: unknown key {k}");
        }
        let seed = top.get("seed").and_then(|v| v.as_integer()).unwrap_or(1) as u64;
        let t = grow(&p, seed).unwrap_or_else(|e| panic!("{stem}: {e}"));
        t.skeleton.validate().unwrap();
        assert!(t.report.stems_per_level[1] > 0, "{stem} has branches");
        assert!(t.report.leaves > 0, "{stem} has leaves");
        let tube = tube_mesh(&t.skeleton, &TubeOptions::default()).unwrap();
        tube.mesh.validate().unwrap_or_else(|e| panic!("{stem}: {e}"));
        assert!(tube.triangles > 0);
        if ["wp-palm", "wp-quaking-aspen", "wp-weeping-willow"].contains(&stem.as_str()) {
            check_closed_manifold(&stem, &tube.mesh);
        }
        if stem == "wp-palm" || stem == "wp-quaking-aspen" {
            let (leaves, missing) = organ_mesh(&t.skeleton, &HashMap::new());
            assert!(missing.is_empty());
            leaves.validate().unwrap();
            assert!(leaves.face_count() >= t.report.leaves * 4);
        }
    }
}

#[test]
fn every_leaf_shape_exports_valid_gltf() {
    let dir = std::env::temp_dir().join(format!("sylva-wp-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut files = Vec::new();
    for shape in 0..=8 {
        let p = WeberPennParams { levels: 2, leaves: 9, leaf_shape: shape, leaf_scale: 0.4, ..exact() };
        let t = grow(&p, shape as u64).unwrap();
        let tube = tube_mesh(&t.skeleton, &TubeOptions::default()).unwrap();
        let (leaves, _) = organ_mesh(&t.skeleton, &HashMap::new());
        assert!(leaves.face_count() >= t.report.leaves * 2, "shape {shape}: every leaf meshes");
        let model = sylva::Model {
            parts: vec![
                sylva::Part {
                    name: "bark".into(),
                    mesh: tube.mesh,
                    material: sylva::Material::bark(),
                    ..Default::default()
                },
                sylva::Part {
                    name: "leaves".into(),
                    mesh: leaves,
                    material: sylva::Material::leaf(),
                    ..Default::default()
                },
            ],
            ..Default::default()
        };
        let path = dir.join(format!("leaf-shape-{shape}.glb"));
        std::fs::write(&path, sylva::export::gltf::to_glb(&model).unwrap()).unwrap();
        files.push(path);
    }
    common::gltf_validator::assert_valid_gltf(&files);
    let _ = std::fs::remove_dir_all(&dir);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 64, ..Default::default() })]

    /// Any legal parameters grow a valid skeleton that meshes, or fail with a recipe
    /// error naming a key (a budget): never a panic.
    #[test]
    fn any_parameters_grow_or_fail_cleanly(
        shape in 0u32..9,
        levels in 1u32..5,
        base_size in 0.0f64..1.0,
        scale_v in 0.0f64..12.0,
        taper in proptest::array::uniform4(0.0f64..3.0),
        res in proptest::array::uniform4(1u32..7),
        curve in proptest::array::uniform4(-400.0f64..400.0),
        curve_v in proptest::array::uniform4(-89.0f64..300.0),
        back in proptest::array::uniform4(-200.0f64..200.0),
        splits in proptest::array::uniform4(0.0f64..1.5),
        split_angle in proptest::array::uniform4(-90.0f64..90.0),
        branches in proptest::array::uniform4(0u32..14),
        down in proptest::array::uniform4(-180.0f64..180.0),
        down_v in proptest::array::uniform4(-90.0f64..90.0),
        rotate in proptest::array::uniform4(-360.0f64..360.0),
        leaves in -20i32..30,
        leaf_shape in 0u32..9,
        attraction in -6.0f64..6.0,
        prune in 0.0f64..1.0,
        base_splits in 0u32..4,
        seed in 0u64..1000,
    ) {
        let p = WeberPennParams {
            shape, levels, base_size, scale: 10.0, scale_v,
            n_taper: taper, n_curve_res: res, n_curve: curve, n_curve_v: curve_v, n_curve_back: back,
            n_seg_splits: splits, n_split_angle: split_angle, n_branches: branches, n_down_angle: down,
            n_down_angle_v: down_v, n_rotate: rotate, leaves, leaf_shape, attraction_up: attraction,
            prune_ratio: prune, base_splits, ..WeberPennParams::default()
        };
        match grow(&p, seed) {
            Ok(t) => {
                t.skeleton.validate().unwrap();
                let tube = tube_mesh(&t.skeleton, &TubeOptions::default()).unwrap();
                tube.mesh.validate().unwrap();
            }
            Err(e) => {
                let m = e.to_string();
                proptest::prop_assert!(m.contains("`generator."), "{}", m);
            }
        }
    }
}
