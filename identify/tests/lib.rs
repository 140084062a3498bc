//! The integration tests of `identify`, laid out like the library: one module per step
//! of the method (`io`, `spectra`, `fit`, `campaign`, `simulate`, `refit`, `diagnose`,
//! `lobes`) and one helper module (`common`). Run one step's tests with e.g.
//! `cargo test --release -p identify --test identify lobes::`.

mod common;

mod campaign;
mod diagnose;
mod fit;
mod io;
mod lobes;
mod refit;
mod simulate;
mod spectra;
