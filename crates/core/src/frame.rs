//! Per-frame data every technique receives: the shared bind group 0 (frame uniforms and the
//! G-buffer), the command encoder and the GPU timer, wrapped so that every pass gets a named
//! timer scope and is recorded in `passes_run`.

use encase::ShaderType;
use glam::{Mat4, Vec4};

use crate::{light::AreaLight, scene_gpu::SceneGpu, Camera, Gpu};

/// The frame uniforms every technique pass reads (`FrameUniforms` in
/// `shaders/common/frame_types.wgsl`).
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct FrameUniforms {
    /// World to clip of the camera.
    pub view_proj: Mat4,
    /// World to light space (light centre at the origin, facing +z).
    pub world_to_light: Mat4,
    /// xyz camera position, w = 1.
    pub camera_pos: Vec4,
    /// xyz light centre, w = light intensity.
    pub light_center: Vec4,
    /// xyz light direction, w = the ambient term ([`AMBIENT`]).
    pub light_dir: Vec4,
    /// Half width, half height and area of the light rectangle; w unused.
    pub light_half: Vec4,
    /// Width, height, 1 / width, 1 / height of the frame.
    pub screen: Vec4,
    /// Light space to world (the inverse of `world_to_light`).
    pub light_to_world: Mat4,
    /// x: the light's kind ([`crate::LightKind`] as a number); y: radius of a disk, sphere or
    /// spot source; z, w: cosines of a spot's inner and outer cone angles.
    pub light_shape: Vec4,
    /// The sun: x = sin of a quarter of its angular diameter (its sampling), y = tan of half
    /// of it (its penumbra per unit of distance), z = cos of half of it; w unused.
    pub light_sun: Vec4,
}

/// Ambient term of the shading pass (fraction of albedo visible in full shadow).
pub const AMBIENT: f32 = 0.12;

impl FrameUniforms {
    /// The uniforms of a frame seen by the workbench's `camera`.
    pub fn new(camera: &Camera, light: &AreaLight, width: u32, height: u32) -> Self {
        let view_proj = camera.view_projection(width as f32 / height as f32);
        Self::from_view(view_proj, camera.eye, light, width, height)
    }

    /// The uniforms of a frame seen through any view-projection matrix (a host renderer's
    /// camera) from `eye`. Depth in clip space is [0, 1], as wgpu's.
    pub fn from_view(
        view_proj: Mat4,
        eye: glam::Vec3,
        light: &AreaLight,
        width: u32,
        height: u32,
    ) -> Self {
        let half = light.half_extent();
        let half_alpha = light.angular_diameter_degrees.to_radians() * 0.5;
        let world_to_light = light.view();
        Self {
            view_proj,
            world_to_light,
            camera_pos: eye.extend(1.0),
            light_center: light.center.extend(light.intensity),
            light_dir: light
                .direction
                .normalize_or(glam::Vec3::NEG_Y)
                .extend(AMBIENT),
            light_half: Vec4::new(half.x, half.y, light.area(), 0.0),
            screen: Vec4::new(
                width as f32,
                height as f32,
                1.0 / width as f32,
                1.0 / height as f32,
            ),
            light_to_world: world_to_light.inverse(),
            light_shape: Vec4::new(
                light.kind as u32 as f32,
                light.radius,
                light.cone_inner_degrees.to_radians().cos(),
                light.cone_outer_degrees.to_radians().cos(),
            ),
            light_sun: Vec4::new(
                (half_alpha * 0.5).sin(),
                half_alpha.tan(),
                half_alpha.cos(),
                0.0,
            ),
        }
    }

    /// The camera's view-projection matrix.
    pub fn view_proj(&self) -> Mat4 {
        self.view_proj
    }

    /// The camera position.
    pub fn eye(&self) -> glam::Vec3 {
        self.camera_pos.truncate()
    }

