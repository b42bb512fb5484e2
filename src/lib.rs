//! `vio-harness`: the root package. It holds no code of its own; its `tests/` directory holds the
//! scenario tests that exercise `sim` → `estimator` → `scenarios` end to end.
