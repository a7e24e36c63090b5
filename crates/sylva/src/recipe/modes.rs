//! The recipe's modes as types (issue 40): every key that takes one of a few names is an
//! enum whose serde form is exactly that name, so a recipe written to a file's metadata
//! keeps its bytes (`docs/recipe.md` lists the names).
//!
//! The enums of the recipe's own keys are here ([`MeshMethod`], [`MeshBase`],
//! [`RefineScheme`], [`RefineBoundary`], [`LeafMode`], [`LeafNormals`], [`WindPreset`],
//! [`ViewFiles`], [`RandomSource`]); a key that a stage already had a type for uses that type: `mesh.tips`
//! is [`crate::mesh::tube::TipStyle`], `output.textures` / `instancing_fallback` /
//! `compress` / `lod_layout` the [`crate::export`] enums, `leaves.place`
//! [`crate::fit::leaves::Placement`], `generator.gap` [`crate::import::lst::GapPolicy`],
//! `leaves.shape` and `textures.bark` an `Option` of [`crate::texture::leaf::LeafShape`]
//! and [`crate::texture::bark::BarkStyle`] (`None` is `auto`, [`crate::texture::auto`]).
//! The least-cost generator's own modes (`generator.axis`, `thickness`, `bcm.weights`,
//! the MGV iterations' and MIG levels' modes, `refine.attach`) are made by the same
//! macro in [`crate::grow::least_cost`].
//!
//! A name serde does not know is reported by [`crate::recipe::from_table`] as the key, the
//! name given and the names allowed (`` `leaves.mode` is `sprites`; use cards, instanced
//! or geometry ``): [`variant_hint`] rewrites serde's `unknown variant` message.

pub use crate::named::one_of;

/// serde's `unknown variant` message said for a recipe key: `` unknown variant `x`,
/// expected one of `a`, `b`, `c` `` becomes `` is `x`; use a, b or c ``. `None` for any
/// other message.
pub fn variant_hint(why: &str) -> Option<String> {
    let rest = why.strip_prefix("unknown variant `")?;
    let (given, expected) = rest.rsplit_once("`, expected ")?;
    let names: Vec<&str> = if let Some(list) = expected.strip_prefix("one of ") {
        list.split(", ").map(|n| n.trim_matches('`')).collect()
    } else if let Some((a, b)) = expected.split_once(" or ") {
        vec![a.trim_matches('`'), b.trim_matches('`')]
    } else {
        vec![expected.trim_matches('`')]
    };
    Some(format!("is `{given}`; use {}", one_of(&names)))
}

use crate::named::mode;

mode! {
    /// `mesh.method`: the mesher ([`crate::mesh::Mesher`] with its options).
    MeshMethod, key "mesh.method", default Tube {
        /// Generalized cylinders, one per axis.
        Tube = "tube",
        /// Pieterse2012's convex-hull joints.
        Hull = "hull",
        /// MacMurchy2004's hexagonal sections and junction templates.
        Sweep = "sweep",
        /// Skjermo2008's SMART quad junction boxes.
        Quad = "quad",
        /// MacMurchy2004's leaf mode: open leaf surfaces.
        Leaf = "leaf",
    }
}

impl MeshMethod {
    /// Whether the mesher joins branches into one watertight surface (hull, sweep,
    /// quad): the meshers the fitting stage (de-collision, clearing) is for.
    pub fn joins(self) -> bool {
        !matches!(self, MeshMethod::Tube | MeshMethod::Leaf)
    }
}

mode! {
    /// `mesh.base`: how the trunk's base ends.
    MeshBase, key "mesh.base", default Flat {
        /// Cut at the root's height and closed flat ([`crate::mesh::ground`]).
        Flat = "flat",
        /// Each mesher's own end.
        Round = "round",
    }
}

mode! {
    /// `refine.scheme`: the subdivision of the bark's control mesh.
    RefineScheme, key "refine.scheme", default Auto {
        /// The mesher's own scheme ([`crate::mesh::Mesher::scheme`]).
        Auto = "auto",
        /// No subdivision.
        None = "none",
        /// Loop's scheme (triangle meshes).
        Loop = "loop",
        /// Catmull–Clark.
        CatmullClark = "catmull-clark",
    }
}

mode! {
    /// `refine.boundary`: where the refined mesh's boundary vertices go.
    RefineBoundary, key "refine.boundary", default Auto {
        /// The mesher's own rule: `fixed` for `hull`, `bspline` for the others.
        Auto = "auto",
        /// Every boundary vertex stays put.
        Fixed = "fixed",
        /// The rim refines as a cubic B-spline, single-face corners pinned.
        Bspline = "bspline",
        /// B-spline, nothing pinned.
        EdgeOnly = "edge-only",
    }
}

