//! The sweep mesher: a triangle control mesh for Loop subdivision made of hexagonal
//! cross-sections swept along every internode and joined at branch points by junction
//! templates, after MacMurchy2004 §5.2–§5.5.3 and §A.3 as distilled by MacMurchy2004-spec §2.2–§2.8.
//!
//! # Construction
//!
//! 1. **Graph.** Internodes shorter than float noise are collapsed into their parent
//!    node (reported in [`SweepMesh::collapsed`]). A *junction* is a node with two or
//!    more children, or a root with several children. A *chain node* has a parent and
//!    one child; a *tip* has none. No axis bookkeeping is needed: every internode is
//!    swept on its own, and `v` comes from the path length (step 6).
//! 2. **Segment-length adjustment** (MacMurchy2004 §5.2, Eq 5.1/5.2, [`pair_offsets`]). At a
//!    junction every pair of branches (the trunk counts, with outward axis `−H`) gets
//!    `d₁ = (r₂ + r₁ cos θ)/sin θ`, `d₂ = (r₁ + r₂ cos θ)/sin θ`; each branch keeps the
//!    largest over its partners. Guards ([`guarded_offsets`]): `θ → π` skips the pair,
//!    every offset is at least the minimum gap `0.25 r` (this also covers `d < 0`), and
//!    the two ends of one internode share at most 90% of its length (the spec's "≤ 0.5
//!    segment length" when both ends need room; one end alone may take 0.9). Where an
//!    internode next to a junction is too short, a chain node at its end is removed
//!    (its child re-attaches to its parent, as the hull mesher's simplification does;
//!    listed in [`SweepMesh::collapsed`]) and the offsets are recomputed; what is still
//!    clamped is listed in [`SweepMesh::clamped`]. Never NaN or ∞.
//! 3. **Hexagonal rings** (§5.5.1): ring vertex `k = C + r(cos(kπ/3) u + sin(kπ/3) w)`,
//!    `w = d × u`, counter-clockwise about the direction of travel `d`. A child's start
//!    ring (at a root, a junction or a fallback) has the internode's explicit start
//!    radius where the skeleton has one ([`Skeleton::start_radius()`]: an LST
//!    `Cylinder(r0, r1, len)` keeps r0), so the internode is the truncated cone r0 → r1;
//!    else `min(r_parent, r_child)` (a child thicker than its parent is narrowed at its
//!    base, as in the tube mesher). Rings at chain nodes are shared by both internodes,
//!    with the bisector of the two headings as axis and the node's radius (an explicit
//!    start radius of the continuing internode is not used there: one ring cannot have
//!    two radii).
//! 4. **Twist** (§5.5.2, default mode). Every ring's reference `u` comes from a
//!    rotation-minimising transport of the previous ring's, except junction rings,
//!    which are turned to be vertex-forward (step 5). Consecutive rings are connected
//!    with the vertex offset `o ∈ {0..5}` that minimises the twist, so the residual is
//!    ≤ 30° ([`SweepMesh::max_twist_deg`]). Each internode is a strip of 12 triangles
//!    with consistent diagonals.
//!
//!    **4b. Bend rings** (beyond the seed, [`SweepOptions::bend_rings`]). Loop
//!    subdivision rounds a bend over the whole length of its two internodes: its limit
//!    cuts the corner by about `L̄ sin(β/2) / 3` (`L̄` their mean length, `β` the bend).
//!    Where that exceeds half the node's radius `r`, each of the two internodes gets one
//!    extra ring `r (0.5 + 1.5 tan(β/2))` (at least `1.5 r`) from the node, taking at
//!    most 45 % of the length its offsets leave free (a side without room for
//!    `1.1 r tan(β/2)`, the mitre's inner reach, gets none); with both, the ring at the
//!    node becomes the bend's mitre, stretched by `1/cos(β/2)` (at most 2) across the
//!    bend, so the tube keeps its width there. The bend is then rounded within a few
//!    radii. Each extra ring adds 6 vertices and 12 triangles; with Tile V its `v` is
//!    its fraction of the internode. (On `mig-m`, whose internodes are 40–80 radii
//!    long, an 82° bend put the level-2 surface 6 radii inside the bend, through a
//!    neighbouring branch: 243 crossing pairs at level 2, 0 with bend rings.)
//! 5. **Junctions** (§5.5.3; our own triangulation, the spec's "Reference
//!    construction"). The branching plane is fitted to the trunk and child axes (its
//!    normal `N` is the least-variance direction, oriented toward the node's `up`),
//!    children are sorted by their signed angle about `N` from the trunk heading. Every
//!    junction ring is rotated about its own axis so that vertex 0 lies on `+N` and
//!    vertex 3 on `−N`: **all junction rings are vertex-forward** (the choice the spec
//!    allows by designing our own templates), so the bitmask is always 0, no ring is
//!    ever pinched and one template covers 2…n children. The left half of a ring is
//!    `[0, 1, 2, 3]`, the right half `[0, 5, 4, 3]` (front to back). Outside strips
//!    join trunk-left ↔ first child's left and trunk-right ↔ last child's right, crotch
//!    strips child `i` right ↔ child `i+1` left; each strip zips two 4-vertex chains
//!    from front to back, choosing the shorter diagonal (6 triangles). The front hole
//!    (trunk vertex 0 and every child's vertex 0) and the back hole (vertices 3) are
//!    polygons of `n + 1` corners triangulated maximising the minimum angle. No new
//!    vertices (G9); each ring edge is used once (G2); the construction depends only on
//!    geometry, so child order does not matter (G8).
//!
//!    **5b. General junction** (beyond the seed, MacMurchy2004-spec §5 "non-planar junctions …
//!    a convex hull of the rings"). A junction whose axes leave the fitted plane by
//!    more than [`SweepOptions::coplanar_deg`] (decussate pairs, ternary whorls), or
//!    that has more than [`SweepOptions::max_children`] children, keeps its trunk ring
//!    (vertex 0 toward `N`) and gives each child ring the trunk frame transported along
//!    the rotation from the trunk heading to the child's. Every ring vertex is projected
//!    centrally from the node onto the unit sphere, where each ring is a small circle
//!    about its axis (shrunk so circles keep a 20 % gap), and the exact convex hull of
//!    those points is built (the hull mesher's joint, `hull::cap_hull`, Pieterse2012
//!    §4.2.3); the faces inside a ring (4 per hexagon) are removed and the rest map back
//!    to the ring vertices: `8(n + 1) − 4` triangles, no new vertices, each ring edge
//!    once in its tube's orientation (checked; a junction whose hull fails a check falls
//!    back). The hull is convex on the sphere, so the joint is one sheet with consistent
//!    orientation for any number of children in any directions; the Eq 5.1 offsets
//!    (pairwise, with the true 3D angles) keep the rings apart. Listed in
//!    [`SweepMesh::general`].
//! 6. **Asymmetric template** (§5.5.3, Figs 5.20–5.22; MacMurchy2004-spec §2.7). A child whose
//!    radius `r` is ≤ 1/3 of its largest partner's (tolerance 1e-6 relative, so exactly
//!    1/3 counts) is *thin*; its junction is listed in [`SweepMesh::asymmetric`]. The
//!    seed's templates "add a ring of vertices near the base of the smaller branch" and
//!    take the places of its top, middle and side subtemplates; ours: an **extra ring**
//!    of radius `ρ = collar_ratio · r` (default 1.75 r, capped at 0.9 × the trunk
//!    radius) is placed on the child's axis at the Eq 5.1 offset computed with `ρ` as
//!    its radius (so every partner clears it), takes the child's place in the junction
//!    (coplanar template or general junction, any of the seed's 16 ring states, since all
//!    our rings are vertex-forward), and a 12-triangle strip joins it to the child's own
//!    ring `ρ` further out. Each extra ring adds exactly 6 vertices and 12 triangles;
//!    symmetric junctions add none (property 16). A thin child whose internode has no
//!    room for the ring (the ring would break the 90 % rule) keeps the symmetric
//!    template. Children with an extra ring are listed in [`SweepMesh::collars`].
//! 7. **Repair and fallbacks.** The finished mesh is checked ([`check_mesh`]); faces
//!    that intersect faces of the same or a neighbouring node, or are degenerate, mark
//!    their nodes. A marked coplanar-template junction is first rebuilt as a general
//!    junction (this is what meshes narrow whorls that fit a plane within
//!    `coplanar_deg` but whose template folds, e.g. every junction of
//!    `lsys-ternary-tree`); in a round where no junction changed that way, the marked
//!    nodes fall back (at most [`SweepOptions::repair_rounds`] rounds). Once the
//!    control mesh is clean, it is refined [`SweepOptions::check_levels`] times with
//!    Loop and the faces refined from each junction and from the first strips of its
//!    children are searched for intersections among themselves (the checker's grouped
//!    search, [`crate::mesh::check`]): a coplanar template that folds, or lets its
//!    children's tubes cross, only under subdivision is rebuilt as a general junction
//!    too, and a general junction that does falls back (default level 2, the level the
//!    issue's acceptance checks: level 1 missed children crossing at level 2 on
//!    `mgv-a/r/grove`; general junctions are searched since session 11, when two
//!    children 8.5° apart at 90° to the trunk of `wp-ca-black-oak` put their rings 13
//!    radii out and the hull between them folded at level 2). A junction with
//!    two axes closer than [`SweepOptions::aligned_deg`] (or, with
//!    [`SweepOptions::general_junctions`] off, a non-coplanar one or one with more than
//!    `max_children` children) falls back from the start. A
//!    fallback node ends its incoming internode with a flat cap at the trunk offset and
//!    starts every child as its own tube with a flat cap at its offset: closed pieces
//!    separated by the Eq 5.1 gap. All are listed in [`SweepMesh::fallbacks`].
//! 8. **Ends** (§A.3). Tips: a cone whose apex lies `tip_size × width` beyond the last
//!    ring, fanned to it (6 triangles, 1 vertex; "Cap Front"), or with
//!    [`SweepTips::Pruned`] a flat fan of 4 triangles whose ring edges are infinitely
//!    sharp creases (Cap Front off: "pruned"). Bases: open (one 6-edge boundary loop
//!    per root) or, with [`SweepOptions::caps`], the same creased flat fan ("Cap Back").
//! 9. **UVs** (§6.3, MacMurchy2004-spec §2.12). `u`: by default the seed's reflected mapping,
//!    0, 1, 0, 1, 0, 1 around each ring ([`UMapping::Reflected`]): every stem edge
//!    spans `[0, 1]` and there is no seam; a strip carries the parity from its start
//!    ring to its end ring through the twist offset, and a junction's child rings take
//!    the trunk ring's parity (all junction rings have vertex 0 on the normal). With
//!    [`UMapping::Wrapped`], `u = k/6` with the seam column duplicated (`u = 1`) in the
//!    face-varying channel. `v` by default ([`VMapping::Texel`], issue 23) is the
//!    texel length from the root, `∫ ds / r(s)` along the path (radii linear along each
//!    internode), divided by `r`'s share of a unit of `u` — one hexagon side with reflected
//!    `u`, six with wrapped — so texels are square on every branch, thick or thin, and
//!    `v` runs on without a jump from a trunk into its children; with
//!    [`VMapping::Path`] (the seed's) it is the path length from the root divided by the
//!    longest root-to-tip path (0 at the base, 1 at the end of the longest path,
//!    increasing along every base-to-tip path), or with [`SweepOptions::tile_v`] 0 → 1 along every
//!    internode (junction corners: 1 on the trunk ring, 0 on the child rings). Junction
//!    corners take their own ring's coordinates; caps map their disc to `[0, 1]²`; a
//!    cone apex gets the middle `u` of its triangle.
//!
//! Output: triangles only, counter-clockwise seen from outside, a 2-manifold.
//! Deterministic; every valid skeleton gives a mesh, never a panic.

