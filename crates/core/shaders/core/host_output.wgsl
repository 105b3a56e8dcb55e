// Copies the visibility buffer into a host's colour target of any float format
// (`softshadow_core::host::HostOutput::View`): V in every channel, alpha 1.
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

@group(0) @binding(0) var visibility: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let v = textureLoad(visibility, vec2<i32>(in.position.xy), 0).x;
    return vec4<f32>(v, v, v, 1.0);
}
