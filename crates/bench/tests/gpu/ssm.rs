//! Soft shadow maps (Atty et al. 2006) against the closed form and the accumulated reference, with
//! the bounds stated in docs/TECHNIQUES.md: the square of section 4.2, two-pass against one-pass
//! on a thick occluder (section 3.5), the FP16 blending failure of appendix A and its batched fix,
//! and the extremes of the backprojection (occluder touching the receiver or the light, a point
//! light, occluders partly outside the light's reach). Small images keep this fast on lavapipe.

use crate::common::{closed_form, gpu, mae_shadowed, run_checked};
use anyhow::{ensure, Context, Result};
use softshadow::ssm::{Precision, Ssm, SsmSettings};
use softshadow_bench::{parse_params, results::Run, Bench, BenchOptions, RunSpec};
use softshadow_core::{Gpu, ParamValue, Renderer, SceneGpu, ShadowTechnique, TechniqueStats};
use softshadow_metrics::ErrorReport;
use softshadow_scenes::AttySquare;

/// Renders `atty-square` (with `params`) with `settings` at `size`² and compares it with the
/// closed form (`reference::exact`) over the receiver pixels.
fn against_closed_form(
    gpu: &Gpu,
    params: AttySquare,
    settings: SsmSettings,
    size: u32,
) -> Result<(ErrorReport, TechniqueStats)> {
    let scene = params.scene()?;
    let scene_gpu = SceneGpu::upload(gpu, &scene);
    let mut renderer = Renderer::new(gpu, size, size)?;
    let mut ssm = Ssm::new(gpu, settings)?;
    renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut ssm, None)?;
    let v = renderer.read_visibility()?;
    let mask = renderer.read_receiver_mask()?;
    let positions = renderer.read_world_positions()?;
    let exact = closed_form(&scene, &positions, &mask)?;
    let stability = softshadow_metrics::stability(&v);
    ensure!(
        stability.nan == 0 && stability.inf == 0 && stability.out_of_range == 0,
        "{stability:?}"
    );
    Ok((softshadow_metrics::compare(&v, &exact, &mask)?, ssm.stats()))
}

#[test]
fn the_square_parallel_to_the_light_matches_the_closed_form() -> Result<()> {
    let gpu = gpu()?;
    let (report, stats) =
        against_closed_form(&gpu, AttySquare::default(), SsmSettings::default(), 128)?;
    eprintln!("atty-square ssm vs exact: {report:?}\nstats {stats:?}");
    ensure!(report.shadowed_pixels > 1000, "{report:?}");
    // Section 4.1: for a planar occluder parallel to the light the micro-patches' backprojections
    // tile exactly, so only the discretisation remains: the square's outline snapped to the
    // 128² occluder map (half a texel, i.e. about 1 % of the penumbra width, worst case along
    // edges aligned with the map, section 4.1.1) and the 128² soft shadow map's bilinear
    // reconstruction at the penumbra's kinks.
    ensure!(
        report.mae_shadowed < 0.008,
        "mae_shadowed {}",
        report.mae_shadowed
    );
    ensure!(report.max_abs < 0.03, "max_abs {}", report.max_abs);

    // The counters are real counts: the square covers (1 / 1.02)² of the fitted 128² map, and
    // every micro-patch blends into the soft-shadow-map texels of its penumbra.
    let patches = stats["micro_patches_drawn"];
    let expected = 128.0 * 128.0 / (1.02f64 * 1.02);
    ensure!(
        (patches - expected).abs() < 0.03 * expected,
        "micro_patches_drawn {patches}, expected about {expected}"
    );
    ensure!(stats["ssm_texels_touched"] > 100.0 * patches, "{stats:?}");
    ensure!(stats["ssm_texels_shadowed"] > 1000.0, "{stats:?}");
    Ok(())
}

/// Appendix A: with a 512² occluder map each micro-patch hides about 1.6e-5 of the light, far
/// below 2^-10 of a running sum near 1, so FP16 blending drops contributions once the sum has
/// grown (equation 4 is violated); FP32 keeps them, and FP16 in floor(sqrt(M)) batches summed in
/// FP32 recovers most of the difference.
#[test]
fn fp16_blending_fails_at_512_and_batching_fixes_it() -> Result<()> {
    let gpu = gpu()?;
    let mut errors = Vec::new();
    for precision in [Precision::Fp32, Precision::Fp16, Precision::Fp16Batched] {
        let settings = SsmSettings {
            occluder_map_size: 512,
            precision,
            ssm_size: 64,
            ..SsmSettings::default()
        };
        let (report, _) = against_closed_form(&gpu, AttySquare::default(), settings, 64)?;
        eprintln!("{}: {report:?}", precision.name());
        errors.push(report.mae_shadowed);
    }
    let (fp32, fp16, batched) = (errors[0], errors[1], errors[2]);
    eprintln!("mae_shadowed at 512²: fp32 {fp32:.4}, fp16 {fp16:.4}, fp16-batched {batched:.4}");
    ensure!(fp32 < 0.005, "fp32 {fp32}");
    ensure!(
        fp16 > fp32 + 0.05,
        "fp16 ({fp16}) should be measurably worse than fp32 ({fp32})"
    );
    ensure!(
        batched - fp32 < 0.1 * (fp16 - fp32),
        "fp16-batched ({batched}) should remove most of the fp16 error ({fp16} vs fp32 {fp32})"
    );
    Ok(())
}

