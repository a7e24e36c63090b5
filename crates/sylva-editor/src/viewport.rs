//! The 3D view: sylva-gpu's renderer (textures, alpha-cut leaves, MSAA, the wind clip)
//! drawing the current tree into an offscreen texture on egui's own wgpu device, shown
//! as an image in the central panel. Drag to orbit, scroll to zoom; wind plays from the
//! model's clip while "play" is on.
//!
//! The "View" row ([`Viewport::view_controls`]) turns on the ground with its contact
//! shadow, the wireframe, the skeleton (on top, orange) and the cage (the mesher's
//! control mesh, depth-tested, blue — meshed by a [`CageWorker`] thread, never on the
//! UI thread), and picks the level of detail: automatic by distance, or a fixed level.
//! Overlays show the tree at rest: pause the wind to compare them with the bark.
//!
//! The texture is `Rgba8Unorm` viewed as `Rgba8UnormSrgb` by the renderer, so the
//! colours are encoded once; it is drawn into the window by a pipeline of its own inside
//! egui's pass ([`Composite`]: one unblended triangle, a texel per pixel), not as an egui
//! image, and only when what it shows changed. Without a wgpu device (no adapter) the
//! view says so and the rest of the editor works.

use crate::composite::Composite;
use crate::worker::{CageOutcome, CageWorker};
use egui_wgpu::wgpu;
use glam::Mat4;
use std::sync::Arc;
use std::time::Instant;
use sylva::pipeline::Tree;
use sylva::recipe::Recipe;
use sylva::{Model, Skeleton, Stage};
use sylva_gpu::render::window::OrbitControl;
use sylva_gpu::render::{Lines, Orbit, RenderOptions, Renderer};

/// The largest side of the view's texture, pixels.
pub const MAX_SIDE: u32 = 4096;

/// The format the renderer draws the view in (the texture's sRGB view).
pub const VIEW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// The offscreen target and the composite's bind group for it.
struct Target {
    size: (u32, u32),
    texture: wgpu::Texture,
    bind_group: wgpu::BindGroup,
}

/// What the view shows besides the tree (the "View" row).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ViewSettings {
    /// The ground disc with its contact shadow.
    pub ground: bool,
    /// The triangles' edges over the shaded tree.
    pub wireframe: bool,
    /// The skeleton's internodes, drawn on top.
    pub skeleton: bool,
    /// The mesher's control mesh (refinement off), depth-tested.
    pub cage: bool,
    /// A fixed level of detail; `None`: chosen by distance.
    pub lod: Option<usize>,
}

impl Default for ViewSettings {
    /// The ground on, everything else off, automatic level of detail.
    fn default() -> Self {
        ViewSettings { ground: true, wireframe: false, skeleton: false, cage: false, lod: None }
    }
}

/// The skeleton overlay's colour (sRGB).
const SKELETON_COLOR: [u8; 3] = [235, 110, 20];
/// The cage overlay's colour (sRGB).
const CAGE_COLOR: [u8; 3] = [40, 80, 230];

/// The cage of the tree shown: what it is meshed from, and the overlay once it is.
#[derive(Default)]
struct Cage {
    /// The tree's recipe and skeleton (what a cage request meshes).
    source: Option<(Recipe, Arc<Skeleton>)>,
    /// The thread, started when the cage is first shown.
    worker: Option<CageWorker>,
    /// The request whose cage is wanted (0: none asked for the current tree yet).
    wanted: u64,
    /// The cage's edges and its triangle count (drawn until a newer one replaces it).
    shown: Option<(Lines, usize)>,
    /// The request `shown` answers.
    shown_job: u64,
    /// Counts the cages received (part of what a drawn frame shows).
    generation: u64,
    /// The mesher's message when the cage failed.
    error: Option<String>,
}

