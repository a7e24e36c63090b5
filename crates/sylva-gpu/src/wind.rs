//! GPU wind (issue 25 item 2; Skjermo2008 Th §3.2.1 and §4.3; Skjermo2008-spec §4, properties 20–24):
//! the engine's [`WindRig`] stepped by a WGSL compute shader (`wind.wgsl`), control
//! points kept in a storage buffer the branch deformer will read.
//!
//! The formulation is the engine's, step for step ([`sylva::wind`]): the parent-carried
//! rest pose at the attach parameter (with the rest offset of P₀ carried too), the force
//! field of sines sampled at the tip in (x, z), targets `P̂ₖ + wₖ κ (L²/H) F`, relaxation
//! β, rest lengths re-projected, joint angles clamped below [`MAX_JOINT_DEG`]. One
//! [`WindOptions`] drives both.
//!
//! ```text
//!  WindRig ──► branches (rest, parent, order, depth, attach, reach)   storage, read
//!          ──► points (4 × vec4 per branch)                           storage, read_write
//!          ──► level order (branch ids sorted by depth) + one range per level
//!  WindOptions ──► waves (D, A, ω, phase of this step), stiffness   storage, read
//!              ──► params (W̄, impulse, wₖ, β, joint limit, lag)     storage, read
//!  step(dt): no lag      one dispatch per depth level, 0 → max, parents first
//!            legacy lag  copy points → prev, one dispatch over all branches reading prev
//! ```
//!
//! Precision: the GPU works in f32 against the CPU's f64. Time is kept in f64 on the
//! host and each wave's phase `φᵢ t` is reduced modulo 2π there, so long runs do not
//! lose the sines' accuracy; the rest leg lengths and joint angles are recomputed in the
//! shader from the rest points (the engine keeps its own private), so zero wind is the
//! rest pose bit for bit on the GPU too. After 1,000 `storm` steps the GPU's points
//! stay within 1e-4 of the tree's height of the CPU's (the tests measure it).

use crate::gpu::{dynamic_storage_entry, storage_entry, workgroups, Gpu};
use bytemuck::{Pod, Zeroable};
use glam::{DVec2, DVec3};
use std::collections::VecDeque;
use sylva::wind::{WindOptions, WindRig, MAX_JOINT_DEG};

/// One branch as the shader reads it (96 bytes, std430).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct GpuBranch {
    /// Rest control points (xyz, w = 0).
    pub rest: [[f32; 4]; 4],
    /// Parent branch (`u32::MAX` for a root), branch order, depth, 0.
    pub ids: [u32; 4],
    /// Attach parameter on the parent, reach `L²/H`, 0, 0.
    pub shape: [f32; 4],
}

/// One wave as the shader reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuWave {
    a: [f32; 4],
    b: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    mean_impulse: [f32; 4],
    weights: [f32; 4],
    beta_joint: [f32; 4],
    counts: [u32; 4],
}

/// The parent id the shader reads for a root.
pub const NO_BRANCH: u32 = u32::MAX;

/// The rig's branches in the shader's layout.
pub fn gpu_branches(rig: &WindRig) -> Vec<GpuBranch> {
    rig.branches
        .iter()
        .map(|b| GpuBranch {
            rest: b.rest.map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0]),
            ids: [b.parent.map_or(NO_BRANCH, |p| p as u32), b.order as u32, b.depth, 0],
            shape: [b.attach as f32, b.reach as f32, 0.0, 0.0],
        })
        .collect()
}

/// The branch ids sorted by depth (stable) and each level's `(offset, count)` in it.
pub fn depth_levels(rig: &WindRig) -> (Vec<u32>, Vec<(u32, u32)>) {
    let mut order: Vec<u32> = (0..rig.branches.len() as u32).collect();
    order.sort_by_key(|&i| rig.branches[i as usize].depth);
    let mut levels: Vec<(u32, u32)> = Vec::new();
    for (k, &i) in order.iter().enumerate() {
        let d = rig.branches[i as usize].depth as usize;
        if d >= levels.len() {
            levels.resize(d + 1, (k as u32, 0));
        }
        levels[d].1 += 1;
    }
    (order, levels)
}

