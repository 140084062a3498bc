//! Time simulation at the oversampled rate.
//!
//! Linear: the first-order form discretised exactly with the matrix exponential of an
//! augmented matrix (zero- or first-order hold of the force), re-discretised whenever the
//! axes have moved by more than [`SimOptions::repose_tol`]; the physical state `[q; q̇]`
//! carries over. The step itself runs in the first-order system's modal coordinates (one
//! complex scalar per pole pair, O(n) instead of the dense O(n²)) wherever they reproduce
//! that exact discretisation to 1e-7 (checked at every re-discretisation; otherwise the
//! dense step): 38 % less CPU for the second generator's cases. Nonlinear (a cubic spring or friction in a joint): classical fixed-step
//! Runge–Kutta 4 with the force interpolated linearly, sub-stepped so that
//! `|λ|max · h ≤ 2` (RK4's stability limit is 2.78).

use crate::modal::StateSpace;
use crate::structure::{Assembly, Machine, Pose};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use num_complex::Complex64;

/// How the force is held between samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// Piecewise constant (introduces half a sample of delay).
    Zero,
    /// Piecewise linear (triangle hold; no delay, `sinc²` attenuation).
    First,
}

/// Options of a simulation.
#[derive(Clone, Debug)]
pub struct SimOptions {
    /// Time step (s).
    pub h: f64,
    /// Force hold.
    pub hold: Hold,
    /// Point mass at the tool tip (kg) (accelerometer).
    pub tip_mass: f64,
    /// Re-discretise when any axis has moved by more than this (m).
    pub repose_tol: f64,
    /// Step the dense exact discretisation even where the modal one reproduces it (a
    /// reference for tests; the modal step is the same system at O(n) per step).
    pub dense: bool,
}

impl SimOptions {
    /// First-order hold at step `h`, no tip mass, 1 mm pose tolerance.
    pub fn new(h: f64) -> Self {
        SimOptions {
            h,
            hold: Hold::First,
            tip_mass: 0.0,
            repose_tol: 1e-3,
            dense: false,
        }
    }
}

/// TCP motion (tool − workpiece) at the simulation rate.
#[derive(Clone, Debug, Default)]
pub struct Motion {
    /// Relative displacement (m).
    pub disp: Vec<[f64; 3]>,
    /// Relative acceleration (m/s²).
    pub acc: Vec<[f64; 3]>,
}

/// The exact discrete-time system of one pose.
#[derive(Clone, Debug)]
pub struct Discrete {
    /// State transition `e^{Ah}`.
    pub phi: DMatrix<f64>,
    /// Input matrix applied to `F_k`.
    pub g0: DMatrix<f64>,
    /// Input matrix applied to `F_{k+1}` (zero for the zero-order hold).
    pub g1: DMatrix<f64>,
    /// The continuous system.
    pub ss: StateSpace,
}

impl Discrete {
    /// Discretise `ss` exactly for step `h`.
    pub fn new(ss: StateSpace, h: f64, hold: Hold) -> Self {
        let ns = ss.a.nrows();
        let ni = ss.b.ncols();
        let size = ns + 2 * ni;
        let mut big = DMatrix::zeros(size, size);
        big.view_mut((0, 0), (ns, ns)).copy_from(&(&ss.a * h));
        big.view_mut((0, ns), (ns, ni)).copy_from(&(&ss.b * h));
        for i in 0..ni {
            big[(ns + i, ns + ni + i)] = 1.0;
        }
        let e = big.exp();
        let phi = e.view((0, 0), (ns, ns)).into_owned();
        let p0 = e.view((0, ns), (ns, ni)).into_owned();
        // with the identity block unscaled, E13 = (1/h)∫₀ʰ e^{As}(h − s) ds B
        let p1 = e.view((0, ns + ni), (ns, ni)).into_owned();
        let (g0, g1) = match hold {
            Hold::Zero => (p0, DMatrix::zeros(ns, ni)),
            Hold::First => (&p0 - &p1, p1),
        };
        Discrete { phi, g0, g1, ss }
    }
}

