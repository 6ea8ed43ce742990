//! The interactive viewer (`demo --window`): a winit window, a swapchain, an orbit camera, and
//! keys to switch technique and shading rate; per-pass GPU times in the title.
//!
//! Controls: left mouse drag orbits, wheel zooms, `T`/`Tab` cycles techniques, `V` toggles
//! per-vertex/per-pixel shading, `B` steps the glossy materials' BRDF (the scene's own, diffuse, Blinn-Phong
//! s = 1000, anisotropic Ashikhmin-Shirley, anisotropic Lafortune, three Lafortune lobes, Cook-Torrance GGX: [`scenes::BRDF_PRESETS`]), `P`/space pause and
//! `.`/`,` step the animation, `+`/`-` change exposure, `R` resets the camera, `Esc`/`Q` quits.
//! The scene renders at the requested resolution and is scaled to the window.

use anyhow::{Context, Result};
use engine::gpu::{Gpu, PassTiming, Swapchain};
use engine::passes::shade::{describe_technique, TECHNIQUES};
use engine::renderer::Renderer;
use engine::scene::Camera;
use glam::Vec3;
use std::io::Write;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::{PhysicalPosition, PhysicalSize};
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

/// What the viewer needs besides the renderer.
pub struct ViewerOptions {
    /// Quit after this many presented frames (0: run until closed). With a limit, every
    /// presented frame is announced on stdout as `presented frame N` (for tests and scripts).
    pub exit_after: u64,
    /// Motion to apply every frame from the viewer's clock (`--animate`).
    pub animation: Option<scenes::Animation>,
    /// The `B` key's BRDF cycle over the scene's glossy materials ([`scenes::BrdfCycle::new`] of the scene
    /// the renderer was built from).
    pub brdf: scenes::BrdfCycle,
    /// `--env-spin`: degrees per second of the viewer's clock the environment turns (rebuilt every frame).
    pub env_spin: Option<f32>,
}

/// The event loop of a display, and the instance extensions its windows need. Create it before
/// the [`Gpu`] (whose instance must enable those extensions).
pub fn event_loop() -> Result<(EventLoop<()>, Vec<&'static std::ffi::CStr>)> {
    let event_loop = EventLoop::new().context(
        "cannot open a window: no display (set DISPLAY or WAYLAND_DISPLAY, or run headless without --window)",
    )?;
    let display = event_loop.display_handle().context("display handle")?.as_raw();
    let extensions = engine::gpu::surface_extensions(display)?;
    Ok((event_loop, extensions))
}

/// Run the viewer until the window closes (or `exit_after` frames), then release the window's
/// Vulkan objects. The caller destroys the renderer and shuts the GPU down.
pub fn run(event_loop: EventLoop<()>, gpu: &Gpu, renderer: &mut Renderer, options: ViewerOptions) -> Result<()> {
    let home = OrbitCamera::from_camera(renderer.camera());
    let mut app = App {
        gpu,
        renderer,
        options,
        window: None,
        swapchain: None,
        error: None,
        orbit: home,
        home,
        dragging: false,
        orbit_moved: false,
        cursor: None,
        presented: 0,
        smoothed: Vec::new(),
        last_title: Instant::now() - Duration::from_secs(1),
        fps_window: (Instant::now(), 0),
        fps: 0.0,
        clock: AnimationClock::new(Instant::now()),
    };
    event_loop.set_control_flow(ControlFlow::Poll);
    let ran = event_loop.run_app(&mut app).context("event loop");
    if let Some(s) = app.swapchain.take() {
        s.destroy(gpu);
    }
    drop(app.window.take());
    ran?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Camera orbiting a target: yaw around +Y, pitch above the horizon, distance.
#[derive(Clone, Copy, Debug)]
struct OrbitCamera {
    target: Vec3,
    yaw: f32,
    pitch: f32,
    distance: f32,
    fov_y_degrees: f32,
}

impl OrbitCamera {
    fn from_camera(c: Camera) -> Self {
        let d = c.eye - c.target;
        let distance = d.length().max(1e-3);
        let dir = d / distance;
        Self {
            target: c.target,
            yaw: dir.z.atan2(dir.x),
            pitch: dir.y.clamp(-1.0, 1.0).asin(),
            distance,
            fov_y_degrees: c.fov_y_degrees,
        }
    }

    fn camera(&self) -> Camera {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        let dir = Vec3::new(cp * cy, sp, cp * sy);
        Camera { eye: self.target + dir * self.distance, target: self.target, fov_y_degrees: self.fov_y_degrees }
    }

    fn rotate(&mut self, dx: f32, dy: f32) {
        const LIMIT: f32 = 1.55; // just short of the poles, where the view basis degenerates
        self.yaw += dx * 0.01;
        self.pitch = (self.pitch + dy * 0.01).clamp(-LIMIT, LIMIT);
    }

    fn zoom(&mut self, steps: f32) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(1e-3, 1e6);
    }
}

