//! The policy of subdividing one control mesh, as `sylva subdivide` asks it: the names a
//! front end writes the refinement options with ([`Named`]), the defaults taken from the
//! mesh and its OBJ tags (Loop for all-triangle meshes, else Catmull–Clark; the tags'
//! boundary and creasing rules), the combinations refused ([`PolicyError`]), and the run
//! (uniform, adaptive Loop, noise between levels, then PN tessellation).
//!
//! Front ends hold a [`SubdivideRequest`] (what was asked, `None` for "the policy's
//! choice"), [`plan`] resolves it against the mesh, and [`Plan::run`] refines. The
//! methods are MacMurchy2004 (adaptive Loop, noise), Skjermo2008 (PN) and Pieterse2012
//! (the `fixed` boundary); docs/subdivision.md describes them (docs/references.md keys).

use super::adaptive::AdaptiveOptions;
use super::noise::{FeatureSize, NoiseOptions};
use super::pn::{EdgeRule, NormalInterpolation, NormalSource, PnOptions, QuadInterior};
use super::{
    BoundaryInterpolation, CreasingMethod, FvarInterpolation, RefineError, RefineOptions, Scheme,
    SubdivideOptions,
};
use crate::geometry::Mesh;
use crate::refine::crease::Corner;

/// A refinement option written as one of a few names (`--scheme catmull-clark`): the
/// names, their aliases and a line of help each, for a front end's parser and help.
pub trait Named: Sized + Copy + 'static {
    /// Every value, in the order of [`Named::NAMES`].
    const ALL: &'static [Self];
    /// The names, in order.
    const NAMES: &'static [&'static str];
    /// The value's name.
    fn name(self) -> &'static str;
    /// Other names the value is also known by (OpenSubdiv's, for UVs).
    fn aliases(self) -> &'static [&'static str] {
        &[]
    }
    /// A line of help on the value.
    fn help(self) -> &'static str;
    /// The value called `name` (or one of its aliases).
    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.iter().copied().find(|v| v.name() == name || v.aliases().contains(&name))
    }
}

/// Implements [`Named`] for a library enum: `Variant = "name" [aliases] "help"`.
macro_rules! named {
    ($ty:ty { $($variant:ident = $name:literal [$($alias:literal),*] $help:literal,)+ }) => {
        impl Named for $ty {
            const ALL: &'static [Self] = &[$(<$ty>::$variant),+];
            const NAMES: &'static [&'static str] = &[$($name),+];
            fn name(self) -> &'static str {
                match self {
                    $(<$ty>::$variant => $name,)+
                }
            }
            fn aliases(self) -> &'static [&'static str] {
                match self {
                    $(<$ty>::$variant => &[$($alias),*],)+
                }
            }
            fn help(self) -> &'static str {
                match self {
                    $(<$ty>::$variant => $help,)+
                }
            }
        }
    };
}

named!(Scheme {
    Loop = "loop" [] "Loop (triangles only)",
    CatmullClark = "catmull-clark" [] "Catmull–Clark (any polygons)",
});

named!(BoundaryInterpolation {
    EdgeAndCorner = "bspline" [] "Cubic B-spline rim, single-face corners pinned",
    EdgeOnly = "edge-only" [] "Cubic B-spline rim, nothing pinned",
    Fixed = "fixed" [] "Every boundary vertex stays put (Pieterse2012 `Fixed`)",
});

named!(CreasingMethod {
    Uniform = "uniform" [] "Sharpness decreases by 1 per level",
    Chaikin = "chaikin" [] "Chaikin: sharpness is averaged along the crease, then decreased by 1",
});

named!(FvarInterpolation {
    Linear = "linear" ["all"] "Linear everywhere (UVs never shrink; OpenSubdiv FVAR_LINEAR_ALL)",
    Boundaries = "smooth" ["boundaries"]
        "Smooth inside each UV chart; seams and borders linear with their corners pinned (FVAR_LINEAR_BOUNDARIES)",
    CornersPlus = "smooth-curves" ["corners-plus1"]
        "Smooth inside; seams and borders as smooth curves with chart corners and junctions of three or more charts pinned (FVAR_LINEAR_CORNERS_PLUS1)",
    CornersPlus2 = "corners-plus2" []
        "As smooth-curves, also pinning seam ends and two-chart corners (FVAR_LINEAR_CORNERS_PLUS2)",
    CornersOnly = "corners-only" []
        "Smooth inside; seams and borders as smooth curves, only chart corners pinned (FVAR_LINEAR_CORNERS_ONLY)",
    Smooth = "smooth-all" ["none"] "Smooth everywhere; only mesh corners pinned (FVAR_LINEAR_NONE)",
});

named!(EdgeRule {
    Standard = "standard" [] "⅓ edge rule (Vlachos; Th Eq. 3.1)",
    Rounder = "rounder" [] "½ edge rule, rounder (Th Eq. 3.2)",
});

named!(QuadInterior {
    Theyer = "theyer" [] "Theyer: the edge rule along the diagonals",
    ZeroTwist = "zero-twist" [] "Zero twist at the corners",
});

