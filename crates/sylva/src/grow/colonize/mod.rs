//! Space colonization (Runions2007 §3–§5): attraction points sampled in a crown
//! envelope pull the nearest nodes towards them until none are left; radii follow the
//! pipe model (Shinozaki1964). The algorithm, parameters and conventions are in
//! `docs/colonize.md`.
//!
//! - `params`: [`Envelope`], [`ColonizeLeaves`], [`ColonizeParams`] and their checks;
//! - `region`: envelope shapes (a closed OBJ mesh included), sampling, inside tests;
//! - `growth`: the iteration, with a k-d tree over the live attraction points;
//! - `skeleton`: pipe-model radii, branch orders, parallel-transported up vectors, leaves.

mod growth;
mod params;
mod region;
mod skeleton;

pub use params::{ColonizeLeaves, ColonizeParams, Envelope};

use crate::error::Result;
use crate::skeleton::Skeleton;
use glam::DVec3;
use growth::Growth;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use region::Region;
use std::time::{Duration, Instant};

/// Most attraction points a tree may ask for (memory and time grow linearly with it).
pub const MAX_POINTS: usize = 5_000_000;
/// Largest allowed [`ColonizeParams::max_nodes`].
pub const MAX_NODES: usize = 50_000_000;
/// Largest allowed [`ColonizeParams::max_iterations`].
pub const MAX_ITERATIONS: u32 = 1_000_000;
/// Most leaves per leafy node ([`ColonizeLeaves::count`]).
pub const MAX_LEAVES_PER_NODE: u32 = 64;
/// Largest magnitude of any number parameter (lengths are metres: 100 km).
pub const MAX_MAGNITUDE: f64 = 1e5;
/// Most leaves a tree may carry in all.
pub const MAX_LEAVES: usize = 20_000_000;
/// Two growth directions of one node closer than this angle (degrees, before
/// perturbation) count as the same child; the second is not grown.
pub const DUPLICATE_ANGLE_DEG: f64 = 2.5;

/// What [`grow`] built.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColonizeReport {
    /// Attraction points sampled.
    pub points: usize,
    /// Attraction points left when growth stopped.
    pub points_left: usize,
    /// Skeleton nodes (root and trunk included).
    pub nodes: usize,
    /// Branch tips (nodes with a parent and no child).
    pub tips: usize,
    /// Leaves placed.
    pub leaves: usize,
    /// Colonization iterations run (leader extensions included, the initial trunk not).
    pub iterations: u32,
    /// True when growth stopped because no node could grow while points were left.
    pub stalled: bool,
    /// Wall-clock time of the whole run (sampling, growth, radii, leaves).
    pub elapsed: Duration,
}

/// The result of [`grow`].
#[derive(Debug, Clone, PartialEq)]
pub struct ColonizeTree {
    /// The skeleton: parent-first, +Y up, metres, pipe-model radii, leaf organs.
    pub skeleton: Skeleton,
    /// The attraction points left when growth stopped (in the generator's Morton order).
    pub remaining: Vec<DVec3>,
    /// What was built.
    pub report: ColonizeReport,
}

/// Reads a file from disk (the default file reader of [`grow`]).
fn read_from_disk(file: &str) -> Result<(String, String)> {
    let path = std::path::Path::new(file);
    Ok((
        path.display().to_string(),
        crate::input::read_input_to_string(path, crate::input::DEFAULT_MAX_BYTES)?,
    ))
}

/// Seeds of the three random streams.
const POINT_STREAM: u64 = 0x5DEE_CE66_D1CE_4E5B;
const GROWTH_STREAM: u64 = 0x9E37_79B9_7F4A_7C15;
const LEAF_STREAM: u64 = 0xC2B2_AE3D_27D4_EB4F;

/// The attraction points [`grow`] starts from for `params` and `seed` (validates first;
/// a mesh envelope's file is read from disk).
pub fn attraction_points(params: &ColonizeParams, seed: u64) -> Result<Vec<DVec3>> {
    params.validate()?;
    let region = Region::new(&params.envelope, &read_from_disk)?;
    region.sample(params.points, &mut Pcg64::seed_from_u64(seed ^ POINT_STREAM))
}

