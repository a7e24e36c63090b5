//! # sylva — procedural trees and plants
//!
//! ```text
//!  recipe ─► generator ─► Skeleton ─► fit ───────► mesher ───► Cage ─► refine ─► Model ─► export
//!  (TOML)    lsystem, import,         decollide    tube, hull,          Loop, CC,         glb gltf
//!            weber-penn, colonize,    clear        sweep, quad          limit, noise      obj ply
//!            least-cost                                                                   preview
//! ```
//!
//! The engine crate: pure Rust, no GPU and no CLI dependencies. Every stage is a plain
//! function from data to data:
//!
//! - [`lsystem`]: the cpfg-compatible L-system language (McLoughlin2021 §2, ABOP), derivation
//!   and the 3D turtle that writes a [`Skeleton`];
//! - [`skeleton`]: the parent-first branching skeleton;
//! - [`geometry`] and [`model`]: the plain data every stage shares (meshes; models with
//!   parts, instances, rig, LODs and branch curves);
//! - [`fit`]: the skeleton passes before meshing (de-collision, mesh-checked thinning);
//! - [`mesh`]: the meshers (`tube`, `hull`, `sweep`, `quad`), the checker, organs;
//! - [`export`]: glTF 2.0 (`.glb`, `.gltf`), OBJ + MTL and binary PLY writers;
//! - [`preview`]: a CPU rasterizer that renders a model to a PNG;
//! - [`recipe`] and [`presets`]: TOML recipes and the embedded preset library.
//!
//! Works are cited by the keys of `docs/references.md` (Pieterse2012, MacMurchy2004,
//! McLoughlin2021, Skjermo2008, Xu2015 and their `-spec` distillations, ABOP, …); "issue N"
//! is the project's issue tracker (`git log --grep "issue N"` finds the change).

#![warn(missing_docs)]

pub mod cancel;
pub mod curves;
pub mod diagnostic;
pub mod error;
pub mod export;
pub mod fit;
pub mod fsutil;
pub mod geometry;
pub mod grow;
pub mod import;
pub mod input;
pub mod lod;
pub mod lsystem;
pub mod mesh;
pub mod model;
pub mod pipeline;
pub mod presets;
pub mod preview;
pub mod recipe;
pub mod refine;
pub mod skeleton;
pub mod texture;
pub mod tolerance;
pub mod wind;

pub use error::{Error, Result};
pub use preview::animation;
pub use geometry::Mesh;
pub use mesh::deform;
pub use model::{Material, Model, Part};
pub use pipeline::session;
pub use skeleton::{Skeleton, NO_PARENT};
