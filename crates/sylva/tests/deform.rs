//! The branch deformer's CPU reference (issue 25, item 1): Skjermo2008-spec §10 properties 12–18
//! and the first half of 19 on hundreds of seeded random branches (joint angles below
//! 90°, every shape term), derivatives against central finite differences in `f64`
//! (the same generic code the `f32` path runs), and the records of grown trees.

use glam::{DVec3, Quat, Vec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f32::consts::{PI, TAU};
use sylva::deform::{
    branch_mesh, branch_records, control_polygon, fallback_axis, grid, radius, sloan_frames, BranchDeformer,
    BranchRecord, DeformError, Deformer, FlareMode, Grids, DEFAULT_LODS, FLARE_END,
};
use sylva::geometry::cubic_bezier;

/// Random branches per property.
const BRANCHES: usize = 400;

fn uniform(rng: &mut Pcg64, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * rng.random::<f32>()
}

fn unit(rng: &mut Pcg64) -> Vec3 {
    loop {
        let v = Vec3::new(uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0), uniform(rng, -1.0, 1.0));
        if (0.01..=1.0).contains(&v.length_squared()) {
            return v.normalize();
        }
    }
}

/// Length 0.3–3 m, bends up to ±85° and any rolls (D §2.1), placed by a random rotation
/// and a translation within ±2 m; the parent direction at least 10° off the first leg.
fn random_points(rng: &mut Pcg64) -> ([Vec3; 4], Vec3, f32) {
    let length = uniform(rng, 0.3, 3.0);
    let bend = 85f32.to_radians();
    let angles =
        [uniform(rng, -PI, PI), uniform(rng, -bend, bend), uniform(rng, -PI, PI), uniform(rng, -bend, bend)];
    let local = control_polygon(length, angles).unwrap();
    let rot = Quat::from_axis_angle(unit(rng), uniform(rng, 0.0, TAU));
    let at = Vec3::new(uniform(rng, -2.0, 2.0), uniform(rng, -2.0, 2.0), uniform(rng, -2.0, 2.0));
    let points = local.map(|p| rot * p + at);
    let l0 = (points[1] - points[0]).normalize();
    let o = loop {
        let o = unit(rng);
        if o.dot(l0).abs() < 10f32.to_radians().cos() {
            break o;
        }
    };
    (points, o, length)
}

/// A random branch with every shape term: radius 1–6 % of the length, a tip radius of 0
/// (the seed's taper) or some fraction of the base, taper 0, in (0, 1), 1 or up to 10,
/// either flare form, up to 5 bulges of depth 0.1 and 7 lobes of depth 0.25.
fn random_branch(rng: &mut Pcg64) -> (BranchRecord, f32) {
    let (points, o, length) = random_points(rng);
    let mut r = BranchRecord::new(points, o, length * uniform(rng, 0.01, 0.06));
    r.tip_radius = if rng.random::<bool>() { 0.0 } else { r.radius * uniform(rng, 0.0, 1.0) };
    r.taper = match rng.random_range(0..4) {
        0 => 0.0,
        1 => uniform(rng, 0.2, 1.0),
        2 => 1.0,
        _ => uniform(rng, 1.0, 10.0),
    };
    r.flare = uniform(rng, 0.0, 0.5);
    r.flare_mode = if rng.random::<bool>() { FlareMode::WeberPenn } else { FlareMode::Printed };
    r.bulge_depth = uniform(rng, 0.0, 0.1);
    r.bulge_count = rng.random_range(0..=5) as f32;
    r.lobe_depth = uniform(rng, 0.0, 0.25);
    r.lobe_count = rng.random_range(0..=7) as f32;
    r.lobe_fade = uniform(rng, 0.0, 1.0);
    r.check().unwrap();
    (r, length)
}

/// The largest coordinate magnitude of the control points, at least 1: the scale of
/// `f32` rounding in positions.
fn scale(r: &BranchRecord) -> f32 {
    r.points().iter().map(|p| p.abs().max_element()).fold(1.0, f32::max)
}

fn close64(a: DVec3, b: DVec3, rel: f64, abs: f64) -> bool {
    (a - b).length() <= rel * a.length().max(b.length()) + abs
}

