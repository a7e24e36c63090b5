//! GPU PN tessellation (issue 25 item 3; Skjermo2008 Th §3.3.1, §4.4; Skjermo2008-spec §5,
//! properties 25–28): PN triangles and PN quads of a coarse cage evaluated by WGSL compute
//! shaders (`pn.wgsl`) over an instanced (u, v) patch grid, with the engine's rules
//! ([`sylva::refine::pn`]): the ⅓ or ½ edge rule, zero-twist or Theyer (diagonal) quad
//! interiors with their own diagonal rule, linear or quadratic normals, corner normals
//! from the mesh or smooth.
//!
//! ```text
//!  Mesh ──► PnPatches::from_mesh (corners + unit normals as pn_tessellate takes them;
//!           quads stay quads, other faces fan into triangles)
//!       ──► GpuPn::new: upload corners; build pass, one thread per patch → control nets
//!       ──► GpuPn::evaluate(level): eval pass, one thread per patch × grid vertex of
//!           PatchGrid (level L: (L+1)² per quad, (L+1)(L+2)/2 per triangle) → PnSamples
//! ```
//!
//! wgpu has no tessellation stage, so this is Tatarinov's instanced tessellation (spec
//! §5): the grid is the per-vertex data, the patch is the instance. The compute pass
//! writes a storage buffer (what the tests read back); the WGSL functions `eval_triangle`
//! and `eval_quad` serve a vertex shader unchanged (`instance_index` → patch).
//!
//! Boundary points come from the edge's two corners alone, evaluated in an order fixed by
//! the corners' bits (as the CPU does), so patches sharing an edge give bit-identical
//! points (property 27). Everything else is the CPU's f32 arithmetic in the same order;
//! results agree with `pn_tessellate` to within about 1e-6 of the cage's size.

use crate::gpu::{storage_entry, workgroups, Gpu, GpuError};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use sylva::geometry::Mesh;
use sylva::refine::pn::{
    smooth_vertex_normals, EdgeRule, NormalInterpolation, NormalSource, PnOptions, QuadInterior,
};
use sylva::refine::RefineError;

/// One corner of a patch: position and unit (or zero) normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PnCorner {
    /// Position.
    pub position: Vec3,
    /// Unit normal (zero where the mesh gives none).
    pub normal: Vec3,
}

/// A patch of [`PnPatches`]: an index into its triangles or its quads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Patch {
    /// `PnPatches::triangles[i]`.
    Triangle(u32),
    /// `PnPatches::quads[i]`.
    Quad(u32),
}

/// The patches of a cage: PN triangles and PN quads, with the corner data
/// [`sylva::refine::pn::pn_tessellate`] builds them from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PnPatches {
    /// Triangles (corners counter-clockwise).
    pub triangles: Vec<[PnCorner; 3]>,
    /// Quads (corners counter-clockwise).
    pub quads: Vec<[PnCorner; 4]>,
    /// Every patch in the order `pn_tessellate` emits its faces: face by face, a quad
    /// as one patch, any other face as its fan of triangles `(0, k, k + 1)`.
    pub order: Vec<Patch>,
}

impl PnPatches {
    /// The patches of `mesh` with corner normals from `source`, exactly as
    /// `pn_tessellate` takes them: the mesh's face-varying normals normalised (for
    /// [`NormalSource::Mesh`] when it has some) or [`smooth_vertex_normals`].
    pub fn from_mesh(mesh: &Mesh, source: NormalSource) -> Result<PnPatches, RefineError> {
        mesh.validate().map_err(RefineError::InvalidMesh)?;
        let use_mesh_normals = source == NormalSource::Mesh && mesh.normals.is_some();
        let smooth = if use_mesh_normals { Vec::new() } else { smooth_vertex_normals(mesh) };
        let corner = |c: usize| -> PnCorner {
            let v = mesh.face_indices[c] as usize;
            let normal = match (&mesh.normals, use_mesh_normals) {
                (Some(ch), true) => ch.values[ch.indices[c] as usize].normalize_or_zero(),
                _ => smooth[v],
            };
            PnCorner { position: mesh.positions[v], normal }
        };
        let mut out = PnPatches::default();
        for f in 0..mesh.face_count() {
            let r = mesh.corners(f);
            if r.len() == 4 {
                out.order.push(Patch::Quad(out.quads.len() as u32));
                out.quads.push([0, 1, 2, 3].map(|k| corner(r.start + k)));
            } else {
                for k in 1..r.len() - 1 {
                    out.order.push(Patch::Triangle(out.triangles.len() as u32));
                    out.triangles.push([corner(r.start), corner(r.start + k), corner(r.start + k + 1)]);
                }
            }
        }
        Ok(out)
    }

