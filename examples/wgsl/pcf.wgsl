// Percentage-closer filtering (Reeves et al. 1987) over a square of texels of the centre shadow map.
// With radius 0 it is one tap: the hard shadow of `hard`, bit for bit.
// @contract 2
// @param radius: u32 = 1 in 0..=8, Half width of the square kernel in texels (0: one tap, a hard shadow)
// @param bias_texels: f32 = 1.5 in 0.0..=16.0, Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
// @fit receivers

fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {
    let size = vec2<i32>(view.size.xy);
    // floor, not truncation: a receiver just left of the map is outside it (lit), as in `hard`.
    let centre = vec2<i32>(floor(view_uv(view, s.light) * view.size.xy));
    let bias = params.bias_texels * texel_slope(view) * s.light.z / light_cosine(s);
    let r = i32(params.radius);
    var lit = 0.0;
    for (var dy = -r; dy <= r; dy += 1) {
        for (var dx = -r; dx <= r; dx += 1) {
            let texel = centre + vec2<i32>(dx, dy);
            // Every caster projects inside the map: a texel outside it holds no occluder.
            if any(texel < vec2<i32>(0)) || any(texel >= size) {
                lit += 1.0;
                continue;
            }
            let d = textureLoad(shadow_map, texel, 0);
            if d >= 1.0 || linear_depth(view, d) >= s.light.z - bias {
                lit += 1.0;
            }
        }
    }
    let taps = f32((2 * r + 1) * (2 * r + 1));
    return lit / taps;
}
