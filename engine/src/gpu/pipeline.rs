//! Compute and graphics pipelines whose descriptor layouts come from shader reflection; resources
//! are bound by name and checked against the shader (a missing, extra or mistyped binding is an
//! error, never a silent mismatch).

use super::shader::{ShaderModuleInfo, ShaderStage};
use super::spirv::{DescriptorKind, ReflectedBinding};
use super::{Buffer, Gpu, GpuError, Image, ImageFormat, Result, VkCheck};
use ash::vk;

/// A resource bound to a shader variable by its GLSL name (the block instance name, or the block
/// type name when the block has no instance name).
#[derive(Clone, Copy)]
pub enum Binding<'a> {
    Buffer(&'a str, &'a Buffer),
    StorageImage(&'a str, &'a Image),
    /// Sampled through the context's linear sampler (repeat in u, clamp in v).
    Sampled(&'a str, &'a Image),
}

impl<'a> Binding<'a> {
    pub fn buffer(name: &'a str, b: &'a Buffer) -> Self {
        Self::Buffer(name, b)
    }
    pub fn storage_image(name: &'a str, i: &'a Image) -> Self {
        Self::StorageImage(name, i)
    }
    pub fn sampled(name: &'a str, i: &'a Image) -> Self {
        Self::Sampled(name, i)
    }
    fn name(&self) -> &'a str {
        match self {
            Self::Buffer(n, _) | Self::StorageImage(n, _) | Self::Sampled(n, _) => n,
        }
    }
    fn kind(&self) -> &'static str {
        match self {
            Self::Buffer(..) => "buffer",
            Self::StorageImage(..) => "storage image",
            Self::Sampled(..) => "sampled image",
        }
    }
}

fn vk_kind(k: DescriptorKind) -> vk::DescriptorType {
    match k {
        DescriptorKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
        DescriptorKind::UniformBuffer => vk::DescriptorType::UNIFORM_BUFFER,
        DescriptorKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        DescriptorKind::CombinedImageSampler => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    }
}

/// What both pipeline kinds share: reflected bindings, layouts, push-constant size.
pub(crate) struct PipelineCore {
    pub name: String,
    pub raw: vk::Pipeline,
    pub layout: vk::PipelineLayout,
    pub set_layout: vk::DescriptorSetLayout,
    pub bindings: Vec<ReflectedBinding>,
    pub push_size: u32,
    pub stages: vk::ShaderStageFlags,
}

