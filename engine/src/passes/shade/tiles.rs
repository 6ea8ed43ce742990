//! Blocker tiles: the blockers culled once per 16 × 16-pixel screen tile instead of once per pixel,
//! for the techniques that traverse the blocker BVH per pixel (`isg`, `lobes`, `shexp`'s per-receiver cut).
//!
//! After the G-buffer, `blocker_tiles/cull.comp` builds for each tile a *start list*: a cut of the BVH that
//! drops the nodes no receiver of the tile can be shadowed by (below every receiver's tangent plane) and stops
//! above the nodes some receiver might take whole (subtending less than the technique's largest take-whole
//! half-angle T). Each pixel's traversals then start from its tile's list instead of the root
//! (shaders-glsl/common/bvh.glsl). The shader says why this is exact: it visits the same nodes in the same
//! order as from the root, so `tiles=on` and `tiles=off` render the same image (tests/tests/tiles.rs). A list
//! longer than `tile_cap` falls back to the root alone: the per-pixel traversal, the same image again.
//!
//! Per vertex there are no screen tiles: the vertex variant traverses from the root.
//!
//! Counters ([`TileCounts`]): list lengths per tile and the BVH nodes each pixel tested, mean and p99 — what
//! the technique's traversal costs, without a profiler. f64 twin of the cull: [`cpu::tile_list`].

use super::ShadeTarget;
use crate::gpu::{Binding, Buffer, BufferDesc, ComputePipeline, Gpu, GpuError, Recorder, Result};
use crate::options::{Kind, OptionSpec, Options};
use crate::resources::BlockerResources;
use std::cell::{Cell, OnceCell, RefCell};

/// Pixels per tile side (the cull pass's workgroup; `BVH_TILE_SIDE` in shaders-glsl/shade/tiles.glsl).
pub const TILE_SIDE: u32 = 16;

/// The option that turns the tile lists on or off (`tiles=off`: every pixel traverses from the root).
pub const TILES_OPTION: OptionSpec = OptionSpec {
    key: "tiles",
    aliases: &[],
    kind: Kind::Choice(&["on", "off"]),
    default: Some("on"),
    help: "per pixel: start each pixel's BVH traversals from its 16×16 tile's culled list (the same image; off: from the root, to measure the difference)",
};

/// The longest start list a tile keeps; a longer one falls back to the root (the same image, slower).
pub const TILE_CAP_OPTION: OptionSpec = OptionSpec {
    key: "tile_cap",
    aliases: &[],
    kind: Kind::Int { min: 1, max: 4096 },
    default: Some("512"),
    help: "tiles=on: the longest start list a tile keeps; a tile with more falls back to traversing from the root",
};

/// The tiles' level of detail: an approximation, off by default.
pub const TILE_LOD_OPTION: OptionSpec = OptionSpec {
    key: "tile_lod",
    aliases: &[],
    kind: Kind::Float { min: 0.0, max: 30.0, min_open: false, max_open: false },
    default: Some("0"),
    help: "tiles=on: a BVH node subtending less than this half-angle (degrees) from every receiver of a tile is one blocker for the whole tile (an approximation that changes the image; 0: off, exact)",
};

/// The bounded reach of the blocker traversals, per pixel and per vertex: an approximation, off by default.
pub const REACH_OPTION: OptionSpec = OptionSpec {
    key: "reach",
    aliases: &[],
    kind: Kind::Float { min: 0.0, max: 1e6, min_open: false, max_open: false },
    default: Some("0"),
    help: "blockers farther than this from a receiver (scene units, centre distance) cast no shadow on it, fading out over the last quarter (an approximation, as Unreal's capsule shadows' reach; 0: unbounded)",
};

/// The tile options of one technique.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TileOptions {
    pub on: bool,
    pub capacity: u32,
    /// The level of detail's half-angle in degrees (0: off).
    pub lod_deg: f64,
    /// The bounded reach (option `reach`, scene units; 0: off). Applies per pixel and per vertex, with or
    /// without tiles; the tile pass also culls what lies beyond it from the whole tile.
    pub reach: f64,
}