mode! {
    /// `leaves.mode`: how leaf organs are written.
    LeafMode, key "leaves.mode", default Cards {
        /// A textured, alpha-cut quad per leaf (or per twig of leaves).
        Cards = "cards",
        /// Cards as one shape and an instance per card (`EXT_mesh_gpu_instancing`).
        Instanced = "instanced",
        /// The leaf polygons as the generator drew them.
        Geometry = "geometry",
    }
}

impl LeafMode {
    /// Whether leaves become cards (`cards` or `instanced`).
    pub fn cards(self) -> bool {
        matches!(self, LeafMode::Cards | LeafMode::Instanced)
    }
}

mode! {
    /// `leaves.normals`: the leaves' normals.
    LeafNormals, key "leaves.normals", default Flat {
        /// Each leaf's own.
        Flat = "flat",
        /// Bent toward the crown's outward direction
        /// ([`crate::mesh::cards::bend_toward_crown`]).
        Crown = "crown",
    }
}

mode! {
    /// `wind.preset`: the wind the rig and clip are made for.
    WindPreset, key "wind.preset", default None {
        /// No wind data.
        None = "none",
        /// A light wind.
        Calm = "calm",
        /// A breeze.
        Breeze = "breeze",
        /// A storm.
        Storm = "storm",
    }
}

impl WindPreset {
    /// The wind module's options of the preset (`None` for [`WindPreset::None`]).
    pub fn options(self) -> Option<crate::wind::WindOptions> {
        crate::wind::WindOptions::preset(self.name())
    }
}

mode! {
    /// `generator.view` (L-systems): whether the cpfg model folder's files (view `.v`,
    /// functions, surfaces) are read.
    ViewFiles, key "generator.view", default Auto {
        /// Read them from the L-system's folder (files on disk only).
        Auto = "auto",
        /// Ignore them.
        None = "none",
    }
}

mode! {
    /// `generator.random` (L-systems): the random generator of `ran`, `nran`, `bran`,
    /// `biran` and stochastic productions ([`crate::lsystem::RandomGenerator`]).
    RandomSource, key "generator.random", default Auto {
        /// cpfg's for an L-system file on disk or in memory (a cpfg model grows as in
        /// cpfg), sylva's for sylva's own presets (their outputs stay as they were).
        Auto = "auto",
        /// cpfg's `drand48` streams and call order (issue 46 item 9).
        Cpfg = "cpfg",
        /// sylva's portable generator.
        Sylva = "sylva",
    }
}

impl RandomSource {
    /// Whether this is the default, `auto` (left out of written metadata then).
    pub fn is_auto(&self) -> bool {
        *self == RandomSource::Auto
    }

    /// The engine's generator for an L-system of a preset (`preset`) or not, with the
    /// recipe seed `seed`. With cpfg's generator the default seed (1) keeps the model's
    /// own seeds and any other replaces them: `--seed n` grows what cpfg grows from the
    /// model with `seed: n` (docs/recipe.md).
    pub fn generator(self, preset: bool, seed: u64) -> crate::lsystem::RandomGenerator {
        use crate::lsystem::RandomGenerator as G;
        match self {
            RandomSource::Sylva => G::Sylva,
            RandomSource::Auto if preset => G::Sylva,
            RandomSource::Auto | RandomSource::Cpfg => {
                G::Cpfg { seed: (seed != super::default_seed()).then_some(seed) }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for m in MeshMethod::ALL {
            assert_eq!(MeshMethod::from_name(m.name()), Some(*m));
            assert_eq!(m.to_string().parse::<MeshMethod>().unwrap(), *m);
        }
        assert_eq!(RefineScheme::CatmullClark.name(), "catmull-clark");
        assert_eq!(RefineBoundary::EdgeOnly.to_string(), "edge-only");
        let e = "sprites".parse::<LeafMode>().unwrap_err().to_string();
        assert!(e.contains("`leaves.mode` is `sprites`; use cards, instanced or geometry"), "{e}");
    }

    #[test]
    fn variant_messages_become_hints() {
        assert_eq!(
            variant_hint("unknown variant `x`, expected one of `a`, `b`, `c`").as_deref(),
            Some("is `x`; use a, b or c")
        );
        assert_eq!(
            variant_hint("unknown variant `x`, expected `a` or `b`").as_deref(),
            Some("is `x`; use a or b")
        );
        assert_eq!(variant_hint("unknown variant `x`, expected `a`").as_deref(), Some("is `x`; use a"));
        assert_eq!(variant_hint("invalid type: integer `3`, expected a string"), None);
    }
}
