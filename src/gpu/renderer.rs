//! Headless rendering: a scene in, a linear radiance image (and ray counts) out.

use super::dispatch::{Dispatcher, GpuScene, RayCounts};
use super::layout::{Tile, BUNDLE_SAMPLES_PER_PASS, LAVAPIPE_LOOP_LIMIT};
use super::shaders::{Kernel, Variant};
use super::GpuContext;
use crate::accel::Grid;
use crate::image::Image;
use crate::scene::{Scene, ShadowMode};
use std::time::{Duration, Instant};

/// Rows per dispatch: small enough for a responsive progress bar, large enough that the
/// per-submit overhead (~0.1 ms) stays negligible against a band's tracing time.
pub const BAND_ROWS: u32 = 32;

#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions {
    /// Count rays by kind (four atomics per pixel; off for timing runs).
    pub count_rays: bool,
    /// Compile the full uber-shader instead of the variant specialised to the scene.
    pub uber_shader: bool,
}

/// How long each stage of setting up took.
#[derive(Clone, Copy, Debug, Default)]
pub struct SetupTimings {
    pub grid_build: Duration,
    pub upload: Duration,
    /// Shader module + pipeline creation (lavapipe compiles at first dispatch, which is in the
    /// first frame's time).
    pub pipeline: Duration,
}

pub struct Renderer {
    pub grid: Grid,
    pub gpu_scene: GpuScene,
    dispatcher: Dispatcher,
    width: u32,
    height: u32,
    pub variant: Variant,
    pub timings: SetupTimings,
    /// The `Tile::pass` of each pass over the image (one unless a bundle is split).
    passes: Vec<[u32; 4]>,
}

/// A rendered frame.
pub struct Frame {
    pub image: Image,
    pub rays: RayCounts,
    /// The most shader loop iterations any pixel needed in one pass (see `LAVAPIPE_LOOP_LIMIT`).
    pub max_loop_iterations: u32,
}

impl Renderer {
    pub fn new(ctx: &GpuContext, scene: &Scene, opts: RenderOptions) -> Result<Self, String> {
        let t0 = Instant::now();
        let grid = Grid::build(scene);
        let t1 = Instant::now();
        let gpu_scene = GpuScene::upload_at(ctx, scene, &grid, scene.camera.eye)?;
        ctx.wait();
        let t2 = Instant::now();
        let variant = if opts.uber_shader {
            Variant { count_rays: opts.count_rays, ..Variant::FULL }
        } else {
            Variant::for_scene(scene, opts.count_rays)
        };
        let (width, height) = (scene.camera.width, scene.camera.height);
        let out_len = width as u64 * height as u64;
        let dispatcher = Dispatcher::new(ctx, &gpu_scene, Kernel::Render, variant, "render", out_len, &[]);
        let timings = SetupTimings { grid_build: t1 - t0, upload: t2 - t1, pipeline: t2.elapsed() };
        let passes = match scene.trace.shadows {
            ShadowMode::Bundle { samples, .. } if scene.lights.iter().any(|l| l.radius > 0.0) => (0..samples)
                .step_by(BUNDLE_SAMPLES_PER_PASS as usize)
                .map(|k0| [k0, k0 + BUNDLE_SAMPLES_PER_PASS, (k0 == 0) as u32, 0])
                .collect(),
            _ => vec![Tile::whole([0; 4]).pass_range],
        };
        Ok(Renderer { grid, gpu_scene, dispatcher, width, height, variant, timings, passes })
    }

    /// Traces every pixel, in bands of [`BAND_ROWS`] rows; `progress(rows_done, rows)` after each.
    pub fn render(&self, ctx: &GpuContext, progress: &mut dyn FnMut(u32, u32)) -> Frame {
        self.dispatcher.reset_counts(ctx);
        let mut y = 0;
        while y < self.height {
            let rows = BAND_ROWS.min(self.height - y);
            for &pass in &self.passes {
                self.dispatcher.dispatch_tile(ctx, Tile { rect: [0, y, self.width, rows], pass_range: pass });
            }
            y += rows;
            progress(y, self.height);
        }
        let (out, rays) = self.dispatcher.read(ctx);
        let pixels = out.iter().map(|p| [p[0], p[1], p[2]]).collect();
        let max_loop_iterations = out.iter().map(|p| p[3] as u32).max().unwrap_or(0);
        if max_loop_iterations > LAVAPIPE_LOOP_LIMIT / 2 {
            log::warn!(
                "a pixel ran {max_loop_iterations} shader loop iterations; lavapipe stops loops after \
                 {LAVAPIPE_LOOP_LIMIT} per invocation group, so parts of this image may be wrong"
            );
        }
        Frame { image: Image { width: self.width, height: self.height, pixels }, rays, max_loop_iterations }
    }
}