/// Grows a tree (see the module docs). A mesh envelope's file is read from disk,
/// relative to the working directory; use [`grow_with`] to resolve it elsewhere.
///
/// Errors: [`crate::Error::Recipe`] naming the key for bad parameters or an exceeded node
/// budget; a read error for a missing envelope file. Deterministic in `seed`.
pub fn grow(params: &ColonizeParams, seed: u64) -> Result<ColonizeTree> {
    grow_with(params, seed, &read_from_disk)
}

/// [`grow`] with a file reader for the mesh envelope: `read(file)` returns a display
/// name and the file's text (the pipeline passes `Loaded::read`, which resolves the
/// file relative to the recipe or inside the embedded presets).
pub fn grow_with(
    params: &ColonizeParams,
    seed: u64,
    read: &dyn Fn(&str) -> Result<(String, String)>,
) -> Result<ColonizeTree> {
    let start = Instant::now();
    params.validate()?;
    let region = Region::new(&params.envelope, read)?;
    let pts = region.sample(params.points, &mut Pcg64::seed_from_u64(seed ^ POINT_STREAM))?;
    let top = region.bounds().1.y + params.influence_radius;
    let mut g = Growth::new(params, pts)?;
    g.run(params, top, &mut Pcg64::seed_from_u64(seed ^ GROWTH_STREAM))?;
    let remaining: Vec<DVec3> = g.live.iter().map(|&i| g.pts[i as usize].p).collect();
    let (skeleton, tips) = g.skeleton(params, &mut Pcg64::seed_from_u64(seed ^ LEAF_STREAM))?;
    let report = ColonizeReport {
        points: params.points,
        points_left: remaining.len(),
        nodes: skeleton.len(),
        tips,
        leaves: skeleton.organs.len(),
        iterations: g.iterations,
        stalled: g.stalled,
        elapsed: start.elapsed(),
    };
    Ok(ColonizeTree { skeleton, remaining, report })
}

#[cfg(test)]
mod tests {
    use super::growth::{random_unit, spatial_order};
    use super::region::MeshRegion;
    use super::skeleton::perpendicular;
    use super::*;
    use crate::geometry::NONE;
    use rand::RngExt;

    fn params(trunk: f64) -> ColonizeParams {
        ColonizeParams {
            influence_radius: 2.0,
            kill_distance: 0.1,
            segment_length: 0.2,
            perturbation: 0.0,
            trunk_height: trunk,
            leaves: ColonizeLeaves { count: 0, ..Default::default() },
            ..Default::default()
        }
    }

    /// Runs the growth on hand-placed points.
    fn run(p: &ColonizeParams, pts: Vec<DVec3>) -> (Growth, Skeleton) {
        let mut g = Growth::new(p, pts).unwrap();
        g.run(p, 100.0, &mut Pcg64::seed_from_u64(1)).unwrap();
        let (sk, _) = g.skeleton(p, &mut Pcg64::seed_from_u64(2)).unwrap();
        (g, sk)
    }

    #[test]
    fn a_single_point_is_reached_in_straight_steps() {
        let (g, sk) = run(&params(0.0), vec![DVec3::new(0.0, 1.0, 0.0)]);
        assert!(g.live.is_empty() && !g.stalled);
        assert_eq!(sk.len(), 6, "root + 5 segments of 0.2 m to reach 1 m");
        assert_eq!(g.iterations, 5);
        assert!((sk.position[5].y - 1.0).abs() < 1e-6);
    }

    #[test]
    fn opposite_attractors_cancel_and_stall() {
        let (g, sk) = run(&params(0.0), vec![DVec3::new(1.0, 0.0, 0.0), DVec3::new(-1.0, 0.0, 0.0)]);
        assert!(g.stalled);
        assert_eq!(sk.len(), 1);
        assert_eq!(g.live.len(), 2);
    }

