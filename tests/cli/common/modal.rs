//! A modal test machine for the command-line tests: modes with a direction, the exact
//! receptance, and impact records in the tryout files' form (10240 Hz, 2 s, five ~300 N
//! hits of 0.4 ms, force noise 0.08 N and acceleration noise 0.029 m/s² RMS), the
//! responses the exact convolution (FFT, zero-padded) of the force with the receptance
//! times −ω².

use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::Rng;
use rand_distr::{Distribution, Normal};
use realfft::RealFftPlanner;
use std::f64::consts::PI;
use std::path::Path;

/// One mode: natural frequency [Hz], damping ratio, modal stiffness [N/m], direction.
#[derive(Clone, Debug)]
pub struct Mode {
    pub f0: f64,
    pub zeta: f64,
    pub k: f64,
    pub d: [f64; 3],
}

/// Sample rate [Hz].
pub const FS: f64 = 10240.0;
pub const AXES: [&str; 3] = ["x", "y", "z"];
/// Samples per record.
pub const N: usize = 20480;

/// Receptance H[o][i] at `f` Hz.
pub fn receptance(modes: &[Mode], f: f64, o: usize, i: usize) -> Complex64 {
    modes
        .iter()
        .map(|m| {
            let r = f / m.f0;
            m.d[o] * m.d[i] / (m.k * Complex64::new(1.0 - r * r, 2.0 * m.zeta * r))
        })
        .sum()
}

/// One impact record, hammer along `axis`, responses delayed by `delay` samples.
pub fn impact(modes: &[Mode], axis: usize, delay: f64, rng: &mut StdRng) -> [Vec<f64>; 6] {
    let mut force = [vec![0.0; N], vec![0.0; N], vec![0.0; N]];
    let t0 = 0.05 + rng.gen_range(0.0..0.02);
    for h in 0..5 {
        let start = ((t0 + h as f64 * 0.4 + rng.gen_range(-0.01..0.01)) * FS) as usize;
        let width = rng.gen_range(4..6);
        let amp = rng.gen_range(270.0..350.0);
        for j in 0..width {
            force[axis][start + j] += amp * (PI * (j as f64 + 0.5) / width as f64).sin();
        }
    }
    let mut out = responses(modes, &force, delay);
    add_sensor_noise(&mut out, force, rng);
    out
}

/// Samples of an impact record at three force levels (3.6 s, as the tryout's).
pub const N_LEVELS: usize = 36864;

