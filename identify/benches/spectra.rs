//! The Welch/H1 estimate against its floor: [`estimate_frf`] on case a of
//! `scripts/bench_peers.sh` (60 s of noise on the virtual machine, force x, displacement
//! x and y: 10 segments of 65 536 points, 30 real FFTs) and the same 30 Hann-windowed
//! real FFTs alone (window, plan and buffers made before timing). One thread: the target
//! is `estimate_frf` within 1.3x of the floor.
//!
//! Before criterion's wall times it prints the ratio of the two in on-CPU time of the
//! thread (`CLOCK_THREAD_CPUTIME_ID`), medians of interleaved runs: on a
//! machine shared with other work, wall times measure the load as much as the code.
//!
//! Run: `cargo bench -p identify --bench spectra` (only the on-CPU ratio:
//! `cargo bench -p identify --bench spectra -- none`; `MTWIN_SPECTRA_RUNS` interleaved
//! runs, 100 unless set).

use criterion::{criterion_group, criterion_main, Criterion};
use identify::axis::Axis;
use identify::spectra::{estimate_frf, FftFloor, FrfOptions};
use identify::timeseries::{ResponseKind, TimeSeries};
use vmachine::daq::{acquire, simulate_machine, Daq};
use vmachine::excitation::noise;
use vmachine::structure::ModalMachine;

/// The record of case a: 60 s of noise force along x at the centre of the virtual
/// machine, displacement along x and y (seed 3).
fn record() -> TimeSeries {
    let machine = ModalMachine::default_machine();
    let pose = machine.center();
    let daq = Daq {
        response: ResponseKind::Displacement,
        seed: 3,
        ..Daq::default()
    };
    let fs = daq.fs_sim();
    let n = (60.0 * fs) as usize;
    let forces = [Some(noise(n, 50.0, 3)), None, None];
    let pose_at = move |_t: f64| pose;
    let resp = simulate_machine(
        &machine,
        &forces,
        fs,
        &pose_at,
        &[Axis::X, Axis::Y],
        daq.response,
    );
    acquire(forces, resp, &pose_at, &daq, "noise_3")
}

/// Nanoseconds this thread has run on a CPU (`CLOCK_THREAD_CPUTIME_ID`; `None` when the
/// clock fails).
fn cpu_ns() -> Option<u64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec for the call's duration.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then(|| ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64)
}

/// On-CPU milliseconds per call of `a` and `b`, `runs` calls each, interleaved: the
/// medians (a call that shared its core's caches with another program's burst does not
/// move them) and the means.
fn on_cpu_ms(runs: usize, mut a: impl FnMut(), mut b: impl FnMut()) -> Option<[(f64, f64); 2]> {
    let (mut ta, mut tb) = (Vec::with_capacity(runs), Vec::with_capacity(runs));
    for _ in 0..runs {
        let t0 = cpu_ns()?;
        a();
        let t1 = cpu_ns()?;
        b();
        let t2 = cpu_ns()?;
        ta.push((t1 - t0) as f64 * 1e-6);
        tb.push((t2 - t1) as f64 * 1e-6);
    }
    let stats = |mut t: Vec<f64>| {
        let mean = t.iter().sum::<f64>() / t.len() as f64;
        t.sort_by(f64::total_cmp);
        (t[t.len() / 2], mean)
    };
    Some([stats(ta), stats(tb)])
}

fn bench(c: &mut Criterion) {
    let rec = record();
    let opts = FrfOptions::default();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    let est = estimate_frf(std::slice::from_ref(&rec), &opts).expect("an estimate");
    let nfft = (rec.fs() / est.df_hz).round() as usize;
    let mut floor = FftFloor::new(&rec, nfft, opts.overlap);
    println!("{}: {} windowed FFTs", est.method, floor.count());
    let runs = std::env::var("MTWIN_SPECTRA_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(100);
    let cpu = pool.install(|| {
        on_cpu_ms(
            runs,
            || {
                std::hint::black_box(estimate_frf(std::slice::from_ref(&rec), &opts).ok());
            },
            || {
                std::hint::black_box(floor.run());
            },
        )
    });
    match cpu {
        Some([(e, em), (f, fm)]) => println!(
            "on-CPU time per call ({runs} interleaved runs), median: estimate_frf {e:.2} ms, floor {f:.2} ms, ratio {:.2} (means {em:.2} / {fm:.2} = {:.2})",
            e / f,
            em / fm
        ),
        None => println!("no thread CPU clock: on-CPU times not measured"),
    }
    let mut g = c.benchmark_group("welch_h1_one_thread");
    g.sample_size(20);
    g.bench_function("estimate_frf", |b| {
        pool.install(|| b.iter(|| estimate_frf(std::slice::from_ref(&rec), &opts)))
    });
    g.bench_function("fft_floor", |b| pool.install(|| b.iter(|| floor.run())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