fn bench() -> Result<Bench> {
    Ok(Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames: 1,
            warmup: 0,
            error: true,
            reference_params: vec![
                ("samples_per_axis".into(), ParamValue::Int(16)),
                ("shadow_map_size".into(), ParamValue::Int(512)),
            ],
            images: false,
            // The closed form is used directly where it applies; skip the ray-cast truth.
            exact_samples_per_axis: None,
            camera_only: false,
            reference_cache: None,
            ..Default::default()
        },
    )?)
}

fn run(bench: &mut Bench, scene: &str, params: &[&str]) -> Result<Run> {
    let texts: Vec<String> = params.iter().map(|s| s.to_string()).collect();
    let spec = RunSpec {
        scene: scene.into(),
        technique: "ssm".into(),
        params: parse_params(&softshadow::registry(), "ssm", &texts)?,
        width: 96,
        height: 96,
        path: None,
    };
    run_checked(bench, &spec)
}

/// Section 3.5: the second occluder map (farthest surfaces) adds the occlusion of the parts of a
/// thick occluder that the light centre does not see; merged by maximum it never lowers the
/// occlusion, and on the blob it brings the shadow closer to the reference.
#[test]
fn two_pass_is_no_worse_than_one_pass_on_a_thick_occluder() -> Result<()> {
    let mut bench = bench()?;
    let scene = "blob-floating:triangles=20000";
    let one = run(&mut bench, scene, &[])?;
    let two = run(&mut bench, scene, &["two_pass=true"])?;
    let (e1, e2) = (mae_shadowed(&one), mae_shadowed(&two));
    eprintln!(
        "blob-floating mae_shadowed: one pass {e1:.4}, two passes {e2:.4}; stats {:?} / {:?}",
        one.stats, two.stats
    );
    ensure!(e2 <= e1, "two-pass {e2} > one-pass {e1}");
    ensure!(e1 < 0.12, "one-pass {e1}");
    ensure!(
        two.passes_run.iter().any(|p| p == "ssm/occluder_map_back"),
        "{:?}",
        two.passes_run
    );
    ensure!(
        two.stats["micro_patches_drawn"] > 1.9 * one.stats["micro_patches_drawn"],
        "two maps, about twice the patches: {:?} / {:?}",
        one.stats,
        two.stats
    );
    Ok(())
}

/// The denominators of the backprojection (z_R - z_O, z_O) and the degenerate light: finite
/// output in [0, 1], no validation error, no device loss, in every precision and pass mode.
#[test]
fn extremes_give_finite_visibility_in_range() -> Result<()> {
    let mut bench = Bench::new(
        gpu()?,
        softshadow::registry(),
        BenchOptions {
            frames: 1,
            warmup: 0,
            error: false,
            reference_params: Vec::new(),
            images: false,
            exact_samples_per_axis: None,
            camera_only: false,
            reference_cache: None,
            ..Default::default()
        },
    )?;
    let dir = tempfile::tempdir()?;
    // A box crossing the light plane: part of the occluder is behind the light and leaves the
    // occluder map's view.
    let crossing = dir.path().join("crossing.toml");
    std::fs::write(
        &crossing,
        "name = \"crossing\"\n[light]\ncenter = [0, 2, 0]\ndirection = [0, -1, 0]\nwidth = 1\n\
         [camera]\neye = [0, 3, 4]\ntarget = [0, 0, 0]\n\
         [[object]]\nplane = { size = [8, 8] }\ncasts_shadow = false\n\
         [[object]]\nbox = { size = [0.6, 1.0, 0.6] }\ntranslation = [0.3, 2.0, 0]\nreceives_shadow = false\n",
    )?;
    let crossing = crossing.display().to_string();
    let scenes = [
        // Occluder on the receiver: z_R - z_O = 0.
        "atty-square:occluder_height=0",
        // Occluder almost touching the receiver and almost touching the light (z_O -> 0).
        "atty-square:occluder_height=0.0001",
        "atty-square:occluder_height=1.9999",
        // Point light.
        "atty-square:light_width=0",
        // Occluder far to the side, larger than the receiver.
        "atty-square:occluder_offset_x=3,occluder_size=8",
        "blob-contact:triangles=2000",
        &crossing,
    ];
    for scene in scenes {
        for params in [
            &[][..],
            &["two_pass=true", "precision=fp16"][..],
            &["precision=fp16-batched", "occluder_map_size=64"][..],
        ] {
            let texts: Vec<String> = params.iter().map(|s| s.to_string()).collect();
            let spec = RunSpec {
                scene: scene.into(),
                technique: "ssm".into(),
                params: parse_params(&softshadow::registry(), "ssm", &texts)?,
                width: 64,
                height: 64,
                path: None,
            };
            run_checked(&mut bench, &spec)?;
        }
    }
    Ok(())
}

