//! Host twins of the std430 structs in `shaders-glsl/common/scene.glsl`, declared once here.

use bytemuck::{Pod, Zeroable};

/// `struct Vertex`: position.w = instance index, normal.w = material index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    pub position: [f32; 4],
    pub normal: [f32; 4],
}

/// `struct Object`: model matrix and its inverse transpose (column-major).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuObject {
    pub model: [f32; 16],
    pub normal_matrix: [f32; 16],
}

/// `struct Material`: diffuse.rgb = ρ_d; specular.rgb = k_s, specular.w = exponent s.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    pub diffuse: [f32; 4],
    pub specular: [f32; 4],
}

/// `struct FrameData` (see the GLSL for the meaning of each lane).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct FrameData {
    pub eye: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub forward: [f32; 4],
    pub params: [f32; 4],
    pub size: [u32; 4],
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::mem::{offset_of, size_of};

    // std430 offsets as declared in shaders-glsl/common/scene.glsl.
    #[test]
    fn std430_layouts() {
        assert_eq!(size_of::<GpuVertex>(), 32);
        assert_eq!(offset_of!(GpuVertex, normal), 16);
        assert_eq!(size_of::<GpuObject>(), 128);
        assert_eq!(offset_of!(GpuObject, normal_matrix), 64);
        assert_eq!(size_of::<GpuMaterial>(), 32);
        assert_eq!(size_of::<FrameData>(), 96);
        assert_eq!(offset_of!(FrameData, params), 64);
        assert_eq!(offset_of!(FrameData, size), 80);
    }
}
