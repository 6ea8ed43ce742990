//! `cloth` pass (shaders-glsl/cloth): the GPU cloth simulation of [`crate::scene::cloth`] (its module docs
//! give the method; `ClothSim` there is the f64 CPU twin). Runs after the `skin` and `blocker_spheres`
//! passes and before `thin_shells` and the BVH build:
//!
//! 1. advances the simulation from its current state to the renderer's time in fixed substeps (predict,
//!    `iterations` Jacobi sweeps with ping-pong buffers, finish; a full barrier between dispatches), the
//!    colliders being this frame's world blocker spheres (the scene's, not the cloth's own) and the ground;
//!    a time earlier than the state's resets it to the rest state first; at most
//!    [`MAX_SUBSTEPS_PER_FRAME`] substeps per frame (a larger jump catches up over the next frames);
//! 2. overwrites the cloth's range of `Geometry::world_vertices` (the skin pass wrote its rest pose) with
//!    the simulated positions and grid normals, so that the G-buffer, the thin shells and per-vertex shading
//!    follow it; the cloth instance's transform is used only for the rest pose;
//! 3. writes the generated blocker spheres (one per `sphere_patch²` quads, after the scene's spheres) for
//!    the BVH build: bounding spheres for the techniques that read only spheres, radius 0 for those that
//!    read thin shells (the cloth's triangles are then its blockers, and a sphere would shadow twice).
//!
//! Everything is allocated in [`ClothPass::new`]; a frame allocates nothing. The state lives only in device
//! memory; the host keeps the number of substeps it holds.

use crate::gpu::{Binding, Buffer, BufferDesc, ComputePipeline, Gpu, Recorder, Result};
use crate::resources::GpuScene;
pub use crate::scene::cloth::MAX_SUBSTEPS_PER_FRAME;
use crate::scene::cloth::{cloth_instance, rest_positions, Cloth};
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};

/// Push constants of every shaders-glsl/cloth kernel (`ClothPush` in cloth.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ClothPush {
    pub columns: u32,
    pub rows: u32,
    pub collider_count: u32,
    pub vertex_base: u32,
    pub dt: f32,
    pub keep: f32,
    pub relaxation: f32,
    pub thickness: f32,
    pub gravity: [f32; 3],
    pub ground: f32,
    pub alpha: [f32; 3],
    pub has_ground: f32,
    pub friction: f32,
    pub sphere_first: u32,
    pub sphere_patch: u32,
    pub emit_spheres: u32,
}

const KERNELS: [&str; 6] = ["reset", "predict", "solve", "finish", "write", "spheres"];

pub struct ClothPass {
    pub cloth: Cloth,
    /// [reset, predict, solve, finish, write, spheres].
    pipelines: Vec<ComputePipeline>,
    /// Rest positions (vec4, world space).
    pub rest: Buffer,
    /// Positions (vec4) of the state.
    pub x: Buffer,
    /// Velocities (vec4).
    pub v: Buffer,
    /// Ping-pong positions of the Jacobi sweeps.
    ping: Buffer,
    pong: Buffer,
    push: ClothPush,
    /// Substeps the state holds (time = steps · substep).
    steps: u64,
}

impl ClothPass {
    /// The pass for the scene's cloth, or `None` without one. `gpu_scene` is `scene` uploaded: its last
    /// `cloth.sphere_count()` blocker spheres are the cloth's.
    pub fn new(gpu: &Gpu, scene: &Scene, gpu_scene: &GpuScene) -> Result<Option<Self>> {
        let Some(cloth) = scene.blockers.cloth.clone() else { return Ok(None) };
        let (instance, vertex_base) = cloth_instance(scene, &cloth).map_err(crate::input::SceneInputError)?;
        let inst = &scene.instances[instance];
        let rest: Vec<[f32; 4]> = rest_positions(&cloth, &scene.meshes[inst.mesh].positions, inst.transform)
            .iter()
            .map(|p| [p.x, p.y, p.z, 0.0])
            .collect();
        let spheres = cloth.sphere_count();
        let total = gpu_scene.blockers.sphere_count;
        if spheres > total {
            return Err(crate::input::SceneInputError(format!(
                "cloth: {spheres} generated spheres, the scene holds {total}"
            ))
            .into());
        }
        let p = &cloth.params;
        let dt = p.substep;
        let push = ClothPush {
            columns: cloth.columns,
            rows: cloth.rows,
            collider_count: total - spheres,
            vertex_base,
            dt,
            keep: (1.0 - p.damping * dt).max(0.0),
            relaxation: p.relaxation,
            thickness: p.thickness,
            gravity: p.gravity.to_array(),
            ground: p.ground.unwrap_or(0.0),
            alpha: p.compliance.map(|c| c / (dt * dt)),
            has_ground: if p.ground.is_some() { 1.0 } else { 0.0 },
            friction: p.friction,
            sphere_first: total - spheres,
            sphere_patch: p.sphere_patch,
            emit_spheres: 1,
        };
        let bytes = std::mem::size_of_val(&rest[..]) as u64;
        let buffers = crate::resources::make_buffers(
            gpu,
            [
                &|| gpu.upload_buffer("cloth-rest", BufferDesc::gpu_only(0), &rest),
                &|| gpu.upload_buffer("cloth-x", BufferDesc::gpu_only(0), &rest),
                &|| gpu.upload_buffer("cloth-v", BufferDesc::gpu_only(0), &vec![[0f32; 4]; rest.len()]),
                &|| gpu.create_buffer("cloth-ping", BufferDesc::gpu_only(bytes)),
                &|| gpu.create_buffer("cloth-pong", BufferDesc::gpu_only(bytes)),
            ],
        )?;
        let mut pipelines = Vec::with_capacity(KERNELS.len());
        for k in KERNELS {
            match gpu.create_compute_pipeline(&format!("cloth/{k}.comp"), &[]) {
                Ok(p) => pipelines.push(p),
                Err(e) => {
                    for p in pipelines {
                        gpu.destroy_compute_pipeline(p);
                    }
                    for b in buffers {
                        gpu.destroy_buffer(b);
                    }
                    return Err(e);
                }
            }
        }
        let [rest, x, v, ping, pong] = buffers;
        Ok(Some(Self { cloth, pipelines, rest, x, v, ping, pong, push, steps: 0 }))
    }

