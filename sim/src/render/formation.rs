//! Image formation on the CPU: from one frame's read-back pinhole renders to the camera images
//! (the distortion remap with vignetting, the motion-blur or rolling-shutter average, the optical
//! blur and the sensor noise; depth remapped). It holds no GPU object, so it runs on any thread:
//! the render worker forms frame k while the rasterizer draws frame k + 1.

use super::{
    CameraImage, DepthImage, GrayImage, ImageFrame, Photometric, padded_row, remap, shutter,
};

/// What image formation needs of one camera.
#[derive(Debug)]
pub(crate) struct CameraFormation {
    pub name: String,
    /// Image size (px).
    pub width: u32,
    pub height: u32,
    pub table: remap::RemapTable,
    /// Byte offset of this camera's first pinhole image in a frame's readback.
    pub readback_offset: usize,
    /// Per row, the weights of the frame's renders (a rig with a rolling shutter; see
    /// `shutter.rs`); `None`: the renders' plain average.
    pub row_weights: Option<Vec<u32>>,
}

/// One frame's renders as read back from the device: every camera's pinhole images (and
/// inverse depth), at the offsets of [`CameraFormation::readback_offset`].
#[derive(Debug)]
pub(crate) struct Readback {
    pub t_ns: i64,
    pub t_capture_ns: i64,
    /// Selects the noise.
    pub frame_index: u64,
    /// The cameras rendered (rig indices, increasing).
    pub live: Vec<usize>,
    pub bytes: Vec<u8>,
}

/// The image formation of a rig: per camera its tables, and the settings shared by all.
#[derive(Debug)]
pub(crate) struct ImageFormation {
    pub cameras: Vec<CameraFormation>,
    pub photometric: Photometric,
    /// Renders per frame (exposure samples).
    pub samples: usize,
    /// Depth images are formed too.
    pub depth: bool,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl ImageFormation {
    /// The camera images of one read-back frame. Cameras are formed in parallel, each from its
    /// own bytes: no shared state, so the result does not depend on the thread count.
    pub(crate) fn form(&self, frame: &Readback) -> ImageFrame {
        let cameras = std::thread::scope(|s| {
            let handles: Vec<_> = frame
                .live
                .iter()
                .map(|&c| s.spawn(move || self.camera_image(c, frame)))
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("image formation thread panicked"))
                .collect()
        });
        ImageFrame {
            t_ns: frame.t_ns,
            t_capture_ns: frame.t_capture_ns,
            cameras,
        }
    }

    /// Remaps (and averages, blurs, adds noise to) camera `c`'s pinhole images.
    fn camera_image(&self, c: usize, frame: &Readback) -> CameraImage {
        let cam = &self.cameras[c];
        let (pw, ph) = (cam.table.pinhole.width, cam.table.pinhole.height);
        let image_bytes = padded_row(pw) as usize * ph as usize;
        let data = &frame.bytes;
        let base = cam.readback_offset;
        let p = &self.photometric;
        let samples = self.samples;
        let noise = (self.seed, cam.name.as_str(), frame.frame_index);
        let image = if samples == 1 && !remap::noisy(p) && p.optical_blur_px == 0.0 {
            // The common case in one pass: no sum buffer.
            GrayImage {
                width: cam.width,
                height: cam.height,
                data: remap::remap_u8(&cam.table, &data[base..base + image_bytes]),
            }
        } else if samples == 1 && cam.row_weights.is_none() {
            // One exposure sample with blur or noise: float levels straight from the remap.
            let pinhole = &data[base..base + image_bytes];
            GrayImage {
                width: cam.width,
                height: cam.height,
                data: remap::develop(
                    remap::remap_levels(&cam.table, pinhole),
                    cam.width as usize,
                    p,
                    noise,
                ),
            }
        } else {
            let mut acc = vec![0u64; cam.width as usize * cam.height as usize];
            for k in 0..samples {
                let at = base + k * image_bytes;
                let pinhole = &data[at..at + image_bytes];
                match &cam.row_weights {
                    None => remap::accumulate(&cam.table, pinhole, &mut acc),
                    Some(w) => remap::accumulate_weighted(
                        &cam.table,
                        pinhole,
                        (w, samples, k),
                        cam.width as usize,
                        &mut acc,
                    ),
                }
            }
            let den = match &cam.row_weights {
                None => (samples as u64) << 16,
                Some(_) => u64::from(shutter::WEIGHT_ONE) << 16,
            };
            remap::finish(&acc, den, (cam.width, cam.height), p, noise)
        };
        let depth = self.depth.then(|| {
            let drow = padded_row(4 * pw) as usize;
            let at = base + samples * image_bytes;
            let inv: Vec<f32> = data[at..at + drow * ph as usize]
                .chunks_exact(4)
                .map(|b| f32::from_bits(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
                .collect();
            DepthImage {
                width: cam.width,
                height: cam.height,
                data: remap::depth(&cam.table, &inv, drow / 4),
            }
        });
        CameraImage {
            cam_id: c,
            image,
            depth,
        }
    }
}
