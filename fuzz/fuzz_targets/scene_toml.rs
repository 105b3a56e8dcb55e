//! TOML scene files through the workbench's loader (parse, build, repair, validate). The path
//! only names the file in messages and anchors relative glTF paths.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = softshadow_scenes::load_scene_bytes(data, std::path::Path::new("fuzz/scene.toml"));
});
