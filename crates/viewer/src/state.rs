//! The viewer state that can be saved to and loaded from a JSON file: scene, technique, every
//! technique's settings, camera, light, view mode and the reference's settings.

use std::{collections::BTreeMap, path::Path};

use softshadow_core::{AreaLight, Camera, ParamValue};

use crate::{display::ViewMode, ViewerError};

/// Bumped when a field changes meaning.
pub const STATE_VERSION: u32 = 1;

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewerState {
    pub version: u32,
    /// Builtin id (optionally `id:param=value,...`), `.toml` scene file or glTF file.
    pub scene: String,
    pub technique: String,
    /// Technique id -> parameter name -> value, for every technique whose settings were changed.
    #[serde(default)]
    pub params: BTreeMap<String, BTreeMap<String, ParamValue>>,
    pub camera: Camera,
    pub light: AreaLight,
    #[serde(default)]
    pub view_mode: ViewMode,
    /// Divider of the split view, fraction of the width.
    #[serde(default = "half")]
    pub split: f32,
    /// Settings of the reference (`reference` technique parameters).
    #[serde(default)]
    pub reference_params: BTreeMap<String, ParamValue>,
}

fn half() -> f32 {
    0.5
}

impl ViewerState {
    pub fn save(&self, path: &Path) -> Result<(), ViewerError> {
        let json = serde_json::to_string_pretty(self).map_err(|e| ViewerError::State {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        std::fs::write(path, json).map_err(|e| ViewerError::State {
            path: path.display().to_string(),
            message: format!("cannot write it ({e}): check the folder exists and is writable"),
        })
    }

    pub fn load(path: &Path) -> Result<Self, ViewerError> {
        let error = |message: String| ViewerError::State {
            path: path.display().to_string(),
            message,
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| error(format!("cannot read it ({e}): check the path")))?;
        Self::parse(&text, path)
    }

    /// Parses and checks the text of a state file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, ViewerError> {
        let error = |message: String| ViewerError::State {
            path: path.display().to_string(),
            message,
        };
        let state: Self = serde_json::from_str(text)
            .map_err(|e| error(format!("not a viewer state file: {e}")))?;
        if state.version != STATE_VERSION {
            return Err(error(format!(
                "version {} is not supported (this viewer reads version {STATE_VERSION})",
                state.version
            )));
        }
        state.camera.validate().map_err(error)?;
        state.light.validate().map_err(error)?;
        if !(0.0..=1.0).contains(&state.split) {
            return Err(error(format!("split = {} is outside 0 to 1", state.split)));
        }
        Ok(state)
    }
}
