//! Order statistics of a recording's samples (spacings, departures, accelerations), shared by
//! its checks: 0 for no samples.

/// The upper median (the middle element of the sorted values).
pub(super) fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The value at fraction `p` (0..=1) of the sorted values, the nearest rank rounded.
pub(super) fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}