use crate::error::{Error, Result};
use crate::geometry::{Crease, FaceVarying, Mesh};
use crate::mesh::check::{check_mesh, group_crossings, CheckOptions};
use crate::mesh::hull::{cap_hull, CapLoop};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{DQuat, DVec3, Vec2};
use std::collections::HashSet;
use std::f64::consts::{FRAC_PI_3, PI};

const NONE: u32 = u32::MAX;
/// Vertices per ring (the seed's hexagon).
pub const SIDES: usize = 6;

/// Options of [`sweep_mesh`] (MacMurchy2004-spec §3 "Sweep tab").
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepOptions {
    /// Close every root base with a flat creased cap ("Cap Back"; default false: the
    /// base is open, one 6-edge boundary loop per root).
    #[serde(skip)]
    pub caps: bool,
    /// Tip cone height divided by the tip width (seed "Tip Size", `/A`; default 1).
    pub tip_size: f64,
    /// Most children the coplanar template takes (default 4); more use the general
    /// junction (or fall back when `general_junctions` is off).
    pub max_children: usize,
    /// Largest angle in degrees between a branch axis and the fitted branching plane
    /// (default 20°); beyond it the junction is non-coplanar and uses the general
    /// junction (or falls back when `general_junctions` is off).
    pub coplanar_deg: f64,
    /// Mesh non-coplanar junctions and junctions with more than `max_children` children
    /// with the general (projected convex-hull) junction instead of falling back
    /// (default true).
    pub general_junctions: bool,
    /// Radius of the asymmetric template's extra ring divided by the thin child's
    /// radius (default 1.75, the middle of MacMurchy2004-spec §2.7's 1.5–2 r); the ring sits
    /// where the child's template ring would be and the child's own ring one extra-ring
    /// radius further out. 0 disables the extra ring (asymmetric junctions are then
    /// meshed symmetrically); otherwise in 1..=3.
    pub collar_ratio: f64,
    /// Two branch axes closer than this angle in degrees are aligned (default 3°): the
    /// junction falls back.
    pub aligned_deg: f64,
    /// A child whose radius is at most this fraction of its largest partner's makes the
    /// junction asymmetric (default 1/3, the seed's rule).
    pub asymmetric_ratio: f64,
    /// Rounds of "check, then fall back where faces intersect" (default 4; 0 disables
    /// the check).
    pub repair_rounds: u32,
    /// How tips end (default [`SweepTips::Cone`], the seed's "Cap Front").
    #[serde(skip)]
    pub tips: SweepTips,
    /// How `u` runs around a ring (default [`UMapping::Reflected`], the seed's stem UVs).
    pub u_mapping: UMapping,
    /// How `v` runs along the branches (default [`VMapping::Texel`]: square texels).
    pub v_mapping: VMapping,
    /// The seed's "Tile V": `v` runs from 0 to 1 along every internode instead of along
    /// the longest root-to-tip path (default false; overrides `v_mapping`).
    pub tile_v: bool,
    /// Loop levels at which the repair also checks the junctions (default 2, 0 = off,
    /// at most 3): once the control mesh is clean, it is refined this many times and a
    /// junction whose refined faces, or those of its children's first strips, intersect
    /// each other (one that folds only under subdivision) is rebuilt as a general
    /// junction, or falls back if it is one (module docs, step 7). Costs one refinement
    /// and a check of the junctions' refined faces per round.
    pub check_levels: u32,
    /// Smallest ring radius as a fraction of the skeleton's largest radius (default
    /// 0.005, range 1e-6–1, as the quad mesher's `min_radius`): thinner tips are raised to
    /// it. At 0.001 (until session 9) a Weber–Penn tip tapering to zero (`r` 3·10⁻⁴ m
    /// over 0.46 m internodes) folded under Loop subdivision.
    pub min_radius: f64,
    /// Bend rings (beyond the seed, default true): at a chain node whose bend would let
    /// Loop subdivision cut the corner by more than half a radius, one extra ring is
    /// placed on each internode a short distance from the node, and the ring at the node
    /// becomes the bend's mitre (an ellipse, stretched by `1/cos(β/2)`, at most 2, across
    /// the bend). Without them a smooth surface rounds a bend over the whole length of
    /// its two internodes: an 82° bend between 40-radius internodes (`mig-m`) moved the
    /// level-2 surface 6 radii inside the bend, through a neighbouring branch (module
    /// docs, step 4b).
    pub bend_rings: bool,
}

/// How the sweep mesher ends a tip (MacMurchy2004 §A.3, MacMurchy2004-spec §2.8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SweepTips {
    /// "Cap Front" on: a cone whose apex lies `tip_size × width` beyond the last ring
    /// (6 triangles, 1 vertex).
    #[default]
    Cone,
    /// "Cap Front" off: a flat cap over the last ring with infinitely sharp crease
    /// edges, so it stays flat under subdivision (a "pruned" branch; 4 triangles, no
    /// vertex).
    Pruned,
}

/// How `u` runs around the sweep mesher's hexagonal rings (MacMurchy2004-spec §2.12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum UMapping {
    /// The seed's stem UVs (Fig 6.4d): `u` is reflected at every ring vertex, 0, 1, 0,
    /// 1, 0, 1 around the ring, so every edge spans `[0, 1]` and there is no seam. The
    /// parity is carried along each strip and held across junctions (every junction
    /// ring's vertex 0 lies on the branching plane's normal, so a child ring takes the
    /// trunk ring's parity).
    #[default]
    Reflected,
    /// `u = k/6` around the ring with the seam column duplicated (`u = 1`): the texture
    /// wraps once around the branch without mirroring, at the cost of a UV seam.
    Wrapped,
}

/// How `v` runs along the sweep mesher's branches.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VMapping {
    /// `v` is the texel length from the root, `∫ ds / r(s)` over a unit of `u` (a
    /// hexagon side of radius `r` with reflected `u`, the six sides with wrapped `u`):
    /// square texels on every branch, continuous from a trunk into its children.
    #[default]
    Texel,
    /// The seed's stem UVs: the path length from the root over the longest root-to-tip
    /// path (0 → 1 over the whole tree; thin branches stretch).
    Path,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            caps: false,
            tip_size: 1.0,
            max_children: 4,
            coplanar_deg: 20.0,
            general_junctions: true,
            collar_ratio: 1.75,
            aligned_deg: 3.0,
            asymmetric_ratio: 1.0 / 3.0,
            repair_rounds: 4,
            tips: SweepTips::Cone,
            u_mapping: UMapping::Reflected,
            v_mapping: VMapping::Texel,
            tile_v: false,
            check_levels: 2,
            min_radius: crate::tolerance::RADIUS_FLOOR,
            bend_rings: true,
        }
    }
}

