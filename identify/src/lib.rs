//! # identify — the numerical core of mtwin
//!
//! From measured force and response to a pose-dependent, lifetime-adaptive LTI twin of a
//! machine tool's tool-center-point dynamics. One module (or folder) per step of the method,
//! in the paper's order (section numbers of ../shared/paper.md):
//!
//! | step (paper section) | module |
//! |---|---|
//! | reading data: time series, FRF CSV, UFF 58/58b (2.1, docs/formats.md) | [`io`] ([`read`], [`uff`]) |
//! | the response sensor's mass loading removed (`# sensor_mass=`, opt-in) | [`mass_loading`] |
//! | FRF estimation: H1/H2/Hv, impact processing, chirps, coherence, operating spectra (2.1, 2.3): one planner and one window for every spectrum | [`spectra`] |
//! | the automatic decisions: band, channels, excitation, with their evidence | [`plan`] |
//! | model order from a stabilization diagram, rational fit by SK iterations / vector fitting and refinement (2.2) | [`fit`] ([`stabilization`], [`rational_fit`]) |
//! | a campaign: one fit per pose, modes tracked over the poses, leave-one-pose-out (2.2) | [`campaign`] |
//! | interpolation between poses, the twin file, the model, simulation (2.2, eq. 1 and 3) | re-exported from `mtwin-core`: [`interpolate`], [`twin`], [`model`], [`simulate`], [`extended`] |
//! | refit from operating data: operating spectra, drift check, intermediate FRF, modal update, output error, spread to the poses, history (2.3, 3.2) | [`refit`] ([`modal_update`], [`output_error`]; operating spectra in [`spectra::operating`]) |
//! | diagnosis: what the twin gets wrong, its cause, the extended twin (ours; docs/formats.md, "Diagnosis output") | [`diagnose`] (one file per cause) |
//! | stability lobes of the twin (the co-simulation's use, ours) | [`lobes`] |
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

pub mod campaign;
mod consistency;
pub mod diagnose;
mod eigen;
pub mod fit;
mod guards;
pub mod io;
mod lanes;
pub mod lobes;
pub mod mass_loading;
pub mod plan;
pub mod refit;
pub mod spectra;
#[cfg(test)]
mod test_util;

// the steps by their own names (`identify::read`, `identify::rational_fit`, ...)
pub use fit::{rational_fit, stabilization};
pub use io::{read, uff};
pub use refit::{modal_update, output_error};
pub use spectra::operating;

// the twin as data and how to run it live in mtwin-core (the FMU links only that);
// re-exported so that `identify::model`, `identify::twin`, ... keep their paths
pub use mtwin_core::{
    atomic, axis, error, extended, frf, interpolate, model, signal, simulate, timeseries, twin,
};

pub use error::{Error, Result};
