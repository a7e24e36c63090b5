//! Levels of detail: issue 24's LOD chain (item 4). From the full model and its
//! skeleton, [`build_chain`] makes one level per triangle budget (LOD0 first) and, on
//! request, a last impostor level.
//!
//! Each budgeted level is **re-meshed from the skeleton** by the caller's `remesh`
//! closure (the pipeline's own meshers), with settings derived from the budget
//! ([`LevelSettings`]): lateral subtrees thinner than a screen-size threshold pruned
//! ([`prune::prune`]; their leaves move to the nearest kept node, so the crown keeps
//! its outline), fewer sides, refinement only where the budget allows it, and fewer,
//! larger leaf cards (`leaves.per_card` up to 64). The bark (and any leaf geometry) is
//! then simplified to what the cards leave of the budget with meshoptimizer (locked
//! borders, normals and UVs weighted; sloppy simplification where topology stops it)
//! and put in vertex-cache and vertex-fetch order ([`simplify`]). Level parts keep the
//! full model's part names and materials, so every level shares its textures.
//!
//! The impostor ([`impostor`]) renders LOD0 with the CPU preview renderer into a
//! hemi-octahedral atlas of `atlas_frames²` orthographic views (albedo + coverage,
//! normals) and shows them on crossed billboards.
//!
//! Screen coverages (the smallest fraction of the view's height at which a level shows)
//! follow triangle density: a level of `B` triangles is fine down to a coverage of
//! `√(B / T)`, `T` being the full model's triangles (the full model is sized for a tree
//! that fills the view), so a level shows until the next one is fine; the last mesh level
//! hands over to the impostor where an atlas frame has as many pixels as the tree has
//! on a [`REFERENCE_PIXELS`]-pixel screen.
//!
//! Plain data in and out; this module does not know the recipe (the pipeline passes a
//! closure, `pipeline::lod_stage`). Deterministic.

pub mod impostor;
pub mod prune;
pub mod simplify;

use crate::error::{Error, Result};
use crate::model::{Lod, Model, ModelImage, Part};
use crate::skeleton::{Skeleton, NO_PARENT};
use std::time::{Duration, Instant};

/// Height in pixels of the screen the coverages and the pruning rule assume: a tree
/// at coverage 1 is this many pixels tall.
pub const REFERENCE_PIXELS: f32 = 1080.0;

/// The screen-size rule: a lateral subtree is pruned from a level when its thickest
/// branch is narrower than this many pixels at the largest coverage the level shows at.
pub const PRUNE_PIXELS: f32 = 1.0;

/// Share of a level's budget the leaf cards aim at (cards are disjoint quads that
/// simplification cannot reduce; their count is set through `per_card`).
pub const LEAF_SHARE: f64 = 0.5;

/// The most of a budget leaf cards may take before the pruning grows (fewer twigs
/// merge more leaves per card).
pub const LEAF_MAX_SHARE: f64 = 0.8;

/// How far a level may land from its budget (±10 %).
pub const TOLERANCE: f64 = 0.1;

/// Most leaves per card (`leaves.per_card`'s limit).
pub const MAX_PER_CARD: u32 = 64;

/// Triangles of one leaf card (a front and a back quad).
const CARD_TRIANGLES: usize = 4;

/// How many times its target a re-meshed bark may have for simplification to work
/// from (more sides are chosen while the estimate stays under this).
const HEADROOM: f64 = 4.0;

/// What to build (the recipe's `[lod]` table and what the full model was made with).
#[derive(Debug, Clone, PartialEq)]
pub struct LodOptions {
    /// Triangle budget of each level, LOD0 first, strictly decreasing, each ≥ 12.
    pub budgets: Vec<u32>,
    /// Add an impostor level last.
    pub impostor: bool,
    /// Frames per side of the hemi-octahedral atlas, `2..=16`.
    pub atlas_frames: u32,
    /// Atlas edge in pixels, `64..=4096`.
    pub atlas_size: u32,
    /// Sides of the full model's tubes (`mesh.sides`); levels use at most this many.
    pub sides: u32,
    /// Fewest sides the mesher takes.
    pub min_sides: u32,
    /// Faces per control face from the full model's refinement (`4^levels`, 1 for none).
    pub refine_factor: u32,
    /// Leaves per card of the full model (0 when it has no leaf cards).
    pub per_card: u32,
}

