//! The headless GPU context ([`Gpu`]): adapter, device and queue, storage and uniform
//! buffers, readback, and the test gate ([`Gpu::or_skip`]) that lets `cargo test` pass on
//! a machine with no adapter (issue 25: "GPU tests skip with a printed reason there";
//! `SYLVA_REQUIRE_GPU=1` makes them mandatory, as `.ci/run` sets it).
//!
//! Any adapter will do, software ones included: Mesa's lavapipe (Vulkan on the CPU) runs
//! every test and bench where no real GPU is present, so adapter selection prefers a
//! high-performance adapter, then any other, then the fallback (CPU) adapter. Set
//! `SYLVA_GPU_ADAPTER` to a part of an adapter's name to pick it among several (e.g.
//! `llvmpipe` on a machine with a GPU), and `WGPU_BACKEND` to restrict the backends.

use bytemuck::Pod;
use std::fmt;
use wgpu::util::DeviceExt;

/// Environment variable that turns a missing adapter into a test failure.
pub const REQUIRE_GPU_ENV: &str = "SYLVA_REQUIRE_GPU";

/// Environment variable naming (a case-insensitive part of) the adapter to use.
pub const ADAPTER_ENV: &str = "SYLVA_GPU_ADAPTER";

/// Threads per workgroup of every compute shader in the crate (each WGSL file declares
/// `@workgroup_size(64)`).
pub const WORKGROUP: u32 = 64;

/// Why no GPU context could be made.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum GpuError {
    /// No adapter at all (no Vulkan driver, no software fallback), or none matching
    /// `SYLVA_GPU_ADAPTER`.
    NoAdapter(String),
    /// An adapter was found but refused a device.
    Device(String),
    /// A request the GPU code cannot serve (a level of 0, a buffer over the device's
    /// limits), with what and why.
    Invalid(String),
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::NoAdapter(why) => write!(
                f,
                "no GPU adapter: {why} (install a Vulkan driver; on Debian `apt-get install mesa-vulkan-drivers` gives the software one, lavapipe)"
            ),
            GpuError::Device(why) => write!(f, "the GPU adapter refused a device: {why}"),
            GpuError::Invalid(why) => write!(f, "{why}"),
        }
    }
}

impl std::error::Error for GpuError {}

