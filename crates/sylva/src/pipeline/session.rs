//! Sessions: a recipe plus the result of every stage, so a changed recipe recomputes only
//! from the first stage whose inputs changed (architecture: "Session").
//!
//! ```text
//!  Generate ─► Fit ─────► Bark ────► Assemble ──► Dress ─────► Lod ───► Rig ─────► Clip ──► Tree
//!  generator   shape,     mesher,    bark part,   textures     LOD      joints,    wind clip,
//!  seed, input decollide, refine,    organs,      (cached),    chain,   skin       provenance
//!              sink,      flat-base  leaf cards   instancing   curves   weights
//!              clear      cut
//! ```
//!
//! Each stage keeps its result with the recipe it was made from; [`Stage::same_inputs`]
//! says which settings it reads, so a leaf or wind change never regrows the skeleton and
//! the bark maps are drawn once per style, size and seed ([`crate::texture::TextureCache`]).
//! A [`Cancel`] token is checked between stages and inside the long ones
//! ([`crate::cancel`]); a progress callback hears each stage start and end.
//! [`crate::pipeline::grow`] is the one-shot path over a session that keeps nothing.

use crate::cancel::Cancel;
use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::mesh::ground::SunkRoot;
use crate::model::{BranchCurves, Model};
use crate::pipeline::{self, Fitted, Generated, Report, Tree};
use crate::recipe::{Loaded, Recipe};
use crate::skeleton::Skeleton;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A stage of the pipeline, in the order they run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stage {
    /// The generator: L-system derivation and turtle, Weber–Penn, colonization,
    /// least-cost paths or an imported skeleton.
    Generate,
    /// The skeleton passes: overlap pruning, leaf placement, degeneracy checks,
    /// de-collision, the flat base's sinking and the mesh-checked clearing.
    Fit,
    /// The mesher's cage, its subdivision and the flat-base cut.
    Bark,
    /// The model's parts: bark, organs and leaf cards, untextured.
    Assemble,
    /// Textures (from the cache), card instancing and the drawn counts.
    Dress,
    /// The branch curves and the LOD chain.
    Lod,
    /// The wind rig: joints within `wind.max_joints`, skin weights, leaf flutter.
    Rig,
    /// The wind clip baked from the wind's settings, and the recipe written into the
    /// model.
    Clip,
}

impl Stage {
    /// Every stage, in order.
    pub const ALL: [Stage; 8] = [
        Stage::Generate,
        Stage::Fit,
        Stage::Bark,
        Stage::Assemble,
        Stage::Dress,
        Stage::Lod,
        Stage::Rig,
        Stage::Clip,
    ];

    /// The stage's name in reports (`generate`, `fit`, …).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Generate => "generate",
            Stage::Fit => "fit",
            Stage::Bark => "bark",
            Stage::Assemble => "assemble",
            Stage::Dress => "dress",
            Stage::Lod => "lod",
            Stage::Rig => "rig",
            Stage::Clip => "clip",
        }
    }

    /// Whether the settings this stage reads are the same in `a` and `b` (the stages
    /// before it aside: a stage also reruns whenever one before it reran). Erring on the
    /// side of rerunning: a section is compared whole when the stage reads part of it.
    pub fn same_inputs(self, a: &Recipe, b: &Recipe) -> bool {
        match self {
            Stage::Generate => a.generator == b.generator && a.seed == b.seed && a.input == b.input,
            Stage::Fit => {
                let (la, lb) = (&a.leaves, &b.leaves);
                a.mesh == b.mesh
                    && a.fit == b.fit
                    && a.refine == b.refine
                    && a.seed == b.seed
                    && a.textures.bark_size == b.textures.bark_size
                    && a.textures.atlas_size == b.textures.atlas_size
                    && (&la.place, la.start_level, la.per_node, la.size)
                        == (&lb.place, lb.start_level, lb.per_node, lb.size)
            }
            Stage::Bark => {
                a.mesh == b.mesh
                    && a.refine == b.refine
                    && a.textures.scale == b.textures.scale
                    && a.textures.bark_size == b.textures.bark_size
                    && a.textures.atlas_size == b.textures.atlas_size
            }
            Stage::Assemble => {
                a.leaves == b.leaves
                    && a.mesh == b.mesh
                    && a.textures.atlas_size == b.textures.atlas_size
                    && a.output.textures == b.output.textures
            }
            Stage::Dress => {
                a.leaves == b.leaves
                    && a.textures == b.textures
                    && a.output.textures == b.output.textures
                    && a.seed == b.seed
            }
            Stage::Lod => {
                a.lod == b.lod
                    && a.mesh == b.mesh
                    && a.refine == b.refine
                    && a.leaves == b.leaves
                    && a.textures == b.textures
                    && a.output.textures == b.output.textures
            }
            // The provenance is the whole recipe: the last stage reruns on any change.
            Stage::Rig => {
                a.wind.enabled() == b.wind.enabled()
                    && a.wind.max_joints == b.wind.max_joints
                    && a.wind.leaf_flutter == b.wind.leaf_flutter
            }
            Stage::Clip => a == b,
        }
    }
}

