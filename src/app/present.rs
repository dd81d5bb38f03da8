//! The window's side of the device: the surface, the blit of the picture, the HUD drawn over
//! it with egui, and the present. [`Presenter::present`] turns one picture and one HUD view into
//! what is on screen and hands back what the user asked of the HUD.

use super::blit::{Blit, Shown};
use super::hud::{self, HudRequest, HudView};
use super::ViewOptions;
use crate::gpu::{AdapterChoice, CacheSetting, GpuContext};
use anyhow::{anyhow, Context as _, Result};
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::dpi::PhysicalSize;
use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

pub struct Egui {
    pub ctx: egui::Context,
    pub state: egui_winit::State,
    renderer: egui_wgpu::Renderer,
    /// The HUD window's rectangle in points at the last present (clicks there are the HUD's).
    pub rect: Option<egui::Rect>,
    /// The view format egui draws to.
    format: wgpu::TextureFormat,
}

/// The window, its surface and what draws on it.
pub struct Presenter {
    pub window: Arc<Window>,
    instance: wgpu::Instance,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// The window is minimised (0×0): nothing is configured or drawn.
    pub minimised: bool,
    blit: Blit,
    pub egui: Egui,
    /// The surface had no image to give: try again at this time.
    pub retry_at: Option<Instant>,
}

/// What a present did.
pub struct Presented {
    /// What the user changed in the HUD (none when it is hidden).
    pub request: Option<HudRequest>,
    /// egui asked for another pass at once.
    pub repaint: bool,
}

