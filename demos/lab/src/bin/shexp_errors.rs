//! `shexp_errors`: SHEXP's error decomposition (Ren et al. 2006, Fig. 7) per SH order, on one frame of a
//! scene, computed in f64 at the G-buffer's receivers with the technique's twin
//! (engine::passes::shade::shexp::cpu). Irradiance only (the shadowed diffuse term, ρ = 1), each stage
//! replacing one more exact quantity by SHEXP's approximation:
//!
//! - **E_true**: 1/π ∫ L(ω) max(0, n·ω) V(ω) dω (the diffuse radiance for ρ = 1) with the full environment and the sphere-proxy visibility V (rays
//!   against the blocker spheres after the §6.2 rules, and the plane blockers: the sphere reference's model);
//! - **lighting**: the same with L_n, the environment's windowed order-n projection (`E_L`);
//! - **visibility truncation**: L_n · (H * V_n), V_n the order-n projection of V (`E_V`);
//! - **log space**: V_n replaced by the exact exp*(Σ f_i) = exp(M_f) 1 of the blockers' summed order-n circle
//!   logs (planes and
//!   `large=product` spheres multiplied in as projected, as the technique does) (`E_log`);
//! - **exp method**: exact exp* replaced by HYB, OL or PS*-2 — the twin's whole per-receiver pipeline
//!   (leaves only: no cut, no clusters).
//!
//! **Spherical lights** (the scene's, and with `--env-lights` the environment's bright regions taken out as
//! lights with the residual as the environment, as `shexp:env_lights=on` shades): each light's true term is
//! 1/π ∫_cap L max(0, n·ω) V(ω) dω by `--light-samples` stratified directions over its cap; the technique
//! takes the exact unshadowed term times the SH visibility ratio (C·(H * g))/(C·H), C the light cap's windowed
//! projection, so a light has no representation error of its own: from the second stage on its term carries
//! the stage's visibility g. The table splits the error into the environment's part and each light's.
//!
//! Every integral is a sum over the texel centres of the environment box-filtered down to about 256 columns
//! (solid-angle weights). Output: a table (relative RMSE % against E_true, and against E_L: the visibility
//! error alone under the same order-n lighting), `errors.csv` and `errors.svg` in `--out`.
//!
//! `cargo run --release -p lab --bin shexp_errors -- --scene bunny --orders 3,4,5,6`

use anyhow::{bail, Context, Result};
use clap::Parser;
use engine::blockers::geom::blocker_for_receiver;
use engine::blockers::{BlockerPlane, Sphere};
use engine::gpu::{Gpu, GpuDesc};
use engine::math::envmap::{texel_solid_angle, LatLongMap};
use engine::math::sh::{circle_visibility_zonal, dot, eval_basis, irradiance_weighting, project_latlong, zh_rotate};
use engine::math::shading::shading_normals;
use engine::math::shexp::exp_exact;
use engine::passes::shade::shexp::cpu::Twin;
use engine::passes::shade::shexp::{ExpChoice, ShexpOptions};
use engine::renderer::{RenderSettings, Renderer};
use glam::DVec3;
use lab::metrics::sqrt_ratio;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "shexp_errors", about = "SHEXP's error decomposition per SH order (f64, at the G-buffer's receivers)")]
struct Args {
    /// Scene (the registry in demos/scenes).
    #[arg(long, default_value = "bunny", value_parser = scenes::value_parser())]
    scene: String,
    /// Environment map (.exr or .hdr) instead of the scene's.
    #[arg(long)]
    env: Option<PathBuf>,
    /// The smooth sky gradient of the `sphere` scene (a low-frequency environment) instead of the scene's.
    #[arg(long, conflicts_with = "env")]
    smooth_sky: bool,
    /// SH orders (3..=8), comma-separated.
    #[arg(long, default_value = "3,4,5,6", value_delimiter = ',')]
    orders: Vec<usize>,
    #[arg(long, default_value_t = 80)]
    width: u32,
    #[arg(long, default_value_t = 60)]
    height: u32,
    /// Use every STEP-th covered pixel (or vertex).
    #[arg(long, default_value_t = 2)]
    step: usize,
    /// Receivers are the scene's vertices (world space, after the frame's skinning; normals as the per-vertex
    /// target turns them: towards the camera) instead of the covered pixels.
    #[arg(long)]
    per_vertex: bool,
    #[arg(long, default_value = "out/shexp_errors")]
    out: PathBuf,
    /// Split the environment into lights and a residual (the scene's environment-lights settings), as
    /// `shexp:env_lights=on` shades it.
    #[arg(long)]
    env_lights: bool,
    /// Directions per light cap for the lights' true terms.
    #[arg(long, default_value_t = 256)]
    light_samples: usize,
}

