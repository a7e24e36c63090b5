//! # sylva — procedural trees and plants
//!
//! ```text
//!  Recipe ─► Session: each stage's result kept, a change reruns from the first stage it touches
//!   Generate ──► Fit ─────────► Bark ──────────► Assemble ──► Dress ──────► Lod ───► Rig ───► Clip ──► Tree
//!   lsystem,     prune, leaves, tube, hull,      bark part,   textures     LOD      joints,  wind     .to_glb()
//!   import,      decollide,     sweep, quad,     organs,      (cached),    chain,   skin     clip,    .write(path):
//!   weber-penn,  flat-base      leaf; refine;    leaf cards   instancing   curves   weights  metadata glb gltf obj
//!   colonize,    sink, clear    flat-base cut                                                         ply pov lst json
//!   least-cost
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
//!
//! The shortest embedding — a preset, the quad mesher, a grow, a `.glb` in memory
//! (`tests/session.rs` checks the same bytes with the Khronos glTF validator):
//!
//! ```
//! let set = sylva::recipe::parse_set("mesh.method=\"quad\"")?;
//! let loaded = sylva::recipe::load("lsys-binary-tree", &[set])?;
//! let tree = sylva::pipeline::grow(&loaded)?;
//! let glb = tree.to_glb()?;
//! assert_eq!(&glb[..4], b"glTF");
//! # Ok::<(), sylva::Error>(())
//! ```
//!
//! For a front end that changes settings live, [`Session`] keeps every stage's result
//! and recomputes only what a change touches.

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
pub mod image;
pub mod import;
pub mod input;
pub mod lod;
pub mod lsystem;
pub mod mesh;
pub mod model;
pub mod named;
pub mod noise;
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
pub use geometry::Mesh;
pub use mesh::deform;
pub use model::{Material, Model, Part};
pub use pipeline::session;
pub use pipeline::session::{Session, Stage};
pub use pipeline::{Report, Tree};
pub use preview::animation;
pub use recipe::Recipe;
pub use skeleton::{Skeleton, NO_PARENT};
