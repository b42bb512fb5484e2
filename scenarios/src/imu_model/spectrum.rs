//! Power spectral density by Welch's method (Hann window, 50 % overlap, each segment's mean
//! removed, one-sided, unit²/Hz), band power per octave, and the narrow spectral lines.
//!
//! A white noise of Kalibr density `N` (unit/√Hz) has the one-sided level `2·N²`.

use std::ops::Range;

use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::Serialize;

/// Longest Welch segment (samples).
pub const MAX_SEGMENT: usize = 2048;
/// Shortest Welch segment (samples).
pub const MIN_SEGMENT: usize = 64;
/// Lowest and highest octave band edges (Hz).
pub const OCTAVE_RANGE_HZ: (f64, f64) = (0.1, 100.0);
/// A line stands at least this far above the local median of the spectrum (dB).
pub const LINE_MIN_DB: f64 = 6.0;
/// Half-width of the running median a line is compared with (Hz).
const MEDIAN_HALF_WIDTH_HZ: f64 = 2.0;
/// Bins either side of a line's peak counted as its power (Hann main lobe: ±2).
const LINE_HALF_BINS: usize = 2;

/// A one-sided power spectral density.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Psd {
    /// Bin frequencies (Hz), from 0 to Nyquist.
    pub freq_hz: Vec<f64>,
    /// Density (unit²/Hz) at each bin.
    pub density: Vec<f64>,
    /// Segment length (samples).
    pub segment: usize,
    /// Segments averaged.
    pub segments: usize,
}

impl Psd {
    /// Bin spacing (Hz).
    pub fn df(&self) -> f64 {
        self.freq_hz.get(1).copied().unwrap_or(0.0)
    }

    /// The sum of several PSDs of the same shape (e.g. the three axes of a sensor).
    pub fn sum(parts: &[Psd]) -> Option<Psd> {
        let first = parts.first()?;
        let mut out = first.clone();
        for p in &parts[1..] {
            for (o, v) in out.density.iter_mut().zip(&p.density) {
                *o += v;
            }
        }
        Some(out)
    }
}

/// Power in one octave band.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Band {
    /// Lower edge (Hz).
    pub lo_hz: f64,
    /// Upper edge (Hz).
    pub hi_hz: f64,
    /// Power in the band (unit²); `None` when no bin falls in it (below the resolution).
    pub power: Option<f64>,
    /// Its square root, the band's RMS (unit).
    pub rms: Option<f64>,
}

/// A narrow spectral line.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Line {
    /// Frequency (Hz), refined between bins by a parabola through the log density.
    pub freq_hz: f64,
    /// Density at the peak bin (unit²/Hz).
    pub peak_density: f64,
    /// Local median density around it (unit²/Hz).
    pub median_density: f64,
    /// Height above the local median (dB).
    pub excess_db: f64,
    /// Power above the median over the peak's main lobe (unit²).
    pub power: f64,
    /// Amplitude of the sinusoid with that power, `sqrt(2·power)` (unit).
    pub amplitude: f64,
}

/// The longest power-of-two segment, at most [`MAX_SEGMENT`], that fits in the longest run.
pub fn segment_length(runs: &[Range<usize>]) -> Option<usize> {
    let longest = runs.iter().map(|r| r.len()).max()?;
    let mut seg = MAX_SEGMENT;
    while seg > longest {
        seg /= 2;
    }
    (seg >= MIN_SEGMENT).then_some(seg)
}

/// Welch PSD of `y` (sample rate `fs_hz`) over segments of `segment` samples inside the given
/// runs of contiguous samples; `None` when no segment fits.
pub fn welch(y: &[f64], runs: &[Range<usize>], fs_hz: f64, segment: usize) -> Option<Psd> {
    let l = segment;
    if l < 2 {
        return None;
    }
    let window: Vec<f64> = (0..l)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / l as f64).cos())
        .collect();
    let w2: f64 = window.iter().map(|w| w * w).sum();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(l);
    let bins = l / 2 + 1;
    let mut acc = vec![0.0; bins];
    let mut count = 0usize;
    let mut buf = vec![Complex::new(0.0, 0.0); l];
    let step = l / 2;
    for r in runs {
        let mut start = r.start;
        while start + l <= r.end {
            let seg = &y[start..start + l];
            let mean = seg.iter().sum::<f64>() / l as f64;
            for (b, (v, w)) in buf.iter_mut().zip(seg.iter().zip(&window)) {
                *b = Complex::new((v - mean) * w, 0.0);
            }
            fft.process(&mut buf);
            for (a, b) in acc.iter_mut().zip(&buf) {
                *a += b.norm_sqr();
            }
            count += 1;
            start += step;
        }
    }
    if count == 0 {
        return None;
    }
    let norm = 1.0 / (fs_hz * w2 * count as f64);
    let density = acc
        .iter()
        .enumerate()
        .map(|(k, a)| {
            let one_sided = if k == 0 || (l.is_multiple_of(2) && k == l / 2) {
                1.0
            } else {
                2.0
            };
            a * norm * one_sided
        })
        .collect();
    Some(Psd {
        freq_hz: (0..bins).map(|k| k as f64 * fs_hz / l as f64).collect(),
        density,
        segment: l,
        segments: count,
    })
}

