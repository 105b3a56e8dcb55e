// Soft shadow map scatter (Atty et al. 2006, sections 3.2-3.4), entirely on the GPU (the paper's
// future work, section 6): one instanced quad per occluder-map texel.
//   vertex stage: the texel becomes its micro-patch (its slope footprint at its depth, parallel to
//     the light, section 3.2) and the quad covers the patch's penumbra rectangle in the soft
//     shadow map (section 3.3); empty texels give a degenerate quad;
//   fragment stage: reads the receiver depth at its soft-shadow-map texel, backprojects the
//     micro-patch through the receiver point onto the light and outputs the occluded fraction of
//     the light (intersection of two axis-aligned rectangles, section 3.4); additive blending sums
//     the micro-patches.
// Slope space from the light centre: a light-space point (x, y, z) has slopes (x / z, y / z);
// texel row 0 of every map is at t_max.

// The same struct in every ssm shader.
struct SsmParams {
    // s_min, s_max, t_min, t_max of the occluder map.
    occluder_window: vec4<f32>,
    // near, far, edge N, depth of an empty texel (1 front map, 0 back map).
    occluder_depth: vec4<f32>,
    // s_min, s_max, t_min, t_max of the soft shadow map and the receiver map.
    ssm_window: vec4<f32>,
    // near, far, edge R, farthest receiver depth (bounds every penumbra).
    ssm_depth: vec4<f32>,
    // a, b (light half extents), bias in texels, 1 when two occluder maps are merged.
    light: vec4<f32>,
    // x: the radius of a disk, sphere or spot light (its disk in the light plane), 0 under
    // the rectangle.
    round_light: vec4<f32>,
}

#import softshadow::light::rect_disk_area

@group(0) @binding(0) var<uniform> params: SsmParams;
@group(0) @binding(1) var occluder_map: texture_depth_2d;
@group(0) @binding(2) var receiver_map: texture_depth_2d;

// Must equal `math::CONTACT_EPSILON`.
const CONTACT_EPSILON: f32 = 1e-4;

fn linear_depth(d: f32, near: f32, far: f32) -> f32 {
    return far * near / (far - d * (far - near));
}

struct PatchVertex {
    @builtin(position) position: vec4<f32>,
    // The micro-patch in slopes: s0, s1, t0, t1.
    @location(0) @interpolate(flat) patch_rect: vec4<f32>,
    // Its light-space depth z_O.
    @location(1) @interpolate(flat) depth: f32,
}

@vertex
fn vs_main(
    @builtin(vertex_index) corner: u32,
    @builtin(instance_index) texel_index: u32,
) -> PatchVertex {
    var out: PatchVertex;
    let n = u32(params.occluder_depth.z);
    let texel = vec2<u32>(texel_index % n, texel_index / n);
    let d = textureLoad(occluder_map, vec2<i32>(texel), 0);
    if d == params.occluder_depth.w || texel.y >= n {
        // Empty texel: all four corners outside the clip volume, nothing is rasterised.
        out.position = vec4<f32>(2.0, 2.0, 2.0, 1.0);
        out.patch_rect = vec4<f32>(0.0);
        out.depth = 0.0;
        return out;
    }
    let z_o = linear_depth(d, params.occluder_depth.x, params.occluder_depth.y);

    // Section 3.2: the micro-patch covers the texel's image-plane extent at depth z_O.
    let w = params.occluder_window;
    let ds = (w.y - w.x) / f32(n);
    let dt = (w.w - w.z) / f32(n);
    let s0 = w.x + f32(texel.x) * ds;
    let t1 = w.w - f32(texel.y) * dt;
    let patch_rect = vec4<f32>(s0, s0 + ds, t1 - dt, t1);

    // Section 3.3: the penumbra pyramid cut by the farthest receiver plane z_far. In slopes the
    // apex construction reduces to growing the patch by a (1/z_O - 1/z_far) (b along t), which
    // stays finite for a point light (crates/ssm/src/math.rs checks both agree).
    let penumbra = penumbra_slopes(patch_rect, z_o, params.ssm_depth.w, params.light.xy);

    // Corner of a triangle strip: 0 (s0, t0), 1 (s1, t0), 2 (s0, t1), 3 (s1, t1).
    let s = select(penumbra.x, penumbra.y, (corner & 1u) != 0u);
    let t = select(penumbra.z, penumbra.w, (corner & 2u) != 0u);
    let v = params.ssm_window;
    let clip = vec2<f32>((s - v.x) / (v.y - v.x), (t - v.z) / (v.w - v.z)) * 2.0 - 1.0;
    // A guard band keeps huge penumbrae (occluder next to the light) finite for the rasteriser.
    out.position = vec4<f32>(clamp(clip, vec2<f32>(-1.5), vec2<f32>(1.5)), 0.5, 1.0);
    out.patch_rect = patch_rect;
    out.depth = z_o;
    return out;
}

