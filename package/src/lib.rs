//! # mtwin-package — an mtwin twin packaged as an FMU
//!
//! The slave library (`mtwin-fmu`, a `cdylib` that links only `mtwin-core`) evaluates a
//! twin inside an importer; this crate, used by the command line and the Python package,
//! writes what the importer opens:
//!
//! * [`export`] — the twin's FMU, FMI 2.0 (`binaries/linux64/mtwin_tcp.so`) or 3.0
//!   (`binaries/x86_64-linux/`): `modelDescription.xml` from the twin's channels and
//!   workspace, the slave library, `resources/twin.json` (the lean twin);
//! * [`process`] — the milling process's FMU (`resources/cut.json`);
//! * [`ssp`] — both FMUs and a `SystemStructure.ssd` that wires them (SSP 1.0).
#![forbid(unsafe_code)]

pub mod export;
pub mod process;
pub mod ssp;
