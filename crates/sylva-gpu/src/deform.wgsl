// The GPU branch deformer (Skjermo2008 D §2–§3.5 as Skjermo2008-spec §3 corrects it; issue 25 item
// 1): a line-for-line port of the engine's CPU reference `sylva::deform`
// (crates/sylva/src/mesh/deform/), in the same f32 operations and order. `deform_at` turns
// a grid sample (v, θ) of one branch record into the surface point and its outward unit
// normal; the compute entry point below the marker writes it for a list of samples (the
// property 19 test), and `branches.wgsl`'s vertex shader calls the same function for
// every instanced grid vertex (src/deform.rs and src/branches.rs put the sources
// together: everything above the marker is shared, it declares no bindings).
//
// Control points come from a separate buffer of 4 × vec4<f32> per branch (xyz, w
// ignored): the layout of `GpuWind::points_buffer`, so the wind pass moves what is drawn
// without a copy. The record's own p0…p3 are the rest pose the host uploaded.

const TINY_SQ: f32 = 1e-12;
const PARALLEL_SQ: f32 = 1e-6;
const NORMAL_SQ: f32 = 1e-10;
const LN_100: f32 = 4.6051702;
const TAU: f32 = 6.2831855;

// `sylva::deform::BranchRecord`, 112 bytes, the same fields at the same offsets.
struct BranchRecord {
    p0: vec3<f32>,
    radius: f32,
    p1: vec3<f32>,
    tip_radius: f32,
    p2: vec3<f32>,
    taper: f32,
    p3: vec3<f32>,
    flare: f32,
    parent_dir: vec3<f32>,
    flare_mode: u32,
    bulge_depth: f32,
    bulge_count: f32,
    lobe_depth: f32,
    lobe_count: f32,
    lobe_fade: f32,
    order: u32,
    axis: u32,
    segment: u32,
}

struct Cubic {
    p0: vec3<f32>,
    p1: vec3<f32>,
    p2: vec3<f32>,
    p3: vec3<f32>,
}

struct Radius {
    r: f32,
    dv: f32,
    dtheta: f32,
}

// Sloan's frame: S₀…S₂, T₀…T₂ and the middle leg L₁ (the centreline fallback).
struct Handles {
    s0: vec3<f32>,
    s1: vec3<f32>,
    s2: vec3<f32>,
    t0: vec3<f32>,
    t1: vec3<f32>,
    t2: vec3<f32>,
    l1: vec3<f32>,
}

struct Surface {
    position: vec3<f32>,
    normal: vec3<f32>,
}

// glam's `lerp`: a (1 − t) + b t.
fn lerp3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return a * (1.0 - t) + b * t;
}

// xᵉ for x ≥ 0 with the CPU's values at x = 0 (1 for e = 0, 0 for e > 0); WGSL leaves
// pow(0, e) undefined. e < 0 at x = 0 (R_v at the base for 0 < t < 1) is infinite on
// the CPU and unused there; 0 here.
fn pow0(x: f32, e: f32) -> f32 {
    if x <= 0.0 {
        return select(0.0, 1.0, e == 0.0);
    }
    return pow(x, e);
}

fn taper(r: f32, r_tip: f32, t: f32, v: f32) -> f32 {
    if t == 0.0 {
        return r;
    }
    let w = pow0(v, t);
    return r * (1.0 - w) + r_tip * w;
}

fn taper_dv(r: f32, r_tip: f32, t: f32, v: f32) -> f32 {
    if t == 0.0 || r == r_tip {
        return 0.0;
    }
    return -t * (r - r_tip) * pow0(v, t - 1.0);
}

fn hundred_pow(y: f32) -> f32 {
    return exp(LN_100 * y);
}

fn flare(f: f32, mode: u32, v: f32) -> f32 {
    let y = 1.0 - 8.0 * v;
    if mode == 0u {
        let yc = select(0.0, y, y > 0.0);
        return f * (hundred_pow(yc) - 1.0) / 100.0 + 1.0;
    }
    return f / 100.0 * hundred_pow(y) + 1.0;
}

