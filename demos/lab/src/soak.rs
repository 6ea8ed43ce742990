//! The soak test (`cargo xtask soak`, `soak` binary; a short run in tests/tests/soak.rs): many animated frames
//! through the viewer's per-frame path, without a window, checking that host and device memory stay flat and
//! that no validation error appears.
//!
//! Per frame it does what the viewer does (demos/src/viewer.rs `App::redraw` and `App::key`): move the camera
//! (an orbit, like a mouse drag), pose the scene's animation, render, and at intervals switch the technique
//! (the `T` key: `Renderer::set_technique`, which destroys the old technique and prepares the next) and the
//! shading rate (the `V` key), and the BRDF with each technique switch (the `B` key: `Renderer::set_materials`). The only difference is the target: `Renderer::render` (an offscreen frame)
//! instead of `render_presenting` (the same frame plus a blit to the swapchain image).
//!
//! The run is a repeated *cycle*: for every scene, every registered technique, `switch_every` frames (half per
//! pixel, half per vertex). The first cycle is the warm-up: everything the run will ever create has then been
//! created once (allocator blocks, malloc arenas, shader caches). After it, memory is sampled at the end of
//! every cycle, the same point of the same work, and must stay within the bounds of [`SoakOptions`] of the
//! warm-up's end; device memory is also compared at the end of every (scene, technique) segment with the same
//! segment of the warm-up. One renderer per scene is made at the start and kept, as the viewer keeps its one.

use anyhow::{bail, Context, Result};
use engine::gpu::Gpu;
use engine::passes::shade::TECHNIQUES;
use engine::renderer::{RenderSettings, Renderer};
use glam::{Mat3, Vec3};
use std::time::{Duration, Instant};

/// What to soak.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    /// Frames in all (warm-up included).
    pub frames: u64,
    pub width: u32,
    pub height: u32,
    /// Registered scene names (each built once, rendered in turn).
    pub scenes: Vec<String>,
    /// Frames per technique before the next (half of them per vertex).
    pub switch_every: u64,
    /// Allowed growth of the process's resident set (VmRSS) after the host warm-up, in bytes.
    pub host_growth_bound: u64,
    /// Cycles before the host baseline (the device's is the end of the first). Host memory settles more
    /// slowly: measured on `arm` (60-frame cycles, 3 technique switches each), the trimmed RSS rose 1.4 MiB in
    /// the second cycle, then 0.1-0.4 MiB per cycle.
    pub host_warmup_cycles: u64,
    /// Allowed growth of the device memory allocated through the engine (gpu-allocator's report) after the
    /// warm-up, in bytes.
    pub device_growth_bound: u64,
    /// A progress line on stderr this often.
    pub progress_every: Duration,
}

impl SoakOptions {
    /// The defaults of `cargo xtask soak`: 10,000 frames at 64×48 over every animated scene, 200 frames per
    /// technique (a switch costs seconds on lavapipe: the isg technique's preparation); bounds of 8 MiB
    /// of host memory and 1 MiB of device memory, with never more live device allocations than at the same
    /// point of the warm-up. (Device bytes are not exactly constant: the reference rebuilds its triangle BVH
    /// from the skinned pose, and the node count, so the buffer, changes with the pose by a few hundred bytes;
    /// measured: +256 bytes on `arm`. A leak adds allocations or grows without bound.)
    pub fn new(frames: u64) -> Self {
        Self {
            frames,
            width: 64,
            height: 48,
            scenes: scenes::SCENES.iter().filter(|s| s.motion.is_some()).map(|s| s.name.to_string()).collect(),
            switch_every: 200,
            host_growth_bound: 8 << 20,
            host_warmup_cycles: 2,
            device_growth_bound: 1 << 20,
            progress_every: Duration::from_secs(10),
        }
    }

    /// Frames in one cycle (every scene × every technique × `switch_every`).
    pub fn cycle_frames(&self) -> u64 {
        self.scenes.len() as u64 * TECHNIQUES.len() as u64 * self.switch_every
    }
}

