//! The quad mesher: one all-quad, watertight control cage for a whole [`Skeleton`], with
//! SMART-style junction boxes at branching nodes, ready for Catmull–Clark subdivision.
//!
//! This implements Skjermo2008's junction paper (Skjermo & Eidheim 2005, "Polygon mesh
//! generation of branching structures", **J §3.2–§3.5**, Eq. 4) as pinned down by Skjermo2008-spec
//! §2. The Catmull–Clark step is [`crate::refine::subdivide`] with
//! [`Scheme::CatmullClark`](crate::refine::Scheme::CatmullClark), run by the caller.
//!
//! # Sections and orientation
//!
//! Every cross-section is a **ring** of four vertices. A ring has a centre, a unit
//! *normal* (the direction the tube leaves it in) and an *up* vector: corner 0 lies along
//! up (J Fig. 1), corners 1–3 follow counter-clockwise about the normal. The corner
//! distance from the centre is `ρ = cs_scale · r` (Skjermo2008-spec §2: the literal reading is
//! `ρ = d/2`; Catmull–Clark shrinks a 4-ring to ≈ 0.65ρ, so `cs_scale ≈ 1.5` restores the
//! nominal radius). Between two rings `A → B` the band faces are
//! `[A_k, A_k+1, B_k+1, B_k]`, counter-clockwise seen from outside (glTF's convention).
//! Up is carried from ring to ring by projection onto the next section plane, never
//! re-derived, so sections do not twist (J §3.2).
//!
//! # The four cases (J §3.2), for an internode from its start ring `R` to node `n`
//!
//! Children are sorted by diameter, descending (ties: the one most aligned with the
//! internode, then the lower index). `d` is the unit direction from `R`'s centre to `n`,
//! `d₀` the direction to the first child.
//!
//! * **(a) End cap** — no child: a ring perpendicular to `d` at `n`, closed by one quad.
//! * **(b) Normal connection** (J §3.3) — one child, `∠(d, d₀) < 90°`: the end ring lies in
//!   the plane through `n` with normal `h = normalize(d + d₀)` (the half direction). Its
//!   corners are the perpendicular square's corners projected along `d` onto that plane
//!   (Skjermo2008-spec §2's "better" tilt compensation: every corner stays on the parent tube,
//!   the up corner along the projected up). The child continues from it.
//! * **(c) Connect backward** (J §3.4) — `∠(d, d₀) ≥ 90°` (any child count): a *middle*
//!   ring at distance `d₁` (the first child's diameter) back from `n` and an *end* ring at
//!   `r₁` beyond `n`, both perpendicular to `d`; the end ring is capped and **all**
//!   children go to the four side faces of the middle→end box.
//! * **(d) Connect branches** (J §3.5) — two or more children, `∠(d, d₀) < 90°`: the end
//!   ring `E` is built as in (b) but pulled back along `d` by `(l + x)/2` (the liver-data
//!   variant of J §3.5, option [`QuadOptions::pull_back`]; less when the internode is
//!   shorter, so `E` stays `min_length · ρ` ahead of the start ring); the box top `T` is a ring of
//!   the first child's radius, perpendicular to `h`, at `E + h·(l + x)` with `l + x` from
//!   Eq. 4 ([`box_length`]). The first child continues from `T`; the others are sorted
//!   into the four side faces `[E_k, E_k+1, T_k+1, T_k]` by the largest dot product of
//!   their direction with the face's outward normal (Skjermo2008-spec §2 inference), keeping
//!   diameter order. A used side face is the start ring of its child; its up vector runs
//!   from the face centre to `E_k` (J Fig. 4). Unused sides are closed by their quad.
//!
//! # Choices where the seed is ambiguous or silent
//!
//! * **Box orientation**: the base ring of a case (d) box is turned about the internode
//!   so that the side faces look at the side children as squarely as possible (24 turns
//!   over the square's 90° period, scored by each side child's cosine to its best face),
//!   then labelled so the band before it twists by at most 45°. The seed carries up
//!   unchanged, which can leave a child 45° off its face for no reason.
//! * **Support rings**: a tube long enough for it gets one extra ring, of its end
//!   section's size, [`QuadOptions::support`]` · ρ` before the end section (past the
//!   section's tilt). One face per internode lets Catmull–Clark round a bend or a box over
//!   the whole next face, cutting the corner by a fraction of the internode's length
//!   (`mig-m`: 8.8 ρ off the axis, into a neighbouring branch); with the ring, by about
//!   ρ. The ring's corners point where the end section's do, seen along the tube (a
//!   best fit of all four; exact for a mitre section), also on bends out of the plane
//!   of the corners. `support = 0` gives the seed's cage exactly.
//! * **Elbows**: a side child leaving its face more than [`QuadOptions::elbow_angle`]
//!   (default 0°: every side child) off the face normal starts from an extra ring of its
//!   own size, a short neck out of the face along the half direction of the normal and
//!   the child. The seed sweeps straight from the face; when the child leaves nearly
//!   along the box the face is seen edge-on from the child and its first tube is a
//!   twisted blade that folds into the sibling under Catmull–Clark, and even a square
//!   exit starts from a box-long rectangle, a flat blade over the child's whole first
//!   face.
//! * **Leading child**: children are sorted by diameter (J §3.5), except that a thickest
//!   child pointing back (≥ 90°) gives the lead to a forward child at least 3/4 as thick —
//!   otherwise a near-equal lateral turns the whole junction, the stem's continuation
//!   included, into a backward box.
//! * **Several children on one side** (Skjermo2008-spec §2 inference): the side face is the end of
//!   a virtual zero-length segment and gets its own box (a *chained box*), recursively up
//!   to [`QuadOptions::max_chain`] levels.
//! * **Eq. 4** as printed, `√Σdᵢ²/cos h + tan h·d₁/2` over **all** children including the
//!   first, with `h` half the angle between the box's base normal and the first child
//!   ([`BoxLength::SumSquares`], default); [`BoxLength::FirstChild`] uses `n = d₁`.
//! * **Root**: the root's start ring is capped (Skjermo2008-spec §2, property 2). A root with
//!   several children gets a box on its capped start ring.
//! * **Child positions** are measured from the parent node, not from the box (J §3.5); a
//!   child's tube runs from its start ring's centre to its node.
//!
//! # Local fallbacks (never a panic, always a closed 2-manifold)
//!
//! * A child whose direction is more than [`QuadOptions::max_side_angle`] from every free
//!   side normal (aligned with the parent, pointing back, or a zero-length internode), or
//!   beyond the chain limit, is **detached**: its subtree becomes a separate closed cage
//!   whose capped start ring sits at the parent node with radius
//!   `min(ρ_parent, ρ_child)` (the tube mesher's lateral convention). Reported as
//!   [`FallbackReason::Detached`] or [`FallbackReason::ChainLimit`].
//! * A first child shorter than its box (Skjermo2008-spec property 8): the box is shortened to end
//!   `2 · min_length · ρ` before the child's node, down to a quarter of its Eq. 4 length.
//!   Reported as [`FallbackReason::ShortBox`].
//! * A node that lies behind (or less than `min_length · ρ` in front of) its start ring —
//!   a child shorter than its box (Skjermo2008-spec property 8) or a sharp kink — is **short**:
//!   with one child the node is skipped (the tube runs on to the child), with several
//!   the box sits directly on the start ring, a tip is extended to `min_length · ρ`.
//!   Reported as [`FallbackReason::Short`] unless the internode itself is shorter than
//!   that (then it is merged and listed in [`QuadMesh::merged`]). A lone child that lies
//!   behind the start ring too (a hairpin) is not carried on: the tube ends as a tip
//!   would and the child is **detached** ([`FallbackReason::Detached`]); carried on, the
//!   ring skipped every later node that also lay behind it.
//! * A node with one child closer to its start ring than `ρ·(tan α_R + tan α_n) +
//!   min_length · ρ` — `α_R` the start ring's tilt against the internode, `α_n` half the
//!   bend at the node — is **merged**: its section would cross the start ring inside the
//!   tube, so the tube runs on to the child — only when the child lies ahead of the start
//!   ring. Listed in [`QuadMesh::merged`] (a chain of tiny internodes thus becomes one
//!   tube).
//! * Zero radii are raised to `min_radius · max radius` (or a fraction of the bounding
//!   box when every radius is 0), so no face has zero area and nothing is NaN.
//!
//! # Repair (beyond the seed)
//!
//! The seed only promises a valid topology. After the cage is built it is refined
//! [`QuadOptions::check_levels`] times with Catmull–Clark (2: the level issue 5's
//! acceptance checks), and each branching node's refined faces — those made for the node,
//! its children and its grandchildren ([`QuadMesh::face_node`]) — are searched for
//! crossings among themselves. For a crossing, with `a`, `b` the junction's children on
//! the way to the two faces: the thinner of them that is not the leading child is
//! **separated** ([`FallbackReason::Separated`]: its subtree starts as a capped cage on
//! its own axis, `1.25·(ρ_axis + ρ_child)` clear of the parent node and of the parent's
//! incoming and leading axes, at most 3/4 of the way to the child); when both already
//! are, a grandchild on the way that is a side child of its own parent; when no side
//! child is involved (the box against its leading child or itself) the junction is
//! **unboxed** ([`FallbackReason::Unboxed`]: every child but the first is separated).
//! Crossings inside one child's subtree are left to that child's junction, unless they
//! are the child's own first tube folding and it has no box (then it is separated). The
//! cage is rebuilt and the changed junctions' subtrees (sections carry their up vector
//! down the tree) and the two junctions above each are searched again, for up to
//! [`QuadOptions::repair_rounds`] rounds. Faces further apart in the tree than a
//! grandparent are not searched: crossings there are skeleton near misses, not junctions.
//!
//! # UVs (the seed has none)
//!
//! Face-varying: `u = k/4` at corner `k` of each ring, the seam between corner 3 and
//! corner 0 (`u = 1` there has its own value); `v` grows along each tube by the distance
//! between ring centres over the mean circumference `2π·ρ` (square texels on the
//! unsubdivided cage). A side face that starts a child restarts `u` at its corner 0 and
//! keeps the box's `v`. Caps map their corners to `(½ ± ½, ½ ± ½)` around the centre.
//!
//! Cost: the cage is O(nodes), one task stack (no recursion on skeleton depth), no
//! hashing; the repair refines the cage to level 2 (16 faces per quad) and searches each
//! junction's few thousand refined triangles, which dominates (see BENCHMARKS.md).

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::TAU;

