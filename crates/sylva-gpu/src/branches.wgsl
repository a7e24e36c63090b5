// Drawing deformed branches (Skjermo2008 D §2.3–§4, issue 25 item 1): LOD selection by
// projected size (compute) and the instanced vertex shader over the shared (v, θ) grid
// buffer, Lambert + hemispherical ambient shading with bark UVs (θ/2π, arc length /
// circumference). src/branches.rs prepends the shared deformer functions of deform.wgsl
// and the camera and light (`Frame`) of render/frame.wgsl to this header, then takes the
// part between the lod and draw marker lines below for the LOD module and the part after
// the draw marker for the drawing module.

fn cubic_of(i: u32) -> Cubic {
    let k = 4u * i;
    return Cubic(points[k].xyz, points[k + 1u].xyz, points[k + 2u].xyz, points[k + 3u].xyz);
}

// ---- lod ----
// One thread per branch: cull the branch's bounding sphere against the view frustum,
// measure its projected diameter in pixels, and append its id to that LOD's list,
// counting instances in the indirect draw arguments (5 words per LOD).

struct LodParams {
    // Projected diameter (px) at or above which LOD 0, 1, 2 is taken; below the last, the
    // coarsest level. w: 1 to cull against the frustum, 0 to keep every branch.
    thresholds: vec4<f32>,
    // branches, words between two LODs' id lists, LODs, 0.
    counts: vec4<u32>,
}

@group(1) @binding(0) var<storage, read> records: array<BranchRecord>;
@group(1) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> lod: LodParams;
@group(1) @binding(3) var<storage, read_write> ids: array<u32>;
@group(1) @binding(4) var<storage, read_write> indirect: array<atomic<u32>>;

@compute @workgroup_size(64)
fn lod_reset(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x < lod.counts.z {
        atomicStore(&indirect[5u * gid.x + 1u], 0u);
    }
}

fn row(m: mat4x4<f32>, i: u32) -> vec4<f32> {
    return vec4<f32>(m[0][i], m[1][i], m[2][i], m[3][i]);
}

// Signed distance of `c` from plane `p` (normalised), positive inside.
fn plane_distance(p: vec4<f32>, c: vec3<f32>) -> f32 {
    return (dot(p.xyz, c) + p.w) / length(p.xyz);
}

@compute @workgroup_size(64)
fn lod_select(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nw: vec3<u32>) {
    let i = gid.x + gid.y * nw.x * 64u;
    if i >= lod.counts.x {
        return;
    }
    let rec = records[i];
    let p = cubic_of(i);
    let c = (p.p0 + p.p1 + p.p2 + p.p3) * 0.25;
    // Widest the radius functions can make the section.
    let r_max = max(rec.radius, rec.tip_radius) * (1.0 + rec.flare) * (1.0 + abs(rec.bulge_depth))
        * (1.0 + abs(rec.lobe_depth) * max(1.0, abs(1.0 - rec.lobe_fade)));
    let bound = max(max(distance(c, p.p0), distance(c, p.p1)), max(distance(c, p.p2), distance(c, p.p3))) + r_max;
    if lod.thresholds.w > 0.0 {
        let m = frame.view_proj;
        let r3 = row(m, 3u);
        let planes = array<vec4<f32>, 5>(r3 + row(m, 0u), r3 - row(m, 0u), r3 + row(m, 1u), r3 - row(m, 1u), row(m, 2u));
        for (var k = 0u; k < 5u; k++) {
            if plane_distance(planes[k], c) < -bound {
                return;
            }
        }
    }
    let dist = max(distance(c, frame.eye.xyz) - bound, 1e-3);
    let px = 2.0 * r_max * frame.params.y / (2.0 * dist * frame.params.z);
    let n_lods = lod.counts.z;
    var level = n_lods - 1u;
    for (var k = 0u; k < min(n_lods - 1u, 3u); k++) {
        if px >= lod.thresholds[k] {
            level = k;
            break;
        }
    }
    let slot = atomicAdd(&indirect[5u * level + 1u], 1u);
    ids[level * lod.counts.y + slot] = i;
}

