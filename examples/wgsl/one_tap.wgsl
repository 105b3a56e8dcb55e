// hard's lookup, line for line, as a file technique: the framework's tax alone.
// @contract 2
// @param bias_texels: f32 = 1.5 in 0.0..=16.0, Depth bias in texel footprints
// @fit receivers
fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {
    let uv = view_uv(view, s.light);
    if !in_map(uv) {
        return 1.0;
    }
    let d = textureLoad(shadow_map, vec2<i32>(uv * view.size.xy), 0);
    if d >= 1.0 {
        return 1.0;
    }
    let bias = params.bias_texels * texel_slope(view) * s.light.z / light_cosine(s);
    return select(0.0, 1.0, linear_depth(view, d) >= s.light.z - bias);
}