impl std::fmt::Display for Stage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A progress callback: the stage and how far it is, 0 at its start and 1 at its end.
pub type Progress = Box<dyn FnMut(Stage, f32) + Send>;

struct Generate {
    generated: Generated,
    report: Report,
}

struct Fit {
    /// The fitted skeleton, roots sunk for the flat base.
    skeleton: Skeleton,
    sunk: Vec<SunkRoot>,
    cleared: Option<Fitted>,
    report: Report,
}

struct Bark {
    bark: Mesh,
    report: Report,
}

struct Assemble {
    model: Model,
    card_nodes: Vec<u32>,
    report: Report,
}

struct Dress {
    model: Model,
    report: Report,
}

struct Lod {
    /// The fitted skeleton with its roots back in place.
    skeleton: Skeleton,
    model: Model,
    report: Report,
}

struct Rig {
    skeleton: Skeleton,
    model: Model,
    plan: Option<crate::wind::JointPlan>,
    report: Report,
}

/// One stage's kept result and the recipe it was made from.
struct Kept<T> {
    recipe: Recipe,
    value: Arc<T>,
}

/// One run of [`Session::compute`]: the first stage to rerun, the cancellation flag,
/// and the time of every stage run so far.
struct Run<'c> {
    first: Stage,
    cancel: &'c Cancel,
    times: Vec<(Stage, Duration)>,
}

/// A stage result with a slot in the [`Cache`].
trait Staged: Sized {
    /// The stage that makes it.
    const STAGE: Stage;
    /// Its slot.
    fn slot(cache: &mut Cache) -> &mut Option<Kept<Self>>;
}

macro_rules! staged {
    ($($ty:ident: $stage:ident, $field:ident;)+) => {
        $(impl Staged for $ty {
            const STAGE: Stage = Stage::$stage;
            fn slot(cache: &mut Cache) -> &mut Option<Kept<Self>> {
                &mut cache.$field
            }
        })+
    };
}

staged! {
    Generate: Generate, generate;
    Fit: Fit, fit;
    Bark: Bark, bark;
    Assemble: Assemble, assemble;
    Dress: Dress, dress;
    Lod: Lod, lod;
    Rig: Rig, rig;
}

/// The kept results, one slot per stage.
#[derive(Default)]
struct Cache {
    generate: Option<Kept<Generate>>,
    fit: Option<Kept<Fit>>,
    bark: Option<Kept<Bark>>,
    assemble: Option<Kept<Assemble>>,
    dress: Option<Kept<Dress>>,
    lod: Option<Kept<Lod>>,
    rig: Option<Kept<Rig>>,
}

impl Cache {
    /// The recipe stage `s`'s kept result was made from, if it has one.
    fn recipe(&self, s: Stage) -> Option<&Recipe> {
        match s {
            Stage::Generate => self.generate.as_ref().map(|k| &k.recipe),
            Stage::Fit => self.fit.as_ref().map(|k| &k.recipe),
            Stage::Bark => self.bark.as_ref().map(|k| &k.recipe),
            Stage::Assemble => self.assemble.as_ref().map(|k| &k.recipe),
            Stage::Dress => self.dress.as_ref().map(|k| &k.recipe),
            Stage::Lod => self.lod.as_ref().map(|k| &k.recipe),
            Stage::Rig => self.rig.as_ref().map(|k| &k.recipe),
            Stage::Clip => None,
        }
    }

