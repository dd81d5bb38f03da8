//! `irt render --frames A..B`: an animation as an image sequence. One session keeps the scene on
//! the device; each frame poses the scene at its time ([`Session::set_time`]: the grid is rebuilt
//! only if geometry moved) and traces one complete picture.

use super::render::RenderArgs;
use anyhow::{bail, Context, Result};
use irt::gpu::device::{Backend, Device};
use irt::image::OutputFormat;
use irt::render::schedule::Schedule;
use irt::render::{Mode, Session, Settings, UpdateReport};
use irt::scene::Scene;
use std::ops::Range;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Most frames one command writes (a day at 60 frames/s would be 5 M: this is a typo guard).
pub const MAX_FRAMES: u32 = 1_000_000;

pub fn run(args: &RenderArgs, scene: &Scene, frames: Range<u32>, mode: Option<Mode>) -> Result<()> {
    let fps = args.fps;
    if !(fps.is_finite() && fps > 0.0 && fps <= 1000.0) {
        bail!("--fps {fps}: give frames per second between 0 and 1000");
    }
    if frames.len() as u64 > MAX_FRAMES as u64 {
        bail!(
            "--frames {}..{} is {} frames; at most {MAX_FRAMES} in one command",
            frames.start,
            frames.end,
            frames.len()
        );
    }
    let pattern = FramePattern::parse(&args.out.to_string_lossy())?;
    let first = pattern.path(frames.start);
    super::check_output_path(&first)?;
    let format = OutputFormat::from_path(&first).map_err(anyhow::Error::msg)?;
    if !scene.is_animated() {
        log::warn!("the scene has no motion: every frame will be the same picture");
    }
    let mode = mode.unwrap_or(Mode::Conventional { schedule: Schedule::Plain, workers: 0 });
    let settings = super::render::one_picture(args, mode);
    let job = Job { args, scene, frames, pattern, format, settings };
    match args.backend.backend {
        Backend::Wgpu => job.run(&super::open_device(&args.device)?),
        Backend::Ash => job.run(&super::open_vk_device(&args.device, Default::default())?),
    }
}

/// The frames to write, and how.
struct Job<'a> {
    args: &'a RenderArgs,
    scene: &'a Scene,
    frames: Range<u32>,
    pattern: FramePattern,
    format: OutputFormat,
    settings: Settings,
}

impl Job<'_> {
    fn run<D: Device>(self, ctx: &D) -> Result<()> {
        let Job { args, scene, frames, pattern, format, settings } = self;
        let fps = args.fps;
        let first = pattern.path(frames.start);
        let mut session = Session::new(ctx, scene, settings).map_err(anyhow::Error::msg)?;
        session.incremental = !args.full_rebuild;
        let bar = super::bar(
            frames.len() as u64,
            "{spinner} frame {pos}/{len} [{bar:30}] {elapsed_precise} eta {eta}",
        );
        let mut cost = Totals::default();
        let t0 = Instant::now();
        for k in frames.clone() {
            let update = session.set_time(ctx, k as f64 / fps).map_err(anyhow::Error::msg)?;
            let t = Instant::now();
            let image = session.try_render_image(ctx, &mut |_, _| {})?;
            let trace = t.elapsed();
            let path = pattern.path(k);
            image.save_as(&path, format).with_context(|| format!("writing {}", path.display()))?;
            cost.add(&update, trace);
            bar.inc(1);
        }
        bar.finish_and_clear();
        let n = frames.len() as f64;
        let ms = |d: Duration| d.as_secs_f64() * 1e3 / n;
        eprintln!(
        "wrote {} frames {} … {} ({}x{}, {} primitives, {:.1} s on {}); per frame: update {:.1} ms (grid {:.1}, \
         pack {:.1}, upload {:.1}; the grid {} in {} of {} frames), trace {:.1} ms",
        frames.len(),
        first.display(),
        pattern.path(frames.end - 1).display(),
        scene.camera.width,
        scene.camera.height,
        scene.primitive_count(),
        t0.elapsed().as_secs_f64(),
        ctx.adapter_name(),
        ms(cost.update),
        ms(cost.grid),
        ms(cost.pack),
        ms(cost.upload),
        if args.full_rebuild { "rebuilt" } else { "updated" },
        cost.rebuilds,
        frames.len(),
        ms(cost.trace),
    );
        Ok(())
    }
}

#[derive(Default)]
struct Totals {
    update: Duration,
    grid: Duration,
    pack: Duration,
    upload: Duration,
    trace: Duration,
    rebuilds: u32,
}

impl Totals {
    fn add(&mut self, u: &UpdateReport, trace: Duration) {
        self.update += u.total();
        self.grid += u.accel.unwrap_or_default();
        self.rebuilds += u.accel.is_some() as u32;
        self.pack += u.pack;
        self.upload += u.upload;
        self.trace += trace;
    }
}

/// A file name with one frame-number placeholder: `%d`, or `%0Nd` (zero-padded to N digits).
#[derive(Debug, PartialEq)]
pub struct FramePattern {
    head: String,
    width: usize,
    tail: String,
}

impl FramePattern {
    pub fn parse(s: &str) -> Result<Self> {
        let Some(at) = s.find('%') else {
            bail!("--out '{s}' has no frame number: with --frames give a pattern such as 'frame_%04d.png'");
        };
        let rest = &s[at + 1..];
        let digits: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
        if !rest[digits.len()..].starts_with('d') || (!digits.is_empty() && !digits.starts_with('0')) {
            bail!("--out '{s}': the frame number is written %d or %0Nd (e.g. %04d)");
        }
        let width = if digits.is_empty() { 0 } else { digits.parse::<usize>().unwrap_or(0).min(12) };
        let tail = rest[digits.len() + 1..].to_string();
        if tail.contains('%') {
            bail!("--out '{s}' has more than one %: give one frame number placeholder");
        }
        Ok(FramePattern { head: s[..at].to_string(), width, tail })
    }

    pub fn path(&self, k: u32) -> PathBuf {
        PathBuf::from(format!("{}{:0w$}{}", self.head, k, self.tail, w = self.width))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_number_frames() {
        let p = FramePattern::parse("out/frame_%04d.png").unwrap();
        assert_eq!(p.path(7), PathBuf::from("out/frame_0007.png"));
        assert_eq!(p.path(123456), PathBuf::from("out/frame_123456.png"));
        assert_eq!(FramePattern::parse("f%d.exr").unwrap().path(12), PathBuf::from("f12.exr"));
        for bad in ["frame.png", "f%x.png", "f%4d.png", "f%d%d.png"] {
            assert!(FramePattern::parse(bad).is_err(), "{bad}");
        }
    }
}
