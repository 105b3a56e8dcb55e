// PCSS (Fernando 2005), in the slope space of one perspective
// shadow map from the light centre: a light-space point (x, y, z) has slopes (x / z, y / z).
//   1. Blocker search over the slopes that the light rectangle [-a, a] x [-b, b] subtends behind
//      the receiver down to the near plane: half extent a (z_r - near) / (z_r near) (and b ...).
//   2. Average blocker depth d_b; penumbra half extent (parallel planes) a (z_r - d_b) / (d_b z_r)
//      in slopes, i.e. w_p = (z_r - d_b) w_light / d_b on the receiver.
//   3. Percentage-closer filtering over that extent (at least `min_filter_texels`).
// Both kernels are rotated (Vogel) or jittered (grid) per pixel by interleaved gradient noise.
// The grid is the KERNEL_GRID permutation, not a uniform flag (docs/DEVICES.md, "Lavapipe's
// branches"). The TEMPORAL permutation (setting `temporal`) moves the noise every frame as Bevy's
// temporal shadow filtering does (the pixel offset by 5.588238 per frame, a cycle of 64 frames),
// so successive frames sample other points of the kernel and `pcss/temporal` averages them
// (shaders/pcss/temporal.wgsl); without it this file is the plain PCSS, unchanged.
#import softshadow::frame::{frame, load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_slope, slope_to_uv, linear_depth, texel_slope, in_map}
#import softshadow::sampling::{interleaved_gradient_noise, vogel_disk, PI}

const MAX_BLOCKER_SAMPLES: u32 = 64u;
const MAX_FILTER_SAMPLES: u32 = 256u;

struct PcssParams {
    blocker_samples: u32,
    filter_samples: u32,
    // Frame index of the temporal mode (read by the TEMPORAL permutation only).
    frame_index: u32,
    bias_texels: f32,
    min_filter_texels: f32,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: PcssParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

// Kernel point i of n in [-1, 1]^2 (grid) or the unit disk (Vogel).
fn kernel_point(i: u32, n: u32, noise: f32) -> vec2<f32> {
#ifdef KERNEL_GRID
    let k = max(u32(round(sqrt(f32(n)))), 1u);
    let cell = vec2<f32>(f32(i % k), f32(i / k));
    let jitter = fract(vec2<f32>(noise, noise * 7.31)) - 0.5;
    return ((cell + 0.5 + jitter) / f32(k)) * 2.0 - 1.0;
#else
    return vogel_disk(i, n, noise * 2.0 * PI);
#endif
}

// The number of kernel points for `n` requested: a whole square for the grid.
fn kernel_count(n: u32) -> u32 {
#ifdef KERNEL_GRID
    let k = max(u32(round(sqrt(f32(n)))), 1u);
    return k * k;
#else
    return n;
#endif
}

// Light-space depth of the nearest caster at `slope`, or -1 outside the map / where the map is empty.
fn caster_depth(slope: vec2<f32>) -> f32 {
    let uv = slope_to_uv(view, slope);
    if !in_map(uv) {
        return -1.0;
    }
    let d = textureLoad(shadow_map, vec2<i32>(uv * view.size.xy), 0);
    if d >= 1.0 {
        return -1.0;
    }
    return linear_depth(view, d);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    let z_r = s.light.z;
    if z_r <= 0.0 {
        return vec4<f32>(0.0);
    }
    let center = view_slope(view, s.light);
    let half_light = frame.light_half.xy;
    let near = view.eye_near_far.z;
    let bias = params.bias_texels * texel_slope(view) * z_r / light_cosine(s);
#ifdef TEMPORAL
    let noise = interleaved_gradient_noise(in.position.xy + 5.588238 * f32(params.frame_index % 64u));
#else
    let noise = interleaved_gradient_noise(in.position.xy);
#endif

    // 1. Blocker search.
    let search = half_light * max(z_r - near, 0.0) / (z_r * near);
    let n = kernel_count(clamp(params.blocker_samples, 1u, MAX_BLOCKER_SAMPLES));
    var blocker_sum = 0.0;
    var blockers = 0u;
    for (var i = 0u; i < n; i = i + 1u) {
        let z = caster_depth(center + kernel_point(i, n, noise) * search);
        if z > 0.0 && z < z_r - bias {
            blocker_sum += z;
            blockers += 1u;
        }
    }
    if blockers == 0u {
        return vec4<f32>(1.0);
    }
    let d_b = blocker_sum / f32(blockers);

    // 2. Penumbra extent in slopes, at least `min_filter_texels` texels.
    let min_extent = params.min_filter_texels * texel_slope(view);
    let extent = max(half_light * (z_r - d_b) / (d_b * z_r), vec2<f32>(min_extent));

    // 3. Percentage-closer filtering.
    let m = kernel_count(clamp(params.filter_samples, 1u, MAX_FILTER_SAMPLES));
    var lit = 0.0;
    for (var i = 0u; i < m; i = i + 1u) {
        let z = caster_depth(center + kernel_point(i, m, fract(noise + 0.5)) * extent);
        if z < 0.0 || z >= z_r - bias {
            lit += 1.0;
        }
    }
    return vec4<f32>(clamp(lit / f32(m), 0.0, 1.0));
}