    /// Drops the results of `from` and every later stage.
    fn drop_from(&mut self, from: Stage) {
        for s in Stage::ALL.into_iter().filter(|&s| s >= from) {
            match s {
                Stage::Generate => self.generate = None,
                Stage::Fit => self.fit = None,
                Stage::Bark => self.bark = None,
                Stage::Assemble => self.assemble = None,
                Stage::Dress => self.dress = None,
                Stage::Lod => self.lod = None,
                Stage::Rig => self.rig = None,
                Stage::Clip => {}
            }
        }
    }
}

/// A recipe and the result of each stage of its pipeline.
///
/// ```
/// use sylva::session::{Session, Stage};
/// let mut session = Session::new(sylva::recipe::load("lsys-binary-tree", &[])?);
/// session.run()?;
/// let mut recipe = session.recipe().clone();
/// recipe.leaves.alpha_cutoff = 0.3;
/// session.update(recipe)?;
/// assert!(!session.last_run().contains(&Stage::Generate));
/// # Ok::<(), sylva::Error>(())
/// ```
pub struct Session {
    loaded: Loaded,
    retain: bool,
    cache: Cache,
    textures: crate::texture::TextureCache,
    tree: Option<Tree>,
    last_run: Vec<Stage>,
    progress: Option<Progress>,
}

impl Session {
    /// A session for `loaded` (nothing computed yet: call [`Session::run`]). It keeps
    /// every stage's result, about five copies of the bark mesh in memory;
    /// [`Session::keep_stages`] turns that off.
    pub fn new(loaded: Loaded) -> Session {
        Session {
            loaded,
            retain: true,
            cache: Cache::default(),
            textures: Default::default(),
            tree: None,
            last_run: Vec::new(),
            progress: None,
        }
    }

    /// Whether the session keeps each stage's result for the next update (default true).
    /// Without, an update recomputes everything but holds one copy of each product, as
    /// the one-shot [`crate::pipeline::grow`] does.
    pub fn keep_stages(mut self, keep: bool) -> Session {
        self.retain = keep;
        if !keep {
            self.cache = Cache::default();
        }
        self
    }

    /// Calls `progress` as each stage starts (0) and ends (1).
    pub fn on_progress(&mut self, progress: impl FnMut(Stage, f32) + Send + 'static) {
        self.progress = Some(Box::new(progress));
    }

    /// The recipe of the last update (or of [`Session::new`]).
    pub fn recipe(&self) -> &Recipe {
        &self.loaded.recipe
    }

    /// The recipe with its origin (where its model files are read from).
    pub fn loaded(&self) -> &Loaded {
        &self.loaded
    }

    /// The tree of the last successful update.
    pub fn tree(&self) -> Option<&Tree> {
        self.tree.as_ref()
    }

    /// The tree of the last successful update, out of the session.
    pub fn into_tree(self) -> Option<Tree> {
        self.tree
    }

    /// The stages the last update ran (the others were kept).
    pub fn last_run(&self) -> &[Stage] {
        &self.last_run
    }

    /// Texture sets drawn over the session's life (each style, size and seed once).
    pub fn textures_drawn(&self) -> usize {
        self.textures.drawn()
    }

    /// Forgets the results of `from` and every later stage, so the next update reruns
    /// them: for a change the recipe does not show (a model file edited on disk).
    pub fn invalidate(&mut self, from: Stage) {
        self.cache.drop_from(from);
        self.tree = None;
    }

    /// Computes the tree of the current recipe (only what is not kept yet). Inside a
    /// [`crate::cancel::scope`] it stops when that scope's token is cancelled.
    pub fn run(&mut self) -> Result<&Tree> {
        self.run_with(&crate::cancel::current().unwrap_or_default())
    }

