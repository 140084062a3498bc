//! The rational fit with automatic order: the paper's example, the real impact test, numerical faults.

mod impact;
mod numerators;
mod numerical_faults;
mod paper;