/// A [`WindRig`] on the GPU: its control points live in [`GpuWind::points_buffer`] and
/// advance with [`GpuWind::step`].
#[derive(Debug)]
pub struct GpuWind {
    gpu: Gpu,
    wind: WindOptions,
    time: f64,
    count: usize,
    /// `(offset, count)` of each depth level in the level order.
    levels: Vec<(u32, u32)>,
    /// Byte stride between consecutive ranges in `ranges` (the storage offset alignment).
    range_stride: u32,
    /// Rest points, 4 per branch, as uploaded (for [`GpuWind::reset`]).
    rest: Vec<[f32; 4]>,
    branches: wgpu::Buffer,
    points: wgpu::Buffer,
    prev: wgpu::Buffer,
    order: wgpu::Buffer,
    ranges: wgpu::Buffer,
    waves: wgpu::Buffer,
    stiffness: wgpu::Buffer,
    params: wgpu::Buffer,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: wgpu::BindGroup,
    /// Submitted steps not yet known finished, oldest first.
    in_flight: VecDeque<wgpu::SubmissionIndex>,
}

/// Steps submitted ahead of the GPU at most: [`GpuWind::step`] waits for older ones, so
/// thousands of steps in a row do not pile up staging memory (a software adapter runs far
/// behind the CPU).
pub const MAX_IN_FLIGHT: usize = 3;

