//! GPU memory per technique (docs/BENCHMARKS.md, "Memory") and the settled error of techniques
//! that accumulate over frames (docs/BENCHMARKS.md, "Settled error").

use anyhow::{ensure, Context, Result};
use softshadow_bench::{report::scored_mae, Bench, BenchOptions, RunSpec};
use softshadow_core::{
    wgpu, Frame, Gpu, ParamValue, Registry, ShadowInputs, ShadowTechnique, TechniqueError,
    TechniqueInfo, TechniqueSettings, VisibilityBuffer,
};

use crate::common::{gpu, run_checked};

/// Bytes of the test technique's own texture (512 x 256 RGBA32Float) and buffer (1 MiB).
const HOG_TEXTURE_BYTES: u64 = 512 * 256 * 16;
const HOG_BUFFER_BYTES: u64 = 1 << 20;

/// `hard` plus a texture and a buffer of known size, made when it is created.
struct Hog {
    inner: Box<dyn ShadowTechnique>,
    _texture: wgpu::Texture,
    _buffer: wgpu::Buffer,
}

impl Hog {
    fn new(gpu: &Gpu, hard: &TechniqueInfo) -> Result<Self, TechniqueError> {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("hog/texture"),
            size: wgpu::Extent3d {
                width: 512,
                height: 256,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("hog/buffer"),
            size: HOG_BUFFER_BYTES,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        Ok(Self {
            inner: hard.create(gpu)?,
            _texture: texture,
            _buffer: buffer,
        })
    }
}

impl ShadowTechnique for Hog {
    fn id(&self) -> &str {
        "hog"
    }

    fn settings(&self) -> &dyn TechniqueSettings {
        self.inner.settings()
    }

    fn settings_mut(&mut self) -> &mut dyn TechniqueSettings {
        self.inner.settings_mut()
    }

    fn render(
        &mut self,
        frame: &mut Frame<'_>,
        inputs: &ShadowInputs<'_>,
        out: &VisibilityBuffer,
    ) -> Result<(), TechniqueError> {
        self.inner.render(frame, inputs, out)
    }

