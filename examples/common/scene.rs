//! The scene: the [`LodObject`] of the morph shown (loaded from the library when chosen), the
//! view state the keys and mouse change, the orbit camera and the readout text, recorded into
//! a pass the caller owns.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::{Mat4, Vec3};
use glyphon::{
    Attrs, Buffer, Cache, Color, ColorMode, Family, FontSystem, Metrics, Resolution, Shaping,
    SwashCache, TextArea, TextAtlas, TextBounds, TextRenderer, Viewport,
};
use morphlod::gpu::{DrawCounter, LodObject, MorphPipeline, RenderTarget, ShadeMode, Upload};
use morphlod::Lod;

use super::cache::{BuiltMorph, Library};
use super::{CommonArgs, DemoError};

/// The one font of the readout, compiled in: CI machines and containers have no system fonts.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSansMono.ttf");
const FONT_FAMILY: &str = "DejaVu Sans Mono";
/// Readout font size and line height, in physical pixels.
const FONT_SIZE: f32 = 15.0;
const LINE_HEIGHT: f32 = 19.0;
const SKIN: [f32; 4] = [0.85, 0.62, 0.5, 1.0];
const AMBIENT: f32 = 0.25;
const FOV_Y: f32 = 30.0 * std::f32::consts::PI / 180.0;
/// Seconds from one pose to the other while playing (then back: t ping-pongs).
const MORPH_SECONDS: f32 = 2.0;

/// How the LOD is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LodControl {
    /// The paper's parameter: 0 = full detail, 1 = coarsest.
    Fraction(f32),
    /// Screen-space error bound in pixels, turned into an object-space bound at the camera's
    /// distance ([`Lod::screen_error`]).
    Pixels(f32),
}

/// The user-controlled view state, shared by the window and the headless sweep.
pub struct View {
    pub t: f32,
    /// +1 or -1: the direction t moves while playing.
    pub direction: f32,
    pub playing: bool,
    pub lod: LodControl,
    pub strips: bool,
    /// The shading while strips are not coloured: textured (the default; an asset without a
    /// surface draws faceted), smooth or faceted.
    pub shade: ShadeMode,
    pub yaw: f32,
    pub pitch: f32,
    /// Camera distance relative to the distance that frames the object.
    pub zoom: f32,
}

impl View {
    pub fn new(strips: bool) -> View {
        // The contact sheets' view direction (-0.35, -0.15, -1), as orbit angles.
        View {
            t: 0.0,
            direction: 1.0,
            playing: true,
            lod: LodControl::Fraction(0.0),
            strips,
            shade: ShadeMode::Textured,
            yaw: 0.35f32.atan2(1.0),
            pitch: (0.15f32 / (0.35f32 * 0.35 + 0.15 * 0.15 + 1.0).sqrt()).asin(),
            zoom: 1.0,
        }
    }

    pub fn advance(&mut self, seconds: f32) {
        if !self.playing {
            return;
        }
        self.t += self.direction * seconds / MORPH_SECONDS;
        if self.t >= 1.0 {
            self.t = 1.0;
            self.direction = -1.0;
        } else if self.t <= 0.0 {
            self.t = 0.0;
            self.direction = 1.0;
        }
    }

    pub fn step_t(&mut self, delta: f32) {
        self.playing = false;
        self.t = (self.t + delta).clamp(0.0, 1.0);
    }

    /// Coarser (`coarser` = true) or finer by one step of the current LOD control.
    pub fn step_lod(&mut self, coarser: bool) {
        self.lod = match self.lod {
            LodControl::Fraction(f) => {
                let step = if coarser { 0.05 } else { -0.05 };
                LodControl::Fraction((f + step).clamp(0.0, 1.0))
            }
            LodControl::Pixels(p) => {
                let factor = if coarser { 1.5 } else { 1.0 / 1.5 };
                LodControl::Pixels((p * factor).clamp(0.05, 500.0))
            }
        };
    }

    /// Textured → smooth → faceted → textured.
    pub fn next_shade(&mut self) {
        self.shade = match self.shade {
            ShadeMode::Textured => ShadeMode::Smooth,
            ShadeMode::Smooth => ShadeMode::Faceted,
            ShadeMode::Faceted | ShadeMode::StripColours => ShadeMode::Textured,
        };
    }

