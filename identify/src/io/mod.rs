//! Reading and writing the data of a campaign: time series (CSV, streamed for long
//! records), FRF CSV and the Universal File Format's dataset 58/58b (docs/formats.md).

pub mod measured;
pub mod read;
pub mod uff;
