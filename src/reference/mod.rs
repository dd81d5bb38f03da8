//! Independent CPU tracer in f64 (the test oracle).
