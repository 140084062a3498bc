//! Fingerprints of [`estimate_frf`]'s Welch estimates, to check that a change to the
//! estimator gives the same numbers bit for bit: every H, coherence, frequency, band,
//! warning and count of a set of estimates (displacement, acceleration, two inputs (MIMO),
//! two records; nfft 3000, 4096 and automatic; one and two threads) hashed by their bits.
//! Run it on the old and the new code and compare the lines.
//!
//! Run: `cargo run --release -p identify --example frf_hash` (`-- loop N`: only case a of
//! the spectra bench N times on one thread, e.g. under a profiler).

use identify::axis::Axis;
use identify::spectra::{estimate_frf, Estimator, FrfEstimate, FrfOptions};
use identify::timeseries::{ResponseKind, TimeSeries};
use std::hash::{Hash, Hasher};
use vmachine::daq::{acquire, simulate_machine, Daq};
use vmachine::excitation::noise;
use vmachine::structure::ModalMachine;

/// `secs` of noise force on the `forces` axes (seeds `seed`, `seed + 1`, ...) at the centre
/// of the virtual machine, responses of `kind` along x and y.
fn record(secs: f64, forces: &[Axis], kind: ResponseKind, seed: u64) -> TimeSeries {
    let machine = ModalMachine::default_machine();
    let pose = machine.center();
    let daq = Daq {
        response: kind,
        seed,
        ..Daq::default()
    };
    let fs = daq.fs_sim();
    let n = (secs * fs) as usize;
    let mut f: [Option<Vec<f64>>; 3] = Default::default();
    for (i, a) in forces.iter().enumerate() {
        f[a.index()] = Some(noise(n, 50.0, seed + i as u64));
    }
    let pose_at = move |_t: f64| pose;
    let resp = simulate_machine(&machine, &f, fs, &pose_at, &[Axis::X, Axis::Y], kind);
    acquire(f, resp, &pose_at, &daq, &format!("noise_{seed}"))
}

