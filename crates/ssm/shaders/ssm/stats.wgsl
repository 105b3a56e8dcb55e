// Counters for the report (not part of the algorithm): micro-patches drawn (non-empty
// occluder-map texels, over both maps in two-pass mode) and soft-shadow-map texels with some
// occlusion. One atomic add per workgroup after a workgroup-local count.

// The same struct in every ssm shader.
struct SsmParams {
    occluder_window: vec4<f32>,
    occluder_depth: vec4<f32>,
    ssm_window: vec4<f32>,
    ssm_depth: vec4<f32>,
    light: vec4<f32>,
    // x: the radius of a disk, sphere or spot light (its disk in the light plane), 0 under
    // the rectangle.
    round_light: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: SsmParams;
@group(0) @binding(1) var front_map: texture_depth_2d;
@group(0) @binding(2) var back_map: texture_depth_2d;
@group(0) @binding(3) var ssm_front: texture_2d<f32>;
@group(0) @binding(4) var ssm_back: texture_2d<f32>;
// [0] micro-patches, [1] soft-shadow-map texels with occlusion > 0.
@group(0) @binding(5) var<storage, read_write> counts: array<atomic<u32>, 2>;

var<workgroup> local_patches: atomic<u32>;
var<workgroup> local_texels: atomic<u32>;

@compute @workgroup_size(8, 8)
fn count(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    if local == 0u {
        atomicStore(&local_patches, 0u);
        atomicStore(&local_texels, 0u);
    }
    workgroupBarrier();
    let two_pass = params.light.w > 0.5;
    let n = u32(params.occluder_depth.z);
    if id.x < n && id.y < n {
        let texel = vec2<i32>(id.xy);
        if textureLoad(front_map, texel, 0) < 1.0 {
            atomicAdd(&local_patches, 1u);
        }
        if two_pass && textureLoad(back_map, texel, 0) > 0.0 {
            atomicAdd(&local_patches, 1u);
        }
    }
    let r = u32(params.ssm_depth.z);
    if id.x < r && id.y < r {
        let texel = vec2<i32>(id.xy);
        var occlusion = textureLoad(ssm_front, texel, 0).r;
        if two_pass {
            occlusion = max(occlusion, textureLoad(ssm_back, texel, 0).r);
        }
        if occlusion > 0.0 {
            atomicAdd(&local_texels, 1u);
        }
    }
    workgroupBarrier();
    if local == 0u {
        atomicAdd(&counts[0], atomicLoad(&local_patches));
        atomicAdd(&counts[1], atomicLoad(&local_texels));
    }
}
