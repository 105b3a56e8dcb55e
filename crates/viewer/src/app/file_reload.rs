//! Hot reload of a technique defined by a WGSL file (docs/WGSL.md, "Hot reload"): the active
//! technique's file is polled once per frame; a new version that compiles replaces the technique
//! (same id, the settings that still apply) and its measurements become new points of the
//! error-against-time plot (`id v2`, `id v3`, ...), every earlier version's points staying with
//! their own legend entry; a version that does not compile shows its one-line error
//! (`file:line:column: message`) while the last good pipeline keeps drawing.

use std::collections::BTreeMap;

use softshadow_core::Registry;
use softshadow_wgsl::WatchedFile;

use super::ViewerApp;

/// The watched file of the active technique, if it is a file technique.
#[derive(Debug, Default)]
pub struct FileReload {
    watched: Option<WatchedFile>,
    /// Per file technique id, the version loaded now (1: the file as first loaded this
    /// session): kept when another technique is shown, so a version is never numbered twice.
    versions: BTreeMap<String, u32>,
    /// Why the file's latest version was refused.
    error: Option<String>,
}

impl FileReload {
    /// Why the file's latest version was refused (the last good one keeps drawing).
    pub fn error(&self) -> Option<&str> {
        self.error.as_deref()
    }

    /// The version of file technique `id` loaded now (`None`: not seen as a file technique).
    pub fn version_of(&self, id: &str) -> Option<u32> {
        self.versions.get(id).copied()
    }
}

impl ViewerApp {
    /// The version of the active technique's file now shown (`None`: not a file technique).
    pub(super) fn file_version(&self) -> Option<u32> {
        let id = &self.technique.id;
        self.registry.get(id).and_then(softshadow_wgsl::file_of)?;
        Some(self.file_reload.versions.get(id).copied().unwrap_or(1))
    }

    /// Polls the active technique's file; once per frame.
    pub(super) fn reload_technique_file(&mut self) {
        let id = self.technique.id.clone();
        let Some(path) = self.registry.get(&id).and_then(softshadow_wgsl::file_of) else {
            self.file_reload.watched = None;
            self.file_reload.error = None;
            return;
        };
        if self.file_reload.watched.as_ref().map(|w| w.path()) != Some(path.as_path()) {
            self.file_reload.watched = Some(WatchedFile::new(&path));
            self.file_reload.versions.entry(id).or_insert(1);
            self.file_reload.error = None;
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
        // The old version's points stay on the plot as they are, under `id vN`.
        *self.file_reload.versions.entry(id.clone()).or_insert(1) += 1;
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
