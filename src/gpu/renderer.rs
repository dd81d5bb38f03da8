//! Headless rendering: a scene in, a linear radiance image (and ray counts) out.

use super::dispatch::{Dispatcher, GpuScene, RayCounts};
use super::shaders::{Kernel, Variant};
use super::GpuContext;
use crate::accel::Grid;
use crate::image::Image;
use crate::scene::Scene;
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
}

/// A rendered frame.
pub struct Frame {
    pub image: Image,
    pub rays: RayCounts,
}

impl Renderer {
    pub fn new(ctx: &GpuContext, scene: &Scene, opts: RenderOptions) -> Result<Self, String> {
        let t0 = Instant::now();
        let grid = Grid::build(scene);
        let t1 = Instant::now();
        let gpu_scene = GpuScene::upload(ctx, scene, &grid)?;
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
        Ok(Renderer { grid, gpu_scene, dispatcher, width, height, variant, timings })
    }

    /// Traces every pixel, in bands of [`BAND_ROWS`] rows; `progress(rows_done, rows)` after each.
    pub fn render(&self, ctx: &GpuContext, progress: &mut dyn FnMut(u32, u32)) -> Frame {
        self.dispatcher.reset_counts(ctx);
        let mut y = 0;
        while y < self.height {
            let rows = BAND_ROWS.min(self.height - y);
            self.dispatcher.dispatch(ctx, [0, y, self.width, rows]);
            y += rows;
            progress(y, self.height);
        }
        let (out, rays) = self.dispatcher.read(ctx);
        let pixels = out.iter().map(|p| [p[0], p[1], p[2]]).collect();
        Frame { image: Image { width: self.width, height: self.height, pixels }, rays }
    }
}