    /// [`Session::run`] that stops with [`Error::Cancelled`] once `cancel` is set.
    pub fn run_with(&mut self, cancel: &Cancel) -> Result<&Tree> {
        let recipe = self.loaded.recipe.clone();
        self.update_with(recipe, cancel)
    }

    /// Makes `recipe` the session's recipe (checked first: an invalid recipe is an
    /// error and changes nothing) and recomputes from the first stage whose inputs
    /// changed; inside a [`crate::cancel::scope`], until that scope's token is cancelled.
    pub fn update(&mut self, recipe: Recipe) -> Result<&Tree> {
        self.update_with(recipe, &crate::cancel::current().unwrap_or_default())
    }

    /// Makes `loaded` the session's recipe and files: where its origin or overlay differ
    /// from the session's (another preset, another folder, an edited grammar), every
    /// stage reruns, but the drawn textures are kept and reused where their settings
    /// match; otherwise this is [`Session::update_with`] of its recipe.
    ///
    /// ```
    /// use sylva::recipe::Loaded;
    /// use sylva::session::{Session, Stage};
    /// let mut session = Session::new(Loaded::preset("lsys-binary-tree")?);
    /// session.run()?;
    /// let drawn = session.textures_drawn();
    /// let edited = session.loaded().clone().with_overlay("lsystem/binary-tree.l", "Lsystem: 1\nderivation length: 2\nAxiom: F\nF --> F[+F]F\nendlsystem\n");
    /// session.update_loaded_with(edited, &Default::default())?;
    /// assert!(session.last_run().contains(&Stage::Generate));
    /// assert_eq!(session.textures_drawn(), drawn, "no texture drawn again");
    /// # Ok::<(), sylva::Error>(())
    /// ```
    pub fn update_loaded_with(&mut self, loaded: Loaded, cancel: &Cancel) -> Result<&Tree> {
        let Loaded { recipe, origin, overlay } = loaded;
        if origin != self.loaded.origin || overlay != self.loaded.overlay {
            recipe.check()?;
            self.loaded.origin = origin;
            self.loaded.overlay = overlay;
            self.invalidate(Stage::Generate);
        }
        self.update_with(recipe, cancel)
    }

    /// [`Session::update`] that stops with [`Error::Cancelled`] once `cancel` is set
    /// (checked between stages and inside the long ones; a front end cancels a stale
    /// update from another thread). A cancelled or failed update keeps the stages it
    /// finished and drops the rest; the session's recipe is then the new one.
    pub fn update_with(&mut self, recipe: Recipe, cancel: &Cancel) -> Result<&Tree> {
        recipe.check()?;
        let first = self.first_stale(&recipe, Stage::ALL).unwrap_or(Stage::Clip);
        let unchanged = first == Stage::Clip && self.loaded.recipe == recipe && self.tree.is_some();
        self.loaded.recipe = recipe;
        self.last_run.clear();
        if unchanged {
            return Ok(self.tree.as_ref().expect("checked above"));
        }
        self.cache.drop_from(first);
        self.tree = None;
        let result = crate::cancel::scope(cancel, || self.compute(first, cancel));
        match result {
            Ok(tree) => Ok(self.tree.insert(tree)),
            Err(e) => Err(e),
        }
    }

    /// The fitted skeleton of the current recipe, roots in place, with the report so
    /// far: the generator and the skeleton passes only, nothing meshed past what the
    /// fit itself needs. This is what a skeleton output (`.lst`, `.skel.json`) writes,
    /// at the cost of the skeleton alone. Stops with [`Error::Cancelled`] once `cancel`
    /// is set; kept stages are reused and kept as in [`Session::update_with`].
    ///
    /// ```
    /// use sylva::session::Session;
    /// let mut session = Session::new(sylva::recipe::load("lsys-binary-tree", &[])?);
    /// let (skeleton, _report) = session.skeleton_with(&Default::default())?;
    /// assert!(skeleton.len() > 1);
    /// assert!(session.tree().is_none(), "nothing was meshed");
    /// # Ok::<(), sylva::Error>(())
    /// ```
    pub fn skeleton_with(&mut self, cancel: &Cancel) -> Result<(Skeleton, Report)> {
        let recipe = self.loaded.recipe.clone();
        recipe.check()?;
        let first = self.first_stale(&recipe, [Stage::Generate, Stage::Fit]).unwrap_or(Stage::Bark);
        self.last_run.clear();
        if first <= Stage::Fit {
            self.cache.drop_from(first);
            self.tree = None;
        }
        crate::cancel::scope(cancel, || {
            let mut run = Run { first, cancel, times: Vec::new() };
            let (_, fit) = self.fitted(&mut run, &recipe)?;
            let mut skeleton = fit.skeleton.clone();
            crate::mesh::ground::restore_roots(&mut skeleton, &fit.sunk);
            let mut report = fit.report.clone();
            report.stage_times = run.times.into_iter().map(|(s, t)| (s.name(), t)).collect();
            report.warnings = pipeline::clip_warnings(std::mem::take(&mut report.warnings));
            Ok((skeleton, report))
        })
    }