impl GpuWind {
    /// Uploads `rig` (its branches and current points; its clock is kept) and `wind`.
    pub fn new(gpu: &Gpu, rig: &WindRig, wind: &WindOptions) -> GpuWind {
        let count = rig.branches.len();
        let branch_data = gpu_branches(rig);
        let rest: Vec<[f32; 4]> = branch_data.iter().flat_map(|b| b.rest).collect();
        let points: Vec<[f32; 4]> =
            rig.points.iter().flat_map(|p| p.map(|x| [x.x as f32, x.y as f32, x.z as f32, 0.0])).collect();
        let (order, levels) = depth_levels(rig);
        // One range per level, then one over every branch (legacy lag), each in a slot
        // aligned for a dynamic storage offset.
        let stride = gpu.device.limits().min_storage_buffer_offset_alignment.max(8);
        let words = stride as usize / 4;
        let mut ranges = vec![0u32; (levels.len() + 1) * words];
        for (k, &(offset, n)) in levels.iter().chain([(0, count as u32)].iter()).enumerate() {
            ranges[k * words] = offset;
            ranges[k * words + 1] = n;
        }
        let (waves, stiffness) = wave_data(wind, rig.time);
        let module = gpu.device.create_shader_module(wgpu::include_wgsl!("wind.wgsl"));
        let layout = gpu.bind_group_layout(
            "wind",
            &[
                storage_entry(0, true),
                storage_entry(1, false),
                storage_entry(2, true),
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, true),
                storage_entry(6, true),
                dynamic_storage_entry(7),
            ],
        );
        let pipeline = gpu.compute_pipeline(&module, "wind_step", &[&layout]);
        let branches = gpu.storage_buffer("wind branches", &branch_data);
        let points_buf = gpu.storage_buffer("wind points", &points);
        let prev = gpu.storage_buffer("wind previous points", &points);
        let order = gpu.storage_buffer("wind level order", &order);
        let ranges = gpu.storage_buffer("wind level ranges", &ranges);
        let waves_buf = gpu.storage_buffer("wind waves", &waves);
        let stiffness_buf = gpu.storage_buffer("wind stiffness", &stiffness);
        let params = gpu.storage_buffer("wind params", &[params(wind, count, DVec2::ZERO, waves.len())]);
        let bind_group = bind(
            gpu,
            &layout,
            [&branches, &points_buf, &prev, &order, &waves_buf, &stiffness_buf, &params],
            &ranges,
        );
        GpuWind {
            gpu: gpu.clone(),
            wind: wind.clone(),
            time: rig.time,
            count,
            levels,
            range_stride: stride,
            rest,
            branches,
            points: points_buf,
            prev,
            order,
            ranges,
            waves: waves_buf,
            stiffness: stiffness_buf,
            params,
            pipeline,
            layout,
            bind_group,
            in_flight: VecDeque::new(),
        }
    }

    /// Replaces the wind (waves, mean, stiffness, γ, β and lag mode); the points and the
    /// clock stay.
    pub fn set_options(&mut self, wind: &WindOptions) {
        let (waves, stiffness) = wave_data(wind, self.time);
        let fits = |data: &[u8], buffer: &wgpu::Buffer| data.len() as u64 <= buffer.size();
        if !fits(bytemuck::cast_slice(&waves), &self.waves)
            || !fits(bytemuck::cast_slice(&stiffness), &self.stiffness)
        {
            self.waves = self.gpu.storage_buffer("wind waves", &waves);
            self.stiffness = self.gpu.storage_buffer("wind stiffness", &stiffness);
            self.bind_group = bind(
                &self.gpu,
                &self.layout,
                [
                    &self.branches,
                    &self.points,
                    &self.prev,
                    &self.order,
                    &self.waves,
                    &self.stiffness,
                    &self.params,
                ],
                &self.ranges,
            );
        }
        self.wind = wind.clone();
    }

    /// The wind in use.
    pub fn options(&self) -> &WindOptions {
        &self.wind
    }

    /// Seconds simulated.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Number of branches.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the rig has no branch.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Number of depth levels: dispatches per step without lag.
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// The control points: 4 × `vec4<f32>` per branch (xyz, w = 0), in rig order. The
    /// branch deformer reads it.
    pub fn points_buffer(&self) -> &wgpu::Buffer {
        &self.points
    }

    /// Advances the wind by `dt` seconds (no impulse).
    pub fn step(&mut self, dt: f64) {
        self.step_with_impulse(dt, DVec2::ZERO);
    }

    /// Advances the wind by `dt` seconds, adding `impulse` to the force on the roots
    /// (depth 0) for this step only, as [`WindRig::step`] does. Submits the work and
    /// returns without waiting.
    pub fn step_with_impulse(&mut self, dt: f64, impulse: DVec2) {
        self.time += dt;
        if self.count == 0 {
            return;
        }
        let (waves, stiffness) = wave_data(&self.wind, self.time);
        let q = &self.gpu.queue;
        q.write_buffer(&self.waves, 0, bytemuck::cast_slice(&waves));
        q.write_buffer(&self.stiffness, 0, bytemuck::cast_slice(&stiffness));
        q.write_buffer(
            &self.params,
            0,
            bytemuck::bytes_of(&params(&self.wind, self.count, impulse, waves.len())),
        );
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("wind step") });
        if self.wind.legacy_lag {
            encoder.copy_buffer_to_buffer(&self.points, 0, &self.prev, 0, None);
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("wind"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipeline);
            let ranges: Vec<(usize, u32)> = if self.wind.legacy_lag {
                vec![(self.levels.len(), self.count as u32)]
            } else {
                self.levels.iter().enumerate().map(|(k, &(_, n))| (k, n)).collect()
            };
            for (slot, n) in ranges {
                pass.set_bind_group(0, &self.bind_group, &[slot as u32 * self.range_stride]);
                let (x, y) = workgroups(n);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        self.in_flight.push_back(q.submit([encoder.finish()]));
        while self.in_flight.len() > MAX_IN_FLIGHT {
            let oldest = self.in_flight.pop_front();
            let wait = wgpu::PollType::Wait { submission_index: oldest, timeout: None };
            self.gpu.device.poll(wait).expect("device poll");
        }
    }

    /// Puts every branch back at rest and the clock at zero.
    pub fn reset(&mut self) {
        self.time = 0.0;
        self.gpu.queue.write_buffer(&self.points, 0, bytemuck::cast_slice(&self.rest));
    }

    /// The current control points, read back (waits for the submitted steps).
    pub fn points(&self) -> Vec<[DVec3; 4]> {
        let raw = self.gpu.read_buffer::<[f32; 4]>(&self.points, self.count * 4);
        raw.chunks_exact(4)
            .map(|c| [0, 1, 2, 3].map(|k| DVec3::new(c[k][0] as f64, c[k][1] as f64, c[k][2] as f64)))
            .collect()
    }

    /// Blocks until the submitted steps are done (for timing).
    pub fn finish(&self) {
        self.gpu.wait();
    }
}