/// A side child closer than this to the first child's direction is aligned with it:
/// beyond [`QuadOptions::max_side_angle`] it is detached, not elbowed (degrees).
const ALIGNED_DEG: f32 = 10.0;

/// A child closer than this to the reversed parent direction runs back inside the
/// parent's tube: beyond [`QuadOptions::max_side_angle`] it is detached (degrees).
const REVERSED_DEG: f32 = 2.0;

/// No node.
const NONE: u32 = u32::MAX;

/// A separated child's start ring keeps this multiple of the two radii from its parent's
/// axes (see [`FallbackReason::Separated`]).
const GAP_MARGIN: f32 = 1.25;

/// How the box length `l + x` of a junction is computed (Skjermo2008, J Eq. 4; Skjermo2008-spec §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoxLength {
    /// Eq. 4 as printed: `√(d₁² + … + dₙ²) / cos h + tan h · d₁ / 2`.
    #[default]
    SumSquares,
    /// The text's "n = d₁ seems adequate": `d₁ / cos h + tan h · d₁ / 2`.
    FirstChild,
}

/// Options of [`quad_mesh`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct QuadOptions {
    /// Corner distance of a section as a multiple of the node radius (default 1.0, the
    /// seed's literal reading; ≈ 1.5 restores the nominal radius after Catmull–Clark).
    pub cs_scale: f32,
    /// Box length rule (default [`BoxLength::SumSquares`]).
    pub box_length: BoxLength,
    /// Pull the end ring of a case (d) internode back by `(l + x)/2`, centring the box on
    /// the node (default true, as J §3.5 did for the liver data).
    pub pull_back: bool,
    /// Largest angle in degrees between a child and the outward normal of the side face
    /// it attaches to; beyond it the child is detached (default 80, range 10–89) —
    /// unless it points back (see [`QuadOptions::max_back_angle`]).
    pub max_side_angle: f32,
    /// The same limit for a child pointing back against the box's axis (but more than 2°
    /// from straight back along its parent), or forward but more than 10° from the
    /// first child (default 120, range 90–150): such a child (a lateral folding back
    /// along its parent, a narrow fork) leaves its face through an elbow instead of
    /// becoming a separate cage inside the parent, as the seed's limit would make it. A
    /// child within 10° of the first child or 2° of the reversed parent runs inside
    /// their tube and is still detached.
    pub max_back_angle: f32,
    /// Most chained boxes below one branching node (default 3, range 0–16).
    pub max_chain: u32,
    /// Smallest section corner distance as a fraction of the skeleton's largest radius
    /// (default 0.005, range 1e-6–1; 0.02 made thin tips fatter than their skeleton,
    /// 0.001 lets zero-radius tips fold under refinement).
    pub min_radius: f32,
    /// Shortest tube between two sections as a fraction of the local corner distance
    /// (default 0.1, range 1e-4–10).
    pub min_length: f32,
    /// Largest angle in degrees between a side child and its side face's normal that the
    /// child's tube may start at directly; beyond it an *elbow* ring first leaves the face
    /// along the half direction (default 0: every side child gets one; range 0–90; 90
    /// turns elbows off). Without it a child leaving nearly along the box starts from the
    /// face seen edge-on, and its first tube flattens into a twisted blade that folds
    /// under Catmull–Clark; and even a child leaving squarely starts from the whole side
    /// face, a box-long rectangle, so its tube is a flat blade over its whole first face
    /// (session 9: 30° left `mig-b`'s 70° trifurcation blades 5 ρ wide into a
    /// neighbour; 0 took `mig-m` 110 → 0, `lsys-abop-c` 60 → 0, `mig-refined` 165 → 33
    /// crossing pairs at level 2).
    pub elbow_angle: f32,
    /// Support rings (beyond the seed): on a tube longer than its sections, an extra
    /// ring of the end section's size is placed this many section corner distances (ρ)
    /// before the end section's reach, perpendicular to the tube (default 1.0; 0 turns
    /// them off and gives the seed's cage, e.g. `4(k + 1)` vertices for a chain of `k`
    /// internodes). Catmull–Clark rounds a bend or a box over the faces next to it:
    /// without them, a tube of one face per internode cuts the corner of a bend by a
    /// fraction of the *internode length* (measured on `mig-m`: 8.8 ρ off the axis, into
    /// a neighbouring branch), with them by about `ρ`.
    pub support: f32,
    /// Repair rounds after refinement (default 4, range 0–16; 0 turns the repair off):
    /// the cage is refined [`QuadOptions::check_levels`] times with Catmull–Clark, the
    /// refined faces of each junction are searched for crossings among themselves, and
    /// the children (or whole junctions) they come from are separated (see the module
    /// docs, "Repair").
    pub repair_rounds: u32,
    /// Catmull–Clark levels at which the repair looks for crossings (default 2, the
    /// level the junction acceptance checks; range 1–3).
    pub check_levels: u32,
    /// Work budget of the repair (issue 27; default [`DEFAULT_REPAIR_WORK`], range
    /// 1–10¹⁴): the refined triangles and candidate triangle pairs its searches look at,
    /// over all its rounds (counted, not timed, so the result stays deterministic). A
    /// repair that needs more stops the mesher with an error naming
    /// `mesh.quad.max_repair_work`; the pipeline shares one budget between all the
    /// meshings of a run (`mesh.clear` meshes once per round). Left out of written
    /// metadata at its default.
    #[serde(skip_serializing_if = "is_default_repair_work")]
    pub max_repair_work: u64,
}

/// Default [`QuadOptions::max_repair_work`]: 2·10⁹ units. One meshing of the largest
/// presets the tests mesh (`mig-a`, 14,925 nodes: 1.14·10⁹ units, about 6 s in release
/// on this project's 2-core machine; `wp-balsam-fir` and `wp-black-tupelo` about as
/// much) fits; the clearing's repeated meshings of such a tree do not.
pub const DEFAULT_REPAIR_WORK: u64 = 2_000_000_000;

/// Largest [`QuadOptions::max_repair_work`] accepted.
pub const MAX_REPAIR_WORK: u64 = 100_000_000_000_000;

/// Whether `w` is the default repair budget (left out of written metadata).
fn is_default_repair_work(w: &u64) -> bool {
    *w == DEFAULT_REPAIR_WORK
}

impl Default for QuadOptions {
    fn default() -> Self {
        QuadOptions {
            cs_scale: 1.0,
            box_length: BoxLength::SumSquares,
            pull_back: true,
            max_side_angle: 80.0,
            max_back_angle: 120.0,
            max_chain: 3,
            min_radius: crate::tolerance::RADIUS_FLOOR as f32,
            min_length: 0.1,
            elbow_angle: 0.0,
            support: 1.0,
            repair_rounds: 4,
            check_levels: 2,
            max_repair_work: DEFAULT_REPAIR_WORK,
        }
    }
}

