#define_import_path softshadow::material

// Materials on the GPU (softshadow_core::material, SceneGpu::materials): the scene's material
// table and every texture's texels in two storage buffers, bound as group MATERIAL_GROUP of the
// passes that test alpha or read albedo. Present only in scenes with a masked or textured
// material; every other scene runs the passes without this module.
//
// Textures are sampled here by hand (textureLoad-free: texels are packed RGBA8 words) so that the
// rasterised passes, the ray queries and the CPU ray cast (Texture::sample, the same f32 steps)
// see the same texel at the same texcoord: nearest or bilinear by the texture's filter, its wrap
// per axis, no mipmaps (glTF 2.0 section 3.8.4, samplers; section 3.9.4, alpha coverage).

struct MaterialEntry {
    base_color: vec4<f32>,
    // Alpha below this is a hole; negative for an opaque material (nothing is cut).
    cutoff: f32,
    // First texel of its texture in `texels`, and its size; width 0: no texture.
    texel_offset: u32,
    width: u32,
    height: u32,
    // TextureWrap (0 repeat, 1 clamp to edge, 2 mirrored repeat) along u and v; TextureFilter
    // (0 nearest, 1 linear).
    wrap_u: u32,
    wrap_v: u32,
    filtering: u32,
    pad: u32,
}

@group(#{MATERIAL_GROUP}) @binding(0) var<storage, read> materials: array<MaterialEntry>;
@group(#{MATERIAL_GROUP}) @binding(1) var<storage, read> texels: array<u32>;

fn wrap_index(i: i32, n: u32, mode: u32) -> u32 {
    let m = i32(max(n, 1u));
    if mode == 1u {
        return u32(clamp(i, 0, m - 1));
    }
    if mode == 2u {
        let k = ((i % (2 * m)) + 2 * m) % (2 * m);
        return u32(select(2 * m - 1 - k, k, k < m));
    }
    return u32(((i % m) + m) % m);
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        return c / 12.92;
    }
    return pow((c + 0.055) / 1.055, 2.4);
}

// Texel (x, y) of `m`'s texture, wrapped, as linear RGB and alpha.
fn texel(m: MaterialEntry, x: i32, y: i32) -> vec4<f32> {
    let tx = wrap_index(x, m.width, m.wrap_u);
    let ty = wrap_index(y, m.height, m.wrap_v);
    let c = unpack4x8unorm(texels[m.texel_offset + ty * m.width + tx]);
    return vec4<f32>(srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b), c.a);
}

fn sample_texture(m: MaterialEntry, uv: vec2<f32>) -> vec4<f32> {
    let p = uv * vec2<f32>(f32(m.width), f32(m.height));
    if m.filtering == 0u {
        let i = floor(p);
        return texel(m, i32(i.x), i32(i.y));
    }
    let q = p - vec2<f32>(0.5);
    let i = floor(q);
    let f = q - i;
    let x = i32(i.x);
    let y = i32(i.y);
    let top = mix(texel(m, x, y), texel(m, x + 1, y), f.x);
    let bottom = mix(texel(m, x, y + 1), texel(m, x + 1, y + 1), f.x);
    return mix(top, bottom, f.y);
}

// The base colour of material `index` (0 is the table's "no material": white, opaque) at
// texcoord `uv`, linear RGBA.
fn base_color(index: u32, uv: vec2<f32>) -> vec4<f32> {
    let m = materials[index];
    if m.width == 0u {
        return m.base_color;
    }
    return m.base_color * sample_texture(m, uv);
}

// Whether the surface of material `index` is there at `uv` (not cut away by its alpha mask).
fn alpha_passes(index: u32, uv: vec2<f32>) -> bool {
    let m = materials[index];
    if m.cutoff < 0.0 {
        return true;
    }
    return base_color(index, uv).a >= m.cutoff;
}

#ifdef MATERIAL_TRIANGLES
// For ray queries (SceneGpu::material_triangles_group): a candidate hit's triangle, found by its
// primitive index in the caster list its BLAS was built from (the TLAS instance's custom data,
// softshadow_core::accel::BLAS_STATIC / BLAS_DYNAMIC), its texcoords interpolated with the hit's
// barycentrics, and the alpha test of its material there.
// Per scene vertex: texcoord u, v (f32 bits) and the material row (MaterialVertex).
@group(#{MATERIAL_GROUP}) @binding(2) var<storage, read> material_vertices: array<u32>;
@group(#{MATERIAL_GROUP}) @binding(3) var<storage, read> static_casters: array<u32>;
@group(#{MATERIAL_GROUP}) @binding(4) var<storage, read> dynamic_casters: array<u32>;

fn caster_index(custom_data: u32, k: u32) -> u32 {
    if custom_data == 0u {
        return static_casters[k];
    }
    return dynamic_casters[k];
}

fn vertex_uv(v: u32) -> vec2<f32> {
    return vec2<f32>(bitcast<f32>(material_vertices[3u * v]), bitcast<f32>(material_vertices[3u * v + 1u]));
}

// Whether the surface is there at a candidate hit: `barycentrics` are the weights of the
// triangle's second and third vertex.
fn candidate_solid(custom_data: u32, primitive: u32, barycentrics: vec2<f32>) -> bool {
    let i0 = caster_index(custom_data, 3u * primitive);
    let i1 = caster_index(custom_data, 3u * primitive + 1u);
    let i2 = caster_index(custom_data, 3u * primitive + 2u);
    let material = material_vertices[3u * i0 + 2u];
    let w = vec3<f32>(1.0 - barycentrics.x - barycentrics.y, barycentrics);
    let uv = vertex_uv(i0) * w.x + vertex_uv(i1) * w.y + vertex_uv(i2) * w.z;
    return alpha_passes(material, uv);
}
#endif
