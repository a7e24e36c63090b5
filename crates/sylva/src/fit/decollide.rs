//! Skeleton de-collision: pulls apart branches that pass through each other, so the
//! joint meshers (`hull`, `sweep`, `quad`) can mesh and refine a tree without
//! self-intersections.
//!
//! Issue 5's acceptance ("after refinement to level 2 it has no self-intersections")
//! needs a skeleton whose internode capsules do not overlap: a mesher cannot keep two
//! surfaces apart when the skeleton itself crosses them (see
//! [`skeleton_collisions`](crate::mesh::check::skeleton_collisions) and
//! `docs/meshers.md`). This pass runs before the mesher (recipe key `mesh.decollide`).
//!
//! What counts as a collision is the checker's rule, shared through
//! `check::meeting`: internodes that share no node are measured axis to axis;
//! siblings (and branches of one node joined through a stub shorter than their radii)
//! from each one's far end to the other's axis, since they always overlap at their
//! joint; one internode hanging below another through a run of short internodes by
//! whether the bends between them fold a tube of their radii; chained internodes never.
//! The pass fixes the two kinds of collision the presets have, then tries two last
//! resorts:
//!
//! - **near a joint** (the two internodes are at most [`DecollideOptions::near_joint_hops`]
//!   internodes apart in the tree, or joined through internodes shorter than
//!   [`DecollideOptions::near_joint_path`] times their radius sum): thick branches with
//!   short internodes overlap a sibling's next internode. The radii of the four end
//!   nodes are **capped** so the capsules clear; a cap is carried down to every
//!   descendant (radii stay non-increasing from root to tip) and relaxed up the axis by
//!   at most [`DecollideOptions::taper`] metres of radius per metre of length, so the
//!   thinning is a smooth taper, not a notch. A distant pair that only grazes (it clears
//!   with radii scaled by no less than [`DecollideOptions::far_thinning`]) is thinned the
//!   same way.
//! - **distant crossings**: the lighter branch is **rotated** rigidly about its base
//!   node (the joint where it leaves its parent axis), by the smallest of a few angles
//!   (both senses, about three axes: in the plane of the two branches, out of it, and
//!   around the parent axis) that leaves its subtree with no collision. When no angle
//!   clears it, the trial that removes the most collisions is kept (so the count only
//!   ever falls). Candidate subtrees are tried lightest first: the nearest joints above
//!   each of the two internodes. Planar figures (`lsys-abop-a`, `lsys-abop-c`,
//!   `lsys-fern`) are "2-D drawings with thickness": rotating a subtree out of their
//!   plane is accepted.
//! - **the last resorts**, after the rounds: a pair rotation could not clear is thinned
//!   like a near-joint pair (radii down to [`DecollideOptions::min_thinning`]); then a
//!   pair left where one internode ends at a tip is cleared by **pulling the tip back**
//!   along its internode (to at most half its length). This frees closed figures such
//!   as the Koch snowflake, whose last internode ends on its first and has no joint to
//!   rotate about. Then a pair left where one internode (or one joining them) is a
//!   **stub** (shorter than twice the pair's radius sum) is cleared by moving the stub's
//!   subtree (or, for a tip, its end) rigidly by at most three radius sums (with the
//!   clearance), along the
//!   stub (lengthening it) or away from the other internode (bending it) (session 10:
//!   Weber–Penn stems whose first internode is a few millimetres long, at the radius
//!   floor, which neither rotation nor thinning can free; session 11: tips too). A
//!   longer internode there is **bent** the same way, its subtree moved rigidly away
//!   from the other by the mildest step that turns it by at most 20°, lightest subtree
//!   first (session 12: `wp-weeping-willow`'s limb whose joint sits against its clone
//!   trunk, which no rotation of the 3.8 k-node limb could free without swinging it
//!   through the crown). Last,
//!   a pair every move leaves is **traded**: a rotation or stub move that clears it but
//!   makes a few new collisions is tried on a copy of the skeleton, the rounds run
//!   again on the copy, and the copy is kept when the whole tree ends with fewer
//!   collisions ([`DecollideReport::traded`]; session 11: `wp-ca-black-oak`'s trunk
//!   against a limb of its clone trunk, `wp-sassafras`'s last stub).
//!
//! Thinning and rotating repeat for at most [`DecollideOptions::max_rounds`] rounds;
//! what is left is reported by node pairs ([`DecollideReport::unresolved`]), never
//! looped on. Node `up` vectors and the organs hanging on moved nodes move with them;
//! roots never move, the topology never changes, and a skeleton the checker finds
//! collision-free is left bit-identical, except that radii under the floor
//! ([`DecollideOptions::min_radius`], 0.005 of the largest: the joint meshers' own floor)
//! are first raised to it, since the meshers draw them that thick.
//! Explicit start radii ([`Skeleton::start_radius()`], an LST cylinder's r0) are raised
//! to the floor likewise and thinned with the node they start at: the start radius of
//! the internode into node `i` is scaled by the factor its parent's radius was lowered
//! by (issue 26; a start radius no larger than its parent's radius stays so, within
//! the capsule, which uses node radii only).
//!
//! Cost per round: a BVH over the internode capsules (median split; its bounds grow to
//! cover each rotated subtree), the collision search parallel over internodes with
//! rayon, and the rotation trials of one subtree evaluated in parallel; the choices
//! themselves are made in a fixed order, so the result is deterministic.

