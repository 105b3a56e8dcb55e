//! The reference crate's tests, one module per subject, linked into one test binary (each binary
//! links wgpu, so one binary instead of four shortens a cold CI build).

mod analytic;
mod closed_form;
mod exact_agreement;
mod light_kinds;
mod progressive;
mod raycast;
