//! Subdivision surfaces: Loop and Catmull–Clark refinement with boundaries, sharp and
//! semi-sharp creases, corners, face-varying UVs and limit positions and normals.
//!
//! ```text
//!  Mesh + corners ─► Topology::from_faces ─► split ─► split ─► …   (Refiner::new: topology once)
//!                      (validate, edges)      │ rules per level (crease.rs)
//!  positions, colours, weights ──────────────►├─ Refiner::interpolate        (any Primvar, any count)
//!  UV indices ─► FaceVaryingRefiner ─────────►├─ FaceVaryingRefiner::interpolate
//!                                             └─ Refiner::limit / limit_normals (limit.rs)
//! ```
//!
//! The split follows OpenSubdiv: the [`Refiner`] refines the **topology** once per level
//! (adjacency, sharpness and the masks that creases change), then any number of
//! per-vertex value sets ([`Primvar`]: `f32`, `Vec2`, `Vec3`, `Vec4`, `[f32; N]`) are
//! interpolated through it; wind animation changes positions every frame, topology never
//! (architecture: "Refiner"). Face-varying channels get their own topology
//! ([`FaceVaryingRefiner`]) whose seams are boundaries, so seams stay exact.
//!
//! Schemes: [`loop_`] (Pieterse2012 §4.4, MacMurchy2004 §3.3; Pieterse2012-spec §2.8, MacMurchy2004-spec §2.10) and
//! [`catmull_clark`] (Skjermo2008 §5; Skjermo2008-spec §5). Creases, corners and boundaries:
//! [`crease`] (DeRose–Kass–Truong / OpenSubdiv rules, MacMurchy2004 §2.10). Limit surface:
//! [`limit`] (MacMurchy2004 §2.11 "move to limit surface"). Adaptive Loop refinement:
//! [`adaptive`] (MacMurchy2004 §A.3). PN triangles and quads: [`pn`] (Skjermo2008 §3.3.1).
//! Fractal noise between levels: [`noise`] (MacMurchy2004 §6.5).
//! The policy of one mesh's subdivision as a front end asks it (the scheme for the
//! mesh, the rules from its tags, the combinations refused): [`policy`].
//!
//! Every level is computed in parallel with rayon over child elements, each child value
//! written by exactly one task with a fixed summation order, so the output is
//! bit-identical for any thread count (and with [`RefineOptions::parallel`] off).

pub mod adaptive;
mod buffers;
pub mod catmull_clark;
pub mod crease;
pub mod fvar;
pub mod limit;
pub mod loop_;
mod memory;
pub mod noise;
mod options;
pub mod pn;
pub mod policy;
mod threads;
pub mod topology;

pub(crate) use buffers::*;
pub use crease::{Corner, INFINITE};
pub use fvar::FaceVaryingRefiner;
pub use options::{
    BoundaryInterpolation, CreasingMethod, FvarInterpolation, RefineError, RefineOptions, Scheme,
    DEFAULT_MAX_FACES, DEFAULT_MAX_MEMORY,
};
pub use threads::{start_global_threads, with_threads, ThreadsError, MAX_THREADS};
pub use topology::{Ring, Topology, NONE};

use crate::geometry::{Crease, FaceVarying, Mesh};
use crease::{Features, Rules};
use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;
use std::mem::MaybeUninit;
use topology::Detail;

/// A value that can be interpolated through a [`Refiner`]: positions, UVs, colours, skin
/// weights. Masks are affine combinations computed in `f32`.
pub trait Primvar: Copy + Send + Sync + 'static {
    /// The additive identity.
    fn zero() -> Self;
    /// `self + other`.
    fn add(self, other: Self) -> Self;
    /// `self · w`.
    fn scale(self, w: f32) -> Self;
}

macro_rules! glam_primvar {
    ($($t:ty),*) => {$(
        impl Primvar for $t {
            #[inline]
            fn zero() -> Self { <$t>::ZERO }
            #[inline]
            fn add(self, o: Self) -> Self { self + o }
            #[inline]
            fn scale(self, w: f32) -> Self { self * w }
        }
    )*};
}
glam_primvar!(Vec2, Vec3, Vec4);

