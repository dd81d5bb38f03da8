//! Which display a window opens on, and winit's errors in a user's words.

/// winit's message without the place in winit's source where it was raised (`os error at
/// …/winit-0.30.13/src/…/mod.rs:765: …`): a path on the build machine says nothing to a user.
pub(super) fn os_words(message: &str) -> String {
    match message.strip_prefix("os error at ").and_then(|rest| rest.split_once(": ")) {
        Some((_, words)) => words.to_string(),
        None => message.to_string(),
    }
}

/// Whether a Wayland compositor's socket is there: `$WAYLAND_SOCKET`, or `$WAYLAND_DISPLAY` as
/// an absolute path or under `$XDG_RUNTIME_DIR`.
pub(super) fn wayland_reachable() -> bool {
    let var = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
    if var("WAYLAND_SOCKET").is_some() {
        return true;
    }
    let Some(display) = var("WAYLAND_DISPLAY") else { return false };
    let path = std::path::Path::new(&display);
    if path.is_absolute() {
        return path.exists();
    }
    var("XDG_RUNTIME_DIR").is_some_and(|dir| std::path::Path::new(&dir).join(path).exists())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_errors_name_no_source_path() {
        let winit =
            "os error at /root/.cargo/registry/src/x/winit-0.30.13/src/platform_impl/linux/mod.rs:765: \
                     neither WAYLAND_DISPLAY nor WAYLAND_SOCKET nor DISPLAY is set.";
        assert_eq!(os_words(winit), "neither WAYLAND_DISPLAY nor WAYLAND_SOCKET nor DISPLAY is set.");
        assert_eq!(os_words("the event loop is gone"), "the event loop is gone");
    }
}
