//! From the virtual pinhole to the real camera: the distortion remap (with vignetting), motion
//! blur accumulation, depth remap and sensor noise — all on the CPU, in integer arithmetic
//! where it decides output bytes.
//!
//! The remap table is built once per camera: every real pixel `(u, v)` is unprojected through
//! the camera model, projected into the virtual pinhole and stored in 8 bytes: the index of its
//! top-left pinhole neighbour, the sub-pixel position in 1/256 px (a GPU's bilinear precision)
//! and the vignetting factor in 1/65536. A frame is then four byte loads and a few integer
//! multiply-adds per pixel, streaming a table small enough to stay cheap.

use super::{GrayImage, Photometric, VirtualPinhole, optics};
use crate::rng::sensor_rng;
use estimator::camera::CameraModel;
use nalgebra::{Vector2, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// One real pixel's bilinear tap into the (row-padded) 8-bit pinhole readback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tap {
    /// Byte index of the top-left neighbour (`y · row + x`).
    pub idx: u32,
    /// Sub-pixel x position inside the 2×2 cell (1/256 px).
    pub fx: u8,
    /// Sub-pixel y position (1/256 px).
    pub fy: u8,
    /// Vignetting factor in 1/65536; 0 for pixels that are not rendered (black).
    pub gain: u16,
}

/// One real pixel's position in the pinhole, for the depth remap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DepthTap {
    /// Column of the top-left neighbour; `u16::MAX`: not rendered.
    pub x: u16,
    /// Row of the top-left neighbour.
    pub y: u16,
    /// Fractional position inside the 2×2 cell, in 1/65535.
    pub frac: [u16; 2],
}

/// The virtual pinhole and remap tables of one camera.
#[derive(Clone, Debug)]
pub(crate) struct RemapTable {
    /// The virtual pinhole.
    pub pinhole: VirtualPinhole,
    /// Bytes per row of the pinhole readback (padded).
    pub row: usize,
    /// Image taps, one per real pixel (row-major).
    pub taps: Vec<Tap>,
    /// Depth taps, one per real pixel.
    pub depth_taps: Vec<DepthTap>,
}

