//! `sylva subdivide`: refine an OBJ control mesh with Loop or Catmull–Clark and write it
//! as glTF, OBJ or PLY (issue 4 item 9). The policy (the scheme for the mesh, the rules
//! from its tags, the combinations refused, the run) is the library's
//! `sylva::refine::policy`; this file parses flags into its request, with the library's
//! own names for every option.
//!
//! Creases and corners come from OpenSubdiv-style tags in the OBJ
//! (`t crease 2/1 v0 v1 sharpness`, `t corner 1/1 v sharpness`); see
//! `sylva::mesh::obj_read`.

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use miette::Result;
use std::path::PathBuf;
use std::time::Instant;
use sylva::refine::pn::{EdgeRule, NormalInterpolation, QuadInterior};
use sylva::refine::policy::{self, Adaptive, MeshTags, Named, Noise, Pn, PolicyError, SubdivideRequest};
use sylva::refine::{self, BoundaryInterpolation, CreasingMethod, FvarInterpolation, Scheme};
use sylva::{Material, Model, Part};

/// A clap value parser for a library option written by name ([`Named`]): the names and
/// their help in `--help`, the aliases accepted.
fn named<T: Named + Clone + Send + Sync>() -> impl TypedValueParser<Value = T> {
    let values = T::ALL.iter().map(|v| PossibleValue::new(v.name()).aliases(v.aliases()).help(v.help()));
    PossibleValuesParser::new(values).map(|s| T::from_name(&s).expect("clap checked the name"))
}