fn flare_dv(f: f32, mode: u32, v: f32) -> f32 {
    let y = 1.0 - 8.0 * v;
    if mode == 0u && y <= 0.0 {
        return 0.0;
    }
    return -(f / 100.0) * 8.0 * LN_100 * hundred_pow(y);
}

fn bulges(depth: f32, count: f32, v: f32) -> f32 {
    return 1.0 + depth * sin(TAU * count * v);
}

fn bulges_dv(depth: f32, count: f32, v: f32) -> f32 {
    return TAU * depth * count * cos(TAU * count * v);
}

fn lobes(depth: f32, count: f32, fade: f32, v: f32, theta: f32) -> f32 {
    return 1.0 + depth * sin(count * theta) * (1.0 - v * fade);
}

fn lobes_dv(depth: f32, count: f32, fade: f32, theta: f32) -> f32 {
    return -depth * fade * sin(count * theta);
}

fn lobes_dtheta(depth: f32, count: f32, fade: f32, v: f32, theta: f32) -> f32 {
    return depth * count * cos(count * theta) * (1.0 - v * fade);
}

// R(v, θ), R_v, R_θ (D Eqs. 2–5, 10, 11 with Skjermo2008-spec's errata).
fn radius_at(b: BranchRecord, v: f32, theta: f32) -> Radius {
    let ft = taper(b.radius, b.tip_radius, b.taper, v);
    let ff = flare(b.flare, b.flare_mode, v);
    let fb = bulges(b.bulge_depth, b.bulge_count, v);
    let fl = lobes(b.lobe_depth, b.lobe_count, b.lobe_fade, v, theta);
    let dft = taper_dv(b.radius, b.tip_radius, b.taper, v);
    let dff = flare_dv(b.flare, b.flare_mode, v);
    let dfb = bulges_dv(b.bulge_depth, b.bulge_count, v);
    let dfl = lobes_dv(b.lobe_depth, b.lobe_count, b.lobe_fade, theta);
    var out: Radius;
    out.r = ft * ff * fb * fl;
    out.dv = dft * ff * fb * fl + ft * dff * fb * fl + ft * ff * dfb * fl + ft * ff * fb * dfl;
    out.dtheta = ft * ff * fb * lobes_dtheta(b.lobe_depth, b.lobe_count, b.lobe_fade, v, theta);
    return out;
}

fn unit_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    if dot(v, v) > TINY_SQ {
        return normalize(v);
    }
    return fallback;
}

// The world axis least aligned with l (ties to X, then Y).
fn fallback_axis(l: vec3<f32>) -> vec3<f32> {
    let a = abs(l);
    if a.x <= a.y && a.x <= a.z {
        return vec3<f32>(1.0, 0.0, 0.0);
    }
    if a.y <= a.z {
        return vec3<f32>(0.0, 1.0, 0.0);
    }
    return vec3<f32>(0.0, 0.0, 1.0);
}

// Sloan's moving frame (D Eq. 8) with Skjermo2008-spec's normalisations and fallbacks.
fn sloan_frames(p: Cubic, o: vec3<f32>) -> Handles {
    let l0 = unit_or(p.p1 - p.p0, unit_or(p.p3 - p.p0, vec3<f32>(1.0, 0.0, 0.0)));
    let l1 = unit_or(p.p2 - p.p1, l0);
    let l2 = unit_or(p.p3 - p.p2, l1);
    var s0 = cross(l0, o);
    if dot(s0, s0) > PARALLEL_SQ {
        s0 = normalize(s0);
    } else {
        s0 = normalize(cross(l0, fallback_axis(l0)));
    }
    let t0 = cross(s0, l0);
    let t1 = unit_or(cross(s0, l1), t0);
    let s1 = cross(l1, t1);
    let t2 = unit_or(cross(s1, l2), t1);
    let s2 = cross(l2, t2);
    return Handles(s0, s1, s2, t0, t1, t2, l1);
}

// The generalized de Casteljau map Q(u, a, b) (D Eq. 9).
fn q_map(p: Cubic, h: Handles, u: f32, a: f32, b: f32) -> vec3<f32> {
    let r00 = lerp3(p.p0, p.p1, u) + h.s0 * a + h.t0 * b;
    let r10 = lerp3(p.p1, p.p2, u) + h.s1 * a + h.t1 * b;
    let r20 = lerp3(p.p2, p.p3, u) + h.s2 * a + h.t2 * b;
    let r01 = lerp3(r00, r10, u);
    let r11 = lerp3(r10, r20, u);
    return lerp3(r01, r11, u);
}