/// A point light makes the soft shadow map a hard shadow of the discretised occluder: the umbra
/// is the square's shadow, and the closed form agrees except along its outline.
#[test]
fn a_point_light_gives_the_hard_shadow() -> Result<()> {
    let gpu = gpu()?;
    let params = AttySquare {
        light_width: 0.0,
        ..AttySquare::default()
    };
    let (report, _) = against_closed_form(&gpu, params, SsmSettings::default(), 96)?;
    eprintln!("point light: {report:?}");
    // Only pixels within a texel of the outline can differ (by 1).
    ensure!(report.mae_all < 0.01, "{report:?}");
    Ok(())
}

#[test]
fn parameters_are_checked_and_listed() -> Result<()> {
    let specs = softshadow::ssm::SsmSettings::param_specs();
    let names: Vec<&str> = specs.iter().map(|s| s.name.as_ref()).collect();
    for name in ["occluder_map_size", "two_pass", "precision"] {
        ensure!(names.contains(&name), "{names:?}");
    }
    ensure!(parse_params(
        &softshadow::registry(),
        "ssm",
        &["occluder_map_size=2048".into()]
    )
    .is_err());
    ensure!(parse_params(
        &softshadow::registry(),
        "ssm",
        &["occluder_map_size=32".into()]
    )
    .is_err());
    ensure!(parse_params(&softshadow::registry(), "ssm", &["precision=fp8".into()]).is_err());
    let gpu = gpu()?;
    let mut ssm = Ssm::new(&gpu, SsmSettings::default())?;
    ssm.set_param("precision", ParamValue::Choice("fp16-batched".into()))?;
    ssm.set_param("two_pass", ParamValue::Bool(true))?;
    ensure!(ssm.settings.precision == Precision::Fp16Batched && ssm.settings.two_pass);
    Ok(())
}

/// The text of `fn name` in `source`: from `fn name(` to the first closing brace at the start of
/// a line.
fn wgsl_function<'a>(source: &'a str, name: &str) -> Result<&'a str> {
    let start = source
        .find(&format!("\nfn {name}("))
        .with_context(|| format!("no `fn {name}` in the shader"))?;
    let end = source[start..]
        .find("\n}")
        .with_context(|| format!("`fn {name}` has no closing brace"))?;
    Ok(&source[start..start + end + 2])
}

