//! One frame, top to bottom (docs/ARCHITECTURE.md, "The contract"):
//! G-buffer pass -> technique passes -> visibility buffer -> shading pass (only when asked),
//! with every pass timed (GPU timestamps, or each pass submitted and waited for on its own: see
//! [`TimingSource`]) and listed in `passes_run`.

use std::time::Instant;

use wgpu_profiler::{GpuProfiler, GpuProfilerSettings, GpuTimerQueryResult};

use crate::{
    error::{GpuError, RenderError},
    frame::{Frame, FrameUniforms, ShadowInputs, TimingSource},
    gbuffer::{GBuffer, GBufferPass},
    readback,
    scene_gpu::SceneGpu,
    shading::{ShadingMode, ShadingPass},
    stage::ShadowStage,
    technique::ShadowTechnique,
    visibility::VisibilityBuffer,
    AreaLight, Camera, Gpu,
};

/// Largest accepted frame edge (a 16384² R32Float buffer is 1 GiB; nobody benchmarks that here).
pub const MAX_RESOLUTION: u32 = 8192;

/// Pass times of one frame, from the source in [`FrameOutput::timing_source`] (timestamp queries,
/// or the wall time of each pass submitted on its own). Passes with the same name (e.g. one depth
/// pass per light sample) are summed; `total_ms` is the sum over all passes.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct GpuFrameTiming {
    /// Sum of every pass.
    pub total_ms: f64,
    /// Time per pass name, in first-run order.
    pub passes: Vec<(String, f64)>,
}

impl GpuFrameTiming {
    /// Time of the technique's own passes (everything but the G-buffer and shading).
    pub fn technique_ms(&self) -> f64 {
        self.passes
            .iter()
            .filter(|(name, _)| !is_core_pass(name))
            .map(|(_, ms)| ms)
            .sum()
    }
}

/// Passes the renderer itself records around the technique.
pub fn is_core_pass(name: &str) -> bool {
    name == "gbuffer" || name == "shading"
}

/// What [`Renderer::render`] returns about a frame.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct FrameOutput {
    /// Names of the passes that ran, in order (light-space passes kept from an earlier frame are not in it).
    pub passes_run: Vec<String>,
    /// Wall time from the start of recording to the end of GPU work.
    pub cpu_ms: f64,
    /// Pass times measured with `timing_source`; `None` with timestamps when the adapter has no
    /// timestamp queries.
    pub gpu: Option<GpuFrameTiming>,
    /// How `gpu` was measured (the viewer's timing panel says which).
    pub timing_source: TimingSource,
    /// The most GPU memory the device held during the frame (after any pass, or once the frame
    /// was submitted): the renderer's, the scene's and the technique's ([`crate::memory`]).
    pub memory_peak: crate::memory::MemoryUse,
}

/// The workbench's renderer: its own G-buffer over an uploaded [`SceneGpu`], a technique, and an
/// optional shading pass, every pass timed. Runs techniques through the same [`ShadowStage`] as
/// [`crate::host::HostRenderer`].
pub struct Renderer {
    gpu: Gpu,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// The G-buffer drawn every frame.
    pub gbuffer: GBuffer,
    gbuffer_pass: GBufferPass,
    shading: ShadingPass,
    /// Bind group 0 over the G-buffer: the same stage a host renderer runs over its textures.
    stage: ShadowStage,
    uniform_bind_group: wgpu::BindGroup,
    /// The technique's output of the last frame.
    pub visibility: VisibilityBuffer,
    /// The shaded image of the last frame rendered with a [`ShadingMode`] (sRGB RGBA8).
    pub shaded: wgpu::Texture,
    shaded_view: wgpu::TextureView,
    profiler: GpuProfiler,
    /// How passes are timed; [`TimingSource::default_for`] the adapter unless set.
    pub timing: TimingSource,
}

