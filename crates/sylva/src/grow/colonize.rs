//! Space colonization: trees grown towards attraction points that fill a crown envelope
//! (Runions, Lane & Prusinkiewicz 2007, "Modeling Trees with a Space Colonization
//! Algorithm", §3 "Algorithm" with the open-growth envelope of §4 and the tropism and
//! pipe-model extensions of §5).
//!
//! # Algorithm
//!
//! 1. **Attraction points.** [`ColonizeParams::points`] points are sampled uniformly
//!    inside the crown [`Envelope`] (rejection sampling in its bounding box).
//! 2. **Trunk.** A root node sits at the origin; a straight trunk of
//!    `ceil(trunk_height / segment_length)` segments grows up +Y. While no attraction
//!    point is within the influence radius of any node, the leader keeps growing straight
//!    up one segment per iteration (the paper's "when no points are near the root"
//!    start), until it passes the top of the envelope (then growth has stalled).
//! 3. **Iteration** (paper §3, Fig. 3):
//!    - every attraction point is associated with its *closest* node, if that node lies
//!      within `influence_radius`;
//!    - every node `v` with a non-empty set `S(v)` of attractors grows one new node
//!      `v' = v + D·n`, with `n` the normalized sum of the unit vectors from `v` to its
//!      attractors, plus `tropism_weight` times the unit tropism vector, plus
//!      `perturbation` times a random unit vector (each sum normalized again);
//!    - every attraction point within `kill_distance` of a node (inclusive) is removed.
//!
//!    Growth stops when no points are left, when no node has attractors or none could
//!    grow (*stalled*), or after `max_iterations`.
//! 4. **Radii** by the pipe model (paper §5, after Shinozaki et al. 1964 and
//!    Murray 1927): tips get `tip_radius`, and every node `r^n = Σ r_child^n` with
//!    `n = pipe_exponent` (2 = da Vinci's rule, 2–3 = Murray's law), in one bottom-up
//!    pass in `f64` over the parent-first arrays, then stored as `f32`.
//! 5. **Leaves** are [`OrganKind::Leaf`] quads on the last `leaves.nodes` nodes of every
//!    tip (see [`ColonizeLeaves`]).
//!
//! # Neighbour queries
//!
//! Nodes are never removed and attraction points never move, so the closest node of a
//! point can only change when a node is added. Instead of querying every point against
//! all nodes each iteration, each *new* node asks a `kiddo` k-d tree over the live
//! attraction points for the points within the influence radius, and updates their
//! closest node (ties keep the older, lower-index node) or removes them when they are
//! within the kill distance. This gives exactly the paper's association and kill sets at
//! every iteration, at a cost proportional to the points near new nodes. The k-d tree is
//! rebuilt from the live points when more than a quarter of its points are dead, and
//! the points are stored in Morton (Z-curve) order so neighbours are near in memory.
//!
//! # Conventions
//!
//! Metres, +Y up, the root at the origin; positions are computed in `f64` and stored as
//! `f32`. Nodes are appended in creation order, so the skeleton is parent-first. Branch
//! order: at every node, the child carrying the largest pipe radius (ties: the one most
//! aligned with the incoming internode, then the lower index) keeps the node's order, the
//! others get order + 1. `up` is a stable perpendicular at the root, carried along every
//! path by parallel transport (the minimal rotation between consecutive internodes), so
//! tube rings do not twist. A node never grows two children whose directions (before
//! perturbation) are closer than [`DUPLICATE_ANGLE_DEG`]: when an attractor set does not
//! change between iterations the paper's rule would grow the same child twice.
//!
//! Deterministic: three PCG streams (points, perturbation, leaves) seeded from the
//! seed; every loop runs in node or point index order.

use crate::error::{Error, Result};
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DQuat, DVec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};
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
/// Most sampling attempts per requested point for a mesh envelope before giving up.
const MESH_ATTEMPTS_PER_POINT: usize = 1000;

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

fn bad<T>(key: &str, why: impl std::fmt::Display) -> Result<T> {
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
    fn trunk_segments(&self) -> f64 {
        (self.trunk_height / self.segment_length - 1e-9).ceil().max(0.0)
    }
}

