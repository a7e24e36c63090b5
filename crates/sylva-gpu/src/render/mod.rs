//! The GPU renderer (issue 25 item 4; Skjermo2008 §4, Skjermo2008-spec §10; McLoughlin2021 §4.2 for the
//! multi-tree slowdown it answers): draws an engine [`Model`] offscreen into an RGBA
//! image.
//!
//! ```text
//!  Model ──► mesh::mesh_data (per part, per LOD level) ──► vertex/index buffers
//!        ──► materials (base colour, colour map, alpha cut) ──► bind groups
//!  per frame: Camera (orbit, fitted like the CPU preview) ──► Frame uniform
//!             clip.pose(t) × inverse binds ──► joint matrices (storage buffer)
//!             instances ──► forest::choose_levels ──► one instance buffer, bucketed by level
//!  one pass: background gradient, then per (level, part, material) one instanced draw
//!             ──► MSAA 4× colour + depth ──► resolve (sRGB) ──► readback
//! ```
//!
//! - **Target**: `Rgba8UnormSrgb` colour with 4× MSAA where the adapter allows it
//!   (resolved into a single-sample texture that is read back), `Depth32Float` depth.
//! - **Shading**: the CPU preview's: Lambert from a key light at the upper left of the
//!   camera (`light_color` 0.78) plus a hemispherical sky (0.42) / ground (0.20) ambient
//!   by the normal's height, two-sided, no back-face culling. Colour maps replace the
//!   base colour where a part has UVs; alpha-cut materials (leaf cards, the impostor)
//!   are drawn by a second pipeline whose UVs are interpolated per sample, so the
//!   cut-off is tested per MSAA sample (as the CPU preview tests each supersample) and
//!   leaf outlines get partial coverage. Colour maps are sampled bilinearly without
//!   mipmaps.
//! - **Wind**: where the model has a rig and a clip, the clip is evaluated on the CPU for
//!   time `t` (the same joint matrices as [`sylva::wind::posed`]) and the vertex shader
//!   blends them by each vertex's `JOINTS_0` / `WEIGHTS_0`.
//! - **Instancing**: every tree is an instance transform; per frame each instance takes a
//!   level of detail by its projected size ([`forest::choose_levels`]); the model's LOD
//!   chain (its last level may be the impostor's crossed billboards) is drawn with one
//!   draw per (level, part, material) over all the instances of that level — never one
//!   draw per tree or per branch.
//!
//! - **For a viewer** (issue 41 item 2; all off by default, so a plain render is
//!   unchanged; [`overlay`]): a ground disc with a contact shadow under each instance,
//!   the wireframe (each part's unique triangle edges, a line-list index buffer built on
//!   the first wireframe frame, drawn depth-tested over the shaded mesh — not
//!   `POLYGON_MODE_LINE`, which lavapipe and others lack), line overlays (depth-tested
//!   or on top, [`Lines`]), and a fixed level of detail instead of the choice by
//!   distance ([`RenderOptions::lod`]).
//!
//! - **Window** (cargo feature `window`): `render::window` draws the same pass into a
//!   winit window's surface through [`Renderer::render_to_view`], resolving the MSAA
//!   colour into the surface texture (docs/render.md, "Window").
//!
//! [`Frame`] is the camera and light uniform at `@group(0) @binding(0)` shared with the
//! branch deformer's renderer.

pub mod camera;
pub mod forest;
pub mod mesh;
pub mod overlay;
#[cfg(feature = "window")]
pub mod window;

pub use camera::{Camera, Orbit};
pub use overlay::Lines;

use crate::gpu::{begin_colour_depth_pass, read_texture, texture_2d, Gpu, GpuError};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};
use std::sync::{Arc, Mutex, OnceLock};
use sylva::model::Model;
use sylva::preview::Image;
pub use sylva::preview::{iou, silhouette};
use wgpu::util::DeviceExt;

/// The camera and light uniform at `@group(0) @binding(0)` of every sylva render
/// pipeline (WGSL `struct Frame`, 160 bytes).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Frame {
    /// World → clip (column-major).
    pub view_proj: [[f32; 4]; 4],
    /// Eye position (w = 1).
    pub eye: [f32; 4],
    /// Unit direction towards the key light (w = 0).
    pub light_dir: [f32; 4],
    /// Linear colour of the key light.
    pub light_color: [f32; 4],
    /// Linear ambient colour for a normal pointing up.
    pub sky: [f32; 4],
    /// Linear ambient colour for a normal pointing down.
    pub ground: [f32; 4],
    /// x: time (s), y: viewport height (px), z: tan(fov / 2), w: 0.
    pub params: [f32; 4],
}

impl Frame {
    /// The frame of `camera` at time `time`, lit as the CPU preview lights: a key light
    /// from the camera's upper left, in front of the model.
    pub fn new(camera: &Camera, time: f32) -> Frame {
        let light = (camera.up * 0.65 - camera.right * 0.45 - camera.fwd * 0.6).normalize();
        Frame {
            view_proj: camera.view_proj().to_cols_array_2d(),
            eye: camera.eye.extend(1.0).to_array(),
            light_dir: light.extend(0.0).to_array(),
            light_color: [0.78, 0.78, 0.78, 1.0],
            sky: [0.42, 0.42, 0.42, 1.0],
            ground: [0.20, 0.20, 0.20, 1.0],
            params: [time, camera.height as f32, camera.tan_half_fov(), 0.0],
        }
    }
}

/// The WGSL of [`Frame`] bound at group(0) binding(0), prepended to the mesh shader and
/// the branch deformer's (one declaration for both pipelines, which share the uniform).
pub(crate) const FRAME_WGSL: &str = include_str!("frame.wgsl");

/// Material uniform of `mesh.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct MaterialUniform {
    base_color: [f32; 4],
    params: [f32; 4],
}

/// Background uniform of `mesh.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct BackgroundUniform {
    top: [f32; 4],
    bottom: [f32; 4],
    size: [f32; 4],
}

/// Largest accepted image width or height (the CPU preview's limit).
pub const MAX_SIZE: u32 = sylva::preview::MAX_SIZE;