/// Builds the virtual pinhole of `model` and its remap table.
///
/// The pinhole shares the camera's frame. Its focal length is the model's magnification on the
/// optical axis times `scale` (so at scale 1 the image centre keeps its resolution; the usual
/// lenses only compress towards the edges), capped so neither side exceeds `max_size`; it covers
/// the bearings of all pixels that the model unprojects within `max_half_angle_deg` of the axis,
/// plus a 2-pixel margin. Pixels outside get no tap (black).
pub(crate) fn build(
    model: &dyn CameraModel,
    row_padding: impl Fn(u32) -> u32,
    max_half_angle_deg: f64,
    max_size: u32,
    scale: f64,
    vignetting: f64,
) -> RemapTable {
    let (w, h) = (model.width(), model.height());
    let cos_max = max_half_angle_deg.to_radians().cos();
    let mut tangents: Vec<Option<Vector2<f64>>> = Vec::with_capacity(w as usize * h as usize);
    let (mut lo, mut hi) = (
        Vector2::repeat(f64::INFINITY),
        Vector2::repeat(f64::NEG_INFINITY),
    );
    for v in 0..h {
        for u in 0..w {
            let uv = Vector2::new(f64::from(u), f64::from(v));
            let t = model
                .unproject(&uv)
                .filter(|b| b.z > cos_max * b.norm())
                .map(|b| Vector2::new(b.x / b.z, b.y / b.z));
            if let Some(t) = t {
                lo = lo.inf(&t);
                hi = hi.sup(&t);
            }
            tangents.push(t);
        }
    }
    if !lo.x.is_finite() {
        lo = Vector2::repeat(-0.5);
        hi = Vector2::repeat(0.5);
    }
    let f_axis = model
        .project_with_jacobian(&Vector3::new(0.0, 0.0, 1.0))
        .map_or(f64::from(w.max(h)) / 2.0, |(_, j)| {
            j[(0, 0)].abs().max(j[(1, 1)].abs())
        });
    let margin = 2.0;
    let span = hi - lo;
    let limit = f64::from(max_size) - 2.0 * margin - 1.0;
    let f = (f_axis * scale).min(limit / span.x).min(limit / span.y);
    let pinhole = VirtualPinhole {
        f,
        cx: margin - f * lo.x,
        cy: margin - f * lo.y,
        width: (f * span.x + 2.0 * margin).ceil() as u32 + 1,
        height: (f * span.y + 2.0 * margin).ceil() as u32 + 1,
    };
    // Vignetting about the optical centre, normalized by the farthest corner.
    let c = model
        .project(&Vector3::new(0.0, 0.0, 1.0))
        .unwrap_or(Vector2::new(f64::from(w) / 2.0, f64::from(h) / 2.0));
    let r2_max = [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1)]
        .iter()
        .map(|&(x, y)| (f64::from(x) - c.x).powi(2) + (f64::from(y) - c.y).powi(2))
        .fold(1.0, f64::max);
    let row = row_padding(pinhole.width) as usize;
    let mut taps = Vec::with_capacity(tangents.len());
    let mut depth_taps = Vec::with_capacity(tangents.len());
    for (k, t) in tangents.into_iter().enumerate() {
        let Some(t) = t else {
            taps.push(Tap {
                idx: 0,
                fx: 0,
                fy: 0,
                gain: 0,
            });
            depth_taps.push(DepthTap {
                x: u16::MAX,
                y: 0,
                frac: [0; 2],
            });
            continue;
        };
        let (x, y) = (f * t.x + pinhole.cx, f * t.y + pinhole.cy);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (u, v) = ((k % w as usize) as f64, (k / w as usize) as f64);
        let r2 = (u - c.x).powi(2) + (v - c.y).powi(2);
        let gain = ((1.0 - vignetting * r2 / r2_max).max(0.0) * 65536.0).round();
        // 1/256-px positions; a position that rounds up to the next pixel moves there.
        let (mut qx, mut qy) = ((fx * 256.0).round() as usize, (fy * 256.0).round() as usize);
        let (mut ix, mut iy) = (x0 as usize, y0 as usize);
        if qx == 256 {
            (ix, qx) = (ix + 1, 0);
        }
        if qy == 256 {
            (iy, qy) = (iy + 1, 0);
        }
        taps.push(Tap {
            idx: (iy * row + ix) as u32,
            fx: qx as u8,
            fy: qy as u8,
            gain: gain.min(65535.0) as u16,
        });
        depth_taps.push(DepthTap {
            x: x0 as u16,
            y: y0 as u16,
            frac: [(fx * 65535.0).round() as u16, (fy * 65535.0).round() as u16],
        });
    }
    RemapTable {
        pinhole,
        row,
        taps,
        depth_taps,
    }
}

/// The tap's value: bilinear grey level × vignetting, in 1/65536 grey levels.
#[inline(always)]
fn tap_value(t: &Tap, pinhole: &[u8], row: usize) -> u32 {
    let i = t.idx as usize;
    let (top, bottom) = (&pinhole[i..i + 2], &pinhole[i + row..i + row + 2]);
    let (fx, fy) = (u32::from(t.fx), u32::from(t.fy));
    let upper = u32::from(top[0]) * (256 - fx) + u32::from(top[1]) * fx;
    let lower = u32::from(bottom[0]) * (256 - fx) + u32::from(bottom[1]) * fx;
    let v = upper * (256 - fy) + lower * fy; // grey level × 2^16, < 2^24
    ((u64::from(v) * u64::from(t.gain)) >> 16) as u32
}

