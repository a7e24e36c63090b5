// GPU wind: one step of Skjermo2008-spec §4's recommended formulation for a range of branches,
// exactly as the engine's CPU `sylva::wind::WindRig::step` does it (crates/sylva/src/wind/mod.rs),
// in f32. See src/wind.rs for the host side.
//
// No lag: the host dispatches `step` once per branch depth level, in order; each level
// reads its parent's points already updated in this step (wgpu puts a barrier between
// dispatches). Legacy lag: the host copies `points` into `prev` and dispatches once over
// every branch; parents are read from `prev` (the previous step).

const NONE: u32 = 0xffffffffu;
const WG: u32 = 64u;
const PI: f32 = 3.14159265358979;
const MAX_F32: f32 = 3.40282347e38;
// glam's 180° test in `from_rotation_arc`, in f32.
const ONE_MINUS_EPS: f32 = 0.99999976;

struct Branch {
    // Rest control points (xyz; w unused).
    rest: array<vec4<f32>, 4>,
    // (parent or NONE, order, depth, 0).
    ids: vec4<u32>,
    // (attach parameter on the parent, reach = L²/H, 0, 0).
    shape: vec4<f32>,
}

struct Wave {
    // (Dᵢ.x, Dᵢ.y, Aᵢ, ωᵢ); Dᵢ already unit (or zero).
    a: vec4<f32>,
    // (phase φᵢ t mod 2π, 0, 0, 0).
    b: vec4<f32>,
}

struct Params {
    // (W̄.x, W̄.z, impulse.x, impulse.z).
    mean_impulse: vec4<f32>,
    // w₀…w₃ = (k/3)^γ.
    weights: vec4<f32>,
    // (β, largest joint angle in radians, 0, 0).
    beta_joint: vec4<f32>,
    // (waves, stiffness entries, branches, 1 for legacy lag).
    counts: vec4<u32>,
}

struct Level {
    offset: u32,
    count: u32,
}

@group(0) @binding(0) var<storage, read> branches: array<Branch>;
@group(0) @binding(1) var<storage, read_write> points: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> prev: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> level_order: array<u32>;
@group(0) @binding(4) var<storage, read> waves: array<Wave>;
@group(0) @binding(5) var<storage, read> stiffness: array<f32>;
// Read-only storage rather than uniform buffers on purpose: lavapipe (Mesa's software
// Vulkan) inlines uniform values used in control flow into the shader and recompiles it
// whenever they change, i.e. on every level's dispatch (milliseconds each).
@group(0) @binding(6) var<storage, read> params: Params;
@group(0) @binding(7) var<storage, read> level: Level;

// A cubic's four points as named fields: no dynamically indexed local arrays, which
// software drivers (lavapipe) spill to scratch memory they clear on every dispatch.
struct Cubic {
    p0: vec3<f32>,
    p1: vec3<f32>,
    p2: vec3<f32>,
    p3: vec3<f32>,
}

fn rest_of(i: u32) -> Cubic {
    let b = &branches[i];
    return Cubic((*b).rest[0].xyz, (*b).rest[1].xyz, (*b).rest[2].xyz, (*b).rest[3].xyz);
}

fn points_of(i: u32) -> Cubic {
    let k = 4u * i;
    return Cubic(points[k].xyz, points[k + 1u].xyz, points[k + 2u].xyz, points[k + 3u].xyz);
}

fn prev_of(i: u32) -> Cubic {
    let k = 4u * i;
    return Cubic(prev[k].xyz, prev[k + 1u].xyz, prev[k + 2u].xyz, prev[k + 3u].xyz);
}

fn bezier(p: Cubic, t: f32) -> vec3<f32> {
    let s = 1.0 - t;
    return p.p0 * (s * s * s) + p.p1 * (3.0 * s * s * t) + p.p2 * (3.0 * s * t * t) + p.p3 * (t * t * t);
}

