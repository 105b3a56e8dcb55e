//! The scene spec parser (`id:key=value,...`) and the builtin scene it names, repaired and
//! validated: what `--scene SPEC` does for anything that is not a file.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(spec) = std::str::from_utf8(data) else {
        return;
    };
    let Ok((id, params)) = softshadow_scenes::builtin::parse_spec(spec) else {
        return;
    };
    // Builds only scenes of modest size: the polygon-count scenes accept up to 8 million
    // triangles by design, which is slow, not a fault.
    let small = params
        .iter()
        .all(|(name, value)| name != "triangles" || *value <= 100_000.0);
    if small {
        let _ = softshadow_scenes::builtin(&id, &params);
    }
});
