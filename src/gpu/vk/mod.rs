//! The second device path: irt's kernels on raw Vulkan through `ash`, beside wgpu.
//!
//! Same adapter rules ([`super::adapter::choose_adapter`]), same composed WGSL
//! ([`super::shaders::compose`]) turned into SPIR-V by naga with the options wgpu-hal would use,
//! same binding table, scene packing and [`super::recording::Recording`]s; only the Vulkan objects
//! are this module's own: instance, device with one compute queue, the descriptor set layout of
//! the binding table, buffers, the scene image, one command buffer and fence (each dispatch is
//! recorded, submitted and waited for, as the wgpu dispatcher does).
//!
//! Every Vulkan failure is a [`VkError`], never a panic.

mod device;
mod kernel;
mod queries;
mod spirv;
mod validate;

pub use device::VkBound;
pub use kernel::{SceneImage, VkDispatcher, VkScene};
pub use queries::{DispatchSample, QuerySupport};
pub use spirv::{check_spirv, compile_entry, spv_options};
pub use validate::{full_check, naga_check, spirv_val_available, spirv_val_check, FullCheck};

use super::adapter::{choose_adapter, AdapterChoice, AdapterFacts, ContextError};
use ash::vk;
use std::ffi::CStr;
use std::sync::{Arc, Mutex};