/// One pinhole readback remapped straight to grey levels (one exposure sample, no noise):
/// the same rounding as [`finish`] of a single accumulated image.
pub(crate) fn remap_u8(table: &RemapTable, pinhole: &[u8]) -> Vec<u8> {
    let row = table.row;
    table
        .taps
        .iter()
        .map(|t| ((tap_value(t, pinhole, row) + (1 << 15)) >> 16).min(255) as u8)
        .collect()
}

/// True if `p` adds any sensor noise.
pub(crate) fn noisy(p: &Photometric) -> bool {
    p.read_noise > 0.0 || p.electrons_per_level > 0.0
}

/// Adds one pinhole readback (`table.row` bytes per row) through the table into `acc` (sums
/// of grey levels in 1/65536).
pub(crate) fn accumulate(table: &RemapTable, pinhole: &[u8], acc: &mut [u64]) {
    let row = table.row;
    for (a, t) in acc.iter_mut().zip(&table.taps) {
        *a += u64::from(tap_value(t, pinhole, row));
    }
}

/// Adds one pinhole readback through the table into `acc`, each image row weighted by its
/// weight in `row_weights[row * renders + render]` (a rolling shutter's rows).
pub(crate) fn accumulate_weighted(
    table: &RemapTable,
    pinhole: &[u8],
    (row_weights, renders, render): (&[u32], usize, usize),
    width: usize,
    acc: &mut [u64],
) {
    let row = table.row;
    for (r, (acc_row, taps)) in acc
        .chunks_exact_mut(width)
        .zip(table.taps.chunks_exact(width))
        .enumerate()
    {
        let w = u64::from(row_weights[r * renders + render]);
        if w == 0 {
            continue;
        }
        for (a, t) in acc_row.iter_mut().zip(taps) {
            *a += w * u64::from(tap_value(t, pinhole, row));
        }
    }
}

/// Turns sums of accumulated images into grey levels (`den`: the sum of a uniform grey level
/// of 1, `samples << 16` for a plain sum of `samples` images): without noise or blur rounded
/// exactly in integers, otherwise through [`develop`].
pub(crate) fn finish(
    acc: &[u64],
    den: u64,
    (width, height): (u32, u32),
    p: &Photometric,
    (seed, name, frame_index): (u64, &str, u64),
) -> GrayImage {
    let data = if !noisy(p) && p.optical_blur_px == 0.0 {
        acc.iter()
            .map(|&a| ((a * 2 + den) / (2 * den)).min(255) as u8)
            .collect()
    } else {
        let scale = (1.0 / den as f64) as f32;
        let levels = acc.iter().map(|&a| a as f32 * scale).collect();
        develop(levels, width as usize, p, (seed, name, frame_index))
    };
    GrayImage {
        width,
        height,
        data,
    }
}

/// One pinhole readback remapped to grey levels as floats: the single-sample case of
/// [`finish`]'s levels (the same values as accumulating once and scaling by 2⁻¹⁶), without the
/// sum buffer.
pub(crate) fn remap_levels(table: &RemapTable, pinhole: &[u8]) -> Vec<f32> {
    let row = table.row;
    let scale = (1.0 / f64::from(1u32 << 16)) as f32;
    table
        .taps
        .iter()
        .map(|t| u64::from(tap_value(t, pinhole, row)) as f32 * scale)
        .collect()
}

/// From grey levels to 8-bit pixels: with an optical blur, blurred (see [`optics`]); with
/// noise, read noise and shot noise from the stream `<name>/pixels` of `seed` (ChaCha stream =
/// `frame_index`) are added; then rounded. The standard normals are drawn first, in pixel order
/// (the one sequential step), and the arithmetic per pixel runs over whole rows at once.
pub(crate) fn develop(
    mut levels: Vec<f32>,
    width: usize,
    p: &Photometric,
    (seed, name, frame_index): (u64, &str, u64),
) -> Vec<u8> {
    if p.optical_blur_px > 0.0 {
        optics::gaussian_blur(&mut levels, width, p.optical_blur_px);
    }
    if !noisy(p) {
        return levels
            .iter()
            .map(|&i| i.round().clamp(0.0, 255.0) as u8)
            .collect();
    }
    let mut rng: ChaCha8Rng = sensor_rng(seed, &format!("{name}/pixels"));
    rng.set_stream(frame_index);
    let normals: Vec<f32> = (0..levels.len())
        .map(|_| StandardNormal.sample(&mut rng))
        .collect();
    let read2 = (p.read_noise * p.read_noise) as f32;
    let per_level = if p.electrons_per_level > 0.0 {
        (1.0 / p.electrons_per_level) as f32
    } else {
        0.0
    };
    levels
        .iter()
        .zip(&normals)
        .map(|(&i, &n)| {
            let v = i + (read2 + i * per_level).sqrt() * n;
            v.round().clamp(0.0, 255.0) as u8
        })
        .collect()
}

