//! Growing a tree: the recursion of stems over levels, segments, splits, child
//! placement, pruning and attraction, written into the [`Skeleton`](crate::Skeleton)
//! (WeberPenn1995 §4.1–§4.7; see `docs/weber-penn.md` for where sylva reads it
//! differently).

use super::curves::{flare_factor, shape_ratio, taper_radius, BezierSegment};
use super::leaf::{leaf_outline, LeafOutline};
use super::params::WeberPennParams;
use super::{
    Stem, WeberPennReport, WeberPennTree, HELIX_STEPS, MAX_LEAVES, MAX_NODES, MAX_STATIONS, MAX_STEMS,
    SNAP_RADII,
};
use crate::error::{Error, Result};
use crate::skeleton::{Organ, OrganKind, Skeleton, NO_PARENT};
use glam::{DQuat, DVec3, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::{PI, TAU};
use std::time::Instant;

/// Grows the tree of `params` with `seed`. Deterministic: the same parameters and seed
/// give the same tree, bit for bit.
///
/// Errors: [`Error::Recipe`] for invalid parameters or a tree over the budgets
/// ([`MAX_STEMS`], [`MAX_LEAVES`], [`MAX_NODES`]), naming the key to lower.
pub fn grow(params: &WeberPennParams, seed: u64) -> Result<WeberPennTree> {
    let t0 = Instant::now();
    params.validate()?;
    let mut rng = Pcg64::seed_from_u64(seed);
    let scale_tree = params.scale + var(&mut rng, params.scale_v);
    let z_scale = params.z_scale + var(&mut rng, params.z_scale_v);
    // The paper: length_trunk = (0Length ± 0LengthV)·scale_tree; radius = length·Ratio·(0Scale ± 0ScaleV).
    let trunk_length = ((params.n_length[0] + var(&mut rng, params.n_length_v[0])) * scale_tree).max(0.0);
    let trunk_radius =
        trunk_length * params.ratio * (params.n_scale[0] + var(&mut rng, params.n_scale_v[0])).max(0.0);
    let mut g = Grower {
        p: params,
        levels: params.levels as usize,
        scale_tree,
        z_scale,
        min_len: 1e-5 * scale_tree.max(1e-9),
        skeleton: Skeleton::new(),
        stems: Vec::new(),
        report: WeberPennReport { scale_tree, ..Default::default() },
        split_err: [0.0; 4],
        child_err: [0.0; 4],
        leaf_err: 0.0,
        outline: leaf_outline(params.leaf_shape),
    };
    let trunk = Task {
        level: 0,
        parent_stem: None,
        base_node: NO_PARENT,
        origin: DVec3::ZERO,
        frame: Frame::IDENTITY,
        offset: 0.0,
        length: trunk_length,
        // The trunk's radius is given: r = r0·(L/L)^p, limited to r0.
        parent_length: trunk_length,
        parent_radius: trunk_radius,
        radius_limit: trunk_radius,
        length_max: params.n_length[0],
        build_seed: rng.random::<u64>(),
        place_seed: rng.random::<u64>(),
    };
    let mut stack = vec![trunk];
    let mut paths = Vec::new();
    while let Some(task) = stack.pop() {
        g.process(task, &mut stack, &mut paths)?;
    }
    // Everything above is finite by construction; this is the last line of defence
    // against a NaN reaching a file.
    g.skeleton.validate()?;
    g.report.nodes = g.skeleton.len();
    g.report.leaves = g.skeleton.organs.len();
    g.report.elapsed = t0.elapsed();
    Ok(WeberPennTree { skeleton: g.skeleton, stems: g.stems, report: g.report })
}

/// A uniform random number in \[−x, x\] (the paper's `±`).
fn var(rng: &mut Pcg64, x: f64) -> f64 {
    x * (2.0 * rng.random::<f64>() - 1.0)
}

/// Error-diffused rounding (Floyd–Steinberg style, as Arbaro does for fractional counts).
pub(super) fn diffuse(err: &mut f64, x: f64) -> usize {
    let n = (x + *err + 0.5).floor().max(0.0);
    *err -= n - x;
    n as usize
}

/// An orthonormal frame in the paper's coordinates: `z` is the heading, `x × y = z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Frame {
    pub(super) x: DVec3,
    pub(super) y: DVec3,
    pub(super) z: DVec3,
}

impl Frame {
    pub(super) const IDENTITY: Frame = Frame { x: DVec3::X, y: DVec3::Y, z: DVec3::Z };

    /// Rotates the frame about a world axis by `deg` degrees (right-handed).
    fn rot_world(self, axis: DVec3, deg: f64) -> Frame {
        if deg == 0.0 {
            return self;
        }
        let q = DQuat::from_axis_angle(axis, deg.to_radians());
        Frame { x: q * self.x, y: q * self.y, z: q * self.z }
    }

    /// About the local x axis: positive angles turn `z` toward `−y` (down for a child).
    pub(super) fn rot_x(self, deg: f64) -> Frame {
        self.rot_world(self.x, deg)
    }

    fn rot_y(self, deg: f64) -> Frame {
        self.rot_world(self.y, deg)
    }

