//! Measurements: an excitation simulated at the oversampled rate, decimated by the
//! [`Daq`], corrupted by sensor noise. [`run`] gives the clean decimated signals (so
//! hidden effects can act on them), [`Clean::into_record`] adds noise and metadata.

use crate::daq::{auto_range, corrupt, Daq, Noise};
use crate::excitation::{Force, Hammer, Hit, Milling};
use crate::record::{Record, Response};
use crate::sim::{simulate_input, simulate_nonlinear, Hold, Input, Motion, SimOptions};
use crate::structure::{Machine, Pose};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// How a test is instrumented.
#[derive(Clone, Debug)]
pub struct Setup {
    /// Acquisition.
    pub daq: Daq,
    /// Accelerometers or displacement sensors.
    pub response: Response,
    /// Accelerometer mass at the tool tip (kg) (mass loading; 0 for non-contact sensors).
    pub tip_mass: f64,
    /// Noise of the force channels.
    pub force_noise: Noise,
    /// Noise of the response channels.
    pub response_noise: Noise,
    /// Force hold of the simulation.
    pub hold: Hold,
}

impl Setup {
    /// Impact testing: 10240 Hz, accelerometers of 12 g, good 24-bit noise.
    pub fn impact() -> Self {
        Setup {
            daq: Daq::default(),
            response: Response::Acceleration,
            tip_mass: 0.012,
            force_noise: Noise::good(),
            response_noise: Noise::good(),
            hold: Hold::First,
        }
    }

    /// Shaker or milling with non-contact displacement sensors (no mass loading).
    pub fn displacement() -> Self {
        Setup {
            response: Response::Displacement,
            tip_mass: 0.0,
            ..Self::impact()
        }
    }

    /// A noise-free setup (for checks against the analytic truth).
    pub fn clean(response: Response) -> Self {
        Setup {
            daq: Daq::default(),
            response,
            tip_mass: 0.0,
            force_noise: Noise::none(),
            response_noise: Noise::none(),
            hold: Hold::First,
        }
    }

    /// The setup's simulation options.
    pub fn sim_options(&self) -> SimOptions {
        SimOptions {
            h: self.daq.h(),
            hold: self.hold,
            tip_mass: self.tip_mass,
            repose_tol: 1e-3,
            dense: false,
        }
    }
}

/// Decimated, noise-free signals of one test.
#[derive(Clone, Debug)]
pub struct Clean {
    /// Output rate (Hz).
    pub fs: f64,
    /// Force (N).
    pub force: [Vec<f64>; 3],
    /// Response (acceleration or displacement).
    pub response: [Vec<f64>; 3],
    /// What the response holds.
    pub kind: Response,
    /// Axis positions per output sample.
    pub poses: Vec<Pose>,
}

fn split(x: &[[f64; 3]]) -> [Vec<f64>; 3] {
    [0, 1, 2].map(|d| x.iter().map(|v| v[d]).collect())
}

/// Simulate `force` (simulation rate) with the axes along `poses` (one per simulation
/// sample, or one) and decimate. The machine's cubic spring or friction, if any, is
/// integrated with Runge–Kutta (at the first pose); otherwise the exact linear
/// discretisation is used.
pub fn run(machine: &Machine, setup: &Setup, force: &Force, poses: &[Pose]) -> Clean {
    run_input(machine, setup, force, poses, Input::Tcp)
}

/// [`run`] with the force acting at `input` (the force columns still show it).
pub fn run_input(
    machine: &Machine,
    setup: &Setup,
    force: &Force,
    poses: &[Pose],
    input: Input,
) -> Clean {
    let opts = setup.sim_options();
    let nonlinear = machine.cubic.is_some() || machine.friction.is_some();
    let motion: Motion = if nonlinear && input == Input::Tcp {
        simulate_nonlinear(machine, force, poses[0], &opts)
    } else {
        simulate_input(machine, force, poses, &opts, input)
    };
    let resp = match setup.response {
        Response::Acceleration => &motion.acc,
        Response::Displacement => &motion.disp,
    };
    let daq = &setup.daq;
    let f = split(force);
    let r = split(resp);
    let os = daq.oversample;
    let n_out = force.len() / os;
    Clean {
        fs: daq.fs,
        force: [0, 1, 2].map(|d| daq.decimate(&f[d])),
        response: [0, 1, 2].map(|d| daq.decimate(&r[d])),
        kind: setup.response,
        poses: (0..n_out)
            .map(|i| crate::sim::pose_at(poses, i * os))
            .collect(),
    }
}