impl SweepOptions {
    /// Checks every option's range; the message starts with the option's name.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidGeometry { what: "sweep mesher".into(), why });
        if !(self.tip_size.is_finite() && (0.0..=100.0).contains(&self.tip_size)) {
            return bad(format!("tip_size = {}; it must be in 0..=100", self.tip_size));
        }
        if !(self.min_radius.is_finite() && (1e-6..=1.0).contains(&self.min_radius)) {
            return bad(format!("min_radius = {}; it must be in 1e-6..=1", self.min_radius));
        }
        if !(2..=64).contains(&self.max_children) {
            return bad(format!("max_children = {}; it must be in 2..=64", self.max_children));
        }
        if !(self.coplanar_deg.is_finite() && (0.0..90.0).contains(&self.coplanar_deg)) {
            return bad(format!("coplanar_deg = {}; it must be in [0, 90)", self.coplanar_deg));
        }
        if !(self.aligned_deg.is_finite() && (0.0..90.0).contains(&self.aligned_deg)) {
            return bad(format!("aligned_deg = {}; it must be in [0, 90)", self.aligned_deg));
        }
        if !(self.collar_ratio == 0.0 || (1.0..=3.0).contains(&self.collar_ratio)) {
            return bad(format!("collar_ratio = {}; it must be 0 or in 1..=3", self.collar_ratio));
        }
        if !(self.asymmetric_ratio.is_finite() && (0.0..=1.0).contains(&self.asymmetric_ratio)) {
            return bad(format!("asymmetric_ratio = {}; it must be in 0..=1", self.asymmetric_ratio));
        }
        if self.check_levels > 3 {
            return bad(format!("check_levels = {}; it must be in 0..=3", self.check_levels));
        }
        Ok(())
    }
}

/// What [`sweep_mesh`] made.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SweepMesh {
    /// The triangle control mesh with face-varying UVs (and base-cap creases).
    pub mesh: Mesh,
    /// Junction nodes meshed with the template (coplanar or general).
    pub junctions: Vec<u32>,
    /// Junction nodes among `junctions` meshed with the general (projected convex-hull)
    /// junction: non-coplanar whorls and junctions with more than `max_children`
    /// children.
    pub general: Vec<u32>,
    /// Nodes (junctions or chain nodes) that fell back to separately capped pieces.
    pub fallbacks: Vec<u32>,
    /// Junction nodes where the asymmetric rule holds (a child's radius ≤
    /// `asymmetric_ratio` × its largest partner's).
    pub asymmetric: Vec<u32>,
    /// Child nodes that start with the asymmetric template's extra ring (one ring of 6
    /// vertices and a 12-triangle strip each); a thin child whose internode has no room
    /// for it is meshed symmetrically and not listed.
    pub collars: Vec<u32>,
    /// Internodes (named by their end node) whose Eq 5.1 offsets had to be clamped.
    pub clamped: Vec<u32>,
    /// Nodes removed: zero-length internodes and chain nodes too close to a junction.
    pub collapsed: Vec<u32>,
    /// Largest twist between connected ring vertices, in degrees (≤ 30).
    pub max_twist_deg: f64,
    /// Designed boundary loops: one per open root base.
    pub open_loops: usize,
    /// For each control face, the nodes it was made for: `[node, NONE]` for a
    /// junction's, cap's or collar strip's faces, `[parent, child]` for an internode's
    /// strip (either may be `u32::MAX` where the face belongs to no junction or chain
    /// node, e.g. a root base). Used to map a crossing back to the skeleton.
    pub face_owner: Vec<[u32; 2]>,
}

/// MacMurchy2004, Eq. 5.1 and 5.2: the offsets `(d₁, d₂)` of two branches of radii `r1`,
/// `r2` whose axes meet at angle `theta` (radians, in `(0, π)`). Not guarded: `θ = 0`
/// divides by zero; use [`guarded_offsets`] for meshing.
pub fn pair_offsets(r1: f64, r2: f64, theta: f64) -> (f64, f64) {
    let (s, c) = theta.sin_cos();
    // MacMurchy2004, Eq. 5.1 and Eq. 5.2
    ((r2 + r1 * c) / s, (r1 + r2 * c) / s)
}

/// [`pair_offsets`] with the MacMurchy2004-spec §2.2 guards: `None` for a straight continuation
/// (`θ` within 1e-3 of π, the pair is skipped); otherwise `(d₁, d₂, clamped)` with each
/// offset at least the minimum gap `0.25 r` and at most `max1` / `max2` (`clamped` says a
/// maximum applied, as it does when `θ → 0`). Always finite and non-negative for finite
/// non-negative input.
pub fn guarded_offsets(r1: f64, r2: f64, theta: f64, max1: f64, max2: f64) -> Option<(f64, f64, bool)> {
    let theta = if theta.is_finite() { theta.clamp(0.0, PI) } else { 0.0 };
    if theta > PI - 1e-3 {
        return None;
    }
    let (mut d1, mut d2) =
        if theta.sin() < 1e-9 { (f64::MAX, f64::MAX) } else { pair_offsets(r1, r2, theta) };
    d1 = d1.max(0.25 * r1);
    d2 = d2.max(0.25 * r2);
    let mut clamped = false;
    if d1 > max1 {
        d1 = max1.max(0.0);
        clamped = true;
    }
    if d2 > max2 {
        d2 = max2.max(0.0);
        clamped = true;
    }
    Some((d1, d2, clamped))
}

/// One hexagonal ring.
#[derive(Debug, Clone, Copy)]
struct Ring {
    c: DVec3,
    d: DVec3,
    u: DVec3,
    r: f64,
    v: f64,
    first: u32,
    /// `u` of vertex `k` is `(k + parity) mod 2` with [`UMapping::Reflected`].
    parity: u8,
    /// `v` of this ring's junction and cap corners with Tile V: 1 where the ring ends an
    /// internode, 0 where it starts one.
    tile: f32,
}

impl Ring {
    fn w(&self) -> DVec3 {
        self.d.cross(self.u)
    }
    fn vertex(&self, k: usize) -> DVec3 {
        let a = k as f64 * FRAC_PI_3;
        self.c + self.r * (a.cos() * self.u + a.sin() * self.w())
    }
    fn index(&self, k: usize) -> u32 {
        self.first + (k % SIDES) as u32
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Root,
    Tip,
    Chain,
    Junction,
}

/// Everything that does not depend on which nodes fall back.
struct Plan {
    pos: Vec<DVec3>,
    rad: Vec<f64>,
    /// Explicit start radius of the internode into each node ([`Skeleton::start_radius()`],
    /// floored like `rad`), if the skeleton has one.
    rad0: Vec<Option<f64>>,
    up: Vec<DVec3>,
    live: Vec<bool>,
    par: Vec<u32>,
    kids: Vec<Vec<u32>>,
    kind: Vec<Kind>,
    dir: Vec<DVec3>,
    len: Vec<f64>,
    /// `v` at each node before division by `vmax`: path length, or texel length with
    /// [`VMapping::Texel`].
    path: Vec<f64>,
    vmax: f64,
    /// Radius per unit of `u` for [`VMapping::Texel`] (1 reflected, 6 wrapped); `None`
    /// for path-length `v`.
    texel: Option<f64>,
    /// Offset of a child's start ring from its parent node.
    off_start: Vec<f64>,
    /// Offset of a node's trunk ring back from the node.
    off_end: Vec<f64>,
    /// Branching-plane normal of a junction (zero when none).
    normal: Vec<DVec3>,
    /// Heading of the trunk into a junction.
    h_in: Vec<DVec3>,
    /// Children sorted by signed angle about the normal.
    sorted: Vec<Vec<u32>>,
    /// Junctions that cannot be templated at all.
    forced: Vec<bool>,
    /// Junctions meshed with the general junction, and its faces as (ring, vertex)
    /// pairs, rings numbered trunk first, then the children in `sorted` order.
    general: Vec<bool>,
    general_faces: Vec<Vec<[(u32, u32); 3]>>,
    /// Reference direction (vertex 0) of a junction child's start ring.
    kid_u: Vec<DVec3>,
    /// Extra-ring radius of a thin child (0: none) and the extra ring's offset.
    collar: Vec<f64>,
    off_collar: Vec<f64>,
    clamped: Vec<u32>,
    collapsed: Vec<u32>,
    asymmetric: Vec<u32>,
    /// Bend rings of a chain node (0: none): distance of the extra ring back from the
    /// node on its incoming internode, and forward on its outgoing one; and the mitre
    /// stretch across the bend (1: a plain ring) with its direction.
    bend_in: Vec<f64>,
    bend_out: Vec<f64>,
    mitre: Vec<(f64, DVec3)>,
}

/// Loop cuts a bend's corner by about `L̄ sin(β/2) / 3` (`L̄` the mean length of the two
/// internodes): bend rings go where that exceeds this many radii.
const BEND_CUT: f64 = 0.5;

/// The skeleton graph with internodes shorter than float noise (or than 1e-3 of the
/// thinner radius) collapsed into their parent node.
pub(crate) struct Collapsed {
    /// Whether each node stands for itself (not collapsed).
    pub live: Vec<bool>,
    /// The live parent of each live node, `NONE` for roots and collapsed nodes.
    pub parent: Vec<u32>,
    /// The collapsed nodes, in order.
    pub collapsed: Vec<u32>,
}

/// Collapses zero-length internodes (step 1 of the module docs; shared with the leaf
/// mesher). `parent` is the skeleton's parent column, parents first.
pub(crate) fn collapse_short(parent: &[u32], pos: &[DVec3], rad: &[f64]) -> Collapsed {
    let n = parent.len();
    let mut rep: Vec<u32> = (0..n as u32).collect();
    let mut collapsed = Vec::new();
    for i in 0..n {
        let p = parent[i];
        if p == NO_PARENT {
            continue;
        }
        let rp = rep[p as usize] as usize;
        let d = (pos[i] - pos[rp]).length();
        let tiny = 1e-6 * (pos[i].abs().max_element().max(pos[rp].abs().max_element())) + 1e-12;
        if d <= tiny.max(1e-3 * rad[i].min(rad[rp])) {
            rep[i] = rp as u32;
            collapsed.push(i as u32);
        }
    }
    let live: Vec<bool> = (0..n).map(|i| rep[i] == i as u32).collect();
    let parent = (0..n)
        .map(|i| if live[i] && parent[i] != NO_PARENT { rep[parent[i] as usize] } else { NONE })
        .collect();
    Collapsed { live, parent, collapsed }
}

/// `v` normalised, or `fallback` when `v` is (near) zero or not finite.
pub(crate) fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    let l = v.length();
    if l > 1e-12 && l.is_finite() {
        v / l
    } else {
        fallback
    }
}