    /// World to light space (light centre at the origin, facing +z).
    pub fn world_to_light(&self) -> Mat4 {
        self.world_to_light
    }
}

/// Bind group layouts shared by all crates.
pub struct CoreLayouts {
    /// Group 0 of technique passes: frame uniforms, G-buffer position and normal
    /// (`shaders/common/frame.wgsl`).
    pub frame: wgpu::BindGroupLayout,
    /// Just the frame uniforms (the G-buffer pass, which cannot read its own targets).
    pub frame_uniform: wgpu::BindGroupLayout,
}

impl CoreLayouts {
    /// Creates the layouts on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        let all =
            wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
        let uniform = wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: all,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: Some(FrameUniforms::min_size()),
            },
            count: None,
        };
        let frame = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("core/frame"),
            entries: &[
                uniform,
                texture_entry(1, all, wgpu::TextureSampleType::Float { filterable: false }),
                texture_entry(2, all, wgpu::TextureSampleType::Float { filterable: false }),
            ],
        });
        let frame_uniform = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("core/frame-uniform"),
            entries: &[uniform],
        });
        Self {
            frame,
            frame_uniform,
        }
    }
}

/// A compute-stage entry for a write-only 2D storage texture of `format`.
pub fn storage_texture_entry(
    binding: u32,
    format: wgpu::TextureFormat,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// A `texture_2d` layout entry (helper for the many fullscreen passes).
pub fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A uniform-buffer layout entry.
pub fn uniform_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

/// What changed since the last frame this renderer drew with the same technique (by id).
/// Light-space results (shadow maps, depth hierarchies, soft shadow maps, precomputes) depend
/// only on the light, the casters and the technique's parameters, so a technique keeps them
/// while [`FrameChanges::light_space`] is false, and leaves their passes out of `passes_run`.
/// A technique that has nothing cached (first frame, or after
/// [`ShadowTechnique::invalidate_cache`](crate::ShadowTechnique::invalidate_cache)) builds
/// whatever the flags say.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameChanges {
    /// Camera position, orientation or field of view.
    pub camera: bool,
    /// Light position, orientation, size or intensity.
    pub light: bool,
    /// Geometry or placement of instances with `dynamic == false`.
    pub static_instances: bool,
    /// Geometry or placement of instances with `dynamic == true`.
    pub dynamic_instances: bool,
    /// Frame width or height.
    pub size: bool,
    /// Any of the technique's own parameters.
    pub params: bool,
}

impl FrameChanges {
    /// Everything changed: the first frame, or inputs made outside a frame.
    pub const ALL: Self = Self {
        camera: true,
        light: true,
        static_instances: true,
        dynamic_instances: true,
        size: true,
        params: true,
    };
    /// Nothing changed.
    pub const NONE: Self = Self {
        camera: false,
        light: false,
        static_instances: false,
        dynamic_instances: false,
        size: false,
        params: false,
    };

    /// Something a light-space result over every caster depends on changed: the light, any
    /// caster (static or dynamic) or the technique's parameters.
    pub fn light_space(&self) -> bool {
        self.light || self.static_instances || self.dynamic_instances || self.params
    }

    /// Something a precompute over the static casters only depends on changed (the light, the
    /// static instances or the parameters; dynamic instances do not matter).
    pub fn static_light_space(&self) -> bool {
        self.light || self.static_instances || self.params
    }
}

/// What [`FrameChanges`] is computed from: the inputs of one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameState {
    /// The camera's view-projection matrix.
    pub view_proj: Mat4,
    /// The camera position.
    pub eye: glam::Vec3,
    /// The area light.
    pub light: AreaLight,
    /// [`SceneGpu::static_hash`] of the casters.
    pub static_hash: u64,
    /// [`SceneGpu::dynamic_hash`] of the casters.
    pub dynamic_hash: u64,
    /// Frame width and height.
    pub size: (u32, u32),
    /// The technique's parameters.
    pub params: crate::params::ParamSet,
}

