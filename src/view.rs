//! `vxgi view`: a window that draws a pipeline's GPU-resident frames continuously, with the camera,
//! the first light, the pipeline and its settings under the mouse and keyboard, and an overlay of
//! what each frame cost (the frame counters `vxgi render` writes to frames.csv).
//!
//! Each frame is [`Resident::present`]: the pipeline's passes, then this module's display pass
//! (`view.wgsl`: `vxgi render`'s PNG transform) and the overlay into the window's surface texture,
//! in one command encoder and one submission.
//!
//! The overlay is egui's (egui-wgpu renders it into the same encoder): a maintained text and
//! layout renderer that already targets wgpu 30, where a hand-made glyph renderer would be code to
//! keep for no gain. It shows the previous frame's counters (a frame's GPU time is known only once
//! it has finished).
//!
//! Scripted input (`--script`) makes runs repeatable: timed [`Action`]s, applied before the frame
//! they name, the same actions the keys and the mouse take.
use crate::frames::FrameRow;
use crate::harness::GpuContext;
use crate::kernels::cone_trace::ConeSettings;
use crate::render::{Pipeline, VolumeMemory};
use crate::resident::{FrameBuffers, Resident};
use crate::scene::{CameraDesc, Light, Scene};
use anyhow::{bail, Context, Result};
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// Which image the window shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Shown {
    Combined,
    Direct,
    Indirect,
    Ao,
}

impl Shown {
    const ALL: [Shown; 4] = [Shown::Combined, Shown::Direct, Shown::Indirect, Shown::Ao];

    pub fn name(self) -> &'static str {
        match self {
            Shown::Combined => "combined",
            Shown::Direct => "direct",
            Shown::Indirect => "indirect",
            Shown::Ao => "ao",
        }
    }

    fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    fn next(self) -> Self {
        Self::ALL[(self as usize + 1) % Self::ALL.len()]
    }
}

/// One input, from a key, the mouse or a script.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Degrees about the camera's up axis through its target (as `vxgi render --orbit`), then about
    /// its right axis.
    Orbit(f32, f32),
    /// The eye and the target moved across the view, in view heights at the target's distance.
    Pan(f32, f32),
    /// The eye's distance to the target times this.
    Zoom(f32),
    /// The eye and the target moved along the view (forward, right, up), in scene units.
    Fly(Vec3),
    Pipeline(Pipeline),
    Show(Shown),
    /// The diffuse cone count (`cones`, 1..=64).
    Cones(u32),
    /// The voxel grid side (`voxels`).
    Voxels(u32),
    /// The first light moved by this (point and spot lights: their position; a directional light:
    /// its direction, renormalized).
    Light(Vec3),
    /// The window's inner size in pixels (the frame follows it).
    Resize(u32, u32),
    /// Play or pause the `[[instances]]` keyframes (a frame a step).
    Play(bool),
    Overlay(bool),
}

/// Timed actions: (frame, action), applied before the frame they name (frames counted from 0), in
/// the order given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    pub steps: Vec<(u32, Action)>,
}

impl Script {
    /// A script's text: one step per line or `;`-separated, `FRAME ACTION ARGS...`, `#` comments:
    /// `orbit YAW [PITCH]`, `pan X Y`, `zoom F`, `fly FORWARD RIGHT UP`, `pipeline NAME`,
    /// `view combined|direct|indirect|ao`, `cones N`, `voxels N`, `light DX DY DZ`, `resize W H`,
    /// `play`, `pause`, `overlay on|off`.
    pub fn parse(text: &str) -> Result<Self> {
        let mut steps = Vec::new();
        for step in text.split([';', '\n']) {
            let step = step.split('#').next().unwrap_or("").trim();
            if step.is_empty() {
                continue;
            }
            let words: Vec<&str> = step.split_whitespace().collect();
            let fail = |why: &str| anyhow::anyhow!("script step `{step}`: {why}");
            let frame: u32 = words[0]
                .parse()
                .map_err(|_| fail("starts with the frame it applies before (0, 1, ...)"))?;
            let Some(&action) = words.get(1) else {
                return Err(fail("names no action"));
            };
            let args = &words[2..];
            let floats = |n: usize, m: usize| -> Result<Vec<f32>> {
                if args.len() < n || args.len() > m {
                    return Err(fail(&format!("`{action}` takes {n}..={m} numbers")));
                }
                args.iter()
                    .map(|a| {
                        a.parse::<f32>()
                            .ok()
                            .filter(|v| v.is_finite())
                            .ok_or_else(|| fail(&format!("`{a}` is not a finite number")))
                    })
                    .collect()
            };
            let whole = |n: usize| -> Result<Vec<u32>> {
                if args.len() != n {
                    return Err(fail(&format!("`{action}` takes {n} whole numbers")));
                }
                args.iter()
                    .map(|a| {
                        a.parse::<u32>()
                            .map_err(|_| fail(&format!("`{a}` is not a whole number")))
                    })
                    .collect()
            };
            let word = || -> Result<&str> {
                match args {
                    [w] => Ok(w),
                    _ => Err(fail(&format!("`{action}` takes one word"))),
                }
            };
            let a =
                match action {
                    "orbit" => {
                        let v = floats(1, 2)?;
                        Action::Orbit(v[0], v.get(1).copied().unwrap_or(0.0))
                    }
                    "pan" => {
                        let v = floats(2, 2)?;
                        Action::Pan(v[0], v[1])
                    }
                    "zoom" => {
                        let v = floats(1, 1)?;
                        if v[0] <= 0.0 {
                            return Err(fail("zoom takes a factor above 0"));
                        }
                        Action::Zoom(v[0])
                    }
                    "fly" => Action::Fly(Vec3::from_slice(&floats(3, 3)?)),
                    "light" => Action::Light(Vec3::from_slice(&floats(3, 3)?)),
                    "pipeline" => {
                        let w = word()?;
                        Action::Pipeline(Pipeline::from_name(w).ok_or_else(|| {
                            fail("pipelines are vct-dense, vct-svo, lrsm and cprc")
                        })?)
                    }
                    "view" => Action::Show(
                        Shown::from_name(word()?)
                            .ok_or_else(|| fail("views are combined, direct, indirect and ao"))?,
                    ),
                    // Checked now by the scene files' own rule, so a bad value names its step.
                    "cones" | "voxels" => {
                        let n = whole(1)?[0];
                        let mut r = crate::scene::RenderSettings::default();
                        let a = if action == "cones" {
                            r.cones = n;
                            Action::Cones(n)
                        } else {
                            r.voxels = n;
                            Action::Voxels(n)
                        };
                        r.validate().map_err(|e| fail(&e))?;
                        a
                    }
                    "resize" => {
                        let v = whole(2)?;
                        if v[0] == 0 || v[1] == 0 || v[0] > 8192 || v[1] > 8192 {
                            return Err(fail("a window is 1x1 to 8192x8192 (the camera's limit)"));
                        }
                        Action::Resize(v[0], v[1])
                    }
                    "play" | "pause" if args.is_empty() => Action::Play(action == "play"),
                    "overlay" => match word()? {
                        "on" => Action::Overlay(true),
                        "off" => Action::Overlay(false),
                        _ => return Err(fail("overlay on or off")),
                    },
                    _ => return Err(fail("unknown action (see `vxgi view --help`)")),
                };
            steps.push((frame, a));
        }
        Ok(Self { steps })
    }