/// Remaps an inverse-depth pinhole image (`row` floats per row) to depth along the optical axis
/// (m, 0 where nothing is seen). Inverse depth is affine in pinhole pixels over a plane, so
/// bilinear interpolation is exact inside a surface; across a depth edge (neighbours more than
/// 2 % apart, or one of them empty) the nearest neighbour is taken instead of a blend.
pub(crate) fn depth(table: &RemapTable, inv: &[f32], row: usize) -> Vec<f32> {
    table
        .depth_taps
        .iter()
        .map(|t| {
            if t.x == u16::MAX {
                return 0.0;
            }
            let r0 = usize::from(t.y) * row + usize::from(t.x);
            let r1 = r0 + row;
            let q = [inv[r0], inv[r0 + 1], inv[r1], inv[r1 + 1]];
            let (fx, fy) = (
                f32::from(t.frac[0]) / 65535.0,
                f32::from(t.frac[1]) / 65535.0,
            );
            let lo = q.iter().cloned().fold(f32::INFINITY, f32::min);
            let hi = q.iter().cloned().fold(0.0, f32::max);
            let d = if lo <= 0.0 || hi > lo * 1.02 {
                q[usize::from(fx >= 0.5) + 2 * usize::from(fy >= 0.5)]
            } else {
                let top = q[0] + (q[1] - q[0]) * fx;
                let bottom = q[2] + (q[3] - q[2]) * fx;
                top + (bottom - top) * fy
            };
            if d > 0.0 { 1.0 / d } else { 0.0 }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::camera::{Camera, KannalaBrandt, PinholeRadtan};

    /// Every tap's 2×2 neighbourhood lies inside the pinhole readback, for a narrow and a wide
    /// lens, with and without the size cap, at the largest half-angle.
    #[test]
    fn taps_stay_inside_the_pinhole() {
        let pad = |w: u32| w.div_ceil(256) * 256;
        let models = [
            Camera::PinholeRadtan(PinholeRadtan::euroc_cam0()),
            Camera::KannalaBrandt(
                KannalaBrandt::new(
                    512, 512, 190.0, 190.0, 254.93, 256.9, 0.0034, 0.0007, -0.002, 0.0002,
                )
                .unwrap(),
            ),
        ];
        for model in &models {
            for (angle, cap, scale) in [(75.0, 2048, 1.0), (88.0, 8192, 1.0), (88.0, 300, 0.85)] {
                let t = build(model, pad, angle, cap, scale, 0.3);
                let (w, h) = (t.pinhole.width as usize, t.pinhole.height as usize);
                assert!(
                    w <= cap as usize && h <= cap as usize,
                    "{w}×{h} over the cap {cap}"
                );
                let len = t.row * h;
                let mut rendered = 0;
                for tap in &t.taps {
                    if tap.gain == 0 {
                        continue;
                    }
                    rendered += 1;
                    let i = tap.idx as usize;
                    assert!(i % t.row + 1 < w, "tap column {} of {w}", i % t.row);
                    assert!(i + t.row + 1 < len, "tap row {} of {h}", i / t.row);
                }
                assert!(rendered > t.taps.len() / 2, "{rendered} rendered pixels");
            }
        }
    }
}
