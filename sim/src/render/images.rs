//! What the renderer returns: grey and depth images per camera and frame, and the adapter it
//! ran on.

/// An 8-bit grey image, row-major, no padding.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GrayImage {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// `width × height` grey levels.
    pub data: Vec<u8>,
}

impl GrayImage {
    /// A black image.
    pub fn black(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            data: vec![0; width as usize * height as usize],
        }
    }

    /// Grey level at integer pixel `(u, v)`.
    pub fn at(&self, u: u32, v: u32) -> u8 {
        self.data[(v * self.width + u) as usize]
    }
}

/// A depth image: z along the optical axis (m), 0 where no surface is seen.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// `width × height` depths.
    pub data: Vec<f32>,
}

/// One camera's rendered image.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraImage {
    /// Camera index in the rig.
    pub cam_id: usize,
    /// The grey image.
    pub image: GrayImage,
    /// The depth image, when depth is configured.
    pub depth: Option<DepthImage>,
}

/// The images of all cameras for one capture.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageFrame {
    /// Stamp (ns, camera clock, like the feature frame of the same capture).
    pub t_ns: i64,
    /// True capture time (ns, IMU clock): the instant the images show (mid-exposure).
    pub t_capture_ns: i64,
    /// One entry per live camera.
    pub cameras: Vec<CameraImage>,
}

/// Description of the adapter in use.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Adapter name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// Backend name (`Gl`, `Vulkan`).
    pub backend: String,
    /// Driver and version as the adapter reports them.
    pub driver: String,
    /// Device kind (`Cpu`, `DiscreteGpu`, …).
    pub device_type: String,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.backend, self.device_type)?;
        if !self.driver.is_empty() {
            write!(f, ", {}", self.driver)?;
        }
        write!(f, ")")
    }
}

/// The undistorted pinhole a camera is first rendered into.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VirtualPinhole {
    /// Focal length (px).
    pub f: f64,
    /// Principal point x (px, OpenCV convention).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
}