impl Primvar for f32 {
    #[inline]
    fn zero() -> Self {
        0.0
    }
    #[inline]
    fn add(self, o: Self) -> Self {
        self + o
    }
    #[inline]
    fn scale(self, w: f32) -> Self {
        self * w
    }
}

impl<const N: usize> Primvar for [f32; N] {
    #[inline]
    fn zero() -> Self {
        [0.0; N]
    }
    #[inline]
    fn add(mut self, o: Self) -> Self {
        for (a, b) in self.iter_mut().zip(o) {
            *a += b;
        }
        self
    }
    #[inline]
    fn scale(mut self, w: f32) -> Self {
        for a in &mut self {
            *a *= w;
        }
        self
    }
}

/// Interpolates one level of `scheme` into uninitialised `dst`, writing all of it.
pub(crate) fn interpolate_into<T: Primvar>(
    scheme: Scheme,
    linear: bool,
    p: &Topology,
    rules: &Rules,
    src: &[T],
    dst: &mut [MaybeUninit<T>],
    par: bool,
) {
    match (scheme, linear) {
        (Scheme::Loop, false) => loop_::interpolate(p, rules, src, dst, par),
        (Scheme::CatmullClark, false) => catmull_clark::interpolate(p, rules, src, dst, par),
        (Scheme::Loop, true) => loop_::interpolate_linear(p, src, dst, par),
        (Scheme::CatmullClark, true) => catmull_clark::interpolate_linear(p, src, dst, par),
    }
}

/// Writes the corners beside the two halves of every parent edge (`halves`: two child
/// edges per parent edge, from its first vertex, then from its second):
/// `ends(ck)` gives the child corners at the start and the end of parent corner `ck`'s
/// side of the edge; a missing side stays [`NONE`].
pub(crate) fn fill_half_edge_corners(
    p: &Topology,
    halves: &mut [[u32; 2]],
    par: bool,
    ends: impl Fn(u32) -> (u32, u32) + Sync,
) {
    fill_chunks(par, halves, 2, |e, out| {
        let a = p.edge_verts[e][0];
        for (k, &ck) in p.edge_corners[e].iter().enumerate() {
            if ck == NONE {
                out[0][k] = NONE;
                out[1][k] = NONE;
                continue;
            }
            let (at_start, at_end) = ends(ck);
            if p.face_verts[ck as usize] == a {
                out[0][k] = at_start;
                out[1][k] = at_end;
            } else {
                out[1][k] = at_start;
                out[0][k] = at_end;
            }
        }
    });
}

/// The child level's vertex → corner offsets, shared by both schemes: vertex points keep
/// their parent's count, then (Catmull–Clark, `face_points`) each face point has one per
/// corner of its face, then each edge point `per_side` per face along the edge.
pub(crate) fn child_corner_offsets(
    p: &Topology,
    child_verts: u32,
    face_points: bool,
    per_side: u32,
) -> Result<Vec<u32>, RefineError> {
    let mut off = try_with_capacity(child_verts as usize + 1, "vertex corner offsets")?;
    off.push(0u32);
    let mut acc = 0u32;
    for v in 0..p.num_verts as usize {
        acc += p.vert_corner_offsets[v + 1] - p.vert_corner_offsets[v];
        off.push(acc);
    }
    if face_points {
        for f in 0..p.num_faces as usize {
            acc += p.corners(f).len() as u32;
            off.push(acc);
        }
    }
    for e in 0..p.edge_count() {
        acc += per_side * (1 + (p.edge_corners[e][1] != NONE) as u32);
        off.push(acc);
    }
    Ok(off)
}