/// A region points can be sampled in and tested against.
enum Region {
    Sphere { c: DVec3, r: f64 },
    Ellipsoid { c: DVec3, r: DVec3 },
    Cone { b: f64, h: f64, r: f64 },
    Cylinder { b: f64, h: f64, r: f64 },
    Mesh(MeshRegion),
}

impl Region {
    fn new(env: &Envelope, read: &dyn Fn(&str) -> Result<(String, String)>) -> Result<Region> {
        Ok(match *env {
            Envelope::Sphere { center_height, radius } => {
                Region::Sphere { c: DVec3::new(0.0, center_height, 0.0), r: radius }
            }
            Envelope::Ellipsoid { center_height, radii } => {
                Region::Ellipsoid { c: DVec3::new(0.0, center_height, 0.0), r: DVec3::from_array(radii) }
            }
            Envelope::Cone { base_height, height, radius } => {
                Region::Cone { b: base_height, h: height, r: radius }
            }
            Envelope::Cylinder { base_height, height, radius } => {
                Region::Cylinder { b: base_height, h: height, r: radius }
            }
            Envelope::Mesh { ref file } => {
                let (name, text) = read(file)?;
                Region::Mesh(MeshRegion::parse(&name, &text)?)
            }
        })
    }

    /// Axis-aligned bounds (min, max).
    fn bounds(&self) -> (DVec3, DVec3) {
        match self {
            Region::Sphere { c, r } => (*c - DVec3::splat(*r), *c + DVec3::splat(*r)),
            Region::Ellipsoid { c, r } => (*c - *r, *c + *r),
            Region::Cone { b, h, r } | Region::Cylinder { b, h, r } => {
                (DVec3::new(-r, *b, -r), DVec3::new(*r, b + h, *r))
            }
            Region::Mesh(m) => (m.lo, m.hi),
        }
    }

    fn contains(&self, p: DVec3) -> bool {
        match self {
            Region::Sphere { c, r } => (p - *c).length_squared() <= r * r,
            Region::Ellipsoid { c, r } => ((p - *c) / *r).length_squared() <= 1.0,
            Region::Cone { b, h, r } => {
                let t = (p.y - b) / h;
                (0.0..=1.0).contains(&t) && (p.x * p.x + p.z * p.z).sqrt() <= r * (1.0 - t)
            }
            Region::Cylinder { b, h, r } => p.y >= *b && p.y <= b + h && p.x * p.x + p.z * p.z <= r * r,
            Region::Mesh(m) => m.contains(p),
        }
    }

    /// `n` points uniformly inside the region, by rejection in its bounding box.
    fn sample(&self, n: usize, rng: &mut Pcg64) -> Result<Vec<DVec3>> {
        let (lo, hi) = self.bounds();
        let span = hi - lo;
        let mut out = Vec::with_capacity(n);
        let limit = match self {
            Region::Mesh(_) => n.saturating_mul(MESH_ATTEMPTS_PER_POINT).max(1_000_000),
            _ => usize::MAX, // analytic shapes accept ≥ π/12 of their box
        };
        let mut attempts = 0usize;
        while out.len() < n {
            if attempts >= limit {
                return bad(
                    "envelope.file",
                    format!(
                        "encloses too little of its bounding box: {} of {n} points inside after \
                         {attempts} tries (is the mesh closed?)",
                        out.len()
                    ),
                );
            }
            attempts += 1;
            let u = DVec3::new(rng.random::<f64>(), rng.random::<f64>(), rng.random::<f64>());
            let p = lo + span * u;
            if self.contains(p) {
                out.push(p);
            }
        }
        Ok(out)
    }
}

