//! `bvh_bench`: GPU build time of the blocker BVH (the `blocker_bvh` pass) for N = 64 … 16384 random
//! spheres, from timestamp queries (median of `--frames` builds after one warm-up), and optionally the
//! bunny's sphere-set fit time and E at 64 spheres. Reported, not asserted.
//!
//! `cargo run --release -p lab --bin bvh_bench [-- --frames 9 --max 16384 --fit]`

use anyhow::Context;
use clap::Parser;
use engine::blockers::fit::{evaluate, fit_spheres, FitSettings};
use engine::gpu::{BufferDesc, Gpu, GpuDesc};
use engine::math::rng::Pcg32;
use engine::passes::blocker_bvh::{node_buffer_size, BlockerBvhPass};

#[derive(Parser, Debug)]
#[command(about = "GPU sphere-BVH build times (timestamp queries) and the bunny fit")]
struct Args {
    /// Builds timed per size (median reported).
    #[arg(long, default_value_t = 9)]
    frames: usize,
    /// Largest sphere count (sizes double from 64).
    #[arg(long, default_value_t = 16384)]
    max: u32,
    /// Also fit 64 spheres to the bunny and report time and E.
    #[arg(long)]
    fit: bool,
    /// Write the build-time curve (log-log, with a linear reference line) as an SVG plot here.
    #[arg(long, default_value = "out/bvh_build.svg")]
    plot: std::path::PathBuf,
}

fn main() {
    scenes::init_logging();
    scenes::exit_on_error(run(Args::parse()));
}

fn run(args: Args) -> anyhow::Result<()> {
    let gpu = Gpu::new(&GpuDesc::default())?;
    println!("device: {}", gpu.info.name);
    let gpu_name = gpu.info.name.clone();
    println!("| spheres | build ms (median of {}) | ns per sphere |", args.frames);
    println!("|---|---|---|");
    let mut rng = Pcg32::new(42, 1);
    let mut n = 64;
    let mut curve: Vec<(f64, f64)> = Vec::new();
    let result = (|| -> anyhow::Result<()> {
        while n <= args.max {
            let spheres: Vec<[f32; 4]> = (0..n)
                .map(|_| {
                    [rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0), rng.uniform(0.05, 0.8)]
                })
                .map(|s| s.map(|x| x as f32))
                .collect();
            let pass = BlockerBvhPass::new(&gpu, n)?;
            let sb = gpu.upload_buffer("bench-spheres", BufferDesc::gpu_only(16), &spheres)?;
            let nb = gpu.create_buffer("bench-nodes", BufferDesc::gpu_only(node_buffer_size(n)))?;
            let mut frame = gpu.create_frame()?;
            let mut times = Vec::new();
            for f in 0..=args.frames {
                let t = gpu.run_frame(&mut frame, None, None, |rec| pass.record(rec, &sb, &nb, n))?;
                let ms = t.iter().find(|p| p.name == "blocker_bvh").map(|p| p.ms).context("no timestamp")?;
                if f > 0 {
                    times.push(ms);
                }
            }
            times.sort_by(f64::total_cmp);
            let median = times[times.len() / 2];
            println!("| {n} | {median:.3} | {:.1} |", median * 1e6 / n as f64);
            curve.push((n as f64, median));
            gpu.destroy_frame(frame);
            gpu.destroy_buffer(sb);
            gpu.destroy_buffer(nb);
            pass.destroy(&gpu);
            n *= 2;
        }
        Ok(())
    })();
    gpu.shutdown()?;
    result?;
    if let Some(&(n_last, ms_last)) = curve.last() {
        // Linear growth through the largest measurement, for comparison.
        let linear: Vec<(f64, f64)> = curve.iter().map(|&(n, _)| (n, ms_last * n / n_last)).collect();
        if let Some(dir) = args.plot.parent() {
            std::fs::create_dir_all(dir)?;
        }
        plot::Plot::new(format!("GPU blocker-BVH build time ({})", gpu_name))
            .x_axis("spheres", plot::Scale::Log10)
            .y_axis("build time (ms, median)", plot::Scale::Log10)
            .line("measured", curve.clone())
            .series(plot::Series::new("linear in n", linear, plot::Style::Line).dashed())
            .legend(plot::Legend::TopLeft)
            .write(&args.plot)?;
        println!("wrote {}", args.plot.display());
    }
    if args.fit {
        let path = scenes::assets_dir().join("meshes/bunny.obj");
        let mesh = engine::scene::load_obj(&path)?;
        let positions = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        let triangles = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let mesh = engine::blockers::mesh::Mesh::new(positions, triangles)?;
        let settings = FitSettings::default();
        let t0 = std::time::Instant::now();
        let fit = fit_spheres(&mesh, &settings, &mut |_| {})?;
        let secs = t0.elapsed().as_secs_f64();
        let q = evaluate(&mesh, &fit.spheres, 40_000, 7)?;
        println!(
            "\nbunny, {} spheres (scene mesh): fit {secs:.2} s, E = {:.3} ± {:.3}, surface covered {:.2} %",
            settings.count,
            q.e_union,
            q.e_union_std_error,
            100.0 * q.surface_coverage
        );
    }
    Ok(())
}