/// What can go wrong on the ash path.
#[derive(Debug, thiserror::Error)]
pub enum VkError {
    /// No Vulkan, no adapter of that name, no lavapipe: the wgpu path's words.
    #[error(transparent)]
    Choice(#[from] ContextError),
    #[error("Vulkan call {what} failed: {result}")]
    Call { what: &'static str, result: vk::Result },
    #[error("the Vulkan device was lost during {what} (VK_ERROR_DEVICE_LOST); its results are gone")]
    DeviceLost { what: &'static str },
    #[error("{0}")]
    Shader(String),
    #[error("{0}")]
    Other(String),
    /// A failure the device-neutral layer found (a frame larger than the buffers).
    #[error("{0}")]
    Neutral(String),
}

impl From<crate::gpu::GpuError> for VkError {
    fn from(e: crate::gpu::GpuError) -> Self {
        match e {
            crate::gpu::GpuError::Vulkan(v) => v,
            other => VkError::Neutral(other.to_string()),
        }
    }
}

/// How the ash path opens its device and makes its pipelines: the raw-Vulkan levers of
/// docs/backends.md, each measured there. [`VkOptions::default`] is what pays (or is safe).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VkOptions {
    /// The device's robustness (robustBufferAccess, robustBufferAccess2, robustImageAccess(2)) on,
    /// as wgpu-hal opens it, with naga's buffer and image checks off where it covers them (the
    /// default). Off: none of those features, and naga writes no buffer or image checks either
    /// (`BoundsCheckPolicy::Unchecked`): an access out of bounds is undefined.
    pub robust: bool,
    /// naga's index checks (`Restrict`: indices into local arrays, vectors and matrices clamped).
    /// The kernels' only run-time indexed local array is the recursion stack, at most
    /// `max_depth` <= `MAX_STACK` deep (`Scene::validate`), and vector indices are computed
    /// modulo their size, so `false` (`Unchecked`) is in bounds too.
    pub index_checks: bool,
    /// The tile (binding 4) as push constants instead of a host-visible uniform buffer written
    /// before each dispatch: the module's `tile` moved to the immediate address space before
    /// naga writes SPIR-V, and `vkCmdPushConstants` in each dispatch.
    pub push_tile: bool,
    /// Besides the structural check that always runs, check each SPIR-V module fully before the
    /// driver sees it (`validate::full_check`: naga's SPIR-V front end and validator on the
    /// words, and `spirv-val` where it is installed).
    pub full_spirv_check: bool,
    /// Per-dispatch timestamps and a compute-invocations query around every dispatch
    /// (`VkContext::take_samples`), where the device supports them.
    pub profile: bool,
    /// Test hook: open the device as if it had no `shaderFloat64`.
    #[doc(hidden)]
    pub pretend_no_f64: bool,
}

impl Default for VkOptions {
    fn default() -> Self {
        VkOptions {
            robust: true,
            index_checks: true,
            push_tile: false,
            full_spirv_check: false,
            profile: false,
            pretend_no_f64: false,
        }
    }
}

/// Maps a failed call to its error (device loss named as such).
pub(crate) fn fail(what: &'static str) -> impl Fn(vk::Result) -> VkError {
    move |result| match result {
        vk::Result::ERROR_DEVICE_LOST => VkError::DeviceLost { what },
        result => VkError::Call { what, result },
    }
}

/// What the device was opened with, for the kernels (SPIR-V options) and the limits of uploads.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Caps {
    pub api_version: u32,
    pub f64: bool,
    pub robust_buffer_access2: bool,
    pub robust_image_access: bool,
    pub zero_init_workgroup: bool,
    pub max_texture_dimension_2d: u32,
    pub max_texture_array_layers: u32,
    /// The most bytes one storage buffer binding covers (`maxStorageBufferRange`, and Vulkan
    /// 1.3's `maxBufferSize` where the device has it).
    pub max_binding_bytes: u64,
    /// The levers the device was opened with ([`VkOptions`]).
    pub options: VkOptions,
    /// Timestamps and pipeline statistics, where `options.profile` asked and the device has them.
    pub queries: QuerySupport,
    /// Lanes of a SIMD group, where compute shaders have subgroup operations (Vulkan 1.1's
    /// basic and ballot sets: `Variant::simd_stats`'s subgroupBroadcastFirst).
    pub subgroup_size: Option<u32>,
}

/// The instance, device and queue, shared (reference-counted) by everything made on them, so that
/// the device outlives its buffers, images and pipelines.
pub(crate) struct Shared {
    _entry: ash::Entry,
    instance: ash::Instance,
    pub device: ash::Device,
    queue: vk::Queue,
    pool: vk::CommandPool,
    /// The one command buffer and its fence: a submit records, submits and waits under this lock.
    submit: Mutex<(vk::CommandBuffer, vk::Fence)>,
    memory: vk::PhysicalDeviceMemoryProperties,
    pub caps: Caps,
    /// The query pools of `VkOptions::profile` and what they measured.
    pub(crate) queries: Option<queries::Queries>,
}

impl Drop for Shared {
    fn drop(&mut self) {
        // SAFETY: everything made on the device holds this `Shared`, so all of it is gone.
        unsafe {
            let _ = self.device.device_wait_idle();
            if let Some(q) = &self.queries {
                q.destroy(&self.device);
            }
            let (_, fence) = *self.submit.lock().unwrap_or_else(|e| e.into_inner());
            self.device.destroy_fence(fence, None);
            self.device.destroy_command_pool(self.pool, None);
            self.device.destroy_device(None);
            self.instance.destroy_instance(None);
        }
    }
}

impl Shared {
    /// Records commands with `record`, submits them and waits for them.
    pub fn submit(
        &self,
        what: &'static str,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer),
    ) -> Result<(), VkError> {
        self.submit_then(what, record, |_| Ok(()))
    }

