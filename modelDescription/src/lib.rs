//! FMI 2.0 model description (work in progress).
#![forbid(unsafe_code)]