impl Presenter {
    /// Opens the window and, on the device that can draw to it, the context the tracer may
    /// share.
    /// `aspect`: the scene camera's width over height, for the default size.
    pub fn new(
        event_loop: &ActiveEventLoop,
        args: &ViewOptions,
        aspect: f64,
    ) -> Result<(Presenter, GpuContext)> {
        let [ww, wh] = args.size.unwrap_or_else(|| {
            let monitor = event_loop.primary_monitor().or_else(|| event_loop.available_monitors().next());
            default_window_size(monitor.map(|m| [m.size().width, m.size().height]), aspect)
        });
        let attrs = Window::default_attributes()
            .with_title(format!("irt — {}", args.scene_name))
            .with_inner_size(PhysicalSize::new(ww, wh));
        let window = Arc::new(event_loop.create_window(attrs).context("creating the window")?);

        let mut desc =
            wgpu::InstanceDescriptor::new_with_display_handle(Box::new(event_loop.owned_display_handle()));
        desc.backends = wgpu::Backends::VULKAN;
        let instance = wgpu::Instance::new(desc);
        let surface =
            instance.create_surface(window.clone()).context("creating the window's Vulkan surface")?;
        let choice = AdapterChoice::from_arg_or_env(args.adapter.as_deref());
        let ctx = GpuContext::for_surface(
            &instance,
            &surface,
            &choice,
            &CacheSetting::from_flag_or_env(args.no_cache),
        )?;
        let size = window.inner_size();
        let config = surface_config(&surface, &ctx.adapter, size.width.max(1), size.height.max(1))?;
        let minimised = size.width == 0 || size.height == 0;
        if !minimised {
            surface.configure(&ctx.device, &config);
        }
        let blit = Blit::new(&ctx.device, config.format);

        let egui_ctx = egui::Context::default();
        // A compact HUD: it shares the window with the picture.
        egui_ctx.global_style_mut(|style| {
            for font in style.text_styles.values_mut() {
                font.size = (font.size * 0.85).round();
            }
            style.spacing.item_spacing = egui::vec2(6.0, 2.0);
            style.spacing.button_padding = egui::vec2(3.0, 0.0);
            style.spacing.interact_size.y = 16.0;
        });
        let max_side = ctx.device.limits().max_texture_dimension_2d as usize;
        let state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_side),
        );
        // egui blends in gamma space: give it a non-sRGB view of the sRGB image where the device
        // can (VK_KHR_swapchain_mutable_format), else the sRGB image itself.
        let format = config.view_formats.first().copied().unwrap_or(config.format);
        let renderer = egui_wgpu::Renderer::new(&ctx.device, format, egui_wgpu::RendererOptions::default());
        let presenter = Presenter {
            window,
            instance,
            surface,
            config,
            minimised,
            blit,
            egui: Egui { ctx: egui_ctx, state, renderer, rect: None, format },
            retry_at: None,
        };
        Ok((presenter, ctx))
    }

    /// The window's size in pixels (as configured).
    pub fn window_size(&self) -> [u32; 2] {
        [self.config.width, self.config.height]
    }

    /// Whether window position `at` (pixels) is on the HUD.
    pub fn over_hud(&self, at: [f64; 2]) -> bool {
        let Some(rect) = self.egui.rect else { return false };
        let ppp = self.egui.ctx.pixels_per_point() as f64;
        rect.contains(egui::pos2((at[0] / ppp) as f32, (at[1] / ppp) as f32))
    }

    pub fn resize(&mut self, ctx: &GpuContext, size: PhysicalSize<u32>) {
        self.minimised = size.width == 0 || size.height == 0;
        if !self.minimised {
            self.config.width = size.width;
            self.config.height = size.height;
            self.surface.configure(&ctx.device, &self.config);
        }
        self.window.request_redraw();
    }

    /// Blit + HUD (`hud`: drawn with this view when shown) + present. `None` when the surface
    /// had no image (a redraw or a retry follows).
    pub fn present(
        &mut self,
        ctx: &GpuContext,
        shown: Shown<'_>,
        render: [u32; 2],
        hud: Option<&HudView>,
    ) -> Result<Option<Presented>> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f) => Some((f, false)),
            wgpu::CurrentSurfaceTexture::Suboptimal(f) => Some((f, true)),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                // Try again a little later rather than spin.
                self.retry_at = Some(Instant::now() + Duration::from_millis(50));
                None
            }
            wgpu::CurrentSurfaceTexture::Outdated => {
                self.surface.configure(&ctx.device, &self.config);
                self.window.request_redraw();
                None
            }
            wgpu::CurrentSurfaceTexture::Lost => {
                self.surface = self
                    .instance
                    .create_surface(self.window.clone())
                    .context("the window's surface was lost and could not be made again")?;
                self.surface.configure(&ctx.device, &self.config);
                self.window.request_redraw();
                None
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                ctx.check()?;
                return Err(anyhow!("the window's surface could not give an image (validation error)"));
            }
        };
        let Some((frame, suboptimal)) = frame else { return Ok(None) };
        let view = frame.texture.create_view(&wgpu::TextureViewDescriptor::default());
        let window = self.window_size();
        let device = &ctx.device;
        let queue = &ctx.queue;
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("present") });

        // The HUD's shapes (before the pass: egui textures and buffers are uploaded first).
        let mut paint = None;
        if let Some(view_data) = hud {
            let raw = self.egui.state.take_egui_input(&self.window);
            let mut request = HudRequest::default();
            let mut rect = None;
            let mut out = self.egui.ctx.run_pass(raw, |ctx| {
                let (r, area) = hud::draw(ctx, view_data);
                request = r;
                rect = area;
            });
            self.egui.rect = rect;
            self.egui.state.handle_platform_output(&self.window, out.platform_output);
            let jobs = self.egui.ctx.tessellate(out.shapes, out.pixels_per_point);
            let screen = egui_wgpu::ScreenDescriptor {
                size_in_pixels: window,
                pixels_per_point: out.pixels_per_point,
            };
            let set = std::mem::take(&mut out.textures_delta.set);
            let free = std::mem::take(&mut out.textures_delta.free);
            for (id, deltas) in &set {
                for delta in deltas {
                    self.egui.renderer.update_texture(device, queue, *id, delta);
                }
            }
            let extra = self.egui.renderer.update_buffers(device, queue, &mut encoder, &jobs, &screen);
            let repaint =
                out.viewport_output.get(&egui::ViewportId::ROOT).is_some_and(|v| v.repaint_delay.is_zero());
            paint = Some((jobs, screen, extra, free, request, repaint));
        } else {
            self.egui.rect = None;
        }
        let attachment = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })
        };
        {
            // The blit covers every pixel: nothing to clear.
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("blit"),
                color_attachments: &[attachment(&view)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.blit.draw(device, queue, &mut pass, shown, render, window);
        }
        if let Some((jobs, screen, ..)) = &paint {
            let hud_view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(self.egui.format),
                ..Default::default()
            });
            let mut pass = encoder
                .begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("hud"),
                    color_attachments: &[attachment(&hud_view)],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                })
                .forget_lifetime();
            self.egui.renderer.render(&mut pass, jobs, screen);
        }
        let mut buffers = Vec::new();
        let mut request = None;
        let mut repaint = false;
        if let Some((_, _, extra, free, r, rp)) = paint {
            buffers = extra;
            for id in &free {
                self.egui.renderer.free_texture(id);
            }
            request = Some(r);
            repaint = rp;
        }
        buffers.push(encoder.finish());
        queue.submit(buffers);
        self.window.pre_present_notify();
        queue.present(frame);
        // The software present copies the image: wait for it here so that the trace time of the
        // next step does not include it.
        ctx.wait();
        ctx.check()?;
        if suboptimal {
            self.surface.configure(device, &self.config);
        }
        Ok(Some(Presented { request, repaint }))
    }
}

