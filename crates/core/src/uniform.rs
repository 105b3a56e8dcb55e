//! The bytes of the structs the shaders read, as WGSL lays them out.
//!
//! A uniform (or a storage struct the CPU writes or reads) is declared once, in Rust, with
//! `#[derive(encase::ShaderType)]`, glam's vectors and matrices for WGSL's: encase places every
//! field where WGSL puts it (a `vec4` on 16 bytes, the struct's size rounded up to its alignment)
//! and writes zeros in between, so no struct carries padding written by hand. The WGSL struct
//! lists the same fields; `tests/shaders.rs` compares the two layouts
//! ([`shader::uniform_layout`](crate::shader::uniform_layout)).

use encase::{internal::WriteInto, ShaderType, StorageBuffer, UniformBuffer};
use wgpu::util::DeviceExt;

use crate::Gpu;

/// The bytes of `value` in a uniform buffer: `T::min_size()` bytes, padding zeroed.
pub fn uniform_bytes<T: ShaderType + WriteInto>(value: &T) -> Vec<u8> {
    let mut buffer = UniformBuffer::new(Vec::new());
    buffer
        .write(value)
        .expect("a Vec<u8> grows to the struct's size");
    buffer.into_inner()
}

/// The bytes of `value` in a storage buffer, padding zeroed: a struct, or a slice of them as
/// `array<T>`, which is also a uniform `array<T, N>` (the same stride; naga's validation requires
/// it to be a multiple of 16 there).
pub fn storage_bytes<T: ?Sized + ShaderType + WriteInto>(value: &T) -> Vec<u8> {
    let mut buffer = StorageBuffer::new(Vec::new());
    buffer
        .write(value)
        .expect("a Vec<u8> grows to the value's size");
    buffer.into_inner()
}

/// The size of `T` in a buffer, as a shader sees it (the binding size of one `T`).
pub fn uniform_size<T: ShaderType>() -> u64 {
    T::min_size().get()
}

/// A uniform buffer holding `value`, writable later with `queue.write_buffer` and
/// [`uniform_bytes`].
pub fn uniform_buffer<T: ShaderType + WriteInto>(
    gpu: &Gpu,
    label: &str,
    value: &T,
) -> wgpu::Buffer {
    gpu.device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &uniform_bytes(value),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        })
}

/// A uniform buffer of one `T`, zeroed (wgpu zeroes new buffers) until written with
/// `queue.write_buffer` and [`uniform_bytes`].
pub fn zeroed_uniform_buffer<T: ShaderType>(gpu: &Gpu, label: &str) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: uniform_size::<T>(),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec2, Vec4};

    #[derive(ShaderType)]
    struct Scalars {
        count: u32,
        scale: f32,
    }

    #[derive(ShaderType)]
    struct Mixed {
        matrix: Mat4,
        count: u32,
        half: Vec2,
        colour: Vec4,
    }

    #[test]
    fn fields_land_where_wgsl_puts_them_with_zeroed_padding() {
        // WGSL: matrix at 0, count at 64, vec2 aligned to 8 (72), vec4 aligned to 16 (80);
        // size 96.
        let bytes = uniform_bytes(&Mixed {
            matrix: Mat4::from_cols_array(&[1.0; 16]),
            count: 7,
            half: Vec2::new(2.0, 3.0),
            colour: Vec4::splat(4.0),
        });
        assert_eq!(bytes.len(), 96);
        assert_eq!(&bytes[64..68], &7u32.to_le_bytes());
        assert_eq!(&bytes[68..72], &[0; 4], "padding before the vec2 is zero");
        assert_eq!(&bytes[72..76], &2f32.to_le_bytes());
        assert_eq!(&bytes[80..84], &4f32.to_le_bytes());
        assert_eq!(uniform_size::<Mixed>(), 96);
    }

    #[test]
    fn a_struct_of_scalars_is_not_rounded_to_sixteen_bytes() {
        // WGSL rounds a struct to its alignment (4 here), not to 16, in a uniform buffer too.
        let bytes = uniform_bytes(&Scalars {
            count: 3,
            scale: 0.5,
        });
        assert_eq!(bytes, [3u32.to_le_bytes(), 0.5f32.to_le_bytes()].concat());
    }

    #[test]
    fn a_slice_is_an_array_of_structs() {
        let items = [
            Scalars {
                count: 1,
                scale: 1.0,
            },
            Scalars {
                count: 2,
                scale: 2.0,
            },
        ];
        let bytes = storage_bytes(&items[..]);
        assert_eq!(bytes.len(), 16);
        assert_eq!(&bytes[8..12], &2u32.to_le_bytes());
    }
}
