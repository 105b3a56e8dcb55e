//! Core of the soft-shadow workbench.
pub mod camera;
pub mod light;
pub mod scene;

pub use camera::Camera;
pub use light::{AreaLight, SlopeFrustum};
pub use scene::{Aabb, Instance, Mesh, MeshRepair, Scene};