    /// Carries out what `command` changes in the view. [`Command::StepMorph`] is the scene's:
    /// its step is returned; [`Command::Quit`] is the caller's and changes nothing.
    pub fn apply(&mut self, command: Command) -> Option<isize> {
        match command {
            Command::Quit => {}
            Command::PlayPause => self.playing = !self.playing,
            Command::StepT(delta) => self.step_t(delta),
            Command::StepLod(coarser) => self.step_lod(coarser),
            Command::ToggleLodControl => self.toggle_lod_control(),
            Command::ToggleStrips => self.strips = !self.strips,
            Command::NextShade => self.next_shade(),
            Command::ResetView => {
                let fresh = View::new(self.strips);
                (self.yaw, self.pitch, self.zoom) = (fresh.yaw, fresh.pitch, fresh.zoom);
            }
            Command::StepMorph(step) => return Some(step),
        }
        None
    }

    pub fn toggle_lod_control(&mut self) {
        self.lod = match self.lod {
            LodControl::Fraction(_) => LodControl::Pixels(1.0),
            LodControl::Pixels(_) => LodControl::Fraction(0.0),
        };
    }
}

/// What a key does. The window maps each pressed key to one by its name ([`Command::for_key`]);
/// the headless sequence replays `--keys` through the same table, so both mean the same.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    Quit,
    PlayPause,
    /// Moves t by this much (and pauses).
    StepT(f32),
    /// One LOD step coarser (`true`) or finer.
    StepLod(bool),
    ToggleLodControl,
    ToggleStrips,
    NextShade,
    ResetView,
    /// Shows the morph this many places on (negative: back), wrapping around.
    StepMorph(isize),
}

impl Command {
    /// The command of a key by its name: winit's name of a named key (`Escape`, `Space`,
    /// `ArrowLeft`, ...) or the character a key types (`q`, `]`, ...). `None`: the key does
    /// nothing.
    pub fn for_key(name: &str) -> Option<Command> {
        Some(match name {
            "Escape" | "q" => Command::Quit,
            "Space" | " " => Command::PlayPause,
            "ArrowRight" => Command::StepT(0.05),
            "ArrowLeft" => Command::StepT(-0.05),
            "ArrowUp" => Command::StepLod(false),
            "ArrowDown" => Command::StepLod(true),
            "l" => Command::ToggleLodControl,
            "s" => Command::ToggleStrips,
            "m" => Command::NextShade,
            "r" => Command::ResetView,
            "n" | "]" => Command::StepMorph(1),
            "[" => Command::StepMorph(-1),
            _ => return None,
        })
    }
}

/// A camera orbiting the morph's bounding sphere.
struct Orbit {
    view_proj: Mat4,
    eye_direction: Vec3,
    distance: f32,
}

fn orbit(centre: Vec3, radius: f32, view: &View, aspect: f32) -> Orbit {
    let d = Vec3::new(
        view.pitch.cos() * view.yaw.sin(),
        view.pitch.sin(),
        view.pitch.cos() * view.yaw.cos(),
    );
    // The sphere fits when its radius subtends at most the narrower half-angle of the view.
    let half_y = FOV_Y * 0.5;
    let half_x = (half_y.tan() * aspect).atan();
    let distance = radius / half_y.min(half_x).sin() * view.zoom;
    let near = (distance - radius * 1.05).max(distance * 1e-2);
    let far = distance + radius * 1.05;
    let eye = centre + d * distance;
    let view_matrix = glam::camera::rh::view::look_at_mat4(eye, centre, Vec3::Y);
    let proj = glam::camera::rh::proj::directx::perspective(FOV_Y, aspect, near, far);
    Orbit {
        view_proj: proj * view_matrix,
        eye_direction: d,
        distance,
    }
}

/// What one frame did, for the readout.
#[derive(Clone, Debug, Default)]
pub struct FrameStats {
    /// CPU time of `set` + `prepare`.
    pub cpu: Duration,
    pub upload: Upload,
    pub draw_calls: u64,
}

/// The object of the morph shown (one at a time: a face demo has 52 morphs, each with its
/// texture; switching loads the next from the cache, or builds it), the view state and the
/// readout.
pub struct Scene<'a> {
    library: &'a Library,
    pipeline: MorphPipeline,
    pub object: SceneObject,
    pub current: usize,
    pub view: View,
    readout: Readout,
    /// Whether the device can colour strips (`INDIRECT_FIRST_INSTANCE`).
    strip_colours: bool,
    adapter: String,
    pub last: FrameStats,
    /// Whether the readout lists the keys (the window) or not (headless frames).
    pub show_keys: bool,
    /// The window's scale factor: the readout keeps its size in logical pixels.
    pub text_scale: f32,
}

/// The readout's key help, under the figures.
const KEYS: &str =
    "\nkeys  <-/-> t  space play/pause  up/down LOD finer/coarser  l fraction/pixels\n      \
     ]/n next morph  [ previous  m textured/smooth/faceted  s strip colours\n      \
     drag orbit  wheel zoom  r reset view  q quit";