named!(NormalInterpolation {
    Linear = "linear" [] "Linear blend of the corner normals",
    Quadratic = "quadratic" [] "Vlachos' quadratic normals",
});

/// Adaptive Loop refinement's tolerances (MacMurchy2004 §A.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adaptive {
    /// Flatness tolerance in radians.
    pub flatness: f32,
    /// Size tolerance: the area of the smallest triangle to split.
    pub size: f32,
}

impl Default for Adaptive {
    /// MacMurchy2004's Fig A.5 values: 0.25 rad, 0.0001.
    fn default() -> Self {
        Adaptive { flatness: 0.25, size: 1e-4 }
    }
}

/// Fractal noise after every uniform level (MacMurchy2004 §6.5), its scale relative to
/// the mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Scale as a fraction of the bounding-box diagonal.
    pub k: f32,
    /// Fractal dimension H.
    pub h: f32,
    /// Bias b.
    pub bias: f32,
    /// Lacunarity L.
    pub lacunarity: f32,
    /// Feature size t at the top of the mesh (1 at the base).
    pub top: f32,
    /// Random seed.
    pub seed: u64,
}

impl Default for Noise {
    /// k 0.005, H 0.5, b 0.5, L 2, top 0.25, seed 1.
    fn default() -> Self {
        Noise { k: 0.005, h: 0.5, bias: 0.5, lacunarity: 2.0, top: 0.25, seed: 1 }
    }
}

/// PN tessellation after the subdivision (Skjermo2008 §3.3.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pn {
    /// The edge rule.
    pub rule: EdgeRule,
    /// Segments per patch edge.
    pub level: u32,
    /// Inner control points of quads.
    pub interior: QuadInterior,
    /// Normal interpolation.
    pub normals: NormalInterpolation,
}

/// What a front end asks of one subdivision; `None` leaves the choice to [`plan`].
#[derive(Debug, Clone, PartialEq)]
pub struct SubdivideRequest {
    /// The scheme; `None`: Loop for an all-triangle mesh, else Catmull–Clark.
    pub scheme: Option<Scheme>,
    /// Uniform levels (the deepest level when adaptive).
    pub levels: u32,
    /// Move the vertices to the limit surface, with limit normals.
    pub limit: bool,
    /// UV interpolation.
    pub uv: FvarInterpolation,
    /// Crease decay; `None`: the mesh's tag, else uniform.
    pub creasing: Option<CreasingMethod>,
    /// Boundary rule; `None`: the mesh's tag, else `bspline`.
    pub boundary: Option<BoundaryInterpolation>,
    /// The most faces to make.
    pub max_faces: usize,
    /// The most memory the refinement may need at its peak, in bytes
    /// ([`RefineOptions::max_memory`]).
    pub max_memory: u64,
    /// Refine each level in parallel (the output is the same either way).
    pub parallel: bool,
    /// Adaptive Loop refinement instead of uniform levels.
    pub adaptive: Option<Adaptive>,
    /// Noise after every uniform level.
    pub noise: Option<Noise>,
    /// PN tessellation of the result.
    pub pn: Option<Pn>,
}

impl Default for SubdivideRequest {
    /// Two uniform levels, the scheme and rules left to [`plan`].
    fn default() -> Self {
        SubdivideRequest {
            scheme: None,
            levels: 2,
            limit: false,
            uv: FvarInterpolation::Linear,
            creasing: None,
            boundary: None,
            max_faces: super::DEFAULT_MAX_FACES,
            max_memory: super::DEFAULT_MAX_MEMORY,
            parallel: true,
            adaptive: None,
            noise: None,
            pn: None,
        }
    }
}

/// The rules a mesh file may carry (OBJ `t interpolateboundary`, `t creasemethod`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MeshTags {
    /// The file's boundary rule.
    pub boundary: Option<BoundaryInterpolation>,
    /// The file's crease decay.
    pub creasing: Option<CreasingMethod>,
}

/// A combination [`plan`] refuses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PolicyError {
    /// Adaptive refinement with Catmull–Clark.
    #[error(
        "adaptive refinement refines triangles with Loop's scheme; it cannot be used with Catmull–Clark"
    )]
    AdaptiveNeedsLoop,
    /// Adaptive refinement with noise or the limit surface.
    #[error(
        "adaptive refinement cannot be combined with noise or the limit surface (they need uniform levels)"
    )]
    AdaptiveNeedsUniform,
    /// Adaptive refinement with UVs other than linear.
    #[error("adaptive refinement carries UVs linearly; use linear UV interpolation")]
    AdaptiveNeedsLinearUv,
}

/// A request resolved for one mesh: what [`Plan::run`] does.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The uniform subdivision's options (the scheme chosen, the rules resolved).
    pub options: SubdivideOptions,
    /// Adaptive Loop refinement instead of the uniform levels.
    pub adaptive: Option<AdaptiveOptions>,
    /// Noise between the uniform levels, its scale in the mesh's units, and the seed.
    pub noise: Option<(NoiseOptions, u64)>,
    /// PN tessellation of the result.
    pub pn: Option<PnOptions>,
}

