//! The branching skeleton every generator writes and every mesher reads.
//!
//! A [`Skeleton`] is a forest of nodes stored **parent-first** (a node's parent always
//! has a smaller index) as struct-of-arrays. Each node is the end point of one
//! internode; a root node is the start point of an axis with no parent. Organs (leaves,
//! flowers, polygons) are a separate list of placed instances.
//!
//! McLoughlin2021 §2 (apex pre-order, "every child's base equals its parent's tip") and the
//! architecture's core types define this shape.

use glam::{DVec3, Vec3};

/// Parent index of a root node.
pub const NO_PARENT: u32 = u32::MAX;

/// Most nodes a skeleton read or drawn from outside data may have by default (issue 27):
/// the turtle and the skeleton readers (LST, JSON, `.str`) check it before they
/// allocate, so a file or grammar cannot ask the meshers for more than they can build
/// in memory (a tube mesh costs about 4 kB per node).
pub const DEFAULT_MAX_NODES: usize = 1_000_000;

/// How to raise the node budget, for messages.
pub const NODE_BUDGET_HELP: &str =
    "the skeleton node budget (`generator.max_nodes`, default 1,000,000) bounds what the meshers are \
     asked to build: grow fewer steps, or raise it with --set generator.max_nodes=N";

/// A placed organ (leaf, flower, petal) attached to a skeleton node.
#[derive(Debug, Clone, PartialEq)]
pub struct Organ {
    /// What kind of organ this is.
    pub kind: OrganKind,
    /// Node the organ hangs on (its petiole base), or [`NO_PARENT`] when free.
    pub node: u32,
    /// Base position of the organ.
    pub position: Vec3,
    /// Unit direction the organ points along (its midrib).
    pub heading: Vec3,
    /// Unit normal of the organ's blade (the turtle's up vector when placed).
    pub up: Vec3,
    /// Uniform size: the organ's length along its heading, in metres.
    pub size: f32,
    /// Material / colour index from the turtle (`;` and `,`).
    pub material: u32,
}

/// The kinds of organ the engine knows how to draw.
#[derive(Debug, Clone, PartialEq)]
pub enum OrganKind {
    /// A leaf blade drawn as a textured quad of length `size` (width `size / 2`).
    Leaf,
    /// A flat polygon traced by the turtle between `{` and `}` (vertices in world space).
    Polygon(Vec<Vec3>),
    /// A named surface (cpfg `~x`, a `.s` Bézier surface), scaled by `size`.
    Surface(String),
    /// A sphere of radius `size` (cpfg `@O`).
    Sphere,
    /// A disc of radius `size` facing along the heading (cpfg `@o`, `@c`).
    Disc,
    /// A swept surface: a cpfg generalized cylinder (`@Gs` … `@Ge`) drawn with a contour
    /// selected by `@#(n)`, as world-space cross-section rings.
    Swept(SweptSurface),
}

/// The cross-sections of a swept surface ([`OrganKind::Swept`]), in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct SweptSurface {
    /// The rings from the start of the sweep to its end, each the same number of points
    /// in the same order around (along) the contour.
    pub rings: Vec<Vec<Vec3>>,
    /// Whether each ring is a closed loop (its last point joins its first); an open
    /// ring (a leaf's cross-section) is a strip with two free edges.
    pub closed: bool,
}

/// A forest of branching axes, stored parent-first as struct-of-arrays.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Skeleton {
    /// Node positions in metres (+Y up).
    pub position: Vec<Vec3>,
    /// Branch radius at each node in metres (not the diameter).
    pub radius: Vec<f32>,
    /// Explicit radius at the **start** of the internode ending at each node, in metres:
    /// an internode is then a truncated cone from this radius to the node's `radius`
    /// (an LST `Cylinder(r0, r1, len)` keeps its r0 here). Empty when no node has one
    /// (every generator's skeleton); otherwise one entry per node, `None` where the
    /// mesher's own default applies (each mesher documents it, e.g. the parent node's
    /// radius along an axis). Ignored on roots. Read it with [`Skeleton::start_radius()`].
    pub start_radius: Vec<Option<f32>>,
    /// Parent node index, [`NO_PARENT`] for roots. Always smaller than the node's own index.
    pub parent: Vec<u32>,
    /// Orientation reference per node: a unit vector perpendicular (or nearly) to the
    /// incoming internode, e.g. the turtle's up vector. Meshers use it to start
    /// rotation-minimizing frames so cross-sections do not twist.
    pub up: Vec<Vec3>,
    /// Branch order: 0 for the trunk, +1 for each lateral branching.
    pub order: Vec<u16>,
    /// Material / colour index per node (from the turtle's `;`).
    pub material: Vec<u32>,
    /// Placed organs.
    pub organs: Vec<Organ>,
}