/// A closed mesh with a (y, z) grid of triangles for ray-parity inside tests along +X.
struct MeshRegion {
    tris: Vec<[DVec3; 3]>,
    lo: DVec3,
    hi: DVec3,
    cells: (usize, usize),
    /// CSR: triangles overlapping grid cell `j * cells.0 + i` (i along y, j along z).
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl MeshRegion {
    fn parse(name: &str, text: &str) -> Result<MeshRegion> {
        let obj = crate::mesh::obj_read::parse_obj(text)
            .map_err(|e| Error::Recipe(format!("`generator.envelope.file` {name}: {e}")))?;
        let m = &obj.mesh;
        let mut tris = Vec::new();
        for f in 0..m.face_count() {
            let face = m.face(f);
            for k in 1..face.len().saturating_sub(1) {
                let v = [face[0], face[k], face[k + 1]];
                if v.iter().any(|&i| i as usize >= m.positions.len()) {
                    return bad("envelope.file", format!("{name}: face {f} has a bad vertex index"));
                }
                let t = v.map(|i| m.positions[i as usize].as_dvec3());
                if t.iter().all(|p| p.is_finite()) {
                    tris.push(t);
                }
            }
        }
        if tris.len() < 4 {
            return bad(
                "envelope.file",
                format!("{name}: a closed envelope needs at least 4 triangles, got {}", tris.len()),
            );
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &tris {
            for p in t {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        let span = hi - lo;
        if !(span.x > 0.0 && span.y > 0.0 && span.z > 0.0) {
            return bad(
                "envelope.file",
                format!("{name}: the mesh is flat (bounds {lo} to {hi}); it must enclose a volume"),
            );
        }
        let side = ((tris.len() as f64).sqrt().ceil() as usize).clamp(1, 256);
        let cells = (side, side);
        let cell_of = |y: f64, z: f64| {
            let i = (((y - lo.y) / span.y) * side as f64).floor().clamp(0.0, (side - 1) as f64) as usize;
            let j = (((z - lo.z) / span.z) * side as f64).floor().clamp(0.0, (side - 1) as f64) as usize;
            (i, j)
        };
        let mut counts = vec![0u32; side * side + 1];
        let ranges: Vec<((usize, usize), (usize, usize))> = tris
            .iter()
            .map(|t| {
                let (ymin, ymax) = (t[0].y.min(t[1].y).min(t[2].y), t[0].y.max(t[1].y).max(t[2].y));
                let (zmin, zmax) = (t[0].z.min(t[1].z).min(t[2].z), t[0].z.max(t[1].z).max(t[2].z));
                (cell_of(ymin, zmin), cell_of(ymax, zmax))
            })
            .collect();
        for &((i0, j0), (i1, j1)) in &ranges {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    counts[j * side + i + 1] += 1;
                }
            }
        }
        for k in 0..side * side {
            counts[k + 1] += counts[k];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; counts[side * side] as usize];
        for (t, &((i0, j0), (i1, j1))) in ranges.iter().enumerate() {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let slot = &mut fill[j * side + i];
                    items[*slot as usize] = t as u32;
                    *slot += 1;
                }
            }
        }
        Ok(MeshRegion { tris, lo, hi, cells, offsets: counts, items })
    }

    /// Ray parity along +X, with rays through shared edges and vertices counted once.
    fn contains(&self, p: DVec3) -> bool {
        if p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return false;
        }
        let span = self.hi - self.lo;
        let (sy, sz) = self.cells;
        let i = (((p.y - self.lo.y) / span.y) * sy as f64).floor().clamp(0.0, (sy - 1) as f64) as usize;
        let j = (((p.z - self.lo.z) / span.z) * sz as f64).floor().clamp(0.0, (sz - 1) as f64) as usize;
        let c = j * sy + i;
        let mut inside = false;
        for &t in &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize] {
            let [a, b, d] = self.tris[t as usize];
            // Edge functions of (p.y, p.z) in the triangle's (y, z) projection.
            let e = |u: DVec3, v: DVec3| (v.y - u.y) * (p.z - u.z) - (v.z - u.z) * (p.y - u.y);
            let (w0, w1, w2) = (e(b, d), e(d, a), e(a, b));
            let area = w0 + w1 + w2;
            if area == 0.0 {
                continue;
            }
            // A ray through a shared edge or vertex must cross exactly one of the
            // triangles there: a zero edge function counts as inside only for edges
            // pointing +z (or +y when horizontal), i.e. the point is symbolically moved
            // by (−ε, ε²) in (y, z). Edges are taken counter-clockwise.
            let s = area.signum();
            let counts = |w: f64, u: DVec3, v: DVec3| {
                let (w, dy, dz) = (w * s, (v.y - u.y) * s, (v.z - u.z) * s);
                w > 0.0 || (w == 0.0 && (dz > 0.0 || (dz == 0.0 && dy > 0.0)))
            };
            if !(counts(w0, b, d) && counts(w1, d, a) && counts(w2, a, b)) {
                continue;
            }
            let x = (w0 * a.x + w1 * b.x + w2 * d.x) / area;
            if x > p.x {
                inside = !inside;
            }
        }
        inside
    }
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
/// Errors: [`Error::Recipe`] naming the key for bad parameters or an exceeded node
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

