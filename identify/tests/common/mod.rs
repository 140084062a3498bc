//! The one helper module of `identify`'s tests: where ../shared/data is (the final
//! layout `../../shared` from the crate, else `$MTWIN_SHARED`, else `/work/shared`), and
//! below it the helpers of the fit tests ([`fit`]), the simulated systems of the spectra
//! tests ([`systems`]) and the base twins of the hidden-effect cases ([`hidden_base`]).

pub mod fit;
pub mod hidden_base;
pub mod systems;

use std::path::PathBuf;

/// The shared folder's file `rel` (e.g. `data/pyfrf_impact_hammer/impact_5hits.csv`).
pub fn shared(rel: &str) -> PathBuf {
    let mut cands = vec![PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared"
    ))];
    if let Ok(p) = std::env::var("MTWIN_SHARED") {
        cands.push(PathBuf::from(p));
    }
    cands.push(PathBuf::from("/work/shared"));
    cands
        .into_iter()
        .map(|c| c.join(rel))
        .find(|p| p.exists())
        .unwrap_or_else(|| panic!("shared data file {rel} not found"))
}

/// The shared data folder.
pub fn data_dir() -> PathBuf {
    shared("data")
}
