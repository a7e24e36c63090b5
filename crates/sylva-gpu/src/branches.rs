//! Drawing a model's branches with the GPU deformer (issue 25 item 1; Skjermo2008 D §2.3
//! and §4, Skjermo2008-spec §3): [`BranchRenderer`] keeps the branch records, their control
//! points (its own rest pose, or [`GpuWind`]'s storage buffer, so wind moves what is drawn
//! with no CPU round trip) and ONE vertex buffer of (v, θ, uv) grids for every level of
//! detail ([`sylva::deform::Grids`]), and draws one indexed, instanced draw per level
//! into a caller's render pass: instance k of level l is branch `ids[l][k]`.
//!
//! ```text
//!  Frame (group 0) ─┐
//!  records, points ─┼─► lod_select (compute, per frame): frustum cull, projected
//!  LodSettings    ──┘     diameter → level; ids[level] += branch, instance_count += 1
//!  grid vertices (v, θ, uv) ─► vs_branch: ids[instance] → record + points → deform_at
//!  indirect args (5 words per level) ─► draw_indexed_indirect × levels
//!  fs_branch: bark texture at (θ/2π, arc length / circumference), Lambert + sky/ground
//! ```
//!
//! The level is chosen on the GPU from the current (wind-moved) control points: the
//! branch's bounding sphere (centroid of P₀…P₃, farthest control point plus the widest
//! radius the shape terms allow) is culled against the frustum's side and near planes,
//! and its projected diameter `2 r_max H / (2 d tan(fov/2))` in pixels, with d the
//! distance from the eye to the sphere, picks the finest level whose threshold it reaches
//! ([`LodSettings`], default 12, 4 and 1.5 px for the first three of
//! [`sylva::deform::DEFAULT_LODS`]: 25 × 16, 13 × 8, 7 × 4 and 4 × 4 rings × sides).
//! Each level's id list is bound at a dynamic storage offset, so no indirect first
//! instance (an optional feature) is needed.

use crate::deform::{record_words, rest_points, shared_wgsl};
use crate::gpu::{buffer_entry, workgroups, Gpu, GpuError};
use crate::GpuWind;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};
use sylva::deform::{branch_records, BranchRecord, Grids, NO_AXIS};
use sylva::image::Image;
use sylva::model::Model;

/// The shader source (see its header for how the parts are put together).
pub const BRANCHES_WGSL: &str = include_str!("branches.wgsl");
const LOD_MARKER: &str = "// ---- lod ----";
const DRAW_MARKER: &str = "// ---- draw ----";

/// The camera and light of one frame, group(0) binding(0): the same uniform as the mesh
/// renderer's, so both can draw into one pass.
pub use crate::render::Frame;

impl Frame {
    /// A perspective camera at `eye` looking at `target` (+Y up) with vertical field of
    /// view `fov_y` (radians) over a `width` × `height` pixel viewport, a warm sun from
    /// the upper left and a blue-sky / brown-ground ambient.
    pub fn look_at(eye: Vec3, target: Vec3, fov_y: f32, width: u32, height: u32, time: f32) -> Frame {
        let aspect = width as f32 / height.max(1) as f32;
        let view = look_at(eye, target, Vec3::Y);
        let proj = perspective(fov_y, aspect, 0.1, 2000.0);
        let light = Vec3::new(-0.4, 0.8, 0.45).normalize();
        Frame {
            view_proj: (proj * view).to_cols_array_2d(),
            eye: [eye.x, eye.y, eye.z, 1.0],
            light_dir: [light.x, light.y, light.z, 0.0],
            light_color: [1.0, 0.95, 0.85, 1.0],
            sky: [0.32, 0.38, 0.48, 1.0],
            ground: [0.14, 0.11, 0.08, 1.0],
            params: [time, height as f32, (fov_y * 0.5).tan(), 0.0],
        }
    }
}