    /// Number of patches.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether there is no patch.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }
}

/// The shape of a patch grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PatchKind {
    /// A PN triangle.
    Triangle,
    /// A PN quad.
    Quad,
}

/// The instanced (u, v) grid of one patch kind at one level: integer grid coordinates
/// (`u = i / level`, `v = j / level`) and the triangles that connect them, the same for
/// every patch (the per-vertex data of Tatarinov's instanced tessellation).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PatchGrid {
    /// Triangle or quad.
    pub kind: PatchKind,
    /// Segments per patch edge (≥ 1).
    pub level: u32,
    /// Grid points `(i, j)`: quads row by row (`j` outer, `i` inner, index
    /// `j (level + 1) + i`); triangles `i` outer, `j` inner over `i + j ≤ level`
    /// (barycentric weight `i/level` on corner 1, `j/level` on corner 2), the order
    /// `pn_tessellate` numbers its grids.
    pub coords: Vec<[u32; 2]>,
    /// Counter-clockwise triangles over `coords` (two per quad cell; a triangle patch's
    /// `level²` triangles as `pn_tessellate` makes them).
    pub triangles: Vec<[u32; 3]>,
}

impl PatchGrid {
    /// The grid of `kind` at `level` (≥ 1).
    pub fn new(kind: PatchKind, level: u32) -> PatchGrid {
        let s = level.max(1);
        let mut coords = Vec::new();
        let mut triangles = Vec::new();
        match kind {
            PatchKind::Quad => {
                for j in 0..=s {
                    for i in 0..=s {
                        coords.push([i, j]);
                    }
                }
                let idx = |i: u32, j: u32| j * (s + 1) + i;
                for j in 0..s {
                    for i in 0..s {
                        triangles.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
                        triangles.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
                    }
                }
            }
            PatchKind::Triangle => {
                for i in 0..=s {
                    for j in 0..=s - i {
                        coords.push([i, j]);
                    }
                }
                let idx = |i: u32, j: u32| (i * (2 * s + 3 - i)) / 2 + j;
                for i in 0..s {
                    for j in 0..s - i {
                        triangles.push([idx(i, j), idx(i + 1, j), idx(i, j + 1)]);
                        if i + j + 1 < s {
                            triangles.push([idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)]);
                        }
                    }
                }
            }
        }
        PatchGrid { kind, level: s, coords, triangles }
    }

    /// Vertices per patch: `(L+1)²` for a quad, `(L+1)(L+2)/2` for a triangle
    /// (property 28).
    pub fn vertex_count(&self) -> usize {
        self.coords.len()
    }

    /// The index of grid point `(i, j)` in [`PatchGrid::coords`].
    pub fn index(&self, i: u32, j: u32) -> usize {
        let s = self.level;
        match self.kind {
            PatchKind::Quad => (j * (s + 1) + i) as usize,
            PatchKind::Triangle => ((i * (2 * s + 3 - i)) / 2 + j) as usize,
        }
    }
}

/// One evaluated point of a patch.
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct PnSample {
    /// Position (xyz; w = 0).
    pub position: [f32; 4],
    /// Unit normal (xyz; w = 0).
    pub normal: [f32; 4],
}

impl PnSample {
    /// The position as a vector.
    pub fn p(&self) -> Vec3 {
        Vec3::new(self.position[0], self.position[1], self.position[2])
    }

    /// The normal as a vector.
    pub fn n(&self) -> Vec3 {
        Vec3::new(self.normal[0], self.normal[1], self.normal[2])
    }
}

