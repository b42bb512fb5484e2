//! The errors that stop a run, each naming the file concerned.

use std::path::PathBuf;

use crate::dataset::DatasetError;
use crate::spec::{Scenario, SpecError};

/// Errors that stop a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scenario does not map onto a world or an estimator.
    #[error("{0}")]
    Spec(#[from] SpecError),
    /// The simulator rejected the world.
    #[error("{file}: the simulator rejected the scenario: {message}")]
    Sim {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// The estimator rejected its configuration.
    #[error("{file}: the estimator rejected the scenario's configuration: {message}")]
    Estimator {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// The image front end rejected its configuration or an image.
    #[error("{file}: image front end: {message}")]
    Frontend {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// A dataset file is missing or malformed.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// An input file or folder cannot feed the run (a recorded dataset's missing calibration,
    /// an unreadable image).
    #[error("{}: {message}", path.display())]
    Input {
        /// The file or folder concerned.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// Ground truth was not available at an estimate's time.
    #[error("no ground truth at t = {t_ns} ns")]
    NoTruth {
        /// The estimate's time.
        t_ns: i64,
    },
}

impl RunError {
    /// A failure of the simulator or the renderer while running `scenario`.
    pub fn sim(scenario: &Scenario, message: impl std::fmt::Display) -> Self {
        RunError::Sim {
            file: scenario.file_label(),
            message: message.to_string(),
        }
    }

    /// `path` cannot feed the run, because of `message`.
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        RunError::Input {
            path: path.into(),
            message: message.into(),
        }
    }
}