impl LodOptions {
    /// Checks the options; errors name the key.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::Recipe(format!("lod: {why}")));
        if self.budgets.is_empty() && !self.impostor {
            return bad("no levels: give triangle budgets, the impostor or both".into());
        }
        if let Some(b) = self.budgets.iter().find(|&&b| b < 12) {
            return bad(format!("a budget of {b} triangles is under the smallest, 12"));
        }
        if self.budgets.windows(2).any(|w| w[1] >= w[0]) {
            return bad(format!("budgets must decrease, LOD0 first: {:?}", self.budgets));
        }
        if !(2..=16).contains(&self.atlas_frames) {
            return bad(format!("atlas_frames is {}; it must be in 2..=16", self.atlas_frames));
        }
        if !(64..=4096).contains(&self.atlas_size) {
            return bad(format!("atlas_size is {}; it must be in 64..=4096", self.atlas_size));
        }
        if self.min_sides == 0 || self.sides < self.min_sides || self.refine_factor == 0 {
            return bad(format!(
                "sides {} (fewest {}) and refinement factor {} are not a mesher's",
                self.sides, self.min_sides, self.refine_factor
            ));
        }
        Ok(())
    }
}

/// How one level is re-meshed (handed to the `remesh` closure with the pruned skeleton).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelSettings {
    /// The level (0 = LOD0).
    pub level: usize,
    /// Its triangle budget.
    pub budget: u32,
    /// Tube sides (`mesh.sides`).
    pub sides: u32,
    /// Keep the recipe's refinement (`false`: none).
    pub refine: bool,
    /// Leaves per card (`leaves.per_card`; 0 when the model has no cards).
    pub per_card: u32,
    /// Lateral subtrees thinner than this radius (metres) were pruned.
    pub prune_radius: f32,
}

/// How a level was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LevelKind {
    /// The full model already fits the budget: its parts, as they are.
    AsIs,
    /// Re-meshed from the pruned skeleton and simplified.
    Rebuilt,
    /// The crossed billboards of the impostor atlas.
    Impostor,
}

/// One part of a level: its name, triangles and how it got there.
#[derive(Debug, Clone, PartialEq)]
pub struct PartReport {
    /// Part name (`bark`, `leaves`, `leaf_cards`, `impostor`).
    pub name: String,
    /// Triangles after simplification.
    pub triangles: usize,
    /// Triangles as re-meshed, before simplification.
    pub meshed: usize,
    /// How it reached its count.
    pub method: simplify::Method,
}

/// What one level is.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelReport {
    /// How it was made.
    pub kind: LevelKind,
    /// Its budget (`None` for the impostor).
    pub budget: Option<u32>,
    /// Its settings (re-meshed levels).
    pub settings: Option<LevelSettings>,
    /// Triangles of the level.
    pub triangles: usize,
    /// Its parts.
    pub parts: Vec<PartReport>,
    /// Leaf cards in the level.
    pub cards: usize,
    /// The original skeleton node of each node of the level's pruned skeleton (empty
    /// for levels made without one), so later stages can map the level to the rig.
    pub nodes: Vec<u32>,
    /// Smallest screen coverage at which the level shows.
    pub screen_coverage: f32,
    /// Time to build the level.
    pub time: Duration,
}

/// The chain [`build_chain`] makes; [`Chain::apply`] puts it into the model.
#[derive(Debug, Clone)]
pub struct Chain {
    /// LOD0's parts; `None` when the full model fits LOD0's budget and stays as it is.
    pub lod0: Option<Vec<Part>>,
    /// LOD1 … LODn, the impostor last.
    pub lods: Vec<Lod>,
    /// LOD0's screen coverage.
    pub lod0_coverage: f32,
    /// The impostor's atlas images, to append to the model's images.
    pub images: Vec<ModelImage>,
    /// The image count of the model the chain was built for (the impostor material's
    /// maps count from here).
    pub image_base: usize,
    /// One report per level, LOD0 first.
    pub levels: Vec<LevelReport>,
    /// Levels off their budget, budgets the full model already meets.
    pub warnings: Vec<String>,
    /// Time to build the whole chain.
    pub time: Duration,
}

impl Chain {
    /// Puts the chain into `model` (the model it was built for): LOD0 replaces the parts
    /// (and, re-meshed, any instanced organs: its cards are parts), the other levels go to
    /// [`Model::lods`], the coverages to [`Model::lod0_coverage`] and each
    /// [`Lod::screen_coverage`], the atlas images to [`Model::images`].
    /// Errors: a model with another image count than the one the chain was built for.
    pub fn apply(self, model: &mut Model) -> Result<()> {
        if model.images.len() != self.image_base {
            return Err(Error::InvalidGeometry {
                what: "LOD chain".into(),
                why: format!(
                    "built for a model of {} images, applied to one of {}",
                    self.image_base,
                    model.images.len()
                ),
            });
        }
        if let Some(parts) = self.lod0 {
            model.parts = parts;
            model.shapes.clear();
            model.instances.clear();
        }
        model.lods = self.lods;
        model.lod0_coverage = self.lod0_coverage;
        model.images.extend(self.images);
        Ok(())
    }
}