/// Writes the corners of every edge point into `evs`, edge by edge: the `N` child
/// corners `corners(ck)` of each parent corner `ck` along the edge (one on a boundary).
pub(crate) fn fill_edge_point_corners<const N: usize>(
    p: &Topology,
    evs: &mut [u32],
    par: bool,
    corners: impl Fn(u32) -> [u32; N] + Sync,
) {
    if evs.len() == 2 * N * p.edge_count() {
        // No boundary: every edge point has 2N corners.
        fill_chunks(par, evs, 2 * N, |e, out| {
            let [c0, c1] = p.edge_corners[e];
            out[..N].copy_from_slice(&corners(c0));
            out[N..].copy_from_slice(&corners(c1));
        });
    } else {
        let mut k = 0;
        for e in 0..p.edge_count() {
            for ck in p.edge_corners[e] {
                if ck != NONE {
                    evs[k..k + N].copy_from_slice(&corners(ck));
                    k += N;
                }
            }
        }
    }
}

/// Applies a level's crease rules to the smooth child values both schemes computed:
/// each special edge point blends the edge's midpoint by its weight, then each special
/// vertex gets [`apply_vertex_specials`].
pub(crate) fn apply_specials<T: Primvar>(rules: &Rules, p: &Topology, src: &[T], ep: &mut [T], vv: &mut [T]) {
    for &(e, w) in &rules.edge_specials {
        let [a, b] = p.edge_verts[e as usize];
        let mid = src[a as usize].add(src[b as usize]).scale(0.5);
        let smooth = ep[e as usize];
        ep[e as usize] = mid.scale(w).add(smooth.scale(1.0 - w));
    }
    apply_vertex_specials(rules, src, vv);
}

/// The linear part both schemes share for face-varying data: vertices kept (`vv`) and
/// edge midpoints (`ep`), all written.
pub(crate) fn interpolate_linear_edges<T: Primvar>(
    p: &Topology,
    src: &[T],
    vv: &mut [MaybeUninit<T>],
    ep: &mut [MaybeUninit<T>],
    par: bool,
) {
    for (d, s) in vv.iter_mut().zip(src) {
        d.write(*s);
    }
    fill(par, ep, |e, out| {
        let [a, b] = p.edge_verts[e];
        out.write(src[a as usize].add(src[b as usize]).scale(0.5));
    });
}

/// Overwrites the crease and corner vertices:
/// `w_vertex·v + w_pair·(a + b) + smooth·(smooth value)`. The pair is summed first, and
/// `a + b` is commutative in floating point, so both sides of a face-varying seam (which
/// see the same values in a different order) get bit-identical results.
pub(crate) fn apply_vertex_specials<T: Primvar>(rules: &Rules, src: &[T], vv: &mut [T]) {
    for s in &rules.vertex_specials {
        let v = s.vertex as usize;
        let mut out = src[v].scale(s.w_vertex);
        if s.w_pair != 0.0 {
            out = out.add(src[s.pair[0] as usize].add(src[s.pair[1] as usize]).scale(s.w_pair));
        }
        if s.smooth != 0.0 {
            out = out.add(vv[v].scale(s.smooth));
        }
        vv[v] = out;
    }
}

/// One refinement level: its adjacency and sharp features.
#[derive(Debug, Clone)]
pub(crate) struct Level {
    pub topo: Topology,
    pub features: Features,
}

/// Splits `p` with `scheme` ([`RefineError::OutOfMemory`] when an array cannot be
/// allocated).
pub(crate) fn split(
    scheme: Scheme,
    p: &Topology,
    detail: Detail,
    par: bool,
) -> Result<Topology, RefineError> {
    match scheme {
        Scheme::Loop => loop_::split(p, detail, par),
        Scheme::CatmullClark => catmull_clark::split(p, detail, par),
    }
}

/// Faces after `levels` steps of `scheme` (saturating).
pub fn output_face_count(scheme: Scheme, faces: usize, corners: usize, levels: u32) -> u128 {
    match scheme {
        Scheme::Loop => loop_::face_count(faces, levels),
        Scheme::CatmullClark => catmull_clark::face_count(faces, corners, levels),
    }
}