// Length of [lo, hi] inside the light's [-half, half], over 2 half (section 3.4: the light is
// mapped to [0, 1] and each interval intersection is a difference of saturated ends). A light of
// zero extent on this axis is a point, covered when lo <= 0 < hi.
fn axis_coverage(lo: f32, hi: f32, half: f32) -> f32 {
    if half <= 0.0 {
        return select(0.0, 1.0, lo <= 0.0 && 0.0 < hi);
    }
    let u = saturate((vec2<f32>(lo, hi) + half) / (2.0 * half));
    return max(u.y - u.x, 0.0);
}

// Section 3.4: fraction of the light (half extents `half`) hidden by the micro-patch
// `patch_rect` (slopes s0, s1, t0, t1) at depth `z_o`, seen from the receiver point with slopes
// `receiver` at depth `z_r`: the patch backprojected through the receiver point onto the light
// plane is the rectangle k (patch - receiver), k = z_r z_o / (z_r - z_o). 0 when the patch is not
// in front of the receiver (or touches it). Mirrors `math::occluded_fraction`; the bench's GPU
// test `ssm::the_scatter_shader_functions_equal_their_cpu_mirrors` runs this function and
// compares.
fn occluded_fraction(patch_rect: vec4<f32>, z_o: f32, receiver: vec2<f32>, z_r: f32, half: vec2<f32>) -> f32 {
    if !(z_o > 0.0 && z_o < z_r * (1.0 - CONTACT_EPSILON)) {
        return 0.0;
    }
    let k = z_r * z_o / (z_r - z_o);
    let shadow = k * (patch_rect - receiver.xxyy);
    return axis_coverage(shadow.x, shadow.y, half.x) * axis_coverage(shadow.z, shadow.w, half.y);
}

// `occluded_fraction` under a disk of radius `radius` (a disk, sphere or spot light): the
// backprojected rectangle's area inside the disk (`rect_disk_area`) over pi r^2.
fn disk_occluded_fraction(patch_rect: vec4<f32>, z_o: f32, receiver: vec2<f32>, z_r: f32, radius: f32) -> f32 {
    if !(z_o > 0.0 && z_o < z_r * (1.0 - CONTACT_EPSILON)) {
        return 0.0;
    }
    let k = z_r * z_o / (z_r - z_o);
    let shadow = k * (patch_rect - receiver.xxyy);
    let area = rect_disk_area(shadow.xz, shadow.yw, radius);
    return clamp(area / (3.14159265 * radius * radius), 0.0, 1.0);
}

// Section 3.3 in slopes: the patch grown by a (1/z_O - 1/z_far) along s and b (...) along t bounds
// the penumbra on every receiver nearer than z_far; finite for a point light. Mirrors
// `math::penumbra_slopes` (tested as `occluded_fraction` is).
fn penumbra_slopes(patch_rect: vec4<f32>, z_o: f32, z_far: f32, half: vec2<f32>) -> vec4<f32> {
    let grow = half * max(1.0 / z_o - 1.0 / z_far, 0.0);
    return patch_rect + vec4<f32>(-grow.x, grow.x, -grow.y, grow.y);
}

@fragment
fn fs_main(in: PatchVertex) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.position.xy);
    let d_r = textureLoad(receiver_map, texel, 0);
    if d_r >= 1.0 {
        // No receiver at this texel.
        discard;
    }
    let z_r = linear_depth(d_r, params.ssm_depth.x, params.ssm_depth.y);
    let v = params.ssm_window;
    let r = params.ssm_depth.z;
    let sigma = vec2<f32>(
        v.x + in.position.x * (v.y - v.x) / r,
        v.w - in.position.y * (v.w - v.z) / r,
    );
    var fraction = occluded_fraction(in.patch_rect, in.depth, sigma, z_r, params.light.xy);
    let radius = params.round_light.x;
    if radius > 0.0 {
        fraction = disk_occluded_fraction(in.patch_rect, in.depth, sigma, z_r, radius);
    }
    if fraction <= 0.0 {
        // Nothing hidden (or the patch is not in front of this receiver): no blend, and the
        // fragment is not counted as a texel update.
        discard;
    }
    return vec4<f32>(fraction, 0.0, 0.0, 0.0);
}
