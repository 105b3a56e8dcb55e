// Accumulated hard shadows, step 1: for one batch of point samples on the light, sum per pixel
// the weights of those that see the surface point (.r) and of all of them (.g); additive
// blending sums both over batches. Every sample weighs 1 but a sphere's (SPHERE).
// Under the sun (SUN) each sample is a direction of its cone and its map an orthographic view
// along it (`sun_view` in src/lib.rs), the same ShadowView struct carrying: `light_view_proj`
// its world-to-clip, `eye_near_far.xyz` the unit direction toward the sun and `.w` the map's
// depth range (far - near), `window.x` its texel edge in world units.
#import softshadow::frame::{frame, Surface, load_surface, light_cosine}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}
#import softshadow::shadow_view::{ShadowView, view_uv, linear_depth, texel_slope, in_map}

const MAX_BATCH: u32 = 16u;

struct Batch {
    // x: number of views in this batch; y: bias in texel footprints; z: the sphere's radius
    // (SPHERE).
    count_bias: vec4<f32>,
    views: array<ShadowView, MAX_BATCH>,
    // Light-space z of each view's eye, four to a vec4: a sphere's samples lie off the light
    // plane, each view drawn from the plane moved to its eye (`sphere_view` in src/lib.rs); 0
    // for every other kind.
    eye_depths: array<vec4<f32>, 4>,
}

@group(1) @binding(0) var<uniform> batch: Batch;
@group(1) @binding(1) var depth_maps: texture_depth_2d_array;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

#ifdef SUN
// 1 where `world` (normal `normal`) sees the sun along the view's direction, else 0.
fn lit_along(view: ShadowView, i: u32, world: vec3<f32>, normal: vec3<f32>, bias_texels: f32) -> f32 {
    let to_sun = view.eye_near_far.xyz;
    let cosine = dot(normal, to_sun);
    // A direction behind the surface's own tangent plane is hidden by the surface itself.
    if cosine <= 0.0 {
        return 0.0;
    }
    let clip = view.light_view_proj * vec4<f32>(world, 1.0);
    let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
    if !in_map(uv) {
        return 1.0;
    }
    let d = textureLoad(depth_maps, vec2<i32>(uv * view.size.xy), i32(i), 0);
    // The bias in world units (texels over the cosine, at most 10 texels), as depth.
    let bias = bias_texels * view.window.x / max(cosine, 0.1) / view.eye_near_far.w;
    return select(0.0, 1.0, d >= 1.0 || d >= clip.z - bias);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver {
        return vec4<f32>(0.0);
    }
    let count = min(u32(batch.count_bias.x), MAX_BATCH);
    var lit = 0.0;
    for (var i = 0u; i < count; i = i + 1u) {
        lit += lit_along(batch.views[i], i, s.world, s.normal, batch.count_bias.y);
    }
    return vec4<f32>(lit, f32(count), 0.0, 0.0);
}
#else
// The light-space eye of view `i`.
fn eye_of(i: u32) -> vec3<f32> {
    return vec3<f32>(batch.views[i].eye_near_far.xy, batch.eye_depths[i / 4u][i % 4u]);
}

#ifdef SPHERE
// The weight of the sphere sample `eye` (light space, the sphere's centre at the origin) at `p`:
// samples uniform over the sphere's area, weighed by the density of the silhouette disk of `p`
// they cross (the disk whose visible fraction is V, softshadow_core::light_shape), so the
// weighted mean is that fraction. 0 on the sphere's far side from `p`.
// dA_disk / dA_sphere = cos_sample / |p - eye|^2 * h^2 / cos_axis^3, h the distance from `p` to
// the disk (the same for every sample of `p`, replaced by |p|^2 to keep weights near 1).
fn sample_weight(eye: vec3<f32>, p: vec3<f32>) -> f32 {
    let to_p = p - eye;
    let distance2 = dot(to_p, to_p);
    let cos_sample = dot(eye, to_p) / (batch.count_bias.z * sqrt(distance2));
    if cos_sample <= 0.0 {
        return 0.0;
    }
    let cos_axis = dot(to_p, p) / sqrt(distance2 * dot(p, p));
    return cos_sample * dot(p, p) / (distance2 * cos_axis * cos_axis * cos_axis);
}
#else
fn sample_weight(eye: vec3<f32>, p: vec3<f32>) -> f32 {
    return 1.0;
}
#endif

// Whether `s` sees the eye of view `i` (`eye`) through its depth map.
fn lit_from(i: u32, eye: vec3<f32>, s: Surface, normal: vec3<f32>, bias_texels: f32) -> bool {
    // A sample behind the surface's own tangent plane is hidden by the surface itself (a
    // point on a closed part sees it only through the part). The depth test cannot tell:
    // its bias, up to 10x the texel footprint at grazing angles (`light_cosine`), exceeds the
    // thickness of a thin part, whose far side then read lit (a CAD-like model's 16 mm rods
    // and 6 mm slats: pixels off by 1.0 against the ray cast; docs/TECHNIQUES.md,
    // `reference`, "The three yardsticks on a multi-part mesh").
    if dot(normal, eye - s.light) <= 0.0 {
        return false;
    }
    let view = batch.views[i];
    // The surface point in the light space of the plane through the eye.
    let from_eye = s.light - vec3<f32>(0.0, 0.0, eye.z);
    if from_eye.z <= 0.0 {
        // Beside a sphere, behind its eye's plane: no map covers it, and its ray runs back
        // past the light (through the ground, for a lamp sunk in it). Counted hidden; the
        // same answer either way on stiff-sphere-in-ground (mae_shadowed 0.0316 at 64²).
        return false;
    }
    let uv = view_uv(view, from_eye);
    if !in_map(uv) {
        return true;
    }
    let d = textureLoad(depth_maps, vec2<i32>(uv * view.size.xy), i32(i), 0);
    let slope_factor = from_eye.z / light_cosine(s);
    let bias = bias_texels * texel_slope(view) * slope_factor;
    return d >= 1.0 || linear_depth(view, d) >= from_eye.z - bias;
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if !s.is_receiver || s.light.z <= 0.0 {
        return vec4<f32>(0.0);
    }
    let count = min(u32(batch.count_bias.x), MAX_BATCH);
    // The surface's normal in light space (the G-buffer's, facing the camera).
    let normal = (frame.world_to_light * vec4<f32>(s.normal, 0.0)).xyz;
    // (weight of the samples that see the point, weight of all)
    var sums = vec2<f32>(0.0);
    for (var i = 0u; i < count; i = i + 1u) {
        let eye = eye_of(i);
        let weight = sample_weight(eye, s.light);
        if weight <= 0.0 {
            continue;
        }
        sums.y += weight;
        if lit_from(i, eye, s, normal, batch.count_bias.y) {
            sums.x += weight;
        }
    }
    return vec4<f32>(sums, 0.0, 0.0);
}
#endif