const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// What to draw and how: image size, view, anti-aliasing and background; for a viewer,
/// the ground, the wireframe, a fixed level of detail and line overlays (all off by
/// default).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels, `1..=8192` (and the adapter's texture limit).
    pub width: u32,
    /// Image height in pixels, `1..=8192`.
    pub height: u32,
    /// View direction; `None` takes the CPU preview's choice ([`Orbit::auto`]).
    pub orbit: Option<Orbit>,
    /// Vertical field of view used to place the eye, degrees `1..=120` (default 30).
    pub fov_deg: f32,
    /// 4× multisampling where the adapter supports it (default on).
    pub msaa: bool,
    /// Background colour (sRGB) at the bottom of the image.
    pub background: [u8; 3],
    /// Background colour (sRGB) at the top of the image.
    pub background_top: [u8; 3],
    /// Box to frame (fitted by its corners); `None` frames one tree by its vertices as
    /// the CPU preview does, or a forest by its instances' boxes.
    pub frame: Option<(Vec3, Vec3)>,
    /// A ground disc with a soft contact shadow under each tree (default off;
    /// [`overlay`]).
    pub ground: bool,
    /// The triangles' edges drawn over the shaded trees (default off).
    pub wireframe: bool,
    /// Draw every tree at this level of detail, `0..`[`Renderer::level_count`]; `None`
    /// (default) chooses each tree's level by its size on screen
    /// ([`forest::choose_levels`]).
    pub lod: Option<usize>,
    /// Line segments drawn over the trees (world space; default none).
    pub overlays: Vec<Lines>,
}

impl Default for RenderOptions {
    /// 1024², the preview's view and background, MSAA on.
    fn default() -> Self {
        let p = sylva::preview::PreviewOptions::default();
        RenderOptions {
            width: 1024,
            height: 1024,
            orbit: None,
            fov_deg: p.fov_deg,
            msaa: true,
            background: p.background,
            background_top: p.background_top,
            frame: None,
            ground: false,
            wireframe: false,
            lod: None,
            overlays: Vec::new(),
        }
    }
}

/// What one render did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    /// Draw calls issued for the trees (the background's excluded).
    pub draw_calls: u32,
    /// Instances drawn at each level of detail (LOD0 first).
    pub instances_per_level: Vec<u32>,
    /// Triangles submitted over all instances.
    pub triangles: u64,
    /// Samples per pixel (4 with MSAA, else 1).
    pub samples: u32,
    /// Line segments drawn over all instances: the wireframe's edges and the overlays'.
    pub lines: u64,
}

/// A rendered picture and what it took.
#[derive(Debug, Clone, PartialEq)]
pub struct Rendered {
    /// The picture, RGBA rows top to bottom (alpha 255).
    pub image: Image,
    /// Draw statistics.
    pub stats: Stats,
    /// The camera used.
    pub camera: Camera,
}

/// One part's buffers and its materials' bind groups.
#[derive(Debug)]
struct GpuPart {
    /// The uploaded streams, shared with the next renderer when its part is the same
    /// ([`Renderer::with_device_reusing`]).
    geometry: Arc<PartGeometry>,
    materials: Vec<wgpu::BindGroup>,
    /// Per material: whether it is alpha-cut (drawn by the per-sample pipeline).
    cut: Vec<bool>,
}

/// A part's streams on the GPU and what the wireframe needs, keyed by the part's content.
#[derive(Debug)]
struct PartGeometry {
    /// [`part_key`] of the part they were made from.
    key: u128,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    groups: Vec<mesh::Group>,
    /// Triangle indices in `indices`.
    index_count: u32,
    /// The vertices' positions and the triangles, kept for the wireframe's edges.
    wire_source: (Vec<[f32; 3]>, Vec<u32>),
    /// The wireframe's line-list indices and their count, built on first use.
    wire: OnceLock<(wgpu::Buffer, u32)>,
}

/// A 128-bit content key (two multiply-rotate lanes, FxHash-like): fast enough to run
/// over a whole tree on every replacement, and only ever compared with the previous
/// tree's keys on the same device, to skip uploading what did not change. Not a
/// cryptographic hash.
struct ContentKey(u64, u64);

impl ContentKey {
    fn new() -> ContentKey {
        ContentKey(0, 0x2545_f491_4f6c_dd1d)
    }

    fn word(&mut self, w: u64) {
        self.0 = (self.0.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95);
        self.1 = (self.1.rotate_left(7) ^ w).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    /// A length, then the bytes eight at a time.
    fn bytes(&mut self, bytes: &[u8]) {
        self.word(bytes.len() as u64);
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            self.word(u64::from_le_bytes(w.try_into().expect("8 bytes")));
        }
        let mut tail = [0u8; 8];
        tail[..words.remainder().len()].copy_from_slice(words.remainder());
        self.word(u64::from_le_bytes(tail));
    }

    /// `len`, then the 32-bit values two at a time.
    fn u32s(&mut self, len: usize, values: impl Iterator<Item = u32>) {
        self.word(len as u64);
        let mut pending: Option<u32> = None;
        for v in values {
            match pending.take() {
                Some(lo) => self.word(u64::from(lo) | (u64::from(v) << 32)),
                None => pending = Some(v),
            }
        }
        if let Some(lo) = pending {
            self.word(u64::from(lo));
        }
    }

    fn finish(&self) -> u128 {
        (u128::from(self.0) << 64) | u128::from(self.1)
    }
}

/// The content key of what a part's streams are made from: its mesh (positions, faces,
/// normals, UVs), skin and per-face materials.
fn part_key(part: &sylva::model::Part) -> u128 {
    let m = &part.mesh;
    let mut k = ContentKey::new();
    k.u32s(m.positions.len(), m.positions.iter().flat_map(|p| p.to_array().map(f32::to_bits)));
    k.u32s(m.face_offsets.len(), m.face_offsets.iter().copied());
    k.u32s(m.face_indices.len(), m.face_indices.iter().copied());
    match &m.normals {
        Some(n) => {
            k.u32s(n.values.len(), n.values.iter().flat_map(|v| v.to_array().map(f32::to_bits)));
            k.u32s(n.indices.len(), n.indices.iter().copied());
        }
        None => k.word(u64::MAX),
    }
    match &m.uvs {
        Some(u) => {
            k.u32s(u.values.len(), u.values.iter().flat_map(|v| v.to_array().map(f32::to_bits)));
            k.u32s(u.indices.len(), u.indices.iter().copied());
        }
        None => k.word(u64::MAX - 1),
    }
    match &part.skin {
        Some(s) => {
            k.bytes(bytemuck::cast_slice(&s.joints));
            k.bytes(bytemuck::cast_slice(&s.weights));
        }
        None => k.word(u64::MAX - 2),
    }
    k.u32s(part.face_materials.len(), part.face_materials.iter().copied());
    k.word(part.extra_materials.len() as u64);
    k.finish()
}

/// The content key of an image (size, channels, pixels).
fn image_key(image: &Image) -> u128 {
    let mut k = ContentKey::new();
    k.word(u64::from(image.width) | (u64::from(image.height) << 32));
    k.word(u64::from(image.channels));
    k.bytes(&image.data);
    k.finish()
}

/// One level of detail.
#[derive(Debug)]
struct Level {
    coverage: f32,
    parts: Vec<GpuPart>,
    triangles: u64,
}

/// Render targets of one size and sample count, kept between frames.
#[derive(Debug)]
struct Targets {
    key: (u32, u32, u32),
    color: wgpu::TextureView,
    resolve: Option<(wgpu::Texture, wgpu::TextureView)>,
    single: Option<wgpu::Texture>,
    depth: wgpu::TextureView,
}

