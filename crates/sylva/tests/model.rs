//! The model's branch curves from every generator (issue 22): Weber–Penn's own stems,
//! fitted chains for the others; continuous, finite, on the skeleton.

fn grow(preset: &str) -> sylva::pipeline::Grown {
    let loaded = sylva::recipe::load(preset, &[]).unwrap();
    sylva::pipeline::grow(&loaded).unwrap()
}

fn assert_chains(preset: &str) {
    let g = grow(preset);
    let curves = &g.model.curves;
    assert!(!curves.axes.is_empty(), "{preset}: curves");
    for (i, axis) in curves.axes.iter().enumerate() {
        if let Some(p) = axis.parent {
            assert!((p as usize) < i, "{preset}: parents first");
        }
        for seg in &axis.segments {
            assert!(seg.points.iter().all(|p| p.is_finite()), "{preset}: finite points");
            assert!(seg.radii.iter().all(|r| r.is_finite() && *r >= 0.0), "{preset}: radii");
        }
        for w in axis.segments.windows(2) {
            assert!(w[0].points[3].distance(w[1].points[0]) < 1e-4, "{preset}: the chain is continuous");
        }
    }
    let root = curves.axes[0].segments[0].points[0];
    assert!(root.distance(g.skeleton.position[0]) < 1e-3, "{preset}: the first axis starts at the root");
}

#[test]
fn lsystem_least_cost_and_weber_penn_trees_carry_branch_curves() {
    for p in ["lsys-honda-c", "mig-i", "wp-palm"] {
        assert_chains(p);
    }
}

#[test]
fn fitted_curves_cover_every_skeleton_node() {
    let g = grow("lsys-honda-c");
    let mut seen = vec![0u32; g.skeleton.len()];
    for axis in &g.model.curves.axes {
        let own = if axis.parent.is_some() { &axis.nodes[1..] } else { &axis.nodes[..] };
        own.iter().for_each(|&n| seen[n as usize] += 1);
    }
    assert!(seen.iter().all(|&c| c == 1), "each node on exactly one axis");
}

#[test]
fn weber_penn_keeps_its_own_stems() {
    let loaded = sylva::recipe::load("wp-palm", &[]).unwrap();
    let sylva::recipe::Generator::WeberPenn(p) = &loaded.recipe.generator else { panic!("weber-penn") };
    let tree = sylva::grow::weber_penn::grow(p, loaded.recipe.seed).unwrap();
    let g = sylva::pipeline::grow(&loaded).unwrap();
    assert_eq!(g.model.curves.axes.len(), tree.stems.len());
    for (axis, stem) in g.model.curves.axes.iter().zip(&tree.stems) {
        let pts: Vec<_> = axis.segments.iter().map(|s| s.points).collect();
        let own: Vec<_> = stem.curve.iter().map(|s| s.points).collect();
        assert_eq!(pts, own, "the stem's Bézier points, unchanged");
        if let Some(first) = axis.segments.first() {
            assert!((first.radii[0] as f64 - stem.radius_at(stem.start as f64)).abs() < 1e-6);
        }
    }
}
