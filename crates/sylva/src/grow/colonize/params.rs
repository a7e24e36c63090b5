//! The `[generator]` keys of a space-colonization recipe (Runions2007 §3–§5;
//! `docs/colonize.md` has the table): the crown [`Envelope`], the leaves and the growth
//! parameters, with range checks whose errors name the key.

use super::{MAX_ITERATIONS, MAX_LEAVES_PER_NODE, MAX_MAGNITUDE, MAX_NODES, MAX_POINTS};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// The crown volume the attraction points fill (`[generator.envelope]`, chosen by its
/// `shape` key). Every shape is centred on the +Y axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "kebab-case")]
pub enum Envelope {
    /// A sphere of `radius` centred at height `center_height`.
    Sphere {
        /// Height of the centre above the ground (m).
        #[serde(default = "d_center_height")]
        center_height: f64,
        /// Radius (m).
        #[serde(default = "d_radius")]
        radius: f64,
    },
    /// An axis-aligned ellipsoid with semi-axes `radii = [x, y, z]` centred at height
    /// `center_height`.
    Ellipsoid {
        /// Height of the centre above the ground (m).
        #[serde(default = "d_center_height")]
        center_height: f64,
        /// Semi-axes along X, Y (vertical) and Z (m).
        #[serde(default = "d_radii")]
        radii: [f64; 3],
    },
    /// An upright cone: a disc of `radius` at `base_height`, the apex `height` above it.
    Cone {
        /// Height of the base disc above the ground (m).
        #[serde(default = "d_base_height")]
        base_height: f64,
        /// Height from the base disc to the apex (m).
        #[serde(default = "d_height")]
        height: f64,
        /// Radius of the base disc (m).
        #[serde(default = "d_radius")]
        radius: f64,
    },
    /// An upright cylinder of `radius` from `base_height` to `base_height + height`.
    Cylinder {
        /// Height of the bottom disc above the ground (m).
        #[serde(default = "d_base_height")]
        base_height: f64,
        /// Height of the cylinder (m).
        #[serde(default = "d_height")]
        height: f64,
        /// Radius (m).
        #[serde(default = "d_radius")]
        radius: f64,
    },
    /// A closed (watertight) triangle or polygon mesh read from a Wavefront OBJ file,
    /// in metres and +Y up in the tree's frame; relative to the recipe (or to
    /// `presets/` for presets). Inside is decided by ray parity.
    Mesh {
        /// The `.obj` file.
        #[serde(default)]
        file: String,
    },
}

fn d_center_height() -> f64 {
    6.5
}
fn d_radius() -> f64 {
    4.0
}
fn d_radii() -> [f64; 3] {
    [4.0, 3.5, 4.0]
}
fn d_base_height() -> f64 {
    3.0
}
fn d_height() -> f64 {
    7.0
}

impl Default for Envelope {
    fn default() -> Self {
        Envelope::Ellipsoid { center_height: d_center_height(), radii: d_radii() }
    }
}

/// Leaves placed on the branch tips (`[generator.leaves]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ColonizeLeaves {
    /// Leaves per leafy node, spread along the node's incoming internode with a
    /// golden-angle roll (0 = no leaves).
    pub count: u32,
    /// Leafy nodes per tip, counted back from the tip along its unbranched end
    /// (1 = the tip only, 0 = no leaves).
    pub nodes: u32,
    /// Leaf length in metres (the quad is half as wide).
    pub size: f64,
    /// Relative random variation of the size: each leaf is `size × (1 ± size_variation)`.
    pub size_variation: f64,
    /// Angle between the branch and the leaf's midrib, degrees.
    pub angle: f64,
}

impl Default for ColonizeLeaves {
    fn default() -> Self {
        ColonizeLeaves { count: 3, nodes: 3, size: 0.15, size_variation: 0.2, angle: 50.0 }
    }
}

