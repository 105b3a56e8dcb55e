//! Every technique the workbench knows. Adding a technique = one line here (and a crate).

use softshadow_core::TechniqueInfo;

/// All registered techniques, in the order `workbench list` prints them.
pub fn techniques() -> Vec<TechniqueInfo> {
    vec![
        softshadow_hard::info(),
        softshadow_pcss::info(),
        softshadow_ssm::info(),
        softshadow_backprojection::info(),
        softshadow_bitmask::info(),
        softshadow_adaptive::info(),
        softshadow_pdsm::info(),
        softshadow_reference::info(),
    ]
}

/// Every shader of every crate (for the naga validation test).
pub fn all_shaders() -> Vec<softshadow_core::shader::ShaderSpec> {
    let mut specs = softshadow_core::shader::CORE_SHADERS.to_vec();
    specs.extend_from_slice(softshadow_hard::SHADERS);
    specs.extend_from_slice(softshadow_pcss::SHADERS);
    specs.extend_from_slice(softshadow_ssm::SHADERS);
    specs.extend_from_slice(softshadow_backprojection::SHADERS);
    specs.extend_from_slice(softshadow_bitmask::SHADERS);
    specs.extend_from_slice(softshadow_adaptive::SHADERS);
    specs.extend_from_slice(softshadow_pdsm::SHADERS);
    specs.extend_from_slice(softshadow_reference::SHADERS);
    specs
}

pub fn find(id: &str) -> Result<TechniqueInfo, crate::BenchError> {
    techniques()
        .into_iter()
        .find(|t| t.id == id)
        .ok_or_else(|| crate::BenchError::UnknownTechnique {
            id: id.into(),
            known: techniques()
                .iter()
                .map(|t| t.id)
                .collect::<Vec<_>>()
                .join(", "),
        })
}
