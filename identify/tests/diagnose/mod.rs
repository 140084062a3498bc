//! Diagnosis of effects hidden in impact and milling data.

mod hidden;
mod hidden_milling;
mod lumped_levels;
