//! The regeneration worker: one thread that owns a [`Session`] and grows the newest
//! recipe it is given, so the UI thread never waits on the engine.
//!
//! [`Worker::submit`] cancels the run in flight (the session's checkpoints stop it within
//! milliseconds) and queues the new job; the thread drains its queue to the newest job
//! before it starts, so while a slider is dragged only the last value is grown. Each run
//! ends in one [`Outcome`] read with [`Worker::poll`]. A session keeps every stage whose
//! inputs the change did not touch (docs/architecture.md, "Sessions"), so a leaf or wind
//! change does not regrow the skeleton.
//!
//! [`CageWorker`] is a second such thread for the view's cage (issue 41 item 2): it
//! meshes a grown tree's skeleton with refinement off ([`cage_mesh`]), newest request
//! first, so turning the cage on never makes the UI wait either.

use egui_wgpu::wgpu;
use std::collections::HashMap;
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use sylva::cancel::Cancel;
use sylva::pipeline::Tree;
use sylva::recipe::{Loaded, Recipe};
use sylva::session::{Session, Stage};
use sylva::{Mesh, Skeleton};
use sylva_gpu::render::Renderer;

/// What one job ended in.
#[derive(Debug)]
pub enum Outcome {
    /// The tree was grown.
    Grown {
        /// The job's number ([`Worker::submit`]'s return).
        job: u64,
        /// The tree (model, skeleton, report, recipe).
        tree: Box<Tree>,
        /// The tree's model already uploaded to the view's GPU device (made on the
        /// worker, so the UI thread does not spend the upload's tens of milliseconds;
        /// what the previous tree uploaded and this one still holds is reused);
        /// `None` without a device, `Some(Err)` with the renderer's message.
        renderer: Option<Result<Arc<Renderer>, String>>,
        /// The stages this run computed (the others were kept).
        stages: Vec<Stage>,
        /// Wall time of the run.
        elapsed: Duration,
    },
    /// The recipe could not be grown: the engine's message (the last good tree stays).
    Failed {
        /// The job's number.
        job: u64,
        /// What went wrong, as the CLI would print it.
        message: String,
    },
    /// A newer job replaced this one before it finished.
    Cancelled {
        /// The job's number.
        job: u64,
    },
}

impl Outcome {
    /// The job this outcome belongs to.
    pub fn job(&self) -> u64 {
        match self {
            Outcome::Grown { job, .. } | Outcome::Failed { job, .. } | Outcome::Cancelled { job } => *job,
        }
    }
}

/// A job: grow `loaded` (a new origin, such as another preset or file, starts a new
/// session; the same origin updates the current one).
struct Job {
    id: u64,
    loaded: Loaded,
    fresh: bool,
}

/// The worker thread and its two channels.
pub struct Worker {
    jobs: Option<Sender<Job>>,
    outcomes: Receiver<Outcome>,
    current: Arc<Mutex<Cancel>>,
    next: u64,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for Worker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Worker").field("next", &self.next).finish_non_exhaustive()
    }
}

/// The view's GPU device, where the worker uploads each tree it grows.
#[derive(Clone)]
pub struct Upload {
    /// The adapter (its limits decide MSAA and texture sizes).
    pub adapter: wgpu::Adapter,
    /// The device the view draws with.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl std::fmt::Debug for Upload {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Upload").field("adapter", &self.adapter.get_info().name).finish()
    }
}

impl Upload {
    /// The device of egui's wgpu state.
    pub fn from_render_state(gpu: &egui_wgpu::RenderState) -> Upload {
        Upload { adapter: gpu.adapter.clone(), device: gpu.device.clone(), queue: gpu.queue.clone() }
    }

    /// The tree uploaded, its pipelines compiled for the view. `previous` is the last
    /// tree this worker uploaded: its pipelines are shared (only the first tree compiles
    /// them), and its buffers and textures reused where the new tree's parts and images
    /// are the same (a leaf change uploads the leaves only).
    fn renderer(&self, tree: &Tree, previous: &mut Option<Arc<Renderer>>) -> Result<Arc<Renderer>, String> {
        let r = Renderer::with_device_reusing(
            &self.adapter,
            &self.device,
            &self.queue,
            &tree.model,
            previous.as_deref(),
        )
        .map_err(|e| format!("cannot draw this tree: {e}"))?;
        r.prepare(crate::viewport::VIEW_FORMAT, true);
        let r = Arc::new(r);
        *previous = Some(Arc::clone(&r));
        Ok(r)
    }
}

