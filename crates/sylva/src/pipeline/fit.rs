//! The fit stage: the skeleton passes between the generator and the mesher — overlap
//! pruning and leaf placement, the degeneracy and memory checks, de-collision, the flat
//! base's sinking and the mesh-checked clearing (McLoughlin2021 §4.2, Pieterse2012,
//! MacMurchy2004, Skjermo2008; `docs/robustness.md` for the checks).

use super::*;

/// Sinks the skeleton's upright roots for a flat base (`mesh.base = "flat"`), see
/// [`crate::mesh::ground`].
pub(crate) fn sink(recipe: &Recipe, skeleton: &mut Skeleton) -> Vec<SunkRoot> {
    // A leaf (`mesh.method = "leaf"`) has no trunk to stand on: its base stays open.
    if recipe.mesh.base == MeshBase::Flat && recipe.mesh.method != MeshMethod::Leaf {
        crate::mesh::ground::sink_roots(skeleton)
    } else {
        Vec::new()
    }
}

/// Pulls apart the skeleton's crossing branches before meshing (`mesh.decollide`), and
/// warns about the collisions it could not resolve.
pub fn decollide_skeleton(recipe: &Recipe, skeleton: &mut Skeleton, report: &mut Report) -> Result<()> {
    let r = crate::fit::decollide::decollide(skeleton, &recipe.fit.decollide)?;
    if r.after > 0 {
        report.warnings.push(format!(
            "decollide: {} of {} skeleton collision(s) left; the mesh will intersect itself there (first internode pairs, by child node: {:?})",
            r.after,
            r.before,
            &r.unresolved[..r.unresolved.len().min(4)]
        ));
    }
    report.decollide = Some(r);
    Ok(())
}

/// A control mesh the fitting stage already made, with its refinement when that is the
/// one `[refine]` asks for.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The bark's control mesh of the skeleton the fitting left.
    pub control: Mesh,
    /// `control` refined exactly as `[refine]` says (levels ≤ 3, no limit), or `None`.
    pub refined: Option<Mesh>,
}

/// Thins the skeleton where the recipe's mesh, refined as `[refine]` says (the control
/// mesh itself for `refine.scheme = "none"`), still crosses itself (`mesh.clear`, see
/// [`crate::fit::clear`]), and warns about what is left. Returns the control mesh of the
/// skeleton it leaves when that was the last one meshed (its axes, warnings and meshing
/// time then go to `report`) and the refinement it searched when `[refine]` asks for the
/// same one, so the caller need not mesh or refine it again.
pub fn clear_skeleton(
    recipe: &Recipe,
    skeleton: &mut Skeleton,
    report: &mut Report,
) -> Result<Option<Fitted>> {
    use crate::fit::clear::{clear_crossings_refined, ClearOptions};
    use crate::refine::Scheme;
    let (scheme, levels) = match recipe.refine_scheme() {
        Some(scheme) => (scheme, recipe.refine.levels.min(3)),
        None => (Scheme::Loop, 0),
    };
    // The refinement searched stays within `[refine]`'s face budget too.
    let max_faces = recipe.fit.clear.max_faces.min(recipe.refine.max_faces);
    let opts =
        ClearOptions { levels, max_faces, boundary: recipe.refine_boundary(), ..recipe.fit.clear.clone() };
    // The clearing's refinement is the output's when it has the same scheme and levels
    // and no limit step (the same `subdivide` call, so the same bytes).
    let reusable = recipe.refine_scheme().is_some()
        && levels == recipe.refine.levels
        && levels > 0
        && !recipe.refine.limit;
    // The last meshing's report and the radii it was made with.
    let mut last: Option<(Report, Vec<f32>)> = None;
    // The quad repair's budget is shared by every meshing of the pass.
    let mut repair_work = report.repair_work;
    // The repair work of the last meshing: the next one needs about as much.
    let mut last_work = 0u64;
    let cleared = clear_crossings_refined(skeleton, &opts, |s| {
        let left = recipe.mesh.quad.max_repair_work.saturating_sub(repair_work);
        if last_work > left {
            // Stop before a meshing that would run out of budget part way (a 15 k-node
            // quad meshing takes seconds): the same error, one meshing earlier.
            return Err(Error::Recipe(format!(
                "`mesh.quad.max_repair_work`: the mesh clearing's next quad meshing needs about {last_work} units \
                 of repair work (as much as its last), more than the {left} left of the budget of {} (one \
                 budget serves all the meshings of a run); raise it with --set mesh.quad.max_repair_work=N, \
                 lower mesh.quad.repair_rounds or fit.clear.max_rounds, or turn the clearing off with \
                 mesh.clear = false",
                recipe.mesh.quad.max_repair_work
            )));
        }
        let t = Instant::now();
        let mut own = Report { repair_work, ..Report::default() };
        let mesh = control_mesh(recipe, s, &mut own)?;
        last_work = own.repair_work - repair_work;
        repair_work = own.repair_work;
        own.mesh_time = t.elapsed();
        last = Some((own, s.radius.clone()));
        Ok((mesh, scheme))
    })?;
    report.repair_work = repair_work;
    let r = cleared.report;
    match (r.before, r.after) {
        (None, _) => report.warnings.push(format!(
            "mesh clearing skipped: the refined mesh would have over {} faces",
            opts.max_faces
        )),
        (_, Some(left)) if left > 0 => report.warnings.push(format!(
            "mesh clearing: {}{left} crossing face pair(s) left after {} round(s); the surface intersects itself near internodes {:?}",
            if r.truncated { "at least " } else { "" },
            r.rounds,
            r.unresolved
        )),
        _ => {}
    }
    report.clear = Some(r);
    match last {
        Some((own, radius)) if radius == skeleton.radius => {
            report.axes = own.axes;
            report.mesh_time = own.mesh_time;
            report.warnings.extend(own.warnings);
            let refined = cleared.refined.filter(|_| reusable);
            Ok(Some(Fitted { control: cleared.control, refined }))
        }
        _ => Ok(None),
    }
}