/// A headless wgpu device and its queue, with the adapter it came from.
#[derive(Debug, Clone)]
pub struct Gpu {
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The logical device (created with the adapter's own limits, so large storage
    /// buffers fit).
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

/// Whether `SYLVA_REQUIRE_GPU` asks for GPU tests to be mandatory (set and not `0`).
pub fn gpu_required() -> bool {
    std::env::var(REQUIRE_GPU_ENV).is_ok_and(|v| !v.is_empty() && v != "0")
}

impl Gpu {
    /// Opens the best adapter present (see the [module docs](self)) and a device on it.
    pub fn new() -> Result<Gpu, GpuError> {
        pollster::block_on(Gpu::open())
    }

    async fn open() -> Result<Gpu, GpuError> {
        let desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let adapter = match std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty()) {
            Some(want) => {
                let all = instance.enumerate_adapters(backends).await;
                let names: Vec<String> = all.iter().map(|a| a.get_info().name).collect();
                all.into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&want.to_lowercase()))
                    .ok_or_else(|| {
                        GpuError::NoAdapter(format!("{ADAPTER_ENV}={want} matches none of {names:?}"))
                    })?
            }
            None => {
                let ask = |force_fallback_adapter| wgpu::RequestAdapterOptions {
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    force_fallback_adapter,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                };
                match instance.request_adapter(&ask(false)).await {
                    Ok(a) => a,
                    Err(first) => instance.request_adapter(&ask(true)).await.map_err(|e| {
                        let (first, e) = (first.to_string(), e.to_string());
                        GpuError::NoAdapter(if first == e {
                            e
                        } else {
                            format!("{first}; fallback adapter: {e}")
                        })
                    })?,
                }
            }
        };
        let info = adapter.get_info();
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("sylva-gpu"),
                required_features: wgpu::Features::empty(),
                required_limits: adapter.limits(),
                experimental_features: wgpu::ExperimentalFeatures::disabled(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GpuError::Device(format!("{} ({:?}): {e}", info.name, info.backend)))?;
        Ok(Gpu { adapter, device, queue, info })
    }

    /// A context for a test or bench named `what`: `None` (after printing why the test is
    /// skipped, visibly even under the test harness's output capture) where no adapter
    /// exists, unless `SYLVA_REQUIRE_GPU=1`, which panics
    /// instead. Prints the adapter's name when one is found.
    pub fn or_skip(what: &str) -> Option<Gpu> {
        match Gpu::new() {
            Ok(gpu) => {
                eprintln!("{what}: on {}", gpu.describe());
                Some(gpu)
            }
            Err(e) if gpu_required() => panic!("{what}: {e} ({REQUIRE_GPU_ENV} is set)"),
            Err(e) => {
                // Written to the process's stderr directly, past the test harness's capture,
                // so the reason shows although the skipped test passes.
                use std::io::Write;
                let _ = writeln!(
                    std::io::stderr(),
                    "skipping {what}: {e} (set {REQUIRE_GPU_ENV}=1 to make this a failure)"
                );
                None
            }
        }
    }

    /// The adapter's details (name, backend, driver).
    pub fn info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// The adapter's name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)` for Mesa's lavapipe.
    pub fn adapter_name(&self) -> &str {
        &self.info.name
    }

    /// One line naming the adapter, its kind, backend and driver.
    pub fn describe(&self) -> String {
        let i = &self.info;
        format!("{} ({:?}, {:?}, {} {})", i.name, i.device_type, i.backend, i.driver, i.driver_info)
    }

    /// A storage buffer holding `data` (at least 16 bytes, as an empty binding is
    /// invalid), also a copy source and destination.
    pub fn storage_buffer<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        self.buffer_with(label, bytemuck::cast_slice(data), usage)
    }

    /// An uninitialised (zeroed) storage buffer of `bytes` bytes (at least 16), also a copy
    /// source and destination.
    pub fn storage_buffer_zeroed(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A uniform buffer holding `data`, writable with [`wgpu::Queue::write_buffer`].
    pub fn uniform_buffer<T: Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        self.buffer_with(
            label,
            bytemuck::cast_slice(data),
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        )
    }

    fn buffer_with(&self, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let size = (bytes.len() as u64).max(16).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT) as usize;
        let mut padded;
        let contents = if size == bytes.len() {
            bytes
        } else {
            padded = vec![0u8; size];
            padded[..bytes.len()].copy_from_slice(bytes);
            &padded[..]
        };
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents,
            usage,
        })
    }

    /// Copies the first `count` elements of `buffer` (which must have `COPY_SRC` usage)
    /// back to the CPU, waiting for all work submitted before.
    pub fn read_buffer<T: Pod>(&self, buffer: &wgpu::Buffer, count: usize) -> Vec<T> {
        let bytes = (count * std::mem::size_of::<T>()) as u64;
        if bytes == 0 {
            return Vec::new();
        }
        let size = bytes.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("sylva-gpu readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit([encoder.finish()]);
        let raw = map_read(&self.device, &staging);
        bytemuck::cast_slice::<u8, T>(&raw[..bytes as usize]).to_vec()
    }

    /// Blocks until every submitted command buffer has finished.
    pub fn wait(&self) {
        self.device.poll(wgpu::PollType::wait_indefinitely()).expect("device poll");
    }

    /// A bind group layout of the given entries ([`storage_entry`], [`uniform_entry`]).
    pub fn bind_group_layout(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> wgpu::BindGroupLayout {
        self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries })
    }

    /// A compute pipeline for entry point `entry` of `module` with bind groups 0, 1, …
    /// of `groups`.
    pub fn compute_pipeline(
        &self,
        module: &wgpu::ShaderModule,
        entry: &str,
        groups: &[&wgpu::BindGroupLayout],
    ) -> wgpu::ComputePipeline {
        let refs: Vec<Option<&wgpu::BindGroupLayout>> = groups.iter().map(|&g| Some(g)).collect();
        let layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(entry),
            bind_group_layouts: &refs,
            immediate_size: 0,
        });
        self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&layout),
            module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        })
    }

    /// A bind group of `buffers` bound whole at bindings 0, 1, … of `layout`.
    pub fn bind_buffers(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        buffers: &[&wgpu::Buffer],
    ) -> wgpu::BindGroup {
        bind_whole_buffers(&self.device, label, layout, buffers)
    }
}

/// A bind group of `buffers` bound whole at bindings 0, 1, … of `layout` (for
/// [`Gpu::bind_buffers`] and the renderer, which keeps its own device).
pub(crate) fn bind_whole_buffers(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    buffers: &[&wgpu::Buffer],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
}

