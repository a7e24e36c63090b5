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
pub mod catmull_clark;
pub mod crease;
pub mod fvar;
pub mod limit;
pub mod loop_;
mod memory;
pub mod noise;
pub mod pn;
pub mod policy;
pub mod topology;

pub use crease::{Corner, INFINITE};
pub use fvar::FaceVaryingRefiner;
pub use topology::{Ring, Topology, NONE};

use crate::geometry::{Crease, FaceVarying, Mesh};
use crease::{Features, Rules};
use glam::{Vec2, Vec3, Vec4};
use rayon::prelude::*;
use std::mem::MaybeUninit;
use topology::Detail;

/// The largest output a refinement may produce unless told otherwise (100 M faces).
pub const DEFAULT_MAX_FACES: usize = 100_000_000;

/// The most memory a refinement may need at its peak unless told otherwise
/// ([`RefineOptions::max_memory`]): 4 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;

/// Why a mesh cannot be refined.
#[derive(Debug, Clone, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum RefineError {
    /// More than two faces share an edge.
    #[error("non-manifold edge between vertices {a} and {b}: it is shared by {} faces ({faces:?}); subdivision needs at most 2", faces.len())]
    #[diagnostic(help("split the edge or remove the extra faces"))]
    NonManifoldEdge {
        /// One end.
        a: u32,
        /// The other end.
        b: u32,
        /// The faces sharing it.
        faces: Vec<u32>,
    },
    /// Two faces traverse an edge in the same direction.
    #[error("inconsistent orientation: faces {} and {} both run from vertex {a} to vertex {b}", faces[0], faces[1])]
    #[diagnostic(help("flip one of the faces so that neighbours agree (counter-clockwise from the front)"))]
    InconsistentOrientation {
        /// Start vertex of both half-edges.
        a: u32,
        /// End vertex of both half-edges.
        b: u32,
        /// The two faces.
        faces: [u32; 2],
    },
    /// A vertex whose faces form several separate fans (a "bow-tie").
    #[error("non-manifold vertex {vertex}: its faces form {fans} separate fans")]
    #[diagnostic(help("duplicate the vertex, one copy per fan"))]
    NonManifoldVertex {
        /// The vertex.
        vertex: u32,
        /// How many fans (at least 2).
        fans: usize,
    },
    /// A face with fewer than 3 corners or a repeated vertex.
    #[error("degenerate face {face}: vertices {vertices:?}")]
    DegenerateFace {
        /// The face.
        face: usize,
        /// Its vertices.
        vertices: Vec<u32>,
    },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {vertex}, but there are {count} vertices")]
    VertexOutOfRange {
        /// The face.
        face: usize,
        /// The bad index.
        vertex: u32,
        /// The number of vertices.
        count: usize,
    },
    /// Loop subdivision needs triangles.
    #[error("Loop subdivision needs triangles, but face {face} has {corners} corners")]
    #[diagnostic(help("triangulate the mesh first, or use --scheme catmull-clark"))]
    NotTriangles {
        /// The first non-triangle face.
        face: usize,
        /// Its corner count.
        corners: usize,
    },
    /// A crease tag on two vertices that share no edge.
    #[error("crease between vertices {a} and {b}: they share no edge")]
    CreaseNotAnEdge {
        /// One end.
        a: u32,
        /// The other end.
        b: u32,
    },
    /// A sharpness that is NaN or negative.
    #[error("invalid sharpness {sharpness} on {what}: sharpness must be a number ≥ 0")]
    BadSharpness {
        /// The edge or vertex.
        what: String,
        /// The value.
        sharpness: f32,
    },
    /// The output would exceed the face budget.
    #[error("{levels} levels of subdivision would make {faces} faces, more than the limit of {limit}")]
    #[diagnostic(help("use fewer levels, or raise the limit (RefineOptions::max_faces)"))]
    Budget {
        /// Requested levels.
        levels: u32,
        /// Faces that would be produced.
        faces: u128,
        /// The limit.
        limit: usize,
    },
    /// The refinement would need more memory at its peak than its limit
    /// ([`RefineOptions::max_memory`]); checked before the levels are allocated.
    #[error(
        "{levels} levels of subdivision would make {faces} faces and need about {bytes} bytes at the \
         refinement's peak, more than the memory limit of {limit} bytes"
    )]
    #[diagnostic(help("use fewer levels, or raise the limit (RefineOptions::max_memory)"))]
    Memory {
        /// Requested levels.
        levels: u32,
        /// Faces that would be produced.
        faces: u128,
        /// The estimated peak ([`peak_memory`]).
        bytes: u128,
        /// The limit.
        limit: u64,
    },
    /// An allocation of the refinement failed (the system has less memory than the
    /// estimate allowed for).
    #[error("out of memory: the refinement's {what} need {bytes} bytes, which could not be allocated")]
    #[diagnostic(help(
        "use fewer levels, or lower the memory limit (RefineOptions::max_memory) to what the system has"
    ))]
    OutOfMemory {
        /// The array that could not be allocated.
        what: &'static str,
        /// Its size.
        bytes: u128,
    },
    /// Indices would overflow `u32`.
    #[error("{what} is too large ({count} elements) for 32-bit indices")]
    TooLarge {
        /// What.
        what: &'static str,
        /// How many.
        count: usize,
    },
    /// A value array of the wrong length.
    #[error("{what}: expected {expected} values, got {got}")]
    WrongLength {
        /// Which input.
        what: &'static str,
        /// Expected count.
        expected: usize,
        /// Given count.
        got: usize,
    },
    /// Catmull–Clark limit masks need quads.
    #[error("Catmull–Clark limit positions need an all-quad level; refine at least one level first")]
    LimitNeedsQuads,
    /// Anything else wrong with the input mesh.
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    /// An option out of range (adaptive tolerances, PN level or size, noise parameters).
    #[error("invalid option: {0}")]
    InvalidOption(String),
}