/// Arc length of the cubic Bézier in f64: 64 intervals of 5-point Gauss–Legendre.
fn arc_length(p: &[Vec3; 4]) -> f64 {
    let p = p.map(|q| q.as_dvec3());
    let d = |t: f64| {
        let s = 1.0 - t;
        ((p[1] - p[0]) * (3.0 * s * s) + (p[2] - p[1]) * (6.0 * s * t) + (p[3] - p[2]) * (3.0 * t * t))
            .length()
    };
    let nodes = [
        (0.0, 0.568_888_888_888_888_9),
        (-0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
        (0.538_469_310_105_683_1, 0.478_628_670_499_366_5),
        (-0.906_179_845_938_664, 0.236_926_885_056_189_1),
        (0.906_179_845_938_664, 0.236_926_885_056_189_1),
    ];
    let n = 64;
    (0..n)
        .map(|i| {
            let (a, h) = (i as f64 / n as f64, 0.5 / n as f64);
            nodes.iter().map(|&(x, w)| w * d(a + h + h * x)).sum::<f64>() * h
        })
        .sum()
}

/// Property 12: legs of length/3, joint angles below 90° (= |bend|), arc length ≤ length,
/// equal iff straight; 90° or more is an error.
#[test]
fn control_polygon_legs_angles_and_arc_length() {
    let mut rng = Pcg64::seed_from_u64(12);
    for case in 0..BRANCHES {
        let length = uniform(&mut rng, 0.1, 10.0);
        let straight = case % 5 == 0;
        let bend = |rng: &mut Pcg64| {
            if straight {
                0.0
            } else {
                let b = uniform(rng, 2f32.to_radians(), 89.5f32.to_radians());
                if rng.random::<bool>() {
                    b
                } else {
                    -b
                }
            }
        };
        let angles = [uniform(&mut rng, -PI, PI), bend(&mut rng), uniform(&mut rng, -PI, PI), bend(&mut rng)];
        let p = control_polygon(length, angles).unwrap();
        assert_eq!(p[0], Vec3::ZERO);
        assert!((p[1] - Vec3::X * (length / 3.0)).length() < 1e-6 * length, "S₀ along +X");
        let legs = [p[1] - p[0], p[2] - p[1], p[3] - p[2]];
        for l in legs {
            assert!((l.length() - length / 3.0).abs() <= 1e-5 * length, "leg {} of {length}", l.length());
        }
        for (k, w) in legs.windows(2).enumerate() {
            let deg = w[0].angle_between(w[1]).to_degrees();
            assert!(deg < 90.0, "joint {deg}°");
            assert!((deg - angles[2 * k + 1].abs().to_degrees()).abs() < 0.05, "the joint angle is |bend|");
        }
        let arc = arc_length(&p);
        let poly: f64 = legs.iter().map(|l| l.as_dvec3().length()).sum();
        if straight {
            assert!((arc - poly).abs() <= 1e-6 * poly, "straight: arc {arc} = length {poly}");
        } else {
            assert!(arc < poly * (1.0 - 1e-6), "bent: arc {arc} < length {poly}");
        }
    }
    for bad in [90f32, 95.0, -90.0, 179.0] {
        let e = control_polygon(1.0, [0.0, 0.0, 0.3, bad.to_radians()]).unwrap_err();
        assert!(matches!(e, DeformError::JointAngle { joint: 2, .. }), "{e}");
    }
    assert!(matches!(
        control_polygon(1.0, [0.0, 1.6, 0.0, 0.0]),
        Err(DeformError::JointAngle { joint: 1, .. })
    ));
    assert_eq!(control_polygon(0.0, [0.0; 4]), Err(DeformError::Length(0.0)));
    assert!(control_polygon(f32::NAN, [0.0; 4]).is_err());
    assert!(control_polygon(1.0, [f32::NAN, 0.0, 0.0, 0.0]).is_err());
    // A record bent past 90° is reported by its check.
    let r = BranchRecord::new(
        [Vec3::ZERO, Vec3::X, Vec3::new(0.8, 1.0, 0.0), Vec3::new(0.8, 2.0, 0.0)],
        Vec3::Y,
        0.1,
    );
    assert!(matches!(r.check(), Err(DeformError::JointAngle { joint: 1, .. })), "{:?}", r.check());
}

/// Property 13: Q(u, 0, 0) is the cubic Bézier of P₀…P₃.
#[test]
fn q_with_zero_offsets_is_the_cubic_bezier() {
    let mut rng = Pcg64::seed_from_u64(13);
    for _ in 0..BRANCHES {
        let (r, _) = random_branch(&mut rng);
        let (d32, d64) = (Deformer::new(&r), BranchDeformer::<DVec3>::new(&r));
        let p64 = r.points().map(|p| p.as_dvec3());
        for _ in 0..20 {
            let u = rng.random::<f32>();
            let q = d32.q(u, 0.0, 0.0);
            assert!(q.distance(cubic_bezier(&r.points(), u)) <= 1e-6 * scale(&r), "u {u}");
            let (t, s) = (u as f64, 1.0 - u as f64);
            let bernstein = p64[0] * (s * s * s)
                + p64[1] * (3.0 * s * s * t)
                + p64[2] * (3.0 * s * t * t)
                + p64[3] * (t * t * t);
            assert!(d64.q(t, 0.0, 0.0).distance(bernstein) < 1e-12);
        }
    }
}

/// Property 14: the base ring is ⟂ L₀ with norm R(0, θ); with a taper to a tip radius of
/// 0 the tip ring collapses to P₃; all angles 0 and no shape terms give an exact cylinder.
#[test]
fn base_ring_tip_ring_and_cylinder() {
    let mut rng = Pcg64::seed_from_u64(14);
    for _ in 0..BRANCHES {
        let (mut r, _) = random_branch(&mut rng);
        if r.taper == 0.0 {
            r.taper = 2.0;
        }
        r.tip_radius = 0.0;
        let (d32, d64) = (Deformer::new(&r), BranchDeformer::<DVec3>::new(&r));
        let l0 = d64.handles.l[0];
        let (p0, p3) = (r.p0.as_dvec3(), r.p3.as_dvec3());
        for _ in 0..16 {
            let theta = uniform(&mut rng, 0.0, TAU);
            let rad = radius::<f64>(&r, 0.0, theta as f64).r;
            let x = d64.position(0.0, theta as f64) - p0;
            assert!(x.dot(l0).abs() <= 1e-12, "base ring ⟂ L₀");
            assert!((x.length() - rad).abs() <= 1e-12, "base ring radius {} vs {rad}", x.length());
            assert!(d64.position(1.0, theta as f64).distance(p3) < 1e-12, "the tip collapses to P₃");
            // The f32 path to its rounding.
            let x32 = d32.position(0.0, theta) - r.p0;
            let tol = 2e-6 * scale(&r);
            assert!(x32.dot(d32.handles.l[0]).abs() <= tol);
            assert!((x32.length() - rad as f32).abs() <= 1e-5 * rad as f32 + tol);
            assert!(d32.position(1.0, theta).distance(r.p3) <= tol);
        }
    }
    // All angles 0, no shape terms: a cylinder of radius r and length `length`, whatever
    // the rolls: exact in the branch's own space (f64 to 1e-12), and to the points' f32
    // rounding wherever it is placed.
    for rolls in [[0.0, 0.0], [0.7, -2.0]] {
        for _ in 0..50 {
            let length = uniform(&mut rng, 0.5, 4.0);
            let local = control_polygon(length, [rolls[0], 0.0, rolls[1], 0.0]).unwrap();
            let rot = Quat::from_axis_angle(unit(&mut rng), uniform(&mut rng, 0.0, TAU));
            let radius = uniform(&mut rng, 0.01, 0.3);
            let o = unit(&mut rng);
            for (points, tol) in [(local, 1e-12), (local.map(|p| rot * p), 1e-6 * length as f64)] {
                let rec = BranchRecord::new(points, o, radius);
                let d = BranchDeformer::<DVec3>::new(&rec);
                let axis = (points[3] - points[0]).as_dvec3().normalize();
                for i in 0..=10 {
                    for j in 0..12 {
                        let (v, theta) = (i as f64 / 10.0, j as f64 * std::f64::consts::TAU / 12.0);
                        let s = d.evaluate(v, theta);
                        let x = s.position - points[0].as_dvec3();
                        let along = x.dot(axis);
                        let radial = x - axis * along;
                        assert!(
                            (along - v * length as f64).abs() < tol + 1e-6 * length as f64,
                            "axial {along}"
                        );
                        assert!((radial.length() - radius as f64).abs() < tol, "radial {}", radial.length());
                        assert!(
                            s.normal.distance(radial.normalize()) < tol / radius as f64,
                            "cylinder normal"
                        );
                    }
                }
            }
        }
    }
}

fn assert_orthonormal(l: Vec3, s: Vec3, t: Vec3, what: &str) {
    for (name, v) in [("L", l), ("S", s), ("T", t)] {
        assert!(v.is_finite(), "{what}: {name} finite");
        assert!((v.length() - 1.0).abs() <= 1e-5, "{what}: |{name}| = {}", v.length());
    }
    assert!(l.dot(s).abs() <= 1e-5 && l.dot(t).abs() <= 1e-5 && s.dot(t).abs() <= 1e-5, "{what}: orthogonal");
    assert!(s.distance(l.cross(t)) <= 1e-5, "{what}: S = L × T");
}

/// Property 15: {Lᵢ, Sᵢ, Tᵢ} orthonormal; L₀ ∥ O takes the fallback, never NaN.
#[test]
fn sloan_frames_are_orthonormal_and_fall_back_when_l0_is_parallel_to_o() {
    let mut rng = Pcg64::seed_from_u64(15);
    for _ in 0..BRANCHES {
        let (points, o, _) = random_points(&mut rng);
        let h = sloan_frames(&points, o);
        assert!(!h.fallback);
        for i in 0..3 {
            assert_orthonormal(h.l[i], h.s[i], h.t[i], &format!("frame {i}"));
        }
        assert!(h.s[0].dot(o).abs() < 1e-5, "S₀ ⟂ O");
        // O along ±L₀, nearly so, or absent: the fallback axis, the same frame.
        let l0 = h.l[0];
        let want = sloan_frames(&points, fallback_axis(l0));
        for bad in [l0, -l0, (l0 + unit(&mut rng) * 1e-5).normalize(), Vec3::ZERO] {
            let f = sloan_frames(&points, bad);
            assert!(f.fallback, "O = {bad} ∥ L₀ = {l0}");
            for i in 0..3 {
                assert_orthonormal(f.l[i], f.s[i], f.t[i], &format!("fallback frame {i}"));
            }
            assert_eq!(f.s, want.s);
            assert_eq!(f.t, want.t);
        }
        let fa = fallback_axis(l0);
        let least =
            [Vec3::X, Vec3::Y, Vec3::Z].map(|e| e.dot(l0).abs()).into_iter().fold(f32::INFINITY, f32::min);
        assert_eq!(fa.dot(l0).abs(), least, "the least aligned world axis");
    }
    // Degenerate polygons: zero legs, everything at one point, a 90° joint.
    let cases = [
        [Vec3::ZERO, Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0],
        [Vec3::ZERO, Vec3::Y, Vec3::Y, Vec3::Y * 2.0],
        [Vec3::ONE; 4],
        [Vec3::ZERO, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 1.0)],
    ];
    for (k, p) in cases.iter().enumerate() {
        for o in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ZERO] {
            let f = sloan_frames(p, o);
            for i in 0..3 {
                assert_orthonormal(f.l[i], f.s[i], f.t[i], &format!("degenerate case {k}, O {o}, frame {i}"));
            }
            let rec = BranchRecord { taper: 0.5, ..BranchRecord::new(*p, o, 0.1) };
            for v in [0.0, 0.5, 1.0] {
                let (x, n) = sylva::deform::deform(&rec, v, 1.0);
                assert!(
                    x.is_finite() && n.is_finite() && (n.length() - 1.0).abs() < 1e-5,
                    "case {k}: {x} {n}"
                );
            }
        }
    }
}

