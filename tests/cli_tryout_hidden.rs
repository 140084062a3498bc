//! Diagnosis on data we did not generate the machine of: impact tests at the centre of
//! the tryout gantry, simulated from its published analytic truth
//! (`../shared/data/tryout_gantry/truth/machine.json`: each mode's frequency, damping,
//! modal stiffness and direction) with one hidden effect each, drawn at random per seed
//! (a mode turned into the other axis, a new mode, a stiffness loss, a damping rise, a
//! response delay, or nothing). The twin is the one the defaults identify from the
//! tryout campaign; `mtwin diagnose` runs with defaults only. Every case must be named
//! with its numbers, and a named cause must gain more than one point of held-out fit.
//!
//! The records follow the tryout files' form (10240 Hz, 2 s, five ~300 N hits of
//! 0.4 ms, force noise 0.08 N and acceleration noise 0.029 m/s² RMS), the responses are
//! the exact convolution (FFT, zero-padded) of the force with the modal receptance times
//! -ω².

mod common;

use common::{mtwin, s, shared_data, stderr, tmp};
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use realfft::RealFftPlanner;
use serde_json::{json, Value};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
struct Mode {
    f0: f64,
    zeta: f64,
    k: f64,
    d: [f64; 3],
}

fn machine() -> Vec<Mode> {
    let path = shared_data().join("tryout_gantry/truth/machine.json");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(path).expect("machine.json"))
        .expect("machine json");
    v["modes"]
        .as_array()
        .expect("modes")
        .iter()
        .map(|m| {
            let d: Vec<f64> = m["d"]
                .as_array()
                .expect("d")
                .iter()
                .map(|x| x.as_f64().unwrap_or(0.0))
                .collect();
            Mode {
                f0: m["f0"].as_f64().expect("f0"),
                zeta: m["zeta"].as_f64().expect("zeta"),
                k: m["k"].as_f64().expect("k"),
                d: [d[0], d[1], d[2]],
            }
        })
        .collect()
}

const FS: f64 = 10240.0;
const AXES: [&str; 3] = ["x", "y", "z"];
const N: usize = 20480;

/// Receptance H[o][i] at `f` Hz.
fn receptance(modes: &[Mode], f: f64, o: usize, i: usize) -> Complex64 {
    modes
        .iter()
        .map(|m| {
            let r = f / m.f0;
            m.d[o] * m.d[i] / (m.k * Complex64::new(1.0 - r * r, 2.0 * m.zeta * r))
        })
        .sum()
}

