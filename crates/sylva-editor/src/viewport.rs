//! The 3D view: sylva-gpu's renderer (textures, alpha-cut leaves, MSAA, the wind clip)
//! drawing the current tree into an offscreen texture on egui's own wgpu device, shown
//! as an image in the central panel. Drag to orbit, scroll to zoom; wind plays from the
//! model's clip while "play" is on.
//!
//! The texture is `Rgba8Unorm` (what egui-wgpu samples for a native texture) viewed as
//! `Rgba8UnormSrgb` by the renderer, so the colours are encoded once. Without a wgpu
//! device (no adapter) the view says so and the rest of the editor works.

use egui_wgpu::wgpu;
use glam::Mat4;
use std::time::Instant;
use sylva::Model;
use sylva_gpu::render::window::OrbitControl;
use sylva_gpu::render::{Orbit, RenderOptions, Renderer};

/// The largest side of the view's texture, pixels.
pub const MAX_SIDE: u32 = 4096;

const VIEW_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// The offscreen target and its egui texture id.
struct Target {
    size: (u32, u32),
    texture: wgpu::Texture,
    id: egui::TextureId,
}

/// The view of the tree.
pub struct Viewport {
    gpu: Option<egui_wgpu::RenderState>,
    renderer: Option<Renderer>,
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
}

/// What a drawn frame depends on: size, view angles, zoom, clip time and tree.
type DrawKey = (u32, u32, [u32; 4], u64);

impl std::fmt::Debug for Viewport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewport").field("frames", &self.frames).finish_non_exhaustive()
    }
}

/// egui-wgpu's texture format for native textures, with the sRGB view the renderer draws.
const TEXTURE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

impl Viewport {
    /// A view on `gpu` (egui's wgpu state; `None` without an adapter).
    pub fn new(gpu: Option<egui_wgpu::RenderState>) -> Viewport {
        Viewport {
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
        }
    }

    /// The adapter's name, for the status bar.
    pub fn adapter(&self) -> Option<String> {
        self.gpu.as_ref().map(|g| {
            let i = g.adapter.get_info();
            format!("{} ({:?})", i.name, i.backend)
        })
    }

    /// Uploads a new tree; the view keeps its angles (the first tree is framed).
    pub fn set_model(&mut self, model: &Model) {
        let Some(gpu) = &self.gpu else { return };
        match Renderer::with_device(&gpu.adapter, &gpu.device, &gpu.queue, model) {
            Ok(r) => {
                if !self.framed {
                    if let Some((lo, hi)) = r.bounds() {
                        self.control = OrbitControl::new(Orbit::auto(lo, hi));
                        self.framed = true;
                    }
                }
                self.renderer = Some(r);
                self.model_generation += 1;
                self.error = None;
            }
            Err(e) => self.error = Some(format!("cannot draw this tree: {e}")),
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

    /// Fills `ui` with the view; returns its response (drags and scrolls move the camera).
    pub fn show(&mut self, ui: &mut egui::Ui) -> egui::Response {
        let size = ui.available_size().max(egui::vec2(64.0, 64.0));
        let (rect, response) = ui.allocate_exact_size(size, egui::Sense::click_and_drag());
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
        painter.rect_filled(rect, 0.0, egui::Color32::from_rgb(225, 222, 214));
        if self.gpu.is_none() {
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
        match self.draw(w, h) {
            Ok(Some(id)) => {
                let uv = egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
                painter.image(id, rect, uv, egui::Color32::WHITE);
            }
            Ok(None) => {}
            Err(e) => self.error = Some(e),
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
        if self.animating() {
            ui.ctx().request_repaint();
        }
        response
    }

    /// Draws the tree into the `w × h` target; the egui texture to show.
    fn draw(&mut self, w: u32, h: u32) -> Result<Option<egui::TextureId>, String> {
        let time = self.time();
        let (Some(gpu), Some(renderer)) = (&self.gpu, &self.renderer) else { return Ok(None) };
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
            let view = texture.create_view(&Default::default());
            let mut egui_renderer = gpu.renderer.write();
            let id = match &self.target {
                Some(t) => {
                    egui_renderer.update_egui_texture_from_wgpu_texture(
                        &gpu.device,
                        &view,
                        wgpu::FilterMode::Linear,
                        t.id,
                    );
                    t.id
                }
                None => egui_renderer.register_native_texture(&gpu.device, &view, wgpu::FilterMode::Linear),
            };
            self.target = Some(Target { size: (w, h), texture, id });
        }
        let target = self.target.as_ref().expect("the target was just made");
        // Nothing moved since the last frame drawn: the texture already shows it (on a
        // software renderer a frame of a big tree costs hundreds of milliseconds).
        let o = self.control.orbit;
        let key = (
            w,
            h,
            [o.azimuth_deg.to_bits(), o.elevation_deg.to_bits(), self.control.zoom.to_bits(), time.to_bits()],
            self.model_generation,
        );
        if self.drawn == Some(key) {
            return Ok(Some(target.id));
        }
        let opts = RenderOptions {
            width: w,
            height: h,
            orbit: Some(self.control.orbit),
            ..RenderOptions::default()
        };
        let instances = [Mat4::IDENTITY];
        let mut camera = renderer.camera(&opts, &instances);
        self.control.apply(&mut camera);
        let view = target
            .texture
            .create_view(&wgpu::TextureViewDescriptor { format: Some(VIEW_FORMAT), ..Default::default() });
        renderer
            .render_to_view(&camera, &opts, &instances, time, &view, VIEW_FORMAT)
            .map_err(|e| format!("drawing failed: {e}"))?;
        self.drawn = Some(key);
        self.frames += 1;
        Ok(Some(target.id))
    }

    /// A picture of the tree from the view's angles (without its zoom), `width × height`
    /// pixels, at the clip time shown: "Export" to a `.png`.
    pub fn picture(&mut self, width: u32, height: u32) -> Result<sylva::image::Image, String> {
        let time = self.time();
        let renderer =
            self.renderer.as_ref().ok_or("no tree is shown (no GPU adapter, or nothing grown yet)")?;
        let opts =
            RenderOptions { width, height, orbit: Some(self.control.orbit), ..RenderOptions::default() };
        renderer
            .render(&opts, &[Mat4::IDENTITY], time)
            .map(|r| r.image)
            .map_err(|e| format!("drawing failed: {e}"))
    }
}
