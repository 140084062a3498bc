//! Pose interpolation: the twin's model at any axis position.
//!
//! Interpolating raw FRFs between poses smears resonance peaks (two peaks of half
//! height instead of one shifted peak). Like the pose-dependent models in the machine-tool
//! literature (modal parameters identified at measured poses and interpolated over the
//! workspace, e.g. Baumann et al. as cited by the paper, Liu et al. with linear
//! interpolation of mode-shape databases), mtwin interpolates the parameters of
//! *tracked* modes: every pose model has the same modes in the same order (see
//! `campaign`), and each parameter is interpolated on its own:
//!
//! * natural frequency ω linearly, damping as ln ζ (stays positive), numerators
//!   `b0, b1` and the residual `d` linearly;
//! * poses on a full tensor grid (every combination of the distinct x, y, z values):
//!   tensor-product interpolation along each axis — linear with 2 values, the parabola
//!   with 3, a not-a-knot cubic spline with 4 or more (exact for quadratic and cubic
//!   variation, C² smooth);
//! * scattered poses: polyharmonic radial basis function φ(r) = r³ with a linear
//!   polynomial tail (exact at the measured poses, minimal bending), on coordinates
//!   scaled to the measured extent of each axis.
//!
//! Outside the measured box the pose is clamped to the box on each axis (the model of
//! the nearest boundary point; no extrapolation of trends), and [`TwinEvaluator::is_inside`]
//! says so.
//!
//! [`TwinEvaluator`] is built once from a [`Twin`] and then answers
//! [`TwinEvaluator::model_at`] without allocating, so the FMU can call it every step.

use crate::axis::Channel;
use crate::error::{Error, Result};
use crate::model::ModalModel;
use crate::twin::Twin;
use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// Simulates the twin's response to sampled forces at sampled poses (the loop behind
/// `mtwin simulate`, the drift check and diagnosis).
///
/// Sample `i` of the result is the response at `t_i`: the state advanced over every
/// step `[t_{k-1}, t_k]`, `k ≤ i`, with the model at the pose of `t_{k-1}`, plus the
/// feedthrough of the force at `t_i` with the model at the pose of `t_i`.
pub fn simulate_twin(
    ev: &mut TwinEvaluator,
    forces: &[[f64; 3]],
    pose_at: impl Fn(usize) -> [f64; 3],
    dt: f64,
    hold: crate::simulate::Hold,
) -> Vec<[f64; 3]> {
    simulate_twin_cubic(ev, forces, &pose_at, dt, hold, &[])
}

/// [`simulate_twin`] with a cubic modal stiffness `kappa[k]` per mode (empty: none; see
/// [`crate::simulate::Simulator::set_cubic`]).
pub fn simulate_twin_cubic(
    ev: &mut TwinEvaluator,
    forces: &[[f64; 3]],
    pose_at: &dyn Fn(usize) -> [f64; 3],
    dt: f64,
    hold: crate::simulate::Hold,
    kappa: &[f64],
) -> Vec<[f64; 3]> {
    // the response at samples `0, every, 2·every, …` of a simulation over all `f`
    let mut run = |f: &[[f64; 3]], at: &dyn Fn(usize) -> [f64; 3], h: f64, every: usize| {
        let mut out = Vec::with_capacity(f.len().div_ceil(every));
        if f.is_empty() {
            return out;
        }
        let mut sim = crate::simulate::Simulator::new(ev.n_modes(), hold);
        if !kappa.is_empty() {
            sim.set_cubic(kappa);
        }
        out.push(sim.output(ev.model_at(at(0)), &f[0]));
        for i in 1..f.len() {
            sim.step(ev.model_at(at(i - 1)), &f[i - 1], &f[i], h);
            if i % every == 0 {
                out.push(sim.output(ev.model_at(at(i)), &f[i]));
            }
        }
        out
    };
    if hold == crate::simulate::Hold::BandLimited {
        return crate::simulate::run_band_limited(forces, dt, |f, h, coarse, every| {
            run(f, &|m| pose_at(coarse(m)), h, every)
        });
    }
    run(forces, pose_at, dt, 1)
}

/// Which interpolation scheme a twin uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// A single measured pose: the same model everywhere.
    Single,
    /// Tensor-product interpolation on a full grid of poses.
    TensorGrid,
    /// Polyharmonic RBF (r³ + linear tail) on scattered poses.
    Rbf,
}

/// Tolerance \[m\] under which two coordinates count as the same grid value.
pub const GRID_TOL_M: f64 = 1e-4;