use crate::error::{Error, Result};
use crate::mesh::check::{
    build_bvh, meeting, meeting_gap, node_depths, segment_closest, skeleton_collisions, Aabb, Meeting, Node,
};
use crate::skeleton::{OrganKind, Skeleton, NO_PARENT};
use glam::{DQuat, DVec3, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Settings of [`decollide`]: the recipe table `[fit.decollide]` (every key optional;
/// [`DecollideOptions::check`] names the key of a value out of range).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DecollideOptions {
    /// Target clearance: two capsules are pulled apart until their axes are at least
    /// `(r_a + r_b) × (1 + clearance)` apart. A little more than the checker's 1 %
    /// tolerance, so meshes (whose surfaces bulge slightly at joints) stay apart too.
    pub clearance: f64,
    /// Internodes at most this many internodes apart in the tree collide "near a joint"
    /// and are fixed by thinning.
    pub near_joint_hops: usize,
    /// Branches of one node joined through internodes shorter in all than this many
    /// times their radius sum also collide "near a joint" (clusters of stubs, where the
    /// hop count says little).
    pub near_joint_path: f64,
    /// A near-joint pair is thinned when that needs a radius factor of at least this
    /// (so radii shrink at most to this fraction); below it, it is moved like a crossing.
    pub min_thinning: f64,
    /// A distant pair is thinned instead of moved when a radius factor of at least this
    /// clears it (a graze, not a crossing).
    pub far_thinning: f64,
    /// Radius slope (metres of radius per metre of axis) allowed above a capped node:
    /// how fast the thinning relaxes towards the root.
    pub taper: f64,
    /// Rotation angles tried, in degrees, smallest first.
    pub angles: Vec<f64>,
    /// Candidate subtrees tried per side of a colliding pair (the nearest joints above
    /// each internode).
    pub candidates: usize,
    /// Rounds of thinning + moving before giving up on what is left.
    pub max_rounds: usize,
    /// Subtrees of more nodes than this are never rotated (moving a whole limb to free
    /// a twig changes the tree's look more than the twig's collision is worth).
    pub max_moved: usize,
    /// Work bound per round: at most this many capsule queries (one per moved internode
    /// per trial) per skeleton node are spent on rotation trials (counted, not timed, so the result stays
    /// deterministic); pairs left when it runs out are reported.
    pub work_per_node: usize,
    /// Radius floor as a fraction of the skeleton's largest radius (default 0.005; 0
    /// turns it off): smaller radii are raised to it first, and no thinning goes below
    /// it. The joint meshers raise thinner sections to this size anyway (`quad` and
    /// `sweep` `min_radius`), so a Weber–Penn tip the skeleton draws at zero radius is
    /// meshed, and must be kept apart, as a tube of that radius (session 9: twigs 5 mm
    /// apart on `wp-balsam-fir` crossed as 1.5 mm tubes while their capsules, of radius
    /// 0, were "clear").
    pub min_radius: f64,
    /// Work budget of the whole pass (issue 27): one unit per skeleton node of every
    /// collision search and per capsule query of the rotation trials, and (issue 39) one
    /// per candidate internode pair a search or query examines and per colliding pair
    /// measured again, over all rounds and last resorts (counted, not timed, so the
    /// result stays deterministic). A pass
    /// that needs more stops with an error naming `fit.decollide.max_work`. Left out of
    /// written metadata at its default ([`DEFAULT_DECOLLIDE_WORK`]).
    #[serde(skip_serializing_if = "is_default_decollide_work")]
    pub max_work: u64,
}

/// Default [`DecollideOptions::max_work`]: 5·10⁷ units, about 4 times the presets' worst
/// case counting candidate pairs (1.3·10⁷, `wp-european-larch` with `hull`; `mig-a`
/// 6.6·10⁶) and 4–15 s of work on this project's 2-core machine (80–290 ns a unit:
/// 400 near-coincident nodes reach it in 4 s).
pub const DEFAULT_DECOLLIDE_WORK: u64 = 50_000_000;

/// Largest [`DecollideOptions::max_work`] accepted.
pub const MAX_DECOLLIDE_WORK: u64 = 100_000_000_000;

/// Whether `w` is the default work budget (left out of written metadata).
fn is_default_decollide_work(w: &u64) -> bool {
    *w == DEFAULT_DECOLLIDE_WORK
}

/// The work a pass has spent, against [`DecollideOptions::max_work`].
///
/// Issue 39: a unit is one skeleton node of a collision search, one capsule query of a
/// trial, or one **candidate pair** a search or query examines (two internode boxes
/// that overlap). The pairs are what varies: a few per internode on a tree, every other
/// internode on a skeleton whose nodes coincide or whose radii dwarf its lengths, so
/// counting nodes alone let such a skeleton run for minutes within its budget. Only
/// what a search must examine is charged, whatever the threads do, so the outcome stays
/// the same for every thread count; a search stops early only once the pass is over
/// its budget, and the pass then fails.
struct Work {
    spent: AtomicU64,
    max: u64,
}

impl Work {
    /// Adds `n` units.
    fn charge(&self, n: usize) {
        self.charge_u64(n as u64);
    }

    /// Adds `n` units.
    fn charge_u64(&self, n: u64) {
        let _ = self.spent.fetch_update(Ordering::Relaxed, Ordering::Relaxed, |v| Some(v.saturating_add(n)));
    }

    /// Whether the spent work is over the budget.
    fn over(&self) -> bool {
        self.spent.load(Ordering::Relaxed) > self.max
    }

    /// Units left before the budget is over (0 once it is).
    fn left(&self) -> u64 {
        self.max.saturating_sub(self.spent.load(Ordering::Relaxed))
    }

    /// Marks the budget as used up.
    fn exhaust(&self) {
        self.charge_u64(self.max.saturating_add(1));
    }
}

impl Default for DecollideOptions {
    fn default() -> Self {
        Self {
            clearance: 0.08,
            near_joint_hops: 3,
            near_joint_path: 4.0,
            min_thinning: 0.3,
            far_thinning: 0.8,
            taper: 0.1,
            angles: vec![3.0, 6.0, 10.0, 15.0, 22.0, 30.0, 45.0, 60.0, 90.0],
            candidates: 5,
            max_rounds: 8,
            max_moved: 4000,
            work_per_node: 200,
            min_radius: crate::tolerance::RADIUS_FLOOR,
            max_work: DEFAULT_DECOLLIDE_WORK,
        }
    }
}

/// What [`decollide`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DecollideReport {
    /// Skeleton collisions before (`skeleton_collisions` at the checker's 1 % tolerance).
    pub before: usize,
    /// Skeleton collisions after, at the same tolerance.
    pub after: usize,
    /// Of the collisions before, how many were near a joint.
    pub near_joint: usize,
    /// Nodes whose radius was reduced.
    pub thinned: usize,
    /// Subtree rotations applied.
    pub rotations: usize,
    /// Tips pulled back along their internode (the last resort, for pairs rotation
    /// could not clear).
    pub retracted: usize,
    /// Stubs whose subtrees were moved, along the stub (lengthening it) or away from the
    /// other internode (bending it): the last resort for a stub shorter than twice the
    /// pair's radius sum, which rotation cannot free; longer internodes bent sideways by
    /// at most 20° are counted here too.
    pub extended: usize,
    /// Pairs the very last resort traded for a few new collisions that further rounds
    /// then cleared (a rotation of a subtree through a dense crown; its rotations are
    /// counted in `rotations`).
    pub traded: usize,
    /// Rounds run.
    pub rounds: usize,
    /// Nodes whose radius was raised to the floor ([`DecollideOptions::min_radius`]).
    pub raised: usize,
    /// The collisions left (internodes named by their child node, smaller first).
    pub unresolved: Vec<[usize; 2]>,
    /// Work spent, in [`DecollideOptions::max_work`]'s units.
    pub work: u64,
    /// Wall time.
    pub elapsed: Duration,
}

impl DecollideReport {
    /// Collisions removed.
    pub fn resolved(&self) -> usize {
        self.before.saturating_sub(self.after)
    }
}

/// The checker's tolerance for `before`/`after` (the one `docs/meshers.md` uses).
const CHECK_TOLERANCE: f64 = 0.01;

/// Pulls apart the branches of `skeleton` that pass through each other (see the module
/// documentation). Errors on an invalid skeleton or options, and when the pass needs
/// more than [`DecollideOptions::max_work`]; otherwise what cannot be
/// resolved within [`DecollideOptions::max_rounds`] is reported, not an error.
pub fn decollide(skeleton: &mut Skeleton, opts: &DecollideOptions) -> Result<DecollideReport> {
    let t0 = Instant::now();
    skeleton.validate()?;
    opts.check()?;
    let raised = raise_to_floor(skeleton, opts.min_radius);
    let work = Work { spent: AtomicU64::new(skeleton.len() as u64), max: opts.max_work };
    let over = |s: &Skeleton| {
        Error::Recipe(format!(
            "`fit.decollide.max_work`: the skeleton de-collision of {} nodes needs more than its work budget \
             of {} units (skeleton nodes per collision search, capsule queries of the rotation trials and the \
             candidate internode pairs both examine: a skeleton whose nodes coincide or whose radii dwarf its \
             lengths has millions); raise it with --set fit.decollide.max_work=N, lower \
             fit.decollide.max_rounds or fit.decollide.work_per_node, or turn the pass off with \
             mesh.decollide = false",
            s.len(),
            opts.max_work
        ))
    };
    // The checker's search examines the same candidate pairs (its boxes are no larger):
    // charged, and stopped, before it runs.
    if !charge_search(skeleton, opts.clearance, &work) {
        return Err(over(skeleton));
    }
    let first = skeleton_collisions(skeleton, CHECK_TOLERANCE);
    let mut report = DecollideReport { before: first.len(), raised, ..Default::default() };
    if first.is_empty() {
        report.elapsed = t0.elapsed();
        report.work = work.spent.load(Ordering::Relaxed);
        return Ok(report);
    }
    let topo = Topology::new(skeleton);
    report.near_joint = first.iter().filter(|p| near_joint(skeleton, &topo, p[0], p[1], opts)).count();
    let original_radius = skeleton.radius.clone();
    (report.rounds, report.rotations) = rounds(skeleton, &topo, opts, opts.max_rounds, &work);
    work.charge(skeleton.len());
    let mut left = collisions(skeleton, &topo, opts.clearance, &work);
    if !left.is_empty() && !work.over() {
        // What rotation could not clear is thinned like a near-joint pair (down to
        // `min_thinning`), then tips are pulled back.
        let deep = DecollideOptions { far_thinning: opts.min_thinning, ..opts.clone() };
        if thin(skeleton, &topo, &left, &deep) {
            work.charge(skeleton.len());
            left = collisions(skeleton, &topo, opts.clearance, &work);
        }
        report.retracted = retract_tips(skeleton, &topo, &left, opts.clearance, &work);
        if report.retracted > 0 {
            work.charge(skeleton.len());
            left = collisions(skeleton, &topo, opts.clearance, &work);
        }
        report.extended = extend_stubs(skeleton, &topo, &left, opts.clearance, &work);
        if report.extended > 0 {
            work.charge(skeleton.len());
            left = collisions(skeleton, &topo, opts.clearance, &work);
        }
        if !left.is_empty() && !work.over() {
            report.traded = trade(skeleton, &topo, &left, opts, &mut report.rotations, &work);
        }
    }
    if work.over() || !charge_search(skeleton, opts.clearance, &work) {
        return Err(over(skeleton));
    }
    report.thinned = skeleton.radius.iter().zip(&original_radius).filter(|(a, b)| a != b).count();
    report.unresolved = skeleton_collisions(skeleton, CHECK_TOLERANCE);
    report.after = report.unresolved.len();
    report.elapsed = t0.elapsed();
    report.work = work.spent.load(Ordering::Relaxed);
    Ok(report)
}