/// The optional skeleton passes of McLoughlin2021 §4.2 before fitting: overlap pruning
/// (`mesh.prune_overlaps`, [`crate::fit::overlap`]) and then leaves by level
/// (`[leaves] place`, [`crate::fit::leaves`]), so pruned branches get no leaves.
pub fn shape_stage(recipe: &Recipe, skeleton: &mut Skeleton, report: &mut Report) -> Result<()> {
    if recipe.mesh.prune_overlaps == Some(true) {
        let (pruned, r) = crate::fit::overlap::prune_overlaps(skeleton, 0.0);
        if r.pairs > 0 {
            report.warnings.push(format!(
                "prune_overlaps: {} overlapping internode pair(s); {} subtree(s) with {} node(s) and {} organ(s) pruned",
                r.pairs,
                r.pruned.len(),
                r.removed,
                r.organs_removed
            ));
        }
        *skeleton = pruned;
    }
    if let Some(p) = recipe.leaves.placement(recipe.seed)? {
        crate::fit::leaves::place_leaves(skeleton, &p);
    }
    Ok(())
}

/// The fitting stage on the generated `skeleton`: overlap pruning and leaf placement
/// ([`shape_stage`]), the degeneracy and memory checks, de-collision, the flat base's
/// sinking and the mesh-checked clearing. Returns the sunk roots and the clearing's
/// last meshing, when it is the skeleton's.
pub(crate) fn fit_stage(
    recipe: &Recipe,
    skeleton: &mut Skeleton,
    report: &mut Report,
) -> Result<(Vec<SunkRoot>, Option<Fitted>)> {
    shape_stage(recipe, skeleton, report)?;
    report.skeleton = skeleton.stats();
    check_degenerate(recipe, skeleton)?;
    if recipe.mesh.decollides_nodes(skeleton.len()) {
        decollide_skeleton(recipe, skeleton, report)?;
    } else if recipe.mesh.decollides() {
        report.warnings.push(format!(
            "decollide skipped: {} skeleton nodes is over the automatic limit of {} (the pass would take many seconds); set mesh.decollide = true to run it",
            skeleton.len(),
            crate::recipe::DECOLLIDE_AUTO_NODES
        ));
    }
    if report.skeleton.segments == 0 && skeleton.organs.is_empty() {
        return Err(Error::InvalidGeometry {
            what: format!("recipe `{}`", recipe.name),
            why: "the generator drew nothing (no `F` and no organ in the interpreted string)".into(),
        });
    }
    check_mesh_memory(recipe, mesh_lower_bound(recipe, skeleton)?, "at least")?;
    // The roots sink for a flat base before the fitting stage meshes the skeleton, and
    // come back up once the model is built.
    let sunk = sink(recipe, skeleton);
    let cleared = if recipe.mesh.clears_nodes(skeleton.len()) {
        clear_skeleton(recipe, skeleton, report)?
    } else {
        None
    };
    Ok((sunk, cleared))
}

/// [`crate::mesh::memory::lower_bound_bytes`] of the bark the recipe's mesher makes of
/// `skeleton` (rings of `mesh.sides` for the tube and hull meshers, of 4 for the others).
fn mesh_lower_bound(recipe: &Recipe, skeleton: &Skeleton) -> Result<u128> {
    use crate::mesh::Mesher;
    let sides = match recipe.mesh.mesher() {
        Mesher::Tube(o) => o.sides,
        Mesher::Hull(o) => o.sides,
        _ => 4,
    };
    let internodes = skeleton.parent.iter().filter(|&&p| p != crate::skeleton::NO_PARENT).count();
    Ok(crate::mesh::memory::lower_bound_bytes(internodes, sides))
}