/// An impact record at three force levels (the tryout's `stiffening_joint` form: three
/// hits each of about 100, 400 and 1000 N, 0.4 s apart, each ±10 ms off its slot, so
/// the hits' records differ in length), hammer along `axis`. `cubic`: mode `k` of
/// `modes` gets a cubic spring that raises its frequency by `shift` (relative) on the
/// backbone at the peak amplitude of a 1000 N hit; that mode is integrated in time
/// (fourth-order Runge–Kutta, 16 steps per sample, the force linear between samples),
/// the others are the exact convolution. Same sensor noise as [`impact`].
pub fn impact_levels(
    modes: &[Mode],
    axis: usize,
    cubic: Option<(usize, f64)>,
    rng: &mut StdRng,
) -> [Vec<f64>; 6] {
    let n = N_LEVELS;
    let mut force = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for h in 0..9 {
        let start = ((0.06 + h as f64 * 0.4 + rng.gen_range(-0.01..0.01)) * FS) as usize;
        let width = rng.gen_range(3..6);
        let amp = [100.0, 400.0, 1000.0][h / 3] * rng.gen_range(0.85..1.15);
        for j in 0..width {
            force[axis][start + j] += amp * (PI * (j as f64 + 0.5) / width as f64).sin();
        }
    }
    let linear: Vec<Mode> = (modes.iter().enumerate())
        .filter(|(k, _)| cubic.is_none_or(|(c, _)| c != *k))
        .map(|(_, m)| m.clone())
        .collect();
    let mut out = responses(&linear, &force, 0.0);
    if let Some((k, shift)) = cubic {
        let m = &modes[k];
        let wn = 2.0 * PI * m.f0;
        let mass = m.k / (wn * wn);
        let c = 2.0 * m.zeta * wn * mass;
        // the peak amplitude of a 1000 N, 4-sample half-sine hit, and the cubic stiffness
        // whose backbone w² = wn² (1 + 3/4 k3 A² / k) is `shift` higher there
        let amp = 1000.0 * 4.0 / FS * 2.0 / PI / (mass * wn);
        let k3 = ((1.0 + shift).powi(2) - 1.0) * m.k * 4.0 / 3.0 / (amp * amp);
        let p: Vec<f64> = (0..n)
            .map(|i| (0..3).map(|a| m.d[a] * force[a][i]).sum())
            .collect();
        let acc = |q: f64, qd: f64, f: f64| (f - c * qd - m.k * q - k3 * q * q * q) / mass;
        let sub = 16;
        let h = 1.0 / (FS * sub as f64);
        let (mut q, mut qd) = (0.0f64, 0.0f64);
        for i in 0..n {
            let (f0, f1) = (p[i], p[(i + 1).min(n - 1)]);
            let qdd = acc(q, qd, f0);
            for (o, col) in out.iter_mut().skip(3).enumerate() {
                col[i] += m.d[o] * qdd;
            }
            for j in 0..sub {
                let at = |x: f64| f0 + (f1 - f0) * (j as f64 + x) / sub as f64;
                let (fa, fb, fc) = (at(0.0), at(0.5), at(1.0));
                let k1 = (qd, acc(q, qd, fa));
                let k2 = (
                    qd + h / 2.0 * k1.1,
                    acc(q + h / 2.0 * k1.0, qd + h / 2.0 * k1.1, fb),
                );
                let k3_ = (
                    qd + h / 2.0 * k2.1,
                    acc(q + h / 2.0 * k2.0, qd + h / 2.0 * k2.1, fb),
                );
                let k4 = (qd + h * k3_.1, acc(q + h * k3_.0, qd + h * k3_.1, fc));
                q += h / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3_.0 + k4.0);
                qd += h / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3_.1 + k4.1);
            }
        }
    }
    add_sensor_noise(&mut out, force, rng);
    out
}

/// Writes an impact record (time-series CSV) at `pose`.
pub fn write(path: &Path, axis: usize, cols: &[Vec<f64>; 6], pose: [f64; 3]) {
    let what = format!("impact test, hammer along {}", AXES[axis]);
    write_record(path, &what, cols, pose);
}

/// Samples per milling record (3 s, as the tryout's).
pub const N_MILL: usize = 3 * 10240;