impl Clean {
    /// The response channels `k` samples late (a constant delay; the first `k` samples
    /// repeat the first value, which is the rest state).
    pub fn delayed(mut self, k: usize) -> Self {
        for ch in &mut self.response {
            let first = ch.first().copied().unwrap_or(0.0);
            let n = ch.len();
            let mut out = vec![first; n];
            if k < n {
                out[k..].copy_from_slice(&ch[..n - k]);
            }
            *ch = out;
        }
        self
    }

    /// RMS of the response channels (all three together).
    pub fn response_rms(&self) -> f64 {
        let n: usize = self.response.iter().map(Vec::len).sum();
        let s: f64 = self.response.iter().flatten().map(|v| v * v).sum();
        (s / n.max(1) as f64).sqrt()
    }

    /// Add `scale ×` another response (same length) to this one.
    pub fn add_response(&mut self, other: &[Vec<f64>; 3], scale: f64) {
        for (a, b) in self.response.iter_mut().zip(other) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += scale * y;
            }
        }
    }

    /// Add noise and quantisation (channel `d` seeded from `seed`) and the metadata.
    pub fn into_record(mut self, setup: &Setup, seed: u64, comments: Vec<String>) -> Record {
        let mut comments = comments;
        // one input range per sensor type (the largest channel sets it), as a tester would
        let all = |ch: &[Vec<f64>; 3]| ch.iter().flatten().copied().collect::<Vec<f64>>();
        let rf = auto_range(&all(&self.force));
        let rr = auto_range(&all(&self.response));
        for d in 0..3 {
            let s = seed.wrapping_mul(16) + d as u64;
            corrupt(&mut self.force[d], rf, &setup.force_noise, s);
            corrupt(&mut self.response[d], rr, &setup.response_noise, s + 8);
        }
        comments.push(format!(
            "adc: force range {rf} N, response range {rr}, {} bits",
            setup.response_noise.bits
        ));
        let sensor = match setup.response {
            Response::Acceleration => format!(
                "sensor=accelerometer (relative acceleration tool - workpiece), mass {} kg at the tool tip",
                setup.tip_mass
            ),
            Response::Displacement => "sensor=displacement (non-contact, relative tool - workpiece)".into(),
        };
        comments.push(sensor);
        if setup.response == Response::Acceleration && setup.tip_mass > 0.0 {
            // the mass loading's key (docs/formats.md): what a tester writes in the header
            comments.push(format!("sensor_mass={}", setup.tip_mass));
        }
        comments.push(format!(
            "generator=lumped; fs={} Hz simulated at {}x, anti-alias FIR, noise white {} pink {} of range",
            setup.daq.fs, setup.daq.oversample, setup.response_noise.white, setup.response_noise.pink
        ));
        Record {
            comments,
            fs: self.fs,
            force: self.force,
            response: self.response,
            kind: self.kind,
            poses: self.poses,
        }
    }
}

/// Unit vector along axis `a` (0 = x, 1 = y, 2 = z).
pub fn unit(a: usize) -> [f64; 3] {
    let mut d = [0.0; 3];
    d[a.min(2)] = 1.0;
    d
}

/// The hits of a standard impact test: `count` hits in `seconds`, peaks in `peak`,
/// 15 % chance of a double hit each, from `seed`.
pub fn standard_hits(
    hammer: &Hammer,
    count: usize,
    seconds: f64,
    peak: (f64, f64),
    seed: u64,
) -> Vec<Hit> {
    let mut rng = StdRng::seed_from_u64(seed);
    hammer.random_hits(count, seconds, peak, 0.15, &mut rng)
}