/// Where one pass draws: the colour attachment (multisampled when `resolve` is set),
/// the resolve target, the depth attachment, their format and sample count.
struct Target<'a> {
    format: wgpu::TextureFormat,
    samples: u32,
    color: &'a wgpu::TextureView,
    resolve: Option<&'a wgpu::TextureView>,
    depth: &'a wgpu::TextureView,
}

/// The render pipelines of one sample count and colour format.
#[derive(Debug, Clone)]
struct Pipelines {
    /// Opaque materials, shaded per pixel.
    mesh: wgpu::RenderPipeline,
    /// Alpha-cut materials, shaded and cut per sample.
    cut: wgpu::RenderPipeline,
    /// The background gradient.
    background: wgpu::RenderPipeline,
    /// The ground disc.
    ground: wgpu::RenderPipeline,
    /// The contact shadow, darkening the ground.
    shadow: wgpu::RenderPipeline,
    /// The wireframe's edges.
    wire: wgpu::RenderPipeline,
    /// Depth-tested line overlays.
    lines: wgpu::RenderPipeline,
    /// Line overlays on top of everything.
    lines_top: wgpu::RenderPipeline,
}

/// Attachments for drawing into a caller's texture view ([`Renderer::render_to_view`]):
/// the MSAA colour texture (none at one sample) and the depth buffer.
#[derive(Debug)]
struct ViewTargets {
    key: (u32, u32, u32, wgpu::TextureFormat),
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// The adapter, device and queue a [`Renderer`] draws with: a [`Gpu`]'s, or those of a
/// device opened for a window's surface ([`Renderer::with_device`]).
#[derive(Debug, Clone)]
struct Ctx {
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
}

impl Ctx {
    /// A buffer holding `bytes`, padded to at least 16 bytes.
    fn buffer(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let size = (bytes.len() as u64).max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT) as usize;
        let mut contents = bytes.to_vec();
        contents.resize(size, 0);
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &contents,
            usage,
        })
    }

    fn uniform_buffer<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST;
        self.buffer(label, bytemuck::cast_slice(data), usage)
    }

    fn storage_buffer<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        self.buffer(label, bytemuck::cast_slice(data), usage)
    }

    fn bind_group_layout(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> wgpu::BindGroupLayout {
        self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    }

    fn bind_buffers(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        crate::gpu::bind_whole_buffers(&self.device, label, layout, buffers)
    }

    /// Whether `format` (and the depth format) take 4× multisampling.
    fn msaa_ok(&self, format: wgpu::TextureFormat) -> bool {
        [format, DEPTH_FORMAT]
            .iter()
            .all(|&f| self.adapter.get_texture_format_features(f).flags.sample_count_supported(4))
    }
}

/// A model uploaded to the GPU, ready to draw any number of times (see the
/// [module docs](self)).
#[derive(Debug)]
pub struct Renderer {
    gpu: Ctx,
    levels: Vec<Level>,
    rig: Option<(sylva::model::Rig, sylva::model::Clip)>,
    bounds: Option<(Vec3, Vec3)>,
    fit_points: Vec<Vec3>,
    frame_buffer: wgpu::Buffer,
    joint_buffer: wgpu::Buffer,
    background_buffer: wgpu::Buffer,
    group0: wgpu::BindGroup,
    shaders: Arc<Shaders>,
    /// The model's images on the GPU with their [`image_key`]s, for the next renderer.
    textures: Vec<(u128, wgpu::TextureView)>,
    reuse: Reuse,
    targets: Mutex<Option<Targets>>,
    view_targets: Mutex<Option<ViewTargets>>,
    msaa_ok: bool,
}

/// What a renderer took from the one it replaced ([`Renderer::with_device_reusing`])
/// and what it uploaded.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reuse {
    /// Parts (of every level) whose buffers were the previous renderer's.
    pub parts_reused: usize,
    /// Parts uploaded.
    pub parts_uploaded: usize,
    /// Images that were the previous renderer's textures.
    pub textures_reused: usize,
    /// Images uploaded.
    pub textures_uploaded: usize,
}

/// What every tree drawn on one device shares: the bind group and pipeline layouts,
/// the shader and the pipelines compiled from it (per sample count and colour format).
/// A renderer made with [`Renderer::with_device_sharing`] takes them from the previous
/// one, so a new tree draws without compiling its pipelines again (on a software
/// renderer such as lavapipe, an LLVM compile of each shader: tens of milliseconds).
#[derive(Debug)]
struct Shaders {
    device: wgpu::Device,
    frame_layout: wgpu::BindGroupLayout,
    material_layout: wgpu::BindGroupLayout,
    layout: wgpu::PipelineLayout,
    background_layout: wgpu::PipelineLayout,
    shader: wgpu::ShaderModule,
    pipelines: Mutex<Vec<((u32, wgpu::TextureFormat), Pipelines)>>,
}

impl Shaders {
    fn new(gpu: &Ctx) -> Shaders {
        let device = &gpu.device;
        let visible = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let buffer_entry = |binding, ty| crate::gpu::buffer_entry(binding, visible, ty, false);
        let frame_layout = gpu.bind_group_layout(
            "sylva-gpu render frame",
            &[
                buffer_entry(0, wgpu::BufferBindingType::Uniform),
                buffer_entry(1, wgpu::BufferBindingType::Storage { read_only: true }),
                buffer_entry(2, wgpu::BufferBindingType::Uniform),
                buffer_entry(3, wgpu::BufferBindingType::Uniform),
            ],
        );
        let [map, map_sampler] = crate::gpu::texture_sampler_entries(1, wgpu::ShaderStages::FRAGMENT);
        let material_layout = gpu.bind_group_layout(
            "sylva-gpu render material",
            &[buffer_entry(0, wgpu::BufferBindingType::Uniform), map, map_sampler],
        );
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sylva-gpu render"),
            bind_group_layouts: &[Some(&frame_layout), Some(&material_layout)],
            immediate_size: 0,
        });
        let background_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sylva-gpu background"),
            bind_group_layouts: &[Some(&frame_layout)],
            immediate_size: 0,
        });
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sylva-gpu mesh.wgsl"),
            source: wgpu::ShaderSource::Wgsl(format!("{FRAME_WGSL}\n{}", include_str!("mesh.wgsl")).into()),
        });
        Shaders {
            device: device.clone(),
            frame_layout,
            material_layout,
            layout,
            background_layout,
            shader,
            pipelines: Mutex::new(Vec::new()),
        }
    }
}

/// The layouts, shader and compiled pipelines of a renderer, handed to the next one on
/// the same device ([`Renderer::shader_cache`], [`Renderer::with_device_sharing`]).
#[derive(Debug, Clone)]
pub struct ShaderCache(Arc<Shaders>);

