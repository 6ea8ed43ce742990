//! Environment maps: OpenEXR (exr) and Radiance HDR (RGBE), equirectangular.
//!
//! Repairs (documented, with a warning): non-finite or negative texels become 0.
//!
//! Size limits: both loaders read the dimensions from the header and check them before allocating
//! anything, against [`MAX_ENV_SIDE`] and [`MAX_ENV_TEXELS`] and against the file's length (a file too short
//! to hold the pixel data its header announces is refused). A corrupt header used to ask for up to 3.4 PB
//! and abort the process.

use super::{Result, SceneError};
use engine_math::envmap::LatLongMap;
use std::path::Path;

/// The widest or tallest environment map accepted, in texels: 16384, the largest equirectangular maps
/// published (16K HDRIs are 16384 × 8192).
pub const MAX_ENV_SIDE: usize = 16384;
/// The most texels accepted: 16384 × 8192 (a 16K map), 1.5 GiB as the loader's f32 RGB texels.
/// Larger maps would not fit the GPU upload anyway, and nothing in the renderer resolves more detail.
pub const MAX_ENV_TEXELS: usize = 16384 * 8192;

/// Refuse `w × h` before anything is allocated for it.
fn check_size(w: usize, h: usize) -> std::result::Result<(), String> {
    if w == 0 || h == 0 {
        return Err(format!("empty image ({w}x{h})"));
    }
    if w > MAX_ENV_SIDE || h > MAX_ENV_SIDE || w.saturating_mul(h) > MAX_ENV_TEXELS {
        return Err(format!(
            "{w}x{h} is larger than the {MAX_ENV_SIDE} texels a side and {MAX_ENV_TEXELS} texels (16384x8192) \
             accepted"
        ));
    }
    Ok(())
}

/// Load an equirectangular environment map (`.exr` or `.hdr`), row 0 at the zenith. Non-finite or
/// negative texel channels are set to 0 with a warning ([`load_environment_with_repairs`] counts them).
pub fn load_environment(path: &Path) -> Result<LatLongMap> {
    load_environment_with_repairs(path).map(|(map, _)| map)
}

/// [`load_environment`], also returning how many texel channels it repaired (set to 0 because they were
/// non-finite or negative). The shipped maps in `assets/envmaps` are clean (0; tests/tests/bad_input.rs checks);
/// the repair is for user files.
pub fn load_environment_with_repairs(path: &Path) -> Result<(LatLongMap, usize)> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
    if !matches!(ext.as_str(), "exr" | "hdr" | "pic") {
        engine_io::check(path, engine_io::Limit::ENVIRONMENT)?;
        return Err(SceneError::invalid(path, "unknown environment format (expected .exr or .hdr)"));
    }
    let data = engine_io::read(path, engine_io::Limit::ENVIRONMENT)?;
    let mut map = match ext.as_str() {
        "exr" => load_exr(path, &data)?,
        _ => load_hdr(path, &data)?,
    };
    drop(data);
    if map.width < 2 || map.height < 1 {
        return Err(SceneError::invalid(path, format!("environment map too small ({}x{})", map.width, map.height)));
    }
    if map.width != 2 * map.height {
        log::warn!("{}: {}x{} is not 2:1; treated as equirectangular anyway", path.display(), map.width, map.height);
    }
    let mut repaired = 0usize;
    for t in &mut map.texels {
        for c in t.iter_mut() {
            if !c.is_finite() || *c < 0.0 {
                *c = 0.0;
                repaired += 1;
            }
        }
    }
    if repaired > 0 {
        log::warn!("{}: {repaired} non-finite or negative texel channel(s) set to 0", path.display());
        eprintln!("warning: {}: {repaired} non-finite or negative texel channel(s) set to 0", path.display());
    }
    Ok((map, repaired))
}

fn load_exr(path: &Path, data: &[u8]) -> Result<LatLongMap> {
    use exr::prelude::*;
    // The exr crate hands the header's resolution to the closure below, which allocates it: check the
    // headers ourselves first.
    check_exr_headers(data).map_err(|m| SceneError::invalid(path, format!("not a valid OpenEXR file: {m}")))?;
    // The crate is meant to return errors, but it has panicked on corrupt input before: contain a panic
    // as an error naming the file (sizes are checked above, so nothing here can abort on allocation).
    //
    // The resolution the decoder settles on is checked again where it allocates: the header walk above and
    // the crate's own parser can disagree on a corrupt header (the fuzzer found an 806-byte file, accepted by the
    // walk, for which the crate asked for 12 TB: tools/fuzz/corpus/exr/abort-12tb-allocation.exr). An
    // oversized resolution gets no storage (every texel write is then skipped) and is refused after reading.
    let refused = std::cell::Cell::new(None);
    let read = engine_io::catch_quiet(|| {
        read()
            .no_deep_data()
            .largest_resolution_level()
            .rgba_channels(
                |res: Vec2<usize>, _: &RgbaChannels| match check_size(res.width(), res.height()) {
                    Ok(()) => (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
                    Err(m) => {
                        refused.set(Some(m));
                        (0, Vec::new())
                    }
                },
                |(w, px): &mut (usize, Vec<[f32; 3]>), pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                    if let Some(t) = px.get_mut(pos.y() * *w + pos.x()) {
                        *t = [r, g, b];
                    }
                },
            )
            .first_valid_layer()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(data))
    });
    if let Some(m) = refused.take() {
        return Err(SceneError::invalid(path, format!("not a valid OpenEXR file: {m}")));
    }
    let image = match read {
        Ok(r) => r.map_err(|e| SceneError::invalid(path, format!("not a readable OpenEXR RGB(A) image: {e}")))?,
        Err(_) => return Err(SceneError::invalid(path, "not a readable OpenEXR image (the decoder panicked)")),
    };
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    if texels.len() != size.width() * size.height() {
        return Err(SceneError::invalid(
            path,
            "not a valid OpenEXR file: the decoder's size disagrees with its pixels",
        ));
    }
    Ok(LatLongMap { width: size.width(), height: size.height(), texels })
}