/// The screen coverage of each level (mesh levels, then the impostor): decreasing and
/// positive (see the module docs). `full` is the full model's triangle count,
/// `frame_px` the atlas frame's edge in pixels.
pub fn coverages(budgets: &[u32], impostor: bool, full: usize, frame_px: u32) -> Vec<f32> {
    let total = (full as f64).max(budgets.first().copied().unwrap_or(1) as f64).max(1.0);
    let fine = |b: u32| ((b as f64 / total).sqrt().min(1.0)) as f32;
    let hand_over = frame_px as f32 / REFERENCE_PIXELS;
    let mut out: Vec<f32> = Vec::new();
    for k in 0..budgets.len() {
        let c = match budgets.get(k + 1) {
            Some(&next) => fine(next),
            None if impostor => hand_over.min(0.75 * fine(budgets[k])),
            None => 0.01f32.min(0.5 * fine(budgets[k])),
        };
        out.push(c);
    }
    if impostor {
        let last = out.last().copied().unwrap_or(hand_over);
        out.push(0.01f32.min(0.5 * last));
    }
    out
}

/// Triangles of the parts named `name` (parts and instanced shapes, flattened).
fn named_triangles(model: &Model, name: &str) -> usize {
    model.parts.iter().filter(|p| p.name == name).map(|p| p.mesh.triangle_count()).sum()
}

/// The full model's material for a level part of this name, if it has such a part.
fn material_of<'a>(full: &'a Model, name: &str) -> Option<&'a crate::model::Material> {
    full.parts.iter().chain(&full.shapes).find(|p| p.name == name).map(|p| &p.material)
}

/// Internodes (nodes with a parent) of a skeleton.
fn internodes(sk: &Skeleton) -> usize {
    sk.parent.iter().filter(|&&p| p != NO_PARENT).count()
}

/// Cards a skeleton gets at `per_card` leaves per card.
fn card_count(sk: &Skeleton, per_card: u32) -> usize {
    crate::mesh::cards::leaf_groups(sk, per_card.max(1) as usize).len()
}

