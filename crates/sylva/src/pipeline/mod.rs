//! The whole pipeline for one recipe: generator → [`Skeleton`] → mesher → [`Model`].
//!
//! Pure data in, data out: reading the recipe's model files goes through
//! [`Loaded::read`]; writing outputs is the caller's (the CLI's) job.

mod fit;
mod generate;
pub mod session;
mod tree;

pub use fit::{check_degenerate, clear_skeleton, decollide_skeleton, shape_stage, Fitted};
pub(crate) use fit::{check_mesh_memory, fit_stage, sink};
pub use generate::{derive_lsystem, skeleton, turtle_options, Derived, Generated};

use crate::error::{Error, Result};
use crate::export::TextureMode;
use crate::geometry::Mesh;
use crate::input::SideFiles;
use crate::lsystem::files::view::{LineStyle, MovementKind};
use crate::lsystem::files::{folder_of, load_folder_in, ModelFolder};
use crate::lsystem::{self, DeriveOptions, LSystem, TurtleOptions};
use crate::mesh::ground::SunkRoot;
use crate::model::{BranchCurves, Material, Model, Part};
use crate::recipe::{
    Generator, LeafMode, LeafNormals, Loaded, LsystemGenerator, MeshBase, MeshMethod, Origin, Recipe,
};
use crate::skeleton::{Skeleton, SkeletonStats};
use std::collections::HashMap;
use std::time::{Duration, Instant};