// Q_u (D Eqs. 15–16 corrected); Q_a and Q_b are `handle_blend` of S and T.
fn q_u(p: Cubic, h: Handles, u: f32, a: f32, b: f32) -> vec3<f32> {
    let dl0 = (p.p1 - p.p0) * 3.0;
    let dl1 = (p.p2 - p.p1) * 3.0;
    let dl2 = (p.p3 - p.p2) * 3.0;
    let ds0 = (h.s1 - h.s0) * 2.0;
    let ds1 = (h.s2 - h.s1) * 2.0;
    let dt0 = (h.t1 - h.t0) * 2.0;
    let dt1 = (h.t2 - h.t1) * 2.0;
    return lerp3(lerp3(dl0, dl1, u), lerp3(dl1, dl2, u), u) + lerp3(ds0, ds1, u) * a + lerp3(dt0, dt1, u) * b;
}

fn handle_blend(x0: vec3<f32>, x1: vec3<f32>, x2: vec3<f32>, u: f32) -> vec3<f32> {
    return lerp3(lerp3(x0, x1, u), lerp3(x1, x2, u), u);
}

// The surface point X(v, θ) = Q(v, sin θ R, cos θ R) and its outward unit normal
// normalize(X_θ × X_v), the centreline tangent where that vanishes (D §3.4–3.5, Skjermo2008-spec
// errata 4–6): `BranchDeformer::evaluate`.
fn deform_at(rec: BranchRecord, p: Cubic, v: f32, theta: f32) -> Surface {
    let h = sloan_frames(p, rec.parent_dir);
    let rad = radius_at(rec, v, theta);
    let sn = sin(theta);
    let cs = cos(theta);
    let a = sn * rad.r;
    let b = cs * rad.r;
    let position = q_map(p, h, v, a, b);
    let qu = q_u(p, h, v, a, b);
    let qa = handle_blend(h.s0, h.s1, h.s2, v);
    let qb = handle_blend(h.t0, h.t1, h.t2, v);
    let t = rec.taper;
    let base_kink = v <= 0.0 && t > 0.0 && t < 1.0 && rec.radius != rec.tip_radius;
    var tangent_v = qu;
    if !base_kink {
        tangent_v = qu + qa * (sn * rad.dv) + qb * (cs * rad.dv);
    }
    let tangent_theta = qa * (cs * rad.r + sn * rad.dtheta) + qb * (cs * rad.dtheta - sn * rad.r);
    let n = cross(tangent_theta, tangent_v);
    let scale = dot(tangent_theta, tangent_theta) * dot(tangent_v, tangent_v);
    var normal: vec3<f32>;
    if base_kink || !(dot(n, n) > NORMAL_SQ * scale) {
        normal = unit_or(q_u(p, h, v, 0.0, 0.0), h.l1);
    } else {
        normal = normalize(n);
    }
    return Surface(position, normal);
}

// ---- compute entry ----
// The sample list pass (property 19): one thread per (branch, v, θ) sample, writing the
// position (xyz, w = 1) and normal (xyz, w = 0) as two vec4s.

struct Sample {
    branch: u32,
    v: f32,
    theta: f32,
    pad: u32,
}

@group(0) @binding(0) var<storage, read> records: array<BranchRecord>;
@group(0) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> samples: array<Sample>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;

@compute @workgroup_size(64)
fn deform_samples(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>) {
    let i = gid.x + gid.y * nw.x * 64u;
    if i >= arrayLength(&samples) {
        return;
    }
    let s = samples[i];
    let k = 4u * s.branch;
    let p = Cubic(points[k].xyz, points[k + 1u].xyz, points[k + 2u].xyz, points[k + 3u].xyz);
    let surface = deform_at(records[s.branch], p, s.v, s.theta);
    out[2u * i] = vec4<f32>(surface.position, 1.0);
    out[2u * i + 1u] = vec4<f32>(surface.normal, 0.0);
}