/// Uniform refinement of a control mesh's topology, OpenSubdiv-style: built once, then
/// used to interpolate any number of value sets.
///
/// ```
/// use sylva::refine::{Refiner, RefineOptions, Scheme};
/// # use sylva::Mesh; use glam::Vec3;
/// let mut quad = Mesh::new();
/// quad.positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
/// quad.push_face(&[0, 1, 2, 3]);
/// let opts = RefineOptions { scheme: Scheme::CatmullClark, levels: 2, ..Default::default() };
/// let refiner = Refiner::new(&quad, &[], &opts).unwrap();
/// let fine = refiner.interpolate(&quad.positions).unwrap();
/// assert_eq!(refiner.finest().face_count(), 16);
/// assert_eq!(fine.len(), refiner.finest().vertex_count());
/// ```
#[derive(Debug, Clone)]
pub struct Refiner {
    options: RefineOptions,
    levels: Vec<Level>,
    rules: Vec<Rules>,
}

impl Refiner {
    /// Validates `mesh` (manifold, consistently oriented; triangles for Loop), reads its
    /// creases (`mesh.creases`) and the vertex sharpness in `corners`, checks the face
    /// budget and refines the topology `options.levels` times. Positions are not read.
    ///
    /// Its estimated peak memory — the levels' topology and one `Vec3` value set
    /// interpolated through them ([`peak_memory`] counts what [`subdivide`] adds) — is
    /// checked against [`RefineOptions::max_memory`] after the control level is built and
    /// before any refined level is allocated ([`RefineError::Memory`]); the levels' arrays
    /// are then reserved fallibly, so a system with less memory than the limit gives
    /// [`RefineError::OutOfMemory`] instead of an abort.
    pub fn new(mesh: &Mesh, corners: &[Corner], options: &RefineOptions) -> Result<Refiner, RefineError> {
        let control = Control::new(mesh, corners, options)?;
        control.check_memory(options, control.peak(options, &PeakParts::default()))?;
        Refiner::refine(control, options)
    }

    /// Refines the checked control level `options.levels` times.
    fn refine(control: Control, options: &RefineOptions) -> Result<Refiner, RefineError> {
        let mut levels = vec![Level { topo: control.topo, features: control.features }];
        let mut rules = Vec::new();
        for l in 0..options.levels {
            if crate::cancel::cancelled() {
                return Err(RefineError::Cancelled { level: l + 1 });
            }
            let last = l + 1 == options.levels;
            let parent = &levels[l as usize];
            let (r, child_features) =
                crease::refine_features(&parent.topo, &parent.features, options.creasing, options.boundary);
            let detail = if last && !options.full_last_level { Detail::Faces } else { Detail::Full };
            let topo = split(options.scheme, &parent.topo, detail, options.parallel)?;
            rules.push(r);
            levels.push(Level { topo, features: child_features });
        }
        Ok(Refiner { options: options.clone(), levels, rules })
    }

    /// The options it was built with.
    pub fn options(&self) -> &RefineOptions {
        &self.options
    }

    /// Number of refinement levels (0 = the control mesh only).
    pub fn levels(&self) -> usize {
        self.levels.len() - 1
    }

    /// The topology of level `l` (0 = control mesh).
    pub fn level(&self, l: usize) -> &Topology {
        &self.levels[l].topo
    }

    /// The finest level's topology.
    pub fn finest(&self) -> &Topology {
        &self.levels.last().expect("level 0 always exists").topo
    }

    /// Interpolates per-vertex values of the control mesh to the finest level.
    pub fn interpolate<T: Primvar>(&self, control: &[T]) -> Result<Vec<T>, RefineError> {
        let expected = self.level(0).vertex_count();
        if control.len() != expected {
            return Err(RefineError::WrongLength { what: "control values", expected, got: control.len() });
        }
        let mut cur = try_to_vec(control, "interpolated values")?;
        for l in 0..self.levels() {
            if crate::cancel::cancelled() {
                return Err(RefineError::Cancelled { level: l as u32 + 1 });
            }
            let p = &self.levels[l].topo;
            let mut next = try_uninit_vec(self.level(l + 1).vertex_count(), "interpolated values")?;
            interpolate_into(
                self.options.scheme,
                false,
                p,
                &self.rules[l],
                &cur,
                &mut next,
                self.options.parallel,
            );
            // SAFETY: the kernels write every child value.
            cur = unsafe { into_init(next) };
        }
        Ok(cur)
    }