use crate::geometry::NONE;
/// The k-d tree is rebuilt from the live points when more than 1/REBUILD of its points are dead.
const REBUILD: usize = 4;

/// The growing tree and its attraction points.
struct Growth {
    // Nodes.
    pos: Vec<DVec3>,
    parent: Vec<u32>,
    /// Growth direction before perturbation (duplicate test), per node.
    dir0: Vec<DVec3>,
    first_child: Vec<u32>,
    next_sibling: Vec<u32>,
    /// Per node: sum of unit directions to its attractors, and their count.
    sum: Vec<DVec3>,
    count: Vec<u32>,
    // Attraction points.
    /// The attraction points, in Morton order (see [`spatial_order`]).
    pts: Vec<Point>,
    /// Live points in increasing index order (compacted once per iteration).
    live: Vec<u32>,
    /// k-d tree over a subset of the points (item = index into `tree_items`).
    tree: Option<ImmutableKdTree<f64, 3>>,
    tree_items: Vec<u32>,
    tree_dead: usize,
    // Parameters.
    di2: f64,
    dk2: f64,
    step: f64,
    max_nodes: usize,
    // Results.
    iterations: u32,
    stalled: bool,
}

impl Growth {
    fn new(p: &ColonizeParams, pts: Vec<DVec3>) -> Result<Growth> {
        let n = pts.len();
        let mut g = Growth {
            pos: Vec::new(),
            parent: Vec::new(),
            dir0: Vec::new(),
            first_child: Vec::new(),
            next_sibling: Vec::new(),
            sum: Vec::new(),
            count: Vec::new(),
            live: (0..n as u32).collect(),
            pts: spatial_order(&pts)
                .into_iter()
                .map(|i| Point { p: pts[i as usize], best: f64::INFINITY, closest: NONE, alive: true })
                .collect(),
            tree: None,
            tree_items: Vec::new(),
            tree_dead: 0,
            di2: p.influence_radius * p.influence_radius,
            dk2: p.kill_distance * p.kill_distance,
            step: p.segment_length,
            max_nodes: p.max_nodes,
            iterations: 0,
            stalled: false,
        };
        g.rebuild_tree()?;
        Ok(g)
    }

    fn rebuild_tree(&mut self) -> Result<()> {
        self.tree_items.clear();
        self.tree_items.extend(self.live.iter().copied().filter(|&i| self.pts[i as usize].alive));
        self.tree_dead = 0;
        if self.tree_items.is_empty() {
            self.tree = None;
            return Ok(());
        }
        let coords: Vec<[f64; 3]> =
            self.tree_items.iter().map(|&i| self.pts[i as usize].p.to_array()).collect();
        let tree = ImmutableKdTree::<f64, 3>::new_from_slice(&coords).map_err(|e| {
            Error::InvalidGeometry { what: "space colonization".into(), why: format!("k-d tree: {e:?}") }
        })?;
        self.tree = Some(tree);
        Ok(())
    }

