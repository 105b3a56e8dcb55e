// Host surface conversion (`softshadow_core::host`): turns a host renderer's G-buffer (world
// position, or depth with the inverse view-projection; a normal; an optional receiver mask) into
// the two textures every technique reads through `softshadow::frame` (world position + hit flag,
// normal facing the camera + receiver flag), so techniques read one surface format whoever drew
// it. `FROM_DEPTH` selects the depth variant (a `texture_depth_2d` cannot share a binding type
// with a colour texture).
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

struct HostSurface {
    inverse_view_proj: mat4x4<f32>,
    // xyz camera position.
    eye: vec4<f32>,
    // x: 1 = normals are stored as n * 0.5 + 0.5; y: 1 = a receiver mask is bound;
    // z: the depth of pixels where nothing was drawn (1 for a depth buffer cleared to 1, 0 with
    // reversed depth); w: unused.
    mode: vec4<f32>,
}

@group(0) @binding(0) var<uniform> host: HostSurface;
#ifdef FROM_DEPTH
@group(0) @binding(1) var positions: texture_depth_2d;
#else
@group(0) @binding(1) var positions: texture_2d<f32>;
#endif
@group(0) @binding(2) var normals: texture_2d<f32>;
@group(0) @binding(3) var receiver_mask: texture_2d<f32>;

struct SurfaceOut {
    // xyz world position; w = 1 where geometry was drawn.
    @location(0) position: vec4<f32>,
    // xyz unit normal facing the camera; w = 1 for shadow receivers.
    @location(1) normal: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> SurfaceOut {
    let pixel = vec2<i32>(in.position.xy);
#ifdef FROM_DEPTH
    let depth = textureLoad(positions, pixel, 0);
    let hit = depth != host.mode.z;
    // Pixel centre to normalised device coordinates (y up), then back to world space.
    let size = vec2<f32>(textureDimensions(positions));
    let ndc = vec2<f32>(in.position.x / size.x * 2.0 - 1.0, 1.0 - in.position.y / size.y * 2.0);
    let h = host.inverse_view_proj * vec4<f32>(ndc, depth, 1.0);
    let world = h.xyz / h.w;
#else
    let p = textureLoad(positions, pixel, 0);
    let hit = p.w > 0.5;
    let world = p.xyz;
#endif
    var n = textureLoad(normals, pixel, 0).xyz;
    if host.mode.x > 0.5 {
        n = n * 2.0 - 1.0;
    }
    n = select(vec3<f32>(0.0, 1.0, 0.0), normalize(n), dot(n, n) > 1e-12);
    // The workbench's G-buffer holds normals facing the camera (both sides of thin occluders are
    // seen); a host's may face away on back faces.
    if dot(n, host.eye.xyz - world) < 0.0 {
        n = -n;
    }
    var receives = true;
    if host.mode.y > 0.5 {
        receives = textureLoad(receiver_mask, pixel, 0).x > 0.5;
    }
    var out: SurfaceOut;
    out.position = vec4<f32>(world, select(0.0, 1.0, hit));
    out.normal = vec4<f32>(n, select(0.0, 1.0, hit && receives));
    return out;
}