struct App<'a> {
    gpu: &'a Gpu,
    renderer: &'a mut Renderer,
    options: ViewerOptions,
    window: Option<Window>,
    swapchain: Option<Swapchain>,
    error: Option<anyhow::Error>,
    orbit: OrbitCamera,
    home: OrbitCamera,
    dragging: bool,
    orbit_moved: bool,
    cursor: Option<PhysicalPosition<f64>>,
    presented: u64,
    /// Exponential moving average of each pass's GPU time.
    smoothed: Vec<(String, f64)>,
    last_title: Instant,
    fps_window: (Instant, u32),
    fps: f64,
    clock: AnimationClock,
}

impl App<'_> {
    fn open(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let s = &self.renderer.settings;
        let attrs = Window::default_attributes()
            .with_title("soft shadows")
            .with_inner_size(PhysicalSize::new(s.width, s.height))
            .with_position(PhysicalPosition::new(0, 0));
        let window = el.create_window(attrs).context("creating the window")?;
        let size = window.inner_size();
        let display = window.display_handle().context("display handle")?.as_raw();
        let handle = window.window_handle().context("window handle")?.as_raw();
        // SAFETY: the window is kept in `self.window` and dropped only after the swapchain is destroyed.
        let swapchain = unsafe { Swapchain::new(self.gpu, display, handle, [size.width, size.height]) }?;
        self.window = Some(window);
        self.swapchain = Some(swapchain);
        eprintln!(
            "viewer: drag to orbit, wheel to zoom, T technique ({}), V per-vertex/per-pixel, B BRDF, E rotate the environment, +/- exposure, R reset, Esc quit",
            TECHNIQUES.iter().map(|t| t.name).collect::<Vec<_>>().join("/")
        );
        Ok(())
    }

    fn redraw(&mut self, el: &ActiveEventLoop) -> Result<()> {
        let (Some(window), Some(swapchain)) = (self.window.as_ref(), self.swapchain.as_mut()) else { return Ok(()) };
        if swapchain.is_stale() {
            let size = window.inner_size();
            swapchain.recreate(self.gpu, [size.width, size.height])?;
        }
        let Some(image) = swapchain.acquire(self.gpu)? else { return Ok(()) };
        if self.orbit_moved {
            // Only once the user moved it: the scene's own camera is kept bit-exact until then.
            self.renderer.set_camera(self.orbit.camera());
        }
        if let Some(a) = &self.options.animation {
            a.apply(self.renderer, self.clock.time(Instant::now()))?;
        }
        if let Some(spin) = self.options.env_spin {
            scenes::spin_environment(self.gpu, self.renderer, spin, self.clock.time(Instant::now()))?;
        }
        let timings = self.renderer.render_presenting(self.gpu, &image)?;
        window.pre_present_notify();
        swapchain.present(self.gpu, image)?;
        self.presented += 1;
        self.account(&timings);
        if self.options.exit_after > 0 {
            println!("presented frame {}", self.presented);
            let _ = std::io::stdout().flush();
            if self.presented >= self.options.exit_after {
                el.exit();
            }
        }
        Ok(())
    }

    fn account(&mut self, timings: &[PassTiming]) {
        for t in timings {
            match self.smoothed.iter_mut().find(|(n, _)| *n == t.name) {
                Some((_, v)) => *v += 0.1 * (t.ms - *v),
                None => self.smoothed.push((t.name.clone(), t.ms)),
            }
        }
        self.fps_window.1 += 1;
        let dt = self.fps_window.0.elapsed().as_secs_f64();
        if dt >= 0.5 {
            self.fps = self.fps_window.1 as f64 / dt;
            self.fps_window = (Instant::now(), 0);
        }
        if self.last_title.elapsed() >= Duration::from_millis(250) {
            self.last_title = Instant::now();
            let s = &self.renderer.settings;
            let passes: Vec<String> = self.smoothed.iter().map(|(n, ms)| format!("{n} {ms:.2}")).collect();
            let title = format!(
                "{} | {} | {}x{} | {} ms | {:.1} fps",
                self.renderer.technique_name(),
                if s.per_vertex { "per vertex" } else { "per pixel" },
                s.width,
                s.height,
                passes.join(", "),
                self.fps
            );
            if let Some(w) = &self.window {
                w.set_title(&title);
            }
        }
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) -> Result<()> {
        match key {
            Key::Named(NamedKey::Escape) => el.exit(),
            Key::Named(NamedKey::Tab) => self.next_technique()?,
            Key::Character(c) => match c.as_str() {
                "q" | "Q" => el.exit(),
                "t" | "T" => self.next_technique()?,
                "b" | "B" => {
                    let materials = self.options.brdf.step()?;
                    self.renderer.set_materials(self.gpu, &materials)?;
                    eprintln!("viewer: BRDF {}", self.options.brdf.label());
                }
                "v" | "V" => {
                    let s = &mut self.renderer.settings;
                    s.per_vertex = !s.per_vertex;
                    eprintln!("viewer: {}", if s.per_vertex { "per-vertex shading" } else { "per-pixel shading" });
                    self.smoothed.clear();
                }
                "e" | "E" => {
                    let degrees = (self.renderer.environment_rotation() + ENV_STEP_DEGREES).rem_euclid(360.0);
                    let start = Instant::now();
                    self.renderer.set_environment_rotation(self.gpu, degrees)?;
                    eprintln!(
                        "viewer: environment turned to {degrees:.0}° from where the scene (and --env-rotation) put it (prepared in {:.0} ms)",
                        start.elapsed().as_secs_f64() * 1e3
                    );
                    self.smoothed.clear();
                }
                "r" | "R" => {
                    self.orbit = self.home;
                    self.orbit_moved = true;
                }
                "p" | "P" | " " if self.options.animation.is_some() => {
                    let paused = self.clock.toggle(Instant::now());
                    eprintln!("viewer: animation {}", if paused { "paused" } else { "playing" });
                }
                "." | ">" if self.options.animation.is_some() => self.step(STEP_S),
                "," | "<" if self.options.animation.is_some() => self.step(-STEP_S),
                "+" | "=" => self.renderer.settings.exposure *= 1.25,
                "-" | "_" => self.renderer.settings.exposure /= 1.25,
                _ => {}
            },
            _ => {}
        }
        Ok(())
    }

    fn step(&mut self, dt: f32) {
        let t = self.clock.step(Instant::now(), dt);
        eprintln!("viewer: animation paused at t = {t:.3} s");
    }

    fn next_technique(&mut self) -> Result<()> {
        let current = self.renderer.technique_name();
        let i = TECHNIQUES.iter().position(|t| t.name == current).unwrap_or(0);
        let next = TECHNIQUES[(i + 1) % TECHNIQUES.len()].name;
        eprintln!("viewer: technique {} (preparing...)", describe_technique(next)?);
        self.renderer.set_technique(self.gpu, next)?;
        self.smoothed.clear();
        Ok(())
    }

    fn handle(&mut self, el: &ActiveEventLoop, event: WindowEvent) -> Result<()> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(_) => {
                // Recreated lazily before the next frame (sizes come in bursts while dragging).
                if let (Some(w), Some(s)) = (self.window.as_ref(), self.swapchain.as_mut()) {
                    let size = w.inner_size();
                    if size.width > 0 && size.height > 0 && [size.width, size.height] != s.extent() {
                        s.recreate(self.gpu, [size.width, size.height])?;
                    }
                }
            }
            WindowEvent::RedrawRequested => self.redraw(el)?,
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(el, &event.logical_key)?
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.dragging = state == ElementState::Pressed
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some(last)) = (self.dragging, self.cursor) {
                    self.orbit.rotate((position.x - last.x) as f32, (position.y - last.y) as f32);
                    self.orbit_moved = true;
                }
                self.cursor = Some(position);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                self.orbit.zoom(match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                });
                self.orbit_moved = true;
            }
            _ => {}
        }
        Ok(())
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(e) = self.open(el) {
                self.error = Some(e);
                el.exit();
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if self.error.is_some() {
            return;
        }
        if let Err(e) = self.handle(el, event) {
            self.error = Some(e);
            el.exit();
        }
    }

    fn about_to_wait(&mut self, _el: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orbit_camera_round_trips_and_clamps() {
        let c = Camera { eye: Vec3::new(1.0, 2.0, 3.0), target: Vec3::new(0.5, 0.0, -1.0), fov_y_degrees: 40.0 };
        let o = OrbitCamera::from_camera(c);
        let back = o.camera();
        assert!((back.eye - c.eye).length() < 1e-5, "{:?} vs {:?}", back.eye, c.eye);
        let mut o2 = o;
        o2.rotate(0.0, 1e6);
        assert!(o2.pitch < std::f32::consts::FRAC_PI_2);
        let d = o2.distance;
        o2.zoom(1.0);
        assert!((o2.distance - 0.9 * d).abs() < 1e-5);
        assert!(o2.camera().eye.is_finite());
    }
}

