//! Environment maps: OpenEXR (exr) and Radiance HDR (RGBE), equirectangular.
//!
//! Repairs (documented, with a warning): non-finite or negative texels become 0.

use super::{Result, SceneError};
use engine_math::envmap::LatLongMap;
use std::path::Path;

/// Load an equirectangular environment map (`.exr` or `.hdr`), row 0 at the zenith. Non-finite or
/// negative texel channels are set to 0 with a warning ([`load_environment_with_repairs`] counts them).
pub fn load_environment(path: &Path) -> Result<LatLongMap> {
    load_environment_with_repairs(path).map(|(map, _)| map)
}

/// [`load_environment`], also returning how many texel channels it repaired (set to 0 because they were
/// non-finite or negative). The shipped maps in `assets/envmaps` are clean (0; tests/tests/bad_input.rs checks);
/// the repair is for user files.
pub fn load_environment_with_repairs(path: &Path) -> Result<(LatLongMap, usize)> {
    if !path.exists() {
        return Err(SceneError::NotFound { path: path.to_path_buf() });
    }
    let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
    let mut map = match ext.as_str() {
        "exr" => load_exr(path)?,
        "hdr" | "pic" => load_hdr(path)?,
        _ => return Err(SceneError::invalid(path, "unknown environment format (expected .exr or .hdr)")),
    };
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

fn load_exr(path: &Path) -> Result<LatLongMap> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res: Vec2<usize>, _| (res.width(), vec![[0f32; 3]; res.width() * res.height()]),
        |(w, px): &mut (usize, Vec<[f32; 3]>), pos: Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| SceneError::invalid(path, format!("not a readable OpenEXR RGB(A) image: {e}")))?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok(LatLongMap { width: size.width(), height: size.height(), texels })
}

/// Radiance RGBE (`#?RADIANCE`), flat or new-style run-length encoded scanlines, `-Y H +X W` only.
fn load_hdr(path: &Path) -> Result<LatLongMap> {
    let data = std::fs::read(path).map_err(|e| SceneError::invalid(path, format!("cannot read: {e}")))?;
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
                return Err(bad(&format!("unsupported FORMAT {f}")));
            }
        }
    }
    let res = line().ok_or_else(|| bad("missing resolution line"))?;
    let parts: Vec<&str> = res.split_whitespace().collect();
    let (h, w) = match parts.as_slice() {
        ["-Y", h, "+X", w] => {
            (h.parse::<usize>().map_err(|_| bad("bad height"))?, w.parse::<usize>().map_err(|_| bad("bad width"))?)
        }
        _ => return Err(bad(&format!("unsupported orientation '{res}' (only -Y H +X W)"))),
    };
    if w == 0 || h == 0 || w > 1 << 16 || h > 1 << 16 {
        return Err(bad(&format!("unreasonable size {w}x{h}")));
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
