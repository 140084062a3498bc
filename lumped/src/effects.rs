//! Hidden effects (to be written).
