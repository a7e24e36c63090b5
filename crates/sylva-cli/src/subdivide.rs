//! `sylva subdivide`: refine an OBJ control mesh with Loop or Catmull–Clark and write it
//! as glTF, OBJ or PLY (issue 4 item 9; the engine is `sylva::refine`).
//!
//! Creases and corners come from OpenSubdiv-style tags in the OBJ
//! (`t crease 2/1 v0 v1 sharpness`, `t corner 1/1 v sharpness`); see
//! `sylva::mesh::obj_read`.

use miette::Result;
use std::path::PathBuf;
use std::time::Instant;
use sylva::refine::{self, FvarInterpolation, RefineOptions, Scheme, SubdivideOptions};
use sylva::{Material, Model, Part};

/// Arguments of `sylva subdivide`.
#[derive(clap::Args, Debug, Clone)]
pub struct SubdivideArgs {
    /// Control mesh (.obj). Crease and corner tags (`t crease 2/1 a b s`) are honoured.
    pub input: PathBuf,
    /// Output file; the extension picks the format (.glb, .gltf, .obj, .ply).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Subdivision scheme. Default: Loop for all-triangle meshes, else Catmull–Clark.
    #[arg(long, value_enum)]
    pub scheme: Option<SchemeArg>,
    /// Uniform refinement levels (each multiplies the face count by 4).
    #[arg(short = 'n', long, default_value_t = 2)]
    pub levels: u32,
    /// Move the vertices to the limit surface and write exact limit normals.
    #[arg(long)]
    pub limit: bool,
    /// UV interpolation (OpenSubdiv's face-varying rules; docs/subdivision.md lists them).
    #[arg(long, value_enum, default_value_t = UvArg::Linear)]
    pub uv: UvArg,
    /// Semi-sharp crease decay: uniform (OpenSubdiv's default) or Chaikin.
    #[arg(long, value_enum)]
    pub creasing: Option<CreasingArg>,
    /// Where boundary vertices go: `bspline` (the rim refines as a cubic B-spline, its
    /// single-face corners pinned; OpenSubdiv's `interpolateboundary 1`), `edge-only`
    /// (`interpolateboundary 2`) or `fixed` (Pieterse2012's rule: every boundary vertex stays
    /// put, so the rim stays the control polygon). Default: the OBJ's `interpolateboundary`
    /// tag, else `bspline`.
    #[arg(long, value_enum)]
    pub boundary: Option<BoundaryArg>,
    /// Refuse to write more faces than this.
    #[arg(long, value_name = "FACES", default_value_t = refine::DEFAULT_MAX_FACES)]
    pub max_faces: usize,
    /// Worker threads, 1..=1024 (`refine::MAX_THREADS`; default: all cores; the output is
    /// identical for any count).
    #[arg(long, value_parser = crate::args::whole_in::<usize>(1, refine::MAX_THREADS as u64))]
    pub threads: Option<usize>,
    /// Adaptive Loop refinement instead of uniform (MacMurchy2004): `flatness=RAD,size=AREA`
    /// (flatness in radians, or degrees with a `deg` suffix; size = smallest triangle
    /// area to split). `-n` is the deepest level. Output is crack-free.
    #[arg(long, value_name = "flatness=F,size=S", value_parser = parse_adaptive)]
    pub adaptive: Option<AdaptiveArg>,
    /// Tessellate the (subdivided) mesh with PN triangles / PN quads (Skjermo2008): `standard`
    /// (⅓ edge rule) or `rounder` (½ rule). Use `-n 0` or `-n 1` before PN.
    #[arg(long, value_enum, value_name = "RULE")]
    pub pn: Option<PnArg>,
    /// Segments per patch edge for `--pn` (each face becomes level² faces).
    #[arg(long, value_name = "K", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub pn_level: u32,
    /// Inner control points of PN quads: Theyer's diagonals or zero twist.
    #[arg(long, value_enum, default_value_t = PnInteriorArg::Theyer)]
    pub pn_interior: PnInteriorArg,
    /// Normal interpolation across PN patches.
    #[arg(long, value_enum, default_value_t = PnNormalsArg::Quadratic)]
    pub pn_normals: PnNormalsArg,
    /// Fractal noise after every uniform level (MacMurchy2004 §6.5): `k=K,h=H,bias=B` and
    /// optionally `l=LACUNARITY` (default 2), `top=T` (feature size at the top of the mesh;
    /// t falls from 1 at the base, default 0.25; 1 = uniform), `seed=N`. K is a fraction of
    /// the bounding-box diagonal.
    #[arg(long, value_name = "k=K,h=H,bias=B", value_parser = parse_noise)]
    pub noise: Option<NoiseArg>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `--adaptive flatness=…,size=…`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveArg {
    /// Flatness tolerance in radians.
    pub flatness: f32,
    /// Size tolerance (area).
    pub size: f32,
}

/// `--noise k=…,h=…,bias=…[,l=…][,top=…][,seed=…]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseArg {
    /// Scale as a fraction of the bounding-box diagonal.
    pub k: f32,
    /// Fractal dimension H.
    pub h: f32,
    /// Bias b.
    pub bias: f32,
    /// Lacunarity L.
    pub lacunarity: f32,
    /// Feature size t at the top.
    pub top: f32,
    /// Random seed.
    pub seed: u64,
}