impl Renderer {
    /// A renderer for `width` x `height` frames (1 to [`MAX_RESOLUTION`] pixels each way).
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> Result<Self, RenderError> {
        let max = MAX_RESOLUTION.min(gpu.device.limits().max_texture_dimension_2d);
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::BadResolution { width, height, max });
        }
        let gbuffer = GBuffer::new(gpu, width, height);
        let stage = ShadowStage::new(
            gpu,
            &gbuffer.position_view,
            &gbuffer.normal_view,
            width,
            height,
        );
        let uniform_bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/frame-uniform"),
            layout: &gpu.layouts.frame_uniform,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: stage.uniform_buffer().as_entire_binding(),
            }],
        });
        let profiler = GpuProfiler::new(
            &gpu.device,
            GpuProfilerSettings {
                enable_timer_queries: gpu.has_timestamps(),
                enable_debug_groups: false,
                max_num_pending_frames: 4,
            },
        )
        .map_err(|e| GpuError::Profiler(e.to_string()))?;
        let shaded = ShadingPass::create_target(gpu, width, height);
        Ok(Self {
            gpu: gpu.clone(),
            width,
            height,
            gbuffer_pass: GBufferPass::new(gpu)?,
            shading: ShadingPass::new(gpu)?,
            stage,
            uniform_bind_group,
            visibility: VisibilityBuffer::new(gpu, "visibility", width, height),
            shaded_view: shaded.create_view(&Default::default()),
            shaded,
            gbuffer,
            profiler,
            timing: TimingSource::default_for(gpu),
        })
    }

    /// The GPU context.
    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    /// What a technique reads: the scene, light and the frame bind group over the G-buffer,
    /// for [`ShadowTechnique::prepare`] outside a frame (`changes` says everything changed). The
    /// uniforms are those of `camera` at this renderer's size.
    pub fn inputs<'a>(
        &'a self,
        scene: &'a SceneGpu,
        camera: &'a Camera,
        light: &'a AreaLight,
    ) -> ShadowInputs<'a> {
        let mut inputs = self.stage.inputs(scene, light);
        inputs.uniforms = FrameUniforms::new(camera, light, self.width, self.height);
        inputs
    }

    /// Renders one frame with `technique` into [`Renderer::visibility`] (and [`Renderer::shaded`]
    /// when `shade`), waits for the GPU, and returns the passes run and their GPU times.
    pub fn render(
        &mut self,
        scene: &SceneGpu,
        camera: &Camera,
        light: &AreaLight,
        technique: &mut dyn ShadowTechnique,
        shade: Option<ShadingMode>,
    ) -> Result<FrameOutput, RenderError> {
        puffin::profile_function!();
        camera.validate().map_err(RenderError::Scene)?;
        let uniforms = FrameUniforms::new(camera, light, self.width, self.height);
        let (state, changes) = self
            .stage
            .begin(&self.gpu, scene, light, uniforms, technique)?;
        let start = Instant::now();

        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some(technique.id()),
            });
        let mut passes_run = Vec::new();
        let timing_source = self.timing;
        let serial;
        let cpu_passes;
        let mut memory_peak;
        let result = {
            let mut frame = Frame::new(&self.gpu, &mut encoder, &self.profiler, &mut passes_run);
            if timing_source == TimingSource::Serial {
                frame = frame.time_serially();
            }
            self.gbuffer_pass
                .record(&mut frame, &self.gbuffer, &self.uniform_bind_group, scene);
            let result = self.stage.record(
                &mut frame,
                scene,
                light,
                changes,
                technique,
                &self.visibility,
            );
            if result.is_ok() {
                if let Some(mode) = shade {
                    self.shading.record(
                        &mut frame,
                        mode,
                        self.stage.frame_bind_group(),
                        &self.gbuffer,
                        &self.visibility,
                        &self.shaded_view,
                    );
                }
            }
            serial = frame.take_serial_times();
            cpu_passes = frame.take_cpu_passes();
            memory_peak = frame.memory_peak();
            result
        };
        self.profiler.resolve_queries(&mut encoder);
        self.gpu.queue.submit([encoder.finish()]);
        let _ = self.profiler.end_frame();
        // Before the wait, which frees what the frame dropped.
        memory_peak = memory_peak.max_by_total(self.gpu.memory_in_use());
        self.gpu.wait_idle()?;
        self.gpu.take_errors()?;
        result?;
        let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        // Drains the profiler's (empty, in serial mode) frame either way.
        let timestamps = self.collect_timings();
        let gpu = match serial {
            Some(serial) => {
                if let Some(e) = serial.error {
                    return Err(e.into());
                }
                Some(GpuFrameTiming {
                    total_ms: serial.passes.iter().map(|(_, ms)| ms).sum(),
                    passes: serial.passes,
                })
            }
            None => timestamps.map(|mut timing| {
                timing.total_ms += cpu_passes.iter().map(|(_, ms)| ms).sum::<f64>();
                timing.passes.extend(cpu_passes);
                timing
            }),
        };
        self.stage.finish(technique.id(), state);
        Ok(FrameOutput {
            passes_run,
            cpu_ms,
            gpu,
            timing_source,
            memory_peak,
        })
    }

    /// Draws the G-buffer at `camera`, takes `visibility` (row-major, this renderer's size) as
    /// the frame's visibility and shades it with `shade`: the frame of a technique that ran
    /// elsewhere (the viewer's render worker, on a device of its own) shown and measured here as
    /// if it had run on this renderer. Nothing is timed.
    pub fn show_visibility(
        &mut self,
        scene: &SceneGpu,
        camera: &Camera,
        light: &AreaLight,
        visibility: &[f32],
        shade: ShadingMode,
    ) -> Result<(), RenderError> {
        puffin::profile_function!();
        camera.validate().map_err(RenderError::Scene)?;
        let expected = self.width as usize * self.height as usize;
        if visibility.len() != expected {
            return Err(RenderError::VisibilitySize {
                got: visibility.len(),
                width: self.width,
                height: self.height,
            });
        }
        self.stage.write_uniforms(
            &self.gpu,
            FrameUniforms::new(camera, light, self.width, self.height),
        );
        self.gpu.queue.write_texture(
            self.visibility.texture.as_image_copy(),
            bytemuck::cast_slice(visibility),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * self.width),
                rows_per_image: Some(self.height),
            },
            self.visibility.texture.size(),
        );
        let mut encoder = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("show_visibility"),
            });
        let mut passes_run = Vec::new();
        {
            let mut frame = Frame::new(&self.gpu, &mut encoder, &self.profiler, &mut passes_run);
            self.gbuffer_pass
                .record(&mut frame, &self.gbuffer, &self.uniform_bind_group, scene);
            self.shading.record(
                &mut frame,
                shade,
                self.stage.frame_bind_group(),
                &self.gbuffer,
                &self.visibility,
                &self.shaded_view,
            );
        }
        self.profiler.resolve_queries(&mut encoder);
        self.gpu.queue.submit([encoder.finish()]);
        let _ = self.profiler.end_frame();
        self.gpu.wait_idle()?;
        self.gpu.take_errors()?;
        // Drains the profiler's frame so the next timed frame reads its own queries.
        let _ = self.collect_timings();
        Ok(())
    }

    fn collect_timings(&mut self) -> Option<GpuFrameTiming> {
        if !self.gpu.has_timestamps() {
            return None;
        }
        // The frame has finished (we waited), so its queries are mapped after one more poll.
        let period = self.gpu.queue.get_timestamp_period();
        let mut latest = None;
        for _ in 0..8 {
            let _ = self.gpu.device.poll(wgpu::PollType::Poll);
            while let Some(results) = self.profiler.process_finished_frame(period) {
                latest = Some(results);
            }
            if latest.is_some() {
                break;
            }
            let _ = self.gpu.wait_idle();
        }
        let results = latest?;
        let mut timing = GpuFrameTiming::default();
        accumulate(&results, &mut timing);
        Some(timing)
    }

    /// The visibility buffer of the last frame, row-major.
    pub fn read_visibility(&self) -> Result<Vec<f32>, GpuError> {
        readback::read_r32f(&self.gpu, &self.visibility.texture)
    }

    /// sRGB RGBA8 bytes of the last shaded frame.
    pub fn read_shaded(&self) -> Result<Vec<u8>, GpuError> {
        readback::read_texture(&self.gpu, &self.shaded)
    }

    /// World position per pixel (`None` where no geometry was hit).
    pub fn read_world_positions(&self) -> Result<Vec<Option<glam::Vec3>>, GpuError> {
        let position = readback::read_r32f(&self.gpu, &self.gbuffer.position)?;
        Ok(position
            .chunks_exact(4)
            .map(|p| (p[3] > 0.5).then(|| glam::Vec3::new(p[0], p[1], p[2])))
            .collect())
    }

    /// World-space unit normal per pixel as the shading uses it (facing the camera; zero where
    /// no geometry was hit), from the G-buffer's RGBA16F normal target.
    pub fn read_world_normals(&self) -> Result<Vec<glam::Vec3>, GpuError> {
        let normal = readback::read_texture(&self.gpu, &self.gbuffer.normal)?;
        let component = |b: &[u8]| half::f16::from_le_bytes([b[0], b[1]]).to_f32();
        Ok(normal
            .chunks_exact(8)
            .map(|n| {
                let v = glam::Vec3::new(
                    component(&n[0..2]),
                    component(&n[2..4]),
                    component(&n[4..6]),
                );
                v.normalize_or_zero()
            })
            .collect())
    }

    /// `true` for pixels that see a shadow receiver.
    pub fn read_receiver_mask(&self) -> Result<Vec<bool>, GpuError> {
        let normal = readback::read_texture(&self.gpu, &self.gbuffer.normal)?;
        let position = readback::read_texture(&self.gpu, &self.gbuffer.position)?;
        // Normal is RGBA16F: w is the receiver flag, 1.0 = 0x3C00.
        Ok(normal
            .chunks_exact(8)
            .zip(position.chunks_exact(16))
            .map(|(n, p)| {
                let receiver = u16::from_le_bytes([n[6], n[7]]) == 0x3C00;
                let hit = f32::from_le_bytes([p[12], p[13], p[14], p[15]]) > 0.5;
                receiver && hit
            })
            .collect())
    }
}

fn accumulate(results: &[GpuTimerQueryResult], timing: &mut GpuFrameTiming) {
    for r in results {
        if let Some(range) = &r.time {
            let ms = (range.end - range.start) * 1e3;
            timing.total_ms += ms;
            match timing.passes.iter_mut().find(|(n, _)| *n == r.label) {
                Some((_, t)) => *t += ms,
                None => timing.passes.push((r.label.clone(), ms)),
            }
        }
        // Nested scopes are inside their parent's time; only top-level passes add to the total.
    }
}