    /// Interpolates values of level `l` (`src`, one per vertex) into level `l + 1` (`dst`).
    ///
    /// # Panics
    /// If the slice lengths do not match the two levels' vertex counts.
    pub fn interpolate_level<T: Primvar>(&self, l: usize, src: &[T], dst: &mut [T]) {
        let p = &self.levels[l].topo;
        assert_eq!(src.len(), p.vertex_count(), "source values of level {l}");
        assert_eq!(
            dst.len(),
            self.levels[l + 1].topo.vertex_count(),
            "destination values of level {}",
            l + 1
        );
        // SAFETY: the kernel only writes valid values into `dst`.
        let dst = unsafe { &mut *(dst as *mut [T] as *mut [MaybeUninit<T>]) };
        interpolate_into(self.options.scheme, false, p, &self.rules[l], src, dst, self.options.parallel);
    }

    /// Builds the refined topology of a face-varying channel with `indices` (one per
    /// control-mesh corner) and the given interpolation.
    pub fn face_varying(
        &self,
        indices: &[u32],
        interpolation: FvarInterpolation,
    ) -> Result<FaceVaryingRefiner, RefineError> {
        FaceVaryingRefiner::new(self, indices, interpolation)
    }

    /// Pushes finest-level values to their limit positions (MacMurchy2004 §2.11; needs
    /// [`RefineOptions::full_last_level`]).
    pub fn limit<T: Primvar>(&self, finest: &[T]) -> Result<Vec<T>, RefineError> {
        let level = self.levels.last().expect("level 0 always exists");
        limit::limit_positions(
            self.options.scheme,
            self.options.boundary,
            &level.topo,
            &level.features,
            finest,
            self.options.parallel,
        )
    }

    /// Exact limit normals of the finest level, face-varying: one value per vertex on
    /// smooth vertices, one per sector on creases, corners and boundaries (needs
    /// [`RefineOptions::full_last_level`]). `finest_positions` are the interpolated
    /// positions of the finest level (before [`Refiner::limit`]): the tangent masks apply
    /// to them.
    pub fn limit_normals(&self, finest_positions: &[Vec3]) -> Result<FaceVarying<Vec3>, RefineError> {
        let level = self.levels.last().expect("level 0 always exists");
        limit::limit_normals(
            self.options.scheme,
            self.options.boundary,
            &level.topo,
            &level.features,
            finest_positions,
        )
    }

    /// The creases still sharp at the finest level, as vertex pairs (so a refined mesh can
    /// be refined again with the same result).
    pub fn finest_creases(&self) -> Vec<Crease> {
        let n = self.levels.len();
        let last = &self.levels[n - 1];
        if n == 1 {
            return last
                .features
                .creases
                .iter()
                .map(|&(e, s)| {
                    let [a, b] = last.topo.edge_verts[e as usize];
                    Crease { a, b, sharpness: s }
                })
                .collect();
        }
        // Child crease edges are always halves of parent edges: 2e at edge_verts[e][0].
        let parent = &self.levels[n - 2].topo;
        let ev_base = match self.options.scheme {
            Scheme::Loop => parent.num_verts,
            Scheme::CatmullClark => parent.num_verts + parent.num_faces,
        };
        last.features
            .creases
            .iter()
            .map(|&(h, s)| {
                let e = h / 2;
                let [a, b] = parent.edge_verts[e as usize];
                let mid = ev_base + e;
                let (a, b) = if h % 2 == 0 { (a, mid) } else { (mid, b) };
                let sharpness = if s >= INFINITE { f32::INFINITY } else { s };
                Crease { a, b, sharpness }
            })
            .collect()
    }

