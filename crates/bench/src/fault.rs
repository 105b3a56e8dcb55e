//! Faults injected into chosen runs of a benchmark, to test that a sweep survives them
//! (docs/STABILITY.md, "Faults"): `SOFTSHADOW_FAULT=KIND:K[,KIND:K...]`, with `K` the run's index
//! in the sweep (counted from 0) and `KIND` one of
//!
//! - `lost`: the device is destroyed in the middle of run K (after its technique and scene are
//!   on the device, before its first frame), so the rest of the run meets a lost device;
//! - `oom`: run K's first allocation is one no device holds (a texture array of 8 TiB), which
//!   fails with the driver's out-of-memory error;
//! - `hang`: run K submits a shader that never ends and waits for it (a GPU with a watchdog
//!   loses its device instead);
//! - `crash`: run K's process aborts (`SIGABRT`).
//!
//! Nothing here runs unless the variable is set.

use std::str::FromStr;

use softshadow_core::{wgpu, Gpu, GpuError};

use crate::BenchError;

/// The environment variable that injects faults.
pub const FAULT_ENV: &str = "SOFTSHADOW_FAULT";

/// What goes wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultKind {
    Lost,
    Oom,
    Hang,
    Crash,
}

/// The faults to inject, by run index.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Faults(Vec<(FaultKind, usize)>);

impl FromStr for Faults {
    type Err = BenchError;

    fn from_str(text: &str) -> Result<Self, BenchError> {
        let bad = |why: &str| {
            BenchError::Fault(format!(
                "{FAULT_ENV}=`{text}`: {why}; write KIND:K with KIND one of lost, oom, hang, crash and K a run index (e.g. lost:2), several joined by commas"
            ))
        };
        let mut faults = Vec::new();
        for item in text.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            let (kind, run) = item
                .split_once(':')
                .ok_or_else(|| bad(&format!("`{item}` has no `:`")))?;
            let kind = match kind.trim() {
                "lost" => FaultKind::Lost,
                "oom" => FaultKind::Oom,
                "hang" => FaultKind::Hang,
                "crash" => FaultKind::Crash,
                other => return Err(bad(&format!("`{other}` is no fault kind"))),
            };
            let run = run
                .trim()
                .parse()
                .map_err(|_| bad(&format!("`{run}` is not a run index")))?;
            faults.push((kind, run));
        }
        Ok(Self(faults))
    }
}

impl Faults {
    /// The faults [`FAULT_ENV`] asks for (none when it is unset or empty).
    pub fn from_env() -> Result<Self, BenchError> {
        match std::env::var(FAULT_ENV) {
            Ok(text) => text.parse(),
            Err(_) => Ok(Self::default()),
        }
    }

    fn has(&self, kind: FaultKind, index: usize) -> bool {
        self.0.contains(&(kind, index))
    }

    /// At the start of run `index`: `oom` fails it, `hang` never returns, `crash` aborts.
    pub fn at_start(&self, index: usize, gpu: &Gpu) -> Result<(), BenchError> {
        if self.has(FaultKind::Crash, index) {
            eprintln!("{FAULT_ENV}: aborting in run {index}");
            std::process::abort();
        }
        if self.has(FaultKind::Hang, index) {
            hang(gpu);
        }
        if self.has(FaultKind::Oom, index) {
            allocate_too_much(gpu)?;
        }
        Ok(())
    }

    /// In the middle of run `index` (its technique and scene on the device): `lost` destroys
    /// the device.
    pub fn in_the_middle(&self, index: usize, gpu: &Gpu) {
        if self.has(FaultKind::Lost, index) {
            gpu.device.destroy();
        }
    }
}

/// Allocates a texture array of 8 TiB (16384² x 2048 layers of 16 bytes; within the limits of
/// lavapipe and of most GPUs, beyond the memory of any), and returns the driver's error.
fn allocate_too_much(gpu: &Gpu) -> Result<(), BenchError> {
    let limits = gpu.device.limits();
    let scope_memory = gpu.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let scope_valid = gpu.device.push_error_scope(wgpu::ErrorFilter::Validation);
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("fault/oom"),
        size: wgpu::Extent3d {
            width: limits.max_texture_dimension_2d,
            height: limits.max_texture_dimension_2d,
            depth_or_array_layers: limits.max_texture_array_layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba32Float,
        usage: wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    });
    let invalid = pollster::block_on(scope_valid.pop());
    let memory = pollster::block_on(scope_memory.pop());
    texture.destroy();
    match memory.or(invalid) {
        Some(error) => Err(GpuError::DeviceLost(format!(
            "this run's first allocation (an 8 TiB texture array, {FAULT_ENV}=oom) failed: {error}"
        ))
        .into()),
        None => Err(BenchError::Fault(format!(
            "{FAULT_ENV}=oom: the device allocated a texture array of {} x {} x {} texels, so no allocation failure could be injected",
            limits.max_texture_dimension_2d,
            limits.max_texture_dimension_2d,
            limits.max_texture_array_layers
        ))),
    }
}

/// A compute shader whose loop ends only when a buffer that holds 0 holds `u32::MAX`.
const NEVER_ENDS: &str = "
@group(0) @binding(0) var<storage, read_write> cell: array<u32, 2>;
@compute @workgroup_size(1)
fn main() {
    loop {
        if cell[0] == 0xffffffffu { break; }
        cell[1] = cell[1] + 1u;
    }
}
";

/// Submits [`NEVER_ENDS`] and waits for it: on lavapipe (no watchdog) for ever.
fn hang(gpu: &Gpu) -> ! {
    eprintln!("{FAULT_ENV}: hanging the device with a shader that never ends");
    let device = &gpu.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("fault/hang"),
        source: wgpu::ShaderSource::Wgsl(NEVER_ENDS.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("fault/hang"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let cell = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("fault/hang"),
        size: 8,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("fault/hang"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: cell.as_entire_binding(),
        }],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    gpu.queue.submit([encoder.finish()]);
    loop {
        // A GPU whose watchdog resets the shader loses the device; nothing then ends either.
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        std::thread::sleep(std::time::Duration::from_secs(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_lists_parse_and_bad_ones_say_how_to_write_them() {
        let faults: Faults = "lost:1, oom:2,hang:3,crash:40".parse().unwrap();
        assert!(faults.has(FaultKind::Lost, 1) && faults.has(FaultKind::Crash, 40));
        assert!(!faults.has(FaultKind::Lost, 2));
        assert_eq!("".parse::<Faults>().unwrap(), Faults::default());
        for bad in ["lost", "melt:1", "hang:x", "oom:-1"] {
            let message = bad.parse::<Faults>().unwrap_err().to_string();
            assert!(
                message.contains("KIND:K") && message.contains(bad),
                "{message}"
            );
        }
    }
}
