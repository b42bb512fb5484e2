//! `vio export`: a scenario's simulated measurements written in the community's formats, so
//! other estimators can consume exactly what ours does: an EuRoC ASL folder ([`asl_folder`]) or
//! a ROS 2 bag in MCAP ([`ros2_bag`]), each with the rig as Kalibr files.
//!
//! The ASL folder: `OUT/mav0/` (`imu0/data.csv` + `sensor.yaml` with the Kalibr noise values,
//! `state_groundtruth_estimate0/data.csv` at every IMU sample with the true biases,
//! `cam<i>/data.csv` + `sensor.yaml` with each camera's calibration), `OUT/features.csv`
//! (`t_ns,cam_id,feature_id,u,v`, distorted pixels), `OUT/camchain-imucam.yaml` and
//! `OUT/imu.yaml`. Rendered scenarios (`camera.mode = "rendered"`) also write every image as
//! `mav0/cam<i>/data/<t_ns>.png` (depth images are not exported; `vio render` writes them), and
//! each camera's `data.csv` lists exactly the images written; feature-level scenarios have no
//! images, so their `data.csv` holds the header only and `features.csv` holds what the cameras
//! measured and when. Feature ids are renumbered densely from 0 keeping their order (they fit
//! in 31 bits): one id is one track (`rig.track_ids = "realistic"`, the default: a re-acquired
//! landmark is a new track) or one landmark (`"landmark"`), shared by the cameras that see it.
//! Stamps: the IMU's and the ground truth's are true time; a camera's are its own clock, `t −
//! rig.time_offset_s` for a frame taken at true time `t` (Kalibr's `timeshift_cam_imu` in the
//! camchain), so a positive offset can give the first frames negative stamps. Each camera's
//! Kalibr entry also carries its rolling-shutter readout (`line_delay_nanoseconds` and the
//! `vio_rolling_shutter_*` keys) and the pixel σ the estimator is told (`vio_pixel_sigma_px`).
//! An export's output is whole or marked ([`out_folder`]).

pub mod asl_folder;
pub mod out_folder;
pub mod rig;
pub mod ros2_bag;
mod sink;
mod write;

pub use rig::kalibr_files;
pub use ros2_bag::GNSS_ORIGIN;
pub use sink::{ExportError, ExportSummary};
pub use write::{export, export_bag};
