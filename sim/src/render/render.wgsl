// Off-screen renderer shaders (see render/mod.rs): the textured scene into the undistorted
// "virtual pinhole" image of a camera, grey level = albedo · shade · gain; or, for depth images,
// the inverse depth 1/z_c (reversed infinite Z: the fragment depth is near / z_c). The camera
// model's distortion is applied afterwards, on the CPU, by a precomputed bilinear remap.

struct SceneCamera {
    view_proj: mat4x4<f32>,
    gain: f32,
    inv_near: f32,
    pad0: f32,
    pad1: f32,
};

@group(0) @binding(0) var<uniform> cam: SceneCamera;
@group(0) @binding(1) var albedo_tex: texture_2d_array<f32>;
@group(0) @binding(2) var albedo_smp: sampler;

struct SceneIn {
    @location(0) pos: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) layer: u32,
    @location(3) shade: f32,
    @location(4) plain: f32,
};

struct SceneOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) layer: u32,
    @location(2) @interpolate(flat) shade: f32,
    @location(3) @interpolate(flat) plain: f32,
};

@vertex
fn vs_scene(v: SceneIn) -> SceneOut {
    var o: SceneOut;
    o.clip = cam.view_proj * vec4<f32>(v.pos, 1.0);
    o.uv = v.uv;
    o.layer = v.layer;
    o.shade = v.shade;
    o.plain = v.plain;
    return o;
}

@fragment
fn fs_scene(i: SceneOut) -> @location(0) vec4<f32> {
    let t = textureSample(albedo_tex, albedo_smp, i.uv, i.layer).r;
    let a = select(t, i.plain, i.plain >= 0.0);
    return vec4<f32>(clamp(a * i.shade * cam.gain, 0.0, 1.0), 0.0, 0.0, 1.0);
}

// Written as the f32's bits into an R32Uint target (R32Float is not renderable on GL).
@fragment
fn fs_inv_depth(i: SceneOut) -> @location(0) vec4<u32> {
    return vec4<u32>(bitcast<u32>(i.clip.z * cam.inv_near), 0u, 0u, 1u);
}
