//! Candidates fitted to the building parts' responses in time (operating data, whose
//! periodic forces leave the Welch FRF evidence little between their harmonics): the
//! parts standing at their mean poses, a base simulation, and the residual of any twin
//! that differs from the base in a few modes (only the difference is simulated).

use crate::axis::Axis;
use crate::extended::{resimulate_as_measured_lti, simulate_as_measured_lti};
use crate::timeseries::TimeSeries;
use crate::twin::Twin;

/// The building parts' measured responses and a base twin's simulation of them, each
/// part at its mean pose (the search only; the held-out test simulates the records as
/// they are), flattened over the parts and the judged response axes.
pub(super) struct InTime<'a> {
    base_twin: &'a Twin,
    still: Vec<TimeSeries>,
    axes: Vec<Axis>,
    base: Vec<[Vec<f64>; 3]>,
    /// The measured responses, flattened.
    pub(super) measured: Vec<f64>,
    /// The base twin's simulation, flattened like `measured`.
    pub(super) base_flat: Vec<f64>,
    /// Σ measured².
    pub(super) power: f64,
}

impl<'a> InTime<'a> {
    /// The parts `parts` against `base_twin`; `None` without any measured response.
    pub(super) fn new(base_twin: &'a Twin, parts: &[TimeSeries]) -> Option<InTime<'a>> {
        let axes = parts
            .first()
            .map(|p| super::evidence::judged_axes(base_twin, p))
            .unwrap_or_default();
        let still: Vec<TimeSeries> = parts
            .iter()
            .map(|p| {
                let mut s = p.clone();
                let m = p.mean_position();
                for (a, v) in s.position.iter_mut().enumerate() {
                    if let Some(v) = v.as_mut() {
                        v.iter_mut().for_each(|x| *x = m[a]);
                    }
                }
                s
            })
            .collect();
        let base: Vec<[Vec<f64>; 3]> = still
            .iter()
            .map(|s| simulate_as_measured_lti(base_twin, s))
            .collect::<crate::error::Result<_>>()
            .ok()?;
        let measured = flatten(&still, &axes, |i, a| still[i].response(a))?;
        let base_flat = flatten(&still, &axes, |i, a| Some(&base[i][a.index()][..]))?;
        let power: f64 = measured.iter().map(|x| x * x).sum();
        (power > 0.0).then_some(InTime {
            base_twin,
            still,
            axes,
            base,
            measured,
            base_flat,
            power,
        })
    }

    /// The parts standing at their mean poses.
    pub(super) fn parts(&self) -> &[TimeSeries] {
        &self.still
    }

    /// The simulation of `t` (which differs from the base twin in a few modes or
    /// numerators), flattened like `measured`.
    pub(super) fn sim(&self, t: &Twin) -> Option<Vec<f64>> {
        let sims: Vec<[Vec<f64>; 3]> = self
            .still
            .iter()
            .zip(&self.base)
            .map(|(s, b)| resimulate_as_measured_lti(self.base_twin, t, s, b))
            .collect::<crate::error::Result<_>>()
            .ok()?;
        flatten(&self.still, &self.axes, |i, a| {
            Some(&sims[i][a.index()][..])
        })
    }

    /// Σ (measured − simulation of `t`)².
    pub(super) fn residual(&self, t: &Twin) -> Option<f64> {
        let y = self.sim(t)?;
        Some(
            self.measured
                .iter()
                .zip(&y)
                .map(|(u, v)| (u - v) * (u - v))
                .sum(),
        )
    }
}

/// `get(part, axis)` of every part of `still` and judged axis with a measured response,
/// concatenated.
fn flatten<'s>(
    still: &[TimeSeries],
    axes: &[Axis],
    get: impl Fn(usize, Axis) -> Option<&'s [f64]>,
) -> Option<Vec<f64>> {
    let mut out = Vec::new();
    for (i, s) in still.iter().enumerate() {
        for a in axes {
            if s.response(*a).is_some() {
                out.extend_from_slice(get(i, *a)?);
            }
        }
    }
    Some(out)
}

/// The records' force power per line (all force columns, each record's own lines):
/// `(frequency [Hz], power)`, the mean removed.
pub(super) fn force_power(parts: &[TimeSeries]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for p in parts {
        let n = p.len();
        if n < 16 {
            continue;
        }
        let fft = crate::spectra::plan(n);
        let df = 1.0 / (n as f64 * p.dt);
        for ax in Axis::ALL {
            let Some(f) = p.force(ax) else { continue };
            let mean = f.iter().sum::<f64>() / n as f64;
            let mut x: Vec<f64> = f.iter().map(|v| v - mean).collect();
            let mut spec = fft.make_output_vec();
            if fft.process(&mut x, &mut spec).is_ok() {
                out.extend(
                    spec.iter()
                        .enumerate()
                        .map(|(l, c)| (l as f64 * df, c.norm_sqr())),
                );
            }
        }
    }
    out
}

/// The share of the force power `power` ([`force_power`]) within the mode's half-power
/// band around `lo..hi` Hz, widened to at least 3 % either side.
pub(super) fn force_share_near(power: &[(f64, f64)], lo: f64, hi: f64, zeta: f64) -> f64 {
    let w = zeta.max(0.03);
    let (a, b) = (lo * (1.0 - w), hi * (1.0 + w));
    let all: f64 = power.iter().map(|p| p.1).sum();
    let inside: f64 = (power.iter())
        .filter(|(f, _)| *f >= a && *f <= b)
        .map(|p| p.1)
        .sum();
    if all > 0.0 {
        inside / all
    } else {
        0.0
    }
}
