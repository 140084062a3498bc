//! Reading and writing: time-series and FRF CSV, universal files, fuzzed inputs.

mod fuzz_readers;
mod read_csv;
mod uff;