// glam's `try_normalize`: None (here `ok = false`) for zero or non-finite lengths.
fn finite_positive(x: f32) -> bool {
    return x > 0.0 && x <= MAX_F32;
}

fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / length(v);
    if (finite_positive(r)) {
        return v * r;
    }
    return vec3<f32>(0.0);
}

fn tangent(p: Cubic, t: f32) -> vec3<f32> {
    let s = 1.0 - t;
    let d = (p.p1 - p.p0) * (3.0 * s * s) + (p.p2 - p.p1) * (6.0 * s * t) + (p.p3 - p.p2) * (3.0 * t * t);
    let r = 1.0 / length(d);
    if (finite_positive(r)) {
        return d * r;
    }
    return normalize_or_zero(p.p3 - p.p0);
}

// glam's `any_orthonormal_vector` (Pixar's branchless basis).
fn any_orthonormal(v: vec3<f32>) -> vec3<f32> {
    let sgn = select(-1.0, 1.0, v.z >= 0.0);
    let a = -1.0 / (sgn + v.z);
    let b = v.x * v.y * a;
    return vec3<f32>(b, sgn + v.y * v.y * a, -v.y);
}

fn quat_axis_angle(axis: vec3<f32>, angle: f32) -> vec4<f32> {
    let h = 0.5 * angle;
    return vec4<f32>(axis * sin(h), cos(h));
}

// The shortest rotation taking unit `from` to unit `to`. Unlike glam's f32 version this
// keeps rotations below ~7e-4 rad (glam snaps them to identity), so f32 follows the f64
// reference closely.
fn rotation_arc(from_dir: vec3<f32>, to_dir: vec3<f32>) -> vec4<f32> {
    let d = dot(from_dir, to_dir);
    if (d < -ONE_MINUS_EPS) {
        return quat_axis_angle(any_orthonormal(from_dir), PI);
    }
    return normalize(vec4<f32>(cross(from_dir, to_dir), 1.0 + d));
}

fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let w = q.w;
    let b = q.xyz;
    let b2 = dot(b, b);
    return v * (w * w - b2) + b * (dot(v, b) * 2.0) + cross(b, v) * (w * 2.0);
}

// glam's `angle_between` (NaN for a zero vector; callers test lengths first).
fn angle_between(a: vec3<f32>, c: vec3<f32>) -> f32 {
    return acos(clamp(dot(a, c) / sqrt(dot(a, a) * dot(c, c)), -1.0, 1.0));
}

fn force(x: f32, z: f32) -> vec2<f32> {
    var f = params.mean_impulse.xy;
    let p = vec2<f32>(x, z);
    for (var i = 0u; i < params.counts.x; i++) {
        let w = waves[i];
        let d = w.a.xy;
        f += d * (w.a.z * sin(w.a.w * dot(d, p) + w.b.x));
    }
    return f;
}

// Step 5 for one leg: `p` re-projected to the rest length from `from` (left alone where
// the leg equals its rest leg, or has its length already, so rest stays rest bit for bit).
fn keep_length(from_p: vec3<f32>, p: vec3<f32>, rest_from: vec3<f32>, rest_p: vec3<f32>, carried_leg: vec3<f32>) -> vec3<f32> {
    let d = p - from_p;
    let rest_leg = rest_p - rest_from;
    if (all(d == rest_leg)) {
        return p;
    }
    let len = length(d);
    let rest_len = length(rest_leg);
    if (len == rest_len) {
        return p;
    }
    var dir: vec3<f32>;
    let r = 1.0 / len;
    if (finite_positive(r)) {
        dir = d * r;
    } else {
        dir = normalize_or_zero(carried_leg);
    }
    return from_p + dir * rest_len;
}

