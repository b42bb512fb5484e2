//! `vio image-stats`: what a camera's frames of a static scene look like to a tracker — sensor
//! noise, photometry, texture and the KLT front end's drift — measured the same way on real
//! recordings and on rendered ones, so the renderer can be fitted to a real sensor.

pub mod photometry;
pub mod sequence;
pub mod static_check;
pub mod static_tracks;
pub mod summary;
pub mod texture;

pub use photometry::{NoiseBin, Photometry, photometry};
pub use sequence::StaticSequence;
pub use static_check::why_not_static;
pub use static_tracks::{StaticTracks, static_tracks};
pub use summary::{ImageStatistics, measure, table};
pub use texture::{Texture, texture};
