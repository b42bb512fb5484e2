//! `vio image-stats`: noise, photometry, texture and the KLT front end's drift on static
//! frames of one or more EuRoC ASL folders, side by side (real recordings against `vio export`
//! of a rendered scenario held at rest).

use std::path::PathBuf;
use std::process::ExitCode;

use estimator::frontend::TrackerConfig;
use scenarios::studies::image_statistics::{StaticSequence, measure, table, why_not_static};

#[derive(clap::Args)]
pub(super) struct ImageStatsArgs {
    /// EuRoC ASL `mav0` folders whose frames show a static scene (the camera at rest).
    #[arg(required = true)]
    mav0: Vec<PathBuf>,
    /// A column name per folder, in order [default: the folder's parent's name].
    #[arg(long)]
    label: Vec<String>,
    /// The camera measured (`cam<i>`).
    #[arg(long, default_value_t = 0)]
    camera: usize,
    /// Read at most this many frames of each folder, from the first.
    #[arg(long, default_value_t = 200)]
    frames: usize,
    /// Also write the figures as `OUT/image_stats.json`.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Exit 0 after printing the table, 2 on bad input or an unwritable `--out`.
pub(super) fn image_stats_command(args: ImageStatsArgs) -> ExitCode {
    let bad = |e: String| {
        eprintln!("vio image-stats: error: {e}");
        ExitCode::from(super::BAD_INPUT)
    };
    if !args.label.is_empty() && args.label.len() != args.mav0.len() {
        return bad(format!(
            "{} --label for {} folders: give one per folder or none",
            args.label.len(),
            args.mav0.len()
        ));
    }
    if let Some(out) = &args.out
        && let Err(code) = super::check_out_dir(out)
    {
        return code;
    }
    let config = TrackerConfig::default();
    let mut stats = Vec::new();
    for (k, mav0) in args.mav0.iter().enumerate() {
        let label = args.label.get(k).cloned().unwrap_or_else(|| {
            let parent = mav0.canonicalize().ok().and_then(|p| {
                p.parent()
                    .and_then(|q| q.file_name())
                    .map(|n| n.to_string_lossy().into_owned())
            });
            parent.unwrap_or_else(|| mav0.display().to_string())
        });
        let seq = match StaticSequence::read(mav0, args.camera, args.frames) {
            Ok(s) => s,
            Err(e) => return bad(e),
        };
        match measure(&seq, &label, &config) {
            Ok(s) => match why_not_static(&s) {
                None => stats.push(s),
                Some(why) => {
                    return bad(format!(
                        "{}: not a static sequence: {why}; image-stats measures a camera at rest",
                        mav0.display()
                    ));
                }
            },
            Err(e) => return bad(format!("{}: front end: {e}", mav0.display())),
        }
    }
    super::say(&table(&stats));
    if let Some(out) = &args.out {
        let path = out.join("image_stats.json");
        let json = serde_json::to_string_pretty(&stats).expect("plain data") + "\n";
        if let Err(e) = std::fs::write(&path, json) {
            return bad(format!("{}: {e}", path.display()));
        }
        super::say(&format!("written: {}\n", path.display()));
    }
    ExitCode::SUCCESS
}