/// The unit part of `seed` perpendicular to the unit `d` (any perpendicular when `seed`
/// is parallel to `d`).
pub(crate) fn perpendicular(seed: DVec3, d: DVec3) -> DVec3 {
    let u = seed - d * seed.dot(d);
    if u.length_squared() > 1e-12 {
        u.normalize()
    } else {
        d.any_orthonormal_vector()
    }
}

/// Least-variance direction of a set of unit vectors (the normal of the fitted plane).
fn fit_normal(axes: &[DVec3]) -> DVec3 {
    let mut m = [[0.0f64; 3]; 3];
    for a in axes {
        let v = a.to_array();
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] += v[i] * v[j];
            }
        }
    }
    // Shift by the trace so the smallest eigenvalue becomes the largest, then iterate.
    let t = m[0][0] + m[1][1] + m[2][2];
    let apply = |x: DVec3| {
        let a = x.to_array();
        DVec3::new(
            t * a[0] - (m[0][0] * a[0] + m[0][1] * a[1] + m[0][2] * a[2]),
            t * a[1] - (m[1][0] * a[0] + m[1][1] * a[1] + m[1][2] * a[2]),
            t * a[2] - (m[2][0] * a[0] + m[2][1] * a[1] + m[2][2] * a[2]),
        )
    };
    // Start from the largest row-pair cross product (exact for coplanar axes).
    let rows = [DVec3::from(m[0]), DVec3::from(m[1]), DVec3::from(m[2])];
    let cands = [rows[0].cross(rows[1]), rows[1].cross(rows[2]), rows[2].cross(rows[0])];
    let mut x =
        cands
            .iter()
            .copied()
            .fold(DVec3::ZERO, |b, c| if c.length_squared() > b.length_squared() { c } else { b });
    if x.length_squared() < 1e-24 {
        return DVec3::ZERO;
    }
    x = x.normalize();
    for _ in 0..32 {
        x = unit_or(apply(x), x);
    }
    x
}

impl Plan {
    /// Radius of the start ring of child `c` at node `j` (root, junction or fallback
    /// children; a chain node's ring is shared and has the node's radius): the
    /// internode's explicit start radius, else `min(r_j, r_c)`.
    fn start_r(&self, j: usize, c: usize) -> f64 {
        self.rad0[c].unwrap_or(self.rad[j].min(self.rad[c]))
    }

    /// The `v` distance covered `x` metres into internode `p → i` of length `len`: `x`
    /// itself for path-length `v`, or `∫₀ˣ ds / r(s)` over the radius per unit of `u`
    /// for texel `v` (the radius runs linearly from `rad[p]` to `rad[i]`, as the rings').
    fn texel_len(&self, p: usize, i: usize, len: f64, x: f64) -> f64 {
        let Some(k) = self.texel else { return x };
        let (r0, r1) = (self.rad[p], self.rad[i]);
        let x = x.clamp(0.0, len.max(0.0));
        let dr = r1 - r0;
        let t = if len <= 0.0 || dr.abs() <= 1e-9 * r0 {
            x / r0
        } else {
            let rx = r0 + dr * (x / len);
            len / dr * (rx / r0).ln()
        };
        t / k
    }

    /// `v` (before `vmax`) `x` metres into internode `i` from its parent node.
    fn v_start(&self, i: usize, x: f64) -> f64 {
        let p = self.par[i] as usize;
        self.path[p] + self.texel_len(p, i, self.len[i], x)
    }

    /// `v` (before `vmax`) `off` metres back from node `i` along its internode.
    fn v_end(&self, i: usize, off: f64) -> f64 {
        match self.texel {
            None => self.path[i] - off,
            Some(_) => self.v_start(i, self.len[i] - off),
        }
    }

    fn new(s: &Skeleton, opts: &SweepOptions) -> Plan {
        let n = s.len();
        let pos: Vec<DVec3> = s.position.iter().map(|p| p.as_dvec3()).collect();
        let rmax = s.radius.iter().fold(0.0f32, |a, &b| a.max(b)) as f64;
        let scale = pos.iter().fold(0.0f64, |a, p| a.max(p.abs().max_element()));
        let f = opts.min_radius;
        let rmin = if rmax > 0.0 { f * rmax } else { f * scale.max(1e-3) };
        let rad: Vec<f64> = s.radius.iter().map(|&r| (r as f64).max(rmin)).collect();
        let rad0: Vec<Option<f64>> =
            (0..n).map(|i| s.start_radius(i).map(|r| (r as f64).max(rmin))).collect();
        let up: Vec<DVec3> = s.up.iter().map(|u| u.as_dvec3()).collect();
        let Collapsed { mut live, parent: mut par, collapsed } = collapse_short(&s.parent, &pos, &rad);
        let mut plan = Plan {
            pos,
            rad,
            rad0,
            up,
            live: Vec::new(),
            par: Vec::new(),
            kids: Vec::new(),
            kind: Vec::new(),
            dir: Vec::new(),
            len: Vec::new(),
            path: Vec::new(),
            vmax: 1.0,
            texel: match opts.v_mapping {
                VMapping::Texel => Some(match opts.u_mapping {
                    UMapping::Reflected => 1.0,
                    UMapping::Wrapped => SIDES as f64,
                }),
                VMapping::Path => None,
            },
            off_start: Vec::new(),
            off_end: Vec::new(),
            normal: Vec::new(),
            h_in: Vec::new(),
            sorted: Vec::new(),
            forced: Vec::new(),
            general: Vec::new(),
            general_faces: Vec::new(),
            kid_u: Vec::new(),
            collar: Vec::new(),
            off_collar: Vec::new(),
            clamped: Vec::new(),
            collapsed,
            asymmetric: Vec::new(),
            bend_in: vec![0.0; n],
            bend_out: vec![0.0; n],
            mitre: vec![(1.0, DVec3::ZERO); n],
        };
        // Offsets; where an internode is too short for them, a chain node at one of its
        // ends is removed (its child re-attaches to its parent; end points never move)
        // and the offsets are computed again.
        for _round in 0..64 {
            let removed = plan.layout(&live, &par, opts);
            if removed.is_empty() {
                break;
            }
            for &r in &removed {
                live[r as usize] = false;
                plan.collapsed.push(r);
            }
            for i in 0..n {
                while par[i] != NONE && !live[par[i] as usize] {
                    par[i] = par[par[i] as usize];
                }
            }
        }
        plan.collapsed.sort_unstable();
        if opts.bend_rings {
            plan.bends();
        }
        plan.general_joints(opts);
        plan
    }

    /// Bend rings and mitres of the chain nodes ([`SweepOptions::bend_rings`]). The
    /// extra ring sits `r (0.5 + 1.5 tan(β/2))`, at least `1.5 r`, from the node, so
    /// that the mitre's inner point (`r tan(β/2)` back along either internode) lies
    /// between it and the node; it takes at most 45% of the internode's length left
    /// between its offsets, and a side without room for `1.1 r tan(β/2)` gets none.
    /// The mitre is stretched only when both sides have their ring.
    fn bends(&mut self) {
        let free = |p: &Plan, c: usize| p.len[c] - p.off_start[c] - p.off_end[c];
        for i in 0..self.live.len() {
            if !self.live[i] || self.kind[i] != Kind::Chain || self.par[i] == NONE {
                continue;
            }
            let c = self.kids[i][0] as usize;
            let (din, dout) = (self.dir[i], self.dir[c]);
            let beta = din.dot(dout).clamp(-1.0, 1.0).acos();
            let r = self.rad[i];
            let mean = 0.5 * (self.len[i] + self.len[c]);
            if mean * (0.5 * beta).sin() / 3.0 <= BEND_CUT * r {
                continue;
            }
            let t = (0.5 * beta).tan().min(4.0);
            let want = (r * (0.5 + 1.5 * t)).max(1.5 * r);
            let least = (1.1 * r * t).max(0.25 * r);
            let side = |room: f64| {
                let s = want.min(0.45 * room);
                if s >= least {
                    s
                } else {
                    0.0
                }
            };
            self.bend_in[i] = side(free(self, i));
            self.bend_out[i] = side(free(self, c));
            if self.bend_in[i] > 0.0 && self.bend_out[i] > 0.0 {
                let axis = unit_or(din + dout, din);
                let across = din - dout;
                let across = across - axis * across.dot(axis);
                if across.length_squared() > 1e-18 {
                    let f = (1.0 / (0.5 * beta).cos().max(0.5)).min(2.0);
                    self.mitre[i] = (f, across.normalize());
                }
            }
        }
    }

