//! Camera models: projection of camera-frame points to distorted pixels and back.
//!
//! Frame convention: camera z forward, x right, y down; pixels in the OpenCV convention (pixel
//! centres at integer coordinates, origin at the top-left pixel's centre).
//!
//! Four models implement [`CameraModel`]: [`PinholeRadtan`], [`KannalaBrandt`], [`Mei`] and
//! [`DoubleSphere`]; [`Camera`] wraps any of them. Every model is built through a checked
//! constructor (`new`) that also caches the bound of the model's valid domain. The parameter
//! fields are public for reading; a model whose fields are changed afterwards must be rebuilt
//! with `new`, or its cached domain bound goes stale.
//!
//! Domain checks are written as negated comparisons (`if !(z > min)`) on purpose: they also
//! reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{Matrix2x3, Vector2, Vector3};

mod double_sphere;
mod kannala_brandt;
mod mei;
mod pinhole_radtan;
mod radtan;
mod rolling_shutter;

pub use double_sphere::DoubleSphere;
pub use kannala_brandt::KannalaBrandt;
pub use mei::Mei;
pub use pinhole_radtan::PinholeRadtan;
pub use rolling_shutter::{ReadoutDirection, RollingShutter};

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

/// Why a camera model's parameters were rejected; names the offending field.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// A parameter is NaN or infinite.
    #[error("camera parameter `{field}` is not finite ({value})")]
    NonFinite {
        /// Name of the parameter.
        field: &'static str,
        /// The rejected value.
        value: f64,
    },
    /// A parameter lies outside the range the model accepts.
    #[error("camera parameter `{field}` = {value} is out of range: must be {expected}")]
    OutOfRange {
        /// Name of the parameter.
        field: &'static str,
        /// The rejected value.
        value: f64,
        /// The accepted range, in words.
        expected: &'static str,
    },
    /// The image width or height is zero.
    #[error("image `{field}` is zero")]
    ZeroSize {
        /// `"width"` or `"height"`.
        field: &'static str,
    },
}

/// Rejects non-finite values.
fn check_finite(field: &'static str, value: f64) -> Result<(), CameraError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(CameraError::NonFinite { field, value })
    }
}

/// Rejects non-finite values and values outside `range` (described by `expected`).
fn check_range(
    field: &'static str,
    value: f64,
    ok: impl FnOnce(f64) -> bool,
    expected: &'static str,
) -> Result<(), CameraError> {
    check_finite(field, value)?;
    if ok(value) {
        Ok(())
    } else {
        Err(CameraError::OutOfRange {
            field,
            value,
            expected,
        })
    }
}

/// Checks the parameters every model shares: image size, focal lengths, principal point.
fn check_intrinsics(
    width: u32,
    height: u32,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
) -> Result<(), CameraError> {
    if width == 0 {
        return Err(CameraError::ZeroSize { field: "width" });
    }
    if height == 0 {
        return Err(CameraError::ZeroSize { field: "height" });
    }
    check_range("fx", fx, |v| v > 0.0, "> 0")?;
    check_range("fy", fy, |v| v > 0.0, "> 0")?;
    check_finite("cx", cx)?;
    check_finite("cy", cy)
}

/// True if `uv` lies in `[-0.5, width − 0.5] × [-0.5, height − 0.5]` (the image's pixel area).
#[inline]
pub fn in_image(width: u32, height: u32, uv: &Vector2<f64>) -> bool {
    uv.x >= -0.5
        && uv.x <= f64::from(width) - 0.5
        && uv.y >= -0.5
        && uv.y <= f64::from(height) - 0.5
}

/// Any of the supported camera models (the form used by configuration and scenario files).
#[derive(Clone, Debug, PartialEq)]
pub enum Camera {
    /// Pinhole with radial-tangential distortion.
    PinholeRadtan(PinholeRadtan),
    /// Kannala-Brandt equidistant fisheye.
    KannalaBrandt(KannalaBrandt),
    /// Mei unified omnidirectional model with radial-tangential distortion.
    Mei(Mei),
    /// Double sphere model.
    DoubleSphere(DoubleSphere),
}

impl Camera {
    /// The wrapped model as a trait object.
    #[inline]
    pub fn model(&self) -> &dyn CameraModel {
        match self {
            Camera::PinholeRadtan(c) => c,
            Camera::KannalaBrandt(c) => c,
            Camera::Mei(c) => c,
            Camera::DoubleSphere(c) => c,
        }
    }
}

/// Forwards a `CameraModel` method call to the wrapped model without dynamic dispatch.
macro_rules! delegate {
    ($self:ident, $c:ident => $call:expr) => {
        match $self {
            Camera::PinholeRadtan($c) => $call,
            Camera::KannalaBrandt($c) => $call,
            Camera::Mei($c) => $call,
            Camera::DoubleSphere($c) => $call,
        }
    };
}

impl CameraModel for Camera {
    #[inline]
    fn width(&self) -> u32 {
        delegate!(self, c => c.width())
    }
    #[inline]
    fn height(&self) -> u32 {
        delegate!(self, c => c.height())
    }
    #[inline]
    fn project(&self, p_c: &Vector3<f64>) -> Option<Vector2<f64>> {
        delegate!(self, c => c.project(p_c))
    }
    #[inline]
    fn project_with_jacobian(&self, p_c: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        delegate!(self, c => c.project_with_jacobian(p_c))
    }
    #[inline]
    fn unproject(&self, uv: &Vector2<f64>) -> Option<Vector3<f64>> {
        delegate!(self, c => c.unproject(uv))
    }
    #[inline]
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        delegate!(self, c => c.is_valid(uv))
    }
}

impl From<PinholeRadtan> for Camera {
    fn from(c: PinholeRadtan) -> Self {
        Camera::PinholeRadtan(c)
    }
}

impl From<KannalaBrandt> for Camera {
    fn from(c: KannalaBrandt) -> Self {
        Camera::KannalaBrandt(c)
    }
}

impl From<Mei> for Camera {
    fn from(c: Mei) -> Self {
        Camera::Mei(c)
    }
}

impl From<DoubleSphere> for Camera {
    fn from(c: DoubleSphere) -> Self {
        Camera::DoubleSphere(c)
    }
}