impl PipelineCore {
    fn layouts(
        gpu: &Gpu,
        name: &str,
        modules: &[&ShaderModuleInfo],
        stages: vk::ShaderStageFlags,
    ) -> Result<(vk::DescriptorSetLayout, vk::PipelineLayout, Vec<ReflectedBinding>, u32)> {
        let mut bindings: Vec<ReflectedBinding> = Vec::new();
        let mut push_size = 0;
        for m in modules {
            push_size = push_size.max(m.reflection.push_constant_size);
            for b in &m.reflection.bindings {
                if b.set != 0 {
                    return Err(GpuError::Binding {
                        pipeline: name.into(),
                        message: format!("'{}' uses set {}; only set 0 (push descriptors) is supported", b.name, b.set),
                    });
                }
                match bindings.iter().find(|x| x.binding == b.binding) {
                    Some(x) if x.name != b.name || x.kind != b.kind => {
                        return Err(GpuError::Binding {
                            pipeline: name.into(),
                            message: format!(
                                "binding {} is '{}' in one stage and '{}' in another",
                                b.binding, x.name, b.name
                            ),
                        })
                    }
                    Some(_) => {}
                    None => bindings.push(b.clone()),
                }
            }
        }
        let vk_bindings: Vec<vk::DescriptorSetLayoutBinding> = bindings
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(vk_kind(b.kind))
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default()
            .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
            .bindings(&vk_bindings);
        // SAFETY: valid device; create infos reference locals.
        let set_layout =
            unsafe { gpu.device.create_descriptor_set_layout(&set_info, None) }.vk("vkCreateDescriptorSetLayout")?;
        let ranges = [vk::PushConstantRange::default().stage_flags(stages).size(push_size)];
        let set_layouts = [set_layout];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_size > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        // SAFETY: as above.
        let layout = match unsafe { gpu.device.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(e) => {
                // SAFETY: unused layout from this device.
                unsafe { gpu.device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(GpuError::Vk { call: "vkCreatePipelineLayout", result: e });
            }
        };
        Ok((set_layout, layout, bindings, push_size))
    }

    /// Descriptor writes for `given`, checked against the reflected bindings by name and kind.
    pub(crate) fn check_bindings(&self, given: &[Binding]) -> Result<()> {
        for b in &self.bindings {
            let Some(g) = given.iter().find(|g| g.name() == b.name) else {
                return Err(GpuError::Binding {
                    pipeline: self.name.clone(),
                    message: format!("shader binding '{}' (binding {}) was not given a resource", b.name, b.binding),
                });
            };
            let ok = matches!(
                (g, b.kind),
                (Binding::Buffer(..), DescriptorKind::StorageBuffer | DescriptorKind::UniformBuffer)
                    | (Binding::StorageImage(..), DescriptorKind::StorageImage)
                    | (Binding::Sampled(..), DescriptorKind::CombinedImageSampler)
            );
            if !ok {
                return Err(GpuError::Binding {
                    pipeline: self.name.clone(),
                    message: format!("'{}' is a {:?} in the shader but a {} was given", b.name, b.kind, g.kind()),
                });
            }
            if let Binding::StorageImage(_, img) = g {
                if img.desc.format == ImageFormat::Depth32f {
                    return Err(GpuError::Binding {
                        pipeline: self.name.clone(),
                        message: format!("'{}': a depth image cannot be a storage image", b.name),
                    });
                }
            }
        }
        // Resources the shader does not use are ignored: the optimizer strips unused declarations
        // from shared includes. A misspelt name still fails, as the binding it meant is missing.
        Ok(())
    }

    pub(crate) fn push_descriptors(
        &self,
        gpu: &Gpu,
        cmd: vk::CommandBuffer,
        bind_point: vk::PipelineBindPoint,
        given: &[Binding],
    ) {
        let mut buffer_infos = Vec::with_capacity(self.bindings.len());
        let mut image_infos = Vec::with_capacity(self.bindings.len());
        for b in &self.bindings {
            let Some(g) = given.iter().find(|g| g.name() == b.name) else { continue };
            match g {
                Binding::Buffer(_, buf) => {
                    buffer_infos.push((b, vk::DescriptorBufferInfo::default().buffer(buf.raw).range(vk::WHOLE_SIZE)))
                }
                Binding::StorageImage(_, img) => image_infos.push((
                    b,
                    vk::DescriptorImageInfo::default().image_view(img.view).image_layout(vk::ImageLayout::GENERAL),
                )),
                Binding::Sampled(_, img) => image_infos.push((
                    b,
                    vk::DescriptorImageInfo::default()
                        .image_view(img.view)
                        .image_layout(vk::ImageLayout::GENERAL)
                        .sampler(gpu.linear_sampler),
                )),
            }
        }
        let mut writes = Vec::with_capacity(self.bindings.len());
        for (b, info) in &buffer_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_binding(b.binding)
                    .descriptor_type(vk_kind(b.kind))
                    .buffer_info(std::slice::from_ref(info)),
            );
        }
        for (b, info) in &image_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_binding(b.binding)
                    .descriptor_type(vk_kind(b.kind))
                    .image_info(std::slice::from_ref(info)),
            );
        }
        if !writes.is_empty() {
            // SAFETY: cmd is recording with this pipeline's layout bound; infos live across the call.
            unsafe { gpu.push_descriptor.cmd_push_descriptor_set(cmd, bind_point, self.layout, 0, &writes) };
        }
    }

    fn destroy(&self, gpu: &Gpu) {
        // SAFETY: the caller guarantees the GPU is done with the pipeline.
        unsafe {
            gpu.device.destroy_pipeline(self.raw, None);
            gpu.device.destroy_pipeline_layout(self.layout, None);
            gpu.device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

fn create_module(gpu: &Gpu, m: &ShaderModuleInfo) -> Result<vk::ShaderModule> {
    // SAFETY: the SPIR-V came from shaderc and was reflected successfully.
    unsafe { gpu.device.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&m.spirv), None) }
        .vk("vkCreateShaderModule")
}

pub struct ComputePipeline {
    pub(crate) core: PipelineCore,
    pub local_size: [u32; 3],
}

impl ComputePipeline {
    pub fn name(&self) -> &str {
        &self.core.name
    }
    pub fn push_constant_size(&self) -> u32 {
        self.core.push_size
    }
    pub fn bindings(&self) -> &[ReflectedBinding] {
        &self.core.bindings
    }
}

/// Fixed-function state of a G-buffer-like raster pass (vertex pulling: no vertex input state).
#[derive(Clone, Debug)]
pub struct GraphicsPipelineDesc<'a> {
    pub vertex: &'a str,
    pub fragment: &'a str,
    pub defines: &'a [(&'a str, &'a str)],
    pub color_formats: &'a [ImageFormat],
    pub depth_format: Option<ImageFormat>,
}

pub struct GraphicsPipeline {
    pub(crate) core: PipelineCore,
    pub(crate) color_count: usize,
}

impl Gpu {
    /// The sources a shader is compiled from: `path` (relative to `shaders-glsl`) and every file it includes,
    /// recursively, each once (`(path, text)`).
    pub fn shader_sources(&self, path: &str) -> Result<Vec<(String, String)>> {
        self.compiler.include_closure(path)
    }

    /// The shaders (paths relative to `shaders-glsl`) this device has compiled so far, sorted.
    pub fn compiled_shaders(&self) -> Vec<String> {
        self.compiler.compiled()
    }

