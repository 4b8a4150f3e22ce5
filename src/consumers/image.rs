//! 8-bit sRGB PNG images, written by the plots and the renderer.

use crate::consumers::ConsumerError;
use crate::error::IoError;

/// Write 8-bit RGB as PNG.
pub fn write_png(
    path: &std::path::Path,
    width: usize,
    height: usize,
    rgb: &[u8],
) -> Result<(), ConsumerError> {
    let png_error = |source| ConsumerError::Png {
        path: path.to_path_buf(),
        source,
    };
    let f = std::fs::File::create(path).map_err(IoError::doing("creating", path))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(f), width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut w = enc.write_header().map_err(png_error)?;
    w.write_image_data(rgb).map_err(png_error)?;
    w.finish().map_err(png_error)?;
    Ok(())
}
