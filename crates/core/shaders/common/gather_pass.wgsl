#define_import_path softshadow::gather_pass

// The gather pass that backprojection and bitmask share: its bindings, the counters, the
// per-pixel loop (receiver, per depth layer the search area with its lit / umbra early outs,
// adaptive screen resolution, the gather of softshadow::gather) and the bodies of the two entry
// points (`gather_pixels`, `gather_coarse_pixels`). A technique's gather file holds only what is
// its own and configures the rest:
//   - the def GATHER_LAYERS: hierarchies bound, 1 (the centre map) or 4 (bitmask's peeled layers);
//   - its own image at group 1, binding 7 (backprojection: the classification; bitmask: the area
//     estimate), written by its `store_pixel`;
//   - overrides of `begin_pixel`, `finish_pixel` and `store_pixel` below (and of
//     softshadow::gather's `emit_patch` / `emit_quad`): how it turns the backprojected
//     micro-primitives into a visibility;
//   - the two `@compute` entry points, each one call of the body here (naga_oil keeps the entry
//     points of the file composed only, not of the modules it imports).
// Counters (receivers, lit, umbra, backprojected pixels, primitives, most primitives in a pixel,
// set bits, upsampled pixels) are summed per workgroup and added to a storage buffer that the
// CPU reads after the frame (softshadow_core::gather::GatherCounts).

#import softshadow::frame::frame
#import softshadow::shadow_view::ShadowView
#import softshadow::search_area::{SEARCH_LIT, SEARCH_UMBRA, refine_search}
#import softshadow::gather::{
    GatherParams, GatherResult, GatherSettings, gather_setup, gather_search_area, ADAPTIVE_INVALID,
    ADAPTIVE_SKIP, ADAPTIVE_UPSAMPLED, Receiver, adaptive_choice, receiver_at, RECEIVER_NONE,
    RECEIVER_BEHIND, RECEIVER_LIT,
}

// Hierarchies bound: one per depth layer gathered.
const MAX_LAYERS: u32 = #{GATHER_LAYERS}u;

struct Counters {
    receivers: atomic<u32>,
    lit: atomic<u32>,
    umbra: atomic<u32>,
    backprojected: atomic<u32>,
    // Micro-primitives processed, as a 64-bit count (low word, high word).
    primitives_lo: atomic<u32>,
    primitives_hi: atomic<u32>,
    primitives_max: atomic<u32>,
    // Set bits over the backprojected pixels, as a 64-bit count (bitmask; 0 elsewhere).
    set_bits_lo: atomic<u32>,
    set_bits_hi: atomic<u32>,
    // Pixels interpolated from the coarse pass (adaptive screen resolution).
    upsampled: atomic<u32>,
}

@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var<uniform> params: GatherParams;
@group(1) @binding(2) var visibility: texture_storage_2d<r32float, write>;
@group(1) @binding(3) var level_map: texture_storage_2d<r32float, write>;
@group(1) @binding(4) var<storage, read_write> counters: Counters;
// Adaptive screen resolution: the coarse pass's (V, second channel) per coarse pixel, read by the
// full-resolution pass; written by the coarse pass (each pass binds a stand-in for the other).
@group(1) @binding(5) var coarse_in: texture_2d<f32>;
@group(1) @binding(6) var coarse_out: texture_storage_2d<rg32float, write>;
// Binding 7 is the technique's own image. Then each layer's HSM and MSSM.
@group(1) @binding(8) var hsm0: texture_2d<f32>;
@group(1) @binding(9) var mssm0: texture_2d_array<f32>;
#if GATHER_LAYERS == 4
@group(1) @binding(10) var hsm1: texture_2d<f32>;
@group(1) @binding(11) var mssm1: texture_2d_array<f32>;
@group(1) @binding(12) var hsm2: texture_2d<f32>;
@group(1) @binding(13) var mssm2: texture_2d_array<f32>;
@group(1) @binding(14) var hsm3: texture_2d<f32>;
@group(1) @binding(15) var mssm3: texture_2d_array<f32>;
#endif

var<workgroup> group_receivers: atomic<u32>;
var<workgroup> group_lit: atomic<u32>;
var<workgroup> group_umbra: atomic<u32>;
var<workgroup> group_backprojected: atomic<u32>;
var<workgroup> group_primitives: atomic<u32>;
var<workgroup> group_primitives_max: atomic<u32>;
var<workgroup> group_set_bits: atomic<u32>;
var<workgroup> group_upsampled: atomic<u32>;

// What a pixel is: classified and counted, and the colours of backprojection's debug view.
const CLASS_NONE: u32 = 0u;
const CLASS_LIT: u32 = 1u;
const CLASS_UMBRA: u32 = 2u;
const CLASS_BACKPROJECTED: u32 = 3u;
// Adaptive screen resolution: interpolated from the coarse pass, or left to the full pass.
const CLASS_UPSAMPLED: u32 = 4u;
const CLASS_SKIPPED: u32 = 5u;

