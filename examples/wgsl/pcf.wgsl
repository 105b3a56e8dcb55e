// Percentage-closer filtering (Reeves et al. 1987) over a square of texels of the centre shadow map.
// With radius 0 it is one tap: the hard shadow of `hard`, bit for bit (under the sun, of `hard`
// with `cascades=1`).
// @contract 3
// @param radius: u32 = 1 in 0..=8, Half width of the square kernel in texels (0: one tap, a hard shadow)
// @param bias_texels: f32 = 1.5 in 0.0..=16.0, Depth bias in texel footprints at the receiver (scaled by 1/cos on slopes)
// @fit receivers

fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {
    let p = map_point(s);
    // floor, not truncation: a receiver just left of the map is outside it (lit), as in `hard`.
    let centre = vec2<i32>(floor(p.uv * view.size.xy));
    let bias = map_bias(s, params.bias_texels);
    let r = i32(params.radius);
    var lit = 0.0;
    for (var dy = -r; dy <= r; dy += 1) {
        for (var dx = -r; dx <= r; dx += 1) {
            // Every caster projects inside the map: a texel outside it holds no occluder.
            if map_texel_depth(centre + vec2<i32>(dx, dy)) >= p.depth - bias {
                lit += 1.0;
            }
        }
    }
    let taps = f32((2 * r + 1) * (2 * r + 1));
    return lit / taps;
}
