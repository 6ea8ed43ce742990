//! `softshadows`: the engine from Python (pyo3, built by maturin; `pip install ./python`). Scenes come from the
//! scenes registry or a file (`scenes::load`, as `--scene`), techniques are the specs of `demo --technique` (parsed
//! by the engine's registry, `engine::passes::shade::TECHNIQUES`), and the measurements are the `lab` crate's
//! (`lab::measure`, as the `compare` binary). Images come back as float32 numpy arrays H×W×3 of linear radiance.
//!
//! Every call that works on the GPU releases the GIL for its whole duration; a `Renderer`'s device is behind a
//! mutex, so two Python threads using one renderer take turns. `render` keeps its engine renderer while the scene and
//! settings stay the same (one at a time); `reference` and `compare` make and destroy their own. Everything on the
//! device goes with `close()` or when the object is dropped.

use anyhow::{Context, Result};
use engine::gpu::{Gpu, GpuDesc};
use engine::passes::shade::reference::Visibility;
use engine::renderer::RenderSettings;
use lab::measure;
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3};
use pyo3::create_exception;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

create_exception!(
    softshadows,
    EngineError,
    PyRuntimeError,
    "An error of the engine (an unknown scene or technique, a bad option, a device fault): its message is the engine's."
);

/// The engine's error as a Python exception, with its whole chain of context (`{:#}`, as the CLI prints it).
fn py_err(e: anyhow::Error) -> PyErr {
    EngineError::new_err(format!("{e:#}"))
}

/// A scene: a registered one or a file, built once and shared by every call that renders it.
#[pyclass(module = "softshadows", frozen)]
struct Scene {
    label: String,
    scene: Arc<engine::scene::Scene>,
}

#[pymethods]
impl Scene {
    /// The name or path it was loaded from.
    #[getter]
    fn name(&self) -> &str {
        &self.label
    }

    fn __repr__(&self) -> String {
        format!(
            "softshadows.Scene('{}': {} meshes, {} instances, {} materials, {} lights)",
            self.label,
            self.scene.meshes.len(),
            self.scene.instances.len(),
            self.scene.materials.len(),
            self.scene.lights.len()
        )
    }
}

/// `load(spec, env=None)`: a registered scene name (`scenes()`) or a `.gltf`/`.glb`/`.obj`/`.toml` file, as
/// `demo --scene`; `env` replaces its environment map (`.exr`/`.hdr`).
#[pyfunction]
#[pyo3(signature = (spec, env = None))]
fn load(py: Python<'_>, spec: &str, env: Option<PathBuf>) -> PyResult<Scene> {
    let loaded = py
        .allow_threads(|| scenes::load(spec, env.as_deref(), &scenes::user::UserOptions::default()))
        .map_err(py_err)?;
    Ok(Scene { label: loaded.label, scene: Arc::new(loaded.scene) })
}

/// The registered scene names.
#[pyfunction]
fn scene_names() -> Vec<&'static str> {
    scenes::SCENES.iter().map(|s| s.name).collect()
}

/// The registered technique names (a spec is `name` or `name:key=value,...`).
#[pyfunction]
fn techniques() -> Vec<&'static str> {
    engine::passes::shade::TECHNIQUES.iter().map(|t| t.name).collect()
}

/// The device and what the last call measured.
struct Inner {
    /// `None` once closed.
    gpu: Option<Gpu>,
    /// Per-pass GPU times of the last frame rendered.
    last_times: Vec<(String, f64)>,
    /// Validation errors already reported.
    validation_seen: usize,
    /// The engine renderer of the last `render`, kept while the scene and settings stay the same (making one
    /// compiles its pipelines and uploads the scene: seconds on lavapipe); replaced (destroyed) when they change,
    /// destroyed by `close()` and when the object is dropped.
    cached: Option<Cached>,
}

/// An engine renderer with what it was made for.
struct Cached {
    scene: Arc<engine::scene::Scene>,
    settings: RenderSettings,
    renderer: engine::renderer::Renderer,
}

impl Cached {
    fn is_for(&self, scene: &Arc<engine::scene::Scene>, settings: &RenderSettings) -> bool {
        Arc::ptr_eq(&self.scene, scene)
            && (self.settings.width, self.settings.height, self.settings.per_vertex)
                == (settings.width, settings.height, settings.per_vertex)
            && self.settings.technique == settings.technique
    }
}

impl Inner {
    /// Destroy the cached engine renderer, if any.
    fn drop_cached(&mut self) {
        if let (Some(c), Some(gpu)) = (self.cached.take(), self.gpu.as_ref()) {
            c.renderer.destroy(gpu);
        }
    }
}

