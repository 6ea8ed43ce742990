//! Window presentation: a surface from raw window handles (`ash_window`), a swapchain, and the
//! per-frame acquire/present protocol.
//!
//! The renderer never renders into swapchain images: it blits its tone-mapped RGBA8 image into
//! the acquired image (format conversion and scaling by `vkCmdBlitImage`), so the presented
//! pixels are exactly those of the headless render when sizes match. One frame is in flight
//! (the renderer waits for each frame), so one acquire semaphore suffices; the "render finished"
//! semaphores are one per swapchain image, as presentation may hold them until the image is
//! acquired again.

use super::{Gpu, GpuError, Image, Result, VkCheck};
use ash::vk;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};
use std::ffi::CStr;

/// Instance extensions needed to present to windows of this display.
pub fn surface_extensions(display: RawDisplayHandle) -> Result<Vec<&'static CStr>> {
    let names = ash_window::enumerate_required_extensions(display).vk("enumerate_required_extensions")?;
    // SAFETY: ash_window returns pointers to static NUL-terminated extension names.
    Ok(names.iter().map(|&p| unsafe { CStr::from_ptr(p) }).collect())
}

/// A window surface and its swapchain.
pub struct Swapchain {
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    format: vk::Format,
    extent: [u32; 2],
    acquired: vk::Semaphore,
    rendered: Vec<vk::Semaphore>,
    /// Set when the surface reported out-of-date or suboptimal: recreate before the next frame.
    stale: bool,
}

/// The image acquired for one frame: where [`Gpu::run_frame_presenting`] blits, and what
/// [`Swapchain::present`] shows.
pub struct SwapchainImage {
    pub(crate) index: u32,
    pub(crate) image: vk::Image,
    pub(crate) extent: [u32; 2],
    pub(crate) wait: vk::Semaphore,
    pub(crate) signal: vk::Semaphore,
}

