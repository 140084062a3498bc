//! Physical mass–spring–damper chains (the paper's 3-DoF example) with exact simulation.

use mtwin_core::axis::{Axis, Channel};
use mtwin_core::frf::{Frf, FrfChannel};
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use std::f64::consts::PI;

/// A chain of masses `m_i` connected by springs `k_i` and dampers `c_i`, element 0 to
/// ground, element `i` between masses `i−1` and `i`. One force input and one
/// displacement output, both at degrees of freedom chosen by index.
#[derive(Debug, Clone, PartialEq)]
pub struct MdofChain {
    /// Masses in kg.
    pub m: Vec<f64>,
    /// Spring stiffnesses in N/m (element 0 to ground).
    pub k: Vec<f64>,
    /// Damper coefficients in N s/m (element 0 to ground).
    pub c: Vec<f64>,
    /// Degree of freedom the force acts on.
    pub input: usize,
    /// Degree of freedom whose displacement is the output.
    pub output: usize,
}

impl MdofChain {
    /// The paper's 3-DoF chain: m = 10 kg, k = 2·10⁴ N/m, c = 5 N s/m per element, force
    /// and displacement at mass 3 (static compliance 3/k = 1.5·10⁻⁴ m/N).
    pub fn paper_chain() -> Self {
        MdofChain {
            m: vec![10.0; 3],
            k: vec![2e4; 3],
            c: vec![5.0; 3],
            input: 2,
            output: 2,
        }
    }

    /// The same chain with the stiffness of element 0 (k1 in the paper) scaled.
    pub fn with_k1_factor(mut self, factor: f64) -> Self {
        self.k[0] *= factor;
        self
    }

    fn n(&self) -> usize {
        self.m.len()
    }

    fn assemble(&self, e: &[f64]) -> DMatrix<f64> {
        let n = self.n();
        let mut a = DMatrix::zeros(n, n);
        for i in 0..n {
            a[(i, i)] += e[i];
            if i > 0 {
                a[(i - 1, i - 1)] += e[i];
                a[(i - 1, i)] -= e[i];
                a[(i, i - 1)] -= e[i];
            }
        }
        a
    }

    /// Mass, damping and stiffness matrices.
    pub fn matrices(&self) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        (
            DMatrix::from_diagonal(&DVector::from_vec(self.m.clone())),
            self.assemble(&self.c),
            self.assemble(&self.k),
        )
    }

    /// Analytic receptance output/input at `f_hz`: `[(K − ω²M + iωC)⁻¹]_{out,in}`.
    pub fn receptance(&self, f_hz: f64) -> Complex64 {
        let (m, c, k) = self.matrices();
        let w = 2.0 * PI * f_hz;
        let z: DMatrix<Complex64> = k.map(|v| Complex64::new(v, 0.0))
            - m.map(|v| Complex64::new(w * w * v, 0.0))
            + c.map(|v| Complex64::new(0.0, w * v));
        let mut rhs = DVector::<Complex64>::zeros(self.n());
        rhs[self.input] = Complex64::new(1.0, 0.0);
        let x = z
            .lu()
            .solve(&rhs)
            .unwrap_or_else(|| DVector::from_element(self.n(), Complex64::new(f64::NAN, 0.0)));
        x[self.output]
    }

    /// Analytic FRF on `freqs` (Hz) as the `zz` channel.
    pub fn frf(&self, freqs: &[f64]) -> Frf {
        Frf {
            freqs_hz: freqs.to_vec(),
            channels: vec![FrfChannel {
                channel: Channel::new(Axis::Z, Axis::Z),
                h: freqs.iter().map(|&f| self.receptance(f)).collect(),
                coherence: None,
            }],
        }
    }

    /// Undamped natural frequencies in Hz, ascending.
    pub fn natural_freqs_hz(&self) -> Vec<f64> {
        let (m, _, k) = self.matrices();
        let minv_sqrt = m.map(|v| if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 });
        let a = &minv_sqrt * k * &minv_sqrt;
        let mut ev: Vec<f64> = a
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .map(|l| l.max(0.0).sqrt() / (2.0 * PI))
            .collect();
        ev.sort_by(f64::total_cmp);
        ev
    }

    /// The exact modal model (channel `zz`) when the damping is proportional to the
    /// stiffness (`C = β K`, as in [`MdofChain::paper_chain`]); `None` otherwise.
    pub fn modal_model(&self) -> Option<mtwin_core::model::ModalModel> {
        use mtwin_core::model::{ChannelModel, ModalModel, Mode, ModeNum};
        let beta = self.c[0] / self.k[0];
        if self
            .c
            .iter()
            .zip(&self.k)
            .any(|(c, k)| (c - beta * k).abs() > 1e-12 * c.abs().max(1e-300))
        {
            return None;
        }
        let (m, _, k) = self.matrices();
        let ms = m.map(|v| if v > 0.0 { 1.0 / v.sqrt() } else { 0.0 });
        let eig = (&ms * k * &ms).symmetric_eigen();
        let mut idx: Vec<usize> = (0..self.n()).collect();
        idx.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let mut modes = Vec::new();
        let mut num = Vec::new();
        for &r in &idx {
            let wn = eig.eigenvalues[r].max(0.0).sqrt();
            let phi = &ms * eig.eigenvectors.column(r);
            modes.push(Mode {
                wn,
                zeta: 0.5 * beta * wn,
            });
            num.push(ModeNum {
                b0: phi[self.output] * phi[self.input],
                b1: 0.0,
            });
        }
        Some(ModalModel {
            modes,
            channels: vec![ChannelModel {
                channel: Channel::new(Axis::Z, Axis::Z),
                num,
                d: 0.0,
            }],
        })
    }

    /// Exact response (displacement of the output dof) to a force sampled every `dt`
    /// seconds, interpolated linearly between samples (first-order hold), from rest.
    pub fn simulate(&self, force: &[f64], dt: f64) -> Vec<f64> {
        let n = self.n();
        let (m, c, k) = self.matrices();
        let minv = m.map(|v| if v > 0.0 { 1.0 / v } else { 0.0 });
        let ns = 2 * n;
        // augmented generator [[A, B, 0], [0, 0, 1], [0, 0, 0]] · dt
        let mut g = DMatrix::<f64>::zeros(ns + 2, ns + 2);
        for i in 0..n {
            g[(i, n + i)] = 1.0;
        }
        let mk = -(&minv * &k);
        let mc = -(&minv * &c);
        for i in 0..n {
            for j in 0..n {
                g[(n + i, j)] = mk[(i, j)];
                g[(n + i, n + j)] = mc[(i, j)];
            }
        }
        g[(n + self.input, ns)] = minv[(self.input, self.input)];
        g[(ns, ns + 1)] = 1.0;
        let e = (g * dt).exp();
        let phi = e.view((0, 0), (ns, ns)).into_owned();
        let g1 = e.view((0, ns), (ns, 1)).into_owned();
        let g2 = e.view((0, ns + 1), (ns, 1)).into_owned() / dt;
        let mut x = DVector::<f64>::zeros(ns);
        let mut out = Vec::with_capacity(force.len());
        if force.is_empty() {
            return out;
        }
        out.push(0.0);
        for i in 1..force.len() {
            let u0 = force[i - 1];
            let du = force[i] - u0;
            x = &phi * &x + &g1 * u0 + &g2 * du;
            out.push(x[self.output]);
        }
        out
    }
}
