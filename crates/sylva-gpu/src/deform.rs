//! The GPU branch deformer (issue 25 item 1; Skjermo2008 D §2–§3.5, Skjermo2008-spec §3 and §10
//! property 19): `deform.wgsl` ports the engine's CPU reference [`sylva::deform`] line for
//! line, and [`GpuDeformer`] runs it as a compute pass over a list of (branch, v, θ)
//! samples, reading the positions and normals back: what the property 19 test compares
//! with [`sylva::deform::deform`]. The same WGSL functions (everything above the compute
//! entry's marker, [`shared_wgsl`]) feed the instanced vertex shader of
//! [`crate::branches::BranchRenderer`].
//!
//! ```text
//!  BranchRecord (112 B, sylva::deform) ──► records  storage, read
//!  control points (4 × vec4 per branch) ──► points   storage, read (GpuWind's layout)
//!  DeformSample (branch, v, θ)          ──► samples  storage, read
//!                                       ◄── out      position (w = 1), normal (w = 0)
//! ```
//!
//! The control points are a separate buffer so the wind's points (its
//! [`crate::GpuWind::points_buffer`], 4 × `vec4<f32>` per branch in rig order, which is
//! [`sylva::deform::branch_records`]' order) replace the records' rest pose without a
//! copy; [`rest_points`] builds that buffer from the records themselves.

use crate::gpu::{storage_entry, workgroups, Gpu};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sylva::deform::BranchRecord;

/// The WGSL source: the shared deformer functions, the marker, the sample pass.
pub const DEFORM_WGSL: &str = include_str!("deform.wgsl");

/// The line that ends the shared part of [`DEFORM_WGSL`].
pub const COMPUTE_MARKER: &str = "// ---- compute entry ----";

/// The deformer's WGSL functions and structs (`BranchRecord`, `Cubic`, `deform_at`, …)
/// without any binding or entry point: the part of [`DEFORM_WGSL`] before
/// [`COMPUTE_MARKER`], for other shaders to prepend.
pub fn shared_wgsl() -> &'static str {
    DEFORM_WGSL.split_once(COMPUTE_MARKER).map_or(DEFORM_WGSL, |(shared, _)| shared)
}

/// One sample for [`GpuDeformer::deform`]: a branch (index into the records) and a
/// grid point (v, θ). 16 bytes, WGSL `struct Sample { branch: u32, v: f32, theta: f32,
/// pad: u32 }`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct DeformSample {
    /// Index of the record.
    pub branch: u32,
    /// Position along the branch in \[0, 1\].
    pub v: f32,
    /// Angle around the branch (radians).
    pub theta: f32,
    /// Padding (0).
    pub pad: u32,
}

impl DeformSample {
    /// The sample of `branch` at (v, θ).
    pub fn new(branch: u32, v: f32, theta: f32) -> DeformSample {
        DeformSample { branch, v, theta, pad: 0 }
    }
}

/// The records as the GPU reads them: 28 `u32` words each ([`BranchRecord::to_words`]).
pub fn record_words(records: &[BranchRecord]) -> Vec<u32> {
    records.iter().flat_map(|r| r.to_words()).collect()
}

/// The records' control points in the wind's layout: 4 × `[x, y, z, 0]` per record.
pub fn rest_points(records: &[BranchRecord]) -> Vec<[f32; 4]> {
    records.iter().flat_map(|r| r.points().map(|p| [p.x, p.y, p.z, 0.0])).collect()
}

/// The deformer's sample pass on a GPU.
#[derive(Debug)]
pub struct GpuDeformer {
    gpu: Gpu,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl GpuDeformer {
    /// Compiles `deform.wgsl`'s `deform_samples` entry point.
    pub fn new(gpu: &Gpu) -> GpuDeformer {
        let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("deform"),
            source: wgpu::ShaderSource::Wgsl(DEFORM_WGSL.into()),
        });
        let layout = gpu.bind_group_layout(
            "deform",
            &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, false),
            ],
        );
        let pipeline = gpu.compute_pipeline(&module, "deform_samples", &[&layout]);
        GpuDeformer { gpu: gpu.clone(), layout, pipeline }
    }

    /// Position and outward unit normal of every sample, the records' own control points
    /// deformed.
    pub fn deform(&self, records: &[BranchRecord], samples: &[DeformSample]) -> Vec<(Vec3, Vec3)> {
        let points = self.gpu.storage_buffer("deform points", &rest_points(records));
        self.deform_with_points(records, &points, samples)
    }

    /// Position and outward unit normal of every sample, with the control points taken
    /// from `points` (4 × `vec4<f32>` per record, e.g. [`crate::GpuWind::points_buffer`]).
    /// Every sample's branch must index `records`.
    pub fn deform_with_points(
        &self,
        records: &[BranchRecord],
        points: &wgpu::Buffer,
        samples: &[DeformSample],
    ) -> Vec<(Vec3, Vec3)> {
        if samples.is_empty() {
            return Vec::new();
        }
        assert!(
            samples.iter().all(|s| (s.branch as usize) < records.len()),
            "a sample names a branch past the {} records",
            records.len()
        );
        let gpu = &self.gpu;
        let records = gpu.storage_buffer("deform records", &record_words(records));
        let samples_buf = gpu.storage_buffer("deform samples", samples);
        let out = gpu.storage_buffer_zeroed("deform out", (samples.len() * 32) as u64);
        let bind = gpu.bind_buffers("deform", &self.layout, &[&records, points, &samples_buf, &out]);
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("deform") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("deform samples"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            let (x, y) = workgroups(samples.len() as u32);
            pass.dispatch_workgroups(x, y, 1);
        }
        gpu.queue.submit([encoder.finish()]);
        let raw = gpu.read_buffer::<[f32; 4]>(&out, samples.len() * 2);
        raw.chunks_exact(2)
            .map(|c| (Vec3::new(c[0][0], c[0][1], c[0][2]), Vec3::new(c[1][0], c[1][1], c[1][2])))
            .collect()
    }
}