    /// `--script`'s value: a file's path, or the script itself.
    pub fn from_arg(arg: &str) -> Result<Self> {
        let path = Path::new(arg);
        if path.is_file() {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading the script {}", path.display()))?;
            Self::parse(&text).with_context(|| format!("in {}", path.display()))
        } else if path.is_dir() {
            anyhow::bail!("--script {arg}: a folder; pass a script file or the steps themselves")
        } else {
            // Steps start with a frame number; a single word that does not is a file's name.
            let first = arg.split_whitespace().next().unwrap_or("");
            if !arg.trim().is_empty()
                && !arg.contains(char::is_whitespace)
                && first.parse::<u32>().is_err()
            {
                anyhow::bail!(
                    "--script {arg}: no such file (steps are `FRAME ACTION ARGS`, e.g. \"2 orbit 5 0\")"
                );
            }
            Self::parse(arg)
        }
    }

    fn at(&self, frame: u32) -> impl Iterator<Item = &Action> {
        self.steps
            .iter()
            .filter(move |(f, _)| *f == frame)
            .map(|(_, a)| a)
    }
}

/// The camera turned about its target: `yaw` degrees about its up axis (exactly as
/// [`Scene::orbited`]), then `pitch` about its right axis, stopping short of the up axis.
pub fn orbit(c: &mut CameraDesc, yaw: f32, pitch: f32) {
    let (eye, target) = (Vec3::from(c.eye), Vec3::from(c.target));
    let axis = Vec3::from(c.up).normalize();
    let mut offset = Quat::from_axis_angle(axis, yaw.to_radians()) * (eye - target);
    if pitch != 0.0 {
        let right = offset.cross(axis).normalize_or_zero();
        let turned = Quat::from_axis_angle(right, pitch.to_radians()) * offset;
        // Within 2 degrees of the up axis the view's basis degenerates: stop there.
        if turned.normalize().dot(axis).abs() < 2f32.to_radians().cos() && right != Vec3::ZERO {
            offset = turned;
        }
    }
    c.eye = (target + offset).to_array();
}

/// The camera's basis: (forward unit, right unit, up unit).
fn basis(c: &CameraDesc) -> (Vec3, Vec3, Vec3) {
    let f = (Vec3::from(c.target) - Vec3::from(c.eye)).normalize();
    let r = f.cross(Vec3::from(c.up)).normalize();
    (f, r, r.cross(f))
}

fn apply_camera(c: &mut CameraDesc, a: &Action) {
    let (eye, target) = (Vec3::from(c.eye), Vec3::from(c.target));
    let (f, r, u) = basis(c);
    let dist = (target - eye).length();
    let shift = match a {
        Action::Orbit(yaw, pitch) => return orbit(c, *yaw, *pitch),
        Action::Zoom(k) => {
            c.eye = (target + (eye - target) * *k).to_array();
            return;
        }
        Action::Pan(x, y) => {
            let height = 2.0 * dist * (c.fov_y_deg.to_radians() * 0.5).tan();
            (r * *x + u * *y) * height
        }
        Action::Fly(v) => f * v.x + r * v.y + u * v.z,
        _ => return,
    };
    c.eye = (eye + shift).to_array();
    c.target = (target + shift).to_array();
}

/// A light moved by `d`: see [`Action::Light`].
pub fn move_light(l: &mut Light, d: Vec3) {
    match l {
        Light::Point { position, .. } | Light::Spot { position, .. } => {
            *position = (Vec3::from(*position) + d).to_array()
        }
        Light::Directional { direction, .. } => {
            let v = Vec3::from(*direction) + d;
            if v.length() > 1e-6 {
                *direction = v.normalize().to_array();
            }
        }
    }
}

