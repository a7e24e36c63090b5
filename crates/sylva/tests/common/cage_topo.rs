//! The cage checks the hull and quad mesher tests share (included with `#[path]`): a mesh
//! of one face size that is a consistently oriented 2-manifold of genus 0 in every
//! component, by `sylva::mesh::check` (Pieterse2012-spec §7, Skjermo2008-spec §10), and
//! the subdivision that refines it.
#![allow(dead_code)]

use sylva::mesh::check::{check_mesh, CheckOptions};
use sylva::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use sylva::Mesh;

/// What [`try_check`] measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Topo {
    pub vertices: usize,
    pub edges: usize,
    pub faces: usize,
    pub boundary_loops: usize,
    pub components: usize,
    pub euler: i64,
}

/// `Ok(counts)` when `m` is valid, every face has `corners` corners, each edge lies in
/// one or two faces run opposite ways, every vertex star is one fan, positions are finite,
/// no vertex is unused, no face is degenerate and every component has genus 0; `closed`
/// also rules out boundary edges (open or flipped faces). Else the first problem.
pub fn try_check(m: &Mesh, corners: usize, closed: bool) -> Result<Topo, String> {
    m.validate()?;
    if let Some(f) = (0..m.face_count()).find(|&f| m.face(f).len() != corners) {
        return Err(format!("face {f} has {} corners, not {corners}", m.face(f).len()));
    }
    let r = check_mesh(m, &CheckOptions { self_intersections: false, ..Default::default() });
    let problems = r.structural_problems();
    if !problems.is_empty() {
        return Err(problems.join("; "));
    }
    if closed && r.boundary_edges > 0 {
        return Err(format!("{} boundary edge(s) (open or flipped faces)", r.boundary_edges));
    }
    if r.total_genus() != 0 {
        return Err(format!(
            "not genus 0 (χ {}, {} components, {} holes)",
            r.euler, r.components, r.boundary_loops
        ));
    }
    Ok(Topo {
        vertices: r.vertices,
        edges: r.edges,
        faces: r.faces,
        boundary_loops: r.boundary_loops,
        components: r.components,
        euler: r.euler,
    })
}

/// [`try_check`], panicking with `name` and the problem.
pub fn check(name: &str, m: &Mesh, corners: usize, closed: bool) -> Topo {
    try_check(m, corners, closed).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// `m` subdivided `levels` times with `scheme`.
pub fn refined(m: &Mesh, scheme: Scheme, levels: u32) -> Mesh {
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme, levels, ..Default::default() },
        ..Default::default()
    };
    subdivide(m, &[], &opts).unwrap_or_else(|e| panic!("{scheme:?} subdivision of the cage: {e}"))
}
