//! Face-varying refinement: UVs (or any per-corner data) with exact seams.
//!
//! Pieterse2012 §4.4.3 (Pieterse2012-spec §2.9) interpolates UVs linearly per face and notes that
//! "better: apply Loop masks to UVs inside each UV chart, treating UV seams as
//! boundaries"; MacMurchy2004 §6.3 (MacMurchy2004-spec §2.12) reports that smoothly subdivided UVs
//! "shrink away from the texture borders". Both are solved the OpenSubdiv way: a
//! face-varying channel gets its own topology whose vertices are the (vertex, value, fan)
//! triples — corners around a mesh vertex are merged across an edge only when both faces
//! agree on the values at both ends — so a UV seam is a boundary of that topology. The
//! channel is then refined by the same scheme with
//! [`super::FvarInterpolation`] deciding how boundaries behave —
//! OpenSubdiv's six `FVarLinearInterpolation` rules: everything linear, linear boundaries
//! with pinned control vertices, or B-spline boundaries with more or fewer pinned chart
//! corners (the pinning rules are those of OpenSubdiv's `Vtr::FVarLevel`). Interior edges
//! inherit the mesh's crease sharpness. Both sides of a seam are computed from the same
//! values by the same rule, so seams stay exact.

use super::crease::{self, Features, Rules, INFINITE};
use super::topology::{Detail, Topology, NONE};
use super::{
    interpolate_into, into_init, try_to_vec, try_uninit_vec, try_with_capacity, BoundaryInterpolation,
    FvarInterpolation, Primvar, RefineError, Refiner, Scheme,
};
use crate::geometry::FaceVarying;

/// The refined topology of one face-varying channel; interpolate any number of value
/// sets that share its indices.
#[derive(Debug, Clone)]
pub struct FaceVaryingRefiner {
    scheme: Scheme,
    linear: bool,
    parallel: bool,
    levels: Vec<Topology>,
    rules: Vec<Rules>,
    /// Face-varying vertex of the control level → index into the channel's values.
    value_of: Vec<u32>,
    /// One more than the largest value index used.
    values_needed: usize,
}

impl FaceVaryingRefiner {
    /// Builds the channel's topology from its per-corner `indices` and refines it like
    /// `refiner`.
    pub fn new(
        refiner: &Refiner,
        indices: &[u32],
        interpolation: FvarInterpolation,
    ) -> Result<FaceVaryingRefiner, RefineError> {
        let mesh = &refiner.levels[0].topo;
        let mesh_features = &refiner.levels[0].features;
        let (top, value_of, mesh_vertex) = control(mesh, indices)?;
        let linear = interpolation == FvarInterpolation::Linear;
        let opts = refiner.options();
        let features = if linear {
            Features::default()
        } else {
            initial_features(mesh, mesh_features, &top, &mesh_vertex, interpolation, opts.boundary)
        };
        // Chart corners (a boundary vertex with one face in its chart) are pinned at every
        // level in every mode but `Smooth`, whatever the mesh's own boundary rule; in
        // `Smooth` only the mesh's corners are, and `initial_features` pins those.
        let fvar_boundary = if interpolation == FvarInterpolation::Smooth {
            BoundaryInterpolation::EdgeOnly
        } else {
            BoundaryInterpolation::EdgeAndCorner
        };
        let mut levels = vec![top];
        let mut rules = Vec::new();
        let mut feats = features;
        for l in 0..refiner.levels() {
            let last = l + 1 == refiner.levels();
            let p = &levels[l];
            let detail = match (last, linear) {
                (true, _) => Detail::Faces,
                (false, true) => Detail::Edges,
                (false, false) => Detail::Full,
            };
            if !linear {
                let (r, child) = crease::refine_features(p, &feats, opts.creasing, fvar_boundary);
                rules.push(r);
                feats = child;
            }
            let child = super::split(opts.scheme, p, detail, opts.parallel)?;
            levels.push(child);
        }
        let values_needed = indices.iter().map(|&i| i as usize + 1).max().unwrap_or(0);
        Ok(FaceVaryingRefiner {
            scheme: opts.scheme,
            linear,
            parallel: opts.parallel,
            levels,
            rules,
            value_of,
            values_needed,
        })
    }

    /// The finest level's per-corner indices (parallel to the refined mesh's faces).
    pub fn indices(&self) -> &[u32] {
        &self.levels.last().expect("level 0 always exists").face_verts
    }

