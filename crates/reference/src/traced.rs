//! The ray-traced exact answer: the CPU ray cast's estimate ([`crate::raycast`]) computed on the
//! device with ray queries (`Features::EXPERIMENTAL_RAY_QUERY`), so it affords more samples.
//!
//! **What it computes.** For each receiver point, the fraction of `N x N` stratified, jittered
//! points of the light (each kind's shape, sampled by core's `sample_light` in
//! `shaders/common/light.wgsl`, the twin of the ray cast's `AreaLight::sample`) for which the open segment from the point meets no caster triangle (the
//! same segment epsilons as the CPU ray cast). Per sample it is exact on any triangle mesh: no
//! depth map, no bias; its only error is the sampling error of `N x N` strata (`O(1/N)` at a
//! penumbra point, see [`crate::raycast`]). Points behind the light are 0, points that see no
//! receiver 1.
//!
//! **Cost.** One dispatch per row of light samples (`N` dispatches of `N` rays per point), each
//! a segment test with terminate-on-first-hit; lavapipe traces about 0.5-1 M rays/s on 2 cores
//! (docs/TECHNIQUES.md, `raytraced`), so `64²` points at `32 x 32` samples take a few seconds.

use encase::ShaderType;
use softshadow_core::{
    accel::AccelError,
    frame::FrameUniforms,
    glam::Vec3,
    readback::read_buffer,
    shader::{self, ShaderSpec},
    shader_file,
    uniform::uniform_bytes,
    wgpu, Camera, Gpu, GpuError, Scene, SceneAccel, SceneGpu,
};
use thiserror::Error;
use wgpu::util::DeviceExt;

/// The compute shader.
pub const SHADER: ShaderSpec = ShaderSpec {
    path: "reference/trace.wgsl",
    source: shader_file!("reference/trace.wgsl").1,
    permutations: &[&[], ALPHA_TEST],
};

/// The alpha-tested permutation (a scene with masked casters): the material group is group 1.
const ALPHA_TEST: softshadow_core::shader::Permutation = softshadow_core::ray_alpha_test_defs!(1);

/// Jitter seed of [`visibility_image`].
pub const IMAGE_SEED: u32 = 1;