    /// Compile `path` (relative to `shaders-glsl`) to SPIR-V only (cached), surfacing GLSL errors without paying
    /// for the driver's pipeline creation.
    pub fn compile_compute_shader(&self, path: &str, defines: &[(&str, &str)]) -> Result<()> {
        self.compiler.compile(path, ShaderStage::Compute, defines).map(|_| ())
    }

    /// Compile `path` (relative to `shaders-glsl`) and build a compute pipeline.
    pub fn create_compute_pipeline(&self, path: &str, defines: &[(&str, &str)]) -> Result<ComputePipeline> {
        let m = self.compiler.compile(path, ShaderStage::Compute, defines)?;
        let stages = vk::ShaderStageFlags::COMPUTE;
        let (set_layout, layout, bindings, push_size) = PipelineCore::layouts(self, path, &[&m], stages)?;
        let module = create_module(self, &m);
        let raw = module.and_then(|module| {
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = vk::ComputePipelineCreateInfo::default().stage(stage).layout(layout);
            // SAFETY: module and layout are valid; the module is destroyed after creation.
            let r = unsafe { self.device.create_compute_pipelines(vk::PipelineCache::null(), &[info], None) };
            // SAFETY: the module is no longer needed once the pipeline exists.
            unsafe { self.device.destroy_shader_module(module, None) };
            r.map(|p| p[0]).map_err(|(_, e)| GpuError::Vk { call: "vkCreateComputePipelines", result: e })
        });
        let core = PipelineCore {
            name: path.into(),
            raw: vk::Pipeline::null(),
            layout,
            set_layout,
            bindings,
            push_size,
            stages,
        };
        match raw {
            Ok(raw) => {
                self.set_name(raw, path);
                Ok(ComputePipeline { core: PipelineCore { raw, ..core }, local_size: m.reflection.local_size })
            }
            Err(e) => {
                core.destroy(self);
                Err(e)
            }
        }
    }

    pub fn create_graphics_pipeline(&self, desc: &GraphicsPipelineDesc) -> Result<GraphicsPipeline> {
        let vs = self.compiler.compile(desc.vertex, ShaderStage::Vertex, desc.defines)?;
        let fs = self.compiler.compile(desc.fragment, ShaderStage::Fragment, desc.defines)?;
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let name = format!("{}+{}", desc.vertex, desc.fragment);
        let (set_layout, layout, bindings, push_size) = PipelineCore::layouts(self, &name, &[&vs, &fs], stages)?;
        let core = PipelineCore {
            name: name.clone(),
            raw: vk::Pipeline::null(),
            layout,
            set_layout,
            bindings,
            push_size,
            stages,
        };
        let modules = create_module(self, &vs).and_then(|v| match create_module(self, &fs) {
            Ok(f) => Ok((v, f)),
            Err(e) => {
                // SAFETY: unused module.
                unsafe { self.device.destroy_shader_module(v, None) };
                Err(e)
            }
        });
        let (vm, fm) = match modules {
            Ok(m) => m,
            Err(e) => {
                core.destroy(self);
                return Err(e);
            }
        };
        let stage_infos = [
            vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::VERTEX).module(vm).name(c"main"),
            vk::PipelineShaderStageCreateInfo::default().stage(vk::ShaderStageFlags::FRAGMENT).module(fm).name(c"main"),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let input_assembly =
            vk::PipelineInputAssemblyStateCreateInfo::default().topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default().viewport_count(1).scissor_count(1);
        // No culling: scanned meshes (the bunny) are open, and thin shells are seen from both sides.
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample =
            vk::PipelineMultisampleStateCreateInfo::default().rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(desc.depth_format.is_some())
            .depth_write_enable(desc.depth_format.is_some())
            .depth_compare_op(vk::CompareOp::LESS);
        let blend_attachments: Vec<_> = desc
            .color_formats
            .iter()
            .map(|_| vk::PipelineColorBlendAttachmentState::default().color_write_mask(vk::ColorComponentFlags::RGBA))
            .collect();
        let blend = vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let color_formats: Vec<vk::Format> = desc.color_formats.iter().map(|f| f.vk()).collect();
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(desc.depth_format.map_or(vk::Format::UNDEFINED, |f| f.vk()));
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stage_infos)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&input_assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: all state structs live across the call; modules destroyed right after.
        let r = unsafe {
            let r = self.device.create_graphics_pipelines(vk::PipelineCache::null(), &[info], None);
            self.device.destroy_shader_module(vm, None);
            self.device.destroy_shader_module(fm, None);
            r
        };
        match r {
            Ok(p) => {
                self.set_name(p[0], &name);
                Ok(GraphicsPipeline { core: PipelineCore { raw: p[0], ..core }, color_count: desc.color_formats.len() })
            }
            Err((_, e)) => {
                core.destroy(self);
                Err(GpuError::Vk { call: "vkCreateGraphicsPipelines", result: e })
            }
        }
    }

    pub fn destroy_compute_pipeline(&self, p: ComputePipeline) {
        self.drain();
        p.core.destroy(self);
    }

    pub fn destroy_graphics_pipeline(&self, p: GraphicsPipeline) {
        self.drain();
        p.core.destroy(self);
    }
}
