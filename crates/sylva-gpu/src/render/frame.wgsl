// The camera and light of one frame, group(0) binding(0), shared by the mesh renderer
// (render/mesh.wgsl) and the branch deformer's renderer (branches.wgsl), which prepend
// this file: params.x = time (s), params.y = viewport height (px), params.z =
// tan(fov / 2). light_dir.xyz points from the surface toward the light; light_color.rgb
// is its colour times intensity; sky and ground are the hemispherical ambient's two
// colours (rgb). Rust side: `render::Frame`.
struct Frame {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    light_dir: vec4<f32>,
    light_color: vec4<f32>,
    sky: vec4<f32>,
    ground: vec4<f32>,
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> frame: Frame;