/// The view of the tree.
pub struct Viewport {
    gpu: Option<egui_wgpu::RenderState>,
    /// Draws the view's texture into the window (made with the device).
    composite: Option<Composite>,
    /// The adapter is a software renderer (Mesa's lavapipe, llvmpipe): the view starts
    /// at the smallest scale and the wind holds while a regeneration runs.
    software: bool,
    renderer: Option<Arc<Renderer>>,
    target: Option<Target>,
    control: OrbitControl,
    framed: bool,
    /// Wind plays (the model's clip, looped).
    pub playing: bool,
    clock: Instant,
    paused_at: f32,
    /// The last renderer or draw error, shown over the view.
    pub error: Option<String>,
    /// Frames drawn.
    pub frames: u64,
    /// Counts the trees uploaded (part of what a drawn frame shows).
    model_generation: u64,
    /// What the texture shows now: a frame with the same key is not drawn again.
    drawn: Option<DrawKey>,
    /// What is shown besides the tree.
    pub view: ViewSettings,
    /// Whether a regeneration is running (set by the app each frame): the view waits
    /// for it before drawing at full resolution again.
    pub busy: bool,
    /// Every frame at full resolution (no adaptive resolution: snapshot tests).
    pub full_resolution: bool,
    /// Adaptive resolution: the frame-cost model and the scale drawn while the view
    /// changes.
    pace: Pace,
    /// The skeleton of the tree shown, as segments.
    skeleton: Option<Lines>,
    cage: Cage,
}

/// Adaptive resolution. While the view changes (wind playing, an orbit, a new tree) it
/// is drawn at a fraction of its side, in steps of 1/8 down to [`MIN_SCALE`], so that a
/// frame costs about [`FRAME_BUDGET_MS`]; once it has been still for [`REFINE_AFTER`]
/// and no regeneration runs, one frame at full resolution follows. A frame's cost is the
/// time from issuing its draw to the start of the next frame (asked for at once), which
/// covers the GPU's work and the present. Over the budget, the scale drops at once to
/// what the cost per pixel says fits; under 80 % of it, it rises one step (not within
/// [`STEP_UP_PAUSE`] of a drop, so it does not flip between two steps every frame). On a
/// GPU the scale stays 1 (a frame waits for the display's refresh, ~17 ms); on a
/// software renderer (lavapipe draws the aspen's 92,744 triangles at 1000×760 in
/// ~250 ms) it drops to keep the editor responsive. A frame drawn smaller is drawn
/// without MSAA; on a software renderer the scale starts at [`MIN_SCALE`], so the first
/// tree's first frame is a small one too.
#[derive(Debug, Clone)]
struct Pace {
    /// The draw being measured: when it was issued, its pixels and the scale it was
    /// drawn at.
    measuring: Option<(Instant, u32, f32)>,
    /// The scale (fraction of the side) used while the view changes.
    scale: f32,
    /// When the scale last dropped.
    dropped_at: Option<Instant>,
    /// When what the view shows last changed.
    changed_at: Instant,
    /// What the view showed then (the draw key without its size).
    content: Option<Content>,
}

/// A frame's cost the view aims at while it changes, milliseconds.
pub const FRAME_BUDGET_MS: f32 = 25.0;
/// How long the view must be still before it is drawn at full resolution.
pub const REFINE_AFTER: std::time::Duration = std::time::Duration::from_millis(300);
/// The smallest scale (fraction of each side) the view is drawn at.
pub const MIN_SCALE: f32 = 0.25;
/// How long after a drop the scale waits before it rises again.
pub const STEP_UP_PAUSE: std::time::Duration = std::time::Duration::from_secs(3);

impl Pace {
    fn new() -> Pace {
        Pace { measuring: None, scale: 1.0, dropped_at: None, changed_at: Instant::now(), content: None }
    }