/// The bind group of `wind.wgsl`: the seven buffers of bindings 0–6 and the level
/// ranges (binding 7, one 8-byte range at a dynamic offset).
fn bind(
    gpu: &Gpu,
    layout: &wgpu::BindGroupLayout,
    buffers: [&wgpu::Buffer; 7],
    ranges: &wgpu::Buffer,
) -> wgpu::BindGroup {
    let mut entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
        .collect();
    entries.push(wgpu::BindGroupEntry {
        binding: 7,
        resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: ranges,
            offset: 0,
            size: wgpu::BufferSize::new(8),
        }),
    });
    gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("wind"),
        layout,
        entries: &entries,
    })
}

/// The waves with their phases at time `t`, and the stiffness table (never empty).
fn wave_data(wind: &WindOptions, t: f64) -> (Vec<GpuWave>, Vec<f32>) {
    let waves = wind
        .waves
        .iter()
        .map(|w| {
            let d = w.direction.normalize_or_zero();
            let omega = std::f64::consts::TAU / w.wavelength.max(1e-9);
            let phase = (w.speed * omega * t).rem_euclid(std::f64::consts::TAU);
            GpuWave {
                a: [d.x as f32, d.y as f32, w.amplitude as f32, omega as f32],
                b: [phase as f32, 0.0, 0.0, 0.0],
            }
        })
        .collect();
    let stiffness = if wind.stiffness.is_empty() {
        vec![1.0]
    } else {
        wind.stiffness.iter().map(|&k| k as f32).collect()
    };
    (waves, stiffness)
}

fn params(wind: &WindOptions, count: usize, impulse: DVec2, waves: usize) -> Params {
    let stiffness = wind.stiffness.len().max(1);
    Params {
        mean_impulse: [wind.mean.x as f32, wind.mean.y as f32, impulse.x as f32, impulse.y as f32],
        weights: [0, 1, 2, 3].map(|k| wind.weight(k) as f32),
        beta_joint: [wind.beta as f32, MAX_JOINT_DEG.to_radians() as f32, 0.0, 0.0],
        counts: [waves as u32, stiffness as u32, count as u32, wind.legacy_lag as u32],
    }
}

/// `count` copies of `rig` on a square grid `spacing` metres apart in (x, z), parents
/// first within each copy: a forest of identical trees for benchmarks and instanced
/// scenes. Each copy keeps its tree's own force scale (`reach` uses the tree's height).
pub fn forest(rig: &WindRig, count: usize, spacing: f64) -> WindRig {
    let side = (count as f64).sqrt().ceil().max(1.0) as usize;
    let n = rig.branches.len();
    let mut out = WindRig {
        branches: Vec::with_capacity(n * count),
        points: Vec::with_capacity(n * count),
        time: rig.time,
    };
    for c in 0..count {
        let shift = DVec3::new((c % side) as f64 * spacing, 0.0, (c / side) as f64 * spacing);
        for (b, p) in rig.branches.iter().zip(&rig.points) {
            let mut b = b.clone();
            b.parent = b.parent.map(|q| q + c * n);
            b.rest = b.rest.map(|x| x + shift);
            out.branches.push(b);
            out.points.push(p.map(|x| x + shift));
        }
    }
    out
}