/// The same exact discretisation as [`Discrete`] in the first-order system's modal
/// coordinates: `A = Σ ψᵢ λᵢ φᵢᵀ / (φᵢᵀψᵢ)`, each coordinate `zᵢ = φᵢᵀx / (φᵢᵀψᵢ)` steps
/// on its own (`e^{λᵢh}` and the scalar hold integrals), one of each conjugate pair kept
/// (the state is `Σ 2 Re(ψᵢ zᵢ)` over pairs plus the real poles' terms). A step costs
/// O(n) instead of the dense O(n²). Built only where it reproduces the dense transition
/// and input matrices to [`MODAL_TOLERANCE`]; otherwise the dense form is used.
struct ModalStep {
    /// `e^{λh}` per kept pole.
    e: Vec<Complex64>,
    /// 2 for a pole of a conjugate pair, 1 for a real pole.
    w: Vec<f64>,
    /// The modal input for `F_k` and `F_{k+1}` (3 force axes).
    g0: Vec<[Complex64; 3]>,
    g1: Vec<[Complex64; 3]>,
    /// `Cd ψ`, `Ca ψ` (3 outputs).
    cd: Vec<[Complex64; 3]>,
    ca: Vec<[Complex64; 3]>,
    /// Right eigenvectors (columns) and the scaled left ones (rows `φᵢᵀ / (φᵢᵀψᵢ)`), to
    /// carry the physical state across a re-discretisation.
    psi: DMatrix<Complex64>,
    left: DMatrix<Complex64>,
}

/// Largest difference, relative to the largest entry, between the modal and the dense
/// transition and input matrices for [`ModalStep`] to be used.
const MODAL_TOLERANCE: f64 = 1e-7;

/// `(e^x − 1)/x` and `(e^x − 1 − x)/x²`, by their series where `x` is small.
fn hold_integrals(x: Complex64) -> (Complex64, Complex64) {
    if x.norm() < 0.05 {
        let (mut p0, mut p1) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
        // Σ x^k/(k+1)!, Σ x^k/(k+2)!
        let mut term = Complex64::new(1.0, 0.0);
        for k in 0..12 {
            let k = k as f64;
            p0 += term / (k + 1.0);
            p1 += term / ((k + 1.0) * (k + 2.0));
            term = term * x / (k + 1.0);
        }
        (p0, p1)
    } else {
        let em1 = x.exp() - 1.0;
        (em1 / x, (em1 - x) / (x * x))
    }
}

