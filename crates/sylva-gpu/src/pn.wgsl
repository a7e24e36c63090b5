// PN triangles and PN quads on the GPU (Skjermo2008-spec §5, Th Eqs. 3.1–3.2, Figs. 3.8–3.9):
// the same control-point and normal rules as the engine's CPU `sylva::refine::pn`
// (crates/sylva/src/refine/pn.rs), in the same f32 arithmetic order. See src/pn.rs for
// the host side.
//
// Two compute passes: `build_*` turns each patch's corners into its control net (one
// thread per patch; redo it when an animated cage moves), `eval_*` evaluates the nets over
// the instanced (i, j) grid of one level (one thread per patch × grid vertex; a vertex
// shader would do the same with `instance_index` → patch and the grid as vertex data).
// Boundary points are evaluated from the edge's two corners alone, in an order fixed by
// the corners' bits, so patches sharing an edge give bit-identical points (property 27).

const WG: u32 = 64u;
const MAX_F32: f32 = 3.40282347e38;

struct Corners {
    // Corner positions and unit normals (xyz); triangles use the first three.
    p: array<vec4<f32>, 4>,
    n: array<vec4<f32>, 4>,
}

// A patch's control net. Triangle: b = b300 b030 b003 b210 b120 b021 b012 b102 b201 b111,
// m = n200 n020 n002 n110 n011 n101. Quad: b[4i + j] = P[i][j], m[3i + j] = N[i][j].
struct Net {
    b: array<vec4<f32>, 16>,
    m: array<vec4<f32>, 9>,
}

struct Params {
    // level (segments per edge), patches, edge rule (0 ⅓, 1 ½), diagonal rule.
    a: vec4<u32>,
    // quad interior (0 zero twist, 1 Theyer), normals (0 linear, 1 quadratic), grid vertices, 0.
    b: vec4<u32>,
}

