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
    var n = normalize(in.normal);
    if !front {
        // Zero-thickness occluders are seen from both sides.
        n = -n;
    }
    let receives = (in.color_flags & 0x02000000u) != 0u;
    var out: GBufferOut;
    out.position = vec4<f32>(in.world, 1.0);
    out.normal = vec4<f32>(n, select(0.0, 1.0, receives));
    out.albedo = vec4<f32>(unpack4x8unorm(in.color_flags).rgb, 1.0);
    return out;
}
