//! # mtwin-core — the twin as data, and how to run it
//!
//! What every other part of mtwin stands on, and what the FMU slave links (nothing of the
//! identification): one module per thing a twin *is*.
//!
//! | what | module |
//! |---|---|
//! | axes and channels (output ← input) | [`axis`] |
//! | errors, atomic file writes | [`error`], [`atomic`] |
//! | a measured or modelled FRF matrix | [`frf`] |
//! | a time series (forces, responses, axis positions) | [`timeseries`] |
//! | the LTI model in modal form (paper eq. 1) | [`model`] |
//! | the twin file: poses, models, plans, history | [`twin`], [`plan`] |
//! | interpolation between measured poses (paper section 3) | [`interpolate`] |
//! | time simulation (paper eq. 3), with the twin's extensions | [`simulate`], [`extended`] |
//! | derivatives and slices of sampled signals | [`signal`] |
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod atomic;
pub mod axis;
pub mod error;
pub mod extended;
pub mod frf;
pub mod interpolate;
pub mod model;
pub mod plan;
pub mod signal;
pub mod simulate;
pub mod timeseries;
pub mod twin;

pub use error::{Error, Result};
