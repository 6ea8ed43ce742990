//! The versioned binary format of the precomputed math tables (`assets/tables/*.bin`).
//!
//! A file is a header followed by a payload of little-endian 32-bit words. All integers are little-endian.
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `b"ENGTABLE"` |
//! | 8 | 4 | format version (u32, [`FORMAT_VERSION`]) |
//! | 12 | 4 | header size in bytes (u32; the payload starts here; a multiple of 16) |
//! | 16 | 4 | generator version (u32; bumped by the generator when the tabulated mathematics changes) |
//! | 20 | 4 | rank: number of axes (u32, 1..=[`MAX_RANK`]) |
//! | 24 | 4 | components: 32-bit words per entry (u32, 1..=[`MAX_COMPONENTS`]) |
//! | 28 | 4 | reserved, 0 |
//! | 32 | 8 | entry count (u64; the product of the axis counts) |
//! | 40 | 8 | payload size in bytes (u64; entry count × components × 4) |
//! | 48 | 8 | FNV-1a 64 checksum of the payload bytes |
//! | 56 | 8 | FNV-1a 64 checksum of the header bytes with this field zeroed |
//! | 64 | … | name (string), component types (string, one `f` = f32 or `u` = u32 per component), description (string), then per axis: count (u32), sampling (u32, [`Sampling`]), sampling parameter (u32), lo (f64), hi (f64), label (string); zero padding to the header size |
//!
//! A string is a u16 byte length and UTF-8 bytes. Entries are row-major: the first axis varies slowest, and each
//! entry is `components` consecutive words, so an entry's word offset is `components × linear index`. That is the
//! layout the GPU buffer holds too (the engine uploads the payload as is).
//!
//! The reader checks everything it can and says what is wrong: magic, version, sizes, checksums, axis counts.

use std::fmt;
use std::path::Path;

/// The file magic.
pub const MAGIC: [u8; 8] = *b"ENGTABLE";
/// The version of this layout. A reader accepts only this version.
pub const FORMAT_VERSION: u32 = 1;
pub const MAX_RANK: usize = 4;
pub const MAX_COMPONENTS: usize = 16;
/// Longest accepted header (a corrupt header-size field must not make the reader allocate gigabytes).
pub const MAX_HEADER_BYTES: usize = 1 << 16;
const FIXED_HEADER: usize = 64;

/// How the samples of an axis are placed between `lo` and `hi` (sample i of `count`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// `lo + (hi − lo) · i / (count − 1)`.
    Uniform,
    /// Uniform in ln: `exp(ln lo + (ln hi − ln lo) · i / (count − 1))`.
    LnUniform,
    /// The cosine-lobe exponent axis of [`crate::lobes::exponent_samples`] with `param` samples per decade:
    /// linear in [0, 1), [1, 10), …, [1e4, 1e5), then 1e5; `lo` = 0, `hi` = 1e5.
    LobeExponent,
    /// A list: sample i is entry i (e.g. the sparse SH tensor); `lo` = 0, `hi` = count − 1.
    Index,
    /// `param` = R samples per octave, linear within each octave: sample i is
    /// `2^(log2 lo + i div R) (1 + (i mod R)/R)`; `lo` and `hi` are powers of two (the ISG table's λ).
    Octave,
}

impl Sampling {
    fn code(self) -> u32 {
        match self {
            Sampling::Uniform => 0,
            Sampling::LnUniform => 1,
            Sampling::LobeExponent => 2,
            Sampling::Index => 3,
            Sampling::Octave => 4,
        }
    }
    fn from_code(c: u32) -> Option<Self> {
        Some(match c {
            0 => Sampling::Uniform,
            1 => Sampling::LnUniform,
            2 => Sampling::LobeExponent,
            3 => Sampling::Index,
            4 => Sampling::Octave,
            _ => return None,
        })
    }
}

/// One axis of a table.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// What the axis is, in words (e.g. "alpha: angle between the lobe axes [rad]").
    pub label: String,
    pub count: u32,
    pub sampling: Sampling,
    /// Sampling parameter (samples per decade for [`Sampling::LobeExponent`], else 0).
    pub param: u32,
    pub lo: f64,
    pub hi: f64,
}