/// One step of `,`/`.` in the viewer: a frame at 30 frames per second.
const STEP_S: f32 = 1.0 / 30.0;
/// The E key turns the environment by this much about +y (each turn prepares the environment again).
const ENV_STEP_DEGREES: f32 = 30.0;

/// The viewer's animation time: follows the wall clock while playing; `P`/space pauses and resumes, `.`/`,` step
/// one frame forward/back (and pause). Never negative.
#[derive(Clone, Copy, Debug)]
pub struct AnimationClock {
    /// Wall-clock instant that corresponds to animation time 0 while playing.
    origin: Instant,
    /// `Some(t)`: paused at animation time t.
    paused: Option<f32>,
}

impl AnimationClock {
    pub fn new(now: Instant) -> Self {
        Self { origin: now, paused: None }
    }

    /// The animation time at `now`.
    pub fn time(&self, now: Instant) -> f32 {
        self.paused.unwrap_or_else(|| now.saturating_duration_since(self.origin).as_secs_f32())
    }

    /// Pause or resume at `now`; returns whether it is paused afterwards.
    pub fn toggle(&mut self, now: Instant) -> bool {
        match self.paused.take() {
            Some(t) => {
                self.origin = now.checked_sub(Duration::from_secs_f32(t)).unwrap_or(now);
                false
            }
            None => {
                self.paused = Some(self.time(now));
                true
            }
        }
    }

