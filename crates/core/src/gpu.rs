//! GPU context: adapter choice (honouring `WGPU_BACKEND` and `WGPU_ADAPTER_NAME`), the device with
//! the optional features the workbench can use, and validation-error capture.

use std::sync::{Arc, Mutex};

use crate::error::GpuError;

/// Features used when the adapter has them. None is required by the core; techniques that need one
/// say so in [`crate::Requirements`].
pub const OPTIONAL_FEATURES: wgpu::Features = wgpu::Features::TIMESTAMP_QUERY
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS)
    .union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES)
    .union(wgpu::Features::FLOAT32_BLENDABLE)
    .union(wgpu::Features::PIPELINE_STATISTICS_QUERY)
    .union(wgpu::Features::SHADER_F16)
    .union(crate::accel::RAY_QUERY);

/// The optional features `adapter` offers, less ray queries when [`crate::accel::NO_RAY_QUERY_ENV`]
/// is `1`: what [`Gpu::from_adapter`] requests, and what `workbench list` checks techniques
/// against without creating a device.
pub fn offered_features(adapter: &wgpu::Adapter) -> wgpu::Features {
    let mut features = adapter.features() & OPTIONAL_FEATURES;
    if std::env::var(crate::accel::NO_RAY_QUERY_ENV).is_ok_and(|v| v == "1") {
        features = features - crate::accel::RAY_QUERY;
    }
    features
}

/// The driver's message of a lost device, or what happened when it gave none.
fn lost_message(reason: wgpu::DeviceLostReason, message: &str) -> String {
    match (reason, message.trim()) {
        (wgpu::DeviceLostReason::Destroyed, "") => "the device was destroyed".to_string(),
        (_, "") => "the driver gave no reason".to_string(),
        (_, message) => message.to_string(),
    }
}

/// Adapter facts that go into reports.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AdapterSummary {
    /// Adapter name, e.g. `llvmpipe (LLVM 17.0.6, 256 bits)`.
    pub name: String,
    /// Backend in lower case (`vulkan`, `metal`, `dx12`, `gl`).
    pub backend: String,
    /// Driver name and version.
    pub driver: String,
}

impl AdapterSummary {
    /// The facts of `adapter`.
    pub fn of(adapter: &wgpu::Adapter) -> Self {
        let info = adapter.get_info();
        Self {
            name: info.name,
            backend: format!("{:?}", info.backend).to_lowercase(),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_string(),
        }
    }

    /// Mesa's (major, minor) version when the driver is Mesa's (lavapipe reads
    /// `llvmpipe Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)`), else `None`. Lavapipe before 24.1 has
    /// limits that later versions lifted (docs/DEVICES.md, "The devices").
    pub fn mesa_version(&self) -> Option<(u32, u32)> {
        let version = self.driver.split("Mesa ").nth(1)?;
        let mut parts = version.split(|c: char| !c.is_ascii_digit());
        Some((parts.next()?.parse().ok()?, parts.next()?.parse().ok()?))
    }
}

/// Shared GPU handles. Cheap to clone (wgpu handles are reference counted).
///
/// Made either by the workbench ([`Gpu::new_headless`], [`Gpu::from_adapter`]: it picks the
/// adapter and creates the device with every optional feature it offers) or from a host
/// renderer's own adapter, device and queue ([`Gpu::from_host`]).
#[derive(Clone)]
pub struct Gpu {
    /// The instance the adapter came from; `None` for a [`Gpu::from_host`] context (the host
    /// keeps its instance; only the viewer needs one, to create window surfaces).
    pub instance: Option<wgpu::Instance>,
    /// The adapter the device was created on.
    pub adapter: wgpu::Adapter,
    /// The device every technique creates its resources on.
    pub device: wgpu::Device,
    /// The queue frames are submitted to.
    pub queue: wgpu::Queue,
    /// Uncaptured validation / out-of-memory errors, drained by [`Gpu::take_errors`].
    errors: Arc<Mutex<Vec<String>>>,
    /// Why the device was lost, once it is (set by its device-lost callback): see [`Gpu::lost`].
    lost: Arc<Mutex<Option<String>>>,
    /// Bind group layouts shared by every technique (see [`crate::frame`]).
    pub layouts: Arc<crate::frame::CoreLayouts>,
    /// The pass behind [`crate::VisibilityBuffer::write_unshadowed`], made on first use.
    pub(crate) unshadowed: Arc<std::sync::OnceLock<crate::visibility::UnshadowedPass>>,
}