    /// Number of distinct face-varying values at the finest level.
    pub fn value_count(&self) -> usize {
        self.levels.last().expect("level 0 always exists").vertex_count()
    }

    /// Number of face-varying vertices of the control level (values split at seams).
    pub fn control_value_count(&self) -> usize {
        self.value_of.len()
    }

    /// Interpolates the channel's `values` (indexed by the control mesh's indices) to the
    /// finest level's values, indexed by [`FaceVaryingRefiner::indices`].
    pub fn interpolate_values<T: Primvar>(&self, values: &[T]) -> Result<Vec<T>, RefineError> {
        if values.len() < self.values_needed {
            return Err(RefineError::WrongLength {
                what: "face-varying values",
                expected: self.values_needed,
                got: values.len(),
            });
        }
        let none = Rules::default();
        let mut cur: Vec<T> = try_with_capacity(self.value_of.len(), "face-varying values")?;
        cur.extend(self.value_of.iter().map(|&i| values[i as usize]));
        for l in 0..self.levels.len() - 1 {
            let mut next = try_uninit_vec(self.levels[l + 1].vertex_count(), "face-varying values")?;
            let rules = self.rules.get(l).unwrap_or(&none);
            interpolate_into(
                self.scheme,
                self.linear,
                &self.levels[l],
                rules,
                &cur,
                &mut next,
                self.parallel,
            );
            // SAFETY: the kernels write every child value.
            cur = unsafe { into_init(next) };
        }
        Ok(cur)
    }

    /// Interpolates the channel's `values` (indexed by the control mesh's indices) to the
    /// finest level, with the finest indices.
    pub fn interpolate<T: Primvar>(&self, values: &[T]) -> Result<FaceVarying<T>, RefineError> {
        let values = self.interpolate_values(values)?;
        Ok(FaceVarying { values, indices: try_to_vec(self.indices(), "face-varying indices")? })
    }
}

/// The control level of a face-varying channel with per-corner `indices` on the mesh's
/// control level `mesh`: its topology (one vertex per (vertex, value, fan)), the value
/// index of each of its vertices, and the mesh vertex of each.
fn control(mesh: &Topology, indices: &[u32]) -> Result<(Topology, Vec<u32>, Vec<u32>), RefineError> {
    let nc = mesh.corner_count();
    if indices.len() != nc {
        return Err(RefineError::WrongLength {
            what: "face-varying indices",
            expected: nc,
            got: indices.len(),
        });
    }
    // Union–find over corners of the same vertex, across non-seam interior edges.
    let mut parent: Vec<u32> = (0..nc as u32).collect();
    fn root(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let g = parent[parent[x as usize] as usize];
            parent[x as usize] = g;
            x = g;
        }
        x
    }
    for c in 0..nc as u32 {
        let e = mesh.face_edges[c as usize] as usize;
        let [c0, c1] = mesh.edge_corners[e];
        if c1 == NONE || c0 != c {
            continue;
        }
        let seam = indices[c0 as usize] != indices[mesh.next(c1) as usize]
            || indices[mesh.next(c0) as usize] != indices[c1 as usize];
        if !seam {
            // c0 (at a) pairs with the corner at a in c1's face, and likewise at b.
            for (x, y) in [(c0, mesh.next(c1)), (mesh.next(c0), c1)] {
                let (rx, ry) = (root(&mut parent, x), root(&mut parent, y));
                if rx != ry {
                    let (lo, hi) = (rx.min(ry), rx.max(ry));
                    parent[hi as usize] = lo;
                }
            }
        }
    }
    let mut id_of_root = vec![NONE; nc];
    let mut ids = vec![0u32; nc];
    let mut value_of = Vec::new();
    let mut mesh_vertex = Vec::new();
    for c in 0..nc as u32 {
        let r = root(&mut parent, c) as usize;
        if id_of_root[r] == NONE {
            id_of_root[r] = value_of.len() as u32;
            value_of.push(indices[c as usize]);
            mesh_vertex.push(mesh.face_verts[c as usize]);
        }
        ids[c as usize] = id_of_root[r];
    }
    let offsets: Vec<u32> = (0..=mesh.face_count())
        .map(|f| if f == mesh.face_count() { nc as u32 } else { mesh.corners(f).start as u32 })
        .collect();
    let top = Topology::from_faces(value_of.len(), &offsets, &ids)?;
    Ok((top, value_of, mesh_vertex))
}

