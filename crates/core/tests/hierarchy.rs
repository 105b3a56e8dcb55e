//! The depth hierarchies built on the GPU against min/max computed on the CPU over a random depth
//! map (with empty texels and a size that is not a power of two, so padding and clamping count).

use anyhow::{ensure, Context, Result};
use softshadow_core::{
    hierarchy::{padded_size, top_level, DepthHierarchy, HierarchyKind, HIERARCHY_EMPTY},
    wgpu, Frame, Gpu,
};

/// splitmix64: a fixed, dependency-free random sequence.
struct Random(u64);

impl Random {
    fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A `padded`² level 0: random depths in [1, 5] over `map_size`², about 20 % empty, empty padding.
fn random_level0(map_size: u32, seed: u64) -> Vec<[f32; 2]> {
    let padded = padded_size(map_size);
    let mut random = Random(seed);
    let mut level0 = vec![[HIERARCHY_EMPTY; 2]; (padded * padded) as usize];
    for y in 0..map_size {
        for x in 0..map_size {
            let r = random.next_f32();
            if r > 0.2 {
                let z = 1.0 + 4.0 * random.next_f32();
                level0[(y * padded + x) as usize] = [z, z];
            }
        }
    }
    level0
}

fn range_over(level0: &[[f32; 2]], padded: u32, x: (i64, i64), y: (i64, i64)) -> [f32; 2] {
    let mut r = [f32::INFINITY, f32::NEG_INFINITY];
    let clamp = |v: i64| v.clamp(0, padded as i64 - 1) as u32;
    for yy in clamp(y.0)..=clamp(y.1) {
        for xx in clamp(x.0)..=clamp(x.1) {
            let t = level0[(yy * padded + xx) as usize];
            r = [r[0].min(t[0]), r[1].max(t[1])];
        }
    }
    r
}

/// HSM mip `level`: min/max over aligned blocks.
fn cpu_hsm(level0: &[[f32; 2]], padded: u32, level: u32) -> Vec<[f32; 2]> {
    let edge = (padded >> level).max(1);
    let block = 1i64 << level;
    let mut out = Vec::with_capacity((edge * edge) as usize);
    for y in 0..edge as i64 {
        for x in 0..edge as i64 {
            out.push(range_over(
                level0,
                padded,
                (x * block, x * block + block - 1),
                (y * block, y * block + block - 1),
            ));
        }
    }
    out
}

/// MSSM level `level`: min/max over the 2^level neighbourhood [x - 2^level / 2, x + 2^level / 2 - 1],
/// clamped to the map (bitmask paper section 5).
fn cpu_mssm(level0: &[[f32; 2]], padded: u32, level: u32) -> Vec<[f32; 2]> {
    let size = 1i64 << level;
    let mut out = Vec::with_capacity((padded * padded) as usize);
    for y in 0..padded as i64 {
        for x in 0..padded as i64 {
            let x0 = x - size / 2;
            let y0 = y - size / 2;
            out.push(range_over(
                level0,
                padded,
                (x0, x0 + size - 1),
                (y0, y0 + size - 1),
            ));
        }
    }
    out
}

/// Reads one mip / layer of an `Rg32Float` texture.
fn read_rg32(gpu: &Gpu, texture: &wgpu::Texture, mip: u32, layer: u32) -> Result<Vec<[f32; 2]>> {
    let edge = (texture.width() >> mip).max(1);
    let row = (edge * 8).div_ceil(256) * 256;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("test readback"),
        size: (row * edge) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: mip,
            origin: wgpu::Origin3d {
                x: 0,
                y: 0,
                z: layer,
            },
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(edge),
            },
        },
        wgpu::Extent3d {
            width: edge,
            height: edge,
            depth_or_array_layers: 1,
        },
    );
    gpu.queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    gpu.wait_idle()?;
    let data = slice.get_mapped_range().context("map readback")?;
    let mut out = Vec::with_capacity((edge * edge) as usize);
    for y in 0..edge {
        for x in 0..edge {
            let at = (y * row + x * 8) as usize;
            let f = |o: usize| f32::from_le_bytes(data[at + o..at + o + 4].try_into().unwrap());
            out.push([f(0), f(4)]);
        }
    }
    drop(data);
    buffer.unmap();
    Ok(out)
}

