//! Hot reload of a technique defined by a WGSL file (docs/WGSL.md, "Hot reload"): the active
//! technique's file is polled once per frame; a new version that compiles replaces the technique
//! (same id, the settings that still apply) and its measurements become a new point of the
//! error-against-time plot, the old version's points staying as `id vN`; a version that does not
//! compile shows its one-line error (`file:line:column: message`) while the last good pipeline
//! keeps drawing.

use softshadow_core::Registry;
use softshadow_wgsl::WatchedFile;

use super::ViewerApp;

/// The watched file of the active technique, if it is a file technique.
#[derive(Debug, Default)]
pub struct FileReload {
    watched: Option<WatchedFile>,
    /// Versions loaded since the file was first watched (1: the one it started with).
    version: u32,
    /// Why the file's latest version was refused.
    error: Option<String>,
}

impl FileReload {
    /// Why the file's latest version was refused (the last good one keeps drawing).
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }
}

impl ViewerApp {
    /// Polls the active technique's file; once per frame.
    pub(super) fn reload_technique_file(&mut self) {
        let id = self.technique.id.clone();
        let Some(path) = self.registry.get(&id).and_then(softshadow_wgsl::file_of) else {
            self.file_reload = FileReload::default();
            return;
        };
        if self.file_reload.watched.as_ref().map(|w| w.path()) != Some(path.as_path()) {
            self.file_reload = FileReload {
                watched: Some(WatchedFile::new(&path)),
                version: 1,
                error: None,
            };
            return;
        }
        let Some(result) = self.file_reload.watched.as_mut().and_then(|w| w.poll()) else {
            return;
        };
        let info = match result {
            Ok(info) => info,
            Err(e) => {
                self.file_reload.error = Some(e.to_string());
                return;
            }
        };
        // The old version's points stay on the plot under their own name.
        let old_name = format!("{id} v{}", self.file_reload.version);
        for view in &mut self.plot.views {
            for point in view.points.iter_mut().filter(|p| p.technique == id) {
                point.technique = old_name.clone();
            }
        }
        self.file_reload.version += 1;
        self.file_reload.error = None;
        // Settings of parameters the new version no longer declares (or with another range) go.
        if let Some(saved) = self.technique.settings.get_mut(&id) {
            saved.retain(|name, value| {
                info.param(name)
                    .is_ok_and(|spec| spec.check(value.clone()).is_ok())
            });
        }
        let techniques =
            self.registry
                .iter()
                .map(|t| if t.id == id { info.clone() } else { t.clone() });
        match Registry::new(techniques) {
            Ok(registry) => self.registry = registry,
            Err(e) => {
                self.file_reload.error = Some(e.to_string());
                return;
            }
        }
        self.select_technique(&id);
        // Same id and parameters, another shader: measure it afresh.
        self.timing.setting_key = None;
        self.reference.measured = None;
    }
}