    pub(super) fn rot_z(self, deg: f64) -> Frame {
        self.rot_world(self.z, deg)
    }

    /// Re-orthonormalizes against rounding drift.
    fn orthonormalized(self) -> Frame {
        let z = self.z.normalize_or(DVec3::Z);
        let x = (self.x - z * self.x.dot(z)).normalize_or(z.any_orthonormal_vector());
        Frame { x, y: z.cross(x), z }
    }
}

/// A stem waiting to be grown.
#[derive(Debug, Clone)]
struct Task {
    level: usize,
    parent_stem: Option<u32>,
    base_node: u32,
    origin: DVec3,
    frame: Frame,
    /// Offset along the parent.
    offset: f64,
    /// Length before pruning.
    length: f64,
    parent_length: f64,
    /// The parent's base radius (RatioPower's reference).
    parent_radius: f64,
    /// The parent's radius at the offset (the child radius limit).
    radius_limit: f64,
    /// `length_child_max` this stem's length was computed with (the children count uses it).
    length_max: f64,
    build_seed: u64,
    place_seed: u64,
}

/// A point of a path after its start.
#[derive(Debug, Clone, Copy)]
struct Pt {
    pos: DVec3,
    dist: f64,
    /// Global segment index.
    seg: u32,
    /// A segment end (or a helix step): a Bézier knot.
    knot: bool,
}

/// One centreline of a stem: the original or a clone.
#[derive(Debug, Clone, Default)]
struct Path {
    /// (path, point index) of the split point; `None` for the original.
    parent: Option<(usize, usize)>,
    start_pos: DVec3,
    start_dist: f64,
    first_seg: usize,
    /// Frame and start position of each segment from `first_seg`.
    frames: Vec<Frame>,
    seg_start: Vec<DVec3>,
    pts: Vec<Pt>,
}

/// A path waiting to grow its next segments.
struct Work {
    path: usize,
    seg: usize,
    frame: Frame,
    pos: DVec3,
    correction: f64,
}

/// Something placed on a stem at a distance: a child's base or a leaf.
#[derive(Debug, Clone, Copy)]
struct Placement {
    path: usize,
    dist: f64,
    pos: DVec3,
    /// The segment frame there.
    seg_frame: Frame,
}

struct Grower<'a> {
    p: &'a WeberPennParams,
    levels: usize,
    scale_tree: f64,
    z_scale: f64,
    min_len: f64,
    skeleton: Skeleton,
    stems: Vec<Stem>,
    report: WeberPennReport,
    split_err: [f64; 4],
    child_err: [f64; 4],
    leaf_err: f64,
    outline: LeafOutline,
}