impl QuadOptions {
    /// Checks every option's range; the message starts with the option's name.
    pub fn check(&self) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidGeometry { what: "quad mesher".into(), why });
        if !(self.cs_scale.is_finite() && self.cs_scale > 0.0 && self.cs_scale <= 100.0) {
            return bad(format!("cs_scale = {}; it must be in (0, 100]", self.cs_scale));
        }
        if !(self.max_side_angle.is_finite() && (10.0..=89.0).contains(&self.max_side_angle)) {
            return bad(format!("max_side_angle = {}; it must be in 10..=89 degrees", self.max_side_angle));
        }
        if !(self.max_back_angle.is_finite() && (90.0..=150.0).contains(&self.max_back_angle)) {
            return bad(format!("max_back_angle = {}; it must be in 90..=150 degrees", self.max_back_angle));
        }
        if self.max_chain > 16 {
            return bad(format!("max_chain = {}; it must be in 0..=16", self.max_chain));
        }
        if !(self.min_radius.is_finite() && (1e-6..=1.0).contains(&self.min_radius)) {
            return bad(format!("min_radius = {}; it must be in 1e-6..=1", self.min_radius));
        }
        if !(self.min_length.is_finite() && (1e-4..=10.0).contains(&self.min_length)) {
            return bad(format!("min_length = {}; it must be in 1e-4..=10", self.min_length));
        }
        if !(self.elbow_angle.is_finite() && (0.0..=90.0).contains(&self.elbow_angle)) {
            return bad(format!("elbow_angle = {}; it must be in 0..=90 degrees", self.elbow_angle));
        }
        if !(self.support.is_finite() && (0.0..=10.0).contains(&self.support)) {
            return bad(format!("support = {}; it must be in 0..=10", self.support));
        }
        if self.repair_rounds > 16 {
            return bad(format!("repair_rounds = {}; it must be in 0..=16", self.repair_rounds));
        }
        if !(1..=3).contains(&self.check_levels) {
            return bad(format!("check_levels = {}; it must be in 1..=3", self.check_levels));
        }
        if !(1..=MAX_REPAIR_WORK).contains(&self.max_repair_work) {
            return bad(format!(
                "max_repair_work = {}; it must be in 1..={MAX_REPAIR_WORK}",
                self.max_repair_work
            ));
        }
        Ok(())
    }
}

/// Why a node was meshed by a local fallback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FallbackReason {
    /// No free side face within `max_side_angle` of the child (aligned with the parent,
    /// pointing back, zero-length): the subtree is a separate capped cage.
    Detached,
    /// More children than chained boxes allow: the subtree is a separate capped cage.
    ChainLimit,
    /// The first child is shorter than its junction box (J §3.5): the box was shortened
    /// to end before the child's node (down to a quarter of its Eq. 4 length).
    ShortBox,
    /// The node lies behind or too close in front of its start section (a child shorter
    /// than its box, a sharp kink): the node was skipped, boxed on its start section or
    /// extended (see the module docs).
    Short,
    /// The repair found this child's refined surface crossing its junction (a narrow
    /// fork, a crowded whorl): it starts as a separate capped cage a small gap away from
    /// its parent's tubes instead of from a side face.
    Separated,
    /// The repair found this junction's own box folding under refinement: every child but
    /// the first is separated and the node becomes a plain connection.
    Unboxed,
}

/// One node meshed by a fallback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct QuadFallback {
    /// The skeleton node (for detached ones: the child whose subtree was detached).
    pub node: u32,
    /// What happened.
    pub reason: FallbackReason,
}

/// How many times each case of J §3.2 was used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CaseCounts {
    /// (a) end caps.
    pub end_caps: usize,
    /// (b) normal connections.
    pub normal: usize,
    /// (c) backward connections.
    pub backward: usize,
    /// (d) junction boxes at branching nodes (including a branching root).
    pub boxes: usize,
    /// Chained boxes on side faces holding several children.
    pub chained: usize,
    /// Elbow rings between a side face and a child leaving it obliquely.
    pub elbows: usize,
}

/// The result of [`quad_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct QuadMesh {
    /// Quads, counter-clockwise seen from outside, with face-varying UVs.
    pub mesh: Mesh,
    /// Nodes meshed by a local fallback, in the order met.
    pub fallbacks: Vec<QuadFallback>,
    /// Case statistics.
    pub cases: CaseCounts,
    /// Nodes with one child skipped because their section would cross the previous one
    /// (short internodes; see the module docs), in the order met.
    pub merged: Vec<u32>,
    /// Closed pieces: one per tree with geometry plus one per detached or separated
    /// subtree.
    pub components: usize,
    /// The skeleton node each face was made for, parallel to the faces: a tube's bands
    /// and end cap belong to the node it runs to, a junction's box to its branching
    /// node, an elbow to its child (for per-branch selection, and for the repair).
    pub face_node: Vec<u32>,
    /// Repair rounds that changed the cage (0 when the first cage was clean or the repair
    /// is off).
    pub repair_rounds: u32,
    /// Work the repair spent ([`QuadOptions::max_repair_work`]'s units).
    pub repair_work: u64,
}

/// Box length `l + x` of a junction (Skjermo2008, J Eq. 4): `diameters` are the children's
/// diameters, first (largest) child first; `half_angle` is `h` in radians, clamped to
/// `[0, π/4]` (the seed's range).
pub fn box_length(rule: BoxLength, diameters: &[f32], half_angle: f32) -> f32 {
    let h = half_angle.clamp(0.0, std::f32::consts::FRAC_PI_4);
    let d1 = diameters.first().copied().unwrap_or(0.0);
    let n = match rule {
        BoxLength::SumSquares => diameters.iter().map(|d| d * d).sum::<f32>().sqrt(),
        BoxLength::FirstChild => d1,
    };
    // Skjermo2008, Eq. 4
    n / h.cos() + h.tan() * d1 / 2.0
}

/// A four-vertex cross-section.
#[derive(Debug, Clone, Copy)]
struct Ring {
    v: [u32; 4],
    /// UV values of corners 0..3 and the seam copy of corner 0 (`u = 1`).
    uv: [u32; 5],
    center: Vec3,
    normal: Vec3,
    up: Vec3,
    rho: f32,
    tex_v: f32,
}

enum Task {
    /// Mesh the internode from `ring` to `node` and everything after it.
    Segment { ring: Ring, node: u32 },
    /// Mesh `node`'s subtree as a separate cage starting at its parent.
    Detach { node: u32 },
    /// Mesh `node`'s subtree as a separate cage a gap away from its parent's tubes.
    Separate { node: u32 },
}

/// What the repair changed at a node (see [`FallbackReason::Separated`] and
/// [`FallbackReason::Unboxed`]).
#[derive(Debug, Clone, Default)]
struct Repairs {
    separated: Vec<bool>,
    unboxed: Vec<bool>,
    /// The junctions the next round searches (empty: all): those that crossed, and the
    /// changed junctions' subtrees and the two junctions above each.
    dirty: Vec<bool>,
}

struct Builder<'a> {
    sk: &'a Skeleton,
    opts: &'a QuadOptions,
    offsets: &'a [u32],
    kids: &'a [u32],
    repairs: &'a Repairs,
    /// The node each face was made for (parallel to the faces).
    owner: Vec<u32>,
    /// The node the faces being made belong to.
    cur: u32,
    /// Each branching node's first (leading) child.
    lead: Vec<u32>,
    floor: f32,
    cos_side: f32,
    cos_back: f32,
    cos_elbow: f32,
    positions: Vec<Vec3>,
    indices: Vec<u32>,
    uv_values: Vec<Vec2>,
    uv_indices: Vec<u32>,
    fallbacks: Vec<QuadFallback>,
    cases: CaseCounts,
    merged: Vec<u32>,
    components: usize,
    stack: Vec<Task>,
}