/// Whether every face of `mesh` is a triangle (and it has faces).
pub fn all_triangles(mesh: &Mesh) -> bool {
    mesh.face_count() > 0 && (0..mesh.face_count()).all(|f| mesh.face(f).len() == 3)
}

/// Resolves `request` for `mesh` with its file's `tags`: the scheme (Loop for an
/// all-triangle mesh, else Catmull–Clark), the boundary and crease rules (asked, else the
/// tags', else the defaults), the noise's scale from the mesh's size; refuses adaptive
/// refinement with Catmull–Clark, noise, the limit surface or smooth UVs.
pub fn plan(request: &SubdivideRequest, mesh: &Mesh, tags: MeshTags) -> Result<Plan, PolicyError> {
    let scheme =
        request.scheme.unwrap_or(if all_triangles(mesh) { Scheme::Loop } else { Scheme::CatmullClark });
    let options = SubdivideOptions {
        refine: RefineOptions {
            scheme,
            levels: request.levels,
            boundary: request.boundary.or(tags.boundary).unwrap_or_default(),
            creasing: request.creasing.or(tags.creasing).unwrap_or_default(),
            max_faces: request.max_faces,
            max_memory: request.max_memory,
            parallel: request.parallel,
            ..Default::default()
        },
        limit: request.limit,
        uv: request.uv,
    };
    let adaptive = match request.adaptive {
        None => None,
        Some(_) if scheme != Scheme::Loop => return Err(PolicyError::AdaptiveNeedsLoop),
        Some(_) if request.noise.is_some() || request.limit => return Err(PolicyError::AdaptiveNeedsUniform),
        Some(_) if request.uv != FvarInterpolation::Linear => return Err(PolicyError::AdaptiveNeedsLinearUv),
        Some(a) => Some(AdaptiveOptions {
            max_levels: request.levels,
            flatness: a.flatness,
            min_area: a.size,
            boundary: options.refine.boundary,
            creasing: options.refine.creasing,
            max_faces: request.max_faces,
            max_memory: request.max_memory,
        }),
    };
    let diagonal = mesh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
    let noise = request.noise.map(|n| {
        let options = NoiseOptions {
            k: n.k * diagonal,
            lacunarity: n.lacunarity,
            h: n.h,
            bias: n.bias,
            feature: FeatureSize::Height { top: n.top },
        };
        (options, n.seed)
    });
    let pn = request.pn.map(|p| PnOptions {
        level: p.level,
        edge_rule: p.rule,
        diagonal_rule: EdgeRule::Standard,
        interior: p.interior,
        normals: p.normals,
        source: NormalSource::Mesh,
        max_faces: request.max_faces,
    });
    Ok(Plan { options, adaptive, noise, pn })
}

impl Plan {
    /// The scheme the plan refines with.
    pub fn scheme(&self) -> Scheme {
        self.options.refine.scheme
    }

    /// Refines `mesh` with its tagged `corners`: adaptive, noisy or uniform levels, then
    /// PN tessellation.
    pub fn run(&self, mesh: &Mesh, corners: &[Corner]) -> Result<Mesh, RefineError> {
        let refined = if let Some(a) = &self.adaptive {
            super::adaptive::adaptive_loop(mesh, corners, a)?
        } else if let Some((noise, seed)) = &self.noise {
            super::noise::subdivide_with_noise(mesh, corners, &self.options, noise, *seed)?
        } else {
            super::subdivide(mesh, corners, &self.options)?
        };
        match &self.pn {
            None => Ok(refined),
            Some(pn) => super::pn::pn_tessellate(&refined, pn),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_with_aliases() {
        for s in Scheme::ALL {
            assert_eq!(Scheme::from_name(s.name()), Some(*s));
        }
        assert_eq!(FvarInterpolation::from_name("boundaries"), Some(FvarInterpolation::Boundaries));
        assert_eq!(FvarInterpolation::from_name("smooth-all"), Some(FvarInterpolation::Smooth));
        assert_eq!(BoundaryInterpolation::from_name("bspline"), Some(BoundaryInterpolation::EdgeAndCorner));
        assert_eq!(BoundaryInterpolation::from_name("nonsense"), None);
        assert_eq!(FvarInterpolation::NAMES.len(), FvarInterpolation::ALL.len());
    }

    #[test]
    fn the_scheme_follows_the_faces_and_adaptive_needs_loop() {
        let mut quad = Mesh::new();
        quad.positions = vec![glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::ONE, glam::Vec3::Y];
        quad.push_face(&[0, 1, 2, 3]);
        let request = SubdivideRequest::default();
        assert_eq!(plan(&request, &quad, MeshTags::default()).unwrap().scheme(), Scheme::CatmullClark);
        let tags = MeshTags { boundary: Some(BoundaryInterpolation::Fixed), creasing: None };
        let p = plan(&request, &quad, tags).unwrap();
        assert_eq!(p.options.refine.boundary, BoundaryInterpolation::Fixed);
        let adaptive = SubdivideRequest { adaptive: Some(Adaptive::default()), ..request };
        assert_eq!(plan(&adaptive, &quad, tags), Err(PolicyError::AdaptiveNeedsLoop));
    }
}