    /// Faces of every general junction (module docs, step 5b); a junction whose hull
    /// fails its checks falls back.
    fn general_joints(&mut self, opts: &SweepOptions) {
        let n = self.live.len();
        self.general_faces = vec![Vec::new(); n];
        for j in 0..n {
            if self.live[j] && self.general[j] && !self.forced[j] && !self.make_general(j, opts) {
                self.forced[j] = true;
            }
        }
    }

    /// Turns junction `j` into a general junction: children's ring frames transported
    /// from the trunk's, hull faces computed. False (and `j` unchanged) when the hull
    /// fails its checks.
    fn make_general(&mut self, j: usize, opts: &SweepOptions) -> bool {
        let eps = 1.0 - opts.aligned_deg.to_radians().cos();
        let h = self.h_in[j];
        let u = perpendicular(self.normal[j], h);
        let r = self.rad[j];
        let mut loops = vec![CapLoop {
            axis: -h,
            radius: r,
            offset: if self.par[j] != NONE { self.off_end[j] } else { 0.0 },
            u,
            w: h.cross(u),
            at_end: true,
        }];
        let mut frames = Vec::with_capacity(self.sorted[j].len());
        for &c in &self.sorted[j] {
            let c = c as usize;
            let d = self.dir[c];
            let uc = perpendicular(DQuat::from_rotation_arc(h, d) * u, d);
            frames.push((c, uc));
            let (radius, offset) = if self.collar[c] > 0.0 {
                (self.collar[c], self.off_collar[c])
            } else {
                (self.start_r(j, c), self.off_start[c])
            };
            loops.push(CapLoop { axis: d, radius, offset, u: uc, w: d.cross(uc), at_end: false });
        }
        match cap_hull(&loops, SIDES as u32, eps) {
            Some(f) => {
                self.general_faces[j] = f;
                self.general[j] = true;
                for (c, uc) in frames {
                    self.kid_u[c] = uc;
                }
                true
            }
            None => false,
        }
    }

    /// Graph, offsets and junction set-up for the live nodes; returns the chain nodes to
    /// remove because an internode next to them is too short for its offsets.
    fn layout(&mut self, live: &[bool], par: &[u32], opts: &SweepOptions) -> Vec<u32> {
        let n = live.len();
        let pos = &self.pos;
        let mut kids = vec![Vec::new(); n];
        for i in 0..n {
            if live[i] && par[i] != NONE {
                kids[par[i] as usize].push(i as u32);
            }
        }
        let mut dir = vec![DVec3::ZERO; n];
        let mut len = vec![0.0; n];
        let mut path = vec![0.0; n];
        let mut vmax = 0.0f64;
        for i in 0..n {
            if live[i] && par[i] != NONE {
                let p = par[i] as usize;
                let e = pos[i] - pos[p];
                len[i] = e.length();
                dir[i] = unit_or(e, DVec3::Y);
                path[i] = path[p] + self.texel_len(p, i, len[i], len[i]);
                vmax = vmax.max(path[i]);
            }
        }
        self.kind = (0..n)
            .map(|i| match (par[i] == NONE, kids[i].len()) {
                (_, k) if k >= 2 => Kind::Junction,
                (true, _) => Kind::Root,
                (false, 0) => Kind::Tip,
                (false, _) => Kind::Chain,
            })
            .collect();
        self.live = live.to_vec();
        self.par = par.to_vec();
        self.kids = kids;
        self.dir = dir;
        self.len = len;
        self.path = path;
        // Texel `v` is not normalized: one unit of `v` is one unit of `u`.
        self.vmax = if self.texel.is_some() {
            1.0
        } else if vmax > 0.0 {
            vmax
        } else {
            1.0
        };
        self.off_start = vec![0.0; n];
        self.off_end = vec![0.0; n];
        self.normal = vec![DVec3::ZERO; n];
        self.h_in = vec![DVec3::ZERO; n];
        self.sorted = vec![Vec::new(); n];
        self.forced = vec![false; n];
        self.general = vec![false; n];
        self.kid_u = vec![DVec3::ZERO; n];
        self.collar = vec![0.0; n];
        self.off_collar = vec![0.0; n];
        self.clamped.clear();
        self.asymmetric.clear();
        for j in 0..n {
            if self.live[j] && matches!(self.kind[j], Kind::Junction | Kind::Chain) {
                self.node(j, opts);
            }
        }
        // Both ends of an internode share 90% of its length (MacMurchy2004-spec §2.2 guard). A thin
        // child without room for its extra ring loses it first (symmetric template).
        for c in 0..n {
            let sum = self.off_start[c] + self.off_end[c];
            if self.collar[c] > 0.0 && sum > 0.9 * self.len[c] {
                self.off_start[c] = self.off_collar[c];
                self.collar[c] = 0.0;
            }
            let sum = self.off_start[c] + self.off_end[c];
            if self.live[c] && self.par[c] != NONE && sum > 0.9 * self.len[c] {
                let f = 0.9 * self.len[c] / sum;
                self.off_start[c] *= f;
                self.off_end[c] *= f;
                self.clamped.push(c as u32);
            }
        }
        self.clamped.sort_unstable();
        self.clamped.dedup();
        // Clamped internodes next to a junction: remove a chain node to make room.
        let mut remove = Vec::new();
        for &c in &self.clamped {
            let c = c as usize;
            let p = self.par[c];
            let near_junction =
                self.kind[c] == Kind::Junction || (p != NONE && self.kind[p as usize] == Kind::Junction);
            if !near_junction {
                continue;
            }
            if self.kind[c] == Kind::Chain {
                remove.push(c as u32);
            } else if p != NONE && self.kind[p as usize] == Kind::Chain {
                remove.push(p);
            }
        }
        remove.sort_unstable();
        remove.dedup();
        remove
    }

    /// Offsets, plane, order and template checks at a junction or chain node.
    fn node(&mut self, j: usize, opts: &SweepOptions) {
        let kids = self.kids[j].clone();
        let has_trunk = self.par[j] != NONE;
        let h_in = if has_trunk {
            self.dir[j]
        } else {
            let sum: DVec3 = kids.iter().map(|&c| self.dir[c as usize]).sum();
            unit_or(sum, self.dir[kids[0] as usize])
        };
        self.h_in[j] = h_in;
        let rj = self.rad[j];
        // Participants: trunk first (outward axis −H), then the children.
        let mut axes = vec![-h_in];
        let mut radii = vec![rj];
        let mut maxes = vec![if has_trunk { 0.9 * self.len[j] } else { 0.0 }];
        for &c in &kids {
            axes.push(self.dir[c as usize]);
            radii.push(self.start_r(j, c as usize));
            maxes.push(0.9 * self.len[c as usize]);
        }
        let k = axes.len();
        // Asymmetric rule (MacMurchy2004 §5.5.3): a child whose radius is ≤ ratio × its
        // largest partner's is thin; it gets the extra ring, which its partners must clear.
        let junction = kids.len() >= 2;
        let thin: Vec<bool> = (0..k)
            .map(|i| {
                let other = (0..k).filter(|&m| m != i).map(|m| radii[m]).fold(0.0, f64::max);
                junction && i > 0 && radii[i] <= opts.asymmetric_ratio * other * (1.0 + 1e-6)
            })
            .collect();
        if thin.iter().any(|&t| t) {
            self.asymmetric.push(j as u32);
        }
        let collar: Vec<f64> = (0..k)
            .map(|i| {
                let rho = (opts.collar_ratio * radii[i]).min(0.9 * rj);
                if thin[i] && rho > 1.05 * radii[i] {
                    rho
                } else {
                    0.0
                }
            })
            .collect();
        let eff: Vec<f64> = (0..k).map(|i| if collar[i] > 0.0 { collar[i] } else { radii[i] }).collect();
        let mut off: Vec<f64> = (0..k).map(|i| (0.25 * eff[i]).min(maxes[i])).collect();
        let mut clamped = false;
        let mut aligned = false;
        let cos_aligned = opts.aligned_deg.to_radians().cos();
        for a in 0..k {
            for b in a + 1..k {
                let c = axes[a].dot(axes[b]).clamp(-1.0, 1.0);
                if c > cos_aligned {
                    aligned = true;
                }
                if let Some((da, db, cl)) = guarded_offsets(eff[a], eff[b], c.acos(), maxes[a], maxes[b]) {
                    off[a] = off[a].max(da);
                    off[b] = off[b].max(db);
                    clamped |= cl;
                }
            }
        }
        if !has_trunk {
            off[0] = 0.0;
        }
        if clamped {
            for (i, &d) in off.iter().enumerate() {
                if d >= maxes[i] && maxes[i] > 0.0 {
                    self.clamped.push(if i == 0 { j as u32 } else { kids[i - 1] });
                }
            }
        }
        self.off_end[j] = off[0];
        for (i, &c) in kids.iter().enumerate() {
            let c = c as usize;
            self.off_start[c] = off[i + 1];
            // The extra ring sits at the template offset (computed for its radius), the
            // child's own ring one extra-ring radius further out, when there is room.
            let rho = collar[i + 1];
            if rho > 0.0 && off[i + 1] + rho <= maxes[i + 1] {
                self.collar[c] = rho;
                self.off_collar[c] = off[i + 1];
                self.off_start[c] = off[i + 1] + rho;
            }
        }
        if !junction {
            return;
        }
        // Branching plane (MacMurchy2004-spec §2.3): least-variance normal, toward the node's up.
        let mut n = fit_normal(&axes);
        let mut force = aligned;
        if n == DVec3::ZERO {
            force = true;
            n = perpendicular(self.up[j], h_in);
        }
        let refv = perpendicular(self.up[j], h_in);
        let sgn = n.dot(refv);
        if sgn < 0.0 || (sgn == 0.0 && n.dot(DVec3::new(0.31, 0.57, 0.76)) < 0.0) {
            n = -n;
        }
        let tol = opts.coplanar_deg.to_radians().sin();
        let general = kids.len() > opts.max_children || axes.iter().any(|a| a.dot(n).abs() > tol);
        if general && !opts.general_junctions {
            force = true;
        }
        self.normal[j] = n;
        self.general[j] = general && !force;
        // Children's ring frames: vertex-forward (vertex 0 on +N) for the coplanar
        // template (a general junction replaces them in `make_general`).
        for &c in &kids {
            let d = self.dir[c as usize];
            self.kid_u[c as usize] = perpendicular(n, d);
        }
        // Children by increasing signed angle about N from the trunk heading.
        let mut by: Vec<(f64, u32)> = kids
            .iter()
            .map(|&c| {
                let h = self.dir[c as usize];
                (n.dot(h_in.cross(h)).atan2(h_in.dot(h)), c)
            })
            .collect();
        by.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        self.sorted[j] = by.iter().map(|x| x.1).collect();
        self.forced[j] = force;
    }
}

