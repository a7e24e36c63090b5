//! The meshers: skeleton → control cage (Pieterse2012, MacMurchy2004, Skjermo2008 and the generalized
//! cylinders of McLoughlin2021), plus the mesh checker and the organ mesher.
//!
//! The mesh type itself is [`crate::geometry::Mesh`] and the model the exporters write
//! is [`crate::model::Model`]: plain data below every stage.

pub mod cards;
pub mod check;
pub mod deform;
pub mod ground;
pub mod hull;
pub mod leaf;
pub mod memory;
pub mod organs;
pub mod quad;
pub mod sweep;
pub mod tube;

/// The OBJ reader, now [`crate::import::obj`]; this path keeps working.
pub use crate::import::obj as obj_read;

use crate::error::Result;
use crate::geometry::Mesh;
use crate::refine::Scheme;
use crate::skeleton::Skeleton;

/// The meshers and their options: one variant per mesher, read from the recipe's
/// `[mesh]` table (`method`) and its `[mesh.<method>]` table of options.
///
/// Adding a mesher: its own file with an options struct (serde, `#[serde(default,
/// deny_unknown_fields)]`, a `check()` naming each option) and a function returning a
/// [`Cage`]; then one line in [`Mesher::NAMES`] and one arm in each `match` below, and
/// one field in `recipe::MeshSection`.
#[derive(Debug, Clone, PartialEq)]
pub enum Mesher {
    /// Generalized cylinders, one per axis (`mesh/tube/`).
    Tube(tube::TubeOptions),
    /// Pieterse2012's convex-hull joints (`mesh/hull/`).
    Hull(hull::HullOptions),
    /// MacMurchy2004's hexagonal sections and junction templates (`mesh/sweep/`).
    Sweep(sweep::SweepOptions),
    /// Skjermo2008's SMART quad junction boxes (`mesh/quad/`).
    Quad(quad::QuadOptions),
    /// MacMurchy2004's leaf mode (`/L`): open, midrib-creased leaf surfaces (`mesh/leaf.rs`).
    Leaf(leaf::LeafOptions),
}

/// What every mesher returns: the control cage and what the stages after it need.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Cage {
    /// The control mesh.
    pub mesh: Mesh,
    /// The subdivision scheme the cage is made for (`refine.scheme = "auto"`).
    pub scheme: Scheme,
    /// The skeleton node each face belongs to (the child node of its internode), where
    /// the mesher records it (quad, sweep); empty otherwise.
    pub face_node: Vec<u32>,
    /// Skeleton nodes where the mesher fell back to a simpler local construction.
    pub fallbacks: Vec<u32>,
    /// Axes or connected pieces the mesher built.
    pub axes: usize,
    /// Problems that did not stop the mesher, one line each.
    pub warnings: Vec<String>,
    /// Work the mesher's repair spent (the quad mesher's
    /// [`QuadOptions::max_repair_work`](quad::QuadOptions::max_repair_work) units; 0 for
    /// the others).
    pub work: u64,
}

impl Mesher {
    /// The `mesh.method` names, in the order of the variants.
    pub const NAMES: [&'static str; 5] = ["tube", "hull", "sweep", "quad", "leaf"];

    /// The mesher's `mesh.method` name.
    pub fn name(&self) -> &'static str {
        match self {
            Mesher::Tube(_) => "tube",
            Mesher::Hull(_) => "hull",
            Mesher::Sweep(_) => "sweep",
            Mesher::Quad(_) => "quad",
            Mesher::Leaf(_) => "leaf",
        }
    }

    /// Whether the mesher joins branches into one watertight surface (hull, sweep,
    /// quad), which the fitting stage (de-collision, clearing) is for.
    pub fn joins(&self) -> bool {
        !matches!(self, Mesher::Tube(_) | Mesher::Leaf(_))
    }

    /// The subdivision scheme the mesher's cage is made for: Catmull–Clark for the
    /// all-quad cage, Loop for the triangle meshers.
    pub fn scheme(&self) -> Scheme {
        match self {
            Mesher::Quad(_) => Scheme::CatmullClark,
            _ => Scheme::Loop,
        }
    }

    /// Checks the options' ranges; the message names the key (`mesh.quad.support = …`).
    pub fn check(&self) -> Result<()> {
        let named = |r: Result<()>| {
            r.map_err(|e| match e {
                crate::Error::InvalidGeometry { why, .. } => {
                    crate::Error::Recipe(format!("`mesh.{}.{why}", self.name()).replacen(" = ", "` = ", 1))
                }
                e => e,
            })
        };
        match self {
            Mesher::Tube(_) => Ok(()),
            Mesher::Hull(o) => named(o.check()),
            Mesher::Sweep(o) => named(o.check()),
            Mesher::Quad(o) => named(o.check()),
            Mesher::Leaf(o) => named(o.check()),
        }
    }

