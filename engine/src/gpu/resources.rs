//! Buffers and images as `{ raw, desc, allocation }`, destroyed by value.

use super::{Gpu, GpuError, Result, VkCheck};
use ash::vk;
use gpu_allocator::vulkan::Allocation;
use gpu_allocator::MemoryLocation;

/// Where a buffer lives.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Memory {
    GpuOnly,
    Upload,
    Readback,
}

/// A buffer's description: small, `Copy`, with intention-named constructors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferDesc {
    pub size: u64,
    pub usage: vk::BufferUsageFlags,
    pub memory: Memory,
}

impl BufferDesc {
    /// Device-local storage buffer (also a copy source and destination).
    pub fn gpu_only(size: u64) -> Self {
        Self {
            size,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            memory: Memory::GpuOnly,
        }
    }
    /// Device-local index buffer that is also a storage buffer.
    pub fn index(size: u64) -> Self {
        let mut d = Self::gpu_only(size);
        d.usage |= vk::BufferUsageFlags::INDEX_BUFFER;
        d
    }
    /// Host-visible buffer the CPU writes and the GPU reads.
    pub fn upload(size: u64) -> Self {
        Self {
            size,
            usage: vk::BufferUsageFlags::TRANSFER_SRC | vk::BufferUsageFlags::STORAGE_BUFFER,
            memory: Memory::Upload,
        }
    }
    /// Host-visible buffer the GPU writes and the CPU reads.
    pub fn readback(size: u64) -> Self {
        Self {
            size,
            usage: vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::STORAGE_BUFFER,
            memory: Memory::Readback,
        }
    }
}

pub struct Buffer {
    pub raw: vk::Buffer,
    pub desc: BufferDesc,
    allocation: Option<Allocation>,
}

/// Image formats the engine uses (each with a GLSL format qualifier where it is a storage image).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ImageFormat {
    Rgba32f,
    Rgba16f,
    Rgba8Unorm,
    Depth32f,
}

