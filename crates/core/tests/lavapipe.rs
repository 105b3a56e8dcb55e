//! Probes of the device limits that docs/DEVICES.md's lavapipe sections work around, so a
//! driver change shows up as a test result rather than as a silently wrong image.
//!
//! - `loops_end_at_the_budget_only_on_lavapipe_before_24_1`: llvmpipe's 65535-iteration loop
//!   budget ("Lavapipe's loop budget"); asserted.
//! - `branch_costs` (ignored, a measurement): what a branch no pixel takes, and `discard`, cost
//!   ("Lavapipe's branches"). `cargo test --workspace --test lavapipe -- --ignored
//!   --nocapture` prints the table quoted there.

use std::time::Instant;

use anyhow::{ensure, Context, Result};
use softshadow_core::{readback, wgpu, Gpu};

fn gpu() -> Result<Gpu> {
    Gpu::new_headless().context(
        "these tests need a GPU adapter: install Mesa's lavapipe (apt-get install -y mesa-vulkan-drivers)",
    )
}

fn is_llvmpipe(gpu: &Gpu) -> bool {
    gpu.summary().name.contains("llvmpipe")
}

/// Runs two loops one after the other in each of 4 invocations, of `a + lane` and `b`
/// iterations, and returns how many iterations each ran, per lane.
fn run_two_loops(gpu: &Gpu, a: u32, b: u32) -> Result<Vec<[u32; 2]>> {
    // Four lanes with counts that differ per lane (a + lane), as a pixel's loop count does: a
    // count the compiler can prove uniform may be compiled to a plain scalar loop.
    let source = "
        @group(0) @binding(0) var<storage, read_write> out: array<u32, 8>;
        @group(0) @binding(1) var<uniform> count: vec2<u32>;
        @compute @workgroup_size(4)
        fn main(@builtin(local_invocation_index) lane: u32) {
            var n = 0u;
            loop { if n >= count.x + lane { break; } n += 1u; }
            var m = 0u;
            loop { if m >= count.y { break; } m += 1u; }
            out[2u * lane] = n;
            out[2u * lane + 1u] = m;
        }";
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("probe/loops"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("probe/loops"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe/out"),
        size: 32,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let count = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe/count"),
        size: 8,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&count, 0, &bytemuck_pair(a, b));
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probe/loops"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: out.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: count.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    let bytes = readback::read_buffer(gpu, &out, 0, 32)?;
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
        .collect();
    Ok(words.chunks_exact(2).map(|p| [p[0], p[1]]).collect())
}

fn bytemuck_pair(a: u32, b: u32) -> Vec<u8> {
    [a, b].iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn mesa_versions_are_read_from_the_driver_string() {
    let summary = |driver: &str| softshadow_core::gpu::AdapterSummary {
        name: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
        backend: "vulkan".into(),
        driver: driver.into(),
    };
    assert_eq!(
        summary("llvmpipe Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)").mesa_version(),
        Some((25, 0))
    );
    assert_eq!(
        summary("llvmpipe Mesa 22.3.6 (LLVM 15.0.6)").mesa_version(),
        Some((22, 3))
    );
    assert_eq!(summary("NVIDIA 550.54.14").mesa_version(), None);
}

/// Lavapipe before Mesa 24.1 ends the loops of a block of invocations once their iterations
/// together reach about 65535, silently (measured on 22.3.6; 25.0.7 runs every iteration):
/// docs/DEVICES.md, "Lavapipe's loop budget". Any other adapter runs every iteration.
#[test]
fn loops_end_at_the_budget_only_on_lavapipe_before_24_1() -> Result<()> {
    let gpu = gpu()?;
    let adapter = gpu.summary();
    let budget_applies = is_llvmpipe(&gpu) && adapter.mesa_version().is_some_and(|v| v < (24, 1));
    let cases = [
        (60_000, 0),
        (65_534, 0),
        (70_000, 0),
        (40_000, 40_000),
        (200_000, 0),
    ];
    let mut report = Vec::new();
    let mut cut = false;
    for (a, b) in cases {
        let ran = run_two_loops(&gpu, a, b)?;
        report.push(format!("({a}, {b}): {ran:?}"));
        for (lane, [n, m]) in ran.iter().copied().enumerate() {
            let asked = [a + lane as u32, b];
            if budget_applies {
                ensure!(
                    n <= asked[0] && m <= asked[1] && n + m <= 65_535,
                    "{}: lane {lane} of ({a}, {b}) ran {n} + {m} iterations, over the budget",
                    adapter.driver
                );
                cut |= [n, m] != asked;
            } else {
                ensure!(
                    [n, m] == asked,
                    "{}: lane {lane} of ({a}, {b}) ran {n} + {m} iterations instead of {asked:?}: \
                     cut loops; see docs/DEVICES.md, \"Lavapipe's loop budget\"",
                    adapter.driver
                );
            }
        }
    }
    eprintln!("{}: {}", adapter.driver, report.join("; "));
    ensure!(
        !budget_applies || cut,
        "{}: no loop was cut at 65535 iterations; docs/DEVICES.md (\"Lavapipe's loop \
         budget\") says this driver cuts them: {report:?}",
        adapter.driver
    );
    Ok(())
}

/// `COUNT` straight-line statements of transcendental arithmetic (no loop: a loop's body would
/// run once per masked-off block, which is a different cost).
fn expensive(count: usize) -> String {
    (0..count)
        .map(|k| format!("x = sin(x * 1.{k:03}) + cos(x * 0.{k:03});\n"))
        .collect()
}

/// Median wall time in ms of a fullscreen draw into a 512² `R32Float` target (submitted and
/// waited for on its own) of fragment body `body`, with the uniform `flag`.
fn time_draw(gpu: &Gpu, body: &str, flag: u32) -> Result<f64> {
    const SIZE: u32 = 512;
    let source = format!(
        "
        @group(0) @binding(0) var<uniform> flag: vec4<u32>;
        @vertex
        fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {{
            let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
            return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
        }}
        @fragment
        fn fs(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {{
            var x = position.x * 0.001 + position.y;
            {body}
            return vec4<f32>(x, 0.0, 0.0, 1.0);
        }}"
    );
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("probe/branch"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let format = wgpu::TextureFormat::R32Float;
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("probe/branch"),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        multiview_mask: None,
        cache: None,
    });
    let target = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("probe/target"),
        size: wgpu::Extent3d {
            width: SIZE,
            height: SIZE,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        view_formats: &[],
    });
    let view = target.create_view(&Default::default());
    let uniform = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe/flag"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(
        &uniform,
        0,
        &[flag.to_le_bytes(), [0; 4], [0; 4], [0; 4]].concat(),
    );
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("probe/branch"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: uniform.as_entire_binding(),
        }],
    });
    let mut times = Vec::new();
    // The first two draws compile the shader (lavapipe compiles on first use).
    for k in 0..9 {
        let start = Instant::now();
        let mut encoder = device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("probe/branch"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.draw(0..3, 0..1);
        }
        gpu.queue.submit([encoder.finish()]);
        gpu.device
            .poll(wgpu::PollType::wait_indefinitely())
            .context("waiting for the draw")?;
        if k >= 2 {
            times.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// What a 512² fullscreen draw costs with 256 statements of arithmetic: absent, behind a branch
/// no pixel takes (a uniform flag of 0), after a `discard` that every pixel takes, and taken.
#[test]
#[ignore = "a measurement: prints the costs quoted in docs/DEVICES.md"]
fn branch_costs() -> Result<()> {
    let gpu = gpu()?;
    let work = expensive(256);
    let variants = [
        ("no work", String::new(), 0),
        (
            "work behind a uniform branch no pixel takes",
            format!("if flag.x != 0u {{ {work} }}"),
            0,
        ),
        (
            "work behind a per-pixel branch no pixel takes",
            format!("if position.x < f32(flag.x) {{ {work} }}"),
            0,
        ),
        (
            "work after a discard every pixel takes",
            format!("if flag.x == 0u {{ discard; }} {work}"),
            0,
        ),
        (
            "work behind a branch every pixel takes",
            format!("if flag.x != 0u {{ {work} }}"),
            1,
        ),
    ];
    println!("{}:", gpu.summary().driver);
    for (name, body, flag) in variants {
        println!("{name}: {:.2} ms", time_draw(&gpu, &body, flag)?);
    }
    Ok(())
}