/// Meshes `skeleton` into one all-quad, closed, consistently oriented control cage (see
/// the module docs). Every tree with at least one internode gives one closed piece, and
/// every detached subtree another.
///
/// Errors: [`Error::InvalidGeometry`] for options out of range or a cage beyond `u32`
/// indices; [`Error::Skeleton`] when the skeleton fails [`Skeleton::validate`]. Never
/// panics on a valid skeleton. Deterministic; O(nodes).
pub fn quad_mesh(skeleton: &Skeleton, opts: &QuadOptions) -> Result<QuadMesh> {
    opts.check()?;
    skeleton.validate()?;
    let n = skeleton.len();
    // Every node makes at most ~3 rings (box, chain, detached start) of 4 vertices.
    if (n as u64) * 64 >= u32::MAX as u64 {
        return Err(Error::InvalidGeometry {
            what: "quad mesher".into(),
            why: format!("{n} nodes could need more than u32 indices; split the skeleton"),
        });
    }
    let ch = skeleton.children();
    let mut offsets = Vec::with_capacity(n + 1);
    let mut kids = Vec::with_capacity(n);
    offsets.push(0);
    for i in 0..n {
        kids.extend_from_slice(ch.of(i));
        offsets.push(kids.len() as u32);
    }
    let max_r = skeleton.radius.iter().fold(0.0f32, |m, &r| m.max(r)) * opts.cs_scale;
    let floor = if max_r > 0.0 {
        max_r * opts.min_radius
    } else {
        let st = skeleton.stats();
        ((st.bounds.1 - st.bounds.0).length() * 0.002).max(1e-4)
    };
    let mut repairs = Repairs { separated: vec![false; n], unboxed: vec![false; n], dirty: Vec::new() };
    let mut rounds = 0;
    let mut work = 0u64;
    loop {
        let mut b = Builder {
            sk: skeleton,
            opts,
            offsets: &offsets,
            kids: &kids,
            repairs: &repairs,
            owner: Vec::with_capacity(n * 5),
            cur: NONE,
            lead: vec![NONE; n],
            floor: floor.max(1e-9),
            cos_side: opts.max_side_angle.to_radians().cos(),
            cos_back: opts.max_back_angle.to_radians().cos(),
            cos_elbow: opts.elbow_angle.to_radians().cos(),
            positions: Vec::with_capacity(n * 5),
            indices: Vec::with_capacity(n * 20),
            uv_values: Vec::with_capacity(n * 6),
            uv_indices: Vec::with_capacity(n * 20),
            fallbacks: Vec::new(),
            cases: CaseCounts::default(),
            merged: Vec::new(),
            components: 0,
            stack: Vec::new(),
        };
        for root in 0..n {
            if skeleton.parent[root] == NO_PARENT {
                b.root(root as u32);
            }
            b.drain();
        }
        let Builder {
            positions,
            indices,
            owner,
            lead,
            uv_values,
            uv_indices,
            fallbacks,
            cases,
            merged,
            components,
            ..
        } = b;
        let faces = indices.len() / 4;
        let mesh = Mesh {
            positions,
            face_offsets: (0..=faces as u32).map(|f| 4 * f).collect(),
            face_indices: indices,
            uvs: None,
            normals: None,
            creases: Vec::new(),
        };
        let changed = if rounds < opts.repair_rounds {
            let left = opts.max_repair_work.saturating_sub(work);
            match repair(skeleton, &mesh, &owner, &lead, opts.check_levels, &mut repairs, left) {
                Some((changed, spent)) => {
                    work += spent;
                    changed
                }
                None => {
                    return Err(Error::Recipe(format!(
                        "`mesh.quad.max_repair_work`: the quad mesher's repair (round {} of at most {}) on {n} \
                         skeleton nodes needs more than the {} units of work left of its budget (refined triangles \
                         and candidate triangle pairs searched; one budget serves all the meshings of a run, \
                         `mesh.clear` meshes once a round); raise it with --set mesh.quad.max_repair_work=N, or \
                         lower mesh.quad.repair_rounds (0 turns the repair off)",
                        rounds + 1,
                        opts.repair_rounds,
                        opts.max_repair_work
                    )))
                }
            }
        } else {
            false
        };
        if !changed {
            let mesh = Mesh { uvs: Some(FaceVarying { values: uv_values, indices: uv_indices }), ..mesh };
            return Ok(QuadMesh {
                mesh,
                fallbacks,
                cases,
                merged,
                components,
                face_node: owner,
                repair_rounds: rounds,
                repair_work: work,
            });
        }
        rounds += 1;
    }
}

/// One repair round (see the module docs, "Repair"): refines `mesh` `levels` times with
/// Catmull–Clark, searches the refined faces of each branching node's neighbourhood —
/// the faces made for the node, its children and its grandchildren — for crossings, and
/// records in `repairs` what to change. Returns whether anything changed and the work
/// spent (the refined triangles grouped plus [`crate::mesh::check`]'s search units), or
/// `None` when that is more than `max_work`. After the first round only the junctions
/// that crossed and those a change can have moved are searched again (see the end of
/// this function).
fn repair(
    sk: &Skeleton,
    mesh: &Mesh,
    owner: &[u32],
    lead: &[u32],
    levels: u32,
    repairs: &mut Repairs,
    max_work: u64,
) -> Option<(bool, u64)> {
    use crate::mesh::check::group_crossings_within;
    use crate::refine::{subdivide_traced, RefineOptions, Scheme, SubdivideOptions};
    let opts = SubdivideOptions {
        refine: RefineOptions { scheme: Scheme::CatmullClark, levels, ..Default::default() },
        ..Default::default()
    };
    // The refinement itself: one unit per refined face, checked before it is made.
    let refined = (mesh.face_count() as u64).saturating_mul(4u64.pow(levels));
    if refined > max_work {
        return None;
    }
    let Ok((fine, up)) = subdivide_traced(mesh, &[], &opts) else { return Some((false, refined)) };
    let parent = |o: u32| if o == NONE { NONE } else { sk.parent[o as usize] };
    let branching = |j: u32| j != NONE && lead[j as usize] != NONE;
    // The junctions each control face is searched with: its node's, its parent's and its
    // grandparent's, where that node branches (and, after the first round, is due).
    let due = |j: u32| branching(j) && (repairs.dirty.is_empty() || repairs.dirty[j as usize]);
    let keys: Vec<[u32; 3]> = (0..mesh.face_count())
        .into_par_iter()
        .map(|f| {
            let o = owner[f];
            let (p, g) = (parent(o), parent(parent(o)));
            [o, p, g].map(|j| if due(j) { j } else { NONE })
        })
        .collect();
    let mut tris: Vec<(u32, [u32; 3], u32)> = Vec::with_capacity(fine.face_count() * 3);
    for f in 0..fine.face_count() {
        let v = fine.face(f);
        for key in keys[up[f] as usize] {
            if key != NONE {
                tris.push((key, [v[0], v[1], v[2]], f as u32));
                tris.push((key, [v[0], v[2], v[3]], f as u32));
            }
        }
    }
    // The child of `j` on the way to `o` (`None` for `j` itself).
    let path = |o: u32, j: u32| {
        if o == j {
            None
        } else if parent(o) == j {
            Some(o)
        } else {
            Some(parent(o))
        }
    };
    let mut touched: Vec<u32> = Vec::new();
    let (crossings, searched) = group_crossings_within(&fine.positions, tris, 64, max_work - refined)?;
    // Next round: the junctions that crossed (they may hold more than the pairs listed)
    // and those whose searched faces a change can have moved.
    let mut dirty = vec![false; sk.len()];
    for (j, fa, fb) in crossings {
        dirty[j as usize] = true;
        let (oa, ob) = (owner[up[fa as usize] as usize], owner[up[fb as usize] as usize]);
        let (ca, cb) = (path(oa, j), path(ob, j));
        if let Some(c) = ca.filter(|_| ca == cb) {
            // Inside one child's subtree: its own junction's business, unless the child's
            // own faces (its first tube, its elbow) fold and it has no junction (or one
            // already unboxed).
            let boxed = branching(c) && !repairs.unboxed[c as usize];
            if oa != c || ob != c || boxed || c == lead[j as usize] {
                continue;
            }
        }
        // The thinner side child is separated (the other one when that one already is);
        // when both are, a grandchild on the way that is a side child of its own parent.
        let thinner = |v: &mut Vec<u32>| {
            v.sort_by(|&a, &b| sk.radius[a as usize].total_cmp(&sk.radius[b as usize]).then(b.cmp(&a)))
        };
        let mut side: Vec<u32> = [ca, cb].into_iter().flatten().filter(|&c| c != lead[j as usize]).collect();
        thinner(&mut side);
        let mut deeper: Vec<u32> = [oa, ob]
            .into_iter()
            .filter(|&o| o != j && parent(o) != j && lead[parent(o) as usize] != o)
            .collect();
        thinner(&mut deeper);
        let free = |c: &&u32| !repairs.separated[**c as usize];
        match side.iter().find(free).or_else(|| deeper.iter().find(free)) {
            Some(&c) => {
                repairs.separated[c as usize] = true;
                touched.push(c);
            }
            None if !side.is_empty() => {}
            None if !repairs.unboxed[j as usize] => {
                repairs.unboxed[j as usize] = true;
                touched.push(j);
            }
            None => {}
        }
    }
    // A change at junction `j` (a child separated, or `j` unboxed) rebuilds `j`'s box,
    // which turns to its remaining side children, and sections carry their up vector
    // down the tree: everything below `j` may move. `j`, the two junctions above it
    // (which search `j`'s faces) and `j`'s whole subtree are searched again (parents
    // precede children, so one pass marks the subtrees).
    let mut below = vec![false; sk.len()];
    for &t in &touched {
        let j = if repairs.unboxed[t as usize] { t } else { parent(t) };
        below[j as usize] = true;
        for k in [parent(j), parent(parent(j))] {
            if k != NONE {
                dirty[k as usize] = true;
            }
        }
    }
    for c in 0..sk.len() {
        let p = sk.parent[c];
        below[c] |= p != NO_PARENT && below[p as usize];
        dirty[c] |= below[c];
    }
    repairs.dirty = dirty;
    Some((!touched.is_empty(), refined + searched))
}

