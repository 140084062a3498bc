//! Campaigns: the pose-dependent twin, and automatic defaults under different excitations.

mod auto_defaults;
mod pose_twin;
