//! `sylva edit`: a live tree editor. The settings panel is generated from the recipe
//! schema; each change goes to a worker thread that regrows the tree through a
//! [`sylva::Session`] (only the stages the change touches) while the UI keeps drawing;
//! sylva-gpu's renderer shows the tree with its wind playing. See docs/editor.md.
//!
//! - [`document`]: the recipe being edited, undo/redo, save (no UI);
//! - [`worker`]: the regeneration thread (newest change wins, stale runs cancelled);
//! - [`panel`]: the controls, from [`sylva::recipe::schema()`];
//! - [`grammar`]: an L-system's text, its errors in place and its `#define` sliders;
//! - [`thumbnails`]: the preset picker's pictures;
//! - [`viewport`]: the 3D view on egui's wgpu device;
//! - [`composite`]: draws the view's texture into the window inside egui's pass;
//! - [`app`]: the window, menu and status bar ([`EditorApp`]);
//! - [`frame_log`]: frame times and change-to-tree latencies;
//! - [`watch`]: `--watch`, reloading a recipe changed on disk.
//!
//! ```no_run
//! let opts = sylva_editor::EditOptions { what: Some("wp-quaking-aspen".into()), ..Default::default() };
//! sylva_editor::run(opts).expect("the editor runs");
//! ```

pub mod app;
pub mod composite;
pub mod document;
pub mod frame_log;
pub mod grammar;
pub mod panel;
pub mod thumbnails;
pub mod viewport;
pub mod watch;
pub mod worker;

pub use app::{EditOptions, EditorApp};
pub use document::Document;

/// Why the editor could not run.
#[derive(Debug)]
pub enum EditError {
    /// The recipe or file to edit could not be read (the engine's message).
    Input(String),
    /// No display or no GPU: the window cannot open.
    Window(String),
}

impl std::fmt::Display for EditError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EditError::Input(m) => f.write_str(m),
            EditError::Window(m) => write!(f, "cannot open the editor's window: {m}"),
        }
    }
}

impl std::error::Error for EditError {}

/// Opens the editor window and runs until it is closed.
///
/// Errors: the input cannot be read (before any window opens), there is no display
/// (`DISPLAY` / `WAYLAND_DISPLAY` unset), or no GPU adapter can draw the window.
pub fn run(mut opts: EditOptions) -> Result<(), EditError> {
    opts.started.get_or_insert_with(std::time::Instant::now);
    let mut doc = Document::open(opts.what.as_deref()).map_err(EditError::Input)?;
    for set in &opts.sets {
        let (k, v) = sylva::recipe::parse_set(set).map_err(|e| EditError::Input(e.to_string()))?;
        doc.set(&k, v, false).map_err(EditError::Input)?;
    }
    if sylva_gpu::render::window::display().is_none() {
        return Err(EditError::Window(
            "no display: neither DISPLAY nor WAYLAND_DISPLAY is set (run it in a desktop session, or under `xvfb-run`)"
                .into(),
        ));
    }
    let title = format!("sylva edit — {}", doc.source());
    let native = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default().with_title(title.clone()).with_inner_size([1280.0, 800.0]),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native(
        &title,
        native,
        Box::new(move |cc| Ok(Box::new(EditorApp::from_creation_context(cc, doc, opts)))),
    )
    .map_err(|e| EditError::Window(e.to_string()))
}
