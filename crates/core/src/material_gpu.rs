//! A scene's materials on the device ([`crate::SceneGpu::materials`]): texcoords and a material
//! index per vertex (a second vertex buffer beside [`crate::scene_gpu::Vertex`]), the material
//! table and every texture's texels in storage buffers, and their bind group, read by
//! `softshadow::material` (`shaders/common/material.wgsl`).
//!
//! Uploaded only for a scene with a masked or textured material ([`needed`]); every other scene
//! has none, and its passes run exactly as before materials existed: the same pipelines, no
//! texture bound.

use bytemuck::{Pod, Zeroable};
use encase::ShaderType;
use glam::Vec4;
use wgpu::util::DeviceExt;

use crate::{
    material::{Texture, TextureFilter},
    uniform::storage_bytes,
    Gpu, Scene,
};

/// The bind group index of `softshadow::material` in the depth pass (group 0 its views, 1 the
/// peeled layer).
pub const DEPTH_MATERIAL_GROUP: u32 = 2;

/// The depth pass's alpha-tested permutation (`shaders/core/depth.wgsl`).
pub const DEPTH_ALPHA_TEST: crate::shader::Permutation = &[
    ("ALPHA_TEST", crate::shader::DefValue::Bool(true)),
    (
        "MATERIAL_GROUP",
        crate::shader::DefValue::UInt(DEPTH_MATERIAL_GROUP),
    ),
];

/// The defs of a ray-query shader's alpha-tested permutation with the material group at
/// `group` (`ALPHA_TEST`, `MATERIAL_TRIANGLES`, `MATERIAL_GROUP`).
#[macro_export]
macro_rules! ray_alpha_test_defs {
    ($group:expr) => {
        &[
            ("ALPHA_TEST", $crate::shader::DefValue::Bool(true)),
            ("MATERIAL_TRIANGLES", $crate::shader::DefValue::Bool(true)),
            ("MATERIAL_GROUP", $crate::shader::DefValue::UInt($group)),
        ]
    };
}

/// A scene needs [`MaterialGpu`]: some instance's material is masked (cuts holes) or textured.
pub fn needed(scene: &Scene) -> bool {
    scene.has_masked_instances() || scene.has_textured_instances()
}

/// Per-vertex material attributes (vertex buffer slot 1, locations 3 and 4).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct MaterialVertex {
    /// Texcoord set 0.
    pub uv: [f32; 2],
    /// Row of the material table: 0 is "no material" (opaque, untextured), k + 1 is
    /// [`Scene::materials`]`[k]`.
    pub material: u32,
}

impl MaterialVertex {
    /// Locations 3 (texcoord) and 4 (material row).
    pub const ATTRIBUTES: [wgpu::VertexAttribute; 2] =
        wgpu::vertex_attr_array![3 => Float32x2, 4 => Uint32];

    /// The layout of slot 1.
    pub fn layout() -> wgpu::VertexBufferLayout<'static> {
        wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<MaterialVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &Self::ATTRIBUTES,
        }
    }
}