    /// The first of `stages` whose kept result was not made from `recipe`'s settings
    /// (or that has none).
    fn first_stale(&self, recipe: &Recipe, stages: impl IntoIterator<Item = Stage>) -> Option<Stage> {
        stages.into_iter().find(|&s| !self.cache.recipe(s).is_some_and(|kept| s.same_inputs(kept, recipe)))
    }

    /// The generator's and the fit's results, run or kept as `run` says.
    fn fitted(&mut self, run: &mut Run, recipe: &Recipe) -> Result<(Arc<Generate>, Arc<Fit>)> {
        let generate = self.cached(run, |me| {
            let mut report = Report::default();
            let generated = pipeline::skeleton(&me.loaded, &mut report)?;
            Ok(Generate { generated, report })
        })?;
        let fit = self.cached(run, |_| {
            let mut report = generate.report.clone();
            let mut skeleton = generate.generated.skeleton.clone();
            let (sunk, cleared) = pipeline::fit_stage(recipe, &mut skeleton, &mut report)?;
            Ok(Fit { skeleton, sunk, cleared, report })
        })?;
        Ok((generate, fit))
    }

    /// Runs stage `s` if it is at or after `run.first` (timed, with progress and a
    /// cancellation check after it); `Ok(None)` when it is kept.
    fn stage<T>(
        &mut self,
        run: &mut Run,
        s: Stage,
        f: impl FnOnce(&mut Self) -> Result<T>,
    ) -> Result<Option<T>> {
        if s < run.first {
            return Ok(None);
        }
        run.cancel.check()?;
        if let Some(p) = self.progress.as_mut() {
            p(s, 0.0);
        }
        let t = Instant::now();
        let value = f(self)?;
        run.cancel.check()?;
        run.times.push((s, t.elapsed()));
        self.last_run.push(s);
        if let Some(p) = self.progress.as_mut() {
            p(s, 1.0);
        }
        Ok(Some(value))
    }

