//! The window: winit's event loop, a wgpu surface with a depth buffer, and the keys and mouse
//! that drive the scene.

use std::sync::Arc;
use std::time::{Duration, Instant};

use morphlod::gpu::RenderTarget;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::Key;
use winit::window::{Window, WindowId};

use super::cache::Library;
use super::scene::{Command, Scene};
use super::{CommonArgs, Demo, DemoError, CLEAR};

pub enum WindowOutcome {
    /// The user closed the window.
    Closed,
    /// No window could be opened (no display, no surface, no event loop): why.
    NoWindow(String),
}

pub fn run_window(
    demo: &Demo,
    args: &CommonArgs,
    library: &Library,
) -> Result<WindowOutcome, DemoError> {
    if let Some(reason) = no_display() {
        return Ok(WindowOutcome::NoWindow(reason));
    }
    let event_loop = match EventLoop::new() {
        Ok(event_loop) => event_loop,
        Err(error) => return Ok(WindowOutcome::NoWindow(error.to_string())),
    };
    let mut app = App {
        demo,
        args,
        library,
        window: None,
        result: None,
    };
    let ran = event_loop.run_app(&mut app);
    match app.result {
        Some(result) => result,
        None => match ran {
            Ok(()) => Ok(WindowOutcome::Closed),
            Err(error) => Err(DemoError::Window(error.to_string())),
        },
    }
}

/// Why no window can be opened here, when that is known before trying: on Unix other than
/// macOS and Android, no `DISPLAY` or `WAYLAND_DISPLAY`. (winit would say the same, prefixed
/// with its source location; this reads better.)
pub fn no_display() -> Option<String> {
    let unix = cfg!(all(
        unix,
        not(target_os = "macos"),
        not(target_os = "android")
    ));
    let unset = ["DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"]
        .iter()
        .all(|name| std::env::var_os(name).is_none_or(|value| value.is_empty()));
    (unix && unset).then(|| "DISPLAY and WAYLAND_DISPLAY are not set".into())
}

struct App<'a> {
    demo: &'a Demo,
    args: &'a CommonArgs,
    library: &'a Library,
    window: Option<WindowState<'a>>,
    /// Set when the loop must end with something other than a normal close.
    result: Option<Result<WindowOutcome, DemoError>>,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, result: Result<WindowOutcome, DemoError>) {
        self.result = Some(result);
        // Drop the surface before the loop ends, while its window still exists.
        self.window = None;
        event_loop.exit();
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        match WindowState::new(event_loop, self.demo, self.args, self.library) {
            Ok(state) => {
                state.presenter.window.request_redraw();
                self.window = Some(state);
            }
            // Nothing was shown yet: the headless path can still do the job.
            Err(Setup::NoWindow(reason)) => {
                self.fail(event_loop, Ok(WindowOutcome::NoWindow(reason)))
            }
            Err(Setup::Failed(error)) => self.fail(event_loop, Err(error)),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        if let Some(error) = window_event(&mut self.window, event_loop, event) {
            self.fail(event_loop, Err(error));
        }
    }
}

/// A demo's window as the events every demo window handles alike see it
/// ([`window_event`]).
pub trait DemoWindow {
    fn presenter(&mut self) -> &mut Presenter;
    /// The window's scale factor changed: the readout's text follows it.
    fn set_text_scale(&mut self, scale: f32);
    /// A key was pressed.
    fn key(&mut self, key: &Key) -> KeyAction;
    fn redraw(&mut self) -> Result<(), DemoError>;
    /// Any other event (the mouse): nothing by default.
    fn other(&mut self, _event: WindowEvent) {}
}

/// What a pressed key does to the window's loop.
pub enum KeyAction {
    Continue,
    Quit,
    /// The key's command failed (e.g. the next asset did not load or build).
    Fail(DemoError),
}

/// Handles `event` for the open `window` (none: nothing to do) the way every demo window
/// does: a close or a quitting key drops the window and ends the loop, a resize reconfigures
/// the surface, a scale change goes to the readout, a redraw draws. Returns the error that
/// must end the loop (the caller drops the window and exits).
pub fn window_event(
    window: &mut Option<impl DemoWindow>,
    event_loop: &ActiveEventLoop,
    event: WindowEvent,
) -> Option<DemoError> {
    let state = window.as_mut()?;
    match event {
        WindowEvent::CloseRequested => {}
        WindowEvent::Resized(size) => {
            state.presenter().resize(size);
            return None;
        }
        WindowEvent::ScaleFactorChanged { scale_factor, .. } => {
            state.set_text_scale((scale_factor as f32).clamp(0.5, 4.0));
            return None;
        }
        WindowEvent::KeyboardInput {
            event:
                KeyEvent {
                    logical_key,
                    state: ElementState::Pressed,
                    ..
                },
            ..
        } => match state.key(&logical_key) {
            KeyAction::Continue => return None,
            KeyAction::Quit => {}
            KeyAction::Fail(error) => return Some(error),
        },
        WindowEvent::RedrawRequested => return state.redraw().err(),
        other => {
            state.other(other);
            return None;
        }
    }
    // Closed or quit: drop the surface while its window still exists.
    *window = None;
    event_loop.exit();
    None
}