    /// The face of level `l` that face `child` of level `l + 1` was cut from: Loop numbers
    /// the four children of triangle `f` `4f..4f + 4`; Catmull–Clark's child face `c` is
    /// the child of parent corner `c`, so it lies in the face that holds that corner
    /// (`4f..4f + 4` only when every face is a quad).
    pub fn parent_face(&self, l: usize, child: u32) -> u32 {
        match self.options.scheme {
            Scheme::Loop => child / 4,
            Scheme::CatmullClark => self.levels[l].topo.face_of(child),
        }
    }

    /// For every face of the finest level, the control-mesh face it descends from (how a
    /// mesher maps refined faces back to its skeleton nodes without refining twice).
    pub fn control_faces(&self) -> Vec<u32> {
        let mut up: Vec<u32> = (0..self.finest().face_count() as u32).collect();
        self.control_faces_into(&mut up);
        up
    }

    /// [`Refiner::control_faces`] with a fallible allocation.
    fn try_control_faces(&self) -> Result<Vec<u32>, RefineError> {
        let n = self.finest().face_count();
        let mut up = try_with_capacity(n, "control faces")?;
        up.extend(0..n as u32);
        self.control_faces_into(&mut up);
        Ok(up)
    }

    /// Maps finest faces `up` to their control faces, in place.
    fn control_faces_into(&self, up: &mut [u32]) {
        for l in (0..self.levels()).rev() {
            for f in up.iter_mut() {
                *f = self.parent_face(l, *f);
            }
        }
    }

    /// The finest level's faces as a [`Mesh`] with `positions` (no face-varying data).
    pub fn finest_mesh(&self, positions: Vec<Vec3>) -> Mesh {
        let t = self.finest();
        let mut m = Mesh::new();
        m.positions = positions;
        m.face_indices = t.face_verts.clone();
        m.face_offsets = if t.face_size > 0 {
            (0..=t.num_faces).map(|f| f * t.face_size).collect()
        } else {
            t.face_offsets.clone()
        };
        m.creases = self.finest_creases();
        m
    }

    /// [`Refiner::finest_mesh`] with fallible allocations of the big arrays.
    fn try_finest_mesh(&self, positions: Vec<Vec3>) -> Result<Mesh, RefineError> {
        let t = self.finest();
        let mut m = Mesh::new();
        m.positions = positions;
        m.face_indices = try_to_vec(&t.face_verts, "refined face indices")?;
        m.face_offsets = if t.face_size > 0 {
            let mut o = try_with_capacity(t.num_faces as usize + 1, "refined face offsets")?;
            o.extend((0..=t.num_faces).map(|f| f * t.face_size));
            o
        } else {
            try_to_vec(&t.face_offsets, "refined face offsets")?
        };
        m.creases = self.finest_creases();
        Ok(m)
    }
}

/// A checked control level: its adjacency and sharp features, before refinement.
struct Control {
    topo: Topology,
    features: Features,
}

impl Control {
    /// Validates `mesh`, checks the face budget and builds level 0.
    fn new(mesh: &Mesh, corners: &[Corner], options: &RefineOptions) -> Result<Control, RefineError> {
        let n_faces = mesh.face_count();
        if options.scheme == Scheme::Loop {
            if let Some(f) = (0..n_faces).find(|&f| mesh.face(f).len() != 3) {
                return Err(RefineError::NotTriangles { face: f, corners: mesh.face(f).len() });
            }
        }
        let out = output_face_count(options.scheme, n_faces, mesh.face_indices.len(), options.levels);
        if out > options.max_faces as u128 {
            return Err(RefineError::Budget { levels: options.levels, faces: out, limit: options.max_faces });
        }
        // Indices must fit in u32 at the finest level (vertices ≈ faces + corners).
        if out.saturating_mul(2) + mesh.positions.len() as u128 >= NONE as u128 {
            return Err(RefineError::TooLarge { what: "refined mesh", count: out as usize });
        }
        let topo = Topology::from_faces(mesh.positions.len(), &mesh.face_offsets, &mesh.face_indices)?;
        let features = control_features(&topo, &mesh.creases, corners)?;
        Ok(Control { topo, features })
    }

