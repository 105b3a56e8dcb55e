// Depth maps of the soft shadow maps (Atty et al. 2006, section 3.1), all from the light centre:
// the occluder map(s) of the casters and the receiver map of the receivers that are not casters
// (the occluder / receiver split of the paper; geometry that is both is an occluder only).

struct DepthView {
    light_view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> view: DepthView;

@vertex
fn vs_occluder(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return view.light_view_proj * vec4<f32>(position, 1.0);
}

const FLAG_CASTS: u32 = 0x01000000u;

@vertex
fn vs_receiver(
    @location(0) position: vec3<f32>,
    @location(2) color_flags: u32,
) -> @builtin(position) vec4<f32> {
    if (color_flags & FLAG_CASTS) != 0u {
        // Outside the clip volume: the triangle is dropped before rasterisation.
        return vec4<f32>(2.0, 2.0, 2.0, 1.0);
    }
    return view.light_view_proj * vec4<f32>(position, 1.0);
}