/// Power per octave from [`OCTAVE_RANGE_HZ`]'s lower edge up to its upper edge or Nyquist.
pub fn octave_bands(psd: &Psd) -> Vec<Band> {
    let df = psd.df();
    let nyquist = psd.freq_hz.last().copied().unwrap_or(0.0);
    let top = OCTAVE_RANGE_HZ.1.min(nyquist);
    let mut out = Vec::new();
    let mut lo = OCTAVE_RANGE_HZ.0;
    while lo < top {
        let hi = (2.0 * lo).min(top);
        let last = hi >= top;
        let p: Vec<f64> = psd
            .freq_hz
            .iter()
            .zip(&psd.density)
            .filter(|(f, _)| **f >= lo && (**f < hi || (last && **f <= hi)))
            .map(|(_, d)| d * df)
            .collect();
        let power = (!p.is_empty()).then(|| p.iter().sum::<f64>());
        out.push(Band {
            lo_hz: lo,
            hi_hz: hi,
            power,
            rms: power.map(f64::sqrt),
        });
        lo *= 2.0;
    }
    out
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// The strongest narrow lines above `min_hz`: local maxima at least [`LINE_MIN_DB`] above the
/// running median (±2 Hz), strongest (by power) first, at most `max_lines`.
pub fn find_lines(psd: &Psd, min_hz: f64, max_lines: usize) -> Vec<Line> {
    let n = psd.density.len();
    let df = psd.df();
    if n < 5 || df <= 0.0 {
        return Vec::new();
    }
    let half = ((MEDIAN_HALF_WIDTH_HZ / df).round() as usize).max(4);
    let d = &psd.density;
    let threshold = 10f64.powf(LINE_MIN_DB / 10.0);
    let mut lines = Vec::new();
    for i in 1..n - 1 {
        if psd.freq_hz[i] < min_hz || !(d[i] > d[i - 1] && d[i] >= d[i + 1]) {
            continue;
        }
        let mut around: Vec<f64> = d[i.saturating_sub(half)..(i + half + 1).min(n)].to_vec();
        let med = median(&mut around);
        if !(med > 0.0 && d[i] >= threshold * med) {
            continue;
        }
        let lobe = i.saturating_sub(LINE_HALF_BINS)..(i + LINE_HALF_BINS + 1).min(n);
        let power: f64 = d[lobe].iter().map(|v| (v - med).max(0.0) * df).sum();
        // Parabola through the log density of the peak and its neighbours.
        let (a, b, c) = (d[i - 1].ln(), d[i].ln(), d[i + 1].ln());
        let den = a - 2.0 * b + c;
        let shift = if den < 0.0 {
            (0.5 * (a - c) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        lines.push(Line {
            freq_hz: psd.freq_hz[i] + shift * df,
            peak_density: d[i],
            median_density: med,
            excess_db: 10.0 * (d[i] / med).log10(),
            power,
            amplitude: (2.0 * power).sqrt(),
        });
    }
    lines.sort_by(|x, y| {
        y.power
            .total_cmp(&x.power)
            .then(x.freq_hz.total_cmp(&y.freq_hz))
    });
    lines.truncate(max_lines);
    lines
}

/// The maximal runs of consecutive indices where `mask` is true.
pub fn runs_of(mask: &[bool]) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, &m) in mask.iter().enumerate() {
        match (m, start) {
            (true, None) => start = Some(i),
            (false, Some(s)) => {
                out.push(s..i);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push(s..mask.len());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sinusoid_is_found_with_its_frequency_and_amplitude() {
        let fs = 200.0;
        let n = 20_000;
        // A 37.3 Hz sinusoid of amplitude 0.5 over a small deterministic broadband signal.
        let y: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 / fs;
                0.5 * (2.0 * std::f64::consts::PI * 37.3 * t).sin()
                    + 0.01 * ((k * 7919 % 1009) as f64 / 1009.0 - 0.5)
            })
            .collect();
        let runs = runs_of(&vec![true; n]);
        let psd = welch(&y, &runs, fs, segment_length(&runs).unwrap()).unwrap();
        assert_eq!(psd.segment, 2048);
        // Parseval: total power ≈ variance (0.125 + the small broadband part).
        let total: f64 = psd.density.iter().sum::<f64>() * psd.df();
        assert!((total - 0.125).abs() < 0.01, "{total}");
        let lines = find_lines(&psd, 1.0, 3);
        assert!((lines[0].freq_hz - 37.3).abs() < 0.05, "{:?}", lines[0]);
        assert!((lines[0].amplitude - 0.5).abs() < 0.03, "{:?}", lines[0]);
    }

    #[test]
    fn runs_split_at_false() {
        let m = [true, true, false, true, false, false, true];
        assert_eq!(runs_of(&m), vec![0..2, 3..4, 6..7]);
    }
}