/// Unit `v`, or `fallback` when `v` is (nearly) zero or not finite.
fn unit_or(v: Vec3, fallback: Vec3) -> Vec3 {
    let l = v.length();
    if l > 1e-12 && l.is_finite() {
        v / l
    } else {
        fallback
    }
}

/// Unit vector of `up` projected perpendicular to unit `n` (any perpendicular when
/// `up` is parallel to `n`).
fn perp(up: Vec3, n: Vec3) -> Vec3 {
    let p = up - n * up.dot(n);
    if p.length_squared() > 1e-10 {
        p.normalize()
    } else {
        n.any_orthonormal_vector()
    }
}

/// Outward unit normal of a planar-ish quad (Newell's method), zero when degenerate.
fn quad_normal(p: [Vec3; 4]) -> Vec3 {
    let mut n = Vec3::ZERO;
    for k in 0..4 {
        n += p[k].cross(p[(k + 1) % 4]);
    }
    unit_or(n, Vec3::ZERO)
}

impl Builder<'_> {
    fn kids(&self, node: u32) -> &[u32] {
        &self.kids[self.offsets[node as usize] as usize..self.offsets[node as usize + 1] as usize]
    }

    fn pos(&self, node: u32) -> Vec3 {
        self.sk.position[node as usize]
    }

    /// Section corner distance of a node.
    fn rho(&self, node: u32) -> f32 {
        (self.sk.radius[node as usize] * self.opts.cs_scale).max(self.floor)
    }

    fn min_len(&self, rho: f32) -> f32 {
        self.opts.min_length * rho
    }

    fn drain(&mut self) {
        while let Some(t) = self.stack.pop() {
            match t {
                Task::Segment { ring, node } => self.segment(ring, node),
                Task::Detach { node } => self.detach(node),
                Task::Separate { node } => self.separate(node),
            }
        }
    }

    /// Children of `node` sorted by diameter (descending), then by alignment with `d`,
    /// then by index.
    fn sorted_kids(&self, node: u32, d: Vec3) -> Vec<u32> {
        let mut k = self.kids(node).to_vec();
        let p = self.pos(node);
        let dot = |c: u32| unit_or(self.pos(c) - p, Vec3::ZERO).dot(d);
        k.sort_by(|&a, &b| {
            let ra = self.sk.radius[a as usize];
            let rb = self.sk.radius[b as usize];
            rb.total_cmp(&ra).then(dot(b).total_cmp(&dot(a))).then(a.cmp(&b))
        });
        // A thickest child that points back (≥ 90°) would make the whole junction a
        // backward box with every other child — the forward continuation included — on
        // its sides. When a forward child is nearly as thick (≥ 3/4 of its radius), that
        // one leads instead.
        if k.len() > 1 && dot(k[0]) <= 0.0 {
            let r0 = self.sk.radius[k[0] as usize];
            if let Some(i) = k.iter().position(|&c| dot(c) > 0.0 && self.sk.radius[c as usize] >= 0.75 * r0) {
                let lead = k.remove(i);
                k.insert(0, lead);
            }
        }
        k
    }

    /// [`Self::sorted_kids`] less the children the repair separated (or, at an unboxed
    /// node, all but the first), which are queued as separate cages and reported.
    fn kids_for(&mut self, node: u32, d: Vec3) -> Vec<u32> {
        let mut k = self.sorted_kids(node, d);
        if k.len() < 2 {
            return k;
        }
        let first = k[0];
        self.lead[node as usize] = first;
        let unboxed = self.repairs.unboxed[node as usize];
        if unboxed {
            self.fallback(node, FallbackReason::Unboxed);
        }
        k.retain(|&c| {
            let keep = c == first || !(unboxed || self.repairs.separated[c as usize]);
            if !keep {
                self.fallback(c, FallbackReason::Separated);
                self.stack.push(Task::Separate { node: c });
            }
            keep
        });
        k
    }

    fn vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    fn uv(&mut self, uv: Vec2) -> u32 {
        self.uv_values.push(uv);
        (self.uv_values.len() - 1) as u32
    }

    fn ring_uvs(&mut self, tex_v: f32) -> [u32; 5] {
        [0, 1, 2, 3, 4].map(|k| self.uv(Vec2::new(k as f32 / 4.0, tex_v)))
    }

    fn quad(&mut self, v: [u32; 4], uv: [u32; 4]) {
        self.indices.extend_from_slice(&v);
        self.uv_indices.extend_from_slice(&uv);
        self.owner.push(self.cur);
    }

    /// `v` of a ring at `center` following `prev`.
    fn next_tex_v(prev: &Ring, center: Vec3, rho: f32) -> f32 {
        let c = TAU * 0.5 * (prev.rho + rho);
        prev.tex_v + center.distance(prev.center) / c.max(1e-12)
    }

    /// A square section perpendicular to `normal` at `center`, corner 0 along `up`
    /// projected into its plane.
    fn ring_perp(&mut self, center: Vec3, normal: Vec3, up: Vec3, rho: f32, tex_v: f32) -> Ring {
        let a = perp(up, normal);
        let b = normal.cross(a);
        let v = [a, b, -a, -b].map(|o| self.vertex(center + o * rho));
        Ring { v, uv: self.ring_uvs(tex_v), center, normal, up: a, rho, tex_v }
    }

    /// The normal-connection section (J §3.3): the square perpendicular to `d` at
    /// `center`, each corner projected along `d` onto the plane with normal `h` (tilt
    /// compensation: corners stay on the tube of direction `d`).
    fn ring_miter(&mut self, center: Vec3, d: Vec3, h: Vec3, up: Vec3, rho: f32, tex_v: f32) -> Ring {
        let a = perp(up, d);
        let b = d.cross(a);
        let cos = d.dot(h).max(0.2);
        let v = [a, b, -a, -b].map(|o| {
            let q = o * rho;
            self.vertex(center + q - d * (q.dot(h) / cos))
        });
        Ring { v, uv: self.ring_uvs(tex_v), center, normal: h, up: perp(a, h), rho, tex_v }
    }

    /// The tube of an internode from ring `r` to ring `e`: one band, or with
    /// [`QuadOptions::support`] two, through a support ring of the end ring's size and
    /// corner orientation ([`Self::corner_up`]) `g·ρ` before the end section's reach along the tube (a tilted
    /// section's corners reach `ρ·tan α` along it), where the tube has room for it with
    /// `g·ρ` to spare; the tube's taper and twist stay on the long first band. There is
    /// no support ring at the start: one there (after a box's side face or a section)
    /// made `lsys-abop-c`'s planar whorls cross 770 times at level 2 instead of 60, and
    /// `mig-e`'s 288 times instead of 54, while end rings alone took `mig-m` from 260 to
    /// 110 and `mig-b` from 396 to 158 (after `decollide`).
    fn tube(&mut self, r: &Ring, e: &Ring) {
        let g = self.opts.support;
        let axis = e.center - r.center;
        let len = axis.length();
        if g <= 0.0 || len <= 0.0 || !len.is_finite() {
            self.band(r, e);
            return;
        }
        let d = axis / len;
        // How far a section's corners reach along the tube: ρ·tan of its tilt.
        let reach = |s: &Ring| {
            let c = s.normal.dot(d).abs().max(0.2);
            s.rho * (1.0 - c * c).max(0.0).sqrt() / c
        };
        let a = reach(e) + g * e.rho;
        // The start section's reach, which the ring must clear too.
        if len < reach(r) + a + g * r.rho.max(e.rho) {
            self.band(r, e);
            return;
        }
        let t = 1.0 - a / len;
        let up = self.corner_up(e, d);
        let m = self.ring_perp(r.center + d * (len - a), d, up, e.rho, r.tex_v + (e.tex_v - r.tex_v) * t);
        self.band(r, &m);
        self.band(&m, e);
    }

    /// Corner 0's direction for a ring perpendicular to `d` whose corners follow ring
    /// `e`'s corners seen along `d`: the unit `a` maximising `Σ_k ĉ_k · R^k a`, with `ĉ_k`
    /// corner `k`'s direction from `e`'s centre projected off `d` and `R` the quarter
    /// turn about `d` (corner `k + 1` of [`Self::ring_perp`] is corner `k` turned by `R`),
    /// i.e. `normalize(ĉ₀ − d × ĉ₁ − ĉ₂ + d × ĉ₃)`. For a mitre section (the end of a
    /// bend, [`Self::ring_miter`]) that is exactly its perpendicular square's corner 0.
    /// Projecting `e.up` instead — the up corner projected into the tilted plane, then
    /// back off `d` — turns the ring by up to ~10° on a bend out of the corner's plane
    /// (4.7°–9.6° at 46°–67° bends), twisting the last band. `perp(e.up, d)` when the
    /// corners are degenerate.
    fn corner_up(&self, e: &Ring, d: Vec3) -> Vec3 {
        let c = e.v.map(|i| {
            let o = self.positions[i as usize] - e.center;
            (o - d * o.dot(d)).normalize_or_zero()
        });
        let a = c[0] - d.cross(c[1]) - c[2] + d.cross(c[3]);
        let a = a - d * a.dot(d);
        if a.length_squared() > 1e-12 {
            a.normalize()
        } else {
            perp(e.up, d)
        }
    }

    /// The four band quads from ring `a` to ring `b`.
    fn band(&mut self, a: &Ring, b: &Ring) {
        for k in 0..4 {
            let k1 = (k + 1) % 4;
            self.quad([a.v[k], a.v[k1], b.v[k1], b.v[k]], [a.uv[k], a.uv[k + 1], b.uv[k + 1], b.uv[k]]);
        }
    }

    /// Closes `r` with one quad facing along its normal (`outward`) or against it.
    fn cap(&mut self, r: &Ring, outward: bool) {
        let uv = [Vec2::new(1.0, 0.5), Vec2::new(0.5, 1.0), Vec2::new(0.0, 0.5), Vec2::new(0.5, 0.0)]
            .map(|p| self.uv(p));
        if outward {
            self.quad(r.v, uv);
        } else {
            self.quad([r.v[3], r.v[2], r.v[1], r.v[0]], [uv[3], uv[2], uv[1], uv[0]]);
        }
    }

    fn fallback(&mut self, node: u32, reason: FallbackReason) {
        self.fallbacks.push(QuadFallback { node, reason });
    }

    /// A root: a capped start ring, then its child (or a box for several children).
    fn root(&mut self, root: u32) {
        self.cur = root;
        let kids = self.kids_for(root, Vec3::Y);
        let Some(&k0) = kids.first() else { return };
        let p = self.pos(root);
        let d0 = unit_or(self.pos(k0) - p, Vec3::Y);
        let rho = self.rho(root);
        let up = self.sk.up[k0 as usize];
        let ring = self.ring_perp(p, d0, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        if kids.len() == 1 {
            self.stack.push(Task::Segment { ring, node: k0 });
        } else {
            self.cases.boxes += 1;
            self.junction(ring, d0, root, &kids, 0);
        }
    }

    /// A detached subtree: a capped start ring at the parent node, then the child.
    fn detach(&mut self, node: u32) {
        self.cur = node;
        let parent = self.sk.parent[node as usize];
        let from = if parent == NO_PARENT { self.pos(node) } else { self.pos(parent) };
        let d = unit_or(self.pos(node) - from, Vec3::Y);
        let rho = if parent == NO_PARENT { self.rho(node) } else { self.rho(node).min(self.rho(parent)) };
        let up = self.sk.up[node as usize];
        let ring = self.ring_perp(from, d, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        self.stack.push(Task::Segment { ring, node });
    }

    /// A separated subtree (see [`FallbackReason::Separated`]): a capped start ring of
    /// the child's size on the child's axis, far enough out that it keeps
    /// `GAP_MARGIN × (ρ_axis + ρ_child)` from the parent node and from the parent's
    /// incoming and leading axes (each a half-line from the node), at most 3/4 of the way
    /// to the child.
    fn separate(&mut self, node: u32) {
        self.cur = node;
        let parent = self.sk.parent[node as usize];
        let pp = self.pos(parent);
        let to = self.pos(node) - pp;
        let dk = unit_or(to, Vec3::Y);
        let rho = self.rho(node);
        let rp = self.rho(parent);
        let mut t = GAP_MARGIN * (rp + rho);
        let gp = self.sk.parent[parent as usize];
        let lead = self.lead[parent as usize];
        let axes = [
            (gp != NO_PARENT).then(|| (unit_or(self.pos(gp) - pp, Vec3::ZERO), rp)),
            (lead != NONE && lead != node)
                .then(|| (unit_or(self.pos(lead) - pp, Vec3::ZERO), rp.max(self.rho(lead)))),
        ];
        for (a, ra) in axes.into_iter().flatten() {
            let c = dk.dot(a);
            if c > 0.0 {
                let sin = (1.0 - c * c).max(0.0).sqrt().max(0.05);
                t = t.max(GAP_MARGIN * (ra + rho) / sin);
            }
        }
        let t = t.min(0.75 * to.length());
        let up = self.sk.up[node as usize];
        let ring = self.ring_perp(pp + dk * t, dk, up, rho, 0.0);
        self.cap(&ring, false);
        self.components += 1;
        self.stack.push(Task::Segment { ring, node });
    }

    /// The internode from `r` to `node` and the structure at `node` (J §3.2 cases).
    fn segment(&mut self, r: Ring, node: u32) {
        self.cur = node;
        let p = self.pos(node);
        let rho = self.rho(node);
        let min_len = self.min_len(rho.max(r.rho));
        let v = p - r.center;
        let along = v.dot(r.normal);
        let short = along < min_len;
        let d = if short { r.normal } else { unit_or(v, r.normal) };
        let kids = self.kids_for(node, d);
        if short {
            let parent = self.sk.parent[node as usize];
            let internode = if parent == NO_PARENT { 0.0 } else { p.distance(self.pos(parent)) };
            if internode >= min_len {
                self.fallback(node, FallbackReason::Short);
            } else {
                self.merged.push(node);
            }
            // A lone child the start ring also faces away from (a hairpin) is not carried
            // on: carrying `r` past a turn back would skip node after node (`mgv-r`: a
            // 38-node chain became one tube from the root to a branch 4.8 m away). The
            // tube ends here and the child starts its own cage.
            let hairpin = match kids[..] {
                [k] => (self.pos(k) - r.center).dot(r.normal) < self.min_len(self.rho(k).max(r.rho)),
                _ => false,
            };
            if hairpin {
                self.fallback(kids[0], FallbackReason::Detached);
                self.stack.push(Task::Detach { node: kids[0] });
            }
            match kids.len() {
                _ if hairpin || kids.is_empty() => {
                    let c = r.center + r.normal * min_len;
                    let tv = Self::next_tex_v(&r, c, rho);
                    let e = self.ring_perp(c, r.normal, r.up, rho, tv);
                    self.tube(&r, &e);
                    self.cap(&e, true);
                    self.cases.end_caps += 1;
                }
                1 => self.stack.push(Task::Segment { ring: r, node: kids[0] }),
                _ => {
                    let d0 = unit_or(self.pos(kids[0]) - p, r.normal);
                    if d0.dot(r.normal) <= 0.0 {
                        self.cases.backward += 1;
                        let len = 2.0 * self.rho(kids[0]);
                        self.backward_box(r, node, &kids, len);
                    } else {
                        self.cases.boxes += 1;
                        self.junction(r, r.normal, node, &kids, 0);
                    }
                }
            }
            return;
        }
        if let [k] = kids[..] {
            // Merge: a section at `node` would cross the start ring inside the tube when
            // the internode is shorter than the two sections' tilts reach along it.
            let d0 = unit_or(self.pos(k) - p, d);
            let tilt = |c: f32| (1.0 - c * c).max(0.0).sqrt() / c.max(0.5);
            let half = ((1.0 + d.dot(d0).max(0.0)) * 0.5).sqrt();
            let reach = rho.max(r.rho) * (tilt(r.normal.dot(d)) + tilt(half)) + min_len;
            // Merged only when the child lies ahead of the start ring (see the hairpin
            // above); otherwise the node gets its own section.
            let ahead = (self.pos(k) - r.center).dot(r.normal) >= self.min_len(self.rho(k).max(r.rho));
            if along < reach && ahead {
                self.merged.push(node);
                self.stack.push(Task::Segment { ring: r, node: k });
                return;
            }
        }
        let Some(&k0) = kids.first() else {
            // (a) End cap.
            let tv = Self::next_tex_v(&r, p, rho);
            let e = self.ring_perp(p, d, r.up, rho, tv);
            self.tube(&r, &e);
            self.cap(&e, true);
            self.cases.end_caps += 1;
            return;
        };
        let d0 = unit_or(self.pos(k0) - p, d);
        let rho0 = self.rho(k0);
        if d0.dot(d) <= 0.0 {
            // (c) Connect backward (J §3.4): middle ring d₁ back from the node, end ring
            // r₁ beyond it; all children on the sides of the box between them.
            self.cases.backward += 1;
            let len = v.length();
            let mid = (len - 2.0 * rho0).max(0.5 * len);
            let m = if mid >= min_len {
                let c = r.center + d * mid;
                let tv = Self::next_tex_v(&r, c, rho);
                let m = self.ring_perp(c, d, r.up, rho, tv);
                self.tube(&r, &m);
                m
            } else {
                r
            };
            let box_len = (len + rho0 - m.center.distance(r.center)).max(min_len);
            self.backward_box(m, node, &kids, box_len);
            return;
        }
        let h = unit_or(d + d0, d);
        if kids.len() == 1 {
            // (b) Normal connection (J §3.3).
            self.cases.normal += 1;
            let tv = Self::next_tex_v(&r, p, rho);
            let e = self.ring_miter(p, d, h, r.up, rho, tv);
            self.tube(&r, &e);
            self.stack.push(Task::Segment { ring: e, node: k0 });
            return;
        }
        // (d) Connect branches (J §3.5): the end ring, pulled back by (l + x)/2.
        self.cases.boxes += 1;
        let lx = self.eq4(&kids, d, d0);
        // Pull back by (l + x)/2, but never to within `min_len` of the start ring.
        let back = if self.opts.pull_back { (0.5 * lx).min(along - min_len) } else { 0.0 };
        let e = if back >= 0.0 {
            let c = p - d * back;
            let tv = Self::next_tex_v(&r, c, rho);
            let up = self.box_up(r.up, d, h, p, &kids);
            let e = self.ring_miter(c, d, h, up, rho, tv);
            self.tube(&r, &e);
            e
        } else {
            r
        };
        self.junction(e, d, node, &kids, 0);
    }

    /// The elbow of a side child (see [`QuadOptions::elbow_angle`]): when `kid` leaves
    /// the side face `r` more than the elbow angle from its normal, a ring of the child's
    /// size perpendicular to the half direction of the face normal and the child, a short
    /// neck (`ρ_child·sin β + ρ_face/2`, β the ring's tilt, at most 0.3 of the way to the
    /// child) out of the face. Returns the ring the child's tube starts from.
    fn elbow(&mut self, r: Ring, kid: u32) -> Ring {
        let p = self.pos(kid);
        let to = p - r.center;
        let dk = unit_or(to, r.normal);
        if dk.dot(r.normal) >= self.cos_elbow {
            return r;
        }
        let rho = self.rho(kid);
        let h = unit_or(r.normal + dk, r.normal);
        // The ring is tilted by β = ∠(h, face normal): its low corners dip ρ·sin β back
        // towards the face, so the neck clears that plus half the face's size.
        let sin_b = h.cross(r.normal).length();
        let len = (rho * sin_b + 0.5 * r.rho).min(0.3 * to.length());
        if len < 2.0 * self.min_len(rho.max(r.rho)) {
            return r;
        }
        let c = r.center + h * len;
        let tv = Self::next_tex_v(&r, c, rho);
        let e = self.ring_perp(c, h, r.up, rho, tv);
        let at = std::mem::replace(&mut self.cur, kid);
        self.band(&r, &e);
        self.cur = at;
        self.cases.elbows += 1;
        e
    }

    /// Up vector of a junction box's base ring, turned about the internode so that the
    /// side faces look at the side children (`kids[1..]`) as squarely as possible: of 24
    /// turns over the square's 90° period, the one with the largest sum over side
    /// children of the cosine to their best face normal (a child sharing a face with an
    /// earlier one, which would need a chained box, counts −1). Of the four equivalent
    /// labellings of that square, the one closest to the incoming `up` is returned, so
    /// the band before the box twists by at most 45°. Without the turn a child may leave
    /// its face up to 45° further off its normal.
    fn box_up(&self, up: Vec3, d: Vec3, h: Vec3, p: Vec3, kids: &[u32]) -> Vec3 {
        let dirs: Vec<Vec3> = kids[1..].iter().map(|&k| unit_or(self.pos(k) - p, Vec3::ZERO)).collect();
        let cur = perp(up, d);
        let x = perp(cur, h);
        let y = h.cross(x);
        let score = |psi: f32| {
            let (sin, cos) = psi.sin_cos();
            // Face normals at ψ, ψ + 90°, ψ + 180°, ψ + 270°.
            let n0 = x * cos + y * sin;
            let n1 = h.cross(n0);
            let normals = [n0, n1, -n0, -n1];
            let mut used = [false; 4];
            let mut total = 0.0;
            for &dk in &dirs {
                let (best, dot) = (0..4).map(|k| (k, normals[k].dot(dk))).fold((0, f32::MIN), |a, v| {
                    if v.1 > a.1 {
                        v
                    } else {
                        a
                    }
                });
                total += if used[best] { -1.0 } else { dot };
                used[best] = true;
            }
            total
        };
        // ψ is the azimuth of face 0's normal about h, measured from `x`.
        let steps = 24;
        let psi = (0..steps)
            .map(|i| std::f32::consts::FRAC_PI_2 * i as f32 / steps as f32)
            .fold((0.0f32, f32::MIN), |a, psi| {
                let sc = score(psi);
                if sc > a.1 + 1e-6 {
                    (psi, sc)
                } else {
                    a
                }
            })
            .0;
        // Face 0's normal lies halfway between corners 0 and 1: corner 0 at ψ − 45°.
        let t = psi - std::f32::consts::FRAC_PI_4;
        let a = perp(x * t.cos() + y * t.sin(), d);
        let b = d.cross(a);
        [a, b, -a, -b].into_iter().fold(a, |best, c| if c.dot(cur) > best.dot(cur) { c } else { best })
    }

    /// `l + x` for `kids` (sorted) leaving a base of normal `n` towards `d0`.
    fn eq4(&self, kids: &[u32], n: Vec3, d0: Vec3) -> f32 {
        let dia: Vec<f32> = kids.iter().map(|&k| 2.0 * self.rho(k)).collect();
        let half = 0.5 * n.dot(d0).clamp(-1.0, 1.0).acos();
        box_length(self.opts.box_length, &dia, half)
    }

    /// A junction box on base ring `e` at branching node `node` (J §3.5): the box runs
    /// along the half direction of `base` (the parent's direction) and the first child;
    /// the first child continues from the box top, the others go to its sides.
    fn junction(&mut self, e: Ring, base: Vec3, node: u32, kids: &[u32], depth: u32) {
        let k0 = kids[0];
        let p = self.pos(node);
        let d0 = unit_or(self.pos(k0) - p, base);
        let mut h = if d0.dot(base) > 0.0 { unit_or(base + d0, base) } else { base };
        if h.dot(e.normal) < 0.1 {
            // The box top must face the same way as its base, or the sides fold.
            h = e.normal;
        }
        let rho0 = self.rho(k0);
        let mut lx = self.eq4(kids, base, d0).max(self.min_len(e.rho));
        // The first child must outrun its box (J §3.5); when it does not, shorten the box
        // to end before the child's node, down to a quarter of its Eq. 4 length.
        // Twice `min_len`: the child's tube then clears the short-node test with margin.
        let reach = (self.pos(k0) - e.center).dot(h) - 2.0 * self.min_len(rho0);
        if reach < lx {
            let floor = (0.25 * lx).max(self.min_len(e.rho));
            if reach >= floor {
                self.fallback(k0, FallbackReason::ShortBox);
            }
            lx = reach.max(floor);
        }
        let c = e.center + h * lx;
        let tv = Self::next_tex_v(&e, c, rho0);
        let t = self.ring_perp(c, h, e.up, rho0, tv);
        self.sides(&e, &t, node, &kids[1..], depth, (base, Some(d0)));
        self.stack.push(Task::Segment { ring: t, node: k0 });
    }

    /// The backward box (J §3.4) on base `m`, `len` long along its normal, top capped,
    /// every child on its sides.
    fn backward_box(&mut self, m: Ring, node: u32, kids: &[u32], len: f32) {
        let rho = self.rho(node);
        let c = m.center + m.normal * len;
        let tv = Self::next_tex_v(&m, c, rho);
        let top = self.ring_perp(c, m.normal, m.up, rho, tv);
        self.cap(&top, true);
        self.sides(&m, &top, node, kids, 0, (m.normal, None));
    }

    /// Side faces `[B_k, B_k+1, T_k+1, T_k]` of the box `b → t`: `kids` (sorted) are
    /// assigned to the face whose outward normal is most aligned with them; used faces
    /// start their children (a chained box for several), unused ones are closed.
    /// `dirs`: the parent internode's direction and the first child's (none for a
    /// backward box).
    fn sides(&mut self, b: &Ring, t: &Ring, node: u32, kids: &[u32], depth: u32, dirs: (Vec3, Option<Vec3>)) {
        let (parent_dir, first) = dirs;
        let mut faces = [[0u32; 4]; 4];
        let mut normals = [Vec3::ZERO; 4];
        for k in 0..4 {
            let k1 = (k + 1) % 4;
            faces[k] = [b.v[k], b.v[k1], t.v[k1], t.v[k]];
            normals[k] = quad_normal(faces[k].map(|i| self.positions[i as usize]));
        }
        let p = self.pos(node);
        let axis = unit_or(t.center - b.center, b.normal);
        let (cos_aligned, cos_reversed) = (ALIGNED_DEG.to_radians().cos(), REVERSED_DEG.to_radians().cos());
        let mut sets: [Vec<u32>; 4] = Default::default();
        for &kid in kids {
            let dk = unit_or(self.pos(kid) - p, Vec3::ZERO);
            let (best, dot) =
                (0..4)
                    .map(|k| (k, normals[k].dot(dk)))
                    .fold((0, f32::MIN), |a, x| if x.1 > a.1 { x } else { a });
            // Beyond `max_side_angle` a child runs along the box: it may still leave
            // through an elbow when it points back, or forward but clear of the first
            // child's direction (≥ ALIGNED_DEG away); inside the first child's tube or
            // the parent's, or along a backward box's capped top, it is detached.
            let back = dk.dot(axis) < 0.0 && -dk.dot(parent_dir) < cos_reversed;
            let clear = first.is_some_and(|f| f.dot(dk) < cos_aligned);
            let limit = if back || clear { self.cos_back } else { self.cos_side };
            if dot >= limit && dk != Vec3::ZERO {
                sets[best].push(kid);
            } else {
                self.fallback(kid, FallbackReason::Detached);
                self.stack.push(Task::Detach { node: kid });
            }
        }
        for k in 0..4 {
            let k1 = k + 1;
            let uv = [b.uv[k], b.uv[k1], t.uv[k1], t.uv[k]];
            if sets[k].is_empty() {
                self.quad(faces[k], uv);
                continue;
            }
            let corners = faces[k].map(|i| self.positions[i as usize]);
            let center = (corners[0] + corners[1] + corners[2] + corners[3]) * 0.25;
            let up = perp(corners[0] - center, normals[k]);
            let rho = corners.iter().map(|c| c.distance(center)).sum::<f32>() * 0.25;
            let ring = Ring {
                v: faces[k],
                uv: self.ring_uvs(b.tex_v),
                center,
                normal: normals[k],
                up,
                rho: rho.max(self.floor),
                tex_v: b.tex_v,
            };
            let set = std::mem::take(&mut sets[k]);
            if set.len() == 1 {
                let ring = self.elbow(ring, set[0]);
                self.stack.push(Task::Segment { ring, node: set[0] });
            } else if depth < self.opts.max_chain {
                self.cases.chained += 1;
                self.junction(ring, ring.normal, node, &set, depth + 1);
            } else {
                // Out of chained boxes: the first child takes the face, the rest detach.
                self.stack.push(Task::Segment { ring, node: set[0] });
                for &kid in &set[1..] {
                    self.fallback(kid, FallbackReason::ChainLimit);
                    self.stack.push(Task::Detach { node: kid });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(k: usize) -> Skeleton {
        let mut s = Skeleton::new();
        let mut at = NO_PARENT;
        for i in 0..=k {
            let p = Vec3::new(0.3 * (i as f32 * 0.7).sin(), i as f32, 0.0);
            at = s.push(p, 0.1, at, Vec3::X, 0);
        }
        s
    }

    #[test]
    fn eq4_matches_hand_computed_values() {
        // h = 0: √Σd².
        assert!((box_length(BoxLength::SumSquares, &[0.3, 0.4], 0.0) - 0.5).abs() < 1e-6);
        // h = 30°, d = (0.3, 0.4): 0.5 / cos 30° + tan 30° · 0.15 = 0.57735 + 0.08660.
        let h = 30f32.to_radians();
        let want = 0.5 / (3f32.sqrt() / 2.0) + 0.15 / 3f32.sqrt();
        assert!((box_length(BoxLength::SumSquares, &[0.3, 0.4], h) - want).abs() < 1e-6);
        assert!((want - 0.663_953).abs() < 1e-5);
        // h = 45°: √2·√Σd² + d₁/2.
        let at45 = box_length(BoxLength::SumSquares, &[0.3, 0.4], std::f32::consts::FRAC_PI_4);
        assert!((at45 - (2f32.sqrt() * 0.5 + 0.15)).abs() < 1e-6);
        // First-child rule: d₁ / cos h + tan h · d₁ / 2.
        let fc = box_length(BoxLength::FirstChild, &[0.3, 0.4], h);
        assert!((fc - (0.3 / h.cos() + h.tan() * 0.15)).abs() < 1e-6);
        // Clamped above 45°, monotone on [0°, 45°].
        assert_eq!(box_length(BoxLength::SumSquares, &[0.3, 0.4], 1.2), at45);
        let mut last = 0.0;
        for i in 0..=45 {
            let l = box_length(BoxLength::SumSquares, &[0.3, 0.2, 0.1], (i as f32).to_radians());
            assert!(l >= last);
            last = l;
        }
    }

    #[test]
    fn chain_counts_follow_the_seed() {
        // The seed's cage: no support rings.
        let seed = QuadOptions { support: 0.0, ..Default::default() };
        for k in 1..6 {
            let m = quad_mesh(&chain(k), &seed).unwrap();
            assert_eq!(m.mesh.positions.len(), 4 * (k + 1));
            assert_eq!(m.mesh.face_count(), 4 * k + 2);
            assert!(m.fallbacks.is_empty());
            assert_eq!(m.cases.normal, k - 1);
            assert_eq!(m.cases.end_caps, 1);
        }
    }

    #[test]
    fn miter_ring_lies_on_the_half_plane_and_the_parent_tube() {
        let mut s = Skeleton::new();
        let a = s.push(Vec3::ZERO, 0.2, NO_PARENT, Vec3::X, 0);
        let b = s.push(Vec3::Y * 2.0, 0.2, a, Vec3::X, 0);
        s.push(Vec3::new(1.0, 3.0, 0.5), 0.2, b, Vec3::X, 0);
        let m = quad_mesh(&s, &QuadOptions::default()).unwrap();
        let d = Vec3::Y;
        let h = (d + Vec3::new(1.0, 1.0, 0.5).normalize()).normalize();
        for i in 4..8 {
            let q = m.mesh.positions[i] - Vec3::Y * 2.0;
            assert!(q.dot(h).abs() < 1e-5, "corner {i} off the half-direction plane");
            let radial = q - d * q.dot(d);
            assert!((radial.length() - 0.2).abs() < 1e-5, "corner {i} off the parent tube");
        }
        // No twist: corner 0 along the projected up (X).
        let q = m.mesh.positions[4] - Vec3::Y * 2.0;
        assert!((q - d * q.dot(d)).normalize().dot(Vec3::X) > 0.9999);
    }

    #[test]
    fn zero_radius_and_zero_length_never_give_nan() {
        let mut s = Skeleton::new();
        let a = s.push(Vec3::ZERO, 0.0, NO_PARENT, Vec3::X, 0);
        let b = s.push(Vec3::ZERO, 0.0, a, Vec3::X, 0);
        let c = s.push(Vec3::Y, 0.0, b, Vec3::X, 0);
        s.push(Vec3::Y, 0.0, c, Vec3::X, 0);
        s.push(Vec3::Y, 0.0, c, Vec3::X, 0);
        let m = quad_mesh(&s, &QuadOptions::default()).unwrap();
        m.mesh.validate().unwrap();
        assert!(m.mesh.face_count() > 0);
    }

    #[test]
    fn bad_options_are_errors() {
        let s = chain(2);
        for o in [
            QuadOptions { cs_scale: 0.0, ..Default::default() },
            QuadOptions { max_side_angle: 95.0, ..Default::default() },
            QuadOptions { max_back_angle: 155.0, ..Default::default() },
            QuadOptions { min_length: f32::NAN, ..Default::default() },
            QuadOptions { elbow_angle: 91.0, ..Default::default() },
            QuadOptions { repair_rounds: 17, ..Default::default() },
            QuadOptions { check_levels: 0, ..Default::default() },
            QuadOptions { check_levels: 4, ..Default::default() },
        ] {
            assert!(matches!(quad_mesh(&s, &o), Err(Error::InvalidGeometry { .. })));
        }
    }
}