/// Interpolation along one axis: nodes and the linear map from node values to
/// second derivatives of the spline (`m = S y`).
#[derive(Debug, Clone)]
struct Axis1d {
    nodes: Vec<f64>,
    s: DMatrix<f64>,
}

impl Axis1d {
    fn new(nodes: Vec<f64>) -> Self {
        let n = nodes.len();
        let mut s = DMatrix::zeros(n, n);
        if n == 3 {
            // the parabola through three points: constant second derivative
            let (x0, x1, x2) = (nodes[0], nodes[1], nodes[2]);
            let c = [
                2.0 / ((x0 - x1) * (x0 - x2)),
                2.0 / ((x1 - x0) * (x1 - x2)),
                2.0 / ((x2 - x0) * (x2 - x1)),
            ];
            for i in 0..3 {
                for (j, cj) in c.iter().enumerate() {
                    s[(i, j)] = *cj;
                }
            }
        } else if n >= 4 {
            // not-a-knot cubic spline: A m = B y
            let h: Vec<f64> = nodes.windows(2).map(|w| w[1] - w[0]).collect();
            let mut a = DMatrix::zeros(n, n);
            let mut b = DMatrix::zeros(n, n);
            a[(0, 0)] = h[1];
            a[(0, 1)] = -(h[0] + h[1]);
            a[(0, 2)] = h[0];
            for i in 1..n - 1 {
                a[(i, i - 1)] = h[i - 1];
                a[(i, i)] = 2.0 * (h[i - 1] + h[i]);
                a[(i, i + 1)] = h[i];
                b[(i, i - 1)] = 6.0 / h[i - 1];
                b[(i, i)] = -6.0 / h[i - 1] - 6.0 / h[i];
                b[(i, i + 1)] = 6.0 / h[i];
            }
            let (k, l) = (n - 1, n - 2);
            a[(k, k - 2)] = h[l];
            a[(k, k - 1)] = -(h[l - 1] + h[l]);
            a[(k, k)] = h[l - 1];
            if let Some(inv) = a.try_inverse() {
                s = inv * b;
            }
        }
        Axis1d { nodes, s }
    }

    /// Weights of the node values at `x` (clamped to the node range).
    fn weights(&self, x: f64, w: &mut [f64]) {
        let n = self.nodes.len();
        w.iter_mut().for_each(|v| *v = 0.0);
        if n == 1 {
            w[0] = 1.0;
            return;
        }
        let x = x.clamp(self.nodes[0], self.nodes[n - 1]);
        let i = match self.nodes.iter().rposition(|&v| v <= x) {
            Some(i) if i >= n - 1 => n - 2,
            Some(i) => i,
            None => 0,
        };
        let h = self.nodes[i + 1] - self.nodes[i];
        let a = (self.nodes[i + 1] - x) / h;
        let b = 1.0 - a;
        w[i] += a;
        w[i + 1] += b;
        if n >= 3 {
            // y = a y_i + b y_{i+1} + ((a³-a) m_i + (b³-b) m_{i+1}) h²/6
            let ca = (a * a * a - a) * h * h / 6.0;
            let cb = (b * b * b - b) * h * h / 6.0;
            for (j, wj) in w.iter_mut().enumerate() {
                *wj += ca * self.s[(i, j)] + cb * self.s[(i + 1, j)];
            }
        }
    }
}

#[derive(Debug, Clone)]
enum Scheme {
    Single,
    Grid {
        axes: [Axis1d; 3],
        /// pose index of grid node (ix, iy, iz), flattened x-fastest
        index: Vec<usize>,
    },
    Rbf {
        centers: Vec<[f64; 3]>,
        /// (N+4)×N: rows = [φ coefficients; polynomial coefficients] per node value
        coef: DMatrix<f64>,
    },
}

/// Evaluates a twin's model at arbitrary poses.
#[derive(Debug, Clone)]
pub struct TwinEvaluator {
    scheme: Scheme,
    /// parameters per pose, flattened (see `flatten`)
    params: Vec<Vec<f64>>,
    lo: [f64; 3],
    hi: [f64; 3],
    current: ModalModel,
    channels: Vec<Channel>,
    weights: Vec<f64>,
    scratch: [Vec<f64>; 3],
    values: Vec<f64>,
    /// ω never drops below 10 % of its smallest measured value (spline overshoot guard)
    floor_wn: Vec<f64>,
    last_pose: Option<[f64; 3]>,
}

fn flatten(m: &ModalModel, out: &mut Vec<f64>) {
    out.clear();
    for mode in &m.modes {
        out.push(mode.wn);
        out.push(mode.zeta.ln());
    }
    for c in &m.channels {
        for n in &c.num {
            out.push(n.b0);
            out.push(n.b1);
        }
        out.push(c.d);
    }
}

