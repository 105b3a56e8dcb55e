//! The benchmark crate's GPU tests, one module per subject, linked into one test binary: each
//! binary links wgpu and every technique, so one binary instead of eleven saves minutes of
//! linking in a cold CI build (the tests themselves are unchanged by this).

mod common;

mod adaptive;
mod backprojection;
mod bitmask;
mod cascades;
mod contract;
mod gather_scaffold;
mod image_checksums;
mod light_kinds;
mod light_space_cache;
mod materials;
mod memory;
mod motion;
mod msm;
mod pcss;
mod pdsm;
mod raytraced;
mod smrt;
mod ssm;
mod stiff;
mod stress;
mod sweeps;
mod techniques;
mod timing;
mod wgsl;
mod yardsticks;
