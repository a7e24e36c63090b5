//! Fitting: the skeleton passes that run between the generator and the mesher so that
//! the joint meshers' single watertight surface is free of self-intersections (beyond
//! the seeds, which assume a collision-free skeleton: Pieterse2012 §2.1, Skjermo2008 §2.1).
//!
//! - [`decollide`]: Skeleton → Skeleton. Raises radii to the joint meshers' floor, thins
//!   near-joint overlaps and rotates crossing branches apart (capsule tests only).
//! - [`clear`]: (Skeleton, mesher) → Skeleton + refined Mesh. Meshes, refines and checks
//!   the surface, thins the internodes its crossing faces lie on and meshes again; hands
//!   the last control mesh and its refinement on so the pipeline does not repeat them.
//!
//! - [`overlap`]: Skeleton → Skeleton. Optional (`mesh.prune_overlaps`): cuts off every
//!   branch that passes through another with its subtree (McLoughlin2021 §4.2, property 17).
//! - [`degenerate`]: finds zero-length, reversing and piled-up internodes before the
//!   searches above (issue 39).
//! - [`leaves`]: adds leaf organs by branch level or on terminal apices (`[leaves]
//!   place`, McLoughlin2021 §4.2, property 18).
//!
//! Decollide and clear only change radii and positions of the skeleton; overlap pruning
//! removes subtrees and leaf placement adds organs, before either. The stage order stays
//! generate → fit → mesh → refine → export. Their options are the recipe tables
//! `[fit.decollide]` and `[fit.clear]` (`docs/recipe.md`); whether they run is
//! `mesh.decollide` / `mesh.clear`.

pub mod clear;
pub mod decollide;
pub mod degenerate;
pub mod leaves;
pub mod overlap;