impl DecollideOptions {
    /// Checks every value's range; the error names the recipe key
    /// (`fit.decollide.<field>`).
    pub fn check(&self) -> Result<()> {
        let o = self;
        let bad = |key: &str, why: String| Err(Error::Recipe(format!("`fit.decollide.{key}` {why}")));
        if !(o.clearance.is_finite() && (0.0..=1.0).contains(&o.clearance)) {
            return bad("clearance", format!("must be in 0..=1, got {}", o.clearance));
        }
        for (name, v) in [("min_thinning", o.min_thinning), ("far_thinning", o.far_thinning)] {
            if !(v.is_finite() && v > 0.0 && v <= 1.0) {
                return bad(name, format!("must be in (0, 1], got {v}"));
            }
        }
        if !(o.min_radius.is_finite() && (0.0..=1.0).contains(&o.min_radius)) {
            return bad("min_radius", format!("must be in 0..=1, got {}", o.min_radius));
        }
        if !(o.near_joint_path.is_finite() && (0.0..=1000.0).contains(&o.near_joint_path)) {
            return bad("near_joint_path", format!("must be in 0..=1000, got {}", o.near_joint_path));
        }
        if !(o.taper.is_finite() && (0.0..=100.0).contains(&o.taper)) {
            return bad("taper", format!("must be in 0..=100, got {}", o.taper));
        }
        if o.angles.len() > 64 || o.angles.iter().any(|a| !a.is_finite() || *a <= 0.0 || *a > 180.0) {
            return bad(
                "angles",
                format!("must be at most 64 angles in (0, 180] degrees, got {:?}", o.angles),
            );
        }
        if !(1..=MAX_DECOLLIDE_WORK).contains(&o.max_work) {
            return bad("max_work", format!("must be in 1..={MAX_DECOLLIDE_WORK}, got {}", o.max_work));
        }
        // Work bounds: each scales the pass's running time.
        for (name, v, max) in [
            ("near_joint_hops", o.near_joint_hops, 64),
            ("candidates", o.candidates, 64),
            ("max_rounds", o.max_rounds, 100),
            ("work_per_node", o.work_per_node, 100_000),
        ] {
            if v > max {
                return bad(name, format!("is {v}; at most {max} (it bounds the pass's work)"));
            }
        }
        Ok(())
    }
}

/// Tree structure that never changes during the pass.
struct Topology {
    depth: Vec<u32>,
    /// Pre-order entry time and subtree end (exclusive) of every node.
    tin: Vec<u32>,
    tout: Vec<u32>,
    /// Nodes in pre-order, so a subtree is `pre[tin[c]..tout[c]]`.
    pre: Vec<u32>,
    /// Number of children per node.
    child_count: Vec<u32>,
    /// The organs hanging on each node, as a CSR (offsets, organ indices).
    organ_offsets: Vec<u32>,
    organ_list: Vec<u32>,
    /// The nearest joint at or above each node ([`joints_above`]), `NO_PARENT` for none:
    /// so finding joints costs one step per joint, not a walk down a long unbranched
    /// chain (issue 39: a chain of 1,000 zero-length internodes walked 1,000 nodes per
    /// colliding pair).
    joint_up: Vec<u32>,
}

impl Topology {
    fn new(s: &Skeleton) -> Self {
        let n = s.len();
        let children = s.children();
        let depth = node_depths(&s.parent);
        let mut child_count = vec![0u32; n];
        for i in 0..n {
            if s.parent[i] != NO_PARENT {
                child_count[s.parent[i] as usize] += 1;
            }
        }
        let (mut tin, mut tout, mut pre) = (vec![0u32; n], vec![0u32; n], Vec::with_capacity(n));
        let mut stack: Vec<(u32, bool)> = Vec::new();
        for r in (0..n).filter(|&i| s.parent[i] == NO_PARENT) {
            stack.push((r as u32, false));
            while let Some((v, done)) = stack.pop() {
                if done {
                    tout[v as usize] = pre.len() as u32;
                    continue;
                }
                tin[v as usize] = pre.len() as u32;
                pre.push(v);
                stack.push((v, true));
                for &c in children.of(v as usize).iter().rev() {
                    stack.push((c, false));
                }
            }
        }
        let mut organ_offsets = vec![0u32; n + 1];
        for o in &s.organs {
            if (o.node as usize) < n {
                organ_offsets[o.node as usize + 1] += 1;
            }
        }
        for i in 0..n {
            organ_offsets[i + 1] += organ_offsets[i];
        }
        let mut fill = organ_offsets.clone();
        let mut organ_list = vec![0u32; organ_offsets[n] as usize];
        for (k, o) in s.organs.iter().enumerate() {
            if (o.node as usize) < n {
                organ_list[fill[o.node as usize] as usize] = k as u32;
                fill[o.node as usize] += 1;
            }
        }
        let mut joint_up = vec![NO_PARENT; n];
        for i in 0..n {
            let p = s.parent[i];
            if p == NO_PARENT {
                continue;
            }
            joint_up[i] = if child_count[p as usize] > 1 || s.order[i] != s.order[p as usize] {
                i as u32
            } else {
                joint_up[p as usize]
            };
        }
        Topology { depth, tin, tout, pre, child_count, organ_offsets, organ_list, joint_up }
    }

    /// True when `x` is in the subtree of `c` (including `c`).
    fn contains(&self, c: usize, x: usize) -> bool {
        self.tin[c] <= self.tin[x] && self.tin[x] < self.tout[c]
    }

    fn subtree(&self, c: usize) -> &[u32] {
        &self.pre[self.tin[c] as usize..self.tout[c] as usize]
    }

    fn size(&self, c: usize) -> usize {
        (self.tout[c] - self.tin[c]) as usize
    }
}

/// Tree distance between two nodes when at most `limit` (walking up from the deeper).
fn hops(s: &Skeleton, t: &Topology, a: usize, b: usize, limit: usize) -> Option<usize> {
    let (mut x, mut y, mut h) = (a, b, 0usize);
    while x != y {
        if h >= limit {
            return None;
        }
        let step = if t.depth[x] >= t.depth[y] { &mut x } else { &mut y };
        let p = s.parent[*step];
        if p == NO_PARENT {
            return None;
        }
        *step = p as usize;
        h += 1;
    }
    Some(h)
}

/// True when internodes `a` and `b` collide "near a joint": at most
/// [`DecollideOptions::near_joint_hops`] apart, or branches of one node joined through
/// internodes shorter than [`DecollideOptions::near_joint_path`] × their radius sum
/// (one internode below the other counts by hops only).
fn near_joint(s: &Skeleton, topo: &Topology, a: usize, b: usize, o: &DecollideOptions) -> bool {
    let short = (capsule(s, a).r + capsule(s, b).r) * o.near_joint_path;
    hops(s, topo, a, b, o.near_joint_hops).is_some()
        || matches!(meeting(s, &topo.depth, a, b, short), Meeting::Joined)
}