/// The subdivision scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Scheme {
    /// Loop's scheme for triangle meshes (Pieterse2012 and MacMurchy2004).
    Loop,
    /// Catmull–Clark for any polygons; the first level makes quads (Skjermo2008).
    #[default]
    CatmullClark,
}

/// How boundary vertices are treated (OpenSubdiv's `VtxBoundaryInterpolation`, plus Pieterse2012's
/// `Fixed` rule). Boundary edges are always infinitely sharp, so a new boundary
/// vertex is the midpoint of its edge; the rules differ in where an existing boundary
/// vertex goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BoundaryInterpolation {
    /// Boundary edges sharp; a vertex with a single face follows the crease rule too.
    EdgeOnly,
    /// Boundary edges sharp, and vertices with a single face are corners (they stay put);
    /// the rest of the rim follows the cubic B-spline curve rule `1/8, 3/4, 1/8` (Pieterse2012-spec
    /// §2.8 `BSpline`: a smooth rim that shrinks slightly).
    #[default]
    EdgeAndCorner,
    /// Every boundary vertex is a corner and keeps its position (Pieterse2012-spec §2.8 `Fixed`,
    /// property 17: "base and tips remain fixed", Pieterse2012 §4.4.1). With boundary edges
    /// split at their midpoints, the refined rim is exactly the control polygon (a square
    /// for a 4-sided loop), at every level and at the limit.
    Fixed,
}

/// How semi-sharp edge sharpness decays (OpenSubdiv's `CreasingMethod`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CreasingMethod {
    /// Every child edge gets the parent's sharpness minus 1.
    #[default]
    Uniform,
    /// DeRose et al.'s Chaikin rule: ¾ own + ¼ mean of the other semi-sharp edges at the
    /// vertex, minus 1; sharpness varies smoothly along a crease.
    Chaikin,
}

