//! Mesh-checked thinning: thins the skeleton where a joint mesher's *refined* surface
//! still crosses itself, and meshes again (beyond the seeds; issue 5's acceptance).
//!
//! [`decollide`](crate::fit::decollide) keeps the internode capsules apart, but a
//! surface is not its capsules: junction boxes and blends stand out of them (Skjermo2008's
//! boxes of Eq. 4 length, MacMurchy2004's Eq. 5.1 offsets, Pieterse2012's trimmed joints) and a
//! tube of short internodes folds at its bends. Where the level-`levels` refinement of
//! the control mesh (the level the acceptance checks, 2 by default) still crosses
//! itself, this pass finds the internodes the crossing faces lie on and thins them:
//!
//! 1. mesh the skeleton with the given mesher and refine it `levels` times with the
//!    mesher's scheme (Loop or Catmull–Clark);
//! 2. search the refined mesh for crossing triangles (the checker's BVH search,
//!    [`check_mesh`](crate::mesh::check::check_mesh)'s test) — in full in the first
//!    round, and in later rounds only where the mesh changed (below);
//! 3. give each crossing face to the internode whose surface is nearest its centre
//!    (`| distance to the axis − radius there |`, over the internodes whose capsule,
//!    grown by 1.5 radii, contains the centre) — and, in *wide* rounds (after the narrow
//!    rule has stalled for [`ClearOptions::patience`] rounds), where a pair's two faces
//!    land on one internode or on two that share a node, each face's runner-up too (one
//!    of the faces then stands out of a neighbour's surface: a box or a fold made for
//!    another internode) — and cap the radii of both end nodes of
//!    each such internode — and, in wide rounds, where an end node is a branching node, the radii of all
//!    its children, since a junction's box, blend or hull is sized by every radius
//!    meeting there — at [`ClearOptions::step`] times their radius, never below
//!    [`ClearOptions::min_factor`] times the radius the pass started with nor below the
//!    floor ([`ClearOptions::min_radius`]; radii under it are raised to it first); caps are
//!    relaxed up the axis by [`ClearOptions::taper`] and carried down to descendants
//!    exactly as `decollide`'s thinning does (a smooth taper, not a notch);
//! 4. repeat until the refined mesh is clean, nothing can be thinned further,
//!    [`ClearOptions::patience`] rounds in a row brought no improvement, or
//!    [`ClearOptions::max_rounds`] rounds ran.
//!
//! The skeleton and mesh with the fewest crossings seen are kept (thinning one junction
//! can change a mesher's repair choices elsewhere), so the count never rises. Only radii
//! change: positions, topology and organs stay as they are. Explicit start radii
//! ([`Skeleton::start_radius()`], which the hull and sweep meshers draw cones from) are
//! raised to the floor and thinned with the node they start at, as `decollide` does
//! (issue 26), so a thinned junction's cones thin too.
//!
//! Cost per round: one meshing, one refinement and one search of the refined triangles;
//! refined meshes over [`ClearOptions::max_faces`] faces are not searched (reported, not
//! an error).
//!
//! **Local, incremental rounds** (issue 44). A round changes only the radii of the
//! nodes it thins, so most of the next surface comes back bit for bit the same. The
//! search after the first matches every refined triangle to the previous round's by its
//! corner positions and tests only the pairs with a triangle that changed, carrying the
//! other crossings over (`mesh::check`'s incremental search: the pairs are exactly those
//! a full search finds, so outputs stay byte-identical; [`ClearReport::searched`] lists
//! the triangles searched per round). And the pass opens a memo of the meshers' own
//! junction searches (the sweep mesher's refined-junction check and the quad repair
//! search each junction's refined faces among themselves on every meshing): a junction
//! whose refined triangles are bit for bit those of a junction searched before in the
//! pass takes the remembered result ([`ClearReport::groups_reused`]). How much either
//! saves depends on the mesher: the quad mesher carries its frames down the tree, so
//! thinning a first-order branch moves the cage of its whole subtree (on
//! `wp-quaking-aspen`, thinning 49 nodes moved the faces of 2,960), while the search
//! still skips what did not move.