/// Arguments of `sylva subdivide`.
#[derive(clap::Args, Debug, Clone)]
pub struct SubdivideArgs {
    /// Control mesh (.obj). Crease and corner tags (`t crease 2/1 a b s`) are honoured.
    pub input: PathBuf,
    /// Output file; the extension picks the format (.glb, .gltf, .obj, .ply).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Subdivision scheme. Default: Loop for all-triangle meshes, else Catmull–Clark.
    #[arg(long, value_parser = named::<Scheme>())]
    pub scheme: Option<Scheme>,
    /// Uniform refinement levels (each multiplies the face count by 4).
    #[arg(short = 'n', long, default_value_t = 2)]
    pub levels: u32,
    /// Move the vertices to the limit surface and write exact limit normals.
    #[arg(long)]
    pub limit: bool,
    /// UV interpolation (OpenSubdiv's face-varying rules; docs/subdivision.md lists them).
    #[arg(long, default_value = "linear", value_parser = named::<FvarInterpolation>())]
    pub uv: FvarInterpolation,
    /// Semi-sharp crease decay: uniform (OpenSubdiv's default) or Chaikin.
    #[arg(long, value_parser = named::<CreasingMethod>())]
    pub creasing: Option<CreasingMethod>,
    /// Where boundary vertices go: `bspline` (the rim refines as a cubic B-spline, its
    /// single-face corners pinned; OpenSubdiv's `interpolateboundary 1`), `edge-only`
    /// (`interpolateboundary 2`) or `fixed` (Pieterse2012's rule: every boundary vertex stays
    /// put, so the rim stays the control polygon). Default: the OBJ's `interpolateboundary`
    /// tag, else `bspline`.
    #[arg(long, value_parser = named::<BoundaryInterpolation>())]
    pub boundary: Option<BoundaryInterpolation>,
    /// Refuse to write more faces than this.
    #[arg(long, value_name = "FACES", default_value_t = refine::DEFAULT_MAX_FACES)]
    pub max_faces: usize,
    /// Refuse a subdivision that would need more memory than this at its peak, in bytes,
    /// 1..=2^40 like the recipe's `refine.max_memory` (default 4 GiB; checked before any level is made, so a machine with less memory
    /// gets an error instead of an abort).
    #[arg(long, value_name = "BYTES", default_value_t = refine::DEFAULT_MAX_MEMORY,
          value_parser = crate::args::whole_in::<u64>(1, sylva::recipe::REFINE_MAX_MEMORY_LIMIT))]
    pub max_memory: u64,
    /// Worker threads, 1..=1024 (`refine::MAX_THREADS`; default: all cores; the output is
    /// identical for any count).
    #[arg(long, value_parser = crate::args::whole_in::<usize>(1, refine::MAX_THREADS as u64))]
    pub threads: Option<usize>,
    /// Adaptive Loop refinement instead of uniform (MacMurchy2004): `flatness=RAD,size=AREA`
    /// (flatness in radians, or degrees with a `deg` suffix; size = smallest triangle
    /// area to split). `-n` is the deepest level. Output is crack-free.
    #[arg(long, value_name = "flatness=F,size=S", value_parser = parse_adaptive)]
    pub adaptive: Option<Adaptive>,
    /// Tessellate the (subdivided) mesh with PN triangles / PN quads (Skjermo2008): `standard`
    /// (⅓ edge rule) or `rounder` (½ rule). Use `-n 0` or `-n 1` before PN.
    #[arg(long, value_name = "RULE", value_parser = named::<EdgeRule>())]
    pub pn: Option<EdgeRule>,
    /// Segments per patch edge for `--pn` (each face becomes level² faces).
    #[arg(long, value_name = "K", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub pn_level: u32,
    /// Inner control points of PN quads: Theyer's diagonals or zero twist.
    #[arg(long, default_value = "theyer", value_parser = named::<QuadInterior>())]
    pub pn_interior: QuadInterior,
    /// Normal interpolation across PN patches.
    #[arg(long, default_value = "quadratic", value_parser = named::<NormalInterpolation>())]
    pub pn_normals: NormalInterpolation,
    /// Fractal noise after every uniform level (MacMurchy2004 §6.5): `k=K,h=H,bias=B` and
    /// optionally `l=LACUNARITY` (default 2), `top=T` (feature size at the top of the mesh;
    /// t falls from 1 at the base, default 0.25; 1 = uniform), `seed=N`. K is a fraction of
    /// the bounding-box diagonal.
    #[arg(long, value_name = "k=K,h=H,bias=B", value_parser = parse_noise)]
    pub noise: Option<Noise>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
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
pub fn parse_adaptive(s: &str) -> Result<Adaptive, String> {
    let mut a = Adaptive::default();
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
pub fn parse_noise(s: &str) -> Result<Noise, String> {
    let mut a = Noise::default();
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

/// The library's request for these flags.
fn request(args: &SubdivideArgs) -> SubdivideRequest {
    SubdivideRequest {
        scheme: args.scheme,
        levels: args.levels,
        limit: args.limit,
        uv: args.uv,
        creasing: args.creasing,
        boundary: args.boundary,
        max_faces: args.max_faces,
        max_memory: args.max_memory,
        parallel: args.threads != Some(1),
        adaptive: args.adaptive,
        noise: args.noise,
        pn: args.pn.map(|rule| Pn {
            rule,
            level: args.pn_level,
            interior: args.pn_interior,
            normals: args.pn_normals,
        }),
    }
}

/// A refused combination, in the flags' words.
fn policy_error(e: PolicyError) -> miette::Report {
    match e {
        PolicyError::AdaptiveNeedsLoop => miette::miette!(
            "--adaptive refines triangles with Loop's scheme; it cannot be used with Catmull–Clark"
        ),
        PolicyError::AdaptiveNeedsUniform => {
            miette::miette!(
                "--adaptive cannot be combined with --noise or --limit (they need uniform levels)"
            )
        }
        PolicyError::AdaptiveNeedsLinearUv => {
            miette::miette!("--adaptive carries UVs linearly; use --uv linear")
        }
    }
}

/// A refinement error, with the budgets named by their flags.
fn refine_error(e: refine::RefineError, args: &SubdivideArgs) -> miette::Report {
    let input = args.input.display();
    match e {
        refine::RefineError::Budget { levels, faces, limit } => miette::miette!(
            "cannot subdivide {input}: {levels} levels (-n) would make {faces} faces, more than --max-faces {limit} \
             (use fewer levels, or raise --max-faces)"
        ),
        refine::RefineError::Memory { levels, faces, bytes, limit } => miette::miette!(
            "cannot subdivide {input}: {levels} levels (-n) would make {faces} faces and need about {bytes} bytes \
             at the refinement's peak, more than --max-memory {limit} (use fewer levels, or raise --max-memory \
             if the machine has the memory)"
        ),
        refine::RefineError::OutOfMemory { what, bytes } => miette::miette!(
            "cannot subdivide {input}: its {what} need {bytes} bytes, which the system could not allocate (use \
             fewer levels, or lower --max-memory to what the machine has so the estimate stops it first)"
        ),
        e => miette::Report::new(e).wrap_err(format!("cannot subdivide {input}")),
    }
}

/// Runs `sylva subdivide`.
pub fn run(args: SubdivideArgs) -> Result<()> {
    // Fail on a bad extension before doing any work.
    sylva::export::Format::from_path(&args.output)?;
    let start = Instant::now();
    let obj = sylva::mesh::obj_read::read_obj(&args.input)?;
    let tags = MeshTags { boundary: obj.boundary, creasing: obj.creasing };
    let plan = policy::plan(&request(&args), &obj.mesh, tags).map_err(policy_error)?;
    let subdivide = || plan.run(&obj.mesh, &obj.corners);
    let refined = match args.threads {
        Some(n) if n > 1 => {
            refine::with_threads(n, subdivide).map_err(|e| miette::miette!("--threads {n}: {e}"))?
        }
        _ => subdivide(),
    }
    .map_err(|e| refine_error(e, &args))?;
    let name =
        args.input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
    let (faces, verts) = (refined.face_count(), refined.vertex_count());
    let model = Model {
        parts: vec![Part { name, mesh: refined, material: Material::bark(), ..Default::default() }],
        ..Default::default()
    };
    sylva::export::write(&model, &args.output)?;
    if !args.quiet {
        let scheme = match plan.scheme() {
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

    /// The arguments `sylva subdivide INPUT -o OUTPUT --quiet` parses to: every other
    /// flag at its command-line default.
    fn args(input: PathBuf, output: PathBuf) -> SubdivideArgs {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: SubdivideArgs,
        }
        let words = [PathBuf::from("subdivide"), input, "-o".into(), output, "--quiet".into()];
        <Cli as clap::Parser>::parse_from(words).args
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
            SubdivideArgs { scheme: Some(Scheme::Loop), ..args(input.clone(), temp("x.obj")) };
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
            pn: Some(EdgeRule::Rounder),
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
        let adaptive: fn(&str) -> Result<(), String> = |s| parse_adaptive(s).map(drop);
        let noise: fn(&str) -> Result<(), String> = |s| parse_noise(s).map(drop);
        let cases: [(_, &[(&str, &str)]); 2] = [
            (
                adaptive,
                &[
                    ("flatness=abc", "not a finite number"),
                    ("flatness=-1", "≥ 0"),
                    ("size=-2", "≥ 0"),
                    ("depth=3", "unknown key `depth`"),
                    ("flatness", "not key=value"),
                    ("size=1,size=2", "twice"),
                ],
            ),
            (
                noise,
                &[
                    ("k=-1", "≥ 0"),
                    ("h=2", "[0, 1]"),
                    ("bias=1.5", "[0, 1]"),
                    ("l=0", "> 0"),
                    ("seed=-3", "integer"),
                    ("k=nan", "finite"),
                    ("q=1", "unknown key"),
                ],
            ),
        ];
        for (parse, bad) in cases {
            for (s, want) in bad {
                let e = parse(s).unwrap_err();
                assert!(e.contains(want), "{s}: {e}");
            }
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
            pn: Some(EdgeRule::Standard),
            pn_level: 1024,
            levels: 3,
            ..args(tetra, temp("y.obj"))
        };
        let e = format!("{:?}", run(huge).unwrap_err());
        assert!(e.contains("100000000"), "{e}");
    }
}
