//! Benchmark cases for the side-by-side comparison with the Python tools
//! (`scripts/bench_peers.sh`): writes the data of every case to a directory, runs
//! mtwin's own step on it (median wall time of several runs, one thread) and writes
//! `cases.json` with the fit against the analytic truth and the time.
//!
//! Run: `cargo run --release --example bench_peers -- DIR`
//!
//! Cases (fit = paper eq. 5, `identify::frf::fit_percent`, worst channel, vs the
//! analytic FRF):
//! * `a_frf`: H1 of a 60 s noise record of the virtual machine (force x, displacement
//!   x and y, 1 % sensor noise) with [`estimate_frf`] (automatic Welch length);
//! * `b_fit`: the 8-mode, 2-channel, 2000-line noisy FRF of `identify/benches/identify.rs`
//!   without its coherence column (computed from the truth: not a measurement's),
//!   [`fit_frf`] with the automatic order;
//! * `c_chain`: the paper's 3-DoF chain, periodic chirp, 0.1 % noise (as
//!   `examples/paper_3dof.rs`), [`fit_frf`] with the options of that example;
//! * `d_campaign`: 18 poses (3 × 3 × 2 grid) of noise records, [`identify_campaign`];
//! * `e_fmu`: one doStep of the slave core (no C layer) on the 3 × 3 × 2 grid twin;
//! * `f_refit`: refit of the twin from milling records of the worn machine;
//! * `g_tryout`: data of an independent generator (shared/data/tryout_gantry), impact
//!   and sweep, `mtwin identify` defaults, xx against its analytic truth;
//! * `h_real`: the real impact test of shared/data/pyfrf_impact_hammer, `mtwin identify`
//!   defaults; the model is written for the script to judge against the raw per-hit H1.
//!
//! Every tool gets one untimed warm-up, then the median of [`RUNS`] timed runs
//! ([`RUNS_SLOW`] in d and f, where a peer takes seconds a run).

use identify::axis::Axis;
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::frf::{fit_percent, Frf};
use identify::model::{ModalModel, Mode};
use identify::rational_fit::{fit_frf, FitOptions, Weighting};
use identify::read::{write_frf_csv, write_timeseries};
use identify::spectra::{estimate_frf, Excitation, FrfOptions};
use identify::timeseries::{ResponseKind, TimeSeries};
use mtwin_fmu::slave::Slave;
use num_complex::Complex64;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use std::time::Instant;
use vmachine::chain::MdofChain;
use vmachine::daq::{acquire, chain_record, simulate_machine, Daq};
use vmachine::excitation::{chirp, noise};
use vmachine::structure::ModalMachine;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Timed runs of every tool in a case (after one untimed warm-up), mtwin and the Python
/// peers alike (`scripts/bench_peers.py` reads it from `cases.json`).
const RUNS: usize = 5;
/// The same for the cases where a peer takes many seconds a run (d, f).
const RUNS_SLOW: usize = 3;

