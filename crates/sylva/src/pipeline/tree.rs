//! What a run made, explaining itself: [`Tree::to_glb`], [`Tree::write`] by the file's
//! extension, and the summary every front end prints ([`Report`]'s and [`Tree`]'s
//! `Display`), so the CLI, Python and the editor say the same thing.

use super::{Report, Tree};
use crate::error::Result;
use std::fmt;
use std::path::Path;

impl Tree {
    /// The tree as a binary glTF (`.glb`) file's bytes, with the recipe's `[output]`
    /// settings (textures embedded unless `output.textures = "none"`, compression, LOD
    /// layout).
    pub fn to_glb(&self) -> Result<Vec<u8>> {
        let mut options = self.recipe.output.export_options(Path::new("tree.glb"))?;
        // Bytes in memory have no folder for side files: `files` embeds too.
        if matches!(options.textures, crate::export::TextureMode::Files { .. }) {
            options.textures = crate::export::TextureMode::Embed;
        }
        crate::export::gltf::to_glb_with(&self.model, &options)
    }

    /// Writes the tree to `path` in the format its extension names: a mesh format
    /// (`.glb`, `.gltf`, `.obj`, `.ply`, `.pov`, with their side files) with the recipe's
    /// `[output]` settings, or the skeleton (`.lst`, `.json`). All files reach their
    /// names together or not at all ([`crate::fsutil::OutputSet`]).
    pub fn write(&self, path: &Path) -> Result<()> {
        let mut set = crate::fsutil::OutputSet::new(path);
        self.stage(path, &mut set)?;
        set.commit()
    }

    /// [`Tree::write`] staged into `set` (committed by the caller with the run's other
    /// outputs).
    pub fn stage(&self, path: &Path, set: &mut crate::fsutil::OutputSet) -> Result<()> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if ext == "lst" || ext == "json" {
            crate::export::skeleton::stage(&self.skeleton, path, set)
        } else {
            let options = self.recipe.output.export_options(path)?;
            crate::export::stage_with_options(&self.model, path, &options, set)
        }
    }
}

fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The lines of a run's summary after its title: the generator, skeleton, passes, mesh
/// and stage times, each line indented by two spaces and ended by a newline.
impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self;
        let s = &r.skeleton;
        if r.summary.is_empty() {
            writeln!(
                f,
                "  derived {} steps, {} modules in {:.1} ms; turtle {:.1} ms; mesh {:.1} ms",
                r.steps,
                r.modules,
                ms(r.derive_time),
                ms(r.interpret_time),
                ms(r.mesh_time)
            )?;
        } else {
            writeln!(f, "  {}; mesh {:.1} ms", r.summary, ms(r.mesh_time))?;
        }
        writeln!(
            f,
            "  skeleton: {} nodes, {} segments, {} tips, depth {}, max order {}, total length {:.3} m, height {:.3} m",
            s.nodes,
            s.segments,
            s.tips,
            s.depth,
            s.max_order,
            s.total_length,
            s.bounds.1.y - s.bounds.0.y
        )?;
        if let Some(d) = &r.decollide {
            writeln!(
                f,
                "  decollide: {} skeleton collision(s), {} resolved, {} left ({} nodes thinned, {} branches moved, {} tips pulled back, {} stubs moved or bent, {} traded, {} rounds, {:.1} ms)",
                d.before,
                d.resolved(),
                d.after,
                d.thinned,
                d.rotations,
                d.retracted,
                d.extended,
                d.traded,
                d.rounds,
                ms(d.elapsed)
            )?;
        }
        if let Some(c) = &r.clear {
            match (c.before, c.after) {
                (Some(before), Some(after)) => writeln!(
                    f,
                    "  clear: {before} crossing face pair(s) in the refined mesh, {}{after} left ({} nodes thinned, {} rounds, {:.1} ms)",
                    if c.truncated { "at least " } else { "" },
                    c.thinned,
                    c.rounds,
                    ms(c.elapsed)
                )?,
                _ => writeln!(f, "  clear: not searched (the refined mesh is too large; see the warning)")?,
            }
        }
        // A report of the skeleton alone (`Session::skeleton_with`) has no mesh line.
        if r.axes + r.triangles + r.vertices > 0 {
            writeln!(f, "  mesh: {} axes, {} triangles, {} vertices", r.axes, r.triangles, r.vertices)?;
        }
        if !r.stage_times.is_empty() {
            let stages: Vec<String> =
                r.stage_times.iter().map(|(name, t)| format!("{name} {:.1}", ms(*t))).collect();
            writeln!(f, "  stages (ms): {}", stages.join(", "))?;
        }
        Ok(())
    }
}

/// The whole summary: `name: description`, the [`Report`]'s lines, the wind clip and the
/// LOD levels.
impl fmt::Display for Tree {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{}: {}", self.recipe.name, self.recipe.description)?;
        write!(f, "{}", self.report)?;
        let r = &self.report;
        if r.joints > 0 {
            let clip = self.model.clip.as_ref().map_or(0.0, |c| c.duration());
            writeln!(f, "  wind: {} joints, {:.1} s clip, {:.1} ms", r.joints, clip, ms(r.wind_time))?;
        }
        for (k, lod) in self.model.lods.iter().enumerate() {
            let tris: usize = lod.parts.iter().map(|p| p.mesh.triangle_count()).sum();
            writeln!(
                f,
                "  LOD{}: {} triangles, from {:.0} % of the view",
                k + 1,
                tris,
                lod.screen_coverage * 100.0
            )?;
        }
        Ok(())
    }
}