impl ModalStep {
    /// The modal form of `d`, or `None` where it does not reproduce `d` (a defective or
    /// near-defective pole, a rigid-body pole at 0).
    fn new(d: &Discrete, h: f64, hold: Hold) -> Option<ModalStep> {
        let ss = &d.ss;
        let ns = ss.a.nrows();
        let eig = ss.a.clone().complex_eigenvalues();
        let scale = eig.iter().map(|l| l.norm()).fold(0.0, f64::max);
        let mut kept: Vec<(Complex64, f64)> = Vec::new();
        for &lam in eig.iter() {
            if lam.norm() <= 1e-9 * scale {
                return None;
            }
            if lam.im.abs() <= 1e-12 * lam.norm() {
                kept.push((Complex64::new(lam.re, 0.0), 1.0));
            } else if lam.im > 0.0 {
                kept.push((lam, 2.0));
            }
        }
        if kept.iter().map(|k| k.1 as usize).sum::<usize>() != ns {
            return None;
        }
        let c = |m: &DMatrix<f64>| m.map(|v| Complex64::new(v, 0.0));
        let (bc, cdc, cac) = (c(&ss.b), c(&ss.cd), c(&ss.ca));
        // right eigenvectors [q; λq] from the second-order form (λ²I + λ M⁻¹C + M⁻¹K) q = 0,
        // by inverse iteration at the pole (an n×n solve, not 2n×2n)
        let nq = ns / 2;
        let mk = -ss.a.view((nq, 0), (nq, nq)).into_owned();
        let mc = -ss.a.view((nq, nq), (nq, nq)).into_owned();
        let m = kept.len();
        let mut full = DMatrix::<Complex64>::zeros(ns, ns);
        let mut col = 0;
        let mut psi = DMatrix::zeros(ns, m);
        for (i, (lam, w)) in kept.iter().enumerate() {
            let mu = lam + Complex64::new(1.0, 1.0) * (1e-10 * lam.norm());
            let q_of = DMatrix::from_fn(nq, nq, |r, k| {
                let id = if r == k {
                    mu * mu
                } else {
                    Complex64::new(0.0, 0.0)
                };
                id + mu * mc[(r, k)] + mk[(r, k)]
            });
            let lu = q_of.lu();
            let mut q = DVector::from_fn(nq, |r, _| Complex64::new(1.0 + 0.01 * r as f64, 0.3));
            for _ in 0..3 {
                let next = lu.solve(&q)?;
                let nrm = next.norm();
                if !(nrm > 0.0 && nrm.is_finite()) {
                    return None;
                }
                q = next / Complex64::new(nrm, 0.0);
            }
            let r = DVector::from_fn(ns, |k, _| if k < nq { q[k] } else { lam * q[k - nq] });
            psi.set_column(i, &r);
            full.set_column(col, &r);
            col += 1;
            if *w == 2.0 {
                full.set_column(col, &r.map(|v| v.conj()));
                col += 1;
            }
        }
        // the left eigenvectors: the rows of the inverse of every right one
        let inv = full.try_inverse()?;
        let mut left = DMatrix::zeros(m, ns);
        let mut row = 0;
        for (i, (_, w)) in kept.iter().enumerate() {
            left.set_row(i, &inv.row(row));
            row += if *w == 2.0 { 2 } else { 1 };
        }
        let bt = &left * &bc; // m×3
        let (cd, ca) = (&cdc * &psi, &cac * &psi); // 3×m
        let mut step = ModalStep {
            e: Vec::with_capacity(m),
            w: kept.iter().map(|k| k.1).collect(),
            g0: Vec::with_capacity(m),
            g1: Vec::with_capacity(m),
            cd: (0..m)
                .map(|i| [cd[(0, i)], cd[(1, i)], cd[(2, i)]])
                .collect(),
            ca: (0..m)
                .map(|i| [ca[(0, i)], ca[(1, i)], ca[(2, i)]])
                .collect(),
            psi,
            left,
        };
        for (i, (lam, _)) in kept.iter().enumerate() {
            let x = lam * h;
            let (p0, p1) = hold_integrals(x);
            let (p0, p1) = (p0 * h, p1 * h);
            let (a0, a1) = match hold {
                Hold::Zero => (p0, Complex64::new(0.0, 0.0)),
                Hold::First => (p0 - p1, p1),
            };
            step.e.push(x.exp());
            step.g0.push([0, 1, 2].map(|j| bt[(i, j)] * a0));
            step.g1.push([0, 1, 2].map(|j| bt[(i, j)] * a1));
        }
        // the modal form must reproduce the dense discretisation
        let back = |diag: &dyn Fn(usize) -> Complex64, cols: &DMatrix<Complex64>| {
            let mut scaled = step.psi.clone();
            for i in 0..m {
                let f = diag(i);
                scaled.column_mut(i).iter_mut().for_each(|v| *v *= f);
            }
            let full = scaled * cols;
            // Σ w Re(ψ f φᵀ) over the kept poles: a pair's conjugate adds the conjugate
            let mut out = DMatrix::<f64>::zeros(ns, cols.ncols());
            for (o, v) in out.iter_mut().zip(full.iter()) {
                *o = v.re;
            }
            out
        };
        let weighted_left = {
            let mut l = step.left.clone();
            for i in 0..m {
                let wi = Complex64::new(step.w[i], 0.0);
                l.row_mut(i).iter_mut().for_each(|v| *v *= wi);
            }
            l
        };
        let phi = back(&|i| step.e[i], &weighted_left);
        // a modal input matrix back in the physical state
        let input = |g: &[[Complex64; 3]]| {
            let rows = DMatrix::from_fn(m, 3, |i, j| g[i][j] * step.w[i]);
            back(&|_| Complex64::new(1.0, 0.0), &rows)
        };
        let (g0, g1) = (input(&step.g0), input(&step.g1));
        let off = |a: &DMatrix<f64>, b: &DMatrix<f64>| {
            let big = b.amax().max(f64::MIN_POSITIVE);
            (a - b).amax() / big
        };
        let err = off(&phi, &d.phi)
            .max(off(&g0, &d.g0))
            .max(if hold == Hold::First {
                off(&g1, &d.g1)
            } else {
                0.0
            });
        (err <= MODAL_TOLERANCE).then_some(step)
    }

