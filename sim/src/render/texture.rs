//! Procedural surface textures: tileable multi-scale grey-level images generated from the seed.
//!
//! Each material is a square, tileable `size × size` image at `texel_m` metres per texel:
//! value-noise fBm (octaves from a quarter of the tile down to two texels, amplitude falling as
//! `cell^H`) plus "splats" — rectangles and disks of random grey, from 1 cm to half a metre, like
//! posters, labels, stains and gravel — that give a tracker corners at every scale. The
//! texture-poor material is a painted wall: a faint, low-frequency shading only. A
//! [`TextureStyle`] thins the shapes out and scales the contrast of the textured materials
//! (fitted to real frames with `vio image-stats`). Mip levels are
//! 2×2 box averages in floating point, rounded once to `u8`.

use rand::RngExt;
use rand_chacha::ChaCha8Rng;

/// The materials, in texture-array layer order. Four layers: never six (the GL backend takes a
/// six-layer array for a cube map).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Material {
    /// fBm plus rectangles of every size (posters, boxes, labels).
    Posters,
    /// fBm plus many small disks (concrete, gravel).
    Gravel,
    /// fBm plus a mix of thin rectangles and disks (clutter).
    Clutter,
    /// A plain painted surface with faint low-frequency shading.
    Painted,
}

/// The layer order of the texture array.
pub(crate) const MATERIALS: [Material; 4] = [
    Material::Posters,
    Material::Gravel,
    Material::Clutter,
    Material::Painted,
];

/// Layers that carry rich texture (surfaces marked `Rich` draw one of these).
pub(crate) const RICH_LAYERS: u32 = 3;

/// Layer of the texture-poor material.
pub(crate) const POOR_LAYER: u32 = 3;

/// One octave of tileable value noise, added to `out` with weight `amp`: random lattice values
/// in [−1, 1] every `cell` texels, quintic-smoothstep interpolation.
fn add_value_noise(out: &mut [f32], n: usize, cell: usize, amp: f32, rng: &mut ChaCha8Rng) {
    let m = (n / cell).max(1);
    let lattice: Vec<f32> = (0..m * m)
        .map(|_| rng.random::<f32>() * 2.0 - 1.0)
        .collect();
    // Per-column lattice index and weight, shared by all rows.
    let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let cols: Vec<(usize, usize, f32)> = (0..n)
        .map(|x| {
            let c = x / cell;
            (c % m, (c + 1) % m, fade((x % cell) as f32 / cell as f32))
        })
        .collect();
    for y in 0..n {
        let c = y / cell;
        let (r0, r1) = ((c % m) * m, ((c + 1) % m) * m);
        let wy = fade((y % cell) as f32 / cell as f32);
        let row = &mut out[y * n..(y + 1) * n];
        for (v, &(c0, c1, wx)) in row.iter_mut().zip(&cols) {
            let a = lattice[r0 + c0] + (lattice[r0 + c1] - lattice[r0 + c0]) * wx;
            let b = lattice[r1 + c0] + (lattice[r1 + c1] - lattice[r1 + c0]) * wx;
            *v += amp * (a + (b - a) * wy);
        }
    }
}

/// fBm: octaves with cells from `max_cell` down to `min_cell` texels (rounded up to powers of
/// two, so every octave tiles), amplitude ∝ cell^h, the coarsest octave at amplitude `amp`.
fn add_fbm(
    out: &mut [f32],
    n: usize,
    (max_cell, min_cell): (usize, usize),
    h: f32,
    amp: f32,
    rng: &mut ChaCha8Rng,
) {
    let max_cell = max_cell.next_power_of_two().min(n);
    let mut cell = max_cell;
    while cell >= min_cell.next_power_of_two() {
        let a = amp * (cell as f32 / max_cell as f32).powf(h);
        add_value_noise(out, n, cell, a, rng);
        cell /= 2;
    }
}

/// A log-uniform draw in `[lo, hi]`.
fn log_uniform(rng: &mut ChaCha8Rng, lo: f32, hi: f32) -> f32 {
    (lo.ln() + rng.random::<f32>() * (hi.ln() - lo.ln())).exp()
}

