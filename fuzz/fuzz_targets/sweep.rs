//! Sweep files (`workbench bench --sweep FILE`): parse, expand the grids, check every value.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = softshadow_bench::Sweep::parse(text);
});
