//! The files `vio imu-model` writes: `imu_model.json`, its plots and the fitted error model.

use std::path::{Path, PathBuf};

use super::plot::{allan_png, spectrum_png};
use super::report::ImuModel;

/// Writes `imu_model.json`, `allan.png` and `spectrum.png` into `dir` (created), and with a
/// ground truth `error_model.toml` (the fitted IMU error model, for the simulator) and
/// `estimator_imu_noise.toml` (the noise model an estimator should assume); returns the paths written.
pub fn write_outputs(dir: &Path, model: &ImuModel) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mut written = Vec::new();
    let json = dir.join("imu_model.json");
    let text = serde_json::to_string_pretty(model).map_err(|e| e.to_string())? + "\n";
    std::fs::write(&json, text).map_err(|e| format!("{}: {e}", json.display()))?;
    written.push(json);
    for (name, png) in [
        ("allan.png", allan_png(model)?),
        ("spectrum.png", spectrum_png(model)?),
    ] {
        let path = dir.join(name);
        std::fs::write(&path, png).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    if let Some(fitted) = &model.error_model {
        let path = dir.join("error_model.toml");
        let text = toml::to_string(&fitted.model).map_err(|e| e.to_string())?;
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    if let Some(noise) = &model.estimator_noise {
        let path = dir.join("estimator_imu_noise.toml");
        std::fs::write(&path, noise.to_toml(&model.log))
            .map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}
