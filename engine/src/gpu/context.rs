//! Instance, device choice, queue, allocator, validation messenger, teardown.

use super::watchdog::Watchdog;
use super::{GpuError, Result, ShaderCompiler, VkCheck};
use ash::{ext, khr, vk};
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};
use std::ffi::{c_void, CStr, CString};
use std::mem::ManuallyDrop;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";
const INSTALL_HINT: &str = "Install a driver: apt-get install mesa-vulkan-drivers (lavapipe, CPU) or your GPU's driver";

/// Whether the Khronos validation layer is loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ValidationMode {
    /// Off (release runs).
    Off,
    /// On when the layer is installed; a warning otherwise (debug builds).
    IfAvailable,
    /// On, and a missing layer is an error (tests).
    Required,
}

/// How to create a [`Gpu`].
#[derive(Clone, Debug)]
pub struct GpuDesc {
    pub validation: ValidationMode,
    /// Case-insensitive substring of the adapter name to use instead of the automatic choice.
    pub device_name: Option<String>,
    /// Instance extensions a window surface needs (from `ash_window::enumerate_required_extensions`).
    pub surface_extensions: Vec<&'static CStr>,
    /// Root of the GLSL sources (`shaders-glsl`).
    pub shader_root: PathBuf,
    /// Print the chosen adapter to stderr.
    pub verbose: bool,
}

impl Default for GpuDesc {
    fn default() -> Self {
        let validation = match std::env::var("ENGINE_VALIDATION").as_deref() {
            Ok("0") => ValidationMode::Off,
            Ok("1") => ValidationMode::Required,
            _ if cfg!(debug_assertions) => ValidationMode::IfAvailable,
            _ => ValidationMode::Off,
        };
        Self {
            validation,
            device_name: std::env::var("ENGINE_DEVICE").ok(),
            surface_extensions: Vec::new(),
            shader_root: default_shader_root(),
            verbose: true,
        }
    }
}

/// `shaders-glsl` next to the workspace root: `ENGINE_SHADER_ROOT`, else found from the crate's
/// manifest folder at build time.
pub fn default_shader_root() -> PathBuf {
    if let Ok(p) = std::env::var("ENGINE_SHADER_ROOT") {
        return PathBuf::from(p);
    }
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shaders-glsl")
}

/// What was chosen, for printing and for reports.
#[derive(Clone, Debug)]
pub struct AdapterInfo {
    pub name: String,
    pub device_type: String,
    pub driver: String,
    pub api_version: String,
    pub validation: bool,
    pub timestamp_period_ns: f64,
}

/// Device memory in use, from the allocator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryStats {
    /// `allocate` calls since creation.
    pub allocations_made: u64,
    pub live_allocations: usize,
    pub allocated_bytes: u64,
    pub reserved_bytes: u64,
}

struct ValidationLog {
    errors: Mutex<Vec<String>>,
    warnings: AtomicU64,
}

/// The GPU context. Create with [`Gpu::new`], end with [`Gpu::shutdown`].
pub struct Gpu {
    _entry: ash::Entry,
    pub(crate) instance: ash::Instance,
    debug_utils: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub(crate) debug_device: Option<ext::debug_utils::Device>,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) device: ash::Device,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    pub(crate) push_descriptor: khr::push_descriptor::Device,
    pub(crate) surface_instance: Option<khr::surface::Instance>,
    pub(crate) swapchain_device: Option<khr::swapchain::Device>,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    allocations_made: AtomicU64,
    pub(crate) command_pool: vk::CommandPool,
    pub(crate) linear_sampler: vk::Sampler,
    pub(crate) compiler: ShaderCompiler,
    log: Box<ValidationLog>,
    pub info: AdapterInfo,
    pub(crate) timestamps_supported: bool,
    pub(crate) watchdog: Watchdog,
    shut_down: bool,
}