use crate::error::{Error, Result};
use crate::fit::decollide::{apply_caps, floor_of, raise_to_floor};
use crate::geometry::Mesh;
use crate::mesh::check::{build_bvh, fan_triangles, query, Aabb, IncrementalSearch};
use crate::refine::{subdivide, RefineOptions, Scheme, SubdivideOptions};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::DVec3;
use std::time::{Duration, Instant};

/// Settings of [`clear_crossings`]: the recipe table `[fit.clear]` (every key optional;
/// [`ClearOptions::check`] names the key of a value out of range).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClearOptions {
    /// Refinement level at which the surface must not cross itself (issue 5: 2). Not a
    /// recipe key: the pipeline sets it to `refine.levels` (at most 3), so the surface
    /// checked is the one written.
    #[serde(skip)]
    pub levels: u32,
    /// Boundary rule of that refinement. Not a recipe key: the pipeline sets it from
    /// `refine.boundary`, so the surface checked is the one written.
    #[serde(skip)]
    pub boundary: crate::refine::BoundaryInterpolation,
    /// Radius factor applied per round to the end nodes of an internode a crossing lies on.
    pub step: f64,
    /// No radius is thinned below this fraction of its radius when the pass started.
    pub min_factor: f64,
    /// Radius slope (metres of radius per metre of axis) allowed above a thinned node.
    pub taper: f64,
    /// Rounds of mesh, refine, search and thin at most.
    pub max_rounds: usize,
    /// Stop after this many rounds in a row that did not lower the fewest crossings seen
    /// (what thinning does not clear, more thinning rarely will).
    pub patience: usize,
    /// Refined meshes with more faces than this are not searched.
    pub max_faces: usize,
    /// At most this many crossing pairs are searched for per round (the rest wait for
    /// the next round).
    pub max_pairs: usize,
    /// Radius floor as a fraction of the largest radius (default 0.005, as
    /// [`DecollideOptions::min_radius`](crate::fit::decollide::DecollideOptions::min_radius)):
    /// radii under it are raised to it first and thinning never goes below it (the
    /// joint meshers draw thinner sections at that size anyway).
    pub min_radius: f64,
    /// Work budget of the whole pass (issue 27): refined faces searched, summed over its
    /// rounds (each round meshes, refines and searches about as many), counted before
    /// each refinement. A pass that needs more stops with an error naming
    /// `fit.clear.max_work` (counted, not timed, so the result stays deterministic).
    /// Left out of written metadata at its default ([`DEFAULT_CLEAR_WORK`]).
    #[serde(skip_serializing_if = "is_default_clear_work")]
    pub max_work: u64,
}

/// Default [`ClearOptions::max_work`]: 12 M refined faces, e.g. three rounds at the
/// default [`ClearOptions::max_faces`] (4 M), which keeps the pass to seconds.
pub const DEFAULT_CLEAR_WORK: u64 = 12_000_000;

/// Largest [`ClearOptions::max_work`] accepted.
pub const MAX_CLEAR_WORK: u64 = 100_000_000_000;

/// Whether `w` is the default work budget (left out of written metadata).
fn is_default_clear_work(w: &u64) -> bool {
    *w == DEFAULT_CLEAR_WORK
}

impl Default for ClearOptions {
    fn default() -> Self {
        Self {
            levels: 2,
            boundary: crate::refine::BoundaryInterpolation::default(),
            step: 0.8,
            min_factor: 0.3,
            taper: 0.1,
            max_rounds: 8,
            patience: 2,
            max_faces: 4_000_000,
            max_pairs: 100_000,
            min_radius: crate::tolerance::RADIUS_FLOOR,
            max_work: DEFAULT_CLEAR_WORK,
        }
    }
}

/// What [`clear_crossings`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ClearReport {
    /// Crossing face pairs of the refined mesh before the pass (`None`: not searched,
    /// the refined mesh is over [`ClearOptions::max_faces`]).
    pub before: Option<usize>,
    /// Crossing face pairs of the refined mesh returned.
    pub after: Option<usize>,
    /// Rounds run (meshings after the first).
    pub rounds: usize,
    /// Nodes whose radius the pass lowered.
    pub thinned: usize,
    /// The search of the mesh returned stopped at [`ClearOptions::max_pairs`]: `after` is
    /// a lower bound.
    pub truncated: bool,
    /// Internodes (by child node) the crossings left lie on, at most 16.
    pub unresolved: Vec<u32>,
    /// Work spent ([`ClearOptions::max_work`]'s units: refined faces searched).
    pub work: u64,
    /// Per search of the refined mesh, in order: `[triangles, triangles searched]`. The
    /// first search covers every triangle; later ones only the triangles that changed
    /// since the search before (issue 44; see the module docs).
    pub searched: Vec<[usize; 2]>,
    /// Junction groups of the meshers' repair searches answered from the pass's memo,
    /// and those searched (see the module docs).
    pub groups_reused: [u64; 2],
    /// Wall time, meshing included.
    pub elapsed: Duration,
}

