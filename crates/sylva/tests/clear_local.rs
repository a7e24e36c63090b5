//! Issue 44, item 1: the mesh clearing's rounds after the first search only where the
//! surface changed, and find what a full search finds.

use glam::Vec3;
use sylva::fit::clear::{clear_crossings, ClearOptions};
use sylva::mesh::check::{check_mesh, CheckOptions};
use sylva::mesh::sweep::{sweep_mesh, SweepOptions};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Mesh, Skeleton, NO_PARENT};

/// A row of `n` three-node plants 1 m apart, the last two only 0.3 m apart (their stems
/// of radius 0.2 overlap, so only they cross).
fn row(n: usize) -> Skeleton {
    let mut s = Skeleton::new();
    for i in 0..n {
        let x = if i + 1 == n { (i - 1) as f32 + 0.3 } else { i as f32 };
        let root = s.push(Vec3::new(x, 0.0, 0.0), 0.2, NO_PARENT, Vec3::Z, 0);
        let mid = s.push(Vec3::new(x, 1.0, 0.0), 0.2, root, Vec3::Z, 0);
        s.push(Vec3::new(x, 2.0, 0.0), 0.15, mid, Vec3::Z, 0);
    }
    s
}

fn sweep(s: &Skeleton) -> sylva::Result<(Mesh, Scheme)> {
    Ok((sweep_mesh(s, &SweepOptions { caps: true, ..Default::default() })?.mesh, Scheme::Loop))
}

/// Crossing pairs of `mesh` refined `levels` times, by the checker's full search.
fn full_search(mesh: &Mesh, levels: u32) -> usize {
    let so = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::Loop, levels, ..Default::default() },
        ..Default::default()
    };
    let fine = subdivide(mesh, &[], &so).unwrap();
    check_mesh(&fine, &CheckOptions { max_intersections: usize::MAX, ..Default::default() })
        .intersection_count
        .unwrap()
}

#[test]
fn later_rounds_search_only_the_plants_that_changed() {
    let mut s = row(12);
    let opts = ClearOptions::default();
    let (mesh, r) = clear_crossings(&mut s, &opts, sweep).unwrap();
    assert!(r.before.unwrap() > 0 && r.after == Some(0) && r.rounds > 0, "{r:?}");
    assert_eq!(r.searched.len(), r.rounds + 1, "one search per meshing: {r:?}");
    let [all, first] = r.searched[0];
    assert_eq!(first, all, "the first search covers the whole mesh");
    for &[n, searched] in &r.searched[1..] {
        // Two plants of twelve are thinned: at most a fifth of the surface is searched.
        assert!(searched > 0 && searched * 5 < n, "{:?}", r.searched);
    }
    // What is left is what a full search of the mesh returned finds.
    assert_eq!(full_search(&mesh, opts.levels), 0);
}

#[test]
fn what_is_left_is_what_a_full_search_finds() {
    // The last two stems' axes 0.1 apart: thinning cannot part them.
    let mut s = row(6);
    for i in 15..18 {
        s.position[i].x = 4.1;
    }
    let opts = ClearOptions::default();
    let (mesh, r) = clear_crossings(&mut s, &opts, sweep).unwrap();
    assert!(r.after.unwrap() > 0 && r.rounds > 0, "{r:?}");
    assert!(r.searched[1..].iter().all(|&[n, searched]| searched * 2 < n), "{:?}", r.searched);
    assert_eq!(Some(full_search(&mesh, opts.levels)), r.after, "{r:?}");
}
