//! Time simulation at the oversampled rate.
//!
//! Linear: the first-order form discretised exactly with the matrix exponential of an
//! augmented matrix (zero- or first-order hold of the force), re-discretised whenever the
//! axes have moved by more than [`SimOptions::repose_tol`]; the physical state `[q; q̇]`
//! carries over. Nonlinear (a cubic spring or friction in a joint): classical fixed-step
//! Runge–Kutta 4 with the force interpolated linearly, sub-stepped so that
//! `|λ|max · h ≤ 2` (RK4's stability limit is 2.78).

use crate::modal::StateSpace;
use crate::structure::{Assembly, Machine, Pose};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

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
}

impl SimOptions {
    /// First-order hold at step `h`, no tip mass, 1 mm pose tolerance.
    pub fn new(h: f64) -> Self {
        SimOptions {
            h,
            hold: Hold::First,
            tip_mass: 0.0,
            repose_tol: 1e-3,
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
    let ns = d.phi.nrows();
    let mut x = DVector::zeros(ns);
    let mut next = DVector::zeros(ns);
    for i in 0..n {
        let p = pose_at(poses, i);
        if moved(&p, &cur, opts.repose_tol) {
            cur = p;
            d = build(cur);
        }
        let u = to_v(&force[i]);
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
