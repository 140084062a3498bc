//! # mtwin-fmu — the twin as an FMI 2.0 and FMI 3.0 co-simulation slave
//!
//! A `cdylib` exporting the 34 functions of FMI 2.0 Co-Simulation and the functions of
//! FMI 3.0 (Co-Simulation supported, the rest returning `fmi3Error`), in three layers:
//!
//! * [`ffi`] — the C types of both versions;
//! * `exports` (FMI 2.0) and `exports3` (FMI 3.0) — the `extern "C"` functions, each
//!   through one trampoline shared by both (`trampoline`: null checks, `catch_unwind`,
//!   errors logged and returned as `fmi2Error`/`fmi3Error`, never `Discard`; an instance
//!   that panicked refuses every later call);
//! * [`slave`] — the safe core both drive: life cycle, value references, `doStep` on the
//!   twin interpolated at the current axis positions (the same state-space core as
//!   `mtwin simulate`).
//!
//! The same library is also the milling process's FMU ([`process`]: the regenerative
//! force model with its delay line, inputs `dx`, `dy`, outputs `Fx`, `Fy`); the resource
//! an FMU carries decides which model an instance evaluates ([`model`]): the lean twin of
//! [`resources`] (pose models, no FRFs or history) or the cut. No global state: instances
//! are independent.
//!
//! This crate is the slave only: it links `mtwin-core` and nothing of the identification.
//! Packaging (`modelDescription.xml`, the zip, the SSP) is the `mtwin-package` crate
//! beside the command line.

#[allow(missing_docs)]
mod exports;
#[allow(missing_docs)]
mod exports3;
pub mod ffi;
pub mod model;
pub mod process;
pub mod resources;
pub mod slave;
mod trampoline;

pub use trampoline::resource_dir;
