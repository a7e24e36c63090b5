//! The view's composite: the tree's offscreen texture drawn over the view's rectangle by
//! a pipeline of its own inside egui's render pass (an `egui_wgpu` paint callback), not
//! as an egui image.
//!
//! egui draws an image with its general shader: a blended, dithered, filtered sample per
//! pixel. On a software renderer (Mesa's lavapipe) that shader is what a frame of the
//! window costs: the view is most of the window, and every egui frame repaints all of
//! it, whether the tree changed or not. This pipeline draws one triangle over the view
//! with blending off: at full resolution a texel load per pixel (a 1:1 copy, the same
//! bytes egui's image showed), and a bilinear sample only while the view is drawn
//! smaller (adaptive resolution, [`crate::viewport`]).
//!
//! The texture holds sRGB-encoded bytes (the renderer draws it through an sRGB view); a
//! linear framebuffer (egui's default, `Bgra8Unorm`) takes them as they are, an sRGB
//! one (a headless test's) reads them through the texture's sRGB view so that its store
//! encodes them back to the same bytes.

use egui_wgpu::wgpu;

/// The shader: a triangle covering the viewport, a texel load or a bilinear sample.
const SHADER: &str = r#"
struct Out {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> Out {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    var out: Out;
    out.position = vec4<f32>(x, y, 0.0, 1.0);
    out.uv = vec2<f32>((x + 1.0) * 0.5, (1.0 - y) * 0.5);
    return out;
}

@group(0) @binding(0) var view_texture: texture_2d<f32>;
@group(0) @binding(1) var view_sampler: sampler;

@fragment
fn fs_load(in: Out) -> @location(0) vec4<f32> {
    let size = vec2<i32>(textureDimensions(view_texture, 0));
    let texel = clamp(vec2<i32>(floor(in.uv * vec2<f32>(size))), vec2<i32>(0, 0), size - vec2<i32>(1, 1));
    return textureLoad(view_texture, texel, 0);
}

@fragment
fn fs_sample(in: Out) -> @location(0) vec4<f32> {
    return textureSample(view_texture, view_sampler, in.uv);
}
"#;

/// The two pipelines (load, sample) for egui's framebuffer format, and their layout.
pub struct Composite {
    load: wgpu::RenderPipeline,
    sample: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    srgb_target: bool,
}

impl std::fmt::Debug for Composite {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Composite").field("srgb_target", &self.srgb_target).finish_non_exhaustive()
    }
}

impl Composite {
    /// The pipelines for egui's pass on `gpu`: its framebuffer format, one sample (the
    /// editor asks eframe for no multisampling; egui_kittest's harness has none), no
    /// depth.
    pub fn new(gpu: &egui_wgpu::RenderState) -> Composite {
        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("sylva-edit view composite"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sylva-edit view composite"),
            entries: &sylva_gpu::gpu::texture_sampler_entries(0, wgpu::ShaderStages::FRAGMENT),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("sylva-edit view composite"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("sylva-edit view composite"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: gpu.target_format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("sylva-edit view composite"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Composite {
            load: pipeline("fs_load"),
            sample: pipeline("fs_sample"),
            layout,
            sampler,
            srgb_target: gpu.target_format.is_srgb(),
        }
    }

    /// The bind group of a view texture made with `Rgba8Unorm` and an `srgb` view format:
    /// read raw for a linear framebuffer, through the sRGB view for an sRGB one.
    pub fn bind(
        &self,
        device: &wgpu::Device,
        texture: &wgpu::Texture,
        srgb: wgpu::TextureFormat,
    ) -> wgpu::BindGroup {
        let format = self.srgb_target.then_some(srgb);
        let view = texture.create_view(&wgpu::TextureViewDescriptor { format, ..Default::default() });
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("sylva-edit view composite"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        })
    }

    /// The paint callback drawing `bind_group`'s texture over `rect`: a texel per pixel
    /// when `one_to_one` (the texture has the rectangle's size in pixels), else
    /// bilinear.
    pub fn paint(
        &self,
        rect: egui::Rect,
        bind_group: wgpu::BindGroup,
        one_to_one: bool,
    ) -> egui::PaintCallback {
        let pipeline = if one_to_one { self.load.clone() } else { self.sample.clone() };
        egui_wgpu::Callback::new_paint_callback(rect, Paint { pipeline, bind_group })
    }
}

/// One composite draw, run inside egui's render pass (its viewport is the view's
/// rectangle, its scissor the clip).
struct Paint {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl egui_wgpu::CallbackTrait for Paint {
    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        _resources: &egui_wgpu::CallbackResources,
    ) {
        render_pass.set_pipeline(&self.pipeline);
        render_pass.set_bind_group(0, &self.bind_group, &[]);
        render_pass.draw(0..3, 0..1);
    }
}