/// A right-handed view matrix: the camera at `eye` looking at `target`, `up` roughly up.
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let f = (target - eye).normalize();
    let s = f.cross(up).normalize();
    let u = s.cross(f);
    Mat4::from_cols(
        Vec4::new(s.x, u.x, -f.x, 0.0),
        Vec4::new(s.y, u.y, -f.y, 0.0),
        Vec4::new(s.z, u.z, -f.z, 0.0),
        Vec4::new(-s.dot(eye), -u.dot(eye), f.dot(eye), 1.0),
    )
}

/// A right-handed perspective projection onto wgpu's depth range \[0, 1\].
pub fn perspective(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let h = 1.0 / (0.5 * fov_y).tan();
    let r = far / (near - far);
    Mat4::from_cols(
        Vec4::new(h / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, h, 0.0, 0.0),
        Vec4::new(0.0, 0.0, r, -1.0),
        Vec4::new(0.0, 0.0, r * near, 0.0),
    )
}

/// How [`BranchRenderer::prepare`] picks each branch's level of detail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LodSettings {
    /// Projected diameter in pixels at or above which levels 0, 1 and 2 are taken; a
    /// branch below every threshold gets the coarsest level.
    pub thresholds: [f32; 3],
    /// Drop branches whose bounding sphere lies outside the view frustum.
    pub cull: bool,
}