impl Drop for Inner {
    fn drop(&mut self) {
        // Before the device goes (the `gpu` field drops after this).
        self.drop_cached();
    }
}

impl Inner {
    fn gpu(&self) -> Result<&Gpu> {
        self.gpu.as_ref().context("this Renderer is closed")
    }

    /// An error naming the validation errors that appeared since the last check (validation layers are on
    /// with ENGINE_VALIDATION=1, and in debug builds when installed).
    fn check_validation(&mut self) -> Result<()> {
        let Some(gpu) = &self.gpu else { return Ok(()) };
        let errors = gpu.validation_errors();
        let new = errors.get(self.validation_seen..).unwrap_or_default().to_vec();
        self.validation_seen = errors.len();
        anyhow::ensure!(new.is_empty(), "validation errors:\n{}", new.join("\n"));
        Ok(())
    }
}

/// One device (the `--device` choice) and the engine's renderers on it.
#[pyclass(module = "softshadows", frozen)]
struct Renderer {
    inner: Mutex<Inner>,
}

/// Settings of one render (the engine parses the technique spec when the renderer is made).
fn settings(technique: &str, width: u32, height: u32, per_vertex: bool) -> RenderSettings {
    RenderSettings { width, height, technique: technique.into(), per_vertex, ..Default::default() }
}

/// Linear RGBA32F (row-major, top row first) as an H×W×3 array.
fn rgb_array(hdr: &[f32], width: u32, height: u32) -> Result<Array3<f32>> {
    let (w, h) = (width as usize, height as usize);
    anyhow::ensure!(hdr.len() == w * h * 4, "image of {} floats for {w}x{h} RGBA", hdr.len());
    let rgb: Vec<f32> = hdr.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    Ok(Array3::from_shape_vec((h, w, 3), rgb)?)
}

/// The measuring passes of one frame, summed by name (a name seen twice adds up).
fn summed(times: &[engine::gpu::PassTiming]) -> Vec<(String, f64)> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for t in times {
        match out.iter_mut().find(|(n, _)| *n == t.name) {
            Some((_, ms)) => *ms += t.ms,
            None => out.push((t.name.clone(), t.ms)),
        }
    }
    out
}

/// A visibility of the reference by its `compare --visibility` name.
fn visibilities(name: &str) -> Result<Vec<Visibility>> {
    match name {
        "both" => Ok(vec![Visibility::Spheres, Visibility::Triangles]),
        v => Ok(vec![measure::parse_visibility(v)?]),
    }
}

impl Renderer {
    /// Run `f` on the device with the GIL released, then report validation errors it caused.
    fn with_gpu<T: Send>(&self, py: Python<'_>, f: impl FnOnce(&mut Inner) -> Result<T> + Send) -> PyResult<T> {
        py.allow_threads(|| {
            let mut inner = self.inner.lock().map_err(|_| anyhow::anyhow!("a previous call panicked"))?;
            let out = f(&mut inner);
            let checked = inner.check_validation();
            let out = out?;
            checked?;
            Ok(out)
        })
        .map_err(py_err)
    }
}

#[pymethods]
impl Renderer {
    /// `Renderer(device=None)`: `device` is a case-insensitive part of the adapter's name, as `demo --device`;
    /// `None` reads ENGINE_DEVICE (empty counts as unset), else the automatic choice.
    #[new]
    #[pyo3(signature = (device = None))]
    fn new(py: Python<'_>, device: Option<String>) -> PyResult<Self> {
        let gpu = py
            .allow_threads(|| {
                let defaults = GpuDesc::default();
                let from_env = defaults.device_name.clone().filter(|d| !d.is_empty());
                let named = device.is_some();
                let device_name = device.or(from_env.clone());
                Gpu::new(&GpuDesc { device_name, verbose: false, ..defaults }).map_err(|e| match from_env {
                    Some(name) if !named => anyhow::Error::new(e).context(format!("ENGINE_DEVICE={name}")),
                    _ => e.into(),
                })
            })
            .map_err(py_err)?;
        Ok(Self {
            inner: Mutex::new(Inner { gpu: Some(gpu), last_times: Vec::new(), validation_seen: 0, cached: None }),
        })
    }

    /// The adapter's name.
    #[getter]
    fn device(&self) -> PyResult<String> {
        let inner = self.inner.lock().map_err(|_| EngineError::new_err("a previous call panicked"))?;
        Ok(inner.gpu().map_err(py_err)?.info.name.clone())
    }