    fn add_node(&mut self, pos: DVec3, parent: u32, dir0: DVec3) -> Result<u32> {
        let i = self.pos.len();
        if i >= self.max_nodes {
            return bad(
                "max_nodes",
                format!(
                    "budget of {} nodes is exhausted; raise generator.max_nodes or lower \
                     generator.points / raise generator.segment_length",
                    self.max_nodes
                ),
            );
        }
        self.pos.push(pos);
        self.parent.push(parent);
        self.dir0.push(dir0);
        self.first_child.push(NONE);
        self.next_sibling.push(NONE);
        self.sum.push(DVec3::ZERO);
        self.count.push(0);
        if parent != NONE {
            // Append at the end of the parent's child list (keeps creation order).
            let p = parent as usize;
            match self.first_child[p] {
                NONE => self.first_child[p] = i as u32,
                mut c => {
                    while self.next_sibling[c as usize] != NONE {
                        c = self.next_sibling[c as usize];
                    }
                    self.next_sibling[c as usize] = i as u32;
                }
            }
        }
        Ok(i as u32)
    }

    /// Associates the points near nodes `from..` with them, or kills them.
    fn visit_new_nodes(&mut self, from: usize) -> Result<()> {
        let Some(tree) = &self.tree else { return Ok(()) };
        let (di2, dk2) = (self.di2, self.dk2);
        let mut dead = 0usize;
        for k in from..self.pos.len() {
            let q = self.pos[k];
            let (pts, items) = (&mut self.pts, &self.tree_items);
            tree.query(&q.to_array()).within::<SquaredEuclidean<f64>>(di2).unsorted().visit(|r| {
                let pt = &mut pts[items[r.item as usize] as usize];
                if !pt.alive {
                    return;
                }
                let d2 = (pt.p - q).length_squared();
                if d2 <= dk2 {
                    pt.alive = false;
                    dead += 1;
                } else if d2 <= di2 && d2 < pt.best {
                    pt.best = d2;
                    pt.closest = k as u32;
                }
            });
        }
        self.tree_dead += dead;
        if self.tree_dead * REBUILD > self.tree_items.len() {
            self.live.retain(|&i| self.pts[i as usize].alive);
            self.rebuild_tree()?;
        }
        Ok(())
    }

    fn run(&mut self, p: &ColonizeParams, top: f64, rng: &mut Pcg64) -> Result<()> {
        // Root and straight trunk.
        self.add_node(DVec3::ZERO, NONE, DVec3::Y)?;
        let trunk = p.trunk_segments() as usize;
        for k in 0..trunk {
            let q = DVec3::new(0.0, self.step * (k + 1) as f64, 0.0);
            self.add_node(q, k as u32, DVec3::Y)?;
        }
        self.visit_new_nodes(0)?;
        let mut leader = self.pos.len() as u32 - 1;
        let mut reached = false;
        let tropism = DVec3::from_array(p.tropism).normalize_or_zero() * p.tropism_weight;
        let dup_cos = DUPLICATE_ANGLE_DEG.to_radians().cos();
        let mut touched: Vec<u32> = Vec::new();
        loop {
            self.live.retain(|&i| self.pts[i as usize].alive);
            if self.live.is_empty() || self.iterations >= p.max_iterations {
                break;
            }
            // Association: sum of unit directions per node, in point index order.
            touched.clear();
            for &i in &self.live {
                let pt = &self.pts[i as usize];
                let c = pt.closest;
                if c == NONE {
                    continue;
                }
                let c = c as usize;
                let v = (pt.p - self.pos[c]) / pt.best.sqrt();
                if self.count[c] == 0 {
                    touched.push(c as u32);
                    self.sum[c] = DVec3::ZERO;
                }
                self.sum[c] += v;
                self.count[c] += 1;
            }
            let first_new = self.pos.len();
            if touched.is_empty() {
                if reached || self.pos[leader as usize].y > top {
                    self.stalled = true;
                    break;
                }
                // No point near any node yet: extend the leader straight up.
                let q = self.pos[leader as usize] + DVec3::Y * self.step;
                leader = self.add_node(q, leader, DVec3::Y)?;
            } else {
                reached = true;
                touched.sort_unstable();
                for &c in &touched {
                    let c = c as usize;
                    let (s, n) = (self.sum[c], self.count[c]);
                    self.count[c] = 0;
                    let len = s.length();
                    if len.is_nan() || len <= 1e-9 * n as f64 {
                        continue; // attractors on opposite sides cancel: no direction
                    }
                    let mut d = s / len;
                    if tropism != DVec3::ZERO {
                        let t = d + tropism;
                        let l = t.length();
                        if l.is_nan() || l <= 1e-9 {
                            continue;
                        }
                        d = t / l;
                    }
                    let mut ch = self.first_child[c];
                    let mut dup = false;
                    while ch != NONE {
                        if self.dir0[ch as usize].dot(d) > dup_cos {
                            dup = true;
                            break;
                        }
                        ch = self.next_sibling[ch as usize];
                    }
                    if dup {
                        continue;
                    }
                    let mut g = d;
                    if p.perturbation > 0.0 {
                        g = (d + random_unit(rng) * p.perturbation).try_normalize().unwrap_or(d);
                    }
                    let q = self.pos[c] + g * self.step;
                    self.add_node(q, c as u32, d)?;
                }
                if self.pos.len() == first_new {
                    self.stalled = true;
                    break;
                }
            }
            self.iterations += 1;
            self.visit_new_nodes(first_new)?;
        }
        self.live.retain(|&i| self.pts[i as usize].alive);
        Ok(())
    }