/// Writes level 0 and builds `levels` of `kind` in one submitted frame.
fn build(
    gpu: &Gpu,
    hierarchy: &mut DepthHierarchy,
    map_size: u32,
    level0: &[[f32; 2]],
    kind: HierarchyKind,
    levels: u32,
) -> Result<Vec<String>> {
    let padded = padded_size(map_size);
    let mut profiler =
        wgpu_profiler::GpuProfiler::new(&gpu.device, Default::default()).context("profiler")?;
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let mut passes = Vec::new();
    // Allocates the textures (a zero-level build), so that level 0 can be written.
    {
        let mut frame = Frame::new(gpu, &mut encoder, &profiler, &mut passes);
        hierarchy.build_levels(&mut frame, map_size, kind, 0, "test");
    }
    let hsm = hierarchy.hsm_texture().context("hsm allocated")?;
    let bytes: Vec<u8> = level0
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    gpu.queue.write_texture(
        hsm.as_image_copy(),
        &bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(padded * 8),
            rows_per_image: Some(padded),
        },
        wgpu::Extent3d {
            width: padded,
            height: padded,
            depth_or_array_layers: 1,
        },
    );
    {
        let mut frame = Frame::new(gpu, &mut encoder, &profiler, &mut passes);
        hierarchy.build_levels(&mut frame, map_size, kind, levels, "test");
    }
    profiler.resolve_queries(&mut encoder);
    gpu.queue.submit([encoder.finish()]);
    let _ = profiler.end_frame();
    gpu.wait_idle()?;
    gpu.take_errors()?;
    // The timing fences (one-texel dispatches around the level pass) are not levels.
    passes.retain(|p| !p.ends_with("/fence"));
    Ok(passes)
}

fn compare(what: &str, gpu: &[[f32; 2]], cpu: &[[f32; 2]]) -> Result<()> {
    ensure!(
        gpu.len() == cpu.len(),
        "{what}: {} vs {} texels",
        gpu.len(),
        cpu.len()
    );
    for (i, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        ensure!(
            g == c,
            "{what}: texel {i} is {g:?} on the GPU, {c:?} on the CPU"
        );
    }
    Ok(())
}

#[test]
fn hsm_levels_match_cpu_min_max() -> Result<()> {
    let gpu = Gpu::new_headless().context("hierarchy tests need a GPU adapter")?;
    let mut hierarchy = DepthHierarchy::new(&gpu)?;
    let map_size = 100; // padded to 128
    let padded = padded_size(map_size);
    let level0 = random_level0(map_size, 7);
    let levels = top_level(map_size);
    let passes = build(
        &gpu,
        &mut hierarchy,
        map_size,
        &level0,
        HierarchyKind::Hsm,
        levels,
    )?;
    ensure!(passes == ["test/hsm"], "passes {passes:?}");
    assert_eq!(hierarchy.built().levels, 7);
    let texture = hierarchy.hsm_texture().context("hsm")?;
    for level in 0..=levels {
        let gpu_level = read_rg32(&gpu, texture, level, 0)?;
        compare(
            &format!("hsm level {level}"),
            &gpu_level,
            &cpu_hsm(&level0, padded, level),
        )?;
    }
    // The top texel is the range of the whole map.
    let top = read_rg32(&gpu, texture, levels, 0)?[0];
    ensure!(
        top[0] >= 1.0 && top[0] < 1.1 && top[1] == HIERARCHY_EMPTY,
        "{top:?}"
    );
    Ok(())
}

#[test]
fn mssm_levels_match_cpu_min_max_over_centred_neighbourhoods() -> Result<()> {
    let gpu = Gpu::new_headless().context("hierarchy tests need a GPU adapter")?;
    let mut hierarchy = DepthHierarchy::new(&gpu)?;
    let map_size = 64;
    let level0 = random_level0(map_size, 11);
    // Only the levels asked for are built.
    let levels = 4;
    let passes = build(
        &gpu,
        &mut hierarchy,
        map_size,
        &level0,
        HierarchyKind::Mssm,
        levels,
    )?;
    ensure!(passes == ["test/mssm"], "passes {passes:?}");
    let texture = hierarchy.mssm_texture().context("mssm")?;
    ensure!(
        texture.depth_or_array_layers() == levels,
        "{} layers",
        texture.depth_or_array_layers()
    );
    for level in 1..=levels {
        let gpu_level = read_rg32(&gpu, texture, 0, level - 1)?;
        compare(
            &format!("mssm level {level}"),
            &gpu_level,
            &cpu_mssm(&level0, map_size, level),
        )?;
    }
    Ok(())
}

#[test]
fn a_zero_level_build_runs_no_level_pass() -> Result<()> {
    let gpu = Gpu::new_headless().context("hierarchy tests need a GPU adapter")?;
    let mut hierarchy = DepthHierarchy::new(&gpu)?;
    let level0 = random_level0(32, 3);
    let passes = build(&gpu, &mut hierarchy, 32, &level0, HierarchyKind::None, 0)?;
    ensure!(passes.is_empty(), "passes {passes:?}");
    assert_eq!(hierarchy.built().levels, 0);
    Ok(())
}