impl Axis {
    pub fn uniform(label: impl Into<String>, count: usize, lo: f64, hi: f64) -> Self {
        Self { label: label.into(), count: count as u32, sampling: Sampling::Uniform, param: 0, lo, hi }
    }
    pub fn ln_uniform(label: impl Into<String>, count: usize, lo: f64, hi: f64) -> Self {
        Self { label: label.into(), count: count as u32, sampling: Sampling::LnUniform, param: 0, lo, hi }
    }
    pub fn lobe_exponent(label: impl Into<String>, per_decade: usize) -> Self {
        let count = crate::lobes::EXPONENT_DECADES * per_decade + 1;
        Self {
            label: label.into(),
            count: count as u32,
            sampling: Sampling::LobeExponent,
            param: per_decade as u32,
            lo: 0.0,
            hi: crate::lobes::MAX_EXPONENT,
        }
    }
    pub fn index(label: impl Into<String>, count: usize) -> Self {
        Self {
            label: label.into(),
            count: count as u32,
            sampling: Sampling::Index,
            param: 0,
            lo: 0.0,
            hi: count.saturating_sub(1) as f64,
        }
    }

    /// `per_octave` samples per octave from `lo` to `hi` (both powers of two), see [`Sampling::Octave`].
    pub fn octave(label: impl Into<String>, per_octave: usize, lo: f64, hi: f64) -> Self {
        let octaves = (hi / lo).log2().round() as usize;
        Self {
            label: label.into(),
            count: (octaves * per_octave + 1) as u32,
            sampling: Sampling::Octave,
            param: per_octave as u32,
            lo,
            hi,
        }
    }

    /// The axis value of sample `i`.
    pub fn sample(&self, i: usize) -> f64 {
        let t = if self.count > 1 { i as f64 / (self.count - 1) as f64 } else { 0.0 };
        match self.sampling {
            Sampling::Uniform => self.lo + (self.hi - self.lo) * t,
            Sampling::LnUniform => (self.lo.ln() + (self.hi.ln() - self.lo.ln()) * t).exp(),
            Sampling::LobeExponent => crate::lobes::exponent_samples(self.param as usize)[i],
            Sampling::Index => i as f64,
            Sampling::Octave => {
                let r = self.param.max(1) as usize;
                self.lo * 2f64.powi((i / r) as i32) * (1.0 + (i % r) as f64 / r as f64)
            }
        }
    }
}

/// Component type of an entry word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Component {
    F32,
    U32,
}

/// Everything in a table file but the payload.
#[derive(Clone, Debug, PartialEq)]
pub struct TableHeader {
    /// File stem and buffer name, e.g. `lobe_product`.
    pub name: String,
    pub generator_version: u32,
    pub axes: Vec<Axis>,
    pub components: Vec<Component>,
    /// What an entry holds and how it is read (one paragraph).
    pub description: String,
}

impl TableHeader {
    pub fn entry_count(&self) -> u64 {
        self.axes.iter().map(|a| a.count as u64).product()
    }
    pub fn words_per_entry(&self) -> usize {
        self.components.len()
    }
    pub fn payload_bytes(&self) -> u64 {
        self.entry_count() * self.components.len() as u64 * 4
    }
    /// Row-major linear entry index of a multi-index (first axis slowest).
    pub fn linear_index(&self, idx: &[usize]) -> usize {
        assert_eq!(idx.len(), self.axes.len());
        idx.iter().zip(&self.axes).fold(0, |acc, (&i, a)| acc * a.count as usize + i)
    }
    /// Multi-index of a linear entry index.
    pub fn multi_index(&self, mut linear: usize) -> Vec<usize> {
        let mut out = vec![0; self.axes.len()];
        for (o, a) in out.iter_mut().zip(&self.axes).rev() {
            *o = linear % a.count as usize;
            linear /= a.count as usize;
        }
        out
    }
}

/// A table: header and payload words (f32 components stored as their bits).
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub header: TableHeader,
    pub words: Vec<u32>,
}