// Step 6 at one joint: the point after the joint `b`, with the angle between the legs
// a → b and b → c clamped to the limit (or the rest joint's own angle, if larger).
fn clamp_joint(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, ra: vec3<f32>, rb: vec3<f32>, rc: vec3<f32>) -> vec3<f32> {
    let u = b - a;
    let v = c - b;
    let lu = length(u);
    if (!(lu > 0.0 && length(v) > 0.0)) {
        return c;
    }
    let ru = rb - ra;
    let rv = rc - rb;
    var max_angle = params.beta_joint.y;
    if (length(ru) > 0.0 && length(rv) > 0.0) {
        max_angle = max(max_angle, angle_between(ru, rv));
    }
    if (!(angle_between(u, v) > max_angle)) {
        return c;
    }
    var axis = cross(u, v);
    let r = 1.0 / length(axis);
    if (finite_positive(r)) {
        axis = axis * r;
    } else {
        axis = any_orthonormal(u);
    }
    let dir = quat_rotate(quat_axis_angle(axis, max_angle), u / lu);
    return b + dir * length(rv);
}

@compute @workgroup_size(64)
fn wind_step(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local = id.x + id.y * groups.x * WG;
    if (local >= level.count) {
        return;
    }
    let i = level_order[level.offset + local];
    let rest = rest_of(i);
    // 1. Carry the rest pose with the parent's current (or, lagging, last) frame.
    var carried = rest;
    let parent = branches[i].ids.x;
    if (parent != NONE) {
        let parent_rest = rest_of(parent);
        var parent_now: Cubic;
        if (params.counts.w != 0u) {
            parent_now = prev_of(parent);
        } else {
            parent_now = points_of(parent);
        }
        let t = branches[i].shape.x;
        let c_rest = bezier(parent_rest, t);
        let c_now = bezier(parent_now, t);
        let t_rest = tangent(parent_rest, t);
        let t_now = tangent(parent_now, t);
        if (any(c_rest != c_now) || any(t_rest != t_now)) {
            let r = rotation_arc(t_rest, t_now);
            carried = Cubic(
                c_now + quat_rotate(r, rest.p0 - c_rest),
                c_now + quat_rotate(r, rest.p1 - c_rest),
                c_now + quat_rotate(r, rest.p2 - c_rest),
                c_now + quat_rotate(r, rest.p3 - c_rest),
            );
        }
    }
    var p = points_of(i);
    // 2. The force at the current tip, in (x, z); the impulse hits the roots only.
    var f = force(p.p3.x, p.p3.z);
    if (branches[i].ids.z == 0u) {
        f += params.mean_impulse.zw;
    }
    let kappa = stiffness[min(branches[i].ids.y, params.counts.y - 1u)];
    let f3 = vec3<f32>(f.x, 0.0, f.y) * (kappa * branches[i].shape.y);
    // 3.–4. Targets and relaxation; P₀ is the attach point.
    let beta = params.beta_joint.x;
    let w = params.weights;
    p.p0 = carried.p0;
    p.p1 += (carried.p1 + f3 * w.y - p.p1) * beta;
    p.p2 += (carried.p2 + f3 * w.z - p.p2) * beta;
    p.p3 += (carried.p3 + f3 * w.w - p.p3) * beta;
    // 5. Rest lengths.
    p.p1 = keep_length(p.p0, p.p1, rest.p0, rest.p1, carried.p1 - carried.p0);
    p.p2 = keep_length(p.p1, p.p2, rest.p1, rest.p2, carried.p2 - carried.p1);
    p.p3 = keep_length(p.p2, p.p3, rest.p2, rest.p3, carried.p3 - carried.p2);
    // 6. Joint angles.
    p.p2 = clamp_joint(p.p0, p.p1, p.p2, rest.p0, rest.p1, rest.p2);
    p.p3 = clamp_joint(p.p1, p.p2, p.p3, rest.p1, rest.p2, rest.p3);
    let k = 4u * i;
    points[k] = vec4<f32>(p.p0, 0.0);
    points[k + 1u] = vec4<f32>(p.p1, 0.0);
    points[k + 2u] = vec4<f32>(p.p2, 0.0);
    points[k + 3u] = vec4<f32>(p.p3, 0.0);
}
