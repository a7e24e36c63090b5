//! Procedural tree generators that write a [`Skeleton`](crate::Skeleton) directly from
//! parameters: Weber–Penn parametric trees and space colonization.
//!
//! - [`weber_penn`]: Weber & Penn 1995 parametric trees (stems, splits, leaves, pruning).
//! - [`least_cost`]: least-cost-path trees, MIG and MGV (Xu2015 Chs. 3–6).

pub mod colonize;
pub mod least_cost;
pub mod weber_penn;
