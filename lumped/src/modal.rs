//! Eigen-analysis of the damped structure in first-order form: poles, complex mode
//! shapes, TCP residues. The modes are an OUTPUT of the structure (they are never
//! parameters), which is what makes this generator differ from a modal one.

use crate::structure::{Assembly, Machine, Pose};
use nalgebra::{DMatrix, DVector, Matrix3};
use num_complex::Complex64;

/// A mode of the damped structure (a pole with positive imaginary part, or a real pole).
#[derive(Clone, Debug)]
pub struct Mode {
    /// The pole `λ` (rad/s).
    pub lambda: Complex64,
    /// Natural frequency `|λ| / 2π` (Hz).
    pub freq_hz: f64,
    /// Damping ratio `−Re λ / |λ|`.
    pub zeta: f64,
    /// Displacement part of the right eigenvector (n generalised coordinates), scaled so
    /// its largest entry is 1.
    pub shape: DVector<Complex64>,
    /// Residue of the TCP receptance: `H(s) = Σ R/(s − λ) + conj`, `(out, in)`.
    pub residue: Matrix3<Complex64>,
    /// Complexity of the shape: `‖Im‖/‖ψ‖` after the best rotation (0 = real mode).
    pub complexity: f64,
    /// True for a real (overdamped) pole.
    pub real: bool,
}

impl Mode {
    /// Approximate peak height of each direct channel (`|R_ii| / |Re λ|`, m/N).
    pub fn peak(&self) -> [f64; 3] {
        let s = self.lambda.re.abs().max(1e-12);
        [0, 1, 2].map(|i| 2.0 * self.residue[(i, i)].norm() / s)
    }

    /// The TCP axis (0 = x, 1 = y, 2 = z) whose direct channel this mode dominates.
    pub fn axis(&self) -> usize {
        let p = self.peak();
        (0..3).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap_or(0)
    }

    /// Largest direct-channel peak height (m/N).
    pub fn max_peak(&self) -> f64 {
        self.peak().into_iter().fold(0.0, f64::max)
    }
}

/// First-order form `ẋ = A x + B F`, `x = [q; q̇]`, with displacement output
/// `d = Cd x` and acceleration output `a = Ca x + Da F` at the TCP.
#[derive(Clone, Debug)]
pub struct StateSpace {
    /// 2n×2n.
    pub a: DMatrix<f64>,
    /// 2n×3.
    pub b: DMatrix<f64>,
    /// 3×2n displacement output.
    pub cd: DMatrix<f64>,
    /// 3×2n acceleration output.
    pub ca: DMatrix<f64>,
    /// 3×3 acceleration feed-through.
    pub da: DMatrix<f64>,
    /// `M⁻¹` (n×n), for nonlinear forces.
    pub m_inv: DMatrix<f64>,
}

impl Assembly {
    /// The first-order form of this assembly.
    pub fn state_space(&self) -> StateSpace {
        let n = self.n();
        let m_inv = self
            .m
            .clone()
            .cholesky()
            .map(|c| c.inverse())
            .unwrap_or_else(|| {
                self.m
                    .clone()
                    .try_inverse()
                    .unwrap_or_else(|| DMatrix::identity(n, n))
            });
        let mk = &m_inv * &self.k;
        let mc = &m_inv * &self.c;
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        a.view_mut((0, n), (n, n)).fill_with_identity();
        a.view_mut((n, 0), (n, n)).copy_from(&(-&mk));
        a.view_mut((n, n), (n, n)).copy_from(&(-&mc));
        let mg = &m_inv * self.g.transpose();
        let mut b = DMatrix::zeros(2 * n, 3);
        b.view_mut((n, 0), (n, 3)).copy_from(&mg);
        let mut cd = DMatrix::zeros(3, 2 * n);
        cd.view_mut((0, 0), (3, n)).copy_from(&self.g);
        let mut ca = DMatrix::zeros(3, 2 * n);
        ca.view_mut((0, 0), (3, n)).copy_from(&(-(&self.g * &mk)));
        ca.view_mut((0, n), (3, n)).copy_from(&(-(&self.g * &mc)));
        let da = &self.g * &mg;
        StateSpace {
            a,
            b,
            cd,
            ca,
            da,
            m_inv,
        }
    }

