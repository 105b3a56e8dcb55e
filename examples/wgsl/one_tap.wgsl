// hard's lookup as a file technique, through the contract's map helpers: the framework's tax alone.
// @contract 3
// @param bias_texels: f32 = 1.5 in 0.0..=16.0, Depth bias in texel footprints
// @fit receivers
fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {
    let p = map_point(s);
    let bias = map_bias(s, params.bias_texels);
    return select(0.0, 1.0, map_depth(p.uv) >= p.depth - bias);
}
