//! glTF (JSON) and GLB bytes through the workbench's loader: import, repair, wrap into a scene,
//! validate. Buffers in other files are refused, so the fuzzer never reads the file system.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = softshadow_scenes::load_gltf_bytes(data, std::path::Path::new("fuzz.glb"), false);
});
