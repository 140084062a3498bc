//! Time series of force, response and axis positions (docs/formats.md, "Time-series CSV"), in memory.

use crate::axis::Axis;
use serde::{Deserialize, Serialize};

/// What the response columns measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ResponseKind {
    /// Acceleration `ax, ay, az` \[m/s²\].
    Acceleration,
    /// Displacement `dx, dy, dz` \[m\].
    Displacement,
}

/// One uniformly sampled record, as read from a time-series CSV.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeSeries {
    /// Where it came from (file path), for messages and provenance.
    pub source: String,
    /// Time of the first sample \[s\].
    pub t0: f64,
    /// Sample period \[s\] (1 / sample rate), the mean step of the `t` column.
    pub dt: f64,
    /// Forces `fx, fy, fz` \[N\], indexed by [`Axis::index`]; `None` = column absent.
    pub force: [Option<Vec<f64>>; 3],
    /// Responses indexed by axis; see [`TimeSeries::response_kind`].
    pub response: [Option<Vec<f64>>; 3],
    /// Kind of the response columns (`None` when no response column is present).
    pub response_kind: Option<ResponseKind>,
    /// Axis positions `x, y, z` \[m\] per sample; `None` = column absent (position 0).
    pub position: [Option<Vec<f64>>; 3],
    /// `#` comment lines (without the `#`), free metadata.
    pub comments: Vec<String>,
}

impl TimeSeries {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.force
            .iter()
            .chain(self.response.iter())
            .flatten()
            .map(Vec::len)
            .next()
            .unwrap_or(0)
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sample rate \[Hz\].
    pub fn fs(&self) -> f64 {
        1.0 / self.dt
    }

    /// Times of the samples \[s\].
    pub fn times(&self) -> Vec<f64> {
        (0..self.len())
            .map(|i| self.t0 + i as f64 * self.dt)
            .collect()
    }

    /// Force along `a`, if measured.
    pub fn force(&self, a: Axis) -> Option<&[f64]> {
        self.force[a.index()].as_deref()
    }

    /// Response along `a`, if measured.
    pub fn response(&self, a: Axis) -> Option<&[f64]> {
        self.response[a.index()].as_deref()
    }

    /// Axes that carry a force column.
    pub fn force_axes(&self) -> Vec<Axis> {
        Axis::ALL
            .into_iter()
            .filter(|a| self.force[a.index()].is_some())
            .collect()
    }

    /// Axes that carry a response column.
    pub fn response_axes(&self) -> Vec<Axis> {
        Axis::ALL
            .into_iter()
            .filter(|a| self.response[a.index()].is_some())
            .collect()
    }

    /// Axis position at sample `i` (0 where the column is absent).
    pub fn position_at(&self, i: usize) -> [f64; 3] {
        let mut p = [0.0; 3];
        for a in Axis::ALL {
            if let Some(v) = &self.position[a.index()] {
                p[a.index()] = v[i];
            }
        }
        p
    }

    /// Mean axis position over the record (the record's pose).
    pub fn mean_position(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for a in Axis::ALL {
            if let Some(v) = &self.position[a.index()] {
                if !v.is_empty() {
                    p[a.index()] = v.iter().sum::<f64>() / v.len() as f64;
                }
            }
        }
        p
    }
}