impl Default for TileOptions {
    fn default() -> Self {
        Self { on: true, capacity: 512, lod_deg: 0.0, reach: 0.0 }
    }
}

impl TileOptions {
    /// From options parsed against a schema holding [`TILES_OPTION`] and [`TILE_CAP_OPTION`].
    pub fn from_options(o: &Options) -> Self {
        Self {
            on: o.choice("tiles") != "off",
            capacity: o.int("tile_cap").clamp(1, 4096) as u32,
            lod_deg: o.float("tile_lod").clamp(0.0, 30.0),
            reach: o.float("reach").max(0.0),
        }
    }

    /// The shader define of the technique's pipelines: `BVH_TILES` when on (read only by the pixel variant).
    pub fn defines(&self) -> Vec<(&'static str, &'static str)> {
        if self.on {
            vec![("BVH_TILES", "1")]
        } else {
            Vec::new()
        }
    }
}

/// What the tiles and the traversals did: the cull pass's lists since the last read, and the nodes tested per
/// pixel in the last frame shaded per pixel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TileCounts {
    /// Frames whose tile lists were built since the last read (0 with `tiles=off`).
    pub frames: u64,
    /// Tiles holding a receiver, summed over those frames.
    pub tiles: u64,
    /// Mean start-list length over those tiles.
    pub list_mean: f64,
    /// The longest start list.
    pub list_max: u64,
    /// Tiles whose list overflowed `tile_cap` (they traversed from the root).
    pub fell_back: u64,
    /// Nodes the cull pass tested per tile (mean).
    pub cull_tested_mean: f64,
    /// BVH nodes tested per shaded pixel in the last frame (every traversal of the pixel): mean, p99, max.
    pub pixel_mean: f64,
    pub pixel_p99: f64,
    pub pixel_max: u64,
    /// Shaded pixels counted.
    pub pixels: u64,
}

impl TileCounts {
    /// One line for the user.
    pub fn line(&self) -> String {
        let mut s = format!(
            "BVH nodes tested per pixel: mean {:.1}, p99 {:.0}, max {} ({} pixels)",
            self.pixel_mean, self.pixel_p99, self.pixel_max, self.pixels
        );
        if self.frames > 0 {
            s.push_str(&format!(
                "; tile lists: mean {:.1}, longest {}, {} of {} tiles fell back to the root; the cull tested {:.1} nodes per tile",
                self.list_mean, self.list_max, self.fell_back, self.tiles, self.cull_tested_mean
            ));
        }
        s
    }
}

/// The cull pass and the buffers of one technique (the lists, the per-pixel counts and the counters).
pub struct BlockerTiles {
    pub options: TileOptions,
    cull: OnceCell<ComputePipeline>,
    /// Every buffer made so far (the last is the largest and in use; earlier ones stay alive until destroy, as an
    /// earlier frame may still read them). A steady frame allocates nothing.
    lists: RefCell<Vec<Buffer>>,
    visits: RefCell<Vec<Buffer>>,
    /// Pixels of the last frame shaded per pixel (the valid prefix of the last `visits` buffer).
    last_pixels: Cell<u64>,
    stats: OnceCell<Buffer>,
    frames: Cell<u64>,
}

const STATS_LEN: usize = 5;

impl BlockerTiles {
    pub fn new(options: TileOptions) -> Self {
        Self {
            options,
            cull: OnceCell::new(),
            lists: RefCell::new(Vec::new()),
            visits: RefCell::new(Vec::new()),
            last_pixels: Cell::new(0),
            stats: OnceCell::new(),
            frames: Cell::new(0),
        }
    }

    fn stats(&self, gpu: &Gpu) -> Result<&Buffer> {
        if self.stats.get().is_none() {
            let b = gpu.upload_buffer("tile-stats", BufferDesc::gpu_only(0), &[0u32; STATS_LEN])?;
            if let Err(b) = self.stats.set(b) {
                gpu.destroy_buffer(b);
            }
        }
        self.stats.get().ok_or_else(|| GpuError::Other("internal: tile stats missing".into()))
    }