/// An impact test at `pose`, hammer along `axis`, the given hits, `seconds` long.
#[allow(clippy::too_many_arguments)]
pub fn impact_clean(
    machine: &Machine,
    setup: &Setup,
    pose: Pose,
    axis: usize,
    hammer: &Hammer,
    hits: &[Hit],
    seconds: f64,
) -> Clean {
    let fs = setup.daq.fs_sim();
    let n = (seconds * fs).round() as usize;
    let f = hammer.force(hits, unit(axis), fs, n);
    run(machine, setup, &f, &[pose])
}

/// A complete impact record: `count` hits of 150–400 N in `seconds`, noise, metadata.
pub fn impact_record(
    machine: &Machine,
    setup: &Setup,
    pose: Pose,
    axis: usize,
    count: usize,
    seconds: f64,
    seed: u64,
) -> Record {
    let hammer = Hammer::plastic();
    let hits = standard_hits(&hammer, count, seconds, (150.0, 400.0), seed);
    let c = impact_clean(machine, setup, pose, axis, &hammer, &hits, seconds);
    let doubles = hits.len() - count;
    c.into_record(
        setup,
        seed,
        vec![
            format!(
                "impact test, hammer along {}, {count} hits{}",
                ['x', 'y', 'z'][axis],
                if doubles > 0 {
                    format!(" ({doubles} double)")
                } else {
                    String::new()
                }
            ),
            format!(
                "hammer {} kg, tip stiffness {:.3e} N/m, pulse {:.3} ms",
                hammer.mass,
                hammer.tip_stiffness,
                hammer.pulse_s() * 1e3
            ),
        ],
    )
}

/// Axis positions of a cut: from `start` along the feed axis at the feed speed.
pub fn feed_track(m: &Milling, start: Pose, fs: f64, n: usize) -> Vec<Pose> {
    let v = m.feed_speed();
    let a = if m.feed_y { 1 } else { 0 };
    (0..n)
        .map(|i| {
            let mut p = start;
            p[a] += v * i as f64 / fs;
            p
        })
        .collect()
}

/// A milling record: `seconds` of cutting from `start`, the axes moving with the feed.
pub fn milling_clean(
    machine: &Machine,
    setup: &Setup,
    m: &Milling,
    start: Pose,
    seconds: f64,
) -> Clean {
    let fs = setup.daq.fs_sim();
    let n = (seconds * fs).round() as usize;
    let f = m.force(fs, n, 0.0);
    let track = feed_track(m, start, fs, n);
    run(machine, setup, &f, &track)
}

/// The metadata lines of a milling record.
pub fn milling_comments(m: &Milling) -> Vec<String> {
    vec![
        format!(
            "{}-milling, {} teeth, {} rpm, feed {}",
            if m.down { "down" } else { "up" },
            m.teeth,
            m.rpm,
            if m.feed_y { "y" } else { "x" }
        ),
        format!(
            "tool D={} m, helix {} deg, ap={} m, ae/D={}, fz={} m, runout {:.2e} m, tooth factors {:?}",
            m.diameter, m.helix_deg, m.depth, m.immersion, m.feed_per_tooth, m.runout, m.tooth_factor
        ),
    ]
}

/// A random seed for sub-steps of a generator.
pub fn sub_seed(rng: &mut StdRng) -> u64 {
    rng.gen()
}

/// A shaker test at `pose`: a logarithmic sweep 20-2500 Hz along x in 8 s at 40 N, then
/// 1.5 s at rest, measured with the displacement sensor (the data set's
/// `sweep_centre_x.csv`).
pub fn log_sweep_record(machine: &Machine, pose: Pose, seed: u64) -> Record {
    let disp = Setup::displacement();
    let fs = disp.daq.fs_sim();
    let f = crate::excitation::sweep(
        crate::excitation::Sweep::Logarithmic,
        fs,
        (9.5 * fs) as usize,
        20.0,
        2500.0,
        8.0,
        40.0,
        unit(0),
    );
    run(machine, &disp, &f, &[pose]).into_record(
        &disp,
        seed,
        vec![
            "shaker, logarithmic sweep 20-2500 Hz along x in 8 s, 40 N, then 1.5 s at rest".into(),
        ],
    )
}
