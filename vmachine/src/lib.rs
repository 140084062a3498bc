//! # vmachine — mtwin's virtual machine tool
//!
//! A generator of realistic test data with a known analytic truth, used by mtwin's tests,
//! examples and `mtwin demo`:
//!
//! * [`structure::ModalMachine`] — modes whose natural frequencies depend on the axis
//!   positions, with mode shapes at the TCP (direct and cross channels), the exact
//!   [`mtwin_core::model::ModalModel`] and analytic FRF at any pose;
//! * [`chain::MdofChain`] — a physical mass–spring–damper chain (the paper's 3-DoF
//!   example), analytic FRF `(K − ω²M + iωC)⁻¹`, exact state-space simulation;
//! * [`excitation`] — impact hammer hits, chirps, random noise, mechanistic milling forces;
//! * [`hidden`] — impact or milling data hiding one effect (worn mode, new mode, delay,
//!   outside vibration, missing cross channel, pose dependence, cubic stiffness) drawn
//!   from a seed, for `diagnose`;
//! * [`daq`] — simulation at a high rate, one linear-phase anti-alias FIR applied to
//!   every channel, decimation, sensor noise: a [`mtwin_core::timeseries::TimeSeries`] like
//!   a real data-acquisition system records.
//!
//! ```
//! use vmachine::structure::ModalMachine;
//! use mtwin_core::axis::Axis;
//! let m = ModalMachine::default_machine();
//! let pose = m.center();
//! let frf = m.frf_at(pose, &[100.0, 200.0], &[Axis::X, Axis::Y]);
//! assert_eq!(frf.channels.len(), 4);
//! let model = m.model_at(pose, &[Axis::X, Axis::Y]);
//! let h = model.eval_hz(0, 100.0);
//! assert!((h - frf.channels[0].h[0]).norm() < 1e-12 * h.norm());
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod cases;
pub mod chain;
pub mod daq;
pub mod excitation;
pub mod hidden;
pub mod structure;