    /// [`Shared::submit`], then `after` once the submission has completed, still under the
    /// submit lock (so no other submission resets what it reads, such as the queries).
    pub fn submit_then<T>(
        &self,
        what: &'static str,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer),
        after: impl FnOnce(&ash::Device) -> Result<T, VkError>,
    ) -> Result<T, VkError> {
        let guard = self.submit.lock().unwrap_or_else(|e| e.into_inner());
        let (cmd, fence) = *guard;
        let d = &self.device;
        // SAFETY: the command buffer and fence are used only under the lock, and the previous
        // submission was waited for before the lock was released.
        unsafe {
            d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()).map_err(fail(what))?;
            d.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )
            .map_err(fail(what))?;
            // Whatever earlier submissions wrote is visible to this one.
            let all = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
                .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE);
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::ALL_COMMANDS,
                vk::PipelineStageFlags::ALL_COMMANDS,
                vk::DependencyFlags::empty(),
                &[all],
                &[],
                &[],
            );
            record(d, cmd);
            // And everything this one wrote, to the host.
            let host = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ);
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::ALL_COMMANDS,
                vk::PipelineStageFlags::HOST,
                vk::DependencyFlags::empty(),
                &[host],
                &[],
                &[],
            );
            d.end_command_buffer(cmd).map_err(fail(what))?;
            let cmds = [cmd];
            d.queue_submit(self.queue, &[vk::SubmitInfo::default().command_buffers(&cmds)], fence)
                .map_err(fail(what))?;
            let waited = d.wait_for_fences(&[fence], true, u64::MAX).map_err(fail(what));
            d.reset_fences(&[fence]).map_err(fail(what))?;
            waited?;
            after(d)
        }
    }

    /// A buffer of `size` bytes (at least 16). `host`: host-visible and coherent, mapped for its
    /// lifetime (uniforms written from the host, staging, readback); else device-local where the
    /// device has such memory.
    pub fn buffer(
        self: &Arc<Self>,
        size: u64,
        usage: vk::BufferUsageFlags,
        host: bool,
    ) -> Result<Buffer, VkError> {
        let size = size.max(16);
        let d = &self.device;
        // SAFETY: plain object creation; every object is destroyed by `Buffer::drop`.
        unsafe {
            let raw = d
                .create_buffer(
                    &vk::BufferCreateInfo::default()
                        .size(size)
                        .usage(usage)
                        .sharing_mode(vk::SharingMode::EXCLUSIVE),
                    None,
                )
                .map_err(fail("vkCreateBuffer"))?;
            let req = d.get_buffer_memory_requirements(raw);
            let (want, prefer) = if host {
                (
                    vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT,
                    vk::MemoryPropertyFlags::HOST_CACHED,
                )
            } else {
                (vk::MemoryPropertyFlags::empty(), vk::MemoryPropertyFlags::DEVICE_LOCAL)
            };
            let memory = match self.allocate(req, want, prefer) {
                Ok(m) => m,
                Err(e) => {
                    d.destroy_buffer(raw, None);
                    return Err(e);
                }
            };
            let buffer = Buffer {
                shared: self.clone(),
                raw,
                memory,
                size,
                mapped: Mutex::new(Mapping(std::ptr::null_mut())),
            };
            d.bind_buffer_memory(raw, memory, 0).map_err(fail("vkBindBufferMemory"))?;
            if host {
                let ptr = d
                    .map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())
                    .map_err(fail("vkMapMemory"))? as *mut u8;
                *buffer.mapped.lock().unwrap_or_else(|e| e.into_inner()) = Mapping(ptr);
            }
            Ok(buffer)
        }
    }

    /// Memory for `req` with all of `want` and, where some type has them, `prefer`.
    pub fn allocate(
        &self,
        req: vk::MemoryRequirements,
        want: vk::MemoryPropertyFlags,
        prefer: vk::MemoryPropertyFlags,
    ) -> Result<vk::DeviceMemory, VkError> {
        let types = &self.memory.memory_types[..self.memory.memory_type_count as usize];
        let fits = |i: usize, flags: vk::MemoryPropertyFlags| {
            req.memory_type_bits & (1 << i) != 0 && types[i].property_flags.contains(flags)
        };
        let index = (0..types.len())
            .find(|&i| fits(i, want | prefer))
            .or_else(|| (0..types.len()).find(|&i| fits(i, want)))
            .ok_or_else(|| {
                VkError::Other(format!(
                    "no Vulkan memory type with {want:?} for a {} byte resource",
                    req.size
                ))
            })?;
        // SAFETY: a valid allocation request; freed by the owner's drop.
        unsafe {
            self.device
                .allocate_memory(
                    &vk::MemoryAllocateInfo::default()
                        .allocation_size(req.size)
                        .memory_type_index(index as u32),
                    None,
                )
                .map_err(fail("vkAllocateMemory"))
        }
    }
}

/// Where a host-visible buffer is mapped (null if it is not).
struct Mapping(*mut u8);

// SAFETY: the pointer is into a mapping the buffer owns for its lifetime; every access goes
// through the buffer's lock.
unsafe impl Send for Mapping {}

/// A buffer and its memory (mapped if host-visible).
pub(crate) struct Buffer {
    shared: Arc<Shared>,
    pub raw: vk::Buffer,
    memory: vk::DeviceMemory,
    pub size: u64,
    mapped: Mutex<Mapping>,
}

