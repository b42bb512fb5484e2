//! A recorded camera image on disk (`cam<i>/data/<t_ns>.png`), read as 8-bit grey.

use std::path::Path;

/// Reads one 8-bit grey image (a colour image is converted); only a regular file is opened. The
/// error says why, for the caller to name the file.
pub fn read_gray_image(path: &Path) -> Result<image::GrayImage, String> {
    sim::input_file::check(path).map_err(|e| format!("cannot read the image: {e}"))?;
    image::open(path)
        .map(|i| i.to_luma8())
        .map_err(|e| format!("cannot read the image: {e}"))
}