/// Refuses a bark mesh of `bytes` bytes (`qualifier`: "at least" for the estimate made
/// before meshing) whose estimated downstream peak is over `mesh.max_memory`.
pub(crate) fn check_mesh_memory(recipe: &Recipe, bytes: u128, qualifier: &str) -> Result<()> {
    let peak = crate::mesh::memory::downstream_peak(bytes, &recipe.textures);
    if peak <= recipe.mesh.max_memory as u128 {
        return Ok(());
    }
    let size_key = match &recipe.generator {
        Generator::Lsystem(_) => "fewer derivation steps (`generator.iterations`, `-n`)",
        Generator::Import(_) => "a smaller skeleton",
        _ => "a smaller tree (the generator's level and branch counts)",
    };
    let qualifier = if qualifier.is_empty() { String::new() } else { format!("{qualifier} ") };
    Err(Error::Recipe(format!(
        "`mesh.max_memory`: the bark mesh of recipe `{}` takes {qualifier}{bytes} bytes and the stages after \
         meshing (the flat-base cut, the exporters, the preview) would need about {peak} bytes, more than the \
         memory budget of {} bytes (use {size_key}, fewer `mesh.sides` or `refine.levels`, or raise the \
         budget with --set mesh.max_memory=N if the machine has the memory)",
        recipe.name, recipe.mesh.max_memory
    )))
}

/// Rejects degenerate geometry before the expensive stages (issue 39): a radius over
/// [`crate::skeleton::ABSURD_RADIUS_RATIO`] times the skeleton's size (every capsule would
/// hold the whole tree: `generator.width = 1e30`), and, when a stage that searches for
/// collisions will run (`mesh.decollide`, `mesh.clear`, the `sweep`, `hull` and `quad`
/// meshers' repairs), a skeleton whose internode capsules overlap in more candidate
/// pairs than [`crate::skeleton::Degeneracy::crowded_limit`] (coincident nodes,
/// zero-length or reversing internodes piled up, radii too large for the lengths):
/// those searches are quadratic in such a pile. The message names the first offending
/// node and the key to change. Counting stops at the limit, so the check costs a BVH
/// over the internodes at most.
pub fn check_degenerate(recipe: &Recipe, skeleton: &Skeleton) -> Result<()> {
    use crate::skeleton::Degeneracy;
    let n = skeleton.len();
    let method = recipe.mesh.method;
    let searching = recipe.mesh.decollides_nodes(n) || recipe.mesh.clears_nodes(n) || method.joins();
    let internodes = skeleton.parent.iter().filter(|&&p| p != crate::skeleton::NO_PARENT).count();
    let d = crate::fit::degenerate::degeneracy(
        skeleton,
        if searching { Degeneracy::crowded_limit(internodes) } else { 0 },
    );
    let what = format!("the skeleton of recipe `{}`", recipe.name);
    let radius_key = match &recipe.generator {
        Generator::Lsystem(_) => "`generator.width` (or the model's own width changes)",
        Generator::Import(_) => "the file's radii",
        _ => "the generator's radius settings",
    };
    if let Some((node, r)) = d.absurd_radius() {
        return Err(Error::InvalidGeometry {
            what,
            why: format!(
                "node {node} has radius {r:.3e}, over {} times the size of the whole skeleton ({:.3e}, the \
                 diagonal of its nodes' bounds): every internode would be a ball holding the tree; lower \
                 {radius_key}",
                crate::skeleton::ABSURD_RADIUS_RATIO,
                d.size
            ),
        });
    }
    if searching && d.crowded() {
        let mut causes = Vec::new();
        if let Some(i) = d.first_zero_length {
            causes.push(format!("{} zero-length internode(s), the first ending at node {i}", d.zero_length));
        }
        if let Some(i) = d.first_reversing {
            causes.push(format!(
                "{} internode(s) turning straight back along their parent, the first ending at node {i}",
                d.reversing
            ));
        }
        if causes.is_empty() {
            causes.push("nodes (near-)coincident or radii large for the lengths".into());
        }
        let limit = Degeneracy::crowded_limit(internodes);
        let pile = if d.pairs > limit {
            let busiest = d
                .busiest
                .map(|(i, m)| format!("; the internode ending at node {i} overlaps {m} others"))
                .unwrap_or_default();
            format!(
                "the capsules of its {internodes} internodes overlap in more than {limit} pairs (over {} per \
                 internode{busiest})",
                crate::skeleton::CROWDED_PAIRS_PER_INTERNODE
            )
        } else {
            format!("{} of its {internodes} internodes have zero length", d.zero_length)
        };
        return Err(Error::InvalidGeometry {
            what,
            why: format!(
                "degenerate geometry: {pile}: {}. The collision searches of `mesh.method = \"{method}\"` (and of \
                 mesh.decollide and mesh.clear) are quadratic in such a pile; merge the coincident nodes, lower \
                 {radius_key}, or mesh it with mesh.method = \"tube\", mesh.decollide = false and \
                 mesh.clear = false",
                causes.join(", ")
            ),
        });
    }
    Ok(())
}