/// The scatter shader's maths is the CPU's (`softshadow::ssm::math`): its `occluded_fraction`,
/// `axis_coverage` and `penumbra_slopes`, cut out of `crates/ssm/shaders/ssm/scatter.wgsl` as
/// they are and run in a compute shader over a grid of patches, receivers and lights (point and
/// line lights, contact, patches behind the receiver), equal the CPU functions the unit tests in
/// `crates/ssm/src/math.rs` pin down, to float rounding; and the shader's `CONTACT_EPSILON` is
/// the CPU's.
#[test]
fn the_scatter_shader_functions_equal_their_cpu_mirrors() -> Result<()> {
    use softshadow::ssm::math::{occluded_fraction, penumbra_slopes, SlopeRect, CONTACT_EPSILON};
    use softshadow_core::{
        glam::{Vec2, Vec4},
        readback::read_r32f,
        wgpu::{self, util::DeviceExt},
    };

    let source = softshadow::ssm::SHADERS
        .iter()
        .find(|s| s.path == "ssm/scatter.wgsl")
        .context("ssm/scatter.wgsl is declared")?
        .source;
    let epsilon_line = format!("const CONTACT_EPSILON: f32 = {CONTACT_EPSILON:e};");
    ensure!(
        source.contains(&epsilon_line),
        "the shader must hold `{epsilon_line}`"
    );
    let functions = ["axis_coverage", "occluded_fraction", "penumbra_slopes"]
        .iter()
        .map(|name| wgsl_function(source, name))
        .collect::<Result<Vec<_>>>()?
        .join("\n");
    let shader = format!(
        "{epsilon_line}\n{functions}\n\
         @group(0) @binding(0) var<storage, read> cases: array<vec4<f32>>;\n\
         @group(0) @binding(1) var out: texture_storage_2d<r32float, write>;\n\
         @compute @workgroup_size(64)\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
             let i = id.x;\n\
             if i >= arrayLength(&cases) / 3u {{ return; }}\n\
             let patch_rect = cases[3u * i];\n\
             let depths = cases[3u * i + 1u];\n\
             let light = cases[3u * i + 2u];\n\
             let f = occluded_fraction(patch_rect, depths.x, depths.zw, depths.y, light.xy);\n\
             let p = penumbra_slopes(patch_rect, depths.x, light.z, light.xy);\n\
             textureStore(out, vec2<i32>(i32(i), 0), vec4<f32>(f));\n\
             textureStore(out, vec2<i32>(i32(i), 1), vec4<f32>(p.x));\n\
             textureStore(out, vec2<i32>(i32(i), 2), vec4<f32>(p.y));\n\
             textureStore(out, vec2<i32>(i32(i), 3), vec4<f32>(p.z));\n\
             textureStore(out, vec2<i32>(i32(i), 4), vec4<f32>(p.w));\n\
         }}\n"
    );

    // Cases: a patch swept across the light's footprint at several depths, lights of every shape.
    let mut cases: Vec<(SlopeRect, f32, Vec2, f32, Vec2, f32)> = Vec::new();
    for half in [
        Vec2::new(0.5, 0.5),
        Vec2::new(1.0, 0.01),
        Vec2::new(0.3, 0.0),
        Vec2::ZERO,
    ] {
        for z_o in [0.001, 0.5, 1.0, 1.9999, 2.0, 2.5] {
            // Small patches swept across the light's footprint, and one large enough to hide
            // all of the light.
            for step in 0..9 {
                let s = -0.6 + 0.17 * step as f32;
                let patch = if step < 8 {
                    SlopeRect {
                        s0: s,
                        s1: s + 0.1,
                        t0: -0.05 + 0.02 * step as f32,
                        t1: 0.08,
                    }
                } else {
                    SlopeRect {
                        s0: -1.0,
                        s1: 1.0,
                        t0: -1.0,
                        t1: 1.0,
                    }
                };
                cases.push((patch, z_o, Vec2::new(0.05, -0.02), 2.0, half, 3.0));
            }
        }
    }
    let data: Vec<Vec4> = cases
        .iter()
        .flat_map(|(p, z_o, r, z_r, half, z_far)| {
            [
                Vec4::new(p.s0, p.s1, p.t0, p.t1),
                Vec4::new(*z_o, *z_r, r.x, r.y),
                Vec4::new(half.x, half.y, *z_far, 0.0),
            ]
        })
        .collect();

    let gpu = gpu()?;
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("ssm mirror test"),
        source: wgpu::ShaderSource::Wgsl(shader.into()),
    });
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("ssm mirror cases"),
        contents: softshadow_core::bytemuck::cast_slice(&data),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let output = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("ssm mirror results"),
        size: wgpu::Extent3d {
            width: cases.len() as u32,
            height: 5,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::R32Float,
        usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("ssm mirror test"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("ssm mirror test"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(
                    &output.create_view(&Default::default()),
                ),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((cases.len() as u32).div_ceil(64), 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let results = read_r32f(&gpu, &output)?;
    gpu.take_errors()?;

    let n = cases.len();
    let (mut outcomes, mut worst) = ([0usize; 3], 0.0f32);
    for (i, (patch, z_o, receiver, z_r, half, z_far)) in cases.iter().enumerate() {
        let cpu = occluded_fraction(*patch, *z_o, *receiver, *z_r, *half);
        let p = penumbra_slopes(*patch, *z_o, *z_far, *half);
        let gpu_values = [
            results[i],
            results[n + i],
            results[2 * n + i],
            results[3 * n + i],
            results[4 * n + i],
        ];
        for (what, c, g) in [
            ("occluded_fraction", cpu, gpu_values[0]),
            ("penumbra s0", p.s0, gpu_values[1]),
            ("penumbra s1", p.s1, gpu_values[2]),
            ("penumbra t0", p.t0, gpu_values[3]),
            ("penumbra t1", p.t1, gpu_values[4]),
        ] {
            let d = (c - g).abs();
            worst = worst.max(d / c.abs().max(1.0));
            ensure!(
                d <= 1e-5 * c.abs().max(1.0),
                "case {i} (patch {patch:?}, z_o {z_o}, light {half}): {what} CPU {c}, GPU {g}"
            );
        }
        outcomes[usize::from(cpu > 0.0) + usize::from(cpu >= 1.0)] += 1;
    }
    eprintln!(
        "{n} cases (nothing hidden, part, all: {outcomes:?}), worst relative difference {worst:e}"
    );
    // The cases must reach every outcome, or agreeing proves little (measured [172, 36, 8]).
    ensure!(
        outcomes.iter().all(|&count| count >= 8),
        "outcomes {outcomes:?}"
    );
    Ok(())
}