/// What the user controls: applied to the loaded scene for every frame.
#[derive(Clone, Debug)]
struct Controls {
    pipeline: Pipeline,
    shown: Shown,
    camera: CameraDesc,
    cones: Option<u32>,
    voxels: Option<u32>,
    light: Vec3,
    playing: bool,
    time: u32,
    overlay: bool,
}

impl Controls {
    fn apply(&mut self, a: &Action, scene: &Scene) {
        match a {
            Action::Pipeline(p) => self.pipeline = *p,
            Action::Show(s) => self.shown = *s,
            Action::Cones(n) => self.cones = Some(*n),
            Action::Voxels(n) => self.voxels = Some(*n),
            Action::Light(d) => self.light += *d,
            Action::Play(p) => self.playing = *p,
            Action::Overlay(o) => self.overlay = *o,
            Action::Resize(..) => {}
            _ => apply_camera(&mut self.camera, a),
        }
        let _ = scene;
    }

    /// The frame's scene: the loaded one at the animation's frame with these controls, its preset
    /// resolved for the pipeline, one sample per pixel, and the exposure it is rendered at (the
    /// display pass scales the radiance back by it).
    fn scene(&self, base: &Scene, size: (u32, u32)) -> Result<(Scene, f32)> {
        let mut s = base.clone();
        for (key, v) in [("cones", self.cones), ("voxels", self.voxels)] {
            if let Some(v) = v {
                match key {
                    "cones" => s.render.cones = v,
                    _ => s.render.voxels = v,
                }
                s.explicit_render.insert(key.to_string());
            }
        }
        s.render.supersample = 1;
        s.render.validate().map_err(anyhow::Error::msg)?;
        let (s, _) = crate::quality::resolved(&s, self.pipeline).map_err(anyhow::Error::msg)?;
        let mut s = s.at_frame(self.time);
        s.camera = CameraDesc {
            width: size.0,
            height: size.1,
            ..self.camera.clone()
        };
        if let Some(l) = s.lights.first_mut() {
            move_light(l, self.light);
        }
        // Moved as far as the scene loader lets a file place things (its coordinate bound).
        let bound = crate::scene::MAX_COORDINATE;
        let far = |what: &str, p: [f32; 3]| {
            (!p.iter().all(|c| c.abs() <= bound)).then(|| {
                format!("{what} moved to {p:?}, past the scenes' coordinate bound +-{bound:e}")
            })
        };
        let light = match s.lights.first() {
            Some(Light::Point { position, .. } | Light::Spot { position, .. }) => Some(*position),
            _ => None,
        };
        let placed = [
            ("the camera", Some(s.camera.eye)),
            ("its target", Some(s.camera.target)),
        ];
        if let Some(e) = placed
            .into_iter()
            .chain([("the first light", light)])
            .find_map(|(what, p)| p.and_then(|p| far(what, p)))
        {
            bail!("{e}");
        }
        crate::limits::check_bounces(&s, self.pipeline).map_err(anyhow::Error::msg)?;
        let k = crate::render::exposure_for(&s, self.pipeline);
        Ok(if k == 0 {
            (s, 1.0)
        } else {
            (s.with_lights_scaled(2f32.powi(-k)), 2f32.powi(k))
        })
    }
}

/// What `vxgi view` is asked to do.
pub struct ViewOptions {
    /// The loaded scene with the command line's `[render]` flags applied (presets unresolved: each
    /// pipeline resolves its own).
    pub scene: Scene,
    pub pipeline: Pipeline,
    pub script: Script,
    /// Stop after this many frames (default: when the window closes).
    pub frames: Option<u32>,
    /// Write the last presented frame here (PNG).
    pub screenshot: Option<PathBuf>,
    /// Write frames.csv (and overlay.txt, the overlay's text per frame) here.
    pub out: Option<PathBuf>,
    pub overlay: bool,
}

