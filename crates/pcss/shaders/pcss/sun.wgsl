// PCSS (Fernando 2005) under the sun, over the cascaded orthographic maps of
// softshadow::cascades. The sun is a cone of directions of half-angle alpha / 2, so an edge at
// light-space distance D in front of the receiver casts a penumbra 2 D tan(alpha / 2) wide, the
// same in every cascade: every size below is in world units, turned into texels of the cascade
// that serves the point (docs/TECHNIQUES.md, `pcss`, "The sun"), so the softness does not jump
// at a cascade boundary.
//   1. Blocker search over the disk of radius tan(alpha / 2) (z_r - near), the sun's cone cut at
//      the cascade's near plane (the nearest caster).
//   2. Average blocker depth d_b; penumbra half width tan(alpha / 2) (z_r - d_b).
//   3. Percentage-closer filtering over that disk (at least `min_filter_texels` texels).
// In the blend band at a cascade's far end the next cascade's answer is mixed in.
#import softshadow::frame::{frame, load_surface}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::cascades::{Cascades, cascade_count, cascade_pick, cascade_point, cascade_view_depth, cascade_depth_z, cascade_in_map, cascade_texels}
#import softshadow::sampling::{interleaved_gradient_noise, vogel_disk, PI}

const MAX_BLOCKER_SAMPLES: u32 = 64u;
const MAX_FILTER_SAMPLES: u32 = 256u;
// What `caster_z` gives where there is no caster (light-space z may be negative for the sun).
const NO_CASTER: f32 = -1.0e30;

struct PcssParams {
    blocker_samples: u32,
    filter_samples: u32,
    frame_index: u32,
    bias_texels: f32,
    min_filter_texels: f32,
}

@group(1) @binding(0) var<uniform> cascades: Cascades;
@group(1) @binding(1) var maps: texture_depth_2d_array;
@group(1) @binding(2) var<uniform> params: PcssParams;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

// Kernel point i of n in [-1, 1]^2 (grid) or the unit disk (Vogel): pcss.wgsl's kernel.
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

fn kernel_count(n: u32) -> u32 {
#ifdef KERNEL_GRID
    let k = max(u32(round(sqrt(f32(n)))), 1u);
    return k * k;
#else
    return n;
#endif
}

// Light-space z of the nearest caster at `texel` of cascade `i`, or NO_CASTER outside the map
// or where it is empty.
fn caster_z(i: u32, texel: vec2<f32>) -> f32 {
    if !cascade_in_map(cascades, texel) {
        return NO_CASTER;
    }
    let d = textureLoad(maps, vec2<i32>(texel), i32(i), 0);
    if d >= 1.0 {
        return NO_CASTER;
    }
    return cascade_depth_z(cascades, i, d);
}

// PCSS of `world` in cascade `i`.
fn pcss_in(i: u32, world: vec3<f32>, cosine: f32, noise: f32) -> f32 {
    let p = cascade_point(cascades, i, world);
    let tan_half = frame.light_sun.y;
    let texel = cascades.texel_world[i];
    let bias = params.bias_texels * texel / cosine;

    // 1. Blocker search (world radius, in this cascade's texels).
    let search = tan_half * max(p.z - cascades.near[i], 0.0);
    let n = kernel_count(clamp(params.blocker_samples, 1u, MAX_BLOCKER_SAMPLES));
    var blocker_sum = 0.0;
    var blockers = 0u;
    for (var k = 0u; k < n; k = k + 1u) {
        let z = caster_z(i, p.texel + cascade_texels(cascades, i, kernel_point(k, n, noise) * search));
        if z > NO_CASTER && z < p.z - bias {
            blocker_sum += z;
            blockers += 1u;
        }
    }
    if blockers == 0u {
        return 1.0;
    }
    let d_b = blocker_sum / f32(blockers);

    // 2. Penumbra half width, world units, at least `min_filter_texels` of this cascade.
    let extent = max(tan_half * (p.z - d_b), params.min_filter_texels * texel);

    // 3. Percentage-closer filtering.
    let m = kernel_count(clamp(params.filter_samples, 1u, MAX_FILTER_SAMPLES));
    var lit = 0.0;
    for (var k = 0u; k < m; k = k + 1u) {
        let offset = cascade_texels(cascades, i, kernel_point(k, m, fract(noise + 0.5)) * extent);
        let z = caster_z(i, p.texel + offset);
        if z <= NO_CASTER || z >= p.z - bias {
            lit += 1.0;
        }
    }
    return clamp(lit / f32(m), 0.0, 1.0);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    let pick = cascade_pick(cascades, cascade_view_depth(cascades, frame.camera_pos.xyz, s.world));
    if pick.first >= cascade_count(cascades) {
        return vec4<f32>(1.0);
    }
    let cosine = max(abs(dot(s.normal, frame.light_dir.xyz)), 0.1);
    let noise = interleaved_gradient_noise(in.position.xy);
    var v = pcss_in(pick.first, s.world, cosine, noise);
    if pick.blend > 0.0 {
        v = mix(v, pcss_in(pick.first + 1u, s.world, cosine, noise), pick.blend);
    }
    return vec4<f32>(v);
}