/// Central difference of `f` at `x` (second-order one-sided at the start of the domain).
fn diff(f: impl Fn(f64) -> f64, x: f64, h: f64, one_sided: bool) -> f64 {
    if one_sided {
        (-3.0 * f(x) + 4.0 * f(x + h) - f(x + 2.0 * h)) / (2.0 * h)
    } else {
        (f(x + h) - f(x - h)) / (2.0 * h)
    }
}

fn close(analytic: f64, numeric: f64, rel: f64, abs: f64) -> bool {
    (analytic - numeric).abs() <= rel * analytic.abs().max(numeric.abs()) + abs
}

/// The (v, θ) samples of a derivative check (`f32` values): random, plus v = 0
/// (one-sided) where R is smooth enough there (t = 0, 1 or ≥ 2); never within 10⁻³ of
/// v = 0 for 0 < t < 1, nor within 10⁻⁵ of the Weber–Penn flare's kink at v = 1/8.
fn derivative_samples(rng: &mut Pcg64, r: &BranchRecord) -> Vec<(f64, f64)> {
    let kinked_base = r.taper > 0.0 && r.taper < 1.0;
    let mut out = Vec::new();
    // For 1 < t < 2 the taper's second derivative is infinite at v = 0, which spoils the
    // one-sided difference there (not the analytic slope, 0).
    if r.taper == 0.0 || r.taper == 1.0 || r.taper >= 2.0 {
        out.push((0.0, uniform(rng, 0.0, TAU) as f64));
    }
    while out.len() < 12 {
        let v = rng.random::<f32>() as f64;
        if (kinked_base && v < 1e-3)
            || (r.flare_mode == FlareMode::WeberPenn && (v - FLARE_END as f64).abs() < 1e-5)
        {
            continue;
        }
        out.push((v, uniform(rng, 0.0, TAU) as f64));
    }
    out
}