/// The hash of every number and text of `e` by its bits.
fn fingerprint(e: &FrfEstimate) -> u64 {
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for f in &e.frf.freqs_hz {
        f.to_bits().hash(&mut h);
    }
    for c in &e.frf.channels {
        c.channel.to_string().hash(&mut h);
        for z in &c.h {
            (z.re.to_bits(), z.im.to_bits()).hash(&mut h);
        }
        for g in c.coherence.iter().flatten() {
            g.to_bits().hash(&mut h);
        }
    }
    e.excitation_band_hz
        .map(|(a, b)| (a.to_bits(), b.to_bits()))
        .hash(&mut h);
    (&e.warnings, e.hits_used, &e.hits_dropped, &e.method).hash(&mut h);
    e.exp_window_sigma.map(f64::to_bits).hash(&mut h);
    e.df_hz.to_bits().hash(&mut h);
    h.finish()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a pool");
    if args.get(1).map(String::as_str) == Some("loop") {
        let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
        let rec = record(60.0, &[Axis::X], ResponseKind::Displacement, 3);
        let opts = FrfOptions::default();
        let t = std::time::Instant::now();
        one.install(|| {
            for _ in 0..n {
                std::hint::black_box(estimate_frf(std::slice::from_ref(&rec), &opts).ok());
            }
        });
        println!(
            "{n} calls, {:.2} ms each",
            t.elapsed().as_secs_f64() * 1e3 / n as f64
        );
        return;
    }
    if args.get(1).map(String::as_str) == Some("floor") {
        // the bench's floor alone: 30 Hann-windowed real FFTs of 65536 points
        let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(200);
        let rec = record(60.0, &[Axis::X], ResponseKind::Displacement, 3);
        let nfft = 1 << 16;
        let cols: Vec<&[f64]> = [
            rec.force(Axis::X),
            rec.response(Axis::X),
            rec.response(Axis::Y),
        ]
        .into_iter()
        .flatten()
        .collect();
        let (hop, segs) = identify::spectra::welch_segments(rec.len(), nfft, 0.5);
        let plan = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(nfft);
        let window = identify::spectra::hann(nfft);
        let (mut buf, mut out, mut scratch) = (
            plan.make_input_vec(),
            plan.make_output_vec(),
            plan.make_scratch_vec(),
        );
        let t = std::time::Instant::now();
        for _ in 0..n {
            for s in 0..segs {
                for c in &cols {
                    for ((b, x), w) in buf.iter_mut().zip(&c[s * hop..]).zip(&window) {
                        *b = x * w;
                    }
                    plan.process_with_scratch(&mut buf, &mut out, &mut scratch)
                        .expect("sizes");
                }
            }
            std::hint::black_box(out[1].re);
        }
        println!(
            "{n} floors, {:.2} ms each",
            t.elapsed().as_secs_f64() * 1e3 / n as f64
        );
        return;
    }
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("a pool");
    let disp = record(60.0, &[Axis::X], ResponseKind::Displacement, 3);
    let acc = record(20.0, &[Axis::X], ResponseKind::Acceleration, 5);
    let mimo = record(20.0, &[Axis::X, Axis::Y], ResponseKind::Displacement, 7);
    let mimo_acc = record(10.0, &[Axis::X, Axis::Y], ResponseKind::Acceleration, 9);
    let other = record(15.0, &[Axis::X], ResponseKind::Displacement, 11);
    let cases: [(&str, Vec<TimeSeries>); 6] = [
        ("displacement", vec![disp.clone()]),
        ("acceleration", vec![acc]),
        ("mimo", vec![mimo]),
        ("mimo acceleration", vec![mimo_acc]),
        ("two records", vec![disp, other.clone()]),
        ("short", vec![other]),
    ];
    let mut all = std::collections::hash_map::DefaultHasher::new();
    for (name, recs) in &cases {
        for nfft in [None, Some(3000), Some(4096)] {
            for (threads, pool) in [(1, &one), (2, &two)] {
                let opts = FrfOptions {
                    nfft,
                    ..FrfOptions::default()
                };
                let label = format!("{name:18} nfft {nfft:?} threads {threads}");
                hash_one(&label, pool, recs, &opts, &mut all);
            }
        }
        for estimator in [Estimator::H2, Estimator::Hv] {
            let opts = FrfOptions {
                estimator,
                nfft: Some(4096),
                fmax_hz: Some(1500.0),
                ..FrfOptions::default()
            };
            let label = format!("{name:18} {estimator:?} nfft 4096 fmax 1500");
            hash_one(&label, &one, recs, &opts, &mut all);
        }
    }
    // a NaN in a response: the error names its sample
    let mut bad = cases[5].1[0].clone();
    if let Some(y) = bad.response[1].as_mut() {
        y[20_000] = f64::NAN;
    }
    for (threads, pool) in [(1, &one), (2, &two)] {
        let e = pool.install(|| estimate_frf(std::slice::from_ref(&bad), &FrfOptions::default()));
        let msg = e
            .map(|e| fingerprint(&e).to_string())
            .unwrap_or_else(|e| e.to_string());
        println!("nan response threads {threads}: {msg}");
        msg.hash(&mut all);
    }
    println!("all: {:016x}", all.finish());
}

/// Prints the fingerprint of `estimate_frf(recs, opts)` in `pool` after `label` and adds
/// it (or the error's text) to `all`.
fn hash_one(
    label: &str,
    pool: &rayon::ThreadPool,
    recs: &[TimeSeries],
    opts: &FrfOptions,
    all: &mut std::collections::hash_map::DefaultHasher,
) {
    let fp = pool
        .install(|| estimate_frf(recs, opts))
        .map(|e| fingerprint(&e));
    match &fp {
        Ok(f) => println!("{label}: {f:016x}"),
        Err(e) => println!("{label}: error {e}"),
    }
    fp.map_err(|e| e.to_string()).hash(all);
}
