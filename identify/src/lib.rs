//! # identify — the numerical core of mtwin
//!
//! From measured force and response to a pose-dependent, lifetime-adaptive LTI twin of a
//! machine tool's tool-center-point dynamics. One module per step of the method:
//!
//! | step (paper section) | module |
//! |---|---|
//! | reading data (docs/formats.md) | [`read`], [`timeseries`] |
//! | the response sensor's mass loading removed | [`mass_loading`] |
//! | FRF exchange with modal software: universal file dataset 58/58b | [`uff`] |
//! | FRF estimation, H1/H2/Hv, impact processing (2.1) | [`spectra`] |
//! | model order from a stabilization diagram (2.2) | [`stabilization`] |
//! | rational fit: Sanathanan–Koerner / vector fitting + refinement (2.2) | [`rational_fit`] |
//! | the model in modal form, discrete-time view (eq. 1) | [`model`] |
//! | time simulation, the state-space core of `simulate` and the FMU (eq. 3) | [`simulate`] |
//! | the twin file | [`twin`] |
//!
//! ```
//! use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};
//! use identify::axis::{Axis, Channel};
//! // A single mode at 100 Hz, 2 % damping, 10 kg modal mass.
//! let m = Mode::from_hz(100.0, 0.02);
//! let model = ModalModel {
//!     modes: vec![m],
//!     channels: vec![ChannelModel {
//!         channel: Channel::new(Axis::X, Axis::X),
//!         num: vec![ModeNum { b0: 0.1, b1: 0.0 }],
//!         d: 0.0,
//!     }],
//! };
//! let static_compliance = model.eval_hz(0, 0.0).re;
//! assert!((static_compliance - 0.1 / (m.wn * m.wn)).abs() < 1e-15);
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod atomic;
pub mod axis;
pub mod campaign;
pub mod diagnose;
mod eigen;
pub mod error;
pub mod extended;
pub mod frf;
pub mod interpolate;
mod lanes;
pub mod lobes;
pub mod mass_loading;
pub mod modal_update;
pub mod model;
pub mod operating;
pub mod output_error;
pub mod plan;
pub mod rational_fit;
pub mod read;
pub mod refit;
mod signal;
pub mod simulate;
pub mod spectra;
pub mod stabilization;
#[cfg(test)]
mod test_util;
pub mod timeseries;
pub mod twin;
pub mod uff;

pub use error::{Error, Result};