/// Walk the OpenEXR headers (OpenEXR file layout: magic, version word, then per part a list of attributes
/// `name\0 type\0 size:i32 value`, ended by an empty name; multi-part files end the list of headers with one
/// more empty name) and check each part's `dataWindow` against [`check_size`], and the file's length
/// against the offset tables that must follow (8 bytes per chunk), before the decoder allocates anything.
fn check_exr_headers(data: &[u8]) -> std::result::Result<(), String> {
    if data.len() < 8 || data[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return Err("missing the OpenEXR magic number".into());
    }
    let flags = u32::from_le_bytes([data[4], data[5], data[6], data[7]]);
    let (tiled, deep, multipart) = (flags & 0x200 != 0, flags & 0x800 != 0, flags & 0x1000 != 0);
    if deep {
        return Err("deep data is not an environment map".into());
    }
    let mut pos = 8usize;
    let cstr = |pos: &mut usize| -> std::result::Result<&[u8], String> {
        let rest = data.get(*pos..).unwrap_or_default();
        let n = rest.iter().take(256).position(|&b| b == 0).ok_or("truncated or overlong attribute name")?;
        *pos += n + 1;
        Ok(&rest[..n])
    };
    let mut chunks_total = 0u64;
    let mut parts = 0;
    loop {
        if multipart && data.get(pos) == Some(&0) {
            pos += 1;
            break;
        }
        parts += 1;
        if parts > 1024 {
            return Err("more than 1024 parts".into());
        }
        let (mut window, mut compression, mut tiles, mut chunk_count) = (None, 0u8, None, None);
        loop {
            let name = cstr(&mut pos)?;
            if name.is_empty() {
                break;
            }
            let _ty = cstr(&mut pos)?;
            let size = data.get(pos..pos + 4).ok_or("truncated attribute size")?;
            let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
            pos += 4;
            let size = usize::try_from(size).map_err(|_| format!("negative attribute size {size}"))?;
            let value = data.get(pos..pos.saturating_add(size)).ok_or("attribute runs past the end of the file")?;
            pos += size;
            let i32_at = |k: usize| value.get(4 * k..4 * k + 4).map(|b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            match name {
                b"dataWindow" => {
                    let b = (0..4).map(i32_at).collect::<Option<Vec<i32>>>().ok_or("short dataWindow")?;
                    window = Some((b[0] as i64, b[1] as i64, b[2] as i64, b[3] as i64));
                }
                b"compression" => compression = *value.first().ok_or("empty compression")?,
                b"tiles" => tiles = Some((i32_at(0).ok_or("short tiles")?, i32_at(1).ok_or("short tiles")?)),
                b"chunkCount" => chunk_count = Some(i32_at(0).ok_or("short chunkCount")?),
                _ => {}
            }
        }
        let (x0, y0, x1, y1) = window.ok_or("a part has no dataWindow")?;
        let (w, h) = (x1 - x0 + 1, y1 - y0 + 1);
        if w <= 0 || h <= 0 {
            return Err(format!("empty or inverted dataWindow ({x0},{y0})-({x1},{y1})"));
        }
        check_size(w as usize, h as usize)?;
        // Chunks of level 0 alone (mip levels only add more): scan-line blocks by compression (OpenEXR
        // file layout: 1 line for none/RLE/ZIPS, 16 for ZIP/PXR24, 32 for PIZ/B44/B44A/DWAA, 256 for DWAB).
        let chunks = if let Some((tw, th)) = tiles.filter(|_| tiled || multipart) {
            if tw <= 0 || th <= 0 {
                return Err(format!("bad tile size {tw}x{th}"));
            }
            // The decoder allocates whole tiles: a tile far larger than the image is a decompression bomb, not
            // a layout (the fuzzer: an 8x4 image in 671 bytes with 4x134217732 tiles cost 1 GiB and 9 s).
            if tw as i64 > w.max(256) || th as i64 > h.max(256) {
                return Err(format!("tile size {tw}x{th} larger than the {w}x{h} image (and 256)"));
            }
            (w as u64).div_ceil(tw as u64) * (h as u64).div_ceil(th as u64)
        } else {
            let lines = match compression {
                0..=2 => 1,
                3 | 5 => 16,
                4 | 6..=8 => 32,
                9 => 256,
                c => return Err(format!("unknown compression {c}")),
            };
            (h as u64).div_ceil(lines)
        };
        if let Some(c) = chunk_count {
            if c < 0 {
                return Err(format!("negative chunkCount {c}"));
            }
        }
        chunks_total += chunks;
        if !multipart {
            break;
        }
    }
    // Each chunk has an 8-byte offset in the table after the headers, and at least 8 bytes of its own.
    let needed = (pos as u64).saturating_add(chunks_total.saturating_mul(16));
    if (data.len() as u64) < needed {
        return Err(format!(
            "the file has {} bytes but its header announces {chunks_total} chunks, which need at least {needed}",
            data.len()
        ));
    }
    Ok(())
}

/// Radiance RGBE (`#?RADIANCE`), flat or new-style run-length encoded scanlines, `-Y H +X W` only.
fn load_hdr(path: &Path, data: &[u8]) -> Result<LatLongMap> {
    let bad = |m: &str| SceneError::invalid(path, format!("not a valid Radiance HDR file: {m}"));
    let mut pos = 0;
    let mut line = || -> Option<String> {
        let start = pos;
        while pos < data.len() && data[pos] != b'\n' {
            pos += 1;
        }
        if pos >= data.len() {
            return None;
        }
        pos += 1;
        Some(String::from_utf8_lossy(&data[start..pos - 1]).into_owned())
    };
    let first = line().ok_or_else(|| bad("empty"))?;
    if !first.starts_with("#?") {
        return Err(bad("missing #? signature"));
    }
    loop {
        let l = line().ok_or_else(|| bad("header not terminated"))?;
        if l.is_empty() {
            break;
        }
        if let Some(f) = l.strip_prefix("FORMAT=") {
            if f.trim() != "32-bit_rle_rgbe" {
                return Err(bad(&format!("unsupported FORMAT {}", engine_io::quote(f))));
            }
        }
    }
    let res = line().ok_or_else(|| bad("missing resolution line"))?;
    let parts: Vec<&str> = res.split_whitespace().collect();
    let (h, w) = match parts.as_slice() {
        ["-Y", h, "+X", w] => {
            (h.parse::<usize>().map_err(|_| bad("bad height"))?, w.parse::<usize>().map_err(|_| bad("bad width"))?)
        }
        _ => return Err(bad(&format!("unsupported orientation {} (only -Y H +X W)", engine_io::quote(&res)))),
    };
    check_size(w, h).map_err(|m| bad(&m))?;
    // The smallest encoding of a scanline: 4 run-length codes of at most 127 texels, 2 bytes each, per
    // channel after a 4-byte marker (flat scanlines take 4 bytes a texel, more). A file shorter than that
    // for its announced size is truncated: refuse it before allocating (8 KB used to ask for 51.5 GB).
    let min_scanline = if (8..32768).contains(&w) { 4 + 4 * 2 * w.div_ceil(127) } else { 4 * w };
    let needed = pos.saturating_add(h.saturating_mul(min_scanline));
    if data.len() < needed {
        return Err(bad(&format!("truncated: {w}x{h} needs at least {needed} bytes, the file has {}", data.len())));
    }
    let mut texels = Vec::with_capacity(w * h);
    let mut scan = vec![[0u8; 4]; w];
    for _ in 0..h {
        let rest = &data[pos.min(data.len())..];
        if rest.len() >= 4
            && rest[0] == 2
            && rest[1] == 2
            && (rest[2] as usize) << 8 | rest[3] as usize == w
            && (8..32768).contains(&w)
        {
            pos += 4;
            for c in 0..4 {
                let mut x = 0;
                while x < w {
                    let n = *data.get(pos).ok_or_else(|| bad("truncated scanline"))? as usize;
                    pos += 1;
                    if n > 128 {
                        let run = n - 128;
                        let v = *data.get(pos).ok_or_else(|| bad("truncated run"))?;
                        pos += 1;
                        if x + run > w {
                            return Err(bad("run overflows scanline"));
                        }
                        for s in &mut scan[x..x + run] {
                            s[c] = v;
                        }
                        x += run;
                    } else {
                        if n == 0 || x + n > w || pos + n > data.len() {
                            return Err(bad("bad literal run"));
                        }
                        for (k, s) in scan[x..x + n].iter_mut().enumerate() {
                            s[c] = data[pos + k];
                        }
                        pos += n;
                        x += n;
                    }
                }
            }
        } else {
            for s in scan.iter_mut() {
                let px = data.get(pos..pos + 4).ok_or_else(|| bad("truncated pixel data"))?;
                s.copy_from_slice(px);
                pos += 4;
            }
        }
        for s in &scan {
            let f = if s[3] == 0 { 0.0 } else { 2f32.powi(s[3] as i32 - 136) };
            texels.push([s[0] as f32 * f, s[1] as f32 * f, s[2] as f32 * f]);
        }
    }
    Ok(LatLongMap { width: w, height: h, texels })
}