    /// `render(scene, technique="isg", width=320, height=240, frames=1, per_vertex=False)`: the last of `frames`
    /// frames as float32 H×W×3 linear radiance. `technique` is a `demo --technique` spec.
    // The Python keywords, one argument each.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (scene, technique = "isg", width = 320, height = 240, frames = 1, per_vertex = false))]
    fn render<'py>(
        &self,
        py: Python<'py>,
        scene: &Scene,
        technique: &str,
        width: u32,
        height: u32,
        frames: u32,
        per_vertex: bool,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let s = scene.scene.clone();
        let image = self.with_gpu(py, |inner| {
            let wanted = settings(technique, width, height, per_vertex);
            if !inner.cached.as_ref().is_some_and(|c| c.is_for(&s, &wanted)) {
                inner.drop_cached();
                let gpu = inner.gpu()?;
                let renderer = engine::renderer::Renderer::new(gpu, &s, wanted.clone())
                    .with_context(|| format!("preparing technique {technique}"))?;
                inner.cached = Some(Cached { scene: s.clone(), settings: wanted, renderer });
            }
            let gpu = inner.gpu.as_ref().context("this Renderer is closed")?;
            let r = &mut inner.cached.as_mut().expect("made above").renderer;
            let out = (|| -> Result<_> {
                let mut times = Vec::new();
                for _ in 0..frames.max(1) {
                    times = r.render(gpu)?;
                }
                Ok((r.read_radiance(gpu)?, times))
            })();
            // A renderer that failed is not reused.
            let (hdr, times) = out.inspect_err(|_| inner.drop_cached())?;
            inner.last_times = summed(&times);
            rgb_array(&hdr, width, height)
        })?;
        Ok(image.into_pyarray(py))
    }

    /// `reference(scene, width=80, height=60, visibility="triangles", spp=1024, samples_per_frame=16)`: the Monte
    /// Carlo reference at `spp` samples per pixel (whole frames of `samples_per_frame`), float32 H×W×3.
    /// `visibility`: `triangles`, `spheres` or `unoccluded` (as `compare --visibility`).
    // The Python keywords, one argument each.
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (scene, width = 80, height = 60, visibility = "triangles", spp = 1024, samples_per_frame = 16))]
    fn reference<'py>(
        &self,
        py: Python<'py>,
        scene: &Scene,
        width: u32,
        height: u32,
        visibility: &str,
        spp: u32,
        samples_per_frame: u32,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let s = scene.scene.clone();
        let image = self.with_gpu(py, |inner| {
            let vis = measure::parse_visibility(visibility)?;
            anyhow::ensure!(spp >= 1, "spp {spp}: at least 1");
            let per_frame = samples_per_frame.clamp(1, spp);
            let gpu = inner.gpu()?;
            let r = measure::reference_at(gpu, &s, &settings("reference", width, height, false), vis, spp, per_frame)?;
            rgb_array(&r.hdr, width, height)
        })?;
        Ok(image.into_pyarray(py))
    }

    /// `compare(scene, techniques, ...)`: as the module's `compare`, on this renderer's device.
    #[pyo3(signature = (scene, techniques, width = 80, height = 60, visibility = "triangles", frames = 3,
                        fraction = 0.2, max_spp = 4096, per_vertex = false))]
    #[allow(clippy::too_many_arguments)]
    fn compare<'py>(
        &self,
        py: Python<'py>,
        scene: &Scene,
        techniques: Vec<String>,
        width: u32,
        height: u32,
        visibility: &str,
        frames: u32,
        fraction: f64,
        max_spp: u32,
        per_vertex: bool,
    ) -> PyResult<Bound<'py, PyList>> {
        let s = scene.scene.clone();
        let rows = self.with_gpu(py, |inner| {
            let gpu = inner.gpu()?;
            let vis = visibilities(visibility)?;
            let mut measured = Vec::new();
            for spec in &techniques {
                measured.push(measure::measure_technique(gpu, &s, settings(spec, width, height, per_vertex), frames)?);
            }
            let mut rows = Vec::new();
            for v in vis {
                let against: Vec<&[f32]> = measured.iter().map(|m| m.hdr.as_slice()).collect();
                let run =
                    measure::ReferenceRun { visibility: v, fraction, max_spp, samples_per_frame: 16.min(max_spp) };
                let reference =
                    measure::converge_reference(gpu, &s, &settings("reference", width, height, false), &run, &against)?;
                for m in &measured {
                    rows.push(Row {
                        technique: m.spec.clone(),
                        visibility: measure::visibility_name(v),
                        errors: measure::errors(&m.hdr, &m.ldr, &reference, width, height),
                        shade_ms: m.shade_ms,
                        frame_ms: m.frame_ms,
                        reference_spp: reference.report.samples,
                        reference_stderr: 100.0 * reference.report.relative_stderr,
                        reference_converged: reference.report.converged,
                        reference_ms_per_sample: reference.ms_per_sample,
                    });
                }
            }
            Ok(rows)
        })?;
        let list = PyList::empty(py);
        for r in rows {
            list.append(r.into_dict(py)?)?;
        }
        Ok(list)
    }

    /// Per-pass GPU times (ms) of the last frame `render` made, as a dict in pass order.
    fn last_pass_times<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.inner.lock().map_err(|_| EngineError::new_err("a previous call panicked"))?;
        let d = PyDict::new(py);
        for (name, ms) in &inner.last_times {
            d.set_item(name, ms)?;
        }
        Ok(d)
    }

    /// Device memory now: `allocated_bytes`, `reserved_bytes`, `live_allocations`, `allocations_made`.
    fn memory<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let inner = self.inner.lock().map_err(|_| EngineError::new_err("a previous call panicked"))?;
        let m = inner.gpu().map_err(py_err)?.memory_stats();
        let d = PyDict::new(py);
        d.set_item("allocated_bytes", m.allocated_bytes)?;
        d.set_item("reserved_bytes", m.reserved_bytes)?;
        d.set_item("live_allocations", m.live_allocations)?;
        d.set_item("allocations_made", m.allocations_made)?;
        Ok(d)
    }

    /// Tear the device down now; raises if anything leaked or a validation error was seen. Closing twice is a
    /// no-op; a closed renderer raises on use.
    fn close(&self, py: Python<'_>) -> PyResult<()> {
        py.allow_threads(|| {
            let mut inner = self.inner.lock().map_err(|_| anyhow::anyhow!("a previous call panicked"))?;
            inner.drop_cached();
            match inner.gpu.take() {
                Some(gpu) => gpu.shutdown().map_err(Into::into),
                None => Ok(()),
            }
        })
        .map_err(py_err)
    }

    fn __enter__(slf: Py<Self>) -> Py<Self> {
        slf
    }

    #[pyo3(signature = (*_args))]
    fn __exit__(&self, py: Python<'_>, _args: &Bound<'_, pyo3::types::PyTuple>) -> PyResult<bool> {
        self.close(py)?;
        Ok(false)
    }
}

