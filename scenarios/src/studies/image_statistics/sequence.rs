//! One camera's frames of a static scene, read from an EuRoC ASL `mav0` folder (a real
//! recording, or `vio export` of a rendered scenario held at rest).

use std::path::{Path, PathBuf};

use estimator::camera::Camera;

use crate::dataset::{read_euroc_cameras, read_gray_image};

/// The frames of one camera, in time order, all of one size.
#[derive(Clone, Debug)]
pub struct StaticSequence {
    /// The `mav0` folder they come from.
    pub mav0: PathBuf,
    /// The camera's index (`cam<i>`).
    pub camera: usize,
    /// The camera's calibration (`cam<i>/sensor.yaml`).
    pub model: Camera,
    /// Width and height (px).
    pub size: [u32; 2],
    /// Frame stamps (ns, the folder's clock).
    pub stamps_ns: Vec<i64>,
    /// The images, row-major 8-bit grey, `size[0] × size[1]` each.
    pub frames: Vec<Vec<u8>>,
}

/// Fewest frames a sequence may hold (two differences per pixel at least).
pub const MIN_FRAMES: usize = 3;

impl StaticSequence {
    /// Reads camera `camera` of `mav0`: at most `max_frames` frames from the first. Every
    /// error names the file.
    pub fn read(mav0: &Path, camera: usize, max_frames: usize) -> Result<Self, String> {
        let data = read_euroc_cameras(mav0, camera + 1).map_err(|e| e.to_string())?;
        let dir = mav0.join(format!("cam{camera}"));
        let cam = data
            .cameras
            .get(camera)
            .ok_or_else(|| format!("{}: no such camera folder", dir.display()))?;
        let yaml = dir.join("sensor.yaml");
        let sensor = cam.sensor.as_ref().ok_or_else(|| {
            format!(
                "{}: missing: the camera's calibration comes from it",
                yaml.display()
            )
        })?;
        let model = sensor
            .camera()
            .map_err(|e| format!("{}: {e}", yaml.display()))?;
        let size = sensor.resolution;
        let mut stamps_ns = Vec::new();
        let mut frames = Vec::new();
        for f in cam.frames.iter().take(max_frames) {
            let path = dir.join("data").join(&f.filename);
            let image = read_gray_image(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            if [image.width(), image.height()] != size {
                return Err(format!(
                    "{}: {}×{} image, but sensor.yaml says {}×{}",
                    path.display(),
                    image.width(),
                    image.height(),
                    size[0],
                    size[1]
                ));
            }
            stamps_ns.push(f.t_ns);
            frames.push(image.into_raw());
        }
        if frames.len() < MIN_FRAMES {
            return Err(format!(
                "{}: {} frames, at least {MIN_FRAMES} needed",
                dir.join("data.csv").display(),
                frames.len()
            ));
        }
        Ok(Self {
            mav0: mav0.to_path_buf(),
            camera,
            model,
            size,
            stamps_ns,
            frames,
        })
    }

    /// Pixels per frame.
    pub fn pixels(&self) -> usize {
        self.size[0] as usize * self.size[1] as usize
    }

    /// The per-pixel mean over the frames.
    pub fn mean_image(&self) -> Vec<f64> {
        let mut mean = vec![0.0; self.pixels()];
        for f in &self.frames {
            for (m, &v) in mean.iter_mut().zip(f) {
                *m += f64::from(v);
            }
        }
        let n = self.frames.len() as f64;
        mean.iter_mut().for_each(|m| *m /= n);
        mean
    }
}