impl Gpu {
    /// Picks an adapter and creates a device without a window.
    ///
    /// `WGPU_BACKEND` (e.g. `vulkan`) restricts the backends; `WGPU_ADAPTER_NAME` picks the first
    /// adapter whose name contains it (case-insensitive). Without a match this returns an error
    /// that says what to install, never panics.
    pub fn new_headless() -> Result<Self, GpuError> {
        Self::new_headless_with(wgpu::MemoryHints::default())
    }

    /// [`Gpu::new_headless`] with the device's memory hints (see [`Gpu::from_adapter_with`]).
    pub fn new_headless_with(memory_hints: wgpu::MemoryHints) -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(Self::pick_adapter(&instance, None))?;
        pollster::block_on(Self::from_adapter_with(instance, adapter, memory_hints))
    }

    /// Adapter selection shared by the headless path and the windowed viewer.
    pub async fn pick_adapter(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<wgpu::Adapter, GpuError> {
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
        let mut adapters = instance.enumerate_adapters(backends).await;
        if let Some(surface) = surface {
            adapters.retain(|a| a.is_surface_supported(surface));
        }
        let filter = match std::env::var("WGPU_BACKEND") {
            Ok(b) => format!(" for WGPU_BACKEND={b}"),
            Err(_) => String::new(),
        };
        if adapters.is_empty() {
            return Err(GpuError::NoAdapter { filter });
        }
        if let Ok(wanted) = std::env::var("WGPU_ADAPTER_NAME") {
            let needle = wanted.to_lowercase();
            let available: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
            return adapters
                .into_iter()
                .find(|a| a.get_info().name.to_lowercase().contains(&needle))
                .ok_or(GpuError::AdapterNameNotFound {
                    wanted,
                    available: available.join(", "),
                });
        }
        // Prefer real hardware, then anything else (lavapipe is a `Cpu` device).
        adapters.sort_by_key(|a| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        });
        Ok(adapters.remove(0))
    }

    /// Creates the device with every optional feature the adapter offers.
    pub async fn from_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
    ) -> Result<Self, GpuError> {
        Self::from_adapter_with(instance, adapter, wgpu::MemoryHints::default()).await
    }

    /// [`Gpu::from_adapter`] with the device's memory hints. wgpu's default, `Performance`,
    /// sub-allocates from blocks of 64-256 MiB and keeps the last block of each memory type when
    /// it empties; `MemoryUsage` uses blocks of 4-32 MiB and gives larger buffers blocks of their
    /// own that are freed with them (the viewer, which loads and drops large scenes).
    pub async fn from_adapter_with(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        memory_hints: wgpu::MemoryHints,
    ) -> Result<Self, GpuError> {
        Self::from_adapter_without(instance, adapter, memory_hints, wgpu::Features::empty()).await
    }

    /// [`Gpu::new_headless`] on a device created without `excluded` even where the adapter
    /// offers them: how tests see what a technique does on an adapter without a feature (ray
    /// queries) without another machine.
    pub fn new_headless_without(excluded: wgpu::Features) -> Result<Self, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(Self::pick_adapter(&instance, None))?;
        pollster::block_on(Self::from_adapter_without(
            instance,
            adapter,
            wgpu::MemoryHints::default(),
            excluded,
        ))
    }

    /// [`Gpu::from_adapter_with`] less the optional features in `excluded`.
    pub async fn from_adapter_without(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        memory_hints: wgpu::MemoryHints,
        excluded: wgpu::Features,
    ) -> Result<Self, GpuError> {
        let features = offered_features(&adapter) - excluded;
        let adapter_limits = adapter.limits();
        let mut limits = wgpu::Limits {
            max_texture_dimension_2d: adapter_limits.max_texture_dimension_2d,
            max_texture_array_layers: adapter_limits.max_texture_array_layers,
            max_buffer_size: adapter_limits.max_buffer_size,
            max_storage_buffer_binding_size: adapter_limits.max_storage_buffer_binding_size,
            ..wgpu::Limits::default()
        };
        let ray_query = features.contains(crate::accel::RAY_QUERY);
        if ray_query {
            // The adapter's own acceleration-structure limits: wgpu's
            // `using_minimum_supported_acceleration_structure_values` asks for 2^28 BLAS
            // primitives, which lavapipe (2^24 - 1) refuses.
            limits = limits.using_acceleration_structure_values(adapter_limits);
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("softshadow device"),
                required_features: features,
                required_limits: limits,
                memory_hints,
                experimental_features: if ray_query {
                    // SAFETY: wgpu asks callers of its EXPERIMENTAL_* features to accept that
                    // its implementation may still have bugs; only the ray-query techniques use
                    // the feature, and their results are checked against exact answers.
                    unsafe { wgpu::ExperimentalFeatures::enabled() }
                } else {
                    wgpu::ExperimentalFeatures::disabled()
                },
                ..Default::default()
            })
            .await
            .map_err(|source| GpuError::Device {
                adapter: adapter.get_info().name,
                source,
            })?;
        let errors: Arc<Mutex<Vec<String>>> = Arc::default();
        let sink = errors.clone();
        // Tests set SOFTSHADOW_GPU_ERRORS=panic: an error then panics in the wgpu call that
        // raised it (as wgpu's own default handler does), so it fails the test that caused it
        // even where no `take_errors` would have looked (docs/STABILITY.md).
        let panic_on_error = std::env::var("SOFTSHADOW_GPU_ERRORS").is_ok_and(|v| v == "panic");
        // A lost device raises no uncaptured error; say so where it happens (a driver failing
        // a pipeline, say), not at the next resource that comes out invalid.
        let lost_sink = errors.clone();
        let lost: Arc<Mutex<Option<String>>> = Arc::default();
        let lost_reason = lost.clone();
        device.set_device_lost_callback(move |reason, message| {
            let message = lost_message(reason, &message);
            if reason != wgpu::DeviceLostReason::Destroyed {
                log::error!("wgpu device lost ({reason:?}): {message}");
                eprintln!("wgpu device lost ({reason:?}): {message}");
                if let Ok(mut e) = lost_sink.lock() {
                    e.push(format!("device lost: {message}"));
                }
            }
            if let Ok(mut lost) = lost_reason.lock() {
                lost.get_or_insert(message);
            }
        });
        device.on_uncaptured_error(Arc::new(move |error: wgpu::Error| {
            if panic_on_error {
                panic!("wgpu error (SOFTSHADOW_GPU_ERRORS=panic): {error}");
            }
            log::error!("wgpu: {error}");
            if let Ok(mut e) = sink.lock() {
                e.push(error.to_string());
            }
        }));
        let mut gpu = Self::wrap(Some(instance), adapter, device, queue, errors);
        gpu.lost = lost;
        Ok(gpu)
    }

    /// A new device on the same adapter with the same features, for when this one is lost
    /// ([`Gpu::lost`]): what the benchmark does before its next run. Resources of this context
    /// (scenes, renderers, techniques) do not carry over.
    pub fn new_device(&self) -> Result<Self, GpuError> {
        let instance = self.instance.clone().ok_or(GpuError::HostContext)?;
        let excluded = offered_features(&self.adapter) - self.features();
        pollster::block_on(Self::from_adapter_without(
            instance,
            self.adapter.clone(),
            wgpu::MemoryHints::default(),
            excluded,
        ))
    }

    /// Why the device was lost (the driver's message), or `None` while it works. Polls the
    /// device first without waiting, so a loss already reported by the driver is seen.
    pub fn lost(&self) -> Option<String> {
        let _ = self.device.poll(wgpu::PollType::Poll);
        self.lost.lock().ok().and_then(|lost| lost.clone())
    }

    /// Wraps a host renderer's own adapter, device and queue, after checking that the device has
    /// the features and limits every technique in `techniques` declares
    /// ([`TechniqueInfo::requirements`](crate::TechniqueInfo::requirements)). The error lists
    /// what is missing and how to request it; to get it right the first time, create the device
    /// with [`Requirements::all`](crate::Requirements::all) (`examples/embed` compiles and runs
    /// this; a doctest would cost CI one more link of wgpu):
    ///
    /// ```ignore
    /// # fn make(adapter: wgpu::Adapter, techniques: &[softshadow_core::TechniqueInfo]) -> Result<(), Box<dyn std::error::Error>> {
    /// let needs = softshadow_core::Requirements::all(techniques);
    /// let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
    ///     required_features: needs.features,
    ///     required_limits: needs.limits.apply_to(wgpu::Limits::default()),
    ///     ..Default::default()
    /// }))?;
    /// let gpu = softshadow_core::Gpu::from_host(adapter, device, queue, techniques)?;
    /// # Ok(()) }
    /// ```
    ///
    /// The host's device keeps its own uncaptured-error handler (this does not replace it), so
    /// [`Gpu::take_errors`] reports nothing for such a context.
    pub fn from_host(
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        techniques: &[crate::TechniqueInfo],
    ) -> Result<Self, GpuError> {
        let mut lacking = Vec::new();
        for info in techniques {
            let (features, limits) = info.requirements.missing_on(&device);
            if !features.is_empty() || !limits.is_empty() {
                let mut what = Vec::new();
                if !features.is_empty() {
                    what.push(format!("features {features:?}"));
                }
                what.extend(limits);
                lacking.push(format!("`{}` needs {}", info.id, what.join(", ")));
            }
        }
        if !lacking.is_empty() {
            return Err(GpuError::HostDeviceLacks {
                adapter: adapter.get_info().name,
                lacking: lacking.join("; "),
            });
        }
        Ok(Self::wrap(None, adapter, device, queue, Arc::default()))
    }

    fn wrap(
        instance: Option<wgpu::Instance>,
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        errors: Arc<Mutex<Vec<String>>>,
    ) -> Self {
        let layouts = Arc::new(crate::frame::CoreLayouts::new(&device));
        Self {
            instance,
            adapter,
            device,
            queue,
            errors,
            lost: Arc::default(),
            layouts,
            unshadowed: Arc::default(),
        }
    }

    /// Adapter facts for reports.
    pub fn summary(&self) -> AdapterSummary {
        AdapterSummary::of(&self.adapter)
    }

    /// The facts of the adapter [`Gpu::new_headless`] would pick, without creating a device
    /// (what a benchmark whose runs each make their own device records).
    pub fn headless_adapter_summary() -> Result<AdapterSummary, GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(Self::pick_adapter(&instance, None))?;
        Ok(AdapterSummary::of(&adapter))
    }

    /// Features the device was created with.
    pub fn features(&self) -> wgpu::Features {
        self.device.features()
    }

    /// Whether the device has ray queries ([`crate::accel`]).
    pub fn has_ray_query(&self) -> bool {
        self.features().contains(crate::accel::RAY_QUERY)
    }

    /// The optional features of the adapter [`Gpu::new_headless`] would pick, without creating a
    /// device (what `workbench list` checks techniques against).
    pub fn headless_adapter_features() -> Result<(String, wgpu::Features), GpuError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(Self::pick_adapter(&instance, None))?;
        Ok((adapter.get_info().name, offered_features(&adapter)))
    }

    /// Whether the device has timestamp queries (GPU pass timing).
    pub fn has_timestamps(&self) -> bool {
        self.features().contains(wgpu::Features::TIMESTAMP_QUERY)
    }

    /// Returns the first validation or device error raised since the last call, if any.
    pub fn take_errors(&self) -> Result<(), GpuError> {
        let mut errors = self
            .errors
            .lock()
            .map_err(|_| GpuError::Validation("error sink poisoned".into()))?;
        if errors.is_empty() {
            return Ok(());
        }
        let all = std::mem::take(&mut *errors);
        let first = all[0].clone();
        if first.contains("lost")
            || first.contains("Out of Memory")
            || first.contains("OutOfMemory")
        {
            Err(GpuError::DeviceLost(first))
        } else {
            Err(GpuError::Validation(first))
        }
    }

    /// Blocks until all submitted work has finished.
    pub fn wait_idle(&self) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| GpuError::DeviceLost(e.to_string()))
    }
}
