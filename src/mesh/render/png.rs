//! PNG: a [`Picture`] → the bytes of an 8-bit RGB PNG file (png crate, fixed settings, so the
//! same picture always gives the same bytes).

use std::io::{self, Write};

use super::Picture;

/// Writes the picture as an 8-bit RGB PNG.
pub fn write_png(out: &mut dyn Write, picture: &Picture) -> io::Result<()> {
    let mut encoder = png::Encoder::new(out, picture.width(), picture.height());
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(picture.rgb())?;
    writer.finish()?;
    Ok(())
}