/// Property 16: the corrected R_v and R_θ (errata 1–3, product rule) equal central
/// differences (relative 10⁻⁴), and the `f32` path gives the `f64` values.
#[test]
fn corrected_radius_derivatives_equal_central_differences() {
    let mut rng = Pcg64::seed_from_u64(16);
    let h = 1e-6;
    let mut worst = 0f64;
    for _ in 0..BRANCHES {
        let (r, _) = random_branch(&mut rng);
        let tiny = 1e-9 * r.radius as f64;
        for (v, theta) in derivative_samples(&mut rng, &r) {
            let an = radius::<f64>(&r, v, theta);
            let dv = diff(|v| radius::<f64>(&r, v, theta).r, v, h, v == 0.0);
            let dt = diff(|t| radius::<f64>(&r, v, t).r, theta, h, false);
            assert!(close(an.dv, dv, 1e-4, tiny), "R_v {} vs {dv} at v {v}, θ {theta}: {r:?}", an.dv);
            assert!(close(an.dtheta, dt, 1e-4, tiny), "R_θ {} vs {dt} at v {v}, θ {theta}: {r:?}", an.dtheta);
            worst = worst.max((an.dv - dv).abs() / an.dv.abs().max(dv.abs()).max(tiny));
            let r32 = r.radius(v as f32, theta as f32);
            let rs = r.radius as f64;
            assert!(close(r32.r as f64, an.r, 1e-5, 1e-7 * rs), "f32 R {} vs {}", r32.r, an.r);
            assert!(close(r32.dv as f64, an.dv, 1e-4, 1e-5 * rs), "f32 R_v {} vs {}", r32.dv, an.dv);
            assert!(
                close(r32.dtheta as f64, an.dtheta, 1e-4, 1e-5 * rs),
                "f32 R_θ {} vs {}",
                r32.dtheta,
                an.dtheta
            );
        }
    }
    assert!(worst < 1e-6, "worst relative error {worst}");
    // Erratum 1: the taper's slope is negative; t = 0 is no taper.
    let r = BranchRecord {
        taper: 2.0,
        ..BranchRecord::new([Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0], Vec3::Y, 0.2)
    };
    assert!(r.radius(0.5, 0.0).dv < 0.0);
    let r0 = BranchRecord { taper: 0.0, ..r };
    assert_eq!((r0.radius(0.9, 1.0).r, r0.radius(0.9, 1.0).dv), (0.2, 0.0));
}