    fn compute(&mut self, first: Stage, cancel: &Cancel) -> Result<Tree> {
        let recipe = self.loaded.recipe.clone();
        let mut run = Run { first, cancel, times: Vec::new() };

        let (generate, fit) = self.fitted(&mut run, &recipe)?;

        let bark = self.cached(&mut run, |_| {
            let mut report = fit.report.clone();
            let fitted = match &fit.cleared {
                Some(f) => f.clone(),
                None => pipeline::mesh_fitted(&recipe, &fit.skeleton, &mut report)?,
            };
            let bark = pipeline::bark_stage(&recipe, fitted, &fit.sunk, &mut report)?;
            Ok(Bark { bark, report })
        })?;

        let (generate_ref, fit_ref, recipe_ref) = (&generate, &fit, &recipe);
        let assemble = self.cached(&mut run, move |_| {
            let mut report = bark.report.clone();
            let mesh = take(bark, |b| b.bark, |b| b.bark.clone());
            let (model, card_nodes) = pipeline::assemble_stage(
                recipe_ref,
                mesh,
                &fit_ref.skeleton,
                &generate_ref.generated.surfaces,
                &mut report,
            );
            Ok(Assemble { model, card_nodes, report })
        })?;

        let dress = self.cached(&mut run, move |me| {
            let mut report = assemble.report.clone();
            let card_nodes = assemble.card_nodes.clone();
            let mut model = take(assemble, |a| a.model, |a| a.model.clone());
            pipeline::dress_stage(recipe_ref, &mut model, &card_nodes, &mut me.textures, &mut report)?;
            Ok(Dress { model, report })
        })?;

        let lod = self.cached(&mut run, move |me| {
            let mut report = dress.report.clone();
            let mut skeleton = fit_ref.skeleton.clone();
            crate::mesh::ground::restore_roots(&mut skeleton, &fit_ref.sunk);
            let mut model = take(dress, |d| d.model, |d| d.model.clone());
            model.curves =
                generate_ref.generated.curves.clone().unwrap_or_else(|| BranchCurves::fit(&skeleton));
            let loaded = Loaded {
                recipe: recipe_ref.clone(),
                origin: me.loaded.origin.clone(),
                overlay: me.loaded.overlay.clone(),
            };
            pipeline::lod_stage(
                &loaded,
                &skeleton,
                &generate_ref.generated.surfaces,
                &mut model,
                &mut report,
            )?;
            Ok(Lod { skeleton, model, report })
        })?;

        let rig = self.cached(&mut run, move |_| {
            let mut report = lod.report.clone();
            let (skeleton, mut model) =
                take(lod, |l| (l.skeleton, l.model), |l| (l.skeleton.clone(), l.model.clone()));
            let plan = pipeline::rig_stage(recipe_ref, &mut model, &mut report);
            Ok(Rig { skeleton, model, plan, report })
        })?;

        let mut tree = self
            .stage(&mut run, Stage::Clip, move |_| {
                let mut report = rig.report.clone();
                let plan = rig.plan.clone();
                let (skeleton, mut model) =
                    take(rig, |r| (r.skeleton, r.model), |r| (r.skeleton.clone(), r.model.clone()));
                if let Some(plan) = &plan {
                    pipeline::clip_stage(recipe_ref, plan, &mut model, &mut report);
                }
                model.provenance = pipeline::provenance(recipe_ref);
                Ok(Tree { skeleton, model, report, recipe: recipe_ref.clone() })
            })?
            .expect("the last stage always runs");
        tree.report.stage_times = run.times.into_iter().map(|(s, t)| (s.name(), t)).collect();
        tree.report.warnings = pipeline::clip_warnings(std::mem::take(&mut tree.report.warnings));
        Ok(tree)
    }

    /// [`Session::stage`] for the stage that makes a `T`: its new result, kept in its
    /// slot when the session keeps stages, or the kept one when it did not run.
    fn cached<T: Staged>(&mut self, run: &mut Run, f: impl FnOnce(&mut Self) -> Result<T>) -> Result<Arc<T>> {
        match self.stage(run, T::STAGE, f)? {
            Some(v) => Ok(self.keep(v, T::slot)),
            None => kept(T::slot(&mut self.cache)),
        }
    }

    /// Keeps `value` in its slot when the session keeps stages; returns it shared.
    fn keep<T>(&mut self, value: T, slot: impl FnOnce(&mut Cache) -> &mut Option<Kept<T>>) -> Arc<T> {
        let value = Arc::new(value);
        if self.retain {
            *slot(&mut self.cache) = Some(Kept { recipe: self.loaded.recipe.clone(), value: value.clone() });
        }
        value
    }
}

/// A kept stage result (a stage after the first to rerun always has one).
fn kept<T>(slot: &Option<Kept<T>>) -> Result<Arc<T>> {
    slot.as_ref()
        .map(|k| k.value.clone())
        .ok_or_else(|| Error::Recipe("internal: a session stage lost its result".into()))
}

/// The part of a stage result the next stage consumes: moved out when nothing else holds
/// the result (a session that keeps no stages), else cloned.
fn take<T, U>(value: Arc<T>, into: impl FnOnce(T) -> U, clone: impl FnOnce(&T) -> U) -> U {
    match Arc::try_unwrap(value) {
        Ok(v) => into(v),
        Err(shared) => clone(&shared),
    }
}
