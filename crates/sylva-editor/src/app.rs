//! The editor window: the settings panel on the left, the view in the middle, a status
//! bar with triangles, vertices, per-stage times and warnings at the bottom, and a menu
//! bar (presets, undo/redo, reset, new seed, play/pause, save, export).
//!
//! Every frame applies the panel's edits to the [`Document`], submits a changed recipe
//! to the [`Worker`] (which cancels the stale run) and takes any finished tree; the UI
//! thread never waits on the engine. A recipe the engine refuses, or a run that fails,
//! shows its message and the last good tree stays. [`FrameLog`] records the latency
//! figures of docs/editor.md.

use crate::document::{Document, Source};
use crate::frame_log::FrameLog;
use crate::panel;
use crate::thumbnails::Thumbnails;
use crate::viewport::Viewport;
use crate::watch::Watch;
use crate::worker::{Outcome, Upload, Worker};
use std::path::PathBuf;
use std::time::{Duration, Instant};
use sylva::pipeline::Tree;

/// How the editor starts.
#[derive(Debug, Clone, Default)]
pub struct EditOptions {
    /// A preset name, a recipe or a model file; `None`: the default tree.
    pub what: Option<String>,
    /// `key=value` settings applied on top (as `--set`).
    pub sets: Vec<String>,
    /// Reload when the recipe file (or its `.l` file) changes on disk.
    pub watch: bool,
    /// Write the frame log (JSON lines) here when the editor closes.
    pub frame_log: Option<PathBuf>,
    /// Close once a tree is shown and this many frames have passed after the newest
    /// one (after the `script`, when there is one).
    pub close_after_tree: Option<u64>,
    /// Changes applied one at a time once a tree is shown, each after the previous
    /// one's tree (latency measurements: the frame log times each).
    pub script: Vec<(String, toml::Value)>,
    /// When the editor was asked to start: the frame log's zero, so "launch to first
    /// tree" includes opening the window and the GPU device ([`crate::run`] sets it on
    /// entry; `None`: when the app is made).
    pub started: Option<Instant>,
    /// Draw the view at full resolution in every frame, even while it changes (snapshot
    /// tests; by default frames are drawn smaller while the view changes if drawing is
    /// slow, [`crate::viewport::FRAME_BUDGET_MS`]).
    pub full_resolution: bool,
}

/// The editor's state.
pub struct EditorApp {
    doc: Document,
    worker: Worker,
    viewport: Viewport,
    tree: Option<Box<Tree>>,
    /// The job whose tree is shown (or 0).
    shown_job: u64,
    /// The revision of the document last submitted.
    submitted: u64,
    filter: String,
    /// The last error (a refused value, a failed run, a file that vanished).
    message: Option<String>,
    /// The stages the last run computed, and its time.
    last_run: Option<(Vec<sylva::Stage>, Duration)>,
    watch: Option<Watch>,
    save_path: String,
    log: FrameLog,
    opts: EditOptions,
    frames_since_tree: Option<u64>,
    /// When the worker's last outcome (a tree or an error) was taken.
    outcome_at: Option<Instant>,
    /// eframe's CPU time of the previous frame (for the frame log).
    previous_cpu: Option<Duration>,
    seed_counter: u64,
    thumbnails: Thumbnails,
}

impl std::fmt::Debug for EditorApp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EditorApp").field("source", self.doc.source()).finish_non_exhaustive()
    }
}

impl EditorApp {
    /// The editor on `doc`, drawing with `gpu` (egui's wgpu state; `None`: no view).
    /// `ctx` is woken when the worker finishes a tree. Starts growing at once.
    pub fn new(
        ctx: &egui::Context,
        gpu: Option<egui_wgpu::RenderState>,
        doc: Document,
        opts: EditOptions,
    ) -> EditorApp {
        let woken = ctx.clone();
        let upload = gpu.as_ref().map(Upload::from_render_state);
        let worker = Worker::new(move || woken.request_repaint(), upload);
        let watch = if opts.watch {
            match &doc.source() {
                Source::File(path) => match Watch::new(path, doc.folder()) {
                    Ok(w) => Some(w),
                    Err(e) => {
                        eprintln!("sylva edit: --watch: {e}");
                        None
                    }
                },
                Source::Preset(_) => None,
            }
        } else {
            None
        };
        let save_path = file_name(doc.source());
        let mut app = EditorApp {
            doc,
            worker,
            viewport: Viewport::new(gpu),
            tree: None,
            shown_job: 0,
            submitted: u64::MAX,
            filter: String::new(),
            message: None,
            last_run: None,
            watch,
            save_path,
            log: FrameLog::starting_at(opts.started.unwrap_or_else(Instant::now)),
            opts,
            frames_since_tree: None,
            outcome_at: None,
            previous_cpu: None,
            seed_counter: 0,
            thumbnails: Thumbnails::default(),
        };
        app.viewport.full_resolution = app.opts.full_resolution;
        app.submit(true);
        app
    }