impl Worker {
    /// Starts the thread. `wake` is called after each outcome is sent (the editor asks
    /// egui for a repaint there, so a finished tree shows without input); each tree
    /// grown is uploaded to `upload`'s device when there is one.
    pub fn new(wake: impl Fn() + Send + Sync + 'static, upload: Option<Upload>) -> Worker {
        let (jobs, queue) = channel::<Job>();
        let (send, outcomes) = channel();
        let current = Arc::new(Mutex::new(Cancel::new()));
        let token = current.clone();
        let thread = std::thread::Builder::new()
            .name("sylva-edit worker".into())
            .spawn(move || run(queue, send, token, wake, upload))
            .expect("the editor's worker thread starts");
        Worker { jobs: Some(jobs), outcomes, current, next: 0, thread: Some(thread) }
    }

    /// Queues `loaded` and cancels the job in flight; `fresh` starts a new session (a
    /// different preset or file) instead of updating the current one. Returns the job's
    /// number.
    pub fn submit(&mut self, loaded: Loaded, fresh: bool) -> u64 {
        self.next += 1;
        lock(&self.current).cancel();
        if let Some(jobs) = &self.jobs {
            // A closed channel means the thread has ended (it only ends on drop).
            let _ = jobs.send(Job { id: self.next, loaded, fresh });
        }
        self.next
    }

    /// The next outcome, if one is ready.
    pub fn poll(&self) -> Option<Outcome> {
        self.outcomes.try_recv().ok()
    }

    /// Waits up to `timeout` for the next outcome (tests and headless runs).
    pub fn wait(&self, timeout: Duration) -> Option<Outcome> {
        self.outcomes.recv_timeout(timeout).ok()
    }

    /// The number of the newest job submitted.
    pub fn latest(&self) -> u64 {
        self.next
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        lock(&self.current).cancel();
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn lock(m: &Mutex<Cancel>) -> std::sync::MutexGuard<'_, Cancel> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The thread: take the newest queued job, grow it with a fresh token, send the outcome.
fn run(
    queue: Receiver<Job>,
    send: Sender<Outcome>,
    current: Arc<Mutex<Cancel>>,
    wake: impl Fn(),
    upload: Option<Upload>,
) {
    let mut session: Option<Session> = None;
    let mut uploaded: Option<Arc<Renderer>> = None;
    while let Ok(mut job) = queue.recv() {
        let mut skipped = Vec::new();
        while let Ok(newer) = queue.try_recv() {
            // A newer job after a `fresh` one must still start a new session.
            let fresh = job.fresh || newer.fresh;
            skipped.push(job.id);
            job = Job { fresh, ..newer };
        }
        for id in skipped {
            let _ = send.send(Outcome::Cancelled { job: id });
        }
        let token = Cancel::new();
        *lock(&current) = token.clone();
        let started = Instant::now();
        let result = match session.as_mut() {
            Some(s) if !job.fresh => {
                let recipe = job.loaded.recipe.clone();
                s.update_with(recipe, &token).cloned().map(|t| (t, s.last_run().to_vec()))
            }
            _ => {
                let mut s = Session::new(job.loaded);
                let r = s.run_with(&token).cloned().map(|t| (t, s.last_run().to_vec()));
                session = Some(s);
                r
            }
        };
        let outcome = match result {
            Ok((tree, stages)) => {
                let renderer = upload.as_ref().map(|u| u.renderer(&tree, &mut uploaded));
                Outcome::Grown {
                    job: job.id,
                    tree: Box::new(tree),
                    renderer,
                    stages,
                    elapsed: started.elapsed(),
                }
            }
            Err(sylva::Error::Cancelled) => Outcome::Cancelled { job: job.id },
            Err(e) => Outcome::Failed { job: job.id, message: e.to_string() },
        };
        if send.send(outcome).is_err() {
            return;
        }
        wake();
    }
}

/// The mesher's control mesh of a grown tree — its cage: `skeleton` (a [`Tree`]'s, the
/// fitted skeleton) meshed by `recipe`'s mesher with refinement off (`refine.levels =
/// 0`, no limit projection), its roots sunk and its base cut as the bark's are, without
/// the leaves.
///
/// Errors: the mesher's (the same the tree's own meshing would have met).
pub fn cage_mesh(recipe: &Recipe, skeleton: &Skeleton) -> sylva::Result<Mesh> {
    let mut unrefined = recipe.clone();
    unrefined.refine.levels = 0;
    unrefined.refine.limit = false;
    unrefined.output.textures = sylva::export::TextureMode::None;
    let mut bare = skeleton.clone();
    bare.organs.clear();
    let model = sylva::pipeline::mesh(&unrefined, &bare, &HashMap::new(), &mut sylva::Report::default())?;
    // The assembly puts the bark (or a leaf-mode leaf) first.
    Ok(model.parts.into_iter().next().map(|p| p.mesh).unwrap_or_default())
}

/// What one cage request ended in.
#[derive(Debug)]
pub enum CageOutcome {
    /// The cage was meshed.
    Meshed {
        /// The request's number ([`CageWorker::submit`]'s return).
        job: u64,
        /// The control mesh.
        mesh: Mesh,
        /// Wall time of the meshing.
        elapsed: Duration,
    },
    /// The mesher failed: its message.
    Failed {
        /// The request's number.
        job: u64,
        /// What went wrong.
        message: String,
    },
    /// A newer request replaced this one before it finished.
    Cancelled {
        /// The request's number.
        job: u64,
    },
}

/// A cage request: mesh `skeleton` by `recipe`.
struct CageJob {
    id: u64,
    recipe: Recipe,
    skeleton: Arc<Skeleton>,
}

/// The cage thread and its two channels (see the [module docs](self)).
pub struct CageWorker {
    jobs: Option<Sender<CageJob>>,
    outcomes: Receiver<CageOutcome>,
    current: Arc<Mutex<Cancel>>,
    next: u64,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for CageWorker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CageWorker").field("next", &self.next).finish_non_exhaustive()
    }
}

impl CageWorker {
    /// Starts the thread; `wake` is called after each outcome is sent.
    pub fn new(wake: impl Fn() + Send + Sync + 'static) -> CageWorker {
        let (jobs, queue) = channel::<CageJob>();
        let (send, outcomes) = channel();
        let current = Arc::new(Mutex::new(Cancel::new()));
        let token = current.clone();
        let thread = std::thread::Builder::new()
            .name("sylva-edit cage".into())
            .spawn(move || run_cages(queue, send, token, wake))
            .expect("the editor's cage thread starts");
        CageWorker { jobs: Some(jobs), outcomes, current, next: 0, thread: Some(thread) }
    }

