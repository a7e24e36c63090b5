// sylva-gpu's mesh pipeline (issue 25 item 4; Skjermo2008 §4, Skjermo2008-spec §10): instanced,
// GPU-skinned trees with a directional light and a sky/ground ambient, colour maps and
// alpha-cut leaves; plus the background gradient. render/mod.rs prepends frame.wgsl
// (group(0) binding(0), `Frame`, shared with the branch deformer's renderer).

struct Material {
    base_color: vec4<f32>,
    // x: 1 where the colour map replaces the base colour, y: alpha cut-off (< 0: none)
    params: vec4<f32>,
}

struct Background {
    top: vec4<f32>,    // sRGB 0..1
    bottom: vec4<f32>, // sRGB 0..1
    size: vec4<f32>,   // x: width, y: height (px)
}

@group(0) @binding(1) var<storage, read> joints: array<mat4x4<f32>>;
@group(0) @binding(2) var<uniform> background: Background;

@group(1) @binding(0) var<uniform> material: Material;
@group(1) @binding(1) var base_map: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) joint: vec4<u32>,
    @location(4) weight: vec4<f32>,
    @location(5) m0: vec4<f32>,
    @location(6) m1: vec4<f32>,
    @location(7) m2: vec4<f32>,
    @location(8) m3: vec4<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
}

// The alpha-cut variant: UVs interpolated per sample, so the fragment shader runs per
// MSAA sample and the cut-off is tested per sample (as the CPU preview tests each of its
// supersamples), giving leaf outlines partial coverage.
struct VertexOutCut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) @interpolate(perspective, sample) uv: vec2<f32>,
}

fn joint_matrix(j: u32) -> mat4x4<f32> {
    let n = arrayLength(&joints);
    return joints[min(j, n - 1u)];
}

fn transform(v: VertexIn) -> VertexOut {
    // Linear blend skinning (as glTF readers do); a vertex without weights stays put.
    let wsum = v.weight.x + v.weight.y + v.weight.z + v.weight.w;
    var skin = mat4x4<f32>(
        vec4<f32>(1.0, 0.0, 0.0, 0.0),
        vec4<f32>(0.0, 1.0, 0.0, 0.0),
        vec4<f32>(0.0, 0.0, 1.0, 0.0),
        vec4<f32>(0.0, 0.0, 0.0, 1.0),
    );
    if (wsum > 0.0) {
        skin = joint_matrix(v.joint.x) * v.weight.x + joint_matrix(v.joint.y) * v.weight.y
            + joint_matrix(v.joint.z) * v.weight.z + joint_matrix(v.joint.w) * v.weight.w;
    }
    let instance = mat4x4<f32>(v.m0, v.m1, v.m2, v.m3);
    let world = instance * skin;
    var out: VertexOut;
    out.clip = frame.view_proj * (world * vec4<f32>(v.position, 1.0));
    out.normal = (world * vec4<f32>(v.normal, 0.0)).xyz;
    out.uv = vec2<f32>(v.uv.x, 1.0 - v.uv.y);
    return out;
}

@vertex
fn vs_mesh(v: VertexIn) -> VertexOut {
    return transform(v);
}

@vertex
fn vs_mesh_cut(v: VertexIn) -> VertexOutCut {
    let t = transform(v);
    var out: VertexOutCut;
    out.clip = t.clip;
    out.normal = t.normal;
    out.uv = t.uv;
    return out;
}

fn shade(base: vec3<f32>, normal: vec3<f32>, front: bool) -> vec4<f32> {
    // Two-sided: a back face shades with its normal flipped (open leaf blades).
    var n = normal;
    let len = length(n);
    if (len > 0.0) {
        n = n / len;
    }
    if (!front) {
        n = -n;
    }
    let diffuse = max(dot(n, frame.light_dir.xyz), 0.0);
    let up = 0.5 + 0.5 * n.y;
    let ambient = mix(frame.ground.rgb, frame.sky.rgb, up);
    return vec4<f32>(base * (ambient + frame.light_color.rgb * diffuse), 1.0);
}

@fragment
fn fs_mesh(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let texel = textureSample(base_map, base_sampler, in.uv);
    var base = material.base_color.rgb;
    if (material.params.x > 0.5) {
        base = texel.rgb;
    }
    return shade(base, in.normal, front);
}

@fragment
fn fs_mesh_cut(in: VertexOutCut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let texel = textureSample(base_map, base_sampler, in.uv);
    if (texel.a < material.params.y) {
        discard;
    }
    return shade(texel.rgb, in.normal, front);
}

struct BackgroundOut {
    @builtin(position) clip: vec4<f32>,
}

@vertex
fn vs_background(@builtin(vertex_index) i: u32) -> BackgroundOut {
    // One triangle covering the viewport, at the far plane.
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    var out: BackgroundOut;
    out.clip = vec4<f32>(x, y, 1.0, 1.0);
    return out;
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

@fragment
fn fs_background(in: BackgroundOut) -> @location(0) vec4<f32> {
    // The CPU preview's vertical gradient: interpolated in sRGB, rounded to 8 bits.
    let row = floor(in.clip.y);
    let h = background.size.y;
    var f = 1.0;
    if (h > 1.0) {
        f = row / (h - 1.0);
    }
    let c = floor((background.top.rgb + (background.bottom.rgb - background.top.rgb) * f) * 255.0 + 0.5) / 255.0;
    return vec4<f32>(srgb_to_linear(c), 1.0);
}