/// What [`Gpu::new`] makes before the device: handed to `create_device` and back on failure, so that
/// teardown runs in reverse creation order.
struct InstanceParts {
    entry: ash::Entry,
    instance: ash::Instance,
    debug_utils: Option<(ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    log: Box<ValidationLog>,
}

impl InstanceParts {
    /// Destroy the messenger, then the instance, then free the messenger's user data, then unload the
    /// loader, in that order (each later one is used by the earlier ones).
    fn destroy(self) {
        let Self { entry, instance, debug_utils, log } = self;
        // SAFETY: nothing created from the instance is alive (create_device destroyed what it made before
        // returning its error); entry is still loaded and log still allocated across these calls.
        unsafe {
            if let Some((du, m)) = debug_utils {
                du.destroy_debug_utils_messenger(m, None);
            }
            instance.destroy_instance(None);
        }
        drop(log);
        drop(entry);
    }
}

unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the loader passes a valid callback-data pointer for the duration of the call, and
    // `user` is the boxed ValidationLog, which outlives the messenger (destroyed first in shutdown).
    let (msg, log) = unsafe {
        let msg = if data.is_null() || (*data).p_message.is_null() {
            String::from("(no message)")
        } else {
            CStr::from_ptr((*data).p_message).to_string_lossy().into_owned()
        };
        (msg, &*(user as *const ValidationLog))
    };
    if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        eprintln!("[vulkan validation error] {msg}");
        if let Ok(mut e) = log.errors.lock() {
            e.push(msg);
        }
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        log.warnings.fetch_add(1, Ordering::Relaxed);
        eprintln!("[vulkan validation warning] {msg}");
    }
    vk::FALSE
}

fn type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

fn type_name(t: vk::PhysicalDeviceType) -> &'static str {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
        vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
        vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
        vk::PhysicalDeviceType::CPU => "CPU",
        _ => "other",
    }
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

