//! The short human summary `vio run` prints.

use std::fmt::Write as _;
use std::path::Path;

use super::Report;
use super::{window_vs_batch, window_vs_filter};

fn opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    match v {
        Some(v) => format!("{v:.digits$}{unit}"),
        None => "n/a".into(),
    }
}

/// The short human summary `vio run` prints.
pub fn summary(report: &Report, out_dir: Option<&Path>) -> String {
    let mut s = String::new();
    let r = report;
    let recorded = r.camera_mode == "recorded";
    let _ = writeln!(
        s,
        "{}{} ({}, seed {})",
        if recorded {
            "dataset       "
        } else {
            "scenario      "
        },
        r.scenario,
        r.suite,
        r.seed
    );
    let _ = writeln!(
        s,
        "frames        {} processed, {} tracking ({:.1} %), {} degraded, {:.1} s {}",
        r.frames,
        r.tracking_frames,
        100.0 * r.tracking_fraction,
        r.degraded_frames,
        r.duration_s,
        if recorded { "recorded" } else { "simulated" }
    );
    match &r.static_trajectory {
        Some(st) => {
            let _ = writeln!(s, "static        {}", st.reason);
            let tilt = match (st.tilt_error_rms_deg, st.tilt_error_max_deg) {
                (Some(rms), Some(max)) => format!("; tilt error RMS {rms:.3}°, max {max:.3}°"),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "drift         from the first pose (anchored in {}): position max {:.2} mm, final {:.2} mm; rotation final {:.3}°{tilt}",
                st.anchored.replace('_', "+"),
                st.position_drift_m * 1e3,
                st.position_drift_final_m * 1e3,
                st.rotation_drift_final_deg,
            );
        }
        None => {
            let _ = writeln!(
                s,
                "ATE           {} RMSE, rotation {} RMSE ({} alignment)",
                opt(r.ate_rmse_m, 4, " m"),
                opt(r.ate_rot_rmse_deg, 3, "°"),
                r.alignment.replace('_', "+")
            );
        }
    }
    let _ = writeln!(
        s,
        "RPE ({} m)     {} translation RMSE, pose pairs {} m of ground-truth path apart",
        r.rpe_delta_m,
        opt(r.rpe_trans_rmse_m, 4, " m"),
        r.rpe_delta_m
    );
    if r.gyro_bias_error_rad_s.is_some() {
        let _ = writeln!(
            s,
            "final biases  gyro error {}, accel error {}",
            opt(r.gyro_bias_error_rad_s, 5, " rad/s"),
            opt(r.accel_bias_error_m_s2, 4, " m/s²")
        );
    }
    if let Some(c) = &r.calibration {
        let worst = |f: fn(&crate::report::ExtrinsicError) -> f64| {
            c.cameras.iter().map(f).fold(0.0, f64::max)
        };
        let _ = writeln!(
            s,
            "calibration   final td error {:.3} ms (true {:.1} ms), extrinsics {:.3}° / {:.1} mm (worst camera)",
            c.td_error_ms,
            c.td_true_ms,
            worst(|e| e.rotation_error_deg),
            worst(|e| e.translation_error_mm)
        );
        if let Some(x) = &c.td_excursion {
            let sigmas = match (x.max_error_sigmas, x.mean_squared_sigmas) {
                (Some(k), Some(m)) => format!(", at most {k:.1} σ (mean squared {m:.2})"),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "              td after {:.0} s: largest error {:.3} ms at {:.1} s{sigmas}",
                x.after_s, x.max_error_ms, x.at_s
            );
        }
    }
    if let Some(z) = &r.rest {
        let _ = writeln!(
            s,
            "rest          {} frames detected at rest ({} false while moving) of {} at rest; largest drift during a rest {}",
            z.frames_detected,
            z.false_detections,
            z.frames_at_rest,
            z.max_drift_m
                .map_or("-".to_string(), |d| format!("{:.1} mm", d * 1e3))
        );
    }
    if let Some(g) = &r.gnss {
        let _ = writeln!(
            s,
            "gnss          aligned at {:.1} s; global position error (no trajectory alignment) RMSE {:.3} m, max {:.3} m, final {:.3} m",
            g.aligned_at_s, g.global_rmse_m, g.global_max_m, g.global_final_m
        );
    }
    if let Some(p) = &r.replay {
        let _ = writeln!(
            s,
            "replay        {} samples, stamps in {}{}; {} glitches dropped (largest {:.3} m / {:.1}°), {} gaps bridged (longest {:.2} s); spline within {:.4} m / {:.3}° of the file",
            p.samples,
            p.time_unit,
            if p.time_unit_detected {
                " (detected)"
            } else {
                ""
            },
            p.glitches_dropped,
            p.largest_glitch_m,
            p.largest_glitch_deg,
            p.gaps_bridged,
            p.longest_gap_s,
            p.fit_max_m,
            p.fit_max_deg
        );
        if let Some(largest) = p
            .steps_blended
            .iter()
            .max_by(|a, b| a.position_m.total_cmp(&b.position_m))
        {
            let _ = writeln!(
                s,
                "replay steps  {} steps in the file bridged by motion-limited blends (largest {:.4} m at line {}, over {:.2} s): the simulated motion leaves the file by up to half a step near each; score against groundtruth.tum, not the file",
                p.steps_blended.len(),
                largest.position_m,
                largest.line,
                largest.blend_s
            );
        }
        if let Some(imu) = &p.recorded_imu {
            let _ = writeln!(s, "recorded IMU  {}", imu.summary());
        }
    }
    let t = &r.timing_ms;
    let _ = writeln!(
        s,
        "timing        per frame median / p99 / max: backend {:.2} / {:.2} / {:.2} ms, total {:.2} / {:.2} / {:.2} ms, frontend {:.3} ms",
        t.backend.median,
        t.backend.p99,
        t.backend.max,
        t.total.median,
        t.total.p99,
        t.total.max,
        t.frontend.median
    );
    if let (Some(rt), Some(adapter)) = (&t.render, &r.renderer) {
        let _ = writeln!(
            s,
            "rendering     per frame median / p99 / max: {:.2} / {:.2} / {:.2} ms on {adapter}",
            rt.median, rt.p99, rt.max
        );
    }
    if let Some(f) = &r.frontend {
        let _ = writeln!(
            s,
            "front end     {:.0} features/frame (min {}), tracks {:.1} frames, stereo {:.0} %, track error median / p95 {:.3} / {:.3} px, wrong {:.2} % → {:.2} % after RANSAC, stereo error median {:.3} px; pixel σ for the estimator {:.3} px",
            f.features_mean,
            f.features_min,
            f.mean_track_length,
            100.0 * f.stereo_match_ratio,
            f.track_error_median_px,
            f.track_error_p95_px,
            100.0 * f.wrong_before_ransac,
            100.0 * f.wrong_after_ransac,
            f.stereo_error_median_px,
            f.pixel_sigma_px
        );
        let (e, fit) = (&f.tracker_error.model, &f.tracker_error);
        let _ = writeln!(
            s,
            "tracker error white {:.3} px + drift {:.4} px/√frame; {:.1} % of tracks slide, drift {:.3} px/√frame; stereo {:.3} px; outliers {:.2} % ({} tracks)",
            e.white_px,
            e.drift_px,
            100.0 * e.sliding_fraction,
            e.sliding_drift_px,
            e.stereo_px,
            100.0 * fit.outlier_rate,
            fit.tracks
        );
    }
    if let Some(f) = &r.frontend_tracks {
        let _ = writeln!(
            s,
            "tracker       {:.0} features/frame ({}–{}), tracks {:.1} frames (median {:.0}), {:.1} new/frame; lost per frame: KLT {:.1}, flow-back {:.1}, RANSAC {:.2} ({:.2} %); stereo {:.0} % matched, {:.1} rejected/frame",
            f.features_mean,
            f.features_min,
            f.features_max,
            f.track_length_mean,
            f.track_length_median,
            f.detected_per_frame,
            f.klt_lost_per_frame,
            f.flow_back_rejected_per_frame,
            f.ransac_rejected_per_frame,
            100.0 * f.ransac_rejected_fraction,
            100.0 * f.stereo_match_ratio,
            f.stereo_rejected_per_frame
        );
    }
    let _ = writeln!(s, "resets        {}", r.resets);
    let _ = writeln!(
        s,
        "sensors       {} suite switches, {} IMU samples excluded as spikes, {} saturated",
        r.suite_switches, r.imu_samples_excluded, r.imu_samples_saturated
    );
    if let Some(b) = &r.batch_reference {
        let _ = writeln!(s, "batch ref     {}", window_vs_batch::summary_line(b));
    }
    if let Some(f) = &r.filter_reference {
        let _ = writeln!(s, "filter ref    {}", window_vs_filter::summary_line(f));
    }
    for e in r
        .events
        .iter()
        .filter(|e| e.kind == "suite_switch" || e.kind == "reset")
    {
        let _ = writeln!(s, "  {:>8.2} s   {} {}", e.t_s, e.kind, e.detail);
    }
    for f in &r.faults {
        let end = f.end_s.map_or("on".to_string(), |e| format!("{e:.2} s"));
        let back = f
            .back_s
            .map_or("never".to_string(), |b| format!("after {b:.2} s"));
        let _ = writeln!(
            s,
            "fault         {} {:.2} s – {end}: suite back {back}, error {} at the end, {} 10 s later, {} resets",
            f.kind,
            f.start_s,
            opt(f.error_at_end_m, 4, " m"),
            opt(f.error_10s_after_m, 4, " m"),
            f.resets
        );
    }
    if r.expectations.is_empty() {
        let _ = writeln!(s, "expectations  none");
    } else {
        let _ = writeln!(s, "expectations");
        for e in &r.expectations {
            let bound = match (e.min, e.max) {
                (Some(a), Some(b)) => format!("in [{a}, {b}]"),
                (Some(a), None) => format!("≥ {a}"),
                (None, Some(b)) => format!("≤ {b}"),
                (None, None) => String::new(),
            };
            let _ = writeln!(
                s,
                "  {:<24} {:<14} {:>12}  {}",
                e.metric,
                bound,
                opt(e.value, 4, ""),
                if e.passed { "pass" } else { "FAIL" }
            );
        }
    }
    let failure = r.estimator.as_ref().and_then(|o| {
        let _ = writeln!(
            s,
            "estimator     {} ({}): {} after {:.1} s, {} poses{}",
            o.name,
            o.adapter,
            o.exit,
            o.wall_s,
            o.poses,
            o.log
                .as_ref()
                .map(|l| format!("; log {}", l.display()))
                .unwrap_or_default()
        );
        o.failure.as_ref()
    });
    if let Some(tail) = r.estimator.as_ref().and_then(|o| o.log_tail.as_ref()) {
        let _ = writeln!(s, "its log ends:");
        for line in tail
            .lines()
            .rev()
            .take(10)
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
        {
            let _ = writeln!(s, "  | {line}");
        }
    }
    let _ = write!(
        s,
        "result        {}",
        match (r.passed, r.interrupted_at_s) {
            _ if failure.is_some() => format!(
                "FAIL (the estimator {})",
                failure.map_or("", |f| f.strip_prefix("the estimator ").unwrap_or(f))
            ),
            (true, _) => "PASS".to_string(),
            (false, Some(t)) => format!("FAIL (interrupted at t = {t:.2} s: partial run)"),
            (false, None) => "FAIL (an expectation is not met)".to_string(),
        }
    );
    if let Some(d) = out_dir {
        let _ = write!(s, "; files in {}", d.display());
    }
    s.push('\n');
    s
}