    /// Takes the cost of the last draw (this frame started now) and moves the scale.
    fn measure(&mut self) {
        let Some((issued, pixels, drawn_scale)) = self.measuring.take() else { return };
        let ms = issued.elapsed().as_secs_f32() * 1e3;
        // A long pause is an idle window (minimised, unfocused), not a frame's cost.
        if ms > 2000.0 || pixels == 0 {
            return;
        }
        if ms > FRAME_BUDGET_MS {
            let fit = drawn_scale * (FRAME_BUDGET_MS / ms).sqrt();
            let stepped = ((fit * 8.0).floor() / 8.0).max(MIN_SCALE);
            if stepped < self.scale {
                self.scale = stepped;
                self.dropped_at = Some(Instant::now());
            }
        } else if ms < 0.8 * FRAME_BUDGET_MS
            && drawn_scale >= self.scale
            && self.dropped_at.is_none_or(|t| t.elapsed() >= STEP_UP_PAUSE)
        {
            self.scale = (self.scale + 0.125).min(1.0);
        }
    }
}

/// What a frame shows apart from its size.
type Content = ([u32; 4], u64, ViewSettings, u64);

/// What a drawn frame depends on: size, view angles, zoom, clip time, tree, the view
/// settings and the cage received.
#[derive(Debug, Clone, Copy, PartialEq)]
struct DrawKey {
    size: (u32, u32),
    angles: [u32; 4],
    model: u64,
    view: ViewSettings,
    cage: u64,
}

impl std::fmt::Debug for Viewport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewport").field("frames", &self.frames).finish_non_exhaustive()
    }
}

/// The view texture's format (the composite reads its bytes as they are), with the sRGB
/// view the renderer draws through.
const TEXTURE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

impl Viewport {
    /// A view on `gpu` (egui's wgpu state; `None` without an adapter).
    pub fn new(gpu: Option<egui_wgpu::RenderState>) -> Viewport {
        let software =
            gpu.as_ref().is_some_and(|g| g.adapter.get_info().device_type == wgpu::DeviceType::Cpu);
        let mut pace = Pace::new();
        if software {
            // The first frames of a software renderer (the first tree's among them) are
            // drawn small at once, not measured first at full size.
            pace.scale = MIN_SCALE;
        }
        Viewport {
            composite: gpu.as_ref().map(Composite::new),
            software,
            gpu,
            renderer: None,
            target: None,
            control: OrbitControl::new(Orbit { azimuth_deg: 25.0, elevation_deg: 15.0 }),
            framed: false,
            playing: true,
            clock: Instant::now(),
            paused_at: 0.0,
            error: None,
            frames: 0,
            model_generation: 0,
            drawn: None,
            view: ViewSettings::default(),
            busy: false,
            full_resolution: false,
            pace,
            skeleton: None,
            cage: Cage::default(),
        }
    }