fn unflatten(v: &[f64], m: &mut ModalModel, floor_wn: &[f64]) {
    let nm = m.modes.len();
    for (k, mode) in m.modes.iter_mut().enumerate() {
        mode.wn = v[2 * k].max(floor_wn[k]);
        mode.zeta = v[2 * k + 1].exp();
    }
    let mut i = 2 * nm;
    for c in &mut m.channels {
        for n in &mut c.num {
            n.b0 = v[i];
            n.b1 = v[i + 1];
            i += 2;
        }
        c.d = v[i];
        i += 1;
    }
}

impl Twin {
    /// The twin's model at `pose` (interpolated between the measured poses); for many
    /// poses, keep a [`TwinEvaluator`].
    pub fn model_at(&self, pose: [f64; 3]) -> Result<ModalModel> {
        Ok(TwinEvaluator::new(self)?.model_at(pose).clone())
    }
}

impl TwinEvaluator {
    /// Prepares the evaluator. All pose models must share channels and mode count
    /// (tracked modes).
    pub fn new(twin: &Twin) -> Result<Self> {
        Self::from_poses(
            &twin
                .poses
                .iter()
                .map(|p| (p.pose, &p.model))
                .collect::<Vec<_>>(),
        )
    }

    /// Prepares the evaluator from `(pose, model)` pairs.
    pub fn from_poses(poses: &[([f64; 3], &ModalModel)]) -> Result<Self> {
        let first = poses
            .first()
            .ok_or_else(|| Error::BadInput("the twin has no poses".into()))?
            .1;
        let chans: Vec<Channel> = first.channels.iter().map(|c| c.channel).collect();
        for (p, m) in poses {
            if m.modes.len() != first.modes.len()
                || m.channels
                    .iter()
                    .map(|c| c.channel)
                    .ne(chans.iter().copied())
            {
                return Err(Error::BadInput(format!(
                    "the model at pose {p:?} has other modes or channels than the first pose; \
                     pose models of a twin must share tracked modes (re-identify the twin)"
                )));
            }
        }
        let params: Vec<Vec<f64>> = poses
            .iter()
            .map(|(_, m)| {
                let mut v = Vec::new();
                flatten(m, &mut v);
                v
            })
            .collect();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for (p, _) in poses {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let scheme = if poses.len() == 1 {
            Scheme::Single
        } else if let Some(g) = detect_grid(poses) {
            g
        } else {
            build_rbf(poses, &lo, &hi)?
        };
        let np = params[0].len();
        let floor_wn = (0..first.modes.len())
            .map(|k| {
                params
                    .iter()
                    .map(|p| p[2 * k])
                    .fold(f64::INFINITY, f64::min)
                    * 0.1
            })
            .collect();
        Ok(TwinEvaluator {
            last_pose: None,
            floor_wn,
            scheme,
            params,
            lo,
            hi,
            current: first.clone(),
            channels: chans,
            weights: vec![0.0; poses.len()],
            scratch: [Vec::new(), Vec::new(), Vec::new()],
            values: vec![0.0; np],
        })
    }

    /// The scheme in use.
    pub fn method(&self) -> Method {
        match self.scheme {
            Scheme::Single => Method::Single,
            Scheme::Grid { .. } => Method::TensorGrid,
            Scheme::Rbf { .. } => Method::Rbf,
        }
    }

    /// Number of modes of every model this evaluator returns.
    pub fn n_modes(&self) -> usize {
        self.current.modes.len()
    }

    /// Channels of the models.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// The measured box: lower and upper corner.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        (self.lo, self.hi)
    }

    /// True when `pose` lies inside the measured box (within 0.1 mm).
    pub fn is_inside(&self, pose: [f64; 3]) -> bool {
        (0..3).all(|a| pose[a] >= self.lo[a] - GRID_TOL_M && pose[a] <= self.hi[a] + GRID_TOL_M)
    }

    /// The model at `pose` (x, y, z in metres); clamped to the measured box.
    pub fn model_at(&mut self, pose: [f64; 3]) -> &ModalModel {
        if self.last_pose == Some(pose) {
            return &self.current;
        }
        self.last_pose = Some(pose);
        let mut p = pose;
        for a in 0..3 {
            p[a] = if p[a].is_finite() {
                p[a].clamp(self.lo[a], self.hi[a])
            } else {
                self.lo[a]
            };
        }
        self.compute_weights(p);
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for (w, par) in self.weights.iter().zip(&self.params) {
            if *w != 0.0 {
                for (v, x) in self.values.iter_mut().zip(par) {
                    *v += w * x;
                }
            }
        }
        unflatten(&self.values, &mut self.current, &self.floor_wn);
        &self.current
    }