/// A problem found by [`Skeleton::validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SkeletonError {
    /// The struct-of-arrays columns differ in length.
    #[error("skeleton columns have different lengths (position {positions}, {column} {len})")]
    ColumnLength {
        /// Number of positions.
        positions: usize,
        /// Name of the mismatching column.
        column: &'static str,
        /// Its length.
        len: usize,
    },
    /// A node's parent index is not smaller than its own index.
    #[error("node {node} has parent {parent}, which does not come before it (parent-first order)")]
    ParentOrder {
        /// Offending node.
        node: usize,
        /// Its parent.
        parent: u32,
    },
    /// A node carries a NaN or infinite number.
    #[error("node {node} has a non-finite {field}")]
    NonFinite {
        /// Offending node.
        node: usize,
        /// Which field.
        field: &'static str,
    },
    /// A node has a negative radius.
    #[error("node {node} has a negative radius {radius}")]
    NegativeRadius {
        /// Offending node.
        node: usize,
        /// Its radius.
        radius: f32,
    },
    /// Too many nodes for u32 indices.
    #[error("skeleton has {0} nodes, more than u32 indices allow")]
    TooLarge(usize),
    /// An organ hangs on a node that does not exist.
    #[error("organ {organ} hangs on node {node}, but the skeleton has {nodes} nodes")]
    OrganNode {
        /// Offending organ.
        organ: usize,
        /// The node it names.
        node: u32,
        /// Number of nodes.
        nodes: usize,
    },
    /// An organ or node value that is finite but so large that geometry built from it
    /// overflows (`f32::MAX / 4`).
    #[error(
        "{what} {index} has a {field} of magnitude {value:e}, beyond the largest a mesh can be built from"
    )]
    OutOfRange {
        /// `node` or `organ`.
        what: &'static str,
        /// Its index.
        index: usize,
        /// Which field.
        field: &'static str,
        /// The value.
        value: f32,
    },
}

/// Largest coordinate, radius or size [`Skeleton::validate`] accepts: sums and
/// differences of a few of them (internode vectors, ring offsets) stay finite in `f32`.
pub const MAX_COORDINATE: f32 = f32::MAX / 16.0;

/// Summary statistics of a skeleton.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct SkeletonStats {
    /// Number of nodes.
    pub nodes: usize,
    /// Number of internodes (nodes with a parent).
    pub segments: usize,
    /// Number of roots.
    pub roots: usize,
    /// Number of tips (nodes with a parent and no children).
    pub tips: usize,
    /// Largest number of internodes from a root to a node.
    pub depth: usize,
    /// Largest branch order.
    pub max_order: u16,
    /// Sum of internode lengths in metres.
    pub total_length: f64,
    /// Number of organs.
    pub organs: usize,
    /// Axis-aligned bounds (min, max); zero when empty.
    pub bounds: (Vec3, Vec3),
}

impl Skeleton {
    /// An empty skeleton.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when the skeleton has no nodes.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Appends a node and returns its index. `parent` must be [`NO_PARENT`] or an
    /// existing node (checked by [`Skeleton::validate`], not here, to keep this cheap).
    pub fn push(&mut self, position: Vec3, radius: f32, parent: u32, up: Vec3, order: u16) -> u32 {
        let i = self.position.len() as u32;
        self.position.push(position);
        self.radius.push(radius);
        if !self.start_radius.is_empty() {
            self.start_radius.push(None);
        }
        self.parent.push(parent);
        self.up.push(up);
        self.order.push(order);
        self.material.push(0);
        i
    }

    /// The explicit start radius of the internode ending at `node` (the `start_radius`
    /// column), or `None` when the
    /// mesher's default applies (also for roots and out-of-range nodes).
    pub fn start_radius(&self, node: usize) -> Option<f32> {
        match self.parent.get(node) {
            Some(&p) if p != NO_PARENT => self.start_radius.get(node).copied().flatten(),
            _ => None,
        }
    }

