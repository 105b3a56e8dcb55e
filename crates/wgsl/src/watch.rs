//! Watching a technique file: on each poll, a changed file (by modification time and contents)
//! is loaded again and yields its new [`TechniqueInfo`] or the error that refused it; the caller
//! keeps drawing with the last good one (the viewer's hot reload, docs/WGSL.md).

use std::{
    path::{Path, PathBuf},
    time::SystemTime,
};

use softshadow_core::TechniqueInfo;

use crate::WgslError;

/// A technique file and the version of it last seen.
#[derive(Debug)]
pub struct WatchedFile {
    path: PathBuf,
    modified: Option<SystemTime>,
    contents: Option<String>,
}

impl WatchedFile {
    /// Watches `path`; the version there now counts as seen (it was loaded by the caller).
    pub fn new(path: &Path) -> Self {
        let mut watched = Self {
            path: path.to_path_buf(),
            modified: None,
            contents: None,
        };
        watched.modified = watched.modified_time();
        watched.contents = std::fs::read_to_string(path).ok();
        watched
    }

    /// The file watched.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn modified_time(&self) -> Option<SystemTime> {
        std::fs::metadata(&self.path)
            .and_then(|m| m.modified())
            .ok()
    }

    /// `None` while the file is unchanged; after a change, the new version's technique or the
    /// one-line error (`file:line:column: message`) that refused it.
    pub fn poll(&mut self) -> Option<Result<TechniqueInfo, WgslError>> {
        let modified = self.modified_time();
        if modified == self.modified {
            return None;
        }
        self.modified = modified;
        let contents = match std::fs::read_to_string(&self.path) {
            Ok(contents) => contents,
            Err(e) => {
                return Some(Err(WgslError::Read {
                    path: self.path.display().to_string(),
                    message: e.to_string(),
                }))
            }
        };
        // A save that changed nothing (or touched the time only) is no new version.
        if self.contents.as_deref() == Some(contents.as_str()) {
            return None;
        }
        self.contents = Some(contents.clone());
        Some(crate::from_source(&self.path, &contents))
    }
}