/// Property 17: Q_u, Q_a, Q_b (corrected Eqs. 15–16) and X_v, X_θ equal finite
/// differences of Q and X.
#[test]
fn jacobian_equals_finite_differences() {
    let mut rng = Pcg64::seed_from_u64(17);
    let h = 1e-6;
    for _ in 0..BRANCHES {
        let (r, length) = random_branch(&mut rng);
        let d = BranchDeformer::<DVec3>::new(&r);
        let len = length as f64;
        let big = 3.0 * r.radius as f64;
        for _ in 0..8 {
            let (u, a, b) = (
                rng.random::<f64>(),
                uniform(&mut rng, -1.0, 1.0) as f64 * big,
                uniform(&mut rng, -1.0, 1.0) as f64 * big,
            );
            let [qu, qa, qb] = d.q_derivatives(u, a, b);
            let nu = (d.q(u + h, a, b) - d.q(u - h, a, b)) / (2.0 * h);
            let na = (d.q(u, a + h, b) - d.q(u, a - h, b)) / (2.0 * h);
            let nb = (d.q(u, a, b + h) - d.q(u, a, b - h)) / (2.0 * h);
            assert!(close64(qu, nu, 1e-4, 1e-9 * len), "Q_u {qu} vs {nu}");
            assert!(close64(qa, na, 1e-4, 1e-9), "Q_a {qa} vs {na}");
            assert!(close64(qb, nb, 1e-4, 1e-9), "Q_b {qb} vs {nb}");
        }
        for (v, theta) in derivative_samples(&mut rng, &r) {
            let s = d.evaluate(v, theta);
            let xv = if v == 0.0 {
                (d.position(0.0, theta) * -3.0 + d.position(h, theta) * 4.0 - d.position(2.0 * h, theta))
                    / (2.0 * h)
            } else {
                (d.position(v + h, theta) - d.position(v - h, theta)) / (2.0 * h)
            };
            let xt = (d.position(v, theta + h) - d.position(v, theta - h)) / (2.0 * h);
            assert!(
                close64(s.tangent_v, xv, 1e-4, 1e-9 * len),
                "X_v {} vs {xv} at v {v}: {r:?}",
                s.tangent_v
            );
            assert!(
                close64(s.tangent_theta, xt, 1e-4, 1e-9 * len),
                "X_θ {} vs {xt} at v {v}",
                s.tangent_theta
            );
        }
    }
}

