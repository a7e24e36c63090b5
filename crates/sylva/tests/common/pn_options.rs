//! Every combination of the PN tessellation's rules (`refine::pn`, Skjermo2008-spec §5),
//! shared by the engine's PN tests and sylva-gpu's GPU-against-CPU PN tests (included
//! with `#[path]` by both crates).
#![allow(dead_code)]

use sylva::refine::pn::{EdgeRule, NormalInterpolation, PnOptions, QuadInterior};

/// The 16 options at `level`: each edge rule × diagonal rule × quad interior × normal
/// interpolation, the rest default.
pub fn all_options(level: u32) -> Vec<PnOptions> {
    let mut v = Vec::new();
    for edge_rule in [EdgeRule::Standard, EdgeRule::Rounder] {
        for interior in [QuadInterior::ZeroTwist, QuadInterior::Theyer] {
            for normals in [NormalInterpolation::Linear, NormalInterpolation::Quadratic] {
                for diagonal_rule in [EdgeRule::Standard, EdgeRule::Rounder] {
                    v.push(PnOptions {
                        level,
                        edge_rule,
                        diagonal_rule,
                        interior,
                        normals,
                        ..Default::default()
                    });
                }
            }
        }
    }
    v
}
