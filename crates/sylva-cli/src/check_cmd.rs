//! `sylva check`: is a mesh file a valid 2-manifold? (issue 5 item 5; the engine is
//! `sylva::mesh::check`).
//!
//! Reads OBJ (one mesh) or glTF/GLB (one report per triangle primitive, with vertices at
//! identical positions welded first, since glTF splits vertices at UV seams), prints a
//! report per mesh and exits with a non-zero status when any mesh is invalid or the file
//! cannot be read.

use miette::{IntoDiagnostic, Result};
use std::path::PathBuf;
use sylva::mesh::check::{check_mesh, CheckOptions};

/// Arguments of `sylva check`.
#[derive(clap::Args, Debug, Clone)]
pub struct CheckArgs {
    /// Mesh file: .obj, .glb or .gltf.
    pub input: PathBuf,
    /// Skip the self-intersection test (the slow part on big meshes).
    #[arg(long)]
    pub no_intersections: bool,
    /// Do not weld glTF vertices that share a position.
    #[arg(long)]
    pub no_weld: bool,
    /// Also fail when a mesh has boundary edges (require closed meshes).
    #[arg(long)]
    pub closed: bool,
    /// Work budget of the self-intersection search: it stops after looking at this many
    /// candidate triangle pairs (pairs whose boxes overlap) and the check fails saying
    /// so. Raise it for huge or heavily overlapping meshes.
    #[arg(long, value_name = "N", default_value_t = sylva::mesh::check::DEFAULT_MAX_PAIRS)]
    pub max_pairs: u64,
}

/// Runs `sylva check`; an error when a mesh is invalid.
pub fn run(args: CheckArgs) -> Result<()> {
    let ext = args.input.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    // (name, mesh, the index of an earlier mesh with the same triangles).
    let meshes: Vec<(String, sylva::Mesh, Option<usize>)> = match ext.as_str() {
        "obj" => {
            vec![("obj".into(), sylva::mesh::obj_read::read_obj(&args.input).into_diagnostic()?.mesh, None)]
        }
        "glb" | "gltf" => sylva::import::gltf_read::read_gltf(&args.input)?
            .into_iter()
            .map(|mut g| {
                if !args.no_weld {
                    sylva::import::gltf_read::weld(&mut g.mesh);
                }
                (g.name, g.mesh, g.same_as)
            })
            .collect(),
        _ => {
            return Err(sylva::Error::UnknownFormat {
                path: args.input.clone(),
                expected: ".obj, .glb, .gltf",
            }
            .into())
        }
    };
    if meshes.is_empty() {
        return Err(miette::miette!("{}: no triangle meshes to check", args.input.display()));
    }
    let opts = CheckOptions {
        self_intersections: !args.no_intersections,
        max_pairs: args.max_pairs,
        ..Default::default()
    };
    let mut ok = true;
    let mut stopped = false;
    for (name, mesh, same_as) in &meshes {
        if let Some(first) = same_as {
            // A primitive drawn again: its triangles were checked once, above.
            let first = meshes.get(*first).map_or("an earlier primitive", |m| m.0.as_str());
            println!(
                "{}: {name}\nthe same triangles as {first} (checked once, above)\n",
                args.input.display()
            );
            continue;
        }
        let report = check_mesh(mesh, &opts);
        let valid = if args.closed { report.is_closed_manifold() } else { report.is_valid() };
        ok &= valid;
        stopped |= report.search_stopped;
        println!("{}: {name}\n{report}\n", args.input.display());
    }
    if ok {
        Ok(())
    } else if stopped {
        Err(miette::miette!(
            "{}: the mesh is not shown valid: the self-intersection search stopped at its budget of {} candidate \
             triangle pairs (raise it with --max-pairs N, or skip the search with --no-intersections)",
            args.input.display(),
            args.max_pairs
        ))
    } else {
        Err(miette::miette!("{}: the mesh is not valid (see the problems above)", args.input.display()))
    }
}