/// One row of a compare table.
struct Row {
    technique: String,
    visibility: &'static str,
    errors: measure::Errors,
    shade_ms: f64,
    frame_ms: f64,
    reference_spp: u32,
    reference_stderr: f64,
    reference_converged: bool,
    reference_ms_per_sample: f64,
}

impl Row {
    fn into_dict(self, py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("technique", self.technique)?;
        d.set_item("visibility", self.visibility)?;
        d.set_item("rmse_percent", self.errors.rmse)?;
        d.set_item("debiased_percent", self.errors.debiased)?;
        d.set_item("noise_percent", self.errors.noise)?;
        d.set_item("max_error", self.errors.max_abs)?;
        d.set_item("flip", self.errors.flip)?;
        d.set_item("shade_ms", self.shade_ms)?;
        d.set_item("frame_ms", self.frame_ms)?;
        d.set_item("reference_spp", self.reference_spp)?;
        d.set_item("reference_stderr_percent", self.reference_stderr)?;
        d.set_item("reference_converged", self.reference_converged)?;
        d.set_item("reference_ms_per_sample", self.reference_ms_per_sample)?;
        Ok(d)
    }
}

/// `compare(scene, techniques, width=80, height=60, visibility="triangles", frames=3, fraction=0.2, max_spp=4096,
/// per_vertex=False, device=None)`: the `compare` binary's table as a list of dicts, one per technique and
/// visibility (`both` gives spheres and triangles rows), on a device of its own.
#[pyfunction]
#[pyo3(signature = (scene, techniques, width = 80, height = 60, visibility = "triangles", frames = 3,
                    fraction = 0.2, max_spp = 4096, per_vertex = false, device = None))]
#[allow(clippy::too_many_arguments)]
fn compare<'py>(
    py: Python<'py>,
    scene: &Scene,
    techniques: Vec<String>,
    width: u32,
    height: u32,
    visibility: &str,
    frames: u32,
    fraction: f64,
    max_spp: u32,
    per_vertex: bool,
    device: Option<String>,
) -> PyResult<Bound<'py, PyList>> {
    let r = Renderer::new(py, device)?;
    let rows = r.compare(py, scene, techniques, width, height, visibility, frames, fraction, max_spp, per_vertex);
    let closed = r.close(py);
    let rows = rows?;
    closed?;
    Ok(rows)
}

#[pymodule]
fn softshadows(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Renderer>()?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(scene_names, m)?)?;
    m.add_function(wrap_pyfunction!(techniques, m)?)?;
    m.add("EngineError", m.py().get_type::<EngineError>())?;
    Ok(())
}