/// Property 18: normals point outward, N · (X − Q(v, 0, 0)) > 0, wherever the normal is
/// not the centreline fallback; and the grid's triangles face the same way.
#[test]
fn normals_point_outward() {
    let mut rng = Pcg64::seed_from_u64(18);
    let grids = Grids::standard();
    for _ in 0..BRANCHES {
        let (r, _) = random_branch(&mut rng);
        let d = Deformer::new(&r);
        for gv in grids.lod_vertices(0) {
            let s = d.evaluate(gv.v, gv.theta);
            assert!(s.normal.is_finite() && (s.normal.length() - 1.0).abs() < 1e-5);
            if s.degenerate {
                assert!(s.radius.r <= 1e-6 * r.radius || gv.v == 0.0, "fallback only at R = 0 or the base");
                assert!(s.normal.dot(d.centreline_tangent(gv.v)) > 0.9999, "the centreline tangent");
            } else {
                assert!(
                    s.normal.dot(s.position - s.centre) > 0.0,
                    "inward normal at v {} θ {}: {r:?}",
                    gv.v,
                    gv.theta
                );
            }
        }
        let mesh = branch_mesh(&[r], &grids, 0);
        let normals = &mesh.normals.as_ref().unwrap().values;
        for f in 0..mesh.face_count() {
            let v = mesh.face(f);
            let p = |k: usize| mesh.positions[v[k] as usize];
            let n = (p(1) - p(0)).cross(p(2) - p(0));
            if n.length() <= 1e-6 * r.radius * r.radius {
                continue; // a sliver on the collapsed tip ring
            }
            let mean = normals[v[0] as usize] + normals[v[1] as usize] + normals[v[2] as usize];
            assert!(n.dot(mean) > 0.0, "triangle {f} faces inward");
        }
    }
    // The fallbacks: the tip of a taper to 0, and v = 0 for 0 < t < 1.
    let mut r = BranchRecord::new(control_polygon(2.0, [0.3, 0.5, -0.2, 0.4]).unwrap(), Vec3::Y, 0.1);
    r.taper = 0.5;
    let d = Deformer::new(&r);
    for (v, th) in [(0.0, 0.3), (1.0, 2.0)] {
        let s = d.evaluate(v, th);
        assert!(s.degenerate && s.tangent_v.is_finite(), "v {v}");
        assert!(s.normal.distance(d.centreline_tangent(v)) < 1e-6);
    }
}