pub struct SceneObject {
    label: String,
    pub object: LodObject,
    centre: Vec3,
    radius: f32,
}

impl SceneObject {
    fn new(
        device: &wgpu::Device,
        pipeline: &MorphPipeline,
        built: BuiltMorph,
    ) -> Result<SceneObject, DemoError> {
        let mut object = LodObject::new(device, pipeline, &built.asset, Arc::clone(&built.model))
            .map_err(DemoError::lib)?;
        object.set_color(SKIN);
        let both: Vec<[f32; 3]> = built
            .asset
            .v0
            .iter()
            .chain(&built.asset.v1)
            .copied()
            .collect();
        // Built assets have vertices; an empty one would have failed DeformingModel::new.
        let (min, max) = morphlod::mesh::bounds(&both).unwrap_or(([0.0; 3], [0.0; 3]));
        let (min, max) = (Vec3::from(min), Vec3::from(max));
        let radius = ((max - min).length() * 0.5).max(1e-6);
        Ok(SceneObject {
            label: built.label,
            object,
            centre: (min + max) * 0.5,
            radius,
        })
    }
}

impl<'a> Scene<'a> {
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        adapter: &wgpu::AdapterInfo,
        color_format: wgpu::TextureFormat,
        library: &'a Library,
        args: &CommonArgs,
    ) -> Result<Scene<'a>, DemoError> {
        let pipeline = MorphPipeline::new(device, color_format, Some(RenderTarget::DEPTH_FORMAT));
        let object = SceneObject::new(device, &pipeline, library.load(args.morph)?)?;
        Ok(Scene {
            library,
            pipeline,
            object,
            current: args.morph,
            view: View::new(args.strips),
            readout: Readout::new(device, queue, color_format),
            strip_colours: device
                .features()
                .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE),
            adapter: format!("{} ({:?}), {color_format:?}", adapter.name, adapter.backend),
            last: FrameStats::default(),
            show_keys: true,
            text_scale: 1.0,
        })
    }

    /// Moves the current object to the view's `(t, LOD)`, uploads what changed and lays out
    /// the readout for a `width` x `height` frame. `status` is the first readout line. The
    /// object's index scatter (on a frame that has one) is recorded into `encoder`, the frame's
    /// encoder: draw in it after this call and submit it before the next `update`
    /// (`LodObject::prepare_with`).
    pub fn update(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        (width, height): (u32, u32),
        status: &str,
    ) -> Result<(), DemoError> {
        let view = &self.view;
        let current = &mut self.object;
        let camera = orbit(
            current.centre,
            current.radius,
            view,
            width as f32 / height.max(1) as f32,
        );
        let lod = match view.lod {
            LodControl::Fraction(f) => Lod::Fraction(f),
            LodControl::Pixels(p) => Lod::screen_error(p, camera.distance, FOV_Y, height as f32),
        };
        let object = &mut current.object;
        let start = Instant::now();
        object.set(view.t, lod).map_err(DemoError::lib)?;
        object.set_view_proj(camera.view_proj);
        object
            .set_light(camera.eye_direction + Vec3::Y * 0.5, AMBIENT)
            .map_err(DemoError::lib)?;
        object.set_shade_mode(if view.strips {
            ShadeMode::StripColours
        } else {
            view.shade
        });
        let upload = object.prepare_with(queue, encoder);
        let cpu = start.elapsed();
        self.last = FrameStats {
            cpu,
            upload,
            draw_calls: self.last.draw_calls,
        };
        let text = self.readout_text(status, lod);
        self.readout
            .prepare(device, queue, (width, height), self.text_scale, &text)
    }

    /// Records the current object (one multi-draw) and the readout into `pass`, whose
    /// attachments have the formats the scene was made for.
    pub fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) -> Result<(), DemoError> {
        let mut counter = DrawCounter::new(pass);
        self.object.object.render(&mut counter);
        self.last.draw_calls = counter.draw_calls;
        self.readout.draw(pass)
    }

    fn readout_text(&self, status: &str, lod: Lod) -> String {
        let current = &self.object;
        let state = current.object.state();
        let model = current.object.model();
        let frame = state.frame();
        let max_steps = model.resolve(frame, Lod::Fraction(1.0)).unwrap_or(0);
        let lod_line = match (self.view.lod, lod) {
            (LodControl::Pixels(p), Lod::MaxError(e)) => {
                format!("LOD   screen error {p:.2} px = {e:.2e} units")
            }
            (LodControl::Fraction(f), _) | (LodControl::Pixels(f), _) => {
                format!("LOD   fraction {f:.2}")
            }
        };
        let triangles = state.triangle_count();
        let indices = state.index_count();
        let upload = &self.last.upload;
        let shading = match (current.object.object().shade_mode(), self.strip_colours) {
            (ShadeMode::Textured, _) => "textured, smooth normals",
            (ShadeMode::Smooth, _) => "smooth normals, one colour",
            (ShadeMode::Faceted, _) if current.object.object().has_surface() => "faceted",
            (ShadeMode::Faceted, _) => "faceted (the asset has no normals or UVs)",
            (ShadeMode::StripColours, true) => "one colour per strip",
            (ShadeMode::StripColours, false) => {
                "strips (this device lacks INDIRECT_FIRST_INSTANCE: one colour)"
            }
        };
        format!(
            "{status}\n\
             morph {}/{}: {}\n\
             t     {:.3} {}   sampled frame k = {} of {}\n\
             {lod_line}   -> {} of {} collapses\n\
             drawn {} triangles, {} indices ({:.2} per triangle), {} mesh draw call(s)\n\
             upload {} B this frame (index+indirect {} B, uniforms {} B, offsets {} B, \
             texture {} B), set+prepare {:.3} ms\n\
             shade {shading}   adapter {}{}",
            self.current + 1,
            self.library.len(),
            current.label,
            self.view.t,
            if self.view.playing {
                "playing"
            } else {
                "paused "
            },
            frame,
            model.frame_count(),
            state.lod(),
            max_steps,
            triangles,
            indices,
            indices as f64 / triangles.max(1) as f64,
            self.last.draw_calls,
            upload.bytes(),
            upload.geometry_bytes(),
            upload.uniform_bytes,
            upload.offset_bytes,
            upload.texture_bytes,
            self.last.cpu.as_secs_f64() * 1e3,
            self.adapter,
            if self.show_keys { KEYS } else { "" },
        )
    }

    /// Carries out `command` (all but [`Command::Quit`], which ends the caller's loop).
    pub fn apply(&mut self, device: &wgpu::Device, command: Command) -> Result<(), DemoError> {
        match self.view.apply(command) {
            Some(step) => self.step_morph(device, step),
            None => Ok(()),
        }
    }

    /// Shows the morph `step` places after the current one (negative: before), wrapping
    /// around; its asset is loaded, or built when not cached (which takes a while the first
    /// time). The new object replaces the old one, so at most two morphs' buffers and textures
    /// are held, and only during the switch.
    pub fn step_morph(&mut self, device: &wgpu::Device, step: isize) -> Result<(), DemoError> {
        let count = self.library.len().max(1) as isize;
        let next = (self.current as isize + step).rem_euclid(count) as usize;
        if next == self.current {
            return Ok(());
        }
        println!("showing {}", self.library.label(next));
        let built = self.library.load(next)?;
        self.object = SceneObject::new(device, &self.pipeline, built)?;
        self.current = next;
        Ok(())
    }
}