    /// The modal coordinates of the physical state `x`.
    fn coords(&self, x: &DVector<f64>) -> Vec<Complex64> {
        let xc = x.map(|v| Complex64::new(v, 0.0));
        (&self.left * xc).iter().copied().collect()
    }

    /// The physical state of the modal coordinates `z`.
    fn state(&self, z: &[Complex64]) -> DVector<f64> {
        let mut x = DVector::zeros(self.psi.nrows());
        for (i, zi) in z.iter().enumerate() {
            for (r, v) in x.iter_mut().enumerate() {
                *v += self.w[i] * (self.psi[(r, i)] * zi).re;
            }
        }
        x
    }
}

fn to_v(f: &[f64; 3]) -> DVector<f64> {
    DVector::from_column_slice(f)
}

fn out3(m: &DMatrix<f64>, x: &DVector<f64>) -> [f64; 3] {
    let y = m * x;
    [y[0], y[1], y[2]]
}

/// The pose of sample `i` of a pose track (one pose = standing still).
pub fn pose_at(poses: &[Pose], i: usize) -> Pose {
    poses[i.min(poses.len().saturating_sub(1))]
}

fn moved(a: &Pose, b: &Pose, tol: f64) -> bool {
    (0..3).any(|d| (a[d] - b[d]).abs() > tol)
}

/// Where a simulated force acts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Input {
    /// Between tool and workpiece at the TCP (`F` on the tool, `−F` on the workpiece).
    Tcp,
    /// On the bed at a world point (m) (a vibration coming in through the floor).
    Bed([f64; 3]),
}

/// Simulate the linear machine for `force` (N, on the tool; −F on the workpiece) at
/// step `opts.h`, axes following `poses` (one per sample, or a single pose).
pub fn simulate(
    machine: &Machine,
    force: &[[f64; 3]],
    poses: &[Pose],
    opts: &SimOptions,
) -> Motion {
    simulate_input(machine, force, poses, opts, Input::Tcp)
}

/// [`simulate`] with the force acting at `input`; the output is always the TCP motion.
pub fn simulate_input(
    machine: &Machine,
    force: &[[f64; 3]],
    poses: &[Pose],
    opts: &SimOptions,
    input: Input,
) -> Motion {
    let n = force.len();
    let mut out = Motion {
        disp: Vec::with_capacity(n),
        acc: Vec::with_capacity(n),
    };
    if n == 0 || poses.is_empty() {
        return out;
    }
    let build = |p: Pose| {
        let asm = machine.assemble(p, opts.tip_mass);
        let mut ss = asm.state_space();
        if let Input::Bed(point) = input {
            let t = asm
                .layout
                .point_map(crate::structure::Body::Bed.index(), &Vector3::from(point));
            let nq = asm.n();
            let mt = &ss.m_inv * t.transpose();
            ss.b.view_mut((nq, 0), (nq, 3)).copy_from(&mt);
            ss.da = &asm.g * &mt;
        }
        Discrete::new(ss, opts.h, opts.hold)
    };
    let mut cur = pose_at(poses, 0);
    let mut d = build(cur);
    let modal_of = |d: &Discrete| {
        if opts.dense {
            None
        } else {
            ModalStep::new(d, opts.h, opts.hold)
        }
    };
    let mut modal = modal_of(&d);
    let ns = d.phi.nrows();
    let mut x = DVector::zeros(ns);
    let mut next = DVector::zeros(ns);
    let mut z: Vec<Complex64> = modal.as_ref().map_or(Vec::new(), |m| m.coords(&x));
    for i in 0..n {
        let p = pose_at(poses, i);
        if moved(&p, &cur, opts.repose_tol) {
            // the physical state carries over
            if let Some(m) = &modal {
                x = m.state(&z);
            }
            cur = p;
            d = build(cur);
            modal = modal_of(&d);
            if let Some(m) = &modal {
                z = m.coords(&x);
            }
        }
        let u = force[i];
        if let Some(m) = &modal {
            let (mut y, mut a) = ([0.0; 3], [0.0; 3]);
            for k in 0..m.e.len() {
                let (zk, w) = (z[k], m.w[k]);
                for j in 0..3 {
                    y[j] += w * (m.cd[k][j] * zk).re;
                    a[j] += w * (m.ca[k][j] * zk).re;
                }
            }
            for (j, aj) in a.iter_mut().enumerate() {
                *aj += (0..3).map(|l| d.ss.da[(j, l)] * u[l]).sum::<f64>();
            }
            out.disp.push(y);
            out.acc.push(a);
            if i + 1 < n {
                let u1 = force[i + 1];
                for k in 0..m.e.len() {
                    let mut v = m.e[k] * z[k];
                    for l in 0..3 {
                        v += m.g0[k][l] * u[l] + m.g1[k][l] * u1[l];
                    }
                    z[k] = v;
                }
            }
            continue;
        }
        let u = to_v(&u);
        out.disp.push(out3(&d.ss.cd, &x));
        let a = &d.ss.ca * &x + &d.ss.da * &u;
        out.acc.push([a[0], a[1], a[2]]);
        if i + 1 < n {
            next.gemv(1.0, &d.phi, &x, 0.0);
            next.gemv(1.0, &d.g0, &u, 1.0);
            if opts.hold == Hold::First {
                next.gemv(1.0, &d.g1, &to_v(&force[i + 1]), 1.0);
            }
            std::mem::swap(&mut x, &mut next);
        }
    }
    out
}