/// Maps `staging` (a `MAP_READ` buffer whose copies are submitted) for reading, waits
/// for the GPU and returns its bytes.
pub(crate) fn map_read(device: &wgpu::Device, staging: &wgpu::Buffer) -> Vec<u8> {
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).expect("device poll");
    rx.recv().expect("map callback ran").expect("readback buffer maps");
    let out = slice.get_mapped_range().expect("mapped range").to_vec();
    staging.unmap();
    out
}

/// Submits `encoder` with a copy of `texture` (`width` × `height` texels of
/// `texel_bytes` bytes) appended, waits for the GPU and returns the texels as tightly
/// packed rows, top row first (the copy's rows are padded to wgpu's alignment).
pub(crate) fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mut encoder: wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    (width, height): (u32, u32),
    texel_bytes: u32,
) -> Vec<u8> {
    let (tight, row) =
        (width * texel_bytes, (width * texel_bytes).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT));
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("sylva-gpu texture readback"),
        size: row as u64 * height as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    queue.submit([encoder.finish()]);
    let raw = map_read(device, &staging);
    raw.chunks_exact(row as usize).flat_map(|r| &r[..tight as usize]).copied().collect()
}

/// A 2D texture of `width` × `height` with one mip level and `samples` samples.
pub(crate) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    samples: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Begins a render pass into `color` (resolved into `resolve` where multisampled),
/// cleared to `clear` and then stored as `store` says, with `depth` cleared to 1 and
/// discarded after the pass.
pub(crate) fn begin_colour_depth_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    (color, resolve): (&wgpu::TextureView, Option<&wgpu::TextureView>),
    depth: &wgpu::TextureView,
    clear: wgpu::Color,
    store: wgpu::StoreOp,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: color,
            depth_slice: None,
            resolve_target: resolve,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store },
        })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: wgpu::LoadOp::Clear(1.0),
                store: wgpu::StoreOp::Discard,
            }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A buffer binding of type `ty` seen by the `visibility` stages, bound at a dynamic
/// offset if `dynamic`.
pub fn buffer_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BufferBindingType,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: dynamic, min_binding_size: None },
        count: None,
    }
}

/// A compute-stage storage buffer binding (`read_only`: `var<storage, read>`).
pub fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BufferBindingType::Storage { read_only };
    buffer_entry(binding, wgpu::ShaderStages::COMPUTE, ty, false)
}

/// A compute-stage read-only storage buffer binding bound at a dynamic offset.
pub fn dynamic_storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BufferBindingType::Storage { read_only: true };
    buffer_entry(binding, wgpu::ShaderStages::COMPUTE, ty, true)
}

/// A compute-stage uniform buffer binding, with a dynamic offset if `dynamic`.
pub fn uniform_entry(binding: u32, dynamic: bool) -> wgpu::BindGroupLayoutEntry {
    buffer_entry(binding, wgpu::ShaderStages::COMPUTE, wgpu::BufferBindingType::Uniform, dynamic)
}

/// A filterable 2D float texture at `binding` and its filtering sampler at `binding + 1`,
/// seen by the `visibility` stages (a colour map and how it is sampled). Public for
/// front ends that draw with pipelines of their own on sylva-gpu's device (the editor).
pub fn texture_sampler_entries(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> [wgpu::BindGroupLayoutEntry; 2] {
    [
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        },
        wgpu::BindGroupLayoutEntry {
            binding: binding + 1,
            visibility,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        },
    ]
}

/// Workgroup counts `(x, y)` covering `threads` invocations of [`WORKGROUP`] threads,
/// split over two dimensions where one would pass the 65,535 limit; the shaders flatten
/// them back as `id.x + id.y * num_workgroups.x * 64`.
pub fn workgroups(threads: u32) -> (u32, u32) {
    let groups = threads.div_ceil(WORKGROUP).max(1);
    let x = groups.min(65_535);
    (x, groups.div_ceil(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn workgroups_cover_every_thread() {
        assert_eq!(workgroups(0), (1, 1));
        assert_eq!(workgroups(64), (1, 1));
        assert_eq!(workgroups(65), (2, 1));
        let (x, y) = workgroups(100_000_000);
        assert!(x <= 65_535 && (x as u64) * (y as u64) * 64 >= 100_000_000);
    }
}