    /// Sets the explicit start radius of the internode ending at `node` (creating the
    /// column on first use). Does nothing for a node that does not exist.
    pub fn set_start_radius(&mut self, node: usize, radius: Option<f32>) {
        if node >= self.len() {
            return;
        }
        if self.start_radius.len() != self.len() {
            self.start_radius.resize(self.len(), None);
        }
        self.start_radius[node] = radius;
    }

    /// Checks the invariants: equal column lengths (`start_radius` may also be empty),
    /// parent-first order (so parents are in range and the graph has no cycle), finite
    /// numbers no larger than [`MAX_COORDINATE`], non-negative radii (start radii too),
    /// organs on existing nodes with finite geometry.
    pub fn validate(&self) -> Result<(), SkeletonError> {
        let n = self.position.len();
        if n >= u32::MAX as usize {
            return Err(SkeletonError::TooLarge(n));
        }
        for (column, len) in [
            ("radius", self.radius.len()),
            ("parent", self.parent.len()),
            ("up", self.up.len()),
            ("order", self.order.len()),
            ("material", self.material.len()),
        ] {
            if len != n {
                return Err(SkeletonError::ColumnLength { positions: n, column, len });
            }
        }
        if !self.start_radius.is_empty() && self.start_radius.len() != n {
            return Err(SkeletonError::ColumnLength {
                positions: n,
                column: "start_radius",
                len: self.start_radius.len(),
            });
        }
        for (i, r) in self.start_radius.iter().enumerate() {
            match *r {
                Some(r) if !r.is_finite() => {
                    return Err(SkeletonError::NonFinite { node: i, field: "start radius" })
                }
                Some(r) if r < 0.0 => return Err(SkeletonError::NegativeRadius { node: i, radius: r }),
                Some(r) if r > MAX_COORDINATE => {
                    return Err(SkeletonError::OutOfRange {
                        what: "node",
                        index: i,
                        field: "start radius",
                        value: r,
                    })
                }
                _ => {}
            }
        }
        for i in 0..n {
            let p = self.parent[i];
            if p != NO_PARENT && p as usize >= i {
                return Err(SkeletonError::ParentOrder { node: i, parent: p });
            }
            if !self.position[i].is_finite() {
                return Err(SkeletonError::NonFinite { node: i, field: "position" });
            }
            if !self.up[i].is_finite() {
                return Err(SkeletonError::NonFinite { node: i, field: "orientation" });
            }
            let r = self.radius[i];
            if !r.is_finite() {
                return Err(SkeletonError::NonFinite { node: i, field: "radius" });
            }
            if r < 0.0 {
                return Err(SkeletonError::NegativeRadius { node: i, radius: r });
            }
            let far = self.position[i].abs().max_element();
            if far > MAX_COORDINATE {
                return Err(SkeletonError::OutOfRange {
                    what: "node",
                    index: i,
                    field: "position",
                    value: far,
                });
            }
            if r > MAX_COORDINATE {
                return Err(SkeletonError::OutOfRange { what: "node", index: i, field: "radius", value: r });
            }
        }
        for (k, o) in self.organs.iter().enumerate() {
            let vertices = match &o.kind {
                OrganKind::Polygon(v) => v.as_slice(),
                _ => &[],
            };
            let rings = match &o.kind {
                OrganKind::Swept(s) => s.rings.as_slice(),
                _ => &[],
            };
            let ok = o.position.is_finite()
                && o.heading.is_finite()
                && o.up.is_finite()
                && o.size.is_finite()
                && vertices.iter().all(|v| v.is_finite())
                && rings.iter().flatten().all(|v| v.is_finite());
            if !ok {
                return Err(SkeletonError::NonFinite { node: k, field: "organ" });
            }
            if o.node != NO_PARENT && o.node as usize >= n {
                return Err(SkeletonError::OrganNode { organ: k, node: o.node, nodes: n });
            }
            let far = rings
                .iter()
                .flatten()
                .fold(o.position.abs().max_element(), |m, v| m.max(v.abs().max_element()));
            for (field, value) in [("position", far), ("size", o.size.abs())] {
                if value > MAX_COORDINATE {
                    return Err(SkeletonError::OutOfRange { what: "organ", index: k, field, value });
                }
            }
        }
        Ok(())
    }