impl FrameState {
    /// What differs from `previous` (everything when there is none).
    pub fn changes_since(&self, previous: Option<&FrameState>) -> FrameChanges {
        match previous {
            None => FrameChanges::ALL,
            Some(p) => FrameChanges {
                camera: self.view_proj != p.view_proj || self.eye != p.eye,
                light: self.light != p.light,
                static_instances: self.static_hash != p.static_hash,
                dynamic_instances: self.dynamic_hash != p.dynamic_hash,
                size: self.size != p.size,
                params: self.params != p.params,
            },
        }
    }
}

/// What a technique reads each frame. Built by [`crate::ShadowStage::inputs`], for the
/// workbench's [`crate::Renderer`] (over its G-buffer and an uploaded scene) and for a host
/// renderer through [`crate::host::HostRenderer`] (over the host's textures and buffers) alike.
pub struct ShadowInputs<'a> {
    /// What changed since this technique's last frame on this renderer.
    pub changes: FrameChanges,
    /// The shadow casters (and receivers' bounds): a scene uploaded by the workbench
    /// ([`SceneGpu::upload`]) or a host's buffers ([`SceneGpu::from_host`]).
    pub scene: &'a SceneGpu,
    /// The area light.
    pub light: &'a AreaLight,
    /// Bind group for [`CoreLayouts::frame`]: the frame uniforms and the receiver surface
    /// (world position and normal textures, `shaders/common/frame.wgsl`).
    pub frame_bind_group: &'a wgpu::BindGroup,
    /// The values in the frame bind group's uniform buffer.
    pub uniforms: FrameUniforms,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
}

/// How pass times are measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimingSource {
    /// GPU timestamp queries around each pass, all passes in one submission. Cheap and exact on
    /// a GPU; on lavapipe before Mesa 24.1 a timestamp does not wait for earlier compute
    /// dispatches, so compute passes read almost nothing (docs/DEVICES.md, "Lavapipe's
    /// timestamps").
    Timestamps,
    /// Each pass recorded into its own submission and waited for: the pass time is the wall
    /// time from the start of its recording to the end of its GPU work. True on every adapter,
    /// at the cost of one CPU-GPU round trip per pass (plus one to drain earlier work).
    Serial,
}

impl TimingSource {
    /// Both sources, in the order the GUI lists them.
    pub const ALL: [Self; 2] = [Self::Timestamps, Self::Serial];

    /// `serial` on a CPU adapter (whose timestamps do not cover compute work), `timestamps` on a
    /// GPU that has timestamp queries, `serial` on one that has none.
    pub fn default_for(gpu: &Gpu) -> Self {
        if gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu || !gpu.has_timestamps() {
            Self::Serial
        } else {
            Self::Timestamps
        }
    }

    /// The name used in JSON and on the command line.
    pub fn as_str(&self) -> &'static str {
        match self {
            Self::Timestamps => "timestamps",
            Self::Serial => "serial",
        }
    }

    /// Parses `timestamps` or `serial`.
    pub fn parse(text: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.as_str() == text)
    }
}

impl std::fmt::Display for TimingSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Pass times of a frame recorded with [`TimingSource::Serial`].
#[derive(Debug, Default)]
pub struct SerialTimes {
    /// Wall time per pass name (passes of the same name summed), in first-run order.
    pub passes: Vec<(String, f64)>,
    /// The first failed wait (device lost): the frame reports it.
    pub error: Option<crate::GpuError>,
}

