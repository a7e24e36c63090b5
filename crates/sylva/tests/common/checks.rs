//! Mesh checks shared by the mesher tests (issue 22: one rule for "a valid cage").
#![allow(dead_code)]

use sylva::mesh::check::{check_mesh, CheckOptions, MeshReport};
use sylva::Mesh;

/// `Ok(report)` when `mesh` is a closed, consistently oriented 2-manifold with finite
/// positions and no degenerate face, enclosing a positive volume; otherwise the problems,
/// one line each. `intersections` also runs the self-intersection search (reported in
/// the returned report, not judged here).
pub fn closed_oriented_manifold(mesh: &Mesh, intersections: bool) -> Result<MeshReport, String> {
    mesh.validate()?;
    let r = check_mesh(mesh, &CheckOptions { self_intersections: intersections, ..Default::default() });
    let mut problems = r.structural_problems();
    if r.boundary_edges > 0 {
        problems.push(format!("{} boundary edge(s) in {} loop(s)", r.boundary_edges, r.boundary_loops));
    }
    if problems.is_empty() && mesh.signed_volume() <= 0.0 {
        problems.push(format!("signed volume {} ≤ 0 (faces point inward)", mesh.signed_volume()));
    }
    if problems.is_empty() {
        Ok(r)
    } else {
        Err(problems.join("; "))
    }
}
