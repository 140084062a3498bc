//! # lumped — a lumped-mass machine tool for mtwin's tests
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod frf;
pub mod modal;
pub mod structure;

pub use structure::{Machine, Pose};
