// Depth peeling from the light centre (Schwarz & Stamminger 2007, sec. 3.2): layer k keeps, per
// texel, the nearest caster surface behind layer k - 1. Same view and window as the centre
// shadow map, so every layer shares its `ShadowView` and texel grid.
#import softshadow::shadow_view::{ShadowView, linear_depth}

@group(0) @binding(0) var<uniform> view: ShadowView;
@group(0) @binding(1) var previous: texture_depth_2d;

// Relative depth gap below which a fragment counts as the previous layer's surface (the same
// triangle rasterised again, or a coincident duplicate such as a two-sided quad's other face).
const PEEL_GAP: f32 = 1.0e-4;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return view.light_view_proj * vec4<f32>(position, 1.0);
}

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) {
    let d_previous = textureLoad(previous, vec2<i32>(frag.xy), 0);
    if d_previous >= 1.0 {
        // Nothing in front: nothing behind either.
        discard;
    }
    let z_previous = linear_depth(view, d_previous);
    if linear_depth(view, frag.z) <= z_previous * (1.0 + PEEL_GAP) {
        discard;
    }
}