    /// Children of every node in compressed sparse rows: the children of node `i` are
    /// `children[offsets[i]..offsets[i + 1]]`, in increasing index order. O(n).
    pub fn children(&self) -> Children {
        let (offsets, children) = children_csr(self.len(), &self.parent);
        Children { offsets, children }
    }

    /// Summary statistics in one linear pass (plus the child index).
    pub fn stats(&self) -> SkeletonStats {
        let n = self.len();
        let mut s = SkeletonStats { nodes: n, organs: self.organs.len(), ..Default::default() };
        if n == 0 {
            return s;
        }
        let mut child_count = vec![0u32; n];
        let mut depth = vec![0usize; n];
        let (mut lo, mut hi) = (self.position[0], self.position[0]);
        for i in 0..n {
            let p = self.parent[i];
            lo = lo.min(self.position[i]);
            hi = hi.max(self.position[i]);
            s.max_order = s.max_order.max(self.order[i]);
            if p == NO_PARENT {
                s.roots += 1;
                continue;
            }
            let p = p as usize;
            s.segments += 1;
            child_count[p] += 1;
            depth[i] = depth[p] + 1;
            s.depth = s.depth.max(depth[i]);
            s.total_length += self.position[i].as_dvec3().distance(self.position[p].as_dvec3());
        }
        s.tips = (0..n).filter(|&i| self.parent[i] != NO_PARENT && child_count[i] == 0).count();
        s.bounds = (lo, hi);
        s
    }

    /// Length of the internode ending at `node` (0 for roots).
    pub fn internode_length(&self, node: usize) -> f64 {
        match self.parent[node] {
            NO_PARENT => 0.0,
            p => {
                let a: DVec3 = self.position[p as usize].as_dvec3();
                a.distance(self.position[node].as_dvec3())
            }
        }
    }
}

/// A radius more than this many times the skeleton's size (the diagonal of its nodes'
/// bounding box) is absurd: every internode's capsule would hold the whole tree
/// ([`Degeneracy::absurd_radius`]).
pub const ABSURD_RADIUS_RATIO: f64 = 1000.0;

/// Candidate pairs per internode over which a skeleton is crowded
/// ([`Degeneracy::crowded`]): a tree's internode capsules overlap a few neighbours each.
pub const CROWDED_PAIRS_PER_INTERNODE: u64 = 64;

/// Candidate pairs under which a skeleton is never crowded, whatever its size. The
/// presets have at most 17 pairs per internode (`wp-weeping-willow`; the small ones at
/// most 7: `wp-palm`'s 574 internodes, 3,890 pairs); 528 nodes of radius 1e30 spaced
/// 2e27 apart make 117,010 pairs, whose de-collision took 11.7 s under the old floor of
/// 10⁶.
pub const CROWDED_MIN_PAIRS: u64 = 20_000;

/// Zero-length internodes a skeleton may have however many it has in all
/// ([`Degeneracy::crowded`]; none of the presets has any).
pub const PILED_ZERO_LENGTH: usize = 64;

/// Degenerate geometry of a skeleton (issue 39), found by `fit::degenerate::degeneracy`
/// before the stages whose collision searches it would make quadratic (the joint
/// meshers' repairs, `mesh.decollide`, `mesh.clear`): zero-length and reversing
/// internodes, coincident nodes, and radii absurd for the lengths. Internodes are named
/// by their child node.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Degeneracy {
    /// Internodes (nodes with a parent).
    pub internodes: usize,
    /// Internodes of zero length (within float noise of their coordinates), and the first.
    pub zero_length: usize,
    /// The first zero-length internode.
    pub first_zero_length: Option<u32>,
    /// Internodes that turn straight back along their parent's (within 2.5°), and the
    /// first.
    pub reversing: usize,
    /// The first reversing internode.
    pub first_reversing: Option<u32>,
    /// The node of the largest radius, and that radius.
    pub max_radius: Option<(u32, f32)>,
    /// The diagonal of the nodes' bounding box.
    pub size: f64,
    /// Pairs of internodes whose capsules' boxes overlap (the candidate pairs of every
    /// collision search), counted up to the limit `fit::degenerate::degeneracy` was given.
    pub pairs: u64,
    /// The internode whose box overlaps the most others among those counted, and how many.
    pub busiest: Option<(u32, u64)>,
}