    /// Radii, orders, up vectors and leaves; returns the skeleton and its tip count.
    fn skeleton(&self, p: &ColonizeParams, rng: &mut Pcg64) -> Result<(Skeleton, usize)> {
        let n = self.pos.len();
        // Pipe model, bottom-up in f64.
        let e = p.pipe_exponent;
        let tip_w = p.tip_radius.powf(e);
        let mut w = vec![0.0f64; n];
        for i in (0..n).rev() {
            if self.first_child[i] == NONE {
                w[i] = tip_w;
            }
            let par = self.parent[i];
            if par != NONE {
                w[par as usize] += w[i];
            }
        }
        // Incoming unit directions (root: towards its first child, else +Y).
        let mut t_in = vec![DVec3::Y; n];
        for (i, t) in t_in.iter_mut().enumerate().skip(1) {
            let par = self.parent[i] as usize;
            *t = (self.pos[i] - self.pos[par]).try_normalize().unwrap_or(DVec3::Y);
        }
        if n > 1 && self.first_child[0] != NONE {
            t_in[0] = t_in[self.first_child[0] as usize];
        }
        // Orders, parent-first: the main child keeps the order.
        let mut order = vec![0u16; n];
        for i in 0..n {
            let mut main = NONE;
            let mut ch = self.first_child[i];
            while ch != NONE {
                let c = ch as usize;
                let better = main == NONE || {
                    let m = main as usize;
                    w[c] > w[m] || (w[c] == w[m] && t_in[c].dot(t_in[i]) > t_in[m].dot(t_in[i]))
                };
                if better {
                    main = ch;
                }
                ch = self.next_sibling[c];
            }
            let mut ch = self.first_child[i];
            while ch != NONE {
                let c = ch as usize;
                order[c] = if ch == main { order[i] } else { order[i].saturating_add(1) };
                ch = self.next_sibling[c];
            }
        }
        // Up vectors by parallel transport.
        let mut up = vec![DVec3::X; n];
        if n > 0 {
            up[0] = perpendicular(t_in[0]);
        }
        for i in 1..n {
            let par = self.parent[i] as usize;
            let rot = DQuat::from_rotation_arc(t_in[par], t_in[i]);
            let u = rot * up[par];
            let u = u - t_in[i] * u.dot(t_in[i]);
            up[i] = u.try_normalize().unwrap_or_else(|| perpendicular(t_in[i]));
        }
        let mut sk = Skeleton::new();
        sk.position.reserve(n);
        for i in 0..n {
            let par = if self.parent[i] == NONE { NO_PARENT } else { self.parent[i] };
            sk.push(self.pos[i].as_vec3(), w[i].powf(1.0 / e) as f32, par, up[i].as_vec3(), order[i]);
        }
        let tips = (1..n).filter(|&i| self.first_child[i] == NONE).count();
        self.leaves(p, &t_in, &up, &mut sk, rng)?;
        Ok((sk, tips))
    }