/// One internode as a capsule: base, tip, radius (the larger end radius).
#[derive(Clone, Copy)]
struct Capsule {
    a: DVec3,
    b: DVec3,
    r: f64,
}

fn capsule(s: &Skeleton, i: usize) -> Capsule {
    let p = s.parent[i] as usize;
    Capsule {
        a: s.position[p].as_dvec3(),
        b: s.position[i].as_dvec3(),
        r: s.radius[i].max(s.radius[p]) as f64,
    }
}

fn capsule_box(c: &Capsule, clearance: f64) -> Aabb {
    let pad = c.r * (1.0 + clearance);
    Aabb { lo: c.a.min(c.b) - pad, hi: c.a.max(c.b) + pad }
}

/// The gap between internodes `i` and `j` (capsules `x` and `y`, which may be moved
/// copies: rigid moves keep every internode length) with the closest points, as the
/// checker measures it ([`meeting`]: siblings and internodes joined by a stub from
/// their far ends, chained ones never). When their axes are at least `within` apart the
/// axis gap is returned without walking the tree: a joined or linked gap is never
/// smaller than the axis gap, and a folded pair's axes are closer than the radii (the
/// stub between them is shorter than that).
fn gap(
    s: &Skeleton,
    topo: &Topology,
    (i, x): (usize, &Capsule),
    (j, y): (usize, &Capsule),
    within: f64,
) -> Option<(f64, DVec3, DVec3)> {
    let (x, y, short) = ([x.a, x.b], [y.a, y.b], x.r + y.r);
    let axes = segment_closest(x[0], x[1], y[0], y[1]);
    if axes.0 >= within {
        let chained = s.parent[i] as usize == j || s.parent[j] as usize == i;
        return (!chained).then_some(axes);
    }
    meeting_gap(x, y, meeting(s, &topo.depth, i, j, short), short)
}

/// True when internodes `i` and `j` (capsules `x`, `y`) collide at `clearance`.
fn collide(
    s: &Skeleton,
    topo: &Topology,
    x: (usize, &Capsule),
    y: (usize, &Capsule),
    clearance: f64,
) -> bool {
    let limit = (x.1.r + y.1.r) * (1.0 + clearance);
    gap(s, topo, x, y, limit).is_some_and(|(d, ..)| d < limit)
}

/// A BVH over the internodes (items are child node ids) whose bounds grow as
/// internodes move.
struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
    /// Box per skeleton node (unused for roots).
    boxes: Vec<Aabb>,
    /// Parent of every BVH node (`u32::MAX` for the root).
    up: Vec<u32>,
    /// The leaf holding each skeleton node's internode.
    leaf: Vec<u32>,
}

impl Bvh {
    fn build(s: &Skeleton, clearance: f64) -> Bvh {
        let boxes: Vec<Aabb> =
            (0..s.len())
                .map(|i| {
                    if s.parent[i] == NO_PARENT {
                        Aabb::EMPTY
                    } else {
                        capsule_box(&capsule(s, i), clearance)
                    }
                })
                .collect();
        let mut order: Vec<u32> =
            (0..s.len() as u32).filter(|&i| s.parent[i as usize] != NO_PARENT).collect();
        let nodes = build_bvh(&boxes, &mut order);
        let mut up = vec![u32::MAX; nodes.len()];
        let mut leaf = vec![u32::MAX; s.len()];
        for (k, n) in nodes.iter().enumerate() {
            if n.count == 0 {
                up[n.first as usize] = k as u32;
                up[n.first as usize + 1] = k as u32;
            } else {
                for &t in &order[n.first as usize..(n.first + n.count) as usize] {
                    leaf[t as usize] = k as u32;
                }
            }
        }
        Bvh { nodes, order, boxes, up, leaf }
    }

    /// Sets the box of item `i` and grows the bounds above it to contain it (the old box
    /// stays inside them: the tree stays correct, only looser, for the rest of a round).
    fn update(&mut self, i: usize, b: Aabb) {
        self.boxes[i] = b;
        let mut k = self.leaf[i];
        while k != u32::MAX {
            let n = &mut self.nodes[k as usize];
            if n.bounds.lo.cmple(b.lo).all() && b.hi.cmple(n.bounds.hi).all() {
                break;
            }
            n.bounds.grow(&b);
            k = self.up[k as usize];
        }
    }

    /// Calls `f` with every item whose box overlaps `q`; stops when `f` returns false.
    fn visit(&self, q: &Aabb, mut f: impl FnMut(usize) -> bool) {
        if self.order.is_empty() {
            return;
        }
        let mut stack = vec![0u32];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k as usize];
            if !n.bounds.overlaps(q) {
                continue;
            }
            if n.count == 0 {
                stack.push(n.first);
                stack.push(n.first + 1);
            } else {
                for &t in &self.order[n.first as usize..(n.first + n.count) as usize] {
                    if self.boxes[t as usize].overlaps(q) && !f(t as usize) {
                        return;
                    }
                }
            }
        }
    }
}

/// Pairs examined between two checks of the budget inside one internode's search.
const PAIR_CHECK: u64 = 4096;

/// Colliding internode pairs at `clearance` (axes closer than `(r_a + r_b)(1 + clearance)`),
/// sorted, each `[smaller, larger]` child node. Every candidate pair examined (both
/// orders) is charged to `work`; the search stops part way once `work` is over its
/// budget (the list is then incomplete, and the pass fails).
fn collisions(s: &Skeleton, topo: &Topology, clearance: f64, work: &Work) -> Vec<[usize; 2]> {
    let bvh = Bvh::build(s, clearance);
    let mut pairs: Vec<[usize; 2]> = bvh
        .order
        .par_iter()
        .flat_map_iter(|&i| {
            let i = i as usize;
            let ci = capsule(s, i);
            let mut found = Vec::new();
            if work.over() {
                return found;
            }
            let mut examined = 0u64;
            bvh.visit(&bvh.boxes[i], |j| {
                examined += 1;
                if j > i && collide(s, topo, (i, &ci), (j, &capsule(s, j)), clearance) {
                    found.push([i, j]);
                }
                if examined.is_multiple_of(PAIR_CHECK) {
                    work.charge_u64(PAIR_CHECK);
                    return !work.over();
                }
                true
            });
            work.charge_u64(examined % PAIR_CHECK);
            found
        })
        .collect();
    pairs.sort_unstable();
    pairs
}

/// Charges `work` with the candidate pairs a collision search of `s` examines (as
/// [`collisions`] counts them) and its nodes, without testing them; false (and the
/// budget over) when they are more than is left. Guards searches that do not count
/// their own pairs ([`skeleton_collisions`]).
fn charge_search(s: &Skeleton, clearance: f64, work: &Work) -> bool {
    let bvh = Bvh::build(s, clearance);
    let left = work.left();
    let mut examined = 0u64;
    for &i in &bvh.order {
        bvh.visit(&bvh.boxes[i as usize], |_| {
            examined += 1;
            examined <= left
        });
        if examined > left {
            work.exhaust();
            return false;
        }
    }
    work.charge_u64(examined);
    work.charge(s.len());
    !work.over()
}

/// Runs at most `max_rounds` rounds of thinning, then rotation, on the collisions left;
/// stops early when none are left or a round changed nothing. Returns the rounds run
/// and the rotations applied.
fn rounds(
    s: &mut Skeleton,
    topo: &Topology,
    o: &DecollideOptions,
    max_rounds: usize,
    work: &Work,
) -> (usize, usize) {
    let (mut run, mut rotations) = (0, 0);
    for _ in 0..max_rounds {
        if work.over() {
            break;
        }
        work.charge(s.len());
        let pairs = collisions(s, topo, o.clearance, work);
        if pairs.is_empty() || work.over() {
            break;
        }
        run += 1;
        // Thinning and the rotation queue measure every pair again.
        work.charge(2 * pairs.len());
        let thinned = thin(s, topo, &pairs, o);
        if thinned {
            work.charge(s.len());
        }
        let pairs = if thinned { collisions(s, topo, o.clearance, work) } else { pairs };
        if work.over() {
            break;
        }
        let (moved, spent) = rotate_pairs(s, topo, &pairs, o, work);
        work.charge(spent);
        rotations += moved;
        if !thinned && moved == 0 {
            break;
        }
    }
    (run, rotations)
}