impl Buffer {
    /// Writes `bytes` at `offset` of a host-visible buffer (no submission may be using it).
    pub fn write(&self, offset: u64, bytes: &[u8]) {
        let m = self.mapped.lock().unwrap_or_else(|e| e.into_inner());
        assert!(!m.0.is_null() && offset + bytes.len() as u64 <= self.size, "write to a mapped buffer");
        // SAFETY: in bounds of the mapping (checked), which lives as long as `self`, under its
        // lock; the caller's submissions are waited for before they return, so the device does
        // not read it now.
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), m.0.add(offset as usize), bytes.len()) }
    }

    /// A copy of the first `len` bytes of a host-visible buffer.
    pub fn read(&self, len: u64) -> Vec<u8> {
        self.read_with(len, <[u8]>::to_vec)
    }

    /// `read` of the first `len` bytes of a host-visible buffer, in place.
    pub fn read_with<T>(&self, len: u64, read: impl FnOnce(&[u8]) -> T) -> T {
        let m = self.mapped.lock().unwrap_or_else(|e| e.into_inner());
        assert!(!m.0.is_null() && len <= self.size, "read of a mapped buffer");
        // SAFETY: as in `write`; coherent memory, and the submission that wrote it was waited for.
        read(unsafe { std::slice::from_raw_parts(m.0, len as usize) })
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: no submission is in flight (each is waited for); the device is alive (`shared`).
        unsafe {
            self.shared.device.destroy_buffer(self.raw, None);
            self.shared.device.free_memory(self.memory, None);
        }
    }
}

fn device_type(t: vk::PhysicalDeviceType) -> wgpu::DeviceType {
    match t {
        vk::PhysicalDeviceType::INTEGRATED_GPU => wgpu::DeviceType::IntegratedGpu,
        vk::PhysicalDeviceType::DISCRETE_GPU => wgpu::DeviceType::DiscreteGpu,
        vk::PhysicalDeviceType::VIRTUAL_GPU => wgpu::DeviceType::VirtualGpu,
        vk::PhysicalDeviceType::CPU => wgpu::DeviceType::Cpu,
        _ => wgpu::DeviceType::Other,
    }
}

fn c_text(s: Result<&CStr, std::ffi::FromBytesUntilNulError>) -> String {
    s.map(|c| c.to_string_lossy().into_owned()).unwrap_or_default()
}

/// An adapter as the ash path sees it: what wgpu's `AdapterInfo` says, from the same queries.
#[derive(Clone, Debug)]
pub struct VkAdapterInfo {
    pub name: String,
    pub driver: String,
    pub driver_info: String,
    pub device_type: wgpu::DeviceType,
    pub api_version: (u32, u32, u32),
}

/// An open Vulkan device on the ash path.
pub struct VkContext {
    pub(crate) shared: Arc<Shared>,
    pub info: VkAdapterInfo,
}

impl std::fmt::Debug for VkContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "VkContext({} / {})", self.info.name, self.info.driver)
    }
}

fn has_extension(exts: &[vk::ExtensionProperties], name: &CStr) -> bool {
    exts.iter().any(|e| e.extension_name_as_c_str() == Ok(name))
}

impl VkContext {
    /// Opens the adapter `choice` names (the wgpu path's rules and messages) with one compute
    /// queue.
    pub fn new(choice: &AdapterChoice) -> Result<Self, VkError> {
        Self::with_options(choice, VkOptions::default())
    }

