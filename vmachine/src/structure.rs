//! A machine tool's TCP dynamics as pose-dependent modes.

use mtwin_core::axis::{Axis, Channel};
use mtwin_core::frf::Frf;
use mtwin_core::model::{ChannelModel, ModalModel, Mode, ModeNum};

/// One structural mode.
#[derive(Debug, Clone, PartialEq)]
pub struct VMode {
    /// Natural frequency at the workspace centre, in Hz.
    pub f_hz: f64,
    /// Damping ratio.
    pub zeta: f64,
    /// Modal mass in kg (mass-normalised shape = shape / sqrt(mass)).
    pub mass: f64,
    /// Mode shape at the TCP along x, y, z.
    pub shape: [f64; 3],
    /// Relative frequency change per metre of axis travel from the centre, per axis.
    pub grad: [f64; 3],
    /// Relative frequency change per square metre from the centre, per axis.
    pub quad: [f64; 3],
}

/// Modes of a machine tool whose frequencies vary with the axis positions.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalMachine {
    /// The modes.
    pub modes: Vec<VMode>,
    /// Lower corner of the workspace, in m.
    pub lo: [f64; 3],
    /// Upper corner of the workspace, in m.
    pub hi: [f64; 3],
}

impl ModalMachine {
    /// A milling machine with 9 modes between 60 and 1400 Hz (1–5 % damping), two of
    /// them 3 % apart, x/y cross coupling through the mode shapes, and frequencies that
    /// shift by up to about ±10 % over a 0.6 × 0.6 × 0.4 m workspace (quadratic along x
    /// and y, linear along z — the vertical axis is usually measured at two heights).
    pub fn default_machine() -> Self {
        let m = |f_hz, zeta, mass, shape, grad, quad| VMode {
            f_hz,
            zeta,
            mass,
            shape,
            grad,
            quad,
        };
        ModalMachine {
            modes: vec![
                m(
                    62.0,
                    0.04,
                    400.0,
                    [0.9, 0.3, 0.1],
                    [0.10, 0.02, 0.15],
                    [0.2, 0.0, 0.0],
                ),
                m(
                    95.0,
                    0.03,
                    250.0,
                    [0.2, 1.0, 0.1],
                    [0.03, 0.30, 0.10],
                    [0.2, 0.0, 0.0],
                ),
                m(
                    180.0,
                    0.025,
                    120.0,
                    [1.0, -0.4, 0.2],
                    [-0.30, 0.05, 0.08],
                    [0.0, 0.1, 0.0],
                ),
                m(
                    186.0,
                    0.02,
                    140.0,
                    [0.3, 0.9, -0.2],
                    [0.05, -0.10, 0.08],
                    [0.0, 0.1, 0.0],
                ),
                m(
                    330.0,
                    0.03,
                    80.0,
                    [0.6, 0.6, 0.3],
                    [0.06, 0.06, -0.45],
                    [0.0, 0.0, 0.0],
                ),
                m(
                    520.0,
                    0.015,
                    60.0,
                    [-0.5, 0.8, 0.1],
                    [0.08, -0.04, 0.05],
                    [0.1, 0.0, 0.0],
                ),
                m(
                    760.0,
                    0.02,
                    40.0,
                    [0.8, 0.2, -0.3],
                    [-0.05, 0.07, 0.04],
                    [0.0, 0.0, 0.0],
                ),
                m(
                    1050.0,
                    0.01,
                    30.0,
                    [0.3, -0.7, 0.2],
                    [0.04, 0.04, -0.06],
                    [0.0, 0.0, 0.0],
                ),
                m(
                    1380.0,
                    0.05,
                    25.0,
                    [0.7, 0.5, 0.4],
                    [0.02, -0.03, 0.05],
                    [0.0, 0.0, 0.0],
                ),
            ],
            lo: [0.0, 0.0, 0.0],
            hi: [0.6, 0.6, 0.4],
        }
    }