impl Swapchain {
    /// Create a surface for the window and a swapchain of `size` pixels (the surface's current
    /// extent wins where the platform fixes it).
    ///
    /// # Safety
    /// The window behind the handles must outlive the returned swapchain.
    pub unsafe fn new(gpu: &Gpu, display: RawDisplayHandle, window: RawWindowHandle, size: [u32; 2]) -> Result<Self> {
        let loader = gpu.surface_instance.as_ref().ok_or_else(|| {
            GpuError::Other("this Gpu was created without surface extensions (GpuDesc::surface_extensions)".into())
        })?;
        // SAFETY: the caller guarantees the handles are valid for the swapchain's lifetime.
        let surface = unsafe { ash_window::create_surface(gpu.entry(), &gpu.instance, display, window, None) }
            .vk("vkCreateSurfaceKHR")?;
        // SAFETY: surface and physical device belong to this instance.
        let supported = unsafe { loader.get_physical_device_surface_support(gpu.physical, gpu.queue_family, surface) }
            .unwrap_or(false);
        if !supported {
            // SAFETY: the surface was created above and is unused.
            unsafe { loader.destroy_surface(surface, None) };
            return Err(GpuError::Other(format!("adapter '{}' cannot present to this window", gpu.info.name)));
        }
        let mut s = Self {
            surface,
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent: [0, 0],
            acquired: vk::Semaphore::null(),
            rendered: Vec::new(),
            stale: false,
        };
        let made = (|| {
            // SAFETY: plain create info.
            s.acquired = unsafe { gpu.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .vk("vkCreateSemaphore")?;
            s.recreate(gpu, size)
        })();
        if let Err(e) = made {
            s.destroy(gpu);
            return Err(e);
        }
        Ok(s)
    }

    pub fn extent(&self) -> [u32; 2] {
        self.extent
    }

    /// Build (or rebuild, after a resize) the swapchain; waits for the device to be idle.
    pub fn recreate(&mut self, gpu: &Gpu, size: [u32; 2]) -> Result<()> {
        let loader = gpu.surface_instance.as_ref().expect("checked in new");
        let device_loader =
            gpu.swapchain_device.as_ref().ok_or_else(|| GpuError::Other("this Gpu has no VK_KHR_swapchain".into()))?;
        gpu.wait_idle()?;
        // SAFETY: surface queries on a valid surface and physical device.
        let (caps, formats, modes) = unsafe {
            (
                loader
                    .get_physical_device_surface_capabilities(gpu.physical, self.surface)
                    .vk("surface capabilities")?,
                loader.get_physical_device_surface_formats(gpu.physical, self.surface).vk("surface formats")?,
                loader.get_physical_device_surface_present_modes(gpu.physical, self.surface).vk("present modes")?,
            )
        };
        // Our LDR image already holds sRGB-encoded values: present them through a UNORM format.
        let format = [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM]
            .into_iter()
            .find_map(|f| formats.iter().find(|sf| sf.format == f).copied())
            .ok_or_else(|| GpuError::Other(format!("no 8-bit UNORM surface format among {formats:?}")))?;
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            return Err(GpuError::Other("the surface does not support TRANSFER_DST images".into()));
        }
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size[0].clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size[1].clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            // Minimized: keep the old swapchain (if any) and stay stale until a real size comes.
            self.stale = true;
            return Ok(());
        }
        // FIFO is always available and never tears; MAILBOX would not cap lavapipe anyway.
        let mode = if modes.contains(&vk::PresentModeKHR::FIFO) { vk::PresentModeKHR::FIFO } else { modes[0] };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(mode)
            .clipped(true)
            .old_swapchain(self.swapchain);
        // SAFETY: the device is idle, so the old swapchain and its semaphores are unused.
        unsafe {
            let new = device_loader.create_swapchain(&info, None).vk("vkCreateSwapchainKHR")?;
            if self.swapchain != vk::SwapchainKHR::null() {
                device_loader.destroy_swapchain(self.swapchain, None);
            }
            self.swapchain = new;
            self.images = device_loader.get_swapchain_images(new).vk("vkGetSwapchainImagesKHR")?;
            for s in self.rendered.drain(..) {
                gpu.device.destroy_semaphore(s, None);
            }
            for _ in 0..self.images.len() {
                self.rendered.push(
                    gpu.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None).vk("vkCreateSemaphore")?,
                );
            }
        }
        for (i, &img) in self.images.iter().enumerate() {
            gpu.set_name(img, &format!("swapchain image {i}"));
        }
        self.format = format.format;
        self.extent = [extent.width, extent.height];
        self.stale = false;
        Ok(())
    }

    /// Acquire the next image. `None` when the swapchain must be recreated first (resize,
    /// minimize): call [`Swapchain::recreate`] with the window's size and try again.
    pub fn acquire(&mut self, gpu: &Gpu) -> Result<Option<SwapchainImage>> {
        if self.stale || self.swapchain == vk::SwapchainKHR::null() {
            return Ok(None);
        }
        let loader = gpu.swapchain_device.as_ref().expect("checked in recreate");
        // SAFETY: the acquire semaphore is unsignalled: the previous frame waited on it and
        // that frame's fence was waited for.
        // Bounded like every fence wait (watchdog.rs): a compositor that never hands an image back is reported.
        let timeout = gpu.fence_timeout();
        let ns = timeout.as_nanos().min(u64::MAX as u128) as u64;
        match unsafe { loader.acquire_next_image(self.swapchain, ns, self.acquired, vk::Fence::null()) } {
            Ok((index, suboptimal)) => {
                self.stale |= suboptimal;
                Ok(Some(SwapchainImage {
                    index,
                    image: self.images[index as usize],
                    extent: self.extent,
                    wait: self.acquired,
                    signal: self.rendered[index as usize],
                }))
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(None)
            }
            Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => Err(GpuError::Timeout {
                submission: "vkAcquireNextImageKHR (waiting for a swapchain image)".into(),
                seconds: timeout.as_secs_f64(),
            }),
            Err(vk::Result::ERROR_DEVICE_LOST) => Err(GpuError::DeviceLost {
                submission: "vkAcquireNextImageKHR".into(),
                detail: "reported by the driver".into(),
            }),
            Err(e) => Err(GpuError::Vk { call: "vkAcquireNextImageKHR", result: e }),
        }
    }

    /// Present an image whose frame was submitted with [`Gpu::run_frame_presenting`].
    pub fn present(&mut self, gpu: &Gpu, image: SwapchainImage) -> Result<()> {
        let loader = gpu.swapchain_device.as_ref().expect("checked in recreate");
        let (waits, chains, indices) = ([image.signal], [self.swapchain], [image.index]);
        let info = vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&chains).image_indices(&indices);
        // SAFETY: the image was acquired from this swapchain and its frame signals `signal`.
        match unsafe { loader.queue_present(gpu.queue, &info) } {
            Ok(suboptimal) => {
                self.stale |= suboptimal;
                Ok(())
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(())
            }
            Err(e) => Err(GpuError::Vk { call: "vkQueuePresentKHR", result: e }),
        }
    }

    /// Whether the next frame needs [`Swapchain::recreate`] first.
    pub fn is_stale(&self) -> bool {
        self.stale
    }

    pub fn destroy(self, gpu: &Gpu) {
        let _ = gpu.wait_idle();
        // SAFETY: the device is idle; every handle was created by this swapchain.
        unsafe {
            for &s in &self.rendered {
                gpu.device.destroy_semaphore(s, None);
            }
            if self.acquired != vk::Semaphore::null() {
                gpu.device.destroy_semaphore(self.acquired, None);
            }
            if let (Some(d), false) = (gpu.swapchain_device.as_ref(), self.swapchain == vk::SwapchainKHR::null()) {
                d.destroy_swapchain(self.swapchain, None);
            }
            if let Some(l) = gpu.surface_instance.as_ref() {
                l.destroy_surface(self.surface, None);
            }
        }
    }
}