/// Parameters of the space colonization generator: the `[generator]` keys of a recipe
/// with `type = "space-colonization"`. Lengths in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ColonizeParams {
    /// The crown volume the attraction points fill.
    pub envelope: Envelope,
    /// Number of attraction points (at most [`MAX_POINTS`]).
    pub points: usize,
    /// Radius of influence `d_i`: a point attracts its closest node only within it.
    pub influence_radius: f64,
    /// Kill distance `d_k`: a point is removed once a node is this close. At least
    /// `segment_length / 2` (so a branch cannot step over a point and oscillate around
    /// it) and less than `influence_radius`.
    pub kill_distance: f64,
    /// Segment (internode) length `D`: every new node is this far from its parent.
    pub segment_length: f64,
    /// Tropism direction (need not be unit length; `[0, -1, 0]` is gravitropism
    /// downwards, `[0, 1, 0]` phototropism upwards).
    pub tropism: [f64; 3],
    /// Weight of the unit tropism vector added to each normalized growth direction
    /// (0 = none).
    pub tropism_weight: f64,
    /// Weight of a random unit vector added to each growth direction (0 = none).
    pub perturbation: f64,
    /// Height of the straight trunk grown from the origin before colonization (m).
    pub trunk_height: f64,
    /// Most colonization iterations.
    pub max_iterations: u32,
    /// Node budget: growing more nodes is an error (at most [`MAX_NODES`]).
    pub max_nodes: usize,
    /// Pipe-model exponent `n` in `r^n = Σ r_child^n` (2 = da Vinci, 2–3 = Murray), in
    /// `[1, 4]`.
    pub pipe_exponent: f64,
    /// Radius of every branch tip (m).
    pub tip_radius: f64,
    /// Leaves on the tips.
    pub leaves: ColonizeLeaves,
}

impl Default for ColonizeParams {
    fn default() -> Self {
        ColonizeParams {
            envelope: Envelope::default(),
            points: 4000,
            influence_radius: 1.5,
            kill_distance: 0.4,
            segment_length: 0.2,
            tropism: [0.0, -1.0, 0.0],
            tropism_weight: 0.0,
            perturbation: 0.05,
            trunk_height: 3.0,
            max_iterations: 1000,
            max_nodes: 2_000_000,
            pipe_exponent: 2.5,
            tip_radius: 0.008,
            leaves: ColonizeLeaves::default(),
        }
    }
}

pub(super) fn bad<T>(key: &str, why: impl std::fmt::Display) -> Result<T> {
    Err(Error::Recipe(format!("`generator.{key}` {why}")))
}

fn finite(key: &str, v: f64) -> Result<()> {
    if !v.is_finite() {
        bad(key, format!("must be a finite number, got {v}"))
    } else if v.abs() > MAX_MAGNITUDE {
        bad(key, format!("must be at most {MAX_MAGNITUDE} in magnitude (lengths are metres), got {v}"))
    } else {
        Ok(())
    }
}

fn positive(key: &str, v: f64) -> Result<()> {
    finite(key, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        bad(key, format!("must be > 0, got {v}"))
    }
}

fn non_negative(key: &str, v: f64) -> Result<()> {
    finite(key, v)?;
    if v >= 0.0 {
        Ok(())
    } else {
        bad(key, format!("must be ≥ 0, got {v}"))
    }
}

impl Envelope {
    /// Checks that every size is finite and positive; errors name the key
    /// (`generator.envelope.radius`).
    pub fn validate(&self) -> Result<()> {
        match self {
            Envelope::Sphere { center_height, radius } => {
                finite("envelope.center_height", *center_height)?;
                positive("envelope.radius", *radius)
            }
            Envelope::Ellipsoid { center_height, radii } => {
                finite("envelope.center_height", *center_height)?;
                for r in radii {
                    if !(r.is_finite() && *r > 0.0 && *r <= MAX_MAGNITUDE) {
                        return bad(
                            "envelope.radii",
                            format!("must be three numbers in (0, {MAX_MAGNITUDE}] m, got {radii:?}"),
                        );
                    }
                }
                Ok(())
            }
            Envelope::Cone { base_height, height, radius }
            | Envelope::Cylinder { base_height, height, radius } => {
                finite("envelope.base_height", *base_height)?;
                positive("envelope.height", *height)?;
                positive("envelope.radius", *radius)
            }
            Envelope::Mesh { file } => {
                if file.trim().is_empty() {
                    bad("envelope.file", "must name an .obj file for `shape = \"mesh\"`")
                } else {
                    Ok(())
                }
            }
        }
    }
}