    /// The centre of the workspace.
    pub fn center(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| 0.5 * (self.lo[i] + self.hi[i]))
    }

    /// Mode `k` at `pose`.
    pub fn mode_at(&self, k: usize, pose: [f64; 3]) -> Mode {
        let v = &self.modes[k];
        let c = self.center();
        let mut rel = 1.0;
        for i in 0..3 {
            let d = pose[i] - c[i];
            rel += v.grad[i] * d + v.quad[i] * d * d;
        }
        Mode::from_hz(v.f_hz * rel, v.zeta)
    }

    /// The exact modal model at `pose` with every channel `(o, i)`, `o, i ∈ axes`
    /// (receptance: residue `φo φi / m` per mode, no feedthrough).
    pub fn model_at(&self, pose: [f64; 3], axes: &[Axis]) -> ModalModel {
        let modes: Vec<Mode> = (0..self.modes.len())
            .map(|k| self.mode_at(k, pose))
            .collect();
        let mut channels = Vec::new();
        for &i in axes {
            for &o in axes {
                channels.push(ChannelModel {
                    channel: Channel::new(o, i),
                    num: self
                        .modes
                        .iter()
                        .map(|v| ModeNum {
                            b0: v.shape[o.index()] * v.shape[i.index()] / v.mass,
                            b1: 0.0,
                        })
                        .collect(),
                    d: 0.0,
                });
            }
        }
        ModalModel { modes, channels }
    }

    /// The analytic receptance FRF at `pose` on `freqs` (Hz), channels as in
    /// [`ModalMachine::model_at`].
    pub fn frf_at(&self, pose: [f64; 3], freqs: &[f64], axes: &[Axis]) -> Frf {
        self.model_at(pose, axes).frf(freqs)
    }

    /// The machine with mode `k`'s modal stiffness scaled by `factor` (wear: e.g. 0.85;
    /// the frequency scales by its square root, mass and damping ratio unchanged).
    pub fn with_stiffness_change(mut self, k: usize, factor: f64) -> Self {
        self.modes[k].f_hz *= factor.sqrt();
        self
    }

    /// The machine with one more mode (e.g. a new tool holder).
    pub fn with_extra_mode(mut self, mode: VMode) -> Self {
        self.modes.push(mode);
        self
    }

    /// A twin made of the machine's exact models at the poses of [`ModalMachine::grid`]
    /// `n` (channels over `axes`): the ideal identification, for testing interpolation,
    /// simulation and the FMU against the machine itself.
    pub fn exact_twin(&self, n: [usize; 3], axes: &[Axis]) -> mtwin_core::twin::Twin {
        use mtwin_core::twin::{OrderInfo, PoseModel, Twin};
        let poses = self
            .grid(n)
            .into_iter()
            .map(|p| {
                let model = self.model_at(p, axes);
                PoseModel {
                    pose: p,
                    frf: model.frf(&[10.0, 20.0]),
                    model,
                    band_hz: [10.0, 20.0],
                    fit: vec![],
                    order: OrderInfo {
                        modes: self.modes.len(),
                        automatic: false,
                        stable_freqs_hz: vec![],
                    },
                    sources: vec![],
                    frf_exp_window_sigma: None,
                    plan: None,
                }
            })
            .collect();
        Twin::new("exact virtual machine", poses)
    }

    /// A regular grid of poses, `n[i]` values along axis `i` spanning the workspace.
    pub fn grid(&self, n: [usize; 3]) -> Vec<[f64; 3]> {
        let vals = |i: usize| -> Vec<f64> {
            if n[i] <= 1 {
                vec![0.5 * (self.lo[i] + self.hi[i])]
            } else {
                (0..n[i])
                    .map(|k| self.lo[i] + (self.hi[i] - self.lo[i]) * k as f64 / (n[i] - 1) as f64)
                    .collect()
            }
        };
        let (xs, ys, zs) = (vals(0), vals(1), vals(2));
        let mut out = Vec::new();
        for &z in &zs {
            for &y in &ys {
                for &x in &xs {
                    out.push([x, y, z]);
                }
            }
        }
        out
    }
}
