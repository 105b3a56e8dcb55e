// Gather backprojection (Guennebaud, Barthe & Paulin 2006)
// with the micro-quads and the multi-scale shadow map of the bitmask soft shadows paper (Schwarz &
// Stamminger 2007, sections 4 and 5). One invocation per screen pixel:
//   1. search area of the receiver point p (light space) on the centre shadow map, refined twice
//      with the depth hierarchy, with lit and umbra early outs (softshadow::search_area);
//   2. a coarser level when the area holds more than max_patches^2 blocks;
//   3. every micro-primitive of the area is backprojected from p onto the light plane: a point at
//      slope (s, t) and depth z < p.z lands at X = z (s p.z - p.x) / (p.z - z) (same for Y), and
//      the covered light area is accumulated; V = 1 - clamp(area / 4ab, 0, 1).
// Counters (receivers, lit, umbra, backprojected pixels, primitives) are summed per workgroup and
// added to a storage buffer that the CPU reads after the frame.
#import softshadow::frame::frame
#import softshadow::shadow_view::{ShadowView, texel_slope}
#import softshadow::search_area::{HIERARCHY_NONE, SEARCH_LIT, SEARCH_UMBRA, refine_search}
#import softshadow::gather::{
    GatherSettings, gather_setup, gather_search_area, ADAPTIVE_INVALID, ADAPTIVE_SKIP, ADAPTIVE_UPSAMPLED,
    adaptive_choice, receiver_at, RECEIVER_NONE, RECEIVER_BEHIND, RECEIVER_LIT,
}

// `hierarchy = none` gathers level-0 texels over the unrefined area, up to this many per axis:
// softshadow_core::hierarchy::full_search_patches(1) (docs/DEVICES.md, "Lavapipe's loop budget").
const FULL_SEARCH_PATCHES: i32 = 240;

// Classification written to the debug view and counted.
const CLASS_NONE: u32 = 0u;
const CLASS_LIT: u32 = 1u;
const CLASS_UMBRA: u32 = 2u;
const CLASS_BACKPROJECTED: u32 = 3u;
const CLASS_UPSAMPLED: u32 = 4u;

struct GatherParams {
    hierarchy: u32,
    primitive: u32,
    gap_filling: u32,
    max_patches: u32,
    bias_texels: f32,
    // Highest hierarchy level built this frame.
    max_level: i32,
    // VISIBILITY_SUM (micro-primitives summed) or VISIBILITY_CONTOUR.
    visibility: u32,
    // Depth bands, each gathered at its own level (1: one level for the whole area).
    depth_bands: u32,
    // Levels a partly occluding block is split down (0: none).
    edge_refine: u32,
    // Adaptive screen resolution: 1 (off), 2 or 4 (coarse pixels per axis), and the penumbra
    // width in screen pixels from which a pixel is interpolated from the coarse pass.
    adaptive_factor: u32,
    adaptive_pixels: f32,
}

