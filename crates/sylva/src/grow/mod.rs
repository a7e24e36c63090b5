//! Procedural tree generators that write a [`Skeleton`](crate::Skeleton) directly from
//! parameters: Weber–Penn parametric trees and space colonization.
//!
//! - [`weber_penn`]: Weber & Penn 1995 parametric trees (stems, splits, leaves, pruning).

pub mod colonize;
pub mod weber_penn;