/// The window's size without `--size`: the scene camera's aspect, as large as fits in 1280×720
/// and in the screen (`monitor`, in pixels, when known) less a margin for the window's
/// decorations and a task bar, and at least 320×240's area. The render follows the window, so
/// this is also what is traced: on lavapipe more would cost frame rate, and 1280×720 is what
/// a person expects a window to open at.
pub fn default_window_size(monitor: Option<[u32; 2]>, aspect: f64) -> [u32; 2] {
    /// Room left on the screen: a title bar and a task bar (height), borders (width).
    const MARGIN: [u32; 2] = [64, 128];
    let mut fit: [f64; 2] = [1280.0, 720.0];
    if let Some([mw, mh]) = monitor.filter(|m| m[0] > 0 && m[1] > 0) {
        fit[0] = fit[0].min(mw.saturating_sub(MARGIN[0]).max(320) as f64);
        fit[1] = fit[1].min(mh.saturating_sub(MARGIN[1]).max(240) as f64);
    }
    let aspect = if aspect.is_finite() && aspect > 0.0 { aspect.clamp(0.1, 10.0) } else { 4.0 / 3.0 };
    let (w, h) = if fit[0] / fit[1] > aspect { (fit[1] * aspect, fit[1]) } else { (fit[0], fit[0] / aspect) };
    // Very wide or tall cameras: not thinner than a usable strip.
    let scale = (320.0 * 240.0 / (w * h)).sqrt().max(1.0);
    [(w * scale).round().max(1.0) as u32, (h * scale).round().max(1.0) as u32]
}

/// The surface's configuration: an sRGB format where offered (Bgra8UnormSrgb first), present
/// mode Mailbox > Immediate > Fifo, one frame of latency.
fn surface_config(
    surface: &wgpu::Surface,
    adapter: &wgpu::Adapter,
    w: u32,
    h: u32,
) -> Result<wgpu::SurfaceConfiguration> {
    let caps = surface.get_capabilities(adapter);
    if caps.formats.is_empty() {
        return Err(anyhow!("the window's surface offers no format this device can draw to"));
    }
    let format = [wgpu::TextureFormat::Bgra8UnormSrgb, wgpu::TextureFormat::Rgba8UnormSrgb]
        .into_iter()
        .find(|f| caps.formats.contains(f))
        .or_else(|| caps.formats.iter().copied().find(|f| f.is_srgb()))
        .unwrap_or(caps.formats[0]);
    let present_mode = [wgpu::PresentMode::Mailbox, wgpu::PresentMode::Immediate, wgpu::PresentMode::Fifo]
        .into_iter()
        .find(|m| caps.present_modes.contains(m))
        .unwrap_or(wgpu::PresentMode::Fifo);
    let mut config = surface
        .get_default_config(adapter, w, h)
        .ok_or_else(|| anyhow!("the window's surface is not supported by this device"))?;
    config.format = format;
    config.present_mode = present_mode;
    config.desired_maximum_frame_latency = 1;
    config.usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    config.view_formats = vec![];
    let gamma = format.remove_srgb_suffix();
    let mutable =
        adapter.get_downlevel_capabilities().flags.contains(wgpu::DownlevelFlags::SURFACE_VIEW_FORMATS);
    if gamma != format && mutable {
        config.view_formats.push(gamma);
    }
    Ok(config)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_window_fits_the_screen_with_the_camera_s_aspect() {
        // A 4:3 camera on a 1080p screen: 720 high; on Xvfb's 1024×768, 640 high (128 left).
        assert_eq!(default_window_size(Some([1920, 1080]), 4.0 / 3.0), [960, 720]);
        assert_eq!(default_window_size(Some([1024, 768]), 4.0 / 3.0), [853, 640]);
        // 16:9 fills 1280×720 where it fits; a square NFF camera is as high as allowed.
        assert_eq!(default_window_size(Some([2560, 1440]), 16.0 / 9.0), [1280, 720]);
        assert_eq!(default_window_size(Some([1366, 768]), 16.0 / 9.0), [1138, 640]);
        assert_eq!(default_window_size(Some([1920, 1080]), 1.0), [720, 720]);
        // No screen known: 1280×720 at most; a nonsense aspect: 4:3.
        assert_eq!(default_window_size(None, 16.0 / 9.0), [1280, 720]);
        assert_eq!(default_window_size(None, f64::NAN), [960, 720]);
        // A tiny screen still gets a usable window; a strip-like camera keeps 320×240's area.
        let [w, h] = default_window_size(Some([320, 200]), 4.0 / 3.0);
        assert!(w * h >= 320 * 240 - 400, "{w}x{h}");
        let [w, h] = default_window_size(Some([1920, 1080]), 10.0);
        assert_eq!(w, 1280);
        assert!(w * h >= 320 * 240 - 400 && (w as f64 / h as f64 - 10.0).abs() < 0.1, "{w}x{h}");
    }
}