    fn cull_pipeline(&self, gpu: &Gpu) -> Result<&ComputePipeline> {
        if self.cull.get().is_none() {
            let p = gpu.create_compute_pipeline("blocker_tiles/cull.comp", &[])?;
            if let Err(p) = self.cull.set(p) {
                gpu.destroy_compute_pipeline(p);
            }
        }
        self.cull.get().ok_or_else(|| GpuError::Other("internal: tile cull pipeline missing".into()))
    }

    /// A buffer of at least `words` u32 in `all` (the last one when it is large enough).
    fn ensure(gpu: &Gpu, all: &RefCell<Vec<Buffer>>, name: &str, words: u64) -> Result<()> {
        let bytes = 4 * words.max(1);
        if all.borrow().last().is_some_and(|b| b.desc.size >= bytes) {
            return Ok(());
        }
        let b = gpu.create_buffer(name, BufferDesc::gpu_only(bytes))?;
        all.borrow_mut().push(b);
        Ok(())
    }

    /// Record the cull pass for a per-pixel `target` (with `tiles=on` and blockers), timed as `shade/<technique> tiles`
    /// (part of the technique's shade time),
    /// and return the bindings the technique's shade pass reads (`NodeVisits`, `TileNodes`; always given, so that
    /// every variant finds them). `sin_take_whole`: sin of the largest half-angle below which the technique's
    /// traversals may take a node whole (1 when that is π/2 or more).
    pub fn record(
        &self,
        rec: &mut Recorder,
        technique: &str,
        blockers: &BlockerResources,
        target: &ShadeTarget,
        sin_take_whole: f32,
    ) -> Result<TileBindings<'_>> {
        let gpu = rec.gpu();
        let (pixels, tiles_xy) = match target {
            ShadeTarget::Pixel { radiance, .. } => {
                let (w, h) = (radiance.desc.width, radiance.desc.height);
                (w as u64 * h as u64, Some((w, h, w.div_ceil(TILE_SIDE), h.div_ceil(TILE_SIDE))))
            }
            ShadeTarget::Vertex { .. } => (0, None),
        };
        let stride = self.options.capacity as u64 + 1;
        let tiles = tiles_xy.map_or(0, |(_, _, x, y)| x as u64 * y as u64);
        Self::ensure(gpu, &self.visits, "tile-node-visits", pixels)?;
        Self::ensure(gpu, &self.lists, "tile-lists", 1 + if self.options.on { tiles * stride } else { 0 })?;
        let stats = self.stats(gpu)?;
        if let (ShadeTarget::Pixel { gbuffer, .. }, Some((w, h, tx, ty))) = (target, tiles_xy) {
            self.last_pixels.set(pixels);
            if self.options.on && blockers.sphere_count > 0 {
                let pipeline = self.cull_pipeline(gpu)?;
                let lists = self.lists.borrow();
                let list = lists.last().ok_or_else(|| GpuError::Other("internal: tile lists missing".into()))?;
                rec.begin_pass(&format!("shade/{technique} tiles"));
                // The record stride, read by every pixel (tiles.glsl): written before the pass.
                rec.fill_buffer(list, stride as u32);
                rec.barrier();
                let sin_lod = self.options.lod_deg.to_radians().sin() as f32;
                let reach = self.options.reach as f32;
                let push: [u32; 7] = [
                    blockers.sphere_count,
                    sin_take_whole.to_bits(),
                    stride as u32,
                    w,
                    h,
                    sin_lod.to_bits(),
                    reach.to_bits(),
                ];
                rec.dispatch(
                    pipeline,
                    &[
                        Binding::storage_image("gbuf_position", &gbuffer.position),
                        Binding::storage_image("gbuf_normal", &gbuffer.normal),
                        Binding::buffer("BvhNodes", &blockers.bvh_nodes),
                        Binding::buffer("TileNodes", list),
                        Binding::buffer("TileStats", stats),
                    ],
                    bytemuck::cast_slice(&push),
                    [tx * TILE_SIDE, ty * TILE_SIDE, 1],
                )?;
                self.frames.set(self.frames.get() + 1);
            }
        }
        Ok(TileBindings { visits: self.visits.borrow(), lists: self.lists.borrow() })
    }

    /// The counts since the last call (the list counters restart; the per-pixel counts are the last frame's).
    pub fn counts(&self, gpu: &Gpu) -> Result<TileCounts> {
        let mut c = TileCounts::default();
        if let Some(stats) = self.stats.get() {
            let v: Vec<u32> = gpu.read_buffer(stats)?;
            let g = |i: usize| v.get(i).copied().unwrap_or(0) as u64;
            c.frames = self.frames.get();
            c.tiles = g(0);
            c.list_mean = if c.tiles > 0 { g(1) as f64 / c.tiles as f64 } else { 0.0 };
            c.list_max = g(2);
            c.fell_back = g(3);
            c.cull_tested_mean = if c.tiles > 0 { g(4) as f64 / c.tiles as f64 } else { 0.0 };
            gpu.copy_to_buffer(stats, bytemuck::cast_slice(&[0u32; STATS_LEN]))?;
            self.frames.set(0);
        }
        let pixels = self.last_pixels.get() as usize;
        if let Some(b) = self.visits.borrow().last() {
            if pixels > 0 {
                let v: Vec<u32> = gpu.read_buffer(b)?;
                // Background pixels hold u32::MAX (tiles.glsl): not shaded.
                let mut shaded: Vec<u32> = v.into_iter().take(pixels).filter(|&x| x != u32::MAX).collect();
                shaded.sort_unstable();
                if !shaded.is_empty() {
                    c.pixels = shaded.len() as u64;
                    c.pixel_mean = shaded.iter().map(|&x| x as f64).sum::<f64>() / shaded.len() as f64;
                    c.pixel_p99 = shaded[((shaded.len() - 1) as f64 * 0.99).round() as usize] as f64;
                    c.pixel_max = *shaded.last().unwrap_or(&0) as u64;
                }
            }
        }
        Ok(c)
    }

    pub fn destroy(self, gpu: &Gpu) {
        for b in self.lists.into_inner().into_iter().chain(self.visits.into_inner()).chain(self.stats.into_inner()) {
            gpu.destroy_buffer(b);
        }
        if let Some(p) = self.cull.into_inner() {
            gpu.destroy_compute_pipeline(p);
        }
    }
}

