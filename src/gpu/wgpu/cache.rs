//! Compiled pipelines kept on disk between runs (wgpu's `PipelineCache`), one file per adapter.
//!
//! The cache only ever speeds things up: a missing, unreadable, corrupt or foreign file is
//! logged and replaced by an empty cache, and a failed save is logged; neither fails a render.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Environment variable naming the cache directory; `off` disables the cache.
pub const CACHE_DIR_ENV: &str = "IRT_CACHE_DIR";

/// Cache files larger than this are ignored (a driver's cache of irt's few pipelines is far
/// smaller; anything bigger is not ours).
const MAX_CACHE_BYTES: u64 = 256 << 20;

/// Where compiled pipelines are kept, if anywhere.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CacheSetting {
    /// No disk cache; the text says why (shown by `irt info`).
    Off(String),
    /// Cache files live in this directory (created on the first save).
    Dir(PathBuf),
}

impl CacheSetting {
    /// `--no-cache`, else `$IRT_CACHE_DIR` (`off` disables), else `$XDG_CACHE_HOME/irt`, else
    /// `~/.cache/irt`.
    pub fn from_flag_or_env(no_cache: bool) -> Self {
        if no_cache {
            return CacheSetting::Off("disabled by --no-cache".into());
        }
        let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        if let Some(dir) = var(CACHE_DIR_ENV) {
            if dir.to_str().map(str::trim) == Some("off") {
                return CacheSetting::Off(format!("disabled by {CACHE_DIR_ENV}=off"));
            }
            return CacheSetting::Dir(PathBuf::from(dir));
        }
        if let Some(xdg) = var("XDG_CACHE_HOME") {
            return CacheSetting::Dir(PathBuf::from(xdg).join("irt"));
        }
        match var("HOME") {
            Some(home) => CacheSetting::Dir(PathBuf::from(home).join(".cache").join("irt")),
            None => CacheSetting::Off(format!("no cache directory: set {CACHE_DIR_ENV} or HOME")),
        }
    }
}

/// The file name of `info`'s cache: wgpu's key (vendor and device ids) where wgpu has one,
/// else one derived from the same facts plus the driver.
pub fn cache_file_name(info: &wgpu::AdapterInfo) -> String {
    let key = wgpu::util::pipeline_cache_key(info).unwrap_or_else(|| {
        format!("irt_{:?}_{}_{}_{}_{}", info.backend, info.vendor, info.device, info.driver, info.driver_info)
    });
    let safe: String = key
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '_' || c == '-' { c } else { '_' })
        .collect();
    format!("{safe}.bin")
}

/// A wgpu pipeline cache backed by a file.
pub struct DiskCache {
    pub cache: wgpu::PipelineCache,
    pub path: PathBuf,
    /// Bytes loaded from the file at start (0: none, or rejected).
    pub loaded_bytes: usize,
    /// Hash of what the file holds now (as loaded or last saved); `None`: nothing usable.
    on_disk: Mutex<Option<u64>>,
}

/// FNV-1a, 64-bit: stable across builds, enough to notice damage (not an adversary).
fn hash(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3))
}

/// File envelope: magic, payload length, payload hash (little-endian u64s), then wgpu's data.
/// wgpu checks its own header but not the driver's bytes after it, and a driver handed a
/// damaged cache may misbehave; the hash stops damage before it reaches the driver.
const MAGIC: &[u8; 8] = b"IRTPCv1\n";
const ENVELOPE: usize = 24;

fn wrap(data: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(ENVELOPE + data.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&(data.len() as u64).to_le_bytes());
    out.extend_from_slice(&hash(data).to_le_bytes());
    out.extend_from_slice(data);
    out
}

fn unwrap(file: &[u8]) -> Result<&[u8], &'static str> {
    if file.len() < ENVELOPE || &file[..8] != MAGIC {
        return Err("not an irt pipeline cache file");
    }
    let word = |i: usize| u64::from_le_bytes(file[i..i + 8].try_into().expect("8 bytes"));
    let data = &file[ENVELOPE..];
    if word(8) != data.len() as u64 {
        return Err("truncated or extended");
    }
    if word(16) != hash(data) {
        return Err("damaged (checksum mismatch)");
    }
    Ok(data)
}

impl DiskCache {
    /// Opens the cache for `info` in `dir`, seeded from its file when that is valid. The
    /// device must have `Features::PIPELINE_CACHE`.
    pub fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo, dir: &Path) -> Self {
        let path = dir.join(cache_file_name(info));
        let data = match std::fs::metadata(&path) {
            Ok(m) if m.len() > MAX_CACHE_BYTES => {
                log::warn!(
                    "ignoring pipeline cache {}: {} bytes is more than irt ever writes",
                    path.display(),
                    m.len()
                );
                None
            }
            Ok(_) => std::fs::read(&path)
                .map_err(|e| log::warn!("ignoring pipeline cache {}: {e}", path.display()))
                .ok(),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => {
                log::warn!("ignoring pipeline cache {}: {e}", path.display());
                None
            }
        };
        let create = |data: Option<&[u8]>| {
            // SAFETY: wgpu checks the data's header (magic, wgpu cache version, adapter and
            // driver keys, length and hash) before handing it to the driver, and reports any
            // mismatch as a validation error, caught below. Only `get_data` output is written.
            unsafe {
                device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                    label: Some("irt"),
                    data,
                    // No silent fallback: a rejected file is reported (below), then replaced.
                    fallback: false,
                })
            }
        };
        let data = data.and_then(|file| match unwrap(&file) {
            Ok(d) => Some(d.to_vec()),
            Err(why) => {
                log::warn!("ignoring pipeline cache {} (it will be rewritten): {why}", path.display());
                None
            }
        });
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let cache = create(data.as_deref());
        let (cache, loaded) = match pollster::block_on(scope.pop()) {
            None => (cache, data),
            Some(err) => {
                // wgpu's message is a multi-line chain; its last line is the reason.
                let text = err.to_string();
                let why = text.lines().map(str::trim).rfind(|l| !l.is_empty()).unwrap_or("rejected");
                log::warn!("ignoring pipeline cache {} (it will be rewritten): {why}", path.display());
                (create(None), None)
            }
        };
        let loaded_bytes = loaded.as_ref().map_or(0, Vec::len);
        DiskCache { cache, path, loaded_bytes, on_disk: Mutex::new(loaded.as_deref().map(hash)) }
    }

    /// Writes the cache's data to its file (atomically) when it differs from what the file
    /// holds. Failures are logged, never returned: the cache is an optimisation.
    pub fn save(&self) {
        let Some(data) = self.cache.get_data() else { return };
        let h = hash(&data);
        let mut on_disk = self.on_disk.lock().unwrap_or_else(|p| p.into_inner());
        if *on_disk == Some(h) {
            return;
        }
        let result = self
            .path
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| crate::image::write_atomic(&self.path, &wrap(&data)));
        match result {
            Ok(()) => log::debug!("saved pipeline cache {} ({} bytes)", self.path.display(), data.len()),
            Err(e) => log::warn!("could not save pipeline cache {}: {e}", self.path.display()),
        }
        // Also after a failure: one warning per change, not one per frame.
        *on_disk = Some(h);
    }
}