impl ImageFormat {
    pub fn vk(self) -> vk::Format {
        match self {
            Self::Rgba32f => vk::Format::R32G32B32A32_SFLOAT,
            Self::Rgba16f => vk::Format::R16G16B16A16_SFLOAT,
            Self::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
            Self::Depth32f => vk::Format::D32_SFLOAT,
        }
    }
    pub fn bytes_per_texel(self) -> u64 {
        match self {
            Self::Rgba32f => 16,
            Self::Rgba16f => 8,
            Self::Rgba8Unorm | Self::Depth32f => 4,
        }
    }
    fn aspect(self) -> vk::ImageAspectFlags {
        if self == Self::Depth32f {
            vk::ImageAspectFlags::DEPTH
        } else {
            vk::ImageAspectFlags::COLOR
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageDesc {
    pub width: u32,
    pub height: u32,
    pub format: ImageFormat,
    pub usage: vk::ImageUsageFlags,
}

impl ImageDesc {
    /// A colour target written by raster or compute and read by compute: storage + attachment + copies.
    pub fn target(width: u32, height: u32, format: ImageFormat) -> Self {
        let mut usage = vk::ImageUsageFlags::TRANSFER_SRC | vk::ImageUsageFlags::TRANSFER_DST;
        if format == ImageFormat::Depth32f {
            usage |= vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        } else {
            usage |= vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::COLOR_ATTACHMENT;
        }
        Self { width, height, format, usage }
    }
    /// A texture sampled by shaders, filled by upload.
    pub fn texture(width: u32, height: u32, format: ImageFormat) -> Self {
        Self {
            width,
            height,
            format,
            usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::TRANSFER_SRC,
        }
    }
}

/// An image, always in `GENERAL` layout once created (simple, and valid for every use here).
pub struct Image {
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub desc: ImageDesc,
    allocation: Option<Allocation>,
}

impl Image {
    pub fn byte_size(&self) -> u64 {
        self.desc.width as u64 * self.desc.height as u64 * self.desc.format.bytes_per_texel()
    }
}

impl Buffer {
    /// Write `data` at the start of a host-visible buffer.
    pub fn write<T: bytemuck::Pod>(&mut self, data: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let Some(slice) = self.allocation.as_mut().and_then(|a| a.mapped_slice_mut()) else {
            return Err(GpuError::Other("write to a buffer that is not host visible".into()));
        };
        if bytes.len() > slice.len() {
            return Err(GpuError::Other(format!("write of {} bytes into a {}-byte buffer", bytes.len(), slice.len())));
        }
        slice[..bytes.len()].copy_from_slice(bytes);
        Ok(())
    }
    /// Read the whole host-visible buffer as `T`s.
    pub fn read<T: bytemuck::Pod>(&self) -> Result<Vec<T>> {
        let Some(slice) = self.allocation.as_ref().and_then(|a| a.mapped_slice()) else {
            return Err(GpuError::Other("read from a buffer that is not host visible".into()));
        };
        let n = self.desc.size as usize / std::mem::size_of::<T>();
        Ok(bytemuck::pod_collect_to_vec(&slice[..n * std::mem::size_of::<T>()]))
    }
}

impl Gpu {
    pub fn create_buffer(&self, name: &str, desc: BufferDesc) -> Result<Buffer> {
        let size = desc.size.max(16);
        let info = vk::BufferCreateInfo::default().size(size).usage(desc.usage);
        // SAFETY: valid device and create info.
        let raw = unsafe { self.device.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: raw was just created from this device.
        let req = unsafe { self.device.get_buffer_memory_requirements(raw) };
        let location = match desc.memory {
            Memory::GpuOnly => MemoryLocation::GpuOnly,
            Memory::Upload => MemoryLocation::CpuToGpu,
            Memory::Readback => MemoryLocation::GpuToCpu,
        };
        let allocation = match self.allocate(name, req, location, true) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unused buffer from this device.
                unsafe { self.device.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        // SAFETY: memory from the allocator fits the requirements of raw.
        if let Err(e) = unsafe { self.device.bind_buffer_memory(raw, allocation.memory(), allocation.offset()) } {
            // SAFETY: unused buffer from this device.
            unsafe { self.device.destroy_buffer(raw, None) };
            self.free(allocation);
            return Err(GpuError::Vk { call: "vkBindBufferMemory", result: e });
        }
        self.set_name(raw, name);
        Ok(Buffer { raw, desc: BufferDesc { size, ..desc }, allocation: Some(allocation) })
    }

    pub fn destroy_buffer(&self, mut buffer: Buffer) {
        self.drain();
        // SAFETY: the caller hands the buffer over by value after the GPU finished with it.
        unsafe { self.device.destroy_buffer(buffer.raw, None) };
        if let Some(a) = buffer.allocation.take() {
            self.free(a);
        }
    }

    /// A device-local buffer filled with `data` through a staging buffer.
    pub fn upload_buffer<T: bytemuck::Pod>(&self, name: &str, mut desc: BufferDesc, data: &[T]) -> Result<Buffer> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        desc.size = desc.size.max(bytes.len() as u64);
        let buffer = self.create_buffer(name, desc)?;
        if !bytes.is_empty() {
            if let Err(e) = self.copy_to_buffer(&buffer, bytes) {
                self.destroy_buffer(buffer);
                return Err(e);
            }
        }
        Ok(buffer)
    }

    /// Copy bytes into a (device-local) buffer through a temporary staging buffer, and wait.
    pub fn copy_to_buffer(&self, buffer: &Buffer, bytes: &[u8]) -> Result<()> {
        let mut staging = self.create_buffer("staging", BufferDesc::upload(bytes.len() as u64))?;
        let result = staging.write(bytes).and_then(|_| {
            self.submit_and_wait_labeled("a buffer upload", |cmd| {
                let region = vk::BufferCopy::default().size(bytes.len() as u64);
                // SAFETY: both buffers are alive until the wait returns.
                unsafe { self.device.cmd_copy_buffer(cmd, staging.raw, buffer.raw, &[region]) };
            })
        });
        self.destroy_buffer(staging);
        result
    }

    /// Read a device-local buffer back to the host, as `T`s.
    pub fn read_buffer<T: bytemuck::Pod>(&self, buffer: &Buffer) -> Result<Vec<T>> {
        let readback = self.create_buffer("readback", BufferDesc::readback(buffer.desc.size))?;
        let result = self
            .submit_and_wait_labeled("a buffer readback", |cmd| {
                let region = vk::BufferCopy::default().size(buffer.desc.size);
                // SAFETY: both buffers are alive until the wait returns.
                unsafe { self.device.cmd_copy_buffer(cmd, buffer.raw, readback.raw, &[region]) };
            })
            .and_then(|_| readback.read::<T>());
        self.destroy_buffer(readback);
        result
    }

    pub fn create_image(&self, name: &str, desc: ImageDesc) -> Result<Image> {
        if desc.width == 0 || desc.height == 0 {
            return Err(GpuError::Other(format!("image '{name}' has zero size {}x{}", desc.width, desc.height)));
        }
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format.vk())
            .extent(vk::Extent3D { width: desc.width, height: desc.height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid device and create info.
        let raw = unsafe { self.device.create_image(&info, None) }.vk("vkCreateImage")?;
        // SAFETY: raw was just created from this device.
        let req = unsafe { self.device.get_image_memory_requirements(raw) };
        let allocation = match self.allocate(name, req, MemoryLocation::GpuOnly, false) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: unused image from this device.
                unsafe { self.device.destroy_image(raw, None) };
                return Err(e);
            }
        };
        let range =
            vk::ImageSubresourceRange::default().aspect_mask(desc.format.aspect()).level_count(1).layer_count(1);
        // SAFETY: memory from the allocator fits raw's requirements; the view matches the image.
        let view = unsafe {
            self.device
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
                .vk("vkBindImageMemory")
                .and_then(|_| {
                    self.device
                        .create_image_view(
                            &vk::ImageViewCreateInfo::default()
                                .image(raw)
                                .view_type(vk::ImageViewType::TYPE_2D)
                                .format(desc.format.vk())
                                .subresource_range(range),
                            None,
                        )
                        .vk("vkCreateImageView")
                })
        };
        let view = match view {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: unused image from this device.
                unsafe { self.device.destroy_image(raw, None) };
                self.free(allocation);
                return Err(e);
            }
        };
        self.set_name(raw, name);
        let image = Image { raw, view, desc, allocation: Some(allocation) };
        // Move to GENERAL once; every later use keeps it there.
        let label = format!("the first layout transition of image '{name}'");
        if let Err(e) = self.submit_and_wait_labeled(&label, |cmd| self.cmd_transition_to_general(cmd, &image)) {
            self.destroy_image(image);
            return Err(e);
        }
        Ok(image)
    }

    pub(crate) fn cmd_transition_to_general(&self, cmd: vk::CommandBuffer, image: &Image) {
        let barrier = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::GENERAL)
            .image(image.raw)
            .subresource_range(
                vk::ImageSubresourceRange::default()
                    .aspect_mask(image.desc.format.aspect())
                    .level_count(1)
                    .layer_count(1),
            );
        let barriers = [barrier];
        // SAFETY: cmd is recording; image is alive.
        unsafe {
            self.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().image_memory_barriers(&barriers))
        };
    }

