//! The sweep mesher: a triangle control mesh for Loop subdivision made of hexagonal
//! cross-sections swept along every internode and joined at branch points by junction
//! templates, after MacMurchy2004 §5.2–§5.5.3 and §A.3 as distilled by MacMurchy2004-spec
//! §2.2–§2.8.
//!
//! [`sweep_mesh`] runs nine steps: graph, segment-length adjustment ([`pair_offsets`],
//! [`guarded_offsets`]), hexagonal rings, twist and bend rings, junction templates
//! (coplanar or general), the asymmetric collar, repair and fallbacks, ends, UVs;
//! `docs/meshers.md` ("sweep", "Construction") describes each. Output: triangles only,
//! counter-clockwise seen from outside, a 2-manifold; never a panic.

use crate::error::{Error, Result};
use crate::geometry::Mesh;
use crate::mesh::check::{group_crossings, surface_faults, CheckOptions};
use crate::skeleton::Skeleton;
use glam::DVec3;
use std::collections::HashSet;
use std::f64::consts::{FRAC_PI_3, PI};

use crate::geometry::NONE;

mod build;
mod plan;

use self::build::build;
pub(crate) use self::plan::{collapse_short, perpendicular, unit_or, Collapsed};

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
        let (mesh, owner, twist, loops) = build(&plan, opts, &fallback)?;
        if round >= opts.repair_rounds || mesh.face_count() == 0 {
            break (mesh, owner, twist, loops);
        }
        round += 1;
        crate::cancel::check()?;
        // Only the crossings and degenerate faces are needed, not the topology.
        let faults =
            surface_faults(&mesh, &CheckOptions { max_intersections: 1_000_000, ..Default::default() });
        let intersections = faults.intersections.map(|found| found.pairs).unwrap_or_default();
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
        for &[f, g] in &intersections {
            let local =
                owner[f].iter().any(|&a| a != NONE && owner[g].iter().any(|&b| b != NONE && near(a, b)));
            if local {
                mark(f, &mut bad);
                mark(g, &mut bad);
            }
        }
        for &f in &faults.degenerate {
            mark(f, &mut bad);
        }
        // A clean control mesh: check the templates once more after refinement.
        let refined_only = bad.is_empty();
        if refined_only {
            crate::cancel::check()?;
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
    // A refinement stopped by the token leaves a mesh the rounds did not finish.
    crate::cancel::check()?;
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
    use super::build::max_min_angle;
    use super::plan::fit_normal;
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
