//! Which Vulkan adapter irt opens, by the same rules and with the same messages on both device
//! paths: lavapipe unless the user names another.

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
