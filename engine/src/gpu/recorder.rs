//! Command recording for one frame: passes with timestamp queries, dispatches and draws with
//! checked bindings, and a full memory barrier between passes (simple and always correct; passes
//! here are few and large).

use super::pipeline::{Binding, ComputePipeline, GraphicsPipeline};
use super::{Buffer, Gpu, GpuError, Image, Result, VkCheck};
use ash::vk;

/// GPU time of one pass in one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    pub name: String,
    pub ms: f64,
}

const MAX_QUERIES: u32 = 128;

/// Reusable per-frame objects: command buffer, fence, timestamp pool. Created once; a steady frame
/// allocates nothing.
pub struct Frame {
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    queries: vk::QueryPool,
    /// The passes recorded, in order, with their first timestamp query (none without timestamps). Kept
    /// either way: a timeout or a lost device names them.
    passes: Vec<(String, Option<u32>)>,
    query_count: u32,
    /// Submitted, and the wait for it failed (timeout, device loss): the fence may still signal.
    pending: bool,
    /// Breadcrumb: a host-visible u32 the frame's commands overwrite with the number of passes finished, at
    /// each pass start (after the full barrier that waits for the earlier passes) and at the frame's end. On a
    /// timeout or a loss it tells which pass was running. Portable stand-in for NVIDIA's
    /// VK_NV_device_diagnostic_checkpoints and AMD's buffer markers. (Timestamp *availability* cannot serve:
    /// lavapipe marks a timestamp available when it processes the command, before the work ahead of it ends.)
    crumb: Buffer,
}

/// Records into a [`Frame`]; get one from [`Gpu::record_frame`].
pub struct Recorder<'g> {
    gpu: &'g Gpu,
    frame: &'g mut Frame,
    open_pass: bool,
    error: Option<GpuError>,
}