struct Sample {
    p: vec4<f32>,
    n: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> corners: array<Corners>;
@group(0) @binding(1) var<storage, read_write> nets: array<Net>;
// Read-only storage rather than a uniform buffer: lavapipe inlines uniform values used in
// control flow and recompiles the shader when they change.
@group(0) @binding(2) var<storage, read> params: Params;

@group(1) @binding(0) var<storage, read> grid: array<vec2<u32>>;
@group(1) @binding(1) var<storage, read_write> samples: array<Sample>;

fn normalize_or_zero(v: vec3<f32>) -> vec3<f32> {
    let r = 1.0 / length(v);
    if (r > 0.0 && r <= MAX_F32) {
        return v * r;
    }
    return vec3<f32>(0.0);
}

// Th Eq. 3.1 (rule 0) or Eq. 3.2 (rule 1): the ⅓ or ½ point of pi → pj projected onto
// the tangent plane of pi.
fn control_point(pi: vec3<f32>, ni: vec3<f32>, pj: vec3<f32>, rule: u32) -> vec3<f32> {
    let w = dot(pj - pi, ni);
    if (rule == 0u) {
        return (2.0 * pi + pj - w * ni) / 3.0;
    }
    return (pi + pj - w * ni) * 0.5;
}

// Vlachos' mid-edge normal (symmetric in its ends).
fn mid_edge_normal(pi: vec3<f32>, ni: vec3<f32>, pj: vec3<f32>, nj: vec3<f32>) -> vec3<f32> {
    let d = pj - pi;
    let dd = dot(d, d);
    var h = ni + nj;
    if (dd > 0.0) {
        h = ni + nj - (2.0 * dot(d, ni + nj) / dd) * d;
    }
    return normalize_or_zero(h);
}

fn bernstein3(t: f32) -> vec4<f32> {
    let s = 1.0 - t;
    return vec4<f32>(s * s * s, 3.0 * s * s * t, 3.0 * s * t * t, t * t * t);
}

fn flat_index(id: vec3<u32>, groups: vec3<u32>) -> u32 {
    return id.x + id.y * groups.x * WG;
}

@compute @workgroup_size(64)
fn build_triangles(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let f = flat_index(id, groups);
    if (f >= params.a.y) {
        return;
    }
    var c = corners[f];
    let p1 = c.p[0].xyz;
    let p2 = c.p[1].xyz;
    let p3 = c.p[2].xyz;
    let n1 = c.n[0].xyz;
    let n2 = c.n[1].xyz;
    let n3 = c.n[2].xyz;
    let r = params.a.z;
    let b210 = control_point(p1, n1, p2, r);
    let b120 = control_point(p2, n2, p1, r);
    let b021 = control_point(p2, n2, p3, r);
    let b012 = control_point(p3, n3, p2, r);
    let b102 = control_point(p3, n3, p1, r);
    let b201 = control_point(p1, n1, p3, r);
    let e = (b210 + b120 + b021 + b012 + b102 + b201) / 6.0;
    let v = (p1 + p2 + p3) / 3.0;
    let b111 = e + (e - v) * 0.5;
    var built: Net;
    built.b[0] = vec4<f32>(p1, 0.0);
    built.b[1] = vec4<f32>(p2, 0.0);
    built.b[2] = vec4<f32>(p3, 0.0);
    built.b[3] = vec4<f32>(b210, 0.0);
    built.b[4] = vec4<f32>(b120, 0.0);
    built.b[5] = vec4<f32>(b021, 0.0);
    built.b[6] = vec4<f32>(b012, 0.0);
    built.b[7] = vec4<f32>(b102, 0.0);
    built.b[8] = vec4<f32>(b201, 0.0);
    built.b[9] = vec4<f32>(b111, 0.0);
    built.m[0] = vec4<f32>(n1, 0.0);
    built.m[1] = vec4<f32>(n2, 0.0);
    built.m[2] = vec4<f32>(n3, 0.0);
    built.m[3] = vec4<f32>(mid_edge_normal(p1, n1, p2, n2), 0.0);
    built.m[4] = vec4<f32>(mid_edge_normal(p2, n2, p3, n3), 0.0);
    built.m[5] = vec4<f32>(mid_edge_normal(p3, n3, p1, n1), 0.0);
    nets[f] = built;
}

@compute @workgroup_size(64)
fn build_quads(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let f = flat_index(id, groups);
    if (f >= params.a.y) {
        return;
    }
    var c = corners[f];
    var cp: array<vec3<f32>, 4>;
    var cn: array<vec3<f32>, 4>;
    for (var k = 0u; k < 4u; k++) {
        cp[k] = c.p[k].xyz;
        cn[k] = c.n[k].xyz;
    }
    let r = params.a.z;
    var p: array<vec3<f32>, 16>;
    // P[i][j] at 4i + j: i along corner 0 → 1, j along 0 → 3.
    p[0] = cp[0];
    p[12] = cp[1];
    p[15] = cp[2];
    p[3] = cp[3];
    p[4] = control_point(cp[0], cn[0], cp[1], r);
    p[8] = control_point(cp[1], cn[1], cp[0], r);
    p[13] = control_point(cp[1], cn[1], cp[2], r);
    p[14] = control_point(cp[2], cn[2], cp[1], r);
    p[11] = control_point(cp[2], cn[2], cp[3], r);
    p[7] = control_point(cp[3], cn[3], cp[2], r);
    p[2] = control_point(cp[3], cn[3], cp[0], r);
    p[1] = control_point(cp[0], cn[0], cp[3], r);
    if (params.b.x == 0u) {
        // Zero twist: P₁₁ = P₁₀ + P₀₁ − P₀₀ at each corner.
        p[5] = p[4] + p[1] - p[0];
        p[9] = p[8] + p[13] - p[12];
        p[10] = p[14] + p[11] - p[15];
        p[6] = p[2] + p[7] - p[3];
    } else {
        // Theyer: the diagonal rule along the diagonals.
        let d = params.a.w;
        p[5] = control_point(cp[0], cn[0], cp[2], d);
        p[10] = control_point(cp[2], cn[2], cp[0], d);
        p[9] = control_point(cp[1], cn[1], cp[3], d);
        p[6] = control_point(cp[3], cn[3], cp[1], d);
    }
    let m01 = mid_edge_normal(cp[0], cn[0], cp[1], cn[1]);
    let m12 = mid_edge_normal(cp[1], cn[1], cp[2], cn[2]);
    let m23 = mid_edge_normal(cp[2], cn[2], cp[3], cn[3]);
    let m30 = mid_edge_normal(cp[3], cn[3], cp[0], cn[0]);
    let centre = normalize_or_zero(m01 + m12 + m23 + m30);
    var built: Net;
    for (var k = 0u; k < 16u; k++) {
        built.b[k] = vec4<f32>(p[k], 0.0);
    }
    built.m[0] = vec4<f32>(cn[0], 0.0);
    built.m[1] = vec4<f32>(m30, 0.0);
    built.m[2] = vec4<f32>(cn[3], 0.0);
    built.m[3] = vec4<f32>(m01, 0.0);
    built.m[4] = vec4<f32>(centre, 0.0);
    built.m[5] = vec4<f32>(m23, 0.0);
    built.m[6] = vec4<f32>(cn[1], 0.0);
    built.m[7] = vec4<f32>(m12, 0.0);
    built.m[8] = vec4<f32>(cn[2], 0.0);
    nets[f] = built;
}

// Lexicographic order of a corner's bits (position, then normal), the CPU's canonical
// edge direction.
fn corner_after(pa: vec3<f32>, na: vec3<f32>, pb: vec3<f32>, nb: vec3<f32>) -> bool {
    var a = array<u32, 6>(bitcast<u32>(pa.x), bitcast<u32>(pa.y), bitcast<u32>(pa.z), bitcast<u32>(na.x), bitcast<u32>(na.y), bitcast<u32>(na.z));
    var b = array<u32, 6>(bitcast<u32>(pb.x), bitcast<u32>(pb.y), bitcast<u32>(pb.z), bitcast<u32>(nb.x), bitcast<u32>(nb.y), bitcast<u32>(nb.z));
    for (var k = 0u; k < 6u; k++) {
        if (a[k] != b[k]) {
            return a[k] > b[k];
        }
    }
    return false;
}

// The point and normal at step `t` of `level` along the boundary curve a → b, evaluated in
// canonical direction.
fn edge_sample(pa: vec3<f32>, na: vec3<f32>, pb: vec3<f32>, nb: vec3<f32>, t: u32, level: u32) -> Sample {
    var x = pa;
    var xn = na;
    var y = pb;
    var yn = nb;
    var k = t;
    if (corner_after(pa, na, pb, nb)) {
        x = pb;
        xn = nb;
        y = pa;
        yn = na;
        k = level - t;
    }
    let r = params.a.z;
    let c1 = control_point(x, xn, y, r);
    let c2 = control_point(y, yn, x, r);
    let u = f32(k) / f32(level);
    let w = bernstein3(u);
    let p = x * w.x + c1 * w.y + c2 * w.z + y * w.w;
    let s = 1.0 - u;
    var n: vec3<f32>;
    if (params.b.y == 0u) {
        n = xn * s + yn * u;
    } else {
        n = xn * (s * s) + mid_edge_normal(x, xn, y, yn) * (s * u) + yn * (u * u);
    }
    return Sample(vec4<f32>(p, 0.0), vec4<f32>(normalize_or_zero(n), 0.0));
}

fn corner_sample(f: u32, k: u32) -> Sample {
    return Sample(vec4<f32>(corners[f].p[k].xyz, 0.0), vec4<f32>(corners[f].n[k].xyz, 0.0));
}

fn edge_of(f: u32, a: u32, b: u32, t: u32, level: u32) -> Sample {
    let c = &corners[f];
    return edge_sample((*c).p[a].xyz, (*c).n[a].xyz, (*c).p[b].xyz, (*c).n[b].xyz, t, level);
}

// PN triangle at grid point (i, j): weight i/level on corner 1, j/level on corner 2.
fn eval_triangle(f: u32, i: u32, j: u32) -> Sample {
    let s = params.a.x;
    if (i == 0u && j == 0u) {
        return corner_sample(f, 0u);
    }
    if (i == s) {
        return corner_sample(f, 1u);
    }
    if (j == s) {
        return corner_sample(f, 2u);
    }
    if (j == 0u) {
        return edge_of(f, 0u, 1u, i, s);
    }
    if (i + j == s) {
        return edge_of(f, 1u, 2u, j, s);
    }
    if (i == 0u) {
        return edge_of(f, 2u, 0u, s - j, s);
    }
    let net = &nets[f];
    let u = f32(i) / f32(s);
    let v = f32(j) / f32(s);
    let w = 1.0 - u - v;
    let p = (*net).b[0].xyz * (w * w * w)
        + (*net).b[1].xyz * (u * u * u)
        + (*net).b[2].xyz * (v * v * v)
        + (*net).b[3].xyz * (3.0 * w * w * u)
        + (*net).b[4].xyz * (3.0 * w * u * u)
        + (*net).b[5].xyz * (3.0 * u * u * v)
        + (*net).b[6].xyz * (3.0 * u * v * v)
        + (*net).b[7].xyz * (3.0 * w * v * v)
        + (*net).b[8].xyz * (3.0 * w * w * v)
        + (*net).b[9].xyz * (6.0 * w * u * v);
    var n: vec3<f32>;
    if (params.b.y == 0u) {
        n = (*net).m[0].xyz * w + (*net).m[1].xyz * u + (*net).m[2].xyz * v;
    } else {
        n = (*net).m[0].xyz * (w * w)
            + (*net).m[1].xyz * (u * u)
            + (*net).m[2].xyz * (v * v)
            + (*net).m[3].xyz * (w * u)
            + (*net).m[4].xyz * (u * v)
            + (*net).m[5].xyz * (v * w);
    }
    return Sample(vec4<f32>(p, 0.0), vec4<f32>(normalize_or_zero(n), 0.0));
}

// PN quad at grid point (i, j): u = i/level along corner 0 → 1, v = j/level along 0 → 3.
fn eval_quad(f: u32, i: u32, j: u32) -> Sample {
    let s = params.a.x;
    if (i == 0u && j == 0u) {
        return corner_sample(f, 0u);
    }
    if (i == s && j == 0u) {
        return corner_sample(f, 1u);
    }
    if (i == s && j == s) {
        return corner_sample(f, 2u);
    }
    if (i == 0u && j == s) {
        return corner_sample(f, 3u);
    }
    if (j == 0u) {
        return edge_of(f, 0u, 1u, i, s);
    }
    if (i == s) {
        return edge_of(f, 1u, 2u, j, s);
    }
    if (j == s) {
        return edge_of(f, 2u, 3u, s - i, s);
    }
    if (i == 0u) {
        return edge_of(f, 3u, 0u, s - j, s);
    }
    let net = &nets[f];
    let u = f32(i) / f32(s);
    let v = f32(j) / f32(s);
    let bu = bernstein3(u);
    let bv = bernstein3(v);
    var p = vec3<f32>(0.0);
    for (var a = 0u; a < 4u; a++) {
        var row = vec3<f32>(0.0);
        for (var b = 0u; b < 4u; b++) {
            row += (*net).b[4u * a + b].xyz * bv[b];
        }
        p += row * bu[a];
    }
    var n = vec3<f32>(0.0);
    if (params.b.y == 0u) {
        let c = &corners[f];
        n = ((*c).n[0].xyz * (1.0 - u) + (*c).n[1].xyz * u) * (1.0 - v) + ((*c).n[3].xyz * (1.0 - u) + (*c).n[2].xyz * u) * v;
    } else {
        let qu = vec3<f32>((1.0 - u) * (1.0 - u), u * (1.0 - u), u * u);
        let qv = vec3<f32>((1.0 - v) * (1.0 - v), v * (1.0 - v), v * v);
        for (var a = 0u; a < 3u; a++) {
            for (var b = 0u; b < 3u; b++) {
                n += (*net).m[3u * a + b].xyz * (qu[a] * qv[b]);
            }
        }
    }
    return Sample(vec4<f32>(p, 0.0), vec4<f32>(normalize_or_zero(n), 0.0));
}

@compute @workgroup_size(64)
fn eval_triangles(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = flat_index(id, groups);
    let per = params.b.z;
    if (k >= params.a.y * per) {
        return;
    }
    let g = grid[k % per];
    samples[k] = eval_triangle(k / per, g.x, g.y);
}

@compute @workgroup_size(64)
fn eval_quads(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = flat_index(id, groups);
    let per = params.b.z;
    if (k >= params.a.y * per) {
        return;
    }
    let g = grid[k % per];
    samples[k] = eval_quad(k / per, g.x, g.y);
}