/// A light as the stages see it: world centre, radius and radiance.
struct Light {
    center: DVec3,
    radius: f64,
    radiance: [f64; 3],
}

/// `count` directions spread evenly over the cap about `axis` of half-angle with cosine `cos_alpha` (a spiral
/// uniform in solid angle), and the solid angle each stands for.
fn cap_directions(axis: DVec3, cos_alpha: f64, count: usize) -> (Vec<DVec3>, f64) {
    let e1 = axis.any_orthonormal_vector();
    let e2 = axis.cross(e1);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let dirs = (0..count)
        .map(|k| {
            let z = 1.0 - (1.0 - cos_alpha) * (k as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * k as f64;
            z * axis + r * (phi.cos() * e1 + phi.sin() * e2)
        })
        .collect();
    (dirs, 2.0 * std::f64::consts::PI * (1.0 - cos_alpha) / count as f64)
}

/// The light's cap seen from p: (axis, cos α), `None` when p is inside it.
fn light_cap(p: DVec3, l: &Light) -> Option<(DVec3, f64)> {
    let d = l.center - p;
    let dist = d.length();
    (dist > l.radius).then(|| (d / dist, ((dist - l.radius) * (dist + l.radius)).sqrt() / dist))
}

/// The integration grid: texel-centre directions and solid angles of the environment averaged down.
struct Grid {
    dirs: Vec<DVec3>,
    weights: Vec<f64>,
    radiance: Vec<[f64; 3]>,
}

/// The integration grid's smallest width: the map is box-filtered down by the largest factor that divides both
/// its sides and keeps at least this many columns.
const GRID_MIN_W: usize = 256;

/// The environment on a lat-long grid of about GRID_MIN_W columns, as texel-centre directions, solid angles and
/// radiance: a larger map averaged down (solid-angle weighted, `LatLongMap::downsample`: the integral is kept), a
/// smaller one sampled bilinearly at the grid's centres (as the GPU's sampler reads it), so that visibility is
/// resolved as finely either way.
fn grid_of(env: &LatLongMap) -> Grid {
    let coarse = if env.width < GRID_MIN_W {
        let mut g = LatLongMap::constant(GRID_MIN_W, GRID_MIN_W / 2, [0.0; 3]);
        for r in 0..g.height {
            for c in 0..g.width {
                g.texels[r * g.width + c] = env.lookup_bilinear(g.texel_direction(c, r)).map(|v| v as f32);
            }
        }
        g
    } else {
        let factor = (1..=env.width / GRID_MIN_W)
            .rev()
            .find(|f| env.width.is_multiple_of(*f) && env.height.is_multiple_of(*f))
            .unwrap_or(1);
        env.downsample(factor)
    };
    let mut g = Grid { dirs: Vec::new(), weights: Vec::new(), radiance: Vec::new() };
    for r in 0..coarse.height {
        for c in 0..coarse.width {
            g.dirs.push(DVec3::from_array(coarse.texel_direction(c, r)));
            g.weights.push(texel_solid_angle(r, coarse.width, coarse.height));
            g.radiance.push(coarse.texel(c, r).map(f64::from));
        }
    }
    g
}

/// Per-order data on the grid: the basis at every direction and the windowed lighting L_n there.
struct OrderGrid {
    n: usize,
    basis: Vec<Vec<f64>>,
    lighting: [Vec<f64>; 3],
    lighting_at: Vec<[f64; 3]>,
}

fn order_grid(grid: &Grid, env: &LatLongMap, o: &ShexpOptions) -> OrderGrid {
    let n = o.order;
    let lighting = project_latlong(env, n, o.window());
    let basis: Vec<Vec<f64>> = grid
        .dirs
        .iter()
        .map(|d| {
            let mut y = vec![0.0; n * n];
            eval_basis(n, d.to_array(), &mut y);
            y
        })
        .collect();
    let lighting_at =
        basis.iter().map(|y| [0, 1, 2].map(|c| y.iter().zip(&lighting[c]).map(|(a, b)| a * b).sum())).collect();
    OrderGrid { n, basis, lighting, lighting_at }
}

/// The sphere-proxy visibility of every grid direction at receiver (p, n).
fn visibility(grid: &Grid, p: DVec3, n: DVec3, spheres: &[Sphere], planes: &[BlockerPlane]) -> Vec<bool> {
    let blockers: Vec<Sphere> = spheres.iter().filter_map(|s| blocker_for_receiver(p, n, s)).collect();
    grid.dirs
        .iter()
        .map(|d| {
            d.dot(n) > 0.0
                && !blockers.iter().any(|s| s.ray_hits(p, *d))
                && !planes.iter().any(|pl| pl.blocks_direction(p, *d))
        })
        .collect()
}

/// Relative RMSE of `a` against `b` over every receiver and channel.
fn rel_rmse(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            num += (x[c] - y[c]).powi(2);
            den += y[c] * y[c];
        }
    }
    sqrt_ratio(num, den)
}