/// Paints a wrapped (tileable) axis-aligned rectangle of grey `g` with opacity `alpha`.
fn splat_rect(
    out: &mut [f32],
    n: usize,
    (x0, y0): (usize, usize),
    (w, h): (usize, usize),
    g: f32,
    alpha: f32,
) {
    for dy in 0..h {
        let row = ((y0 + dy) % n) * n;
        for dx in 0..w {
            let v = &mut out[row + (x0 + dx) % n];
            *v += alpha * (g - *v);
        }
    }
}

/// Paints a wrapped disk of radius `r` texels (edge anti-aliased over one texel).
fn splat_disk(out: &mut [f32], n: usize, (cx, cy): (f32, f32), r: f32, g: f32, alpha: f32) {
    let ri = r.ceil() as i64 + 1;
    let (icx, icy) = (cx.floor() as i64, cy.floor() as i64);
    for dy in -ri..=ri {
        let y = icy + dy;
        let row = (y.rem_euclid(n as i64) as usize) * n;
        for dx in -ri..=ri {
            let x = icx + dx;
            let d = ((x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2)).sqrt();
            let cover = (r - d + 0.5).clamp(0.0, 1.0);
            if cover > 0.0 {
                let v = &mut out[row + x.rem_euclid(n as i64) as usize];
                *v += alpha * cover * (g - *v);
            }
        }
    }
}

/// How the textured materials are drawn (`RenderConfig::texture_contrast`, `texture_density`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TextureStyle {
    /// Contrast about mid-grey (1: as generated).
    pub contrast: f32,
    /// Shape count relative to the generator's own (1: as generated).
    pub density: f32,
}

impl TextureStyle {
    /// The generator's own textures.
    #[cfg(test)]
    pub(crate) const GENERATED: TextureStyle = TextureStyle {
        contrast: 1.0,
        density: 1.0,
    };
}

/// The base (level 0) image of `material`, values in [0, 1].
fn base_level(
    material: Material,
    n: usize,
    texel_m: f64,
    style: TextureStyle,
    rng: &mut ChaCha8Rng,
) -> Vec<f32> {
    let mut img = vec![0.5f32; n * n];
    let tex = |m: f32| ((f64::from(m) / texel_m).round() as usize).max(1); // metres → texels
    let texf = |m: f32| (f64::from(m) / texel_m) as f32;
    // Number of splats for a mean covered fraction `cover` of the tile at a mean area `area_m2`.
    let area = (n as f64 * texel_m).powi(2) as f32;
    let count =
        |cover: f32, area_m2: f32| (cover * style.density * area / area_m2).round() as usize;
    match material {
        Material::Posters => {
            add_fbm(&mut img, n, (tex(1.0), 2), 0.45, 0.3, rng);
            for _ in 0..count(0.6, 0.012) {
                let w = tex(log_uniform(rng, 0.015, 0.5));
                let h = tex(log_uniform(rng, 0.015, 0.5));
                let (x, y) = (rng.random_range(0..n), rng.random_range(0..n));
                let g = rng.random_range(0.05f32..0.95);
                let a = rng.random_range(0.5f32..1.0);
                splat_rect(&mut img, n, (x, y), (w, h), g, a);
            }
            add_fbm(&mut img, n, (tex(0.05), 2), 0.3, 0.05, rng);
        }
        Material::Gravel => {
            add_fbm(&mut img, n, (tex(2.0), 2), 0.35, 0.25, rng);
            for _ in 0..count(1.2, 0.0012) {
                let r = texf(log_uniform(rng, 0.006, 0.05));
                let (x, y) = (
                    rng.random::<f32>() * n as f32,
                    rng.random::<f32>() * n as f32,
                );
                let g = rng.random_range(0.1f32..0.9);
                let a = rng.random_range(0.4f32..1.0);
                splat_disk(&mut img, n, (x, y), r, g, a);
            }
        }
        Material::Clutter => {
            add_fbm(&mut img, n, (tex(1.0), 2), 0.4, 0.2, rng);
            for _ in 0..count(0.7, 0.004) {
                let (x, y) = (rng.random_range(0..n), rng.random_range(0..n));
                let g = rng.random_range(0.05f32..0.95);
                let a = rng.random_range(0.5f32..1.0);
                if rng.random::<bool>() {
                    let long = tex(log_uniform(rng, 0.05, 0.6));
                    let thin = tex(log_uniform(rng, 0.01, 0.05));
                    let (w, h) = if rng.random::<bool>() {
                        (long, thin)
                    } else {
                        (thin, long)
                    };
                    splat_rect(&mut img, n, (x, y), (w, h), g, a);
                } else {
                    let r = texf(log_uniform(rng, 0.01, 0.12));
                    splat_disk(&mut img, n, (x as f32, y as f32), r, g, a);
                }
            }
        }
        Material::Painted => {
            img.fill(0.72);
            add_fbm(&mut img, n, (tex(2.0), tex(0.25)), 0.8, 0.02, rng);
            return img;
        }
    }
    if style.contrast != 1.0 {
        img.iter_mut()
            .for_each(|v| *v = 0.5 + style.contrast * (*v - 0.5));
    }
    img
}

