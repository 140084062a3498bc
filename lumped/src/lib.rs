//! # lumped — a lumped-mass machine tool for mtwin's tests
//!
//! A second test-data generator, built unlike `vmachine`: nothing here is a mode.
//! Rigid bodies (bed, table, portal, cross-rail, saddle, ram, spindle, tool) are joined by
//! point springs and discrete dashpots (levelling mounts, guide carriages, ball screws,
//! bolted joints, spindle bearings, the holder interface); the modes, their damping,
//! their complex shapes, the cross coupling at the TCP and their change with the axis
//! positions all follow from that structure.
//!
//! * [`structure::Machine`] — parameters ([`Machine::nominal`], [`Machine::random`]),
//!   layout at a pose, `M`, `C`, `K` and the TCP map;
//! * [`frf`] — the exact receptance `G (K − ω²M + iωC)⁻¹ Gᵀ` ([`Machine::analytic_frf`]);
//! * [`modal`] — eigen-analysis: poles, complex shapes, TCP residues;
//! * [`sim`] — exact discretisation (matrix exponential, zero/first-order hold) while the
//!   axes move, and Runge–Kutta 4 for a cubic spring or friction;
//! * [`daq`] — anti-alias FIR and decimation, white + 1/f noise, ADC quantisation;
//! * [`excitation`] — hammer (pulse from the tip stiffness), random, sweeps, stepped
//!   sine, milling (helix, runout, tooth-to-tooth variation);
//! * [`measure`] — tests put together: simulate, decimate, add noise;
//! * [`effects`] — the hidden effects of the diagnosis causes (docs/formats.md) with their expected answers;
//! * [`record`] — records and the CSV files of SPEC sections 2 and 3.
//!
//! ```
//! use lumped::structure::{Machine, CENTRE};
//! let m = Machine::nominal();
//! let frf = m.analytic_frf(CENTRE, &[100.0, 500.0]);
//! let modes = m.modes(CENTRE);
//! assert!(modes.iter().any(|md| md.freq_hz > 50.0 && md.freq_hz < 3000.0));
//! // the TCP receptance is symmetric (reciprocity) and dissipative (Im h_xx < 0)
//! let h = frf.h[0];
//! assert!((h[(0, 1)] - h[(1, 0)]).norm() < 1e-9 * h[(0, 0)].norm());
//! assert!(h[(0, 0)].im < 0.0);
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod daq;
pub mod effects;
pub mod excitation;
pub mod frf;
pub mod measure;
pub mod modal;
pub mod observe;
pub mod record;
pub mod sim;
pub mod structure;

pub use frf::Frf;
pub use record::{Record, Response};
pub use structure::{Machine, Pose};

use std::path::{Path, PathBuf};

/// Errors of this crate (only file output can fail).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file or folder could not be written.
    #[error("cannot write {path}: {source} (check that the folder exists and is writable)")]
    Io {
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl Error {
    /// An I/O error at `path`.
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