/// Why the window could not be set up.
enum Setup {
    /// No window, surface or adapter for it: fall back to headless.
    NoWindow(String),
    /// Something else (the scene's GPU resources): an error.
    Failed(DemoError),
}

/// A window with a wgpu surface in a linear format, a depth buffer, and the device and queue
/// that draw into it: what every demo window presents with. Fields drop in declaration order:
/// the surface before the window it draws into.
pub struct Presenter {
    pub surface: wgpu::Surface<'static>,
    pub config: wgpu::SurfaceConfiguration,
    pub depth: wgpu::TextureView,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: wgpu::AdapterInfo,
    pub window: Arc<Window>,
}

impl Presenter {
    /// Opens a window titled `title` of `(width, height)` pixels and a device that presents to
    /// it; `Err`: why not (no display, surface, adapter or device), for a headless fallback.
    pub fn open(
        event_loop: &ActiveEventLoop,
        title: &str,
        (width, height): (u32, u32),
    ) -> Result<Presenter, String> {
        let attributes = Window::default_attributes()
            .with_title(title)
            .with_inner_size(PhysicalSize::new(width, height));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| format!("creating the window failed: {e}"))?,
        );
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle_from_env(
                Box::new(event_loop.owned_display_handle()),
            ));
        let surface = instance
            .create_surface(Arc::clone(&window))
            .map_err(|e| format!("creating a surface failed: {e}"))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| format!("no adapter can present to the window: {e}"))?;
        // As the headless context: strip colouring needs a nonzero first_instance per draw.
        let descriptor = wgpu::DeviceDescriptor {
            label: Some("morphlod demo device"),
            required_features: adapter.features() & wgpu::Features::INDIRECT_FIRST_INSTANCE,
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .map_err(|e| format!("the adapter could not create a device: {e}"))?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| "the surface does not work with this adapter".to_string())?;
        // A linear format, like the offscreen target: the shader's colours are stored as is,
        // so the window shows what the headless PNGs show.
        let capabilities = surface.get_capabilities(&adapter);
        if let Some(&linear) = capabilities.formats.iter().find(|f| !f.is_srgb()) {
            config.format = linear;
        }
        config.present_mode = wgpu::PresentMode::AutoVsync;
        surface.configure(&device, &config);
        let depth = depth_view(&device, config.width, config.height);
        Ok(Presenter {
            surface,
            config,
            depth,
            device,
            queue,
            adapter: adapter.get_info(),
            window,
        })
    }

    /// Follows the window's new size (a minimised window's size 0 keeps the old one).
    pub fn resize(&mut self, size: PhysicalSize<u32>) {
        if size.width == 0 || size.height == 0 {
            return;
        }
        self.config.width = size.width;
        self.config.height = size.height;
        self.surface.configure(&self.device, &self.config);
        self.depth = depth_view(&self.device, size.width, size.height);
        self.window.request_redraw();
    }

    /// The surface texture to draw this frame into, or `None` when there is none now (the
    /// surface was reconfigured or is hidden; a redraw is requested).
    pub fn frame(&mut self) -> Result<Option<wgpu::SurfaceTexture>, DemoError> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame)
            | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => Ok(Some(frame)),
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                self.window.request_redraw();
                Ok(None)
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.device, &self.config);
                self.window.request_redraw();
                Ok(None)
            }
            wgpu::CurrentSurfaceTexture::Validation => Err(DemoError::Window(
                "the surface texture failed validation".into(),
            )),
        }
    }

    /// The frame's pass: `view` cleared to the demos' background, the depth buffer cleared.
    pub fn begin_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("demo frame"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(CLEAR),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Presents `frame` and asks for the next redraw: the demos redraw continuously, so the
    /// animation plays and the fps figure measures real frames.
    pub fn present(&self, frame: wgpu::SurfaceTexture) {
        self.window.pre_present_notify();
        self.queue.present(frame);
        self.window.request_redraw();
    }
}

/// Frames per second and milliseconds per frame of a window's redraws, averaged over half a
/// second.
pub struct FrameClock {
    last_frame: Instant,
    /// Frames and seconds counted since the figures were last updated.
    window: (u32, Duration),
    pub fps: f32,
    pub frame_ms: f32,
}

impl FrameClock {
    pub fn new() -> FrameClock {
        FrameClock {
            last_frame: Instant::now(),
            window: (0, Duration::ZERO),
            fps: 0.0,
            frame_ms: 0.0,
        }
    }