// ---- draw ----
// One instanced draw per LOD: the vertex buffer is the shared (v, θ, uv) grid list of
// every level, instance k of LOD l draws branch ids[k] of that level's list (bound at a
// dynamic offset, so instance_index starts at 0 in each list).

struct Material {
    // Linear RGB multiplied into the bark texture (the flat colour without one), a = 1.
    color: vec4<f32>,
}

// Per-branch texture mapping: arc length at v = 0 along its axis (m), the segment's arc
// length (m), 1 / the axis's base circumference (1/m), 0.
@group(1) @binding(0) var<storage, read> records: array<BranchRecord>;
@group(1) @binding(1) var<storage, read> points: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read> tex: array<vec4<f32>>;
@group(1) @binding(3) var<storage, read> ids: array<u32>;
@group(1) @binding(4) var bark: texture_2d<f32>;
@group(1) @binding(5) var bark_sampler: sampler;
@group(1) @binding(6) var<uniform> material: Material;

struct GridIn {
    @location(0) v: f32,
    @location(1) theta: f32,
    @location(2) uv: vec2<f32>,
}

struct BranchVertex {
    position: vec3<f32>,
    normal: vec3<f32>,
    uv: vec2<f32>,
}

fn branch_vertex(instance: u32, g: GridIn) -> BranchVertex {
    let b = ids[instance];
    let s = deform_at(records[b], cubic_of(b), g.v, g.theta);
    let t = tex[b];
    return BranchVertex(s.position, s.normal, vec2<f32>(g.uv.x, (t.x + g.v * t.y) * t.z));
}

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
}

@vertex
fn vs_branch(g: GridIn, @builtin(instance_index) instance: u32) -> VsOut {
    let bv = branch_vertex(instance, g);
    var out: VsOut;
    out.clip = frame.view_proj * vec4<f32>(bv.position, 1.0);
    out.normal = bv.normal;
    out.uv = bv.uv;
    return out;
}

@fragment
fn fs_branch(in: VsOut) -> @location(0) vec4<f32> {
    let n = normalize(in.normal);
    let albedo = textureSample(bark, bark_sampler, in.uv).rgb * material.color.rgb;
    let lambert = max(dot(n, normalize(frame.light_dir.xyz)), 0.0) * frame.light_color.rgb;
    let ambient = mix(frame.ground.rgb, frame.sky.rgb, 0.5 + 0.5 * n.y);
    return vec4<f32>(albedo * (lambert + ambient), 1.0);
}

// Vertex capture (tests): the same `branch_vertex` for a point list over one LOD's
// vertex range, each vertex a point on its own pixel of a `capture.z`-wide Rgba32Float
// target pair (position, normal): pixel = instance × capture.y + (vertex − capture.x).

struct Capture {
    // first vertex of the level, its vertex count, target width, target height.
    range: vec4<u32>,
}

@group(2) @binding(0) var<storage, read> capture: Capture;

struct CaptureOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) position: vec4<f32>,
    @location(1) @interpolate(flat) normal: vec4<f32>,
}

@vertex
fn vs_capture(g: GridIn, @builtin(instance_index) instance: u32, @builtin(vertex_index) vertex: u32) -> CaptureOut {
    let bv = branch_vertex(instance, g);
    let pixel = instance * capture.range.y + (vertex - capture.range.x);
    let x = f32(pixel % capture.range.z) + 0.5;
    let y = f32(pixel / capture.range.z) + 0.5;
    var out: CaptureOut;
    out.clip = vec4<f32>(2.0 * x / f32(capture.range.z) - 1.0, 1.0 - 2.0 * y / f32(capture.range.w), 0.5, 1.0);
    out.position = vec4<f32>(bv.position, 1.0);
    out.normal = vec4<f32>(bv.normal, 0.0);
    return out;
}

struct CaptureTargets {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
}

@fragment
fn fs_capture(in: CaptureOut) -> CaptureTargets {
    return CaptureTargets(in.position, in.normal);
}