    /// The adapter's name, for the status bar.
    pub fn adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(|g| {
            let i = g.adapter.get_info();
            format!("{} ({:?})", i.name, i.backend)
        })
    }

    /// Shows a new tree: its model (`renderer`: already uploaded by the worker; `None`:
    /// uploaded here, [`Viewport::set_model`]), its skeleton for the skeleton overlay,
    /// and what its cage is meshed from (a new cage is asked for when the cage is shown
    /// and the skeleton or the meshing settings changed).
    pub fn set_tree(&mut self, tree: &Tree, renderer: Option<Result<Arc<Renderer>, String>>) {
        match renderer {
            Some(r) => self.set_renderer(r),
            None => self.set_model(&tree.model),
        }
        let s = &tree.skeleton;
        let segments = s
            .parent
            .iter()
            .enumerate()
            .filter(|(_, &p)| p != sylva::NO_PARENT)
            .filter_map(|(i, &p)| Some([*s.position.get(p as usize)?, *s.position.get(i)?]))
            .collect();
        self.skeleton = Some(Lines { on_top: true, ..Lines::new(segments, SKELETON_COLOR) });
        let same_cage = self.cage.source.as_ref().is_some_and(|(recipe, skeleton)| {
            [Stage::Generate, Stage::Fit, Stage::Bark].iter().all(|st| st.same_inputs(recipe, &tree.recipe))
                && **skeleton == tree.skeleton
        });
        if !same_cage {
            self.cage.source = Some((tree.recipe.clone(), Arc::new(tree.skeleton.clone())));
            self.cage.wanted = 0;
            self.cage.error = None;
        }
    }

    /// The number of triangles of the cage shown (its faces fan-triangulated), once it
    /// has been meshed.
    pub fn cage_triangles(&self) -> Option<usize> {
        let c = &self.cage;
        c.shown.as_ref().filter(|_| c.wanted != 0 && c.shown_job == c.wanted).map(|(_, n)| *n)
    }

    /// Uploads a new tree's model; the view keeps its angles (the first tree is framed).
    pub fn set_model(&mut self, model: &Model) {
        let Some(gpu) = &self.gpu else { return };
        let r = Renderer::with_device(&gpu.adapter, &gpu.device, &gpu.queue, model)
            .map(Arc::new)
            .map_err(|e| format!("cannot draw this tree: {e}"));
        self.set_renderer(r);
    }

    /// Shows a tree uploaded to the view's device (or the upload's error; the last tree
    /// stays then).
    fn set_renderer(&mut self, renderer: Result<Arc<Renderer>, String>) {
        if self.gpu.is_none() {
            return;
        }
        match renderer {
            Ok(r) => {
                if !self.framed {
                    if let Some((lo, hi)) = r.bounds() {
                        self.control = OrbitControl::new(Orbit::auto(lo, hi));
                        self.framed = true;
                    }
                }
                if self.view.lod.is_some_and(|l| l >= r.level_count()) {
                    self.view.lod = None;
                }
                self.renderer = Some(r);
                self.model_generation += 1;
                self.error = None;
            }
            Err(e) => self.error = Some(e),
        }
    }

    /// Whether the view animates (wind playing on a rigged tree).
    pub fn animating(&self) -> bool {
        self.playing && self.renderer.as_ref().is_some_and(|r| r.animated())
    }

    /// The clip time drawn now, seconds.
    fn time(&mut self) -> f32 {
        let duration = self.renderer.as_ref().map_or(0.0, |r| r.clip_duration());
        if duration <= 0.0 {
            return 0.0;
        }
        if self.playing {
            (self.paused_at + self.clock.elapsed().as_secs_f32()) % duration
        } else {
            self.paused_at % duration
        }
    }

    /// Starts or stops the wind.
    pub fn toggle_play(&mut self) {
        if self.playing {
            self.paused_at += self.clock.elapsed().as_secs_f32();
        } else {
            self.clock = Instant::now();
        }
        self.playing = !self.playing;
    }

    /// Back to the framed view of the current tree.
    pub fn reframe(&mut self) {
        if let Some((lo, hi)) = self.renderer.as_ref().and_then(|r| r.bounds()) {
            self.control = OrbitControl::new(Orbit::auto(lo, hi));
        }
    }

    /// Asks for the cage of the tree shown when the cage is on and none is asked for
    /// yet, and takes a finished one; never waits.
    fn update_cage(&mut self, ctx: &egui::Context) {
        if !self.view.cage {
            return;
        }
        let cage = &mut self.cage;
        if cage.wanted == 0 {
            if let Some((recipe, skeleton)) = &cage.source {
                let worker = cage.worker.get_or_insert_with(|| {
                    let ctx = ctx.clone();
                    CageWorker::new(move || ctx.request_repaint())
                });
                cage.wanted = worker.submit(recipe.clone(), skeleton.clone());
            }
        }
        let Some(worker) = &cage.worker else { return };
        while let Some(outcome) = worker.poll() {
            match outcome {
                CageOutcome::Meshed { job, mesh, .. } if job == cage.wanted => {
                    let triangles =
                        (0..mesh.face_count()).map(|f| mesh.face(f).len().saturating_sub(2)).sum();
                    cage.shown = Some((Lines::mesh_edges(&mesh, CAGE_COLOR), triangles));
                    cage.shown_job = job;
                    cage.generation += 1;
                    cage.error = None;
                }
                CageOutcome::Failed { job, message } if job == cage.wanted => {
                    cage.error = Some(format!("no cage: {message}"));
                }
                _ => {}
            }
        }
    }

    /// The "View" row: ground, wireframe, skeleton and cage toggles and the level of
    /// detail (each control named for accessibility: "Ground", "Wireframe", "Skeleton",
    /// "Cage", "Level of detail").
    pub fn view_controls(&mut self, ui: &mut egui::Ui) {
        let cage = match (&self.cage.error, self.cage_triangles()) {
            (Some(e), _) => e.clone(),
            (None, Some(n)) => format!("cage: {n} triangles"),
            (None, None) => "cage: meshing…".to_string(),
        };
        let levels: Vec<u64> = match &self.renderer {
            Some(r) => (0..r.level_count()).map(|l| r.level_triangles(l)).collect(),
            None => vec![0],
        };
        let v = &mut self.view;
        ui.label("View:");
        ui.checkbox(&mut v.ground, "Ground").on_hover_text("a ground disc with a soft contact shadow");
        ui.checkbox(&mut v.wireframe, "Wireframe").on_hover_text("the triangles' edges");
        ui.checkbox(&mut v.skeleton, "Skeleton").on_hover_text("the skeleton's internodes, on top (at rest)");
        ui.checkbox(&mut v.cage, "Cage")
            .on_hover_text("the mesher's control mesh: the tree meshed with refine.levels = 0 (at rest)");
        if v.cage {
            ui.label(egui::RichText::new(cage).weak());
        }
        let name = |l: Option<usize>| l.map_or("LOD auto".to_string(), |l| format!("LOD {l}"));
        egui::ComboBox::from_id_salt("view lod")
            .selected_text(name(v.lod))
            .show_ui(ui, |ui| {
                ui.selectable_value(&mut v.lod, None, name(None))
                    .on_hover_text("each level by its size on screen");
                for (l, tris) in levels.iter().enumerate() {
                    ui.selectable_value(&mut v.lod, Some(l), name(Some(l)))
                        .on_hover_text(format!("{tris} triangles"));
                }
            })
            .response
            .accessible_name("Level of detail");
    }

    /// Fills `ui` with the view (accessible name "tree view"); returns its response
    /// (drags and scrolls move the camera).
    pub fn show(&mut self, ui: &mut egui::Ui) -> egui::Response {
        let size = ui.available_size().max(egui::vec2(64.0, 64.0));
        let (rect, response) = ui.allocate_exact_size(size, egui::Sense::click_and_drag());
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, "tree view"));
        if response.dragged() {
            let d = response.drag_delta();
            self.control.drag(d.x, d.y);
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                self.control.wheel(scroll / 50.0);
            }
        }
        let painter = ui.painter_at(rect);
        let background = egui::Color32::from_rgb(225, 222, 214);
        if self.gpu.is_none() {
            painter.rect_filled(rect, 0.0, background);
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "no GPU adapter: the tree is grown and can be exported, but not shown",
                egui::FontId::proportional(14.0),
                egui::Color32::DARK_GRAY,
            );
            return response;
        }
        let ppp = ui.ctx().pixels_per_point();
        let w = ((rect.width() * ppp).round() as u32).clamp(1, MAX_SIDE);
        let h = ((rect.height() * ppp).round() as u32).clamp(1, MAX_SIDE);
        self.update_cage(ui.ctx());
        self.pace.measure();
        // The tree's texture covers the view: no background under it (on a software
        // renderer each layer egui paints over the view costs a frame milliseconds).
        match self.draw(w, h, response.dragged()) {
            Ok(Some((bind_group, one_to_one))) => match &self.composite {
                Some(c) => {
                    painter.add(c.paint(rect, bind_group, one_to_one));
                }
                None => {
                    painter.rect_filled(rect, 0.0, background);
                }
            },
            Ok(None) => {
                painter.rect_filled(rect, 0.0, background);
            }
            Err(e) => {
                painter.rect_filled(rect, 0.0, background);
                self.error = Some(e);
            }
        }
        if let Some(e) = &self.error {
            painter.text(
                rect.left_top() + egui::vec2(8.0, 8.0),
                egui::Align2::LEFT_TOP,
                e,
                egui::FontId::proportional(13.0),
                egui::Color32::DARK_RED,
            );
        }
        if self.busy && self.software {
            // The wind holds while a software renderer's tree regrows: each frame would
            // take the cores the worker needs (the next tree comes sooner), and the
            // worker wakes the window when it is done. A frame's cost is measured only
            // when another follows at once.
            self.pace.measuring = None;
        } else if self.animating() || self.pace.measuring.is_some() {
            ui.ctx().request_repaint();
        } else if self.drawn.is_some_and(|d| d.size != (w, h)) {
            // Drawn small while it changed: the full-resolution frame once it is still.
            ui.ctx().request_repaint_after(REFINE_AFTER);
        }
        response
    }

    /// The scale (fraction of each side) frames are drawn at while the view changes.
    pub fn changing_scale(&self) -> f32 {
        self.pace.scale
    }

    /// Draws the tree for a `w × h` view (fewer pixels while it changes: [`Pace`]);
    /// the composite's bind group of the texture to show, stretched over the view, and
    /// whether it has the view's size (drawn a texel per pixel).
    fn draw(&mut self, w: u32, h: u32, orbiting: bool) -> Result<Option<(wgpu::BindGroup, bool)>, String> {
        let full = (w, h);
        let time = self.time();
        let o = self.control.orbit;
        let content: Content = (
            [o.azimuth_deg.to_bits(), o.elevation_deg.to_bits(), self.control.zoom.to_bits(), time.to_bits()],
            self.model_generation,
            self.view,
            self.cage.generation,
        );
        if self.pace.content != Some(content) {
            self.pace.content = Some(content);
            self.pace.changed_at = Instant::now();
        }
        let still = self.full_resolution
            || !orbiting && !self.busy && !self.animating() && self.pace.changed_at.elapsed() >= REFINE_AFTER;
        let scale = if still { 1.0 } else { self.pace.scale };
        let (w, h) = (((w as f32 * scale).round() as u32).max(1), ((h as f32 * scale).round() as u32).max(1));
        let (Some(gpu), Some(renderer), Some(composite)) = (&self.gpu, &self.renderer, &self.composite)
        else {
            return Ok(None);
        };
        if self.target.as_ref().is_none_or(|t| t.size != (w, h)) {
            let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("sylva-edit view"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: TEXTURE_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[VIEW_FORMAT],
            });
            let bind_group = composite.bind(&gpu.device, &texture, VIEW_FORMAT);
            self.target = Some(Target { size: (w, h), texture, bind_group });
        }
        let target = self.target.as_ref().expect("the target was just made");
        let shown = Some((target.bind_group.clone(), (w, h) == full));
        // Nothing moved since the last frame drawn: the texture already shows it (on a
        // software renderer a frame of a big tree costs hundreds of milliseconds).
        let key = DrawKey {
            size: (w, h),
            angles: content.0,
            model: self.model_generation,
            view: self.view,
            cage: self.cage.generation,
        };
        if self.drawn == Some(key) {
            return Ok(shown);
        }
        let mut opts = self.render_options(w, h);
        // A frame drawn smaller while the view changes is drawn without MSAA: on a
        // software renderer 4× samples cost a small frame about three times its price
        // (lavapipe: the aspen at 256×192, ~155 ms against ~50 ms), and the frame is
        // stretched over the view anyway. The still frame at full size has them.
        if (w, h) != full {
            opts.msaa = false;
        }
        let instances = [Mat4::IDENTITY];
        let mut camera = renderer.camera(&opts, &instances);
        self.control.apply(&mut camera);
        let view = target
            .texture
            .create_view(&wgpu::TextureViewDescriptor { format: Some(VIEW_FORMAT), ..Default::default() });
        let issued = Instant::now();
        renderer
            .render_to_view(&camera, &opts, &instances, time, &view, VIEW_FORMAT)
            .map_err(|e| format!("drawing failed: {e}"))?;
        self.drawn = Some(key);
        self.frames += 1;
        self.pace.measuring = Some((issued, w * h, scale));
        Ok(shown)
    }

    /// The renderer's options for a `w × h` frame from the view's angles, with what the
    /// "View" row shows.
    fn render_options(&self, w: u32, h: u32) -> RenderOptions {
        let v = &self.view;
        let mut overlays = Vec::new();
        if let (true, Some((lines, _))) = (v.cage, &self.cage.shown) {
            overlays.push(lines.clone());
        }
        if let (true, Some(lines)) = (v.skeleton, &self.skeleton) {
            overlays.push(lines.clone());
        }
        RenderOptions {
            width: w,
            height: h,
            orbit: Some(self.control.orbit),
            ground: v.ground,
            wireframe: v.wireframe,
            lod: v.lod,
            overlays,
            ..RenderOptions::default()
        }
    }

    /// A picture of the tree from the view's angles (without its zoom), `width × height`
    /// pixels, at the clip time shown, with what the "View" row shows: "Export" to a
    /// `.png`.
    pub fn picture(&mut self, width: u32, height: u32) -> Result<sylva::image::Image, String> {
        let time = self.time();
        let renderer =
            self.renderer.as_ref().ok_or("no tree is shown (no GPU adapter, or nothing grown yet)")?;
        let opts = self.render_options(width, height);
        renderer
            .render(&opts, &[Mat4::IDENTITY], time)
            .map(|r| r.image)
            .map_err(|e| format!("drawing failed: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn frame(pace: &mut Pace, ms: u64, scale: f32) {
        let pixels = (1000.0 * 760.0 * scale * scale) as u32;
        pace.measuring = Some((Instant::now() - Duration::from_millis(ms), pixels, scale));
        pace.measure();
    }

    /// A software renderer's full frame (250 ms) drops the scale to what fits the
    /// budget; cheap frames (a GPU waiting for the display, 17 ms) raise it a step at a
    /// time once the pause after a drop has passed; an idle gap is not a frame's cost.
    #[test]
    fn the_scale_follows_the_measured_cost() {
        let mut pace = Pace::new();
        assert_eq!(pace.scale, 1.0, "nothing measured: full resolution");
        frame(&mut pace, 250, 1.0);
        assert_eq!(pace.scale, 0.25, "sqrt(25 / 250) = 0.32, stepped down to 2/8");
        frame(&mut pace, 17, 0.25);
        assert_eq!(pace.scale, 0.25, "no rise right after a drop");
        frame(&mut pace, 5000, 0.25);
        assert_eq!(pace.scale, 0.25, "an idle gap changes nothing");
        pace.dropped_at = Some(Instant::now() - STEP_UP_PAUSE);
        for _ in 0..6 {
            let s = pace.scale;
            frame(&mut pace, 17, s);
        }
        assert_eq!(pace.scale, 1.0, "six steps of 1/8 back to full");
        frame(&mut pace, 40, 1.0);
        assert_eq!(pace.scale, 0.75, "sqrt(25 / 40) = 0.79: one step down");
        frame(&mut pace, 17, 1.0);
        assert_eq!(
            pace.scale, 0.75,
            "a cheap full-resolution refinement frame does not raise it during the pause"
        );
    }
}
