// Depth-only pass of the shadow casters (or receivers) from one eye on the light plane: every
// light-space rasterisation of the workspace (softshadow_core::shadow_map::DepthMapRenderer).
// One uniform slot per view, selected with a dynamic offset.

#import softshadow::shadow_view::{ShadowView, linear_depth}

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
    return receiver_clip(position, color_flags);
}

fn receiver_clip(position: vec3<f32>, color_flags: u32) -> vec4<f32> {
    if (color_flags & FLAG_CASTS) != 0u {
        // Outside the clip volume: the triangle is dropped before rasterisation.
        return vec4<f32>(2.0, 2.0, 2.0, 1.0);
    }
    return view.light_view_proj * vec4<f32>(position, 1.0);
}

// Depth peeling (Schwarz & Stamminger 2007, sec. 3.2; bitmask's layers): the pass keeps, per
// texel, the nearest caster surface behind the previous layer, drawn through the same view.
@group(1) @binding(0) var<uniform> peel_view: ShadowView;
@group(1) @binding(1) var previous: texture_depth_2d;

// Relative depth gap below which a fragment counts as the previous layer's surface (the same
// triangle rasterised again, or a coincident duplicate such as a two-sided quad's other face).
const PEEL_GAP: f32 = 1.0e-4;

@fragment
fn fs_peel(@builtin(position) frag: vec4<f32>) {
    peel(frag);
}

// Discards what is not behind the previous layer at fragment `frag`.
fn peel(frag: vec4<f32>) {
    let d_previous = textureLoad(previous, vec2<i32>(frag.xy), 0);
    if d_previous >= 1.0 {
        // Nothing in front: nothing behind either.
        discard;
    }
    let z_previous = linear_depth(peel_view, d_previous);
    if linear_depth(peel_view, frag.z) <= z_previous * (1.0 + PEEL_GAP) {
        discard;
    }
}

#ifdef ALPHA_TEST
// The alpha-tested variants (issue 40; glTF 2.0 section 3.9.4): a caster texel whose alpha is
// below its material's cut-off is a hole and writes no depth, in every light-space pass. Only
// scenes with a masked caster use them (softshadow_core::material_gpu); the material rows and
// texcoords come from the scene's second vertex buffer.
#import softshadow::material::alpha_passes

struct MaskedOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) @interpolate(flat) material: u32,
}

@vertex
fn vs_masked(
    @location(0) position: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) material: u32,
) -> MaskedOut {
    var out: MaskedOut;
    out.clip = view.light_view_proj * vec4<f32>(position, 1.0);
    out.uv = uv;
    out.material = material;
    return out;
}

@vertex
fn vs_receiver_masked(
    @location(0) position: vec3<f32>,
    @location(2) color_flags: u32,
    @location(3) uv: vec2<f32>,
    @location(4) material: u32,
) -> MaskedOut {
    var out: MaskedOut;
    out.clip = receiver_clip(position, color_flags);
    out.uv = uv;
    out.material = material;
    return out;
}

@fragment
fn fs_masked(in: MaskedOut) {
    if !alpha_passes(in.material, in.uv) {
        discard;
    }
}

@fragment
fn fs_peel_masked(in: MaskedOut) {
    if !alpha_passes(in.material, in.uv) {
        discard;
    }
    peel(in.clip);
}
#endif