    /// Queues the cage of `skeleton` by `recipe` and cancels the one in flight; returns
    /// the request's number.
    pub fn submit(&mut self, recipe: Recipe, skeleton: Arc<Skeleton>) -> u64 {
        self.next += 1;
        lock(&self.current).cancel();
        if let Some(jobs) = &self.jobs {
            let _ = jobs.send(CageJob { id: self.next, recipe, skeleton });
        }
        self.next
    }

    /// The next outcome, if one is ready.
    pub fn poll(&self) -> Option<CageOutcome> {
        self.outcomes.try_recv().ok()
    }

    /// The number of the newest request.
    pub fn latest(&self) -> u64 {
        self.next
    }
}

impl Drop for CageWorker {
    fn drop(&mut self) {
        lock(&self.current).cancel();
        self.jobs = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The cage thread: the newest queued request, meshed under a fresh token.
fn run_cages(
    queue: Receiver<CageJob>,
    send: Sender<CageOutcome>,
    current: Arc<Mutex<Cancel>>,
    wake: impl Fn(),
) {
    while let Ok(mut job) = queue.recv() {
        while let Ok(newer) = queue.try_recv() {
            let _ = send.send(CageOutcome::Cancelled { job: job.id });
            job = newer;
        }
        let token = Cancel::new();
        *lock(&current) = token.clone();
        let started = Instant::now();
        let result = sylva::cancel::scope(&token, || cage_mesh(&job.recipe, &job.skeleton));
        let outcome = match result {
            _ if token.is_cancelled() => CageOutcome::Cancelled { job: job.id },
            Ok(mesh) => CageOutcome::Meshed { job: job.id, mesh, elapsed: started.elapsed() },
            Err(e) => CageOutcome::Failed { job: job.id, message: e.to_string() },
        };
        if send.send(outcome).is_err() {
            return;
        }
        wake();
    }
}
