//! `blocker_bvh` pass (shaders-glsl/blocker_bvh): every frame, a binary LBVH over the world-space blocker
//! spheres, built on the GPU from scratch (Karras 2012):
//!
//! 1. `bounds` — scene bounds of the centres (one workgroup, strided reduction);
//! 2. `morton` — 30-bit Morton codes, identity values, refit counters cleared;
//! 3. `radix_count` / `radix_scan` / `radix_scatter` × 8 — stable LSD radix sort, 4-bit digits, tiles of
//!    1024 keys; stability makes the order that of the CPU build's sort by (code, index);
//! 4. `hierarchy` — Karras's range/split search per internal node, leaves per sphere;
//! 5. `refit` — bottom-up bounding spheres with atomic counters (second arrival merges).
//!
//! Every step is O(n): the build grows linearly with the sphere count. The node array layout is
//! [`GpuBvhNode`] (std430, 32 bytes; GLSL `BvhNode` in shaders-glsl/common/bvh.glsl), root at index 0,
//! with the numbering of the CPU reference [`engine_blockers::bvh::SphereBvh`]. All scratch buffers are
//! allocated in [`BlockerBvhPass::new`] for a capacity; recording allocates nothing.

use crate::gpu::{Binding, Buffer, BufferDesc, ComputePipeline, Gpu, GpuError, Recorder, Result};
pub use crate::resources::blockers::{node_buffer_size, GpuBvhNode, MAX_SPHERES};

/// Keys per radix tile (shaders-glsl/blocker_bvh/radix.glsl: 256 threads × 4 keys).
const RADIX_TILE: u32 = 1024;
/// Radix sort passes: 4-bit digits over the 30-bit codes (32 bits, an even count so the sorted keys end
/// in the first buffer).
const RADIX_PASSES: u32 = 8;

/// Push constants of the radix sort steps (`Push` in shaders-glsl/blocker_bvh/radix.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RadixPush {
    pub n: u32,
    pub shift: u32,
    pub tiles: u32,
}

struct Scratch {
    bounds: Buffer,
    keys: [Buffer; 2],
    values: [Buffer; 2],
    hist: Buffer,
    counters: Buffer,
}

impl Scratch {
    fn destroy(self, gpu: &Gpu) {
        let [k0, k1] = self.keys;
        let [v0, v1] = self.values;
        for b in [self.bounds, k0, k1, v0, v1, self.hist, self.counters] {
            gpu.destroy_buffer(b);
        }
    }
}

pub struct BlockerBvhPass {
    pipelines: Vec<ComputePipeline>,
    scratch: Scratch,
    capacity: u32,
}

const SHADERS: [&str; 7] = [
    "blocker_bvh/bounds.comp",
    "blocker_bvh/morton.comp",
    "blocker_bvh/radix_count.comp",
    "blocker_bvh/radix_scan.comp",
    "blocker_bvh/radix_scatter.comp",
    "blocker_bvh/hierarchy.comp",
    "blocker_bvh/refit.comp",
];

impl BlockerBvhPass {
    /// Compiles the steps and allocates scratch for up to `capacity` spheres.
    pub fn new(gpu: &Gpu, capacity: u32) -> Result<Self> {
        if capacity > MAX_SPHERES {
            return Err(crate::input::SceneInputError(format!(
                "blocker_bvh: {capacity} spheres, at most {MAX_SPHERES}"
            ))
            .into());
        }
        let mut pipelines = Vec::with_capacity(SHADERS.len());
        for s in SHADERS {
            match gpu.create_compute_pipeline(s, &[]) {
                Ok(p) => pipelines.push(p),
                Err(e) => {
                    for p in pipelines {
                        gpu.destroy_compute_pipeline(p);
                    }
                    return Err(e);
                }
            }
        }
        let n = capacity.max(1) as u64;
        let tiles = capacity.div_ceil(RADIX_TILE).max(1) as u64;
        let mut made = Vec::new();
        let sizes: [(&str, u64); 7] = [
            ("bvh-bounds", 32),
            ("bvh-keys-a", 4 * n),
            ("bvh-keys-b", 4 * n),
            ("bvh-values-a", 4 * n),
            ("bvh-values-b", 4 * n),
            ("bvh-radix-histogram", 4 * 16 * tiles),
            ("bvh-refit-counters", 4 * n),
        ];
        for (name, size) in sizes {
            match gpu.create_buffer(name, BufferDesc::gpu_only(size)) {
                Ok(b) => made.push(b),
                Err(e) => {
                    for b in made {
                        gpu.destroy_buffer(b);
                    }
                    for p in pipelines {
                        gpu.destroy_compute_pipeline(p);
                    }
                    return Err(e);
                }
            }
        }
        let mut it = made.into_iter();
        let mut next = || it.next().ok_or_else(|| GpuError::Other("internal: blocker_bvh buffers".into()));
        let scratch = Scratch {
            bounds: next()?,
            keys: [next()?, next()?],
            values: [next()?, next()?],
            hist: next()?,
            counters: next()?,
        };
        Ok(Self { pipelines, scratch, capacity })
    }