    fn compute_weights(&mut self, p: [f64; 3]) {
        match &self.scheme {
            Scheme::Single => self.weights[0] = 1.0,
            Scheme::Grid { axes, index } => {
                for a in 0..3 {
                    self.scratch[a].resize(axes[a].nodes.len(), 0.0);
                    axes[a].weights(p[a], &mut self.scratch[a]);
                }
                let (nx, ny) = (axes[0].nodes.len(), axes[1].nodes.len());
                for (k, wz) in self.scratch[2].iter().enumerate() {
                    for (j, wy) in self.scratch[1].iter().enumerate() {
                        for (i, wx) in self.scratch[0].iter().enumerate() {
                            self.weights[index[i + nx * (j + ny * k)]] = wx * wy * wz;
                        }
                    }
                }
            }
            Scheme::Rbf { centers, coef } => {
                let q = scale(p, &self.lo, &self.hi);
                let n = centers.len();
                self.scratch[0].resize(n + 4, 0.0);
                for (j, c) in centers.iter().enumerate() {
                    let r = ((q[0] - c[0]).powi(2) + (q[1] - c[1]).powi(2) + (q[2] - c[2]).powi(2))
                        .sqrt();
                    self.scratch[0][j] = r * r * r;
                }
                self.scratch[0][n] = 1.0;
                self.scratch[0][n + 1..n + 4].copy_from_slice(&q);
                for i in 0..n {
                    self.weights[i] = (0..n + 4).map(|r| self.scratch[0][r] * coef[(r, i)]).sum();
                }
            }
        }
    }
}

fn scale(p: [f64; 3], lo: &[f64; 3], hi: &[f64; 3]) -> [f64; 3] {
    let mut q = [0.0; 3];
    for a in 0..3 {
        let ext = hi[a] - lo[a];
        q[a] = if ext > GRID_TOL_M {
            (p[a] - lo[a]) / ext
        } else {
            0.0
        };
    }
    q
}

fn distinct(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for x in v {
        if out.last().is_none_or(|l| x - l > GRID_TOL_M) {
            out.push(x);
        }
    }
    out
}

fn detect_grid(poses: &[([f64; 3], &ModalModel)]) -> Option<Scheme> {
    let vals: Vec<Vec<f64>> = (0..3)
        .map(|a| distinct(poses.iter().map(|(p, _)| p[a])))
        .collect();
    let (nx, ny, nz) = (vals[0].len(), vals[1].len(), vals[2].len());
    if nx * ny * nz != poses.len() {
        return None;
    }
    let find = |a: usize, x: f64| vals[a].iter().position(|v| (v - x).abs() <= GRID_TOL_M);
    let mut index = vec![usize::MAX; poses.len()];
    for (pi, (p, _)) in poses.iter().enumerate() {
        let (i, j, k) = (find(0, p[0])?, find(1, p[1])?, find(2, p[2])?);
        let slot = &mut index[i + nx * (j + ny * k)];
        if *slot != usize::MAX {
            return None;
        }
        *slot = pi;
    }
    Some(Scheme::Grid {
        axes: [
            Axis1d::new(vals[0].clone()),
            Axis1d::new(vals[1].clone()),
            Axis1d::new(vals[2].clone()),
        ],
        index,
    })
}

