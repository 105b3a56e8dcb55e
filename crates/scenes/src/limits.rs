//! Limits that keep a hostile or broken file from exhausting memory or time. Every loader checks
//! them before it allocates, and a file over a limit gets [`crate::SceneError::Limit`], which
//! names the limit and its value.
//!
//! They sit far above every scene of this workbench (the largest builtin scene has 8 million
//! triangles, `blob` objects at most 8 million each).

/// Largest file a loader reads (scene file, glTF, GLB or an external glTF buffer): 1 GiB.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Most triangles a scene may have, counted per instance (what is uploaded to the GPU, about
/// 14 bytes per triangle: 32 million is about 450 MB).
pub const MAX_TRIANGLES: usize = 32_000_000;

/// Most vertices one glTF primitive may have (checked on the accessor before it is read).
pub const MAX_VERTICES: usize = 32_000_000;

/// Most mesh instances a scene may have (glTF node uses and `[[object]]` tables).
pub const MAX_INSTANCES: usize = 100_000;

/// Deepest glTF node hierarchy (deeper is treated as a cycle).
pub const MAX_NODE_DEPTH: usize = 256;

/// Most glTF nodes visited while walking the node graph: a graph whose nodes reuse their
/// children names 2^depth paths in a few hundred bytes, with or without meshes.
pub const MAX_NODE_VISITS: usize = 1_000_000;