/// All mip levels of `material` as `u8`, level 0 first (`size` a power of two).
pub(crate) fn generate(
    material: Material,
    size: usize,
    texel_m: f64,
    style: TextureStyle,
    rng: &mut ChaCha8Rng,
) -> Vec<Vec<u8>> {
    let mut level = base_level(material, size, texel_m, style, rng);
    let mut n = size;
    let to_u8 = |l: &[f32]| -> Vec<u8> {
        l.iter()
            .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect()
    };
    let mut out = vec![to_u8(&level)];
    while n > 1 {
        let h = n / 2;
        let mut next = vec![0f32; h * h];
        for y in 0..h {
            for x in 0..h {
                let (a, b) = (level[2 * y * n + 2 * x], level[2 * y * n + 2 * x + 1]);
                let (c, d) = (
                    level[(2 * y + 1) * n + 2 * x],
                    level[(2 * y + 1) * n + 2 * x + 1],
                );
                next[y * h + x] = 0.25 * (a + b + c + d);
            }
        }
        out.push(to_u8(&next));
        level = next;
        n = h;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::sensor_rng;

    #[test]
    fn materials_are_deterministic_and_textured_as_named() {
        let n = 256;
        for (i, m) in MATERIALS.iter().enumerate() {
            let a = generate(
                *m,
                n,
                0.004,
                TextureStyle::GENERATED,
                &mut sensor_rng(3, "tex"),
            );
            let b = generate(
                *m,
                n,
                0.004,
                TextureStyle::GENERATED,
                &mut sensor_rng(3, "tex"),
            );
            assert_eq!(a, b);
            assert_eq!(a.len(), 9); // 256 … 1
            // Mean absolute horizontal gradient: rich layers have structure, the painted one not.
            let l0 = &a[0];
            let grad: f64 = (0..n * n)
                .map(|k| (f64::from(l0[k]) - f64::from(l0[(k / n) * n + (k + 1) % n])).abs())
                .sum::<f64>()
                / (n * n) as f64;
            if (i as u32) < RICH_LAYERS {
                assert!(grad > 3.0, "{m:?}: mean |grad| {grad}");
            } else {
                assert!(grad < 0.5, "{m:?}: mean |grad| {grad}");
            }
        }
    }

    #[test]
    fn noise_and_splats_wrap_around_the_tile() {
        let n = 256;
        // fBm: the step across the wrap is an ordinary step (a non-periodic lattice would make
        // it as large as the noise amplitude on every row).
        let mut img = vec![0f32; n * n];
        add_fbm(&mut img, n, (64, 2), 0.4, 1.0, &mut sensor_rng(5, "tex"));
        let step = |a: usize, b: usize| {
            (0..n)
                .map(|y| (img[y * n + a] - img[y * n + b]).abs())
                .sum::<f32>()
                / n as f32
        };
        let interior = (0..n - 1).map(|x| step(x, x + 1)).sum::<f32>() / (n - 1) as f32;
        let wrap = step(n - 1, 0);
        assert!(
            wrap < 2.0 * interior,
            "wrap step {wrap} vs interior {interior}"
        );
        // Splats crossing the edge continue on the other side.
        let mut img = vec![0f32; n * n];
        splat_rect(&mut img, n, (n - 2, n - 2), (4, 4), 1.0, 1.0);
        for (x, y) in [(n - 1, n - 1), (0, 0), (1, n - 2), (n - 2, 1)] {
            assert_eq!(img[y * n + x], 1.0, "({x}, {y})");
        }
        assert_eq!(img[2 * n + 2], 0.0);
        let mut img = vec![0f32; n * n];
        splat_disk(&mut img, n, (0.0, 0.0), 3.0, 1.0, 1.0);
        assert!(img[n - 1] > 0.9 && img[(n - 1) * n] > 0.9 && img[1] > 0.9);
    }
}