/// Median wall time in milliseconds of `runs` calls of `f` (after one warm-up call);
/// `MTWIN_BENCH_RUNS=N` overrides `runs` (many runs of one case for a profiler).
fn median_ms<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    let runs = std::env::var("MTWIN_BENCH_RUNS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(runs);
    std::hint::black_box(f());
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let t0 = Instant::now();
            std::hint::black_box(f());
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// Interleaved calls of [`case_a`]'s estimate and its FFT floor for their ratio: one
/// call of each in turn, so that a change of the machine's load moves both alike.
const RATIO_RUNS: usize = 41;

/// Median wall times in milliseconds over `runs` interleaved calls of `a` and `b`
/// (after one warm-up call of each): one call of each in turn, so that a change of the
/// machine's load moves both alike (the thread stays on its core: in the runs of
/// 2026-11-27 the on-CPU times of the same calls matched these to 0.01 ms).
fn interleaved_ms(runs: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> [f64; 2] {
    a();
    b();
    let mut wall = [Vec::new(), Vec::new()];
    for _ in 0..runs {
        for (i, f) in [&mut a as &mut dyn FnMut(), &mut b].into_iter().enumerate() {
            let t0 = Instant::now();
            f();
            wall[i].push(t0.elapsed().as_secs_f64() * 1e3);
        }
    }
    wall.map(|mut v| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    })
}

/// The number of threads of [`on_all_cores`].
fn all_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// [`median_ms`] inside a rayon pool of [`all_cores`] threads (every other measurement
/// runs on one); `None` on a one-core machine.
fn on_all_cores<T>(runs: usize, f: impl FnMut() -> T + Send) -> Res<Option<f64>> {
    if all_cores() < 2 {
        return Ok(None);
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(all_cores())
        .build()?;
    Ok(Some(pool.install(|| median_ms(runs, f))))
}

/// Worst channel fit of `model` against `truth` on the lines inside `band`.
fn worst_fit(model: &ModalModel, truth: &Frf, band: (f64, f64)) -> f64 {
    let b = truth.band(band.0, band.1);
    b.channels
        .iter()
        .map(|c| match model.channel_index(c.channel) {
            Some(ci) => {
                let est: Vec<Complex64> =
                    b.freqs_hz.iter().map(|&f| model.eval_hz(ci, f)).collect();
                fit_percent(&c.h, &est)
            }
            None => f64::NEG_INFINITY,
        })
        .fold(f64::INFINITY, f64::min)
}

/// Worst channel fit of an estimated FRF against `truth` (same grid) inside `band`.
fn worst_fit_frf(est: &Frf, truth: &Frf, band: (f64, f64)) -> f64 {
    let (e, t) = (est.band(band.0, band.1), truth.band(band.0, band.1));
    t.channels
        .iter()
        .map(|c| {
            e.channel(c.channel)
                .map_or(f64::NEG_INFINITY, |ec| fit_percent(&c.h, &ec.h))
        })
        .fold(f64::INFINITY, f64::min)
}

/// The channels of `frf` driven along `input`.
fn input_channels(mut frf: Frf, input: Axis) -> Frf {
    frf.channels.retain(|c| c.channel.input == input);
    frf
}

/// The 8-mode, 2-channel truth of `identify/benches/identify.rs`.
fn truth8() -> ModalModel {
    vmachine::cases::eight_modes()
}

/// The noisy FRF of `identify/benches/identify.rs` (1 % of |H| per line plus a floor).
fn noisy(model: &ModalModel, freqs: &[f64], seed: u64) -> Frf {
    vmachine::cases::noisy_frf(model, freqs, seed)
}

/// A noise record of `machine` standing at `pose`: force along x, displacement x and y.
fn noise_record(machine: &ModalMachine, pose: [f64; 3], secs: f64, seed: u64) -> TimeSeries {
    let daq = Daq {
        response: ResponseKind::Displacement,
        seed,
        ..Daq::default()
    };
    let fs = daq.fs_sim();
    let n = (secs * fs) as usize;
    let forces = [Some(noise(n, 50.0, seed)), None, None];
    let pose_at = move |_t: f64| pose;
    let resp = simulate_machine(
        machine,
        &forces,
        fs,
        &pose_at,
        &[Axis::X, Axis::Y],
        daq.response,
    );
    acquire(forces, resp, &pose_at, &daq, &format!("noise_{seed}"))
}

fn path_str(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

const MACHINE_BAND: (f64, f64) = (20.0, 2000.0);

fn case_a(dir: &Path, machine: &ModalMachine) -> Res<Value> {
    let pose = machine.center();
    let rec = noise_record(machine, pose, 60.0, 3);
    let ts = dir.join("a_noise.csv");
    write_timeseries(&ts, &rec)?;
    let opts = FrfOptions::default();
    let est = estimate_frf(std::slice::from_ref(&rec), &opts)?;
    let ms = median_ms(RUNS, || estimate_frf(std::slice::from_ref(&rec), &opts));
    // the segments' FFTs and the line chunks of the spectra on every core
    let ms_all_cores = on_all_cores(RUNS, || estimate_frf(std::slice::from_ref(&rec), &opts))?;
    let truth = input_channels(
        machine.frf_at(pose, &est.frf.freqs_hz, &[Axis::X, Axis::Y]),
        Axis::X,
    );
    let truth_path = dir.join("a_truth.csv");
    write_frf_csv(&truth_path, &truth)?;
    let fit = worst_fit_frf(&est.frf, &truth, MACHINE_BAND);
    let nfft = (rec.fs() / est.df_hz).round() as usize;
    let mut floor = identify::spectra::FftFloor::new(&rec, nfft, opts.overlap);
    let ffts = floor.count();
    // the ratio of the two from calls in turn (timed apart, the machine's load moves in
    // between), both on the one worker of a pool, where the estimate runs its parts; the
    // floor's row is its median from these calls
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let wall = pool.install(|| {
        interleaved_ms(
            RATIO_RUNS,
            || {
                std::hint::black_box(estimate_frf(std::slice::from_ref(&rec), &opts).ok());
            },
            || {
                std::hint::black_box(floor.run());
            },
        )
    });
    let floor_ms = wall[1];
    println!(
        "a. FRF estimation: {} ({} lines), fit {fit:.3} %, {ms:.1} ms (all cores: {}); \
         in turn with its FFT floor ({RATIO_RUNS} calls each): {:.2} / {:.2} ms = {:.2}x",
        est.method,
        est.frf.freqs_hz.len(),
        ms_all_cores.map_or("-".into(), |m| format!("{m:.1} ms")),
        wall[0],
        wall[1],
        wall[0] / wall[1]
    );
    Ok(json!({
        "timeseries": path_str(&ts), "truth": path_str(&truth_path),
        "nfft": nfft, "overlap": opts.overlap, "band": [MACHINE_BAND.0, MACHINE_BAND.1],
        "method": est.method, "runs": RUNS,
        "mtwin": {"fit": fit, "ms": ms, "note": "estimate_frf, default options"},
        "mtwin_all_cores": ms_all_cores.map(|m| json!({"ms": m, "threads": all_cores()})),
        "fft_floor": {"ffts": ffts, "ms": floor_ms},
        "ratio": {"runs": RATIO_RUNS, "wall_ms": wall},
    }))
}

fn case_b(dir: &Path) -> Res<Value> {
    let model = truth8();
    let freqs: Vec<f64> = (0..2000).map(|k| 20.0 + k as f64).collect();
    let mut frf = noisy(&model, &freqs, 7);
    // only what a measurement gives: the coherence of `noisy_frf` is computed from the
    // noise-free |H| and the true noise level (an oracle the peers do not get)
    for c in &mut frf.channels {
        c.coherence = None;
    }
    let truth = model.frf(&freqs);
    let (fp, tp) = (dir.join("b_frf.csv"), dir.join("b_truth.csv"));
    write_frf_csv(&fp, &frf)?;
    write_frf_csv(&tp, &truth)?;
    let opts = FitOptions::default();
    let r = fit_frf(&frf, &opts)?;
    let band = (freqs[0], freqs[freqs.len() - 1]);
    let fit = worst_fit(&r.model, &truth, band);
    if std::env::var_os("MTWIN_BENCH_VERBOSE").is_some() {
        eprintln!("{}", r.report);
    }
    let ms = median_ms(RUNS, || fit_frf(&frf, &opts));
    println!(
        "b. 8 modes, 2 channels, 2000 lines: {} modes, fit {fit:.3} %, {ms:.1} ms",
        r.model.modes.len()
    );
    Ok(json!({
        "frf": path_str(&fp), "truth": path_str(&tp), "band": [band.0, band.1], "runs": RUNS,
        "natural_freqs_hz": model.modes.iter().map(Mode::freq_hz).collect::<Vec<_>>(),
        "mtwin": {"fit": fit, "ms": ms, "modes": r.model.modes.len(),
                  "note": "fit_frf, default options (automatic order)"},
    }))
}

fn case_c(dir: &Path) -> Res<Value> {
    let chain = MdofChain::paper_chain();
    let d = Daq {
        fs: 100.0,
        oversample: 8,
        force_noise: 0.001,
        response_noise: 0.001,
        response: ResponseKind::Displacement,
        seed: 11,
    };
    let (period, periods) = (4096, 10);
    let force = chirp(
        d.fs_sim(),
        period * d.oversample * periods,
        0.2,
        40.0,
        10.0,
        periods,
    );
    let rec = chain_record(&chain, force, &d, "paper_chirp");
    let rec = identify::diagnose::slice(&rec, 4 * period, periods * period);
    let est = estimate_frf(
        &[rec],
        &FrfOptions {
            excitation: Excitation::Chirp,
            nfft: Some(period),
            ..FrfOptions::default()
        },
    )?;
    let band = (0.2, 40.0);
    let frf = est.frf.band(band.0, band.1);
    let mut truth = frf.clone();
    for c in &mut truth.channels {
        c.h = truth
            .freqs_hz
            .iter()
            .map(|&f| chain.receptance(f))
            .collect();
        c.coherence = None;
    }
    let (fp, tp) = (dir.join("c_frf.csv"), dir.join("c_truth.csv"));
    write_frf_csv(&fp, &frf)?;
    write_frf_csv(&tp, &truth)?;
    // the options of examples/paper_3dof.rs (the paper's uniform weight W = 1)
    let opts = FitOptions {
        weighting: Weighting::Uniform,
        band_hz: Some(band),
        ..FitOptions::default()
    };
    let r = fit_frf(&frf, &opts)?;
    let fit = worst_fit(&r.model, &truth, band);
    if std::env::var_os("MTWIN_BENCH_VERBOSE").is_some() {
        eprintln!("{}", r.report);
    }
    let ms = median_ms(RUNS, || fit_frf(&frf, &opts));
    println!(
        "c. paper 3-DoF chain ({} lines): {} modes, fit {fit:.3} %, {ms:.1} ms",
        frf.freqs_hz.len(),
        r.model.modes.len()
    );
    Ok(json!({
        "frf": path_str(&fp), "truth": path_str(&tp), "band": [band.0, band.1], "runs": RUNS,
        "natural_freqs_hz": chain.natural_freqs_hz(),
        "mtwin": {"fit": fit, "ms": ms, "modes": r.model.modes.len(),
                  "note": "fit_frf, automatic order, uniform weight (as examples/paper_3dof.rs)"},
    }))
}

fn case_d(dir: &Path, machine: &ModalMachine) -> Res<Value> {
    let poses = machine.grid([3, 3, 2]);
    let recs: Vec<TimeSeries> = poses
        .iter()
        .enumerate()
        .map(|(i, &p)| noise_record(machine, p, 10.0, 100 + i as u64))
        .collect();
    let mut opts = CampaignOptions::default();
    if let Ok(w) = std::env::var("MTWIN_BENCH_WEIGHTING") {
        opts.fit.weighting = match w.as_str() {
            "uniform" => identify::rational_fit::Weighting::Uniform,
            "ml" => identify::rational_fit::Weighting::InverseVariance,
            _ => identify::rational_fit::Weighting::Coherence,
        };
    }
    let res = identify_campaign(&recs, &opts, &|_, _| {})?;
    let ms = median_ms(RUNS_SLOW, || identify_campaign(&recs, &opts, &|_, _| {}));
    // the same campaign on every core (rayon across poses), for the row that shows it
    let ms_all_cores = on_all_cores(RUNS_SLOW, || identify_campaign(&recs, &opts, &|_, _| {}))?;
    let mut entries = Vec::new();
    let mut worst = f64::INFINITY;
    for (i, (p, rec)) in poses.iter().zip(&recs).enumerate() {
        let ts = dir.join(format!("d_pose{i:02}.csv"));
        write_timeseries(&ts, rec)?;
        let pm = res
            .twin
            .poses
            .iter()
            .min_by(|a, b| {
                let d = |q: &[f64; 3]| (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>();
                d(&a.pose).total_cmp(&d(&b.pose))
            })
            .ok_or("no pose model")?;
        let truth = input_channels(
            machine.frf_at(*p, &pm.frf.freqs_hz, &[Axis::X, Axis::Y]),
            Axis::X,
        );
        let tp = dir.join(format!("d_truth{i:02}.csv"));
        write_frf_csv(&tp, &truth)?;
        let fit = worst_fit(&pm.model, &truth, MACHINE_BAND);
        if std::env::var_os("MTWIN_BENCH_VERBOSE").is_some() {
            eprintln!(
                "pose {i} {p:?}: fit {fit:.2} %, {} modes {:?}",
                pm.model.modes.len(),
                pm.model
                    .modes
                    .iter()
                    .map(|m| (m.freq_hz() * 10.0).round() / 10.0)
                    .collect::<Vec<_>>()
            );
        }
        worst = worst.min(fit);
        let nat: Vec<f64> = (0..machine.modes.len())
            .map(|k| machine.mode_at(k, *p).freq_hz())
            .collect();
        entries.push(json!({"timeseries": path_str(&ts), "truth": path_str(&tp),
                            "natural_freqs_hz": nat}));
    }
    let df = res.twin.poses[0].frf.freqs_hz[0];
    let nfft = (recs[0].fs() / df).round() as usize;
    println!(
        "d. campaign of {} poses: worst fit {worst:.3} %, {ms:.0} ms ({} threads: {})",
        poses.len(),
        all_cores(),
        ms_all_cores.map_or("-".into(), |m| format!("{m:.0} ms"))
    );
    Ok(json!({
        "poses": entries, "nfft": nfft, "runs": RUNS_SLOW, "overlap": opts.frf.overlap,
        "band": [MACHINE_BAND.0, MACHINE_BAND.1],
        "mtwin": {"fit": worst, "ms": ms,
                  "note": "identify_campaign, default options: H1 + automatic-order fit per pose, mode tracking, leave-one-out interpolation check"},
        "mtwin_all_cores": ms_all_cores.map(|m| json!({"ms": m, "threads": all_cores()})),
    }))
}

/// f. Refit from milling data: the exact twin of the machine before the wear, mode 2
/// stiffness −15 %, milling (fx, fy; ax, ay) at 3 spindle speeds × 15 s at the centre.
fn case_f(dir: &Path, machine: &ModalMachine) -> Res<Value> {
    use identify::refit::{default_nfft, refit, RefitMethod, RefitOptions};
    use vmachine::daq::milling_at_centre;
    let axes = [Axis::X, Axis::Y];
    let twin = machine.exact_twin([3, 3, 2], &axes);
    let worn = machine.clone().with_stiffness_change(2, 0.85);
    let c = machine.center();
    // the records of identify/tests/refit/truth.rs
    let recs = milling_at_centre(&worn, &[2400.0, 3300.0, 4500.0], 15.0, 7);
    let band = (30.0, 1500.0);
    let freqs: Vec<f64> = (0..=1000)
        .map(|i| band.0 + (band.1 - band.0) * i as f64 / 1000.0)
        .collect();
    let truth = worn.frf_at(c, &freqs, &axes);
    let tp = dir.join("f_truth.csv");
    write_frf_csv(&tp, &truth)?;
    let mut files = Vec::new();
    for (i, r) in recs.iter().enumerate() {
        let p = dir.join(format!("f_milling{i}.csv"));
        write_timeseries(&p, r)?;
        files.push(path_str(&p));
    }
    let old = machine.model_at(c, &axes);
    let nfft = default_nfft(&recs[0], &old);
    let mut out = serde_json::Map::new();
    // MTWIN_BENCH_F_METHOD=time|modal|paper: that method only (for profiling)
    let only = std::env::var("MTWIN_BENCH_F_METHOD").ok();
    for (name, method) in [
        ("time", RefitMethod::Time),
        ("modal", RefitMethod::Modal),
        ("paper", RefitMethod::Paper),
    ] {
        if only.as_deref().is_some_and(|o| o != name) {
            continue;
        }
        let opts = RefitOptions {
            method,
            ..RefitOptions::default()
        };
        let (new, _) = refit(&twin, &recs, &opts)?;
        let mut ev = identify::interpolate::TwinEvaluator::new(&new)?;
        let m = ev.model_at(c).clone();
        let fit = worst_fit(&m, &direct_channels(truth.clone()), band);
        let ms = median_ms(RUNS_SLOW, || refit(&twin, &recs, &opts));
        println!("f. refit from milling ({name}): worst direct channel {fit:.3} %, {ms:.0} ms");
        out.insert(name.into(), json!({"fit": fit, "ms": ms}));
    }
    Ok(json!({
        "records": files, "truth": path_str(&tp), "band": [band.0, band.1], "nfft": nfft,
        "runs": RUNS_SLOW,
        "natural_freqs_hz": (0..worn.modes.len()).map(|k| worn.mode_at(k, c).freq_hz()).collect::<Vec<_>>(),
        "mtwin": Value::Object(out),
    }))
}

/// Only the direct channels (xx, yy) of an FRF.
fn direct_channels(mut frf: Frf) -> Frf {
    frf.channels.retain(|c| c.channel.output == c.channel.input);
    frf
}

fn case_e(machine: &ModalMachine) -> Res<Value> {
    let twin = machine.exact_twin([3, 3, 2], &[Axis::X, Axis::Y]);
    let mut s = Slave::new(&twin)?;
    s.enter_init()?;
    s.exit_init()?;
    let steps = 100_000;
    let dt = 1e-4;
    let mut t = 0.0;
    let mut k = 0u64;
    let ms = median_ms(RUNS, || -> Result<f64, String> {
        let mut y = [0.0; 2];
        for _ in 0..steps {
            k += 1;
            let x = 0.3 + 0.2 * ((k % 1000) as f64 * 1e-3);
            s.set_real(&[0, 1, 2, 3], &[100.0, -50.0, x, 0.2])?;
            s.get_real(&[5, 6], &mut y)?;
            s.do_step(t, dt)?;
            t += dt;
        }
        Ok(y[0])
    });
    let us = ms * 1e3 / steps as f64;
    println!("e. FMU doStep (slave core, moving pose, 9 modes, 2 axes): {us:.3} us");
    Ok(
        json!({"runs": RUNS, "mtwin": {"us_per_step": us, "ms": ms, "steps": steps,
                        "note": "slave core set_real + get_real + do_step, axes moving every step"}}),
    )
}

/// The tryout data of an independent generator and the real impact test (shared/data).
const TRYOUT: &str = "/work/shared/data/tryout_gantry";
const REAL_IMPACT: &str = "/work/shared/data/pyfrf_impact_hammer/impact_5hits.csv";

/// `mtwin identify FILE` with its defaults (the library call behind it) on one record:
/// the model of its one pose and the median time of [`RUNS`] runs (record in memory).
fn identify_record(rec: &TimeSeries) -> Res<(ModalModel, f64)> {
    let opts = CampaignOptions::default();
    let recs = std::slice::from_ref(rec);
    let res = identify_campaign(recs, &opts, &|_, _| {})?;
    let ms = median_ms(RUNS, || identify_campaign(recs, &opts, &|_, _| {}));
    let model = res.twin.poses.first().ok_or("no pose model")?.model.clone();
    Ok((model, ms))
}

/// The xx channel of `frf`.
fn xx(mut frf: Frf) -> Frf {
    frf.channels
        .retain(|c| c.channel.output == Axis::X && c.channel.input == Axis::X);
    frf
}

/// g. Data mtwin was not tuned on: the tryout gantry's impact record at pose g00 (hammer
/// along x) and its log sweep at the centre, fit of xx against the analytic truth.
fn case_g() -> Res<Value> {
    let dir = Path::new(TRYOUT);
    let mut out = serde_json::Map::new();
    for (name, rec_path, truth_path, band) in [
        (
            "impact_g00_x",
            "campaign/g00_x.csv",
            "truth/g00.csv",
            (30.0, 2500.0),
        ),
        (
            "sweep_centre_x",
            "sweep_centre_x.csv",
            "truth/centre.csv",
            (30.0, 2400.0),
        ),
    ] {
        let rec = identify::read::read_timeseries(&dir.join(rec_path))?;
        let truth = xx(identify::read::read_frf_csv(&dir.join(truth_path))?);
        let (model, ms) = identify_record(&rec)?;
        let fit = worst_fit(&model, &truth, band);
        println!(
            "g. tryout {name}: {} modes, xx fit {fit:.3} %, {ms:.1} ms",
            model.modes.len()
        );
        out.insert(
            name.into(),
            json!({"record": path_str(&dir.join(rec_path)), "truth": path_str(&dir.join(truth_path)),
                   "band": [band.0, band.1],
                   "mtwin": {"fit": fit, "ms": ms, "modes": model.modes.len()}}),
        );
    }
    out.insert("runs".into(), json!(RUNS));
    Ok(Value::Object(out))
}

/// h. The real impact test (5 hits, force and acceleration): mtwin's model (receptance)
/// on 1 Hz lines, for the script to judge against the per-hit H1 of the raw data.
fn case_h(dir: &Path) -> Res<Value> {
    let rec = identify::read::read_timeseries(Path::new(REAL_IMPACT))?;
    let (model, ms) = identify_record(&rec)?;
    let freqs: Vec<f64> = (1..12_800).map(f64::from).collect();
    let p = dir.join("h_mtwin_model.csv");
    write_frf_csv(&p, &model.frf(&freqs))?;
    println!(
        "h. real impact test: {} modes, {ms:.1} ms",
        model.modes.len()
    );
    Ok(
        json!({"record": REAL_IMPACT, "model": path_str(&p), "band": [200.0, 4500.0],
              "runs": RUNS, "mtwin": {"ms": ms, "modes": model.modes.len()}}),
    )
}

fn main() -> Res<()> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: bench_peers DIR (where the case files and cases.json go)")?,
    );
    std::fs::create_dir_all(&dir)?;
    // one thread, whatever RAYON_NUM_THREADS says: the peers run single-threaded too
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()?;
    let machine = ModalMachine::default_machine();
    // MTWIN_BENCH_ONLY=a|b|c|d|e|f: run one case only (for profiling; no cases.json)
    if let Ok(only) = std::env::var("MTWIN_BENCH_ONLY") {
        let v = match only.as_str() {
            "a" => case_a(&dir, &machine)?,
            "b" => case_b(&dir)?,
            "c" => case_c(&dir)?,
            "d" => case_d(&dir, &machine)?,
            "e" => case_e(&machine)?,
            "f" => case_f(&dir, &machine)?,
            "g" => case_g()?,
            "h" => case_h(&dir)?,
            other => return Err(format!("MTWIN_BENCH_ONLY={other}: expected a..h").into()),
        };
        println!("{}", serde_json::to_string(&v["mtwin"])?);
        if let (Some(n), Some(f)) = (v.get("nfft"), v.get("natural_freqs_hz")) {
            println!("nfft {n}, natural frequencies (Hz) {f}");
        }
        if let Some(floor) = v.get("fft_floor") {
            println!("FFT floor: {floor}");
        }
        return Ok(());
    }
    let out = json!({
        "a_frf": case_a(&dir, &machine)?,
        "b_fit": case_b(&dir)?,
        "c_chain": case_c(&dir)?,
        "d_campaign": case_d(&dir, &machine)?,
        "e_fmu": case_e(&machine)?,
        "f_refit": case_f(&dir, &machine)?,
        "g_tryout": case_g()?,
        "h_real": case_h(&dir)?,
    });
    let p = dir.join("cases.json");
    std::fs::write(&p, serde_json::to_string_pretty(&out)?)?;
    println!("wrote {}", p.display());
    Ok(())
}
