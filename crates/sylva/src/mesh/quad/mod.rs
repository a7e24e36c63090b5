//! The quad mesher: one all-quad, watertight control cage for a whole [`Skeleton`], with
//! SMART-style junction boxes at branching nodes, ready for Catmull–Clark subdivision.
//!
//! This implements Skjermo2008's junction paper (Skjermo & Eidheim 2005, "Polygon mesh
//! generation of branching structures", **J §3.2–§3.5**, Eq. 4) as pinned down by
//! Skjermo2008-spec §2 (Felkel2004's SMART). The Catmull–Clark step is
//! [`crate::refine::subdivide`] with
//! [`Scheme::CatmullClark`](crate::refine::Scheme::CatmullClark), run by the caller.
//! `docs/meshers.md` ("quad", "Construction") has the sections, the four cases, the
//! choices where the seed is silent, the local fallbacks, the repair and the UVs.

use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::{Skeleton, NO_PARENT};
use glam::{Vec2, Vec3};

/// A side child closer than this to the first child's direction is aligned with it:
/// beyond [`QuadOptions::max_side_angle`] it is detached, not elbowed (degrees).
const ALIGNED_DEG: f32 = 10.0;

/// A child closer than this to the reversed parent direction runs back inside the
/// parent's tube: beyond [`QuadOptions::max_side_angle`] it is detached (degrees).
const REVERSED_DEG: f32 = 2.0;

// No node.
use crate::geometry::NONE;

mod builder;
mod repair;

use self::repair::repair;

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
        let o = self;
        // (name, value, whether it is in range, the range as said)
        for (name, v, ok, range) in [
            ("cs_scale", o.cs_scale, o.cs_scale > 0.0 && o.cs_scale <= 100.0, "(0, 100]"),
            (
                "max_side_angle",
                o.max_side_angle,
                (10.0..=89.0).contains(&o.max_side_angle),
                "10..=89 degrees",
            ),
            (
                "max_back_angle",
                o.max_back_angle,
                (90.0..=150.0).contains(&o.max_back_angle),
                "90..=150 degrees",
            ),
            ("min_radius", o.min_radius, (1e-6..=1.0).contains(&o.min_radius), "1e-6..=1"),
            ("min_length", o.min_length, (1e-4..=10.0).contains(&o.min_length), "1e-4..=10"),
            ("elbow_angle", o.elbow_angle, (0.0..=90.0).contains(&o.elbow_angle), "0..=90 degrees"),
            ("support", o.support, (0.0..=10.0).contains(&o.support), "0..=10"),
        ] {
            if !(v.is_finite() && ok) {
                return bad(format!("{name} = {v}; it must be in {range}"));
            }
        }
        for (name, v, range) in [
            ("max_chain", u64::from(o.max_chain), 0..=16),
            ("repair_rounds", u64::from(o.repair_rounds), 0..=16),
            ("check_levels", u64::from(o.check_levels), 1..=3),
            ("max_repair_work", o.max_repair_work, 1..=MAX_REPAIR_WORK),
        ] {
            if !range.contains(&v) {
                return bad(format!("{name} = {v}; it must be in {}..={}", range.start(), range.end()));
            }
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
        // Checked per internode in `drain`, which stops early when cancelled.
        crate::cancel::check()?;
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
                    // A refinement stopped by the token is no finished round.
                    crate::cancel::check()?;
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