impl Table {
    /// A table of f32 entries; `values.len()` must be `entry count × components`.
    pub fn from_f32(header: TableHeader, values: &[f32]) -> Self {
        Self { header, words: values.iter().map(|v| v.to_bits()).collect() }
    }
    /// The words of entry `linear`.
    pub fn entry(&self, linear: usize) -> &[u32] {
        let c = self.header.words_per_entry();
        &self.words[linear * c..(linear + 1) * c]
    }
    /// The payload as f32 values (for all-f32 tables; u32 components are reinterpreted, so check
    /// `header.components` first when that matters).
    pub fn f32_values(&self) -> Vec<f32> {
        self.words.iter().map(|&w| f32::from_bits(w)).collect()
    }
    pub fn payload_bytes(&self) -> Vec<u8> {
        self.words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }

    /// Serialize (header, then payload).
    pub fn to_bytes(&self) -> Result<Vec<u8>, TableError> {
        self.validate()?;
        let payload = self.payload_bytes();
        let h = &self.header;
        let mut var = Vec::new();
        put_str(&mut var, &h.name)?;
        let types: String = h.components.iter().map(|c| if *c == Component::F32 { 'f' } else { 'u' }).collect();
        put_str(&mut var, &types)?;
        put_str(&mut var, &h.description)?;
        for a in &h.axes {
            var.extend(a.count.to_le_bytes());
            var.extend(a.sampling.code().to_le_bytes());
            var.extend(a.param.to_le_bytes());
            var.extend(a.lo.to_le_bytes());
            var.extend(a.hi.to_le_bytes());
            put_str(&mut var, &a.label)?;
        }
        let header_size = (FIXED_HEADER + var.len()).div_ceil(16) * 16;
        if header_size > MAX_HEADER_BYTES {
            return Err(TableError::Malformed(format!("header of {header_size} bytes exceeds {MAX_HEADER_BYTES}")));
        }
        let mut out = Vec::with_capacity(header_size + payload.len());
        out.extend(MAGIC);
        out.extend(FORMAT_VERSION.to_le_bytes());
        out.extend((header_size as u32).to_le_bytes());
        out.extend(h.generator_version.to_le_bytes());
        out.extend((h.axes.len() as u32).to_le_bytes());
        out.extend((h.components.len() as u32).to_le_bytes());
        out.extend(0u32.to_le_bytes());
        out.extend(h.entry_count().to_le_bytes());
        out.extend((payload.len() as u64).to_le_bytes());
        out.extend(fnv1a64(&payload).to_le_bytes());
        out.extend(0u64.to_le_bytes());
        out.extend(var);
        out.resize(header_size, 0);
        let hsum = fnv1a64(&out);
        out[56..64].copy_from_slice(&hsum.to_le_bytes());
        out.extend(payload);
        Ok(out)
    }

    fn validate(&self) -> Result<(), TableError> {
        let h = &self.header;
        if h.axes.is_empty() || h.axes.len() > MAX_RANK {
            return Err(TableError::Malformed(format!("{} axes (1..={MAX_RANK} allowed)", h.axes.len())));
        }
        if h.components.is_empty() || h.components.len() > MAX_COMPONENTS {
            return Err(TableError::Malformed(format!(
                "{} components (1..={MAX_COMPONENTS} allowed)",
                h.components.len()
            )));
        }
        if let Some(a) = h.axes.iter().find(|a| a.count == 0) {
            return Err(TableError::Malformed(format!("axis '{}' has no samples", a.label)));
        }
        let want = h.entry_count() * h.components.len() as u64;
        if self.words.len() as u64 != want {
            return Err(TableError::Size { what: "payload words", expected: want, found: self.words.len() as u64 });
        }
        Ok(())
    }