fn invalid(why: impl Into<String>) -> GpuError {
    GpuError::Invalid(why.into())
}

impl Renderer {
    /// Uploads `model` (LOD0 with its instanced organs flattened, then every
    /// [`Model::lods`] level) with its textures and rig.
    ///
    /// Errors: a part whose mesh fails validation, a texture over the adapter's limits,
    /// or a model with nothing to draw.
    pub fn new(gpu: &Gpu, model: &Model) -> Result<Renderer, GpuError> {
        Renderer::with_device(&gpu.adapter, &gpu.device, &gpu.queue, model)
    }

    /// [`Renderer::new`] on a device the caller opened (e.g. one compatible with a
    /// window's surface, as `render::window` opens); `device` must come from `adapter`.
    pub fn with_device(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
    ) -> Result<Renderer, GpuError> {
        Renderer::with_device_sharing(adapter, device, queue, model, None)
    }

    /// [`Renderer::with_device`] that takes the layouts, shader and compiled pipelines
    /// of `cache` (a previous renderer's [`Renderer::shader_cache`]) when it is of the
    /// same device (an editor replacing its tree), instead of making and compiling them
    /// again.
    pub fn with_device_sharing(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        cache: Option<&ShaderCache>,
    ) -> Result<Renderer, GpuError> {
        Renderer::build(adapter, device, queue, model, cache.map(|c| &c.0), None)
    }

    /// [`Renderer::with_device_sharing`] that also keeps what `previous` (a renderer of
    /// the tree this one replaces, on the same device) already uploaded and `model`
    /// still holds: each part's vertex and index buffers whose mesh, skin and face
    /// materials are the same (compared by a 128-bit content key), and each image with
    /// the same pixels. After a leaf or material change an editor then uploads only the
    /// leaves, or nothing but the material uniforms. The result draws exactly as a
    /// renderer made from scratch. A `previous` of another device is ignored.
    pub fn with_device_reusing(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        previous: Option<&Renderer>,
    ) -> Result<Renderer, GpuError> {
        let previous = previous.filter(|p| p.gpu.device == *device);
        Renderer::build(adapter, device, queue, model, previous.map(|p| &p.shaders), previous)
    }