/// One nonlinear contact direction: generalised-force map and law.
struct NlTerm {
    /// 1×n: the contact's displacement along the direction.
    row: DVector<f64>,
    cubic: f64,
    friction: Option<(f64, f64)>,
}

/// Simulate the machine with its [`crate::structure::CubicSpring`] and
/// [`crate::structure::Friction`] (if any) by Runge–Kutta 4 at one pose.
pub fn simulate_nonlinear(
    machine: &Machine,
    force: &[[f64; 3]],
    pose: Pose,
    opts: &SimOptions,
) -> Motion {
    let asm: Assembly = machine.assemble(pose, opts.tip_mass);
    let nq = asm.n();
    let ss = asm.state_space();
    let mk = &ss.m_inv * &asm.k;
    let mc = &ss.m_inv * &asm.c;
    let mg = &ss.m_inv * asm.g.transpose();
    let mut terms = Vec::new();
    for ct in &asm.layout.contacts {
        let t = asm.layout.contact_map(ct);
        let mut add = |dir: usize, cubic: f64, friction: Option<(f64, f64)>| {
            let e: Vector3<f64> = ct.frame.column(dir).into_owned();
            let row = t.transpose() * DVector::from_column_slice(e.as_slice());
            terms.push(NlTerm {
                row,
                cubic,
                friction,
            });
        };
        if let Some(c) = &machine.cubic {
            if c.joint == ct.joint {
                add(c.dir, c.k3, None);
            }
        }
        if let Some(f) = &machine.friction {
            if f.joint == ct.joint {
                add(f.dir, 0.0, Some((f.f_c, f.v0)));
            }
        }
    }
    // generalised nonlinear force → acceleration: M⁻¹ rowᵀ
    let maps: Vec<DVector<f64>> = terms.iter().map(|t| &ss.m_inv * &t.row).collect();
    let lam_max =
        ss.a.clone()
            .complex_eigenvalues()
            .iter()
            .map(|l| l.norm())
            .fold(0.0, f64::max);
    let sub = ((lam_max * opts.h / 2.0).ceil() as usize).max(1);
    let hs = opts.h / sub as f64;
    let deriv = |q: &DVector<f64>, v: &DVector<f64>, u: &DVector<f64>| -> DVector<f64> {
        let mut a = &mg * u - &mk * q - &mc * v;
        for (t, m) in terms.iter().zip(&maps) {
            let d = t.row.dot(q);
            let dv = t.row.dot(v);
            let mut f = t.cubic * d * d * d;
            if let Some((fc, v0)) = t.friction {
                f += fc * (dv / v0).tanh();
            }
            a.axpy(-f, m, 1.0);
        }
        a
    };
    let n = force.len();
    let mut out = Motion {
        disp: Vec::with_capacity(n),
        acc: Vec::with_capacity(n),
    };
    let mut q = DVector::zeros(nq);
    let mut v = DVector::zeros(nq);
    let g = &asm.g;
    for i in 0..n {
        let u0 = to_v(&force[i]);
        let a0 = deriv(&q, &v, &u0);
        let d = g * &q;
        let acc = g * &a0;
        out.disp.push([d[0], d[1], d[2]]);
        out.acc.push([acc[0], acc[1], acc[2]]);
        if i + 1 == n {
            break;
        }
        let u1 = to_v(&force[i + 1]);
        for s in 0..sub {
            let ua = &u0 + (&u1 - &u0) * (s as f64 / sub as f64);
            let um = &u0 + (&u1 - &u0) * ((s as f64 + 0.5) / sub as f64);
            let ub = &u0 + (&u1 - &u0) * ((s as f64 + 1.0) / sub as f64);
            let k1v = deriv(&q, &v, &ua);
            let k1q = v.clone();
            let q2 = &q + &k1q * (hs / 2.0);
            let v2 = &v + &k1v * (hs / 2.0);
            let k2v = deriv(&q2, &v2, &um);
            let k2q = v2.clone();
            let q3 = &q + &k2q * (hs / 2.0);
            let v3 = &v + &k2v * (hs / 2.0);
            let k3v = deriv(&q3, &v3, &um);
            let k3q = v3.clone();
            let q4 = &q + &k3q * hs;
            let v4 = &v + &k3v * hs;
            let k4v = deriv(&q4, &v4, &ub);
            let k4q = v4;
            q += (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (hs / 6.0);
            v += (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (hs / 6.0);
        }
    }
    out
}

/// Static deflection of a joint under a TCP force pair `force` (N): the largest
/// `|δ|` along principal direction `dir` over the joint's contacts (m). Used to scale
/// a cubic spring to a force level.
pub fn static_joint_deflection(
    asm: &Assembly,
    joint: crate::structure::Joint,
    dir: usize,
    force: [f64; 3],
) -> f64 {
    let f = asm.g.transpose() * DVector::from_column_slice(&force);
    let Some(q) = asm.k.clone().lu().solve(&f) else {
        return 0.0;
    };
    asm.layout
        .contacts
        .iter()
        .filter(|c| c.joint == joint)
        .map(|c| {
            let d = asm.layout.contact_map(c) * &q;
            let e: Matrix3<f64> = c.frame;
            (e.column(dir).transpose() * Vector3::new(d[0], d[1], d[2]))[(0, 0)].abs()
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A force with every frequency up to the simulation's Nyquist (seeded noise).
    fn force(n: usize) -> Vec<[f64; 3]> {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(12345);
        (0..n)
            .map(|_| [100.0, 60.0, 30.0].map(|a| a * (rng.gen::<f64>() - 0.5)))
            .collect()
    }

    fn max_rel(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        let big = b.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        let d = a
            .iter()
            .flatten()
            .zip(b.iter().flatten())
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        d / big
    }

    /// The modal step is the dense exact discretisation (first- and zero-order hold, a
    /// pose standing still and axes moving through several re-discretisations) up to
    /// rounding, and the nominal machine gets it.
    #[test]
    fn modal_step_reproduces_the_dense_discretisation() {
        let machine = Machine::nominal();
        let f = force(6000);
        let moving: Vec<Pose> = (0..f.len())
            .map(|i| [0.2 + 1e-6 * i as f64, 0.1, 0.15 + 5e-7 * i as f64])
            .collect();
        for hold in [Hold::First, Hold::Zero] {
            let mut opts = SimOptions::new(1.0 / 81920.0);
            opts.hold = hold;
            let asm = machine.assemble(moving[0], 0.0);
            let d = Discrete::new(asm.state_space(), opts.h, hold);
            assert!(ModalStep::new(&d, opts.h, hold).is_some(), "{hold:?}");
            for poses in [&moving[..1], &moving[..]] {
                let modal = simulate(&machine, &f, poses, &opts);
                let dense = simulate(
                    &machine,
                    &f,
                    poses,
                    &SimOptions {
                        dense: true,
                        ..opts.clone()
                    },
                );
                let (ed, ea) = (
                    max_rel(&modal.disp, &dense.disp),
                    max_rel(&modal.acc, &dense.acc),
                );
                assert!(
                    ed < 1e-6 && ea < 1e-6,
                    "{hold:?}, {} poses: {ed:e} {ea:e}",
                    poses.len()
                );
            }
        }
    }
}
