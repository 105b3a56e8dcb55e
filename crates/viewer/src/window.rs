//! The winit window: one wgpu device shared by the renderer, the viewer's passes and egui-wgpu,
//! a surface to present to, and `--frames N --screenshot FILE` for documentation and CI.

use std::{path::PathBuf, sync::Arc, time::Instant};

use egui::mutex::RwLock;
use softshadow_core::{wgpu, Gpu};
use winit::{
    application::ApplicationHandler,
    dpi::PhysicalSize,
    event::WindowEvent,
    event_loop::{ActiveEventLoop, ControlFlow, EventLoop},
    window::{Window, WindowId},
};

use crate::{app::ViewerOptions, timing::median, ViewerApp, ViewerError};

/// How to run the window.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub app: ViewerOptions,
    /// Inner size of the window in physical pixels.
    pub width: u32,
    pub height: u32,
    /// Close after this many frames (otherwise run until the window is closed).
    pub frames: Option<u64>,
    /// Save the last frame, UI included, as PNG before closing.
    pub screenshot: Option<PathBuf>,
}

impl Default for ViewOptions {
    fn default() -> Self {
        Self {
            app: ViewerOptions::default(),
            // A size a laptop shows, at which every panel's content is reachable.
            width: 1280,
            height: 800,
            frames: None,
            screenshot: None,
        }
    }
}

/// What a run measured.
#[derive(Clone, Debug, Default)]
pub struct ViewSummary {
    pub frames: u64,
    /// Wall time per frame over the frames after the first (which builds pipelines), ms.
    pub mean_frame_ms: Option<f64>,
    pub median_frame_ms: Option<f64>,
    /// Mean frame time once the reference had converged (only the technique renders), ms.
    pub converged_mean_frame_ms: Option<f64>,
    pub adapter: String,
    /// Technique passes' median GPU time at the end, ms; when the last frames ran none of the
    /// technique's passes (a kept result, as the reference's), its cost of computing instead.
    pub technique_gpu_ms: Option<f64>,
    /// Light samples of the reference done / total at the end.
    pub reference_progress: (u32, u32),
}