impl ClearOptions {
    /// Checks every value's range; the error names the recipe key (`fit.clear.<field>`).
    pub fn check(&self) -> Result<()> {
        let o = self;
        let bad = |key: &str, why: String| Err(Error::Recipe(format!("`fit.clear.{key}` {why}")));
        if !(o.step.is_finite() && o.step > 0.0 && o.step < 1.0) {
            return bad("step", format!("must be in (0, 1), got {}", o.step));
        }
        if !(o.min_factor.is_finite() && o.min_factor > 0.0 && o.min_factor <= 1.0) {
            return bad("min_factor", format!("must be in (0, 1], got {}", o.min_factor));
        }
        if !(o.taper.is_finite() && (0.0..=100.0).contains(&o.taper)) {
            return bad("taper", format!("must be in 0..=100, got {}", o.taper));
        }
        if !(o.min_radius.is_finite() && (0.0..=1.0).contains(&o.min_radius)) {
            return bad("min_radius", format!("must be in 0..=1, got {}", o.min_radius));
        }
        if o.max_pairs == 0 {
            return bad("max_pairs", "must be at least 1 (0 would report every mesh clean)".into());
        }
        if o.levels > 4 {
            return bad("levels", format!("must be at most 4, got {}", o.levels));
        }
        if !(1..=MAX_CLEAR_WORK).contains(&o.max_work) {
            return bad("max_work", format!("must be in 1..={MAX_CLEAR_WORK}, got {}", o.max_work));
        }
        // Work bounds: each scales the pass's running time or memory.
        for (name, v, max) in [
            ("max_rounds", o.max_rounds, 100),
            ("patience", o.patience, 100),
            ("max_faces", o.max_faces, 64_000_000),
            ("max_pairs", o.max_pairs, 10_000_000),
        ] {
            if v > max {
                return bad(name, format!("is {v}; at most {max} (it bounds the pass's work)"));
            }
        }
        Ok(())
    }
}

/// Meshes `skeleton` with `mesher` (which returns a control mesh and the scheme it is
/// refined with) and thins the skeleton where the refined mesh crosses itself, as the
/// module docs describe. Returns the control mesh of the final skeleton (the one with
/// the fewest crossings seen) and the report.
///
/// Errors: [`Error::Recipe`] for options out of range, and whatever `mesher` returns.
/// Deterministic when `mesher` is.
pub fn clear_crossings<F>(
    skeleton: &mut Skeleton,
    opts: &ClearOptions,
    mesher: F,
) -> Result<(Mesh, ClearReport)>
where
    F: FnMut(&Skeleton) -> Result<(Mesh, Scheme)>,
{
    clear_crossings_refined(skeleton, opts, mesher).map(|c| (c.control, c.report))
}

/// What [`clear_crossings_refined`] returns.
#[derive(Debug, Clone)]
pub struct Cleared {
    /// The control mesh of the skeleton kept.
    pub control: Mesh,
    /// Its refinement at [`ClearOptions::levels`] by the mesher's scheme (exactly what
    /// [`crate::refine::subdivide`] with those levels and default options gives, so the
    /// pipeline need not refine it again), when it was searched (`None` over
    /// [`ClearOptions::max_faces`]).
    pub refined: Option<Mesh>,
    /// What the pass did.
    pub report: ClearReport,
}

/// [`clear_crossings`], also handing on the refined mesh it searched last.
pub fn clear_crossings_refined<F>(skeleton: &mut Skeleton, opts: &ClearOptions, mesher: F) -> Result<Cleared>
where
    F: FnMut(&Skeleton) -> Result<(Mesh, Scheme)>,
{
    let t0 = Instant::now();
    opts.check()?;
    skeleton.validate()?;
    let (cleared, counts) = crate::mesh::check::memo::scope(|| clear_rounds(skeleton, opts, mesher));
    let mut cleared = cleared?;
    cleared.report.groups_reused = counts.map_or([0, 0], |(hits, misses)| [hits, misses]);
    cleared.report.elapsed = t0.elapsed();
    Ok(cleared)
}