/// `--boundary`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundaryArg {
    /// Cubic B-spline rim, single-face corners pinned.
    Bspline,
    /// Cubic B-spline rim, nothing pinned.
    EdgeOnly,
    /// Every boundary vertex stays put (Pieterse2012 `Fixed`).
    Fixed,
}

/// `--pn`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PnArg {
    /// ⅓ edge rule (Vlachos; Th Eq. 3.1).
    Standard,
    /// ½ edge rule, rounder (Th Eq. 3.2).
    Rounder,
}

/// `--pn-interior`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PnInteriorArg {
    /// Theyer: the edge rule along the diagonals.
    Theyer,
    /// Zero twist at the corners.
    ZeroTwist,
}

/// `--pn-normals`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum PnNormalsArg {
    /// Linear blend of the corner normals.
    Linear,
    /// Vlachos' quadratic normals.
    Quadratic,
}

/// Splits `key=value,key=value` into pairs, rejecting unknown and repeated keys.
fn key_values<'a>(s: &'a str, keys: &[&str]) -> Result<Vec<(&'a str, &'a str)>, String> {
    let mut out: Vec<(&str, &str)> = Vec::new();
    for item in s.split(',').map(str::trim).filter(|x| !x.is_empty()) {
        let (k, v) = item.split_once('=').ok_or_else(|| format!("`{item}` is not key=value"))?;
        let (k, v) = (k.trim(), v.trim());
        if !keys.contains(&k) {
            return Err(format!("unknown key `{k}` (expected {})", keys.join(", ")));
        }
        if out.iter().any(|(x, _)| *x == k) {
            return Err(format!("`{k}` is given twice"));
        }
        out.push((k, v));
    }
    Ok(out)
}

fn number(key: &str, v: &str) -> Result<f32, String> {
    match v.parse::<f32>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("`{key}={v}`: not a finite number")),
    }
}

/// Parses `--adaptive flatness=0.25,size=0.0001` (`flatness=15deg` in degrees).
pub fn parse_adaptive(s: &str) -> Result<AdaptiveArg, String> {
    let mut a = AdaptiveArg { flatness: 0.25, size: 1e-4 };
    for (k, v) in key_values(s, &["flatness", "size"])? {
        match k {
            "flatness" => {
                let x = match v.strip_suffix("deg") {
                    Some(d) => number(k, d.trim())?.to_radians(),
                    None => number(k, v)?,
                };
                if x < 0.0 {
                    return Err(format!("`flatness={v}`: the angle must be ≥ 0"));
                }
                a.flatness = x;
            }
            _ => {
                let x = number(k, v)?;
                if x < 0.0 {
                    return Err(format!("`size={v}`: the area must be ≥ 0"));
                }
                a.size = x;
            }
        }
    }
    Ok(a)
}

