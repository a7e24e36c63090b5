//! The settings of a refinement and what can go wrong: the scheme, the boundary and
//! crease rules, the output and memory limits ([`RefineOptions`]), and [`RefineError`].
//! Names follow OpenSubdiv's (Pieterse2012 §4.4, Skjermo2008 §5, MacMurchy2004 §2.10).

/// The largest output a refinement may produce unless told otherwise (100 M faces).
pub const DEFAULT_MAX_FACES: usize = 100_000_000;

/// The most memory a refinement may need at its peak unless told otherwise
/// ([`RefineOptions::max_memory`]): 4 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 4 << 30;

/// Why a mesh cannot be refined.
#[derive(Debug, Clone, PartialEq, thiserror::Error, miette::Diagnostic)]
pub enum RefineError {
    /// The computation's [`crate::cancel::Cancel`] token was cancelled; checked before
    /// each level is split and interpolated.
    #[error("subdivision cancelled before level {level}")]
    Cancelled {
        /// The level that was not computed (1 = the first).
        level: u32,
    },
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
        /// The estimated peak ([`peak_memory`](super::peak_memory)).
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

/// Options of a [`Refiner`](super::Refiner).
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
    /// Refuse a refinement whose estimated peak memory ([`peak_memory`](super::peak_memory)) is over this
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
