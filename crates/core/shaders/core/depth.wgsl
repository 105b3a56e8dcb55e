// Depth-only pass of the shadow casters from one eye on the light plane.
// One uniform slot per view, selected with a dynamic offset.

struct DepthView {
    light_view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> view: DepthView;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return view.light_view_proj * vec4<f32>(position, 1.0);
}