/// The buffers a shade pass binds ([`BlockerTiles::record`]), borrowed while it records.
pub struct TileBindings<'a> {
    visits: std::cell::Ref<'a, Vec<Buffer>>,
    lists: std::cell::Ref<'a, Vec<Buffer>>,
}

impl TileBindings<'_> {
    /// `NodeVisits` and `TileNodes` (both always made by `record`).
    pub fn bindings(&self) -> Result<[Binding<'_>; 2]> {
        match (self.visits.last(), self.lists.last()) {
            (Some(v), Some(l)) => Ok([Binding::buffer("NodeVisits", v), Binding::buffer("TileNodes", l)]),
            _ => Err(GpuError::Other("internal: tile buffers missing".into())),
        }
    }
}

/// sin T for a take-whole half-angle T (radians): 1 from π/2 on (the cull pass then opens a node only when the
/// whole tile lies inside it).
pub fn sin_take_whole(t: f64) -> f32 {
    if t >= std::f64::consts::FRAC_PI_2 {
        1.0
    } else {
        t.max(0.0).sin() as f32
    }
}

#[cfg(test)]
mod option_tests {
    /// The tile and reach options of every technique that has them refuse bad values with an error naming the key.
    #[test]
    fn bad_tile_options_are_errors_naming_the_key() {
        for t in ["isg", "lobes", "shexp"] {
            for (kv, key) in [
                ("tiles=maybe", "tiles"),
                ("tile_cap=0", "tile_cap"),
                ("tile_cap=5000", "tile_cap"),
                ("tile_lod=31", "tile_lod"),
                ("tile_lod=-1", "tile_lod"),
                ("reach=-1", "reach"),
                ("reach=nan", "reach"),
                ("reach=inf", "reach"),
            ] {
                let e = crate::passes::shade::parse_technique(&format!("{t}:{kv}")).err().map(|e| e.to_string());
                let e = e.unwrap_or_else(|| panic!("{t}:{kv} was accepted"));
                assert!(e.contains(key), "{t}:{kv}: {e}");
            }
            let (_, o) =
                crate::passes::shade::parse_technique(&format!("{t}:tiles=off,tile_cap=1,tile_lod=30,reach=8"))
                    .expect("valid tile options");
            let o = super::TileOptions::from_options(&o);
            assert_eq!(o, super::TileOptions { on: false, capacity: 1, lod_deg: 30.0, reach: 8.0 });
        }
    }
}

