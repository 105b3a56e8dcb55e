//! The left panel's scene, light and camera sections.

use softshadow_core::{glam::Vec3, scene::Fnv1a, AreaLight, Camera, Gpu, Scene, SceneGpu};

use super::{ViewerApp, ViewerError};
use crate::orbit::Orbit;

/// The scene with its camera and light: what is looked at, and from where.
pub(super) struct SceneState {
    pub(super) loaded: LoadedScene,
    pub(super) camera: Camera,
    pub(super) orbit: Orbit,
    pub(super) light: AreaLight,
    /// The "Open" field's text.
    pub(super) path_field: String,
}

impl SceneState {
    pub(super) fn new(loaded: LoadedScene, camera: Camera, light: AreaLight) -> Self {
        Self {
            loaded,
            orbit: Orbit::from_camera(&camera),
            camera,
            light,
            path_field: String::new(),
        }
    }
}

impl SceneState {
    /// The scene picker and path field; returns the scene to open, if one was picked.
    pub(super) fn ui(&mut self, ui: &mut egui::Ui) -> Option<String> {
        let mut open = None;
        // A file is named by its file name (a whole path widened the box onto two lines); the
        // whole spec is on hover.
        let spec = self.loaded.spec.clone();
        let shown = std::path::Path::new(&spec)
            .file_name()
            .map_or(spec.clone(), |n| n.to_string_lossy().into_owned());
        egui::ComboBox::from_label("Scene")
            .selected_text(shown)
            .truncate()
            .width(ui.available_width() - 60.0)
            .show_ui(ui, |ui| {
                for info in softshadow_scenes::builtin_scenes() {
                    if ui
                        .selectable_label(self.loaded.spec == info.id, info.id)
                        .on_hover_text(info.description)
                        .clicked()
                    {
                        open = Some(info.id.to_string());
                    }
                }
            })
            .response
            .on_hover_text(spec);
        ui.horizontal(|ui| {
            let field = ui.add(
                egui::TextEdit::singleline(&mut self.path_field)
                    .hint_text("scene.toml / model.glb")
                    .desired_width(170.0),
            );
            // Enter in the field opens, as the Open button does.
            let entered = field.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
            if (ui.button("Open").clicked() || entered) && !self.path_field.trim().is_empty() {
                open = Some(self.path_field.trim().to_string());
            }
        });
        ui.small("Or drop a .toml / .gltf / .glb file on the window.");
        ui.label(format!("{} triangles", self.loaded.scene.triangle_count()));
        open
    }

    pub(super) fn light_ui(&mut self, ui: &mut egui::Ui) {
        let light = &mut self.light;
        ui.horizontal(|ui| {
            ui.label("position");
            ui.add(
                egui::DragValue::new(&mut light.center.x)
                    .speed(0.02)
                    .prefix("x "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.y)
                    .speed(0.02)
                    .prefix("y "),
            );
            ui.add(
                egui::DragValue::new(&mut light.center.z)
                    .speed(0.02)
                    .prefix("z "),
            );
        });
        // Orientation as yaw (around +y) and tilt below the horizon, degrees.
        let d = light.direction.normalize_or(Vec3::NEG_Y);
        let mut tilt = (-d.y).clamp(-1.0, 1.0).asin().to_degrees();
        let mut yaw = d.x.atan2(d.z).to_degrees();
        let tilt_changed = ui
            .add(egui::Slider::new(&mut tilt, -90.0..=90.0).text("tilt (deg)"))
            .on_hover_text("degrees below the horizon: 90 points straight down")
            .changed();
        let yaw_changed = ui
            .add(egui::Slider::new(&mut yaw, -180.0..=180.0).text("yaw (deg)"))
            .changed();
        if tilt_changed || yaw_changed {
            let (t, y) = (tilt.to_radians(), yaw.to_radians());
            light.direction = Vec3::new(t.cos() * y.sin(), -t.sin(), t.cos() * y.cos());
        }
        light_shape_ui(ui, light);
        ui.add(egui::Slider::new(&mut light.intensity, 0.0..=4.0).text("intensity"));
        if ui.button("Reset light").clicked() {
            self.light = self.loaded.scene.light;
        }
    }

    pub(super) fn camera_ui(&mut self, ui: &mut egui::Ui) {
        ui.small("Image: left drag orbits, right or middle drag pans, scroll zooms.");
        ui.add(egui::Slider::new(&mut self.camera.fov_y_degrees, 10.0..=120.0).text("fov (deg)"));
        ui.add(
            egui::Slider::new(&mut self.orbit.distance, 0.1..=100.0)
                .logarithmic(true)
                .text("distance"),
        );
        if ui.button("Reset camera and light").clicked() {
            self.reset_view();
        }
    }