/// Mesh under construction.
struct Build<'a> {
    plan: &'a Plan,
    opts: &'a SweepOptions,
    mesh: Mesh,
    uv: FaceVarying<Vec2>,
    owner: Vec<[u32; 2]>,
    max_twist: f64,
    open_loops: usize,
}

impl Build<'_> {
    fn ring(&mut self, c: DVec3, d: DVec3, u: DVec3, r: f64, v: f64) -> Ring {
        let first = self.mesh.positions.len() as u32;
        let ring = Ring { c, d, u: perpendicular(u, d), r, v, first, parity: 0, tile: 0.0 };
        for k in 0..SIDES {
            self.mesh.positions.push(ring.vertex(k).as_vec3());
        }
        ring
    }

    /// Stretches `ring`'s vertices by `f` along `across` (a unit vector in its plane): a
    /// bend's mitre.
    fn stretch(&mut self, ring: &Ring, across: DVec3, f: f64) {
        for k in 0..SIDES {
            let p = ring.vertex(k);
            let x = (p - ring.c).dot(across);
            self.mesh.positions[ring.index(k) as usize] = (p + across * (x * (f - 1.0))).as_vec3();
        }
    }

    fn tri(&mut self, v: [u32; 3], uv: [Vec2; 3], owner: [u32; 2]) {
        self.mesh.push_face(&v);
        for t in uv {
            self.uv.indices.push(self.uv.values.len() as u32);
            self.uv.values.push(t);
        }
        self.owner.push(owner);
    }

    fn ring_uv(&self, ring: &Ring, k: usize) -> Vec2 {
        let v = if self.opts.tile_v { ring.tile } else { (ring.v / self.plan.vmax) as f32 };
        Vec2::new(self.u(ring, k), v)
    }

    /// `u` of vertex `k` of `ring`; `k = 6` is the wrap column (`u = 1` when wrapped).
    fn u(&self, ring: &Ring, k: usize) -> f32 {
        match self.opts.u_mapping {
            UMapping::Reflected => ((k + ring.parity as usize) % 2) as f32,
            UMapping::Wrapped => k as f32 / SIDES as f32,
        }
    }

    /// UV of global vertex `g` on one of `rings`.
    fn vertex_uv(&self, rings: &[Ring], g: u32) -> Vec2 {
        for r in rings {
            if g >= r.first && g < r.first + SIDES as u32 {
                return self.ring_uv(r, (g - r.first) as usize);
            }
        }
        Vec2::ZERO
    }

    /// The 12-triangle strip from `a` (start) to `b` (end) with the least twist; sets
    /// `b`'s `u` parity from `a`'s (connected vertices share `u`) and `b` as an end ring
    /// for Tile V.
    fn strip(&mut self, a: &Ring, b: &mut Ring, owner: [u32; 2]) {
        self.strip_part(a, b, owner, (0.0, 1.0));
    }

    /// [`Build::strip`] for a part of an internode: with Tile V, `v` runs over `tiles`
    /// (the parts' fractions of the internode) instead of `0 → 1`.
    fn strip_part(&mut self, a: &Ring, b: &mut Ring, owner: [u32; 2], tiles: (f32, f32)) {
        let t = DQuat::from_rotation_arc(a.d, b.d) * a.u;
        let alpha = t.dot(b.w()).atan2(t.dot(b.u));
        let o = (alpha / FRAC_PI_3).round();
        self.max_twist = self.max_twist.max((alpha - o * FRAC_PI_3).abs().to_degrees());
        let o = o.rem_euclid(6.0) as usize;
        b.parity = ((a.parity as usize + o) % 2) as u8;
        b.tile = 1.0;
        let (va, vb) = if self.opts.tile_v {
            tiles
        } else {
            ((a.v / self.plan.vmax) as f32, (b.v / self.plan.vmax) as f32)
        };
        for k in 0..SIDES {
            let (a0, a1) = (a.index(k), a.index(k + 1));
            let (b0, b1) = (b.index(k + o), b.index(k + 1 + o));
            let (u0, u1) = (self.u(a, k), self.u(a, k + 1));
            let (ua0, ua1, ub0, ub1) =
                (Vec2::new(u0, va), Vec2::new(u1, va), Vec2::new(u0, vb), Vec2::new(u1, vb));
            self.tri([a0, a1, b1], [ua0, ua1, ub1], owner);
            self.tri([a0, b1, b0], [ua0, ub1, ub0], owner);
        }
    }

    /// Flat fan over a ring without new vertices; `start` caps the start of a tube.
    fn flat_cap(&mut self, ring: &Ring, start: bool, owner: [u32; 2], crease: bool) {
        let disc = |k: usize| {
            let a = k as f32 * std::f32::consts::FRAC_PI_3;
            Vec2::new(0.5 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin())
        };
        for k in 1..SIDES - 1 {
            let (x, y) = if start { (k + 1, k) } else { (k, k + 1) };
            self.tri([ring.index(0), ring.index(x), ring.index(y)], [disc(0), disc(x), disc(y)], owner);
        }
        if crease {
            for k in 0..SIDES {
                self.mesh.creases.push(Crease {
                    a: ring.index(k),
                    b: ring.index(k + 1),
                    sharpness: f32::INFINITY,
                });
            }
        }
    }

    /// End of a tip's tube (seed §A.3): a cone ("Cap Front"; `len` is the internode's
    /// length, for Tile V) or a flat creased cap ("pruned").
    fn tip(&mut self, ring: &Ring, len: f64, owner: [u32; 2]) {
        if self.opts.tips == SweepTips::Pruned {
            self.flat_cap(ring, false, owner, true);
            return;
        }
        let h = self.opts.tip_size * 2.0 * ring.r;
        let h = h.max(0.05 * ring.r);
        let apex = self.mesh.positions.len() as u32;
        self.mesh.positions.push((ring.c + ring.d * h).as_vec3());
        let va = if self.opts.tile_v {
            (1.0 + h / len.max(1e-12)) as f32
        } else {
            let h = self.plan.texel.map_or(h, |k| h / (ring.r * k));
            ((ring.v + h) / self.plan.vmax) as f32
        };
        for k in 0..SIDES {
            let (u0, u1) = (self.ring_uv(ring, k), Vec2::new(self.u(ring, k + 1), self.ring_uv(ring, k).y));
            let ua = Vec2::new(0.5 * (u0.x + u1.x), va);
            self.tri([ring.index(k), ring.index(k + 1), apex], [u0, u1, ua], owner);
        }
    }

    /// Start-of-tube base at a root: open or capped.
    fn base(&mut self, ring: &Ring, owner: [u32; 2]) {
        if self.opts.caps {
            self.flat_cap(ring, true, owner, true);
        } else {
            self.open_loops += 1;
        }
    }

    /// The general junction at node `j` (module docs, step 5b): the faces found by
    /// [`cap_hull`] on `trunk` followed by `kids`, mapped to their ring vertices.
    fn general_junction(&mut self, j: u32, trunk: &Ring, kids: &[Ring], faces: &[[(u32, u32); 3]]) {
        let mut rings = vec![*trunk];
        rings.extend_from_slice(kids);
        for f in faces {
            let t = f.map(|(l, k)| rings[l as usize].index(k as usize));
            let uv =
                [self.vertex_uv(&rings, t[0]), self.vertex_uv(&rings, t[1]), self.vertex_uv(&rings, t[2])];
            self.tri(t, uv, [j, NONE]);
        }
    }

    /// The junction template at node `j` (module docs, step 5). `trunk` ends the
    /// incoming tube (or is the base ring of a root junction); `kids` are the children's
    /// start rings in sorted order.
    fn junction(&mut self, j: u32, trunk: &Ring, kids: &[Ring]) {
        let owner = [j, NONE];
        let mut rings = vec![*trunk];
        rings.extend_from_slice(kids);
        let mut tris: Vec<[u32; 3]> = Vec::new();
        // Zip chain `p` of ring `rp` with chain `q` of ring `rq`, front to back.
        let mut zip = |rp: &Ring, p: [usize; 4], p_trunk: bool, rq: &Ring, q: [usize; 4], q_trunk: bool| {
            let (mut i, mut k) = (0, 0);
            let dist = |a: DVec3, b: DVec3| (a - b).length_squared();
            while i < 3 || k < 3 {
                let adv_p = if i == 3 {
                    false
                } else if k == 3 {
                    true
                } else {
                    dist(rp.vertex(p[i + 1]), rq.vertex(q[k])) <= dist(rp.vertex(p[i]), rq.vertex(q[k + 1]))
                };
                let (ring, trunk_ring, x, y, apex) = if adv_p {
                    let t = (rp, p_trunk, p[i], p[i + 1], rq.index(q[k]));
                    i += 1;
                    t
                } else {
                    let t = (rq, q_trunk, q[k], q[k + 1], rp.index(p[i]));
                    k += 1;
                    t
                };
                // Trunk ring edges run k → k+1, child ring edges k+1 → k (opposite to
                // their tubes).
                let forward = (x + 1) % SIDES == y % SIDES;
                let (from, to) = if forward == trunk_ring { (x, y) } else { (y, x) };
                tris.push([ring.index(from), ring.index(to), apex]);
            }
        };
        const LEFT: [usize; 4] = [0, 1, 2, 3];
        const RIGHT: [usize; 4] = [0, 5, 4, 3];
        let n = kids.len();
        zip(trunk, LEFT, true, &kids[0], LEFT, false);
        for i in 0..n - 1 {
            zip(&kids[i], RIGHT, false, &kids[i + 1], LEFT, false);
        }
        zip(trunk, RIGHT, true, &kids[n - 1], RIGHT, false);
        // Front (vertex 0) and back (vertex 3) holes.
        for side in [0usize, 3] {
            let mut cycle: Vec<u32> = vec![trunk.index(side)];
            cycle.extend(kids.iter().map(|r| r.index(side)));
            let (a, b) = (cycle[0], cycle[1]);
            let used = tris.iter().any(|t| (0..3).any(|e| t[e] == a && t[(e + 1) % 3] == b));
            if used {
                cycle[1..].reverse();
            }
            let pts: Vec<DVec3> = cycle.iter().map(|&g| self.mesh.positions[g as usize].as_dvec3()).collect();
            for [x, y, z] in max_min_angle(&pts) {
                tris.push([cycle[x], cycle[y], cycle[z]]);
            }
        }
        for t in tris {
            let uv =
                [self.vertex_uv(&rings, t[0]), self.vertex_uv(&rings, t[1]), self.vertex_uv(&rings, t[2])];
            self.tri(t, uv, owner);
        }
    }
}

