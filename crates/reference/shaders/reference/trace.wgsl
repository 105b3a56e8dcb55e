// The ray-traced exact answer (crates/reference/src/traced.rs): for each receiver point, one row
// of N stratified, jittered light samples per dispatch (row `params.row` of the N x N grid), each
// an exact segment test against the casters' triangles with a ray query; the lit count is added
// to the point's running sum. Segment ends as the CPU ray cast's (raycast.rs); the light's shape
// sampled by core's `sample_light` (the frame uniforms of the light, `light`).
enable wgpu_ray_query;

#import softshadow::frame_types::FrameUniforms
#import softshadow::light::{sample_light, light_reaches_point}

struct TraceParams {
    samples_per_axis: u32,
    row: u32,
    count: u32,
    seed: u32,
}

@group(0) @binding(0) var<uniform> params: TraceParams;
@group(0) @binding(1) var casters: acceleration_structure;
// xyz: world position; w: 1 for a receiver point, 0 for a pixel that sees none.
@group(0) @binding(2) var<storage, read> points: array<vec4<f32>>;
// Lit samples so far (summed over rows).
@group(0) @binding(3) var<storage, read_write> lit: array<f32>;
// Pairs of strata (columns 2k and 2k + 1 of a row) whose samples disagree, summed over rows: the
// collapsed-strata estimate of the sampling error (raycast.rs, `visibility_and_error`).
@group(0) @binding(4) var<storage, read_write> disagree: array<f32>;
// The light (only its fields are read).
@group(0) @binding(5) var<uniform> light: FrameUniforms;

// A hash of three integers to [0, 1)^2: the jitter of one sample of one point.
fn jitter(a: u32, b: u32, c: u32) -> vec2<f32> {
    var h = a * 0x9e3779b9u ^ (b * 0x85ebca6bu) ^ (c * 0xc2b2ae35u) ^ params.seed;
    h = (h ^ (h >> 16u)) * 0x7feb352du;
    h = (h ^ (h >> 15u)) * 0x846ca68bu;
    h = h ^ (h >> 16u);
    var g = h * 747796405u + 2891336453u;
    g = (g ^ (g >> 16u)) * 0x7feb352du;
    g = g ^ (g >> 15u);
    return vec2<f32>(f32(h >> 8u), f32(g >> 8u)) / 16777216.0;
}

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x + id.y * 65535u * 64u;
    if k >= params.count {
        return;
    }
    let point = points[k];
    if point.w < 0.5 {
        return;
    }
    let p = point.xyz;
    if !light_reaches_point(light, p, (light.world_to_light * vec4<f32>(p, 1.0)).xyz) {
        // Behind the one-sided light: never lit.
        return;
    }
    let n = params.samples_per_axis;
    var count = 0u;
    var pairs_apart = 0u;
    var even_lit = false;
    // Declared once, outside the loop: a `ray_query` declared inside a loop body makes lavapipe
    // (Mesa 25.0.7) fail the pipeline and lose the device (docs/DEVICES.md, "Lavapipe's ray queries").
    var rq: ray_query;
    for (var i = 0u; i < n; i++) {
        let u = (vec2<f32>(f32(i), f32(params.row)) + jitter(k, i, params.row)) / f32(n);
        let ray = sample_light(light, u, p);
        rayQueryInitialize(&rq, casters, RayDesc(RAY_FLAG_TERMINATE_ON_FIRST_HIT | RAY_FLAG_FORCE_OPAQUE, 0xffu, ray.t_min, ray.t_max, p, ray.to_light));
        rayQueryProceed(&rq);
        let hit = rayQueryGetCommittedIntersection(&rq).kind != RAY_QUERY_INTERSECTION_NONE;
        if !hit {
            count += 1u;
        }
        if (i & 1u) == 0u {
            even_lit = !hit;
        } else if even_lit == hit {
            pairs_apart += 1u;
        }
    }
    lit[k] += f32(count);
    disagree[k] += f32(pairs_apart);
}
