//! The precomputed math tables in device memory.
//!
//! The files are `assets/tables/<name>.bin` in the format of [`engine_math::tables`], written by
//! `cargo xtask tables` (engine-math's `table_gen` lists them). Each is uploaded as is, payload only, into one
//! device-local storage buffer named `table <name>`; shaders index it with the layout its header describes (entries
//! row-major, first axis slowest, `components` 32-bit words per entry). The engine reads them from the project's
//! assets at run time and never from anywhere else.

use crate::gpu::{Buffer, BufferDesc, Gpu, GpuError};
use engine_math::table_gen::{all_tables, MathTable};
use engine_math::tables::{Table, TableError, TableHeader};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum TablesError {
    #[error("math table '{name}': {source} (regenerate with `cargo xtask tables`)")]
    File { name: String, source: TableError },
    #[error(
        "math table '{name}' in {file} is stale: generator version {found}, this build expects {expected} \
         (regenerate with `cargo xtask tables`)"
    )]
    Stale { name: String, file: String, found: u32, expected: u32 },
    #[error("{file} holds table '{found}', expected '{expected}'")]
    WrongName { file: String, found: String, expected: String },
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

/// The project's tables folder: `$ENGINE_ASSETS/tables` when set, else `assets/tables` of this checkout.
pub fn default_dir() -> PathBuf {
    std::env::var_os("ENGINE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets"))
        .join("tables")
}

/// One table on the device: its header (dimensions, ranges, layout) and the buffer holding its payload.
pub struct GpuTable {
    pub table: MathTable,
    pub header: TableHeader,
    pub buffer: Buffer,
}

/// A set of tables in device memory. Destroy with [`MathTables::destroy`] before `Gpu::shutdown`.
pub struct MathTables {
    tables: Vec<GpuTable>,
}

impl MathTables {
    /// Every table of the generator, from `dir`.
    pub fn load_all(gpu: &Gpu, dir: &Path) -> Result<Self, TablesError> {
        Self::load(gpu, dir, &all_tables())
    }

    /// The given tables from `dir`. On an error nothing stays allocated.
    pub fn load(gpu: &Gpu, dir: &Path, which: &[MathTable]) -> Result<Self, TablesError> {
        let mut out = Self { tables: Vec::with_capacity(which.len()) };
        for &t in which {
            match load_one(gpu, dir, t) {
                Ok(g) => out.tables.push(g),
                Err(e) => {
                    out.destroy(gpu);
                    return Err(e);
                }
            }
        }
        Ok(out)
    }

    pub fn get(&self, table: MathTable) -> Option<&GpuTable> {
        self.tables.iter().find(|g| g.table == table)
    }

    pub fn iter(&self) -> impl Iterator<Item = &GpuTable> {
        self.tables.iter()
    }

    pub fn len(&self) -> usize {
        self.tables.len()
    }

    pub fn is_empty(&self) -> bool {
        self.tables.is_empty()
    }

    /// Device bytes of all payloads.
    pub fn total_bytes(&self) -> u64 {
        self.tables.iter().map(|g| g.header.payload_bytes()).sum()
    }

    pub fn destroy(self, gpu: &Gpu) {
        for g in self.tables {
            gpu.destroy_buffer(g.buffer);
        }
    }
}

fn load_one(gpu: &Gpu, dir: &Path, table: MathTable) -> Result<GpuTable, TablesError> {
    let name = table.name();
    let path = dir.join(format!("{name}.bin"));
    let file = path.display().to_string();
    let t = Table::read(&path).map_err(|source| TablesError::File { name: name.clone(), source })?;
    if t.header.name != name {
        return Err(TablesError::WrongName { file, found: t.header.name, expected: name });
    }
    if t.header.generator_version != table.generator_version() {
        return Err(TablesError::Stale {
            name,
            file,
            found: t.header.generator_version,
            expected: table.generator_version(),
        });
    }
    let buffer = gpu.upload_buffer(&format!("table {name}"), BufferDesc::gpu_only(0), &t.words)?;
    Ok(GpuTable { table, header: t.header, buffer })
}
