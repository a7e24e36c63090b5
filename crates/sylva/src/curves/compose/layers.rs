//! The builders that turn one layer (particles, grid, fill, hair, fire, meander,
//! lines, space, sphere) into raw curves (Xu2015 §7.2–§7.3: Figs. 7.1–7.7, 7.9, 7.10,
//! 7.13, 7.14; §8.1). `build_layer` stays one function: each arm is one layer type.

use super::spec::{ChargeSpec, CurvesSpec, LayerSpec, Stats, ViewSpec};
use super::{check_finite, check_positive, heading, rotate, uniform, v2, Ctx, Raw};
use crate::curves::fill::{self, FillParams, Region, Root};
use crate::curves::magnetic::{
    self, advance, grow_branching, Branching, Budget, Field, Particle, Signs, TraceOptions,
};
use crate::curves::render::Rgba;
use crate::curves::space;
use crate::error::{Error, Result};
use glam::{DVec2, DVec3};
use rand::RngExt;
use rand_pcg::Pcg64;

/// Builds one layer's raw curves; returns the 2D field for noise colouring.
pub(super) fn build_layer(
    layer: &LayerSpec,
    ctx: &Ctx,
    rng: &mut Pcg64,
    budget: &mut Budget,
    stats: &mut Stats,
    curves3d: &mut Vec<space::Curve3>,
) -> Result<(Vec<Raw>, Option<Field>)> {
    let spec = ctx.spec;
    let opts = ctx.opts();
    match layer {
        LayerSpec::Particles { particle, region, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let region = region.as_ref().map(|r| r.region(&format!("{}: region", ctx.what))).transpose()?;
            let mut raws = Vec::new();
            for (pi, p) in particle.iter().enumerate() {
                let (mut charge, duration) = ctx.charge(&p.charge, p.k, p.duration, p.flip_at)?;
                check_finite("sign", p.sign).map_err(|e| ctx.err(e))?;
                charge.scale *= p.sign;
                let speed = p.speed.unwrap_or(spec.speed);
                let particle = Particle {
                    position: v2(p.start),
                    velocity: heading(p.heading) * speed,
                    mass: spec.mass,
                    charge,
                    duration,
                };
                magnetic::validate_particle(&particle, &opts, &format!("{}: particle {}", ctx.what, pi + 1))?;
                let branching = match &p.children {
                    Some(c) => Branching {
                        count: c.count,
                        depth: c.depth,
                        from: c.from,
                        to: c.to,
                        signs: c.signs,
                        duration_scale: c.scale,
                    },
                    None => Branching {
                        count: 0,
                        depth: 0,
                        from: 0.0,
                        to: 1.0,
                        signs: Signs::Random,
                        duration_scale: 1.0,
                    },
                };
                let grown = match &region {
                    None => {
                        grow_branching(&particle, &field, &opts, &branching, rng, budget, spec.max_curves)?
                    }
                    Some(r) => {
                        grow_in_region(&particle, &field, &opts, &branching, r, rng, budget, spec.max_curves)?
                    }
                };
                let base = raws.len();
                let mut group: Vec<Raw> = grown
                    .into_iter()
                    .map(|b| {
                        let mut r = Raw::new(b.trace.points, b.parent.map(|(q, i)| (q + base, i)), b.depth);
                        r.style = Some(p.style.clone());
                        r
                    })
                    .collect();
                if let Some([x0, y0, x1, y1]) = p.center_in {
                    let (lo, hi) = fill::bounding_box(group.iter().flat_map(|r| r.points.iter()));
                    let shift = DVec2::new(0.5 * (x0 + x1), 0.5 * (y0 + y1)) - 0.5 * (lo + hi);
                    if shift.is_finite() {
                        for r in &mut group {
                            for q in &mut r.points {
                                *q += shift;
                            }
                        }
                    }
                }
                raws.extend(group);
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Grid { t, alpha, k, heading: h, sign, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            if t.is_empty() || alpha.is_empty() {
                return Err(ctx.err("a grid needs at least one T and one alpha"));
            }
            let (cw, ch) = (spec.width / alpha.len() as f64, spec.height / t.len() as f64);
            let mut raws = Vec::new();
            for (row, &tv) in t.iter().enumerate() {
                for (col, &a) in alpha.iter().enumerate() {
                    let (charge, duration) =
                        ctx.charge(&ChargeSpec::Spiral { t_end: tv, alpha: a }, k * sign, None, None)?;
                    let particle = Particle {
                        position: DVec2::ZERO,
                        velocity: heading(*h) * spec.speed,
                        mass: spec.mass,
                        charge,
                        duration,
                    };
                    let tr = magnetic::trace(&particle, &field, &opts, budget)?;
                    let mut pts = tr.points;
                    // Row 0 is the top row.
                    let centre = DVec2::new((col as f64 + 0.5) * cw, spec.height - (row as f64 + 0.5) * ch);
                    let (lo, hi) = fill::bounding_box(&pts);
                    let shift = centre - 0.5 * (lo + hi);
                    for p in &mut pts {
                        *p += shift;
                    }
                    raws.push(Raw::new(pts, None, 0));
                }
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Fill {
            root,
            region,
            release_region,
            ladder,
            k,
            release_every,
            release_skip,
            cell,
            recent,
            peel,
            min_radius,
            min_length,
            max_curves,
            signs,
            field,
            ..
        } => {
            let field = field.field(ctx.noise_seed)?;
            let region = match region {
                Some(r) => r.region(&format!("{}: region", ctx.what))?,
                None => ctx.canvas(),
            };
            let d = FillParams::default();
            let params = FillParams {
                ladder: ladder.as_ref().map(|l| l.iter().map(|p| (p[0], p[1])).collect()).unwrap_or(d.ladder),
                k: *k,
                speed: spec.speed,
                mass: spec.mass,
                release_every: release_every.unwrap_or(d.release_every),
                release_skip: release_skip.unwrap_or(d.release_skip),
                release_region: release_region
                    .as_ref()
                    .map(|r| r.region(&format!("{}: release_region", ctx.what)))
                    .transpose()?,
                region: region.clone(),
                cell: cell.unwrap_or(d.cell),
                recent: recent.unwrap_or(d.recent),
                peel: peel.unwrap_or(d.peel),
                min_radius: min_radius.unwrap_or(d.min_radius),
                min_length: min_length.unwrap_or(d.min_length),
                max_curves: max_curves.unwrap_or(spec.max_curves).min(spec.max_curves),
                signs: *signs,
                dt: spec.dt,
                integrator: spec.integrator,
            };
            let roots = if root.is_empty() {
                let (lo, hi) = region.bounds();
                vec![Root {
                    position: DVec2::new(0.5 * (lo.x + hi.x), lo.y),
                    direction: DVec2::Y,
                    charge: None,
                }]
            } else {
                root.iter()
                    .map(|r| {
                        let charge = match &r.charge {
                            Some(c) => {
                                let (mut ch, d) = ctx.charge(c, r.k, r.duration, r.flip_at)?;
                                ch.scale *= r.sign;
                                Some((ch, d))
                            }
                            None => None,
                        };
                        Ok(Root { position: v2(r.start), direction: heading(r.heading), charge })
                    })
                    .collect::<Result<Vec<_>>>()?
            };
            let res = fill::space_fill(&roots, &params, &field, rng, budget).map_err(|e| match e {
                Error::Recipe(m) => ctx.err(m),
                e => e,
            })?;
            stats.attempts += res.attempts.len();
            stats.abandoned += res.abandoned;
            let raws = res.curves.into_iter().map(|c| Raw::new(c.trace.points, c.parent, c.depth)).collect();
            Ok((raws, Some(field)))
        }
        LayerSpec::Hair {
            hairline,
            strands,
            charge,
            t_range,
            alpha_range,
            duration_range,
            flip_range,
            k,
            heading: fixed_heading,
            parting,
            lean,
            spread,
            sign,
            region,
            field,
            ..
        } => {
            let field = field.field(ctx.noise_seed)?;
            let region = region.as_ref().map(|r| r.region(&format!("{}: region", ctx.what))).transpose()?;
            let line: Vec<DVec2> = hairline.iter().map(|p| v2(*p)).collect();
            if line.len() < 2 || line.iter().any(|p| !p.is_finite()) {
                return Err(ctx.err("the hairline needs at least two finite points"));
            }
            let parting = parting.unwrap_or(0.5 * spec.width);
            ctx.check_count(*strands as u64, "strands")?;
            let mut raws = Vec::new();
            for s in 0..*strands {
                let (pos, tangent) = along(&line, (s as f64 + 0.5) / *strands as f64);
                let right = pos.x >= parting;
                let side = if right { 1.0 } else { -1.0 };
                let mut cs = charge.clone();
                if let ChargeSpec::Spiral { t_end, alpha } = &mut cs {
                    if let Some([a, b]) = t_range {
                        *t_end = uniform(rng, *a, *b);
                    }
                    if let Some([a, b]) = alpha_range {
                        *alpha = uniform(rng, *a, *b);
                    }
                }
                let duration = duration_range.map(|[a, b]| uniform(rng, a, b));
                let flip = flip_range.map(|[a, b]| uniform(rng, a, b));
                let (mut ch, duration) = ctx.charge(&cs, *k, duration, flip)?;
                ch.scale *= sign * side;
                let base = match fixed_heading {
                    Some(h) => heading(*h),
                    None => tangent.perp(),
                };
                let jitter = uniform(rng, -spread, *spread);
                let dir = rotate(base, -side * lean + jitter);
                let particle = Particle {
                    position: pos,
                    velocity: dir * spec.speed,
                    mass: spec.mass,
                    charge: ch,
                    duration,
                };
                let tr = match &region {
                    None => magnetic::trace(&particle, &field, &opts, budget)?,
                    Some(r) => magnetic::trace_with(&particle, &field, &opts, budget, s as u64, |v| {
                        if r.contains(v.to) {
                            magnetic::Control::Continue
                        } else {
                            magnetic::Control::Stop
                        }
                    })?,
                };
                raws.push(Raw::new(tr.points, None, 0));
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Fire { start, charge, k, flip_at, side, field, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let (base_charge, duration) = ctx.charge(charge, *k, None, Some(*flip_at))?;
            let total: u64 = side.iter().map(|sd| sd.tongues as u64).sum();
            ctx.check_count(total, "tongues")?;
            let mut raws = Vec::new();
            let mut at = v2(*start);
            {
                for sd in side {
                    if let Some(s) = sd.start {
                        at = v2(s);
                    }
                    if !at.is_finite() {
                        return Err(ctx.err("a fire start is not finite"));
                    }
                    for i in 0..sd.tongues {
                        let h = sd.heading + sd.turn * i as f64 + uniform(rng, -sd.spread, sd.spread);
                        let mut ch = base_charge.clone();
                        ch.scale *= sd.sign;
                        let v0 = heading(h) * spec.speed;
                        let particle =
                            Particle { position: at, velocity: v0, mass: spec.mass, charge: ch, duration };
                        // The seed: terminate when v_x reaches 0 (a sign change of v_x).
                        let mut ref_sign = v0.x.signum() * (v0.x.abs() > 1e-9) as i32 as f64;
                        let tr = magnetic::trace_with(&particle, &field, &opts, budget, i as u64, |v| {
                            if ref_sign == 0.0 {
                                ref_sign = v.velocity.x.signum();
                                return magnetic::Control::Continue;
                            }
                            if v.velocity.x * ref_sign <= 0.0 {
                                magnetic::Control::Stop
                            } else {
                                magnetic::Control::Continue
                            }
                        })?;
                        at = *tr.points.last().unwrap_or(&at);
                        raws.push(Raw::new(tr.points, None, 0));
                    }
                }
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Meander { start, heading: h, q, duration, region, field, style, .. } => {
            let field = field.field(ctx.noise_seed)?;
            let region = match region {
                Some(r) => r.region(&format!("{}: region", ctx.what))?,
                None => ctx.canvas(),
            };
            check_finite("q", *q).map_err(|e| ctx.err(e))?;
            check_finite("duration", *duration).map_err(|e| ctx.err(e))?;
            let x0 = v2(*start);
            if !region.contains(x0) {
                return Err(ctx.err("the start lies outside the region"));
            }
            let random_colors = style.color_by.is_none() && style.color.is_none();
            let mut raws = Vec::new();
            let (mut x, mut v) = (x0, heading(*h) * spec.speed);
            let mut current = vec![x];
            let steps = (duration / spec.dt).ceil().max(0.0) as u64;
            let new_color = |rng: &mut Pcg64| -> Rgba {
                let mut c = [0, 0, 0, 255];
                for ch in &mut c[..3] {
                    *ch = (rng.random::<f64>() * 255.0).round() as u8;
                }
                c
            };
            let mut color = new_color(rng);
            for _ in 0..steps {
                budget.step()?;
                let omega = q * field.bz(x + v * (0.5 * spec.dt)) / spec.mass;
                let (x1, v1) = advance(x, v, omega, spec.dt, spec.integrator);
                if !region.contains(x1) {
                    // §7.3: reverse the velocity at the border; the re-entry starts a
                    // new curve with a new random colour.
                    v = -v;
                    if raws.len() >= spec.max_curves {
                        return Err(ctx.err(format!(
                            "more than {} re-entries; raise `curves.max_curves` or shorten `duration`",
                            spec.max_curves
                        )));
                    }
                    if current.len() >= 2 {
                        let mut r = Raw::new(std::mem::take(&mut current), None, 0);
                        if random_colors {
                            r.color = Some(color);
                        }
                        raws.push(r);
                        color = new_color(rng);
                    }
                    current = vec![x];
                    continue;
                }
                x = x1;
                v = v1;
                current.push(x);
            }
            if current.len() >= 2 {
                let mut r = Raw::new(current, None, 0);
                if random_colors {
                    r.color = Some(color);
                }
                raws.push(r);
            }
            Ok((raws, Some(field)))
        }
        LayerSpec::Lines { lines, closed, .. } => {
            let mut raws = Vec::new();
            for l in lines {
                let mut pts: Vec<DVec2> = l.iter().map(|p| v2(*p)).collect();
                if pts.iter().any(|p| !p.is_finite()) {
                    return Err(ctx.err("a line has a non-finite point"));
                }
                if *closed && pts.len() > 2 {
                    pts.push(pts[0]);
                }
                let mut r = Raw::new(pts, None, 0);
                r.magnetic = false;
                raws.push(r);
            }
            Ok((raws, None))
        }
        LayerSpec::Space { start, direction, charge, k, duration, children, tilt, field, view, .. } => {
            let field3 = field.field3(ctx.noise_seed)?;
            let (ch, duration) = ctx.charge(charge, *k, *duration, None)?;
            let dir = direction.map(DVec3::from_array).unwrap_or(DVec3::Y);
            let root = space::Particle3 {
                position: DVec3::from_array(*start),
                velocity: dir.normalize_or(DVec3::Y) * spec.speed,
                mass: spec.mass,
                charge: ch,
                duration,
            };
            let branching = space::Branching3 {
                count: children.as_ref().map_or(0, |c| c.count),
                depth: children.as_ref().map_or(0, |c| c.depth),
                from: children.as_ref().map_or(0.0, |c| c.from),
                to: children.as_ref().map_or(1.0, |c| c.to),
                duration_scale: children.as_ref().map_or(0.5, |c| c.scale),
                tilt: tilt.to_radians(),
            };
            let curves = space::grow3(&root, &field3, spec.dt, &branching, rng, budget, spec.max_curves)
                .map_err(|e| match e {
                    Error::Recipe(m) => ctx.err(m),
                    e => e,
                })?;
            let proj = Projection::new(view, spec);
            let raws = curves
                .iter()
                .map(|c| Raw::new(c.points.iter().map(|p| proj.apply(*p)).collect(), c.parent, c.depth))
                .collect();
            curves3d.extend(curves);
            Ok((raws, None))
        }
        LayerSpec::Sphere { radius, particles, charge, k, duration, cull, field, view, .. } => {
            check_positive("radius", *radius).map_err(|e| ctx.err(e))?;
            let field3 = field.field3(ctx.noise_seed)?;
            let (ch, duration) = ctx.charge(charge, *k, *duration, None)?;
            let proj = Projection::new(view, spec);
            ctx.check_count(*particles as u64, "particles")?;
            let mut raws = Vec::new();
            for i in 0..*particles {
                // A uniform random point and tangent direction on the sphere.
                let z = uniform(rng, -1.0, 1.0);
                let phi = uniform(rng, 0.0, std::f64::consts::TAU);
                let rxy = (1.0 - z * z).max(0.0).sqrt();
                let n = DVec3::new(rxy * phi.cos(), rxy * phi.sin(), z);
                let a = n.any_orthonormal_vector();
                let b = n.cross(a);
                let ang = uniform(rng, 0.0, std::f64::consts::TAU);
                let mut c = ch.clone();
                if rng.random::<f64>() < 0.5 {
                    c.scale = -c.scale;
                }
                let sp = space::SphereParticle {
                    radius: *radius,
                    normal: n,
                    direction: a * ang.cos() + b * ang.sin(),
                    speed: spec.speed,
                    mass: spec.mass,
                    charge: c,
                    duration,
                };
                let curve = space::trace_on_sphere(&sp, &field3, spec.dt, budget, i as u64)?;
                // Split into runs on the visible hemisphere.
                let mut run = Vec::new();
                for p in &curve.points {
                    let visible = !*cull || proj.facing(*p);
                    if visible {
                        run.push(proj.apply(*p));
                    } else if run.len() >= 2 {
                        raws.push(Raw::new(std::mem::take(&mut run), None, 0));
                    } else {
                        run.clear();
                    }
                }
                if run.len() >= 2 {
                    raws.push(Raw::new(run, None, 0));
                }
                curves3d.push(curve);
            }
            Ok((raws, Some(Field::Uniform(1.0))))
        }
    }
}

/// Branching with every curve stopped at a region's border.
#[allow(clippy::too_many_arguments)]
fn grow_in_region(
    root: &Particle,
    field: &Field,
    opts: &TraceOptions,
    branching: &Branching,
    region: &Region,
    rng: &mut Pcg64,
    budget: &mut Budget,
    max_curves: usize,
) -> Result<Vec<magnetic::BranchCurve>> {
    let mut all = grow_branching(root, field, opts, branching, rng, budget, max_curves)?;
    // Cut each curve at its first point outside the region; children released past
    // the cut are dropped with their descendants.
    let mut keep = vec![true; all.len()];
    let mut cut = vec![usize::MAX; all.len()];
    for i in 0..all.len() {
        if let Some((p, at)) = all[i].parent {
            if !keep[p] || at >= cut[p] {
                keep[i] = false;
                continue;
            }
        }
        let n = all[i].trace.points.iter().position(|q| !region.contains(*q)).unwrap_or(usize::MAX);
        cut[i] = n;
        if n < 2 {
            keep[i] = false;
        }
    }
    let mut index = vec![usize::MAX; all.len()];
    let mut out = Vec::new();
    for (i, mut c) in all.drain(..).enumerate() {
        if !keep[i] {
            continue;
        }
        if cut[i] != usize::MAX {
            c.trace.points.truncate(cut[i]);
            c.trace.times.truncate(cut[i]);
            c.trace.velocities.truncate(cut[i]);
        }
        c.parent = c.parent.map(|(p, k)| (index[p], k));
        index[i] = out.len();
        out.push(c);
    }
    Ok(out)
}

/// The point and unit tangent at arc-length fraction `f` of a polyline.
fn along(line: &[DVec2], f: f64) -> (DVec2, DVec2) {
    let total: f64 = line.windows(2).map(|w| w[0].distance(w[1])).sum();
    let mut target = f.clamp(0.0, 1.0) * total;
    for w in line.windows(2) {
        let l = w[0].distance(w[1]);
        if target <= l && l > 0.0 {
            return (w[0].lerp(w[1], target / l), (w[1] - w[0]) / l);
        }
        target -= l;
    }
    let n = line.len();
    (line[n - 1], (line[n - 1] - line[n - 2]).normalize_or(DVec2::X))
}

/// An orthographic view of 3D curves onto the canvas.
struct Projection {
    right: DVec3,
    up: DVec3,
    toward: DVec3,
    origin: DVec2,
    zoom: f64,
}

impl Projection {
    pub(super) fn new(view: &ViewSpec, spec: &CurvesSpec) -> Self {
        let (yaw, pitch) = (view.yaw.to_radians(), view.pitch.to_radians());
        // Camera looking along −toward; +Y stays up on the canvas.
        let toward = DVec3::new(yaw.sin() * pitch.cos(), pitch.sin(), yaw.cos() * pitch.cos());
        let right = DVec3::Y.cross(toward).normalize_or(DVec3::X);
        let up = toward.cross(right);
        let origin = view.origin.map(v2).unwrap_or(DVec2::new(0.5 * spec.width, 0.05 * spec.height));
        Projection { right, up, toward, origin, zoom: if view.zoom.is_finite() { view.zoom } else { 1.0 } }
    }

    fn apply(&self, p: DVec3) -> DVec2 {
        self.origin + self.zoom * DVec2::new(p.dot(self.right), p.dot(self.up))
    }

    fn facing(&self, p: DVec3) -> bool {
        p.dot(self.toward) >= 0.0
    }
}