/// One row of the material table (`MaterialEntry` in `softshadow::material`).
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub struct MaterialEntry {
    /// Linear RGBA factor.
    pub base_color: Vec4,
    /// Alpha below which a texel is a hole; negative for an opaque material.
    pub cutoff: f32,
    /// First texel of the texture in the texel buffer.
    pub texel_offset: u32,
    /// Texture width; 0 without a texture.
    pub width: u32,
    /// Texture height.
    pub height: u32,
    /// Wrap along u (0 repeat, 1 clamp to edge, 2 mirrored repeat).
    pub wrap_u: u32,
    /// Wrap along v.
    pub wrap_v: u32,
    /// 0 nearest, 1 linear.
    pub filtering: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// The material data of one uploaded scene.
pub struct MaterialGpu {
    /// [`MaterialVertex`] per scene vertex, in the order of [`crate::SceneGpu::vertices`].
    pub vertices: wgpu::Buffer,
    /// The material table (row 0: no material).
    pub table: wgpu::Buffer,
    /// Every texture's RGBA8 texels, one `u32` each.
    pub texels: wgpu::Buffer,
    /// Some caster is masked: light-space passes take their alpha-test variants.
    pub masked_casters: bool,
    /// Some instance is masked: the G-buffer tests alpha.
    pub masked: bool,
    /// Textures halved to fit the device, one line each (also logged).
    pub warnings: Vec<String>,
    layout: wgpu::BindGroupLayout,
    group: wgpu::BindGroup,
}

impl MaterialGpu {
    /// The bind group layout of `softshadow::material` (binding 0 the table, 1 the texels;
    /// fragment and compute stages).
    pub fn layout_of(gpu: &Gpu) -> wgpu::BindGroupLayout {
        Self::layout_with(gpu, 2)
    }

    /// The layout of `softshadow::material` with `MATERIAL_TRIANGLES` (ray queries): bindings 2
    /// to 4 the material vertices and the static and dynamic caster indices.
    pub fn triangles_layout_of(gpu: &Gpu) -> wgpu::BindGroupLayout {
        Self::layout_with(gpu, 5)
    }

    fn layout_with(gpu: &Gpu, bindings: u32) -> wgpu::BindGroupLayout {
        let entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        gpu.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("core/material"),
                entries: &(0..bindings).map(entry).collect::<Vec<_>>(),
            })
    }

    /// Uploads the material data of `scene`; `vertices` are its [`MaterialVertex`]es in the
    /// order [`crate::SceneGpu`] baked them.
    pub fn upload(gpu: &Gpu, scene: &Scene, vertices: &[MaterialVertex]) -> Self {
        let limits = gpu.device.limits();
        let mut warnings = Vec::new();
        let textures: Vec<Texture> = scene
            .textures
            .iter()
            .map(|t| {
                let (fitted, warning) = fit_texture(t, limits.max_texture_dimension_2d);
                warnings.extend(warning);
                fitted
            })
            .collect();
        for w in &warnings {
            log::warn!("{w}");
        }
        let mut texels: Vec<u32> = Vec::new();
        let mut offsets = Vec::new();
        for t in &textures {
            offsets.push(texels.len() as u32);
            texels.extend(
                t.rgba8
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])),
            );
        }
        if texels.is_empty() {
            texels.push(0);
        }
        let mut table = vec![MaterialEntry {
            base_color: Vec4::ONE,
            cutoff: -1.0,
            ..Default::default()
        }];
        for m in &scene.materials {
            let mut row = MaterialEntry {
                base_color: m.base_color,
                cutoff: m.alpha_mode.effective_cutoff().unwrap_or(-1.0),
                ..Default::default()
            };
            if let Some(t) = m.base_color_texture.filter(|&t| t < textures.len()) {
                let texture = &textures[t];
                row.texel_offset = offsets[t];
                row.width = texture.width;
                row.height = texture.height;
                row.wrap_u = texture.wrap[0] as u32;
                row.wrap_v = texture.wrap[1] as u32;
                row.filtering = (texture.filter == TextureFilter::Linear) as u32;
            }
            table.push(row);
        }
        let device = &gpu.device;
        let storage = |label: &str, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let table = storage("scene materials", &storage_bytes(&table));
        let texels = storage("scene texels", bytemuck::cast_slice(&texels));
        let vertex_bytes: &[u8] = if vertices.is_empty() {
            &[0u8; 12]
        } else {
            bytemuck::cast_slice(vertices)
        };
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("scene material vertices"),
            contents: vertex_bytes,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
        });
        let layout = Self::layout_of(gpu);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/material"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: table.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: texels.as_entire_binding(),
                },
            ],
        });
        Self {
            vertices,
            table,
            texels,
            masked_casters: scene.has_masked_casters(),
            masked: scene.has_masked_instances(),
            warnings,
            layout,
            group,
        }
    }

    /// The bind group of `softshadow::material`.
    pub fn group(&self) -> &wgpu::BindGroup {
        &self.group
    }

    /// Its layout.
    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// The `MATERIAL_TRIANGLES` group ([`Self::triangles_layout_of`]) over `scene`'s caster
    /// lists: what a ray query's candidate loop reads to test alpha at a hit.
    pub fn triangles_group(&self, gpu: &Gpu, scene: &crate::SceneGpu) -> wgpu::BindGroup {
        // An empty list is never read (no BLAS refers to it): any buffer stands in.
        let static_list = scene
            .static_casters
            .as_ref()
            .map_or(&self.texels, |l| &l.buffer);
        let dynamic_list = scene
            .dynamic_casters
            .as_ref()
            .map_or(&self.texels, |l| &l.buffer);
        let resources = [
            self.table.as_entire_binding(),
            self.texels.as_entire_binding(),
            self.vertices.as_entire_binding(),
            static_list.as_entire_binding(),
            dynamic_list.as_entire_binding(),
        ];
        let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
            .into_iter()
            .enumerate()
            .map(|(k, resource)| wgpu::BindGroupEntry {
                binding: k as u32,
                resource,
            })
            .collect();
        gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("core/material triangles"),
            layout: &Self::triangles_layout_of(gpu),
            entries: &entries,
        })
    }
}

/// `texture` halved (2 x 2 box filter) until both sides are at most `max_side`, with a warning
/// saying so; unchanged and no warning when it fits.
pub fn fit_texture(texture: &Texture, max_side: u32) -> (Texture, Option<String>) {
    let mut t = texture.clone();
    let max_side = max_side.max(1);
    while t.width > max_side || t.height > max_side {
        t = halve(&t);
    }
    let warning = (t.width != texture.width || t.height != texture.height).then(|| {
        format!(
            "texture `{}` is {}x{}, over the device's {max_side}-texel limit: downscaled to {}x{}",
            texture.name, texture.width, texture.height, t.width, t.height
        )
    });
    (t, warning)
}

/// One 2 x 2 box-filter step (odd sides keep their last row / column's weight by clamping).
fn halve(t: &Texture) -> Texture {
    let (w, h) = ((t.width / 2).max(1), (t.height / 2).max(1));
    let mut rgba8 = Vec::with_capacity((w * h * 4) as usize);
    let at = |x: u32, y: u32, c: usize| {
        let (x, y) = (x.min(t.width - 1), y.min(t.height - 1));
        t.rgba8[4 * (y * t.width + x) as usize + c] as u32
    };
    for y in 0..h {
        for x in 0..w {
            for c in 0..4 {
                let sum = at(2 * x, 2 * y, c)
                    + at(2 * x + 1, 2 * y, c)
                    + at(2 * x, 2 * y + 1, c)
                    + at(2 * x + 1, 2 * y + 1, c);
                rgba8.push(((sum + 2) / 4) as u8);
            }
        }
    }
    Texture {
        width: w,
        height: h,
        rgba8,
        ..t.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_texture_over_the_limit_is_halved_until_it_fits_and_says_so() {
        let t = Texture {
            name: "big".into(),
            width: 8,
            height: 2,
            rgba8: vec![200; 64],
            wrap: Default::default(),
            filter: Default::default(),
        };
        let (fitted, warning) = fit_texture(&t, 3);
        assert_eq!((fitted.width, fitted.height), (2, 1));
        assert_eq!(fitted.rgba8, vec![200; 8]);
        assert!(warning.unwrap().contains("downscaled to 2x1"));
        let (same, none) = fit_texture(&t, 8);
        assert_eq!(same, t);
        assert!(none.is_none());
    }
}