    /// Camera and light back to the scene's own.
    pub(super) fn reset_view(&mut self) {
        self.camera = self.loaded.scene.camera;
        self.light = self.loaded.scene.light;
        self.orbit = Orbit::from_camera(&self.camera);
    }
}

pub(super) struct LoadedScene {
    pub(super) spec: String,
    pub(super) scene: Scene,
    pub(super) gpu: SceneGpu,
    pub(super) warnings: Vec<String>,
    /// Paths the scene file declares (the timeline offers them beside the built-ins).
    pub(super) paths: Vec<softshadow_scenes::path::Path>,
}

pub(super) fn load_scene(gpu: &Gpu, spec: &str) -> Result<LoadedScene, ViewerError> {
    let loaded = softshadow_scenes::load(spec)?;
    let scene_gpu = SceneGpu::upload(gpu, &loaded.scene);
    Ok(LoadedScene {
        spec: spec.trim().to_string(),
        gpu: scene_gpu,
        scene: loaded.scene,
        warnings: loaded.warnings,
        paths: loaded.paths,
    })
}

impl ViewerApp {
    /// Loads a scene (builtin id, scene file or glTF). On failure the error is shown and the
    /// current scene stays.
    pub fn open_scene(&mut self, spec: &str) {
        match load_scene(&self.gpu, spec) {
            Ok(scene) => {
                for warning in &scene.warnings {
                    log::warn!("{warning}");
                }
                self.scene.camera = scene.scene.camera;
                self.scene.light = scene.scene.light;
                self.scene.orbit = Orbit::from_camera(&self.scene.camera);
                self.scene.loaded = scene;
                self.timeline = Default::default();
                self.technique.shown_key = None;
                self.release_memory();
                self.timing.rolling.clear();
            }
            Err(e) => self.report_error(format!("cannot open scene `{spec}`: {e}")),
        }
    }

    /// Camera and light back to the scene's own.
    pub fn reset_view(&mut self) {
        self.scene.reset_view();
    }

    /// Scene, light and camera: what the plot's points are comparable for.
    pub(super) fn current_view_key(&self) -> u64 {
        let mut h = Fnv1a::default();
        h.write_u64(self.scene.loaded.gpu.content_hash);
        h.write_u64(self.scene.camera.content_hash());
        h.write_u64(self.scene.light.content_hash());
        h.finish()
    }
}

/// The light's kind and the sizes that kind uses (docs/SCENES.md, "Light kinds").
fn light_shape_ui(ui: &mut egui::Ui, light: &mut softshadow_core::AreaLight) {
    use softshadow_core::LightKind;
    egui::ComboBox::from_label("kind")
        .selected_text(light.kind.name())
        .show_ui(ui, |ui| {
            for kind in LightKind::ALL {
                ui.selectable_value(&mut light.kind, kind, kind.name());
            }
        })
        .response
        .on_hover_text(
            "the light's shape; a technique that does not support it is marked in the technique list",
        );
    match light.kind {
        LightKind::Rect => {
            ui.add(egui::Slider::new(&mut light.width, 0.0..=4.0).text("width"));
            ui.add(egui::Slider::new(&mut light.height, 0.0..=4.0).text("height"));
        }
        LightKind::Disk | LightKind::Sphere => {
            ui.add(egui::Slider::new(&mut light.radius, 0.0..=2.0).text("radius"));
        }
        LightKind::Spot => {
            ui.add(egui::Slider::new(&mut light.radius, 0.0..=2.0).text("radius"));
            ui.add(
                egui::Slider::new(&mut light.cone_inner_degrees, 0.0..=90.0)
                    .text("inner cone (deg)"),
            );
            ui.add(
                egui::Slider::new(&mut light.cone_outer_degrees, 0.0..=90.0)
                    .text("outer cone (deg)"),
            );
            light.cone_outer_degrees = light.cone_outer_degrees.max(light.cone_inner_degrees);
        }
        LightKind::Sun => {
            ui.add(
                egui::Slider::new(&mut light.angular_diameter_degrees, 0.0..=20.0)
                    .text("angular diameter (deg)"),
            )
            .on_hover_text("the real sun is 0.53 degrees wide; its position is ignored");
        }
    }
}