/// Caps radii so the near-joint (and grazing) pairs clear; returns whether any radius
/// changed.
fn thin(s: &mut Skeleton, topo: &Topology, pairs: &[[usize; 2]], o: &DecollideOptions) -> bool {
    let n = s.len();
    let mut cap = vec![f64::INFINITY; n];
    let mut any = false;
    for &[a, b] in pairs {
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        let Some((d, ..)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        let sum = (ca.r + cb.r) * (1.0 + o.clearance);
        if sum <= 0.0 {
            continue;
        }
        let f = d / sum;
        let near = near_joint(s, topo, a, b, o);
        if f >= 1.0 || f < if near { o.min_thinning } else { o.far_thinning } {
            continue;
        }
        // Slightly under the exact factor, so f32 rounding cannot leave a graze.
        let f = f * 0.999;
        for (x, r) in [(a, ca.r), (b, cb.r)] {
            for node in [x, s.parent[x] as usize] {
                cap[node] = cap[node].min(f * r);
            }
        }
        any = true;
    }
    any && apply_caps(s, cap, o.taper, floor_of(s, o.min_radius))
}

/// Lowers every radius to its cap in `cap` (one per node, `INFINITY` for none) after
/// relaxing each cap up its axis by at most `taper` metres of radius per metre of length
/// and carrying it down to every descendant (radii stay non-increasing towards the tips
/// and the thinning is a smooth taper, not a notch). Returns whether any radius changed.
///
/// Explicit start radii ([`Skeleton::start_radius()`]) are thinned with the node they
/// start at: the start radius of the internode ending at node `i` lies at its parent
/// `p`, so it is scaled by the factor `p`'s radius was lowered by (a cone keeps its
/// proportions to the axis it leaves, and a start radius no larger than `p`'s radius,
/// the capsule's, stays so), never below the floor unless it already was.
pub(crate) fn apply_caps(s: &mut Skeleton, mut cap: Vec<f64>, taper: f64, floor: f32) -> bool {
    let n = s.len();
    let before = if s.start_radius.is_empty() { Vec::new() } else { s.radius.clone() };
    // Relax up each axis (a child continuing its parent's order), children first.
    for i in (0..n).rev() {
        let p = s.parent[i];
        if p == NO_PARENT || !cap[i].is_finite() || s.order[i] != s.order[p as usize] {
            continue;
        }
        let up = cap[i] + taper * s.internode_length(i);
        cap[p as usize] = cap[p as usize].min(up);
    }
    // Carry every cap down to the descendants (radii non-increasing towards the tips).
    for i in 0..n {
        let p = s.parent[i];
        if p != NO_PARENT {
            cap[i] = cap[i].min(cap[p as usize]);
        }
    }
    let mut changed = false;
    for (r, &c) in s.radius.iter_mut().zip(&cap) {
        let c = (c as f32).max(floor).max(0.0);
        if c < *r {
            *r = c;
            changed = true;
        }
    }
    if changed && !before.is_empty() {
        scale_start_radii(s, &before, floor);
    }
    changed
}

/// Scales each explicit start radius by the factor its internode's parent node's radius
/// changed by from `before` (only where that radius was lowered), never below `floor`
/// unless it already was (see [`apply_caps`]).
fn scale_start_radii(s: &mut Skeleton, before: &[f32], floor: f32) {
    let n = s.len().min(s.start_radius.len()).min(before.len());
    for i in 0..n {
        let p = s.parent[i];
        let Some(r0) = s.start_radius[i] else { continue };
        if p == NO_PARENT || p as usize >= n {
            continue;
        }
        let (old, new) = (before[p as usize], s.radius[p as usize]);
        if new < old && old > 0.0 {
            let scaled = (f64::from(r0) * f64::from(new) / f64::from(old)) as f32;
            s.start_radius[i] = Some(scaled.max(floor.min(r0)));
        }
    }
}

/// The radius floor: `fraction` of the skeleton's largest radius.
pub(crate) fn floor_of(s: &Skeleton, fraction: f64) -> f32 {
    let rmax = s.radius.iter().fold(0.0f32, |m, &r| m.max(r));
    (fraction * rmax as f64) as f32
}

/// Raises every radius under the floor (`fraction` of the largest radius) to it;
/// returns how many were raised. Explicit start radii under the floor are raised to it
/// too (the meshers draw them that thick), but not counted.
pub(crate) fn raise_to_floor(s: &mut Skeleton, fraction: f64) -> usize {
    let floor = floor_of(s, fraction);
    let mut raised = 0;
    for r in s.radius.iter_mut().filter(|r| **r < floor) {
        *r = floor;
        raised += 1;
    }
    for r0 in s.start_radius.iter_mut().flatten().filter(|r| **r < floor) {
        *r0 = floor;
    }
    raised
}

/// A subtree rotation to try (about the subtree root's parent node).
#[derive(Clone, Copy)]
struct Trial {
    rot: DQuat,
}

/// Trials of one subtree evaluated together (in parallel); only those up to the first
/// that clears are charged, so the work counted does not depend on this.
const TRIAL_CHUNK: usize = 8;

/// Moves subtrees to separate the pairs that thinning left; returns rotations applied.
/// Also returns the work spent (capsule queries) against the round's bound
/// ([`DecollideOptions::work_per_node`]); the candidate pairs the queries examine are
/// charged to `global` directly, and the pass stops once that is over its budget.
fn rotate_pairs(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    o: &DecollideOptions,
    global: &Work,
) -> (usize, usize) {
    let mut bvh = Bvh::build(s, o.clearance);
    let mut moved = 0;
    let (mut work, budget) = (0usize, o.work_per_node.saturating_mul(s.len()));
    // Lightest first: order the pairs by the smaller subtree either side could move.
    let mut queue: Vec<(usize, [usize; 2])> = pairs
        .iter()
        .map(|&[a, b]| {
            let w = joints_above(s, topo, a, 1)
                .into_iter()
                .chain(joints_above(s, topo, b, 1))
                .map(|c| topo.size(c))
                .min()
                .unwrap_or(usize::MAX);
            (w, [a, b])
        })
        .collect();
    queue.sort_unstable();
    for (_, [a, b]) in queue {
        if global.over() {
            break;
        }
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        let Some((d, pa, pb)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        if d >= (ca.r + cb.r) * (1.0 + o.clearance) {
            continue; // already separated by an earlier move
        }
        let cands = rotation_candidates(s, topo, [a, b], pa - pb, o);
        // Smallest clearing rotation of the lightest candidate that has one.
        let mut done = false;
        let mut tried: Vec<(usize, DVec3, usize, Vec<Trial>)> = Vec::new();
        for &(w, c, away) in &cands {
            if work > budget || global.over() {
                break;
            }
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            let (current, examined) = subtree_hits(
                s,
                topo,
                &bvh,
                c,
                &Motion::rotation(pivot, DQuat::IDENTITY),
                o.clearance,
                usize::MAX,
                global.left(),
            );
            work += w;
            global.charge_u64(examined.saturating_add(w as u64));
            if current == 0 || global.over() {
                continue;
            }
            let trials = trials_for(s, c, away, &o.angles);
            // The first trial that clears, in order (evaluated a chunk at a time); the
            // pairs of the trials up to it are charged.
            let (mut first, mut charged, left) = (None, 0u64, global.left());
            for (n, chunk) in trials.chunks(TRIAL_CHUNK).enumerate() {
                let limit = left - charged;
                let res: Vec<(usize, u64)> = chunk
                    .par_iter()
                    .map(|t| {
                        subtree_hits(s, topo, &bvh, c, &Motion::rotation(pivot, t.rot), o.clearance, 1, limit)
                    })
                    .collect();
                for (k, &(h, p)) in res.iter().enumerate() {
                    charged = charged.saturating_add(p);
                    if charged > left {
                        break;
                    }
                    if h == 0 {
                        first = Some(n * TRIAL_CHUNK + k);
                        break;
                    }
                }
                if first.is_some() || charged > left {
                    break;
                }
            }
            let trials_run = first.map_or(trials.len(), |k| k + 1);
            work += w * trials_run;
            global.charge_u64(charged.saturating_add((w * trials_run) as u64));
            if global.over() {
                break;
            }
            if let Some(k) = first {
                apply(s, topo, &mut bvh, c, &Motion::rotation(pivot, trials[k].rot), o.clearance);
                moved += 1;
                done = true;
                break;
            }
            tried.push((c, away, current, trials));
        }
        if done || work > budget || global.over() {
            continue;
        }
        // None clears: keep the trial that removes the most collisions (of the two
        // lightest candidates), so the total only ever falls.
        let mut best: Option<(usize, usize, DQuat)> = None; // (reduction, root, rotation)
        for (c, _, current, trials) in tried.into_iter().take(2) {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            let left = global.left();
            let res: Vec<(usize, u64)> = trials
                .par_iter()
                .map(|t| {
                    subtree_hits(
                        s,
                        topo,
                        &bvh,
                        c,
                        &Motion::rotation(pivot, t.rot),
                        o.clearance,
                        current,
                        left,
                    )
                })
                .collect();
            let hits: Vec<usize> = res.iter().map(|r| r.0).collect();
            work += topo.size(c) * trials.len();
            global.charge_u64(
                res.iter().fold((topo.size(c) * trials.len()) as u64, |a, r| a.saturating_add(r.1)),
            );
            if global.over() {
                break;
            }
            if let Some((k, &h)) = hits.iter().enumerate().min_by_key(|&(k, &h)| (h, k)) {
                if h < current && best.is_none_or(|(r, ..)| current - h > r) {
                    best = Some((current - h, c, trials[k].rot));
                }
            }
        }
        if let Some((_, c, rot)) = best {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            apply(s, topo, &mut bvh, c, &Motion::rotation(pivot, rot), o.clearance);
            moved += 1;
        }
    }
    (moved, work)
}

/// The subtrees that may be rotated to separate internodes `a` and `b` (`away` points
/// from `b`'s closest point to `a`'s), lightest first, as (size, root, direction away
/// from the other): the nearest joints above each internode that do not also carry the
/// other internode (moving both rigidly would not separate them), of at most
/// [`DecollideOptions::max_moved`] nodes.
fn rotation_candidates(
    s: &Skeleton,
    topo: &Topology,
    [a, b]: [usize; 2],
    away: DVec3,
    o: &DecollideOptions,
) -> Vec<(usize, usize, DVec3)> {
    let mut cands: Vec<(usize, usize, DVec3)> = Vec::new();
    for (x, y, away) in [(a, b, away), (b, a, -away)] {
        for c in joints_above(s, topo, x, o.candidates) {
            if !topo.contains(c, y) && !topo.contains(c, s.parent[y] as usize) {
                cands.push((topo.size(c), c, away));
            }
        }
    }
    cands.sort_unstable_by_key(|&(w, c, _)| (w, c));
    cands.dedup_by_key(|&mut (_, c, _)| c);
    cands.retain(|&(w, ..)| w <= o.max_moved);
    cands
}

/// Moves per pair [`trade`] follows up, fewest new collisions first.
const TRADE_TRIALS: usize = 4;

/// Rounds of thinning and rotation [`trade`] runs after each move.
const TRADE_ROUNDS: usize = 3;

/// A move [`trade`] follows up makes at most this many new collisions.
const TRADE_HITS: usize = 40;

/// The very last resort, for pairs every other step left (session 11:
/// `wp-ca-black-oak`'s trunk against a 3 k-node limb of its clone trunk, which every
/// rotation swings through 2–150 twigs of the dense crown; `wp-sassafras`'s stub whose
/// every lengthening meets a third internode). Of the moves the rounds and the stub
/// resort try (the rotations of the candidate subtrees, the stub motions), those that
/// clear the pair but make at most [`TRADE_HITS`] new collisions elsewhere are sorted
/// by how many; the first [`TRADE_TRIALS`] are applied in turn to a copy of the
/// skeleton, the normal rounds (thinning, rotation) run on the copy for at most
/// [`TRADE_ROUNDS`], and the first copy that ends with fewer collisions in the whole
/// skeleton than before is kept. Returns the pairs so traded, and adds the rotations
/// applied to `rotations`.
fn trade(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    o: &DecollideOptions,
    rotations: &mut usize,
    work: &Work,
) -> usize {
    work.charge(s.len());
    let mut total = collisions(s, topo, o.clearance, work).len();
    let mut traded = 0;
    for &[a, b] in pairs {
        if work.over() {
            break;
        }
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        if total == 0 || !collide(s, topo, (a, &ca), (b, &cb), o.clearance) {
            continue;
        }
        let Some((_, pa, pb)) = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY) else { continue };
        let mut moves: Vec<(usize, Motion)> = Vec::new();
        for (_, c, away) in rotation_candidates(s, topo, [a, b], pa - pb, o) {
            let pivot = s.position[s.parent[c] as usize].as_dvec3();
            moves.extend(
                trials_for(s, c, away, &o.angles).into_iter().map(|t| (c, Motion::rotation(pivot, t.rot))),
            );
        }
        moves.extend(stub_motions(s, topo, [a, b], o.clearance).into_iter().map(|(_, x, mv, _)| (x, mv)));
        let bvh = Bvh::build(s, o.clearance);
        work.charge(s.len() + moves.iter().map(|&(c, _)| topo.size(c)).sum::<usize>());
        let left = work.left();
        let res: Vec<(Option<(usize, usize)>, u64)> = moves
            .par_iter()
            .enumerate()
            .map(|(k, &(c, mv))| {
                // The one of the two that moves with `c`, against the other.
                let (mover, other) = if topo.contains(c, a) { (a, b) } else { (b, a) };
                let cm = moved_capsule(s, c, mover, &mv);
                if collide(s, topo, (mover, &cm), (other, &capsule(s, other)), o.clearance) {
                    return (None, 0);
                }
                let (hits, examined) = subtree_hits(s, topo, &bvh, c, &mv, o.clearance, TRADE_HITS + 1, left);
                ((hits <= TRADE_HITS).then_some((hits, k)), examined)
            })
            .collect();
        work.charge_u64(res.iter().fold(0u64, |a, r| a.saturating_add(r.1)));
        if work.over() {
            break;
        }
        let mut scored: Vec<(usize, usize)> = res.into_iter().filter_map(|r| r.0).collect();
        scored.sort_unstable();
        for &(_, k) in scored.iter().take(TRADE_TRIALS) {
            let (c, mv) = moves[k];
            if work.over() {
                break;
            }
            let mut copy = s.clone();
            let mut copy_bvh = Bvh::build(&copy, o.clearance);
            apply(&mut copy, topo, &mut copy_bvh, c, &mv, o.clearance);
            work.charge(2 * s.len());
            let moved =
                usize::from(mv.shift == DVec3::ZERO) + rounds(&mut copy, topo, o, TRADE_ROUNDS, work).1;
            work.charge(s.len());
            let n = collisions(&copy, topo, o.clearance, work).len();
            if work.over() {
                break;
            }
            if n < total {
                *s = copy;
                total = n;
                *rotations += moved;
                traded += 1;
                break;
            }
        }
    }
    traded
}

/// The first `k` joints at or above internode `x`: nodes `c` (with a parent) whose
/// parent has several children or starts a new branch order, nearest first.
fn joints_above(s: &Skeleton, topo: &Topology, x: usize, k: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut c = topo.joint_up[x];
    while c != NO_PARENT && out.len() < k {
        out.push(c as usize);
        c = topo.joint_up[s.parent[c as usize] as usize];
    }
    out
}

/// The rotations tried for the subtree at `c`, smallest angle first: about the axis
/// that swings it along `away` (in the plane of the two branches), the axis that swings
/// it out of that plane, and its parent's axis; both senses each.
fn trials_for(s: &Skeleton, c: usize, away: DVec3, angles: &[f64]) -> Vec<Trial> {
    let p = s.parent[c] as usize;
    let dir = (s.position[c].as_dvec3() - s.position[p].as_dvec3()).normalize_or_zero();
    let any_perp = |v: DVec3| {
        let t = if v.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
        v.cross(t).normalize_or_zero()
    };
    let mut in_plane = dir.cross(away).normalize_or_zero();
    if in_plane == DVec3::ZERO {
        in_plane = any_perp(dir);
    }
    let out_of_plane = dir.cross(in_plane).normalize_or_zero();
    let parent_axis = match s.parent[p] {
        NO_PARENT => DVec3::ZERO,
        g => (s.position[p].as_dvec3() - s.position[g as usize].as_dvec3()).normalize_or_zero(),
    };
    let axes: Vec<DVec3> =
        [in_plane, out_of_plane, parent_axis].into_iter().filter(|a| a.length_squared() > 0.5).collect();
    let mut out = Vec::new();
    for &deg in angles {
        for &axis in &axes {
            for sign in [1.0, -1.0] {
                out.push(Trial { rot: DQuat::from_axis_angle(axis, sign * deg.to_radians()) });
            }
        }
    }
    out
}

/// A rigid motion of a subtree: rotation by `rot` about `pivot` (the subtree's base
/// node, which stays put), then translation by `shift`.
#[derive(Debug, Clone, Copy)]
struct Motion {
    pivot: DVec3,
    rot: DQuat,
    shift: DVec3,
}

impl Motion {
    fn rotation(pivot: DVec3, rot: DQuat) -> Self {
        Motion { pivot, rot, shift: DVec3::ZERO }
    }
    fn of(&self, s: &Skeleton, node: usize) -> DVec3 {
        self.point(s.position[node].as_dvec3())
    }
    fn point(&self, p: DVec3) -> DVec3 {
        self.pivot + self.shift + self.rot * (p - self.pivot)
    }
}

/// The capsule of internode `m` of the subtree at `c` once the subtree is moved by `mv`
/// (the subtree's base node, `mv.pivot`, stays put).
fn moved_capsule(s: &Skeleton, c: usize, m: usize, mv: &Motion) -> Capsule {
    let pm = s.parent[m] as usize;
    Capsule {
        a: if m == c { mv.pivot } else { mv.of(s, pm) },
        b: mv.of(s, m),
        r: s.radius[m].max(s.radius[pm]) as f64,
    }
}

/// Collisions (at most `limit`) between the subtree at `c`, moved by `mv` (its base
/// node stays put), and every internode outside it, with the candidate pairs examined
/// (the search stops once they are over `pair_limit`).
#[allow(clippy::too_many_arguments)]
fn subtree_hits(
    s: &Skeleton,
    topo: &Topology,
    bvh: &Bvh,
    c: usize,
    mv: &Motion,
    clearance: f64,
    limit: usize,
    pair_limit: u64,
) -> (usize, u64) {
    let (mut hits, mut examined) = (0, 0u64);
    for &m in topo.subtree(c) {
        let m = m as usize;
        let cm = moved_capsule(s, c, m, mv);
        hits += capsule_hits(s, topo, bvh, c, (m, &cm), clearance, limit - hits, (&mut examined, pair_limit));
        if hits >= limit || examined > pair_limit {
            break;
        }
    }
    (hits, examined)
}

/// Collisions (at most `limit`) of internode `m`, moved to the capsule `cm`, with every
/// internode outside the subtree at `c`. Candidate pairs examined are added to
/// `examined`; the query stops once they are over `pair_limit`.
#[allow(clippy::too_many_arguments)]
fn capsule_hits(
    s: &Skeleton,
    topo: &Topology,
    bvh: &Bvh,
    c: usize,
    (m, cm): (usize, &Capsule),
    clearance: f64,
    limit: usize,
    (examined, pair_limit): (&mut u64, u64),
) -> usize {
    let mut hits = 0;
    bvh.visit(&capsule_box(cm, clearance), |j| {
        *examined += 1;
        if topo.contains(c, j) {
            return *examined <= pair_limit;
        }
        if collide(s, topo, (m, cm), (j, &capsule(s, j)), clearance) {
            hits += 1;
        }
        hits < limit && *examined <= pair_limit
    });
    hits
}

/// Lengths (fractions of the internode) a colliding tip internode is shortened to,
/// mildest first.
const RETRACT: [f64; 5] = [0.9, 0.8, 0.7, 0.6, 0.5];

/// The last resort for what rotation left: a pair where one internode ends at a tip
/// (a node without children) is cleared by pulling that tip back along its internode,
/// by the mildest of [`RETRACT`] that leaves it with no collision (the shorter change
/// of the two when both are tips). This is what frees a closed figure such as the Koch
/// snowflake, whose last internode ends on its first and has no joint to rotate about.
/// Returns the tips pulled back.
fn retract_tips(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    clearance: f64,
    work: &Work,
) -> usize {
    let mut bvh = Bvh::build(s, clearance);
    let mut pulled = 0;
    for &[a, b] in pairs {
        if work.over() {
            break;
        }
        if !collide(s, topo, (a, &capsule(s, a)), (b, &capsule(s, b)), clearance) {
            continue; // cleared by an earlier retraction
        }
        let mut best: Option<(usize, usize, DVec3)> = None; // (step, tip, new position)
        for x in [a, b] {
            if topo.child_count[x] != 0 {
                continue;
            }
            let base = s.position[s.parent[x] as usize].as_dvec3();
            let tip = s.position[x].as_dvec3();
            for (k, &f) in RETRACT.iter().enumerate() {
                if best.is_some_and(|(bk, ..)| bk <= k) {
                    break;
                }
                let cm = Capsule { a: base, b: base + (tip - base) * f, r: capsule(s, x).r };
                let mut examined = 0u64;
                let hits =
                    capsule_hits(s, topo, &bvh, x, (x, &cm), clearance, 1, (&mut examined, work.left()));
                work.charge_u64(examined.saturating_add(1));
                if work.over() {
                    return pulled;
                }
                if hits == 0 {
                    best = Some((k, x, cm.b));
                    break;
                }
            }
        }
        let Some((_, x, to)) = best else { continue };
        let delta = (to - s.position[x].as_dvec3()).as_vec3();
        s.position[x] = to.as_vec3();
        move_organs(s, topo, x, |p| p + delta, |d| d);
        bvh.update(x, capsule_box(&capsule(s, x), clearance));
        pulled += 1;
    }
    pulled
}

/// Moves tried by the stub resort (lengthening or bending a stub, bending a longer
/// internode), in clearance distances `(r_a + r_b)(1 + clearance)`, mildest first.
const EXTEND: [f64; 4] = [0.5, 1.0, 2.0, 3.0];

/// The largest bend, in degrees, a sideways move gives an internode that is no stub
/// (session 12: `wp-weeping-willow`'s limb whose joint sits against its clone trunk).
const BEND_MAX_DEG: f64 = 20.0;

/// Internodes tried by the stub resort on each side of a pair: its own, and up to
/// `STUB_HOPS - 1` above it towards the other.
const STUB_HOPS: usize = 3;

/// The last resort for a stub: a pair left where one of its internodes, or one of
/// those joining them in the tree ([`STUB_HOPS`] per side, its own included), is
/// shorter than twice the pair's clearance distance `(r_a + r_b)(1 + clearance)` and
/// carries a subtree with one of the two in it (or is one of the two, a tip), is
/// cleared by moving that subtree by the mildest of [`EXTEND`] (times that distance)
/// that leaves it with no collision: along the stub (lengthening it), or else away
/// from the other internode (bending it). Rotation cannot free such a stub, whose far
/// end stays within its own length of the joint where its sibling starts, and thinning
/// cannot either once both are at the radius floor (Weber–Penn stems whose first
/// internode is a few millimetres long: `wp-sassafras` kept 6 such pairs,
/// `wp-european-larch` 23). A longer internode among those candidates is bent away
/// the same way, by steps that turn it by at most [`BEND_MAX_DEG`]; at one step stubs
/// come first, then the lightest subtree (see [`stub_motions`]). Moves ignore
/// [`DecollideOptions::max_moved`]: they are translations of a few radii, which keep a
/// subtree's shape. Returns the stubs moved and internodes bent.
fn extend_stubs(
    s: &mut Skeleton,
    topo: &Topology,
    pairs: &[[usize; 2]],
    clearance: f64,
    work: &Work,
) -> usize {
    let mut bvh = Bvh::build(s, clearance);
    let mut pushed = 0;
    for &[a, b] in pairs {
        if work.over() {
            break;
        }
        let (ca, cb) = (capsule(s, a), capsule(s, b));
        if !collide(s, topo, (a, &ca), (b, &cb), clearance) {
            continue; // cleared by an earlier move
        }
        // Mildest step first; at one step, stubs (in the order tried), then the bends
        // of the lightest subtrees.
        let mut best: Option<((usize, usize), usize, Motion)> = None; // (rank, stub, motion)
        for (k, x, mv, weight) in stub_motions(s, topo, [a, b], clearance) {
            if best.is_some_and(|(bk, ..)| bk <= (k, weight)) {
                continue;
            }
            let (hits, examined) = subtree_hits(s, topo, &bvh, x, &mv, clearance, 1, work.left());
            work.charge_u64(examined.saturating_add(topo.size(x) as u64));
            if work.over() {
                return pushed;
            }
            if hits == 0 {
                best = Some(((k, weight), x, mv));
            }
        }
        let Some((_, x, mv)) = best else { continue };
        apply(s, topo, &mut bvh, x, &mv, clearance);
        pushed += 1;
    }
    pushed
}

/// The stub motions [`extend_stubs`] tries for the pair `a`, `b`, as (step in
/// [`EXTEND`], stub, motion, weight), in the order tried: for the pair's own internodes
/// and those joining them ([`STUB_HOPS`] per side) whose subtree carries one of
/// the two but not the other (a tip among them too: its end moves), each step moves the
/// internode's subtree along it, then away from the other internode, when it is
/// shorter than twice the pair's clearance distance (a stub; weight 0); a longer one
/// only away, while that bends it by at most [`BEND_MAX_DEG`] (weight: 1 + the nodes
/// it moves, so the lighter side bends first).
fn stub_motions(
    s: &Skeleton,
    topo: &Topology,
    [a, b]: [usize; 2],
    clearance: f64,
) -> Vec<(usize, usize, Motion, usize)> {
    let (ca, cb) = (capsule(s, a), capsule(s, b));
    let reach = (ca.r + cb.r) * (1.0 + clearance);
    // From b's closest point towards a's.
    let apart = gap(s, topo, (a, &ca), (b, &cb), f64::INFINITY).map_or(DVec3::ZERO, |(_, pa, pb)| pa - pb);
    let mut cands = Vec::new();
    for (start, other) in [(a, b), (b, a)] {
        let mut x = start;
        for _ in 0..STUB_HOPS {
            if s.parent[x] == NO_PARENT || topo.contains(x, other) {
                break;
            }
            cands.push(x);
            x = s.parent[x] as usize;
        }
    }
    let mut out = Vec::new();
    let max_bend = BEND_MAX_DEG.to_radians().tan();
    for x in cands {
        let base = s.position[s.parent[x] as usize].as_dvec3();
        let axis = s.position[x].as_dvec3() - base;
        let len = axis.length();
        if len.is_nan() || len <= 0.0 {
            continue;
        }
        let stub = len < 2.0 * reach;
        // Along the stub, or (a stub aligned with the other, which no lengthening
        // frees) away from the other internode; a longer internode only bends away,
        // by at most `BEND_MAX_DEG`.
        let along = axis / len;
        let away = if topo.contains(x, a) { apart } else { -apart };
        let away = away - along * away.dot(along);
        let away = if away.length() > 1e-9 * len { away.normalize() } else { along.any_orthonormal_vector() };
        let weight = if stub { 0 } else { 1 + topo.size(x) };
        let shift = |dir: DVec3| Motion { pivot: base, rot: DQuat::IDENTITY, shift: dir };
        for (k, &e) in EXTEND.iter().enumerate() {
            if stub {
                out.push((k, x, shift(along * (e * reach)), weight));
            } else if e * reach > len * max_bend {
                break;
            }
            out.push((k, x, shift(away * (e * reach)), weight));
        }
    }
    out
}

/// Moves the organs hanging on `node`: points (position, polygon outline) by `point`,
/// directions (heading, up) by `dir`.
fn move_organs(
    s: &mut Skeleton,
    topo: &Topology,
    node: usize,
    point: impl Fn(Vec3) -> Vec3,
    dir: impl Fn(Vec3) -> Vec3,
) {
    for &k in &topo.organ_list[topo.organ_offsets[node] as usize..topo.organ_offsets[node + 1] as usize] {
        let org = &mut s.organs[k as usize];
        org.position = point(org.position);
        org.heading = dir(org.heading);
        org.up = dir(org.up);
        if let OrganKind::Polygon(vs) = &mut org.kind {
            for v in vs.iter_mut() {
                *v = point(*v);
            }
        }
    }
}

/// Moves the subtree at `c` by `mv` (positions, `up` vectors, organs) and updates the
/// BVH.
fn apply(s: &mut Skeleton, topo: &Topology, bvh: &mut Bvh, c: usize, mv: &Motion, clearance: f64) {
    let rot_f = mv.rot.as_quat();
    for &m in topo.subtree(c) {
        let m = m as usize;
        s.position[m] = mv.of(s, m).as_vec3();
        let up = rot_f * s.up[m];
        if up.is_finite() {
            s.up[m] = up;
        }
        move_organs(s, topo, m, |p| mv.point(p.as_dvec3()).as_vec3(), |d| rot_f * d);
    }
    for &m in topo.subtree(c) {
        bvh.update(m as usize, capsule_box(&capsule(s, m as usize), clearance));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A longer internode is only bent by steps that turn it by at most
    /// [`BEND_MAX_DEG`]: the 50 mm one (radius 5 mm, against another of 5 mm: a
    /// clearance distance of 10.8 mm, so 20° allows 18.2 mm) gets the first two steps
    /// of [`EXTEND`], the 1 m one all four; each is sideways, weighted by the nodes it
    /// moves.
    #[test]
    fn bends_stop_at_the_largest_angle() {
        let mut s = Skeleton::new();
        let r = 0.005;
        let r0 = s.push(Vec3::ZERO, r, NO_PARENT, Vec3::Z, 0);
        let x1 = s.push(Vec3::new(0.0, 0.05, 0.0), r, r0, Vec3::Z, 0) as usize;
        let q0 = s.push(Vec3::new(0.008, 0.04, -0.5), r, NO_PARENT, Vec3::Y, 0);
        let q1 = s.push(Vec3::new(0.008, 0.04, 0.5), r, q0, Vec3::Y, 0) as usize;
        let topo = Topology::new(&s);
        let moves = stub_motions(&s, &topo, [x1, q1], 0.08);
        let count = |x: usize| moves.iter().filter(|m| m.1 == x).count();
        assert_eq!((count(x1), count(q1)), (2, 4), "{moves:?}");
        for &(k, x, mv, weight) in &moves {
            let base = s.position[s.parent[x] as usize].as_dvec3();
            let axis = s.position[x].as_dvec3() - base;
            assert!(mv.shift.dot(axis).abs() < 1e-12, "not sideways: {mv:?}");
            let turn = mv.shift.length().atan2(axis.length()).to_degrees();
            assert!(turn <= BEND_MAX_DEG + 1e-9, "{turn}° at step {k}");
            assert_eq!(weight, 2, "1 + the one node moved");
        }
    }
}
