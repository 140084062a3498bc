//! Stability lobes: zero-order and semi-discretisation.

mod sd;
mod zoa;