/// One impact record, hammer along `axis`, responses delayed by `delay` samples.
fn impact(modes: &[Mode], axis: usize, delay: f64, rng: &mut StdRng) -> [Vec<f64>; 6] {
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

fn write(path: &Path, axis: usize, cols: &[Vec<f64>; 6]) {
    let mut txt = format!(
        "# impact test, hammer along {}\nt,fx,fy,fz,ax,ay,az,x,y,z\n",
        ["x", "y", "z"][axis]
    );
    for i in 0..N {
        txt.push_str(&format!("{:.7e}", i as f64 / FS));
        for c in cols {
            txt.push_str(&format!(",{:.6e}", c[i]));
        }
        txt.push_str(",0.6,0.4,0.15\n");
    }
    std::fs::write(path, txt).expect("write csv");
}

/// The cases of one seed: (folder name, modes, delay in samples, SPEC answer).
fn cases(base: &[Mode], rng: &mut StdRng) -> Vec<(&'static str, Vec<Mode>, f64, Value)> {
    let pure: Vec<usize> = (0..base.len())
        .filter(|&i| base[i].d[0].abs().max(base[i].d[1].abs()) > 0.99)
        .collect();
    let mut out = vec![("healthy", base.to_vec(), 0.0, json!({"cause": "none"}))];
    // a pure x or y mode turned 15-30 degrees towards the other axis
    let i = pure[rng.gen_range(0..pure.len())];
    let ang = rng.gen_range(15f64..30.0).to_radians() * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
    let mut m = base.to_vec();
    let d = m[i].d;
    m[i].d = [
        d[0] * ang.cos() - d[1] * ang.sin(),
        d[0] * ang.sin() + d[1] * ang.cos(),
        0.0,
    ];
    out.push((
        "cross_coupling",
        m,
        0.0,
        json!({"cause": "cross_coupling", "freq_hz": base[i].f0}),
    ));
    // a new mode along x or y, 10 % away from every other
    let f_new = loop {
        let f = rng.gen_range(300.0..1500.0);
        if base.iter().all(|m| (f / m.f0 - 1.0).abs() > 0.1) {
            break f;
        }
    };
    let ax = rng.gen_range(0..2);
    let mut dn = [0.0; 3];
    dn[ax] = 1.0;
    let mut m = base.to_vec();
    m.push(Mode {
        f0: f_new,
        zeta: rng.gen_range(0.015..0.04),
        k: rng.gen_range(0.5e8..1.5e8),
        d: dn,
    });
    out.push((
        "unmodeled_mode",
        m,
        0.0,
        json!({"cause": "unmodeled_mode", "freq_hz": f_new, "axis": AXES[ax]}),
    ));
    // a stiffness loss of 10-25 % in one x or y mode
    let i = pure[rng.gen_range(0..pure.len())];
    let sf = rng.gen_range(0.75..0.9);
    let mut m = base.to_vec();
    m[i].k *= sf;
    m[i].f0 *= f64::sqrt(sf);
    out.push(("stiffness_loss", m, 0.0, json!({"cause": "mode_change", "freq_hz": base[i].f0, "new_freq_hz": base[i].f0 * sf.sqrt()})));
    // the damping of one x or y mode x1.6-2.2
    let i = pure[rng.gen_range(0..pure.len())];
    let mut m = base.to_vec();
    m[i].zeta *= rng.gen_range(1.6..2.2);
    out.push((
        "damping_up",
        m,
        0.0,
        json!({"cause": "mode_change", "freq_hz": base[i].f0}),
    ));
    // responses 2-6 samples late
    let k = rng.gen_range(2..7) as f64;
    out.push((
        "time_delay",
        base.to_vec(),
        k,
        json!({"cause": "time_delay", "delay_s": k / FS}),
    ));
    out
}

fn within(a: Option<f64>, b: Option<f64>, rel: f64) -> bool {
    matches!((a, b), (Some(a), Some(b)) if (a / b - 1.0).abs() <= rel)
}

#[test]
fn tryout_truth_with_hidden_effects_is_diagnosed() {
    let dir = tmp();
    let twin = dir.path().join("twin.json");
    let campaign = shared_data().join("tryout_gantry/campaign");
    let o = mtwin(&["identify", "-q", s(&campaign), "--out", s(&twin)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let base = machine();
    let mut wrong = Vec::new();
    let mut n = 0;
    for seed in 1..=3u64 {
        let mut rng = StdRng::seed_from_u64(seed);
        for (name, modes, delay, want) in cases(&base, &mut rng) {
            let folder: PathBuf = dir.path().join(format!("s{seed}_{name}"));
            std::fs::create_dir_all(&folder).expect("folder");
            for axis in 0..2 {
                let rec = impact(&modes, axis, delay, &mut rng);
                write(
                    &folder.join(format!("imp_{}.csv", ["x", "y"][axis])),
                    axis,
                    &rec,
                );
            }
            let out = dir.path().join(format!("o{seed}_{name}"));
            let o = mtwin(&[
                "diagnose",
                "-q",
                "--twin",
                s(&twin),
                s(&folder),
                "--out",
                s(&out),
            ]);
            assert!(o.status.success(), "{name}: {}", stderr(&o));
            let d: Value = serde_json::from_str(
                &std::fs::read_to_string(out.join("diagnosis.json")).expect("diagnosis.json"),
            )
            .expect("json");
            let (cause, det) = (d["cause"].as_str().unwrap_or("?"), &d["details"]);
            let want_cause = want["cause"].as_str().unwrap_or("?");
            let numbers = match want_cause {
                "none" => true,
                "time_delay" => within(det["delay_s"].as_f64(), want["delay_s"].as_f64(), 0.1),
                _ => {
                    within(det["freq_hz"].as_f64(), want["freq_hz"].as_f64(), 0.01)
                        && want
                            .get("new_freq_hz")
                            .is_none_or(|f| within(det["new_freq_hz"].as_f64(), f.as_f64(), 0.01))
                        && want.get("axis").is_none_or(|a| det["axis"] == *a)
                }
            };
            let (before, after) = (
                d["fit_before_pct"].as_f64().unwrap_or(f64::NAN),
                d["fit_after_pct"].as_f64().unwrap_or(f64::NAN),
            );
            eprintln!("seed {seed} {name}: {cause} {det} | want {want} | held-out {before:.2} -> {after:.2} %");
            n += 1;
            if cause != want_cause || !numbers || (want_cause != "none" && after - before <= 1.0) {
                wrong.push(format!("seed {seed} {name}: found {cause} {det}, want {want}, held-out {before:.2} -> {after:.2}"));
            }
        }
    }
    assert!(wrong.is_empty(), "{} of {n} wrong: {wrong:#?}", wrong.len());
}
