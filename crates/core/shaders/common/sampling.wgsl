#define_import_path softshadow::sampling

const PI: f32 = 3.14159265358979;
const GOLDEN_ANGLE: f32 = 2.39996322972865;

// Jimenez 2014 interleaved gradient noise: per-pixel rotation that a small blur hides.
fn interleaved_gradient_noise(pixel: vec2<f32>) -> f32 {
    return fract(52.9829189 * fract(dot(pixel, vec2<f32>(0.06711056, 0.00583715))));
}

// Point i of n on a Vogel (golden-angle) spiral in the unit disk, rotated by `phi`.
fn vogel_disk(i: u32, n: u32, phi: f32) -> vec2<f32> {
    let r = sqrt((f32(i) + 0.5) / f32(n));
    let theta = f32(i) * GOLDEN_ANGLE + phi;
    return r * vec2<f32>(cos(theta), sin(theta));
}