/// How face-varying values (UVs) are interpolated: OpenSubdiv's six
/// `Sdc::Options::FVarLinearInterpolation` rules, each refined exactly as OpenSubdiv 3
/// refines it (checked against OpenSubdiv `Far` by `uv_modes_agree_with_opensubdiv` in
/// `tests/refine.rs`).
///
/// Inside a UV chart every mode except [`Linear`](FvarInterpolation::Linear) applies the
/// scheme's masks, the mesh's creases included; the modes differ only on chart boundaries
/// (UV seams and mesh borders), whose edges always take the midpoint of their two values.
/// A boundary vertex is either *pinned* (keeps its value) or follows the cubic B-spline
/// curve rule `¾ v + ⅛ (a + b)` along its chart's boundary. Tagged corners and, with
/// [`BoundaryInterpolation::EdgeAndCorner`], mesh corners (a border vertex with one face)
/// are pinned in every mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FvarInterpolation {
    /// Linear everywhere: face centroids and edge midpoints of the UV polygons (Pieterse2012
    /// §2.9; OpenSubdiv `FVAR_LINEAR_ALL`). UVs never shrink, seams are exact.
    #[default]
    Linear,
    /// Smooth inside each UV chart; every chart-boundary vertex is pinned, so seams and
    /// borders stay the linear UV polyline (OpenSubdiv `FVAR_LINEAR_BOUNDARIES`). Removes
    /// the UV shrinkage MacMurchy2004 §6.3 reports.
    Boundaries,
    /// Smooth inside; chart boundaries are B-spline curves. Pinned: chart corners (a
    /// boundary vertex with one face in its chart) and every value of a vertex where three
    /// or more charts meet, or where two meet and one of them has an infinitely sharp
    /// crease running into the vertex (OpenSubdiv `FVAR_LINEAR_CORNERS_PLUS1`).
    CornersPlus,
    /// As [`CornersPlus`](FvarInterpolation::CornersPlus), and also the end of a seam inside
    /// the mesh (a "dart") and both values of a two-chart vertex where either chart has a
    /// corner (OpenSubdiv `FVAR_LINEAR_CORNERS_PLUS2`).
    CornersPlus2,
    /// Smooth inside; chart boundaries are B-spline curves and only chart corners (a
    /// boundary vertex with one face in its chart) are pinned (OpenSubdiv
    /// `FVAR_LINEAR_CORNERS_ONLY`).
    CornersOnly,
    /// Smooth everywhere: chart boundaries are B-spline curves and no chart corner is
    /// pinned; only mesh corners and tagged corners stay put (OpenSubdiv
    /// `FVAR_LINEAR_NONE`). UVs shrink at chart corners (MacMurchy2004 §6.3).
    Smooth,
}

impl FvarInterpolation {
    /// Every mode, from the most linear to the smoothest.
    pub const ALL: [FvarInterpolation; 6] = [
        FvarInterpolation::Linear,
        FvarInterpolation::Boundaries,
        FvarInterpolation::CornersPlus2,
        FvarInterpolation::CornersPlus,
        FvarInterpolation::CornersOnly,
        FvarInterpolation::Smooth,
    ];

    /// The name of OpenSubdiv's matching `FVarLinearInterpolation` rule, as
    /// `bench/opensubdiv/osd_refine.cpp --fvar` takes it.
    pub fn opensubdiv_name(self) -> &'static str {
        match self {
            FvarInterpolation::Linear => "all",
            FvarInterpolation::Boundaries => "boundaries",
            FvarInterpolation::CornersPlus => "corners-plus1",
            FvarInterpolation::CornersPlus2 => "corners-plus2",
            FvarInterpolation::CornersOnly => "corners-only",
            FvarInterpolation::Smooth => "none",
        }
    }
}

/// Options of a [`Refiner`].
#[derive(Debug, Clone, PartialEq)]
pub struct RefineOptions {
    /// Loop or Catmull–Clark.
    pub scheme: Scheme,
    /// Uniform refinement levels.
    pub levels: u32,
    /// Boundary vertex rule.
    pub boundary: BoundaryInterpolation,
    /// Sharpness decay of semi-sharp creases.
    pub creasing: CreasingMethod,
    /// Build full adjacency at the last level as well (needed for limit positions and
    /// normals); otherwise the last level has only its faces.
    pub full_last_level: bool,
    /// Run on the rayon thread pool (the result is identical either way).
    pub parallel: bool,
    /// Refuse to produce more faces than this.
    pub max_faces: usize,
    /// Refuse a refinement whose estimated peak memory ([`peak_memory`]) is over this
    /// many bytes, before its levels are allocated.
    pub max_memory: u64,
}

impl Default for RefineOptions {
    fn default() -> Self {
        RefineOptions {
            scheme: Scheme::CatmullClark,
            levels: 1,
            boundary: BoundaryInterpolation::EdgeAndCorner,
            creasing: CreasingMethod::Uniform,
            full_last_level: false,
            parallel: true,
            max_faces: DEFAULT_MAX_FACES,
            max_memory: DEFAULT_MAX_MEMORY,
        }
    }
}

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