/// Open the window and draw until it closes or `frames` frames are presented.
pub fn run(opts: ViewOptions) -> Result<()> {
    if cfg!(all(unix, not(target_os = "macos")))
        && std::env::var_os("DISPLAY").is_none()
        && std::env::var_os("WAYLAND_DISPLAY").is_none()
    {
        bail!(
            "{}",
            no_display("neither DISPLAY nor WAYLAND_DISPLAY is set")
        );
    }
    let event_loop = EventLoop::new().map_err(|e| anyhow::anyhow!(no_display(&e.to_string())))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    if let Some(dir) = &opts.out {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut app = App::new(opts);
    event_loop
        .run_app(&mut app)
        .context("the window's event loop")?;
    if let Some(e) = app.failure.take() {
        return Err(e);
    }
    app.finish()
}

fn no_display(why: &str) -> String {
    format!(
        "vxgi view needs a display to open its window ({why}). Without one, run it under a virtual \
         X server: `xvfb-run -a vxgi view ... --frames N --screenshot FILE.png`; or write the frames \
         to disk with `vxgi render`"
    )
}

struct App {
    opts: ViewOptions,
    controls: Controls,
    /// The last controls a frame drew without error (a failing change is undone to these).
    good: Option<Controls>,
    gfx: Option<Gfx>,
    frame: u32,
    rows: Vec<FrameRow>,
    /// The overlay's text of each frame (`overlay.txt`).
    overlay_log: Vec<String>,
    last: Option<Shot>,
    message: Option<String>,
    failure: Option<anyhow::Error>,
    drag: Option<(MouseButton, (f64, f64))>,
    cursor: (f64, f64),
    pending_size: Option<(u32, u32)>,
    exiting: bool,
}

/// What the overlay reports of a frame.
struct Shot {
    row: FrameRow,
    pipeline: Pipeline,
    stages: Vec<(&'static str, f64)>,
    skipped: Vec<&'static str>,
    chain_bytes: Option<u64>,
    memory: Option<VolumeMemory>,
    scene_line: String,
}

struct Gfx {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    /// Frames copy the surface texture for the screenshot (else an offscreen target of the same
    /// format).
    copyable: bool,
    ctx: &'static GpuContext,
    residents: Vec<Resident<'static>>,
    display: Display,
    egui: egui::Context,
    overlay: egui_wgpu::Renderer,
}

impl App {
    fn new(opts: ViewOptions) -> Self {
        let controls = Controls {
            pipeline: opts.pipeline,
            shown: Shown::Combined,
            camera: opts.scene.camera.clone(),
            cones: None,
            voxels: None,
            light: Vec3::ZERO,
            playing: false,
            time: 0,
            overlay: opts.overlay,
        };
        Self {
            opts,
            controls,
            good: None,
            gfx: None,
            frame: 0,
            rows: Vec::new(),
            overlay_log: Vec::new(),
            last: None,
            message: None,
            failure: None,
            drag: None,
            cursor: (0.0, 0.0),
            pending_size: None,
            exiting: false,
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.failure.is_none() {
            self.failure = Some(e);
        }
        self.exiting = true;
        event_loop.exit();
    }

    /// After the window closed: frames.csv, overlay.txt and the summary line.
    fn finish(&self) -> Result<()> {
        if let Some(dir) = &self.opts.out {
            let csv = dir.join("frames.csv");
            std::fs::write(&csv, crate::frames::csv(&self.rows))
                .with_context(|| format!("writing {}", csv.display()))?;
            let log = dir.join("overlay.txt");
            std::fs::write(&log, self.overlay_log.join("\n"))
                .with_context(|| format!("writing {}", log.display()))?;
        }
        if !self.rows.is_empty() {
            println!("{}", crate::frames::summary(&self.rows));
        }
        Ok(())
    }

    fn create(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let cam = &self.opts.scene.camera;
        let attrs = Window::default_attributes()
            .with_title(format!("vxgi view: {}", self.controls.pipeline.name()))
            .with_inner_size(PhysicalSize::new(cam.width, cam.height));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(|e| anyhow::anyhow!(no_display(&e.to_string())))?,
        );
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(window.clone())),
        );
        let surface = instance
            .create_surface(window.clone())
            .context("creating the window's surface")?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .context("no GPU adapter presents to this window (is a Vulkan driver installed? `.ci/ensure-gpu`)")?;
        let ctx: &'static GpuContext = Box::leak(Box::new(
            GpuContext::for_adapter(&adapter).context("creating the GPU context")?,
        ));
        eprintln!("adapter: {}", ctx.describe());
        let caps = surface.get_capabilities(&adapter);
        // A UNORM format stores the display pass's own sRGB encoding (and egui draws in it as it
        // prefers); an sRGB one encodes in hardware.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| {
                matches!(
                    f,
                    wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm
                )
            })
            .or_else(|| caps.formats.first().copied())
            .context("the surface offers no format")?;
        let copyable = caps.usages.contains(wgpu::TextureUsages::COPY_SRC);
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .context("the surface does not work with this adapter")?;
        config.format = format;
        if copyable {
            config.usage |= wgpu::TextureUsages::COPY_SRC;
        }
        surface.configure(&ctx.device, &config);
        if self.opts.screenshot.is_some() {
            println!(
                "screenshot: {}",
                if copyable {
                    "copied from the presented surface texture"
                } else {
                    "this surface cannot be copied from: an offscreen target of the same format, drawn by the same passes"
                }
            );
        }
        let display = Display::new(&ctx.device, format);
        let overlay =
            egui_wgpu::Renderer::new(&ctx.device, format, egui_wgpu::RendererOptions::default());
        self.gfx = Some(Gfx {
            window,
            surface,
            config,
            copyable,
            ctx,
            residents: Vec::new(),
            display,
            egui: egui::Context::default(),
            overlay,
        });
        Ok(())
    }

    fn key(&mut self, code: KeyCode) -> Option<Action> {
        let c = &self.controls;
        let step = (Vec3::from(c.camera.target) - Vec3::from(c.camera.eye)).length() * 0.05;
        let render = &self.opts.scene.render;
        Some(match code {
            KeyCode::KeyW => Action::Fly(Vec3::X * step),
            KeyCode::KeyS => Action::Fly(-Vec3::X * step),
            KeyCode::KeyD => Action::Fly(Vec3::Y * step),
            KeyCode::KeyA => Action::Fly(-Vec3::Y * step),
            KeyCode::KeyE => Action::Fly(Vec3::Z * step),
            KeyCode::KeyQ => Action::Fly(-Vec3::Z * step),
            KeyCode::Digit1 => Action::Pipeline(Pipeline::VctDense),
            KeyCode::Digit2 => Action::Pipeline(Pipeline::VctSvo),
            KeyCode::Digit3 => Action::Pipeline(Pipeline::Lrsm),
            KeyCode::Digit4 => Action::Pipeline(Pipeline::Cprc),
            KeyCode::Tab => {
                let all = Resident::PIPELINES;
                let k = all.iter().position(|p| *p == c.pipeline).unwrap_or(0);
                Action::Pipeline(all[(k + 1) % all.len()])
            }
            KeyCode::KeyV => Action::Show(c.shown.next()),
            KeyCode::BracketLeft => Action::Cones(c.cones.unwrap_or(render.cones).max(2) - 1),
            KeyCode::BracketRight => Action::Cones((c.cones.unwrap_or(render.cones) + 1).min(64)),
            KeyCode::Minus => Action::Voxels((c.voxels.unwrap_or(render.voxels) / 2).max(8)),
            KeyCode::Equal => Action::Voxels((c.voxels.unwrap_or(render.voxels) * 2).min(512)),
            KeyCode::ArrowLeft => Action::Light(-Vec3::X * step),
            KeyCode::ArrowRight => Action::Light(Vec3::X * step),
            KeyCode::ArrowUp => Action::Light(-Vec3::Z * step),
            KeyCode::ArrowDown => Action::Light(Vec3::Z * step),
            KeyCode::PageUp => Action::Light(Vec3::Y * step),
            KeyCode::PageDown => Action::Light(-Vec3::Y * step),
            KeyCode::KeyP | KeyCode::Space => Action::Play(!c.playing),
            KeyCode::KeyH => Action::Overlay(!c.overlay),
            _ => return None,
        })
    }

    fn act(&mut self, a: &Action) {
        if let (Action::Resize(w, h), Some(g)) = (a, &self.gfx) {
            let _ = g.window.request_inner_size(PhysicalSize::new(*w, *h));
            // The frame follows the surface: where the window system grants the size at once the
            // next frame has it.
            self.pending_size = Some((*w, *h));
        }
        self.controls.apply(a, &self.opts.scene);
    }

    /// One frame: the script's steps for it, the scene, the pipeline's frame and the display and
    /// overlay passes into the surface texture, presented; counted as `vxgi render` counts its.
    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let k = self.frame;
        let steps: Vec<Action> = self.opts.script.at(k).cloned().collect();
        for a in &steps {
            self.act(a);
        }
        if let Some((w, h)) = self.pending_size.take() {
            let g = self.gfx.as_mut().expect("created");
            g.config.width = w;
            g.config.height = h;
            g.surface.configure(&g.ctx.device, &g.config);
        }
        let shoot = self.opts.screenshot.is_some() && self.opts.frames == Some(k + 1);
        let overlay = self.overlay_text();
        match self.draw(k, shoot, overlay.as_deref()) {
            Ok(Some((shot, image))) => {
                self.good = Some(self.controls.clone());
                self.overlay_log
                    .push(format!("frame {k}:\n{}", overlay.unwrap_or_default()));
                self.rows.push(shot.row.clone());
                self.last = Some(shot);
                if let (Some(path), Some(img)) = (&self.opts.screenshot, image) {
                    img.save_with_format(path, image::ImageFormat::Png)
                        .with_context(|| format!("writing {}", path.display()))?;
                    println!("wrote {}", path.display());
                }
                self.frame += 1;
                if self.controls.playing {
                    self.controls.time += 1;
                }
                if self.opts.frames.is_some_and(|n| self.frame >= n) {
                    self.exiting = true;
                    event_loop.exit();
                }
            }
            // No surface texture this time (occluded, timeout): the next redraw tries again.
            Ok(None) => {}
            Err(e) => match self.good.clone() {
                // A change that cannot be drawn (e.g. voxels past the device's limits) is undone.
                Some(good) if steps.is_empty() || self.opts.frames.is_none() => {
                    let why = format!("{e:#}");
                    eprintln!("frame {k}: {why}; the last change is undone");
                    self.message = Some(why);
                    self.controls = good;
                }
                _ => return Err(e.context(format!("frame {k}"))),
            },
        }
        Ok(())
    }

    /// The overlay's text, from the last frame's counters (None when hidden).
    fn overlay_text(&self) -> Option<String> {
        if !self.controls.overlay {
            return None;
        }
        let mut lines = vec![format!(
            "{}  {}  (1-4/Tab pipeline, V view, [ ] cones, -/= voxels, arrows light, P play, H hide)",
            self.controls.pipeline.name(),
            self.controls.shown.name()
        )];
        match &self.last {
            None => lines.push("first frame: building".into()),
            Some(s) => {
                let c = &s.row.counters;
                lines.push(format!(
                    "frame {}: {:.1} fps, wall {:.1} ms, GPU {:.1} ms, {} submission{}, {} buffers created, {} bytes up, {} bytes read back",
                    s.row.frame,
                    1e3 / s.row.wall_ms.max(1e-3),
                    s.row.wall_ms,
                    s.row.gpu_ms(),
                    c.submissions,
                    if c.submissions == 1 { "" } else { "s" },
                    c.buffers_created,
                    c.upload_bytes,
                    c.readback_bytes
                ));
                lines.push(format!(
                    "{} (GPU-resident), {}",
                    s.pipeline.name(),
                    s.scene_line
                ));
                for (name, secs) in &s.stages {
                    lines.push(format!("  {name:<24} {:8.2} ms", secs * 1e3));
                }
                let mut memory = Vec::new();
                if let Some(b) = s.chain_bytes {
                    memory.push(format!("{:.1} MB on the GPU", b as f64 / 1e6));
                }
                match &s.memory {
                    Some(VolumeMemory::Octree(m)) => {
                        memory.push(format!("octree {:.1} MB", m.bytes as f64 / 1e6))
                    }
                    Some(VolumeMemory::Lrsm(m)) => memory.push(m.light_text()),
                    Some(VolumeMemory::Caches(c)) => {
                        memory.push(format!("{} radiance caches", c.caches))
                    }
                    None => {}
                }
                if !memory.is_empty() {
                    lines.push(format!("memory: {}", memory.join(", ")));
                }
                if !s.skipped.is_empty() {
                    lines.push(format!("skipped by the plan: {}", s.skipped.join(", ")));
                }
            }
        }
        if let Some(m) = &self.message {
            lines.push(format!("undone: {m}"));
        }
        Some(lines.join("\n"))
    }

    /// The frame into the surface: `Some` once presented (with the screenshot's pixels where
    /// `shoot`), `None` where the surface gave no texture.
    fn draw(
        &mut self,
        k: u32,
        shoot: bool,
        overlay: Option<&str>,
    ) -> Result<Option<(Shot, Option<image::RgbImage>)>> {
        let g = self.gfx.as_mut().expect("created");
        let ctx = g.ctx;
        let size = (g.config.width, g.config.height);
        let controls = self.controls.clone();
        let base = &self.opts.scene;
        let mut presented = None;
        let ((), row) = crate::frames::counted(ctx, k, || {
            let (scene, scale) = controls.scene(base, size)?;
            let cones = ConeSettings::from(&scene.render);
            let texture = match g.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(t)
                | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
                wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                    return Ok(())
                }
                other => {
                    // Outdated or lost: configure again and skip this frame.
                    g.surface.configure(&ctx.device, &g.config);
                    if matches!(other, wgpu::CurrentSurfaceTexture::Validation) {
                        bail!("the surface texture failed validation");
                    }
                    return Ok(());
                }
            };
            let target = texture
                .texture
                .create_view(&wgpu::TextureViewDescriptor::default());
            let params = DisplayParams {
                size: [size.0, size.1],
                shown: controls.shown as u32,
                encode: u32::from(!g.config.format.is_srgb()),
                scale,
                pad: [0.0; 3],
            };
            let paint = overlay.map(|text| paint_overlay(&g.egui, &mut g.overlay, ctx, text, size));
            let shot_buffer = shoot.then(|| Readback::new(&ctx.device, size, g.config.format));
            let offscreen = (shoot && !g.copyable).then(|| {
                ctx.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("screenshot"),
                    size: wgpu::Extent3d {
                        width: size.0,
                        height: size.1,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: g.config.format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                })
            });
            let (display, overlay_renderer) = (&mut g.display, &mut g.overlay);
            let mut passes =
                |encoder: &mut wgpu::CommandEncoder, fb: &FrameBuffers| -> Result<()> {
                    let mut targets = vec![(target.clone(), &texture.texture)];
                    if let Some(t) = &offscreen {
                        targets.push((t.create_view(&Default::default()), t));
                    }
                    for (view, _) in &targets {
                        display.encode(ctx, encoder, fb, view, &params);
                        if let Some(p) = &paint {
                            p.encode(ctx, overlay_renderer, encoder, view);
                        }
                    }
                    if let Some(rb) = &shot_buffer {
                        rb.copy(encoder, targets.last().expect("the surface").1);
                    }
                    Ok(())
                };
            let (stages, skipped, chain_bytes, memory) = {
                let r = match g
                    .residents
                    .iter()
                    .position(|r| r.pipeline() == controls.pipeline)
                {
                    Some(i) => &mut g.residents[i],
                    None => {
                        g.residents.push(Resident::new(ctx, controls.pipeline)?);
                        g.residents.last_mut().expect("pushed")
                    }
                };
                let report = r.present(&scene, &cones, &mut passes)?;
                (
                    report.stages,
                    report.plan.skipped(),
                    r.gpu_bytes(),
                    r.memory(),
                )
            };
            if let Some(p) = paint {
                p.finish(&mut g.overlay);
            }
            let image = match &shot_buffer {
                Some(rb) => Some(rb.read(ctx)?),
                None => None,
            };
            ctx.queue.present(texture);
            presented = Some((
                stages,
                skipped,
                chain_bytes,
                memory,
                scene_line(&scene),
                image,
            ));
            Ok(())
        })?;
        Ok(presented.map(
            |(stages, skipped, chain_bytes, memory, scene_line, image)| {
                (
                    Shot {
                        row,
                        pipeline: controls.pipeline,
                        stages,
                        skipped,
                        chain_bytes,
                        memory,
                        scene_line,
                    },
                    image,
                )
            },
        ))
    }
}