/// The element counts of the control level of a channel with `indices` on `control`
/// (for the memory estimate, [`super::peak_memory`]).
pub(super) fn control_counts(
    mesh: &super::Control,
    indices: &[u32],
) -> Result<super::memory::Counts, RefineError> {
    let (top, _, _) = control(&mesh.topo, indices)?;
    let sharp = top.boundary_edges().len() + mesh.features.creases.len();
    Ok(super::memory::Counts::of(&top, sharp))
}

/// Sharp features of the control level of a smooth face-varying channel: the mesh's
/// creases and corners, plus the chart-boundary vertices that `interpolation` pins
/// (OpenSubdiv `Vtr::FVarLevel::completeTopologyFromFaceValues`; "values" there are our
/// face-varying vertices, "siblings" the values of one mesh vertex).
fn initial_features(
    mesh: &Topology,
    mesh_features: &Features,
    top: &Topology,
    mesh_vertex: &[u32],
    interpolation: FvarInterpolation,
    mesh_boundary_rule: BoundaryInterpolation,
) -> Features {
    let boundary = top.boundary_edges();
    let mut creases = Vec::new();
    // A chart with an infinitely sharp crease running into its vertex is "disjoint" in
    // OpenSubdiv's terms: it is a corner there, and with CORNERS_PLUS1/2 so are the other
    // values of a two-chart vertex.
    let mut disjoint = vec![false; top.vertex_count()];
    for fe in 0..top.edge_count() {
        let [c0, c1] = top.edge_corners[fe];
        if c1 == NONE {
            continue;
        }
        let s = mesh_features.edge_sharpness(mesh.face_edges[c0 as usize]);
        if s > 0.0 {
            creases.push((fe as u32, s));
        }
        if s >= INFINITE {
            for v in top.edge_verts[fe] {
                disjoint[v as usize] = true;
            }
        }
    }
    let mut on_boundary = vec![false; top.vertex_count()];
    for &e in &boundary {
        for v in top.edge_verts[e as usize] {
            on_boundary[v as usize] = true;
        }
    }
    let mut mesh_on_boundary = vec![false; mesh.vertex_count()];
    for e in mesh.boundary_edges() {
        for v in mesh.edge_verts[e as usize] {
            mesh_on_boundary[v as usize] = true;
        }
    }
    // Per mesh vertex: number of values, and whether any of its values is disjoint or a
    // chart corner (one face).
    let mut siblings = vec![0u32; mesh.vertex_count()];
    let mut any_disjoint = vec![false; mesh.vertex_count()];
    let mut any_chart_corner = vec![false; mesh.vertex_count()];
    for (fv, &v) in mesh_vertex.iter().enumerate() {
        siblings[v as usize] += 1;
        any_disjoint[v as usize] |= disjoint[fv];
        any_chart_corner[v as usize] |= on_boundary[fv] && top.vertex_corners(fv).len() == 1;
    }
    let mut corners = Vec::new();
    for (fv, &v) in mesh_vertex.iter().enumerate() {
        let inherited = match mesh_features.corners.binary_search_by_key(&v, |x| x.0) {
            Ok(i) => mesh_features.corners[i].1,
            Err(_) => 0.0,
        };
        let vi = v as usize;
        let two_charts_sharp = siblings[vi] == 2 && any_disjoint[vi];
        let dart = siblings[vi] == 1 && !mesh_on_boundary[vi];
        let pinned = on_boundary[fv]
            && match interpolation {
                FvarInterpolation::Linear | FvarInterpolation::Boundaries => true,
                FvarInterpolation::CornersPlus => siblings[vi] >= 3 || two_charts_sharp,
                FvarInterpolation::CornersPlus2 => {
                    siblings[vi] >= 3
                        || two_charts_sharp
                        || dart
                        || (siblings[vi] == 2 && any_chart_corner[vi])
                }
                FvarInterpolation::CornersOnly => false,
                // The mesh's own corners keep the mesh's (corner) rule.
                FvarInterpolation::Smooth => match mesh_boundary_rule {
                    BoundaryInterpolation::EdgeAndCorner => {
                        mesh_on_boundary[vi] && mesh.vertex_corners(vi).len() == 1
                    }
                    BoundaryInterpolation::Fixed => mesh_on_boundary[vi],
                    BoundaryInterpolation::EdgeOnly => false,
                },
            };
        let s = if pinned { INFINITE } else { inherited };
        if s > 0.0 {
            corners.push((fv as u32, s));
        }
    }
    Features { creases, corners, boundary }
}