    /// Every mode, sorted by natural frequency (rigid-body poles at 0 left out).
    pub fn modes(&self) -> Vec<Mode> {
        let n = self.n();
        let ss = self.state_space();
        let eig = ss.a.clone().complex_eigenvalues();
        let ac = ss.a.map(|v| Complex64::new(v, 0.0));
        let at = ac.transpose();
        let bc = ss.b.map(|v| Complex64::new(v, 0.0));
        let cc = ss.cd.map(|v| Complex64::new(v, 0.0));
        let mut modes = Vec::new();
        for &lam in eig.iter() {
            if lam.im < 0.0 || lam.norm() < 1e-6 {
                continue;
            }
            let real = lam.im.abs() < 1e-9 * lam.norm();
            let psi = inverse_iteration(&ac, lam);
            let phi = inverse_iteration(&at, lam);
            let den = (phi.transpose() * &psi)[(0, 0)];
            let cpsi = &cc * &psi;
            let phib = phi.transpose() * &bc;
            let r = (cpsi * phib) / den;
            let residue = Matrix3::from_fn(|i, j| r[(i, j)]);
            let mut shape = psi.rows(0, n).into_owned();
            let big = shape
                .iter()
                .copied()
                .max_by(|a, b| a.norm().total_cmp(&b.norm()))
                .unwrap_or(Complex64::new(1.0, 0.0));
            shape /= big;
            modes.push(Mode {
                lambda: lam,
                freq_hz: lam.norm() / (2.0 * std::f64::consts::PI),
                zeta: -lam.re / lam.norm(),
                complexity: complexity(&shape),
                shape,
                residue,
                real,
            });
        }
        modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        modes
    }

    /// The receptance rebuilt from the modes (`Σ R/(iω − λ) + conj`), for checks.
    pub fn modal_receptance(modes: &[Mode], f_hz: f64) -> Matrix3<Complex64> {
        let s = Complex64::new(0.0, 2.0 * std::f64::consts::PI * f_hz);
        let mut h = Matrix3::zeros();
        for m in modes {
            h += m.residue / (s - m.lambda);
            if !m.real {
                h += m.residue.map(|v| v.conj()) / (s - m.lambda.conj());
            }
        }
        h
    }
}

impl Machine {
    /// The modes at `pose` (no sensor mass).
    pub fn modes(&self, pose: Pose) -> Vec<Mode> {
        self.assemble(pose, 0.0).modes()
    }
}

/// Eigenvector of `a` for the eigenvalue `lam` by two steps of shifted inverse iteration.
pub(crate) fn inverse_iteration(a: &DMatrix<Complex64>, lam: Complex64) -> DVector<Complex64> {
    let n = a.nrows();
    let shift = lam + Complex64::new(1.0, 1.0) * (1e-10 * lam.norm().max(1.0));
    let mut s = a.clone();
    for i in 0..n {
        s[(i, i)] -= shift;
    }
    let lu = s.lu();
    let mut v = DVector::from_fn(n, |i, _| Complex64::new(1.0 + 0.01 * i as f64, 0.3));
    for _ in 0..3 {
        if let Some(w) = lu.solve(&v) {
            let nrm = w.norm();
            if nrm > 0.0 && nrm.is_finite() {
                v = w / Complex64::new(nrm, 0.0);
            }
        }
    }
    v
}

/// `‖Im(e^{−iα}ψ)‖ / ‖ψ‖` at the rotation `α` that makes ψ most real.
pub fn complexity(psi: &DVector<Complex64>) -> f64 {
    let s: Complex64 = psi.iter().map(|v| v * v).sum();
    let rot = Complex64::from_polar(1.0, -s.arg() / 2.0);
    let im: f64 = psi.iter().map(|v| (v * rot).im.powi(2)).sum();
    let all: f64 = psi.iter().map(|v| v.norm_sqr()).sum();
    (im / all.max(f64::MIN_POSITIVE)).sqrt()
}

/// Modal assurance criterion of two complex shapes (1 = same shape).
pub fn mac(a: &DVector<Complex64>, b: &DVector<Complex64>) -> f64 {
    let ab = a.dotc(b).norm_sqr();
    ab / (a.norm_squared() * b.norm_squared()).max(f64::MIN_POSITIVE)
}

/// Pair each mode of `before` with the mode of `after` of highest MAC (greedy, each used
/// once): `(index before, index after, mac)`. Shapes of the common coordinates are
/// compared (an extra body's coordinates are ignored).
pub fn pair_modes(before: &[Mode], after: &[Mode]) -> Vec<(usize, usize, f64)> {
    let mut cand = Vec::new();
    for (i, a) in before.iter().enumerate() {
        for (j, b) in after.iter().enumerate() {
            let n = a.shape.len().min(b.shape.len());
            let m = mac(
                &a.shape.rows(0, n).into_owned(),
                &b.shape.rows(0, n).into_owned(),
            );
            cand.push((i, j, m));
        }
    }
    cand.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut used_a = vec![false; before.len()];
    let mut used_b = vec![false; after.len()];
    let mut out = Vec::new();
    for (i, j, m) in cand {
        if !used_a[i] && !used_b[j] {
            used_a[i] = true;
            used_b[j] = true;
            out.push((i, j, m));
        }
    }
    out.sort_by_key(|p| p.0);
    out
}
