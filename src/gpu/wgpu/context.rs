//! The wgpu device: Vulkan only, lavapipe unless the user names another adapter.

use super::cache::{CacheSetting, DiskCache};
use crate::gpu::adapter::{
    choose_adapter, mesa_version, AdapterChoice, AdapterFacts, ContextError, MIN_FAST_MESA,
};
use crate::gpu::failure::{DeviceFailure, FailureKind};
use crate::gpu::GpuError;
use std::fmt;
use std::sync::{Arc, Mutex};

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
    /// The device's first failure (a validation error, an allocation it could not make, its
    /// loss), as its error handlers caught it: once failed, every later call reports it.
    failure: Arc<Mutex<Option<DeviceFailure>>>,
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
        let failure = catch_failures(&device);
        let ctx = GpuContext { adapter, device, queue, info, pipeline_cache, cache_status, failure };
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

    /// Blocks until all submitted work is done; a device lost meanwhile is recorded (and
    /// reported by [`GpuContext::check`]).
    pub fn wait(&self) {
        if let Err(e) = self.device.poll(wgpu::PollType::wait_indefinitely()) {
            self.fail(DeviceFailure::new(FailureKind::Lost, e.to_string()));
        }
    }

    /// The device's first failure, if it has failed.
    pub fn failure(&self) -> Option<DeviceFailure> {
        self.failure.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// `Err` once the device has failed: what every call on this path ends with, so that a
    /// failure is reported where it happened instead of as garbage later.
    pub fn check(&self) -> Result<(), GpuError> {
        match self.failure() {
            Some(f) => Err(GpuError::Device(f)),
            None => Ok(()),
        }
    }

    /// The slot failures are recorded in, for callbacks that outlive a borrow of the context.
    pub(super) fn failure_slot(&self) -> Arc<Mutex<Option<DeviceFailure>>> {
        self.failure.clone()
    }

    /// Records `f` unless an earlier failure is recorded.
    pub(super) fn fail(&self, f: DeviceFailure) {
        self.failure.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(f);
    }

    /// Test hook (`IRT_FAULT=device-lost`): destroys the device, as a driver reset would.
    pub fn lose_device(&self) {
        self.device.destroy();
        self.fail(DeviceFailure::new(FailureKind::Lost, "destroyed (IRT_FAULT=device-lost)"));
    }
}

/// Replaces wgpu's default error handler, which panics, with one that records the device's
/// first failure (and its loss) for [`GpuContext::check`].
fn catch_failures(device: &wgpu::Device) -> Arc<Mutex<Option<DeviceFailure>>> {
    let slot: Arc<Mutex<Option<DeviceFailure>>> = Arc::new(Mutex::new(None));
    let record = |slot: &Arc<Mutex<Option<DeviceFailure>>>, f: DeviceFailure| {
        slot.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(f);
    };
    let s = slot.clone();
    device.on_uncaptured_error(Arc::new(move |err: wgpu::Error| {
        let f = match &err {
            wgpu::Error::OutOfMemory { .. } => DeviceFailure::new(FailureKind::OutOfMemory, err.to_string()),
            wgpu::Error::Validation { description, .. } => {
                DeviceFailure::new(FailureKind::Validation, description)
            }
            wgpu::Error::Internal { description, .. } => {
                DeviceFailure::new(FailureKind::Internal, description)
            }
        };
        record(&s, f);
    }));
    let s = slot.clone();
    device.set_device_lost_callback(move |reason, msg| {
        // Dropping the device at the end of a run is no failure (a test's destroy records its
        // own, `lose_device`).
        if reason != wgpu::DeviceLostReason::Destroyed {
            record(&s, DeviceFailure::new(FailureKind::Lost, format!("{reason:?}: {msg}")));
        }
    });
    slot
}
