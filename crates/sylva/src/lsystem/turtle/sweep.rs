//! Contour-swept generalized cylinders (cpfg's `@Gs`/`@Gc`/`@Ge` with a contour `@#`):
//! the traced control points become a [`OrganKind::Swept`] organ, rings on the cubic
//! Hermite curve between control points, the frame carried by the smallest rotation
//! (Mech2004; `docs/lsystem.md`).

use crate::lsystem::source::{ErrorKind, LsystemError, Source};
use crate::skeleton::{Organ, OrganKind};
use glam::{DVec2, DVec3};

/// A control point of a contour-swept generalized cylinder.
#[derive(Debug, Clone, Copy)]
pub(super) struct SweepPoint {
    pub(super) pos: DVec3,
    pub(super) h: DVec3,
    pub(super) u: DVec3,
    pub(super) radius: f64,
    /// Index of the contour (shape) at this point.
    pub(super) shape: u32,
    /// Rings drawn from the previous control point to this one (`@Gc(n)`).
    pub(super) rings: u32,
}

/// A contour-swept generalized cylinder being traced.
#[derive(Debug, Clone)]
pub(super) struct Sweep {
    pub(super) points: Vec<SweepPoint>,
    pub(super) node: u32,
    pub(super) material: u32,
    /// The module that started it, for messages.
    pub(super) module: usize,
}

/// Most rings one `@Gc(n)` / `@Ge(n)` segment may ask for.
pub(super) const MAX_RINGS: u32 = 256;

/// The rotation-minimizing transport of `up` from heading `from` to heading `to`
/// (the smallest rotation taking `from` to `to`, applied to `up`), made perpendicular
/// to `to`.
fn transport(up: DVec3, from: DVec3, to: DVec3) -> DVec3 {
    let q = glam::DQuat::from_rotation_arc(from.normalize_or_zero(), to.normalize_or_zero());
    let u = q * up;
    (u - to * u.dot(to)).try_normalize().unwrap_or_else(|| to.any_orthonormal_vector())
}

/// Turns a traced contour-swept generalized cylinder into a [`OrganKind::Swept`] organ
/// (see `docs/lsystem.md`, "Contours and generalized cylinders", for the placement and
/// interpolation); `None` when it has fewer than two control points or no length. `used`
/// counts the ring points made so far, which may not pass `budget`.
pub(super) fn sweep_organ(
    sw: &Sweep,
    shapes: &[(Vec<DVec2>, bool, i32)],
    twist: bool,
    source: &Source,
    used: &mut usize,
    budget: usize,
) -> Result<Option<Organ>, Box<LsystemError>> {
    let closed = shapes[sw.points[0].shape as usize].1;
    if let Some(p) = sw.points.iter().find(|p| shapes[p.shape as usize].1 != closed) {
        let (a, b) = if closed { ("closed", "open") } else { ("open", "closed") };
        let e = source.error_nowhere(
            ErrorKind::Unsupported,
            &format!(
                "unsupported: the generalized cylinder started at module {} mixes {a} and {b} contours (contour {} \
                 is {b}); cpfg blends contours of the same kind only",
                sw.module,
                shapes[p.shape as usize].2
            ),
        );
        return Err(e);
    }
    if sw.points.len() < 2 {
        return Ok(None);
    }
    // Frames per control point: the turtle's own, or transported when twist is off.
    let mut pts = sw.points.clone();
    for k in 0..pts.len() {
        pts[k].h = pts[k].h.try_normalize().unwrap_or(DVec3::Y);
        pts[k].u = if twist || k == 0 {
            (pts[k].u - pts[k].h * pts[k].u.dot(pts[k].h))
                .try_normalize()
                .unwrap_or_else(|| pts[k].h.any_orthonormal_vector())
        } else {
            transport(pts[k - 1].u, pts[k - 1].h, pts[k].h)
        };
    }
    let ring =
        |pos: DVec3, h: DVec3, u: DVec3, r: f64, a: &[DVec2], b: &[DVec2], t: f64| -> Vec<glam::Vec3> {
            // Contour x along up, y along −left (cpfg's make_contour).
            let l = u.cross(h);
            a.iter()
                .zip(b)
                .map(|(p, q)| (pos + (u * p.lerp(*q, t).x - l * p.lerp(*q, t).y) * r).as_vec3())
                .collect()
        };
    let shape = |p: &SweepPoint| shapes[p.shape as usize].0.as_slice();
    let first = &pts[0];
    let mut rings = vec![ring(first.pos, first.h, first.u, first.radius, shape(first), shape(first), 0.0)];
    let mut centres = vec![first.pos];
    for w in pts.windows(2) {
        let (p0, p1) = (&w[0], &w[1]);
        let chord = p0.pos.distance(p1.pos);
        if chord < 1e-12 {
            continue; // coincident control points draw nothing (as in cpfg)
        }
        let (a, b) = (shape(p0), shape(p1));
        let b = if a.len() == b.len() { b } else { a };
        // The twist from p0's transported frame to p1's, shared out along the segment.
        let carried = transport(p0.u, p0.h, p1.h);
        let twist_angle = carried.cross(p1.u).dot(p1.h).atan2(carried.dot(p1.u));
        let (m0, m1) = (p0.h * chord, p1.h * chord);
        for k in 1..=p1.rings {
            let t = k as f64 / p1.rings as f64;
            let (pos, h, u) = if k == p1.rings {
                (p1.pos, p1.h, p1.u)
            } else {
                // Cubic Hermite through the two points with the turtle's headings as
                // tangents (scaled by the chord), as cpfg's `@Gc(n)` rings are.
                let (t2, t3) = (t * t, t * t * t);
                let pos = p0.pos * (2.0 * t3 - 3.0 * t2 + 1.0)
                    + m0 * (t3 - 2.0 * t2 + t)
                    + p1.pos * (-2.0 * t3 + 3.0 * t2)
                    + m1 * (t3 - t2);
                let d = (p0.pos - p1.pos) * (6.0 * t2 - 6.0 * t)
                    + m0 * (3.0 * t2 - 4.0 * t + 1.0)
                    + m1 * (3.0 * t2 - 2.0 * t);
                let h = d.try_normalize().unwrap_or(p0.h.lerp(p1.h, t).normalize_or(p1.h));
                let u = transport(p0.u, p0.h, h);
                let u = glam::DQuat::from_axis_angle(h, twist_angle * t) * u;
                (pos, h, u)
            };
            *used += a.len();
            if *used > budget {
                return Err(source
                    .error_nowhere(
                        ErrorKind::Budget,
                        &format!(
                            "the generalized cylinders draw more than {budget} contour points (16 per node of the \
                             skeleton node budget)"
                        ),
                    )
                    .with_help(crate::skeleton::NODE_BUDGET_HELP));
            }
            let r = p0.radius + (p1.radius - p0.radius) * t;
            rings.push(ring(pos, h, u, r, a, b, t));
            centres.push(pos);
        }
    }
    if rings.len() < 2 {
        return Ok(None);
    }
    let size: f64 = centres.windows(2).map(|w| w[0].distance(w[1])).sum();
    Ok(Some(Organ {
        kind: OrganKind::Swept(crate::skeleton::SweptSurface { rings, closed }),
        node: sw.node,
        position: first.pos.as_vec3(),
        heading: first.h.as_vec3(),
        up: first.u.as_vec3(),
        size: size as f32,
        material: sw.material,
    }))
}