/// The rounds of [`clear_crossings_refined`], inside its memo scope.
fn clear_rounds<F>(skeleton: &mut Skeleton, opts: &ClearOptions, mut mesher: F) -> Result<Cleared>
where
    F: FnMut(&Skeleton) -> Result<(Mesh, Scheme)>,
{
    /// The round with the fewest crossings: (count, radii, start radii, cage, refined
    /// cage, crossing face centres).
    type Best = (usize, Vec<f32>, Vec<Option<f32>>, Mesh, Mesh, Vec<DVec3>);
    raise_to_floor(skeleton, opts.min_radius);
    let floor = floor_of(skeleton, opts.min_radius);
    let initial_radius = skeleton.radius.clone();
    let mut report = ClearReport::default();
    let (mut mesh, scheme) = mesher(skeleton)?;
    let mut best: Option<Best> = None;
    let mut stalled = 0;
    // Narrow thinning first (each face's nearest internode, as in session 8); once it
    // has stalled for `patience` rounds, wide thinning (runner-ups and whole junctions)
    // with the full patience again.
    let mut wide = false;
    let mut search = IncrementalSearch::default();
    while let Some((faces, fine)) = crossing_faces(&mesh, scheme, opts, &mut report.work, &mut search)? {
        report.searched.push([search.stats.triangles, search.stats.searched]);
        // Each round remeshes the whole tree: a cancelled front end stops between rounds.
        crate::cancel::check()?;
        let count = faces.len() / 2;
        if report.before.is_none() {
            report.before = Some(count);
        }
        if best.as_ref().is_none_or(|b| count < b.0) {
            let starts = skeleton.start_radius.clone();
            best = Some((count, skeleton.radius.clone(), starts, mesh.clone(), fine, faces.clone()));
            stalled = 0;
        } else {
            stalled += 1;
        }
        if !wide && stalled >= opts.patience && count > 0 {
            wide = true;
            stalled = 0;
        }
        if count == 0 || report.rounds >= opts.max_rounds || stalled >= opts.patience {
            break;
        }
        let internodes = nearest_internodes(skeleton, &faces, wide);
        let children = skeleton.children();
        let mut cap = vec![f64::INFINITY; skeleton.len()];
        let mut thin = |node: u32| {
            let (r, r0) = (skeleton.radius[node as usize] as f64, initial_radius[node as usize] as f64);
            let c = (opts.step * r).max(opts.min_factor * r0);
            cap[node as usize] = cap[node as usize].min(c);
        };
        for &x in &internodes {
            for node in [x, skeleton.parent[x as usize]] {
                thin(node);
                // A junction's surface (box, blend, hull) is sized by every radius meeting
                // there: thin them all, not only the one the face landed on.
                let kids = children.of(node as usize);
                if wide && kids.len() > 1 {
                    kids.iter().for_each(|&k| thin(k));
                }
            }
        }
        if !apply_caps(skeleton, cap, opts.taper, floor) {
            break;
        }
        report.rounds += 1;
        mesh = mesher(skeleton)?.0;
    }
    let mut refined = None;
    if let Some((count, radius, starts, best_mesh, fine, faces)) = best {
        report.after = Some(count);
        report.truncated = count >= opts.max_pairs;
        skeleton.radius = radius;
        skeleton.start_radius = starts;
        mesh = best_mesh;
        refined = Some(fine);
        if count > 0 {
            let mut left = nearest_internodes(skeleton, &faces, false);
            left.truncate(16);
            report.unresolved = left;
        }
    }
    report.thinned = skeleton.radius.iter().zip(&initial_radius).filter(|(a, b)| a != b).count();
    Ok(Cleared { control: mesh, refined, report })
}

