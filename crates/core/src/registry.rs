//! An open list of techniques: the workspace's built-ins (`softshadow::registry()`) plus any a
//! user adds from their own crate or a WGSL file. The benchmark, the viewer, the report and the
//! tests take a [`Registry`] and know techniques only through its [`TechniqueInfo`]s.

use thiserror::Error;

use crate::{
    shader::{ShaderSpec, CORE_SHADERS},
    technique::{COST_FLOOR_TECHNIQUE, YARDSTICK_TECHNIQUE},
    TechniqueInfo,
};

/// A technique could not be added or found.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RegistryError {
    /// No technique of that id.
    #[error("unknown technique `{id}`: known techniques are {known} (see `workbench list`), or give a .wgsl file by path")]
    Unknown {
        /// The id given.
        id: String,
        /// The ids there are.
        known: String,
    },
    /// Two techniques with one id.
    #[error("two techniques have the id `{id}`: give the one you add another id")]
    Duplicate {
        /// The id both have.
        id: String,
    },
}

/// Techniques in the order `workbench list` prints them, ids unique.
#[derive(Clone, Debug, Default)]
pub struct Registry {
    techniques: Vec<TechniqueInfo>,
}

impl Registry {
    /// A registry of `techniques`, refusing two with one id.
    pub fn new(techniques: impl IntoIterator<Item = TechniqueInfo>) -> Result<Self, RegistryError> {
        let mut registry = Self::default();
        for info in techniques {
            registry.add(info)?;
        }
        Ok(registry)
    }

    /// Adds `info` after the others, refusing an id already there.
    pub fn add(&mut self, info: TechniqueInfo) -> Result<(), RegistryError> {
        if self.get(&info.id).is_some() {
            return Err(RegistryError::Duplicate {
                id: info.id.into_owned(),
            });
        }
        self.techniques.push(info);
        Ok(())
    }

    /// The technique called `id`, if registered.
    pub fn get(&self, id: &str) -> Option<&TechniqueInfo> {
        self.techniques.iter().find(|t| t.id == id)
    }

    /// The technique called `id`, or an error listing the ids there are.
    pub fn find(&self, id: &str) -> Result<&TechniqueInfo, RegistryError> {
        self.get(id).ok_or_else(|| RegistryError::Unknown {
            id: id.into(),
            known: self.ids().join(", "),
        })
    }

    /// Every technique, in order.
    pub fn iter(&self) -> std::slice::Iter<'_, TechniqueInfo> {
        self.techniques.iter()
    }

    /// Every id, in order.
    pub fn ids(&self) -> Vec<&str> {
        self.techniques.iter().map(|t| t.id.as_ref()).collect()
    }

    /// How many techniques there are.
    pub fn len(&self) -> usize {
        self.techniques.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.techniques.is_empty()
    }

    /// The yardstick technique ([`YARDSTICK_TECHNIQUE`]), if registered.
    pub fn yardstick(&self) -> Result<&TechniqueInfo, RegistryError> {
        self.find(YARDSTICK_TECHNIQUE)
    }

    /// The cost floor ([`COST_FLOOR_TECHNIQUE`]), if registered.
    pub fn cost_floor(&self) -> Option<&TechniqueInfo> {
        self.get(COST_FLOOR_TECHNIQUE)
    }

    /// The technique a viewer opens with: the first that is neither the cost floor nor the
    /// yardstick (the first soft technique in registry order), else the first of all.
    pub fn default_technique(&self) -> Option<&TechniqueInfo> {
        self.techniques
            .iter()
            .find(|t| t.id != COST_FLOOR_TECHNIQUE && t.id != YARDSTICK_TECHNIQUE)
            .or(self.techniques.first())
    }

    /// The core's shaders and every technique's, for the naga validation test.
    pub fn all_shaders(&self) -> Vec<ShaderSpec> {
        let mut specs = CORE_SHADERS.to_vec();
        for info in &self.techniques {
            specs.extend_from_slice(info.shaders);
        }
        specs
    }
}

impl<'a> IntoIterator for &'a Registry {
    type Item = &'a TechniqueInfo;
    type IntoIter = std::slice::Iter<'a, TechniqueInfo>;

    fn into_iter(self) -> Self::IntoIter {
        self.techniques.iter()
    }
}
