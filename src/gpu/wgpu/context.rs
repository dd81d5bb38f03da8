//! The wgpu device: Vulkan only, lavapipe unless the user names another adapter.

use super::cache::{CacheSetting, DiskCache};
use crate::gpu::adapter::{
    choose_adapter, mesa_version, AdapterChoice, AdapterFacts, ContextError, MIN_FAST_MESA,
};
use std::fmt;

/// An open device and queue, and what they are.
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Compiled pipelines kept on disk; `None` when off or unsupported (see `cache_status`).
    pub pipeline_cache: Option<DiskCache>,
    /// What the pipeline cache is doing, in words (`irt info`).
    pub cache_status: String,
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "GpuContext({} / {})", self.info.name, self.info.driver)
    }
}

impl GpuContext {
    /// Opens the device without a disk pipeline cache (what tests and library users get unless
    /// they ask, so nothing is written outside their control).
    pub fn new(choice: &AdapterChoice) -> Result<Self, ContextError> {
        Self::with_cache(choice, &CacheSetting::Off("not requested".into()))
    }

    /// Opens the device with compiled pipelines cached as `cache` says, where the adapter
    /// supports `Features::PIPELINE_CACHE`; silently without where it does not.
    pub fn with_cache(choice: &AdapterChoice, cache: &CacheSetting) -> Result<Self, ContextError> {
        let instance = crate::gpu::vulkan_instance();
        Self::open(&instance, choice, cache, None)
    }

    /// Opens the device on an adapter of `instance` that can present to `surface` (a window's,
    /// made from the same instance, which was built with the window's display handle); otherwise
    /// as [`GpuContext::with_cache`].
    pub fn for_surface(
        instance: &wgpu::Instance,
        surface: &wgpu::Surface<'_>,
        choice: &AdapterChoice,
        cache: &CacheSetting,
    ) -> Result<Self, ContextError> {
        Self::open(instance, choice, cache, Some(surface))
    }

    fn open(
        instance: &wgpu::Instance,
        choice: &AdapterChoice,
        cache: &CacheSetting,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, ContextError> {
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        if let Some(surface) = surface {
            adapters.retain(|a| a.is_surface_supported(surface));
        }
        if adapters.is_empty() {
            return Err(ContextError::NoVulkan);
        }
        let facts: Vec<AdapterFacts> = adapters
            .iter()
            .map(|a| {
                let i = a.get_info();
                AdapterFacts { name: i.name, driver: i.driver, device_type: i.device_type }
            })
            .collect();
        let adapter = adapters[choose_adapter(choice, &facts)?].clone();
        let info = adapter.get_info();
        // Ask for what this adapter offers: scenes are sized by its texture and buffer limits.
        let limits = adapter.limits();
        let supported = adapter.features().contains(wgpu::Features::PIPELINE_CACHE);
        let cache_dir = match cache {
            CacheSetting::Dir(dir) if supported => Some(dir),
            _ => None,
        };
        let mut features =
            if cache_dir.is_some() { wgpu::Features::PIPELINE_CACHE } else { wgpu::Features::empty() };
        // f64 shaders (`--precision f64`) where the adapter has them (lavapipe does).
        features |= adapter.features() & wgpu::Features::SHADER_F64;
        // Subgroup operations for the SIMD counters (`irt bench --simd`) where the adapter has them.
        features |= adapter.features() & wgpu::Features::SUBGROUP;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("irt"),
            required_features: features,
            required_limits: limits,
            memory_hints: wgpu::MemoryHints::Performance,
            ..Default::default()
        }))
        .map_err(|source| ContextError::Device { adapter: info.name.clone(), source })?;
        let pipeline_cache = cache_dir.map(|dir| DiskCache::open(&device, &info, dir));
        let cache_status = match (&pipeline_cache, cache) {
            (Some(c), _) if c.loaded_bytes > 0 => {
                format!("{} ({} bytes loaded)", c.path.display(), c.loaded_bytes)
            }
            (Some(c), _) => format!("{} (empty at start)", c.path.display()),
            (None, CacheSetting::Off(why)) => format!("off ({why})"),
            (None, CacheSetting::Dir(_)) => {
                "off (this adapter lacks PIPELINE_CACHE; the driver's own shader cache still applies)".into()
            }
        };
        let ctx = GpuContext { adapter, device, queue, info, pipeline_cache, cache_status };
        if let Some(w) = ctx.old_driver_warning() {
            log::warn!("{w}");
        }
        Ok(ctx)
    }

    /// The Mesa version of a lavapipe device, from its driver string ("Mesa 25.0.7-2…"):
    /// (major, minor), or `None` for other drivers.
    pub fn mesa_version(&self) -> Option<(u32, u32)> {
        mesa_version(&self.info.driver_info)
    }

    /// A warning for a lavapipe older than Mesa 24, which runs irt's kernels 2–4x slower than
    /// 25.0 (docs/performance.md); `None` when the driver is new enough or not lavapipe.
    pub fn old_driver_warning(&self) -> Option<String> {
        match self.mesa_version() {
            Some((major, minor)) if major < MIN_FAST_MESA && self.info.device_type == wgpu::DeviceType::Cpu => {
                Some(format!(
                    "lavapipe is Mesa {major}.{minor}: irt traces 2-4x slower than on Mesa {MIN_FAST_MESA} or \
                     newer (Debian 12: scripts/setup.sh installs Mesa 25.0 from bookworm-backports)"
                ))
            }
            _ => None,
        }
    }

    /// The pipeline cache to pass to pipeline descriptors.
    pub fn wgpu_pipeline_cache(&self) -> Option<&wgpu::PipelineCache> {
        self.pipeline_cache.as_ref().map(|c| &c.cache)
    }

    /// Saves the pipeline cache to disk if it changed; never fails (see [`DiskCache::save`]).
    pub fn save_pipeline_cache(&self) {
        if let Some(c) = &self.pipeline_cache {
            c.save();
        }
    }

    /// Blocks until all submitted work is done.
    pub fn wait(&self) {
        // An error here means the device was lost; the next call reports it with context.
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }
}