    /// Pause (if playing) and move by `dt` seconds (not below 0); returns the new time.
    pub fn step(&mut self, now: Instant, dt: f32) -> f32 {
        let t = (self.time(now) + dt).max(0.0);
        self.paused = Some(t);
        t
    }
}

#[cfg(test)]
mod clock_tests {
    use super::*;

    #[test]
    fn the_animation_clock_pauses_resumes_and_steps() {
        let t0 = Instant::now();
        let at = |s: f32| t0 + Duration::from_secs_f32(s);
        let mut c = AnimationClock::new(t0);
        assert!((c.time(at(1.0)) - 1.0).abs() < 1e-4);
        assert!(c.toggle(at(1.0)), "paused");
        assert!((c.time(at(5.0)) - 1.0).abs() < 1e-4, "time stands while paused");
        assert!(!c.toggle(at(5.0)), "resumed");
        assert!((c.time(at(6.0)) - 2.0).abs() < 1e-4, "resumes where it paused");
        assert!((c.step(at(6.0), STEP_S) - (2.0 + STEP_S)).abs() < 1e-4);
        assert!((c.time(at(9.0)) - (2.0 + STEP_S)).abs() < 1e-4, "a step pauses");
        assert_eq!(AnimationClock::new(t0).step(t0, -1.0), 0.0, "never negative");
    }
}