/// Every patch evaluated at one level: for each patch its grid's points in
/// [`PatchGrid::coords`] order.
#[derive(Debug, Clone, PartialEq)]
pub struct PnSamples {
    /// Segments per edge.
    pub level: u32,
    /// The triangle grid.
    pub triangle_grid: PatchGrid,
    /// The quad grid.
    pub quad_grid: PatchGrid,
    /// Triangle samples, `triangle_grid.vertex_count()` per triangle patch.
    pub triangles: Vec<PnSample>,
    /// Quad samples, `quad_grid.vertex_count()` per quad patch.
    pub quads: Vec<PnSample>,
}

impl PnSamples {
    /// The samples of one patch, in its grid's order.
    pub fn patch(&self, patch: Patch) -> &[PnSample] {
        match patch {
            Patch::Triangle(t) => {
                let n = self.triangle_grid.vertex_count();
                &self.triangles[t as usize * n..(t as usize + 1) * n]
            }
            Patch::Quad(q) => {
                let n = self.quad_grid.vertex_count();
                &self.quads[q as usize * n..(q as usize + 1) * n]
            }
        }
    }
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct GpuCorners {
    p: [[f32; 4]; 4],
    n: [[f32; 4]; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    a: [u32; 4],
    b: [u32; 4],
}

/// Bytes of one control net in the shader (16 + 9 `vec4<f32>`).
const NET_BYTES: u64 = 25 * 16;

/// One kind of patch on the GPU.
#[derive(Debug)]
struct PatchSet {
    kind: PatchKind,
    count: u32,
    corners: wgpu::Buffer,
    params: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// PN patches on the GPU: corners and control nets in storage buffers, evaluated at any
/// level by [`GpuPn::evaluate`].
#[derive(Debug)]
pub struct GpuPn {
    gpu: Gpu,
    options: PnOptions,
    sets: Vec<PatchSet>,
    build: [wgpu::ComputePipeline; 2],
    eval: [wgpu::ComputePipeline; 2],
    grid_layout: wgpu::BindGroupLayout,
}

fn rule(r: EdgeRule) -> u32 {
    match r {
        EdgeRule::Standard => 0,
        EdgeRule::Rounder => 1,
    }
}

fn corners_data<const N: usize>(patches: &[[PnCorner; N]]) -> Vec<GpuCorners> {
    patches
        .iter()
        .map(|c| {
            let mut g = GpuCorners::zeroed();
            for (k, x) in c.iter().enumerate() {
                g.p[k] = [x.position.x, x.position.y, x.position.z, 0.0];
                g.n[k] = [x.normal.x, x.normal.y, x.normal.z, 0.0];
            }
            g
        })
        .collect()
}

impl GpuPn {
    /// Uploads `patches` and builds their control nets with `options`' edge rule,
    /// diagonal rule, interior and normal interpolation (`options.level` is ignored:
    /// [`GpuPn::evaluate`] takes the level; `options.source` was applied by
    /// [`PnPatches::from_mesh`]).
    pub fn new(gpu: &Gpu, patches: &PnPatches, options: &PnOptions) -> GpuPn {
        let module = gpu.device.create_shader_module(wgpu::include_wgsl!("pn.wgsl"));
        let nets_layout = gpu.bind_group_layout(
            "pn nets",
            &[storage_entry(0, true), storage_entry(1, false), storage_entry(2, true)],
        );
        let grid_layout =
            gpu.bind_group_layout("pn grid", &[storage_entry(0, true), storage_entry(1, false)]);
        let build =
            ["build_triangles", "build_quads"].map(|e| gpu.compute_pipeline(&module, e, &[&nets_layout]));
        let eval = ["eval_triangles", "eval_quads"]
            .map(|e| gpu.compute_pipeline(&module, e, &[&nets_layout, &grid_layout]));
        let mut sets = Vec::new();
        for (kind, data) in [
            (PatchKind::Triangle, corners_data(&patches.triangles)),
            (PatchKind::Quad, corners_data(&patches.quads)),
        ] {
            let count = data.len() as u32;
            let corners = gpu.storage_buffer("pn corners", &data);
            let nets = gpu.storage_buffer_zeroed("pn nets", count as u64 * NET_BYTES);
            let params = gpu.storage_buffer("pn params", &[Params::zeroed()]);
            let group = gpu.bind_buffers("pn nets", &nets_layout, &[&corners, &nets, &params]);
            sets.push(PatchSet { kind, count, corners, params, group });
        }
        let pn = GpuPn { gpu: gpu.clone(), options: options.clone(), sets, build, eval, grid_layout };
        pn.build_nets();
        pn
    }

    /// Replaces the corners (an animated cage: the same patches, moved) and rebuilds the
    /// control nets. Panics if the patch counts differ from those uploaded.
    pub fn set_corners(&mut self, patches: &PnPatches) {
        let data = [corners_data(&patches.triangles), corners_data(&patches.quads)];
        for (set, d) in self.sets.iter().zip(&data) {
            assert_eq!(set.count as usize, d.len(), "GpuPn::set_corners: the patch counts must not change");
            if !d.is_empty() {
                self.gpu.queue.write_buffer(&set.corners, 0, bytemuck::cast_slice(d));
            }
        }
        self.build_nets();
    }

    fn params(&self, set: &PatchSet, level: u32, per: u32) -> Params {
        let o = &self.options;
        Params {
            a: [level, set.count, rule(o.edge_rule), rule(o.diagonal_rule)],
            b: [
                (o.interior == QuadInterior::Theyer) as u32,
                (o.normals == NormalInterpolation::Quadratic) as u32,
                per,
                0,
            ],
        }
    }

    fn build_nets(&self) {
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pn nets") });
        for (k, set) in self.sets.iter().enumerate() {
            if set.count == 0 {
                continue;
            }
            self.gpu.queue.write_buffer(&set.params, 0, bytemuck::bytes_of(&self.params(set, 1, 1)));
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("pn nets"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.build[k]);
            pass.set_bind_group(0, &set.group, &[]);
            let (x, y) = workgroups(set.count);
            pass.dispatch_workgroups(x, y, 1);
        }
        self.gpu.queue.submit([encoder.finish()]);
    }

    /// Evaluates every patch at `level` segments per edge (≥ 1) and reads the samples
    /// back.
    pub fn evaluate(&self, level: u32) -> Result<PnSamples, GpuError> {
        if level == 0 {
            return Err(GpuError::Invalid("PN tessellation level must be at least 1".into()));
        }
        let limits = self.gpu.device.limits();
        let max = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        let grids = [PatchGrid::new(PatchKind::Triangle, level), PatchGrid::new(PatchKind::Quad, level)];
        let mut out: [Vec<PnSample>; 2] = [Vec::new(), Vec::new()];
        for (k, set) in self.sets.iter().enumerate() {
            let per = grids[k].vertex_count() as u64;
            let total = set.count as u64 * per;
            if total == 0 {
                continue;
            }
            let bytes = total * std::mem::size_of::<PnSample>() as u64;
            if bytes > max || total > u32::MAX as u64 {
                return Err(GpuError::Invalid(format!(
                    "PN tessellation at level {level} needs {bytes} bytes of {:?} samples, more than the device's limit of {max}",
                    set.kind
                )));
            }
            let grid = self.gpu.storage_buffer("pn grid", &grids[k].coords);
            let samples = self.gpu.storage_buffer_zeroed("pn samples", bytes);
            let group = self.gpu.bind_buffers("pn grid", &self.grid_layout, &[&grid, &samples]);
            self.gpu.queue.write_buffer(
                &set.params,
                0,
                bytemuck::bytes_of(&self.params(set, level, per as u32)),
            );
            let mut encoder = self
                .gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pn eval") });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("pn eval"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.eval[k]);
                pass.set_bind_group(0, &set.group, &[]);
                pass.set_bind_group(1, &group, &[]);
                let (x, y) = workgroups(total as u32);
                pass.dispatch_workgroups(x, y, 1);
            }
            self.gpu.queue.submit([encoder.finish()]);
            out[k] = self.gpu.read_buffer::<PnSample>(&samples, total as usize);
        }
        let [triangles, quads] = out;
        let [triangle_grid, quad_grid] = grids;
        Ok(PnSamples { level, triangle_grid, quad_grid, triangles, quads })
    }
}