impl ColonizeParams {
    /// Checks every value range; errors are [`Error::Recipe`] naming the key
    /// (`generator.kill_distance`).
    pub fn validate(&self) -> Result<()> {
        self.envelope.validate()?;
        if self.points > MAX_POINTS {
            return bad(
                "points",
                format!(
                    "is {}, over the budget of {MAX_POINTS} attraction points (time and memory grow \
                     linearly with it: about 0.25 s per 100 000 points)",
                    self.points
                ),
            );
        }
        positive("influence_radius", self.influence_radius)?;
        positive("kill_distance", self.kill_distance)?;
        positive("segment_length", self.segment_length)?;
        if self.kill_distance >= self.influence_radius {
            return bad(
                "kill_distance",
                format!(
                    "({}) must be less than generator.influence_radius ({}): a point inside the \
                     kill distance is removed before it can attract",
                    self.kill_distance, self.influence_radius
                ),
            );
        }
        if self.kill_distance < 0.5 * self.segment_length {
            return bad(
                "kill_distance",
                format!(
                    "({}) must be at least generator.segment_length / 2 ({}), or a branch can step \
                     over an attraction point and oscillate around it",
                    self.kill_distance,
                    0.5 * self.segment_length
                ),
            );
        }
        for (k, v) in self.tropism.iter().enumerate() {
            if !v.is_finite() {
                return bad("tropism", format!("component {k} must be a finite number, got {v}"));
            }
        }
        non_negative("tropism_weight", self.tropism_weight)?;
        non_negative("perturbation", self.perturbation)?;
        non_negative("trunk_height", self.trunk_height)?;
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            return bad(
                "max_iterations",
                format!("must be in 1..={MAX_ITERATIONS}, got {}", self.max_iterations),
            );
        }
        if !(1..=MAX_NODES).contains(&self.max_nodes) {
            return bad("max_nodes", format!("must be in 1..={MAX_NODES}, got {}", self.max_nodes));
        }
        let trunk = self.trunk_segments();
        if trunk >= self.max_nodes as f64 {
            return bad(
                "trunk_height",
                format!(
                    "needs {trunk} trunk segments of generator.segment_length {}, over the node budget \
                     generator.max_nodes = {}",
                    self.segment_length, self.max_nodes
                ),
            );
        }
        finite("pipe_exponent", self.pipe_exponent)?;
        if !(1.0..=4.0).contains(&self.pipe_exponent) {
            return bad(
                "pipe_exponent",
                format!("must be in [1, 4] (2 = da Vinci, 2–3 = Murray), got {}", self.pipe_exponent),
            );
        }
        positive("tip_radius", self.tip_radius)?;
        let l = &self.leaves;
        if l.count > MAX_LEAVES_PER_NODE {
            return bad("leaves.count", format!("must be at most {MAX_LEAVES_PER_NODE}, got {}", l.count));
        }
        non_negative("leaves.size", l.size)?;
        finite("leaves.size_variation", l.size_variation)?;
        if !(0.0..1.0).contains(&l.size_variation) {
            return bad("leaves.size_variation", format!("must be in [0, 1), got {}", l.size_variation));
        }
        finite("leaves.angle", l.angle)?;
        if !(0.0..=180.0).contains(&l.angle) {
            return bad("leaves.angle", format!("must be in [0, 180] degrees, got {}", l.angle));
        }
        Ok(())
    }

    /// Number of trunk segments (a float, so huge values do not overflow).
    pub(super) fn trunk_segments(&self) -> f64 {
        (self.trunk_height / self.segment_length - 1e-9).ceil().max(0.0)
    }
}