    fn build(
        adapter: &wgpu::Adapter,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        model: &Model,
        shaders: Option<&Arc<Shaders>>,
        previous: Option<&Renderer>,
    ) -> Result<Renderer, GpuError> {
        let gpu = &Ctx { adapter: adapter.clone(), device: device.clone(), queue: queue.clone() };
        let shaders = match shaders {
            Some(c) if c.device == *device => c.clone(),
            _ => Arc::new(Shaders::new(gpu)),
        };
        let old_textures: std::collections::HashMap<u128, &wgpu::TextureView> =
            previous.map(|p| p.textures.iter().map(|(k, v)| (*k, v)).collect()).unwrap_or_default();
        let old_parts: std::collections::HashMap<u128, &Arc<PartGeometry>> = previous
            .map(|p| p.levels.iter().flat_map(|l| &l.parts).map(|g| (g.geometry.key, &g.geometry)).collect())
            .unwrap_or_default();
        let (frame_layout, material_layout) = (&shaders.frame_layout, &shaders.material_layout);
        let flat = model.flattened();
        let device = &gpu.device;
        let limit = gpu.device.limits().max_texture_dimension_2d;

        // Textures: every model image as sRGB RGBA, plus a white one for plain materials.
        let mut views = Vec::with_capacity(flat.images.len());
        let mut textures = Vec::with_capacity(flat.images.len());
        let mut reuse = Reuse::default();
        for im in &flat.images {
            let i = &im.image;
            if i.width == 0 || i.height == 0 || i.width > limit || i.height > limit {
                return Err(invalid(format!(
                    "texture `{}` is {}×{}; the adapter takes 1..={limit}",
                    im.name, i.width, i.height
                )));
            }
            i.check(&format!("texture `{}`", im.name)).map_err(|e| invalid(e.to_string()))?;
            let key = image_key(i);
            let view = match old_textures.get(&key) {
                Some(v) => {
                    reuse.textures_reused += 1;
                    (*v).clone()
                }
                None => {
                    reuse.textures_uploaded += 1;
                    texture(gpu, &im.name, i)
                }
            };
            textures.push((key, view.clone()));
            views.push((view, im.repeat));
        }
        let white = texture(gpu, "white", &Image::from_rgba(1, 1, vec![255; 4]));
        let sampler = |mode| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("sylva-gpu render sampler"),
                address_mode_u: mode,
                address_mode_v: mode,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            })
        };
        let repeat = sampler(wgpu::AddressMode::Repeat);
        let clamp = sampler(wgpu::AddressMode::ClampToEdge);

        // Levels: LOD0 (the flattened parts), then the model's LOD chain.
        let mut sources: Vec<(f32, &[sylva::model::Part])> = vec![(0.0, &flat.parts[..])];
        if !flat.lods.is_empty() {
            sources[0].0 = flat.lod0_coverage;
            sources.extend(flat.lods.iter().map(|l| (l.screen_coverage, &l.parts[..])));
        }
        let mut levels = Vec::with_capacity(sources.len());
        for (coverage, parts) in sources {
            let mut level = Level { coverage, parts: Vec::new(), triangles: 0 };
            for part in parts {
                let key = part_key(part);
                let geometry = match old_parts.get(&key) {
                    Some(g) => {
                        reuse.parts_reused += 1;
                        Arc::clone(g)
                    }
                    None => {
                        reuse.parts_uploaded += 1;
                        part.mesh
                            .validate()
                            .map_err(|why| invalid(format!("part `{}`: {why}", part.name)))?;
                        let data = mesh::mesh_data(part);
                        if data.indices.is_empty() {
                            continue;
                        }
                        Arc::new(upload_part(gpu, &part.name, key, data)?)
                    }
                };
                let has_uv =
                    part.mesh.uvs.as_ref().is_some_and(|u| u.indices.len() == part.mesh.face_indices.len());
                let cut = mesh::part_materials(part)
                    .iter()
                    .map(|m| {
                        let map = m.maps.base_color.filter(|_| has_uv).and_then(|i| views.get(i as usize));
                        map.is_some() && m.alpha_cutoff.is_some()
                    })
                    .collect();
                let materials = mesh::part_materials(part)
                    .into_iter()
                    .map(|m| {
                        let map = m.maps.base_color.filter(|_| has_uv).and_then(|i| views.get(i as usize));
                        let ch = |x: f32| if x.is_finite() { x.clamp(0.0, 1.0) } else { 0.0 };
                        let c = m.base_color;
                        let uniform = MaterialUniform {
                            base_color: [ch(c[0]), ch(c[1]), ch(c[2]), 1.0],
                            params: [
                                if map.is_some() { 1.0 } else { 0.0 },
                                m.alpha_cutoff.filter(|_| map.is_some()).unwrap_or(-1.0),
                                0.0,
                                0.0,
                            ],
                        };
                        let buffer = gpu.uniform_buffer("sylva-gpu render material", &[uniform]);
                        let (view, sampler) = match map {
                            Some((v, true)) => (v, &repeat),
                            Some((v, false)) => (v, &clamp),
                            None => (&white, &clamp),
                        };
                        device.create_bind_group(&wgpu::BindGroupDescriptor {
                            label: Some("sylva-gpu render material"),
                            layout: material_layout,
                            entries: &[
                                wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() },
                                wgpu::BindGroupEntry {
                                    binding: 1,
                                    resource: wgpu::BindingResource::TextureView(view),
                                },
                                wgpu::BindGroupEntry {
                                    binding: 2,
                                    resource: wgpu::BindingResource::Sampler(sampler),
                                },
                            ],
                        })
                    })
                    .collect();
                level.triangles += u64::from(geometry.index_count) / 3;
                level.parts.push(GpuPart { geometry, materials, cut });
            }
            levels.push(level);
        }
        if levels.iter().all(|l| l.parts.is_empty()) {
            return Err(invalid("the model has no triangles to draw"));
        }

        let rig = match (&flat.rig, &flat.clip) {
            (Some(r), Some(c)) if !r.joints.is_empty() => Some((r.clone(), c.clone())),
            _ => None,
        };
        let joints = rig.as_ref().map_or(1, |(r, _)| r.joints.len());
        let identity = vec![Mat4::IDENTITY.to_cols_array(); joints];
        let joint_buffer = gpu.storage_buffer("sylva-gpu render joints", &identity);
        let frame_buffer = gpu.uniform_buffer("sylva-gpu render frame", &[Frame::zeroed()]);
        let background_buffer =
            gpu.uniform_buffer("sylva-gpu render background", &[BackgroundUniform::zeroed()]);
        let fit_points: Vec<Vec3> =
            flat.parts.iter().flat_map(|p| p.mesh.positions.iter().copied()).collect();
        let bounds = flat.bounds();
        let (lo, hi) = bounds.unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let ground_buffer =
            gpu.uniform_buffer("sylva-gpu render ground", &[overlay::ground(lo, hi, &fit_points)]);
        let group0 = gpu.bind_buffers(
            "sylva-gpu render frame",
            frame_layout,
            &[&frame_buffer, &joint_buffer, &background_buffer, &ground_buffer],
        );
        let msaa_ok = gpu.msaa_ok(COLOR_FORMAT);
        Ok(Renderer {
            gpu: gpu.clone(),
            levels,
            rig,
            bounds,
            fit_points,
            frame_buffer,
            joint_buffer,
            background_buffer,
            group0,
            shaders,
            textures,
            reuse,
            targets: Mutex::new(None),
            view_targets: Mutex::new(None),
            msaa_ok,
        })
    }

    /// What this renderer reused from the one it replaced and what it uploaded.
    pub fn reuse(&self) -> Reuse {
        self.reuse
    }

    /// This renderer's layouts, shader and compiled pipelines, for the next renderer on
    /// the same device ([`Renderer::with_device_sharing`]).
    pub fn shader_cache(&self) -> ShaderCache {
        ShaderCache(self.shaders.clone())
    }

    /// Compiles the pipelines for drawing into `format` (4× MSAA when `msaa` and the
    /// adapter allows it), so the first frame does not: a caller that makes the renderer
    /// on a worker thread calls this there.
    pub fn prepare(&self, format: wgpu::TextureFormat, msaa: bool) {
        let samples = if msaa && self.gpu.msaa_ok(format) { 4 } else { 1 };
        self.pipelines(samples, format);
    }

    /// Number of levels of detail (1 without a LOD chain).
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Smallest screen coverage of each level, finest first (`[0]` without a LOD chain).
    pub fn level_coverages(&self) -> Vec<f32> {
        self.levels.iter().map(|l| l.coverage).collect()
    }

    /// Triangles of one tree at level `level` (0 past the last level).
    pub fn level_triangles(&self, level: usize) -> u64 {
        self.levels.get(level).map_or(0, |l| l.triangles)
    }

    /// Draw calls one instanced draw of level `level` issues (its parts' material groups).
    pub fn draws_per_level(&self, level: usize) -> u32 {
        self.levels.get(level).map_or(0, |l| l.parts.iter().map(|p| p.geometry.groups.len() as u32).sum())
    }

    /// LOD0's bounds (model space).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        self.bounds
    }

    /// Whether the model is skinned and animated (a rig and a clip).
    pub fn animated(&self) -> bool {
        self.rig.is_some()
    }

    /// The clip's length in seconds (0 without one).
    pub fn clip_duration(&self) -> f32 {
        self.rig.as_ref().map_or(0.0, |(_, c)| c.duration())
    }

    /// Whether 4× MSAA is available for the colour and depth formats.
    pub fn msaa_supported(&self) -> bool {
        self.msaa_ok
    }

    /// The skinning matrix of each joint at time `t` (its posed transform times its
    /// inverse bind matrix, as [`sylva::wind::posed`] uses); one identity without a rig.
    pub fn joint_matrices(&self, t: f32) -> Vec<Mat4> {
        match &self.rig {
            Some((rig, clip)) => clip
                .pose(rig, t)
                .iter()
                .zip(&rig.joints)
                .map(|(m, j)| *m * Mat4::from_translation(-j.head))
                .collect(),
            None => vec![Mat4::IDENTITY],
        }
    }

    /// The camera of `opts` for `instances` (see [`RenderOptions::frame`]).
    pub fn camera(&self, opts: &RenderOptions, instances: &[Mat4]) -> Camera {
        let model = self.bounds.unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let one_tree = instances.len() == 1 && instances[0] == Mat4::IDENTITY;
        let corners = |(lo, hi): (Vec3, Vec3)| -> Vec<Vec3> {
            (0..8)
                .map(|k| Vec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo))
                .collect()
        };
        let (frame, fit) = match opts.frame {
            Some(b) => (b, corners(b)),
            None if one_tree => (model, self.fit_points.clone()),
            None => {
                let b = forest::bounds(instances, model).unwrap_or(model);
                (b, corners(b))
            }
        };
        let orbit = opts.orbit.unwrap_or_else(|| Orbit::auto(frame.0, frame.1));
        // Depth range: everything drawn, with room for swaying crowns.
        let mut all = forest::bounds(instances, model).unwrap_or(model);
        if opts.ground {
            if let Some((lo, hi)) = forest::bounds(instances, overlay::ground_box(model.0, model.1)) {
                all = (all.0.min(lo), all.1.max(hi));
            }
        }
        let pad = Vec3::splat((all.1 - all.0).max_element() / 6.0);
        let depth = (all.0.min(frame.0) - pad, all.1.max(frame.1) + pad);
        Camera::new(frame, orbit, opts.fov_deg, (opts.width, opts.height), fit, depth)
    }

    fn pipelines(&self, samples: u32, format: wgpu::TextureFormat) -> Pipelines {
        let mut cache = self.shaders.pipelines.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, p)) = cache.iter().find(|(k, _)| *k == (samples, format)) {
            return p.clone();
        }
        let device = &self.gpu.device;
        let attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Uint16x4, 4 => Float32x4];
        let inst = wgpu::vertex_attr_array![5 => Float32x4, 6 => Float32x4, 7 => Float32x4, 8 => Float32x4];
        let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let instances = wgpu::VertexBufferLayout {
            array_stride: 64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &inst,
        };
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<mesh::Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &attrs,
            }),
            Some(instances.clone()),
        ];
        let ground_buffers = [None, Some(instances)];
        let line_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<overlay::LineVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &line_attrs,
        })];
        let multisample = wgpu::MultisampleState { count: samples, ..Default::default() };
        /// How one pipeline draws, besides its shaders and vertex buffers.
        struct Draw {
            topology: wgpu::PrimitiveTopology,
            blend: Option<wgpu::BlendState>,
            depth_write: bool,
            compare: wgpu::CompareFunction,
        }
        let make = |label, layout, (vs, fs), buffers: &[Option<wgpu::VertexBufferLayout>], d: Draw| {
            let target =
                [Some(wgpu::ColorTargetState { format, blend: d.blend, write_mask: wgpu::ColorWrites::ALL })];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &self.shaders.shader,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: d.topology,
                    front_face: wgpu::FrontFace::Ccw,
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(d.depth_write),
                    depth_compare: Some(d.compare),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample,
                fragment: Some(wgpu::FragmentState {
                    module: &self.shaders.shader,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &target,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::CompareFunction::{Always, Less, LessEqual};
        use wgpu::PrimitiveTopology::{LineList, TriangleList};
        let solid = |depth_write, compare| Draw { topology: TriangleList, blend: None, depth_write, compare };
        let lines = |compare| Draw { topology: LineList, blend: None, depth_write: false, compare };
        // The shadow multiplies what is there by 1 − its alpha.
        let darken = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::Zero,
            dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha,
            operation: wgpu::BlendOperation::Add,
        };
        let (mesh_layout, plain) = (&self.shaders.layout, &self.shaders.background_layout);
        let p = Pipelines {
            mesh: make("sylva-gpu mesh", mesh_layout, ("vs_mesh", "fs_mesh"), &buffers, solid(true, Less)),
            cut: make(
                "sylva-gpu mesh (alpha cut)",
                mesh_layout,
                ("vs_mesh_cut", "fs_mesh_cut"),
                &buffers,
                solid(true, Less),
            ),
            background: make(
                "sylva-gpu background",
                plain,
                ("vs_background", "fs_background"),
                &[],
                solid(false, Always),
            ),
            ground: make(
                "sylva-gpu ground",
                plain,
                ("vs_ground", "fs_ground"),
                &ground_buffers,
                Draw { blend: Some(wgpu::BlendState::ALPHA_BLENDING), ..solid(true, Less) },
            ),
            shadow: make(
                "sylva-gpu contact shadow",
                plain,
                ("vs_ground", "fs_shadow"),
                &ground_buffers,
                Draw {
                    blend: Some(wgpu::BlendState { color: darken, alpha: darken }),
                    ..solid(false, Always)
                },
            ),
            wire: make("sylva-gpu wireframe", plain, ("vs_wire", "fs_wire"), &buffers, lines(LessEqual)),
            lines: make("sylva-gpu lines", plain, ("vs_line", "fs_line"), &line_buffers, lines(LessEqual)),
            lines_top: make(
                "sylva-gpu lines on top",
                plain,
                ("vs_line", "fs_line"),
                &line_buffers,
                lines(Always),
            ),
        };
        cache.push(((samples, format), p.clone()));
        p
    }

    /// Renders `instances` (tree transforms; `[Mat4::IDENTITY]` for the model alone) at
    /// time `time` (seconds into the wind clip, ignored without one).
    ///
    /// Errors: a size outside `1..=8192` or the adapter's texture limit, a field of view
    /// outside `1..=120`, no instances or more than [`forest::MAX_TREES`], a fixed level
    /// of detail the model does not have, an overlay point that is not finite or more
    /// than [`overlay::MAX_SEGMENTS`] overlay segments.
    pub fn render(&self, opts: &RenderOptions, instances: &[Mat4], time: f32) -> Result<Rendered, GpuError> {
        self.check((opts.width, opts.height), opts.fov_deg, instances, time)?;
        self.check_view(opts)?;
        let (w, h) = (opts.width, opts.height);
        let samples = if opts.msaa && self.msaa_ok { 4 } else { 1 };
        let camera = self.camera(opts, instances);
        let mut guard = self.targets.lock().unwrap_or_else(|e| e.into_inner());
        if guard.as_ref().is_none_or(|t| t.key != (w, h, samples)) {
            // A device out of memory for the targets (an 8192² 4× MSAA frame is over 1 GB
            // of colour and depth) is an error, not wgpu's panic.
            *guard = None;
            let scope = self.gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let targets = self.make_targets(w, h, samples);
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(invalid(format!(
                    "the device has no memory for a {w}x{h} frame with {samples} sample(s) per pixel \
                     (about {} bytes of targets): {e}",
                    frame_memory(w, h, samples)
                )));
            }
            *guard = Some(targets);
        }
        let t = guard.as_ref().expect("targets were just made");
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("sylva-gpu render") });
        let resolve = t.resolve.as_ref().map(|(_, v)| v);
        let target = Target { format: COLOR_FORMAT, samples, color: &t.color, resolve, depth: &t.depth };
        let stats = self.encode(&mut encoder, &camera, opts, instances, time, &target);
        let texture = match (&t.resolve, &t.single) {
            (Some((tex, _)), _) | (None, Some(tex)) => tex,
            (None, None) => unreachable!("a single-sample target or a resolve target exists"),
        };
        let image = self.read_back(encoder, texture, w, h);
        Ok(Rendered { image, stats, camera })
    }

    /// Draws `instances` at time `time`, seen by `camera`, into `view`: a single-sample
    /// colour view of `format` (any `…Srgb` format, e.g. a window surface's
    /// `Bgra8UnormSrgb`) of `camera.width × camera.height` pixels, as a window's frame is
    /// drawn (`render::window`, cargo feature `window`). With `opts.msaa` (and an
    /// adapter that takes 4× samples of `format`) the pass draws into a multisampled
    /// texture and resolves into `view`. Of `opts` the size, `orbit` and `frame` are not
    /// used (the camera carries the size and the view); `msaa`, `fov_deg` (checked), the
    /// background colours, `ground`, `wireframe`, `lod` and `overlays` are. The work is
    /// submitted; the caller presents.
    ///
    /// Errors: as [`Renderer::render`] for the camera's size, the instances, the level
    /// and the overlays.
    pub fn render_to_view(
        &self,
        camera: &Camera,
        opts: &RenderOptions,
        instances: &[Mat4],
        time: f32,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
    ) -> Result<Stats, GpuError> {
        let (w, h) = (camera.width, camera.height);
        self.check((w, h), opts.fov_deg, instances, time)?;
        self.check_view(opts)?;
        let samples = if opts.msaa && self.gpu.msaa_ok(format) { 4 } else { 1 };
        let mut guard = self.view_targets.lock().unwrap_or_else(|e| e.into_inner());
        if guard.as_ref().is_none_or(|t| t.key != (w, h, samples, format)) {
            let make = |label, format| {
                let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
                texture_2d(&self.gpu.device, label, (w, h), samples, format, attach)
                    .create_view(&Default::default())
            };
            let msaa = (samples > 1).then(|| make("sylva-gpu view msaa colour", format));
            let depth = make("sylva-gpu view depth", DEPTH_FORMAT);
            *guard = Some(ViewTargets { key: (w, h, samples, format), msaa, depth });
        }
        let t = guard.as_ref().expect("view targets were just made");
        let target = match &t.msaa {
            Some(msaa) => Target { format, samples, color: msaa, resolve: Some(view), depth: &t.depth },
            None => Target { format, samples, color: view, resolve: None, depth: &t.depth },
        };
        let mut encoder = self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("sylva-gpu render to view"),
        });
        let stats = self.encode(&mut encoder, camera, opts, instances, time, &target);
        self.gpu.queue.submit([encoder.finish()]);
        Ok(stats)
    }

    /// Checks a frame's size, field of view, instances and time.
    fn check(&self, (w, h): (u32, u32), fov_deg: f32, instances: &[Mat4], time: f32) -> Result<(), GpuError> {
        let limit = self.gpu.device.limits().max_texture_dimension_2d.min(MAX_SIZE);
        for (name, v) in [("width", w), ("height", h)] {
            if !(1..=limit).contains(&v) {
                return Err(invalid(format!("image {name} is {v}; it must be in 1..={limit}")));
            }
        }
        // The readback copies a frame into one buffer of padded rows.
        let staging = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) as u64 * h as u64;
        let max_buffer = self.gpu.device.limits().max_buffer_size;
        if staging > max_buffer {
            return Err(invalid(format!(
                "a {w}x{h} frame needs a readback buffer of {staging} bytes, more than the device's \
                 limit of {max_buffer}"
            )));
        }
        if !(1.0..=120.0).contains(&fov_deg) {
            return Err(invalid(format!("fov_deg is {fov_deg}; it must be in 1..=120")));
        }
        if instances.is_empty() || instances.len() > forest::MAX_TREES {
            return Err(invalid(format!(
                "{} trees; draw 1..={} at once",
                instances.len(),
                forest::MAX_TREES
            )));
        }
        if !time.is_finite() {
            return Err(invalid("the time is not finite"));
        }
        Ok(())
    }

    /// Checks what a viewer asks for: the fixed level of detail and the overlays.
    fn check_view(&self, opts: &RenderOptions) -> Result<(), GpuError> {
        if let Some(l) = opts.lod.filter(|&l| l >= self.levels.len()) {
            return Err(invalid(format!(
                "lod is {l}; this model has level{} 0..={}",
                if self.levels.len() > 1 { "s" } else { "" },
                self.levels.len() - 1
            )));
        }
        overlay::check(&opts.overlays).map_err(invalid)
    }

    /// Writes the frame's uniforms, joints and instances and encodes its one render pass
    /// into `target`: the background, then one instanced draw per (level, part,
    /// material).
    fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        camera: &Camera,
        opts: &RenderOptions,
        instances: &[Mat4],
        time: f32,
        target: &Target,
    ) -> Stats {
        let (w, h) = (camera.width, camera.height);
        let samples = target.samples;
        let q = &self.gpu.queue;
        q.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&Frame::new(camera, time)));
        let srgb = |c: [u8; 3]| [c[0] as f32 / 255.0, c[1] as f32 / 255.0, c[2] as f32 / 255.0, 1.0];
        let bg = BackgroundUniform {
            top: srgb(opts.background_top),
            bottom: srgb(opts.background),
            size: [w as f32, h as f32, 0.0, 0.0],
        };
        q.write_buffer(&self.background_buffer, 0, bytemuck::bytes_of(&bg));
        if self.rig.is_some() {
            let m: Vec<[f32; 16]> = self.joint_matrices(time).iter().map(Mat4::to_cols_array).collect();
            q.write_buffer(&self.joint_buffer, 0, bytemuck::cast_slice(&m));
        }

        // Level of detail per instance, bucketed into one buffer, coarsest trees last.
        let (lo, hi) = self.bounds.unwrap_or((Vec3::ZERO, Vec3::ZERO));
        let sphere = ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-6));
        let levels = match opts.lod {
            Some(l) => vec![l.min(self.levels.len() - 1); instances.len()],
            None => forest::choose_levels(camera, instances, sphere, &self.level_coverages()),
        };
        let mut counts = vec![0u32; self.levels.len()];
        for &l in &levels {
            counts[l] += 1;
        }
        let mut order: Vec<usize> = (0..instances.len()).collect();
        order.sort_by_key(|&i| levels[i]);
        let data: Vec<[f32; 16]> = order.iter().map(|&i| instances[i].to_cols_array()).collect();
        let instance_buffer = self.gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sylva-gpu render instances"),
            contents: bytemuck::cast_slice(&data),
            usage: wgpu::BufferUsages::VERTEX,
        });

        let pipelines = self.pipelines(samples, target.format);
        let mut stats = Stats { instances_per_level: counts.clone(), samples, ..Default::default() };
        let resolve = target.resolve;
        let store = if resolve.is_some() { wgpu::StoreOp::Discard } else { wgpu::StoreOp::Store };
        let mut pass = begin_colour_depth_pass(
            encoder,
            "sylva-gpu render",
            (target.color, resolve),
            target.depth,
            wgpu::Color::BLACK,
            store,
        );
        pass.set_bind_group(0, &self.group0, &[]);
        pass.set_pipeline(&pipelines.background);
        pass.draw(0..3, 0..1);
        pass.set_vertex_buffer(1, instance_buffer.slice(..));
        if opts.ground {
            let all = 0..instances.len() as u32;
            pass.set_pipeline(&pipelines.ground);
            pass.draw(0..6, all.clone());
            pass.set_pipeline(&pipelines.shadow);
            pass.draw(0..6, all);
        }
        let mut current_cut = None;
        let mut start = 0u32;
        for (level, &n) in self.levels.iter().zip(&counts) {
            let range = start..start + n;
            start += n;
            if n == 0 {
                continue;
            }
            for part in &level.parts {
                pass.set_vertex_buffer(0, part.geometry.vertices.slice(..));
                pass.set_index_buffer(part.geometry.indices.slice(..), wgpu::IndexFormat::Uint32);
                for g in &part.geometry.groups {
                    let cut = part.cut[g.material];
                    if current_cut != Some(cut) {
                        pass.set_pipeline(if cut { &pipelines.cut } else { &pipelines.mesh });
                        current_cut = Some(cut);
                    }
                    pass.set_bind_group(1, &part.materials[g.material], &[]);
                    pass.draw_indexed(g.first..g.first + g.count, 0, range.clone());
                    stats.draw_calls += 1;
                }
            }
            stats.triangles += level.triangles * n as u64;
        }
        if opts.wireframe {
            pass.set_pipeline(&pipelines.wire);
            let mut start = 0u32;
            for (level, &n) in self.levels.iter().zip(&counts) {
                let range = start..start + n;
                start += n;
                if n == 0 {
                    continue;
                }
                for part in &level.parts {
                    let (edges, count) = self.wire_edges(part);
                    if *count == 0 {
                        continue;
                    }
                    pass.set_vertex_buffer(0, part.geometry.vertices.slice(..));
                    pass.set_index_buffer(edges.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..*count, 0, range.clone());
                    stats.lines += *count as u64 / 2 * n as u64;
                }
            }
        }
        if !opts.overlays.is_empty() {
            let (vertices, tested) = overlay::vertices(&opts.overlays);
            if !vertices.is_empty() {
                let buffer = self.gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("sylva-gpu render overlays"),
                    contents: bytemuck::cast_slice(&vertices),
                    usage: wgpu::BufferUsages::VERTEX,
                });
                pass.set_vertex_buffer(0, buffer.slice(..));
                let total = vertices.len() as u32;
                for (pipeline, range) in
                    [(&pipelines.lines, 0..tested), (&pipelines.lines_top, tested..total)]
                {
                    if !range.is_empty() {
                        pass.set_pipeline(pipeline);
                        pass.draw(range, 0..1);
                    }
                }
                stats.lines += total as u64 / 2;
            }
        }
        stats
    }

    /// The wireframe's line-list index buffer of `part` and its index count, built from
    /// its triangles on first use.
    fn wire_edges<'a>(&self, part: &'a GpuPart) -> &'a (wgpu::Buffer, u32) {
        part.geometry.wire.get_or_init(|| {
            let (positions, triangles) = &part.geometry.wire_source;
            let edges = mesh::edge_indices(positions, triangles);
            let buffer = self.gpu.buffer(
                "sylva-gpu render wireframe",
                bytemuck::cast_slice(&edges),
                wgpu::BufferUsages::INDEX,
            );
            (buffer, edges.len() as u32)
        })
    }

    fn make_targets(&self, w: u32, h: u32, samples: u32) -> Targets {
        let device = &self.gpu.device;
        let make = |label, samples, format, usage| texture_2d(device, label, (w, h), samples, format, usage);
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let depth = make("sylva-gpu depth", samples, DEPTH_FORMAT, attach).create_view(&Default::default());
        let readable = attach | wgpu::TextureUsages::COPY_SRC;
        if samples > 1 {
            let color =
                make("sylva-gpu msaa colour", samples, COLOR_FORMAT, attach).create_view(&Default::default());
            let resolve = make("sylva-gpu colour", 1, COLOR_FORMAT, readable);
            let view = resolve.create_view(&Default::default());
            Targets { key: (w, h, samples), color, resolve: Some((resolve, view)), single: None, depth }
        } else {
            let single = make("sylva-gpu colour", 1, COLOR_FORMAT, readable);
            let color = single.create_view(&Default::default());
            Targets { key: (w, h, samples), color, resolve: None, single: Some(single), depth }
        }
    }

    /// Submits `encoder` with a copy of `texture` into a buffer and reads it back.
    fn read_back(&self, encoder: wgpu::CommandEncoder, texture: &wgpu::Texture, w: u32, h: u32) -> Image {
        let rgba = read_texture(&self.gpu.device, &self.gpu.queue, encoder, texture, (w, h), 4);
        Image::from_rgba(w, h, rgba)
    }
}

