//! `softshadow`: the soft-shadow workbench as a library.
//!
//! One crate per technique behind the [`core::ShadowTechnique`] trait; enable only the ones you
//! need with cargo features (`hard`, `pcss`, `ssm`, `backprojection`, `bitmask`, `adaptive`,
//! `pdsm`, `msm`, `smrt`, `raytraced`, `reference`; all on by default).
//!
//! ```no_run
//! use softshadow::core::{Gpu, Renderer, SceneGpu, ShadingMode};
//! let gpu = Gpu::new_headless()?;
//! let scene = softshadow::scenes::load("atty-square")?.scene;
//! let scene_gpu = SceneGpu::upload(&gpu, &scene);
//! let mut renderer = Renderer::new(&gpu, 256, 256)?;
//! let mut pcss = softshadow::pcss::Pcss::new(&gpu, Default::default())?;
//! renderer.render(&scene_gpu, &scene.camera, &scene.light, &mut pcss, Some(ShadingMode::Shaded))?;
//! let visibility: Vec<f32> = renderer.read_visibility()?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub use softshadow_core as core;
pub use softshadow_metrics as metrics;
pub use softshadow_scenes as scenes;

#[cfg(feature = "adaptive")]
pub use softshadow_adaptive as adaptive;
#[cfg(feature = "backprojection")]
pub use softshadow_backprojection as backprojection;
#[cfg(feature = "bitmask")]
pub use softshadow_bitmask as bitmask;
#[cfg(feature = "hard")]
pub use softshadow_hard as hard;
#[cfg(feature = "msm")]
pub use softshadow_msm as msm;
#[cfg(feature = "pcss")]
pub use softshadow_pcss as pcss;
#[cfg(feature = "pdsm")]
pub use softshadow_pdsm as pdsm;
#[cfg(feature = "raytraced")]
pub use softshadow_raytraced as raytraced;
#[cfg(feature = "reference")]
pub use softshadow_reference as reference;
#[cfg(feature = "smrt")]
pub use softshadow_smrt as smrt;
#[cfg(feature = "ssm")]
pub use softshadow_ssm as ssm;

use softshadow_core::{Registry, TechniqueInfo};

/// The built-in techniques of the enabled features, in the order `workbench list` prints them:
/// the cost floor first, the yardstick last. Adding a built-in technique is one line here.
pub fn builtin_techniques() -> Vec<TechniqueInfo> {
    vec![
        #[cfg(feature = "hard")]
        softshadow_hard::info(),
        #[cfg(feature = "pcss")]
        softshadow_pcss::info(),
        #[cfg(feature = "ssm")]
        softshadow_ssm::info(),
        #[cfg(feature = "backprojection")]
        softshadow_backprojection::info(),
        #[cfg(feature = "bitmask")]
        softshadow_bitmask::info(),
        #[cfg(feature = "adaptive")]
        softshadow_adaptive::info(),
        #[cfg(feature = "pdsm")]
        softshadow_pdsm::info(),
        #[cfg(feature = "msm")]
        softshadow_msm::info(),
        #[cfg(feature = "smrt")]
        softshadow_smrt::info(),
        #[cfg(feature = "raytraced")]
        softshadow_raytraced::info(),
        #[cfg(feature = "reference")]
        softshadow_reference::info(),
    ]
}

/// The built-in techniques as a [`Registry`], to which a user's own can be added
/// ([`Registry::add`]).
pub fn registry() -> Registry {
    Registry::new(builtin_techniques()).expect("the built-in techniques have distinct ids")
}
