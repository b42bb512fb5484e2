//! From the read-back pinhole images to the camera images: remap, motion-blur average,
//! sensor noise; and the copy of a frame's targets into the readback buffer.

use super::*;

/// Remaps (and blurs, and adds noise to) one camera's pinhole images from the readback bytes.
pub(super) fn finish_camera(
    cam: &CameraTargets,
    c: usize,
    data: &[u8],
    samples: usize,
    config: &RenderConfig,
    seed: u64,
    frame_index: u64,
) -> CameraImage {
    let (pw, ph) = (cam.table.pinhole.width, cam.table.pinhole.height);
    let row = padded_row(pw) as usize;
    let image_bytes = row * ph as usize;
    let base = cam.readback_offset as usize;
    let p = &config.photometric;
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
                (seed, &cam.name, frame_index),
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
        remap::finish(
            &acc,
            den,
            (cam.width, cam.height),
            p,
            (seed, &cam.name, frame_index),
        )
    };
    let depth = cam.inv_depth.as_ref().map(|_| {
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

pub(super) fn copy_out(
    enc: &mut wgpu::CommandEncoder,
    texture: &wgpu::Texture,
    buffer: &wgpu::Buffer,
    offset: u64,
    (width, height): (u32, u32),
    bytes_per_pixel: u32,
) {
    enc.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset,
                bytes_per_row: Some(padded_row(width * bytes_per_pixel)),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
}