impl Gpu {
    /// Like [`Gpu::run_frame`], then blit `src` (an RGBA8 image in GENERAL layout) into the
    /// acquired swapchain image and leave it ready to present. The blit scales (linear filter)
    /// when the sizes differ.
    pub fn run_frame_presenting(
        &self,
        frame: &mut super::Frame,
        target: &SwapchainImage,
        src: &Image,
        record: impl FnOnce(&mut super::Recorder) -> Result<()>,
    ) -> Result<Vec<super::PassTiming>> {
        self.run_frame(frame, Some((target.wait, vk::PipelineStageFlags::TRANSFER)), Some(target.signal), |rec| {
            record(rec)?;
            rec.present_blit(src, target);
            Ok(())
        })
    }
}

impl super::Recorder<'_> {
    /// Transition the swapchain image, blit `src` into it, and transition it for presentation.
    pub(crate) fn present_blit(&mut self, src: &Image, target: &SwapchainImage) {
        let range =
            vk::ImageSubresourceRange::default().aspect_mask(vk::ImageAspectFlags::COLOR).level_count(1).layer_count(1);
        let to_dst = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_WRITE | vk::AccessFlags2::TRANSFER_READ)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .image(target.image)
            .subresource_range(range);
        let to_present = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::BOTTOM_OF_PIPE)
            .dst_access_mask(vk::AccessFlags2::NONE)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .image(target.image)
            .subresource_range(range);
        // The source was just written by a compute pass: full barrier first.
        self.barrier();
        // SAFETY: the command buffer is recording; the image is the acquired swapchain image.
        unsafe {
            self.gpu().device.cmd_pipeline_barrier2(
                self.raw(),
                &vk::DependencyInfo::default().image_memory_barriers(std::slice::from_ref(&to_dst)),
            );
        }
        let filter =
            if [src.desc.width, src.desc.height] == target.extent { vk::Filter::NEAREST } else { vk::Filter::LINEAR };
        self.blit_filtered(src, target.image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, target.extent, filter);
        // SAFETY: as above.
        unsafe {
            self.gpu().device.cmd_pipeline_barrier2(
                self.raw(),
                &vk::DependencyInfo::default().image_memory_barriers(std::slice::from_ref(&to_present)),
            );
        }
    }
}