struct PixelResult {
    v: f32,
    // The coarse pass's second channel: bitmask's area estimate A (visibility from the summed
    // areas, unclamped).
    area_v: f32,
    kind: u32,
    level: i32,
    primitives: u32,
    // Set bits of bitmask's occlusion mask (0 elsewhere).
    set_bits: u32,
}

virtual fn begin_pixel() {
    // (No comment right above a virtual or override function: see softshadow::gather's
    // `emit_patch`.) Called once per receiver pixel before its first layer is gathered: a
    // technique resets what it accumulates (bitmask: the area estimate).
}

virtual fn finish_pixel(r: PixelResult, half_light: vec2<f32>, area: f32) -> PixelResult {
    // A pixel that backprojected anything: `area` is the sum of what the technique's `emit_patch`
    // / `emit_quad` returned over every layer. The technique sets r.v (and r.area_v, r.set_bits).
    return r;
}

virtual fn store_pixel(pixel: vec2<i32>, r: PixelResult) {
    // The full-resolution pass's pixel into the technique's own image (binding 7).
}

// What one layer did.
struct LayerResult {
    kind: u32,
    level: i32,
    primitives: u32,
    // What `emit_patch` / `emit_quad` returned, summed.
    area: f32,
}

// The (V, second channel) interpolated from the coarse pass when layer 0 returned CLASS_UPSAMPLED.
var<private> upsampled: vec2<f32>;

// Search, classify and gather one depth layer. Layer 0 decides adaptive screen resolution from its
// nearest blocker (`coarse`: this is the coarse pass).
fn gather_layer(hsm: texture_2d<f32>, mssm: texture_2d_array<f32>, receiver: Receiver, pixel: vec2<i32>, first: bool, coarse: bool) -> LayerResult {
    let p = receiver.s.light;
    let half_light = receiver.half_light;
    let bias = receiver.bias;
    var out: LayerResult;
    out.kind = CLASS_LIT;
    out.level = -1;
    out.primitives = 0u;
    out.area = 0.0;
    let search = refine_search(view, hsm, mssm, params.hierarchy, params.max_level, p, half_light, p.z - bias);
    if search.kind == SEARCH_LIT {
        return out;
    }
    if search.kind == SEARCH_UMBRA {
        out.kind = CLASS_UMBRA;
        return out;
    }
    if first {
        let adaptive = adaptive_choice(coarse_in, receiver, pixel, search.z_range.x, params.adaptive_factor, params.adaptive_pixels, coarse);
        if adaptive.x == ADAPTIVE_SKIP {
            out.kind = CLASS_SKIPPED;
            return out;
        }
        if adaptive.x == ADAPTIVE_UPSAMPLED {
            upsampled = adaptive.yz;
            out.kind = CLASS_UPSAMPLED;
            return out;
        }
    }
    let settings = GatherSettings(
        params.hierarchy,
        params.primitive,
        params.gap_filling,
        params.visibility,
        params.max_level,
        i32(params.per_axis),
        params.depth_bands,
        params.edge_refine,
    );
    let gathered = gather_search_area(hsm, mssm, gather_setup(view, settings, p, half_light, bias), search);
    out.kind = CLASS_BACKPROJECTED;
    out.level = gathered.level;
    out.primitives = gathered.primitives;
    out.area = gathered.area;
    return out;
}

// Layer `k` over its own hierarchy.
fn gather_layer_k(k: u32, receiver: Receiver, pixel: vec2<i32>, coarse: bool) -> LayerResult {
#if GATHER_LAYERS == 4
    switch k {
        case 0u: { return gather_layer(hsm0, mssm0, receiver, pixel, true, coarse); }
        case 1u: { return gather_layer(hsm1, mssm1, receiver, pixel, false, coarse); }
        case 2u: { return gather_layer(hsm2, mssm2, receiver, pixel, false, coarse); }
        default: { return gather_layer(hsm3, mssm3, receiver, pixel, false, coarse); }
    }
#else
    return gather_layer(hsm0, mssm0, receiver, pixel, true, coarse);
#endif
}