    /// Counts a frame; returns the seconds since the last one.
    pub fn tick(&mut self) -> f32 {
        let now = Instant::now();
        let elapsed = now - self.last_frame;
        self.last_frame = now;
        self.window.0 += 1;
        self.window.1 += elapsed;
        if self.window.1 >= Duration::from_millis(500) {
            let seconds = self.window.1.as_secs_f32();
            self.fps = self.window.0 as f32 / seconds;
            self.frame_ms = seconds * 1e3 / self.window.0 as f32;
            self.window = (0, Duration::ZERO);
        }
        elapsed.as_secs_f32()
    }
}

/// Everything that lives as long as the window. Fields drop in declaration order: the scene's
/// GPU resources before the device and surface.
struct WindowState<'a> {
    scene: Scene<'a>,
    presenter: Presenter,
    name: &'static str,
    clock: FrameClock,
    dragging: bool,
    cursor: Option<(f32, f32)>,
}

impl<'a> WindowState<'a> {
    fn new(
        event_loop: &ActiveEventLoop,
        demo: &Demo,
        args: &CommonArgs,
        library: &'a Library,
    ) -> Result<WindowState<'a>, Setup> {
        let presenter = Presenter::open(event_loop, &format!("morphlod {}", demo.name), args.size)
            .map_err(Setup::NoWindow)?;
        let (device, queue) = (&presenter.device, &presenter.queue);
        let mut scene = Scene::new(
            device,
            queue,
            &presenter.adapter,
            presenter.config.format,
            library,
            args,
        )
        .map_err(Setup::Failed)?;
        scene.text_scale = (presenter.window.scale_factor() as f32).clamp(0.5, 4.0);
        println!(
            "{}: window open on {} ({:?}), surface {:?}",
            demo.name, presenter.adapter.name, presenter.adapter.backend, presenter.config.format
        );
        Ok(WindowState {
            scene,
            presenter,
            name: demo.name,
            clock: FrameClock::new(),
            dragging: false,
            cursor: None,
        })
    }
}

impl DemoWindow for WindowState<'_> {
    fn presenter(&mut self) -> &mut Presenter {
        &mut self.presenter
    }

    fn set_text_scale(&mut self, scale: f32) {
        self.scene.text_scale = scale;
    }

    fn key(&mut self, key: &Key) -> KeyAction {
        let named;
        let name = match key.as_ref() {
            Key::Named(key) => {
                named = format!("{key:?}");
                named.as_str()
            }
            Key::Character(character) => character,
            _ => return KeyAction::Continue,
        };
        match Command::for_key(name) {
            Some(Command::Quit) => return KeyAction::Quit,
            Some(command) => {
                if let Err(error) = self.scene.apply(&self.presenter.device, command) {
                    return KeyAction::Fail(error);
                }
            }
            None => {}
        }
        self.presenter.window.request_redraw();
        KeyAction::Continue
    }

    fn redraw(&mut self) -> Result<(), DemoError> {
        self.scene.view.advance(self.clock.tick());
        let Some(frame) = self.presenter.frame()? else {
            return Ok(());
        };
        let (width, height) = (self.presenter.config.width, self.presenter.config.height);
        let status = format!(
            "{}  {:.1} fps  {:.2} ms/frame  {width}x{height}",
            self.name, self.clock.fps, self.clock.frame_ms
        );
        let (device, queue) = (&self.presenter.device, &self.presenter.queue);
        let mut encoder = device.create_command_encoder(&Default::default());
        self.scene
            .update(device, queue, &mut encoder, (width, height), &status)?;
        let view = frame.texture.create_view(&Default::default());
        {
            let mut pass = self.presenter.begin_pass(&mut encoder, &view);
            self.scene.draw(&mut pass)?;
        }
        queue.submit([encoder.finish()]);
        self.presenter.present(frame);
        Ok(())
    }

    /// Dragging with the left button turns the view, the wheel zooms.
    fn other(&mut self, event: WindowEvent) {
        match event {
            WindowEvent::MouseInput {
                state: pressed,
                button: MouseButton::Left,
                ..
            } => self.dragging = pressed == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                let at = (position.x as f32, position.y as f32);
                if self.dragging {
                    if let Some((x, y)) = self.cursor {
                        let view = &mut self.scene.view;
                        view.yaw -= (at.0 - x) * 0.01;
                        view.pitch = (view.pitch + (at.1 - y) * 0.01).clamp(-1.4, 1.4);
                    }
                }
                self.cursor = Some(at);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
                let view = &mut self.scene.view;
                view.zoom = (view.zoom * 0.9f32.powf(lines)).clamp(0.05, 20.0);
            }
            _ => {}
        }
    }
}

/// The depth buffer of the window's pass, in the format the pipelines were made for.
fn depth_view(device: &wgpu::Device, width: u32, height: u32) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("demo depth"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: RenderTarget::DEPTH_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}