    /// Parse and check a file's bytes.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, TableError> {
        if bytes.len() < 8 || bytes[..8] != MAGIC {
            let found = bytes[..bytes.len().min(8)].to_vec();
            return Err(TableError::Magic { found });
        }
        if bytes.len() < FIXED_HEADER {
            return Err(TableError::Size {
                what: "file (shorter than the fixed header)",
                expected: FIXED_HEADER as u64,
                found: bytes.len() as u64,
            });
        }
        let mut r = Reader { b: bytes, at: 8 };
        let version = r.u32()?;
        if version != FORMAT_VERSION {
            return Err(TableError::Version { found: version, supported: FORMAT_VERSION });
        }
        let header_size = r.u32()? as usize;
        if !(FIXED_HEADER..=MAX_HEADER_BYTES).contains(&header_size) || header_size & 15 != 0 {
            return Err(TableError::Malformed(format!("header size {header_size}")));
        }
        if bytes.len() < header_size {
            return Err(TableError::Size {
                what: "file (shorter than its header)",
                expected: header_size as u64,
                found: bytes.len() as u64,
            });
        }
        let mut hcopy = bytes[..header_size].to_vec();
        hcopy[56..64].fill(0);
        let hsum_stored = u64::from_le_bytes(bytes[56..64].try_into().unwrap());
        let hsum = fnv1a64(&hcopy);
        if hsum != hsum_stored {
            return Err(TableError::Checksum { what: "header", expected: hsum_stored, found: hsum });
        }
        let generator_version = r.u32()?;
        let rank = r.u32()? as usize;
        let ncomp = r.u32()? as usize;
        let _reserved = r.u32()?;
        let entry_count = r.u64()?;
        let payload_size = r.u64()?;
        let psum_stored = r.u64()?;
        let _ = r.u64()?;
        if rank == 0 || rank > MAX_RANK {
            return Err(TableError::Malformed(format!("rank {rank}")));
        }
        if ncomp == 0 || ncomp > MAX_COMPONENTS {
            return Err(TableError::Malformed(format!("{ncomp} components")));
        }
        let name = r.string()?;
        let types = r.string()?;
        let components = types
            .chars()
            .map(|c| match c {
                'f' => Ok(Component::F32),
                'u' => Ok(Component::U32),
                c => Err(TableError::Malformed(format!("component type '{c}'"))),
            })
            .collect::<Result<Vec<_>, _>>()?;
        if components.len() != ncomp {
            return Err(TableError::Malformed(format!("{} component types for {ncomp} components", components.len())));
        }
        let description = r.string()?;
        let mut axes = Vec::with_capacity(rank);
        for _ in 0..rank {
            let count = r.u32()?;
            let code = r.u32()?;
            let sampling = Sampling::from_code(code).ok_or(TableError::Malformed(format!("sampling code {code}")))?;
            let param = r.u32()?;
            let lo = r.f64()?;
            let hi = r.f64()?;
            let label = r.string()?;
            axes.push(Axis { label, count, sampling, param, lo, hi });
        }
        if r.at > header_size {
            return Err(TableError::Malformed("header fields run past the header size".into()));
        }
        let header = TableHeader { name, generator_version, axes, components, description };
        if header.entry_count() != entry_count {
            return Err(TableError::Size {
                what: "entry count (axis counts vs header)",
                expected: header.entry_count(),
                found: entry_count,
            });
        }
        if header.payload_bytes() != payload_size {
            return Err(TableError::Size {
                what: "payload bytes (header)",
                expected: header.payload_bytes(),
                found: payload_size,
            });
        }
        let payload = &bytes[header_size..];
        if payload.len() as u64 != payload_size {
            return Err(TableError::Size {
                what: "payload bytes (file)",
                expected: payload_size,
                found: payload.len() as u64,
            });
        }
        let psum = fnv1a64(payload);
        if psum != psum_stored {
            return Err(TableError::Checksum { what: "payload", expected: psum_stored, found: psum });
        }
        let words = payload.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect();
        Ok(Self { header, words })
    }

    /// Write to `path`.
    pub fn write(&self, path: &Path) -> Result<(), TableError> {
        let bytes = self.to_bytes()?;
        std::fs::write(path, bytes).map_err(|e| TableError::Io(format!("{}: {e}", path.display())))
    }

    /// Read and check `path`; errors name the file.
    pub fn read(path: &Path) -> Result<Self, TableError> {
        let bytes = std::fs::read(path).map_err(|e| TableError::Io(format!("{}: {e}", path.display())))?;
        Self::from_bytes(&bytes).map_err(|e| e.in_file(path))
    }
}

