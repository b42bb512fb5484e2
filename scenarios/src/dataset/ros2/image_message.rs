//! A `sensor_msgs/msg/Image` as grey levels: `mono8` (and its OpenCV name `8UC1`) as it is,
//! `mono16` / `16UC1` scaled to 8 bits by the high byte, rows copied out of a padded `step`.

use super::cdr::decode;
use super::messages::Image;

/// The grey image in a bag's `Image` message bytes; an error says what does not fit.
pub fn gray_image(data: &[u8]) -> Result<image::GrayImage, String> {
    let msg: Image = decode(data)?;
    let (w, h, step) = (msg.width as usize, msg.height as usize, msg.step as usize);
    let bytes_per_pixel = match msg.encoding.as_str() {
        "mono8" | "8UC1" => 1,
        "mono16" | "16UC1" => 2,
        other => {
            return Err(format!(
                "image encoding `{other}`: the front end takes mono8 (or mono16) images"
            ));
        }
    };
    if w == 0 || h == 0 {
        return Err(format!("an empty image ({w}×{h})"));
    }
    if step < w * bytes_per_pixel || msg.data.len() < step * (h - 1) + w * bytes_per_pixel {
        return Err(format!(
            "{w}×{h} {} with step {step} needs {} bytes, the message has {}",
            msg.encoding,
            step * (h - 1) + w * bytes_per_pixel,
            msg.data.len()
        ));
    }
    let mut pixels = Vec::with_capacity(w * h);
    for row in 0..h {
        let line = &msg.data[row * step..row * step + w * bytes_per_pixel];
        if bytes_per_pixel == 1 {
            pixels.extend_from_slice(line);
        } else {
            let high = if msg.is_bigendian != 0 { 0 } else { 1 };
            pixels.extend(line.chunks_exact(2).map(|p| p[high]));
        }
    }
    image::GrayImage::from_raw(msg.width, msg.height, pixels)
        .ok_or_else(|| format!("{w}×{h}: not an image size"))
}
