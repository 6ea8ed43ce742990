//! Fits a sphere set to a mesh and writes a `.spheres.json` file (see `engine_blockers::file`).
//!
//! `cargo run -p engine-blockers --release --bin spheres -- MESH.obj --count 64 -o MESH.spheres.json`
//! `--compare 16,32,64,128` prints the variational-vs-k-means table instead of writing a file.

use anyhow::{bail, Context, Result};
use clap::Parser;
use engine_blockers::file::SphereSetFile;
use engine_blockers::fit::{compare_with_baseline, comparison_markdown, evaluate, fit_spheres, FitSettings};
use engine_blockers::mesh::Mesh;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(about = "Fit bounding spheres to a mesh (SHEXP §6.2 variational sphere sets)")]
struct Args {
    /// Input mesh (OBJ).
    mesh: PathBuf,
    /// Number of spheres.
    #[arg(long, default_value_t = 64)]
    count: usize,
    /// Output file (default: MESH with extension .spheres.json).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Interior sample grid cells along the longest axis.
    #[arg(long, default_value_t = FitSettings::default().grid_resolution)]
    grid: usize,
    /// Maximum iterations.
    #[arg(long, default_value_t = FitSettings::default().max_iterations)]
    iterations: usize,
    /// Monte Carlo samples for the reported quality (0: skip the evaluation).
    #[arg(long, default_value_t = 40000)]
    eval_samples: usize,
    /// Compare with the k-means baseline at these counts (comma separated) and print a table.
    #[arg(long, value_delimiter = ',')]
    compare: Vec<usize>,
}

fn main() -> std::process::ExitCode {
    // Print the error chain on one line, without anyhow's backtrace (this is a user-facing tool).
    match run(Args::parse()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    let t0 = Instant::now();
    let mesh = Mesh::load_obj(&args.mesh).with_context(|| format!("loading {}", args.mesh.display()))?;
    eprintln!(
        "loaded {}: {} vertices, {} triangles, hash {}",
        args.mesh.display(),
        mesh.positions().len(),
        mesh.triangles().len(),
        mesh.content_hash()
    );
    let settings = FitSettings {
        count: args.count,
        seed: args.seed,
        grid_resolution: args.grid,
        max_iterations: args.iterations,
        ..FitSettings::default()
    };
    settings.validate().context("invalid options")?;
    if !args.compare.is_empty() {
        if args.eval_samples == 0 {
            bail!("--compare needs --eval-samples > 0");
        }
        let rows = compare_with_baseline(&mesh, &args.compare, &settings, args.eval_samples)?;
        println!(
            "E = outside volume of the sphere union / object volume, seeded Monte Carlo with {} samples \
             (winding number ≥ 1/2 = inside); surface coverage over {} area-uniform points.\n",
            args.eval_samples, args.eval_samples
        );
        print!("{}", comparison_markdown(&rows));
        return Ok(());
    }
    let fit = fit_spheres(&mesh, &settings, &mut |p| {
        if p.setup {
            eprintln!("  {:6.1} s  {}", t0.elapsed().as_secs_f64(), p.message);
        } else {
            eprintln!(
                "  {:6.1} s  iter {:3}  E(sum, grid) {:.5}  teleports {}/{}  {}",
                t0.elapsed().as_secs_f64(),
                p.iteration,
                p.outside_sum,
                p.teleports_accepted,
                p.teleports_tried,
                p.message
            )
        }
    })?;
    let fit_time = t0.elapsed().as_secs_f64();
    eprintln!(
        "fitted {} spheres in {:.2} s ({} surface + {} interior samples, {} iterations)",
        fit.spheres.len(),
        fit_time,
        fit.surface_samples,
        fit.interior_samples,
        fit.iterations
    );
    if args.eval_samples > 0 {
        let q = evaluate(&mesh, &fit.spheres, args.eval_samples, args.seed)?;
        eprintln!(
            "E (union outside / object volume, Monte Carlo {} samples) = {:.4} ± {:.4}; Eq. 35 sum form {:.4}; \
             surface covered {:.2} %",
            q.samples,
            q.e_union,
            q.e_union_std_error,
            q.e_sum,
            100.0 * q.surface_coverage
        );
    }
    let bvh = engine_blockers::bvh::SphereBvh::build(&fit.spheres)?;
    let hierarchy = engine_blockers::hierarchy::SphereHierarchy::build(&fit.spheres)?;
    let root = &hierarchy.nodes()[0];
    eprintln!(
        "LBVH: {} nodes; 4-ary hierarchy: {} nodes, mean branching {:.2}, {} levels; SHEXP cut at θ_max = 25° \
         from 2 root radii away: {} spheres",
        bvh.nodes().len(),
        hierarchy.nodes().len(),
        hierarchy.mean_branching(),
        root.level + 1,
        hierarchy
            .cut(
                &engine_blockers::Sphere::new(root.sphere.center + glam::DVec3::X * 2.0 * root.sphere.radius, 0.0),
                25f64.to_radians()
            )
            .len()
    );
    let output = args.output.unwrap_or_else(|| args.mesh.with_extension("spheres.json"));
    SphereSetFile::from_fit(&args.mesh.display().to_string(), &mesh, &settings, &fit)
        .save(&output)
        .with_context(|| format!("writing {}", output.display()))?;
    eprintln!("wrote {}", output.display());
    Ok(())
}