/// First half of property 19: every LOD grid lies on the same analytic surface (shared
/// (v, θ) samples deform to the same point, every vertex is X(v, θ)), and the seam
/// column coincides with the first one.
#[test]
fn lod_grids_lie_on_one_surface_and_seams_close() {
    let mut rng = Pcg64::seed_from_u64(19);
    let grids = Grids::standard();
    assert_eq!(grids.lods.len(), DEFAULT_LODS.len());
    for (l, &(rings, sides)) in grids.lods.iter().zip(&DEFAULT_LODS) {
        assert_eq!((l.rings, l.sides), (rings, sides));
        assert_eq!(l.vertex_count, rings * (sides + 1));
        assert_eq!(l.index_count, 6 * (rings - 1) * sides);
    }
    assert_eq!(grids.vertices.len(), grids.lods.iter().map(|l| l.vertex_count as usize).sum::<usize>());
    assert!(grids.indices.iter().all(|&i| (i as usize) < grids.vertices.len()));
    let records: Vec<BranchRecord> = (0..40).map(|_| random_branch(&mut rng).0).collect();
    let meshes: Vec<_> = (0..grids.lods.len()).map(|lod| branch_mesh(&records, &grids, lod)).collect();
    let key = |v: f32, t: f32| (v.to_bits(), t.to_bits());
    for (lod, mesh) in meshes.iter().enumerate() {
        let level = grids.lods[lod];
        let verts = grids.lod_vertices(lod);
        assert_eq!(mesh.positions.len(), records.len() * verts.len());
        assert_eq!(mesh.face_count(), records.len() * level.index_count as usize / 3);
        mesh.validate().unwrap();
        let fine: std::collections::HashMap<_, usize> =
            grids.lod_vertices(0).iter().enumerate().map(|(i, g)| (key(g.v, g.theta), i)).collect();
        for (k, rec) in records.iter().enumerate() {
            let at = |m: &sylva::Mesh, n: usize, i: usize| m.positions[k * n + i];
            for (i, g) in verts.iter().enumerate() {
                let p = at(mesh, verts.len(), i);
                assert_eq!(
                    (p, mesh.normals.as_ref().unwrap().values[k * verts.len() + i]),
                    sylva::deform::deform(rec, g.v, g.theta)
                );
                let j =
                    *fine.get(&key(g.v, g.theta)).expect("a coarser level's samples are the finest level's");
                assert_eq!(
                    p,
                    at(&meshes[0], grids.lod_vertices(0).len(), j),
                    "same surface point on LOD 0 and {lod}"
                );
            }
            let cols = level.sides as usize + 1;
            for ring in 0..level.rings as usize {
                let (first, seam) = (ring * cols, ring * cols + cols - 1);
                assert_eq!(at(mesh, verts.len(), first), at(mesh, verts.len(), seam), "the seam closes");
                assert_eq!((verts[first].uv.x, verts[seam].uv.x), (0.0, 1.0));
            }
        }
    }
    // A single grid, and the limits.
    let g = grid(5, 6).unwrap();
    assert_eq!((g.vertices.len(), g.indices.len()), (5 * 7, 6 * 4 * 6));
    assert!(grid(2, 2).is_err() && Grids::new(&[(8, 8), (1, 3)]).is_err());
}