/// Parses `--noise k=0.01,h=0.5,bias=0.5[,l=2][,top=0.25][,seed=1]`.
pub fn parse_noise(s: &str) -> Result<NoiseArg, String> {
    let mut a = NoiseArg { k: 0.005, h: 0.5, bias: 0.5, lacunarity: 2.0, top: 0.25, seed: 1 };
    for (k, v) in key_values(s, &["k", "h", "bias", "l", "top", "seed"])? {
        let in01 = |x: f32| -> Result<f32, String> {
            if (0.0..=1.0).contains(&x) {
                Ok(x)
            } else {
                Err(format!("`{k}={v}`: must be in [0, 1]"))
            }
        };
        match k {
            "k" => {
                a.k = number(k, v)?;
                if a.k < 0.0 {
                    return Err(format!("`k={v}`: the scale must be ≥ 0"));
                }
            }
            "h" => a.h = in01(number(k, v)?)?,
            "bias" => a.bias = in01(number(k, v)?)?,
            "top" => a.top = in01(number(k, v)?)?,
            "l" => {
                a.lacunarity = number(k, v)?;
                if a.lacunarity <= 0.0 {
                    return Err(format!("`l={v}`: the lacunarity must be > 0"));
                }
            }
            _ => a.seed = v.parse().map_err(|_| format!("`seed={v}`: not a non-negative integer"))?,
        }
    }
    Ok(a)
}

/// `--scheme`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum SchemeArg {
    /// Loop (triangles only).
    Loop,
    /// Catmull–Clark (any polygons).
    CatmullClark,
}

/// `--uv`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum UvArg {
    /// Linear everywhere (UVs never shrink; OpenSubdiv FVAR_LINEAR_ALL).
    #[value(alias = "all")]
    Linear,
    /// Smooth inside each UV chart; seams and borders linear with their corners pinned
    /// (FVAR_LINEAR_BOUNDARIES).
    #[value(alias = "boundaries")]
    Smooth,
    /// Smooth inside; seams and borders as smooth curves with chart corners and
    /// junctions of three or more charts pinned (FVAR_LINEAR_CORNERS_PLUS1).
    #[value(alias = "corners-plus1")]
    SmoothCurves,
    /// As smooth-curves, also pinning seam ends and two-chart corners
    /// (FVAR_LINEAR_CORNERS_PLUS2).
    CornersPlus2,
    /// Smooth inside; seams and borders as smooth curves, only chart corners pinned
    /// (FVAR_LINEAR_CORNERS_ONLY).
    CornersOnly,
    /// Smooth everywhere; only mesh corners pinned (FVAR_LINEAR_NONE).
    #[value(alias = "none")]
    SmoothAll,
}

/// `--creasing`.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum CreasingArg {
    /// Sharpness decreases by 1 per level.
    Uniform,
    /// Chaikin: sharpness is averaged along the crease, then decreased by 1.
    Chaikin,
}

