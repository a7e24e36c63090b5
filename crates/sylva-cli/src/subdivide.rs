//! `sylva subdivide`: refine an OBJ control mesh with Loop or Catmull–Clark and write it
//! as glTF, OBJ or PLY (issue 4 item 9; the engine is `sylva::refine`).
//!
//! Creases and corners come from OpenSubdiv-style tags in the OBJ
//! (`t crease 2/1 v0 v1 sharpness`, `t corner 1/1 v sharpness`); see
//! `sylva::mesh::obj_read`.

use miette::{IntoDiagnostic, Result};
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
    /// UV interpolation: linear everywhere, or smooth inside with linear seams and borders.
    #[arg(long, value_enum, default_value_t = UvArg::Linear)]
    pub uv: UvArg,
    /// Semi-sharp crease decay: uniform (OpenSubdiv's default) or Chaikin.
    #[arg(long, value_enum)]
    pub creasing: Option<CreasingArg>,
    /// Refuse to write more faces than this.
    #[arg(long, value_name = "FACES", default_value_t = refine::DEFAULT_MAX_FACES)]
    pub max_faces: usize,
    /// Worker threads (default: all cores; the output is identical for any count).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
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
    /// Linear everywhere (UVs never shrink).
    Linear,
    /// Smooth inside each UV chart; seams and borders linear with their corners pinned.
    Smooth,
    /// Smooth inside; seams and borders as smooth curves with chart corners pinned.
    SmoothCurves,
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
            boundary: obj.boundary.unwrap_or_default(),
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
        },
    };
    let subdivide = || refine::subdivide(mesh, &obj.corners, &options);
    let refined = match args.threads {
        Some(n) if n > 1 => refine::with_threads(n, subdivide).into_diagnostic()?,
        _ => subdivide(),
    }
    .map_err(|e| miette::Report::new(e).wrap_err(format!("cannot subdivide {}", args.input.display())))?;
    let name =
        args.input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
    let (faces, verts) = (refined.face_count(), refined.vertex_count());
    let model = Model { parts: vec![Part { name, mesh: refined, material: Material::bark() }] };
    sylva::export::write(&model, &args.output)?;
    if !args.quiet {
        let scheme = match scheme {
            Scheme::Loop => "Loop",
            Scheme::CatmullClark => "Catmull–Clark",
        };
        println!(
            "wrote {}: {faces} faces, {verts} vertices ({scheme}, {} levels{}) in {:.0} ms",
            args.output.display(),
            args.levels,
            if args.limit { ", limit" } else { "" },
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
            max_faces: refine::DEFAULT_MAX_FACES,
            threads: None,
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
}