/// The ray-traced exact answer could not be computed.
#[derive(Debug, Error)]
pub enum TracedError {
    /// No ray queries on the device, or the scene's casters exceed its limits.
    #[error(transparent)]
    Accel(#[from] AccelError),
    /// A GPU problem.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// Bad input.
    #[error("{0}")]
    Input(String),
}

#[derive(ShaderType)]
struct Params {
    samples_per_axis: u32,
    row: u32,
    count: u32,
    seed: u32,
}

/// The ray-traced answer's uniform against its WGSL struct (tests/shaders.rs).
pub(crate) fn uniform_mirrors() -> Vec<softshadow_core::shader::uniform_layout::UniformMirror> {
    vec![softshadow_core::uniform_mirror!(
        Params {
            samples_per_axis, row, count, seed
        } => "reference/trace.wgsl", TraceParams
    )]
}

/// The visible fraction of the light at every point of `positions` (`None` or not a receiver:
/// 1.0), from `samples_per_axis`² stratified, jittered light samples traced on `gpu` (see the
/// [module docs](self)).
pub fn visibility_image(
    gpu: &Gpu,
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver: &[bool],
    samples_per_axis: u32,
) -> Result<Vec<f32>, TracedError> {
    Ok(visibility_image_and_error(gpu, scene, positions, receiver, samples_per_axis)?.0)
}

/// [`visibility_image`] and each pixel's standard-error estimate from the same samples (collapsed
/// strata, as [`crate::raycast::visibility_and_error`]; 0 where the pixel is not a receiver or
/// every pair of samples agrees, `NaN` at receivers with one sample per axis).
pub fn visibility_image_and_error(
    gpu: &Gpu,
    scene: &Scene,
    positions: &[Option<Vec3>],
    receiver: &[bool],
    samples_per_axis: u32,
) -> Result<(Vec<f32>, Vec<f32>), TracedError> {
    check_inputs(positions, receiver, samples_per_axis)?;
    let count = positions.len();
    if count == 0 {
        return Ok((Vec::new(), Vec::new()));
    }
    let points = trace_points(positions, receiver);
    let device = &gpu.device;
    let scene_gpu = SceneGpu::upload(gpu, scene);
    if !scene_gpu.has_casters() {
        return Ok(without_casters(scene, &points));
    }
    let mut accel = SceneAccel::new();
    let mut encoder = device.create_command_encoder(&Default::default());
    accel.build(gpu, &mut encoder, &scene_gpu)?;
    gpu.queue.submit([encoder.finish()]);

    // Masked casters: the candidate loop tests alpha (group 1, the material triangles).
    let masked = scene_gpu.materials.as_ref().filter(|m| m.masked_casters);
    let material_group = masked.map(|m| m.triangles_group(gpu, &scene_gpu));
    let (layout, pipeline) = trace_pipeline(gpu, masked.is_some())?;
    let points_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("reference/trace points"),
        contents: bytemuck::cast_slice(&points),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let lit_buffer = zeroed_counts(device, "reference/trace lit", count);
    let disagree_buffer = zeroed_counts(device, "reference/trace disagree", count);
    // The light's shape as every pass reads it (`FrameUniforms`; only its light fields count).
    let light_uniforms = FrameUniforms::new(&Camera::default(), &scene.light, 1, 1);
    let light_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("reference/trace light"),
        contents: &uniform_bytes(&light_uniforms),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    // One uniform buffer per row: rows are dispatched in one submission.
    let groups = (count as u32).div_ceil(64);
    let (gx, gy) = (groups.min(65535), groups.div_ceil(65535));
    let tlas = accel.tlas().expect("built above");
    for row in 0..samples_per_axis {
        let params = Params {
            samples_per_axis,
            row,
            count: count as u32,
            seed: IMAGE_SEED,
        };
        let buffers = [&points_buffer, &lit_buffer, &disagree_buffer, &light_buffer];
        let pass = TracePass {
            layout: &layout,
            pipeline: &pipeline,
            tlas,
            buffers,
            material_group: material_group.as_ref(),
        };
        pass.dispatch_row(gpu, &params, (gx, gy));
    }
    let counts = [&lit_buffer, &disagree_buffer];
    read_visibility_and_error(gpu, &points, counts, samples_per_axis)
}

/// One row of the trace: what every row's dispatch binds besides its own parameters.
struct TracePass<'a> {
    layout: &'a wgpu::BindGroupLayout,
    pipeline: &'a wgpu::ComputePipeline,
    tlas: &'a wgpu::Tlas,
    /// Points, lit counts, disagreement counts and the light, at bindings 2, 3, 4 and 5.
    buffers: [&'a wgpu::Buffer; 4],
    material_group: Option<&'a wgpu::BindGroup>,
}

impl TracePass<'_> {
    /// Bind `params` (binding 0) beside the shared resources and submit one row's dispatch.
    fn dispatch_row(&self, gpu: &Gpu, params: &Params, (gx, gy): (u32, u32)) {
        let device = &gpu.device;
        let params_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("reference/trace params"),
            contents: &uniform_bytes(params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let [points, lit, disagree, light] = self.buffers;
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("reference/trace"),
            layout: self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: params_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.tlas.as_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: points.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: lit.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: disagree.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: light.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(self.pipeline);
            pass.set_bind_group(0, &group, &[]);
            if let Some(material_group) = self.material_group {
                pass.set_bind_group(1, material_group, &[]);
            }
            pass.dispatch_workgroups(gx, gy, 1);
        }
        gpu.queue.submit([encoder.finish()]);
    }
}

/// One position and one receiver flag per pixel, and at least one sample per axis.
fn check_inputs(
    positions: &[Option<Vec3>],
    receiver: &[bool],
    samples_per_axis: u32,
) -> Result<(), TracedError> {
    if positions.len() != receiver.len() {
        return Err(TracedError::Input(format!(
            "{} positions but {} receiver flags: give one of each per pixel",
            positions.len(),
            receiver.len()
        )));
    }
    if samples_per_axis == 0 {
        return Err(TracedError::Input(
            "samples_per_axis is 0: give at least 1".into(),
        ));
    }
    Ok(())
}