/// Elements per parallel task.
const CHUNK: usize = 2048;

/// `dst[i] = f(i)` for every element, on the rayon pool when `par`.
pub(crate) fn fill<T: Send>(par: bool, dst: &mut [T], f: impl Fn(usize, &mut T) + Sync) {
    if par && dst.len() > CHUNK {
        dst.par_chunks_mut(CHUNK).enumerate().for_each(|(ci, chunk)| {
            let base = ci * CHUNK;
            for (k, x) in chunk.iter_mut().enumerate() {
                f(base + k, x);
            }
        });
    } else {
        for (i, x) in dst.iter_mut().enumerate() {
            f(i, x);
        }
    }
}

/// Fills `dst` in chunks of `n` elements: `f(i, &mut dst[i*n..(i+1)*n])`.
pub(crate) fn fill_chunks<T: Send>(par: bool, dst: &mut [T], n: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    if par && dst.len() > CHUNK * n {
        dst.par_chunks_mut(CHUNK * n).enumerate().for_each(|(ci, chunk)| {
            for (k, x) in chunk.chunks_mut(n).enumerate() {
                f(ci * CHUNK + k, x);
            }
        });
    } else {
        for (i, x) in dst.chunks_mut(n).enumerate() {
            f(i, x);
        }
    }
}

/// The error of a failed allocation of `n` values of `T` for `what`.
fn out_of_memory<T>(n: usize, what: &'static str) -> RefineError {
    RefineError::OutOfMemory { what, bytes: n as u128 * std::mem::size_of::<T>() as u128 }
}

/// `n` uninitialised slots, for outputs that a kernel writes completely (saves zeroing
/// large arrays and lets the first touch of each page happen in the parallel writers),
/// or [`RefineError::OutOfMemory`] naming `what` when the allocation fails.
pub(crate) fn try_uninit_vec<T>(n: usize, what: &'static str) -> Result<Vec<MaybeUninit<T>>, RefineError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<T>(n, what))?;
    // SAFETY: `MaybeUninit` needs no initialisation, and the capacity is at least `n`.
    unsafe { v.set_len(n) };
    Ok(v)
}

/// An empty vector with room for `n` values, or [`RefineError::OutOfMemory`].
pub(crate) fn try_with_capacity<T>(n: usize, what: &'static str) -> Result<Vec<T>, RefineError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| out_of_memory::<T>(n, what))?;
    Ok(v)
}

/// Types whose all-zero bit pattern is a valid value (index arrays).
///
/// # Safety
/// Implement only for types valid when zeroed.
pub(crate) unsafe trait Zeroable: Copy {}
// SAFETY: integers and arrays of them are valid when zeroed.
unsafe impl Zeroable for u32 {}
// SAFETY: as above.
unsafe impl Zeroable for [u32; 2] {}

/// `n` zeros (as `vec![0; n]`, whose pages the system zeroes lazily), or
/// [`RefineError::OutOfMemory`] naming `what` when the allocation fails.
pub(crate) fn try_zeroed<T: Zeroable>(n: usize, what: &'static str) -> Result<Vec<T>, RefineError> {
    let layout = std::alloc::Layout::array::<T>(n).map_err(|_| out_of_memory::<T>(n, what))?;
    if layout.size() == 0 {
        return Ok(Vec::new());
    }
    // SAFETY: the layout has a non-zero size.
    let ptr = unsafe { std::alloc::alloc_zeroed(layout) }.cast::<T>();
    if ptr.is_null() {
        return Err(out_of_memory::<T>(n, what));
    }
    // SAFETY: allocated by the global allocator with `T`'s layout for `n` values, all
    // valid because `T: Zeroable`.
    Ok(unsafe { Vec::from_raw_parts(ptr, n, n) })
}

/// A copy of `src`, or [`RefineError::OutOfMemory`] naming `what`.
pub(crate) fn try_to_vec<T: Copy>(src: &[T], what: &'static str) -> Result<Vec<T>, RefineError> {
    let mut v = try_with_capacity(src.len(), what)?;
    v.extend_from_slice(src);
    Ok(v)
}

/// Views fully written slots as values.
///
/// # Safety
/// Every element of `s` must have been written.
pub(crate) unsafe fn assume_init<T>(s: &[MaybeUninit<T>]) -> &[T] {
    // SAFETY: same layout; initialised by the caller's contract.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<T>(), s.len()) }
}

