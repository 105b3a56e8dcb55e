#define_import_path softshadow::light

#import softshadow::frame_types::FrameUniforms

// The light's shapes, sampled in one place (`AreaLight::sample` in crates/core/src/light_shape.rs
// is the CPU twin). Every function takes the frame uniforms `f`, so a pass with its own copy of
// them (the ray-traced exact answer) uses the same maths; passes with group 0 call the wrappers
// in frame.wgsl (`light_sample`, `light_reaches`, ...).

// The kinds (`LightKind`, `f.light_shape.x`).
const LIGHT_RECT: u32 = 0u;
const LIGHT_DISK: u32 = 1u;
const LIGHT_SPHERE: u32 = 2u;
const LIGHT_SPOT: u32 = 3u;
const LIGHT_SUN: u32 = 4u;

// Shadow segments to a light point ignore hits within this fraction of their length at the
// receiver and at the light (the CPU ray cast's `SEGMENT_EPSILON` / `LIGHT_END_EPSILON`).
const LIGHT_SEGMENT_EPSILON: f32 = 1e-4;
const LIGHT_END_EPSILON: f32 = 1e-6;

fn light_kind_of(f: FrameUniforms) -> u32 {
    return u32(f.light_shape.x + 0.5);
}

// Whether the light reaches the world point `world` (light-space `light`): every kind but the sun
// is one-sided (in front of the light plane), and a sphere does not light points inside itself.
fn light_reaches_point(f: FrameUniforms, world: vec3<f32>, light: vec3<f32>) -> bool {
    let kind = light_kind_of(f);
    if kind == LIGHT_SUN {
        return true;
    }
    if kind == LIGHT_SPHERE && length(world - f.light_center.xyz) <= f.light_shape.y {
        return false;
    }
    return light.z > 0.0;
}

// The area of the disk of radius `r` about the origin with u <= x and v <= y: the integral over
// u of the disk's chord below y (2 s(u) above the chord's top, y + s(u) across it, s(u) =
// sqrt(r^2 - u^2)), in closed form from `disk_area_left`.
fn disk_area_below_left(x: f32, y: f32, r: f32) -> f32 {
    if y <= -r || r <= 0.0 {
        return 0.0;
    }
    let xc = clamp(x, -r, r);
    if y >= r {
        return 2.0 * disk_area_left(xc, r);
    }
    let c = sqrt(max(r * r - y * y, 0.0));
    let m = clamp(xc, -c, c);
    let across = y * (m + c) + disk_area_left(m, r) - disk_area_left(-c, r);
    if y < 0.0 {
        return across;
    }
    let below = 2.0 * disk_area_left(min(xc, -c), r);
    let beyond = 2.0 * (disk_area_left(max(xc, c), r) - disk_area_left(c, r));
    return below + across + beyond;
}

// The integral of sqrt(r^2 - u^2) over [-r, x] (x in [-r, r]): half the disk's area left of x.
fn disk_area_left(x: f32, r: f32) -> f32 {
    let t = clamp(x / r, -1.0, 1.0);
    return 0.5 * r * r * (t * sqrt(max(1.0 - t * t, 0.0)) + asin(t)) + 0.25 * 3.14159265 * r * r;
}

// The area of the rectangle [lo, hi] inside the disk of radius `r` about the origin: a
// backprojected micro-patch's coverage of a disk light (docs/LIGHTS.md, "Round lights in the
// seed techniques").
fn rect_disk_area(lo: vec2<f32>, hi: vec2<f32>, r: f32) -> f32 {
    let a = disk_area_below_left(hi.x, hi.y, r) - disk_area_below_left(lo.x, hi.y, r)
        - disk_area_below_left(hi.x, lo.y, r) + disk_area_below_left(lo.x, lo.y, r);
    return max(a, 0.0);
}

// Shirley and Chiu's concentric map of [0, 1)^2 onto the unit disk (area-preserving).
fn concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let a = 2.0 * u - vec2<f32>(1.0);
    if a.x == 0.0 && a.y == 0.0 {
        return vec2<f32>(0.0);
    }
    let quarter = 0.785398163397448;
    var r = a.y;
    var theta = 2.0 * quarter - quarter * (a.x / a.y);
    if abs(a.x) > abs(a.y) {
        r = a.x;
        theta = quarter * (a.y / a.x);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

// Two unit vectors orthogonal to the unit `n` (Duff et al. 2017), as `orthonormal_basis` in Rust.
fn orthonormal_basis(n: vec3<f32>) -> array<vec3<f32>, 2> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return array<vec3<f32>, 2>(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}

// One shadow ray from a receiver: `world + t * to_light` for t in (t_min, t_max) must be free.
struct LightRay {
    to_light: vec3<f32>,
    t_min: f32,
    t_max: f32,
}

// The shadow ray from `world` to the light sample `u` in [0, 1)^2 (uniform u: uniform over the
// light's surface as seen from `world`): the rectangle, the disk (a spot's source too), the
// sphere's silhouette disk facing `world`, or the sun's cone of directions (unbounded ray).
// Call only where `light_reaches_point` holds.
fn sample_light(f: FrameUniforms, u: vec2<f32>, world: vec3<f32>) -> LightRay {
    var ray: LightRay;
    ray.t_min = LIGHT_SEGMENT_EPSILON;
    ray.t_max = 1.0 - LIGHT_END_EPSILON;
    let kind = light_kind_of(f);
    if kind == LIGHT_SUN {
        // Area-preserving from the disk to the cap: sin(theta / 2) = rho sin(alpha / 2).
        let d = concentric_disk(u);
        let rho = length(d);
        let theta = 2.0 * asin(rho * f.light_sun.x);
        let around = select(vec2<f32>(1.0, 0.0), d / max(rho, 1e-30), rho > 0.0);
        let x = f.light_to_world[0].xyz;
        let y = f.light_to_world[1].xyz;
        ray.to_light = -f.light_dir.xyz * cos(theta) + (x * around.x + y * around.y) * sin(theta);
        // The receiver's own rounding scale; the sun is at infinity.
        let scale = max(max(abs(world.x), abs(world.y)), max(abs(world.z), 1.0));
        ray.t_min = LIGHT_SEGMENT_EPSILON * scale;
        ray.t_max = 3.0e38;
        return ray;
    }
    if kind == LIGHT_SPHERE {
        // The circle where the tangent cone from `world` touches the sphere.
        let w = world - f.light_center.xyz;
        let dist = length(w);
        let n = w / dist;
        let r = f.light_shape.y;
        let ratio = min(r / dist, 1.0);
        let centre = f.light_center.xyz + n * (r * ratio);
        let radius = r * sqrt(max(1.0 - ratio * ratio, 0.0));
        let basis = orthonormal_basis(n);
        let d = concentric_disk(u) * radius;
        ray.to_light = centre + basis[0] * d.x + basis[1] * d.y - world;
        return ray;
    }
    var on_light = vec2<f32>((2.0 * u.x - 1.0) * f.light_half.x, (2.0 * u.y - 1.0) * f.light_half.y);
    if kind != LIGHT_RECT {
        on_light = concentric_disk(u) * f.light_shape.y;
    }
    let light_point = (f.light_to_world * vec4<f32>(on_light, 0.0, 1.0)).xyz;
    ray.to_light = light_point - world;
    return ray;
}