impl Default for LodSettings {
    /// 12, 4 and 1.5 px, culling on.
    fn default() -> Self {
        LodSettings { thresholds: [12.0, 4.0, 1.5], cull: true }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct LodParams {
    thresholds: [f32; 4],
    counts: [u32; 4],
}

/// The level [`BranchRenderer::prepare`] gives a branch (the GPU's `lod_select` in f32 on
/// the CPU), or `None` where it is culled: for tests and statistics.
pub fn select_lod(
    record: &BranchRecord,
    points: [Vec3; 4],
    frame: &Frame,
    settings: &LodSettings,
    levels: usize,
) -> Option<usize> {
    let (c, r_max, bound) = bounding_sphere(record, points);
    if settings.cull {
        let m = Mat4::from_cols_array_2d(&frame.view_proj);
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        for p in [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2] {
            if (p.truncate().dot(c) + p.w) / p.truncate().length() < -bound {
                return None;
            }
        }
    }
    Some(lod_of(projected_diameter(frame, c, r_max, bound), settings, levels))
}

/// The level of a branch whose projected diameter is `px` pixels: the first threshold it
/// reaches, else the coarsest of `levels`.
pub fn lod_of(px: f32, settings: &LodSettings, levels: usize) -> usize {
    let last = levels.saturating_sub(1);
    (0..last.min(3)).find(|&k| px >= settings.thresholds[k]).unwrap_or(last)
}

/// Centroid of the control points, the widest radius the shape terms allow, and the
/// bounding sphere's radius around the centroid.
fn bounding_sphere(r: &BranchRecord, p: [Vec3; 4]) -> (Vec3, f32, f32) {
    let c = (p[0] + p[1] + p[2] + p[3]) * 0.25;
    let r_max = r.radius.max(r.tip_radius)
        * (1.0 + r.flare)
        * (1.0 + r.bulge_depth.abs())
        * (1.0 + r.lobe_depth.abs() * (1.0 - r.lobe_fade).abs().max(1.0));
    let far = c.distance(p[0]).max(c.distance(p[1])).max(c.distance(p[2]).max(c.distance(p[3])));
    (c, r_max, far + r_max)
}

/// Projected diameter (px) of a section of radius `r_max` at the sphere's nearest point.
fn projected_diameter(frame: &Frame, c: Vec3, r_max: f32, bound: f32) -> f32 {
    let eye = Vec3::new(frame.eye[0], frame.eye[1], frame.eye[2]);
    let dist = (c.distance(eye) - bound).max(1e-3);
    2.0 * r_max * frame.params[1] / (2.0 * dist * frame.params[2])
}

/// Per-record texture mapping as `tex[i]` of the shader: the arc length along the axis at
/// the segment's start, the segment's arc length (both from the rest pose, Gravesen's
/// estimate `(chord + polygon) / 2`), and 1 / the circumference of the axis's base
/// (`2π r` of its first record; a record without an axis is its own axis). The bark's v
/// is their `(start + v · length) / circumference`, continuous across a chain's knots.
pub fn texture_mapping(records: &[BranchRecord]) -> Vec<[f32; 4]> {
    let mut out = Vec::with_capacity(records.len());
    let mut current: Option<(u32, f32, f32)> = None; // axis, arc so far, 1 / circumference
    for r in records {
        let p = r.points();
        let polygon = p[0].distance(p[1]) + p[1].distance(p[2]) + p[2].distance(p[3]);
        let length = 0.5 * (polygon + p[0].distance(p[3]));
        let (start, inv) = match current {
            Some((axis, arc, inv)) if r.axis != NO_AXIS && axis == r.axis => (arc, inv),
            _ => (0.0, 1.0 / (std::f32::consts::TAU * r.radius.max(1e-4))),
        };
        current = Some((r.axis, start + length, inv));
        out.push([start, length, inv, 0.0]);
    }
    out
}

/// The bark base-colour image of `model`: the map of its `bark` part's material, else
/// an image named `bark_albedo`; `None` when the texture stage made none.
pub fn model_bark(model: &Model) -> Option<&Image> {
    let by_part = model
        .parts
        .iter()
        .find(|p| p.name == "bark")
        .and_then(|p| p.material.maps.base_color)
        .and_then(|i| model.images.get(i as usize));
    by_part.or_else(|| model.images.iter().find(|i| i.name == "bark_albedo")).map(|i| &*i.image)
}

/// What the render pass the renderer draws into looks like.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TargetFormat {
    /// Colour attachment format (an sRGB one for correct shading).
    pub color: wgpu::TextureFormat,
    /// Depth attachment format.
    pub depth: wgpu::TextureFormat,
    /// MSAA samples (1 or 4).
    pub samples: u32,
}

impl Default for TargetFormat {
    /// `Rgba8UnormSrgb`, `Depth32Float`, 4× MSAA.
    fn default() -> Self {
        TargetFormat {
            color: wgpu::TextureFormat::Rgba8UnormSrgb,
            depth: wgpu::TextureFormat::Depth32Float,
            samples: 4,
        }
    }
}

/// Draws branch records with the GPU deformer; see the [module docs](self).
#[derive(Debug)]
pub struct BranchRenderer {
    gpu: Gpu,
    grids: Grids,
    count: usize,
    /// Words between two levels' id lists (a multiple of the storage offset alignment).
    region_words: u32,
    records: wgpu::Buffer,
    rest: wgpu::Buffer,
    tex: wgpu::Buffer,
    ids: wgpu::Buffer,
    indirect: wgpu::Buffer,
    lod_params: wgpu::Buffer,
    frame: wgpu::Buffer,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    lod_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    capture_layout: wgpu::BindGroupLayout,
    lod_group: wgpu::BindGroup,
    draw_group: wgpu::BindGroup,
    texture_view: wgpu::TextureView,
    sampler: wgpu::Sampler,
    material: wgpu::Buffer,
    lod_reset: wgpu::ComputePipeline,
    lod_select: wgpu::ComputePipeline,
    draw_pipeline: wgpu::RenderPipeline,
    capture_pipeline: wgpu::RenderPipeline,
}

fn storage(read_only: bool) -> wgpu::BufferBindingType {
    wgpu::BufferBindingType::Storage { read_only }
}

/// The bind group layout of the [`Frame`] uniform (group 0, binding 0, every stage).
pub fn frame_layout(gpu: &Gpu) -> wgpu::BindGroupLayout {
    let all = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    gpu.bind_group_layout("frame", &[buffer_entry(0, all, wgpu::BufferBindingType::Uniform, false)])
}

/// `image` as RGBA8 with a box-filtered mip chain down to 1 × 1.
fn mip_chain(image: &Image) -> Vec<(u32, u32, Vec<u8>)> {
    let (w, h) = (image.width.max(1), image.height.max(1));
    let ch = image.channels.max(1) as usize;
    let mut rgba = Vec::with_capacity((w * h * 4) as usize);
    for px in image.data.chunks_exact(ch).take((w * h) as usize) {
        let c = |k: usize| px.get(k).copied().unwrap_or(if k == 3 { 255 } else { px[0] });
        rgba.extend_from_slice(&[c(0), c(1), c(2), if ch >= 4 { px[3] } else { 255 }]);
    }
    rgba.resize((w * h * 4) as usize, 255);
    let mut levels = vec![(w, h, rgba)];
    while let Some(&(w, h, ref data)) = levels.last() {
        if w == 1 && h == 1 {
            break;
        }
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = vec![0u8; (nw * nh * 4) as usize];
        for y in 0..nh {
            for x in 0..nw {
                for k in 0..4 {
                    let mut sum = 0u32;
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (sx, sy) = ((2 * x + dx).min(w - 1), (2 * y + dy).min(h - 1));
                        sum += data[((sy * w + sx) * 4) as usize + k] as u32;
                    }
                    next[((y * nw + x) * 4) as usize + k] = ((sum + 2) / 4) as u8;
                }
            }
        }
        levels.push((nw, nh, next));
    }
    levels
}

