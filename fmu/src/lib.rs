//! FMI 2.0 co-simulation slave (work in progress).