/// The on-screen text: glyphon's atlas and renderer with the embedded font only.
pub struct Readout {
    font_system: FontSystem,
    swash_cache: SwashCache,
    viewport: Viewport,
    atlas: TextAtlas,
    renderer: TextRenderer,
    buffer: Buffer,
}

impl Readout {
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Readout {
        let mut db = glyphon::fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        // No system fonts are loaded: the text looks the same everywhere, and works where none
        // are installed.
        let mut font_system = FontSystem::new_with_locale_and_db("en-US".to_string(), db);
        let cache = Cache::new(device);
        let viewport = Viewport::new(device, &cache);
        // Web mode stores glyph colours as given: right for the linear (non-sRGB) formats the
        // demos draw into, where the mesh's shader output is also stored as is.
        let color_mode = if format.is_srgb() {
            ColorMode::Accurate
        } else {
            ColorMode::Web
        };
        let mut atlas = TextAtlas::with_color_mode(device, queue, &cache, format, color_mode);
        // The text is drawn in the mesh's pass, which has a depth buffer: the text pipeline
        // must declare it, and neither tests nor writes depth so it stays on top.
        let depth = wgpu::DepthStencilState {
            format: RenderTarget::DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        };
        let renderer = TextRenderer::new(
            &mut atlas,
            device,
            wgpu::MultisampleState::default(),
            Some(depth),
        );
        let buffer = Buffer::new(&mut font_system, Metrics::new(FONT_SIZE, LINE_HEIGHT));
        Readout {
            font_system,
            swash_cache: SwashCache::new(),
            viewport,
            atlas,
            renderer,
            buffer,
        }
    }

