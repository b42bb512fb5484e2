//! Deterministic simulation harness (filled by the simulator issue).
