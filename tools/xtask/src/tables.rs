//! `cargo xtask tables`: regenerate the versioned binary math tables (issue 3; not built yet).

use anyhow::{bail, Result};

pub fn run(_args: &[String]) -> Result<()> {
    bail!("`cargo xtask tables` is not built yet")
}