// `coarse`: the coarse pass of adaptive screen resolution (a narrow penumbra is left to the
// full-resolution pass: ADAPTIVE_INVALID).
fn shade_pixel(pixel: vec2<i32>, coarse: bool) -> PixelResult {
    var r: PixelResult;
    r.v = 1.0;
    r.area_v = 1.0;
    r.kind = CLASS_NONE;
    r.level = -1;
    r.primitives = 0u;
    r.set_bits = 0u;
    let receiver = receiver_at(view, pixel, params.bias_texels);
    if receiver.kind == RECEIVER_NONE {
        return r;
    }
    if receiver.kind == RECEIVER_BEHIND {
        r.v = 0.0;
        r.area_v = 0.0;
        r.kind = CLASS_UMBRA;
        return r;
    }
    r.kind = CLASS_LIT;
    if receiver.kind == RECEIVER_LIT {
        return r;
    }
    begin_pixel();
    var area = 0.0;
    // Every layer adds its occluders (bitmask sec. 3.2); an umbra layer decides the pixel alone.
    for (var k = 0u; k < MAX_LAYERS; k = k + 1u) {
        if k >= params.layers {
            break;
        }
        let layer = gather_layer_k(k, receiver, pixel, coarse);
        r.primitives += layer.primitives;
        r.level = max(r.level, layer.level);
        if layer.kind == CLASS_UMBRA {
            r.v = 0.0;
            r.area_v = 0.0;
            r.kind = CLASS_UMBRA;
            return r;
        }
        if layer.kind == CLASS_SKIPPED {
            r.v = ADAPTIVE_INVALID;
            r.kind = CLASS_SKIPPED;
            return r;
        }
        if layer.kind == CLASS_UPSAMPLED {
            r.v = clamp(upsampled.x, 0.0, 1.0);
            r.area_v = upsampled.y;
            r.kind = CLASS_UPSAMPLED;
            return r;
        }
        if layer.kind == CLASS_BACKPROJECTED {
            r.kind = CLASS_BACKPROJECTED;
            area += layer.area;
        }
    }
    if r.kind != CLASS_BACKPROJECTED {
        return r;
    }
    return finish_pixel(r, receiver.half_light, area);
}

// The body of a technique's `gather` entry point (workgroup size 8 x 8): every pixel's visibility,
// level and own image, and the counters.
fn gather_pixels(id: vec3<u32>, local: u32) {
    if local == 0u {
        atomicStore(&group_receivers, 0u);
        atomicStore(&group_lit, 0u);
        atomicStore(&group_umbra, 0u);
        atomicStore(&group_backprojected, 0u);
        atomicStore(&group_primitives, 0u);
        atomicStore(&group_primitives_max, 0u);
        atomicStore(&group_set_bits, 0u);
        atomicStore(&group_upsampled, 0u);
    }
    workgroupBarrier();
    let size = vec2<u32>(frame.screen.xy);
    if all(id.xy < size) {
        let pixel = vec2<i32>(id.xy);
        let r = shade_pixel(pixel, false);
        textureStore(visibility, pixel, vec4<f32>(r.v, 0.0, 0.0, 0.0));
        textureStore(level_map, pixel, vec4<f32>(f32(r.level), 0.0, 0.0, 0.0));
        store_pixel(pixel, r);
        count_pixel(r);
    }
    workgroupBarrier();
    if local == 0u {
        add_group_counts();
    }
}

fn count_pixel(r: PixelResult) {
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
        atomicAdd(&group_set_bits, r.set_bits);
    }
    if r.kind == CLASS_UPSAMPLED {
        atomicAdd(&group_upsampled, 1u);
    }
    atomicAdd(&group_primitives, r.primitives);
    atomicMax(&group_primitives_max, r.primitives);
}

fn add_group_counts() {
    atomicAdd(&counters.receivers, atomicLoad(&group_receivers));
    atomicAdd(&counters.lit, atomicLoad(&group_lit));
    atomicAdd(&counters.umbra, atomicLoad(&group_umbra));
    atomicAdd(&counters.backprojected, atomicLoad(&group_backprojected));
    atomicAdd(&counters.upsampled, atomicLoad(&group_upsampled));
    atomicMax(&counters.primitives_max, atomicLoad(&group_primitives_max));
    let added = atomicLoad(&group_primitives);
    let before = atomicAdd(&counters.primitives_lo, added);
    if before > 0xffffffffu - added {
        atomicAdd(&counters.primitives_hi, 1u);
    }
    let bits = atomicLoad(&group_set_bits);
    let bits_before = atomicAdd(&counters.set_bits_lo, bits);
    if bits_before > 0xffffffffu - bits {
        atomicAdd(&counters.set_bits_hi, 1u);
    }
}

// The body of a technique's `gather_coarse` entry point (workgroup size 8 x 8), the coarse pass of
// adaptive screen resolution: pixel id * factor of the full image, its (V, second channel) where it
// is lit, umbra or has a wide penumbra, ADAPTIVE_INVALID elsewhere.
fn gather_coarse_pixels(id: vec3<u32>) {
    let dims = textureDimensions(coarse_out);
    let pixel = vec2<i32>(id.xy * max(params.adaptive_factor, 1u));
    if all(id.xy < dims) && all(pixel < vec2<i32>(frame.screen.xy)) {
        let r = shade_pixel(pixel, true);
        textureStore(coarse_out, id.xy, vec4<f32>(r.v, r.area_v, 0.0, 0.0));
    }
}
