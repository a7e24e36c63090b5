//! Skeleton de-collision: pulls apart branches that pass through each other, so the
//! joint meshers (`hull`, `sweep`, `quad`) can mesh and refine a tree without
//! self-intersections.
//!
//! Issue 5's acceptance ("after refinement to level 2 it has no self-intersections")
//! needs a skeleton whose internode capsules do not overlap: a mesher cannot keep two
//! surfaces apart when the skeleton itself crosses them (see
//! [`crate::mesh::check::skeleton_collisions`] and
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
use crate::mesh::check::skeleton_collisions;
use crate::skeleton::Skeleton;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

mod detect;
mod motion;
mod resort;
mod rotate;
mod thin;

use self::detect::{charge_search, collisions, near_joint, Topology};
use self::resort::Resort;
use self::rotate::{rotate_pairs, trade};
use self::thin::thin;
pub(crate) use self::thin::{apply_caps, floor_of, raise_to_floor};

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
    // A cancelled front end keeps nothing of a half-fitted skeleton.
    crate::cancel::check()?;
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
        for (resort, count) in
            [(Resort::RetractTips, &mut report.retracted), (Resort::ExtendStubs, &mut report.extended)]
        {
            *count = resort.run(skeleton, &topo, &left, opts.clearance, &work);
            if *count > 0 {
                work.charge(skeleton.len());
                left = collisions(skeleton, &topo, opts.clearance, &work);
            }
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
        if work.over() || crate::cancel::cancelled() {
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
#[cfg(test)]
mod tests {
    use super::detect::Topology;
    use super::resort::{stub_motions, BEND_MAX_DEG};
    use super::*;
    use crate::skeleton::NO_PARENT;
    use glam::Vec3;

    /// Two crossing stems under a cancelled token: the pass stops after its rounds with
    /// [`Error::Cancelled`]; without the token it runs.
    #[test]
    fn a_cancelled_token_stops_the_pass() {
        let crossing = || {
            let mut s = Skeleton::new();
            let a = s.push(Vec3::new(-0.5, 0.0, 0.0), 0.05, NO_PARENT, Vec3::Z, 0);
            s.push(Vec3::new(0.5, 0.0, 0.0), 0.05, a, Vec3::Z, 0);
            let b = s.push(Vec3::new(0.0, -0.5, 0.0), 0.05, NO_PARENT, Vec3::Z, 0);
            s.push(Vec3::new(0.0, 0.5, 0.0), 0.05, b, Vec3::Z, 0);
            s
        };
        let token = crate::cancel::Cancel::new();
        token.cancel();
        let r = crate::cancel::scope(&token, || decollide(&mut crossing(), &DecollideOptions::default()));
        assert!(matches!(r, Err(Error::Cancelled)), "{r:?}");
        let r = decollide(&mut crossing(), &DecollideOptions::default()).unwrap();
        assert!(r.before > 0, "{r:?}");
    }

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