pub mod cpu {
    //! f64 twin of `blocker_tiles/cull.comp`'s list.

    /// A BVH node as the twin reads it: centre, radius, children (`None` for a leaf).
    #[derive(Clone, Copy, Debug)]
    pub struct Node {
        pub center: [f64; 3],
        pub radius: f64,
        pub children: Option<(u32, u32)>,
    }

    /// The tile's bounds: the bounding sphere of its receivers' positions and the cone of their normals.
    #[derive(Clone, Copy, Debug)]
    pub struct TileBounds {
        pub center: [f64; 3],
        pub radius: f64,
        pub axis: [f64; 3],
        pub half_angle: f64,
    }

    fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }

    /// The bounds of receivers (position, unit normal) as the shader forms them: the AABB's centre and half
    /// diagonal, the normalized sum of the normals and the widest angle from it. `None` without receivers.
    pub fn bounds(receivers: &[([f64; 3], [f64; 3])]) -> Option<TileBounds> {
        let (first, _) = receivers.first()?;
        let (mut lo, mut hi, mut sum) = (*first, *first, [0.0; 3]);
        for (p, n) in receivers {
            for i in 0..3 {
                lo[i] = lo[i].min(p[i]);
                hi[i] = hi[i].max(p[i]);
                sum[i] += n[i];
            }
        }
        let center = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
        let radius = 0.5 * dot(sub(hi, lo), sub(hi, lo)).sqrt();
        let len = dot(sum, sum).sqrt();
        if len <= 1e-6 {
            return Some(TileBounds { center, radius, axis: [0.0, 0.0, 1.0], half_angle: std::f64::consts::PI });
        }
        let axis = [sum[0] / len, sum[1] / len, sum[2] / len];
        let min_cos = receivers.iter().map(|(_, n)| dot(*n, axis)).fold(1.0, f64::min);
        Some(TileBounds { center, radius, axis, half_angle: min_cos.clamp(-1.0, 1.0).acos() })
    }

    /// Whether node (c, r) lies below the tangent plane of every receiver within the bounds.
    pub fn culled(b: &TileBounds, c: [f64; 3], r: f64) -> bool {
        let d = sub(c, b.center);
        let dl = dot(d, d).sqrt();
        let ang = if dl > 0.0 { (dot(d, b.axis) / dl).clamp(-1.0, 1.0).acos() } else { 0.0 };
        let reach = dl * (ang - b.half_angle).clamp(0.0, std::f64::consts::PI).cos() + b.radius;
        reach + r <= 0.0
    }

    /// Whether node (c, r) subtends at least asin(sin_t) from every point within the bounds.
    pub fn opened(b: &TileBounds, c: [f64; 3], r: f64, sin_t: f64) -> bool {
        let d = sub(c, b.center);
        r >= sin_t * (dot(d, d).sqrt() + b.radius)
    }

    /// Whether node (c, r) subtends less than asin(sin_lod) from every point within the bounds (the level of
    /// detail's "take whole").
    pub fn taken_whole(b: &TileBounds, c: [f64; 3], r: f64, sin_lod: f64) -> bool {
        let d = sub(c, b.center);
        let dl = dot(d, d).sqrt();
        dl > b.radius && r < sin_lod * (dl - b.radius)
    }

    /// A list entry's "take whole" mark (BVH_TILE_WHOLE in shaders-glsl/common/bvh.glsl).
    pub const WHOLE: u32 = 0x8000_0000;

    /// The tile's start list (root 0), depth first, left first; `None` when it would exceed `capacity`. With
    /// `sin_lod` > 0, internal nodes subtending less than its angle from the whole tile are listed marked
    /// [`WHOLE`].
    pub fn tile_list(nodes: &[Node], b: &TileBounds, sin_t: f64, sin_lod: f64, capacity: usize) -> Option<Vec<u32>> {
        let mut out = Vec::new();
        let mut stack = if nodes.is_empty() { vec![] } else { vec![0u32] };
        while let Some(v) = stack.pop() {
            let n = nodes[v as usize];
            if culled(b, n.center, n.radius) {
                continue;
            }
            match n.children {
                Some(_) if taken_whole(b, n.center, n.radius, sin_lod) => {
                    if out.len() >= capacity {
                        return None;
                    }
                    out.push(v | WHOLE);
                }
                Some((l, r)) if opened(b, n.center, n.radius, sin_t) => {
                    stack.push(r);
                    stack.push(l);
                }
                _ => {
                    if out.len() >= capacity {
                        return None;
                    }
                    out.push(v);
                }
            }
        }
        Some(out)
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        fn leaf(c: [f64; 3], r: f64) -> Node {
            Node { center: c, radius: r, children: None }
        }

        /// A ground tile facing up: a blocker below the ground is culled, one above is listed; a near, large node
        /// is opened and a far, small one is kept whole; past the capacity the list is refused.
        #[test]
        fn the_list_culls_below_the_tangent_planes_and_opens_what_every_receiver_sees_large() {
            let b = bounds(&[([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]), ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])]).unwrap();
            assert!((b.radius - 0.5).abs() < 1e-12 && b.half_angle.abs() < 1e-12);
            assert!(culled(&b, [0.0, -2.0, 0.0], 1.0));
            assert!(!culled(&b, [0.0, -0.5, 0.0], 1.0), "straddles the ground");
            assert!(!culled(&b, [5.0, 1.0, 0.0], 0.1));
            // Root 0 = {1, 2}; 1 = {3, 4} near and large; 2 far and small (a leaf-like internal node {5, 6}).
            let nodes = vec![
                Node { center: [0.0, 1.0, 0.0], radius: 20.0, children: Some((1, 2)) },
                Node { center: [0.5, 1.0, 0.0], radius: 1.4, children: Some((3, 4)) },
                Node { center: [15.0, 1.0, 0.0], radius: 0.2, children: Some((5, 6)) },
                leaf([0.5, 1.0, 0.0], 0.4),
                leaf([0.5, -3.0, 0.0], 0.5),
                leaf([15.0, 1.0, 0.0], 0.1),
                leaf([15.2, 1.0, 0.0], 0.1),
            ];
            let sin_t = 0.1f64;
            assert_eq!(tile_list(&nodes, &b, sin_t, 0.0, 8), Some(vec![3, 2]), "4 culled, 1 and the root opened");
            assert_eq!(tile_list(&nodes, &b, sin_t, 0.0, 1), None);
            assert_eq!(tile_list(&nodes, &b, 1.0, 0.0, 8), Some(vec![1, 2]), "only the root holds the whole tile");
            // A level of detail of 5°: node 2 (0.2 at 14.5 from the tile) is taken whole, node 1 (around it) not.
            let lod = 5f64.to_radians().sin();
            assert_eq!(tile_list(&nodes, &b, 1.0, lod, 8), Some(vec![1, 2 | WHOLE]));
            assert_eq!(tile_list(&nodes, &b, sin_t, lod, 8), Some(vec![3, 2 | WHOLE]));
        }

        /// Spread normals (opposite faces in one tile) cull nothing above either face.
        #[test]
        fn opposite_normals_cull_only_what_is_below_both() {
            let b = bounds(&[([0.0, 0.0, 0.0], [0.0, 1.0, 0.0]), ([0.0, 0.0, 0.0], [0.0, -1.0, 0.0])]).unwrap();
            assert!(b.half_angle >= std::f64::consts::PI - 1e-9);
            assert!(!culled(&b, [0.0, -2.0, 0.0], 1.0) && !culled(&b, [0.0, 2.0, 0.0], 1.0));
        }
    }
}