    /// [`VkContext::new`] with the levers of `options`.
    pub fn with_options(choice: &AdapterChoice, options: VkOptions) -> Result<Self, VkError> {
        super::instance::ensure_runtime_dir();
        // SAFETY: loading the system's Vulkan loader, as wgpu-hal does.
        let entry = unsafe { ash::Entry::load() }.map_err(|_| ContextError::NoVulkan)?;
        // SAFETY: plain instance creation without layers or extensions (no surfaces: headless).
        let instance_version =
            unsafe { entry.try_enumerate_instance_version() }.ok().flatten().unwrap_or(vk::API_VERSION_1_0);
        if instance_version < vk::API_VERSION_1_1 {
            return Err(VkError::Other("the Vulkan loader is 1.0; irt's ash path needs Vulkan 1.1".into()));
        }
        let app = vk::ApplicationInfo::default()
            .application_name(c"irt")
            .engine_name(c"irt-ash")
            .api_version(vk::API_VERSION_1_3);
        let instance = match unsafe {
            entry.create_instance(&vk::InstanceCreateInfo::default().application_info(&app), None)
        } {
            Ok(i) => i,
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => return Err(ContextError::NoVulkan.into()),
            Err(e) => return Err(fail("vkCreateInstance")(e)),
        };
        // From here the instance must be destroyed on every error: `open` returns it back.
        match Self::open(&instance, choice, options) {
            Ok((physical, device, family, caps, info)) => {
                Self::finish(entry, instance, physical, device, family, caps, info)
            }
            Err(e) => {
                // SAFETY: nothing was made on it that still lives.
                unsafe { instance.destroy_instance(None) };
                Err(e)
            }
        }
    }