    /// Substeps the state holds.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The simulation's time (s).
    pub fn time(&self) -> f64 {
        self.steps as f64 * self.cloth.params.substep as f64
    }

    /// Record the advance to `time` (see the module docs), the cloth's world vertices and its generated
    /// spheres (`emit_spheres`: bounding spheres; otherwise radius 0).
    pub fn record(&mut self, rec: &mut Recorder, scene: &GpuScene, time: f64, emit_spheres: bool) -> Result<()> {
        let target = self.cloth.substeps_at(time);
        let n = self.cloth.vertex_count() as u32;
        let push = ClothPush { emit_spheres: emit_spheres as u32, ..self.push };
        let bytes = bytemuck::bytes_of(&push);
        let [reset, predict, solve, finish, write, spheres] = [0, 1, 2, 3, 4, 5].map(|i| &self.pipelines[i]);
        let world_spheres = &scene.blockers.spheres;
        rec.begin_pass("cloth");
        if target < self.steps {
            rec.dispatch(
                reset,
                &[
                    Binding::buffer("ClothRest", &self.rest),
                    Binding::buffer("ClothX", &self.x),
                    Binding::buffer("ClothV", &self.v),
                ],
                bytes,
                [n, 1, 1],
            )?;
            rec.barrier();
            self.steps = 0;
        }
        let substeps = (target - self.steps).min(MAX_SUBSTEPS_PER_FRAME);
        for _ in 0..substeps {
            rec.dispatch(
                predict,
                &[
                    Binding::buffer("ClothX", &self.x),
                    Binding::buffer("ClothV", &self.v),
                    Binding::buffer("ClothOut", &self.ping),
                    Binding::buffer("Spheres", world_spheres),
                ],
                bytes,
                [n, 1, 1],
            )?;
            let (mut from, mut to) = (&self.ping, &self.pong);
            for _ in 0..self.cloth.params.iterations {
                rec.barrier();
                rec.dispatch(
                    solve,
                    &[
                        Binding::buffer("ClothRest", &self.rest),
                        Binding::buffer("ClothIn", from),
                        Binding::buffer("ClothOut", to),
                    ],
                    bytes,
                    [n, 1, 1],
                )?;
                std::mem::swap(&mut from, &mut to);
            }
            rec.barrier();
            rec.dispatch(
                finish,
                &[
                    Binding::buffer("ClothIn", from),
                    Binding::buffer("ClothX", &self.x),
                    Binding::buffer("ClothV", &self.v),
                    Binding::buffer("Spheres", world_spheres),
                ],
                bytes,
                [n, 1, 1],
            )?;
            rec.barrier();
        }
        self.steps += substeps;
        rec.dispatch(
            write,
            &[
                Binding::buffer("ClothX", &self.x),
                Binding::buffer("Vertices", &scene.geometry.vertices),
                Binding::buffer("WorldVertices", &scene.geometry.world_vertices),
            ],
            bytes,
            [n, 1, 1],
        )?;
        rec.dispatch(
            spheres,
            &[Binding::buffer("ClothX", &self.x), Binding::buffer("Spheres", world_spheres)],
            bytes,
            [self.cloth.sphere_count(), 1, 1],
        )
    }

    pub fn destroy(self, gpu: &Gpu) {
        for p in self.pipelines {
            gpu.destroy_compute_pipeline(p);
        }
        for b in [self.rest, self.x, self.v, self.ping, self.pong] {
            gpu.destroy_buffer(b);
        }
    }
}
