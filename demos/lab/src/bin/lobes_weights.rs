//! `cargo xtask lobes-weights [--check]`: fit the lobes technique's per-depth light leaf weights
//! (engine::passes::shade::lobes::fit) and write assets/tables/lobes_weights.txt, or check that the stored
//! table is what the fit gives today. `--by-distance` reports what distance-dependent weights w(depth, dist)
//! (paper Eq. 39) could gain: the calibration rows binned by octaves of the receiver's distance to the light
//! and to the blocker (in their radii), each bin fitted on its own.

use clap::Parser;
use engine::passes::shade::lobes::fit;

#[derive(Parser, Debug)]
#[command(name = "lobes_weights", about = "Fit the lobes light leaf weights into assets/tables/lobes_weights.txt")]
struct Args {
    /// Compare the stored table with today's fit instead of writing it.
    #[arg(long, conflicts_with = "by_distance")]
    check: bool,
    /// Report what distance-dependent weights w(depth, dist) could gain.
    #[arg(long)]
    by_distance: bool,
}

fn main() {
    scenes::init_logging();
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let Args { check, by_distance: distance } = Args::parse();
    if distance {
        return by_distance();
    }
    let dir = engine::tables::default_dir();
    eprintln!(
        "fitting the lobes light weights ({} set-ups, {}x{} receivers each)...",
        fit::setups().len(),
        fit::GRID,
        fit::GRID
    );
    let t = std::time::Instant::now();
    let (w, rows, uniform, fitted) = fit::fit_default()?;
    eprintln!(
        "{rows} receivers in {:.1} s: relative RMSE with unit weights {:.2} %, fitted {:.2} %; weights {w:?}",
        t.elapsed().as_secs_f64(),
        100.0 * uniform,
        100.0 * fitted
    );
    let path = dir.join(fit::TABLE_FILE);
    if check {
        let stored = fit::load_table(&dir)?;
        let worst = (0..w.len()).map(|d| (w[d] - stored[d]).abs()).fold(0.0, f64::max);
        if worst > 1e-9 {
            return Err(format!(
                "{}: drifted by {worst:e} from today's fit {w:?} (run `cargo xtask lobes-weights`)",
                path.display()
            ));
        }
        println!("{}: up to date", path.display());
        return Ok(());
    }
    std::fs::write(&path, fit::table_text(&w, rows, uniform, fitted))
        .map_err(|e| format!("{}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// The per-depth fit against fits per distance octave (in-sample: an upper bound on the gain).
fn by_distance() -> Result<(), String> {
    eprintln!("computing the calibration rows ({} set-ups)...", fit::setups().len());
    let rows = fit::rows(&engine::passes::shade::lobes::LobesOptions::default(), fit::GRID, fit::QUAD)?;
    let w = fit::fit(&rows, fit::LAMBDA);
    println!(
        "{} receivers: relative RMSE with unit weights {:.3} %, per-depth weights {:.3} %",
        rows.len(),
        100.0 * fit::error(&rows, &[1.0; engine::passes::shade::lobes::WEIGHT_DEPTHS]),
        100.0 * fit::error(&rows, &w)
    );
    for (what, key) in [("light", 0), ("blocker", 1)] {
        let (bins, e) = fit::binned_error(&rows, |r| if key == 0 { r.light_dist } else { r.blocker_dist });
        println!(
            "per-depth weights fitted per octave of the distance to the {what} ({bins} octaves): {:.3} %",
            100.0 * e
        );
    }
    Ok(())
}