/// Builds the LOD chain of `full` (grown from `skeleton`): one level per budget of
/// `opts`, re-meshed by `remesh(pruned skeleton, settings)`, which returns a model whose
/// parts carry the full model's part names (`bark`, `leaves`, `leaf_cards`); then the
/// impostor. A level the full model already fits (within [`TOLERANCE`]) is the full
/// model as it is, and a warning says so.
///
/// Errors: bad options ([`LodOptions::check`]), an invalid skeleton, a full model
/// without triangles, and whatever `remesh` or the renderer return.
pub fn build_chain(
    full: &Model,
    skeleton: &Skeleton,
    opts: &LodOptions,
    remesh: &mut dyn FnMut(&Skeleton, &LevelSettings) -> Result<Model>,
) -> Result<Chain> {
    let start = Instant::now();
    opts.check()?;
    skeleton.validate()?;
    let flat = full.flattened();
    let total = flat.triangle_count();
    let bad = |why: String| Error::InvalidGeometry { what: "LOD chain".into(), why };
    if total == 0 {
        return Err(bad("the model has no triangles".into()));
    }
    let (lo, hi) = flat.bounds().ok_or_else(|| bad("the model has no vertices".into()))?;
    let extent = (hi - lo).max_element();
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(bad(format!("the model's extent {extent} is not a positive size")));
    }
    let frame_px = opts.atlas_size / opts.atlas_frames;
    let cov = coverages(&opts.budgets, opts.impostor, total, frame_px);
    let cards = opts.per_card > 0;
    let ctx = Context {
        skeleton,
        opts,
        extent,
        internodes: internodes(skeleton).max(1),
        bark: named_triangles(&flat, "bark"),
    };
    let mut chain = Chain {
        lod0: None,
        lods: Vec::new(),
        lod0_coverage: cov.first().copied().unwrap_or(1.0),
        images: Vec::new(),
        image_base: full.images.len(),
        levels: Vec::new(),
        warnings: Vec::new(),
        time: Duration::ZERO,
    };
    // LOD0's parts (for the impostor), when it is not the full model.
    let mut lod0_parts: Option<Vec<Part>> = None;
    for (k, &budget) in opts.budgets.iter().enumerate() {
        crate::cancel::check()?;
        let t = Instant::now();
        let (parts, mut report) = if total as f64 <= budget as f64 * (1.0 + TOLERANCE) {
            chain.warnings.push(format!(
                "LOD{k}: the full model's {total} triangles already fit the budget of {budget}; it is used as it is"
            ));
            let parts: Vec<Part> = flat.parts.clone();
            let report = LevelReport {
                kind: LevelKind::AsIs,
                budget: Some(budget),
                settings: None,
                triangles: total,
                parts: parts
                    .iter()
                    .map(|p| {
                        let n = p.mesh.triangle_count();
                        PartReport {
                            name: p.name.clone(),
                            triangles: n,
                            meshed: n,
                            method: simplify::Method::Kept,
                        }
                    })
                    .collect(),
                cards: 0,
                nodes: Vec::new(),
                screen_coverage: 0.0,
                time: Duration::ZERO,
            };
            (parts, report)
        } else {
            let max_coverage = if k == 0 { 1.0 } else { cov[k - 1] };
            ctx.level(k, budget, max_coverage, cards, full, remesh)?
        };
        report.screen_coverage = cov[k];
        report.time = t.elapsed();
        let off = report.triangles as f64 / budget as f64 - 1.0;
        if off.abs() > TOLERANCE && report.kind == LevelKind::Rebuilt {
            chain.warnings.push(format!(
                "LOD{k}: {} triangles, {:+.1} % off its budget of {budget} (parts: {})",
                report.triangles,
                off * 100.0,
                report
                    .parts
                    .iter()
                    .map(|p| format!("{} {}", p.name, p.triangles))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if k == 0 {
            if report.kind == LevelKind::Rebuilt {
                chain.lod0 = Some(parts.clone());
                lod0_parts = Some(parts);
            }
        } else {
            chain.lods.push(Lod { parts, screen_coverage: cov[k] });
        }
        chain.levels.push(report);
    }
    if opts.impostor {
        crate::cancel::check()?;
        let t = Instant::now();
        let parts = lod0_parts.as_deref().unwrap_or(&flat.parts);
        let imp = impostor::build(
            parts,
            &full.images,
            opts.atlas_frames,
            opts.atlas_size,
            full.images.len() as u32,
        )?;
        let c = *cov.last().unwrap_or(&0.0);
        let n = imp.part.mesh.triangle_count();
        chain.levels.push(LevelReport {
            kind: LevelKind::Impostor,
            budget: None,
            settings: None,
            triangles: n,
            parts: vec![PartReport {
                name: imp.part.name.clone(),
                triangles: n,
                meshed: n,
                method: simplify::Method::Kept,
            }],
            cards: 0,
            nodes: Vec::new(),
            screen_coverage: c,
            time: t.elapsed(),
        });
        chain.lods.push(Lod { parts: vec![imp.part], screen_coverage: c });
        chain.images = imp.images;
    }
    chain.time = start.elapsed();
    Ok(chain)
}

/// What every level is planned from.
struct Context<'a> {
    skeleton: &'a Skeleton,
    opts: &'a LodOptions,
    /// The full model's largest extent (metres).
    extent: f32,
    /// Internodes of the full skeleton.
    internodes: usize,
    /// Bark triangles of the full model.
    bark: usize,
}

impl Context<'_> {
    /// The screen-size rule's pruning radius for a level shown up to `coverage`.
    fn prune_radius(&self, coverage: f32) -> f32 {
        let pixel = self.extent / (coverage.max(1e-3) * REFERENCE_PIXELS);
        0.5 * PRUNE_PIXELS * pixel
    }

    /// Estimated bark triangles of `internodes` internodes at `sides` sides, refined or not.
    fn bark_estimate(&self, internodes: usize, sides: u32, refine: bool) -> f64 {
        let per = self.bark as f64
            / (self.internodes as f64 * self.opts.sides as f64 * self.opts.refine_factor as f64);
        per * internodes as f64 * sides as f64 * if refine { self.opts.refine_factor as f64 } else { 1.0 }
    }

    /// The most sides level `k` may have: the full model's, then ¾, ½ of it, then the
    /// mesher's fewest (8 → 6 → 4 → 3).
    fn side_cap(&self, k: usize) -> u32 {
        let s = self.opts.sides as f32;
        let cap = match k {
            0 => s,
            1 => (0.75 * s).round(),
            2 => (0.5 * s).round(),
            _ => 0.0,
        };
        (cap as u32).max(self.opts.min_sides).min(self.opts.sides)
    }

    /// Plans, re-meshes and simplifies level `k`.
    fn level(
        &self,
        k: usize,
        budget: u32,
        max_coverage: f32,
        cards: bool,
        full: &Model,
        remesh: &mut dyn FnMut(&Skeleton, &LevelSettings) -> Result<Model>,
    ) -> Result<(Vec<Part>, LevelReport)> {
        let b = budget as f64;
        // Prune by the screen-size rule; where even the largest cards would take more
        // than their most of the budget, prune further (fewer twigs, fewer card groups).
        let mut radius = self.prune_radius(max_coverage);
        let top = self.skeleton.radius.iter().cloned().fold(0.0f32, f32::max);
        let mut pruned = prune::prune(self.skeleton, radius);
        while cards
            && (card_count(&pruned.skeleton, MAX_PER_CARD) * CARD_TRIANGLES) as f64 > LEAF_MAX_SHARE * b
            && radius < top
        {
            radius *= 1.5;
            pruned = prune::prune(self.skeleton, radius);
        }
        // The fewest leaves per card (no fewer than the full model's) whose cards fit
        // the leaves' share.
        let per_card = if cards {
            let fits = |pc: u32| (card_count(&pruned.skeleton, pc) * CARD_TRIANGLES) as f64 <= LEAF_SHARE * b;
            let (mut lo, mut hi) = (self.opts.per_card.clamp(1, MAX_PER_CARD), MAX_PER_CARD);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if fits(mid) {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            lo
        } else {
            0
        };
        let card_tris = if cards { card_count(&pruned.skeleton, per_card) * CARD_TRIANGLES } else { 0 };
        let bark_target = (b - card_tris as f64).max(0.1 * b);
        let nodes = internodes(&pruned.skeleton);
        let cap = self.side_cap(k);
        let sides = (self.opts.min_sides..=cap)
            .rev()
            .find(|&s| self.bark_estimate(nodes, s, false) <= HEADROOM * bark_target)
            .unwrap_or(self.opts.min_sides);
        let refine = k == 0
            && self.opts.refine_factor > 1
            && self.bark_estimate(nodes, sides, true) <= HEADROOM * bark_target;
        let settings = LevelSettings { level: k, budget, sides, refine, per_card, prune_radius: radius };
        let meshed = remesh(&pruned.skeleton, &settings)?;
        // Cards stay as they are; everything else shares what they leave of the budget.
        let fixed: usize =
            meshed.parts.iter().filter(|p| p.name == "leaf_cards").map(|p| p.mesh.triangle_count()).sum();
        let rest: usize =
            meshed.parts.iter().filter(|p| p.name != "leaf_cards").map(|p| p.mesh.triangle_count()).sum();
        let room = (b - fixed as f64).max(0.05 * b);
        let mut parts = Vec::with_capacity(meshed.parts.len());
        let mut reports = Vec::with_capacity(meshed.parts.len());
        for mut part in meshed.parts {
            let n = part.mesh.triangle_count();
            let target = if part.name == "leaf_cards" || rest == 0 {
                n
            } else {
                ((room * n as f64 / rest as f64).round() as usize).max(1)
            };
            let what = format!("LOD{k} part `{}`", part.name);
            crate::cancel::check()?;
            let (mesh, method) = simplify::simplify(&part.mesh, target, &what)?;
            part.mesh = mesh;
            if let Some(m) = material_of(full, &part.name) {
                part.material = m.clone();
            }
            reports.push(PartReport {
                name: part.name.clone(),
                triangles: part.mesh.triangle_count(),
                meshed: n,
                method,
            });
            if part.mesh.face_count() > 0 {
                parts.push(part);
            }
        }
        let triangles = reports.iter().map(|p| p.triangles).sum();
        let cards_made = parts
            .iter()
            .filter(|p| p.name == "leaf_cards")
            .map(|p| p.mesh.triangle_count() / CARD_TRIANGLES)
            .sum();
        let report = LevelReport {
            kind: LevelKind::Rebuilt,
            budget: Some(budget),
            settings: Some(settings),
            triangles,
            parts: reports,
            cards: cards_made,
            nodes: pruned.original,
            screen_coverage: 0.0,
            time: Duration::ZERO,
        };
        Ok((parts, report))
    }
}

/// Triangles of a level's parts (fan-triangulated faces), as the budgets count them.
pub fn level_triangles(parts: &[Part]) -> usize {
    parts.iter().map(|p| p.mesh.triangle_count()).sum()
}
