//! The EuRoC ASL folder an export writes: `mav0/` with every sensor's `data.csv` and
//! `sensor.yaml`, the rendered images as `cam<i>/data/<t_ns>.png`, and beside it `features.csv`,
//! `camchain-imucam.yaml` and `imu.yaml`.

use std::path::PathBuf;

use estimator::frontend::FeatureFrame;
use estimator::imu::ImuSample;
use sim::render::ImageFrame;

use super::rig::ExportRig;
use super::sink::{ExportError, ExportSink};
use crate::dataset::{
    CameraFrame, EurocCamera, EurocDataset, GroundTruthState, write_euroc, write_features_csv,
};

/// Writes into a folder.
pub(super) struct AslFolder {
    out: PathBuf,
    data: EurocDataset,
    camchain: String,
    imu_yaml: String,
}

impl AslFolder {
    pub(super) fn new(out: PathBuf, rig: ExportRig) -> Self {
        let data = EurocDataset {
            imu_sensor: Some(rig.imu),
            cameras: rig
                .cameras
                .into_iter()
                .map(|sensor| EurocCamera {
                    sensor: Some(sensor),
                    frames: Vec::new(),
                })
                .collect(),
            ..EurocDataset::default()
        };
        Self {
            out,
            data,
            camchain: rig.camchain,
            imu_yaml: rig.imu_yaml,
        }
    }
}

impl ExportSink for AslFolder {
    fn imu(&mut self, s: &ImuSample, truth: Option<&GroundTruthState>) -> Result<(), ExportError> {
        self.data.imu.push(*s);
        if let Some(gt) = truth {
            self.data.groundtruth.push(*gt);
        }
        Ok(())
    }

    fn images(&mut self, frame: &ImageFrame) -> Result<(), ExportError> {
        for c in &frame.cameras {
            let dir = self.out.join(format!("mav0/cam{}/data", c.cam_id));
            std::fs::create_dir_all(&dir)
                .map_err(|e| ExportError::Image(format!("{}: {e}", dir.display())))?;
            let path = dir.join(format!("{}.png", frame.t_ns));
            crate::images::write_gray_png(&path, &c.image).map_err(ExportError::Image)?;
            // `data.csv` lists only the images that exist (an EuRoC reader opens them).
            if let Some(cam) = self.data.cameras.get_mut(c.cam_id) {
                cam.frames.push(CameraFrame::at(frame.t_ns));
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>, frames: &[FeatureFrame]) -> Result<(), ExportError> {
        write_euroc(self.out.join("mav0"), &self.data)?;
        write_features_csv(self.out.join("features.csv"), frames)?;
        for (name, text) in [
            ("camchain-imucam.yaml", &self.camchain),
            ("imu.yaml", &self.imu_yaml),
        ] {
            let path = self.out.join(name);
            std::fs::write(&path, text)
                .map_err(|e| ExportError::Write(format!("{}: {e}", path.display())))?;
        }
        Ok(())
    }
}
