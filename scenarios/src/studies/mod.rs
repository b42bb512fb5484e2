//! Studies and checks built on the run pipeline: `vio nees` (Monte-Carlo consistency), `vio
//! sweep` (a parameter grid × seeds), `vio bench` (per-stage timing) and `vio regress` (the
//! regression catalog against a baseline), `vio image-stats` (static frames, real or rendered).

pub mod bench;
pub mod image_statistics;
pub mod nees_monte_carlo;
pub mod regress;
pub mod sweep;