/// Command recording for one frame. Every pass goes through [`Frame::render_pass`] or
/// [`Frame::compute_pass`], which times the pass (a timestamp-query scope, or with
/// [`TimingSource::Serial`] a submission of its own) and records its name in
/// [`Frame::passes_run`].
pub struct Frame<'a> {
    /// The GPU context.
    pub gpu: &'a Gpu,
    /// The encoder passes are recorded into (replaced by a fresh one by [`Frame::submit_and_wait`]).
    pub encoder: &'a mut wgpu::CommandEncoder,
    profiler: &'a wgpu_profiler::GpuProfiler,
    passes_run: &'a mut Vec<String>,
    /// `Some` when passes are timed serially.
    serial: Option<SerialTimes>,
    /// Wall times of CPU passes when timing with timestamps ([`Frame::end_cpu_pass`]).
    cpu_passes: Vec<(String, f64)>,
    /// The most GPU memory the device held after any pass of this frame ([`crate::memory`]).
    memory_peak: crate::memory::MemoryUse,
}

impl<'a> Frame<'a> {
    /// A frame recording into `encoder`, timing passes with `profiler`'s timestamp queries (see
    /// [`Frame::time_serially`]) and listing their names in `passes_run`.
    pub fn new(
        gpu: &'a Gpu,
        encoder: &'a mut wgpu::CommandEncoder,
        profiler: &'a wgpu_profiler::GpuProfiler,
        passes_run: &'a mut Vec<String>,
    ) -> Self {
        Self {
            gpu,
            encoder,
            profiler,
            passes_run,
            serial: None,
            cpu_passes: Vec::new(),
            memory_peak: gpu.memory_in_use(),
        }
    }

    /// The most GPU memory the device held at the start of this frame or after any of its
    /// passes so far: every pass ends in [`Frame::note_pass`], which reads it.
    pub fn memory_peak(&self) -> crate::memory::MemoryUse {
        self.memory_peak
    }

    /// Times every pass of this frame with [`TimingSource::Serial`] instead of timestamp queries.
    pub fn time_serially(mut self) -> Self {
        self.serial = Some(SerialTimes::default());
        self
    }

    /// The serial pass times (`None` when timing with timestamps).
    pub fn take_serial_times(&mut self) -> Option<SerialTimes> {
        self.serial.take()
    }

    /// Whether this frame times its passes serially ([`TimingSource::Serial`]).
    pub fn is_timed_serially(&self) -> bool {
        self.serial.is_some()
    }

    /// With serial timing, the wall time of the passes named `label` so far in this frame, in ms
    /// (0 before the first); `None` when timing with timestamps.
    pub fn serial_pass_ms(&self, label: &str) -> Option<f64> {
        let serial = self.serial.as_ref()?;
        Some(
            serial
                .passes
                .iter()
                .find(|(n, _)| n == label)
                .map_or(0.0, |(_, ms)| *ms),
        )
    }

    /// Serial timing: drains the work recorded before the pass, so it is not counted in it, and
    /// starts the pass's clock.
    fn begin_serial(&mut self) -> Option<std::time::Instant> {
        self.serial.as_ref()?;
        let drained = self.submit_and_wait();
        self.note_serial_error(drained);
        Some(std::time::Instant::now())
    }

    /// Serial timing: submits the pass alone, waits for it, and adds its wall time.
    fn end_serial(&mut self, label: &str, start: Option<std::time::Instant>) {
        let Some(start) = start else { return };
        let waited = self.submit_and_wait();
        let ms = start.elapsed().as_secs_f64() * 1e3;
        self.note_serial_error(waited);
        if let Some(serial) = &mut self.serial {
            match serial.passes.iter_mut().find(|(n, _)| n == label) {
                Some((_, t)) => *t += ms,
                None => serial.passes.push((label.to_string(), ms)),
            }
        }
    }

    fn note_serial_error(&mut self, result: Result<(), crate::GpuError>) {
        if let (Err(e), Some(serial)) = (result, &mut self.serial) {
            serial.error.get_or_insert(e);
        }
    }

