//! `cargo xtask report math`: plots of ISG, SH exp and lobe errors (issue 3; not built yet).

use anyhow::{bail, Result};

pub fn run(_args: &[String]) -> Result<()> {
    bail!("`cargo xtask report math` is not built yet")
}
