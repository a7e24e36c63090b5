// sylva-gpu's mesh pipeline (issue 25 item 4; Skjermo2008 §4, Skjermo2008-spec §10): instanced,
// GPU-skinned trees with a directional light and a sky/ground ambient, colour maps and
// alpha-cut leaves; plus the background gradient and, for a viewer (issue 41 item 2;
// render/overlay.rs), the ground disc with its contact shadow, the wireframe's edges and
// line overlays. render/mod.rs prepends frame.wgsl
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

struct Ground {
    centre: vec4<f32>, // xyz: disc centre (model space), w: radius
    crown: vec4<f32>,  // xy: crown shadow half extents (x, z), z: strength
    trunk: vec4<f32>,  // xy: trunk foot (x, z), z: contact radius, w: contact strength
    color: vec4<f32>,  // linear ground colour
    wire: vec4<f32>,   // linear wireframe colour
}

@group(0) @binding(3) var<uniform> ground: Ground;

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

// The instance transform times the vertex's skinning matrix: linear blend skinning (as
// glTF readers do); a vertex without weights stays put.
fn world_matrix(v: VertexIn) -> mat4x4<f32> {
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
    return instance * skin;
}

fn transform(v: VertexIn) -> VertexOut {
    let world = world_matrix(v);
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

// The ground disc: two triangles of a square around the model's base, per instance;
// `local` is the offset from the disc's centre (model space, x and z).
struct InstanceIn {
    @location(5) m0: vec4<f32>,
    @location(6) m1: vec4<f32>,
    @location(7) m2: vec4<f32>,
    @location(8) m3: vec4<f32>,
}

struct GroundOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) local: vec2<f32>,
}

@vertex
fn vs_ground(@builtin(vertex_index) i: u32, inst: InstanceIn) -> GroundOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    let local = corners[i] * ground.centre.w;
    let p = vec3<f32>(ground.centre.x + local.x, ground.centre.y, ground.centre.z + local.y);
    let instance = mat4x4<f32>(inst.m0, inst.m1, inst.m2, inst.m3);
    var out: GroundOut;
    out.clip = frame.view_proj * (instance * vec4<f32>(p, 1.0));
    out.local = local;
    return out;
}

@fragment
fn fs_ground(in: GroundOut) -> @location(0) vec4<f32> {
    // A flat floor fading into the background over the outer quarter of its radius.
    let r = length(in.local) / ground.centre.w;
    if (r > 1.0) {
        discard;
    }
    return vec4<f32>(ground.color.rgb, 1.0 - smoothstep(0.75, 1.0, r));
}

@fragment
fn fs_shadow(in: GroundOut) -> @location(0) vec4<f32> {
    // Drawn with blend dst × (1 − a): a soft ellipse under the crown plus a tighter
    // darkening at the trunk's foot.
    let q = in.local / max(ground.crown.xy, vec2<f32>(1e-4));
    let crown = ground.crown.z * (1.0 - smoothstep(0.0, 1.0, length(q)));
    let foot = ground.centre.xz + in.local - ground.trunk.xy;
    let t = length(foot) / max(ground.trunk.z, 1e-4);
    let contact = ground.trunk.w * exp(-t * t);
    return vec4<f32>(0.0, 0.0, 0.0, clamp(crown + contact, 0.0, 0.8));
}

// Depth-tested lines are pulled this fraction of their distance towards the eye, so an
// edge lying on a surface is drawn over it.
const LINE_PULL: f32 = 0.0015;

fn pulled(world: vec4<f32>) -> vec4<f32> {
    let p = world.xyz / world.w;
    return vec4<f32>(p + (frame.eye.xyz - p) * LINE_PULL, 1.0);
}

// The wireframe: the mesh's unique triangle edges (a line-list index buffer built on the
// CPU), skinned and instanced like the mesh.
@vertex
fn vs_wire(v: VertexIn) -> GroundOut {
    var out: GroundOut;
    out.clip = frame.view_proj * pulled(world_matrix(v) * vec4<f32>(v.position, 1.0));
    out.local = vec2<f32>(0.0);
    return out;
}

@fragment
fn fs_wire(in: GroundOut) -> @location(0) vec4<f32> {
    return vec4<f32>(ground.wire.rgb, 1.0);
}

// Line overlays: world-space segments in one colour each.
struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) color: vec4<f32>,
}

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
}

@vertex
fn vs_line(v: LineIn) -> LineOut {
    var out: LineOut;
    out.clip = frame.view_proj * pulled(vec4<f32>(v.position, 1.0));
    out.color = v.color;
    return out;
}

@fragment
fn fs_line(in: LineOut) -> @location(0) vec4<f32> {
    return vec4<f32>(in.color.rgb, 1.0);
}
