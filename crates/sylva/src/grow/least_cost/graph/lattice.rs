//! Lattices (BCM, Xu2015 §3.3.1, Figs. 3.3–3.4).
//!
//! [`lattice`] builds the 6-connected (3D) or 4-connected (2D) lattice inside a volume,
//! optionally jittered by up to `jitter·spacing` per axis, with both edge directions.

use super::volume::Volume;
use super::{Graph, NONE};
use crate::error::{Error, Result};
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;

/// The lattice graph of BCM (§3.3.1): nodes on a lattice of `spacing` inside `volume`,
/// each jittered by up to `jitter·spacing` per axis, 6-connected (3D) or 4-connected
/// (2D) with both edge directions. The root is the node nearest the bottom centre.
pub fn lattice(volume: &Volume, spacing: f64, jitter: f64, dims: u8, seed: u64) -> Result<Graph> {
    let (lo, hi) = volume.bounds_dims(dims);
    let n = |e: f64| (e / spacing).floor() as usize + 1;
    let (nx, ny, nz) = (n(hi.x - lo.x), n(hi.y - lo.y), if dims == 2 { 1 } else { n(hi.z - lo.z) });
    let cells = nx.saturating_mul(ny).saturating_mul(nz);
    if cells > crate::grow::least_cost::MAX_NODES * 4 {
        return Err(Error::Recipe(format!(
            "the lattice would have {cells} sites: make the spacing larger (at most {} sites)",
            crate::grow::least_cost::MAX_NODES * 4
        )));
    }
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut id = vec![NONE; cells];
    let mut pos = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let p = lo + DVec3::new(x as f64, y as f64, z as f64) * spacing;
                if volume.contains(p) {
                    let mut j = DVec3::new(
                        rng.random::<f64>() * 2.0 - 1.0,
                        rng.random::<f64>() * 2.0 - 1.0,
                        if dims == 2 { 0.0 } else { rng.random::<f64>() * 2.0 - 1.0 },
                    );
                    j *= jitter * spacing;
                    id[(z * ny + y) * nx + x] = pos.len() as u32;
                    pos.push((p + j).as_vec3());
                }
            }
        }
    }
    if pos.is_empty() {
        return Err(Error::Recipe("the lattice has no site inside the volume".into()));
    }
    let mut offsets = vec![0u32];
    let mut targets = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                if id[(z * ny + y) * nx + x] == NONE {
                    continue;
                }
                let mut nb = |xx: isize, yy: isize, zz: isize| {
                    if xx >= 0
                        && yy >= 0
                        && zz >= 0
                        && (xx as usize) < nx
                        && (yy as usize) < ny
                        && (zz as usize) < nz
                    {
                        let t = id[(zz as usize * ny + yy as usize) * nx + xx as usize];
                        if t != NONE {
                            targets.push(t);
                        }
                    }
                };
                let (x, y, z) = (x as isize, y as isize, z as isize);
                nb(x - 1, y, z);
                nb(x + 1, y, z);
                nb(x, y - 1, z);
                nb(x, y + 1, z);
                if dims == 3 {
                    nb(x, y, z - 1);
                    nb(x, y, z + 1);
                }
                offsets.push(targets.len() as u32);
            }
        }
    }
    let bc = volume.bottom_center(dims).as_vec3();
    let root = (0..pos.len())
        .min_by(|&a, &b| pos[a].distance_squared(bc).total_cmp(&pos[b].distance_squared(bc)))
        .unwrap_or(0) as u32;
    Ok(Graph { dims, position: pos, offsets, targets, root, spacing: spacing as f32, shortfall: 0 })
}