impl BranchRenderer {
    /// A renderer of `model`'s branch curves ([`branch_records`]) with its bark texture
    /// ([`model_bark`]) or, without one, the bark material's flat colour.
    pub fn for_model(gpu: &Gpu, model: &Model, target: TargetFormat) -> Result<BranchRenderer, GpuError> {
        let color = model
            .parts
            .iter()
            .find(|p| p.name == "bark")
            .map_or(sylva::model::Material::bark().base_color, |p| p.material.base_color);
        let bark = model_bark(model);
        let tint = if bark.is_some() { [1.0; 3] } else { [color[0], color[1], color[2]] };
        BranchRenderer::new(gpu, &branch_records(&model.curves), bark, tint, target)
    }

    /// A renderer of `records` (drawn over [`Grids::standard`]'s levels): `bark` is the
    /// base-colour texture (sRGB, tiled), multiplied by the linear `tint`; without one the
    /// branches take the flat `tint`. Fails where the records do not fit the device's
    /// storage buffer limit.
    pub fn new(
        gpu: &Gpu,
        records: &[BranchRecord],
        bark: Option<&Image>,
        tint: [f32; 3],
        target: TargetFormat,
    ) -> Result<BranchRenderer, GpuError> {
        let device = &gpu.device;
        let limits = device.limits();
        let count = records.len();
        let bytes = count as u64 * BranchRecord::SIZE as u64;
        if bytes > limits.max_storage_buffer_binding_size {
            return Err(GpuError::Invalid(format!(
                "{count} branch records ({bytes} bytes) pass the device's storage binding limit of {} bytes",
                limits.max_storage_buffer_binding_size
            )));
        }
        let grids = Grids::standard();
        let align_words = (limits.min_storage_buffer_offset_alignment / 4).max(1);
        let region_words = (count as u32).max(1).next_multiple_of(align_words);
        let levels = grids.lods.len() as u32;

        let records_buf = gpu.storage_buffer("branch records", &record_words(records));
        let rest = gpu.storage_buffer("branch rest points", &rest_points(records));
        let tex = gpu.storage_buffer("branch texture mapping", &texture_mapping(records));
        let ids = gpu.storage_buffer_zeroed("branch lod ids", region_words as u64 * levels as u64 * 4);
        let args: Vec<u32> =
            grids.lods.iter().flat_map(|l| [l.index_count, 0, l.first_index, 0, 0]).collect();
        let indirect = buffer_init(
            gpu,
            "branch indirect draws",
            bytemuck::cast_slice(&args),
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::INDIRECT
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        );
        let lod_params = gpu.storage_buffer(
            "branch lod params",
            &[lod_params(&LodSettings::default(), count, region_words, levels)],
        );
        let frame = gpu.uniform_buffer(
            "frame",
            &[Frame::look_at(Vec3::new(0.0, 2.0, 10.0), Vec3::ZERO, 0.8, 16, 16, 0.0)],
        );
        let grid_words: Vec<[f32; 4]> =
            grids.vertices.iter().map(|g| [g.v, g.theta, g.uv.x, g.uv.y]).collect();
        let vertices = buffer_init(
            gpu,
            "branch grid vertices",
            bytemuck::cast_slice(&grid_words),
            wgpu::BufferUsages::VERTEX,
        );
        let indices = buffer_init(
            gpu,
            "branch grid indices",
            bytemuck::cast_slice(&grids.indices),
            wgpu::BufferUsages::INDEX,
        );
        let material = gpu.uniform_buffer("branch material", &[[tint[0], tint[1], tint[2], 1.0]]);

        // The bark texture (or 1 × 1 white) with its mips.
        let white = Image::from_rgba(1, 1, vec![255; 4]);
        let mips = mip_chain(bark.unwrap_or(&white));
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("bark"),
            size: wgpu::Extent3d { width: mips[0].0, height: mips[0].1, depth_or_array_layers: 1 },
            mip_level_count: mips.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        for (level, (w, h, data)) in mips.iter().enumerate() {
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: level as u32,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                data,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * w),
                    rows_per_image: Some(*h),
                },
                wgpu::Extent3d { width: *w, height: *h, depth_or_array_layers: 1 },
            );
        }
        let texture_view = texture.create_view(&Default::default());
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("bark"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });

        let (cs, vs, fs) =
            (wgpu::ShaderStages::COMPUTE, wgpu::ShaderStages::VERTEX, wgpu::ShaderStages::FRAGMENT);
        let frame_layout = frame_layout(gpu);
        let lod_layout = gpu.bind_group_layout(
            "branch lod",
            &[
                buffer_entry(0, cs, storage(true), false),
                buffer_entry(1, cs, storage(true), false),
                buffer_entry(2, cs, storage(true), false),
                buffer_entry(3, cs, storage(false), false),
                buffer_entry(4, cs, storage(false), false),
            ],
        );
        let [map, map_sampler] = crate::gpu::texture_sampler_entries(4, fs);
        let draw_layout = gpu.bind_group_layout(
            "branch draw",
            &[
                buffer_entry(0, vs, storage(true), false),
                buffer_entry(1, vs, storage(true), false),
                buffer_entry(2, vs, storage(true), false),
                buffer_entry(3, vs, storage(true), true),
                map,
                map_sampler,
                buffer_entry(6, fs, wgpu::BufferBindingType::Uniform, false),
            ],
        );
        let capture_layout =
            gpu.bind_group_layout("branch capture", &[buffer_entry(0, vs, storage(true), false)]);

        let (header, rest_src) =
            BRANCHES_WGSL.split_once(LOD_MARKER).expect("branches.wgsl has the lod marker");
        let (lod_src, draw_src) =
            rest_src.split_once(DRAW_MARKER).expect("branches.wgsl has the draw marker");
        let module = |label: &str, part: &str| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(
                    format!("{}\n{}\n{header}\n{part}", shared_wgsl(), crate::render::FRAME_WGSL).into(),
                ),
            })
        };
        let lod_module = module("branch lod", lod_src);
        let draw_module = module("branch draw", draw_src);
        let lod_reset = gpu.compute_pipeline(&lod_module, "lod_reset", &[&frame_layout, &lod_layout]);
        let lod_select = gpu.compute_pipeline(&lod_module, "lod_select", &[&frame_layout, &lod_layout]);

        let vertex_layout = wgpu::VertexBufferLayout {
            array_stride: 16,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32, 1 => Float32, 2 => Float32x2],
        };
        let layout = |groups: &[&wgpu::BindGroupLayout]| {
            let refs: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|&g| Some(g)).collect();
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("branches"),
                bind_group_layouts: &refs,
                immediate_size: 0,
            })
        };
        let draw_layout_p = layout(&[&frame_layout, &draw_layout]);
        let draw_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("branches"),
            layout: Some(&draw_layout_p),
            vertex: wgpu::VertexState {
                module: &draw_module,
                entry_point: Some("vs_branch"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout.clone())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Back),
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: target.depth,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: target.samples,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
            fragment: Some(wgpu::FragmentState {
                module: &draw_module,
                entry_point: Some("fs_branch"),
                compilation_options: Default::default(),
                targets: &[Some(target.color.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let capture_layout_p = layout(&[&frame_layout, &draw_layout, &capture_layout]);
        let capture_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("branch capture"),
            layout: Some(&capture_layout_p),
            vertex: wgpu::VertexState {
                module: &draw_module,
                entry_point: Some("vs_capture"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout.clone())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::PointList,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &draw_module,
                entry_point: Some("fs_capture"),
                compilation_options: Default::default(),
                targets: &[Some(CAPTURE_FORMAT.into()), Some(CAPTURE_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });

        let frame_group = gpu.bind_buffers("frame", &frame_layout, &[&frame]);
        let lod_group =
            gpu.bind_buffers("branch lod", &lod_layout, &[&records_buf, &rest, &lod_params, &ids, &indirect]);
        let mut renderer = BranchRenderer {
            gpu: gpu.clone(),
            grids,
            count,
            region_words,
            records: records_buf,
            draw_group: lod_group.clone(),
            lod_group,
            rest,
            tex,
            ids,
            indirect,
            lod_params,
            frame,
            vertices,
            indices,
            frame_group,
            lod_layout,
            draw_layout,
            capture_layout,
            texture_view,
            sampler,
            material,
            lod_reset,
            lod_select,
            draw_pipeline,
            capture_pipeline,
        };
        let rest = renderer.rest.clone();
        renderer.bind_points(&rest);
        Ok(renderer)
    }

    /// Rebuilds the LOD and draw bind groups over `points`.
    fn bind_points(&mut self, points: &wgpu::Buffer) {
        self.lod_group = self.gpu.bind_buffers(
            "branch lod",
            &self.lod_layout,
            &[&self.records, points, &self.lod_params, &self.ids, &self.indirect],
        );
        fn buffer(binding: u32, b: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry { binding, resource: b.as_entire_binding() }
        }
        self.draw_group = self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("branch draw"),
            layout: &self.draw_layout,
            entries: &[
                buffer(0, &self.records),
                buffer(1, points),
                buffer(2, &self.tex),
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &self.ids,
                        offset: 0,
                        size: wgpu::BufferSize::new(self.region_words as u64 * 4),
                    }),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&self.texture_view),
                },
                wgpu::BindGroupEntry { binding: 5, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                buffer(6, &self.material),
            ],
        });
    }

    /// Takes the control points from `wind`'s storage buffer from now on (the wind's
    /// branches must be the records, in order: [`branch_records`] of the curves the rig
    /// was made from). Fails where the branch counts differ.
    pub fn use_wind(&mut self, wind: &GpuWind) -> Result<(), GpuError> {
        if wind.len() != self.count {
            return Err(GpuError::Invalid(format!(
                "the wind has {} branches, the renderer {} records",
                wind.len(),
                self.count
            )));
        }
        self.bind_points(wind.points_buffer());
        Ok(())
    }

    /// Takes the control points from `points` (4 × `vec4<f32>` per record, xyz used) from
    /// now on.
    pub fn use_points(&mut self, points: &wgpu::Buffer) -> Result<(), GpuError> {
        let need = self.count as u64 * 64;
        if points.size() < need {
            return Err(GpuError::Invalid(format!(
                "a points buffer of {} bytes; {need} needed",
                points.size()
            )));
        }
        self.bind_points(points);
        Ok(())
    }

    /// Goes back to the records' own (rest) control points.
    pub fn use_rest_points(&mut self) {
        let rest = self.rest.clone();
        self.bind_points(&rest);
    }

    /// Number of branch records.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether there is no branch.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The LOD grids (one shared vertex buffer, one index range per level).
    pub fn grids(&self) -> &Grids {
        &self.grids
    }

    /// Writes the camera and light used by the next [`BranchRenderer::prepare`] and
    /// [`BranchRenderer::draw`].
    pub fn set_frame(&self, frame: &Frame) {
        self.gpu.queue.write_buffer(&self.frame, 0, bytemuck::bytes_of(frame));
    }

    /// Sets how levels are chosen.
    pub fn set_lod(&self, settings: &LodSettings) {
        let p = lod_params(settings, self.count, self.region_words, self.grids.lods.len() as u32);
        self.gpu.queue.write_buffer(&self.lod_params, 0, bytemuck::bytes_of(&p));
    }

    /// Records the LOD selection pass into `encoder` (call once per frame, after the wind
    /// step and before the render pass that [`BranchRenderer::draw`]s).
    pub fn prepare(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("branch lod"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.frame_group, &[]);
        pass.set_bind_group(1, &self.lod_group, &[]);
        pass.set_pipeline(&self.lod_reset);
        pass.dispatch_workgroups(1, 1, 1);
        if self.count > 0 {
            pass.set_pipeline(&self.lod_select);
            let (x, y) = workgroups(self.count as u32);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// Draws every level's branches (one indirect instanced draw per level) into `pass`,
    /// whose attachments must match the [`TargetFormat`] given at creation.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.draw_pipeline);
        pass.set_bind_group(0, &self.frame_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        for level in 0..self.grids.lods.len() as u32 {
            pass.set_bind_group(1, &self.draw_group, &[level * self.region_words * 4]);
            pass.draw_indexed_indirect(&self.indirect, level as u64 * 20);
        }
    }

    /// The branch count of each level after the last [`BranchRenderer::prepare`], read
    /// back (waits for the GPU).
    pub fn lod_counts(&self) -> Vec<u32> {
        let args = self.gpu.read_buffer::<u32>(&self.indirect, 5 * self.grids.lods.len());
        args.chunks_exact(5).map(|a| a[1]).collect()
    }

    /// Vertices the last frame's draws run: Σ over levels of instances × grid vertices.
    pub fn vertices_drawn(&self) -> u64 {
        self.lod_counts().iter().zip(&self.grids.lods).map(|(&n, l)| n as u64 * l.vertex_count as u64).sum()
    }

    /// The branch ids level `level` drew after the last [`BranchRenderer::prepare`] (in
    /// the order the GPU appended them), read back.
    pub fn lod_ids(&self, level: usize) -> Vec<u32> {
        let n = self.lod_counts()[level] as usize;
        let all = self.gpu.read_buffer::<u32>(&self.ids, (level + 1) * self.region_words as usize);
        all[level * self.region_words as usize..][..n].to_vec()
    }

    /// Runs the drawing vertex shader's deformation (`branch_vertex`, the instance →
    /// branch id mapping included) for branches `ids` over level `level`'s grid, and
    /// captures each vertex's position and normal by drawing it as a point into a pair of
    /// `Rgba32Float` targets: per id, the level's vertices in order. Overwrites level
    /// `level`'s id list (the next [`BranchRenderer::prepare`] rewrites it). For tests.
    pub fn capture(&self, level: usize, ids: &[u32]) -> Vec<(Vec3, Vec3)> {
        let l = self.grids.lods[level];
        let total = ids.len() as u32 * l.vertex_count;
        if total == 0 {
            return Vec::new();
        }
        assert!(ids.len() <= self.region_words as usize, "more ids than branches");
        let offset = level as u64 * self.region_words as u64 * 4;
        self.gpu.queue.write_buffer(&self.ids, offset, bytemuck::cast_slice(ids));
        let width = total.min(1024);
        let height = total.div_ceil(width);
        let params =
            self.gpu.storage_buffer("capture range", &[[l.first_vertex, l.vertex_count, width, height]]);
        let capture_group = self.gpu.bind_buffers("branch capture", &self.capture_layout, &[&params]);
        let target = |label| {
            let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
            crate::gpu::texture_2d(&self.gpu.device, label, (width, height), 1, CAPTURE_FORMAT, usage)
        };
        let (pos_tex, nor_tex) = (target("capture positions"), target("capture normals"));
        let (pos_view, nor_view) =
            (pos_tex.create_view(&Default::default()), nor_tex.create_view(&Default::default()));
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        {
            let attach = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("branch capture"),
                color_attachments: &[attach(&pos_view), attach(&nor_view)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.capture_pipeline);
            pass.set_bind_group(0, &self.frame_group, &[]);
            pass.set_bind_group(1, &self.draw_group, &[level as u32 * self.region_words * 4]);
            pass.set_bind_group(2, &capture_group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.draw(l.first_vertex..l.first_vertex + l.vertex_count, 0..ids.len() as u32);
        }
        // Texel i of the capture is vertex i (row-major); past `total` the rows are empty.
        let texels = |encoder, tex: &wgpu::Texture| -> Vec<Vec3> {
            let (device, queue) = (&self.gpu.device, &self.gpu.queue);
            let raw = crate::gpu::read_texture(device, queue, encoder, tex, (width, height), 16);
            let texel = |t: &[u8]| bytemuck::pod_read_unaligned::<[f32; 4]>(t);
            raw.chunks_exact(16).take(total as usize).map(|t| Vec3::from_slice(&texel(t)[..3])).collect()
        };
        let positions = texels(encoder, &pos_tex);
        let normals = texels(self.gpu.device.create_command_encoder(&Default::default()), &nor_tex);
        positions.into_iter().zip(normals).collect()
    }
}

/// A buffer of `usage` holding `bytes`.
fn buffer_init(gpu: &Gpu, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage,
    })
}

