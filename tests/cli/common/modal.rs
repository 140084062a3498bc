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
    let npad = 2 * N;
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(npad);
    let inv = planner.plan_fft_inverse(npad);
    let mut fin = vec![0.0; npad];
    fin[..N].copy_from_slice(&force[axis]);
    let mut fspec = fwd.make_output_vec();
    fwd.process(&mut fin, &mut fspec).expect("fft");
    let mut out: [Vec<f64>; 6] = Default::default();
    for o in 0..3 {
        let mut y: Vec<Complex64> = fspec
            .iter()
            .enumerate()
            .map(|(k, fv)| {
                let f = k as f64 * FS / npad as f64;
                let w = 2.0 * PI * f;
                fv * receptance(modes, f, o, axis)
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
        out[3 + o] = a[..N].to_vec();
    }
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
    out
}

/// Writes an impact record (time-series CSV) at `pose`.
pub fn write(path: &Path, axis: usize, cols: &[Vec<f64>; 6], pose: [f64; 3]) {
    let mut txt = format!(
        "# impact test, hammer along {}\nt,fx,fy,fz,ax,ay,az,x,y,z\n",
        ["x", "y", "z"][axis]
    );
    for i in 0..N {
        txt.push_str(&format!("{:.7e}", i as f64 / FS));
        for c in cols {
            txt.push_str(&format!(",{:.6e}", c[i]));
        }
        txt.push_str(&format!(",{},{},{}\n", pose[0], pose[1], pose[2]));
    }
    std::fs::write(path, txt).expect("write csv");
}
