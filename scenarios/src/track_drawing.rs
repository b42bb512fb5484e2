//! Drawing tracks: a colour per track age and the strokes (lines, circles) both pictures of the
//! front end's tracks use (`vio render --tracks`, the tracks image of `run.mcap`).

use image::{Rgb, RgbImage};

/// Age (frames) at which the colour ramp ends (blue).
pub(crate) const OLDEST_AGE: u32 = 41;
/// Radius of the position circles (px).
pub(crate) const CIRCLE_PX: i32 = 4;
/// Width of every stroke (px): 2 stays visible in a half-size copy.
const PEN_PX: i64 = 2;

/// Colour of a track `age` frames old: hue from red (new) through yellow, green and cyan to
/// azure ([`OLDEST_AGE`] frames and older; lighter than pure blue on grey).
pub(crate) fn age_colour(age: u32) -> Rgb<u8> {
    let f = f64::from(age.saturating_sub(1).min(OLDEST_AGE - 1)) / f64::from(OLDEST_AGE - 1);
    let h = 3.5 * f; // hue in sixths of the circle: 0 red, 2 green, 3 cyan, 3.5 azure
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        _ => (0.0, x, 1.0),
    };
    let c = |v: f64| (255.0 * v).round() as u8;
    Rgb([c(r), c(g), c(b)])
}

/// Blends `colour` into the [`PEN_PX`]-wide square at `(x, y)` (top left) with opacity
/// `alpha`; pixels outside the image are skipped.
fn plot(img: &mut RgbImage, x: i64, y: i64, colour: Rgb<u8>, alpha: f32) {
    for (px, py) in (0..PEN_PX).flat_map(|dy| (0..PEN_PX).map(move |dx| (x + dx, y + dy))) {
        if px < 0 || py < 0 || px >= i64::from(img.width()) || py >= i64::from(img.height()) {
            continue;
        }
        let p = img.get_pixel_mut(px as u32, py as u32);
        for (d, s) in p.0.iter_mut().zip(colour.0) {
            *d = (f32::from(*d) * (1.0 - alpha) + f32::from(s) * alpha).round() as u8;
        }
    }
}

/// Bresenham line from `a` to `b` (both ends included).
pub(crate) fn line(img: &mut RgbImage, a: (i64, i64), b: (i64, i64), colour: Rgb<u8>, alpha: f32) {
    let (mut x, mut y) = a;
    let (dx, dy) = ((b.0 - a.0).abs(), -(b.1 - a.1).abs());
    let (sx, sy) = ((b.0 - a.0).signum(), (b.1 - a.1).signum());
    let mut err = dx + dy;
    loop {
        plot(img, x, y, colour, alpha);
        if (x, y) == b {
            break;
        }
        let e2 = 2 * err;
        if e2 >= dy {
            err += dy;
            x += sx;
        }
        if e2 <= dx {
            err += dx;
            y += sy;
        }
    }
}

/// Midpoint circle of radius `r` around `c` (outline only).
pub(crate) fn circle(img: &mut RgbImage, c: (i64, i64), r: i32, colour: Rgb<u8>) {
    let (mut x, mut y) = (i64::from(r), 0i64);
    let mut err = 1 - x;
    while x >= y {
        for (px, py) in [
            (x, y),
            (y, x),
            (-y, x),
            (-x, y),
            (-x, -y),
            (-y, -x),
            (y, -x),
            (x, -y),
        ] {
            plot(img, c.0 + px, c.1 + py, colour, 1.0);
        }
        y += 1;
        if err < 0 {
            err += 2 * y + 1;
        } else {
            x -= 1;
            err += 2 * (y - x) + 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn age_ramp_runs_from_red_to_azure() {
        assert_eq!(age_colour(1), Rgb([255, 0, 0]));
        assert_eq!(age_colour(OLDEST_AGE), Rgb([0, 128, 255]));
        assert_eq!(age_colour(1000), Rgb([0, 128, 255]));
        let mid = age_colour(OLDEST_AGE / 2 + 1);
        assert_eq!(mid.0[1], 255, "green halfway: {mid:?}");
    }

    #[test]
    fn lines_and_circles_stay_inside_and_hit_their_ends() {
        let mut img = RgbImage::new(10, 8);
        let red = Rgb([255, 0, 0]);
        line(&mut img, (-5, -5), (20, 20), red, 1.0);
        line(&mut img, (1, 6), (8, 2), red, 1.0);
        assert_eq!(*img.get_pixel(1, 6), red);
        assert_eq!(*img.get_pixel(8, 2), red);
        circle(&mut img, (9, 7), 3, red);
        assert_eq!(*img.get_pixel(9, 4), red);
        assert_eq!(*img.get_pixel(6, 7), red);
        assert_eq!(*img.get_pixel(0, 0), red, "on the diagonal");
        assert_eq!(*img.get_pixel(0, 7), Rgb([0, 0, 0]));
    }
}