    #[test]
    fn an_unchanged_attractor_set_does_not_grow_a_duplicate_child() {
        // Both points stay closer to the root than to its new child, so the root sees
        // the same set again; the paper's rule would grow the same child twice.
        let (g, sk) = run(&params(0.0), vec![DVec3::new(1.0, 0.05, 0.0), DVec3::new(-1.0, 0.05, 0.0)]);
        assert_eq!(sk.len(), 2, "one child only");
        assert!(g.stalled);
        assert_eq!(g.iterations, 1);
    }

    #[test]
    fn ties_keep_the_older_node_and_kills_are_inclusive() {
        let p = params(0.0);
        let mut g = Growth::new(&p, vec![DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.0, 0.1, 0.0)]).unwrap();
        g.add_node(DVec3::ZERO, NONE, DVec3::Y).unwrap();
        g.add_node(DVec3::new(0.0, 1.0, 0.0), 0, DVec3::Y).unwrap();
        g.visit_new_nodes(0).unwrap();
        // Point (0, 0.5, 0) is equidistant from both nodes: the older one wins. Point
        // (0, 0.1, 0) is exactly at the kill distance of the root: removed.
        let mid = g.pts.iter().find(|q| q.p.y == 0.5).unwrap();
        assert_eq!(mid.closest, 0);
        let near = g.pts.iter().find(|q| q.p.y == 0.1).unwrap();
        assert!(!near.alive);
    }

    #[test]
    fn trunk_segments_reach_the_trunk_height() {
        let p = params(1.0);
        assert_eq!(p.trunk_segments(), 5.0);
        assert_eq!(ColonizeParams { trunk_height: 1.05, ..p.clone() }.trunk_segments(), 6.0);
        assert_eq!(ColonizeParams { trunk_height: 0.0, ..p }.trunk_segments(), 0.0);
    }

    #[test]
    fn spatial_order_is_a_permutation() {
        let mut rng = Pcg64::seed_from_u64(3);
        let pts: Vec<DVec3> =
            (0..1000).map(|_| DVec3::new(rng.random(), rng.random(), rng.random())).collect();
        let mut o = spatial_order(&pts);
        o.sort_unstable();
        assert_eq!(o, (0..1000).collect::<Vec<u32>>());
        assert!(spatial_order(&[]).is_empty());
        assert_eq!(spatial_order(&[DVec3::ONE, DVec3::ONE]), vec![0, 1]);
    }

    #[test]
    fn helpers_give_unit_vectors() {
        let mut rng = Pcg64::seed_from_u64(4);
        for _ in 0..100 {
            let u = random_unit(&mut rng);
            assert!((u.length() - 1.0).abs() < 1e-12);
            let q = perpendicular(u);
            assert!((q.length() - 1.0).abs() < 1e-12 && q.dot(u).abs() < 1e-12);
        }
    }

    #[test]
    fn mesh_region_parity() {
        // A unit cube from quads.
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
                   f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n";
        let m = MeshRegion::parse("cube.obj", obj).unwrap();
        // Lattice points: their rays run through the quads' diagonals and the grid's
        // shared edges and vertices.
        for i in 1..8 {
            for j in 1..8 {
                for k in 1..8 {
                    let q = DVec3::new(i as f64, j as f64, k as f64) / 8.0;
                    assert!(m.contains(q), "{q} is inside");
                    assert!(!m.contains(q + DVec3::new(1.0, 0.0, 0.0)), "{q} + x is outside");
                    assert!(!m.contains(q - DVec3::new(1.0, 0.0, 0.0)), "{q} - x is outside");
                }
            }
        }
        assert!(m.contains(DVec3::new(0.5, 0.5, 0.5)));
        assert!(m.contains(DVec3::new(0.1, 0.83, 0.27)));
        assert!(!m.contains(DVec3::new(1.5, 0.5, 0.5)));
        assert!(!m.contains(DVec3::new(-0.5, 0.3, 0.6)));
        assert!(MeshRegion::parse("bad.obj", "v 0 0 0\nf 1 2 3\n").is_err());
        assert!(MeshRegion::parse("empty.obj", "").is_err());
    }
}
