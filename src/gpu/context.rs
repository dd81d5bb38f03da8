//! The wgpu device: Vulkan only, lavapipe unless the user names another adapter.

use super::cache::{CacheSetting, DiskCache};
use std::fmt;

/// Environment variable that picks an adapter when `--adapter` is not given.
pub const ADAPTER_ENV: &str = "IRT_ADAPTER";

/// The oldest Mesa whose lavapipe runs irt at full speed (Mesa 22.3 is 2–4x slower than 25.0).
pub const MIN_FAST_MESA: u32 = 24;

/// What both device paths say when `--precision f64` meets an adapter without f64 shaders
/// (wgpu's `SHADER_F64`, Vulkan's `shaderFloat64`).
pub fn no_f64_message(adapter: &str) -> String {
    format!("{adapter} has no f64 shader support (SHADER_F64): use --precision f32")
}

/// Why the SIMD counters cannot run on `adapter`: a `Variant::simd_stats` kernel needs subgroup
/// operations in compute shaders, and `irt bench --simd` also one SIMD group size to count lanes.
pub fn no_subgroups_message(adapter: &str) -> String {
    format!(
        "{adapter} lacks what the SIMD counters (--simd) need: subgroup operations in compute shaders, \
         with one SIMD group size"
    )
}

/// (major, minor) of the first "Mesa X.Y" in a driver string.
pub fn mesa_version(driver_info: &str) -> Option<(u32, u32)> {
    let rest = &driver_info[driver_info.find("Mesa ")? + 5..];
    let mut parts = rest.split(|c: char| !c.is_ascii_digit());
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some((major, minor))
}

/// Which Vulkan adapter to use.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum AdapterChoice {
    /// Mesa's lavapipe (software Vulkan on the CPU): the same everywhere, CI included.
    #[default]
    Lavapipe,
    /// The first adapter whose name contains this text (case-insensitive).
    Named(String),
    /// The first discrete/integrated GPU, else lavapipe.
    BestGpu,
}

impl AdapterChoice {
    /// `--adapter` value, else `$IRT_ADAPTER`, else lavapipe. "gpu" means the best hardware GPU.
    pub fn from_arg_or_env(arg: Option<&str>) -> Self {
        let text = arg.map(str::to_owned).or_else(|| std::env::var(ADAPTER_ENV).ok());
        match text.as_deref().map(str::trim) {
            None | Some("") | Some("lavapipe") | Some("llvmpipe") => AdapterChoice::Lavapipe,
            Some("gpu") => AdapterChoice::BestGpu,
            Some(name) => AdapterChoice::Named(name.to_owned()),
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ContextError {
    #[error(
        "no Vulkan device found. irt runs on any Vulkan driver; the portable one is Mesa's \
         lavapipe (Vulkan on the CPU). On Debian/Ubuntu install it with:\n    \
         sudo apt-get install mesa-vulkan-drivers libvulkan1\n(or run scripts/setup.sh)"
    )]
    NoVulkan,
    #[error("no Vulkan adapter matches '{wanted}'; available: {available}")]
    NoMatch { wanted: String, available: String },
    #[error("lavapipe (llvmpipe) is not installed; available adapters: {available}. Install it with `sudo apt-get install mesa-vulkan-drivers`, or pick one with --adapter NAME / {ADAPTER_ENV}=NAME")]
    NoLavapipe { available: String },
    #[error("could not open the device on adapter '{adapter}': {source}")]
    Device {
        adapter: String,
        #[source]
        source: wgpu::RequestDeviceError,
    },
}

/// What adapter choice looks at, whichever backend lists the adapters (wgpu, or raw Vulkan in
/// [`super::vk`]): both pick by the same rules, with the same messages.
#[derive(Clone, Debug)]
pub struct AdapterFacts {
    pub name: String,
    pub driver: String,
    pub device_type: wgpu::DeviceType,
}

/// The index in `adapters` that `choice` picks: lavapipe by default, a name's first match, or the
/// best hardware GPU (else lavapipe).
pub fn choose_adapter(choice: &AdapterChoice, adapters: &[AdapterFacts]) -> Result<usize, ContextError> {
    if adapters.is_empty() {
        return Err(ContextError::NoVulkan);
    }
    let names = || adapters.iter().map(|a| a.name.as_str()).collect::<Vec<_>>().join(", ");
    let is_lavapipe = |a: &AdapterFacts| a.name.contains("llvmpipe") || a.driver.contains("llvmpipe");
    let find = |f: &dyn Fn(&AdapterFacts) -> bool| adapters.iter().position(f);
    let chosen = match choice {
        AdapterChoice::Lavapipe => find(&is_lavapipe),
        AdapterChoice::Named(name) => {
            let want = name.to_lowercase();
            find(&|a| a.name.to_lowercase().contains(&want))
        }
        AdapterChoice::BestGpu => find(&|a| a.device_type == wgpu::DeviceType::DiscreteGpu)
            .or_else(|| find(&|a| a.device_type == wgpu::DeviceType::IntegratedGpu))
            .or_else(|| find(&is_lavapipe)),
    };
    match (chosen, choice) {
        (Some(i), _) => Ok(i),
        (None, AdapterChoice::Named(n)) => {
            Err(ContextError::NoMatch { wanted: n.clone(), available: names() })
        }
        (None, _) => Err(ContextError::NoLavapipe { available: names() }),
    }
}

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
        let instance = super::vulkan_instance();
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

#[cfg(test)]
mod tests {
    #[test]
    fn mesa_versions_are_read_from_driver_strings() {
        assert_eq!(super::mesa_version("Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)"), Some((25, 0)));
        assert_eq!(super::mesa_version("Mesa 22.3.6 (LLVM 15.0.6)"), Some((22, 3)));
        assert_eq!(super::mesa_version("NVIDIA 550.54"), None);
        assert_eq!(super::mesa_version("Mesa "), None);
    }
}
