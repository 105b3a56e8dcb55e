// Appendix A workaround of Atty et al. 2006 (fp16-batched): one batch of micro-patches has been
// summed with FP16 blending; this pass adds the batch's soft shadow map into the FP32 total
// (additive blending), so small contributions are never added to a large FP16 sum.
#import softshadow::fullscreen::{FullscreenVertex, fullscreen_vertex}

@group(1) @binding(0) var batch: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(batch, vec2<i32>(in.position.xy), 0).r, 0.0, 0.0, 0.0);
}