    #[allow(clippy::type_complexity)]
    fn open(
        instance: &ash::Instance,
        choice: &AdapterChoice,
        options: VkOptions,
    ) -> Result<(vk::PhysicalDevice, ash::Device, u32, Caps, VkAdapterInfo), VkError> {
        // SAFETY: queries on a live instance.
        unsafe {
            let physicals = match instance.enumerate_physical_devices() {
                Ok(p) => p,
                Err(vk::Result::ERROR_INITIALIZATION_FAILED) => Vec::new(),
                Err(e) => return Err(fail("vkEnumeratePhysicalDevices")(e)),
            };
            let mut infos = Vec::new();
            for &pd in &physicals {
                let props = instance.get_physical_device_properties(pd);
                let mut driver = vk::PhysicalDeviceDriverProperties::default();
                if props.api_version >= vk::API_VERSION_1_2 {
                    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
                    instance.get_physical_device_properties2(pd, &mut p2);
                }
                let v = props.api_version;
                infos.push(VkAdapterInfo {
                    name: c_text(props.device_name_as_c_str()),
                    driver: c_text(driver.driver_name_as_c_str()),
                    driver_info: c_text(driver.driver_info_as_c_str()),
                    device_type: device_type(props.device_type),
                    api_version: (
                        vk::api_version_major(v),
                        vk::api_version_minor(v),
                        vk::api_version_patch(v),
                    ),
                });
            }
            let facts: Vec<AdapterFacts> = infos
                .iter()
                .map(|i| AdapterFacts {
                    name: i.name.clone(),
                    driver: i.driver.clone(),
                    device_type: i.device_type,
                })
                .collect();
            let index = choose_adapter(choice, &facts)?;
            let pd = physicals[index];
            let info = infos[index].clone();
            let props = instance.get_physical_device_properties(pd);
            let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
            let mut maintenance4 = vk::PhysicalDeviceMaintenance4Properties::default();
            if props.api_version >= vk::API_VERSION_1_1 {
                let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut subgroup);
                if props.api_version >= vk::API_VERSION_1_3 {
                    p2 = p2.push_next(&mut maintenance4);
                }
                instance.get_physical_device_properties2(pd, &mut p2);
            }
            // Vulkan 1.3's largest buffer; before it, only the allocation limit bounds one.
            let max_buffer_size = match maintenance4.max_buffer_size {
                0 => u64::MAX,
                n => n,
            };
            let subgroup_size = (subgroup.supported_stages.contains(vk::ShaderStageFlags::COMPUTE)
                && subgroup
                    .supported_operations
                    .contains(vk::SubgroupFeatureFlags::BASIC | vk::SubgroupFeatureFlags::BALLOT))
            .then_some(subgroup.subgroup_size);
            let family = instance
                .get_physical_device_queue_family_properties(pd)
                .iter()
                .position(|f| f.queue_flags.contains(vk::QueueFlags::COMPUTE))
                .ok_or_else(|| VkError::Other(format!("{} has no compute queue", info.name)))?
                as u32;
            let exts = instance
                .enumerate_device_extension_properties(pd)
                .map_err(fail("vkEnumerateDeviceExtensionProperties"))?;
            let api = props.api_version;
            let has_rob2 = has_extension(&exts, ash::ext::robustness2::NAME);
            // What the device offers: wgpu-hal turns the same robustness and zero-init features on
            // and picks naga's bounds-check policies from them (spirv::spv_options).
            let mut rob2 = vk::PhysicalDeviceRobustness2FeaturesEXT::default();
            let mut v13 = vk::PhysicalDeviceVulkan13Features::default();
            let core = {
                let mut f2 = vk::PhysicalDeviceFeatures2::default();
                if has_rob2 {
                    f2 = f2.push_next(&mut rob2);
                }
                if api >= vk::API_VERSION_1_3 {
                    f2 = f2.push_next(&mut v13);
                }
                instance.get_physical_device_features2(pd, &mut f2);
                f2.features
            };
            let rob2 =
                (has_rob2).then_some((rob2.robust_buffer_access2 != 0, rob2.robust_image_access2 != 0));
            let robust_image_access = match rob2 {
                Some((_, image2)) => image2,
                None => v13.robust_image_access != 0,
            };
            let robust = options.robust;
            let queries = queries::QuerySupport::of(
                &props.limits,
                &instance.get_physical_device_queue_family_properties(pd)[family as usize],
                core.pipeline_statistics_query != 0,
                options.profile,
            );
            let caps = Caps {
                api_version: api,
                f64: core.shader_float64 != 0 && !options.pretend_no_f64,
                robust_buffer_access2: robust && rob2.is_some_and(|r| r.0),
                robust_image_access: robust && robust_image_access,
                zero_init_workgroup: api >= vk::API_VERSION_1_3
                    && v13.shader_zero_initialize_workgroup_memory != 0,
                max_texture_dimension_2d: props
                    .limits
                    .max_image_dimension2_d
                    .min(props.limits.max_image_dimension_cube)
                    .min(props.limits.max_framebuffer_width)
                    .min(props.limits.max_framebuffer_height),
                max_texture_array_layers: props.limits.max_image_array_layers,
                max_binding_bytes: (props.limits.max_storage_buffer_range as u64).min(max_buffer_size),
                options,
                queries,
                subgroup_size,
            };
            let enable_core = vk::PhysicalDeviceFeatures::default()
                .robust_buffer_access(robust && core.robust_buffer_access != 0)
                .shader_float64(caps.f64)
                .pipeline_statistics_query(queries.invocations);
            let mut enable_rob2 = vk::PhysicalDeviceRobustness2FeaturesEXT::default()
                .robust_buffer_access2(caps.robust_buffer_access2)
                .robust_image_access2(robust && rob2.is_some_and(|r| r.1));
            let mut enable_v13 = vk::PhysicalDeviceVulkan13Features::default()
                .robust_image_access(robust && v13.robust_image_access != 0)
                .shader_zero_initialize_workgroup_memory(caps.zero_init_workgroup);
            let priorities = [1.0];
            let queues = [vk::DeviceQueueCreateInfo::default()
                .queue_family_index(family)
                .queue_priorities(&priorities)];
            let ext_names = [ash::ext::robustness2::NAME.as_ptr()];
            let mut create =
                vk::DeviceCreateInfo::default().queue_create_infos(&queues).enabled_features(&enable_core);
            if has_rob2 {
                create = create.enabled_extension_names(&ext_names).push_next(&mut enable_rob2);
            }
            if api >= vk::API_VERSION_1_3 {
                create = create.push_next(&mut enable_v13);
            }
            let device = instance.create_device(pd, &create, None).map_err(|e| {
                VkError::Other(format!("could not open the device on adapter '{}': {e}", info.name))
            })?;
            Ok((pd, device, family, caps, info))
        }
    }

    fn finish(
        entry: ash::Entry,
        instance: ash::Instance,
        physical: vk::PhysicalDevice,
        device: ash::Device,
        family: u32,
        caps: Caps,
        info: VkAdapterInfo,
    ) -> Result<Self, VkError> {
        // SAFETY: object creation on the live device; on failure everything made is destroyed.
        unsafe {
            let memory = instance.get_physical_device_memory_properties(physical);
            let queue = device.get_device_queue(family, 0);
            let made = (|| {
                let pool = device
                    .create_command_pool(
                        &vk::CommandPoolCreateInfo::default()
                            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER)
                            .queue_family_index(family),
                        None,
                    )
                    .map_err(fail("vkCreateCommandPool"))?;
                let cmd = device
                    .allocate_command_buffers(
                        &vk::CommandBufferAllocateInfo::default()
                            .command_pool(pool)
                            .level(vk::CommandBufferLevel::PRIMARY)
                            .command_buffer_count(1),
                    )
                    .map_err(|e| {
                        device.destroy_command_pool(pool, None);
                        fail("vkAllocateCommandBuffers")(e)
                    })?[0];
                let fence = device.create_fence(&vk::FenceCreateInfo::default(), None).map_err(|e| {
                    device.destroy_command_pool(pool, None);
                    fail("vkCreateFence")(e)
                })?;
                Ok((pool, cmd, fence))
            })();
            let (pool, cmd, fence) = match made {
                Ok(m) => m,
                Err(e) => {
                    device.destroy_device(None);
                    instance.destroy_instance(None);
                    return Err(e);
                }
            };
            let queries = match queries::Queries::new(&device, caps.queries) {
                Ok(q) => q,
                Err(e) => {
                    device.destroy_fence(fence, None);
                    device.destroy_command_pool(pool, None);
                    device.destroy_device(None);
                    instance.destroy_instance(None);
                    return Err(e);
                }
            };
            let shared = Arc::new(Shared {
                _entry: entry,
                instance,
                device,
                queue,
                pool,
                submit: Mutex::new((cmd, fence)),
                memory,
                caps,
                queries,
            });
            Ok(VkContext { shared, info })
        }
    }

    /// The options the device was opened with.
    pub fn options(&self) -> VkOptions {
        self.shared.caps.options
    }

    /// Which queries `VkOptions::profile` has on this device (all off without it).
    pub fn query_support(&self) -> QuerySupport {
        self.shared.caps.queries
    }

    /// What the queries measured of each dispatch since the last call, in order (empty without
    /// `VkOptions::profile`).
    pub fn take_samples(&self) -> Vec<DispatchSample> {
        self.shared.queries.as_ref().map_or_else(Vec::new, |q| q.take())
    }

    /// Whether f64 shaders can run (`shaderFloat64`).
    pub fn has_f64(&self) -> bool {
        self.shared.caps.f64
    }

    /// The Mesa version of a lavapipe device, as [`super::GpuContext::mesa_version`].
    pub fn mesa_version(&self) -> Option<(u32, u32)> {
        super::adapter::mesa_version(&self.info.driver_info)
    }

    /// Creates a compute pipeline for `entry` of the SPIR-V `words` on the one binding layout,
    /// checks it, and destroys it: how a caller (a test) learns whether the words are accepted.
    pub fn try_pipeline(&self, words: &[u32], entry: &str) -> Result<(), VkError> {
        let layout = kernel::Layout::new(&self.shared)?;
        let p = layout.pipeline(words, entry)?;
        // SAFETY: never used.
        unsafe { self.shared.device.destroy_pipeline(p, None) };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every submit, wait, query read-back and pipeline creation maps its `vk::Result` through
    /// `fail` (pipeline creation: the same match), so `VK_ERROR_DEVICE_LOST` is this message
    /// wherever it comes back. Lavapipe cannot lose a device on demand, so the mapping is tested,
    /// not the loss.
    #[test]
    fn device_loss_is_named_and_other_failures_are_calls() {
        let lost = fail("a dispatch")(vk::Result::ERROR_DEVICE_LOST);
        assert!(matches!(lost, VkError::DeviceLost { what: "a dispatch" }), "{lost:?}");
        assert_eq!(
            lost.to_string(),
            "the Vulkan device was lost during a dispatch (VK_ERROR_DEVICE_LOST); its results are gone"
        );
        let oom = fail("vkCreateBuffer")(vk::Result::ERROR_OUT_OF_DEVICE_MEMORY);
        assert!(matches!(oom, VkError::Call { what: "vkCreateBuffer", .. }), "{oom:?}");
        assert!(oom.to_string().starts_with("Vulkan call vkCreateBuffer failed: "), "{oom}");
    }
}