/// One down-milling record at `rpm` (3 teeth, feed along x, radial immersion a third):
/// the mechanistic force of each engaged tooth (tangential `Kt a h`, radial 0.3 of it,
/// axial 0.2; chip `h = f_z sin φ`, 8 % tooth-to-tooth runout) plus a broadband share of
/// `broadband` times its RMS (0: tooth and spindle harmonics only), forces along x, y, z; the responses the exact convolution with the
/// receptance times −ω², the same sensor noise as [`impact`], and an outside vibration
/// `disturbance` (frequency [Hz], RMS relative to each response's RMS, in x and y, random
/// phases) added to the accelerations only.
pub fn milling(
    modes: &[Mode],
    rpm: f64,
    disturbance: &[(f64, f64)],
    broadband: f64,
    rng: &mut StdRng,
) -> [Vec<f64>; 6] {
    let n = N_MILL;
    let teeth = 3usize;
    let kta = 200.0; // Kt a f_z [N]
    let runout: Vec<f64> = (0..teeth)
        .map(|_| 1.0 + rng.gen_range(-0.08..0.08))
        .collect();
    let (phi_st, phi_ex) = (PI - (1.0f64 - 2.0 / 3.0).acos(), PI);
    let broad = Normal::new(0.0, 1.0).expect("normal");
    let mut force = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    for i in 0..n {
        let t = i as f64 / FS;
        let rot = 2.0 * PI * rpm / 60.0 * t;
        for (j, r) in runout.iter().enumerate() {
            let phi = (rot + 2.0 * PI * j as f64 / teeth as f64).rem_euclid(2.0 * PI);
            if phi < phi_st || phi > phi_ex {
                continue;
            }
            let ft = kta * r * phi.sin();
            let fr = 0.3 * ft;
            force[0][i] += -ft * phi.cos() - fr * phi.sin();
            force[1][i] += ft * phi.sin() - fr * phi.cos();
            force[2][i] += 0.2 * ft;
        }
    }
    for f in force.iter_mut() {
        let rms = (f.iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
        for v in f.iter_mut() {
            *v += broadband * rms * broad.sample(rng);
        }
    }
    let mut out = responses(modes, &force, 0.0);
    for &(f, rel) in disturbance {
        for o in 0..2 {
            let rms = (out[3 + o].iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
            let amp = rel * rms * std::f64::consts::SQRT_2;
            let ph = rng.gen_range(0.0..2.0 * PI);
            for (i, v) in out[3 + o].iter_mut().enumerate() {
                *v += amp * (2.0 * PI * f * i as f64 / FS + ph).sin();
            }
        }
    }
    add_sensor_noise(&mut out, force, rng);
    out
}

/// Writes a milling record (time-series CSV) at `pose`.
pub fn write_milling(path: &Path, rpm: f64, cols: &[Vec<f64>; 6], pose: [f64; 3]) {
    let what = format!("down-milling, 3 teeth, {rpm} rpm, feed x");
    write_record(path, &what, cols, pose);
}

/// Writes forces and accelerations (time-series CSV, SPEC section 3) at `pose` under the
/// comment line `what`.
fn write_record(path: &Path, what: &str, cols: &[Vec<f64>; 6], pose: [f64; 3]) {
    let mut txt = format!("# {what}\nt,fx,fy,fz,ax,ay,az,x,y,z\n");
    for i in 0..cols[0].len() {
        txt.push_str(&format!("{:.7e}", i as f64 / FS));
        for c in cols {
            txt.push_str(&format!(",{:.6e}", c[i]));
        }
        txt.push_str(&format!(",{},{},{}\n", pose[0], pose[1], pose[2]));
    }
    std::fs::write(path, txt).expect("write csv");
}

/// The accelerations (in slots 3-5; 0-2 empty) of `modes` under the forces along x, y, z,
/// `delay` samples late: the exact convolution (FFT, zero-padded) with the receptance
/// times −ω².
fn responses(modes: &[Mode], force: &[Vec<f64>; 3], delay: f64) -> [Vec<f64>; 6] {
    let n = force[0].len();
    let npad = 2 * n;
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(npad);
    let inv = planner.plan_fft_inverse(npad);
    let spectra: Vec<Vec<Complex64>> = force
        .iter()
        .map(|f| {
            let mut fin = vec![0.0; npad];
            fin[..n].copy_from_slice(f);
            let mut s = fwd.make_output_vec();
            fwd.process(&mut fin, &mut s).expect("fft");
            s
        })
        .collect();
    let mut out: [Vec<f64>; 6] = Default::default();
    for o in 0..3 {
        let mut y: Vec<Complex64> = (0..spectra[0].len())
            .map(|k| {
                let f = k as f64 * FS / npad as f64;
                let w = 2.0 * PI * f;
                (0..3)
                    .map(|i| spectra[i][k] * receptance(modes, f, o, i))
                    .sum::<Complex64>()
                    * (-w * w)
                    * Complex64::from_polar(1.0, -w * delay / FS)
                    / npad as f64
            })
            .collect();
        y[0].im = 0.0;
        if let Some(last) = y.last_mut() {
            last.im = 0.0;
        }
        let mut a = inv.make_output_vec();
        inv.process(&mut y, &mut a).expect("ifft");
        out[3 + o] = a[..n].to_vec();
    }
    out
}

/// The forces into slots 0-2 of `out` and the sensor noise of the tryout files on all six
/// (force 0.08 N, acceleration 0.029 m/s² RMS).
fn add_sensor_noise(out: &mut [Vec<f64>; 6], force: [Vec<f64>; 3], rng: &mut StdRng) {
    let (nf, na) = (
        Normal::new(0.0, 0.08).expect("normal"),
        Normal::new(0.0, 0.029).expect("normal"),
    );
    for (c, f) in force.into_iter().enumerate() {
        out[c] = f.into_iter().map(|v| v + nf.sample(rng)).collect();
    }
    for a in out.iter_mut().skip(3) {
        a.iter_mut().for_each(|v| *v += na.sample(rng));
    }
}