/// Mutable view of fully written slots as values.
///
/// # Safety
/// Every element of `s` must have been written.
pub(crate) unsafe fn assume_init_mut<T>(s: &mut [MaybeUninit<T>]) -> &mut [T] {
    // SAFETY: same layout; initialised by the caller's contract.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<T>(), s.len()) }
}

/// Turns a fully written vector into a vector of values.
///
/// # Safety
/// Every element of `v` must have been written.
pub(crate) unsafe fn into_init<T>(v: Vec<MaybeUninit<T>>) -> Vec<T> {
    let mut v = std::mem::ManuallyDrop::new(v);
    // SAFETY: same layout, length and capacity; initialised by the caller's contract.
    unsafe { Vec::from_raw_parts(v.as_mut_ptr().cast::<T>(), v.len(), v.capacity()) }
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
    let mut positions = refiner.interpolate(&mesh.positions)?;
    let mut normals = None;
    if options.limit {
        // Tangent masks apply to the finest control points, not to their limits.
        normals = Some(refiner.limit_normals(&positions)?);
        positions = refiner.limit(&positions)?;
    }
    let mut out = refiner.try_finest_mesh(positions)?;
    out.normals = normals;
    if let Some(uvs) = &mesh.uvs {
        let fvr = refiner.face_varying(&uvs.indices, options.uv)?;
        out.uvs = Some(fvr.interpolate(&uvs.values)?);
    }
    let control_faces = refiner.try_control_faces()?;
    Ok((out, control_faces))
}

/// The most worker threads a pool may have ([`with_threads`], `sylva subdivide
/// --threads`, `RAYON_NUM_THREADS` for [`start_global_threads`]). A fixed number, not one
/// derived from the machine, so a command that works on one machine is not refused on
/// another: far above the cores of any machine sylva runs on (the result is the same
/// for any count, so more threads than cores only cost memory), yet small enough that
/// the pool's stacks (2 MiB of address space each, 2 GiB for 1024) fit a 6 GB
/// address-space limit. Issue 39: 100,000 threads failed after 36 s with an error that
/// never named threads.
pub const MAX_THREADS: usize = 1024;

/// Why a pool of worker threads could not be started.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
pub enum ThreadsError {
    /// More threads were asked for than [`MAX_THREADS`]; nothing was started.
    #[error("{threads} worker threads: more than the limit of {MAX_THREADS} (use 1..={MAX_THREADS}; the output is the same for any count)")]
    TooMany {
        /// The count asked for.
        threads: usize,
    },
    /// The process's address-space limit (`ulimit -v`) leaves no room for the threads'
    /// stacks; checked before any thread starts, because a thread the system starts
    /// without room for its signal stack aborts the process (Rust's runtime cannot
    /// unwind from that).
    #[error("cannot start {threads} worker threads: with their stacks and malloc arenas they need about {need_mib} MiB of address space and the limit (ulimit -v) leaves {free_mib} MiB (use --threads {fit} or fewer, or raise the limit)")]
    AddressSpace {
        /// The count asked for.
        threads: usize,
        /// Address space the threads need (stacks and malloc arenas), in MiB.
        need_mib: u64,
        /// Address space left under the limit, in MiB.
        free_mib: u64,
        /// The most threads that fit.
        fit: usize,
    },
    /// The system refused to start the threads (too many processes, no memory).
    #[error("cannot start {threads} worker threads: {source} (use fewer)")]
    Start {
        /// The count asked for.
        threads: usize,
        /// Why.
        source: rayon::ThreadPoolBuildError,
    },
}

/// Runs `f` on a dedicated rayon pool of `threads` workers (refinement inside it uses that
/// many threads; the result is the same for any count). `0` counts as 1. More than
/// [`MAX_THREADS`] is [`ThreadsError::TooMany`], checked before any thread starts; a pool
/// the system cannot start is [`ThreadsError::Start`].
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, ThreadsError> {
    let threads = threads.max(1);
    if threads > MAX_THREADS {
        return Err(ThreadsError::TooMany { threads });
    }
    check_address_space(threads)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|source| ThreadsError::Start { threads, source })?;
    Ok(pool.install(f))
}

