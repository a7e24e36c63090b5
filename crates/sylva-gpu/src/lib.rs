//! sylva's real-time half on wgpu (issue 25; McLoughlin2021 and Skjermo2008, Skjermo2008-spec §3–§5): what
//! the engine computes on the CPU, computed on a GPU (or Mesa's software Vulkan) with
//! WGSL compute shaders, agreeing with the engine's CPU reference within stated
//! tolerances.
//!
//! ```text
//!  sylva::wind::WindRig + WindOptions ──► wind::GpuWind ──► control points (storage buffer)
//!       one compute dispatch per branch depth level (no lag), or one over a copy (legacy lag)
//!  sylva::Mesh (coarse cage) + PnOptions ──► pn::PnPatches ──► pn::GpuPn ──► PN samples
//!       compute: control nets per patch, then points + normals over an instanced (u, v) grid
//!  sylva::deform::BranchRecord ──► deform::GpuDeformer ──► positions + normals (compute, tests)
//!  model curves + wind points ──► branches::BranchRenderer ──► GPU LOD pass ──► one instanced
//!       indirect draw per (v, θ) grid level, deformed in the vertex shader (deform.wgsl)
//!  sylva::Model (meshes, textures, rig + clip, LODs) ──► render ──► offscreen picture / frames
//! ```
//!
//! [`Gpu`] opens a headless adapter (any kind, software included) and carries the buffer
//! and readback helpers; [`Gpu::or_skip`] is the gate every GPU test and bench goes
//! through, so `cargo test --workspace` passes without a Vulkan driver and fails where
//! `SYLVA_REQUIRE_GPU=1` says a GPU must be there. The engine crate `sylva` stays free of
//! GPU dependencies: this crate depends on it, never the other way round.

#![warn(missing_docs)]

pub mod branches;
pub mod deform;
pub mod gpu;
pub mod pn;
pub mod render;
pub mod wind;

pub use gpu::{Gpu, GpuError};
pub use pn::{GpuPn, PatchGrid, PnPatches};
pub use wind::GpuWind;
