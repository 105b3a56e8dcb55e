//! `softshadow`: the soft-shadow workbench as a library.
//!
//! One crate per technique behind the [`core::ShadowTechnique`] trait, re-exported here under its
//! id (`softshadow::pcss`) behind a cargo feature of the same name; all are on by default, so
//! `default-features = false, features = ["pcss"]` keeps only the ones you need.
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

use softshadow_core::{shader::uniform_layout::UniformMirror, Registry, TechniqueInfo};

/// Declares the built-in techniques, one line each: `#[cfg(feature = "<id>")] <id>,`, where the
/// root `Cargo.toml` has the technique's crate as the optional dependency `<id>` (whose implicit
/// feature is the gate). Each line re-exports the crate as `softshadow::<id>` and registers its
/// `info()`; the order of the lines is the order `workbench list` prints.
macro_rules! builtins {
    ($(#[$gate:meta] $technique:ident,)*) => {
        $(
            #[$gate]
            pub use $technique;
        )*

        /// The built-in techniques of the enabled features, in the order `workbench list` prints
        /// them: the cost floor first, the yardstick last.
        pub fn builtin_techniques() -> Vec<TechniqueInfo> {
            vec![$(#[$gate] $technique::info(),)*]
        }

        // Test support (tests/shaders.rs): every built-in's Rust uniform structs with the WGSL
        // structs they mirror.
        #[doc(hidden)]
        pub fn builtin_uniform_mirrors() -> Vec<UniformMirror> {
            let mut mirrors = Vec::new();
            $(
                #[$gate]
                mirrors.extend($technique::uniform_mirrors());
            )*
            mirrors
        }
    };
}

builtins! {
    #[cfg(feature = "hard")] hard,
    #[cfg(feature = "pcss")] pcss,
    #[cfg(feature = "ssm")] ssm,
    #[cfg(feature = "backprojection")] backprojection,
    #[cfg(feature = "bitmask")] bitmask,
    #[cfg(feature = "adaptive")] adaptive,
    #[cfg(feature = "pdsm")] pdsm,
    #[cfg(feature = "msm")] msm,
    #[cfg(feature = "smrt")] smrt,
    #[cfg(feature = "raytraced")] raytraced,
    #[cfg(feature = "reference")] reference,
}

/// The built-in techniques as a [`Registry`], to which a user's own can be added
/// ([`Registry::add`]).
pub fn registry() -> Registry {
    Registry::new(builtin_techniques()).expect("the built-in techniques have distinct ids")
}