    /// The element counts of level 0.
    fn counts(&self) -> memory::Counts {
        memory::Counts::of(&self.topo, self.features.creases.len() + self.features.boundary.len())
    }

    /// The estimated peak of refining it with `options` and `parts`.
    fn peak(&self, options: &RefineOptions, parts: &PeakParts) -> u128 {
        memory::peak(options, self.counts(), self.topo.face_size == 0, parts)
    }

    /// [`RefineError::Memory`] when `bytes` is over the options' limit.
    fn check_memory(&self, options: &RefineOptions, bytes: u128) -> Result<(), RefineError> {
        if bytes > options.max_memory as u128 {
            let faces = output_face_count(
                options.scheme,
                self.topo.face_count(),
                self.topo.corner_count(),
                options.levels,
            );
            return Err(RefineError::Memory {
                levels: options.levels,
                faces,
                bytes,
                limit: options.max_memory,
            });
        }
        Ok(())
    }
}

/// What a refinement holds at its peak besides its levels' topology and one `Vec3`
/// value set (the input of [`peak_memory`]'s estimate).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct PeakParts {
    /// Face-varying UVs: their control level's counts and interpolation.
    uvs: Option<(memory::Counts, FvarInterpolation)>,
    /// Limit positions and normals.
    limit: bool,
    /// The refined [`Mesh`] and the control face of every refined face, as
    /// [`subdivide_traced`] returns them.
    output: bool,
}

/// The estimated peak memory, in bytes, of [`subdivide`] (and [`subdivide_traced`]) on
/// `mesh` with `options`: every level's adjacency and sharp features, the positions
/// interpolated level by level, the limit positions and normals, the face-varying UV
/// channel's own levels and values, and the refined [`Mesh`] with its control faces, at
/// the point where most of them are alive at once. It is an upper bound, within about
/// a third, of what the allocations measure (`tests/robustness_memory.rs`); about 85
/// bytes per refined Catmull–Clark face without UVs or limit, 160 with UVs, 270 with
/// both (Loop: about 60, 110 and 190 per refined triangle). Builds the control level
/// (and its UV channel's) to count its edges and seams, so it errs as [`subdivide`]
/// does on an invalid mesh or a face budget exceeded.
pub fn peak_memory(mesh: &Mesh, corners: &[Corner], options: &SubdivideOptions) -> Result<u128, RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    let mut ro = options.refine.clone();
    ro.full_last_level |= options.limit;
    let control = Control::new(mesh, corners, &ro)?;
    let parts = subdivide_parts(mesh, &control, options)?;
    Ok(control.peak(&ro, &parts))
}

/// What [`subdivide_traced`] adds to the refiner's peak for `mesh`.
fn subdivide_parts(
    mesh: &Mesh,
    control: &Control,
    options: &SubdivideOptions,
) -> Result<PeakParts, RefineError> {
    let uvs = match &mesh.uvs {
        Some(uvs) => Some((fvar::control_counts(control, &uvs.indices)?, options.uv)),
        None => None,
    };
    Ok(PeakParts { uvs, limit: options.limit, output: true })
}

