//! The command-line integration tests: the `mtwin` binary run as a user runs it, one
//! module per subject (a command, a data set, messages, reports), one helper module
//! (`common`). Run one subject with e.g. `cargo test --release --test cli refit::`.

mod common;

mod atomic;
mod bad_input;
mod lumped;
mod messages;
mod modal_campaign;
mod real_impact;
mod refit;
mod refit_tryout;
mod reports;
mod robustness;
mod stream;
mod tryout;
mod tryout_hidden;
mod uff;
