// G-buffer pass: world position, normal (+ receiver flag) and albedo per camera pixel.
#import softshadow::frame_types::FrameUniforms

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    // RGB8 albedo in the low 24 bits, flags in the high byte (bit 24 casts, bit 25 receives).
    @location(2) color_flags: u32,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) color_flags: u32,
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    var out: VertexOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.color_flags = v.color_flags;
    return out;
}

struct GBufferOut {
    // xyz world position; w = 1 where geometry was hit (cleared to 0).
    @location(0) position: vec4<f32>,
    // xyz normal facing the camera; w = 1 for receivers.
    @location(1) normal: vec4<f32>,
    @location(2) albedo: vec4<f32>,
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> GBufferOut {
    return gbuffer_out(in.world, in.normal, in.color_flags, front);
}

fn gbuffer_out(world: vec3<f32>, normal: vec3<f32>, color_flags: u32, front: bool) -> GBufferOut {
    var n = normalize(normal);
    if !front {
        // Zero-thickness occluders are seen from both sides.
        n = -n;
    }
    let receives = (color_flags & 0x02000000u) != 0u;
    var out: GBufferOut;
    out.position = vec4<f32>(world, 1.0);
    out.normal = vec4<f32>(n, select(0.0, 1.0, receives));
    out.albedo = vec4<f32>(unpack4x8unorm(color_flags).rgb, 1.0);
    return out;
}

#ifdef MATERIALS
// Scenes with a textured or masked material (softshadow_core::material_gpu): the albedo is the
// material's base colour (factor times texture, texcoord set 0), and a texel its alpha mask cuts
// away is not drawn, so the pixel sees what is behind it: the hole is neither receiver nor
// caster here (glTF 2.0 section 3.9.4).
#import softshadow::material::{alpha_passes, base_color}

struct MaterialVertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) color_flags: u32,
    @location(3) uv: vec2<f32>,
    @location(4) @interpolate(flat) material: u32,
}

@vertex
fn vs_material(
    v: VertexIn,
    @location(3) uv: vec2<f32>,
    @location(4) material: u32,
) -> MaterialVertexOut {
    var out: MaterialVertexOut;
    out.clip = frame.view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    out.color_flags = v.color_flags;
    out.uv = uv;
    out.material = material;
    return out;
}

@fragment
fn fs_material(in: MaterialVertexOut, @builtin(front_facing) front: bool) -> GBufferOut {
    var out = gbuffer_out(in.world, in.normal, in.color_flags, front);
    if in.material != 0u {
        if !alpha_passes(in.material, in.uv) {
            discard;
        }
        let color = base_color(in.material, in.uv);
        out.albedo = vec4<f32>(clamp(color.rgb, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
    }
    return out;
}
#endif
