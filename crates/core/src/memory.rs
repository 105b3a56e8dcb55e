//! GPU memory held on a device: the bytes of buffers, textures and acceleration structures,
//! counted where they are allocated. wgpu-hal adds an allocation's size to its counters when it
//! binds memory to a resource and subtracts it when the resource is destroyed (wgpu's `counters`
//! feature, on in this workspace); [`Gpu::memory_in_use`] reads them. So every buffer and
//! texture a technique creates is counted, whoever's code creates it, with the size the driver
//! asked for (alignment and padding included), and nothing has to be routed through a wrapper.
//! Acceleration structures are counted only where wgpu-hal counts them: DX12 in wgpu 30, not
//! Vulkan (docs/DEVICES.md), so ray-traced techniques' BLAS and TLAS are missing there.
//!
//! What a technique holds is the difference from a baseline read before it was created
//! ([`MemoryUse::since`]); a frame's peak is the largest value read after each of its passes
//! ([`crate::Frame`]). A dropped resource is freed when the device is next polled, so callers
//! poll ([`Gpu::wait_idle`]) before a baseline.

use serde::{Deserialize, Serialize};

use crate::Gpu;

/// Bytes of GPU memory, by kind of resource.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MemoryUse {
    /// Buffers (uniforms, storage, vertex and index, staging).
    pub buffers: u64,
    /// Textures (render targets, shadow maps, hierarchies, history).
    pub textures: u64,
    /// Acceleration structures (ray queries).
    pub acceleration_structures: u64,
}

impl MemoryUse {
    /// All kinds together.
    pub fn total(&self) -> u64 {
        self.buffers + self.textures + self.acceleration_structures
    }

    /// What was added since `baseline`, per kind (0 where less is held now).
    pub fn since(&self, baseline: MemoryUse) -> MemoryUse {
        MemoryUse {
            buffers: self.buffers.saturating_sub(baseline.buffers),
            textures: self.textures.saturating_sub(baseline.textures),
            acceleration_structures: self
                .acceleration_structures
                .saturating_sub(baseline.acceleration_structures),
        }
    }

    /// The larger of the two by [`MemoryUse::total`].
    pub fn max_by_total(self, other: MemoryUse) -> MemoryUse {
        if other.total() > self.total() {
            other
        } else {
            self
        }
    }

    /// The total in MiB (for tables).
    pub fn total_mib(&self) -> f64 {
        self.total() as f64 / (1024.0 * 1024.0)
    }
}

impl Gpu {
    /// The GPU memory the device holds now. All zero on a backend whose wgpu-hal keeps no
    /// counters (every Vulkan, Metal and DX12 device keeps them; GL does not):
    /// [`Gpu::counts_memory`] tells.
    pub fn memory_in_use(&self) -> MemoryUse {
        let hal = self.device.get_internal_counters().hal;
        let bytes = |v: isize| v.max(0) as u64;
        MemoryUse {
            buffers: bytes(hal.buffer_memory.read()),
            textures: bytes(hal.texture_memory.read()),
            acceleration_structures: bytes(hal.acceleration_structure_memory.read()),
        }
    }

    /// Whether [`Gpu::memory_in_use`] counts anything on this device (every device holds some
    /// buffer once a scene is uploaded; a backend without counters reports none).
    pub fn counts_memory(&self) -> bool {
        self.memory_in_use().total() > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn since_and_max_work_per_kind_and_by_total() {
        let a = MemoryUse {
            buffers: 10,
            textures: 100,
            acceleration_structures: 0,
        };
        let b = MemoryUse {
            buffers: 30,
            textures: 50,
            acceleration_structures: 5,
        };
        assert_eq!(
            b.since(a),
            MemoryUse {
                buffers: 20,
                textures: 0,
                acceleration_structures: 5
            }
        );
        assert_eq!(a.max_by_total(b), a);
        assert_eq!(b.max_by_total(a), a);
        assert_eq!(a.total(), 110);
    }
}
