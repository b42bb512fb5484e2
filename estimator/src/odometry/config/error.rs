//! A setting out of its range, and the range checks that say so.

/// A setting out of its range: the field as serialized (`solver.max_iterations`,
/// `cameras[1].pixel_sigma`) and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {message}")]
pub struct ConfigError {
    /// The field's path.
    pub field: String,
    /// What was wrong / expected.
    pub message: String,
}

impl ConfigError {
    pub(crate) fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }
}

/// `Ok` if `v` > 0, infinity included (what infinity means: `infinite`); else an error
/// naming `field`.
pub(super) fn positive_or_infinite(field: &str, v: f64, infinite: &str) -> Result<(), ConfigError> {
    if v > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            field,
            format!("must be > 0 (infinite: {infinite}), got {v}"),
        ))
    }
}

/// `Ok` if `v` is finite and > 0; else an error naming `field`.
pub(crate) fn positive(field: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            field,
            format!("expected a finite number > 0, got {v}"),
        ))
    }
}

/// `Ok` if `v` is finite and ≥ 0; else an error naming `field`.
pub(super) fn non_negative(field: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ConfigError::new(
            field,
            format!("expected a finite number ≥ 0, got {v}"),
        ))
    }
}

/// `Ok` if `v` is finite and lies in `lo..=hi`; else an error naming `field`, in `unit` (" s").
pub(super) fn value_in(
    field: &str,
    v: f64,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<(), ConfigError> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ConfigError::new(
            field,
            format!("expected {lo} to {hi}{unit}, got {v}"),
        ))
    }
}

/// `Ok` if the count `v` lies in `lo..=hi`; else an error naming `field`, in `unit` (" frames",
/// or "" for a bare count).
pub(super) fn count_in(
    field: &str,
    v: usize,
    lo: usize,
    hi: usize,
    unit: &str,
) -> Result<(), ConfigError> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(ConfigError::new(
            field,
            format!("expected {lo} to {hi}{unit}, got {v}"),
        ))
    }
}
