//! [`hull_mesh`]: steps 4–7 of the hull mesher in one pass over the simplified graph —
//! branch segments (Pieterse2012 §4.2.2, Algorithm 1), joints (§4.2.3), UVs (§4.3.2–
//! §4.3.3) and caps. It stays one function: every step reads the previous one's tables.

use super::joint::{flip_slivers, hull_joint, root_base};
use super::simplify::Work;
use super::uv::joint_uvs;
use super::{BranchSpan, Emit, Geo, HullMesh, HullOptions, JointKind, JointSpan, LoopRef, Plan, NONE};
use crate::error::{Error, Result};
use crate::geometry::{FaceVarying, Mesh};
use crate::skeleton::Skeleton;
use glam::{DQuat, Vec2};
use std::f64::consts::{PI, TAU};

/// Meshes `skeleton` with convex-hull joints (see the module docs).
///
/// Errors: [`Error::InvalidGeometry`] for options out of range or a mesh beyond `u32`
/// indices; [`Error::Skeleton`] when the skeleton fails [`Skeleton::validate`].
/// Joints that cannot be meshed fall back locally and are reported, never an error.
pub fn hull_mesh(skeleton: &Skeleton, opts: &HullOptions) -> Result<HullMesh> {
    opts.check()?;
    skeleton.validate()?;
    let work = Work::new(skeleton, opts);
    let n = work.n;
    let s = opts.sides;
    let su = s as usize;

    // Live branches, their slots and frames (parent-first, so parents come first).
    let mut slot = vec![NONE; n];
    let mut geo: Vec<Geo> = Vec::new();
    for b in 0..n {
        if !work.branch[b] {
            continue;
        }
        slot[b] = geo.len() as u32;
        let len = work.len(b);
        let d = (work.end[b] - work.start[b]) / len;
        let pj = work.start_joint[b] as usize;
        let seed = if work.branch[pj] {
            let pg = &geo[slot[pj] as usize];
            DQuat::from_rotation_arc(pg.d, d) * pg.u
        } else {
            skeleton.up[b].as_dvec3()
        };
        let mut u = seed - d * seed.dot(d);
        u = if u.length_squared() > 1e-12 { u.normalize() } else { d.any_orthonormal_vector() };
        let wv = d.cross(u);
        geo.push(Geo {
            node: b as u32,
            start: work.start[b],
            d,
            len,
            r0: work.r0[b],
            r1: work.r1[b],
            u,
            w: wv,
            off_s: work.soff[b],
            off_e: work.eoff[b],
            ..Geo::default()
        });
    }

    // Meshing offsets: a floor at joints so bands and hulls never join coincident
    // loops, within 80% of the length; never less than 5% of the length left.
    for g in geo.iter_mut() {
        let b = g.node as usize;
        let sj = work.start_joint[b] as usize;
        let start_is_joint = work.branch[sj] || work.out[sj].len() >= 2;
        let end_is_joint = !work.out[b].is_empty();
        let floor = |r: f64| (0.25 * PI * r).min(0.25 * g.len);
        let fs = if start_is_joint { floor(g.r0) } else { 0.0 };
        let fe = if end_is_joint { floor(g.r1) } else { 0.0 };
        let (xs, xe) = ((fs - g.off_s).max(0.0), (fe - g.off_e).max(0.0));
        let room = (0.8 * g.len - g.off_s - g.off_e).max(0.0);
        let k = if xs + xe > room && xs + xe > 0.0 { room / (xs + xe) } else { 1.0 };
        g.off_s += xs * k;
        g.off_e += xe * k;
        let sum = g.off_s + g.off_e;
        if sum > 0.95 * g.len {
            let f = 0.95 * g.len / sum;
            g.off_s *= f;
            g.off_e *= f;
        }
    }

    // Joints and their plans.
    let mut joint_nodes = Vec::new();
    let mut plans = Vec::new();
    let mut joint_loops: Vec<Vec<LoopRef>> = Vec::new();
    let mut joint_detached: Vec<Vec<LoopRef>> = Vec::new();
    for j in 0..n {
        let k = work.out[j].len() + work.branch[j] as usize;
        if k < 2 {
            continue;
        }
        crate::cancel::check()?;
        let mut loops: Vec<LoopRef> = Vec::with_capacity(k);
        if work.branch[j] {
            loops.push(LoopRef { slot: slot[j], at_end: true });
        }
        for &c in &work.out[j] {
            loops.push(LoopRef { slot: slot[c as usize], at_end: false });
        }
        // Aligned branches (Pieterse2012 §4.1.3 case 3) cannot share a joint: the thinner of
        // each aligned pair is detached (a child folding back into its parent always is)
        // and closed by a fan; the others still get their joint.
        let mut detached: Vec<LoopRef> = Vec::new();
        if work.aligned[j] {
            let eps = opts.aligned_epsilon;
            let axis = |l: &LoopRef| {
                let g = &geo[l.slot as usize];
                if l.at_end {
                    -g.d
                } else {
                    g.d
                }
            };
            let radius = |l: &LoopRef| geo[l.slot as usize].end_loop(l.at_end).1;
            let mut kept: Vec<LoopRef> = Vec::with_capacity(loops.len());
            for l in loops.drain(..) {
                let a = axis(&l);
                match kept.iter().position(|m| axis(m).dot(a) > 1.0 - eps) {
                    None => kept.push(l),
                    Some(p) => {
                        let m = kept[p];
                        if !m.at_end && radius(&l) > radius(&m) {
                            kept[p] = l;
                            detached.push(m);
                        } else {
                            detached.push(l);
                        }
                    }
                }
            }
            loops = kept;
        }
        let has_in = loops.first().is_some_and(|l| l.at_end);
        // A root whose stems all leave within a cone gets a virtual base loop (see
        // `root_base`); without it the hull of their loops is a thin lens.
        let based = if !work.branch[j] && detached.is_empty() {
            root_base(skeleton, j, &geo, &loops).and_then(|b| {
                geo.push(b);
                let mut with = vec![LoopRef { slot: (geo.len() - 1) as u32, at_end: false }];
                with.extend(loops.iter().copied());
                match hull_joint(&geo, &with, s, opts.aligned_epsilon) {
                    Some(t) => Some((t, with)),
                    None => {
                        geo.pop();
                        None
                    }
                }
            })
        } else {
            None
        };
        let plan = if let Some((t, with)) = based {
            loops = with;
            Plan::Hull(t)
        } else if loops.len() < 2 {
            Plan::Fallback
        } else if loops.len() == 2 && has_in {
            let (a, b) = (&geo[loops[0].slot as usize], &geo[loops[1].slot as usize]);
            if (-a.d).dot(b.d) > 1.0 - opts.aligned_epsilon {
                Plan::Fallback
            } else {
                Plan::Band
            }
        } else {
            match hull_joint(&geo, &loops, s, opts.aligned_epsilon) {
                Some(t) => Plan::Hull(t),
                None => Plan::Fallback,
            }
        };
        if matches!(plan, Plan::Fallback) {
            loops.append(&mut detached);
            loops.sort_by_key(|l| (!l.at_end, geo[l.slot as usize].node));
        }
        let zeroed = if matches!(plan, Plan::Fallback) { &loops } else { &detached };
        for l in zeroed.clone() {
            let g = &mut geo[l.slot as usize];
            if l.at_end {
                g.off_e = 0.0;
            } else {
                g.off_s = 0.0;
            }
        }
        joint_nodes.push(j as u32);
        plans.push(plan);
        joint_loops.push(loops);
        joint_detached.push(detached);
    }
    let mut plan_of = vec![NONE; n];
    for (k, &j) in joint_nodes.iter().enumerate() {
        plan_of[j as usize] = k as u32;
    }

    // Segments, vertex and UV bases, v₀ (chains through bands are one chart).
    let mut counts = (0u64, 0u64, 0u64); // vertices, uvs, triangles
    for gi in 0..geo.len() {
        let g = geo[gi];
        if g.base {
            let g = &mut geo[gi];
            g.first_vertex = counts.0.min(u32::MAX as u64) as u32;
            g.first_uv = counts.1.min(u32::MAX as u64) as u32;
            counts.0 += su as u64;
            counts.1 += su as u64 + 1;
            continue;
        }
        let l = (g.len - g.off_s - g.off_e).max(0.0);
        let (_, rs) = g.end_loop(false);
        let (_, re) = g.end_loop(true);
        let seg = l / (opts.segment_factor * PI * 0.5 * (rs + re));
        let segments =
            if seg.is_finite() { seg.round().clamp(1.0, opts.max_segments as f64) as u32 } else { 1 };
        let sj = work.start_joint[g.node as usize] as usize;
        let mut v0 = 0.0;
        let band_child = work.branch[sj]
            && plan_of[sj] != NONE
            && matches!(plans[plan_of[sj] as usize], Plan::Band)
            && joint_loops[plan_of[sj] as usize][1].slot == gi as u32;
        if band_child {
            let p = &geo[slot[sj] as usize];
            let (pc, pr) = p.end_loop(true);
            let (cc, cr) = g.end_loop(false);
            let delta = pc.distance(cc) / (PI * (pr + cr));
            v0 = p.v0 + p.segments as f64 * 0.5 + if delta.is_finite() { delta } else { 0.0 };
        }
        let g = &mut geo[gi];
        g.segments = segments;
        g.v0 = v0;
        g.first_vertex = counts.0.min(u32::MAX as u64) as u32;
        g.first_uv = counts.1.min(u32::MAX as u64) as u32;
        counts.0 += (segments as u64 + 1) * su as u64;
        counts.1 += (segments as u64 + 1) * (su as u64 + 1);
        counts.2 += 2 * segments as u64 * su as u64;
    }
    let cap_count = |caps: bool| -> u64 {
        let mut c = 0u64;
        for j in 0..n {
            let k = work.out[j].len() + work.branch[j] as usize;
            if k == 1 && caps {
                c += 1;
            }
        }
        c
    };
    let extra_caps = cap_count(opts.caps)
        + plans
            .iter()
            .zip(&joint_loops)
            .filter(|(p, _)| matches!(p, Plan::Fallback))
            .map(|(_, l)| l.len() as u64)
            .sum::<u64>()
        + joint_detached.iter().map(|d| d.len() as u64).sum::<u64>()
        + geo.iter().filter(|g| g.base).count() as u64;
    let joint_tris: u64 = joint_loops.iter().map(|l| (l.len() as u64) * (su as u64 + 2)).sum();
    let limit = u32::MAX as u64 / 4;
    if counts.0 + extra_caps >= limit
        || (counts.2 + joint_tris + extra_caps * su as u64) * 3 >= limit
        || counts.1 + extra_caps * (su as u64 + 1) + joint_tris * 3 >= limit
    {
        return Err(Error::InvalidGeometry {
            what: "hull mesher".into(),
            why: format!(
                "the hull mesh would have {} vertices and {} triangles, more than u32 indices \
                 allow; use fewer sides, a larger segment_factor or a smaller skeleton",
                counts.0, counts.2
            ),
        });
    }

    // Emit branches.
    let mut e = Emit::default();
    e.face_offsets.push(0);
    let mut branches = Vec::with_capacity(geo.len());
    for g in &geo {
        crate::cancel::check()?;
        let first_face = e.face_count();
        let (c0, r0) = g.end_loop(false);
        let (c1, r1) = g.end_loop(true);
        let nseg = g.segments;
        for i in 0..=nseg {
            let t = if nseg == 0 { 0.0 } else { i as f64 / nseg as f64 };
            let c = c0.lerp(c1, t);
            let r = r0 + (r1 - r0) * t;
            for j in 0..s {
                let ph = TAU * j as f64 / s as f64;
                e.positions.push((c + (g.u * ph.cos() + g.w * ph.sin()) * r).as_vec3());
            }
            let v = g.v0 + i as f64 * 0.5;
            for j in 0..=s {
                e.uvs.push(Vec2::new(j as f32 / s as f32, v as f32));
            }
        }
        for i in 0..nseg {
            for j in 0..s {
                let jn = (j + 1) % s;
                let a = g.first_vertex + i * s + j;
                let b = g.first_vertex + i * s + jn;
                let c = g.first_vertex + (i + 1) * s + j;
                let d = g.first_vertex + (i + 1) * s + jn;
                let ua = g.first_uv + i * (s + 1) + j;
                let uc = g.first_uv + (i + 1) * (s + 1) + j;
                e.tri([a, b, c], [ua, ua + 1, uc]);
                e.tri([b, d, c], [ua + 1, uc + 1, uc]);
            }
        }
        if g.base {
            continue;
        }
        let sj = work.start_joint[g.node as usize];
        branches.push(BranchSpan {
            node: g.node,
            start_node: sj,
            first_vertex: g.first_vertex,
            segments: nseg,
            faces: first_face..e.face_count(),
            start_offset: g.off_s,
            end_offset: g.off_e,
            length: g.len,
            v0: g.v0,
        });
    }

    // Emit joints.
    let mut joints = Vec::with_capacity(joint_nodes.len());
    let mut fallbacks = Vec::new();
    for (k, &jn) in joint_nodes.iter().enumerate() {
        let loops = &joint_loops[k];
        let first_face = e.face_count();
        let kind = match &plans[k] {
            Plan::Band => {
                let (p, c) = (&geo[loops[0].slot as usize], &geo[loops[1].slot as usize]);
                for j in 0..s {
                    let jn1 = (j + 1) % s;
                    let (a, b) = (p.loop_vertex(true, j, s), p.loop_vertex(true, jn1, s));
                    let (cc, d) = (c.loop_vertex(false, j, s), c.loop_vertex(false, jn1, s));
                    let (ua, ub) = (p.loop_uv(true, j, s), p.loop_uv(true, j + 1, s));
                    let (uc, ud) = (c.loop_uv(false, j, s), c.loop_uv(false, j + 1, s));
                    e.tri([a, b, cc], [ua, ub, uc]);
                    e.tri([b, d, cc], [ub, ud, uc]);
                }
                JointKind::Band
            }
            Plan::Hull(tris) => {
                let vid = |(l, j): (u32, u32)| {
                    let lr = loops[l as usize];
                    geo[lr.slot as usize].loop_vertex(lr.at_end, j, s)
                };
                let mut faces: Vec<[u32; 3]> = tris.iter().map(|t| t.map(vid)).collect();
                flip_slivers(&mut faces, &e.positions);
                let uvs = joint_uvs(&mut e, &geo, loops, &faces, s);
                for (f, uv) in faces.iter().zip(uvs) {
                    e.tri(*f, uv);
                }
                for l in loops.iter().filter(|l| geo[l.slot as usize].base) {
                    e.cap(&geo[l.slot as usize], true, s);
                }
                JointKind::Hull
            }
            Plan::Fallback => {
                for l in loops {
                    e.cap(&geo[l.slot as usize], l.at_end, s);
                }
                fallbacks.push(jn);
                JointKind::Fallback
            }
        };
        let faces = first_face..e.face_count();
        let detached = &joint_detached[k];
        for l in detached {
            e.cap(&geo[l.slot as usize], l.at_end, s);
        }
        if !detached.is_empty() && kind != JointKind::Fallback {
            fallbacks.push(jn);
        }
        let detached = detached.iter().map(|l| geo[l.slot as usize].node).collect();
        joints.push(JointSpan { node: jn, kind, loops: loops.len() as u32, faces, detached });
    }

    // Base and tip loops.
    let mut open_loops = 0;
    for j in 0..n {
        let k = work.out[j].len() + work.branch[j] as usize;
        if k != 1 {
            continue;
        }
        let (g, at_end) = if work.branch[j] {
            (&geo[slot[j] as usize], true)
        } else {
            (&geo[slot[work.out[j][0] as usize] as usize], false)
        };
        if opts.caps {
            e.cap(g, at_end, s);
        } else {
            open_loops += 1;
        }
    }

    let normals = e.normals();
    let face_indices = e.indices;
    let mesh = Mesh {
        positions: e.positions,
        face_offsets: e.face_offsets,
        uvs: Some(FaceVarying { values: e.uvs, indices: e.uv_indices }),
        normals: Some(FaceVarying { values: normals, indices: face_indices.clone() }),
        face_indices,
        creases: Vec::new(),
    };
    Ok(HullMesh {
        mesh,
        fallbacks,
        joints,
        branches,
        collapsed: work.collapsed,
        clamped: work.clamped,
        dropped: work.dropped,
        open_loops,
    })
}
