//! Compiling a technique file: the contract's preamble (bindings and helpers) before the user's
//! code and the entry points after it, parsed and validated with naga, every error mapped back to
//! the user's file's line and column (docs/WGSL.md, "The contract").

use softshadow_core::shader::COMMON_MODULES;

use crate::{
    directives::{Directives, ScalarType},
    WgslError, CONTRACT_VERSION,
};

/// The common modules whose items the contract offers, in dependency order (their
/// `#define_import_path` / `#import` lines are dropped: concatenated, they are plain WGSL).
const CONTRACT_MODULES: &[&str] = &[
    "common/frame_types.wgsl",
    "common/light.wgsl",
    "common/frame.wgsl",
    "common/shadow_view.wgsl",
    "common/sampling.wgsl",
    "common/fullscreen.wgsl",
];

/// Group 1 of the pass (after the generated `Params` struct), and (version 3) the helpers that
/// read its map the same way for the perspective map and the sun's orthographic one
/// (docs/WGSL.md, "The map"). Under the sun `view` holds: `light_view_proj` world to clip,
/// `window.x` the texel edge in world units, `eye_near_far.z` the near plane (light-space z at
/// depth 0), `.w` far - near (`technique::sun_map_view`).
const GROUP1: &str = "
@group(1) @binding(0) var<uniform> view: ShadowView;
@group(1) @binding(1) var shadow_map: texture_depth_2d;
@group(1) @binding(2) var<uniform> params: Params;

// The depth map_depth gives where no caster is: beyond every receiver.
const MAP_EMPTY: f32 = 3.0e38;

// A receiver in the map: where it falls (`uv`, [0, 1)^2 inside the map) and its depth along the
// light's rays, in the units of map_depth (light-space z).
struct MapPoint {
    uv: vec2<f32>,
    depth: f32,
}

fn map_point(s: Surface) -> MapPoint {
    if light_kind() == LIGHT_SUN {
        let clip = view.light_view_proj * vec4<f32>(s.world, 1.0);
        let uv = vec2<f32>(clip.x * 0.5 + 0.5, 0.5 - clip.y * 0.5);
        return MapPoint(uv, view.eye_near_far.z + clip.z * view.eye_near_far.w);
    }
    return MapPoint(view_uv(view, s.light), s.light.z);
}

// The nearest caster's depth in `texel`, or MAP_EMPTY where none is (or outside the map).
fn map_texel_depth(texel: vec2<i32>) -> f32 {
    if any(texel < vec2<i32>(0)) || any(texel >= vec2<i32>(view.size.xy)) {
        return MAP_EMPTY;
    }
    let d = textureLoad(shadow_map, texel, 0);
    if d >= 1.0 {
        return MAP_EMPTY;
    }
    if light_kind() == LIGHT_SUN {
        return view.eye_near_far.z + d * view.eye_near_far.w;
    }
    return linear_depth(view, d);
}

// The nearest caster's depth at `uv`, or MAP_EMPTY.
fn map_depth(uv: vec2<f32>) -> f32 {
    if !in_map(uv) {
        return MAP_EMPTY;
    }
    return map_texel_depth(vec2<i32>(uv * view.size.xy));
}

// A texel's edge at the receiver, in world units.
fn map_texel_world(s: Surface) -> f32 {
    if light_kind() == LIGHT_SUN {
        return view.window.x;
    }
    return texel_slope(view) * s.light.z;
}

// Map uv per world unit across the light's rays at the receiver.
fn map_uv_per_world(s: Surface) -> f32 {
    return view.size.z / map_texel_world(s);
}

// A depth bias of `texels` texel footprints at the receiver over the cosine to the light (at
// least 0.1): `hard`'s bias, for either map.
fn map_bias(s: Surface, texels: f32) -> f32 {
    if light_kind() == LIGHT_SUN {
        return texels * view.window.x / max(abs(dot(s.normal, frame.light_dir.xyz)), 0.1);
    }
    return texels * texel_slope(view) * s.light.z / light_cosine(s);
}
";

/// The entry points, after the user's code: the pixels where the file is asked are receivers in
/// front of the light (docs/ARCHITECTURE.md, "The contract").
const ENTRY_POINTS: &str = "
@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> FullscreenVertex {
    return fullscreen_vertex(index);
}

@fragment
fn fs_main(in: FullscreenVertex) -> @location(0) vec4<f32> {
    let pixel = vec2<i32>(in.position.xy);
    let s = load_surface(pixel);
    if !s.is_receiver {
        return vec4<f32>(1.0);
    }
    if !light_reaches(s) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(clamp(visibility(s, pixel), 0.0, 1.0));
}
";