/// Memory at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemorySample {
    /// Frame index after which it was taken.
    pub frame: u64,
    /// VmRSS of this process, bytes.
    pub host_rss: u64,
    /// Device bytes allocated through gpu-allocator.
    pub device_allocated: u64,
    /// Device bytes reserved in allocator blocks.
    pub device_reserved: u64,
    /// Live device allocations.
    pub live_allocations: usize,
}

/// What a soak measured.
#[derive(Clone, Debug)]
pub struct SoakReport {
    pub frames: u64,
    pub seconds: f64,
    /// At the end of the warm-up cycle (the device baseline).
    pub warm: MemorySample,
    /// At the end of the host warm-up ([`SoakOptions::host_warmup_cycles`]; the host baseline).
    pub host_warm: MemorySample,
    /// At the end of every later cycle (frames past the last whole cycle are rendered and checked for
    /// validation errors and device memory, not sampled).
    pub samples: Vec<MemorySample>,
    /// Technique switches made.
    pub switches: u64,
    /// Seconds spent creating renderers and switching techniques (preparation, not frames).
    pub prepare_seconds: f64,
}

impl SoakReport {
    /// Largest host growth after the warm-up (bytes; 0 when it shrank).
    pub fn host_growth(&self) -> u64 {
        let after = self.samples.iter().filter(|s| s.frame > self.host_warm.frame);
        after.map(|s| s.host_rss.saturating_sub(self.host_warm.host_rss)).max().unwrap_or(0)
    }

    /// Largest device growth after the warm-up (bytes).
    pub fn device_growth(&self) -> u64 {
        self.samples.iter().map(|s| s.device_allocated.saturating_sub(self.warm.device_allocated)).max().unwrap_or(0)
    }

    /// A summary for the terminal.
    pub fn summary(&self) -> String {
        let mib = |b: u64| b as f64 / 1048576.0;
        let last = self.samples.last().copied().unwrap_or(self.warm);
        format!(
            "soak: {} frames in {:.1} s ({:.1} s of it preparing renderers and techniques), {} technique switches\n  host RSS after \
             warm-up (frame {}) {:.2} MiB, at the end {:.2} MiB, largest growth {:.3} MiB\n  device memory after warm-up {:.3} MiB in {} \
             allocations ({:.2} MiB reserved), at the end {:.3} MiB in {}, largest growth {} bytes",
            self.frames,
            self.seconds,
            self.prepare_seconds,
            self.switches,
            self.host_warm.frame,
            mib(self.host_warm.host_rss),
            mib(last.host_rss),
            mib(self.host_growth()),
            mib(self.warm.device_allocated),
            self.warm.live_allocations,
            mib(self.warm.device_reserved),
            mib(last.device_allocated),
            last.live_allocations,
            self.device_growth()
        )
    }
}

/// The resident set size of this process (VmRSS in /proc/self/status), in bytes.
pub fn host_rss() -> Result<u64> {
    let status = std::fs::read_to_string("/proc/self/status").context("reading /proc/self/status")?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).context("no VmRSS in /proc/self/status")?;
    let kb: u64 = line
        .trim_start_matches("VmRSS:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .with_context(|| format!("cannot read '{line}'"))?;
    Ok(kb * 1024)
}

fn sample(gpu: &Gpu, frame: u64) -> Result<MemorySample> {
    let m = gpu.memory_stats();
    Ok(MemorySample {
        frame,
        host_rss: host_rss()?,
        device_allocated: m.allocated_bytes,
        device_reserved: m.reserved_bytes,
        live_allocations: m.live_allocations,
    })
}

/// The scene's camera turned about the vertical through its target (a slow mouse-drag orbit).
fn orbit(camera: engine::scene::Camera, angle: f32) -> engine::scene::Camera {
    let eye = camera.target + Mat3::from_axis_angle(Vec3::Y, angle) * (camera.eye - camera.target);
    engine::scene::Camera { eye, ..camera }
}