/// The stages at one order, one row per receiver: E_L, E_V, E_log, HYB, OL, PS*-2.
const STAGES: [&str; 6] = ["lighting L_n", "+ visibility truncation", "+ log space", "+ HYB", "+ OL", "+ PS*-2"];

fn main() {
    scenes::init_logging();
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let args = Args::parse();
    for &n in &args.orders {
        if !(3..=8).contains(&n) {
            bail!("--orders: {n} is not an SH order in 3..=8");
        }
    }
    if args.step == 0 || args.width == 0 || args.height == 0 {
        bail!("--step, --width and --height must be positive");
    }
    let mut scene = scenes::build(&args.scene, args.env.as_deref())?;
    if args.smooth_sky {
        scene.environment = scenes::sphere::sky();
    }
    let gpu = Gpu::new(&GpuDesc::default()).context("a Vulkan device")?;
    let settings =
        RenderSettings { width: args.width, height: args.height, technique: "none".into(), ..Default::default() };
    let mut r = Renderer::new(&gpu, &scene, settings).context("renderer")?;
    let per_vertex = args.per_vertex;
    let read = r.render(&gpu).map_err(anyhow::Error::from).and_then(|_| {
        let (pos, nrm) = if per_vertex {
            let mut v: Vec<engine::resources::layout::GpuVertex> = gpu.read_buffer(&r.scene.geometry.world_vertices)?;
            v.truncate(r.scene.geometry.vertex_count as usize);
            let pos: Vec<f32> = v.iter().flat_map(|x| [x.position[0], x.position[1], x.position[2], 1.0]).collect();
            let nrm: Vec<f32> = v.iter().flat_map(|x| [x.normal[0], x.normal[1], x.normal[2], 0.0]).collect();
            (pos, nrm)
        } else {
            (gpu.read_image_rgba32f(&r.gbuffer.position)?, gpu.read_image_rgba32f(&r.gbuffer.normal)?)
        };
        let mut spheres = gpu.read_buffer::<[f32; 4]>(&r.scene.blockers.spheres)?;
        spheres.truncate(r.scene.blockers.sphere_count as usize);
        Ok((pos, nrm, spheres))
    });
    r.destroy(&gpu);
    let (pos, nrm, spheres) = read?;
    gpu.shutdown().context("GPU teardown")?;
    let spheres: Vec<Sphere> = spheres.iter().map(|a| Sphere::from_array(a.map(f64::from))).collect();
    let planes = engine::resources::blockers::gather_planes(&scene).context("the scene's plane blockers")?;
    let receivers: Vec<(DVec3, DVec3)> = pos
        .chunks_exact(4)
        .zip(nrm.chunks_exact(4))
        .filter(|(p, _)| p[3] >= 0.5)
        .step_by(args.step)
        .map(|(p, n)| {
            let v = |a: &[f32]| DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64);
            let (p, n) = (v(p), v(n).normalize());
            // Per vertex: the normal target_vertex.glsl shades with (shading_normals with the vertex normal as
            // both normals: two-sided, towards the camera).
            if per_vertex {
                let view = (scene.camera.eye.as_dvec3() - p).normalize();
                let (s, _) = shading_normals(n.to_array(), n.to_array(), view.to_array());
                (p, DVec3::from_array(s).normalize())
            } else {
                (p, n)
            }
        })
        .filter(|(p, n)| p.is_finite() && n.is_finite())
        .collect();
    if receivers.is_empty() {
        bail!("no covered pixel in the frame");
    }
    if scene.environment.width == 0 || scene.environment.height == 0 {
        bail!("the environment map is empty");
    }
    // The environment the technique shades (scaled by the scene's intensity), and its lights.
    let scaled = LatLongMap {
        width: scene.environment.width,
        height: scene.environment.height,
        texels: scene.environment.texels.iter().map(|t| t.map(|c| c * scene.environment_intensity)).collect(),
    };
    let mut lights: Vec<Light> = scene
        .lights
        .iter()
        .map(|l| Light {
            center: l.center.as_dvec3(),
            radius: l.radius as f64,
            radiance: l.radiance.as_dvec3().to_array(),
        })
        .collect();
    let env = if args.env_lights {
        let d = engine::math::env_lights::decompose(&scaled, &scene.env_lights);
        let (lo, hi) = scene.bounds();
        let (center, radius) = (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3));
        for l in engine::resources::environment::env_sphere_lights(&d, center, radius) {
            lights.push(Light {
                center: l.center.as_dvec3(),
                radius: l.radius as f64,
                radiance: l.radiance.as_dvec3().to_array(),
            });
        }
        eprintln!("environment lights: {} light(s), {:.1} % of the power", d.lights.len(), 100.0 * d.share);
        d.residual(&scaled)
    } else {
        scaled
    };
    let env = &env;
    let grid = grid_of(env);
    eprintln!(
        "{}: {} receivers, {} spheres, {} planes, {} directions, {} lights; true visibility...",
        args.scene,
        receivers.len(),
        spheres.len(),
        planes.len(),
        grid.dirs.len(),
        lights.len()
    );
    let vis: Vec<Vec<bool>> = receivers.iter().map(|(p, n)| visibility(&grid, *p, *n, &spheres, &planes)).collect();
    let truth: Vec<[f64; 3]> = receivers
        .iter()
        .zip(&vis)
        .map(|((_, n), v)| {
            let mut e = [0.0; 3];
            for (k, d) in grid.dirs.iter().enumerate() {
                if v[k] {
                    let w = grid.weights[k] * d.dot(*n) / std::f64::consts::PI;
                    (0..3).for_each(|c| e[c] += w * grid.radiance[k][c]);
                }
            }
            e
        })
        .collect();

    // Each light's true term and its exact unshadowed term, per receiver (1/π folded in: ρ = 1).
    let light_truth: Vec<Vec<([f64; 3], [f64; 3])>> = receivers
        .iter()
        .map(|(p, n)| {
            let blockers: Vec<Sphere> = spheres.iter().filter_map(|s| blocker_for_receiver(*p, *n, s)).collect();
            lights
                .iter()
                .map(|l| {
                    let Some((axis, cos_alpha)) = light_cap(*p, l) else { return ([0.0; 3], [0.0; 3]) };
                    let (dirs, w) = cap_directions(axis, cos_alpha, args.light_samples.max(1));
                    let mut e = 0.0;
                    for d in dirs {
                        let c = d.dot(*n);
                        if c > 0.0
                            && !blockers.iter().any(|s| s.ray_hits(*p, d))
                            && !planes.iter().any(|pl| pl.blocks_direction(*p, d))
                        {
                            e += w * c / std::f64::consts::PI;
                        }
                    }
                    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
                    let free = engine::math::sphere_light::cap_clamped_cosine(axis.dot(*n), sin_alpha, cos_alpha)
                        / std::f64::consts::PI;
                    (l.radiance.map(|x| x * e), l.radiance.map(|x| x * free))
                })
                .collect()
        })
        .collect();
    let truth_env = truth.clone();
    let truth: Vec<[f64; 3]> = truth
        .iter()
        .zip(&light_truth)
        .map(|(e, ls)| [0, 1, 2].map(|c| e[c] + ls.iter().map(|l| l.0[c]).sum::<f64>()))
        .collect();

    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut csv = String::from("order,stage,rel_rmse_vs_true,rel_rmse_vs_lighting_n\n");
    let mut table = vec![];
    let mut parts: Vec<(usize, Vec<f64>, Vec<Vec<f64>>)> = vec![];
    for &order in &args.orders {
        eprintln!("order {order}...");
        // The §6.2 rule without the α scale: the one the true visibility's rays apply (as the reference's).
        let base = ShexpOptions { order, alpha_scale: false, ..ShexpOptions::default() };
        let og = order_grid(&grid, env, &base);
        let twins: Vec<Twin> = [ExpChoice::Hyb, ExpChoice::Ol, ExpChoice::PsStar]
            .into_iter()
            .map(|exp| Twin::new(&ShexpOptions { exp, ps_degree: 2, ..base.clone() }, env).map_err(anyhow::Error::msg))
            .collect::<Result<_>>()?;
        // exp*(f) = exp(M_f) 1, M_f the product matrix (SHEXP Eqs. 26–29): the exponential the circle logs
        // invert (engine::math::shexp::exp_exact, by eigen decomposition in f64).
        let exact_exp = |f: &[f64]| exp_exact(&twins[0].tensor, f);
        let mut stages: Vec<Vec<[f64; 3]>> = vec![Vec::new(); STAGES.len()];
        // The environment's part alone and each light's term alone, per stage.
        let mut env_stages: Vec<Vec<[f64; 3]>> = vec![Vec::new(); STAGES.len()];
        let mut light_stages: Vec<Vec<Vec<[f64; 3]>>> = vec![vec![Vec::new(); lights.len()]; STAGES.len()];
        // How far past OL's fitted range the logs go (OL clamps its (a, b) at the table's end).
        let (mut beyond, mut largest) = (0usize, 0.0f64);
        let ol_end = twins[1].ol.norms.last().copied().unwrap_or(0.0);
        for (receiver, ((p, n), v)) in receivers.iter().zip(&vis).enumerate() {
            let (f, _) = twins[0].log_visibility(*p, *n, &spheres);
            let norm = f[1..].iter().map(|x| x * x).sum::<f64>().sqrt();
            largest = largest.max(norm);
            beyond += (norm > ol_end) as usize;
            let mut e_l = [0.0; 3];
            let mut v_n = vec![0.0; og.n * og.n];
            for (k, d) in grid.dirs.iter().enumerate() {
                if v[k] {
                    let w = grid.weights[k];
                    let c = d.dot(*n) / std::f64::consts::PI;
                    (0..3).for_each(|ch| e_l[ch] += w * c * og.lighting_at[k][ch]);
                    v_n.iter_mut().zip(&og.basis[k]).for_each(|(a, b)| *a += w * b);
                }
            }
            let h = irradiance_weighting(og.n, n.to_array());
            let window = base.window();
            // The lights under visibility g: each its exact unshadowed term times (C·(H * g))/(C·H).
            let light_terms = |g: Option<&[f64]>| -> Vec<[f64; 3]> {
                let pv = g.map(|g| twins[0].tensor.product(&h, g));
                lights
                    .iter()
                    .enumerate()
                    .map(|(j, l)| {
                        let (exact, free) = light_truth[receiver][j];
                        let Some(g_pv) = &pv else { return exact };
                        let Some((axis, cos_alpha)) = light_cap(*p, l) else { return free };
                        // The cap's zonal projection: the whole sphere's minus the circle's visibility, windowed.
                        let mut zonal = circle_visibility_zonal(og.n, cos_alpha.clamp(-1.0, 1.0).acos());
                        let factors = window.band_factors(og.n);
                        zonal.iter_mut().enumerate().for_each(|(k, z)| {
                            *z = (if k == 0 { (4.0 * std::f64::consts::PI).sqrt() } else { 0.0 }) - *z;
                            *z *= factors[k];
                        });
                        let cap = zh_rotate(&zonal, axis.to_array());
                        let (num, den) = (dot(&cap, g_pv), dot(&cap, &h));
                        let v = if den > 1e-12 { (num / den).clamp(0.0, 1.0) } else { 1.0 };
                        free.map(|x| x * v)
                    })
                    .collect()
            };
            let shade = |g: &[f64]| -> [f64; 3] {
                let pv = twins[0].tensor.product(&h, g);
                [0, 1, 2].map(|c| dot(&og.lighting[c], &pv))
            };
            let mut push = |s: usize, e: [f64; 3], ls: Vec<[f64; 3]>| {
                stages[s].push([0, 1, 2].map(|c| e[c] + ls.iter().map(|l| l[c]).sum::<f64>()));
                env_stages[s].push(e);
                for (j, l) in ls.into_iter().enumerate() {
                    light_stages[s][j].push(l);
                }
            };
            push(0, e_l, light_terms(None));
            push(1, shade(&v_n), light_terms(Some(&v_n)));
            let (g, _) = twins[0].visibility_with_exp(*p, *n, &spheres, &planes, &exact_exp);
            push(2, shade(&g), light_terms(Some(&g)));
            for (t, twin) in twins.iter().enumerate() {
                let (g, _) = twin.visibility(*p, *n, &spheres, &planes);
                push(3 + t, shade(&g), light_terms(Some(&g)));
            }
        }
        let mut row = vec![];
        for (s, name) in STAGES.iter().enumerate() {
            let vs_true = rel_rmse(&stages[s], &truth);
            let vs_l = rel_rmse(&stages[s], &stages[0]);
            csv.push_str(&format!("{order},{name},{vs_true:.6},{vs_l:.6}\n"));
            row.push((vs_true, vs_l));
        }
        let exp_vs_exact: Vec<f64> = (3..6).map(|s| rel_rmse(&stages[s], &stages[2])).collect();
        // The parts at each stage: the environment's against its own truth, each light's against its own.
        let env_part: Vec<f64> = (0..STAGES.len()).map(|s| rel_rmse(&env_stages[s], &truth_env)).collect();
        let light_parts: Vec<Vec<f64>> = (0..lights.len())
            .map(|j| {
                let t: Vec<[f64; 3]> = light_truth.iter().map(|l| l[j].0).collect();
                (0..STAGES.len()).map(|s| rel_rmse(&light_stages[s][j], &t)).collect()
            })
            .collect();
        parts.push((order, env_part, light_parts));
        eprintln!(
            "order {order}: largest ‖f̂‖ {largest:.1}; {beyond} of {} receivers past OL's table end ({ol_end:.2})",
            receivers.len()
        );
        table.push((order, row, exp_vs_exact));
    }
    std::fs::write(args.out.join("errors.csv"), csv).context("writing errors.csv")?;

    println!(
        "SHEXP error decomposition, {}{} ({}, {} receivers), relative RMSE % of the shadowed irradiance",
        args.scene,
        if args.smooth_sky { " under the smooth sky" } else { "" },
        if args.per_vertex { "per vertex".to_string() } else { format!("{}x{} per pixel", args.width, args.height) },
        receivers.len()
    );
    println!("against E_true (full lighting, true sphere visibility); in parentheses against E_L (the same order-n lighting, true visibility: visibility error alone):");
    println!();
    println!("| n | {} |", STAGES.join(" | "));
    println!("|---|{}", "---|".repeat(STAGES.len()));
    for (order, row, _) in &table {
        let cells: Vec<String> = row
            .iter()
            .enumerate()
            .map(
                |(s, (t, l))| {
                    if s == 0 {
                        format!("{:.2}", 100.0 * t)
                    } else {
                        format!("{:.2} ({:.2})", 100.0 * t, 100.0 * l)
                    }
                },
            )
            .collect();
        println!("| {order} | {} |", cells.join(" | "));
    }
    if !lights.is_empty() {
        println!();
        println!(
            "The parts: the environment's term against its own truth, then each light's (relative RMSE %; the \
             light's power share of the truth in parentheses):"
        );
        println!();
        let total: f64 = truth.iter().map(|t| t[0] + t[1] + t[2]).sum();
        let share =
            |j: usize| 100.0 * light_truth.iter().map(|l| l[j].0.iter().sum::<f64>()).sum::<f64>() / total.max(1e-300);
        println!("| n | part | {} |", STAGES.join(" | "));
        println!("|---|---|{}", "---|".repeat(STAGES.len()));
        for (order, env_part, light_parts) in &parts {
            let cells = |v: &[f64]| v.iter().map(|x| format!("{:.2}", 100.0 * x)).collect::<Vec<_>>().join(" | ");
            let env_share = 100.0 * truth_env.iter().map(|t| t.iter().sum::<f64>()).sum::<f64>() / total.max(1e-300);
            println!("| {order} | environment ({env_share:.0} %) | {} |", cells(env_part));
            for (j, lp) in light_parts.iter().enumerate() {
                println!("| {order} | light {j} ({:.0} %) | {} |", share(j), cells(lp));
            }
        }
    }
    println!();
    println!("Exp method against the exact exp* of the same log vector (relative RMSE %):");
    println!();
    println!("| n | HYB | OL | PS*-2 |");
    println!("|---|---|---|---|");
    for (order, _, e) in &table {
        println!("| {order} | {:.2} | {:.2} | {:.2} |", 100.0 * e[0], 100.0 * e[1], 100.0 * e[2]);
    }
    let mut plot = plot::Plot::new(format!("SHEXP error decomposition, {}", args.scene))
        .x_axis("SH order n", plot::Scale::Linear)
        .y_axis("relative RMSE % vs E_true", plot::Scale::Linear)
        .legend(plot::Legend::TopRight);
    for (s, name) in STAGES.iter().enumerate() {
        plot = plot.line(*name, table.iter().map(|(o, row, _)| (*o as f64, 100.0 * row[s].0)).collect());
    }
    std::fs::write(args.out.join("errors.svg"), plot.to_svg()).context("writing errors.svg")?;
    eprintln!("wrote {}/errors.csv and errors.svg", args.out.display());
    Ok(())
}