struct Counters {
    receivers: atomic<u32>,
    lit: atomic<u32>,
    umbra: atomic<u32>,
    backprojected: atomic<u32>,
    // Micro-primitives processed, as a 64-bit count (low word, high word).
    primitives_lo: atomic<u32>,
    primitives_hi: atomic<u32>,
    // Pixels interpolated from the coarse pass (adaptive screen resolution).
    upsampled: atomic<u32>,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var hsm: texture_2d<f32>;
@group(1) @binding(2) var mssm: texture_2d_array<f32>;
@group(1) @binding(3) var<uniform> params: GatherParams;
@group(1) @binding(4) var visibility: texture_storage_2d<r32float, write>;
@group(1) @binding(5) var classification: texture_storage_2d<rgba8unorm, write>;
@group(1) @binding(6) var level_map: texture_storage_2d<r32float, write>;
@group(1) @binding(7) var<storage, read_write> counters: Counters;
// Adaptive screen resolution: the coarse pass's (V, unused) per coarse pixel, read by the
// full-resolution pass; written by the coarse pass (each pass binds a stand-in for the other).
@group(1) @binding(8) var coarse_in: texture_2d<f32>;
@group(1) @binding(9) var coarse_out: texture_storage_2d<rg32float, write>;

var<workgroup> group_receivers: atomic<u32>;
var<workgroup> group_lit: atomic<u32>;
var<workgroup> group_umbra: atomic<u32>;
var<workgroup> group_backprojected: atomic<u32>;
var<workgroup> group_primitives: atomic<u32>;
var<workgroup> group_upsampled: atomic<u32>;

struct PixelResult {
    v: f32,
    kind: u32,
    level: i32,
    primitives: u32,
}

// `coarse`: the coarse pass of adaptive screen resolution (a narrow penumbra is left to the
// full-resolution pass: ADAPTIVE_INVALID).
fn shade_pixel(pixel: vec2<i32>, coarse: bool) -> PixelResult {
    var r: PixelResult;
    r.v = 1.0;
    r.kind = CLASS_NONE;
    r.level = -1;
    r.primitives = 0u;
    let receiver = receiver_at(view, pixel, params.bias_texels);
    if receiver.kind == RECEIVER_NONE {
        return r;
    }
    if receiver.kind == RECEIVER_BEHIND {
        r.v = 0.0;
        r.kind = CLASS_UMBRA;
        return r;
    }
    r.kind = CLASS_LIT;
    if receiver.kind == RECEIVER_LIT {
        return r;
    }
    let p = receiver.s.light;
    let half_light = receiver.half_light;
    let bias = receiver.bias;
    let search = refine_search(view, hsm, mssm, params.hierarchy, params.max_level, p, half_light, p.z - bias);
    if search.kind == SEARCH_LIT {
        return r;
    }
    if search.kind == SEARCH_UMBRA {
        r.v = 0.0;
        r.kind = CLASS_UMBRA;
        return r;
    }
    let adaptive = adaptive_choice(coarse_in, receiver, pixel, search.z_range.x, params.adaptive_factor, params.adaptive_pixels, coarse);
    if adaptive.x == ADAPTIVE_SKIP {
        r.v = ADAPTIVE_INVALID;
        return r;
    }
    if adaptive.x == ADAPTIVE_UPSAMPLED {
        r.v = clamp(adaptive.y, 0.0, 1.0);
        r.kind = CLASS_UPSAMPLED;
        return r;
    }
    var per_axis = i32(params.max_patches);
    if params.hierarchy == HIERARCHY_NONE {
        per_axis = FULL_SEARCH_PATCHES;
    }
    let settings = GatherSettings(
        params.hierarchy,
        params.primitive,
        params.gap_filling,
        params.visibility,
        params.max_level,
        per_axis,
        params.depth_bands,
        params.edge_refine,
    );
    // The scaffold's default primitives return their clipped light area: summed here.
    let gathered = gather_search_area(hsm, mssm, gather_setup(view, settings, p, half_light, bias), search);
    let area = gathered.area;
    r.level = gathered.level;
    let primitives = gathered.primitives;
    let light_area = 4.0 * half_light.x * half_light.y;
    r.v = 1.0 - clamp(area / light_area, 0.0, 1.0);
    if !(r.v >= 0.0 && r.v <= 1.0) {
        // NaN guard: never write a non-finite visibility.
        r.v = 1.0;
    }
    r.kind = CLASS_BACKPROJECTED;
    r.primitives = primitives;
    return r;
}

fn class_colour(r: PixelResult) -> vec4<f32> {
    switch r.kind {
        case CLASS_LIT: {
            return vec4<f32>(0.9, 0.9, 0.85, 1.0);
        }
        case CLASS_UMBRA: {
            return vec4<f32>(0.1, 0.1, 0.35, 1.0);
        }
        case CLASS_BACKPROJECTED: {
            // Red for few micro-primitives, towards blue for max_patches^2 (paper Fig. 8).
            let full = f32(params.max_patches * params.max_patches);
            let t = clamp(f32(r.primitives) / full, 0.0, 1.0);
            return vec4<f32>(1.0 - t, 0.15, t, 1.0);
        }
        case CLASS_UPSAMPLED: {
            return vec4<f32>(0.1, 0.8, 0.2, 1.0);
        }
        default: {
            return vec4<f32>(0.0);
        }
    }
}

@compute @workgroup_size(8, 8)
fn gather(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) local: u32,
) {
    if local == 0u {
        atomicStore(&group_receivers, 0u);
        atomicStore(&group_lit, 0u);
        atomicStore(&group_umbra, 0u);
        atomicStore(&group_backprojected, 0u);
        atomicStore(&group_primitives, 0u);
        atomicStore(&group_upsampled, 0u);
    }
    workgroupBarrier();
    let size = vec2<u32>(frame.screen.xy);
    if all(id.xy < size) {
        let pixel = vec2<i32>(id.xy);
        let r = shade_pixel(pixel, false);
        textureStore(visibility, pixel, vec4<f32>(r.v, 0.0, 0.0, 0.0));
        textureStore(classification, pixel, class_colour(r));
        textureStore(level_map, pixel, vec4<f32>(f32(r.level), 0.0, 0.0, 0.0));
        if r.kind != CLASS_NONE {
            atomicAdd(&group_receivers, 1u);
        }
        if r.kind == CLASS_LIT {
            atomicAdd(&group_lit, 1u);
        }
        if r.kind == CLASS_UMBRA {
            atomicAdd(&group_umbra, 1u);
        }
        if r.kind == CLASS_BACKPROJECTED {
            atomicAdd(&group_backprojected, 1u);
            atomicAdd(&group_primitives, r.primitives);
        }
        if r.kind == CLASS_UPSAMPLED {
            atomicAdd(&group_upsampled, 1u);
        }
    }
    workgroupBarrier();
    if local == 0u {
        atomicAdd(&counters.receivers, atomicLoad(&group_receivers));
        atomicAdd(&counters.lit, atomicLoad(&group_lit));
        atomicAdd(&counters.umbra, atomicLoad(&group_umbra));
        atomicAdd(&counters.backprojected, atomicLoad(&group_backprojected));
        atomicAdd(&counters.upsampled, atomicLoad(&group_upsampled));
        let added = atomicLoad(&group_primitives);
        let before = atomicAdd(&counters.primitives_lo, added);
        if before > 0xffffffffu - added {
            atomicAdd(&counters.primitives_hi, 1u);
        }
    }
}

// The coarse pass of adaptive screen resolution: pixel id * factor of the full image, its V where
// it is lit, umbra or has a wide penumbra, ADAPTIVE_INVALID elsewhere.
@compute @workgroup_size(8, 8)
fn gather_coarse(@builtin(global_invocation_id) id: vec3<u32>) {
    let dims = textureDimensions(coarse_out);
    let pixel = vec2<i32>(id.xy * max(params.adaptive_factor, 1u));
    if all(id.xy < dims) && all(pixel < vec2<i32>(frame.screen.xy)) {
        let r = shade_pixel(pixel, true);
        textureStore(coarse_out, id.xy, vec4<f32>(r.v, 0.0, 0.0, 0.0));
    }
}
