//! Generate (or check) the precomputed math tables: `tables [--out DIR] [--check] [--only NAME,...]
//! [--samples N] [--seed S]`. `cargo xtask tables` runs this optimized.
//!
//! Generation writes `DIR/<name>.bin` for every table of `engine_math::table_gen::all_tables`, printing the time
//! and size of each, and fails if all of them together exceed the device-memory budget. `--check` reads the files
//! instead and regenerates a seeded random sample of entries of each (`--samples`, default 2000), comparing them
//! within the drift tolerance.
//!
//! It also writes (or with `--check` compares) the generated GLSL of the SH products,
//! `shaders-glsl/common/sh_product_gen.glsl` (`--glsl PATH`; engine_math::sh::glsl_products).

use engine_math::table_gen::{all_tables, sample_indices, MathTable, Regenerator, DRIFT_ABS, DRIFT_REL};
use engine_math::tables::Table;
use std::path::PathBuf;
use std::time::Instant;

/// All tables together must fit this much device memory (issue 3: 16 MiB; the paper's were under 10 MB).
const BUDGET_BYTES: u64 = 16 << 20;

struct Args {
    out: PathBuf,
    glsl: PathBuf,
    check: bool,
    only: Option<Vec<String>>,
    samples: usize,
    seed: u64,
}

fn parse() -> Result<Args, String> {
    let mut a = Args {
        out: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/tables"),
        glsl: PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shaders-glsl/common/sh_product_gen.glsl"),
        check: false,
        only: None,
        samples: 2000,
        seed: 1,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value"));
        match arg.as_str() {
            "--out" => a.out = PathBuf::from(value("--out")?),
            "--glsl" => a.glsl = PathBuf::from(value("--glsl")?),
            "--check" => a.check = true,
            "--only" => a.only = Some(value("--only")?.split(',').map(str::to_string).collect()),
            "--samples" => a.samples = value("--samples")?.parse().map_err(|e| format!("--samples: {e}"))?,
            "--seed" => a.seed = value("--seed")?.parse().map_err(|e| format!("--seed: {e}"))?,
            "-h" | "--help" => {
                println!(
                    "tables [--out DIR] [--glsl PATH] [--check] [--only NAME,...] [--samples N] [--seed S]\n  \
                     default DIR: assets/tables of the project; default PATH: its \
                     shaders-glsl/common/sh_product_gen.glsl\n  tables: {}",
                    all_tables().iter().map(|t| t.name()).collect::<Vec<_>>().join(", ")
                );
                std::process::exit(0)
            }
            other => return Err(format!("unknown argument '{other}' (see --help)")),
        }
    }
    Ok(a)
}

fn selected(a: &Args) -> Result<Vec<MathTable>, String> {
    match &a.only {
        None => Ok(all_tables()),
        Some(names) => {
            names.iter().map(|n| MathTable::from_name(n).ok_or(format!("no table named '{n}' (see --help)"))).collect()
        }
    }
}

fn shape(t: &Table) -> String {
    let dims: Vec<String> = t.header.axes.iter().map(|a| a.count.to_string()).collect();
    let types: String =
        t.header.components.iter().map(|c| if *c == engine_math::tables::Component::F32 { 'f' } else { 'u' }).collect();
    format!("{} x [{}]", dims.join("x"), types)
}

fn generate(a: &Args, tables: &[MathTable]) -> Result<(), String> {
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    println!("tables: generating {} tables into {}", tables.len(), a.out.display());
    let t_all = Instant::now();
    let mut total = 0u64;
    for (k, table) in tables.iter().enumerate() {
        let t0 = Instant::now();
        let t = table.generate();
        let secs = t0.elapsed().as_secs_f64();
        let path = a.out.join(format!("{}.bin", table.name()));
        t.write(&path).map_err(|e| e.to_string())?;
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        total += t.header.payload_bytes();
        println!(
            "  [{:>2}/{}] {:<20} {:<18} {:>9.1} KiB  {:>7.2} s",
            k + 1,
            tables.len(),
            table.name(),
            shape(&t),
            bytes as f64 / 1024.0,
            secs
        );
    }
    println!(
        "tables: {} tables, {:.2} MiB of payload, generated in {:.1} s",
        tables.len(),
        total as f64 / (1u64 << 20) as f64,
        t_all.elapsed().as_secs_f64()
    );
    if a.only.is_none() {
        std::fs::write(&a.glsl, engine_math::sh::glsl_products()).map_err(|e| format!("{}: {e}", a.glsl.display()))?;
        println!("tables: wrote {}", a.glsl.display());
        if total > BUDGET_BYTES {
            return Err(format!("the tables take {total} bytes, over the budget of {BUDGET_BYTES}"));
        }
        // Files the generator no longer makes would be loaded by nobody: say so.
        let known: Vec<String> = all_tables().iter().map(|t| format!("{}.bin", t.name())).collect();
        if let Ok(rd) = std::fs::read_dir(&a.out) {
            for e in rd.flatten() {
                let f = e.file_name().to_string_lossy().to_string();
                if f.ends_with(".bin") && !known.contains(&f) {
                    println!("tables: warning: {} is not a table of this generator (stale?)", e.path().display());
                }
            }
        }
    }
    Ok(())
}

fn check(a: &Args, tables: &[MathTable]) -> Result<(), String> {
    println!(
        "tables: checking {} tables in {} ({} sampled entries each, seed {}, tolerance {DRIFT_ABS:e} + {DRIFT_REL:e}·|v|)",
        tables.len(),
        a.out.display(),
        a.samples,
        a.seed
    );
    let mut failures = Vec::new();
    let t_all = Instant::now();
    for (k, table) in tables.iter().enumerate() {
        let t0 = Instant::now();
        let path = a.out.join(format!("{}.bin", table.name()));
        let result = Table::read(&path).map_err(|e| e.to_string()).and_then(|stored| {
            let n = stored.header.entry_count() as usize;
            let idx = sample_indices(n, a.samples, a.seed ^ k as u64);
            Regenerator::new(*table).check(&stored, &idx).map(|w| (w, idx.len(), n))
        });
        match result {
            Ok((worst, m, n)) => println!(
                "  [{:>2}/{}] {:<20} ok: {m} of {n} entries, worst deviation {:.3} of tolerance  {:>6.2} s",
                k + 1,
                tables.len(),
                table.name(),
                worst,
                t0.elapsed().as_secs_f64()
            ),
            Err(e) => {
                println!("  [{:>2}/{}] {:<20} FAILED: {e}", k + 1, tables.len(), table.name());
                failures.push(table.name());
            }
        }
    }
    if a.only.is_none() {
        let stored = std::fs::read_to_string(&a.glsl).unwrap_or_default();
        if stored == engine_math::sh::glsl_products() {
            println!("  {} ok", a.glsl.display());
        } else {
            println!("  {} FAILED: differs from the generator's", a.glsl.display());
            failures.push("sh_product_gen.glsl".to_string());
        }
    }
    println!("tables: checked in {:.1} s", t_all.elapsed().as_secs_f64());
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!("{} table(s) failed the check: {}", failures.len(), failures.join(", ")))
    }
}

fn main() {
    let result = parse().and_then(|a| {
        let tables = selected(&a)?;
        if a.check {
            check(&a, &tables)
        } else {
            generate(&a, &tables)
        }
    });
    if let Err(e) = result {
        eprintln!("tables: {e}");
        std::process::exit(1);
    }
}
