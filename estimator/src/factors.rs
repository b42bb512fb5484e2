//! Residual factors.
