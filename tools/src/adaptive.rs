//! The adaptive frameless order against the paper's Hilbert permutation (docs/adaptive.md).
//! Each scene's own camera is swung 60° about its look-at point in 3 s and replayed in both
//! orders at equal rays per second (a virtual clock calibrated per scene and size from a
//! conventional frame, the same for both orders): dynamic error, latency to 50/90/100% of the
//! screen and pixel age; and the dynamic error on the real clock, each order at its own speed.
//! Then the real cost of a slice in each order, interleaved slice by
//! slice (the adaptive order reads its samples back and ranks its blocks on the host, which the
//! virtual clock does not charge), and frames side by side for the first scene. What is shown
//! of the adaptive order is filled (`render::fill`), as the window's blit shows it.
//! `--virtual-only` skips the real clock and the slice cost (their columns read "—"): half the
//! time. `--ns N` runs the virtual clock at N ns a pixel for every scene instead of each one's
//! calibration (how the gain depends on how long a pass takes). `--blit-only` times only the
//! window's blit of the picture, plain and filled.
//!
//!     cargo run --release -p irt-tools -- adaptive [--sizes 512x512,1280x720] [--error-every K]
//!         [--virtual-only] [--ns N] [--blit-only] [--out-dir docs/adaptive] [SCENE...]
//!
//! Without scenes: the two its constants were chosen on (the default scene, balls_s2) and the
//! held-out ones, marked so in the table.

use crate::study::plot_timeline;
use anyhow::{anyhow, bail, Context, Result};
use glam::DMat3;
use irt::gpu::device::Device;
use irt::gpu::{AdapterChoice, GpuContext};
use irt::image::Image;
use irt::render::metrics::Clock;
use irt::render::replay::{calibrate, replay, CameraKey, CameraPath, ReplayOptions, ReplayReport};
use irt::render::{Mode, PixelOrder, Session, Settings, DEFAULT_SLICE};
use irt::scene::{Camera, Scene};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The scenes the adaptive order's constants were chosen on.
const TUNED: [&str; 2] = ["default", "scenes/spd/balls_s2.nff"];
/// Scenes it was not tuned on (the first eight were measured once with the order's first
/// design, 8×8 blocks and raw differences; the last five only with the order as it is).
const HELD_OUT: [&str; 13] = [
    "scenes/spd/teapot_s2.nff",
    "scenes/spd/gears_s1.nff",
    "scenes/spd/mount_s3.nff",
    "scenes/spd/rings_s2.nff",
    "scenes/spd/tree_s3.nff",
    "scenes/spd/jacks_s2.nff",
    "scenes/mesh.toml",
    "scenes/textured.toml",
    "scenes/spd/shells_s1.nff",
    "scenes/spd/sombrero_s1.nff",
    "scenes/spd/tetra_s4.nff",
    "scenes/shadows.toml",
    "scenes/dielectric.toml",
];

struct Options {
    sizes: Vec<[u32; 2]>,
    error_every: u32,
    virtual_only: bool,
    /// Only time the window's blit, plain and filled.
    blit_only: bool,
    /// The virtual clock's ns per pixel for every scene, instead of each scene's calibration.
    ns: Option<f64>,
    out_dir: PathBuf,
    scenes: Vec<String>,
}

fn parse(args: &[String]) -> Result<Options> {
    let mut o = Options {
        sizes: vec![[512, 512], [1280, 720]],
        error_every: 4,
        virtual_only: false,
        blit_only: false,
        ns: None,
        out_dir: "docs/adaptive".into(),
        scenes: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().cloned().ok_or_else(|| anyhow!("{a} needs a value"));
        match a.as_str() {
            "--sizes" => {
                o.sizes = value()?
                    .split(',')
                    .map(|s| {
                        let (w, h) = s.split_once('x').ok_or_else(|| anyhow!("--sizes: WxH, not {s}"))?;
                        Ok([w.parse()?, h.parse()?])
                    })
                    .collect::<Result<_>>()?
            }
            "--error-every" => o.error_every = value()?.parse()?,
            "--virtual-only" => o.virtual_only = true,
            "--blit-only" => o.blit_only = true,
            "--ns" => o.ns = Some(value()?.parse()?),
            "--out-dir" => o.out_dir = value()?.into(),
            s if s.starts_with("--") => bail!("unknown option {s}"),
            s => o.scenes.push(s.into()),
        }
    }
    Ok(o)
}