impl Gpu {
    pub fn create_frame(&self) -> Result<Frame> {
        // SAFETY: valid device and pool; create infos have no pointers.
        unsafe {
            let cmd = self
                .device
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(self.command_pool)
                        .level(vk::CommandBufferLevel::PRIMARY)
                        .command_buffer_count(1),
                )
                .vk("vkAllocateCommandBuffers")?[0];
            let fence = self.device.create_fence(&vk::FenceCreateInfo::default(), None).vk("vkCreateFence")?;
            let queries = self
                .device
                .create_query_pool(
                    &vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(MAX_QUERIES),
                    None,
                )
                .vk("vkCreateQueryPool")?;
            let crumb = match self.create_buffer("frame-breadcrumb", super::BufferDesc::readback(4)) {
                Ok(b) => b,
                Err(e) => {
                    self.device.destroy_query_pool(queries, None);
                    self.device.destroy_fence(fence, None);
                    self.device.free_command_buffers(self.command_pool, &[cmd]);
                    return Err(e);
                }
            };
            Ok(Frame { cmd, fence, queries, passes: Vec::with_capacity(16), query_count: 0, pending: false, crumb })
        }
    }

    pub fn destroy_frame(&self, frame: Frame) {
        // After a failed wait the frame may still execute: wait for the device first (watchdog.rs).
        self.drain();
        // SAFETY: the frame finished: run_frame waited for it, or drain() waited for the device.
        unsafe {
            self.device.destroy_query_pool(frame.queries, None);
            self.device.destroy_fence(frame.fence, None);
            self.device.free_command_buffers(self.command_pool, &[frame.cmd]);
        }
        self.destroy_buffer(frame.crumb);
    }

    /// Record a frame with `record`, submit it (waiting on / signalling the given semaphores),
    /// wait for the fence, and return per-pass GPU times.
    pub fn run_frame(
        &self,
        frame: &mut Frame,
        wait: Option<(vk::Semaphore, vk::PipelineStageFlags)>,
        signal: Option<vk::Semaphore>,
        record: impl FnOnce(&mut Recorder) -> Result<()>,
    ) -> Result<Vec<PassTiming>> {
        self.check_not_lost("a frame")?;
        if frame.pending {
            // The last submission of this frame was given up on: let it end before its command buffer,
            // queries and fence are reused.
            self.drain();
            // SAFETY: the device is idle, so the fence is not in use.
            unsafe { self.device.reset_fences(&[frame.fence]) }.vk("vkResetFences")?;
            frame.pending = false;
        }
        frame.passes.clear();
        frame.query_count = 0;
        // SAFETY: the frame's previous submission was waited for; the pool is host-resettable
        // (hostQueryReset enabled).
        unsafe {
            self.device.reset_query_pool(frame.queries, 0, MAX_QUERIES);
            self.device
                .reset_command_buffer(frame.cmd, vk::CommandBufferResetFlags::empty())
                .vk("vkResetCommandBuffer")?;
            self.device
                .begin_command_buffer(
                    frame.cmd,
                    &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                )
                .vk("vkBeginCommandBuffer")?;
        }
        let mut rec = Recorder { gpu: self, frame, open_pass: false, error: None };
        rec.crumb(0);
        let recorded = record(&mut rec);
        if rec.open_pass {
            rec.end_pass();
        }
        // Every pass finished (the barrier waits for them), for the breadcrumb.
        rec.barrier();
        rec.crumb(rec.frame.passes.len() as u32);
        let deferred = rec.error.take();
        let frame = rec.frame;
        // SAFETY: cmd is in the recording state.
        unsafe { self.device.end_command_buffer(frame.cmd) }.vk("vkEndCommandBuffer")?;
        recorded?;
        if let Some(e) = deferred {
            return Err(e);
        }
        let cmds = [frame.cmd];
        let (wait_sems, wait_stages): (Vec<_>, Vec<_>) = wait.into_iter().unzip();
        let signal_sems: Vec<_> = signal.into_iter().collect();
        let submit = vk::SubmitInfo::default()
            .command_buffers(&cmds)
            .wait_semaphores(&wait_sems)
            .wait_dst_stage_mask(&wait_stages)
            .signal_semaphores(&signal_sems);
        // SAFETY: everything referenced by the command buffer is alive until the fence wait below (or, when
        // that wait fails, until drain() at the next destroy).
        unsafe { self.device.queue_submit(self.queue, &[submit], frame.fence) }.vk("vkQueueSubmit")?;
        frame.pending = true;
        self.wait_fence(frame.fence, || self.describe_frame(frame))?;
        frame.pending = false;
        // SAFETY: the fence signalled; nothing waits on it.
        unsafe { self.device.reset_fences(&[frame.fence]) }.vk("vkResetFences")?;
        let mut timings = Vec::with_capacity(frame.passes.len());
        if self.timestamps_supported && frame.query_count > 0 {
            let mut stamps = [0u64; MAX_QUERIES as usize];
            // SAFETY: the queries were written by the waited-for submission.
            unsafe {
                self.device
                    .get_query_pool_results(
                        frame.queries,
                        0,
                        &mut stamps[..frame.query_count as usize],
                        vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                    )
                    .vk("vkGetQueryPoolResults")?;
            }
            for (name, q) in frame.passes.iter().filter_map(|(n, q)| q.map(|q| (n, q))) {
                let q = &q;
                let dt = stamps[*q as usize + 1].wrapping_sub(stamps[*q as usize]);
                timings.push(PassTiming { name: name.clone(), ms: dt as f64 * self.info.timestamp_period_ns * 1e-6 });
            }
        }
        Ok(timings)
    }

    /// A frame whose wait failed, for the error: its passes and, from the breadcrumb, which had finished,
    /// which was running and which had not started.
    fn describe_frame(&self, frame: &Frame) -> String {
        let names: Vec<&str> = frame.passes.iter().map(|(n, _)| n.as_str()).collect();
        if names.is_empty() {
            return "a frame with no named pass".into();
        }
        let list = format!("a frame with passes [{}]", names.join(", "));
        // The device may still write it: a torn read is impossible for one aligned u32 (and a stale one only
        // names an earlier pass).
        let Some(finished) = frame.crumb.read::<u32>().ok().and_then(|v| v.first().copied()) else { return list };
        let finished = finished as usize;
        let join = |v: &[&str]| if v.is_empty() { "none".to_string() } else { v.join(", ") };
        match names.get(finished) {
            Some(running) => format!(
                "{list}: pass '{running}' was running (finished: {}; not started: {})",
                join(&names[..finished]),
                join(&names[finished + 1..])
            ),
            None => format!("{list}: every pass had finished (the end of the frame had not)"),
        }
    }
}