/// Bytes of device memory one frame of `w × h` with `samples` samples per pixel takes
/// in [`Renderer::render`]: multisampled colour and depth, the resolved colour and the
/// readback buffer (on a software adapter such as lavapipe all of it is host memory,
/// plus the image read back). Frames are drawn one at a time, so this does not grow
/// with the frame count or with the trees of a forest (instanced).
pub fn frame_memory(w: u32, h: u32, samples: u32) -> u64 {
    let px = w as u64 * h as u64;
    let per_sample = 4 + 4; // Rgba8 colour + Depth32 depth
    px * (samples as u64 * per_sample + if samples > 1 { 4 } else { 0 } + 4)
}

/// An sRGB RGBA texture of `image` (an RGB image gains alpha 255) and its view.
/// `data`'s vertex and index buffers on the GPU (`name`: the part's, for messages).
fn upload_part(gpu: &Ctx, name: &str, key: u128, data: mesh::MeshData) -> Result<PartGeometry, GpuError> {
    let device = &gpu.device;
    let max = device.limits().max_buffer_size;
    let bytes = (data.vertices.len() * std::mem::size_of::<mesh::Vertex>()) as u64;
    if bytes > max {
        return Err(invalid(format!(
            "part `{name}` needs {bytes} bytes of vertices; the adapter allows {max}"
        )));
    }
    let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("sylva-gpu render vertices"),
        contents: bytemuck::cast_slice(&data.vertices),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("sylva-gpu render indices"),
        contents: bytemuck::cast_slice(&data.indices),
        usage: wgpu::BufferUsages::INDEX,
    });
    let positions = data.vertices.iter().map(|v| v.position).collect();
    Ok(PartGeometry {
        key,
        vertices,
        indices,
        groups: data.groups,
        index_count: data.indices.len() as u32,
        wire_source: (positions, data.indices),
        wire: OnceLock::new(),
    })
}

fn texture(gpu: &Ctx, label: &str, image: &Image) -> wgpu::TextureView {
    let (w, h) = (image.width, image.height);
    let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
    let tex = texture_2d(&gpu.device, label, (w, h), 1, COLOR_FORMAT, usage);
    let expanded;
    let rgba = if image.channels == 4 {
        &image.data
    } else {
        expanded = image.clone().into_rgba();
        &expanded.data
    };
    gpu.queue.write_texture(
        tex.as_image_copy(),
        rgba,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 4), rows_per_image: Some(h) },
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
    );
    tex.create_view(&Default::default())
}