/// `camera` swung `degrees` about its look-at point around its up axis over `seconds`, keys
/// every 10°.
pub fn orbit(camera: &Camera, degrees: f64, seconds: f64, origin: &str) -> CameraPath {
    let steps = (degrees / 10.0).ceil().max(1.0) as usize;
    let axis = camera.up.normalize();
    let arm = camera.eye - camera.look_at;
    let keys = (0..=steps)
        .map(|k| {
            let f = k as f64 / steps as f64;
            let turn = DMat3::from_axis_angle(axis, (degrees * f).to_radians());
            CameraKey {
                t: seconds * f,
                eye: camera.look_at + turn * arm,
                look_at: camera.look_at,
                up: camera.up,
                fov: camera.vfov_deg,
                line: 0,
            }
        })
        .collect();
    CameraPath { keys, origin: origin.to_string() }
}

fn load(name: &str) -> Result<Scene> {
    if name == "default" {
        Ok(irt::scene::default_scene())
    } else {
        irt::io::load(Path::new(name)).with_context(|| format!("loading {name}"))
    }
}

fn settings(order: PixelOrder) -> Settings {
    let Mode::Frameless { slice, present_every, blend, jitter_pairs, .. } = Mode::frameless() else {
        unreachable!()
    };
    Settings {
        mode: Mode::Frameless { order, slice, present_every, blend, jitter_pairs },
        max_samples: 1,
        ..Settings::default()
    }
}

const ORDERS: [(&str, PixelOrder); 2] = [
    ("hilbert", PixelOrder::Hilbert { chunk: irt::render::order::DEFAULT_CHUNK, procs: 16 }),
    ("adaptive", PixelOrder::Adaptive { revisit: irt::render::adaptive::DEFAULT_REVISIT_PASSES }),
];

/// Wall milliseconds per slice of each order, the camera moving along `path` slice by slice,
/// the two sessions taking turns.
fn slice_cost(ctx: &GpuContext, scene: &Scene, path: &CameraPath, slices: u32) -> Result<[f64; 2]> {
    let mut sessions = ORDERS
        .iter()
        .map(|(_, o)| {
            let mut s = Session::new(ctx, scene, settings(*o))?;
            s.try_complete_pass(ctx)?;
            Ok(s)
        })
        .collect::<Result<Vec<_>>>()?;
    let (mut wall, mut traced) = ([Duration::ZERO; 2], [Duration::ZERO; 2]);
    let [w, h] = [scene.camera.width, scene.camera.height];
    for k in 0..slices {
        let camera = path.camera_at(k as f64 / 60.0, w, h);
        for (i, s) in sessions.iter_mut().enumerate() {
            s.set_camera(ctx, &camera);
            let t0 = Instant::now();
            traced[i] += s.try_step(ctx)?.trace_time;
            wall[i] += t0.elapsed();
        }
    }
    let ms = |t: Duration| t.as_secs_f64() * 1e3 / slices as f64;
    // What the host adds to a slice beyond its dispatch (the adaptive order's ranking, the
    // work buffer's write and the readback).
    eprintln!(
        "host ms per slice: hilbert {:.2}, adaptive {:.2}",
        ms(wall[0] - traced[0]),
        ms(wall[1] - traced[1])
    );
    Ok(wall.map(ms))
}

/// Wall milliseconds of the window's blit of a `scene`-sized adaptive picture mid-motion onto
/// an offscreen target of the same size, plain and filled (`render::fill`), alternating.
fn blit_cost(ctx: &GpuContext, scene: &Scene, path: &CameraPath) -> Result<[f64; 2]> {
    use irt::app::blit::{offscreen_target, Blit, Shown};
    let [w, h] = [scene.camera.width, scene.camera.height];
    let mut s = Session::new(ctx, scene, settings(ORDERS[1].1))?;
    s.try_complete_pass(ctx)?;
    for k in 0..8 {
        s.set_camera(ctx, &path.camera_at(k as f64 / 60.0, w, h));
        s.try_step(ctx)?;
    }
    s.update_fill();
    let fill = s.fill().ok_or_else(|| anyhow!("mid-motion, some block missed the change"))?;
    let format = wgpu::TextureFormat::Rgba8Unorm;
    let target = offscreen_target(&ctx.device, format, [w, h], wgpu::TextureUsages::empty());
    let mut blit = Blit::new(&ctx.device, format);
    let mut total = [Duration::ZERO; 2];
    const ROUNDS: u32 = 20;
    for round in 0..=ROUNDS {
        for (i, f) in [None, Some(fill)].into_iter().enumerate() {
            let t0 = Instant::now();
            blit.draw_offscreen(&ctx.device, &ctx.queue, &target, Shown::Device(s.frame_buffer(), f), [w, h]);
            ctx.wait();
            // Round 0 compiles and uploads: not counted.
            if round > 0 {
                total[i] += t0.elapsed();
            }
        }
    }
    Ok(total.map(|t| t.as_secs_f64() * 1e3 / ROUNDS as f64))
}