    pub fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Records the build of `nodes` (at least [`node_buffer_size`]`(count)` bytes) over the first
    /// `count` entries of `spheres` (`vec4(center, radius)`), as one timed pass `blocker_bvh`. With no
    /// spheres nothing is dispatched.
    pub fn record(&self, rec: &mut Recorder, spheres: &Buffer, nodes: &Buffer, count: u32) -> Result<()> {
        if count > self.capacity {
            return Err(GpuError::Other(format!(
                "blocker_bvh: {count} spheres but scratch for {} (create the pass with a larger capacity)",
                self.capacity
            )));
        }
        if nodes.desc.size < node_buffer_size(count) || spheres.desc.size < 16 * count as u64 {
            return Err(GpuError::Other(format!("blocker_bvh: buffers too small for {count} spheres")));
        }
        if count == 0 {
            return Ok(());
        }
        rec.begin_pass("blocker_bvh");
        let [bounds, morton, radix_count, radix_scan, radix_scatter, hierarchy, refit] = &self.pipelines[..] else {
            return Err(GpuError::Other("internal: blocker_bvh pipelines".into()));
        };
        let s = &self.scratch;
        let n = bytemuck::bytes_of(&count);
        rec.dispatch(
            bounds,
            &[Binding::buffer("Spheres", spheres), Binding::buffer("Bounds", &s.bounds)],
            n,
            [256, 1, 1],
        )?;
        rec.barrier();
        rec.dispatch(
            morton,
            &[
                Binding::buffer("Spheres", spheres),
                Binding::buffer("Bounds", &s.bounds),
                Binding::buffer("Keys", &s.keys[0]),
                Binding::buffer("Values", &s.values[0]),
                Binding::buffer("Counters", &s.counters),
            ],
            n,
            [count, 1, 1],
        )?;
        let tiles = count.div_ceil(RADIX_TILE);
        for pass in 0..RADIX_PASSES {
            let (src, dst) = ((pass % 2) as usize, ((pass + 1) % 2) as usize);
            let push = RadixPush { n: count, shift: 4 * pass, tiles };
            let push = bytemuck::bytes_of(&push);
            rec.barrier();
            rec.dispatch(
                radix_count,
                &[Binding::buffer("KeysIn", &s.keys[src]), Binding::buffer("Histogram", &s.hist)],
                push,
                [tiles * 256, 1, 1],
            )?;
            rec.barrier();
            rec.dispatch(radix_scan, &[Binding::buffer("Histogram", &s.hist)], push, [256, 1, 1])?;
            rec.barrier();
            rec.dispatch(
                radix_scatter,
                &[
                    Binding::buffer("KeysIn", &s.keys[src]),
                    Binding::buffer("ValuesIn", &s.values[src]),
                    Binding::buffer("KeysOut", &s.keys[dst]),
                    Binding::buffer("ValuesOut", &s.values[dst]),
                    Binding::buffer("Histogram", &s.hist),
                ],
                push,
                [tiles * 256, 1, 1],
            )?;
        }
        rec.barrier();
        rec.dispatch(
            hierarchy,
            &[
                Binding::buffer("Spheres", spheres),
                Binding::buffer("Bounds", &s.bounds),
                Binding::buffer("Keys", &s.keys[0]),
                Binding::buffer("Values", &s.values[0]),
                Binding::buffer("BvhNodes", nodes),
            ],
            n,
            [2 * count - 1, 1, 1],
        )?;
        rec.barrier();
        rec.dispatch(
            refit,
            &[Binding::buffer("BvhNodes", nodes), Binding::buffer("Counters", &s.counters)],
            n,
            [count, 1, 1],
        )
    }

    /// The sorted (Morton code, sphere index) pairs of the last build of `count` spheres, read back
    /// (for tests of the sort; waits for the device).
    pub fn read_sorted(&self, gpu: &Gpu, count: u32) -> Result<Vec<(u32, u32)>> {
        let keys = gpu.read_buffer::<u32>(&self.scratch.keys[0])?;
        let values = gpu.read_buffer::<u32>(&self.scratch.values[0])?;
        Ok(keys.into_iter().zip(values).take(count as usize).collect())
    }

    pub fn destroy(self, gpu: &Gpu) {
        for p in self.pipelines {
            gpu.destroy_compute_pipeline(p);
        }
        self.scratch.destroy(gpu);
    }
}