/// Triangulates the polygon `pts` (in order) into `len − 2` triangles maximising the
/// smallest angle (dynamic programming over diagonals); corners keep the polygon order.
fn max_min_angle(pts: &[DVec3]) -> Vec<[usize; 3]> {
    let m = pts.len();
    if m < 3 {
        return Vec::new();
    }
    let min_angle = |a: usize, b: usize, c: usize| {
        let ang = |p: DVec3, q: DVec3, r: DVec3| {
            let (u, v) = (q - p, r - p);
            let d = u.length() * v.length();
            if d > 0.0 {
                (u.dot(v) / d).clamp(-1.0, 1.0).acos()
            } else {
                0.0
            }
        };
        ang(pts[a], pts[b], pts[c]).min(ang(pts[b], pts[c], pts[a])).min(ang(pts[c], pts[a], pts[b]))
    };
    let mut best = vec![vec![f64::INFINITY; m]; m];
    let mut split = vec![vec![0usize; m]; m];
    for gap in 2..m {
        for i in 0..m - gap {
            let j = i + gap;
            best[i][j] = f64::NEG_INFINITY;
            for k in i + 1..j {
                let q = best[i][k].min(best[k][j]).min(min_angle(i, k, j));
                if q > best[i][j] {
                    best[i][j] = q;
                    split[i][j] = k;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(m - 2);
    let mut stack = vec![(0, m - 1)];
    while let Some((i, j)) = stack.pop() {
        if j < i + 2 {
            continue;
        }
        let k = split[i][j];
        out.push([i, k, j]);
        stack.push((i, k));
        stack.push((k, j));
    }
    out
}

fn build(plan: &Plan, opts: &SweepOptions, fallback: &[bool]) -> (Mesh, Vec<[u32; 2]>, f64, usize) {
    let n = plan.pos.len();
    let mut b = Build {
        plan,
        opts,
        mesh: Mesh::new(),
        uv: FaceVarying::default(),
        owner: Vec::new(),
        max_twist: 0.0,
        open_loops: 0,
    };
    // Start ring of each internode (indexed by its child node).
    let mut start: Vec<Option<Ring>> = vec![None; n];
    let nodeown =
        |j: usize| if matches!(plan.kind[j], Kind::Junction | Kind::Chain) { j as u32 } else { NONE };
    for i in 0..n {
        if !plan.live[i] {
            continue;
        }
        let fb = fallback[i];
        let kind = plan.kind[i];
        let r = plan.rad[i];
        // End ring of the internode into i, and its tube.
        let mut end: Option<Ring> = None;
        if plan.par[i] != NONE {
            let Some(mut a) = start[i] else { continue };
            let owner = [nodeown(plan.par[i] as usize), nodeown(i)];
            let d = plan.dir[i];
            // Bend rings (step 4b): after a bent chain parent, and before this node when
            // it is one.
            let p = plan.par[i] as usize;
            let after = if plan.kind[p] == Kind::Chain && !fallback[p] { plan.bend_out[p] } else { 0.0 };
            let before = if kind == Kind::Chain && !fb { plan.bend_in[i] } else { 0.0 };
            let len = plan.len[i];
            let mut tile = 0.0f32;
            for x in [after, len - before].into_iter().filter(|&x| x > 0.0 && x < len) {
                let ux = DQuat::from_rotation_arc(a.d, d) * a.u;
                let rx = plan.rad[p] + (r - plan.rad[p]) * (x / len);
                let mut ring = b.ring(plan.pos[p] + d * x, d, ux, rx, plan.v_start(i, x));
                let t = (x / len) as f32;
                b.strip_part(&a, &mut ring, owner, (tile, t));
                tile = t;
                a = ring;
            }
            let ut = DQuat::from_rotation_arc(a.d, d) * a.u;
            let mut e = match kind {
                Kind::Tip => b.ring(plan.pos[i], d, ut, r, plan.path[i]),
                Kind::Chain if !fb => {
                    let c = plan.kids[i][0] as usize;
                    let axis = unit_or(d + plan.dir[c], d);
                    let ua = DQuat::from_rotation_arc(a.d, axis) * a.u;
                    let ring = b.ring(plan.pos[i], axis, ua, r, plan.path[i]);
                    let (f, across) = plan.mitre[i];
                    if f > 1.0 {
                        b.stretch(&ring, across, f);
                    }
                    ring
                }
                Kind::Junction if !fb => {
                    let off = plan.off_end[i];
                    b.ring(plan.pos[i] - d * off, d, plan.normal[i], r, plan.v_end(i, off))
                }
                _ => {
                    let off = plan.off_end[i];
                    b.ring(plan.pos[i] - d * off, d, ut, r, plan.v_end(i, off))
                }
            };
            b.strip_part(&a, &mut e, owner, (tile, 1.0));
            if kind == Kind::Tip {
                b.tip(&e, plan.len[i], owner);
            } else if fb {
                b.flat_cap(&e, false, [i as u32, NONE], false);
            }
            end = Some(e);
        }
        // Start rings of the children.
        let kids = &plan.kids[i];
        if kids.is_empty() {
            continue;
        }
        let own = [nodeown(i), NONE];
        match kind {
            Kind::Root => {
                let c = kids[0] as usize;
                let d = plan.dir[c];
                let ring = b.ring(plan.pos[i], d, plan.up[i], plan.start_r(i, c), 0.0);
                b.base(&ring, [NONE, NONE]);
                start[c] = Some(ring);
            }
            Kind::Chain if !fb => start[kids[0] as usize] = end,
            Kind::Junction if !fb => {
                let h = plan.h_in[i];
                let nrm = plan.normal[i];
                let trunk = match end {
                    Some(e) => e,
                    None => {
                        let ring = b.ring(plan.pos[i], h, nrm, r, 0.0);
                        b.base(&ring, [NONE, NONE]);
                        ring
                    }
                };
                let mut rings = Vec::with_capacity(kids.len());
                for &c in &plan.sorted[i] {
                    let c = c as usize;
                    let (off, d, u) = (plan.off_start[c], plan.dir[c], plan.kid_u[c]);
                    let mut ring =
                        b.ring(plan.pos[i] + d * off, d, u, plan.start_r(i, c), plan.v_start(c, off));
                    // Every junction ring has vertex 0 on the normal: the child takes
                    // the trunk's `u` parity.
                    ring.parity = trunk.parity;
                    if plan.collar[c] > 0.0 {
                        // Asymmetric template: the extra ring takes the child's place in
                        // the junction, a strip joins it to the child's own ring.
                        let oc = plan.off_collar[c];
                        let mut extra =
                            b.ring(plan.pos[i] + d * oc, d, u, plan.collar[c], plan.v_start(c, oc));
                        extra.parity = trunk.parity;
                        b.strip(&extra, &mut ring, own);
                        ring.tile = 0.0;
                        rings.push(extra);
                    } else {
                        rings.push(ring);
                    }
                    start[c] = Some(ring);
                }
                if plan.general[i] {
                    b.general_junction(i as u32, &trunk, &rings, &plan.general_faces[i]);
                } else {
                    b.junction(i as u32, &trunk, &rings);
                }
            }
            _ => {
                // Fallback: every child its own tube, capped at its offset.
                let seed = end.map(|e| e.u).unwrap_or(plan.up[i]);
                let from = end.map(|e| e.d).unwrap_or(plan.h_in[i]);
                for &c in kids {
                    let c = c as usize;
                    let off = plan.off_start[c];
                    let d = plan.dir[c];
                    let u = DQuat::from_rotation_arc(unit_or(from, d), d) * seed;
                    let ring = b.ring(plan.pos[i] + d * off, d, u, plan.start_r(i, c), plan.v_start(c, off));
                    b.flat_cap(&ring, true, own, false);
                    start[c] = Some(ring);
                }
            }
        }
    }
    let mut mesh = b.mesh;
    mesh.uvs = Some(b.uv);
    (mesh, b.owner, b.max_twist, b.open_loops)
}

/// Junctions (coplanar templates and general junctions) whose faces intersect each
/// other after `levels` Loop refinements of `mesh` (empty when `levels` is 0 or there
/// is no junction). Only the faces refined from junction faces are searched; Loop numbers the
/// children of face `f` `4f..4f + 4`, so a level-`L` face descends from control face
/// `f >> 2L`.
///
/// A junction's faces depend only on its own rings, so a junction searched once and
/// found clean (`checked`) is not searched again in later repair rounds.
fn folded_junctions(
    plan: &Plan,
    mesh: &Mesh,
    owner: &[[u32; 2]],
    levels: u32,
    checked: &mut [bool],
) -> HashSet<u32> {
    use crate::refine::{subdivide_traced, RefineOptions, Scheme, SubdivideOptions};
    let mut out = HashSet::new();
    // A junction's own faces and the first strips of its children.
    let junction = |f: usize| {
        let j = owner[f][0];
        (j != NONE
            && (owner[f][1] == NONE || plan.par[owner[f][1] as usize] == j)
            && plan.kind[j as usize] == Kind::Junction
            && !checked[j as usize])
            .then_some(j)
    };
    if levels == 0 || !(0..mesh.face_count()).any(|f| junction(f).is_some()) {
        return out;
    }
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::Loop, levels, ..Default::default() },
        ..Default::default()
    };
    let Ok((fine, up)) = subdivide_traced(mesh, &[], &opts) else { return out };
    // The refined triangles of each junction, searched among themselves.
    let tris: Vec<(u32, [u32; 3], u32)> = (0..fine.face_count())
        .filter_map(|f| {
            let v = fine.face(f);
            junction(up[f] as usize).filter(|_| v.len() == 3).map(|j| (j, [v[0], v[1], v[2]], f as u32))
        })
        .collect();
    for t in &tris {
        checked[t.0 as usize] = true;
    }
    // A folded junction is searched again after its repair (a template rebuilt as a
    // general junction can fold too).
    for (j, ..) in group_crossings(&fine.positions, tris, 1) {
        checked[j as usize] = false;
        out.insert(j);
    }
    out
}

/// Meshes `skeleton` with hexagonal sweeps and junction templates (see the module docs).
///
/// Errors: [`Error::InvalidGeometry`] for options out of range or a mesh beyond `u32`
/// indices; [`Error::Skeleton`] when the skeleton fails [`Skeleton::validate`].
/// Junctions that cannot be templated fall back locally and are reported, never an
/// error.
pub fn sweep_mesh(skeleton: &Skeleton, opts: &SweepOptions) -> Result<SweepMesh> {
    opts.check()?;
    skeleton.validate()?;
    if skeleton.len() > (u32::MAX as usize - 16) / 16 {
        return Err(Error::InvalidGeometry {
            what: "sweep mesher".into(),
            why: format!("{} nodes exceed u32 vertex indices", skeleton.len()),
        });
    }
    let mut plan = Plan::new(skeleton, opts);
    let n = skeleton.len();
    let mut fallback: Vec<bool> = plan.forced.clone();
    // Junctions already searched after refinement and found clean ([`folded_junctions`]).
    let mut checked = vec![false; n];
    let mut round = 0;
    let (mesh, face_owner, max_twist, open_loops) = loop {
        let (mesh, owner, twist, loops) = build(&plan, opts, &fallback);
        if round >= opts.repair_rounds || mesh.face_count() == 0 {
            break (mesh, owner, twist, loops);
        }
        round += 1;
        let rep = check_mesh(
            &mesh,
            &CheckOptions { max_listed: usize::MAX, max_intersections: 1_000_000, ..Default::default() },
        );
        let mut bad: HashSet<u32> = HashSet::new();
        let mark = |f: usize, bad: &mut HashSet<u32>| {
            for &o in &owner[f] {
                if o != NONE && !fallback[o as usize] {
                    bad.insert(o);
                }
            }
        };
        // An intersection is the mesher's own when the two faces belong to the same or
        // to neighbouring nodes; others are branches passing through each other in the
        // skeleton, which no fallback can separate.
        let near = |a: u32, b: u32| a == b || plan.par[a as usize] == b || plan.par[b as usize] == a;
        for &[f, g] in &rep.intersections {
            let local =
                owner[f].iter().any(|&a| a != NONE && owner[g].iter().any(|&b| b != NONE && near(a, b)));
            if local {
                mark(f, &mut bad);
                mark(g, &mut bad);
            }
        }
        for &f in &rep.degenerate_faces {
            mark(f, &mut bad);
        }
        // A clean control mesh: check the templates once more after refinement.
        let refined_only = bad.is_empty();
        if refined_only {
            bad = folded_junctions(&plan, &mesh, &owner, opts.check_levels, &mut checked);
        }
        if bad.is_empty() {
            break (mesh, owner, twist, loops);
        }
        // A coplanar template that fails is tried once as a general junction (module
        // docs, step 7); the other nodes fall back, but only once no junction changed
        // in this round (a neighbour's faces may have been the culprit).
        let mut bad: Vec<u32> = bad.into_iter().collect();
        bad.sort_unstable();
        let mut escalated = false;
        for &o in &bad {
            let o = o as usize;
            if opts.general_junctions
                && plan.kind[o] == Kind::Junction
                && !plan.general[o]
                && !plan.forced[o]
                && plan.make_general(o, opts)
            {
                escalated = true;
            }
        }
        if !escalated {
            if refined_only && bad.iter().all(|&o| fallback[o as usize]) {
                break (mesh, owner, twist, loops);
            }
            // General junctions that fold only under subdivision fall back too (session
            // 11: two children 8.5° apart at 90° to the trunk, whose offsets put their
            // rings 13 radii out, gave a hull that Loop folded at level 2).
            for o in bad {
                fallback[o as usize] = true;
            }
        }
    };
    let plan = &plan;
    let kind_is = |k: Kind| (0..n).filter(move |&i| plan.live[i] && plan.kind[i] == k);
    let fallbacks: Vec<u32> = (0..n).filter(|&i| fallback[i]).map(|i| i as u32).collect();
    let junctions: Vec<u32> = kind_is(Kind::Junction).filter(|&i| !fallback[i]).map(|i| i as u32).collect();
    let general: Vec<u32> = junctions.iter().copied().filter(|&i| plan.general[i as usize]).collect();
    let collars: Vec<u32> = (0..n)
        .filter(|&c| {
            plan.live[c] && plan.collar[c] > 0.0 && plan.par[c] != NONE && !fallback[plan.par[c] as usize]
        })
        .map(|c| c as u32)
        .collect();
    Ok(SweepMesh {
        mesh,
        junctions,
        general,
        fallbacks,
        asymmetric: plan.asymmetric.clone(),
        collars,
        clamped: plan.clamped.clone(),
        collapsed: plan.collapsed.clone(),
        max_twist_deg: max_twist,
        open_loops,
        face_owner,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq_5_1_values() {
        let (d1, d2) = pair_offsets(0.3, 0.7, PI / 2.0);
        assert!((d1 - 0.7).abs() < 1e-12 && (d2 - 0.3).abs() < 1e-12);
        let (d, _) = pair_offsets(1.0, 1.0, PI / 3.0);
        assert!((d - 3f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn hole_triangulation_counts() {
        let pts: Vec<DVec3> = (0..5).map(|k| DVec3::new((k as f64).cos(), (k as f64).sin(), 0.0)).collect();
        assert_eq!(max_min_angle(&pts).len(), 3);
        assert_eq!(max_min_angle(&pts[..3]).len(), 1);
    }

    #[test]
    fn fitted_normal_of_a_plane() {
        let n = fit_normal(&[DVec3::X, DVec3::new(0.6, 0.8, 0.0), DVec3::new(-0.6, 0.8, 0.0)]);
        assert!(n.z.abs() > 1.0 - 1e-9);
    }
}