    /// Lays out `text` at the top left of a `width` x `height` frame, `scale` times the
    /// font's size.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        (width, height): (u32, u32),
        scale: f32,
        text: &str,
    ) -> Result<(), DemoError> {
        self.viewport.update(queue, Resolution { width, height });
        self.buffer
            .set_size(Some(width as f32 / scale), Some(height as f32 / scale));
        self.buffer.set_text(
            text,
            &Attrs::new().family(Family::Name(FONT_FAMILY)),
            Shaping::Basic,
            None,
        );
        self.buffer.shape_until_scroll(&mut self.font_system, false);
        let bounds = TextBounds {
            left: 0,
            top: 0,
            right: width as i32,
            bottom: height as i32,
        };
        let area = |offset: f32, color: Color| TextArea {
            buffer: &self.buffer,
            left: (10.0 + offset) * scale,
            top: (8.0 + offset) * scale,
            scale,
            bounds,
            default_color: color,
            custom_glyphs: &[],
        };
        // A dark copy one pixel down-right under the light text keeps it readable over the mesh.
        self.renderer
            .prepare(
                device,
                queue,
                &mut self.font_system,
                &mut self.atlas,
                &self.viewport,
                [
                    area(1.0, Color::rgb(0, 0, 0)),
                    area(0.0, Color::rgb(235, 235, 235)),
                ],
                &mut self.swash_cache,
            )
            .map_err(|e| DemoError::Text(e.to_string()))
    }

    /// Records the text into `pass` (which has the depth buffer the demos draw with).
    pub fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) -> Result<(), DemoError> {
        self.renderer
            .render(&self.atlas, &self.viewport, pass)
            .map_err(|e| DemoError::Text(e.to_string()))?;
        self.atlas.trim();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every key the readout lists does what it says, through the one table the window and
    /// `--keys` share.
    #[test]
    fn keys_do_what_the_readout_says() {
        let press = |view: &mut View, key: &str| {
            let command = Command::for_key(key).unwrap_or_else(|| panic!("{key:?} is a key"));
            view.apply(command)
        };
        let mut view = View::new(false);
        assert_eq!(Command::for_key("Escape"), Some(Command::Quit));
        assert_eq!(Command::for_key("q"), Some(Command::Quit));
        assert_eq!(Command::for_key("x"), None);
        assert_eq!(Command::for_key("F1"), None);

        press(&mut view, "Space");
        assert!(!view.playing, "space pauses");
        press(&mut view, " ");
        assert!(view.playing, "and plays again");
        press(&mut view, "ArrowRight");
        press(&mut view, "ArrowRight");
        assert!(!view.playing && (view.t - 0.1).abs() < 1e-6, "t {}", view.t);
        press(&mut view, "ArrowLeft");
        assert!((view.t - 0.05).abs() < 1e-6, "t {}", view.t);
        for _ in 0..3 {
            press(&mut view, "ArrowLeft");
        }
        assert_eq!(view.t, 0.0, "t stops at 0");

        press(&mut view, "ArrowDown");
        assert_eq!(view.lod, LodControl::Fraction(0.05), "down is coarser");
        press(&mut view, "ArrowUp");
        press(&mut view, "ArrowUp");
        assert_eq!(
            view.lod,
            LodControl::Fraction(0.0),
            "up is finer, down to full detail"
        );
        press(&mut view, "l");
        assert_eq!(view.lod, LodControl::Pixels(1.0));
        press(&mut view, "ArrowDown");
        assert_eq!(
            view.lod,
            LodControl::Pixels(1.5),
            "pixels grow by 1.5 when coarser"
        );
        press(&mut view, "l");
        assert_eq!(view.lod, LodControl::Fraction(0.0));

        assert_eq!(view.shade, ShadeMode::Textured);
        let shades: Vec<ShadeMode> = (0..3)
            .map(|_| {
                press(&mut view, "m");
                view.shade
            })
            .collect();
        assert_eq!(
            shades,
            [ShadeMode::Smooth, ShadeMode::Faceted, ShadeMode::Textured]
        );
        press(&mut view, "s");
        assert!(view.strips);

        (view.yaw, view.pitch, view.zoom) = (1.0, 0.5, 3.0);
        press(&mut view, "r");
        let fresh = View::new(true);
        assert_eq!(
            (view.yaw, view.pitch, view.zoom),
            (fresh.yaw, fresh.pitch, fresh.zoom)
        );
        assert!(view.strips, "reset keeps the strip colours");

        assert_eq!(press(&mut view, "]"), Some(1));
        assert_eq!(press(&mut view, "n"), Some(1));
        assert_eq!(press(&mut view, "["), Some(-1));
        assert_eq!(press(&mut view, "q"), None);
    }
}