impl Gpu {
    /// Create the context: load Vulkan, choose the device (discrete > integrated > virtual > CPU,
    /// or `desc.device_name`), enable what the engine needs.
    pub fn new(desc: &GpuDesc) -> Result<Self> {
        // Fence timeout and test hook from the environment first: a malformed value fails before any Vulkan call.
        let watchdog = Watchdog::from_env()?;
        // SAFETY: loading libvulkan runs its initialisers; we trust the system loader.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::Loader(e.to_string()))?;

        // SAFETY: plain enumeration calls on a loaded entry.
        let layers = unsafe { entry.enumerate_instance_layer_properties() }.vk("vkEnumerateInstanceLayerProperties")?;
        let has_validation = layers.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == VALIDATION_LAYER));
        let validation = match desc.validation {
            ValidationMode::Off => false,
            ValidationMode::IfAvailable => {
                if !has_validation {
                    log::warn!(
                        "validation layer not installed (apt-get install vulkan-validationlayers): running without it"
                    );
                }
                has_validation
            }
            ValidationMode::Required => {
                if !has_validation {
                    return Err(GpuError::Other(
                        "the Khronos validation layer is required but not installed: apt-get install vulkan-validationlayers".into(),
                    ));
                }
                true
            }
        };

        let app_name = CString::new("softshadows").unwrap_or_default();
        let app = vk::ApplicationInfo::default().application_name(&app_name).api_version(vk::API_VERSION_1_3);
        let mut ext_names: Vec<*const i8> = desc.surface_extensions.iter().map(|e| e.as_ptr()).collect();
        if validation {
            ext_names.push(ext::debug_utils::NAME.as_ptr());
        }
        let layer_names = if validation { vec![VALIDATION_LAYER.as_ptr()] } else { vec![] };
        let log = Box::new(ValidationLog { errors: Mutex::new(Vec::new()), warnings: AtomicU64::new(0) });
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::ERROR | vk::DebugUtilsMessageSeverityFlagsEXT::WARNING,
            )
            .message_type(
                // Not PERFORMANCE: images stay in GENERAL layout by design (see resources.rs).
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION,
            )
            .pfn_user_callback(Some(debug_callback))
            .user_data(&*log as *const ValidationLog as *mut c_void);
        let mut instance_info = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_extension_names(&ext_names)
            .enabled_layer_names(&layer_names);
        if validation {
            instance_info = instance_info.push_next(&mut messenger_info);
        }
        // SAFETY: every pointer in instance_info refers to locals alive across the call.
        let instance = unsafe { entry.create_instance(&instance_info, None) }.vk("vkCreateInstance")?;

        let debug_utils = if validation {
            let du = ext::debug_utils::Instance::new(&entry, &instance);
            // SAFETY: the messenger's user data (log) is boxed and outlives the messenger.
            match unsafe { du.create_debug_utils_messenger(&messenger_info, None) } {
                Ok(m) => Some((du, m)),
                Err(result) => {
                    // SAFETY: nothing else was created from the instance; entry is still loaded.
                    unsafe { instance.destroy_instance(None) };
                    return Err(GpuError::Vk { call: "vkCreateDebugUtilsMessengerEXT", result });
                }
            }
        } else {
            None
        };

        match Self::create_device(InstanceParts { entry, instance, debug_utils, log }, desc, validation, watchdog) {
            Ok(gpu) => Ok(gpu),
            Err(failed) => {
                let (e, parts) = *failed;
                parts.destroy();
                Err(e)
            }
        }
    }

    /// Choose the adapter and create the device from `parts`. On failure everything made here from the
    /// device is already destroyed, and `parts` comes back whole so that [`InstanceParts::destroy`] can end
    /// the messenger and the instance while the loader (`entry`) and the messenger's user data (`log`)
    /// are still alive. (Dropping them first, as an earlier version did, unloaded libvulkan under the
    /// cleanup: `--device NoSuchGPU` segfaulted instead of printing the adapters present.)
    fn create_device(
        parts: InstanceParts,
        desc: &GpuDesc,
        validation: bool,
        watchdog: Watchdog,
    ) -> std::result::Result<Self, Box<(GpuError, InstanceParts)>> {
        macro_rules! fail {
            ($e:expr) => {
                return Err(Box::new(($e, parts)))
            };
        }
        let instance = &parts.instance;
        // SAFETY: enumeration on a valid instance.
        let physicals = match unsafe { instance.enumerate_physical_devices() } {
            Ok(p) => p,
            Err(e) => fail!(GpuError::Vk { call: "vkEnumeratePhysicalDevices", result: e }),
        };
        let windowed = !desc.surface_extensions.is_empty();
        let mut candidates = Vec::new();
        let mut rejected = Vec::new();
        for &pd in &physicals {
            // SAFETY: queries on a physical device from this instance.
            let (props, families, exts) = unsafe {
                (
                    instance.get_physical_device_properties(pd),
                    instance.get_physical_device_queue_family_properties(pd),
                    instance.enumerate_device_extension_properties(pd).unwrap_or_default(),
                )
            };
            let name = props.device_name_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
            let has_ext = |n: &CStr| exts.iter().any(|e| e.extension_name_as_c_str().is_ok_and(|x| x == n));
            if props.api_version < vk::API_VERSION_1_3 {
                rejected.push(format!("{name}: Vulkan {} < 1.3", version_string(props.api_version)));
                continue;
            }
            if !has_ext(khr::push_descriptor::NAME) {
                rejected.push(format!("{name}: no VK_KHR_push_descriptor"));
                continue;
            }
            if windowed && !has_ext(khr::swapchain::NAME) {
                rejected.push(format!("{name}: no VK_KHR_swapchain"));
                continue;
            }
            let family = families
                .iter()
                .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE));
            let Some(family) = family else {
                rejected.push(format!("{name}: no graphics+compute queue"));
                continue;
            };
            let ts_bits = families[family].timestamp_valid_bits;
            candidates.push((pd, props, family as u32, name, ts_bits));
        }
        if let Some(want) = &desc.device_name {
            let w = want.to_lowercase();
            candidates.retain(|c| c.3.to_lowercase().contains(&w));
            if candidates.is_empty() {
                let names: Vec<String> = physicals
                    .iter()
                    .map(|&pd| {
                        // SAFETY: query on a valid physical device.
                        let p = unsafe { instance.get_physical_device_properties(pd) };
                        p.device_name_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default()
                    })
                    .collect();
                fail!(GpuError::NoDevice(if names.is_empty() {
                    format!("no adapter matches --device {want:?}: the Vulkan loader found no device at all. {INSTALL_HINT}")
                } else {
                    format!(
                        "no adapter matches --device {want:?} (a case-insensitive part of the name); available adapters: {}",
                        names.join(", ")
                    )
                }));
            }
        }
        candidates.sort_by_key(|c| type_rank(c.1.device_type));
        let Some((physical, props, queue_family, name, ts_bits)) = candidates.into_iter().next() else {
            fail!(GpuError::NoDevice(if physicals.is_empty() {
                format!("the Vulkan loader found no device. {INSTALL_HINT}")
            } else {
                format!("no adapter fits: {}", rejected.join("; "))
            }));
        };

        let priorities = [1.0f32];
        let queue_info =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let mut dev_exts = vec![khr::push_descriptor::NAME.as_ptr()];
        if windowed {
            dev_exts.push(khr::swapchain::NAME.as_ptr());
        }
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .maintenance4(true);
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default().host_query_reset(true);
        let features = vk::PhysicalDeviceFeatures::default();
        let device_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&dev_exts)
            .enabled_features(&features)
            .push_next(&mut f13)
            .push_next(&mut f12);
        // SAFETY: all pointers refer to locals alive across the call.
        let device = match unsafe { instance.create_device(physical, &device_info, None) } {
            Ok(d) => d,
            Err(e) => fail!(GpuError::Vk { call: "vkCreateDevice", result: e }),
        };
        // SAFETY: the family was requested with one queue.
        let queue = unsafe { device.get_device_queue(queue_family, 0) };

        let allocator = match Allocator::new(&AllocatorCreateDesc {
            instance: instance.clone(),
            device: device.clone(),
            physical_device: physical,
            debug_settings: {
                let mut d = gpu_allocator::AllocatorDebugSettings::default();
                d.log_leaks_on_shutdown = false; // shutdown() reports leaks as an error instead
                d
            },
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        }) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: nothing was created from the device yet.
                unsafe { device.destroy_device(None) };
                fail!(GpuError::Other(format!("gpu-allocator: {e}")))
            }
        };
        let pool_info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid device and create info; sampler create info has no pointers.
        let (command_pool, linear_sampler) = unsafe {
            let pool = device.create_command_pool(&pool_info, None);
            let sampler = device.create_sampler(
                &vk::SamplerCreateInfo::default()
                    .mag_filter(vk::Filter::LINEAR)
                    .min_filter(vk::Filter::LINEAR)
                    .mipmap_mode(vk::SamplerMipmapMode::LINEAR)
                    .address_mode_u(vk::SamplerAddressMode::REPEAT)
                    .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                    .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
                    .max_lod(vk::LOD_CLAMP_NONE),
                None,
            );
            match (pool, sampler) {
                (Ok(p), Ok(s)) => (p, s),
                (p, s) => {
                    drop(allocator);
                    if let Ok(p) = p {
                        device.destroy_command_pool(p, None);
                    }
                    if let Ok(s) = s {
                        device.destroy_sampler(s, None);
                    }
                    device.destroy_device(None);
                    fail!(GpuError::Other("could not create the command pool or sampler".into()))
                }
            }
        };

        let compiler = match ShaderCompiler::new(desc.shader_root.clone()) {
            Ok(c) => c,
            Err(e) => {
                drop(allocator);
                // SAFETY: objects created above from this device, nothing in flight.
                unsafe {
                    device.destroy_sampler(linear_sampler, None);
                    device.destroy_command_pool(command_pool, None);
                    device.destroy_device(None);
                }
                fail!(e)
            }
        };

        let driver = {
            let mut drv = vk::PhysicalDeviceDriverProperties::default();
            let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut drv);
            // SAFETY: valid physical device; p2 chain lives across the call.
            unsafe { instance.get_physical_device_properties2(physical, &mut p2) };
            let n = drv.driver_name_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
            let i = drv.driver_info_as_c_str().map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
            format!("{n} {i}").trim().to_string()
        };
        let info = AdapterInfo {
            name,
            device_type: type_name(props.device_type).into(),
            driver,
            api_version: version_string(props.api_version),
            validation,
            timestamp_period_ns: props.limits.timestamp_period as f64,
        };
        if desc.verbose {
            eprintln!(
                "adapter: {} ({}, {}, Vulkan {}){}",
                info.name,
                info.device_type,
                info.driver,
                info.api_version,
                if validation { ", validation on" } else { "" }
            );
        }
        let debug_device = validation.then(|| ext::debug_utils::Device::new(instance, &device));
        let push_descriptor = khr::push_descriptor::Device::new(instance, &device);
        let surface_instance = windowed.then(|| khr::surface::Instance::new(&parts.entry, instance));
        let swapchain_device = windowed.then(|| khr::swapchain::Device::new(instance, &device));
        let InstanceParts { entry, instance, debug_utils, log } = parts;
        Ok(Self {
            _entry: entry,
            instance,
            debug_utils,
            debug_device,
            physical,
            device,
            queue,
            queue_family,
            push_descriptor,
            surface_instance,
            swapchain_device,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            allocations_made: AtomicU64::new(0),
            command_pool,
            linear_sampler,
            compiler,
            log,
            info,
            timestamps_supported: ts_bits > 0 && props.limits.timestamp_compute_and_graphics == vk::TRUE,
            watchdog,
            shut_down: false,
        })
    }

    /// The raw entry for window-surface creation (`ash_window`).
    pub(crate) fn entry(&self) -> &ash::Entry {
        &self._entry
    }

    pub(crate) fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: gpu_allocator::MemoryLocation,
        linear: bool,
    ) -> Result<gpu_allocator::vulkan::Allocation> {
        let mut alloc = self.allocator.lock().map_err(|_| GpuError::Other("allocator lock poisoned".into()))?;
        self.allocations_made.fetch_add(1, Ordering::Relaxed);
        alloc
            .allocate(&gpu_allocator::vulkan::AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: gpu_allocator::vulkan::AllocationScheme::GpuAllocatorManaged,
            })
            .map_err(|source| GpuError::Alloc { name: name.to_string(), source })
    }

    pub(crate) fn free(&self, allocation: gpu_allocator::vulkan::Allocation) {
        if let Ok(mut a) = self.allocator.lock() {
            if let Err(e) = a.free(allocation) {
                log::error!("freeing an allocation failed: {e}");
            }
        }
    }

    /// Device memory currently allocated and the number of allocations ever made.
    pub fn memory_stats(&self) -> MemoryStats {
        let report = self.allocator.lock().map(|a| a.generate_report()).ok();
        MemoryStats {
            allocations_made: self.allocations_made.load(Ordering::Relaxed),
            live_allocations: report.as_ref().map_or(0, |r| r.allocations.len()),
            allocated_bytes: report.as_ref().map_or(0, |r| r.total_allocated_bytes),
            reserved_bytes: report.as_ref().map_or(0, |r| r.total_capacity_bytes),
        }
    }

    /// Validation errors seen so far.
    pub fn validation_errors(&self) -> Vec<String> {
        self.log.errors.lock().map(|e| e.clone()).unwrap_or_default()
    }

    /// Give a Vulkan object a debug name (shown by validation messages and capture tools).
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        if let Some(du) = &self.debug_device {
            let Ok(cname) = CString::new(name) else { return };
            let info = vk::DebugUtilsObjectNameInfoEXT::default().object_handle(handle).object_name(&cname);
            // SAFETY: handle belongs to this device; the name outlives the call.
            let _ = unsafe { du.set_debug_utils_object_name(&info) };
        }
    }

    /// Wait until the device is idle.
    pub fn wait_idle(&self) -> Result<()> {
        // SAFETY: valid device.
        unsafe { self.device.device_wait_idle() }.vk("vkDeviceWaitIdle")
    }

    /// Record commands into a one-time command buffer, submit and wait (at most [`Gpu::fence_timeout`]).
    pub fn submit_and_wait(&self, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        self.submit_and_wait_labeled("a one-time submission", record)
    }

    /// [`Gpu::submit_and_wait`] with the submission's name for a timeout or device-loss error.
    pub(crate) fn submit_and_wait_labeled(&self, label: &str, record: impl FnOnce(vk::CommandBuffer)) -> Result<()> {
        self.check_not_lost(label)?;
        self.drain();
        let alloc_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool belongs to this device and is used from one thread (&self methods here are
        // not called concurrently by the engine).
        unsafe {
            let cmd = self.device.allocate_command_buffers(&alloc_info).vk("vkAllocateCommandBuffers")?[0];
            let result = (|| {
                self.device
                    .begin_command_buffer(
                        cmd,
                        &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
                    )
                    .vk("vkBeginCommandBuffer")?;
                record(cmd);
                self.device.end_command_buffer(cmd).vk("vkEndCommandBuffer")?;
                let fence = self.device.create_fence(&vk::FenceCreateInfo::default(), None).vk("vkCreateFence")?;
                let cmds = [cmd];
                let submit = vk::SubmitInfo::default().command_buffers(&cmds);
                if let Err(e) = self.device.queue_submit(self.queue, &[submit], fence).vk("vkQueueSubmit") {
                    self.device.destroy_fence(fence, None);
                    return Err(e);
                }
                let r = self.wait_fence(fence, || format!("{label} (not a frame: an upload, readback or transition)"));
                if r.is_err() {
                    // The submission may still run: the device must be idle before its fence and command
                    // buffer (and the caller's staging buffers, destroyed next) go (watchdog.rs).
                    self.drain();
                }
                self.device.destroy_fence(fence, None);
                r
            })();
            self.device.free_command_buffers(self.command_pool, &[cmd]);
            result
        }
    }

    /// Tear everything down in reverse order. Returns an error listing leaked allocations (by
    /// name) and validation errors, so that tests fail on either.
    pub fn shutdown(mut self) -> Result<()> {
        self.shutdown_inner()
    }

    fn shutdown_inner(&mut self) -> Result<()> {
        if self.shut_down {
            return Ok(());
        }
        self.shut_down = true;
        let mut problems = Vec::new();
        // SAFETY: teardown in reverse creation order after the device is idle; the allocator is
        // dropped before the device (gpu-allocator requirement).
        unsafe {
            let _ = self.device.device_wait_idle();
            let _ = self.watchdog.take_draining();
            self.device.destroy_sampler(self.linear_sampler, None);
            self.device.destroy_command_pool(self.command_pool, None);
            if let Ok(a) = self.allocator.lock() {
                let report = a.generate_report();
                for leak in &report.allocations {
                    problems.push(format!("leaked device allocation '{}' ({} bytes)", leak.name, leak.size));
                }
            }
            ManuallyDrop::drop(&mut self.allocator);
            self.device.destroy_device(None);
            if let Some((du, m)) = self.debug_utils.take() {
                du.destroy_debug_utils_messenger(m, None);
            }
            self.instance.destroy_instance(None);
        }
        for e in self.validation_errors() {
            problems.push(format!("validation error: {e}"));
        }
        if problems.is_empty() {
            Ok(())
        } else {
            Err(GpuError::Teardown(problems.join("\n")))
        }
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        if let Err(e) = self.shutdown_inner() {
            eprintln!("{e}");
        }
    }
}