/// Hand the C allocator's free pages back to the system before a sample (glibc `malloc_trim`), so that the
/// resident set measures live memory and not what malloc keeps cached: the driver's and the validation
/// layer's threads each get a malloc arena, and how much of it stays resident after a free varies from run to
/// run by megabytes. A leak is live memory and survives the trim.
fn trim_host_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> i32;
        }
        // SAFETY: glibc's malloc_trim takes no pointers and may be called from any thread at any time.
        unsafe { malloc_trim(0) };
    }
}

/// The renderers of the soak's scenes, destroyed on every path out.
struct Renderers<'g> {
    gpu: &'g Gpu,
    list: Vec<Renderer>,
}

impl Drop for Renderers<'_> {
    fn drop(&mut self) {
        for r in self.list.drain(..) {
            r.destroy(self.gpu);
        }
    }
}

/// Run the soak on `gpu`. Fails on the first validation error (naming the frame), on memory growth past the
/// bounds, on a non-finite pixel at the end of a segment, or on any render error.
pub fn run(gpu: &Gpu, options: &SoakOptions) -> Result<SoakReport> {
    if options.scenes.is_empty() || options.switch_every < 2 || options.frames == 0 {
        bail!("soak: no scenes, no frames or a switch interval under 2");
    }
    let cycle = options.cycle_frames();
    let needed = (options.host_warmup_cycles.max(1) + 1) * cycle;
    if options.frames < needed {
        bail!(
            "soak: {} frames is less than {needed}: {} warm-up cycle(s) of {cycle} frames and one measured cycle; give \
             more frames, fewer scenes or a shorter --switch-every",
            options.frames,
            options.host_warmup_cycles.max(1)
        );
    }
    let t0 = Instant::now();
    // One renderer per scene, made once and kept, as the viewer keeps its one: the per-frame path is what soaks.
    let mut scenes = Vec::new();
    let mut renderers = Renderers { gpu, list: Vec::new() };
    for name in &options.scenes {
        let entry = scenes::find(name)?;
        let scene = scenes::build(name, None)?;
        let animation = scenes::Animation::for_entry(entry, &scene);
        let settings = RenderSettings {
            width: options.width,
            height: options.height,
            technique: TECHNIQUES[0].name.to_string(),
            per_vertex: false,
            exposure: 1.0,
        };
        let renderer = Renderer::new(gpu, &scene, settings).with_context(|| format!("soak: scene '{name}'"))?;
        scenes.push((entry.name, animation, renderer.camera(), scenes::BrdfCycle::new(&scene)));
        renderers.list.push(renderer);
    }
    let mut report = SoakReport {
        frames: 0,
        seconds: 0.0,
        warm: MemorySample::default(),
        host_warm: MemorySample::default(),
        samples: Vec::new(),
        switches: 0,
        prepare_seconds: t0.elapsed().as_secs_f64(),
    };
    let mut last_progress = Instant::now();
    // Device memory at the last frame of each (scene, technique) segment of the second cycle: a later cycle at
    // the same point must not hold more (a per-frame leak inside a live renderer, or a technique switch that
    // does not free the old technique, shows here). Not the first cycle's: there the other scenes' renderers
    // still hold their first technique, later they hold their last (a different amount, by design).
    let mut segment_warm: Vec<Option<(u64, usize)>> = vec![None; scenes.len() * TECHNIQUES.len()];
    let per_scene = TECHNIQUES.len() as u64 * options.switch_every;
    for frame in 0..options.frames {
        let in_cycle = frame % cycle;
        let scene_index = (in_cycle / per_scene) as usize;
        let technique_index = ((in_cycle % per_scene) / options.switch_every) as usize;
        let k = in_cycle % options.switch_every;
        let (name, animation, home, brdf) = &mut scenes[scene_index];
        let renderer = &mut renderers.list[scene_index];
        let technique = TECHNIQUES[technique_index].name;
        if renderer.technique_name() != technique {
            let tp = Instant::now();
            renderer.set_technique(gpu, technique).with_context(|| format!("soak: '{name}' to {technique}"))?;
            report.prepare_seconds += tp.elapsed().as_secs_f64();
            report.switches += 1;
            // And the BRDF, as the `B` key does (a material upload: its staging buffer must not stay alive).
            let materials = brdf.step()?;
            renderer.set_materials(gpu, &materials).with_context(|| format!("soak: '{name}' BRDF {}", brdf.label()))?;
        }
        renderer.settings.per_vertex = k >= options.switch_every / 2;
        renderer.set_camera(orbit(*home, 0.01 * frame as f32));
        if let Some(a) = animation {
            a.apply(renderer, frame as f32 / 30.0)?;
        }
        renderer.render(gpu).with_context(|| format!("soak: frame {frame} ('{name}', {technique})"))?;
        if let Some(e) = gpu.validation_errors().first() {
            bail!("soak: validation error at frame {frame} ('{name}', {technique}): {e}");
        }
        if k + 1 == options.switch_every {
            // End of a segment: the image is finite (a NaN that grows must not hide), and device memory is what
            // it was at the same point of the warm-up.
            let hdr = renderer.read_radiance(gpu)?;
            let bad = hdr.iter().filter(|v| !v.is_finite()).count();
            if bad > 0 {
                bail!("soak: {bad} non-finite values in frame {frame} ('{name}', {technique})");
            }
            let m = gpu.memory_stats();
            let slot = &mut segment_warm[scene_index * TECHNIQUES.len() + technique_index];
            match *slot {
                None if frame < cycle => {}
                None => *slot = Some((m.allocated_bytes, m.live_allocations)),
                Some((bytes, live)) => {
                    if m.allocated_bytes > bytes + options.device_growth_bound || m.live_allocations > live {
                        bail!(
                            "soak: at frame {frame} ('{name}', {technique}) the engine holds {} device bytes in {} \
                             allocations, {bytes} in {live} at the same point of the warm-up (bound: +{} bytes)",
                            m.allocated_bytes,
                            m.live_allocations,
                            options.device_growth_bound
                        );
                    }
                }
            }
        }
        let done = frame + 1;
        // Only at cycle ends: the same point of the same work (mid-cycle, another technique is alive).
        if done % cycle == 0 {
            trim_host_heap();
            let s = sample(gpu, done)?;
            eprintln!(
                "soak: cycle {} ends at frame {done}: host RSS {:.2} MiB, device {} bytes in {} allocations",
                done / cycle,
                s.host_rss as f64 / 1048576.0,
                s.device_allocated,
                s.live_allocations
            );
            if done == cycle {
                report.warm = s;
            } else {
                report.samples.push(s);
            }
            if done == cycle * options.host_warmup_cycles.max(1) {
                report.host_warm = s;
            } else if done > cycle * options.host_warmup_cycles.max(1) {
                let host = s.host_rss.saturating_sub(report.host_warm.host_rss);
                if host > options.host_growth_bound {
                    bail!(
                        "soak: host memory grew by {:.2} MiB after the warm-up (bound {:.2} MiB), at frame {done} (RSS \
                         {:.2} MiB at frame {})",
                        host as f64 / 1048576.0,
                        options.host_growth_bound as f64 / 1048576.0,
                        report.host_warm.host_rss as f64 / 1048576.0,
                        report.host_warm.frame
                    );
                }
            }
        }
        if last_progress.elapsed() >= options.progress_every {
            last_progress = Instant::now();
            let s = sample(gpu, done)?;
            eprintln!(
                "soak: frame {done} of {} ({name}, {technique}), {:.0} s, host RSS {:.2} MiB, device {:.3} MiB in {} \
                 allocations",
                options.frames,
                t0.elapsed().as_secs_f64(),
                s.host_rss as f64 / 1048576.0,
                s.device_allocated as f64 / 1048576.0,
                s.live_allocations
            );
        }
    }
    drop(renderers);
    report.frames = options.frames;
    report.seconds = t0.elapsed().as_secs_f64();
    Ok(report)
}