/// What a run built, with timings.
#[derive(Debug, Clone, Default)]
pub struct Report {
    /// Derivation steps applied.
    pub steps: u32,
    /// Modules in the derived string.
    pub modules: usize,
    /// Skeleton statistics.
    pub skeleton: SkeletonStats,
    /// Axes the mesher built.
    pub axes: usize,
    /// Triangles in the model.
    pub triangles: usize,
    /// Vertices in the model.
    pub vertices: usize,
    /// Time spent deriving.
    pub derive_time: Duration,
    /// Time spent interpreting (homomorphism + turtle).
    pub interpret_time: Duration,
    /// Time spent meshing.
    pub mesh_time: Duration,
    /// What the skeleton de-collision did (`mesh.decollide`), when it ran.
    pub decollide: Option<crate::fit::decollide::DecollideReport>,
    /// What the mesh-checked thinning did (`mesh.clear`), when it ran.
    pub clear: Option<crate::fit::clear::ClearReport>,
    /// Surfaces (`~x`) the model places but no `.s` file provides.
    pub missing_surfaces: Vec<String>,
    /// Problems that did not stop the run (printed by the CLI): at most
    /// [`MAX_WARNINGS`], each clipped like an error's message ([`clip_warnings`]).
    pub warnings: Vec<String>,
    /// One line from generators other than the L-system: what they built.
    pub summary: String,
    /// Joints of the wind rig (0 without `[wind]`).
    pub joints: usize,
    /// Time spent rigging, skinning and baking the wind clip.
    pub wind_time: Duration,
    /// Work the quad mesher's repair spent in this run's meshings, against
    /// `mesh.quad.max_repair_work` (shared by every meshing of the run but the LOD
    /// levels').
    pub repair_work: u64,
    /// Wall time of each stage the last run computed, by stage name
    /// ([`crate::session::Stage::name`]); stages a session kept are not listed.
    pub stage_times: Vec<(&'static str, Duration)>,
}

/// The products of a run: the tree a recipe makes ([`Tree::to_glb`], [`Tree::write`],
/// and a `Display` summary).
#[derive(Debug, Clone)]
pub struct Tree {
    /// The skeleton.
    pub skeleton: Skeleton,
    /// The meshed model.
    pub model: Model,
    /// What was built.
    pub report: Report,
    /// The recipe it was made from.
    pub recipe: Recipe,
}

/// The former name of [`Tree`].
pub type Grown = Tree;

/// Meshes a skeleton as the recipe's `[mesh]` section says.
pub fn mesh(
    recipe: &Recipe,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let mut sunk_skeleton = skeleton.clone();
    let sunk = sink(recipe, &mut sunk_skeleton);
    mesh_sunk(recipe, &sunk_skeleton, &sunk, surfaces, report)
}

/// [`mesh`] of a skeleton whose roots [`sink`] has already moved.
fn mesh_sunk(
    recipe: &Recipe,
    skeleton: &Skeleton,
    sunk: &[SunkRoot],
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let fitted = mesh_fitted(recipe, skeleton, report)?;
    finish(recipe, fitted, skeleton, sunk, surfaces, report)
}

/// Refines the bark's control mesh and adds the leaves: the model.
fn finish(
    recipe: &Recipe,
    fitted: Fitted,
    skeleton: &Skeleton,
    sunk: &[SunkRoot],
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> Result<Model> {
    let bark = bark_stage(recipe, fitted, sunk, report)?;
    let (mut model, card_nodes) = assemble_stage(recipe, bark, skeleton, surfaces, report);
    dress_stage(recipe, &mut model, &card_nodes, &mut crate::texture::TextureCache::default(), report)?;
    Ok(model)
}

/// The bark stage: refines the fitted control mesh as `[refine]` says (unless the
/// fitting already did), checks `mesh.max_memory`, cuts the flat base at the sunk roots
/// and scales the UVs by `textures.scale`.
pub(crate) fn bark_stage(
    recipe: &Recipe,
    fitted: Fitted,
    sunk: &[SunkRoot],
    report: &mut Report,
) -> Result<Mesh> {
    let mut bark = match fitted.refined {
        Some(refined) => refined,
        None => refine_bark(recipe, fitted.control)?,
    };
    // A refined hero mesh makes each step below take seconds: a stopped run stops here.
    crate::cancel::check()?;
    check_mesh_memory(recipe, crate::mesh::memory::mesh_bytes(&bark), "")?;
    for (root, outcome) in sunk.iter().zip(crate::mesh::ground::cut_base(&mut bark, sunk)) {
        use crate::mesh::ground::CutOutcome;
        let why = match outcome {
            CutOutcome::Flat(_) => continue,
            CutOutcome::NothingBelow => "nothing near it reaches below its height",
            CutOutcome::Open => "the cut's loops do not close",
        };
        report.warnings.push(format!(
            "flat base: the trunk at root node {} is left as meshed ({why}); mesh.base = \"round\" keeps every mesher's own end",
            root.node
        ));
    }
    crate::cancel::check()?;
    if recipe.textures.scale != 1.0 {
        if let Some(uv) = bark.uvs.as_mut() {
            uv.values.iter_mut().for_each(|t| *t *= recipe.textures.scale);
        }
    }
    Ok(bark)
}

/// The assembly stage: the bark (or leaf-mode leaf) part, the organs' meshes and the leaf
/// cards, untextured. Returns the model and the skeleton node of each leaf card.
pub(crate) fn assemble_stage(
    recipe: &Recipe,
    bark: Mesh,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    report: &mut Report,
) -> (Model, Vec<u32>) {
    // The skeleton node of each leaf card, for instancing.
    let mut card_nodes = Vec::new();
    // Leaf mode (`mesh.method = "leaf"`) makes a leaf surface, not bark.
    let (name, material) = if recipe.mesh.method == MeshMethod::Leaf {
        ("leaf", Material::leaf())
    } else {
        ("bark", Material::bark())
    };
    let mut parts = vec![Part { name: name.into(), mesh: bark, material, ..Default::default() }];
    if !skeleton.organs.is_empty() {
        use crate::mesh::cards::{is_card_leaf, leaf_cards};
        let cards = recipe.leaves.mode.cards() && recipe.output.textures != TextureMode::None;
        let keep = |o: &crate::skeleton::Organ| !(cards && is_card_leaf(o));
        let (mut leaves, missing) = crate::mesh::organs::organ_mesh_where(skeleton, surfaces, keep);
        report.missing_surfaces = missing;
        let crown = recipe.leaves.normals == LeafNormals::Crown;
        if crown {
            crate::mesh::cards::bend_toward_crown(&mut leaves);
        }
        if leaves.face_count() > 0 {
            parts.push(Part {
                name: "leaves".into(),
                mesh: leaves,
                material: Material::leaf(),
                ..Default::default()
            });
        }
        if cards {
            // The cell's geometry only: the atlas itself is drawn by the texture stage.
            let atlas = crate::texture::leaf::atlas_layout(recipe.textures.atlas_size);
            let count = skeleton.organs.iter().filter(|o| is_card_leaf(o)).count();
            let (per_card, shape) = recipe.leaves.cards(count);
            let (mut mesh, nodes) = leaf_cards(skeleton, atlas.cell(shape), per_card);
            card_nodes = nodes;
            // One shared instanced shape cannot hold per-card bent normals.
            if crown && recipe.leaves.mode != LeafMode::Instanced {
                crate::mesh::cards::bend_toward_crown(&mut mesh);
            }
            if mesh.face_count() > 0 {
                let material = Material {
                    name: "leaf_card".into(),
                    double_sided: false,
                    alpha_cutoff: Some(recipe.leaves.alpha_cutoff),
                    ..Material::leaf()
                };
                parts.push(Part { name: "leaf_cards".into(), mesh, material, ..Default::default() });
            }
        }
    }
    (Model { parts, ..Default::default() }, card_nodes)
}

/// The dressing stage: textures from `cache` (drawn once per style, size and seed),
/// instancing of the leaf cards, and the report's triangle and vertex counts.
pub(crate) fn dress_stage(
    recipe: &Recipe,
    model: &mut Model,
    card_nodes: &[u32],
    cache: &mut crate::texture::TextureCache,
    report: &mut Report,
) -> Result<()> {
    texture_model(recipe, model, cache);
    if recipe.leaves.mode == LeafMode::Instanced {
        // The textured cards become one card shape and an instance per card, each on the
        // skeleton node of its first leaf.
        model.instance_cards("leaf_cards", card_nodes)?;
    }
    // Counted as drawn: every instance's shape once per instance.
    let drawn = model.flattened();
    report.triangles = drawn.triangle_count();
    report.vertices = drawn.vertex_count();
    Ok(())
}

/// The recipe as TOML for the file's metadata, without where the output goes (the same
/// tree written to two names is the same file).
pub(crate) fn provenance(recipe: &Recipe) -> Option<crate::model::Provenance> {
    let mut value = toml::Value::try_from(recipe).ok()?;
    if let Some(out) = value.get_mut("output").and_then(|o| o.as_table_mut()) {
        out.remove("file");
        out.remove("preview");
    }
    let text = toml::to_string(&value).ok()?;
    Some(crate::model::Provenance { recipe: text, seed: recipe.seed })
}

/// The texture stage (issue 23): draws the bark maps (and the leaf atlas when the model
/// has leaf cards) from the recipe's seed and points the materials at them. Nothing is
/// drawn for `output.textures = "none"`.
fn texture_model(recipe: &Recipe, model: &mut Model, cache: &mut crate::texture::TextureCache) {
    use crate::model::ModelImage;
    use crate::texture::bark;
    if recipe.output.textures == TextureMode::None {
        return;
    }
    let style = recipe.textures.bark.unwrap_or(match recipe.generator {
        crate::recipe::Generator::LeastCost(_) => bark::BarkStyle::Smooth,
        _ => bark::BarkStyle::Furrowed,
    });
    let cards = model.parts.iter().position(|p| p.name == "leaf_cards");
    // A model without bark (a leaf-mode leaf, a cpfg model of organs only) gets no bark
    // maps: nothing would use them.
    let has_bark = model.parts.iter().any(|p| p.name == "bark");
    let colour = {
        let c = crate::model::Material::leaf().base_color;
        [c[0], c[1], c[2]]
    };
    let (maps, atlas) = cache.get(
        has_bark.then_some((style, recipe.textures.bark_size, recipe.seed)),
        cards.map(|_| (recipe.textures.atlas_size, colour, recipe.seed)),
    );
    if let Some(maps) = maps {
        let first = model.images.len() as u32;
        for (name, image) in
            [("bark_albedo", maps.albedo), ("bark_normal", maps.normal), ("bark_orm", maps.orm)]
        {
            model.images.push(ModelImage { name: name.into(), image, repeat: true });
        }
        for part in model.parts.iter_mut().filter(|p| p.name == "bark") {
            part.material.maps = crate::model::MaterialMaps {
                base_color: Some(first),
                normal: Some(first + 1),
                occlusion_roughness_metallic: Some(first + 2),
            };
        }
    }
    if let (Some(i), Some(atlas)) = (cards, atlas) {
        let index = model.images.len() as u32;
        model.images.push(ModelImage { name: "leaf_atlas".into(), image: atlas, repeat: false });
        model.parts[i].material.maps.base_color = Some(index);
    }
}

/// The bark's control mesh of `skeleton` by the recipe's mesher (its warnings and axis
/// count go to `report`).
fn control_mesh(recipe: &Recipe, skeleton: &Skeleton, report: &mut Report) -> Result<Mesh> {
    let mut mesher = recipe.mesh.mesher();
    if let crate::mesh::Mesher::Quad(q) = &mut mesher {
        // One repair budget for every meshing of the run (the clearing meshes once a
        // round): what is left of it, at least 1 (the smallest value the mesher takes;
        // its next repair then stops with the budget's error).
        q.max_repair_work = q.max_repair_work.saturating_sub(report.repair_work).max(1);
        // The level-2 repair costs seconds per 10 k nodes: above the de-collision limit
        // (where the skeleton is not de-collided either) the cage is left as built.
        if skeleton.len() > crate::recipe::DECOLLIDE_AUTO_NODES {
            q.repair_rounds = 0;
            report.warnings.push(format!(
                "quad mesher: level-2 repair skipped on {} skeleton nodes (over the automatic limit of {}; the cage may cross itself after subdivision)",
                skeleton.len(),
                crate::recipe::DECOLLIDE_AUTO_NODES
            ));
        }
    }
    let cage = mesher.cage(skeleton)?;
    report.repair_work = report.repair_work.saturating_add(cage.work);
    report.axes = cage.axes;
    report.warnings.extend(cage.warnings);
    Ok(cage.mesh)
}

/// Subdivides the bark control mesh as `[refine]` says (unchanged for `none` or 0 levels).
fn refine_bark(recipe: &Recipe, mesh: Mesh) -> Result<Mesh> {
    use crate::refine::{subdivide, RefineOptions, SubdivideOptions};
    let Some(scheme) = recipe.refine_scheme() else { return Ok(mesh) };
    if recipe.refine.levels == 0 && !recipe.refine.limit {
        return Ok(mesh);
    }
    let opts = SubdivideOptions {
        refine: RefineOptions {
            scheme,
            levels: recipe.refine.levels,
            max_faces: recipe.refine.max_faces,
            max_memory: recipe.refine.max_memory,
            boundary: recipe.refine_boundary(),
            ..Default::default()
        },
        limit: recipe.refine.limit,
        ..Default::default()
    };
    // Without `limit` the result has no normals; the exporters compute smooth ones.
    subdivide(&mesh, &[], &opts).map_err(|e| refine_budget(recipe, e))
}

/// A `[refine]` face- or memory-budget error as a message naming `refine.max_faces` or
/// `refine.max_memory` and `refine.levels`; other refinement errors unchanged.
fn refine_budget(recipe: &Recipe, e: crate::refine::RefineError) -> Error {
    match e {
        crate::refine::RefineError::Budget { levels, faces, limit } => Error::Recipe(format!(
            "`refine.max_faces`: {levels} levels of subdivision would make {faces} faces, more than the face \
             budget of {limit} (use fewer `refine.levels`, or raise the budget with --set refine.max_faces=N; \
             a refined face costs about 200 bytes at the refinement's peak)"
        )),
        crate::refine::RefineError::Memory { levels, faces, bytes, limit } => Error::Recipe(format!(
            "`refine.max_memory`: {levels} levels of subdivision (`refine.levels`) would make {faces} faces and \
             need about {bytes} bytes at the refinement's peak, more than the memory budget of {limit} bytes \
             (use fewer `refine.levels`, or raise the budget with --set refine.max_memory=N if the machine \
             has the memory)"
        )),
        crate::refine::RefineError::OutOfMemory { what, bytes } => Error::Recipe(format!(
            "`refine.max_memory`: the subdivision (`refine.levels` = {}) ran out of memory: its {what} need {bytes} \
             bytes, which the system could not allocate (use fewer `refine.levels`, or lower \
             refine.max_memory to what the machine has so the budget stops it first)",
            recipe.refine.levels
        )),
        e => e.into(),
    }
}

/// The wind stage (issue 24): with `wind.preset` other than `none`, a rig of joints
/// chosen from the branch curves, skin weights and wind channels on every part of every
/// level, and a looping clip baked from the wind (see [`crate::wind`]).
pub fn wind_stage(recipe: &Recipe, model: &mut Model, report: &mut Report) {
    if let Some(plan) = rig_stage(recipe, model, report) {
        clip_stage(recipe, &plan, model, report);
    }
}

/// The rig half of [`wind_stage`]: joints from the branch curves within
/// `wind.max_joints`, skin weights and wind channels (`wind.leaf_flutter`) on every
/// part. Reads no other wind setting. `None` without wind.
pub(crate) fn rig_stage(
    recipe: &Recipe,
    model: &mut Model,
    report: &mut Report,
) -> Option<crate::wind::JointPlan> {
    recipe.wind.options()?;
    let t = Instant::now();
    let plan = crate::wind::JointPlan::new(&model.curves, recipe.wind.max_joints as usize);
    crate::wind::rig_model(model, &plan, recipe.wind.leaf_flutter as f32);
    report.joints = plan.rig.joints.len();
    report.wind_time = t.elapsed();
    Some(plan)
}

/// The clip half of [`wind_stage`]: the looping clip baked from the wind's preset,
/// strength, direction, gusts and stiffness over the rig `plan`.
pub(crate) fn clip_stage(
    recipe: &Recipe,
    plan: &crate::wind::JointPlan,
    model: &mut Model,
    report: &mut Report,
) {
    let Some(wind) = recipe.wind.options() else { return };
    let t = Instant::now();
    model.clip = Some(crate::wind::bake_clip(plan, &wind, recipe.wind.clip_seconds, recipe.wind.fps));
    report.wind_time += t.elapsed();
}

/// Runs the whole pipeline of a loaded recipe: a [`crate::session::Session`] that keeps
/// no stage, run once.
pub fn grow(loaded: &Loaded) -> Result<Tree> {
    let mut session = crate::session::Session::new(loaded.clone()).keep_stages(false);
    session.run()?;
    Ok(session.into_tree().expect("a successful run leaves a tree"))
}

/// The bark's control mesh of a fitted skeleton (the clearing did not leave one), with
/// its meshing time in `report`.
pub(crate) fn mesh_fitted(recipe: &Recipe, skeleton: &Skeleton, report: &mut Report) -> Result<Fitted> {
    let t = Instant::now();
    let control = control_mesh(recipe, skeleton, report)?;
    report.mesh_time = t.elapsed();
    Ok(Fitted { control, refined: None })
}

/// The LOD stage (issue 24, `[lod]`): builds the chain of [`crate::lod::build_chain`]
/// and puts it into the model (LOD0 replaces the parts, LOD1…n and the impostor go to
/// [`Model::lods`]). Each level re-meshes the pruned skeleton through [`mesh`] with the
/// recipe's `mesh.sides`, `[refine]` and `leaves.per_card` changed as the level asks,
/// and without drawing textures (`output.textures = "none"`): the levels take the full
/// model's materials and maps, so the leaf cards are cut here, from the full atlas's
/// layout, as the finishing step cuts them. Returns what each level is (nothing without
/// `[lod]`); its warnings go to `report`, whose triangle and vertex counts become
/// LOD0's.
pub fn lod_stage(
    loaded: &Loaded,
    skeleton: &Skeleton,
    surfaces: &HashMap<String, Mesh>,
    model: &mut Model,
    report: &mut Report,
) -> Result<Vec<crate::lod::LevelReport>> {
    use crate::mesh::cards::{bend_toward_crown, is_card_leaf, leaf_cards};
    let recipe = &loaded.recipe;
    if !recipe.lod.enabled() {
        return Ok(Vec::new());
    }
    recipe.lod.check()?;
    let cards = recipe.leaves.mode.cards() && recipe.output.textures != TextureMode::None;
    let card_leaves = skeleton.organs.iter().filter(|o| is_card_leaf(o)).count();
    let refine_levels = match recipe.refine_scheme() {
        Some(_) => recipe.refine.levels.min(6),
        None => 0,
    };
    let opts = crate::lod::LodOptions {
        budgets: recipe.lod.levels.clone(),
        impostor: recipe.lod.impostor,
        atlas_frames: recipe.lod.atlas_frames,
        atlas_size: recipe.lod.atlas_size,
        sides: recipe.mesh.sides.max(crate::mesh::tube::MIN_SIDES),
        min_sides: crate::mesh::tube::MIN_SIDES,
        refine_factor: 4u32.pow(refine_levels),
        per_card: if cards && card_leaves > 0 { recipe.leaves.cards(card_leaves).0 as u32 } else { 0 },
    };
    let mut warnings: Vec<String> = Vec::new();
    let mut remesh = |sk: &Skeleton, s: &crate::lod::LevelSettings| -> Result<Model> {
        let mut r = recipe.clone();
        r.mesh.sides = s.sides;
        if !s.refine {
            r.refine.levels = 0;
            r.refine.limit = false;
        }
        r.output.textures = TextureMode::None;
        r.leaves.mode = LeafMode::Cards;
        // The cards are cut below; `mesh` makes the bark and any other organs.
        let mut bare = sk.clone();
        if cards {
            bare.organs.retain(|o| !is_card_leaf(o));
        }
        let mut own = Report::default();
        let mut level = mesh(&r, &bare, surfaces, &mut own)?;
        warnings.append(&mut own.warnings);
        if cards {
            let mut leaves = recipe.leaves.clone();
            leaves.per_card = s.per_card;
            let (per_card, shape) = leaves.cards(card_leaves);
            let atlas = crate::texture::leaf::atlas_layout(recipe.textures.atlas_size);
            let (mut m, _) = leaf_cards(sk, atlas.cell(shape), per_card);
            if recipe.leaves.normals == LeafNormals::Crown {
                bend_toward_crown(&mut m);
            }
            if m.face_count() > 0 {
                level.parts.push(Part::new("leaf_cards", m, Material::leaf()));
            }
        }
        Ok(level)
    };
    let chain = crate::lod::build_chain(model, skeleton, &opts, &mut remesh)?;
    for w in warnings.into_iter().chain(chain.warnings.iter().cloned()) {
        if !report.warnings.contains(&w) {
            report.warnings.push(w);
        }
    }
    let levels = chain.levels.clone();
    chain.apply(model)?;
    // The report counts what the file shows first: LOD0.
    let drawn = model.flattened();
    report.triangles = drawn.triangle_count();
    report.vertices = drawn.vertex_count();
    Ok(levels)
}

/// The most warnings a [`Report`] keeps; the rest are counted in a last line.
pub const MAX_WARNINGS: usize = 50;

/// Bounds a run's warnings the way errors are bounded (issue 39): every quoted piece of
/// input clipped to [`crate::diagnostic::MAX_QUOTED_CHARS`] characters, each warning to
/// [`crate::diagnostic::MAX_MESSAGE_CHARS`], repeated warnings kept once, and at most
/// [`MAX_WARNINGS`] of them, the rest counted in a last line. A hostile model can name
/// thousands of unknown keys or a key of a megabyte; the report stays readable.
pub fn clip_warnings(warnings: Vec<String>) -> Vec<String> {
    use crate::diagnostic::{clip, clip_quoted_to, MAX_MESSAGE_CHARS, MAX_QUOTED_CHARS};
    let mut seen = std::collections::HashSet::new();
    let mut out = Vec::new();
    let mut dropped = 0usize;
    for w in warnings {
        let w = clip(&clip_quoted_to(&w, MAX_QUOTED_CHARS), MAX_MESSAGE_CHARS).into_owned();
        if !seen.insert(w.clone()) {
            continue;
        }
        if out.len() < MAX_WARNINGS {
            out.push(w);
        } else {
            dropped += 1;
        }
    }
    if dropped > 0 {
        out.push(format!("… and {dropped} more warnings"));
    }
    out
}

#[cfg(test)]
mod warning_tests {
    use super::*;

    #[test]
    fn warnings_are_clipped_deduplicated_and_counted() {
        let huge = format!("unknown key `{}` in the spec file", "k".repeat(100_000));
        let mut w = vec![huge.clone(), huge, "x".repeat(10_000)];
        w.extend((0..200).map(|i| format!("warning {i}")));
        let out = clip_warnings(w);
        assert_eq!(out.len(), MAX_WARNINGS + 1, "{:?}", out.last());
        assert!(out[0].chars().count() < crate::diagnostic::MAX_QUOTED_CHARS + 100, "{}", out[0].len());
        assert!(out[0].ends_with("in the spec file"), "{}", &out[0][out[0].len() - 40..]);
        assert!(out[1].chars().count() <= crate::diagnostic::MAX_MESSAGE_CHARS + 1);
        assert_eq!(out[2], "warning 0");
        assert_eq!(out[MAX_WARNINGS], "… and 152 more warnings");
        assert_eq!(clip_warnings(vec!["a".into(), "b".into()]), ["a", "b"]);
    }
}