fn build_rbf(poses: &[([f64; 3], &ModalModel)], lo: &[f64; 3], hi: &[f64; 3]) -> Result<Scheme> {
    let n = poses.len();
    let centers: Vec<[f64; 3]> = poses.iter().map(|(p, _)| scale(*p, lo, hi)).collect();
    let mut a = DMatrix::zeros(n + 4, n + 4);
    for i in 0..n {
        for j in 0..n {
            let r = (0..3)
                .map(|d| (centers[i][d] - centers[j][d]).powi(2))
                .sum::<f64>()
                .sqrt();
            a[(i, j)] = r * r * r;
        }
        a[(i, n)] = 1.0;
        a[(n, i)] = 1.0;
        for d in 0..3 {
            a[(i, n + 1 + d)] = centers[i][d];
            a[(n + 1 + d, i)] = centers[i][d];
        }
    }
    // Axes along which all poses agree make the polynomial block singular: pin those
    // coefficients to zero.
    for d in 0..3 {
        if hi[d] - lo[d] <= GRID_TOL_M {
            a[(n + 1 + d, n + 1 + d)] = 1.0;
        }
    }
    let mut rhs = DMatrix::zeros(n + 4, n);
    for i in 0..n {
        rhs[(i, i)] = 1.0;
    }
    let svd = a.svd(true, true);
    let coef = svd
        .solve(&rhs, 1e-12)
        .map_err(|e| Error::Numerical(format!("pose interpolation system: {e}")))?;
    Ok(Scheme::Rbf { centers, coef })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axis::Axis;
    use crate::model::{ChannelModel, Mode, ModeNum};

    fn model(f: f64) -> ModalModel {
        ModalModel {
            modes: vec![Mode::from_hz(f, 0.02)],
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::X, Axis::X),
                num: vec![ModeNum { b0: f, b1: 0.0 }],
                d: 0.0,
            }],
        }
    }

    /// f(x, y, z) quadratic in x and y, linear in z: recovered exactly on a 3×3×2 grid.
    fn truth(p: [f64; 3]) -> f64 {
        100.0 * (1.0 + 0.2 * p[0] - 0.3 * p[0] * p[0] + 0.1 * p[1] * p[1] - 0.05 * p[2])
    }

    #[test]
    fn tensor_grid_is_exact_for_quadratic_variation() {
        let mut poses = Vec::new();
        for &z in &[0.0, 0.3] {
            for &y in &[0.0, 0.2, 0.4] {
                for &x in &[0.0, 0.3, 0.6] {
                    poses.push(([x, y, z], model(truth([x, y, z]))));
                }
            }
        }
        let refs: Vec<_> = poses.iter().map(|(p, m)| (*p, m)).collect();
        let mut ev = TwinEvaluator::from_poses(&refs).unwrap();
        assert_eq!(ev.method(), Method::TensorGrid);
        for &p in &[[0.1, 0.05, 0.1], [0.45, 0.33, 0.29], [0.6, 0.4, 0.0]] {
            let f = ev.model_at(p).modes[0].freq_hz();
            assert!(
                (f - truth(p)).abs() < 1e-9 * truth(p),
                "{p:?}: {f} vs {}",
                truth(p)
            );
        }
        // outside: clamped to the box
        assert!(!ev.is_inside([0.7, 0.1, 0.1]));
        let f = ev.model_at([0.7, 0.1, 0.1]).modes[0].freq_hz();
        assert!((f - truth([0.6, 0.1, 0.1])).abs() < 1e-9 * f);
    }

    #[test]
    fn spline_reproduces_cubics_with_four_or_more_nodes() {
        for n in [4usize, 5, 7] {
            let nodes: Vec<f64> = (0..n).map(|i| (i as f64).powf(1.3)).collect();
            let ax = Axis1d::new(nodes.clone());
            let f = |x: f64| 1.0 + x - 0.5 * x * x + 0.1 * x * x * x;
            let mut w = vec![0.0; n];
            for k in 0..20 {
                let x = nodes[n - 1] * k as f64 / 19.0;
                ax.weights(x, &mut w);
                let y: f64 = w.iter().zip(&nodes).map(|(w, xn)| w * f(*xn)).sum();
                assert!((y - f(x)).abs() < 1e-9, "n={n} x={x}: {y} vs {}", f(x));
            }
        }
    }

    #[test]
    fn rbf_interpolates_scattered_poses_exactly_at_nodes() {
        let pts = [
            [0.0, 0.0, 0.0],
            [0.5, 0.1, 0.0],
            [0.2, 0.4, 0.1],
            [0.6, 0.35, 0.2],
            [0.1, 0.2, 0.3],
            [0.4, 0.0, 0.25],
        ];
        let poses: Vec<_> = pts.iter().map(|p| (*p, model(truth(*p)))).collect();
        let refs: Vec<_> = poses.iter().map(|(p, m)| (*p, m)).collect();
        let mut ev = TwinEvaluator::from_poses(&refs).unwrap();
        assert_eq!(ev.method(), Method::Rbf);
        for p in pts {
            let f = ev.model_at(p).modes[0].freq_hz();
            assert!((f - truth(p)).abs() < 1e-8 * f);
        }
        // linear trends are reproduced exactly between the nodes
        let lin = |p: [f64; 3]| 100.0 + 20.0 * p[0] - 10.0 * p[1] + 5.0 * p[2];
        let poses: Vec<_> = pts.iter().map(|p| (*p, model(lin(*p)))).collect();
        let refs: Vec<_> = poses.iter().map(|(p, m)| (*p, m)).collect();
        let mut ev = TwinEvaluator::from_poses(&refs).unwrap();
        let q = [0.3, 0.2, 0.15];
        assert!((ev.model_at(q).modes[0].freq_hz() - lin(q)).abs() < 1e-8 * lin(q));
    }
}