    /// Records a timed render pass named `label` (e.g. `pcss/filter`).
    pub fn render_pass(
        &mut self,
        label: &str,
        desc: wgpu::RenderPassDescriptor<'_>,
        record: impl FnOnce(&mut wgpu::RenderPass<'_>),
    ) {
        puffin::profile_scope!("record_pass", label);
        if let Some(start) = self.begin_serial() {
            {
                let mut pass = self.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(label),
                    timestamp_writes: None,
                    ..desc
                });
                record(&mut pass);
            }
            self.end_serial(label, Some(start));
        } else {
            let query = self.profiler.begin_pass_query(label, self.encoder);
            {
                let mut pass = self.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(label),
                    timestamp_writes: query.render_pass_timestamp_writes(),
                    ..desc
                });
                record(&mut pass);
            }
            self.profiler.end_query(self.encoder, query);
        }
        self.note_pass(label);
    }

    /// Records a timed compute pass named `label`.
    pub fn compute_pass(&mut self, label: &str, record: impl FnOnce(&mut wgpu::ComputePass<'_>)) {
        if let Some(start) = self.begin_serial() {
            {
                let mut pass = self
                    .encoder
                    .begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(label),
                        timestamp_writes: None,
                    });
                record(&mut pass);
            }
            self.end_serial(label, Some(start));
        } else {
            let query = self.profiler.begin_pass_query(label, self.encoder);
            {
                let mut pass = self
                    .encoder
                    .begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some(label),
                        timestamp_writes: query.compute_pass_timestamp_writes(),
                    });
                record(&mut pass);
            }
            self.profiler.end_query(self.encoder, query);
        }
        self.note_pass(label);
    }

    /// Submits everything recorded so far and waits until the GPU has finished it; recording
    /// goes on in a fresh encoder. For techniques whose next passes depend on GPU answers read
    /// back mid-frame (occlusion query counts, say): every call is a CPU-GPU round trip, so call
    /// it as rarely as the algorithm allows.
    pub fn submit_and_wait(&mut self) -> Result<(), crate::GpuError> {
        let fresh = self
            .gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame (after a mid-frame submission)"),
            });
        let recorded = std::mem::replace(&mut *self.encoder, fresh);
        self.gpu.queue.submit([recorded.finish()]);
        self.gpu.wait_idle()
    }

    /// Starts timing work the CPU does inside the frame (a read-back and what is computed from
    /// it, a precompute such as the PDSM's): with serial timing it first drains the GPU work
    /// recorded so far. End it with [`Frame::end_cpu_pass`].
    pub fn begin_cpu_pass(&mut self) -> std::time::Instant {
        let _ = self.begin_serial();
        std::time::Instant::now()
    }

    /// Ends a CPU pass begun with [`Frame::begin_cpu_pass`] and records it as the pass `label`
    /// with its wall time, in both timing modes (a CPU stage has no GPU time to query; leaving it
    /// out would hide it from the frame's pass times).
    pub fn end_cpu_pass(&mut self, label: &str, start: std::time::Instant) {
        if self.serial.is_some() {
            self.end_serial(label, Some(start));
        } else {
            let ms = start.elapsed().as_secs_f64() * 1e3;
            match self.cpu_passes.iter_mut().find(|(n, _)| n == label) {
                Some((_, t)) => *t += ms,
                None => self.cpu_passes.push((label.to_string(), ms)),
            }
        }
        self.note_pass(label);
    }

    /// The CPU passes of a frame timed with timestamps (with serial timing they are among the
    /// serial times).
    pub fn take_cpu_passes(&mut self) -> Vec<(String, f64)> {
        std::mem::take(&mut self.cpu_passes)
    }

    /// Records a pass name for work that is not a render or compute pass (a texture copy).
    pub fn note_pass(&mut self, label: &str) {
        self.memory_peak = self.memory_peak.max_by_total(self.gpu.memory_in_use());
        if !self.passes_run.iter().any(|p| p == label) {
            self.passes_run.push(label.to_string());
        }
    }

    /// Names of the passes recorded so far, in first-run order.
    pub fn passes_run(&self) -> &[String] {
        self.passes_run
    }
}
