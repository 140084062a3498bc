//! Pose interpolation: the twin's model at any axis position.
//!
//! [`TwinEvaluator`] is built once from a [`Twin`] and then answers `model_at(pose)`
//! without allocating, so the FMU can call it at every communication step.
//!
//! (Current state: nearest measured pose; modal-parameter interpolation of tracked
//! modes follows in the pose-dependent-twin work.)

use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::model::ModalModel;
use crate::twin::Twin;

/// Evaluates a twin's model at arbitrary poses.
#[derive(Debug, Clone)]
pub struct TwinEvaluator {
    poses: Vec<[f64; 3]>,
    models: Vec<ModalModel>,
    current: ModalModel,
    channels: Vec<Channel>,
}

impl TwinEvaluator {
    /// Prepares the evaluator. All pose models must share channels and mode count.
    pub fn new(twin: &Twin) -> Result<Self> {
        let first = twin
            .poses
            .first()
            .ok_or_else(|| Error::BadInput("the twin has no poses".into()))?;
        let n = first.model.modes.len();
        if twin.poses.iter().any(|p| p.model.modes.len() != n) {
            return Err(Error::BadInput(
                "pose models have different mode counts; re-identify the twin".into(),
            ));
        }
        Ok(TwinEvaluator {
            poses: twin.poses.iter().map(|p| p.pose).collect(),
            models: twin.poses.iter().map(|p| p.model.clone()).collect(),
            current: first.model.clone(),
            channels: first.model.channels.iter().map(|c| c.channel).collect(),
        })
    }

    /// Number of modes of every model this evaluator returns.
    pub fn n_modes(&self) -> usize {
        self.current.modes.len()
    }

    /// Channels of the models.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The model at `pose` (x, y, z in metres).
    pub fn model_at(&mut self, pose: [f64; 3]) -> &ModalModel {
        let d2 = |p: &[f64; 3]| -> f64 { (0..3).map(|i| (p[i] - pose[i]).powi(2)).sum() };
        let best = (0..self.poses.len())
            .min_by(|&a, &b| d2(&self.poses[a]).total_cmp(&d2(&self.poses[b])))
            .unwrap_or(0);
        self.current.clone_from(&self.models[best]);
        &self.current
    }
}