/// Address space one worker thread takes: its 2 MiB stack (Rust's default) with its
/// guard page, signal stack and thread-local storage, rounded up.
const THREAD_ADDRESS_SPACE: u64 = (2 << 20) + (256 << 10);

/// Address space kept free for the work itself once the threads are started.
const WORK_HEADROOM: u64 = 256 << 20;

/// Refuses `threads` workers when the address-space limit (`RLIMIT_AS`, `ulimit -v`)
/// minus what the process already maps leaves less than their stacks and
/// [`WORK_HEADROOM`]. Issue 39: under `ulimit -v 1500000`, 1024 threads started, and the
/// last ones aborted the process when their signal stacks could not be mapped.
fn check_address_space(threads: usize) -> Result<(), ThreadsError> {
    let Some(free) = free_address_space() else { return Ok(()) };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let need = |n: usize| n as u64 * THREAD_ADDRESS_SPACE + arenas(n, cores) * ARENA_ADDRESS_SPACE;
    if need(threads) + WORK_HEADROOM <= free {
        return Ok(());
    }
    let fit = (1..threads).rev().find(|&n| need(n) + WORK_HEADROOM <= free).unwrap_or(1);
    Err(ThreadsError::AddressSpace { threads, need_mib: need(threads) >> 20, free_mib: free >> 20, fit })
}

/// Address space glibc reserves for each malloc arena a thread may create (64 MiB on
/// 64-bit systems: `HEAP_MAX_SIZE`).
const ARENA_ADDRESS_SPACE: u64 = 64 << 20;

/// The malloc arenas `threads` workers may add besides the main one: one per thread up
/// to glibc's default cap of 8 per core. Measured: under a 1.5 GB limit on 2 cores, 250
/// threads failed to start and 400 aborted, far sooner than their stacks alone explain.
fn arenas(threads: usize, cores: usize) -> u64 {
    threads.min(8 * cores).saturating_sub(1) as u64
}

/// Bytes of address space left under `RLIMIT_AS`, or `None` when there is no limit
/// (or it cannot be read). What the process maps now is read from `/proc/self/statm`
/// where there is one.
#[cfg(unix)]
fn free_address_space() -> Option<u64> {
    let mut lim = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes one rlimit into the struct it is given.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut lim) } != 0 || lim.rlim_cur == libc::RLIM_INFINITY {
        return None;
    }
    let used = std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().next().and_then(|p| p.parse::<u64>().ok()))
        .map_or(0, |pages| pages * page_size());
    // rlim_t is u64 on Linux but not on every Unix.
    #[allow(clippy::unnecessary_cast)]
    let limit = lim.rlim_cur as u64;
    Some(limit.saturating_sub(used))
}

/// The system's page size in bytes (4096 where it cannot be read).
#[cfg(unix)]
fn page_size() -> u64 {
    // SAFETY: sysconf only reads a system constant.
    let p = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    if p > 0 {
        p as u64
    } else {
        4096
    }
}

/// No address-space limit is read outside Unix.
#[cfg(not(unix))]
fn free_address_space() -> Option<u64> {
    None
}

/// Starts rayon's global pool now, so that a count it cannot start is an error rather
/// than a panic at its first use: the pool has `RAYON_NUM_THREADS` workers when that is
/// set to a number above 0 (at most [`MAX_THREADS`], else [`ThreadsError::TooMany`]
/// before any thread starts), else one per core. Call it once, before any parallel
/// work; a global pool that is already running is left as it is.
pub fn start_global_threads() -> Result<(), ThreadsError> {
    let asked = std::env::var("RAYON_NUM_THREADS").ok().and_then(|v| v.trim().parse::<u128>().ok());
    let asked = asked.map_or(0, |n| usize::try_from(n).unwrap_or(usize::MAX));
    if asked > MAX_THREADS {
        return Err(ThreadsError::TooMany { threads: asked });
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    check_address_space(if asked == 0 { cores } else { asked })?;
    match rayon::ThreadPoolBuilder::new().build_global() {
        Ok(()) => Ok(()),
        // rayon says so only in words: a pool already running is not an error here.
        Err(e) if e.to_string().contains("already") => Ok(()),
        Err(source) => Err(ThreadsError::Start { threads: if asked == 0 { cores } else { asked }, source }),
    }
}
