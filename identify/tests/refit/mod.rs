//! Lifetime refit from milling data against the truth.

mod truth;