/// Opens the viewer window and runs until it is closed (or `frames` have been shown).
pub fn run(options: ViewOptions) -> Result<ViewSummary, ViewerError> {
    if options.frames == Some(0) {
        return Err(ViewerError::NoFrames);
    }
    let event_loop = EventLoop::new().map_err(|e| ViewerError::Window(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut handler = Handler {
        options,
        running: None,
        error: None,
        frame_times: Vec::new(),
        last_frame: None,
        summary: ViewSummary::default(),
        driver_warning: None,
    };
    event_loop
        .run_app(&mut handler)
        .map_err(|e| ViewerError::Window(e.to_string()))?;
    if let Some(error) = handler.error {
        return Err(error);
    }
    // The first frame compiles every pipeline; leave it out.
    let steady: Vec<(f64, bool)> = handler.frame_times.iter().skip(1).copied().collect();
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    let all: Vec<f64> = steady.iter().map(|(ms, _)| *ms).collect();
    let converged: Vec<f64> = steady
        .iter()
        .filter(|(_, done)| *done)
        .map(|(ms, _)| *ms)
        .collect();
    handler.summary.mean_frame_ms = mean(&all);
    handler.summary.median_frame_ms = (!all.is_empty()).then(|| median(all.iter().copied()));
    handler.summary.converged_mean_frame_ms = mean(&converged);
    Ok(handler.summary)
}

struct Running {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    context: egui::Context,
    input: egui_winit::State,
    egui_renderer: Arc<RwLock<egui_wgpu::Renderer>>,
    app: ViewerApp,
}

struct Handler {
    options: ViewOptions,
    running: Option<Running>,
    error: Option<ViewerError>,
    /// Wall time per frame, and whether the reference had converged before that frame.
    frame_times: Vec<(f64, bool)>,
    last_frame: Option<Instant>,
    summary: ViewSummary,
    /// A known driver problem, logged once the first frame is shown (after the state file and
    /// the rest of the user's input were accepted, so a bad input still fails in one line).
    driver_warning: Option<String>,
}

impl ApplicationHandler for Handler {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        match self.start(event_loop) {
            Ok(running) => {
                running.window.request_redraw();
                self.running = Some(running);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(running) = self.running.as_mut() else {
            return;
        };
        let response = running.input.on_window_event(&running.window, &event);
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if size.width > 0 && size.height > 0 {
                    running.config.width = size.width;
                    running.config.height = size.height;
                    running
                        .surface
                        .configure(&running.gpu.device, &running.config);
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.error = Some(e);
                    event_loop.exit();
                }
            }
            _ => {
                if response.repaint {
                    running.window.request_redraw();
                }
            }
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        // Continuous rendering: GPU timings and the progressive reference advance every frame.
        if let Some(running) = &self.running {
            running.window.request_redraw();
        }
    }
}

impl Handler {
    fn start(&mut self, event_loop: &ActiveEventLoop) -> Result<Running, ViewerError> {
        let window_error = |e: &dyn std::fmt::Display| ViewerError::Window(e.to_string());
        let attributes = Window::default_attributes()
            .with_title("softshadow viewer")
            .with_inner_size(PhysicalSize::new(self.options.width, self.options.height));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| window_error(&e))?,
        );
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(
                Box::new(event_loop.owned_display_handle()),
            ));
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| window_error(&e))?;
        let adapter = pollster::block_on(Gpu::pick_adapter(&instance, Some(&surface)))?;
        let gpu = pollster::block_on(Gpu::from_adapter_with(
            instance,
            adapter,
            crate::MEMORY_HINTS,
        ))?;
        let capabilities = surface.get_capabilities(&gpu.adapter);
        // egui-wgpu writes gamma-space colours: prefer a non-sRGB surface format.
        let format = capabilities
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .or_else(|| capabilities.formats.first().copied())
            .ok_or_else(|| ViewerError::Window("the surface offers no format".into()))?;
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            // Measure what the viewer can do, not the display's refresh rate.
            present_mode: wgpu::PresentMode::AutoNoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: capabilities
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&gpu.device, &config);
        self.summary.adapter = gpu.summary().name;
        self.driver_warning = known_driver_leak(&gpu.adapter.get_info());

        let context = egui::Context::default();
        let input = egui_winit::State::new(
            context.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer = Arc::new(RwLock::new(egui_wgpu::Renderer::new(
            &gpu.device,
            format,
            // Dithering costs fragment work on a CPU rasteriser and shows nothing on 8-bit UI colours.
            egui_wgpu::RendererOptions {
                dithering: false,
                ..Default::default()
            },
        )));
        let mut app = ViewerApp::new(gpu.clone(), egui_renderer.clone(), &self.options.app)?;
        // The frame is cleared to the panel colour, so the panels need not paint it.
        app.set_opaque_panels(false);
        if self.options.frames.is_some() {
            // `--frames N` (documentation screenshots, CI): every frame shows the technique
            // frame it asked for, as before the render worker.
            app.set_frame_wait(std::time::Duration::MAX);
        }
        Ok(Running {
            window,
            surface,
            config,
            gpu,
            context,
            input,
            egui_renderer,
            app,
        })
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        let running = self.running.as_mut().expect("started");
        let raw_input = running.input.take_egui_input(&running.window);
        let app = &mut running.app;
        let output = running.context.run_ui(raw_input, |ui| app.ui(ui));
        running
            .input
            .handle_platform_output(&running.window, output.platform_output);
        let jobs = running
            .context
            .tessellate(output.shapes, output.pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [running.config.width, running.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        let gpu = &running.gpu;
        let mut renderer = running.egui_renderer.write();
        let mut textures = output.textures_delta;
        for (id, deltas) in textures.set.drain() {
            for delta in &deltas {
                renderer.update_texture(&gpu.device, &gpu.queue, id, delta);
            }
        }
        let frame = match running.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame)
            | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => frame,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                running.surface.configure(&gpu.device, &running.config);
                textures.clear();
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                textures.clear();
                return Ok(());
            }
            other => {
                return Err(ViewerError::Window(format!(
                    "cannot get the next surface texture: {other:?}"
                )))
            }
        };
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("viewer/egui"),
            });
        let user_buffers =
            renderer.update_buffers(&gpu.device, &gpu.queue, &mut encoder, &jobs, &screen);
        let view = frame.texture.create_view(&Default::default());
        let background = clear_colour(running.context.global_style().visuals.panel_fill);
        paint(&renderer, &mut encoder, &view, &jobs, &screen, background);

        let last_frame = self
            .options
            .frames
            .is_some_and(|n| running.app.stats().frames >= n);
        let mut screenshot = running.app.take_screenshot_request();
        if last_frame && self.options.screenshot.is_some() {
            screenshot = self.options.screenshot.clone();
        }
        let capture = screenshot.as_ref().map(|path| {
            // The same paint jobs into a copyable texture (surface textures may not be).
            let texture = screenshot_texture(gpu, &running.config);
            let view = texture.create_view(&Default::default());
            paint(&renderer, &mut encoder, &view, &jobs, &screen, background);
            (path.clone(), texture)
        });
        gpu.queue
            .submit(user_buffers.into_iter().chain([encoder.finish()]));
        running.window.pre_present_notify();
        gpu.queue.present(frame);
        for id in textures.free.drain() {
            renderer.free_texture(&id);
        }
        drop(renderer);

        if let Some((path, texture)) = capture {
            save_capture(&mut running.app, gpu, &texture, &path, last_frame)?;
        }
        self.count_frame();
        if last_frame {
            self.warn_of_a_shown_error();
            event_loop.exit();
        }
        Ok(())
    }

    /// Counts a frame shown: its wall time, and the summary's frames, reference progress and
    /// technique time; logs the driver warning once the first frame is shown.
    fn count_frame(&mut self) {
        let running = self.running.as_ref().expect("started");
        let now = Instant::now();
        if let Some(last) = self.last_frame.replace(now) {
            let converged = self.summary.reference_progress.0 >= self.summary.reference_progress.1
                && self.summary.reference_progress.1 > 0;
            self.frame_times
                .push(((now - last).as_secs_f64() * 1e3, converged));
        }
        let stats = running.app.stats();
        if stats.frames > 0 {
            if let Some(warning) = self.driver_warning.take() {
                log::warn!("{warning}");
            }
        }
        self.summary.frames = stats.frames;
        let progress = running.app.reference_progress();
        self.summary.reference_progress = (progress.done, progress.total);
        self.summary.technique_gpu_ms = running
            .app
            .timing_rows()
            .iter()
            .filter(|r| !softshadow_core::renderer::is_core_pass(&r.name))
            .map(|r| r.median_ms)
            .reduce(|a, b| a + b)
            .or(running.app.cost_ms());
    }

    /// Logs the error the viewer shows, if any (the technique's first), as a `--frames` run
    /// closes the window.
    fn warn_of_a_shown_error(&self) {
        let app = &self.running.as_ref().expect("started").app;
        let errors = app.errors();
        if let Some(error) = app.technique_error().or(errors.first().map(|e| e.as_str())) {
            log::warn!("the viewer showed an error: {error}");
        }
    }
}