    /// Meshes `skeleton` into a control cage.
    pub fn cage(&self, skeleton: &Skeleton) -> Result<Cage> {
        Ok(match self {
            Mesher::Tube(o) => {
                let t = tube::tube_mesh(skeleton, o)?;
                Cage { mesh: t.mesh, scheme: self.scheme(), axes: t.axes, ..Default::default() }
            }
            Mesher::Hull(o) => {
                let h = hull::hull_mesh(skeleton, o)?;
                let warnings = self.fallback_warnings(&h.fallbacks);
                Cage {
                    mesh: h.mesh,
                    scheme: self.scheme(),
                    face_node: Vec::new(),
                    fallbacks: h.fallbacks,
                    axes: h.branches.len(),
                    warnings,
                    work: 0,
                }
            }
            Mesher::Sweep(o) => {
                let sw = sweep::sweep_mesh(skeleton, o)?;
                let warnings = self.fallback_warnings(&sw.fallbacks);
                Cage {
                    axes: sw.junctions.len() + sw.fallbacks.len(),
                    face_node: sw
                        .face_owner
                        .iter()
                        .map(|&[a, b]| if b != u32::MAX { b } else { a })
                        .collect(),
                    mesh: sw.mesh,
                    scheme: self.scheme(),
                    fallbacks: sw.fallbacks,
                    warnings,
                    work: 0,
                }
            }
            Mesher::Quad(o) => {
                let q = quad::quad_mesh(skeleton, o)?;
                let fallbacks: Vec<u32> = q.fallbacks.iter().map(|f| f.node).collect();
                let warnings = self.fallback_warnings(&fallbacks);
                Cage {
                    mesh: q.mesh,
                    scheme: self.scheme(),
                    face_node: q.face_node,
                    fallbacks,
                    axes: q.components,
                    warnings,
                    work: q.repair_work,
                }
            }
            Mesher::Leaf(o) => {
                let l = leaf::leaf_mesh(skeleton, o)?;
                Cage {
                    axes: l.midribs.len(),
                    face_node: l.face_node,
                    mesh: l.mesh,
                    scheme: self.scheme(),
                    ..Default::default()
                }
            }
        })
    }

    /// The one warning line for a cage's fallbacks (none when there are none): the
    /// mesher, how many, what it fell back to and the first eight nodes.
    fn fallback_warnings(&self, fallbacks: &[u32]) -> Vec<String> {
        if fallbacks.is_empty() {
            return Vec::new();
        }
        let (what, detail) = match self {
            Mesher::Hull(_) => ("joint(s) fell back to capped tubes", ""),
            Mesher::Sweep(_) => ("node(s) fell back to separately capped tubes", ""),
            Mesher::Quad(_) => {
                ("node(s) fell back", "detached or separated capped cages, unboxed or shortened junctions; ")
            }
            Mesher::Tube(_) | Mesher::Leaf(_) => ("node(s) fell back", ""),
        };
        let first = &fallbacks[..fallbacks.len().min(8)];
        vec![format!("{} mesher: {} {what} ({detail}first nodes {first:?})", self.name(), fallbacks.len())]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With a cancelled token installed every skeleton mesher returns `Error::Cancelled`
    /// (tube per axis, hull per joint and branch, sweep per node and repair round, quad
    /// per internode and repair round); without one the same call meshes.
    #[test]
    fn every_mesher_stops_when_cancelled() {
        let s = tube::tests::binary_tree(5, 2);
        let token = crate::cancel::Cancel::new();
        token.cancel();
        for mesher in [
            Mesher::Tube(Default::default()),
            Mesher::Hull(Default::default()),
            Mesher::Sweep(Default::default()),
            Mesher::Quad(Default::default()),
        ] {
            let r = crate::cancel::scope(&token, || mesher.cage(&s));
            assert!(matches!(r, Err(crate::Error::Cancelled)), "{}: {r:?}", mesher.name());
            assert!(mesher.cage(&s).is_ok_and(|c| c.mesh.face_count() > 0), "{}", mesher.name());
        }
    }

    #[test]
    fn fallback_warnings_name_the_mesher_count_and_first_nodes() {
        assert!(Mesher::Hull(Default::default()).fallback_warnings(&[]).is_empty());
        let many: Vec<u32> = (0..10).collect();
        let w = Mesher::Quad(Default::default()).fallback_warnings(&many);
        assert_eq!(
            w,
            ["quad mesher: 10 node(s) fell back (detached or separated capped cages, unboxed or \
              shortened junctions; first nodes [0, 1, 2, 3, 4, 5, 6, 7])"]
        );
        let w = Mesher::Hull(Default::default()).fallback_warnings(&[4]);
        assert_eq!(w, ["hull mesher: 1 joint(s) fell back to capped tubes (first nodes [4])"]);
    }
}