impl Degeneracy {
    /// The node and radius when the largest radius is over [`ABSURD_RADIUS_RATIO`] times
    /// the skeleton's size (a skeleton whose nodes all lie at one point has no size: its
    /// internodes are zero-length, not its radii absurd).
    pub fn absurd_radius(&self) -> Option<(u32, f32)> {
        let (node, r) = self.max_radius?;
        (self.internodes > 0 && self.size > 0.0 && (r as f64) > ABSURD_RADIUS_RATIO * self.size)
            .then_some((node, r))
    }

    /// The pair limit over which a skeleton of `internodes` internodes is crowded.
    pub fn crowded_limit(internodes: usize) -> u64 {
        (internodes as u64).saturating_mul(CROWDED_PAIRS_PER_INTERNODE).max(CROWDED_MIN_PAIRS)
    }

    /// Whether the candidate pairs are over [`Degeneracy::crowded_limit`], or more than
    /// [`PILED_ZERO_LENGTH`] internodes, and over a quarter of them, have zero length
    /// (a pile of coincident nodes: every pair of it is measured through the whole
    /// pile).
    pub fn crowded(&self) -> bool {
        self.pairs > Self::crowded_limit(self.internodes)
            || (self.zero_length > PILED_ZERO_LENGTH && self.zero_length * 4 > self.internodes)
    }
}

/// Child lists of a [`Skeleton`] in compressed sparse rows (see [`Skeleton::children`]).
#[derive(Debug, Clone)]
pub struct Children {
    offsets: Vec<u32>,
    children: Vec<u32>,
}

impl Children {
    /// The children of node `i`, in increasing index order.
    pub fn of(&self, i: usize) -> &[u32] {
        &self.children[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }
}

/// Children of the `n` nodes of a parent array (`NO_PARENT` for roots) in compressed
/// sparse rows `(offsets, children)`: the children of node `i` are
/// `children[offsets[i]..offsets[i + 1]]`, in increasing index order. O(n). Shared by
/// [`Skeleton::children`] and the least-cost generator's path trees.
pub(crate) fn children_csr(n: usize, parent: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; n + 1];
    for &p in parent {
        if p != NO_PARENT {
            offsets[p as usize + 1] += 1;
        }
    }
    for i in 0..n {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut children = vec![0u32; offsets[n] as usize];
    for (i, &p) in parent.iter().enumerate() {
        if p != NO_PARENT {
            let slot = &mut fill[p as usize];
            children[*slot as usize] = i as u32;
            *slot += 1;
        }
    }
    (offsets, children)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn y_fork() -> Skeleton {
        let mut s = Skeleton::new();
        let r = s.push(Vec3::ZERO, 0.1, NO_PARENT, Vec3::X, 0);
        let a = s.push(Vec3::Y, 0.1, r, Vec3::X, 0);
        s.push(Vec3::new(0.0, 2.0, 0.0), 0.05, a, Vec3::X, 0);
        s.push(Vec3::new(1.0, 1.0, 0.0), 0.05, a, Vec3::X, 1);
        s
    }

    #[test]
    fn stats_of_a_fork() {
        let s = y_fork();
        s.validate().unwrap();
        let st = s.stats();
        assert_eq!(st.nodes, 4);
        assert_eq!(st.segments, 3);
        assert_eq!(st.roots, 1);
        assert_eq!(st.tips, 2);
        assert_eq!(st.depth, 2);
        assert_eq!(st.max_order, 1);
        assert!((st.total_length - 3.0).abs() < 1e-9);
        let c = s.children();
        assert_eq!(c.of(1), &[2, 3]);
        assert!(c.of(3).is_empty());
    }

    #[test]
    fn validate_rejects_bad_nodes() {
        let mut s = y_fork();
        s.radius[2] = -1.0;
        assert!(matches!(s.validate(), Err(SkeletonError::NegativeRadius { node: 2, .. })));
        let mut s = y_fork();
        s.position[1].x = f32::NAN;
        assert!(matches!(s.validate(), Err(SkeletonError::NonFinite { node: 1, .. })));
        let mut s = y_fork();
        s.parent[1] = 3;
        assert!(matches!(s.validate(), Err(SkeletonError::ParentOrder { node: 1, .. })));
    }
}