impl Recorder<'_> {
    pub fn gpu(&self) -> &Gpu {
        self.gpu
    }

    pub fn raw(&self) -> vk::CommandBuffer {
        self.frame.cmd
    }

    /// Full memory barrier: every earlier write is visible to every later read or write.
    pub fn barrier(&mut self) {
        let b = [vk::MemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)];
        // SAFETY: cmd is recording.
        unsafe {
            self.gpu.device.cmd_pipeline_barrier2(self.frame.cmd, &vk::DependencyInfo::default().memory_barriers(&b))
        };
    }

    /// Overwrite the frame's breadcrumb with `passes_finished` (after a barrier: see [`Frame`]).
    fn crumb(&mut self, passes_finished: u32) {
        // SAFETY: cmd is recording, outside any render pass; the buffer is the frame's, 4 bytes, TRANSFER_DST.
        unsafe { self.gpu.device.cmd_fill_buffer(self.frame.cmd, self.frame.crumb.raw, 0, 4, passes_finished) };
    }

    /// Fill the whole of `buffer` with the 32-bit `value` (a transfer: put a [`Self::barrier`] before a
    /// pass that reads it; [`Self::begin_pass`] already puts one after earlier work).
    pub fn fill_buffer(&mut self, buffer: &super::Buffer, value: u32) {
        // SAFETY: cmd is recording, outside any render pass; the buffer is alive until the frame's fence and
        // was created with TRANSFER_DST (every BufferDesc preset has it).
        unsafe { self.gpu.device.cmd_fill_buffer(self.frame.cmd, buffer.raw, 0, vk::WHOLE_SIZE, value) };
    }

    /// Start a timed pass (ends the previous one). A barrier separates it from earlier work.
    pub fn begin_pass(&mut self, name: &str) {
        if self.open_pass {
            self.end_pass();
        }
        self.barrier();
        self.crumb(self.frame.passes.len() as u32);
        self.frame.passes.push((name.to_string(), None));
        if self.gpu.timestamps_supported && self.frame.query_count + 2 <= MAX_QUERIES {
            let q = self.frame.query_count;
            // SAFETY: q is within the (reset) pool.
            unsafe {
                self.gpu.device.cmd_write_timestamp2(
                    self.frame.cmd,
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    self.frame.queries,
                    q,
                )
            };
            self.frame.query_count += 2;
            if let Some(last) = self.frame.passes.last_mut() {
                last.1 = Some(q);
            }
            self.open_pass = true;
        }
    }

    pub fn end_pass(&mut self) {
        if !self.open_pass {
            return;
        }
        self.open_pass = false;
        let Some(q) = self.frame.passes.last().and_then(|p| p.1).map(|q| q + 1) else { return };
        // SAFETY: q was reserved by begin_pass.
        unsafe {
            self.gpu.device.cmd_write_timestamp2(
                self.frame.cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.frame.queries,
                q,
            )
        };
    }

    fn push_constants(
        &self,
        layout: vk::PipelineLayout,
        stages: vk::ShaderStageFlags,
        size: u32,
        push: &[u8],
        name: &str,
    ) -> Result<()> {
        if push.len() as u32 != size {
            return Err(GpuError::Binding {
                pipeline: name.into(),
                message: format!("push constants: shader expects {size} bytes, {} given", push.len()),
            });
        }
        if size > 0 {
            // SAFETY: cmd is recording; layout has a range of exactly `size` bytes for `stages`.
            unsafe { self.gpu.device.cmd_push_constants(self.frame.cmd, layout, stages, 0, push) };
        }
        Ok(())
    }

    /// Dispatch enough workgroups to cover `invocations` (x, y, z) threads.
    pub fn dispatch(
        &mut self,
        pipe: &ComputePipeline,
        bindings: &[Binding],
        push: &[u8],
        invocations: [u32; 3],
    ) -> Result<()> {
        let core = &pipe.core;
        core.check_bindings(bindings)?;
        let ls = pipe.local_size.map(|v| v.max(1));
        let groups = [0, 1, 2].map(|i| invocations[i].div_ceil(ls[i]));
        if groups.contains(&0) {
            return Ok(());
        }
        // SAFETY: cmd is recording; pipeline and resources outlive the frame's fence wait.
        unsafe {
            self.gpu.device.cmd_bind_pipeline(self.frame.cmd, vk::PipelineBindPoint::COMPUTE, core.raw);
        }
        core.push_descriptors(self.gpu, self.frame.cmd, vk::PipelineBindPoint::COMPUTE, bindings);
        self.push_constants(core.layout, core.stages, core.push_size, push, &core.name)?;
        // SAFETY: as above.
        unsafe { self.gpu.device.cmd_dispatch(self.frame.cmd, groups[0], groups[1], groups[2]) };
        Ok(())
    }

    /// Draw `index_count` indices with vertex pulling into the given colour targets and depth
    /// (all cleared first: colours to zero, depth to 1).
    #[allow(clippy::too_many_arguments)]
    pub fn draw_indexed(
        &mut self,
        pipe: &GraphicsPipeline,
        bindings: &[Binding],
        push: &[u8],
        colors: &[&Image],
        depth: Option<&Image>,
        index_buffer: &Buffer,
        index_count: u32,
    ) -> Result<()> {
        let core = &pipe.core;
        core.check_bindings(bindings)?;
        if colors.len() != pipe.color_count {
            return Err(GpuError::Binding {
                pipeline: core.name.clone(),
                message: format!("{} colour targets given, pipeline has {}", colors.len(), pipe.color_count),
            });
        }
        let extent = colors
            .first()
            .or(depth.as_ref())
            .map(|i| vk::Extent2D { width: i.desc.width, height: i.desc.height })
            .ok_or_else(|| GpuError::Other("draw without targets".into()))?;
        let color_infos: Vec<vk::RenderingAttachmentInfo> = colors
            .iter()
            .map(|img| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(img.view)
                    .image_layout(vk::ImageLayout::GENERAL)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(vk::ClearValue { color: vk::ClearColorValue { float32: [0.0; 4] } })
            })
            .collect();
        let depth_info = depth.map(|img| {
            vk::RenderingAttachmentInfo::default()
                .image_view(img.view)
                .image_layout(vk::ImageLayout::GENERAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue { depth_stencil: vk::ClearDepthStencilValue { depth: 1.0, stencil: 0 } })
        });
        let mut rendering = vk::RenderingInfo::default()
            .render_area(vk::Rect2D { offset: vk::Offset2D::default(), extent })
            .layer_count(1)
            .color_attachments(&color_infos);
        if let Some(d) = depth_info.as_ref() {
            rendering = rendering.depth_attachment(d);
        }
        let cmd = self.frame.cmd;
        let dev = &self.gpu.device;
        // SAFETY: cmd is recording; attachments are in GENERAL; everything outlives the fence wait.
        unsafe {
            dev.cmd_begin_rendering(cmd, &rendering);
            dev.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, core.raw);
            dev.cmd_set_viewport(
                cmd,
                0,
                &[vk::Viewport {
                    x: 0.0,
                    y: 0.0,
                    width: extent.width as f32,
                    height: extent.height as f32,
                    min_depth: 0.0,
                    max_depth: 1.0,
                }],
            );
            dev.cmd_set_scissor(cmd, 0, &[vk::Rect2D { offset: vk::Offset2D::default(), extent }]);
        }
        core.push_descriptors(self.gpu, cmd, vk::PipelineBindPoint::GRAPHICS, bindings);
        let r = self.push_constants(core.layout, core.stages, core.push_size, push, &core.name);
        // SAFETY: as above; rendering is ended on every path.
        unsafe {
            if r.is_ok() && index_count > 0 {
                dev.cmd_bind_index_buffer(cmd, index_buffer.raw, 0, vk::IndexType::UINT32);
                dev.cmd_draw_indexed(cmd, index_count, 1, 0, 0, 0);
            }
            dev.cmd_end_rendering(cmd);
        }
        r
    }

    /// Copy a whole image into another of the same size (blit with format conversion).
    pub fn blit(&mut self, src: &Image, dst_raw: vk::Image, dst_layout: vk::ImageLayout, dst_extent: [u32; 2]) {
        self.blit_filtered(src, dst_raw, dst_layout, dst_extent, vk::Filter::NEAREST)
    }

    /// [`Recorder::blit`] with a chosen filter (linear when scaling).
    pub(crate) fn blit_filtered(
        &mut self,
        src: &Image,
        dst_raw: vk::Image,
        dst_layout: vk::ImageLayout,
        dst_extent: [u32; 2],
        filter: vk::Filter,
    ) {
        let sub = vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1);
        let region = vk::ImageBlit::default()
            .src_subresource(sub)
            .src_offsets([
                vk::Offset3D::default(),
                vk::Offset3D { x: src.desc.width as i32, y: src.desc.height as i32, z: 1 },
            ])
            .dst_subresource(sub)
            .dst_offsets([
                vk::Offset3D::default(),
                vk::Offset3D { x: dst_extent[0] as i32, y: dst_extent[1] as i32, z: 1 },
            ]);
        // SAFETY: cmd is recording; src in GENERAL, dst in dst_layout as the caller states.
        unsafe {
            self.gpu.device.cmd_blit_image(
                self.frame.cmd,
                src.raw,
                vk::ImageLayout::GENERAL,
                dst_raw,
                dst_layout,
                &[region],
                filter,
            )
        };
    }

    /// Record an error to be returned by `run_frame` (for helpers without a Result path).
    pub fn defer_error(&mut self, e: GpuError) {
        self.error.get_or_insert(e);
    }
}
