//! Images out: linear OpenEXR and tone-mapped PNG.

use std::path::Path;

#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct OutputError {
    pub path: String,
    pub message: String,
}

fn err(path: &Path, message: impl ToString) -> OutputError {
    OutputError { path: path.display().to_string(), message: message.to_string() }
}

/// Write RGBA32F texels (row-major, top row first) as a linear RGB OpenEXR file (f32 channels).
pub fn write_exr(path: &Path, width: u32, height: u32, rgba: &[f32]) -> Result<(), OutputError> {
    if rgba.len() != (width * height * 4) as usize {
        return Err(err(path, format!("{} floats for a {width}x{height} RGBA image", rgba.len())));
    }
    exr::prelude::write_rgb_file(path, width as usize, height as usize, |x, y| {
        let i = (y * width as usize + x) * 4;
        (rgba[i], rgba[i + 1], rgba[i + 2])
    })
    .map_err(|e| err(path, e))
}

/// Write RGBA8 texels as an sRGB PNG.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), OutputError> {
    let bytes = encode_png(width, height, rgba).map_err(|e| err(path, e))?;
    std::fs::write(path, bytes).map_err(|e| err(path, e))
}

/// RGBA8 texels as the bytes of an sRGB PNG file (for pages that embed their images).
pub fn encode_png(width: u32, height: u32, rgba: &[u8]) -> Result<Vec<u8>, String> {
    if rgba.len() != (width as usize) * (height as usize) * 4 {
        return Err(format!("{} bytes for a {width}x{height} RGBA8 image", rgba.len()));
    }
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut w = enc.write_header().map_err(|e| e.to_string())?;
    w.write_image_data(rgba).map_err(|e| e.to_string())?;
    w.finish().map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// Read a PNG as 8-bit RGBA: (width, height, RGBA8 bytes). Palette, grey and grey-alpha images are expanded,
/// 16-bit channels reduced to their high byte. The file is read through `engine_io` (a regular file of at most
/// `Limit::IMAGE`).
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>), OutputError> {
    let bytes = engine_io::read(path, engine_io::Limit::IMAGE).map_err(|e| err(path, e.message()))?;
    decode_png(&bytes).map_err(|m| err(path, m))
}

/// [`read_png`] from the file's bytes. The decoder's default limit (64 MiB of decoded image) bounds what a
/// header can ask for.
pub fn decode_png(bytes: &[u8]) -> Result<(u32, u32, Vec<u8>), String> {
    let mut dec = png::Decoder::new(std::io::Cursor::new(bytes));
    dec.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = dec.read_info().map_err(|e| e.to_string())?;
    let mut buf = vec![0; reader.output_buffer_size().ok_or("image too large")?];
    let info = reader.next_frame(&mut buf).map_err(|e| e.to_string())?;
    buf.truncate(info.buffer_size());
    let rgba = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf.chunks_exact(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g, 255]).collect(),
        png::ColorType::GrayscaleAlpha => buf.chunks_exact(2).flat_map(|c| [c[0], c[0], c[0], c[1]]).collect(),
        other => return Err(format!("unsupported PNG colour type {other:?}")),
    };
    Ok((info.width, info.height, rgba))
}