/// A small tree: a trunk of five nodes with two side branches, one with a sub-branch.
fn small_skeleton() -> sylva::Skeleton {
    use sylva::NO_PARENT;
    let mut s = sylva::Skeleton::new();
    let up = Vec3::Z;
    let a = s.push(Vec3::ZERO, 0.3, NO_PARENT, up, 0);
    let b = s.push(Vec3::new(0.0, 1.0, 0.0), 0.25, a, up, 0);
    let c = s.push(Vec3::new(0.1, 2.0, 0.0), 0.2, b, up, 0);
    let d = s.push(Vec3::new(0.0, 3.0, 0.1), 0.15, c, up, 0);
    s.push(Vec3::new(-0.1, 4.0, 0.0), 0.1, d, up, 0);
    let e = s.push(Vec3::new(0.8, 1.6, 0.0), 0.1, b, up, 1);
    let f = s.push(Vec3::new(1.5, 2.0, 0.3), 0.07, e, up, 1);
    s.push(Vec3::new(1.8, 2.8, 0.3), 0.04, f, up, 2);
    s.push(Vec3::new(-0.7, 2.8, 0.4), 0.08, c, up, 1);
    s
}

fn assert_records(curves: &sylva::model::BranchCurves, what: &str) {
    let records = branch_records(curves);
    let segments: Vec<_> = curves
        .axes
        .iter()
        .enumerate()
        .flat_map(|(a, ax)| ax.segments.iter().enumerate().map(move |(k, s)| (a, k, s)))
        .collect();
    assert_eq!(records.len(), segments.len(), "{what}: one record per segment");
    // The wind rig's branches, in the same order.
    let rig = sylva::wind::WindRig::new(curves);
    assert_eq!(rig.branches.len(), records.len());
    let mut continued = 0;
    for (i, (rec, &(a, k, seg))) in records.iter().zip(&segments).enumerate() {
        assert_eq!(rec.points(), seg.points, "{what}: record {i}");
        assert_eq!(rig.branches[i].rest.map(|p| p.as_vec3()), seg.points, "{what}: wind branch {i}");
        assert_eq!((rec.radius, rec.tip_radius, rec.taper), (seg.radii[0], seg.radii[1], 1.0));
        assert_eq!((rec.axis, rec.segment, rec.order), (a as u32, k as u32, curves.axes[a].order as u32));
        assert!((rec.parent_dir.length() - 1.0).abs() < 1e-5, "{what}: O unit");
        let d = Deformer::new(rec);
        for theta in [0.0, 2.0, 4.0] {
            for (v, want) in [(0.0, seg.radii[0]), (1.0, seg.radii[1])] {
                let s = d.evaluate(v, theta);
                assert!(s.position.is_finite() && s.normal.is_finite());
                assert!(
                    (s.position.distance(s.centre) - want).abs() <= 1e-5 * want.max(1.0),
                    "{what}: ring radius"
                );
            }
        }
        // Along a C¹ chain the frame runs on across the knot.
        if k > 0 {
            let prev = Deformer::new(&records[i - 1]);
            let (l2, l0) = (prev.handles.l[2], d.handles.l[0]);
            if l2.dot(l0) > 1.0 - 1e-6 {
                assert!(d.handles.s[0].distance(prev.handles.s[2]) < 1e-3, "{what}: S₀ = previous S₂");
                assert!(d.handles.t[0].distance(prev.handles.t[2]) < 1e-3, "{what}: T₀ = previous T₂");
                continued += 1;
            }
        }
    }
    assert!(continued > 0 || records.len() == curves.axes.len(), "{what}: some knot checked");
    let mesh = branch_mesh(&records, &Grids::standard(), 3);
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
}

/// Records of a model's branch curves: fitted chains (L-systems, colonization, least
/// cost) and Weber–Penn's own Béziers.
#[test]
fn records_of_fitted_and_weber_penn_curves() {
    let fitted = sylva::model::BranchCurves::fit(&small_skeleton());
    assert_records(&fitted, "fitted");
    let loaded = sylva::recipe::load("wp-quaking-aspen", &[]).unwrap();
    let sylva::recipe::Generator::WeberPenn(p) = &loaded.recipe.generator else { panic!("weber-penn") };
    let tree = sylva::grow::weber_penn::grow(p, loaded.recipe.seed).unwrap();
    assert_records(&sylva::grow::weber_penn::branch_curves(&tree), "wp-quaking-aspen");
}