    pub fn destroy_image(&self, mut image: Image) {
        self.drain();
        // SAFETY: the caller hands the image over by value after the GPU finished with it.
        unsafe {
            self.device.destroy_image_view(image.view, None);
            self.device.destroy_image(image.raw, None);
        }
        if let Some(a) = image.allocation.take() {
            self.free(a);
        }
    }

    fn image_copy_region(image: &Image) -> vk::BufferImageCopy {
        vk::BufferImageCopy::default()
            .image_subresource(
                vk::ImageSubresourceLayers::default().aspect_mask(image.desc.format.aspect()).layer_count(1),
            )
            .image_extent(vk::Extent3D { width: image.desc.width, height: image.desc.height, depth: 1 })
    }

    /// A sampled texture filled with tightly packed texels.
    pub fn upload_image(&self, name: &str, desc: ImageDesc, bytes: &[u8]) -> Result<Image> {
        let image = self.create_image(name, desc)?;
        if bytes.len() as u64 != image.byte_size() {
            let n = image.byte_size();
            self.destroy_image(image);
            return Err(GpuError::Other(format!("image '{name}': {} bytes given, {n} expected", bytes.len())));
        }
        let mut staging = self.create_buffer("staging-image", BufferDesc::upload(bytes.len() as u64))?;
        let label = format!("the upload of image '{name}'");
        let r = staging.write(bytes).and_then(|_| {
            self.submit_and_wait_labeled(&label, |cmd| {
                let region = Self::image_copy_region(&image);
                // SAFETY: buffer and image alive until the wait; image in GENERAL.
                unsafe {
                    self.device.cmd_copy_buffer_to_image(
                        cmd,
                        staging.raw,
                        image.raw,
                        vk::ImageLayout::GENERAL,
                        &[region],
                    )
                };
            })
        });
        self.destroy_buffer(staging);
        match r {
            Ok(()) => Ok(image),
            Err(e) => {
                self.destroy_image(image);
                Err(e)
            }
        }
    }

    /// Read an image back as raw bytes (tightly packed rows).
    pub fn read_image_bytes(&self, image: &Image) -> Result<Vec<u8>> {
        let readback = self.create_buffer("readback-image", BufferDesc::readback(image.byte_size()))?;
        let r = self
            .submit_and_wait_labeled("an image readback", |cmd| {
                let barrier = [vk::MemoryBarrier2::default()
                    .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                    .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                    .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                    .dst_access_mask(vk::AccessFlags2::MEMORY_READ)];
                let region = Self::image_copy_region(image);
                // SAFETY: buffer and image alive until the wait; image in GENERAL.
                unsafe {
                    self.device.cmd_pipeline_barrier2(cmd, &vk::DependencyInfo::default().memory_barriers(&barrier));
                    self.device.cmd_copy_image_to_buffer(
                        cmd,
                        image.raw,
                        vk::ImageLayout::GENERAL,
                        readback.raw,
                        &[region],
                    )
                };
            })
            .and_then(|_| readback.read::<u8>());
        self.destroy_buffer(readback);
        r.map(|mut v| {
            v.truncate(image.byte_size() as usize);
            v
        })
    }

    /// Read an `Rgba32f` image as floats.
    pub fn read_image_rgba32f(&self, image: &Image) -> Result<Vec<f32>> {
        if image.desc.format != ImageFormat::Rgba32f {
            return Err(GpuError::Other(format!("read_image_rgba32f on a {:?} image", image.desc.format)));
        }
        Ok(bytemuck::pod_collect_to_vec(&self.read_image_bytes(image)?))
    }
}
