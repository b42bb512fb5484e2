//! `vio imu-model`: IMU characterization of a recorded log (Allan deviation and Kalibr noise
//! fit, spectra, and with ground truth the residual, clock lag and frame check).

use std::path::PathBuf;
use std::process::ExitCode;

use scenarios::imu_model::{Options, analyze, load, summary, write_outputs};

#[derive(clap::Args)]
pub(super) struct ImuModelArgs {
    /// The IMU log: an EuRoC ASL `imu0/data.csv` (or the `imu0` or `mav0` folder holding it).
    log: PathBuf,
    /// EuRoC ground truth (`state_groundtruth_estimate0/data.csv`) of the same run: adds the
    /// residual against the IMU it implies, the clock lag, the frame check and the fitted error
    /// model.
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Output folder (`imu_model.json`, `allan.png`, `spectrum.png`; with --gt also
    /// `error_model.toml` and `estimator_imu_noise.toml`).
    #[arg(long)]
    out: PathBuf,
    /// Analyse from this time (s from the log's first sample), e.g. the start of a rest.
    #[arg(long)]
    from: Option<f64>,
    /// Analyse up to this time (s from the log's first sample).
    #[arg(long)]
    to: Option<f64>,
    /// With --gt: the rest is everything before this time (s from the log's first sample)
    /// instead of where the ground truth's speed and rate are near zero.
    #[arg(long)]
    rest_until: Option<f64>,
    /// With --gt: knot spacing (s) of the spline through the ground-truth poses [default: the
    /// ground truth's median period, at least 0.05 s].
    #[arg(long)]
    knot_spacing: Option<f64>,
    /// With --gt: the IMU interval (s), the shortest time scale the estimator's white
    /// densities in `estimator_imu_noise.toml` are matched over: the camera period [default:
    /// 0.05, EuRoC's 20 Hz].
    #[arg(long)]
    interval: Option<f64>,
    /// With --gt: the span (s) of the estimator's window, the longest time scale its white
    /// densities are matched over [default: 0.8, the 10-keyframe window on the EuRoC flights].
    #[arg(long)]
    window: Option<f64>,
}

/// Exit 0 after writing the outputs, 2 on bad input or an unwritable `--out`.
pub(super) fn imu_model_command(args: ImuModelArgs) -> ExitCode {
    let bad = |e: String| {
        eprintln!("vio imu-model: error: {e}");
        ExitCode::from(super::BAD_INPUT)
    };
    let (input, warning) = match load(&args.log, args.gt.as_deref()) {
        Ok(x) => x,
        Err(e) => return bad(e),
    };
    if let Some(w) = warning {
        eprintln!("vio imu-model: warning: {w}");
    }
    let opts = Options {
        from_s: args.from,
        to_s: args.to,
        rest_until_s: args.rest_until,
        knot_spacing_s: args.knot_spacing,
        estimator_interval_s: args.interval,
        estimator_window_s: args.window,
    };
    let model = match analyze(&input, &opts) {
        Ok(m) => m,
        Err(e) => return bad(e),
    };
    if let Err(code) = super::check_out_dir(&args.out) {
        return code;
    }
    let written = match write_outputs(&args.out, &model) {
        Ok(w) => w,
        Err(e) => return bad(e),
    };
    let mut text = summary(&model);
    text.push_str("written:\n");
    for p in written {
        text.push_str(&format!("  {}\n", p.display()));
    }
    super::say(&text);
    ExitCode::SUCCESS
}