    /// The editor inside eframe (a window, or egui_kittest's headless harness): egui's
    /// context and wgpu state come from `cc`.
    pub fn from_creation_context(
        cc: &eframe::CreationContext<'_>,
        doc: Document,
        opts: EditOptions,
    ) -> EditorApp {
        EditorApp::new(&cc.egui_ctx, cc.wgpu_render_state.clone(), doc, opts)
    }

    /// The document (tests read the recipe from it).
    pub fn document(&self) -> &Document {
        &self.doc
    }

    /// The tree shown, if one has been grown.
    pub fn tree(&self) -> Option<&Tree> {
        self.tree.as_deref()
    }

    /// The message shown in the status bar, if any.
    pub fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }

    /// The stages the last finished run computed.
    pub fn last_stages(&self) -> Option<&[sylva::Stage]> {
        self.last_run.as_ref().map(|(s, _)| s.as_slice())
    }

    /// Whether the newest submitted recipe has been grown (or has failed).
    pub fn settled(&self) -> bool {
        self.shown_job == self.worker.latest()
    }

    /// The frame log.
    pub fn log(&self) -> &FrameLog {
        &self.log
    }

    /// Applies an edit as the panel would (tests; scripted use).
    pub fn apply(&mut self, key: &str, value: toml::Value, dragging: bool) {
        let started = Instant::now();
        match self.doc.set(key, value, dragging) {
            Ok(()) => self.message = None,
            Err(e) => self.message = Some(e),
        }
        self.log.event("edit", key, started.elapsed());
    }

    /// Waits (tests) until the newest recipe is grown or `timeout` passes, taking the
    /// outcomes as frames would.
    pub fn wait_settled(&mut self, timeout: Duration) -> bool {
        let deadline = Instant::now() + timeout;
        self.submit(false);
        while !self.settled() {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return false;
            }
            if let Some(o) = self.worker.wait(left.min(Duration::from_millis(50))) {
                self.take(o);
            }
        }
        true
    }

    /// Submits the document when it changed since the last submission.
    fn submit(&mut self, fresh: bool) {
        // An edited grammar is a new file under the recipe: a new session grows it.
        let fresh = self.doc.take_files_changed() || fresh;
        if fresh || self.submitted != self.doc.revision() {
            self.submitted = self.doc.revision();
            self.worker.submit(self.doc.loaded().clone(), fresh);
            self.log.mark_submitted();
        }
    }

    /// Takes one outcome of the worker.
    fn take(&mut self, outcome: Outcome) {
        let job = outcome.job();
        if !matches!(outcome, Outcome::Cancelled { .. }) {
            self.outcome_at = Some(Instant::now());
        }
        match outcome {
            Outcome::Grown { tree, renderer, stages, elapsed, .. } => {
                self.viewport.set_tree(&tree, renderer);
                self.last_run = Some((stages, elapsed));
                self.log.tree_arrived(elapsed, tree.report.stage_times.clone());
                self.tree = Some(tree);
                self.shown_job = job;
                if job == self.worker.latest() {
                    self.message = None;
                }
                // `--close-after-tree` counts the frames after the newest tree.
                self.frames_since_tree = Some(0);
            }
            Outcome::Failed { message, .. } => {
                self.shown_job = job;
                self.message = Some(message);
            }
            Outcome::Cancelled { .. } => {}
        }
    }

    /// One frame of the whole window.
    pub fn frame(&mut self, ui: &mut egui::Ui) {
        let started = Instant::now();
        self.log.frame_began();
        while let Some(o) = self.worker.poll() {
            self.take(o);
        }
        self.poll_watch();
        self.menu(ui);
        self.status(ui);
        let edits = egui::Panel::left("settings")
            .resizable(true)
            .default_size(340.0)
            .show(ui, |ui| {
                ui.horizontal(|ui| {
                    ui.label("find");
                    ui.add(
                        egui::TextEdit::singleline(&mut self.filter)
                            .hint_text("key or words")
                            .desired_width(200.0),
                    );
                });
                ui.separator();
                egui::ScrollArea::vertical().show(ui, |ui| panel::show(ui, &self.doc, &self.filter)).inner
            })
            .inner;
        let dragging = edits.iter().any(|e| e.dragging);
        for e in edits {
            self.apply(&e.key, e.value, e.dragging);
        }
        if !dragging && !ui.input(|i| i.pointer.any_down()) {
            self.doc.end_join();
        }
        if let Some(m) = crate::grammar::show(ui, &mut self.doc, self.message.as_deref()) {
            self.message = Some(m);
        }
        self.viewport.busy = !self.settled();
        egui::CentralPanel::no_frame().show(ui, |ui| {
            self.viewport.show(ui);
        });
        self.shortcuts(ui);
        self.run_script(ui);
        self.submit(false);
        // No repaint loop while the worker runs: it wakes the UI when its tree is
        // ready, and on a software renderer every frame of the window costs a core for
        // a hundred milliseconds or more that the worker would otherwise have.
        if let Some(n) = self.frames_since_tree.as_mut() {
            *n += 1;
        }
        self.log.frame_with_cpu(started.elapsed(), self.previous_cpu.take());
        if self.log.awaiting_present() {
            // The next frame begins once this one is painted and presented: the log's
            // "presented" time of the tree it shows.
            ui.ctx().request_repaint();
        }
        self.close_when_done(ui);
    }

    /// Applies the next scripted change [`SCRIPT_PAUSE`] after the last one's tree is
    /// shown (waiting by a timed repaint, not a repaint loop that would take the CPU
    /// from the worker being measured).
    fn run_script(&mut self, ui: &egui::Ui) {
        if self.opts.script.is_empty() || !self.settled() {
            return;
        }
        let Some(shown) = self.outcome_at else { return };
        let waited = shown.elapsed();
        if waited < SCRIPT_PAUSE {
            ui.ctx().request_repaint_after(SCRIPT_PAUSE - waited);
            return;
        }
        let (key, value) = self.opts.script.remove(0);
        self.apply(&key, value, false);
        self.frames_since_tree = Some(0);
        ui.ctx().request_repaint();
    }

    fn close_when_done(&mut self, ui: &egui::Ui) {
        if !self.opts.script.is_empty() {
            return;
        }
        let by_tree =
            self.opts.close_after_tree.is_some_and(|n| self.frames_since_tree.is_some_and(|k| k >= n));
        if by_tree {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        // Frames to count, but no repaint loop while the worker runs (it would take the
        // cores of the run being timed): the worker wakes the window with its tree.
        if self.opts.close_after_tree.is_some() && self.settled() {
            ui.ctx().request_repaint();
        }
    }

    fn menu(&mut self, ui: &mut egui::Ui) {
        egui::Panel::top("menu").show(ui, |ui| {
            ui.horizontal_wrapped(|ui| {
                let mut chosen = None;
                let thumbnails = &mut self.thumbnails;
                egui::ComboBox::from_id_salt("preset")
                    .selected_text(self.doc.source().to_string())
                    .height(480.0)
                    .show_ui(ui, |ui| {
                        for p in sylva::presets::all().into_iter().filter(|p| !p.is_curves()) {
                            let picture = thumbnails.get(ui.ctx(), p.name);
                            let item = match &picture {
                                Some(t) => egui::Button::image_and_text(
                                    egui::Image::new(t).fit_to_exact_size(egui::vec2(40.0, 40.0)),
                                    p.name,
                                ),
                                None => egui::Button::new(p.name),
                            };
                            let clicked = ui
                                .add(item.frame(false))
                                .on_hover_ui(|ui| {
                                    if let Some(t) = &picture {
                                        ui.image((t.id(), egui::vec2(128.0, 128.0)));
                                    }
                                    ui.label(p.description());
                                })
                                .clicked();
                            if clicked {
                                chosen = Some(p.name.to_string());
                            }
                        }
                    })
                    .response
                    .accessible_name("preset picker");
                if let Some(name) = chosen {
                    self.open(Some(&name));
                }
                if ui.add_enabled(self.doc.can_undo(), egui::Button::new("Undo")).clicked() {
                    self.doc.undo();
                    drop_focus(ui);
                }
                if ui.add_enabled(self.doc.can_redo(), egui::Button::new("Redo")).clicked() {
                    self.doc.redo();
                    drop_focus(ui);
                }
                if ui.button("Reset").on_hover_text("back to the preset or file").clicked() {
                    self.result(|d| d.reset());
                    drop_focus(ui);
                }
                if ui.button("New seed").clicked() {
                    self.seed_counter += 1;
                    let seed = self.doc.recipe().seed.wrapping_mul(6364136223846793005).wrapping_add(self.seed_counter);
                    self.result(|d| d.new_seed(seed));
                }
                let play = if self.viewport.playing { "Pause wind" } else { "Play wind" };
                if ui.button(play).clicked() {
                    self.viewport.toggle_play();
                }
                if ui.button("Frame").clicked() {
                    self.viewport.reframe();
                }
                ui.separator();
                self.viewport.view_controls(ui);
                ui.separator();
                crate::grammar::menu_toggle(ui, &self.doc);
                ui.separator();
                ui.add(egui::TextEdit::singleline(&mut self.save_path).desired_width(180.0))
                    .on_hover_text("file to save the recipe to (.toml) or export the tree to (.glb, .gltf, .obj, .ply, .pov, .lst, .skel.json; .png: a picture of the view)");
                if ui.button("Open").on_hover_text("open the recipe, model or preset named in the field").clicked() {
                    let what = self.save_path.trim().to_string();
                    self.open(Some(&what));
                }
                if ui.button("Save recipe").clicked() {
                    self.save();
                }
                if ui.button("Export").clicked() {
                    self.export();
                }
            });
        });
    }

    fn status(&mut self, ui: &mut egui::Ui) {
        egui::Panel::bottom("status").show(ui, |ui| {
            ui.horizontal_wrapped(|ui| {
                match &self.tree {
                    Some(t) => {
                        ui.label(format!("{} triangles, {} vertices", t.report.triangles, t.report.vertices));
                        if let Some((stages, time)) = &self.last_run {
                            let names: Vec<&str> = stages.iter().map(|s| s.name()).collect();
                            ui.label(format!("· {:.0} ms ({})", time.as_secs_f64() * 1e3, names.join(", ")))
                                .on_hover_text(stage_times(t));
                        }
                        if !t.report.warnings.is_empty() {
                            ui.label(
                                egui::RichText::new(format!("· {} warnings", t.report.warnings.len()))
                                    .color(egui::Color32::from_rgb(160, 110, 0)),
                            )
                            .on_hover_text(t.report.warnings.join("\n"));
                        }
                    }
                    None => {
                        ui.label("growing…");
                    }
                }
                if !self.settled() {
                    // A still label, not egui's spinner: a spinner repaints every frame.
                    ui.label(egui::RichText::new("· regrowing…").weak());
                }
                if let Some(a) = self.viewport.adapter() {
                    ui.label(egui::RichText::new(a).weak());
                }
            });
            if let Some(m) = &self.message {
                ui.label(egui::RichText::new(m).color(egui::Color32::DARK_RED));
            }
        });
    }

    fn shortcuts(&mut self, ui: &egui::Ui) {
        let (undo, redo) = ui.input_mut(|i| {
            let redo = i.consume_key(egui::Modifiers::COMMAND | egui::Modifiers::SHIFT, egui::Key::Z)
                || i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y);
            (i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z), redo)
        });
        if undo {
            self.doc.undo();
        }
        if redo {
            self.doc.redo();
        }
        if undo || redo {
            drop_focus(ui);
        }
    }

    fn result(&mut self, f: impl FnOnce(&mut Document) -> Result<(), String>) {
        if let Err(e) = f(&mut self.doc) {
            self.message = Some(e);
        }
    }

    /// Opens another preset or file (a new session; `--watch` follows it when it is a
    /// file); on error the current one stays and the message says why.
    pub fn open(&mut self, what: Option<&str>) {
        match Document::open(what) {
            Ok(doc) => {
                self.save_path = file_name(doc.source());
                if self.opts.watch {
                    self.watch = match doc.source() {
                        Source::File(path) => Watch::new(path, doc.folder()).ok(),
                        Source::Preset(_) => None,
                    };
                }
                self.message = Some(format!("opened {}", doc.source()));
                self.doc = doc;
                self.submit(true);
            }
            Err(e) => self.message = Some(format!("cannot open: {e}")),
        }
    }

    /// Saves the recipe to the path in the menu bar.
    pub fn save(&mut self) {
        let path = PathBuf::from(self.save_path.trim());
        let written = self.doc.to_toml().and_then(|text| {
            sylva::fsutil::write_atomic(&path, |w| w.write_all(text.as_bytes())).map_err(|e| e.to_string())
        });
        self.message = Some(match written {
            Ok(()) => format!("saved {}", path.display()),
            Err(e) => format!("cannot save {}: {e}", path.display()),
        });
    }

    /// The file name in the menu bar that "Save recipe" and "Export" write.
    pub fn set_file_name(&mut self, name: &str) {
        self.save_path = name.to_string();
    }

    /// Exports the shown tree to the path in the menu bar (format by extension; `.png`:
    /// a 1024² picture of the view).
    pub fn export(&mut self) {
        let path = PathBuf::from(self.save_path.trim());
        if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            let written = self.viewport.picture(1024, 1024).and_then(|image| {
                let png = image.to_png().map_err(|e| e.to_string())?;
                sylva::fsutil::write_atomic(&path, |w| w.write_all(&png)).map_err(|e| e.to_string())
            });
            self.message = Some(match written {
                Ok(()) => format!("saved a picture of the view to {}", path.display()),
                Err(e) => format!("cannot save {}: {e}", path.display()),
            });
            return;
        }
        let Some(tree) = &self.tree else {
            self.message = Some("no tree to export yet".into());
            return;
        };
        self.message = Some(match tree.write(&path) {
            Ok(()) => format!("exported {}", path.display()),
            Err(e) => format!("cannot export {}: {e}", path.display()),
        });
    }

    fn poll_watch(&mut self) {
        let Some(w) = self.watch.as_mut() else { return };
        if w.changed() {
            match self.doc.reload() {
                Ok(()) => self.message = Some("reloaded from disk".into()),
                Err(e) => self.message = Some(format!("not reloaded: {e}")),
            }
        }
    }

    /// Writes the frame log if the options ask for it.
    pub fn write_log(&self) {
        if let Some(path) = &self.opts.frame_log {
            if let Err(e) = self.log.write(path) {
                eprintln!("sylva edit: cannot write the frame log {}: {e}", path.display());
            }
        }
    }
}

