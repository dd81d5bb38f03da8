//! Render a scene file to a PNG through the library: load, open a device, trace one picture,
//! write it.
//!
//!     cargo run --release --example render_scene -- scenes/spd/balls_s2.nff balls.png

use irt::gpu::{AdapterChoice, GpuContext};
use irt::render::{Session, Settings};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene_file = PathBuf::from(args.next().unwrap_or_else(|| "scenes/default.toml".into()));
    let out = PathBuf::from(args.next().unwrap_or_else(|| "render_scene.png".into()));

    // Any format irt reads (TOML, glTF, NFF, OBJ, PLY), by its extension; limits are checked.
    let scene = irt::io::load(&scene_file)?;
    // Lavapipe by default; `IRT_ADAPTER=gpu` picks a hardware GPU.
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    // The bands mode: one picture, traced in bands of rows, read back with its ray counts.
    let mut session = Session::new(&ctx, &scene, Settings::bands())?;
    let picture = session.picture(&ctx, &mut |rows, total| eprint!("\rtracing {rows}/{total} rows"));
    eprintln!();
    picture.image.save_png(&out)?;
    println!("wrote {} ({}x{})", out.display(), picture.image.width, picture.image.height);
    Ok(())
}
