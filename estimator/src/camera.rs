//! Camera models: projection of camera-frame points to distorted pixels and back.
//!
//! Frame convention: camera z forward, x right, y down; pixels in the OpenCV convention (pixel
//! centres at integer coordinates, origin at the top-left pixel's centre).

use nalgebra::{Matrix2x3, Vector2, Vector3};

/// A central camera model.
pub trait CameraModel: Send + Sync + std::fmt::Debug {
    /// Image width (px).
    fn width(&self) -> u32;
    /// Image height (px).
    fn height(&self) -> u32;
    /// Projects a camera-frame point to distorted pixels; `None` outside the model's valid
    /// domain (behind the camera, beyond the field of view the model can represent). Does not
    /// check the image bounds: see [`CameraModel::is_valid`].
    fn project(&self, p_c: &Vector3<f64>) -> Option<Vector2<f64>>;
    /// [`CameraModel::project`] plus the 2×3 Jacobian `∂uv/∂p_c`.
    fn project_with_jacobian(&self, p_c: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)>;
    /// Unit bearing vector of a pixel, by the model's closed form or Gauss-Newton on the
    /// distortion; `None` if the pixel is outside the model's valid region or does not converge.
    fn unproject(&self, uv: &Vector2<f64>) -> Option<Vector3<f64>>;
    /// True if `uv` lies inside the image and inside the region the model can unproject.
    fn is_valid(&self, uv: &Vector2<f64>) -> bool;

    /// Normalized-plane coordinates `(x/z, y/z)` of a pixel; `None` for bearings with z ≤ 1e-6.
    fn unproject_normalized(&self, uv: &Vector2<f64>) -> Option<Vector2<f64>> {
        let b = self.unproject(uv)?;
        (b.z > 1e-6).then(|| Vector2::new(b.x / b.z, b.y / b.z))
    }
}
