//! Viewer state files (`workbench view --state FILE`): parse and check.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = softshadow_viewer::state::ViewerState::parse(text, std::path::Path::new("fuzz-state.json"));
});