/// The images of frame `k` of each order's presents, the ideal image of its instant beneath
/// each, and their error maps: one picture.
fn side_by_side(
    ctx: &GpuContext,
    scene: &Scene,
    path: &CameraPath,
    dirs: &[PathBuf],
    t: f64,
) -> Result<Image> {
    let [w, h] = [scene.camera.width, scene.camera.height];
    let mut ideal_scene = scene.clone();
    ideal_scene.camera = path.camera_at(t, w, h);
    let conventional = Settings { mode: Mode::conventional(), max_samples: 1, ..Settings::default() };
    let mut s = Session::new(ctx, &ideal_scene, conventional)?;
    s.try_complete_pass(ctx)?;
    let ideal = s.try_read_image(ctx)?;
    let k = (t * 60.0).round() as usize;
    let shown: Vec<Image> = dirs
        .iter()
        .map(|d| {
            let f = d.join(format!("frame_{k:04}.png"));
            let bytes = std::fs::read(&f).with_context(|| format!("reading {}", f.display()))?;
            let (w, h, texels) =
                irt::io::png::decode(&bytes, "a replay frame").map_err(|e| anyhow!("{e:?}"))?;
            let lin = |c: u8| irt::image::srgb_to_linear(c as f64 / 255.0) as f32;
            let pixels = texels.iter().map(|t| [lin(t[0]), lin(t[1]), lin(t[2])]).collect();
            Ok(Image { width: w, height: h, pixels })
        })
        .collect::<Result<_>>()?;
    // Row 1: what each order shows, then the ideal; row 2: each one's error ×4.
    let cols = shown.len() as u32 + 1;
    let mut out =
        Image { width: w * cols, height: h * 2, pixels: vec![[1.0; 3]; (w * cols * h * 2) as usize] };
    let mut put = |img: &Image, cx: u32, cy: u32| {
        for y in 0..h {
            for x in 0..w {
                out.pixels[((cy * h + y) * w * cols + cx * w + x) as usize] =
                    img.pixels[(y * w + x) as usize];
            }
        }
    };
    for (i, img) in shown.iter().enumerate() {
        put(img, i as u32, 0);
        put(&irt::metrics::diff_image(img, &ideal, 4.0), i as u32, 1);
    }
    put(&ideal, cols - 1, 0);
    Ok(out)
}

/// `x` to `digits` decimals, or "—" where it was not measured.
fn dash(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "—".into()
    }
}

