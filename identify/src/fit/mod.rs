//! From an FRF to an LTI model (paper section 2.2): the model order from a stabilization
//! diagram, then the rational fit (Sanathanan–Koerner / vector fitting, refinement).

pub(crate) mod linalg;
pub mod rational_fit;
pub mod stabilization;