/// The names the contract's bindings have (a file declares no binding of its own).
const CONTRACT_BINDINGS: &[&str] = &[
    "frame",
    "gbuffer_position",
    "gbuffer_normal",
    "view",
    "shadow_map",
    "params",
];

/// The `Params` struct of `directives`: one 4-byte scalar per parameter in declaration order
/// (`bool` as `u32`), `shadow_map_size` last, padded to 16 bytes (a uniform block's size rule).
pub fn params_struct(directives: &Directives) -> String {
    let mut fields: Vec<(String, &str)> = directives
        .params
        .iter()
        .map(|p| (p.spec.name.to_string(), p.ty.wgsl_field_type()))
        .collect();
    fields.push((
        crate::directives::SHADOW_MAP_SIZE.to_string(),
        ScalarType::U32.wgsl_field_type(),
    ));
    let mut padding = 0;
    while fields.len() % 4 != 0 {
        fields.push((format!("_padding{padding}"), "u32"));
        padding += 1;
    }
    let body: String = fields
        .iter()
        .map(|(name, ty)| format!("    {name}: {ty},\n"))
        .collect();
    format!("struct Params {{\n{body}}}\n")
}

/// The WGSL before the user's code: the contract's modules, `Params` and group 1.
pub fn preamble(directives: &Directives) -> String {
    let mut text = format!(
        "// softshadow WGSL technique contract, version {CONTRACT_VERSION} (docs/WGSL.md)\n"
    );
    for wanted in CONTRACT_MODULES {
        let (_, source) = COMMON_MODULES
            .iter()
            .find(|(path, _)| path == wanted)
            .expect("the contract's modules are core's common modules");
        for line in source.lines() {
            if !line.trim_start().starts_with('#') {
                text.push_str(line);
                text.push('\n');
            }
        }
    }
    text.push_str(&params_struct(directives));
    text.push_str(GROUP1);
    text
}

/// The file `path` (its text `source`) with the contract around it, validated.
#[derive(Debug)]
pub struct CompiledFile {
    /// The naga module (validated), handed to wgpu as IR.
    pub module: naga::Module,
}

/// Parses and validates `source` (the file `path`) with the contract around it.
pub fn compile(
    path: &str,
    source: &str,
    directives: &Directives,
) -> Result<CompiledFile, WgslError> {
    let preamble = preamble(directives);
    // The user's code starts a line of its own and ends one, so its lines and columns are
    // those of the file from `preamble.len()` on.
    let full = format!("{preamble}{source}\n{ENTRY_POINTS}");
    let user = preamble.len()..preamble.len() + source.len();
    let locate = |spans: Vec<naga::Span>, message: String| -> WgslError {
        let ranges: Vec<_> = spans.iter().filter_map(|s| s.to_range()).collect();
        match ranges.iter().find(|r| user.contains(&r.start)) {
            Some(range) => {
                let before = &source[..range.start - user.start];
                let line = before.matches('\n').count() + 1;
                let line_start = before.rfind('\n').map_or(0, |i| i + 1);
                let column = before[line_start..].chars().count() + 1;
                WgslError::Shader {
                    path: path.to_string(),
                    line,
                    column,
                    message,
                }
            }
            // Only the contract's code is named: the file left out `visibility`, gave it
            // another signature, or redefined a name of the contract.
            None => WgslError::Shader {
                path: path.to_string(),
                line: 1,
                column: 1,
                message: format!(
                    "{message} (in the contract's code around the file: define `fn visibility(s: Surface, pixel: vec2<i32>) -> f32` and redefine none of the contract's names, docs/WGSL.md)"
                ),
            },
        }
    };
    let module = naga::front::wgsl::parse_str(&full).map_err(|e| {
        let labels: Vec<_> = e.labels().collect();
        let spans = labels.iter().map(|(span, _)| *span).collect();
        let mut message = e.message().to_string();
        if let Some((_, label)) = labels.first().filter(|(_, l)| !l.is_empty()) {
            message = format!("{message} ({label})");
        }
        locate(spans, one_line(&message))
    })?;
    for (handle, global) in module.global_variables.iter() {
        let Some(binding) = &global.binding else {
            continue;
        };
        let name = global.name.as_deref().unwrap_or("");
        let span = module.global_variables.get_span(handle);
        let declared_by_file = span.to_range().is_some_and(|r| user.contains(&r.start));
        if declared_by_file || !CONTRACT_BINDINGS.contains(&name) {
            return Err(locate(
                vec![span],
                format!(
                    "`{name}` at @group({}) @binding({}) is not a binding of the contract (version {CONTRACT_VERSION}): a file declares no bindings; read `frame`, `view`, `shadow_map` and `params` (docs/WGSL.md)",
                    binding.group, binding.binding
                ),
            ));
        }
    }
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .map_err(|e| {
        // Validation names the function, then what inside it is wrong: the narrowest span is
        // the most precise place.
        let mut spans: Vec<naga::Span> = e.spans().map(|(span, _)| *span).collect();
        spans.sort_by_key(|s| s.to_range().map_or(usize::MAX, |r| r.len()));
        let mut message = e.as_inner().to_string();
        let mut cause = std::error::Error::source(e.as_inner());
        while let Some(c) = cause {
            message.push_str(": ");
            message.push_str(&c.to_string());
            cause = c.source();
        }
        locate(spans, one_line(&message))
    })?;
    Ok(CompiledFile { module })
}

fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::{directives, WgslError};

    fn compile_text(source: &str) -> Result<(), WgslError> {
        // Every test file is a version 3 file (its directive last, so lines stay as written).
        let source = &format!("{source}\n// @contract 3\n");
        let directives = directives::parse("t.wgsl", source)?;
        super::compile("t.wgsl", source, &directives).map(|_| ())
    }

    fn example(name: &str) -> String {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/wgsl")
            .join(name);
        std::fs::read_to_string(path).unwrap()
    }

    #[test]
    fn the_examples_compile() {
        for name in ["pcf.wgsl", "pcss_like.wgsl", "one_tap.wgsl"] {
            compile_text(&example(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }

    #[test]
    fn a_syntax_error_is_one_line_with_the_files_line_and_column() {
        let source = "// @param r: f32 = 1.0 in 0.0..=2.0\n\nfn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    let x = params.r +;\n    return x;\n}\n";
        let message = compile_text(source).unwrap_err().to_string();
        assert!(message.starts_with("t.wgsl:4:23: "), "{message}");
        assert!(!message.contains('\n'), "{message}");
    }

    #[test]
    fn a_type_error_found_by_validation_names_the_files_line() {
        let source =
            "fn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    return s.light;\n}\n";
        let message = compile_text(source).unwrap_err().to_string();
        assert!(message.starts_with("t.wgsl:2:"), "{message}");
    }

    #[test]
    fn a_binding_of_its_own_is_refused_at_its_line_and_column() {
        let source = "@group(1) @binding(3) var<uniform> extra: vec4<f32>;\nfn visibility(s: Surface, pixel: vec2<i32>) -> f32 {\n    return extra.x;\n}\n";
        let message = compile_text(source).unwrap_err().to_string();
        assert!(message.starts_with("t.wgsl:1:"), "{message}");
        assert!(message.contains("@group(1) @binding(3)"), "{message}");
        assert!(
            message.contains("not a binding of the contract"),
            "{message}"
        );
        assert!(!message.contains('\n'), "{message}");
    }

    #[test]
    fn a_file_without_visibility_is_told_what_to_define() {
        let message = compile_text("fn other() -> f32 { return 1.0; }\n")
            .unwrap_err()
            .to_string();
        assert!(message.starts_with("t.wgsl:1:1: "), "{message}");
        assert!(message.contains("fn visibility(s: Surface"), "{message}");
    }

    #[test]
    fn params_are_four_byte_fields_padded_to_sixteen_bytes() {
        let directives = directives::parse(
            "t.wgsl",
            "// @param a: f32 = 1.0 in 0.0..=2.0\n// @param b: bool = true\n// @contract 3\n",
        )
        .unwrap();
        let text = super::params_struct(&directives);
        assert_eq!(
            text,
            "struct Params {\n    a: f32,\n    b: u32,\n    shadow_map_size: u32,\n    _padding0: u32,\n}\n"
        );
        let settings = crate::FileSettings::new(&directives);
        let bytes = settings.uniform_bytes();
        assert_eq!(bytes.len(), 16);
        assert_eq!(&bytes[0..4], &1.0f32.to_ne_bytes());
        assert_eq!(&bytes[4..8], &1u32.to_ne_bytes());
        assert_eq!(&bytes[8..12], &1024u32.to_ne_bytes());
    }
}