/// Runs `sylva subdivide`.
pub fn run(args: SubdivideArgs) -> Result<()> {
    // Fail on a bad extension before doing any work.
    sylva::export::Format::from_path(&args.output)?;
    let start = Instant::now();
    let obj = sylva::mesh::obj_read::read_obj(&args.input)?;
    let mesh = &obj.mesh;
    let scheme = match args.scheme {
        Some(SchemeArg::Loop) => Scheme::Loop,
        Some(SchemeArg::CatmullClark) => Scheme::CatmullClark,
        None if mesh.face_count() > 0 && (0..mesh.face_count()).all(|f| mesh.face(f).len() == 3) => {
            Scheme::Loop
        }
        None => Scheme::CatmullClark,
    };
    let creasing = match args.creasing {
        Some(CreasingArg::Uniform) => refine::CreasingMethod::Uniform,
        Some(CreasingArg::Chaikin) => refine::CreasingMethod::Chaikin,
        None => obj.creasing.unwrap_or_default(),
    };
    let options = SubdivideOptions {
        refine: RefineOptions {
            scheme,
            levels: args.levels,
            boundary: match args.boundary {
                Some(BoundaryArg::Bspline) => refine::BoundaryInterpolation::EdgeAndCorner,
                Some(BoundaryArg::EdgeOnly) => refine::BoundaryInterpolation::EdgeOnly,
                Some(BoundaryArg::Fixed) => refine::BoundaryInterpolation::Fixed,
                None => obj.boundary.unwrap_or_default(),
            },
            creasing,
            max_faces: args.max_faces,
            parallel: args.threads != Some(1),
            ..Default::default()
        },
        limit: args.limit,
        uv: match args.uv {
            UvArg::Linear => FvarInterpolation::Linear,
            UvArg::Smooth => FvarInterpolation::Boundaries,
            UvArg::SmoothCurves => FvarInterpolation::CornersPlus,
            UvArg::CornersPlus2 => FvarInterpolation::CornersPlus2,
            UvArg::CornersOnly => FvarInterpolation::CornersOnly,
            UvArg::SmoothAll => FvarInterpolation::Smooth,
        },
    };
    if args.adaptive.is_some() {
        if scheme != Scheme::Loop {
            miette::bail!(
                "--adaptive refines triangles with Loop's scheme; it cannot be used with Catmull–Clark"
            );
        }
        if args.noise.is_some() || args.limit {
            miette::bail!("--adaptive cannot be combined with --noise or --limit (they need uniform levels)");
        }
        if options.uv != FvarInterpolation::Linear {
            miette::bail!("--adaptive carries UVs linearly; use --uv linear");
        }
    }
    let diagonal = mesh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length());
    let subdivide = || -> Result<sylva::Mesh, refine::RefineError> {
        let refined = if let Some(a) = args.adaptive {
            let opts = refine::adaptive::AdaptiveOptions {
                max_levels: args.levels,
                flatness: a.flatness,
                min_area: a.size,
                boundary: options.refine.boundary,
                creasing: options.refine.creasing,
                max_faces: args.max_faces,
            };
            refine::adaptive::adaptive_loop(mesh, &obj.corners, &opts)?
        } else if let Some(n) = args.noise {
            let noise = refine::noise::NoiseOptions {
                k: n.k * diagonal,
                lacunarity: n.lacunarity,
                h: n.h,
                bias: n.bias,
                feature: refine::noise::FeatureSize::Height { top: n.top },
            };
            refine::noise::subdivide_with_noise(mesh, &obj.corners, &options, &noise, n.seed)?
        } else {
            refine::subdivide(mesh, &obj.corners, &options)?
        };
        match args.pn {
            None => Ok(refined),
            Some(rule) => {
                let edge_rule = match rule {
                    PnArg::Standard => refine::pn::EdgeRule::Standard,
                    PnArg::Rounder => refine::pn::EdgeRule::Rounder,
                };
                let opts = refine::pn::PnOptions {
                    level: args.pn_level,
                    edge_rule,
                    diagonal_rule: refine::pn::EdgeRule::Standard,
                    interior: match args.pn_interior {
                        PnInteriorArg::Theyer => refine::pn::QuadInterior::Theyer,
                        PnInteriorArg::ZeroTwist => refine::pn::QuadInterior::ZeroTwist,
                    },
                    normals: match args.pn_normals {
                        PnNormalsArg::Linear => refine::pn::NormalInterpolation::Linear,
                        PnNormalsArg::Quadratic => refine::pn::NormalInterpolation::Quadratic,
                    },
                    source: refine::pn::NormalSource::Mesh,
                    max_faces: args.max_faces,
                };
                refine::pn::pn_tessellate(&refined, &opts)
            }
        }
    };
    let refined = match args.threads {
        Some(n) if n > 1 => {
            refine::with_threads(n, subdivide).map_err(|e| miette::miette!("--threads {n}: {e}"))?
        }
        _ => subdivide(),
    }
    .map_err(|e| miette::Report::new(e).wrap_err(format!("cannot subdivide {}", args.input.display())))?;
    let name =
        args.input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
    let (faces, verts) = (refined.face_count(), refined.vertex_count());
    let model = Model {
        parts: vec![Part { name, mesh: refined, material: Material::bark(), ..Default::default() }],
        ..Default::default()
    };
    sylva::export::write(&model, &args.output)?;
    if !args.quiet {
        let scheme = match scheme {
            Scheme::Loop => "Loop",
            Scheme::CatmullClark => "Catmull–Clark",
        };
        println!(
            "wrote {}: {faces} faces, {verts} vertices ({scheme}, {} {}levels{}{}{}) in {:.0} ms",
            args.output.display(),
            args.levels,
            if args.adaptive.is_some() { "adaptive " } else { "" },
            if args.limit { ", limit" } else { "" },
            if args.noise.is_some() { ", noise" } else { "" },
            if args.pn.is_some() { format!(", PN level {}", args.pn_level) } else { String::new() },
            start.elapsed().as_secs_f64() * 1e3
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("sylva-subdivide-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    fn args(input: PathBuf, output: PathBuf) -> SubdivideArgs {
        SubdivideArgs {
            input,
            output,
            scheme: None,
            levels: 2,
            limit: false,
            uv: UvArg::Linear,
            creasing: None,
            boundary: None,
            max_faces: refine::DEFAULT_MAX_FACES,
            threads: None,
            adaptive: None,
            pn: None,
            pn_level: 4,
            pn_interior: PnInteriorArg::Theyer,
            pn_normals: PnNormalsArg::Quadratic,
            noise: None,
            quiet: true,
        }
    }

    const CUBE: &str = "v -1 -1 -1\nv 1 -1 -1\nv -1 1 -1\nv 1 1 -1\nv -1 -1 1\nv 1 -1 1\nv -1 1 1\nv 1 1 1\n\
                        f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\nt crease 2/1 0 1 10\n";

    #[test]
    fn subdivides_a_cube_to_every_format() {
        let input = temp("cube.obj");
        std::fs::write(&input, CUBE).unwrap();
        for ext in ["obj", "glb", "ply"] {
            let out = temp(&format!("cube-out.{ext}"));
            run(SubdivideArgs { limit: true, ..args(input.clone(), out.clone()) }).unwrap();
            assert!(std::fs::metadata(&out).unwrap().len() > 0);
        }
        let back = sylva::mesh::obj_read::read_obj(&temp("cube-out.obj")).unwrap();
        assert_eq!(back.mesh.face_count(), 6 * 16);
    }

    #[test]
    fn clear_errors() {
        let input = temp("quads.obj");
        std::fs::write(&input, CUBE).unwrap();
        let loop_on_quads =
            SubdivideArgs { scheme: Some(SchemeArg::Loop), ..args(input.clone(), temp("x.obj")) };
        let e = format!("{:?}", run(loop_on_quads).unwrap_err());
        assert!(e.contains("Loop subdivision needs triangles"), "{e}");
        let too_big = SubdivideArgs { levels: 12, ..args(input.clone(), temp("x.obj")) };
        let e = format!("{:?}", run(too_big).unwrap_err());
        assert!(e.contains("100000000"), "{e}");
        let e = format!("{:?}", run(args(input.clone(), temp("x.stl"))).unwrap_err());
        assert!(e.contains(".glb"), "{e}");
        let bad = temp("bad.obj");
        std::fs::write(&bad, "v 0 0 0\nf 1 2 3\n").unwrap();
        let e = format!("{:?}", run(args(bad, temp("x.obj"))).unwrap_err());
        assert!(e.contains("line 2"), "{e}");
        assert!(!temp("x.obj").exists());
    }

    const TETRA: &str = "v 1 1 1\nv -1 -1 1\nv -1 1 -1\nv 1 -1 -1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";

    #[test]
    fn adaptive_pn_and_noise_flags() {
        let input = temp("tetra.obj");
        std::fs::write(&input, TETRA).unwrap();
        let out = temp("tetra-out.obj");
        let adaptive = parse_adaptive("flatness=15deg,size=0.001").unwrap();
        assert!((adaptive.flatness - 15f32.to_radians()).abs() < 1e-6);
        run(SubdivideArgs { adaptive: Some(adaptive), levels: 3, ..args(input.clone(), out.clone()) })
            .unwrap();
        let back = sylva::mesh::obj_read::read_obj(&out).unwrap();
        assert!(back.mesh.face_count() > 4 && back.mesh.face_count() <= 4 * 64);
        run(SubdivideArgs {
            pn: Some(PnArg::Rounder),
            pn_level: 3,
            levels: 1,
            ..args(input.clone(), out.clone())
        })
        .unwrap();
        let back = sylva::mesh::obj_read::read_obj(&out).unwrap();
        assert_eq!(back.mesh.face_count(), 16 * 9);
        let noise = parse_noise("k=0.01,h=0.5,bias=0.3,seed=9").unwrap();
        run(SubdivideArgs { noise: Some(noise), ..args(input.clone(), out.clone()) }).unwrap();
        let a = std::fs::read(&out).unwrap();
        run(SubdivideArgs { noise: Some(noise), ..args(input.clone(), out.clone()) }).unwrap();
        assert_eq!(a, std::fs::read(&out).unwrap(), "seeded noise is deterministic");
    }

    #[test]
    fn bad_adaptive_pn_and_noise_values_are_clear_errors() {
        for (s, want) in [
            ("flatness=abc", "not a finite number"),
            ("flatness=-1", "≥ 0"),
            ("size=-2", "≥ 0"),
            ("depth=3", "unknown key `depth`"),
            ("flatness", "not key=value"),
            ("size=1,size=2", "twice"),
        ] {
            let e = parse_adaptive(s).unwrap_err();
            assert!(e.contains(want), "{s}: {e}");
        }
        for (s, want) in [
            ("k=-1", "≥ 0"),
            ("h=2", "[0, 1]"),
            ("bias=1.5", "[0, 1]"),
            ("l=0", "> 0"),
            ("seed=-3", "integer"),
            ("k=nan", "finite"),
            ("q=1", "unknown key"),
        ] {
            let e = parse_noise(s).unwrap_err();
            assert!(e.contains(want), "{s}: {e}");
        }
        let input = temp("cube-adaptive.obj");
        std::fs::write(&input, CUBE).unwrap();
        let a = parse_adaptive("flatness=0.2,size=0").unwrap();
        let e = format!(
            "{:?}",
            run(SubdivideArgs { adaptive: Some(a), ..args(input.clone(), temp("y.obj")) }).unwrap_err()
        );
        assert!(e.contains("Catmull–Clark"), "{e}");
        let tetra = temp("tetra2.obj");
        std::fs::write(&tetra, TETRA).unwrap();
        let both = SubdivideArgs { adaptive: Some(a), limit: true, ..args(tetra.clone(), temp("y.obj")) };
        let e = format!("{:?}", run(both).unwrap_err());
        assert!(e.contains("--limit"), "{e}");
        let huge = SubdivideArgs {
            pn: Some(PnArg::Standard),
            pn_level: 1024,
            levels: 3,
            ..args(tetra, temp("y.obj"))
        };
        let e = format!("{:?}", run(huge).unwrap_err());
        assert!(e.contains("100000000"), "{e}");
    }
}