/// The points the shader traces from: `[x, y, z, 1]` at a finite receiver position, zeros (not
/// traced) elsewhere.
fn trace_points(positions: &[Option<Vec3>], receiver: &[bool]) -> Vec<[f32; 4]> {
    positions
        .iter()
        .zip(receiver)
        .map(|(p, &r)| match p {
            Some(p) if r && p.is_finite() => [p.x, p.y, p.z, 1.0],
            _ => [0.0; 4],
        })
        .collect()
}

/// The answer of a scene without casters: every traced point lit unless behind the light, with
/// no sampling error.
fn without_casters(scene: &Scene, points: &[[f32; 4]]) -> (Vec<f32>, Vec<f32>) {
    let lit: Vec<f32> = points
        .iter()
        .map(|p| {
            let lit = p[3] < 0.5 || scene.light.reaches(Vec3::new(p[0], p[1], p[2]));
            if lit {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    let errors = vec![0.0; lit.len()];
    (lit, errors)
}

/// The trace pass's bind group layout (the row's parameters, the casters' acceleration
/// structure, the points, the lit and disagreeing sample counts) and its compute pipeline.
fn trace_pipeline(
    gpu: &Gpu,
    masked: bool,
) -> Result<(wgpu::BindGroupLayout, wgpu::ComputePipeline), TracedError> {
    let device = &gpu.device;
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("reference/trace"),
        entries: &[
            softshadow_core::frame::uniform_entry(0, wgpu::ShaderStages::COMPUTE, false),
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::AccelerationStructure {
                    vertex_return: false,
                },
                count: None,
            },
            storage_entry(2, true),
            storage_entry(3, false),
            storage_entry(4, false),
            softshadow_core::frame::uniform_entry(5, wgpu::ShaderStages::COMPUTE, false),
        ],
    });
    let defs: &[_] = if masked { ALPHA_TEST } else { &[] };
    let module = shader::create_module(gpu, &SHADER, defs)?;
    let material =
        masked.then(|| softshadow_core::material_gpu::MaterialGpu::triangles_layout_of(gpu));
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("reference/trace"),
        bind_group_layouts: &[Some(&layout), material.as_ref()],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("reference/trace"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("trace"),
        compilation_options: Default::default(),
        cache: None,
    });
    Ok((layout, pipeline))
}

/// A storage buffer of `count` zeros (f32) the trace pass adds sample counts to, read back after.
fn zeroed_counts(device: &wgpu::Device, label: &str, count: usize) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::cast_slice(&vec![0f32; count]),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    })
}

/// Reads the lit and disagreeing sample counts back (`counts`) and turns them into each point's
/// visible fraction and standard-error estimate (1 and 0 where nothing was traced).
fn read_visibility_and_error(
    gpu: &Gpu,
    points: &[[f32; 4]],
    [lit_buffer, disagree_buffer]: [&wgpu::Buffer; 2],
    samples_per_axis: u32,
) -> Result<(Vec<f32>, Vec<f32>), TracedError> {
    let count = points.len();
    let bytes = read_buffer(gpu, lit_buffer, 0, (count * 4) as u64)?;
    let lit: &[f32] = bytemuck::cast_slice(&bytes);
    let bytes = read_buffer(gpu, disagree_buffer, 0, (count * 4) as u64)?;
    let disagree: &[f32] = bytemuck::cast_slice(&bytes);
    let total = (samples_per_axis * samples_per_axis) as f32;
    Ok(points
        .iter()
        .zip(lit.iter().zip(disagree))
        .map(|(p, (&l, &d))| {
            if p[3] < 0.5 {
                (1.0, 0.0)
            } else {
                (
                    l / total,
                    crate::raycast::collapsed_strata_error(d as f64, samples_per_axis) as f32,
                )
            }
        })
        .unzip())
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}