impl Grower<'_> {
    fn res(&self, level: usize) -> usize {
        self.p.n_curve_res[level].max(1) as usize
    }

    /// paper (x, y, z) → sylva (x, z·ZScale, −y).
    fn to_world(&self, p: DVec3) -> Vec3 {
        Vec3::new(p.x as f32, (p.z * self.z_scale) as f32, (-p.y) as f32)
    }

    /// A direction (tangent) under the same map, normalized.
    fn dir_to_world(&self, d: DVec3) -> Vec3 {
        DVec3::new(d.x, d.z * self.z_scale, -d.y).normalize_or(DVec3::Y).as_vec3()
    }

    /// A normal: the inverse transpose keeps it perpendicular to mapped tangents.
    fn normal_to_world(&self, n: DVec3) -> Vec3 {
        DVec3::new(n.x, n.z / self.z_scale, -n.y).normalize_or(DVec3::X).as_vec3()
    }

    /// Appends a level-`level` skeleton node at stem-space `pos` after `prev`, its up
    /// vector the stem-space normal `normal` (a segment frame's y) mapped to sylva's axes.
    fn push_node(&mut self, pos: DVec3, radius: f64, prev: u32, normal: DVec3, level: usize) -> u32 {
        let up = self.normal_to_world(normal);
        self.skeleton.push(self.to_world(pos), radius as f32, prev, up, level as u16)
    }

    /// The pruning envelope test (the paper's pruning): inside when
    /// `r / scale_tree < PruneWidth · ShapeRatio(8, (scale_tree − z) / (scale_tree·(1 − BaseSize)))`.
    fn inside_envelope(&self, p: DVec3) -> bool {
        let r = (p.x * p.x + p.y * p.y).sqrt();
        let ratio = (self.scale_tree - p.z) / (self.scale_tree * (1.0 - self.p.base_size));
        r / self.scale_tree < self.p.prune_width * shape_ratio(8, ratio, self.p)
    }

    /// The stem's base radius after pruning: the paper's Ratio, RatioPower and the parent limit.
    fn stem_radius(&self, task: &Task, length: f64) -> f64 {
        if task.level == 0 {
            return task.radius_limit;
        }
        let r = task.parent_radius * (length / task.parent_length).powf(self.p.ratio_power);
        if r.is_finite() {
            r.min(task.radius_limit).max(0.0)
        } else {
            task.radius_limit.max(0.0)
        }
    }

    /// Distances along a stem where the radius profile needs a node between segment
    /// ends: the flare zone, a spherical end, periodic bulges.
    fn stations(&self, level: usize, length: f64, radius: f64) -> Vec<f64> {
        let mut st = Vec::new();
        if length <= 0.0 {
            return st;
        }
        if level == 0 && self.p.flare != 0.0 {
            st.extend([1.0 / 32.0, 1.0 / 16.0, 3.0 / 32.0, 1.0 / 8.0].map(|f| f * length));
        }
        let taper = self.p.n_taper[level];
        if taper > 1.0 && radius > 0.0 {
            let unit = if taper <= 2.0 { 2.0 - taper } else { 0.0 };
            let r_end = radius * (1.0 - unit);
            if taper <= 2.0 || r_end * 2.0 >= length {
                // A spherical end of radius ≈ r_end.
                for k in 1..=6 {
                    st.push(length - r_end * (1.0 - (k as f64 * PI / 12.0).cos()));
                }
                st.push(length - r_end);
            } else {
                // Periodic bulges of period 2r, measured from the tip.
                let step = (r_end / 4.0).max(length / MAX_STATIONS as f64);
                let mut d = step;
                while d < length && st.len() < MAX_STATIONS + 8 {
                    st.push(length - d);
                    d += step;
                }
            }
        }
        st.retain(|d| *d > 0.0 && *d < length);
        st.sort_by(f64::total_cmp);
        st.dedup_by(|a, b| (*a - *b).abs() <= 1e-12 * length);
        st
    }

    /// Curving of segment `s` (the paper's curvature): `nCurve/nCurveRes` (or `2·nCurve`, `2·nCurveBack`
    /// per half), plus the split correction, plus a random turn of `nCurveV/nCurveRes`
    /// about a random axis across the stem, plus vertical attraction for levels ≥ 2.
    fn new_direction(&self, f: Frame, s: usize, correction: f64, level: usize, rng: &mut Pcg64) -> Frame {
        let res = self.res(level);
        let resf = res as f64;
        let curve = self.p.n_curve[level];
        let back = self.p.n_curve_back[level];
        let curve_v = self.p.n_curve_v[level];
        // Always draw, so the stream does not depend on the branch taken.
        let dv = var(rng, curve_v.max(0.0)) / resf;
        let rho = (180.0 + var(rng, 180.0)).to_radians();
        if s == 0 {
            return f;
        }
        let mut delta = if back == 0.0 {
            curve / resf
        } else if s < res.div_ceil(2) {
            curve * 2.0 / resf
        } else {
            back * 2.0 / resf
        };
        delta += correction;
        let mut f = f.rot_x(delta);
        if curve_v > 0.0 {
            let axis = (f.x * rho.cos() + f.y * rho.sin()).normalize_or(f.x);
            f = f.rot_world(axis, dv);
        }
        if self.p.attraction_up != 0.0 && level >= 2 {
            // Vertical attraction: curve_up = AttractionUp · declination / nCurveRes, applied in the
            // vertical plane of the heading (the paper's cos(orientation) factor
            // depends on the frame's arbitrary roll; Arbaro drops it too) and never
            // turning past the vertical.
            let decl = f.z.z.clamp(-1.0, 1.0).acos();
            let mut a = self.p.attraction_up * decl / resf;
            a = if a > 0.0 { a.min(decl) } else { a.max(-(PI - decl)) };
            let axis = f.z.cross(DVec3::Z);
            if axis.length_squared() > 1e-18 {
                f = f.rot_world(axis.normalize(), a.to_degrees());
            }
        }
        f.orthonormalized()
    }

    /// The split of one path at the end of segment `s` (the paper's stem splitting): every clone and the
    /// original turn by `max(0, nSplitAngle ± V − declination)` about their x axis, and
    /// the remaining segments turn back by the same total (the split correction);
    /// clones then spread about the vertical: evenly for the trunk's base splits, by
    /// `±(20 + 0.75·(30 + |declination − 90|)·r²)` otherwise.
    #[allow(clippy::too_many_arguments)]
    fn split(
        &self,
        f: Frame,
        s_angle: f64,
        s: usize,
        level: usize,
        base_split: bool,
        correction: &mut f64,
        rng: &mut Pcg64,
    ) -> Frame {
        let remaining = (self.res(level) - s - 1).max(1) as f64;
        let decl = f.z.z.clamp(-1.0, 1.0).acos().to_degrees();
        let angle = (self.p.n_split_angle[level] + var(rng, self.p.n_split_angle_v[level]) - decl).max(0.0);
        let mut f = f.rot_x(angle);
        *correction -= angle / remaining;
        let r = (var(rng, 1.0) + 1.0) / 2.0;
        let side = var(rng, 1.0);
        let spread = var(rng, self.p.n_split_angle_v[level]);
        if s_angle > 0.0 {
            let diverge = if base_split {
                s_angle + spread
            } else {
                let d = 20.0 + 0.75 * (30.0 + (decl - 90.0).abs()) * r * r;
                if side >= 0.0 {
                    -d
                } else {
                    d
                }
            };
            f = f.rot_world(DVec3::Z, diverge);
        }
        f.orthonormalized()
    }

    /// A point of segment `s` (start `start`, frame `f`) at fraction `t`: straight, or
    /// on one helix turn of radius `helix` about the segment.
    fn seg_point(start: DVec3, f: &Frame, seg_len: f64, helix: f64, t: f64) -> DVec3 {
        let mut p = start + f.z * (t * seg_len);
        if helix > 0.0 {
            let a = TAU * t;
            p += (f.x * (a.cos() - 1.0) + f.y * a.sin()) * helix;
        }
        p
    }

    /// Builds the paths (original and clones) of one stem at `length`. With `prune`,
    /// returns the first segment whose points leave the envelope (Arbaro's reading of
    /// the paper's pruning: the test stops there).
    fn build(
        &self,
        task: &Task,
        length: f64,
        prune: bool,
        split_err: &mut f64,
        paths: &mut Vec<Path>,
    ) -> Result<Option<usize>> {
        let level = task.level;
        let res = self.res(level);
        let seg_len = length / res as f64;
        let curve_v = self.p.n_curve_v[level];
        // One helix turn per segment, its tangent leaning |nCurveV| from the axis.
        let helix = if curve_v < 0.0 { (-curve_v).to_radians().tan() * seg_len / TAU } else { 0.0 };
        let radius = self.stem_radius(task, length);
        let stations = self.stations(level, length, radius);
        let nss = self.p.n_seg_splits[level];
        let mut rng = Pcg64::seed_from_u64(task.build_seed);
        paths.clear();
        paths.push(Path { start_pos: task.origin, ..Default::default() });
        let mut work = vec![Work { path: 0, seg: 0, frame: task.frame, pos: task.origin, correction: 0.0 }];
        let mut points = 0usize;
        let mut fractions: Vec<f64> = Vec::new();
        while let Some(w) = work.pop() {
            let Work { path, seg: mut s, mut frame, mut pos, mut correction } = w;
            loop {
                frame = self.new_direction(frame, s, correction, level, &mut rng);
                let s0 = s as f64 * seg_len;
                fractions.clear();
                let lo = stations.partition_point(|d| *d <= s0);
                let hi = stations.partition_point(|d| *d < s0 + seg_len);
                fractions.extend(stations[lo..hi].iter().map(|d| (d - s0) / seg_len));
                if helix > 0.0 {
                    fractions.extend((1..HELIX_STEPS).map(|k| k as f64 / HELIX_STEPS as f64));
                    fractions.sort_by(f64::total_cmp);
                }
                let first_new = paths[path].pts.len();
                {
                    let pa = &mut paths[path];
                    pa.frames.push(frame);
                    pa.seg_start.push(pos);
                    for &t in &fractions {
                        if t <= 1e-6 || t >= 1.0 - 1e-6 {
                            continue;
                        }
                        let knot = helix > 0.0
                            && ((t * HELIX_STEPS as f64).round() - t * HELIX_STEPS as f64).abs() < 1e-9;
                        pa.pts.push(Pt {
                            pos: Self::seg_point(pos, &frame, seg_len, helix, t),
                            dist: s0 + t * seg_len,
                            seg: s as u32,
                            knot,
                        });
                    }
                    let end = Self::seg_point(pos, &frame, seg_len, helix, 1.0);
                    pa.pts.push(Pt { pos: end, dist: s0 + seg_len, seg: s as u32, knot: true });
                    points += pa.pts.len() - first_new;
                }
                if points > MAX_NODES {
                    return Err(Error::Recipe(format!(
                        "`generator.n_curve_res[{level}]`: one level-{level} stem needs more than {MAX_NODES} \
                         skeleton nodes; lower n_curve_res, n_seg_splits or the tapers that add nodes"
                    )));
                }
                if prune && paths[path].pts[first_new..].iter().any(|pt| !self.inside_envelope(pt.pos)) {
                    return Ok(Some(s));
                }
                let end = paths[path].pts.last().map(|p| p.pos).unwrap_or(pos);
                if s + 1 >= res {
                    break;
                }
                let base_split = level == 0 && s == 0 && self.p.base_splits > 0;
                let k = if base_split { self.p.base_splits as usize } else { diffuse(split_err, nss) };
                if k == 0 {
                    pos = end;
                    s += 1;
                    continue;
                }
                if paths.len() + k > MAX_STEMS {
                    let key =
                        if base_split { "base_splits".into() } else { format!("n_seg_splits[{level}]") };
                    return Err(Error::Recipe(format!(
                        "`generator.{key}`: one level-{level} stem splits into more than {MAX_STEMS} clones; lower it"
                    )));
                }
                let s_angle = 360.0 / (k + 1) as f64;
                let split_pt = paths[path].pts.len() - 1;
                let mut clones = Vec::with_capacity(k);
                for i in 1..=k {
                    let mut c = correction;
                    let cf = self.split(frame, s_angle * i as f64, s, level, base_split, &mut c, &mut rng);
                    paths.push(Path {
                        parent: Some((path, split_pt)),
                        start_pos: end,
                        start_dist: s0 + seg_len,
                        first_seg: s + 1,
                        ..Default::default()
                    });
                    clones.push(Work {
                        path: paths.len() - 1,
                        seg: s + 1,
                        frame: cf,
                        pos: end,
                        correction: c,
                    });
                }
                frame = self.split(frame, 0.0, s, level, base_split, &mut correction, &mut rng);
                work.push(Work { path, seg: s + 1, frame, pos: end, correction });
                work.extend(clones.into_iter().rev());
                break;
            }
        }
        Ok(None)
    }

    /// Grows one stem: pruning, the final build, its children and leaves, and its nodes.
    fn process(&mut self, task: Task, stack: &mut Vec<Task>, paths: &mut Vec<Path>) -> Result<()> {
        let level = task.level;
        let res = self.res(level);
        let mut length = task.length;
        if length <= self.min_len {
            return Ok(());
        }
        // Pruning: rebuild the same stem (same random numbers) shorter until every
        // point is inside the envelope, then blend with the original by PruneRatio.
        if level >= 1 && self.p.prune_ratio > 0.0 {
            let orig = length;
            let mut len = length;
            loop {
                let mut e = self.split_err[level];
                match self.build(&task, len, true, &mut e, paths)? {
                    None => break,
                    Some(seg) => {
                        let seg_len = len / res as f64;
                        let next = (seg_len * seg as f64).max(len / 2.0).min(len - orig / 15.0);
                        if next <= self.min_len {
                            len = 0.0;
                            break;
                        }
                        len = next;
                    }
                }
            }
            length = orig - (orig - len) * self.p.prune_ratio;
            if length <= self.min_len {
                return Ok(());
            }
        }
        let mut err = self.split_err[level];
        self.build(&task, length, false, &mut err, paths)?;
        self.split_err[level] = err;
        let radius = self.stem_radius(&task, length);
        let seg_len = length / res as f64;
        let helix = {
            let cv = self.p.n_curve_v[level];
            if cv < 0.0 {
                (-cv).to_radians().tan() * seg_len / TAU
            } else {
                0.0
            }
        };
        let flare = if level == 0 { self.p.flare } else { 0.0 };
        let taper = self.p.n_taper[level];
        let radius_at = |d: f64| {
            let z = if length > 0.0 { d / length } else { 0.0 };
            taper_radius(taper, radius, length, z) * flare_factor(flare, z)
        };

        // Segment instances: the paths that cover each segment index.
        let mut instances: Vec<Vec<usize>> = vec![Vec::new(); res];
        for (pi, pa) in paths.iter().enumerate() {
            for (s, inst) in instances.iter_mut().enumerate().skip(pa.first_seg) {
                if s < pa.first_seg + pa.frames.len() {
                    inst.push(pi);
                }
            }
        }
        let mut rr = vec![0usize; res];
        let place = |t: f64, rr: &mut Vec<usize>| -> Placement {
            let s = ((t / seg_len).floor().max(0.0) as usize).min(res - 1);
            let inst = &instances[s];
            let path = inst[rr[s] % inst.len()];
            rr[s] += 1;
            let pa = &paths[path];
            let i = s - pa.first_seg;
            let f = pa.frames[i];
            let frac = ((t - s as f64 * seg_len) / seg_len).clamp(0.0, 1.0);
            Placement {
                path,
                dist: t,
                pos: Self::seg_point(pa.seg_start[i], &f, seg_len, helix, frac),
                seg_frame: f,
            }
        };
        let mut prng = Pcg64::seed_from_u64(task.place_seed);
        let start = if level == 0 { self.p.base_size * length } else { task.radius_limit.min(0.5 * length) };
        let span = (length - start).max(0.0);

        // Children: the paper's count, spacing, rotation, down angle, length and radius.
        let mut children: Vec<(Placement, Task)> = Vec::new();
        if level + 1 < self.levels {
            let cl = level + 1;
            let lcm = (self.p.n_length[cl] + var(&mut prng, self.p.n_length_v[cl])).max(0.0);
            let stems_max = self.p.n_branches[cl] as f64;
            let n = if level == 0 {
                stems_max
            } else if task.length_max > 0.0 && task.parent_length > 0.0 {
                stems_max * (0.2 + 0.8 * (length / task.parent_length) / task.length_max)
            } else {
                0.2 * stems_max
            };
            let count = diffuse(&mut self.child_err[cl], n);
            let base_len = self.p.base_size * self.scale_tree;
            self.spaced(cl, (level, length), (start, span), count, &mut prng, |t, angle, down, prng| {
                let pl = place(t, &mut rr);
                let child_len = if cl == 1 {
                    let denom = length - base_len;
                    let ratio = if denom > 0.0 { ((length - t) / denom).clamp(0.0, 1.0) } else { 0.0 };
                    length * lcm * shape_ratio(self.p.shape, ratio, self.p)
                } else {
                    lcm * (length - 0.6 * t)
                }
                .max(0.0);
                let build_seed = prng.random::<u64>();
                let place_seed = prng.random::<u64>();
                if child_len <= self.min_len {
                    return;
                }
                let frame = pl.seg_frame.rot_z(angle).rot_x(down).orthonormalized();
                children.push((
                    pl,
                    Task {
                        level: cl,
                        parent_stem: None,
                        base_node: NO_PARENT,
                        origin: pl.pos,
                        frame,
                        offset: t,
                        length: child_len,
                        parent_length: length,
                        parent_radius: radius,
                        radius_limit: radius_at(t),
                        length_max: lcm,
                        build_seed,
                        place_seed,
                    },
                ));
            });
        }

        // Leaves on the last level (the paper's Leaves, placed like children).
        let mut leaves: Vec<(Placement, Frame)> = Vec::new();
        if level + 1 == self.levels && self.p.leaves != 0 {
            let ll = self.p.leaf_level();
            let per = self.p.leaves.unsigned_abs() as f64
                * self.p.leaf_quality
                * if level == 0 || task.parent_length <= 0.0 {
                    1.0
                } else {
                    shape_ratio(4, (task.offset / task.parent_length).clamp(0.0, 1.0), self.p)
                };
            if self.p.leaves > 0 {
                let count = diffuse(&mut self.leaf_err, per);
                self.leaf_budget(count)?;
                self.spaced(ll, (level, length), (start, span), count, &mut prng, |t, angle, down, _| {
                    let pl = place(t, &mut rr);
                    leaves.push((pl, pl.seg_frame.rot_z(angle).rot_x(down)));
                });
            } else {
                // A fan at every tip (each path's last segment end).
                let cnt = (per + 0.5).floor() as usize;
                self.leaf_budget(cnt.saturating_mul(paths.len()))?;
                let dist_angle = if cnt > 0 { self.p.n_rotate[ll] / cnt as f64 } else { 0.0 };
                let var_angle = if cnt > 0 { self.p.n_rotate_v[ll] / cnt as f64 } else { 0.0 };
                for (pi, pa) in paths.iter().enumerate() {
                    let (Some(f), Some(tip)) = (pa.frames.last(), pa.pts.last()) else { continue };
                    let pl = Placement { path: pi, dist: length, pos: tip.pos, seg_frame: *f };
                    let offset_angle = if cnt % 2 == 1 {
                        leaves.push((pl, *f));
                        dist_angle
                    } else {
                        dist_angle / 2.0
                    };
                    for s in 0..cnt / 2 {
                        for side in [1.0, -1.0] {
                            let a = side * (offset_angle + s as f64 * dist_angle + var(&mut prng, var_angle));
                            let down = self.p.n_down_angle[ll] + var(&mut prng, self.p.n_down_angle_v[ll]);
                            leaves.push((pl, f.rot_y(a).rot_x(down)));
                        }
                    }
                }
            }
        }

        // Nodes: every path's points merged with the child bases on it.
        let stem_records = self.stems.len() as u32;
        if self.stems.len() + paths.len() > MAX_STEMS {
            return Err(Error::Recipe(format!(
                "`generator.n_branches[{level}]`: the tree would have more than {MAX_STEMS} stems; lower the \
                 branch counts or n_seg_splits"
            )));
        }
        let total_pts: usize = paths.iter().map(|p| p.pts.len()).sum::<usize>() + children.len() + 1;
        if self.skeleton.len() + total_pts > MAX_NODES {
            return Err(Error::Recipe(format!(
                "`generator.n_branches[{level}]`: the tree would have more than {MAX_NODES} skeleton nodes; lower \
                 the branch counts or n_curve_res"
            )));
        }
        let mut by_path: Vec<Vec<usize>> = vec![Vec::new(); paths.len()];
        for (ci, (pl, _)) in children.iter().enumerate() {
            by_path[pl.path].push(ci);
        }
        let mut child_node = vec![NO_PARENT; children.len()];
        // Where each child's base ends up: a child within `snap` of a node on its path
        // hangs on that node and starts there (no stub internodes, which lie inside the
        // joint and fold the meshers' tubes).
        let mut child_origin: Vec<Option<(DVec3, f64)>> = vec![None; children.len()];
        let snap = |d: f64| SNAP_RADII * radius_at(d);
        // Per path: (distance, node) of every node on it, base included.
        let mut path_nodes: Vec<Vec<(f64, u32)>> = Vec::with_capacity(paths.len());
        let mut point_node: Vec<Vec<u32>> = Vec::with_capacity(paths.len());
        let eps = 1e-9 * length.max(1e-12);
        for (pi, pa) in paths.iter().enumerate() {
            let first = self.skeleton.len() as u32;
            let base = match pa.parent {
                None if level == 0 => self.push_node(task.origin, radius_at(0.0), NO_PARENT, task.frame.y, 0),
                None => task.base_node,
                Some((pp, pt)) => point_node[pp][pt],
            };
            let mut nodes = vec![(pa.start_dist, base)];
            let mut pn = Vec::with_capacity(pa.pts.len());
            let mut list = std::mem::take(&mut by_path[pi]);
            list.sort_by(|a, b| children[*a].0.dist.total_cmp(&children[*b].0.dist));
            let mut li = 0;
            let mut pt_i = 0;
            let mut prev = base;
            let mut prev_dist = pa.start_dist;
            let mut prev_pos = match pa.parent {
                None => task.origin,
                Some((pp, pt)) => paths[pp].pts[pt].pos,
            };
            loop {
                let child_dist = list.get(li).map(|&c| children[c].0.dist);
                let pt = pa.pts.get(pt_i);
                let child_first = match (pt, child_dist) {
                    (None, None) => break,
                    (None, Some(_)) => true,
                    (Some(_), None) => false,
                    // A child just before the next point waits for it when nearer to
                    // it than to the previous node.
                    (Some(pt), Some(cd)) => {
                        cd < pt.dist - eps && (cd < pt.dist - snap(cd) || cd - prev_dist <= pt.dist - cd)
                    }
                };
                if child_first {
                    let ci = list[li];
                    let pl = children[ci].0;
                    if pl.dist <= prev_dist + snap(pl.dist).max(eps) {
                        child_node[ci] = prev;
                        child_origin[ci] = Some((prev_pos, prev_dist));
                    } else {
                        let n = self.push_node(pl.pos, radius_at(pl.dist), prev, pl.seg_frame.y, level);
                        nodes.push((pl.dist, n));
                        prev = n;
                        prev_dist = pl.dist;
                        prev_pos = pl.pos;
                        child_node[ci] = n;
                    }
                    li += 1;
                    continue;
                }
                let Some(pt) = pt else { break };
                let f = pa.frames[pt.seg as usize - pa.first_seg];
                let n = self.push_node(pt.pos, radius_at(pt.dist), prev, f.y, level);
                pn.push(n);
                nodes.push((pt.dist, n));
                prev = n;
                prev_dist = pt.dist;
                prev_pos = pt.pos;
                pt_i += 1;
                // Children at this very point (or waiting for it) hang on it.
                while li < list.len() && children[list[li]].0.dist <= pt.dist + eps {
                    child_node[list[li]] = n;
                    child_origin[list[li]] = Some((pt.pos, pt.dist));
                    li += 1;
                }
            }
            let last = self.skeleton.len() as u32;
            // The record.
            let stem_index = self.stems.len() as u32;
            let parent_stem = match pa.parent {
                None => task.parent_stem,
                Some((pp, _)) => Some(stem_records + pp as u32),
            };
            self.stems.push(Stem {
                level: level as u8,
                parent_stem,
                clone_of: if pi == 0 { None } else { Some(stem_records) },
                offset: task.offset as f32,
                start: pa.start_dist as f32,
                length: length as f32,
                curve: self.bezier(pa),
                radius_base: radius as f32,
                radius_tip: taper_radius(taper, radius, length, 1.0) as f32,
                taper: taper as f32,
                flare: flare as f32,
                lobes: if level == 0 { self.p.lobes } else { 0 },
                lobe_depth: if level == 0 { self.p.lobe_depth as f32 } else { 0.0 },
                nodes: first..last,
            });
            debug_assert_eq!(stem_index, stem_records + pi as u32);
            if pi == 0 {
                self.report.stems_per_level[level] += 1;
            } else {
                self.report.clones_per_level[level] += 1;
            }
            path_nodes.push(nodes);
            point_node.push(pn);
        }

        // Leaves as organs.
        for (pl, frame) in leaves {
            let nodes = &path_nodes[pl.path];
            // The last node at or before the leaf, never the parent's node the path
            // starts on when the path has nodes of its own.
            let k = nodes.partition_point(|(d, _)| *d <= pl.dist + eps).max(2) - 1;
            let node = nodes[k.min(nodes.len() - 1)].1;
            let f = self.bend_leaf(frame, pl.pos);
            let organ = self.leaf_organ(&f, pl.pos, node);
            self.skeleton.organs.push(organ);
        }

        // Children, pushed so that they pop in order (depth first, parents first).
        for (ci, (pl, mut t)) in children.into_iter().enumerate().rev() {
            t.base_node = child_node[ci];
            if let Some((origin, dist)) = child_origin[ci] {
                // Hung on a node further up: limited by the parent's radius there.
                t.origin = origin;
                t.radius_limit = t.radius_limit.min(radius_at(dist));
            }
            t.parent_stem = Some(stem_records + pl.path as u32);
            stack.push(t);
        }
        Ok(())
    }

    /// Refuses `more` leaves beyond [`MAX_LEAVES`] before they are made.
    fn leaf_budget(&self, more: usize) -> Result<()> {
        if self.skeleton.organs.len().saturating_add(more) > MAX_LEAVES {
            return Err(Error::Recipe(format!(
                "`generator.leaves`: the tree would have more than {MAX_LEAVES} leaves; lower leaves, \
                 leaf_quality or n_branches"
            )));
        }
        Ok(())
    }

    /// Places `count` children or leaves of level `lvl` on a `(level, length)` stem,
    /// evenly over its `(start, span)`, as the paper places both: `each` gets the
    /// offset `t` along the stem, the running rotation about it and the down angle (both
    /// drawn from `prng`, which `each` may go on drawing from).
    fn spaced(
        &self,
        lvl: usize,
        (level, length): (usize, f64),
        (start, span): (f64, f64),
        count: usize,
        prng: &mut Pcg64,
        mut each: impl FnMut(f64, f64, f64, &mut Pcg64),
    ) {
        let mut rot = RotateState::default();
        for k in 0..count {
            let t = start + (k as f64 + 0.5) * span / count as f64;
            let angle = rot.next(self.p.n_rotate[lvl], self.p.n_rotate_v[lvl], prng);
            let down = self.down_angle(lvl, level, length, t, prng);
            each(t, angle, down, prng);
        }
    }

    /// `nDownAngle ± nDownAngleV`, or for negative `nDownAngleV` the paper's variation
    /// along the parent: `nDownAngle + nDownAngleV·(1 − 2·ShapeRatio(0, (L − t)/(L − base)))`.
    fn down_angle(&self, cl: usize, level: usize, length: f64, t: f64, rng: &mut Pcg64) -> f64 {
        let d = self.p.n_down_angle[cl];
        let v = self.p.n_down_angle_v[cl];
        let r = var(rng, v.abs());
        if v >= 0.0 {
            return d + r;
        }
        let len = if level == 0 { length * (1.0 - self.p.base_size) } else { length };
        let ratio = if len > 0.0 { ((length - t) / len).clamp(0.0, 1.0) } else { 0.0 };
        d + v * (1.0 - 2.0 * shape_ratio(0, ratio, self.p))
    }

    /// LeafBend: turn the leaf about the vertical so its normal faces away from
    /// the trunk, then tilt the normal toward the sky, each by the fraction LeafBend.
    fn bend_leaf(&self, f: Frame, pos: DVec3) -> Frame {
        let b = self.p.leaf_bend;
        if b == 0.0 {
            return f;
        }
        // The signed angle from the normal's azimuth to the position's, in (−π, π].
        let n = f.y;
        let t = (n.x * pos.y - n.y * pos.x).atan2(n.x * pos.x + n.y * pos.y);
        let f = f.rot_world(DVec3::Z, (b * t).to_degrees());
        let n = f.y;
        let phi = n.z.clamp(-1.0, 1.0).acos();
        let axis = n.cross(DVec3::Z);
        if axis.length_squared() > 1e-18 {
            f.rot_world(axis.normalize(), (b * phi).to_degrees())
        } else {
            f
        }
    }

    /// A leaf organ: the outline of `LeafShape` in the leaf frame (midrib along `z`,
    /// width along `x`, normal `y`), scaled by LeafScale and LeafScaleX.
    fn leaf_organ(&self, f: &Frame, pos: DVec3, node: u32) -> Organ {
        let len = self.p.leaf_scale / self.p.leaf_quality.sqrt();
        let wid = len * self.p.leaf_scale_x;
        let map = |(u, w): (f64, f64)| self.to_world(pos + f.x * (u * wid) + f.z * (w * len));
        let mut verts = Vec::with_capacity(self.outline.points.len() + 2);
        if let Some(c) = self.outline.center {
            verts.push(map(c));
            verts.extend(self.outline.points.iter().map(|p| map(*p)));
            if let Some(p0) = self.outline.points.first() {
                verts.push(map(*p0));
            }
        } else {
            verts.extend(self.outline.points.iter().map(|p| map(*p)));
        }
        Organ {
            kind: OrganKind::Polygon(verts),
            node,
            position: self.to_world(pos),
            heading: self.dir_to_world(f.z),
            up: self.normal_to_world(f.y),
            size: len as f32,
            material: 0,
        }
    }

    /// The path's centreline as cubic Bézier segments through its knots (segment ends,
    /// or helix steps), with Catmull–Rom tangents (one-sided at the ends).
    fn bezier(&self, pa: &Path) -> Vec<BezierSegment> {
        let mut k: Vec<DVec3> = Vec::with_capacity(pa.pts.len() + 1);
        k.push(pa.start_pos);
        k.extend(pa.pts.iter().filter(|p| p.knot).map(|p| p.pos));
        let n = k.len();
        let mut out = Vec::with_capacity(n.saturating_sub(1));
        if n < 2 {
            return out;
        }
        let tangent = |i: usize| -> DVec3 {
            let (a, b) = if i == 0 {
                (k[0], k[1])
            } else if i == n - 1 {
                (k[n - 2], k[n - 1])
            } else {
                (k[i - 1], k[i + 1])
            };
            (b - a).normalize_or_zero()
        };
        for i in 0..n - 1 {
            let h = k[i].distance(k[i + 1]) / 3.0;
            let p1 = k[i] + tangent(i) * h;
            let p2 = k[i + 1] - tangent(i + 1) * h;
            out.push(BezierSegment {
                points: [self.to_world(k[i]), self.to_world(p1), self.to_world(p2), self.to_world(k[i + 1])],
            });
        }
        out
    }
}

/// The running rotation of successive children about their parent (the paper's nRotate): `nRotate`
/// accumulates; a negative `nRotate` alternates sides by `±(180 + nRotate)`.
#[derive(Debug, Default)]
struct RotateState {
    angle: f64,
    side: f64,
}

impl RotateState {
    fn next(&mut self, rotate: f64, rotate_v: f64, rng: &mut Pcg64) -> f64 {
        let v = var(rng, rotate_v);
        if rotate >= 0.0 {
            self.angle = (self.angle + rotate + v).rem_euclid(360.0);
            self.angle
        } else {
            self.side = if self.side == -1.0 { 1.0 } else { -1.0 };
            self.side * (180.0 + rotate + v)
        }
    }
}