pub fn run(args: &[String]) -> Result<()> {
    let o = parse(args)?;
    let scenes: Vec<(String, bool)> = if o.scenes.is_empty() {
        TUNED
            .iter()
            .map(|s| (s.to_string(), true))
            .chain(HELD_OUT.iter().map(|s| (s.to_string(), false)))
            .collect()
    } else {
        o.scenes.iter().map(|s| (s.clone(), TUNED.contains(&s.as_str()))).collect()
    };
    std::fs::create_dir_all(&o.out_dir)?;
    let ctx = GpuContext::new(&AdapterChoice::from_arg_or_env(None))?;
    let device = format!("{} ({})", ctx.adapter_name(), ctx.adapter_driver());
    let mut table = format!(
        "Adaptive against Hilbert (hilbert:64:16), frameless, S = {DEFAULT_SLICE}, one sample; the scene's camera \
         swung 60° in 3 s at 60 Hz; a virtual clock at the scene's calibrated ns per pixel (the same for both \
         orders: equal rays per second); error every {} refreshes. Device: {device}. Regenerate: `cargo run \
         --release -p irt-tools -- adaptive`.\n\n\
         | scene | size | ns/pixel | dynamic error, Hilbert | adaptive | ratio | latency 50/90/100% (ms), Hilbert | \
         adaptive | mean / p90 age (ms), Hilbert | adaptive | ms per slice (real), Hilbert | adaptive | real clock: \
         error ratio |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        o.error_every
    );
    let mut ratios: Vec<(String, [u32; 2], bool, f64, f64)> = Vec::new();
    let frames_root = std::env::temp_dir().join(format!("irt-adaptive-{}", std::process::id()));
    for (name, tuned) in &scenes {
        let base = load(name)?;
        let short = Path::new(name).file_stem().map_or(name.clone(), |s| s.to_string_lossy().into_owned());
        let path = orbit(&base.camera, 60.0, 3.0, &format!("orbit of {name}"));
        for &[w, h] in &o.sizes {
            let mut scene = base.clone();
            scene.camera = path.camera_at(0.0, w, h);
            if o.blit_only {
                let [plain, filled] = blit_cost(&ctx, &scene, &path)?;
                println!("{short} blit ms at {w}x{h}: plain {plain:.2}, filled {filled:.2}");
                continue;
            }
            let spp = match o.ns {
                Some(ns) => ns * 1e-9,
                None => calibrate(&ctx, &scene, &settings(ORDERS[0].1), 3)?,
            };
            let first = name == &scenes[0].0 && [w, h] == o.sizes[0];
            let mut reports: Vec<(String, ReplayReport)> = Vec::new();
            let mut dirs = Vec::new();
            for (label, order) in ORDERS {
                let dir = frames_root.join(label);
                let opts = ReplayOptions {
                    clock: Clock::Virtual { seconds_per_pixel: spp },
                    error_every: o.error_every,
                    frames_dir: first.then(|| dir.clone()),
                    ..ReplayOptions::default()
                };
                let t = Instant::now();
                let r = replay(&ctx, &scene, &settings(order), &path, &opts)?;
                eprintln!("{short} {w}x{h} {label}: {:.1} s", t.elapsed().as_secs_f64());
                reports.push((label.to_string(), r));
                dirs.push(dir);
            }
            // The same on the real clock: what a viewer on this machine would see (each order
            // at its own speed; noisy, one run each).
            let mut real = [f64::NAN; 2];
            for (i, (_, order)) in ORDERS.iter().enumerate().filter(|_| !o.virtual_only) {
                let opts = ReplayOptions {
                    clock: Clock::Real,
                    error_every: o.error_every,
                    ..ReplayOptions::default()
                };
                let r = replay(&ctx, &scene, &settings(*order), &path, &opts)?;
                real[i] = r.dynamic_error.map_or(f64::NAN, |e| e.mean);
            }
            let cost = if o.virtual_only { [f64::NAN; 2] } else { slice_cost(&ctx, &scene, &path, 30)? };
            if !o.virtual_only {
                let [plain, filled] = blit_cost(&ctx, &scene, &path)?;
                eprintln!("blit ms at {w}x{h}: plain {plain:.2}, filled {filled:.2}");
            }
            let err = |r: &ReplayReport| r.dynamic_error.map_or(f64::NAN, |e| e.mean);
            let (eh, ea) = (err(&reports[0].1), err(&reports[1].1));
            let lat = |r: &ReplayReport| {
                let l = r.latency.mean;
                format!("{:.0} / {:.0} / {:.0}", l[1] * 1e3, l[2] * 1e3, l[3] * 1e3)
            };
            let age = |r: &ReplayReport| {
                format!("{:.0} / {:.0}", r.age_at_refreshes.mean * 1e3, r.age_at_refreshes.p90 * 1e3)
            };
            let (rh, ra) = (&reports[0].1, &reports[1].1);
            writeln!(
                table,
                "| {short}{} | {w}×{h} | {:.0} | {eh:.4} | {ea:.4} | **{:.2}** | {} | {} | {} | {} | {} | {} | {} |",
                if *tuned { " (tuned on)" } else { "" },
                spp * 1e9,
                ea / eh,
                lat(rh),
                lat(ra),
                age(rh),
                age(ra),
                dash(cost[0], 1),
                dash(cost[1], 1),
                dash(real[1] / real[0], 2),
            )?;
            ratios.push((short.clone(), [w, h], *tuned, ea / eh, real[1] / real[0]));
            if first {
                let title = format!("{short}, {w}×{h}, orbit: displayed vs ideal image at equal rays/s");
                plot_timeline(&reports, &title, &o.out_dir.join("error.svg"))?;
                let picture = side_by_side(&ctx, &scene, &path, &dirs, 1.5)?;
                picture.save_png(&o.out_dir.join("frames.png"))?;
                std::fs::remove_dir_all(&frames_root).ok();
            }
        }
    }
    for (what, pick) in [("equal rays/s", 3), ("real clock", 4)] {
        let held: Vec<f64> = ratios
            .iter()
            .filter(|r| !r.2)
            .map(|r| if pick == 3 { r.3 } else { r.4 })
            .filter(|r| r.is_finite())
            .collect();
        if !held.is_empty() {
            let worst = held.iter().copied().fold(0.0, f64::max);
            let mean = held.iter().sum::<f64>() / held.len() as f64;
            writeln!(
                table,
                "\nHeld-out scenes, {what}: dynamic error ratio mean {mean:.2}, worst {worst:.2}."
            )?;
        }
    }
    if o.blit_only {
        return Ok(());
    }
    let sizes: Vec<String> = o.sizes.iter().map(|[w, h]| format!("{w}x{h}")).collect();
    let file = o.out_dir.join(format!("table-{}.md", sizes.join("_")));
    irt::image::write_atomic(&file, table.as_bytes())
        .with_context(|| format!("writing {}", file.display()))?;
    println!("{table}");
    Ok(())
}