/// Centres of the refined faces that cross another (both faces of each pair, in turn),
/// with the refined mesh, or `None` when the refinement is over
/// [`ClearOptions::max_faces`].
/// The refined faces count against [`ClearOptions::max_work`] (`work`, the pass's
/// total so far) before the refinement is made.
fn crossing_faces(
    mesh: &Mesh,
    scheme: Scheme,
    opts: &ClearOptions,
    work: &mut u64,
    search: &mut IncrementalSearch,
) -> Result<Option<(Vec<DVec3>, Mesh)>> {
    let estimate = mesh.face_count() * 4usize.pow(opts.levels);
    if estimate > opts.max_faces {
        return Ok(None);
    }
    let total = work.saturating_add(estimate as u64);
    if total > opts.max_work {
        return Err(Error::Recipe(format!(
            "`fit.clear.max_work`: the mesh clearing has searched {work} refined faces and its next round needs \
             {estimate} more, over its work budget of {} (raise it with --set fit.clear.max_work=N, lower \
             fit.clear.max_rounds, or turn the pass off with mesh.clear = false)",
            opts.max_work
        )));
    }
    *work = total;
    let fine = if opts.levels == 0 {
        mesh.clone()
    } else {
        let so = SubdivideOptions {
            refine: RefineOptions {
                scheme,
                levels: opts.levels,
                boundary: opts.boundary,
                ..Default::default()
            },
            ..Default::default()
        };
        subdivide(mesh, &[], &so).map_err(|e| match e {
            crate::refine::RefineError::Cancelled { .. } => Error::Cancelled,
            e => Error::InvalidGeometry {
                what: "mesh clearing".into(),
                why: format!("the control mesh does not refine: {e}"),
            },
        })?
    };
    if fine.positions.iter().any(|p| !p.is_finite()) {
        return Err(Error::InvalidGeometry {
            what: "mesh clearing".into(),
            why: "the refined mesh has a non-finite position".into(),
        });
    }
    let pairs = search.crossings(&fine.positions, &fan_triangles(&fine, |_| true), opts.max_pairs);
    let centre = |f: usize| {
        let face = fine.face(f);
        face.iter().map(|&v| fine.positions[v as usize].as_dvec3()).sum::<DVec3>() / face.len() as f64
    };
    let centres = pairs.iter().flat_map(|&[a, b]| [centre(a), centre(b)]).collect();
    Ok(Some((centres, fine)))
}

