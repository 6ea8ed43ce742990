//! `cargo xtask lobes-weights [--check]`: fit the lobes technique's per-depth light leaf weights
//! (engine::passes::shade::lobes::fit) and write assets/tables/lobes_weights.txt, or check that the stored
//! table is what the fit gives today.

use engine::passes::shade::lobes::fit;

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let check = match args.as_slice() {
        [] => false,
        [a] if a == "--check" => true,
        [a] if a == "-h" || a == "--help" => {
            println!(
                "usage: lobes_weights [--check]   (fit the lobes light leaf weights; --check compares with the table)"
            );
            return Ok(());
        }
        other => return Err(format!("unexpected arguments {other:?} (usage: lobes_weights [--check])")),
    };
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
