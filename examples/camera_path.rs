//! Run a camera path headless: a frameless session (the paper's mode) takes the path's camera
//! at each display refresh, traces slices for one refresh's worth of time, and every tenth
//! refresh is written as a PNG — what `irt view` shows, without a window.
//!
//!     cargo run --release --example camera_path -- scenes/paths/orbit.toml frames/

use irt::gpu::{AdapterChoice, GpuContext};
use irt::render::replay::CameraPath;
use irt::render::{Mode, Session, Settings};
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path =
        CameraPath::load(&PathBuf::from(args.next().unwrap_or_else(|| "scenes/paths/orbit.toml".into())))?;
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "camera_path".into()));
    std::fs::create_dir_all(&dir)?;

    let mut scene = irt::scene::default_scene();
    (scene.camera.width, scene.camera.height) = (320, 240);
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let mut session =
        Session::new(&ctx, &scene, Settings { mode: Mode::frameless(), ..Settings::default() })?;

    let refresh = Duration::from_secs_f64(1.0 / 60.0);
    let refreshes = (path.duration() / refresh.as_secs_f64()).ceil() as u32;
    for k in 0..=refreshes {
        let t = k as f64 * refresh.as_secs_f64();
        session.set_camera(&ctx, &path.camera_at(t, 320, 240));
        // Slices until this refresh's time is spent; each slice sees the newest camera.
        let start = Instant::now();
        while start.elapsed() < refresh {
            if session.step(&ctx).idle {
                break;
            }
        }
        if k % 10 == 0 {
            let file = dir.join(format!("frame_{k:04}.png"));
            session.read_image(&ctx).save_png(&file)?;
            println!("t = {t:.2} s: {}", file.display());
        }
    }
    Ok(())
}