/// A texture the size and format of the surface that can be painted into and copied from.
fn screenshot_texture(gpu: &Gpu, config: &wgpu::SurfaceConfiguration) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("viewer/screenshot"),
        size: wgpu::Extent3d {
            width: config.width,
            height: config.height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: config.format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Saves the screenshot painted into `texture` to `path` and says so in `app`; a failure is
/// shown in `app`, or returned on the `last_frame` (no one would see it).
fn save_capture(
    app: &mut ViewerApp,
    gpu: &Gpu,
    texture: &wgpu::Texture,
    path: &std::path::Path,
    last_frame: bool,
) -> Result<(), ViewerError> {
    if let Err(e) = save_screenshot(gpu, texture, path) {
        if last_frame {
            return Err(e);
        }
        app.report_error(e.to_string());
    } else {
        log::info!("screenshot saved to {}", path.display());
        app.confirm(format!(
            "saved the screenshot to {}",
            crate::app::shown_path(path)
        ));
    }
    Ok(())
}

fn paint(
    renderer: &egui_wgpu::Renderer,
    encoder: &mut wgpu::CommandEncoder,
    target: &wgpu::TextureView,
    jobs: &[egui::ClippedPrimitive],
    screen: &egui_wgpu::ScreenDescriptor,
    background: wgpu::Color,
) {
    let mut pass = encoder
        .begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewer/egui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(background),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
        .forget_lifetime();
    renderer.render(&mut pass, jobs, screen);
}

/// An egui colour (gamma-space bytes) as the clear colour of a gamma-space (non-sRGB) target.
fn clear_colour(colour: egui::Color32) -> wgpu::Color {
    let [r, g, b, a] = colour.to_array();
    let unit = |c: u8| f64::from(c) / 255.0;
    wgpu::Color {
        r: unit(r),
        g: unit(g),
        b: unit(b),
        a: unit(a),
    }
}

/// Reads `texture` (RGBA8 or BGRA8, gamma space) back and writes it as an RGB PNG.
fn save_screenshot(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    path: &std::path::Path,
) -> Result<(), ViewerError> {
    let error = |message: String| ViewerError::Screenshot {
        path: path.display().to_string(),
        message,
    };
    let bytes = softshadow_core::readback::read_texture(gpu, texture)?;
    let bgra = matches!(
        texture.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let rgb: Vec<u8> = bytes
        .chunks_exact(4)
        .flat_map(|p| {
            if bgra {
                [p[2], p[1], p[0]]
            } else {
                [p[0], p[1], p[2]]
            }
        })
        .collect();
    let image = image::RgbImage::from_raw(texture.width(), texture.height(), rgb)
        .ok_or_else(|| error("the frame has an unexpected size".into()))?;
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| error(e.to_string()))?;
    }
    image
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| error(format!("{e}: check the folder exists and is writable")))
}

/// A warning for drivers known to leak memory per frame whatever the viewer does: lavapipe from
/// Mesa 22.x (measured on 22.3.6: about 1 MiB per frame inside the driver, none on Mesa 25.0.7;
/// docs/DEVICES.md, "Mesa 22.3's leak per presented frame").
fn known_driver_leak(info: &wgpu::AdapterInfo) -> Option<String> {
    let lavapipe = info.device_type == wgpu::DeviceType::Cpu && info.name.contains("llvmpipe");
    (lavapipe && info.driver_info.contains("Mesa 22.")).then(|| {
        format!(
            "{} ({}) leaks about 1 MiB of memory per frame inside the driver, so long viewer sessions grow; \
             Mesa 25 does not: on Debian 12 `apt-get install -t bookworm-backports mesa-vulkan-drivers` \
             (docs/DEVICES.md)",
            info.name, info.driver_info
        )
    })
}
