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
//! Every integral is a sum over the texel centres of the environment box-filtered down to about 256 columns
//! (solid-angle weights). Output: a table (relative RMSE % against E_true, and against E_L: the visibility
//! error alone under the same order-n lighting), `errors.csv` and `errors.svg` in `--out`.
//!
//! `cargo run --release -p demos --bin shexp_errors -- --scene bunny --orders 3,4,5,6`

use anyhow::{bail, Context, Result};
use clap::Parser;
use engine::blockers::geom::blocker_for_receiver;
use engine::blockers::{BlockerPlane, Sphere};
use engine::gpu::{Gpu, GpuDesc};
use engine::math::envmap::{texel_solid_angle, LatLongMap};
use engine::math::sh::{dot, eval_basis, irradiance_weighting, project_latlong};
use engine::math::shading::shading_normals;
use engine::math::shexp::exp_exact;
use engine::metrics::sqrt_ratio;
use engine::passes::shade::shexp::cpu::Twin;
use engine::passes::shade::shexp::{ExpChoice, ShexpOptions};
use engine::renderer::{RenderSettings, Renderer};
use glam::DVec3;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(name = "shexp_errors", about = "SHEXP's error decomposition per SH order (f64, at the G-buffer's receivers)")]
struct Args {
    /// Scene (the registry in demos/src/scenes).
    #[arg(long, default_value = "bunny", value_parser = demos::scenes::value_parser())]
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
    demos::init_logging();
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
    let mut scene = demos::scenes::build(&args.scene, args.env.as_deref())?;
    if args.smooth_sky {
        scene.environment = demos::scenes::sphere::sky();
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
    let env = &scene.environment;
    if env.width == 0 || env.height == 0 {
        bail!("the environment map is empty");
    }
    let grid = grid_of(env);
    eprintln!(
        "{}: {} receivers, {} spheres, {} planes, {} directions; true visibility...",
        args.scene,
        receivers.len(),
        spheres.len(),
        planes.len(),
        grid.dirs.len()
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

    std::fs::create_dir_all(&args.out).with_context(|| format!("creating {}", args.out.display()))?;
    let mut csv = String::from("order,stage,rel_rmse_vs_true,rel_rmse_vs_lighting_n\n");
    let mut table = vec![];
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
        // How far past OL's fitted range the logs go (OL clamps its (a, b) at the table's end).
        let (mut beyond, mut largest) = (0usize, 0.0f64);
        let ol_end = twins[1].ol.norms.last().copied().unwrap_or(0.0);
        for ((p, n), v) in receivers.iter().zip(&vis) {
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
            let shade = |g: &[f64]| -> [f64; 3] {
                let pv = twins[0].tensor.product(&h, g);
                [0, 1, 2].map(|c| dot(&og.lighting[c], &pv))
            };
            stages[0].push(e_l);
            stages[1].push(shade(&v_n));
            let (g, _) = twins[0].visibility_with_exp(*p, *n, &spheres, &planes, &exact_exp);
            stages[2].push(shade(&g));
            for (t, twin) in twins.iter().enumerate() {
                let (g, _) = twin.visibility(*p, *n, &spheres, &planes);
                stages[3 + t].push(shade(&g));
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
