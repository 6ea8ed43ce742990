//! Drift check of the committed tables (assets/tables): every table's header (dimensions, ranges, generator version,
//! component types) must equal the generator's, its checksums must hold, and a seeded random sample of its entries,
//! regenerated from the f64 mathematics, must match the stored f32 values within
//! `table_gen::DRIFT_ABS + DRIFT_REL·|v|` (1e-6 + 1e-5·|v|; on the machine that wrote them the match is exact).
//! If the mathematics changes on purpose, run `cargo xtask tables` and commit the files.
//!
//! `TABLES_DRIFT_SEED=<n>` picks another sample.

use engine_math::table_gen::{all_tables, sample_indices, Regenerator};
use engine_math::tables::Table;
use std::path::PathBuf;

/// Entries regenerated per table: enough to hit every region of the big tables many times over, few enough to run
/// in seconds unoptimized (the lobe product fit is the expensive one, ~1 ms each at opt-level 1).
const SAMPLES: usize = 1000;
const BUDGET_BYTES: u64 = 16 << 20;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/tables")
}

#[test]
fn committed_tables_match_the_mathematics() {
    let seed: u64 = std::env::var("TABLES_DRIFT_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(20240611);
    let mut failures = Vec::new();
    let mut total = 0u64;
    for (k, table) in all_tables().into_iter().enumerate() {
        let path = dir().join(format!("{}.bin", table.name()));
        let t0 = std::time::Instant::now();
        let stored = match Table::read(&path) {
            Ok(t) => t,
            Err(e) => {
                failures.push(format!("{e} (regenerate with `cargo xtask tables`)"));
                continue;
            }
        };
        total += stored.header.payload_bytes();
        let n = stored.header.entry_count() as usize;
        let idx = sample_indices(n, SAMPLES, seed.wrapping_add(k as u64));
        match Regenerator::new(table).check(&stored, &idx) {
            Ok(worst) => eprintln!(
                "{:<18} {} of {n} entries, worst deviation {worst:.3} of tolerance, {:.2} s",
                table.name(),
                idx.len(),
                t0.elapsed().as_secs_f64()
            ),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "seed {seed}:\n{}", failures.join("\n"));
    assert!(total <= BUDGET_BYTES, "tables take {total} bytes, over {BUDGET_BYTES}");
}

#[test]
fn no_stray_table_files() {
    let known: Vec<String> = all_tables().iter().map(|t| format!("{}.bin", t.name())).collect();
    for e in std::fs::read_dir(dir()).expect("assets/tables").flatten() {
        let f = e.file_name().to_string_lossy().to_string();
        assert!(!f.ends_with(".bin") || known.contains(&f), "{f} is in assets/tables but no generator makes it");
    }
}

/// The generated GLSL of the SH products is the generator's (`cargo xtask tables` rewrites it).
#[test]
fn generated_glsl_products_match_the_tensor() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shaders-glsl/common/sh_product_gen.glsl");
    let stored = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        stored == engine_math::sh::glsl_products(),
        "{} differs from engine_math::sh::glsl_products(): run `cargo xtask tables` and commit it",
        path.display()
    );
}