fn put_str(out: &mut Vec<u8>, s: &str) -> Result<(), TableError> {
    let len = u16::try_from(s.len()).map_err(|_| TableError::Malformed(format!("string of {} bytes", s.len())))?;
    out.extend(len.to_le_bytes());
    out.extend(s.as_bytes());
    Ok(())
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], TableError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len()).ok_or(TableError::Size {
            what: "header (truncated)",
            expected: (self.at + n) as u64,
            found: self.b.len() as u64,
        })?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, TableError> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn u64(&mut self) -> Result<u64, TableError> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn f64(&mut self) -> Result<f64, TableError> {
        Ok(f64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn string(&mut self) -> Result<String, TableError> {
        let len = u16::from_le_bytes(self.take(2)?.try_into().unwrap()) as usize;
        let s = self.take(len)?;
        String::from_utf8(s.to_vec()).map_err(|_| TableError::Malformed("string is not UTF-8".into()))
    }
}

/// FNV-1a, 64 bit (Fowler–Noll–Vo): a small, dependency-free checksum that catches corruption (not tampering).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a64::default();
    h.bytes(bytes);
    h.0
}

/// [`fnv1a64`] fed piece by piece: as a [`std::hash::Hasher`] (stable across Rust versions and runs, unlike
/// `DefaultHasher`, so its values can name files on disk) and as a [`std::fmt::Write`] (so `write!(h, "{x:?}")`
/// digests a value's `Debug` text without building the string).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a64(pub u64);

impl Default for Fnv1a64 {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a64 {
    pub fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

impl std::hash::Hasher for Fnv1a64 {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        self.bytes(bytes);
    }
}

impl std::fmt::Write for Fnv1a64 {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// What is wrong with a table file.
#[derive(Clone, Debug, PartialEq)]
pub enum TableError {
    Io(String),
    Magic {
        found: Vec<u8>,
    },
    Version {
        found: u32,
        supported: u32,
    },
    Size {
        what: &'static str,
        expected: u64,
        found: u64,
    },
    Checksum {
        what: &'static str,
        expected: u64,
        found: u64,
    },
    Malformed(String),
    /// Any of the above, in a named file.
    InFile {
        file: String,
        error: Box<TableError>,
    },
}

impl TableError {
    fn in_file(self, path: &Path) -> Self {
        TableError::InFile { file: path.display().to_string(), error: Box::new(self) }
    }
}

impl fmt::Display for TableError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TableError::Io(e) => write!(f, "{e}"),
            TableError::Magic { found } => {
                write!(f, "not a table file: magic {found:02x?}, expected {:02x?} (\"ENGTABLE\")", MAGIC)
            }
            TableError::Version { found, supported } => {
                write!(f, "table format version {found}, this reader supports {supported}: regenerate with `cargo xtask tables`")
            }
            TableError::Size { what, expected, found } => {
                write!(f, "wrong size of {what}: expected {expected}, found {found}")
            }
            TableError::Checksum { what, expected, found } => write!(
                f,
                "{what} checksum mismatch (stored {expected:016x}, computed {found:016x}): the file is corrupt"
            ),
            TableError::Malformed(m) => write!(f, "malformed table header: {m}"),
            TableError::InFile { file, error } => write!(f, "{file}: {error}"),
        }
    }
}