/// The capture targets' format.
const CAPTURE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

fn lod_params(s: &LodSettings, count: usize, region_words: u32, levels: u32) -> LodParams {
    LodParams {
        thresholds: [s.thresholds[0], s.thresholds[1], s.thresholds[2], if s.cull { 1.0 } else { 0.0 }],
        counts: [count as u32, region_words, levels, 0],
    }
}

/// An offscreen colour + depth target of one size and [`TargetFormat`], with a
/// single-sample resolve texture when multisampled: what the benchmark and tests draw
/// into.
#[derive(Debug)]
pub struct Offscreen {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The formats.
    pub format: TargetFormat,
    color: wgpu::TextureView,
    resolve: Option<wgpu::TextureView>,
    resolved: wgpu::Texture,
    depth: wgpu::TextureView,
}

impl Offscreen {
    /// The textures of a `width` × `height` target.
    pub fn new(gpu: &Gpu, width: u32, height: u32, format: TargetFormat) -> Offscreen {
        let make = |label, fmt, samples, usage| {
            crate::gpu::texture_2d(&gpu.device, label, (width, height), samples, fmt, usage)
        };
        let attach = wgpu::TextureUsages::RENDER_ATTACHMENT;
        let resolved = make("offscreen colour", format.color, 1, attach | wgpu::TextureUsages::COPY_SRC);
        let (color, resolve) = if format.samples > 1 {
            let ms = make("offscreen msaa colour", format.color, format.samples, attach);
            (ms.create_view(&Default::default()), Some(resolved.create_view(&Default::default())))
        } else {
            (resolved.create_view(&Default::default()), None)
        };
        let depth =
            make("offscreen depth", format.depth, format.samples, attach).create_view(&Default::default());
        Offscreen { width, height, format, color, resolve, resolved, depth }
    }

    /// Begins a render pass that clears to `clear` (linear rgb) and depth 1.
    pub fn begin<'e>(&self, encoder: &'e mut wgpu::CommandEncoder, clear: [f64; 3]) -> wgpu::RenderPass<'e> {
        crate::gpu::begin_colour_depth_pass(
            encoder,
            "offscreen",
            (&self.color, self.resolve.as_ref()),
            &self.depth,
            wgpu::Color { r: clear[0], g: clear[1], b: clear[2], a: 1.0 },
            wgpu::StoreOp::Store,
        )
    }

    /// The resolved colour as tightly packed RGBA8 rows, top row first (waits for the
    /// GPU; the colour format must have 4 bytes per pixel).
    pub fn read_rgba(&self, gpu: &Gpu) -> Vec<u8> {
        let encoder = gpu.device.create_command_encoder(&Default::default());
        crate::gpu::read_texture(
            &gpu.device,
            &gpu.queue,
            encoder,
            &self.resolved,
            (self.width, self.height),
            4,
        )
    }
}