    fn invalidate_cache(&mut self) {
        self.inner.invalidate_cache();
    }
}

fn spec(technique: &str, params: &[(&str, &str)], registry: &Registry) -> Result<RunSpec> {
    let info = registry.find(technique)?;
    let params = params
        .iter()
        .map(|(n, v)| info.parse_param(&format!("{n}={v}")))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(RunSpec {
        scene: "atty-square".into(),
        technique: technique.into(),
        params,
        width: 48,
        height: 48,
        path: None,
    })
}

#[test]
fn the_memory_counted_is_what_a_technique_creates() -> Result<()> {
    let mut registry = softshadow::registry();
    let hard = registry.find("hard")?.clone();
    let hog = TechniqueInfo::new("hog", "hard and 3 MiB", "test", hard.params.clone(), {
        move |gpu| Ok(Box::new(Hog::new(gpu, &hard)?))
    });
    registry.add(hog)?;
    let options = BenchOptions {
        frames: 1,
        warmup: 1,
        error: false,
        images: false,
        camera_only: false,
        ..BenchOptions::default()
    };
    let mut bench = Bench::new(gpu()?, registry.clone(), options)?;
    // `hard` first: the first run on a scene once counted the scene upload's staging buffers in
    // its baseline (948 bytes fewer), which the bench's flush before the baseline prevents.
    let hard_run = run_checked(&mut bench, &spec("hard", &[], &registry)?)?;
    let hog_run = run_checked(&mut bench, &spec("hog", &[], &registry)?)?;
    let (hard, hog) = (
        hard_run.memory.context("lavapipe counts memory")?,
        hog_run.memory.context("lavapipe counts memory")?,
    );
    eprintln!("hard {hard:?}\nhog {hog:?}");
    ensure!(
        hog.current.textures - hard.current.textures == HOG_TEXTURE_BYTES,
        "textures: hog {} - hard {} should be {HOG_TEXTURE_BYTES}",
        hog.current.textures,
        hard.current.textures
    );
    ensure!(
        hog.current.buffers - hard.current.buffers == HOG_BUFFER_BYTES,
        "buffers: hog {} - hard {} should be {HOG_BUFFER_BYTES}",
        hog.current.buffers,
        hard.current.buffers
    );
    ensure!(hard.peak.total() >= hard.current.total() && hard.current.total() > 0);
    Ok(())
}

/// Runs each built-in at two settings of its cost model's first knob and holds the memory
/// counted against what its model states, within the tolerance the model gives.
#[test]
fn every_technique_holds_the_memory_its_cost_model_states() -> Result<()> {
    let registry = softshadow::registry();
    let options = BenchOptions {
        frames: 1,
        warmup: 1,
        error: false,
        images: false,
        camera_only: false,
        ..BenchOptions::default()
    };
    let mut bench = Bench::new(gpu()?, registry.clone(), options)?;
    let mut problems = Vec::new();
    for info in registry.iter() {
        for setting in memory_settings(info) {
            let spec = spec(&info.id, &setting, &registry)?;
            let run = run_checked(&mut bench, &spec)?;
            let counted = run.memory.context("lavapipe counts memory")?.peak.total() as f64;
            // Every parameter the run used (a model reads the defaults too), as the stress does.
            let params: Vec<_> = run.params.clone().into_iter().collect();
            let model = info
                .cost
                .estimate(&params, (spec.width * spec.height) as f64);
            let (low, high) = (
                model.gpu_bytes * (1.0 - model.gpu_tolerance),
                model.gpu_bytes * (1.0 + model.gpu_tolerance),
            );
            eprintln!(
                "{} {setting:?}: counted {counted:.0} B, model {:.0} B (+-{:.0}%)",
                info.id,
                model.gpu_bytes,
                model.gpu_tolerance * 100.0
            );
            if !(low..=high).contains(&counted) {
                problems.push(format!(
                    "{} {setting:?}: counted {counted:.0} bytes, its model states {:.0} +- {:.0}%",
                    info.id,
                    model.gpu_bytes,
                    model.gpu_tolerance * 100.0
                ));
            }
        }
    }
    ensure!(problems.is_empty(), "{}", problems.join("\n"));
    Ok(())
}

/// Two settings of `info`'s first memory knob (its cost model's first knob): the default and
/// another value in its range, or the defaults once when it has none.
fn memory_settings(info: &TechniqueInfo) -> Vec<Vec<(&'static str, &'static str)>> {
    let default_is = |name: &str, value: i64| {
        info.param(name)
            .is_ok_and(|p| p.default_value() == ParamValue::Int(value))
    };
    match info.cost.knobs.first().map(|k| k.as_ref()) {
        // `adaptive` and `msm` default to 512 already.
        Some("shadow_map_size") if default_is("shadow_map_size", 512) => {
            vec![vec![], vec![("shadow_map_size", "256")]]
        }
        Some("shadow_map_size") => vec![vec![], vec![("shadow_map_size", "512")]],
        // `ssm`: its memory grows with both edges.
        Some("occluder_map_size") => vec![
            vec![],
            vec![("occluder_map_size", "64"), ("ssm_size", "256")],
        ],
        Some("samples_per_axis") => vec![vec![], vec![("samples_per_axis", "4")]],
        Some("rays_per_pixel") => vec![vec![], vec![("rays_per_pixel", "1")]],
        // `pdsm`, without the disk cache: a PDSM an earlier test left there would be loaded
        // instead of built, and no sample maps read back.
        Some("samples") => vec![
            vec![("disk_cache", "false")],
            vec![("samples", "16"), ("disk_cache", "false")],
        ],
        _ => vec![vec![]],
    }
}

/// Settled error: below the first frame's for the techniques that accumulate, absent (and the
/// score equal to the first frame's) for one that keeps no history.
#[test]
fn settled_error_is_below_the_first_frames_where_a_history_accumulates() -> Result<()> {
    let registry = softshadow::registry();
    let mut bench = Bench::new(
        gpu()?,
        registry.clone(),
        BenchOptions {
            frames: 1,
            warmup: 1,
            images: false,
            camera_only: false,
            ..BenchOptions::default()
        },
    )?;
    for (technique, params) in [
        ("raytraced", &[("max_history", "8")][..]),
        ("pcss", &[("temporal", "true"), ("max_history", "8")][..]),
    ] {
        let run = run_checked(&mut bench, &spec(technique, params, &registry)?)?;
        let settled = run
            .settled
            .as_ref()
            .context("an accumulating run has a settled frame")?;
        let first = run
            .error
            .as_ref()
            .and_then(|e| e.vs_exact.as_ref())
            .context("exact")?;
        let last = settled.vs_exact.as_ref().context("exact")?;
        eprintln!(
            "{technique}: first frame {:.4}, settled after {} frames {:.4}",
            first.mae_shadowed, settled.frames, last.mae_shadowed
        );
        ensure!(
            settled.frames == 8,
            "{technique}: {} frames",
            settled.frames
        );
        ensure!(
            last.mae_shadowed < first.mae_shadowed,
            "{technique}: settled {} is not below the first frame's {}",
            last.mae_shadowed,
            first.mae_shadowed
        );
        ensure!(scored_mae(&run) == Some(last.mae_shadowed));
    }
    let hard = run_checked(&mut bench, &spec("hard", &[], &registry)?)?;
    ensure!(hard.settled.is_none(), "hard keeps no history");
    ensure!(scored_mae(&hard) == softshadow_bench::report::mae_shadowed(&hard));
    Ok(())
}
