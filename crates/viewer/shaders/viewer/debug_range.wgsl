// The value range of a technique's debug image, so the debug view can map it black to white
// (one flat grey otherwise: shadow-map depths crowd near 1). Depth maps: texels that hold a
// caster (depth < 1; empty texels and the far plane are 1). Float images: finite values of the
// red channel. Values are kept as order-preserving u32 so atomicMin / atomicMax compare floats.

struct Range {
    lo: atomic<u32>,
    hi: atomic<u32>,
    count: atomic<u32>,
}

#ifdef DEPTH
@group(0) @binding(0) var source: texture_depth_2d;
#else
@group(0) @binding(0) var source: texture_2d<f32>;
#endif
@group(0) @binding(1) var<storage, read_write> range: Range;

// Negative floats: all bits flipped; positive: the sign bit set. Unsigned order is then float
// order (the usual radix-sort key).
fn ordered(x: f32) -> u32 {
    let bits = bitcast<u32>(x);
    return select(bits | 0x80000000u, ~bits, (bits & 0x80000000u) != 0u);
}

@compute @workgroup_size(8, 8, 1)
fn cs_main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(source);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
#ifdef DEPTH
    let value = textureLoad(source, vec2<i32>(id.xy), 0);
    let counts = value < 1.0;
#else
    let value = textureLoad(source, vec2<i32>(id.xy), 0).r;
    // NaN fails the comparison; infinities are outside it.
    let counts = abs(value) <= 3.0e38;
#endif
    if counts {
        atomicMin(&range.lo, ordered(value));
        atomicMax(&range.hi, ordered(value));
        atomicAdd(&range.count, 1u);
    }
}