/// How long a scripted change (`--script-set`) waits after the previous one's tree.
pub const SCRIPT_PAUSE: Duration = Duration::from_millis(500);

/// The file "Save recipe" writes until the user names another: the recipe file itself,
/// a model file's name with `.toml` (never the model: Save grammar writes an `.l`), or
/// `<preset>-edited.toml`.
fn file_name(source: &Source) -> String {
    match source {
        Source::File(p) if p.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")) => {
            p.display().to_string()
        }
        Source::File(p) => p.with_extension("toml").display().to_string(),
        Source::Preset(name) => format!("{name}-edited.toml"),
    }
}

/// Takes the keyboard focus from the control that has it: after an undo, a reset or a
/// reload the recipe changed under the controls, and a focused slider or drop-down item
/// would otherwise report its old value again on the next frame.
fn drop_focus(ui: &egui::Ui) {
    ui.memory_mut(|m| {
        if let Some(id) = m.focused() {
            m.surrender_focus(id);
        }
    });
}

fn stage_times(t: &Tree) -> String {
    t.report
        .stage_times
        .iter()
        .map(|(name, d)| format!("{name}: {:.1} ms", d.as_secs_f64() * 1e3))
        .collect::<Vec<_>>()
        .join("\n")
}

impl eframe::App for EditorApp {
    fn ui(&mut self, ui: &mut egui::Ui, frame: &mut eframe::Frame) {
        self.previous_cpu = frame.info().cpu_usage.map(Duration::from_secs_f32);
        self.frame(ui);
    }

    fn on_exit(&mut self) {
        self.write_log();
    }
}
