// `raytraced/trace`: rays_per_pixel shadow rays per receiver pixel toward points of the area light,
// traced with ray queries against the casters' acceleration structure (crates/core/src/accel.rs).
// Writes the raw visible fraction and the mean distance to the first hit (-1 where no ray hit).
enable wgpu_ray_query;

#import softshadow::frame::{frame, load_surface, light_reaches, light_sample}

struct TraceParams {
    light_to_world: mat4x4<f32>,
    rays: u32,
    frame_index: u32,
}

@group(1) @binding(0) var<uniform> params: TraceParams;
@group(1) @binding(1) var casters: acceleration_structure;
@group(1) @binding(2) var raw_out: texture_storage_2d<rg32float, write>;

// Segment ends as the CPU ray cast's (crates/reference/src/raycast.rs): occluders within 1e-4
// of the segment at the receiver end and 1e-6 at the light end are ignored (`light_sample`, which
// samples every light kind's shape).

// A per-pixel rotation of the sequence (Cranley-Patterson): a hash of the pixel.
fn hash2(p: vec2<u32>) -> vec2<f32> {
    var h = p.x * 1664525u + p.y * 1013904223u;
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = (h ^ (h >> 16u)) * 0x45d9f3bu;
    h = h ^ (h >> 16u);
    let g = h * 747796405u + 2891336453u;
    return vec2<f32>(f32(h >> 8u), f32(g >> 8u)) / 16777216.0;
}

// The R2 sequence (Roberts 2018, the 2D generalised golden ratio): point i is well spread for
// every prefix, so the rays of one frame and of all frames so far both cover the light evenly.
const R2: vec2<f32> = vec2<f32>(0.7548776662466927, 0.5698402909980532);

@compute @workgroup_size(8, 8)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<u32>(frame.screen.xy);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let pixel = vec2<i32>(id.xy);
    let s = load_surface(pixel);
    if !s.is_receiver {
        textureStore(raw_out, pixel, vec4<f32>(1.0, -1.0, 0.0, 0.0));
        return;
    }
    if !light_reaches(s) {
        // Behind the one-sided light.
        textureStore(raw_out, pixel, vec4<f32>(0.0, -1.0, 0.0, 0.0));
        return;
    }
    let rotation = hash2(id.xy);
    var lit = 0u;
    var hit_sum = 0.0;
    var hits = 0u;
    // Declared once, outside the loop: a `ray_query` declared inside a loop body makes lavapipe
    // (Mesa 25.0.7) fail the pipeline and lose the device (docs/DEVICES.md, "Lavapipe's ray queries").
    var rq: ray_query;
    for (var i = 0u; i < params.rays; i++) {
        // Frame k continues the sequence where frame k - 1 ended.
        let index = f32(params.frame_index * params.rays + i);
        let u = fract(rotation + index * R2);
        let ray = light_sample(u, s.world);
        let dir = ray.to_light;
        rayQueryInitialize(&rq, casters, RayDesc(RAY_FLAG_TERMINATE_ON_FIRST_HIT | RAY_FLAG_FORCE_OPAQUE, 0xffu, ray.t_min, ray.t_max, s.world, dir));
        rayQueryProceed(&rq);
        let hit = rayQueryGetCommittedIntersection(&rq);
        if hit.kind == RAY_QUERY_INTERSECTION_NONE {
            lit += 1u;
        } else {
            hits += 1u;
            hit_sum += hit.t * length(dir);
        }
    }
    let visible = f32(lit) / f32(params.rays);
    let mean_hit = select(-1.0, hit_sum / f32(max(hits, 1u)), hits > 0u);
    textureStore(raw_out, pixel, vec4<f32>(visible, mean_hit, 0.0, 0.0));
}
