//! The virtual machine tool (work in progress).
#![forbid(unsafe_code)]