/// Reads the control mesh's tagged creases and vertex sharpness into sparse feature lists
/// (sharpness ≥ [`INFINITE`], including `f32::INFINITY`, is infinitely sharp).
fn control_features(
    topo: &Topology,
    creases: &[Crease],
    corners: &[Corner],
) -> Result<Features, RefineError> {
    let boundary = topo.boundary_edges();
    let mut ec: Vec<(u32, f32)> = Vec::with_capacity(creases.len());
    for c in creases {
        if c.sharpness.is_nan() || c.sharpness < 0.0 {
            return Err(RefineError::BadSharpness {
                what: format!("crease {}–{}", c.a, c.b),
                sharpness: c.sharpness,
            });
        }
        let e = topo.find_edge(c.a, c.b).ok_or(RefineError::CreaseNotAnEdge { a: c.a, b: c.b })?;
        if c.sharpness > 0.0 && !topo.is_boundary_edge(e as usize) {
            ec.push((e, c.sharpness.min(INFINITE)));
        }
    }
    ec.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
    ec.dedup_by_key(|x| x.0); // a repeated tag: the sharpest wins
    let mut vc: Vec<(u32, f32)> = Vec::with_capacity(corners.len());
    for c in corners {
        if c.sharpness.is_nan() || c.sharpness < 0.0 {
            return Err(RefineError::BadSharpness {
                what: format!("vertex {}", c.vertex),
                sharpness: c.sharpness,
            });
        }
        if c.vertex as usize >= topo.vertex_count() {
            return Err(RefineError::InvalidMesh(format!(
                "corner tag on vertex {}, but there are {} vertices",
                c.vertex,
                topo.vertex_count()
            )));
        }
        if c.sharpness > 0.0 {
            vc.push((c.vertex, c.sharpness.min(INFINITE)));
        }
    }
    // Isolated vertices have no mask: keep them where they are.
    for v in 0..topo.vertex_count() {
        if topo.vertex_corners(v).is_empty() {
            vc.push((v as u32, INFINITE));
        }
    }
    vc.sort_by(|a, b| a.0.cmp(&b.0).then(b.1.total_cmp(&a.1)));
    vc.dedup_by_key(|x| x.0);
    Ok(Features { creases: ec, corners: vc, boundary })
}

/// What [`subdivide`] does beyond the refinement itself.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SubdivideOptions {
    /// Scheme, levels, boundary and crease rules, parallelism, budget.
    pub refine: RefineOptions,
    /// Push the finest vertices to the limit surface and emit exact limit normals.
    pub limit: bool,
    /// How UVs are interpolated (when the mesh has UVs).
    pub uv: FvarInterpolation,
}

/// Subdivides `mesh` (positions, creases, corners, UVs) and returns the refined mesh.
/// Input normals are dropped (they no longer describe the surface); with
/// [`SubdivideOptions::limit`] the result has exact limit normals instead.
pub fn subdivide(mesh: &Mesh, corners: &[Corner], options: &SubdivideOptions) -> Result<Mesh, RefineError> {
    subdivide_traced(mesh, corners, options).map(|(m, _)| m)
}

/// [`subdivide`], also returning the control face of every refined face
/// ([`Refiner::control_faces`]).
pub fn subdivide_traced(
    mesh: &Mesh,
    corners: &[Corner],
    options: &SubdivideOptions,
) -> Result<(Mesh, Vec<u32>), RefineError> {
    mesh.validate().map_err(RefineError::InvalidMesh)?;
    let mut ro = options.refine.clone();
    ro.full_last_level |= options.limit;
    // The whole run's peak is checked before any refined level is allocated.
    let control = Control::new(mesh, corners, &ro)?;
    let parts = subdivide_parts(mesh, &control, options)?;
    control.check_memory(&ro, control.peak(&ro, &parts))?;
    let refiner = Refiner::refine(control, &ro)?;
    // Each pass over the finest level takes seconds on a hero mesh: a cancelled
    // computation stops between them.
    let stop = || {
        if crate::cancel::cancelled() {
            Err(RefineError::Cancelled { level: ro.levels })
        } else {
            Ok(())
        }
    };
    let mut positions = refiner.interpolate(&mesh.positions)?;
    stop()?;
    let mut normals = None;
    if options.limit {
        // Tangent masks apply to the finest control points, not to their limits.
        normals = Some(refiner.limit_normals(&positions)?);
        positions = refiner.limit(&positions)?;
        stop()?;
    }
    let mut out = refiner.try_finest_mesh(positions)?;
    out.normals = normals;
    stop()?;
    if let Some(uvs) = &mesh.uvs {
        let fvr = refiner.face_varying(&uvs.indices, options.uv)?;
        stop()?;
        out.uvs = Some(fvr.interpolate(&uvs.values)?);
    }
    let control_faces = refiner.try_control_faces()?;
    Ok((out, control_faces))
}