    /// Leaf organs on the last `leaves.nodes` nodes of every tip.
    fn leaves(
        &self,
        p: &ColonizeParams,
        t_in: &[DVec3],
        up: &[DVec3],
        sk: &mut Skeleton,
        rng: &mut Pcg64,
    ) -> Result<()> {
        let l = &p.leaves;
        let n = self.pos.len();
        if l.count == 0 || l.nodes == 0 || l.size <= 0.0 || n < 2 {
            return Ok(());
        }
        let mut leafy = vec![false; n];
        let mut total = 0usize;
        for tip in 1..n {
            if self.first_child[tip] != NONE {
                continue;
            }
            let mut v = tip;
            for k in 0..l.nodes {
                if self.parent[v] == NONE {
                    break;
                }
                // Beyond the tip, only unbranched nodes (one child).
                if k > 0 && (self.next_sibling[self.first_child[v] as usize] != NONE) {
                    break;
                }
                if !leafy[v] {
                    leafy[v] = true;
                    total += l.count as usize;
                }
                v = self.parent[v] as usize;
            }
        }
        if total > MAX_LEAVES {
            return bad(
                "leaves.count",
                format!("would place {total} leaves, over the budget of {MAX_LEAVES}; lower generator.leaves.count or generator.leaves.nodes"),
            );
        }
        sk.organs.reserve(total);
        const GOLDEN: f64 = 2.399_963_229_728_653; // π (3 − √5)
        let alpha = l.angle.to_radians();
        for i in 0..n {
            if !leafy[i] {
                continue;
            }
            let t = t_in[i];
            let u = up[i];
            let b = t.cross(u);
            let par = self.parent[i] as usize;
            let seg = (self.pos[i] - self.pos[par]).length();
            let phase = rng.random::<f64>() * std::f64::consts::TAU;
            for k in 0..l.count {
                let phi = phase + GOLDEN * k as f64;
                let side = u * phi.cos() + b * phi.sin();
                let heading = t * alpha.cos() + side * alpha.sin();
                let x = t.cross(side);
                let mut normal = x.cross(heading);
                if normal.y < 0.0 {
                    normal = -normal;
                }
                let along = seg * k as f64 / l.count as f64;
                let jitter = 1.0 + l.size_variation * (2.0 * rng.random::<f64>() - 1.0);
                sk.organs.push(Organ {
                    kind: OrganKind::Leaf,
                    node: i as u32,
                    position: (self.pos[i] - t * along).as_vec3(),
                    heading: heading.as_vec3(),
                    up: normal.as_vec3(),
                    size: (l.size * jitter) as f32,
                    material: 0,
                });
            }
        }
        Ok(())
    }
}

/// One attraction point and its association.
struct Point {
    p: DVec3,
    /// Squared distance to `closest`.
    best: f64,
    /// Closest node within the influence radius, or `NONE`.
    closest: u32,
    alive: bool,
}

/// Indices of `pts` sorted along a Morton (Z-order) curve over their bounds (ties by
/// index), so points near in space are near in memory and in the k-d tree's items.
fn spatial_order(pts: &[DVec3]) -> Vec<u32> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in pts {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let scale = (hi - lo).max(DVec3::splat(1e-300));
    let spread = |v: f64| -> u64 {
        let mut x = ((v.clamp(0.0, 1.0)) * 1_048_575.0) as u64; // 20 bits
        x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
        x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
        x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
        x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
        x = (x | (x << 2)) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, u32)> = pts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let u = (*p - lo) / scale;
            (spread(u.x) | (spread(u.y) << 1) | (spread(u.z) << 2), i as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// A uniformly distributed random unit vector.
fn random_unit(rng: &mut Pcg64) -> DVec3 {
    let z = 2.0 * rng.random::<f64>() - 1.0;
    let phi = std::f64::consts::TAU * rng.random::<f64>();
    let s = (1.0 - z * z).max(0.0).sqrt();
    DVec3::new(s * phi.cos(), z, s * phi.sin())
}

/// A stable unit vector perpendicular to the unit vector `t`.
fn perpendicular(t: DVec3) -> DVec3 {
    let a = if t.x.abs() < 0.9 { DVec3::X } else { DVec3::Z };
    (a - t * a.dot(t)).try_normalize().unwrap_or(DVec3::Z)
}

#[cfg(test)]
mod tests {
    use super::*;

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
