//! The one place irt creates its wgpu (Vulkan) instance, and the environment it needs first.
//!
//! Why the environment: creating the instance enables every surface extension the loader offers,
//! `VK_KHR_wayland_surface` included, and Mesa's device-select layer (an implicit Vulkan layer,
//! `libVkLayer_MESA_device_select`) then probes for a Wayland compositor with
//! `wl_display_connect(NULL)` while it sorts the physical devices. Older Mesa (such as Debian
//! 12's 22.3) probes whenever the extension is enabled; newer Mesa (25.0, which
//! scripts/setup.sh installs) only when `$WAYLAND_DISPLAY` or `$WAYLAND_SOCKET` is set. When
//! `$XDG_RUNTIME_DIR` is unset or relative, libwayland-client cannot form the socket path and
//! prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` on stderr — on
//! headless runs (containers, CI, ssh, cron), though nothing failed. With a runtime directory the
//! probe finds no compositor socket there and stays quiet.
//!
//! So, in exactly the case where no Wayland connection could succeed anyway (runtime directory
//! unset or relative, and neither `$WAYLAND_SOCKET` nor an absolute `$WAYLAND_DISPLAY`, the two
//! ways libwayland connects without it), irt points `$XDG_RUNTIME_DIR` at a private, empty
//! directory of its own (`$TMPDIR/irt-runtime-<uid>`, mode 0700, owned by the user; Qt does the
//! same). A real Wayland session (valid runtime directory) and X11 (`$DISPLAY`, untouched) are
//! left exactly as they were, so a later window (winit) connects as it would have.

/// The wgpu instance irt uses, Vulkan only and without a display handle. Every instance irt
/// creates comes from here, so the runtime-directory fix above always precedes it.
pub fn vulkan_instance() -> wgpu::Instance {
    ensure_runtime_dir();
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

/// Sets `$XDG_RUNTIME_DIR` to irt's private directory when [`needs_runtime_dir`] says so; once
/// per process, before the first instance (the `Once` holds back any other thread about to
/// create one, so the Vulkan loader and drivers never read the environment while it changes).
pub fn ensure_runtime_dir() {
    #[cfg(all(unix, not(target_vendor = "apple"), not(target_os = "android")))]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            use std::env::var_os;
            let (xdg, display, socket) =
                (var_os("XDG_RUNTIME_DIR"), var_os("WAYLAND_DISPLAY"), var_os("WAYLAND_SOCKET"));
            if !needs_runtime_dir(xdg.as_deref(), display.as_deref(), socket.as_deref()) {
                return;
            }
            match private_runtime_dir(&std::env::temp_dir()) {
                Ok(dir) => {
                    log::debug!("XDG_RUNTIME_DIR unset or relative: using {}", dir.display());
                    std::env::set_var("XDG_RUNTIME_DIR", dir);
                }
                // Only costs the harmless message this avoids.
                Err(e) => log::debug!("no private XDG_RUNTIME_DIR: {e}"),
            }
        });
    }
}

/// Whether libwayland-client's `wl_display_connect(NULL)` would fail for want of a runtime
/// directory, given `$XDG_RUNTIME_DIR`, `$WAYLAND_DISPLAY` and `$WAYLAND_SOCKET`: the runtime
/// directory is unset or not absolute (libwayland's test), no socket fd is handed over, and the
/// display is not an absolute socket path.
#[cfg(unix)]
pub fn needs_runtime_dir(
    xdg_runtime_dir: Option<&std::ffi::OsStr>,
    wayland_display: Option<&std::ffi::OsStr>,
    wayland_socket: Option<&std::ffi::OsStr>,
) -> bool {
    use std::os::unix::ffi::OsStrExt;
    let absolute = |v: Option<&std::ffi::OsStr>| v.is_some_and(|v| v.as_bytes().first() == Some(&b'/'));
    !absolute(xdg_runtime_dir) && wayland_socket.is_none() && !absolute(wayland_display)
}

/// `base/irt-runtime-<uid>`, created with mode 0700 if missing. An existing one must be a real
/// directory (not a symlink) owned by this user; its mode is reset to 0700. Anything else is an
/// error (someone else's directory is never used: it could hold a fake compositor socket).
#[cfg(unix)]
pub fn private_runtime_dir(base: &std::path::Path) -> std::io::Result<std::path::PathBuf> {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt, PermissionsExt};
    // SAFETY: geteuid has no preconditions and cannot fail.
    let uid = unsafe { libc::geteuid() };
    let dir = base.join(format!("irt-runtime-{uid}"));
    match std::fs::DirBuilder::new().mode(0o700).create(&dir) {
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        other => other?,
    }
    let meta = std::fs::symlink_metadata(&dir)?;
    if !meta.file_type().is_dir() || meta.uid() != uid {
        return Err(std::io::Error::other(format!(
            "{} is not a directory of user {uid}; not using it",
            dir.display()
        )));
    }
    if meta.mode() & 0o777 != 0o700 {
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o700))?;
    }
    Ok(dir)
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;
    use std::ffi::OsStr;

    #[test]
    fn runtime_dir_is_set_only_where_wayland_could_not_connect() {
        let s = |v: &'static str| Some(OsStr::new(v));
        // Headless: nothing set, or a relative/empty runtime directory (libwayland rejects it).
        assert!(needs_runtime_dir(None, None, None));
        assert!(needs_runtime_dir(s(""), None, None));
        assert!(needs_runtime_dir(s("run/user/1000"), None, None));
        // A relative display name needs the runtime directory, which is missing: no connection.
        assert!(needs_runtime_dir(None, s("wayland-0"), None));
        // A real session, or ways to connect without a runtime directory: left alone.
        assert!(!needs_runtime_dir(s("/run/user/1000"), None, None));
        assert!(!needs_runtime_dir(s("/run/user/1000"), s("wayland-0"), None));
        assert!(!needs_runtime_dir(None, s("/run/user/1000/wayland-0"), None));
        assert!(!needs_runtime_dir(None, None, s("3")));
    }

    #[test]
    fn private_runtime_dir_is_private_and_reused() {
        use std::os::unix::fs::PermissionsExt;
        let base = std::env::temp_dir().join(format!("irt-runtime-test-{}", std::process::id()));
        std::fs::create_dir_all(&base).unwrap();
        let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let dir = private_runtime_dir(&base).unwrap();
        assert!(dir.starts_with(&base) && dir.is_dir());
        assert_eq!(mode(&dir), 0o700);
        // Found again; a loosened mode is tightened.
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        assert_eq!(private_runtime_dir(&base).unwrap(), dir);
        assert_eq!(mode(&dir), 0o700);
        // A symlink in its place (to a directory someone else could control) is refused.
        std::fs::remove_dir(&dir).unwrap();
        std::os::unix::fs::symlink(&base, &dir).unwrap();
        assert!(private_runtime_dir(&base).is_err());
        std::fs::remove_dir_all(&base).unwrap();
    }
}
