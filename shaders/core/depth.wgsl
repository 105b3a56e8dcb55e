// Depth-only pass of the shadow casters (or receivers) from one eye on the light plane: every
// light-space rasterisation of the workspace (softshadow_core::shadow_map::DepthMapRenderer).
// One uniform slot per view, selected with a dynamic offset.

struct DepthView {
    light_view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> view: DepthView;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return view.light_view_proj * vec4<f32>(position, 1.0);
}

const FLAG_CASTS: u32 = 0x01000000u;

// The receivers that are not casters (SSM's receiver map, Atty et al. 2006, section 3.1: geometry
// that is both is an occluder only).
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