fn scene_line(s: &Scene) -> String {
    format!(
        "{}x{}, {}^3 voxels, {} cones",
        s.camera.width, s.camera.height, s.render.voxels, s.render.cones
    )
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gfx.is_none() {
            if let Err(e) = self.create(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        if self.exiting {
            return;
        }
        let scripted = self.opts.frames.is_some();
        match event {
            WindowEvent::CloseRequested => {
                self.exiting = true;
                event_loop.exit();
            }
            WindowEvent::Resized(s) if s.width > 0 && s.height > 0 => {
                self.pending_size = Some((s.width, s.height));
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            // A scripted run (--frames) is its script's alone: stray input does not change it.
            _ if scripted => {}
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                match event.physical_key {
                    PhysicalKey::Code(KeyCode::Escape) => {
                        self.exiting = true;
                        event_loop.exit();
                    }
                    PhysicalKey::Code(code) => {
                        if let Some(a) = self.key(code) {
                            self.act(&a);
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                self.drag = (state == ElementState::Pressed).then_some((button, self.cursor));
            }
            WindowEvent::CursorMoved { position, .. } => {
                self.cursor = (position.x, position.y);
                if let (Some((button, from)), Some(g)) = (self.drag, &self.gfx) {
                    let (dx, dy) = (position.x - from.0, position.y - from.1);
                    let h = g.config.height.max(1) as f64;
                    let a = match button {
                        MouseButton::Left => Action::Orbit(-0.3 * dx as f32, -0.3 * dy as f32),
                        _ => Action::Pan((-dx / h) as f32, (dy / h) as f32),
                    };
                    self.drag = Some((button, self.cursor));
                    self.act(&a);
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.act(&Action::Zoom(0.9f32.powf(lines)));
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let (false, Some(g)) = (self.exiting, &self.gfx) {
            g.window.request_redraw();
        }
    }
}

/// The display pass's uniform (`Params` in view.wgsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayParams {
    size: [u32; 2],
    shown: u32,
    encode: u32,
    scale: f32,
    pad: [f32; 3],
}

/// The display pass: its render pipeline and uniform, made once; its bind group made again only
/// when the frame's image buffers change (a rebuilt chain).
struct Display {
    pipeline: wgpu::RenderPipeline,
    params: wgpu::Buffer,
    bound: Option<([wgpu::Buffer; 3], wgpu::BindGroup)>,
}

impl Display {
    fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("view display"),
            source: wgpu::ShaderSource::Wgsl(include_str!("view.wgsl").into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("view display"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(format.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("view params"),
            size: std::mem::size_of::<DisplayParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            params,
            bound: None,
        }
    }

    fn encode(
        &mut self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        fb: &FrameBuffers,
        target: &wgpu::TextureView,
        params: &DisplayParams,
    ) {
        ctx.queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        let buffers = [fb.direct.clone(), fb.indirect.clone(), fb.ao.clone()];
        if self.bound.as_ref().is_none_or(|(b, _)| *b != buffers) {
            fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
                wgpu::BindGroupEntry {
                    binding,
                    resource: buffer.as_entire_binding(),
                }
            }
            let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("view display"),
                layout: &self.pipeline.get_bind_group_layout(0),
                entries: &[
                    entry(0, &self.params),
                    entry(1, &buffers[0]),
                    entry(2, &buffers[1]),
                    entry(3, &buffers[2]),
                ],
            });
            self.bound = Some((buffers, group));
        }
        let group = &self.bound.as_ref().expect("bound above").1;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view display"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// The overlay's shapes for one frame, tessellated, its new textures already uploaded; the
/// textures egui no longer needs are freed once the frame's passes are recorded (`finish`).
struct OverlayPaint {
    jobs: Vec<egui::ClippedPrimitive>,
    free: Vec<egui::TextureId>,
    screen: egui_wgpu::ScreenDescriptor,
}

fn paint_overlay(
    egui: &egui::Context,
    renderer: &mut egui_wgpu::Renderer,
    ctx: &GpuContext,
    text: &str,
    size: (u32, u32),
) -> OverlayPaint {
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(size.0 as f32, size.1 as f32),
        )),
        ..Default::default()
    };
    let mut out = egui.run_pass(input, |ctx| {
        egui::Area::new(egui::Id::unique("vxgi overlay"))
            .fixed_pos(egui::pos2(6.0, 6.0))
            .show(ctx, |ui| {
                egui::Frame::new()
                    .fill(egui::Color32::from_black_alpha(170))
                    .inner_margin(4.0)
                    .show(ui, |ui| {
                        ui.label(
                            egui::RichText::new(text)
                                .monospace()
                                .size(10.0)
                                .color(egui::Color32::WHITE),
                        );
                    });
            });
    });
    // egui hands each texture change out once: applied here, once per frame, whatever number
    // of targets the frame draws into.
    for (id, deltas) in std::mem::take(&mut out.textures_delta.set) {
        for delta in &deltas {
            renderer.update_texture(&ctx.device, &ctx.queue, id, delta);
        }
    }
    OverlayPaint {
        jobs: egui.tessellate(out.shapes, out.pixels_per_point),
        free: std::mem::take(&mut out.textures_delta.free)
            .into_iter()
            .collect(),
        screen: egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: out.pixels_per_point,
        },
    }
}

impl OverlayPaint {
    fn encode(
        &self,
        ctx: &GpuContext,
        renderer: &mut egui_wgpu::Renderer,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
    ) {
        let extra =
            renderer.update_buffers(&ctx.device, &ctx.queue, encoder, &self.jobs, &self.screen);
        debug_assert!(extra.is_empty(), "no paint callbacks");
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view overlay"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        renderer.render(&mut pass.forget_lifetime(), &self.jobs, &self.screen);
    }

    /// Free what egui retired this frame (wgpu keeps a texture alive while recorded work uses it).
    fn finish(self, renderer: &mut egui_wgpu::Renderer) {
        for id in &self.free {
            renderer.free_texture(id);
        }
    }
}

/// A texture's pixels copied into a mappable buffer (rows padded to wgpu's 256-byte alignment).
struct Readback {
    buffer: wgpu::Buffer,
    size: (u32, u32),
    row: u32,
    format: wgpu::TextureFormat,
}

impl Readback {
    fn new(device: &wgpu::Device, size: (u32, u32), format: wgpu::TextureFormat) -> Self {
        let row = (size.0 * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("screenshot"),
            size: row as u64 * size.1 as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            size,
            row,
            format,
        }
    }

    fn copy(&self, encoder: &mut wgpu::CommandEncoder, texture: &wgpu::Texture) {
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &self.buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.row),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width: self.size.0,
                height: self.size.1,
                depth_or_array_layers: 1,
            },
        );
    }

    /// The pixels as 8-bit sRGB (the surface stores sRGB-encoded values in either format family).
    fn read(&self, ctx: &GpuContext) -> Result<image::RgbImage> {
        let slice = self.buffer.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        ctx.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| anyhow::anyhow!("waiting for the screenshot: {e}"))?;
        let data = slice
            .get_mapped_range()
            .map_err(|e| anyhow::anyhow!("mapping the screenshot: {e}"))?;
        let bgra = matches!(
            self.format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        );
        let (w, h) = self.size;
        let mut rgb = Vec::with_capacity((w * h * 3) as usize);
        for y in 0..h {
            let row = &data[(y * self.row) as usize..][..(w * 4) as usize];
            for p in row.chunks_exact(4) {
                if bgra {
                    rgb.extend_from_slice(&[p[2], p[1], p[0]]);
                } else {
                    rgb.extend_from_slice(&p[..3]);
                }
            }
        }
        drop(data);
        self.buffer.unmap();
        image::RgbImage::from_raw(w, h, rgb).context("screenshot size")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scripts_parse_every_action_and_refuse_bad_steps() {
        let s = Script::parse(
            "0 orbit 10\n1 orbit -5 3; 2 pan 0.1 -0.2 # a comment\n3 zoom 0.5; 3 fly 1 0 0\n\
             4 pipeline lrsm; 5 view ao; 6 cones 9; 7 voxels 32; 8 light 0.1 0 -0.1\n\
             9 resize 64 48; 10 play; 11 pause; 12 overlay off",
        )
        .unwrap();
        assert_eq!(s.steps.len(), 14);
        assert_eq!(s.steps[0], (0, Action::Orbit(10.0, 0.0)));
        assert_eq!(s.steps[5], (4, Action::Pipeline(Pipeline::Lrsm)));
        assert_eq!(s.steps[10], (9, Action::Resize(64, 48)));
        assert_eq!(s.at(3).count(), 2);
        for bad in [
            "orbit 10",
            "1",
            "1 orbit",
            "1 orbit x",
            "1 orbit inf",
            "1 zoom 0",
            "1 pipeline vct",
            "1 view everything",
            "1 cones -1",
            "1 cones 0",
            "1 voxels 3",
            "1 resize 0 10",
            "1 play now",
            "1 overlay maybe",
            "1 jump",
        ] {
            let e = Script::parse(bad).unwrap_err().to_string();
            assert!(e.contains(&format!("`{bad}`")), "{bad}: {e}");
        }
    }

    #[test]
    fn a_yaw_orbit_is_the_render_commands_orbit() {
        let scene = Scene::cornell_box();
        let mut c = scene.camera.clone();
        orbit(&mut c, 10.0, 0.0);
        assert_eq!(c.eye, scene.orbited(10.0).camera.eye);
    }

    #[test]
    fn camera_moves_keep_what_they_should() {
        let start = Scene::cornell_box().camera;
        let dist = |c: &CameraDesc| (Vec3::from(c.eye) - Vec3::from(c.target)).length();
        let mut c = start.clone();
        orbit(&mut c, 30.0, 20.0);
        assert!((dist(&c) - dist(&start)).abs() < 1e-4 * dist(&start));
        assert_eq!(c.target, start.target);
        // Pitch stops short of the up axis instead of flipping over it.
        let mut top = start.clone();
        for _ in 0..20 {
            orbit(&mut top, 0.0, 10.0);
        }
        let (_, r, _) = basis(&top);
        assert!(r.is_finite());
        let mut z = start.clone();
        apply_camera(&mut z, &Action::Zoom(0.5));
        assert!((dist(&z) - 0.5 * dist(&start)).abs() < 1e-4);
        let mut p = start.clone();
        apply_camera(&mut p, &Action::Pan(0.25, 0.0));
        let moved = Vec3::from(p.eye) - Vec3::from(start.eye);
        assert!((Vec3::from(p.target) - Vec3::from(start.target) - moved).length() < 1e-5);
        assert!(moved.length() > 0.0);
    }

    #[test]
    fn controls_change_the_frames_scene() {
        let base = Scene::cornell_box();
        let mut c = Controls {
            pipeline: Pipeline::VctDense,
            shown: Shown::Combined,
            camera: base.camera.clone(),
            cones: None,
            voxels: None,
            light: Vec3::ZERO,
            playing: false,
            time: 0,
            overlay: true,
        };
        let (s, scale) = c.scene(&base, (64, 48)).unwrap();
        assert_eq!((s.camera.width, s.camera.height), (64, 48));
        assert_eq!(scale, 1.0);
        c.apply(&Action::Cones(9), &base);
        c.apply(&Action::Voxels(32), &base);
        c.apply(&Action::Light(Vec3::new(0.1, 0.0, 0.0)), &base);
        let (s, _) = c.scene(&base, (64, 48)).unwrap();
        assert_eq!((s.render.cones, s.render.voxels), (9, 32));
        let mut l = base.lights[0].clone();
        move_light(&mut l, Vec3::new(0.1, 0.0, 0.0));
        assert_eq!(s.lights[0], l);
        // A change that cannot be drawn is refused by the scene, not drawn.
        c.apply(&Action::Voxels(3), &base);
        assert!(c.scene(&base, (64, 48)).is_err());
    }
}