impl std::error::Error for TableError {}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        let header = TableHeader {
            name: "test_table".into(),
            generator_version: 7,
            axes: vec![Axis::ln_uniform("lambda", 3, 1e-3, 1e5), Axis::uniform("s", 4, 0.0, 1.0)],
            components: vec![Component::F32, Component::U32],
            description: "a test: [value, index]".into(),
        };
        let words = (0..12).flat_map(|i| [(i as f32 * 0.25).to_bits(), i as u32]).collect();
        Table { header, words }
    }

    #[test]
    fn round_trip() {
        let t = sample();
        let bytes = t.to_bytes().unwrap();
        assert_eq!(&bytes[..8], b"ENGTABLE");
        let header_size = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        assert_eq!(header_size % 16, 0);
        assert_eq!(bytes.len(), header_size + 12 * 2 * 4);
        let back = Table::from_bytes(&bytes).unwrap();
        assert_eq!(back, t);
        assert_eq!(back.entry(5), &[(5.0f32 * 0.25).to_bits(), 5]);
        assert_eq!(back.header.linear_index(&[1, 1]), 5);
        assert_eq!(back.header.multi_index(5), vec![1, 1]);
        assert!((back.header.axes[0].sample(1) - 10.0).abs() < 1e-12);
    }

    #[test]
    fn fnv_known_values() {
        // Reference values of the FNV-1a 64 specification.
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        // Fed in pieces, as bytes or as formatted text, it is the same digest.
        let mut h = Fnv1a64::default();
        h.bytes(b"ab");
        std::fmt::Write::write_fmt(&mut h, format_args!("c{}", 1)).unwrap();
        assert_eq!(h.0, fnv1a64(b"abc1"));
        assert_eq!(fnv1a64(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn wrong_magic() {
        let mut b = sample().to_bytes().unwrap();
        b[0] = b'X';
        let e = Table::from_bytes(&b).unwrap_err();
        assert!(matches!(e, TableError::Magic { .. }), "{e}");
        assert!(e.to_string().contains("not a table file"), "{e}");
        assert!(matches!(Table::from_bytes(b"ENG").unwrap_err(), TableError::Magic { .. }));
    }

    #[test]
    fn wrong_version() {
        let mut b = sample().to_bytes().unwrap();
        b[8..12].copy_from_slice(&2u32.to_le_bytes());
        let e = Table::from_bytes(&b).unwrap_err();
        assert_eq!(e, TableError::Version { found: 2, supported: FORMAT_VERSION });
        assert!(e.to_string().contains("cargo xtask tables"), "{e}");
    }

    #[test]
    fn wrong_size() {
        let b = sample().to_bytes().unwrap();
        // Truncated payload.
        let e = Table::from_bytes(&b[..b.len() - 4]).unwrap_err();
        assert!(matches!(e, TableError::Size { what: "payload bytes (file)", expected: 96, found: 92 }), "{e}");
        // Extra bytes.
        let mut longer = b.clone();
        longer.extend([0u8; 4]);
        assert!(matches!(Table::from_bytes(&longer).unwrap_err(), TableError::Size { .. }));
        // Truncated inside the header.
        let e = Table::from_bytes(&b[..40]).unwrap_err();
        assert!(matches!(e, TableError::Size { .. }), "{e}");
        let e = Table::from_bytes(&b[..70]).unwrap_err();
        assert!(e.to_string().contains("shorter than its header"), "{e}");
        // A writer refuses a payload that does not fill the axes.
        let mut t = sample();
        t.words.pop();
        assert!(matches!(t.to_bytes().unwrap_err(), TableError::Size { .. }));
    }

    #[test]
    fn wrong_checksum() {
        let b = sample().to_bytes().unwrap();
        // A flipped payload bit.
        let mut p = b.clone();
        let last = p.len() - 1;
        p[last] ^= 1;
        let e = Table::from_bytes(&p).unwrap_err();
        assert!(matches!(e, TableError::Checksum { what: "payload", .. }), "{e}");
        assert!(e.to_string().contains("corrupt"), "{e}");
        // A changed axis count in the header fails the header checksum before anything reads it.
        let mut h = b.clone();
        h[70] ^= 0x40;
        let e = Table::from_bytes(&h).unwrap_err();
        assert!(matches!(e, TableError::Checksum { what: "header", .. }), "{e}");
    }

    #[test]
    fn errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("table-format-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.bin");
        let mut b = sample().to_bytes().unwrap();
        b[20] = 0xff;
        std::fs::write(&path, &b).unwrap();
        let e = Table::read(&path).unwrap_err().to_string();
        assert!(e.contains("t.bin") && e.contains("checksum"), "{e}");
        let e = Table::read(&dir.join("missing.bin")).unwrap_err().to_string();
        assert!(e.contains("missing.bin"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