/// The internodes (by child node, sorted, each once) the crossings of `points` (the two
/// face centres of each crossing pair, in turn) lie on (see the module docs, step 3):
/// each face's nearest internode, and with `runner_ups`, where a pair's two faces are nearest the same
/// internode or two that share a node, each face's second nearest too (one of the two
/// faces then stands out of another internode's surface — a junction box or a fold —
/// and the internode it was made for is likely the runner-up).
fn nearest_internodes(s: &Skeleton, points: &[DVec3], runner_ups: bool) -> Vec<u32> {
    let ranked = ranked_internodes(s, points);
    let touch = |a: u32, b: u32| {
        let (pa, pb) = (s.parent[a as usize], s.parent[b as usize]);
        a == b || pa == b || pb == a || pa == pb
    };
    let mut out = Vec::new();
    for pair in ranked.chunks(2) {
        let firsts: Vec<u32> = pair.iter().filter_map(|r| r[0]).collect();
        out.extend(&firsts);
        if let [a, b] = firsts[..] {
            if runner_ups && touch(a, b) {
                out.extend(pair.iter().filter_map(|r| r[1]));
            }
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// For each of `points`, the internodes (by child node) whose surface lies nearest it,
/// best first (`| distance to the axis − radius there |`, over the internodes whose
/// capsule grown by 1.5 radii contains the point).
fn ranked_internodes(s: &Skeleton, points: &[DVec3]) -> Vec<[Option<u32>; 2]> {
    let seg: Vec<u32> = (0..s.len() as u32).filter(|&i| s.parent[i as usize] != NO_PARENT).collect();
    let ends = |i: u32| {
        let p = s.parent[i as usize] as usize;
        let i = i as usize;
        (s.position[p].as_dvec3(), s.position[i].as_dvec3(), s.radius[p] as f64, s.radius[i] as f64)
    };
    let reach = |i: u32| {
        let (a, b, ra, rb) = ends(i);
        let pad = 2.5 * ra.max(rb);
        Aabb { lo: a.min(b) - pad, hi: a.max(b) + pad }
    };
    let mut boxes = vec![Aabb::EMPTY; s.len()];
    for &i in &seg {
        boxes[i as usize] = reach(i);
    }
    let mut order = seg.clone();
    let nodes = build_bvh(&boxes, &mut order);
    points
        .iter()
        .map(|&p| {
            let q = Aabb { lo: p, hi: p };
            let mut near: Vec<(f64, u32)> = query(&nodes, &order, &q)
                .into_iter()
                .filter(|&i| boxes[i].overlaps(&q))
                .map(|i| {
                    let (a, b, ra, rb) = ends(i as u32);
                    let ab = b - a;
                    let t = if ab.length_squared() > 0.0 {
                        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    let miss = ((p - (a + ab * t)).length() - (ra + (rb - ra) * t)).abs();
                    (miss, i as u32)
                })
                .collect();
            near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            [near.first().map(|x| x.1), near.get(1).map(|x| x.1)]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::sweep::{sweep_mesh, SweepOptions};
    use glam::Vec3;

    /// Two plants side by side whose stems' surfaces overlap by a quarter of their radii
    /// (two roots, so no joint mesher can keep them apart).
    fn grazing_stems() -> Skeleton {
        let mut s = Skeleton::new();
        for x in [0.0f32, 0.3] {
            let root = s.push(Vec3::new(x, 0.0, 0.0), 0.2, NO_PARENT, Vec3::Z, 0);
            let mid = s.push(Vec3::new(x, 1.0, 0.0), 0.2, root, Vec3::Z, 0);
            s.push(Vec3::new(x, 2.0, 0.0), 0.15, mid, Vec3::Z, 0);
        }
        s
    }

    fn sweep(s: &Skeleton) -> Result<(Mesh, Scheme)> {
        Ok((sweep_mesh(s, &SweepOptions { caps: true, ..Default::default() })?.mesh, Scheme::Loop))
    }

    #[test]
    fn a_cancelled_token_stops_the_rounds() {
        let token = crate::cancel::Cancel::new();
        token.cancel();
        let r = crate::cancel::scope(&token, || {
            clear_crossings(&mut grazing_stems(), &ClearOptions::default(), sweep)
        });
        assert!(matches!(r, Err(crate::Error::Cancelled)), "{:?}", r.map(|x| x.1));
    }

    #[test]
    fn a_crossing_mesh_is_thinned_until_clean_and_a_clean_one_is_left_alone() {
        let mut s = grazing_stems();
        let (_, r) = clear_crossings(&mut s, &ClearOptions::default(), sweep).unwrap();
        assert!(r.before.unwrap() > 0, "the stems should cross: {r:?}");
        assert_eq!(r.after, Some(0), "{r:?}");
        assert!(r.thinned > 0 && r.rounds > 0, "{r:?}");
        let start = grazing_stems();
        for (i, (&now, &was)) in s.radius.iter().zip(&start.radius).enumerate() {
            assert!(now <= was && now as f64 >= 0.3 * was as f64 - 1e-6, "node {i}: {now} vs {was}");
        }
        // A clean skeleton: one meshing, nothing changed.
        let before = s.clone();
        let (_, r2) = clear_crossings(&mut s, &ClearOptions::default(), sweep).unwrap();
        assert_eq!((r2.before, r2.after, r2.rounds, r2.thinned), (Some(0), Some(0), 0, 0));
        assert_eq!(s, before);
    }

    #[test]
    fn what_thinning_cannot_clear_is_reported_and_radii_stay_above_the_floor() {
        let mut s = grazing_stems();
        // Axes 0.1 apart: even at 0.3 of their radii (0.06 + 0.06) the stems overlap.
        for i in 3..6 {
            s.position[i].x = 0.1;
        }
        let start = s.clone();
        let o = ClearOptions::default();
        let (mesh, r) = clear_crossings(&mut s, &o, sweep).unwrap();
        assert!(r.after.unwrap() > 0 && !r.unresolved.is_empty(), "{r:?}");
        assert!(r.after <= r.before && r.rounds <= o.max_rounds, "{r:?}");
        for (&now, &was) in s.radius.iter().zip(&start.radius) {
            assert!(now as f64 >= o.min_factor * was as f64 * (1.0 - 1e-6), "{now} vs {was}");
        }
        assert_eq!(mesh, sweep(&s).unwrap().0, "the mesh returned is the kept skeleton's");
    }

    /// Plants with a stem of four internodes and a side branch each, at random spots of
    /// a small plot (so some graze each other).
    fn random_plants(seed: u64) -> Skeleton {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut s = Skeleton::new();
        for _ in 0..6 {
            let base = Vec3::new(rng.random::<f32>() * 1.2, 0.0, rng.random::<f32>() * 1.2);
            let r = 0.06 + 0.06 * rng.random::<f32>();
            let mut at = s.push(base, r, NO_PARENT, Vec3::Z, 0);
            for k in 1..5 {
                let p =
                    base + Vec3::new(0.1 * rng.random::<f32>(), 0.5 * k as f32, 0.1 * rng.random::<f32>());
                at = s.push(p, r * (1.0 - 0.15 * k as f32), at, Vec3::Z, 0);
                if k == 2 {
                    let side =
                        p + Vec3::new(0.4 * rng.random::<f32>() - 0.2, 0.3, 0.4 * rng.random::<f32>() - 0.2);
                    s.push(side, 0.5 * r, at, Vec3::Z, 1);
                }
            }
        }
        s
    }

    #[test]
    fn every_round_finds_what_a_full_search_finds() {
        use crate::mesh::check::self_intersections;
        use crate::mesh::quad::{quad_mesh, QuadOptions};
        let quad = |s: &Skeleton| -> Result<(Mesh, Scheme)> {
            Ok((quad_mesh(s, &QuadOptions::default())?.mesh, Scheme::CatmullClark))
        };
        let mut incremental_rounds = 0;
        for seed in 0..6 {
            for (name, mesher) in
                [("sweep", &sweep as &dyn Fn(&Skeleton) -> Result<(Mesh, Scheme)>), ("quad", &quad)]
            {
                let opts = ClearOptions { levels: 1, ..Default::default() };
                let mut meshes = Vec::new();
                let (_, r) = clear_crossings(&mut random_plants(seed), &opts, |s| {
                    let m = mesher(s)?;
                    meshes.push(m.clone());
                    Ok(m)
                })
                .unwrap();
                // The same meshes again: every search equals a full one.
                let mut search = IncrementalSearch::default();
                let mut work = 0;
                for (round, (m, scheme)) in meshes.iter().enumerate().take(r.searched.len()) {
                    let before = search.stats;
                    let (faces, fine) =
                        crossing_faces(m, *scheme, &opts, &mut work, &mut search).unwrap().unwrap();
                    let full =
                        self_intersections(&fine.positions, &fan_triangles(&fine, |_| true), opts.max_pairs);
                    let centre = |f: usize| {
                        let face = fine.face(f);
                        face.iter().map(|&v| fine.positions[v as usize].as_dvec3()).sum::<DVec3>()
                            / face.len() as f64
                    };
                    let want: Vec<DVec3> = full.iter().flat_map(|&[a, b]| [centre(a), centre(b)]).collect();
                    assert_eq!(faces, want, "seed {seed} {name} round {round}");
                    assert_eq!([search.stats.triangles, search.stats.searched], r.searched[round]);
                    if round > 0 && !search.stats.full {
                        incremental_rounds += 1;
                        assert!(
                            search.stats.searched < search.stats.triangles,
                            "{before:?} {:?}",
                            search.stats
                        );
                    }
                }
            }
        }
        assert!(incremental_rounds > 3, "the plants should need rounds: {incremental_rounds}");
    }

    #[test]
    fn bad_options_are_errors() {
        let mut s = grazing_stems();
        for o in [
            ClearOptions { step: 1.0, ..Default::default() },
            ClearOptions { step: f64::NAN, ..Default::default() },
            ClearOptions { min_factor: 0.0, ..Default::default() },
            ClearOptions { taper: -1.0, ..Default::default() },
            ClearOptions { levels: 9, ..Default::default() },
            ClearOptions { max_pairs: 0, ..Default::default() },
            ClearOptions { min_radius: 2.0, ..Default::default() },
            ClearOptions { min_radius: f64::NAN, ..Default::default() },
        ] {
            let e = clear_crossings(&mut s, &o, sweep).unwrap_err();
            assert!(e.to_string().contains("fit.clear."), "{e}");
        }
    }
}
