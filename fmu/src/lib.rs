//! FMI 2.0 co-simulation slave evaluating an mtwin twin (work in progress).

pub mod export;
