// What a frame with no caster in front of the light writes (`VisibilityBuffer::write_unshadowed`):
// receivers in front of the light plane are lit, receivers at or behind it hold 0 (a one-sided
// light cannot reach them; docs/ARCHITECTURE.md), pixels without a receiver hold 1.
#import softshadow::frame::{load_surface, light_reaches}
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let s = load_surface(vec2<i32>(in.position.xy));
    if s.is_receiver && !light_reaches(s) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(1.0);
}
