//! Diagnosis with default options on the second generator (`lumped`: a lumped-mass
//! bridge mill whose modes, cross coupling and noise come from its structure and sensor
//! models, not from modal superposition): a one-pose twin from a healthy impact test at
//! the centre, then the hidden-effect cases there that this twin's band can see. Judged
//! against the generator's answers. (What it still misses is listed in the README.)

use crate::common::{f64_list, mtwin, s, stderr, tmp};
use lumped::effects::{case, case_with, CaseOptions, Effect};
use lumped::measure::{impact_record, Setup};
use lumped::structure::{Machine, CENTRE};
use std::path::{Path, PathBuf};

fn diagnose(twin: &Path, files: &[PathBuf], out: &Path) -> serde_json::Value {
    let mut args = vec!["diagnose", "-q", "--twin", s(twin)];
    args.extend(files.iter().map(|p| s(p)));
    args.extend(["--out", s(out)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    serde_json::from_str(&std::fs::read_to_string(out.join("diagnosis.json")).expect("json"))
        .expect("diagnosis json")
}

/// A healthy impact test at the centre (hammer along x and along y, 5 hits each, seeds
/// `seed0` and `seed0 + 1`) in `dir` and its one-pose twin, identified with the defaults:
/// (the impact files, the twin file).
fn centre_twin(dir: &Path, machine: &Machine, seed0: u64) -> (Vec<PathBuf>, PathBuf) {
    let setup = Setup::impact();
    let mut files = Vec::new();
    for (a, name) in [(0usize, "x"), (1, "y")] {
        let p = dir.join(format!("imp_{name}.csv"));
        impact_record(machine, &setup, CENTRE, a, 5, 2.0, seed0 + a as u64)
            .write_csv(&p)
            .expect("write");
        files.push(p);
    }
    let twin = dir.join("twin.json");
    let mut args = vec!["identify", "-q"];
    args.extend(files.iter().map(|p| s(p)));
    args.extend(["--out", s(&twin)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    (files, twin)
}

/// The diagnosis of `effect`'s case for `seed` on the nominal lumped mill against the
/// one-pose twin of that seed's centre impact test (as
/// `lumped::effects::write_diagnosis_material` makes them).
fn diagnose_effect_case(effect: Effect, seed: u64) -> serde_json::Value {
    diagnose_with_answer(effect, seed).0
}

/// [`diagnose_effect_case`] with the generator's answer: (diagnosis, answer), both
/// printed.
fn diagnose_with_answer(effect: Effect, seed: u64) -> (serde_json::Value, serde_json::Value) {
    diagnose_case_with(effect, seed, &CaseOptions::default())
}

/// [`diagnose_with_answer`] of the case made with options `o`.
fn diagnose_case_with(
    effect: Effect,
    seed: u64,
    o: &CaseOptions,
) -> (serde_json::Value, serde_json::Value) {
    let dir = tmp();
    let machine = Machine::nominal();
    let (_, twin) = centre_twin(dir.path(), &machine, seed * 1000 + 700);
    let c = case_with(&machine, effect, seed, o);
    let files = write_records(dir.path(), &c);
    let d = diagnose(&twin, &files, &dir.path().join("out"));
    eprintln!(
        "seed {seed}: {} {} | truth {}",
        d["cause"], d["details"], c.answer
    );
    (d, c.answer)
}

/// [`diagnose_case_with`] of the effect recorded in milling (two cuts) instead of impacts.
fn diagnose_milling_case(effect: Effect, seed: u64) -> (serde_json::Value, serde_json::Value) {
    let o = CaseOptions {
        milling_data: true,
        ..CaseOptions::default()
    };
    diagnose_case_with(effect, seed, &o)
}

/// A case's records written to `dir` under their own names.
fn write_records(dir: &Path, c: &lumped::effects::Case) -> Vec<PathBuf> {
    c.records
        .iter()
        .map(|(name, r)| {
            let p = dir.join(name);
            r.write_csv(&p).expect("write");
            p
        })
        .collect()
}

#[test]
fn lumped_one_pose_twin_diagnoses_healthy_disturbance_and_delay() {
    let dir = tmp();
    let machine = Machine::nominal();
    let (healthy, twin) = centre_twin(dir.path(), &machine, 700);

    // its own healthy hits: nothing to report
    let d = diagnose(&twin, &healthy, &dir.path().join("self"));
    assert_eq!(d["cause"], "none", "{d}");

    // seed 2's outside vibration: two milling records whose tones have different phases
    // (the held-out check fits each record's phase on its own building part)
    for (effect, seed) in [
        (Effect::Healthy, 1),
        (Effect::Disturbance, 1),
        (Effect::TimeDelay, 1),
        (Effect::Disturbance, 2),
    ] {
        let c = case(&machine, effect, seed);
        let files: Vec<PathBuf> = c
            .records
            .iter()
            .map(|(name, r)| {
                let p = dir.path().join(format!("{effect:?}{seed}_{name}"));
                r.write_csv(&p).expect("write");
                p
            })
            .collect();
        let d = diagnose(&twin, &files, &dir.path().join(format!("{effect:?}{seed}")));
        let want = c.answer["cause"].as_str().unwrap_or("?");
        eprintln!("{effect:?}: {} (want {want}) {}", d["cause"], d["details"]);
        assert_eq!(d["cause"], want, "{d}");
        let det = &d["details"];
        let truth = &c.answer["details"];
        match effect {
            Effect::Disturbance => {
                let found = f64_list(&det["freq_hz"]);
                let want = f64_list(&truth["freq_hz"]);
                assert_eq!(found.len(), want.len(), "{found:?} vs {want:?}");
                for f in &want {
                    assert!(
                        found.iter().any(|g| (g / f - 1.0).abs() < 0.01),
                        "{found:?} vs {want:?}"
                    );
                }
                assert!(d["fit_after_pct"].as_f64() > d["fit_before_pct"].as_f64());
            }
            Effect::TimeDelay => {
                let (got, want) = (
                    det["delay_s"].as_f64().unwrap_or(f64::NAN),
                    truth["delay_s"].as_f64().unwrap_or(f64::NAN),
                );
                assert!((got / want - 1.0).abs() < 0.1, "delay {got} vs {want}");
            }
            Effect::Healthy => {
                // the static part of the misfit: the mean deflection of the held-out parts
                // (the last 30 % of each cut) as the records have it, and its share
                let sd = &det["static_deflection"];
                for (a, name) in ["x", "y"].iter().enumerate() {
                    let want = c
                        .records
                        .iter()
                        .map(|(_, r)| {
                            let v = &r.response[a];
                            let h = v.len() * 7 / 10;
                            v[h..].iter().sum::<f64>() / (v.len() - h) as f64
                        })
                        .sum::<f64>()
                        / c.records.len() as f64;
                    let got = sd["axes"][name]["measured_m"].as_f64().unwrap_or(f64::NAN);
                    assert!(
                        (got / want - 1.0).abs() < 0.01,
                        "{name}: {got} vs {want}: {sd}"
                    );
                }
                let share = sd["share_of_misfit"].as_f64().unwrap_or(f64::NAN);
                assert!((0.0..=1.0).contains(&share), "{sd}");
            }
            _ => {}
        }
    }
}

/// Fit [%] of `twin` at `pose` against the generator's receptance with the campaign's
/// accelerometer mass, channel out/in, on `band`.
fn twin_vs_loaded_truth(
    twin: &identify::twin::Twin,
    machine: &Machine,
    pose: [f64; 3],
    (out, inp): (usize, usize),
    band: (f64, f64),
    tip_mass: f64,
) -> f64 {
    use identify::axis::{Axis, Channel};
    let freqs = lumped::frf::linspace(band.0, band.1, 600);
    let truth = machine.analytic_frf_loaded(pose, &freqs, tip_mass);
    let m = twin.model_at(pose).expect("model at pose");
    let ax = |i: usize| [Axis::X, Axis::Y, Axis::Z][i];
    let ci = m
        .channel_index(Channel {
            output: ax(out),
            input: ax(inp),
        })
        .expect("channel in the twin");
    let t = truth.channel(out, inp);
    let e: Vec<_> = freqs.iter().map(|&f| m.eval_hz(ci, f)).collect();
    identify::frf::fit_percent(&t, &e)
}

/// One-pose twins from two centre impact tests whose hits come 0.29 s apart (lines
/// 3.4 Hz apart; `cases --seed 13 --centre-only --centre-noise 0.1`, an accelerometer
/// 20 dB quieter, and `cases --seed 9`), judged against the truth on a 0.25 Hz grid (xx
/// and yy, 30-2500 Hz). Seed 13's fit held a mode with 0.001 % damping inside its band,
/// between two lines (39.5 Hz), whose peak stood 1000 times above the lines around it:
/// fit to the measured lines 98 %, to the truth −133 %. Seed 9's first fit held one at
/// 73.8 Hz (0.014 %), and the hits separated over its poles left xx at 46 %. Identify
/// gives such a mode the damping of one line's width or removes it, whichever fits the
/// data better (when that costs the lines at most a point): 97.5 / 97.3 % and
/// 86.3 / 86.7 %.
#[test]
fn lumped_one_pose_twin_holds_no_peak_between_the_lines() {
    let dir = tmp();
    let machine = Machine::nominal();
    for (seed, noise, least) in [(13u64, 0.1, 90.0), (9, 1.0, 80.0)] {
        let (files, setup) = centre_impacts(dir.path(), &machine, seed, noise);
        let twin = identify_quietly(&files, &dir.path().join(format!("s{seed}.json")));
        let m = twin.model_at(CENTRE).expect("model at the centre");
        let freqs = lumped::frf::linspace(30.0, 2500.0, 9881);
        let truth = machine.analytic_frf_loaded(CENTRE, &freqs, setup.tip_mass);
        for (c, (out, inp)) in [("xx", (0, 0)), ("yy", (1, 1))] {
            let ci = m
                .channel_index(identify::axis::Channel {
                    output: [identify::axis::Axis::X, identify::axis::Axis::Y][out],
                    input: [identify::axis::Axis::X, identify::axis::Axis::Y][inp],
                })
                .expect("channel");
            let e: Vec<_> = freqs.iter().map(|&f| m.eval_hz(ci, f)).collect();
            let fit = identify::frf::fit_percent(&truth.channel(out, inp), &e);
            println!("seed {seed}, accelerometer noise x{noise}: {c} vs truth {fit:.2} %");
            assert!(fit >= least, "seed {seed} {c}: {fit:.2} % vs the truth");
        }
    }
}

/// A held channel (one pose; its numerators fitted with the poles of the direct channels
/// held) that fits its own FRF far below what the FRF's noise allows is solved again
/// under the other weightings, poles held. Second generator, effect seed 9's centre
/// impact test: `zx`, trusted in 138-2300 Hz, fitted its measured accelerance there at
/// −190.4 % (noise limit 74.4 %) and the analytic truth over 30-2500 Hz at 17.1 % as
/// receptance; now 58.6 % and 40.5 %.
#[test]
fn lumped_held_cross_channel_is_solved_again_when_far_below_its_noise() {
    let dir = tmp();
    let machine = Machine::nominal();
    let (_, twin) = centre_twin(dir.path(), &machine, 9 * 1000 + 700);
    let twin = identify::twin::Twin::load(&twin).expect("twin loads");
    let zx = identify::axis::Channel {
        output: identify::axis::Axis::Z,
        input: identify::axis::Axis::X,
    };
    let own = twin.poses[0]
        .fit
        .iter()
        .find(|f| f.channel == zx)
        .expect("the twin holds zx");
    println!(
        "zx fits its own FRF at {:.2} % (noise limit {:?})",
        own.fit_pct, own.noise_limit_pct
    );
    assert!(
        own.fit_pct >= 50.0,
        "zx {:.2} % of its own FRF",
        own.fit_pct
    );
    let m = twin.model_at(CENTRE).expect("model at the centre");
    let ci = m.channel_index(zx).expect("zx");
    let freqs = lumped::frf::linspace(30.0, 2500.0, 4941);
    let truth = machine.analytic_frf_loaded(CENTRE, &freqs, Setup::impact().tip_mass);
    let e: Vec<_> = freqs.iter().map(|&f| m.eval_hz(ci, f)).collect();
    let fit = identify::frf::fit_percent(&truth.channel(2, 0), &e);
    println!("zx vs the truth (receptance, 30-2500 Hz): {fit:.2} %");
    assert!(fit >= 30.0, "zx {fit:.2} % vs the truth");
}

/// A one-pose twin from a sensor 20 dB quieter than the one that records the new data
/// (second generator, accelerometer noise ×0.1 for the twin's centre impact test), and
/// healthy hits at three force levels (the cubic-joint case's linear control) at effect
/// seeds 4, 11 and 12: `none`. The twin is sounder than the data, so their noise must not
/// pass for a misfit. Before, each was `unexplained`: seed 4's twin holds its `xy` and
/// `zy` as models of noise (fit to its own FRF −1.4 and −0.3 %), against which the data's
/// noise-level lines that pass the coherence threshold by chance (4 averages) were 5–7 σ
/// (local misfit 4.1 σ > 3); seeds 11 and 12 had such chance lines in `yy` near an
/// antiresonance and in `zx` (local 3.2 and 3.4 σ). A channel the twin fits no better
/// than zero now counts as one it holds empty, and a few hits' standard error takes the
/// median coherence of the line and its two neighbours.
#[test]
fn lumped_twin_from_a_quieter_sensor_calls_healthy_hits_none() {
    let machine = Machine::nominal();
    for seed in [4u64, 11, 12] {
        let dir = tmp();
        let (files, _) = centre_impacts(dir.path(), &machine, seed, 0.1);
        let twin = dir.path().join("twin.json");
        identify_quietly(&files, &twin);
        let control = CaseOptions {
            linear_control: true,
            ..CaseOptions::default()
        };
        let c = case_with(&machine, Effect::Nonlinearity, seed, &control);
        let data = write_records(dir.path(), &c);
        let d = diagnose(&twin, &data, &dir.path().join("out"));
        eprintln!("seed {seed}: {} {}", d["cause"], d["details"]);
        assert_eq!(d["cause"], "none", "seed {seed}: healthy hits named {d}");
    }
}

/// Effect seed `seed`'s healthy centre impact test (hammer along x and along y, 5 hits
/// each, as `lumped::effects::write_diagnosis_material` makes it) with the accelerometer's
/// noise (white and 1/f) scaled by `noise`, written to `dir`: (the files, the setup).
fn centre_impacts(dir: &Path, machine: &Machine, seed: u64, noise: f64) -> (Vec<PathBuf>, Setup) {
    let mut setup = Setup::impact();
    setup.response_noise.white *= noise;
    setup.response_noise.pink *= noise;
    let mut files = Vec::new();
    for (a, name) in [(0usize, "x"), (1, "y")] {
        let p = dir.join(format!("s{seed}_imp_{name}.csv"));
        impact_record(
            machine,
            &setup,
            CENTRE,
            a,
            5,
            2.0,
            seed * 1000 + 700 + a as u64,
        )
        .write_csv(&p)
        .expect("write");
        files.push(p);
    }
    (files, setup)
}

/// `mtwin identify -q FILES --out OUT` with the defaults, which must succeed: the twin.
fn identify_quietly(files: &[PathBuf], out: &Path) -> identify::twin::Twin {
    let mut args = vec!["identify", "-q"];
    args.extend(files.iter().map(|p| s(p)));
    args.extend(["--out", s(out)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    identify::twin::Twin::load(out).expect("twin loads")
}

/// The 3x3x2 grid of the lumped campaigns (x, then y, then z innermost).
fn campaign_grid() -> Vec<[f64; 3]> {
    let mut grid = Vec::new();
    for x in [0.1, 0.4, 0.7] {
        for y in [0.1, 0.3, 0.5] {
            for z in [0.05, 0.25] {
                grid.push([x, y, z]);
            }
        }
    }
    grid
}

/// An 18-pose impact campaign of `machine` in `dir` (hammer along x and along y at every
/// pose of [`campaign_grid`], 5 hits, accelerations; record seeds `seed0 + 2k + a`, as
/// `lumped`'s `dump` example writes them): the grid and the files.
fn campaign_files(dir: &Path, machine: &Machine, seed0: u64) -> (Vec<[f64; 3]>, Vec<PathBuf>) {
    campaign_files_at(
        dir,
        machine,
        seed0,
        &(0..campaign_grid().len()).collect::<Vec<_>>(),
    )
}

/// [`campaign_files`] at the poses `keep` of [`campaign_grid`] only (the same records
/// there): those poses and the files.
fn campaign_files_at(
    dir: &Path,
    machine: &Machine,
    seed0: u64,
    keep: &[usize],
) -> (Vec<[f64; 3]>, Vec<PathBuf>) {
    use rayon::prelude::*;
    let setup = Setup::impact();
    let grid = campaign_grid();
    let jobs: Vec<(usize, usize)> = keep.iter().flat_map(|&k| [(k, 0), (k, 1)]).collect();
    let files = jobs
        .par_iter()
        .map(|&(k, a)| {
            let p = dir.join(format!("g{k:02}_{}.csv", ["x", "y"][a]));
            impact_record(
                machine,
                &setup,
                grid[k],
                a,
                5,
                2.0,
                seed0 + 2 * k as u64 + a as u64,
            )
            .write_csv(&p)
            .expect("write");
            p
        })
        .collect();
    (keep.iter().map(|&k| grid[k]).collect(), files)
}

/// On a random lumped machine (seed 2) the z response to the y hammer is coherent at 10
/// of the 18 poses: the campaign keeps that channel, so every pose model carries it
/// (before, identify failed: "the model at pose ... has other modes or channels than the
/// first pose"). Where a pose's own data show no coherent response it is stored as zero
/// and steers nothing, and the plan says so. The poses' own orders differ (y direction:
/// 3 to 20 modes): the twin kept is the one of the campaign's variants that fits the
/// measured poses best, judged against the analytic receptance here (xx, yy, 150-2500
/// Hz; with the own orders only: mean 93.8 %, worst 86.3 %).
#[test]
fn lumped_campaign_keeps_a_channel_coherent_at_some_poses_in_every_pose_model() {
    use identify::axis::{Axis, Channel};
    let dir = tmp();
    let machine = Machine::random(2);
    let setup = Setup::impact();
    let (grid, files) = campaign_files(dir.path(), &machine, 2000);
    let twin_path = dir.path().join("twin.json");
    let twin = identify_quietly(&files, &twin_path);
    let zy = Channel::new(Axis::Z, Axis::Y);
    let (mut held, mut fitted) = (0, 0);
    for p in &twin.poses {
        let ci = p.model.channel_index(zy).expect("zy in every pose model");
        let zero = p.model.channels[ci]
            .num
            .iter()
            .all(|n| n.b0 == 0.0 && n.b1 == 0.0);
        let plan = p.plan.as_ref().expect("plan");
        let d = plan
            .channels
            .iter()
            .find(|d| d.channel == zy)
            .expect("zy judged");
        let says = d.reason.contains("stored as zero at this pose");
        assert_eq!(zero, says, "pose {:?}: {}", p.pose, d.reason);
        if zero {
            held += 1;
        } else {
            fitted += 1;
        }
    }
    assert!(
        held > 0 && fitted > held,
        "zy held at {held}, fitted at {fitted} poses"
    );
    let fits: Vec<f64> = (grid.iter())
        .flat_map(|&p| {
            [(0, 0), (1, 1)].map(|c| {
                twin_vs_loaded_truth(&twin, &machine, p, c, (150.0, 2500.0), setup.tip_mass)
            })
        })
        .collect();
    let mean = fits.iter().sum::<f64>() / fits.len() as f64;
    let worst = fits.iter().cloned().fold(f64::INFINITY, f64::min);
    eprintln!("lumped random machine 2, campaign vs truth: mean {mean:.2} %, worst {worst:.2} %");
    assert!(
        mean >= 95.0 && worst >= 90.0,
        "measured poses vs truth: mean {mean:.2} %, worst {worst:.2} %"
    );
    // the twin answers between the poses too
    let o = mtwin(&[
        "eval",
        "-q",
        "--twin",
        s(&twin_path),
        "--at",
        "0.25,0.2,0.15",
        "--out",
        s(&dir.path().join("u0.csv")),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Six poses of the nominal machine's campaign (x = 0.4 m; the records of `lumped`'s
/// `dump --seed 2`): at z = 0.25 m the x direction holds a 127-131 Hz mode that the
/// z = 0.05 m poses do not, and the tracked models at the common order lost it there (a
/// pole common to every pose at 147 Hz stood in): xx vs the truth 38.1 / 17.5 / 20.3 %
/// at the upper poses (30-2500 Hz), where each pose's own fit holds the mode. Identify
/// adds a mode that a pose's own fit holds and the tracked models lost, at that pose
/// (zero at the others), and says so in the plan: 72.4 / 41.9 / 55.4 %.
#[test]
fn lumped_campaign_keeps_a_mode_that_only_some_poses_hold() {
    let dir = tmp();
    let machine = Machine::nominal();
    let setup = Setup::impact();
    let (poses, files) = campaign_files_at(dir.path(), &machine, 2000, &[6, 7, 8, 9, 10, 11]);
    let twin = identify_quietly(&files, &dir.path().join("twin.json"));
    let upper: Vec<f64> = (poses.iter())
        .filter(|p| p[2] > 0.2)
        .map(|&p| twin_vs_loaded_truth(&twin, &machine, p, (0, 0), (30.0, 2500.0), setup.tip_mass))
        .collect();
    let mean = upper.iter().sum::<f64>() / upper.len() as f64;
    eprintln!("upper poses xx vs truth, 30-2500 Hz: {upper:.1?}");
    let plan = twin.poses[0].plan.as_ref().expect("plan");
    assert!(
        plan.alternatives
            .iter()
            .any(|a| a.contains("the tracked models lost there")),
        "the plan names the added modes: {:?}",
        plan.alternatives
    );
    assert!(
        mean >= 45.0 && upper.iter().all(|&f| f >= 30.0),
        "upper poses xx vs truth: {upper:.1?}"
    );
}

/// An 18-pose impact campaign on the lumped mill (3x3x2 grid, hammer along x and along
/// y, accelerations, cross channels without coherent response), identified with the
/// defaults, judged at the measured and at three unmeasured poses against the analytic
/// receptance (xx, yy, 150-2500 Hz: below, the accelerometer's noise hides the
/// response). The x and y directions do not couple: identify must fit and track them
/// apart (with common poles the measured poses fell to 74 % worst, 86 % mean).
#[test]
fn lumped_campaign_twin_fits_the_truth_at_measured_and_unmeasured_poses() {
    let dir = tmp();
    let machine = Machine::nominal();
    let setup = Setup::impact();
    let (grid, files) = campaign_files(dir.path(), &machine, 1000);
    let twin_path = dir.path().join("twin.json");
    let mut args = vec!["identify"];
    args.extend(files.iter().map(|p| s(p)));
    args.extend(["--out", s(&twin_path)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &stderr(&o);
    assert!(
        text.contains("fitted with separate poles"),
        "the plan names the split of the force directions:\n{text}"
    );
    let twin = identify::twin::Twin::load(&twin_path).expect("twin loads");
    let band = (150.0, 2500.0);
    let score = |p: [f64; 3]| {
        [(0, 0), (1, 1)]
            .iter()
            .map(|&c| twin_vs_loaded_truth(&twin, &machine, p, c, band, setup.tip_mass))
            .fold(f64::INFINITY, f64::min)
    };
    let measured: Vec<f64> = grid.iter().map(|&p| score(p)).collect();
    let unmeasured: Vec<f64> = [[0.25, 0.2, 0.15], [0.55, 0.45, 0.1], [0.6, 0.15, 0.2]]
        .iter()
        .map(|&p| score(p))
        .collect();
    let mean = measured.iter().sum::<f64>() / measured.len() as f64;
    let worst = measured.iter().cloned().fold(f64::INFINITY, f64::min);
    let u_worst = unmeasured.iter().cloned().fold(f64::INFINITY, f64::min);
    eprintln!(
        "lumped campaign vs truth: measured worst {worst:.2} mean {mean:.2} %, unmeasured {unmeasured:.2?}"
    );
    assert!(mean >= 90.0, "measured mean {mean:.2} % ({measured:.1?})");
    assert!(
        worst >= 80.0,
        "measured worst {worst:.2} % ({measured:.1?})"
    );
    assert!(u_worst >= 75.0, "unmeasured {unmeasured:.2?}");
    // 30-2500 Hz: the 73 Hz x mode, the largest receptance peak, is in the twin (its
    // coherence is 0.87-0.95 on its peak line, its flanks sink into 1/f sensor noise);
    // without it the measured poses fitted 43 % mean in xx and yy
    let wide = (30.0, 2500.0);
    let wide_fits: Vec<f64> = (grid.iter())
        .flat_map(|&p| {
            [(0, 0), (1, 1)]
                .map(|c| twin_vs_loaded_truth(&twin, &machine, p, c, wide, setup.tip_mass))
        })
        .collect();
    let wide_mean = wide_fits.iter().sum::<f64>() / wide_fits.len() as f64;
    eprintln!("30-2500 Hz: measured poses xx, yy mean {wide_mean:.2} % ({wide_fits:.1?})");
    assert!(
        wide_mean >= 65.0,
        "30-2500 Hz mean {wide_mean:.2} % ({wide_fits:.1?})"
    );
    // This is the `dump` example's seed-1 campaign. Two of its tracked slots wander: a
    // 70-75 Hz mode held 4.7 Hz at 124 % and 3.9 Hz at 168 % damping at two poses, another
    // 66-232 Hz. No pole for every pose fits the measured poses within a point, so they
    // stayed as fitted, and the twin between poses interpolated them: xx 30-2500 Hz at the
    // unmeasured pose (0.25, 0.2, 0.15) 39.9 % while the worst measured pose fitted 57.7 %.
    // Each pose where such a slot departs wildly from its nearest poses takes their pole
    // where that costs its fit at most a point (the plan names it): no unmeasured pose may
    // fall more than 2 points below the worst measured one (the rule). Since
    // the hits that ring into the next are separated (a 143 Hz mode keeps 1.0-1.7 % at a
    // few poses) no slot of this campaign wanders any more; the records as measured
    // still make them wander, and the repair must name them.
    let raw_path = dir.path().join("twin_as_measured.json");
    let mut args = vec!["identify", "-q", "--ringing-hits", "as-measured"];
    args.extend(files.iter().map(|p| s(p)));
    args.extend(["--out", s(&raw_path)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let file = std::fs::read_to_string(&raw_path).expect("twin file");
    assert!(
        file.contains("take their nearest poses' pole"),
        "the twin's plan names the repaired poses"
    );
    let xx = |p: [f64; 3]| {
        twin_vs_loaded_truth(&twin, &machine, p, (0, 0), (30.0, 2500.0), setup.tip_mass)
    };
    let measured_xx: Vec<f64> = grid.iter().map(|&p| xx(p)).collect();
    let unmeasured_xx: Vec<f64> = [[0.25, 0.2, 0.15], [0.55, 0.45, 0.1], [0.6, 0.15, 0.2]]
        .iter()
        .map(|&p| xx(p))
        .collect();
    let worst_xx = measured_xx.iter().cloned().fold(f64::INFINITY, f64::min);
    assert!(
        unmeasured_xx.iter().all(|&u| u >= worst_xx - 2.0),
        "xx 30-2500 Hz: unmeasured {unmeasured_xx:.1?} vs the worst measured {worst_xx:.1}"
    );
}

/// A logarithmic sweep 20-2500 Hz along x at the centre (displacement sensor, 8 s then
/// 1.5 s at rest), identified with the defaults: the twin's xx must fit the analytic
/// receptance (30-2400 Hz) at least as well as the raw full-record ratio FFT(dx)/FFT(fx)
/// of the same file does. One record has no averages: its coherence comes from the
/// FRF's line-to-line scatter, which also leaves the noise-only yx channel out (before:
/// band cut at 1.7 kHz, yx fitted, 20.8 % vs truth).
#[test]
fn lumped_log_sweep_twin_beats_the_raw_ratio_of_its_record() {
    use num_complex::Complex64;
    let dir = tmp();
    let machine = Machine::nominal();
    let rec = lumped::measure::log_sweep_record(&machine, CENTRE, 1500);
    let path = dir.path().join("sweep.csv");
    rec.write_csv(&path).expect("write");
    let twin_path = dir.path().join("twin.json");
    let o = mtwin(&["identify", s(&path), "--out", s(&twin_path)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &stderr(&o);
    assert!(text.contains("line-to-line scatter"), "{text}");
    let twin = identify::twin::Twin::load(&twin_path).expect("twin");
    let band = (30.0, 2400.0);
    let fit_twin = twin_vs_loaded_truth(&twin, &machine, CENTRE, (0, 0), band, 0.0);
    // the raw ratio of the record, read back as mtwin reads it
    let ts = identify::read::read_timeseries(&path).expect("read");
    let fx = ts.force(identify::axis::Axis::X).expect("fx").to_vec();
    let dx = ts.response(identify::axis::Axis::X).expect("dx").to_vec();
    let n = fx.len();
    let mut planner = rustfft::FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let spec = |v: &[f64]| {
        let mut b: Vec<Complex64> = v.iter().map(|&x| Complex64::new(x, 0.0)).collect();
        fft.process(&mut b);
        b
    };
    let (fxs, dxs) = (spec(&fx), spec(&dx));
    let dt = ts.dt;
    let (mut freqs, mut ratio) = (Vec::new(), Vec::new());
    for k in 1..n / 2 {
        let fk = k as f64 / (n as f64 * dt);
        if fk >= band.0 && fk <= band.1 {
            freqs.push(fk);
            ratio.push(dxs[k] / fxs[k]);
        }
    }
    let truth = machine.analytic_frf(CENTRE, &freqs).channel(0, 0);
    let fit_raw = identify::frf::fit_percent(&truth, &ratio);
    eprintln!("lumped log sweep xx vs truth: twin {fit_twin:.2} %, raw ratio {fit_raw:.2} %");
    assert!(
        fit_twin >= fit_raw,
        "twin {fit_twin:.2} % below the raw ratio {fit_raw:.2} %"
    );
}

/// One pose of the lumped mill identified alone with the defaults (hammer along x and
/// along y, responses x, y, z; the z and cross channels coherent in part of the band
/// only): the twin's xx and yy must fit the analytic receptance (150-2500 Hz) at least
/// as well as mtwin's own H1 of the same files, within 2.5 points. The partly coherent
/// channels do not steer the poles; with them steering, the twin fell below its H1 at
/// all three poses (xx 90.0 vs 96.5 % and 65.8 vs 95.0 %, yy 88.9 vs 96.5 %).
#[test]
fn lumped_one_pose_twin_fits_the_truth_as_well_as_its_h1() {
    use identify::read::read_frf_csv;
    use rayon::prelude::*;
    let dir = tmp();
    let machine = Machine::nominal();
    let setup = Setup::impact();
    let poses: [[f64; 3]; 3] = [[0.4, 0.1, 0.05], [0.7, 0.3, 0.25], [0.7, 0.5, 0.05]];
    let results: Vec<String> = poses
        .par_iter()
        .enumerate()
        .map(|(k, &pose)| {
            let files: Vec<PathBuf> = (0..2)
                .map(|a| {
                    let p = dir.path().join(format!("p{k}_{}.csv", ["x", "y"][a]));
                    impact_record(
                        &machine,
                        &setup,
                        pose,
                        a,
                        5,
                        2.0,
                        3000 + 2 * k as u64 + a as u64,
                    )
                    .write_csv(&p)
                    .expect("write");
                    p
                })
                .collect();
            let twin_path = dir.path().join(format!("twin{k}.json"));
            let h1_path = dir.path().join(format!("h1_{k}.csv"));
            for (cmd, out) in [("identify", &twin_path), ("frf", &h1_path)] {
                let mut args = vec![cmd, "-q"];
                args.extend(files.iter().map(|p| s(p)));
                args.extend(["--out", s(out)]);
                let o = mtwin(&args);
                assert!(o.status.success(), "{cmd}: {}", stderr(&o));
            }
            let twin = identify::twin::Twin::load(&twin_path).expect("twin loads");
            let h1 = read_frf_csv(&h1_path).expect("H1 file");
            let lines: Vec<usize> = (0..h1.freqs_hz.len())
                .filter(|&i| (150.0..=2500.0).contains(&h1.freqs_hz[i]))
                .collect();
            let freqs: Vec<f64> = lines.iter().map(|&i| h1.freqs_hz[i]).collect();
            let truth = machine.analytic_frf_loaded(pose, &freqs, setup.tip_mass);
            let m = twin.model_at(pose).expect("model at pose");
            let mut report = format!("pose {pose:?}:");
            for (i, ax) in [identify::axis::Axis::X, identify::axis::Axis::Y]
                .into_iter()
                .enumerate()
            {
                let ch = identify::axis::Channel {
                    output: ax,
                    input: ax,
                };
                let t = truth.channel(i, i);
                let ci = m.channel_index(ch).expect("direct channel in the twin");
                let e: Vec<_> = freqs.iter().map(|&f| m.eval_hz(ci, f)).collect();
                let hc = h1.channel(ch).expect("direct channel in the H1");
                let h: Vec<_> = lines.iter().map(|&l| hc.h[l]).collect();
                let (fit_twin, fit_h1) = (
                    identify::frf::fit_percent(&t, &e),
                    identify::frf::fit_percent(&t, &h),
                );
                report += &format!(" {ch} twin {fit_twin:.2} % H1 {fit_h1:.2} %;");
                assert!(
                    fit_twin >= fit_h1 - 2.5,
                    "{report} the twin is worse than the H1 it came from"
                );
            }
            report
        })
        .collect();
    eprintln!("{}", results.join("\n"));
}

/// Healthy milling of the lumped mill (effect seed 4) against the one-pose twin of its
/// centre impact test: whatever misfit the twin leaves (its band starts above the 73 Hz
/// modes, the impacts carried a 12 g accelerometer), no catalogue cause may be named
/// whose held-out prediction gets worse where it acts. Before the band guard this case
/// was named `cross_coupling` (zx) while its band-passed held-out fit fell from 89.0 to
/// 77.6 %.
#[test]
fn lumped_healthy_milling_names_no_cause_that_predicts_its_band_worse() {
    let seed = 4u64;
    let d = diagnose_effect_case(Effect::Healthy, seed);
    let cause = d["cause"].as_str().unwrap_or("?");
    eprintln!("healthy seed {seed}: {cause} {}", d["details"]);
    let (before, after) = (
        d["fit_before_pct"].as_f64().unwrap_or(f64::NAN),
        d["fit_after_pct"].as_f64().unwrap_or(f64::NAN),
    );
    assert!(
        matches!(cause, "none" | "unexplained") || after > before,
        "healthy data named {cause} with held-out fit {before:.2} -> {after:.2} %: {d}"
    );
    assert!(
        matches!(cause, "none" | "unexplained"),
        "healthy data named {cause}: {d}"
    );
}

/// Healthy milling on the second generator (effect seed 3) whose FRF estimate misfits the
/// twin near the 2 kHz tool mode (up to 8.7 σ: the cutting forces along x, y and z rise
/// and fall together, so the multi-input estimate cannot tell the channels apart at some
/// lines), while the twin predicts the held-out responses there well: every candidate
/// that follows that FRF predicts them worse. That is no evidence against the twin: the
/// verdict is `none`, and the diagnosis says why. Before this rule it was `unexplained`
/// (a false alarm on a healthy machine).
#[test]
fn lumped_healthy_milling_whose_frf_misfit_the_held_out_data_contradict_is_none() {
    healthy_none_because(3, "predicts the held-out responses worse");
}

/// Healthy milling of effect seed `seed` comes back `none`, its
/// `frf_misfit_contradicted` saying `says`.
fn healthy_none_because(seed: u64, says: &str) {
    let d = diagnose_effect_case(Effect::Healthy, seed);
    let cause = d["cause"].as_str().unwrap_or("?");
    eprintln!("healthy seed {seed}: {cause} {}", d["details"]);
    assert_eq!(cause, "none", "healthy data named {cause}: {d}");
    let why = d["details"]["frf_misfit_contradicted"]
        .as_str()
        .unwrap_or("");
    assert!(
        why.contains(says),
        "the none verdict should say why the held-out data contradict the FRF misfit ({says:?}): {d}"
    );
}

/// A guide turned on the second generator (effect seed 4: the 137 Hz y mode now also moves
/// the tool along x): the data gain a yx (and xy) response that the twin does not have,
/// and the mode's direct response falls. The diagnosis must name `cross_coupling` in a
/// cross channel between x and y near that mode, and the extended twin must predict the
/// held-out responses in that band better than the twin by more than a point. Before the
/// turned-mode refit the missing channel's numerators were fitted for every mode on a
/// dozen lines around 140 Hz and the extended twin's simulation blew up (fit -1e13 %).
#[test]
fn lumped_turned_guide_is_named_cross_coupling() {
    let (d, answer) = diagnose_with_answer(Effect::CrossCoupling, 4);
    let cause = d["cause"].as_str().unwrap_or("?");
    assert_eq!(cause, "cross_coupling", "{d}");
    let ch = d["details"]["channel"].as_str().unwrap_or("");
    assert!(ch == "yx" || ch == "xy", "channel {ch}: {d}");
    // the turned guide splits the 137/140 Hz x/y pair; the new cross peak sits at the
    // lower one (a single mode refitted stayed 2 % above it)
    let f = d["details"]["freq_hz"].as_f64().unwrap_or(f64::NAN);
    let want = answer["details"]["freq_hz"].as_f64().unwrap_or(f64::NAN);
    assert!((f / want - 1.0).abs() < 0.01, "freq {f} Hz vs {want}: {d}");
    let (before, after) = (
        d["fit_before_pct"].as_f64().unwrap_or(f64::NAN),
        d["fit_after_pct"].as_f64().unwrap_or(f64::NAN),
    );
    assert!(
        after > before + 1.0,
        "band fit {before:.2} -> {after:.2} %: {d}"
    );
}

/// Healthy milling on the second generator (effect seed 11): the milling FRF estimate
/// claims the twin misses the 2 kHz tool mode's response by about 29 % (its fit there
/// would be 71 %), while the twin predicts the held-out responses in that band at 94 %,
/// and no candidate predicts any band better. The estimate is contradicted by the
/// responses themselves (no candidate need follow it): `none`, and the diagnosis says
/// why. Before this test it was `unexplained` (a false alarm on a healthy machine). Since
/// a retune of several modes is tried too, one candidate follows that FRF and predicts
/// the band worse: the diagnosis gives both reasons.
#[test]
fn lumped_healthy_milling_whose_frf_the_held_out_band_contradicts_is_none() {
    healthy_none_because(11, "predicts the held-out responses there at");
}

/// A rear bearing whose damping grew 1.7 times at an unchanged frequency (second
/// generator, effect seed 6: the 566 Hz mode). An added mode beside the twin's imitates
/// the wider peak (band gain 16.7 points), but the retune of the twin's own mode predicts
/// the held-out responses in that band better (18.4) with fewer parameters: the diagnosis
/// must be `mode_change` near that mode with its damping raised. Before, the retune's
/// local misfit (14.4 -> 9.0) missed the halving the band test asks of a candidate alone,
/// and the new mode was named.
#[test]
fn lumped_wider_peak_is_named_mode_change_not_a_new_mode() {
    let seed = 6u64;
    let d = diagnose_effect_case(Effect::ModeChange, seed);
    let cause = d["cause"].as_str().unwrap_or("?");
    eprintln!("damping x1.7 seed {seed}: {cause} {}", d["details"]);
    assert_eq!(cause, "mode_change", "{d}");
    let num = |k: &str| d["details"][k].as_f64().unwrap_or(f64::NAN);
    let f = num("freq_hz");
    assert!((530.0..600.0).contains(&f), "freq {f} Hz: {d}");
    assert!(num("new_damping") > 1.2 * num("damping"), "{d}");
}

/// Seed 4's outside vibration at 867 Hz during milling. Its centre twin once took a
/// 3508 Hz "mode" with ζ = 0.005 % (half-power band 0.3 Hz on 3.2 Hz lines: one noise
/// line fitted) from the order alternatives; every milling simulation rang with it
/// (held-out fit -7876 %) and the disturbance went unnamed. Every mode in the twin's band
/// must be resolved by its lines, and the tone found.
#[test]
fn lumped_twin_holds_no_mode_narrower_than_its_lines_and_names_the_outside_tone() {
    let dir = tmp();
    let machine = Machine::nominal();
    let seed = 4;
    let (_, twin_path) = centre_twin(dir.path(), &machine, seed * 1000 + 700);
    let twin = identify::twin::Twin::load(&twin_path).expect("twin loads");
    for p in &twin.poses {
        let f = &p.frf.freqs_hz;
        let df = f[1] - f[0];
        for m in &p.model.modes {
            let fn_hz = m.wn / (2.0 * std::f64::consts::PI);
            if fn_hz >= p.band_hz[0] && fn_hz <= p.band_hz[1] {
                assert!(
                    2.0 * m.zeta * fn_hz >= 0.25 * df,
                    "mode at {fn_hz:.1} Hz, damping {:.5}, lines {df:.2} Hz apart",
                    m.zeta
                );
            }
        }
    }
    let c = case(&machine, Effect::Disturbance, seed);
    let files = write_records(dir.path(), &c);
    let d = diagnose(&twin_path, &files, &dir.path().join("out"));
    assert_eq!(d["cause"], "disturbance", "{d}");
    let found = f64_list(&d["details"]["freq_hz"]);
    for w in f64_list(&c.answer["details"]["freq_hz"]) {
        assert!(
            found.iter().any(|g| (g / w - 1.0).abs() < 0.01),
            "{found:?} vs {w}"
        );
    }
}

/// Seed 17's centre twin: its zx channel (coherent in part of the band, its numerators
/// solved with the poles of xx and yy held) once got a 2.9 µm/N resonance at 583 Hz
/// where its coherence is below 0.5 (no line weighed there): -7859 % of its measured FRF,
/// written to the twin, and every held-out simulation of diagnose rang with it (the
/// twin's whole-response fit 66 %, its mode change, new mode and pose dependence named
/// wrongly). No channel of a twin may fit worse than its noise allows by far, and worse
/// than no model at all.
#[test]
fn lumped_twin_holds_no_channel_that_runs_away_where_its_coherence_is_low() {
    let dir = tmp();
    let machine = Machine::nominal();
    let seed = 17;
    let (_, twin_path) = centre_twin(dir.path(), &machine, seed * 1000 + 700);
    let twin: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&twin_path).expect("twin")).expect("json");
    for p in twin["poses"].as_array().expect("poses") {
        for f in p["fit"].as_array().expect("fit") {
            let fit = f["fit_pct"].as_f64().unwrap_or(f64::NAN);
            let allowed = f["noise_limit_pct"].as_f64().unwrap_or(0.0).min(0.0);
            assert!(
                fit >= allowed - 10.0,
                "channel {}: fit {fit:.1} %",
                f["channel"]
            );
        }
    }
    let c = case(&machine, Effect::ModeChange, seed);
    let files = write_records(dir.path(), &c);
    let d = diagnose(&twin_path, &files, &dir.path().join("out"));
    assert_eq!(d["cause"], "mode_change", "{d}");
}

/// A joint's change moves every mode it strains, and the mode named is the one that
/// moved. Seed 10: the saddle guide at 0.84x stiffness and 1.9x damping moves the 137 Hz
/// y mode to 131 Hz and widens the 566 Hz x mode (1.67x damping, 1.6 % lower); the
/// larger of the two relative changes once named the 566 Hz mode, whose band then showed
/// no gain (`unexplained`). Seed 18: the ram guide at 0.58x stiffness moves the 137 Hz
/// mode to 125 Hz; retuned together with the 928 Hz mode, the 140 Hz mode was carried
/// off to 202 Hz (the new mode beside it was named instead). Seeds 3 and 5: the saddle
/// guide's damping x2.1, and its stiffness x0.76 (137.1 -> 127.3 Hz), on the y mode of the
/// 137/140-145 Hz x/y pair; retuned together, the pair carried the x mode there and named
/// it (139.4 and 143.8 Hz), for 1-3 % less misfit than the y mode retuned alone.
#[test]
fn lumped_joint_change_names_the_mode_that_moved() {
    for seed in [10u64, 18, 3, 5] {
        let (d, answer) = diagnose_with_answer(Effect::ModeChange, seed);
        assert_eq!(d["cause"], "mode_change", "seed {seed}: {d}");
        let got = |k: &str| d["details"][k].as_f64().unwrap_or(f64::NAN);
        let want = |k: &str| answer["details"][k].as_f64().unwrap_or(f64::NAN);
        assert!(
            (got("freq_hz") / want("freq_hz") - 1.0).abs() < 0.01,
            "seed {seed}: {d}"
        );
        assert!(
            (got("new_freq_hz") / want("new_freq_hz") - 1.0).abs() < 0.02,
            "seed {seed}: {d}"
        );
    }
}

/// Seed 12: the saddle guide's cubic spring moves the 566 Hz mode 1.2 % up between 60 and
/// 1200 N hits (noise-free), beside modes at 576 and 615 Hz. The two heaviest levels' FRFs
/// disagree 6.4 times their variance there, the lighter pair 0.8 times. (Seed 18 of the
/// generator before its spring was drawn to move a mode by 1-3 % held the same group at a
/// 0.34 % move, the response centroid over it moving only 0.10 %.)
#[test]
fn lumped_strong_level_disagreement_in_a_close_group_is_a_nonlinearity() {
    let (d, answer) = diagnose_with_answer(Effect::Nonlinearity, 12);
    assert_eq!(d["cause"], "nonlinearity", "{d}");
    assert_eq!(d["details"]["kind"], answer["details"]["kind"], "{d}");
    let got = d["details"]["freq_hz"].as_f64().unwrap_or(f64::NAN);
    let want = answer["details"]["freq_hz"].as_f64().unwrap_or(f64::NAN);
    assert!((got / want - 1.0).abs() < 0.02, "{got} vs {want} Hz");
}

/// The null of the force-level test: the nonlinearity case's impact record (two hits
/// each at 60, 300 and 1200 N) made on the machine without its cubic spring. A twin
/// right within noise must be `none`. Before, each force level's FRF was judged against
/// the twin with standard errors from its coherence, which two hits bias to 1 (local
/// misfit 6-11 sigma at the 60 N level: `unexplained` at 4 of 10 seeds), and any pair of
/// levels disagreeing 2.5 times their variance named a nonlinearity: noise at the 73-137
/// Hz modes did so at 5 of 20 seeds (10, 12, 14, 17, 19; 2.6-3.9 times). Now the two
/// heaviest levels must disagree at least 3 times, and 1.5 times more than the next
/// lighter pair (a cubic spring moves a mode with the square of the amplitude).
#[test]
fn lumped_linear_control_of_the_force_level_test_is_healthy() {
    let o = CaseOptions {
        linear_control: true,
        ..CaseOptions::default()
    };
    for seed in [1, 10, 19] {
        let (d, _) = diagnose_case_with(Effect::Nonlinearity, seed, &o);
        assert_eq!(d["cause"], "none", "seed {seed}: {d}");
    }
}

/// Seeds 2 and 3: the rail mount at 0.58x stiffness (72.9 -> 68.3 Hz) and the saddle
/// guide's damping x2.1 (137 Hz mode 1.9 -> 2.9 %): the twin misfits the data locally by
/// 3.6 sigma, under the former threshold of 4 (`none`); healthy impact hits reach 0.9-2.2.
/// Seed 2 was named right before only through the per-level test's coherence-biased
/// errors (the same that called healthy three-level hits `unexplained`).
#[test]
fn lumped_mode_change_with_a_local_misfit_under_four_sigma_is_named() {
    for seed in [2, 3] {
        let d = diagnose_effect_case(Effect::ModeChange, seed);
        assert_eq!(d["cause"], "mode_change", "seed {seed}: {d}");
    }
}

/// Seed 6: the saddle guide turned 15 degrees couples the x and y modes; under the
/// accelerometer's 1/f noise the cross channels yx and xy are coherent at 0.65-0.87 on
/// three lines only (131-138 Hz), never at 0.8 on the five an empty channel needed, and
/// the change was read as a `mode_change` of the 137 Hz mode. Both reciprocal channels
/// coherent beyond chance on three lines in a row are evidence (noise: 1.6e-8).
#[test]
fn lumped_turned_guide_seen_in_both_reciprocal_channels_is_cross_coupling() {
    let (d, _) = diagnose_with_answer(Effect::CrossCoupling, 6);
    assert_eq!(d["cause"], "cross_coupling", "{d}");
}

/// Seeds 12 and 19: the ram guide turned 28-30 degrees moves the 137-140 Hz mode to
/// 127-128 Hz while it turns into the other axis. A turned mode refitted only within 5 %
/// of its frequency left 7-10 sigma of local misfit, and the case was `unexplained`; the
/// turn may move the mode by up to 15 %. Seed 18 (the saddle guide turned 20 degrees):
/// the cross coupling and a retune pass the band test alike (band gain 33.4 vs 33.9); the
/// cross coupling leaves less local misfit (3.6 vs 5.8 sigma) and fills the channels the
/// twin holds empty, which no retune does.
#[test]
fn lumped_turned_guide_that_moves_its_mode_is_cross_coupling() {
    for seed in [12, 18, 19] {
        let (d, _) = diagnose_with_answer(Effect::CrossCoupling, seed);
        assert_eq!(d["cause"], "cross_coupling", "seed {seed}: {d}");
        let gain = d["fit_after_pct"].as_f64().unwrap_or(f64::NAN)
            - d["fit_before_pct"].as_f64().unwrap_or(f64::NAN);
        assert!(gain > 1.0, "seed {seed}: band gain {gain}: {d}");
    }
}

/// Seed 5: the ram guide's pose dependence moves the 137 Hz mode by +1.0 / -2.3 % at the
/// two data poses (z 0.05 and 0.25 m, 0.04-0.17 % sd), while a loosely identified 442 Hz
/// mode wanders -5.4 / +13 % (0.5-1.4 % sd). Named by its spread alone, the 442 Hz mode's
/// extensions gained 1.8-2.1 points in their band and the case was `unexplained`; the most
/// significant mover's extensions compete too, and the one that refits every mode per pose
/// gains 35 points at 122-154 Hz with the rate along z within 20 %.
#[test]
fn lumped_pose_dependence_names_the_most_significant_mover() {
    let (d, answer) = diagnose_with_answer(Effect::PoseDependence, 5);
    assert_pose_dependence_with_its_rate(&d, &answer);
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    assert!(
        (num(&d["details"]["freq_hz"]) / num(&answer["details"]["freq_hz"]) - 1.0).abs() <= 0.01,
        "{d}"
    );
}

/// Seed 6: the table guide's stiffness grows along x and moves the 249 Hz mode by -22 /
/// +18 % at the two data poses. The extension that refitted every mode at each pose (from
/// its few hits) gained 11.8 points in 222-280 Hz but lost 2 points of the whole held-out
/// response, and the case was `unexplained`; the extension with only the moving mode
/// refitted keeps the whole response and gains 35 points there.
#[test]
fn lumped_pose_dependence_names_the_moving_mode_without_refitting_the_others() {
    let (d, answer) = diagnose_with_answer(Effect::PoseDependence, 6);
    assert_pose_dependence_with_its_rate(&d, &answer);
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    assert!(
        num(&d["fit_after_pct"]) > num(&d["fit_before_pct"]) + 1.0,
        "{d}"
    );
}

/// `d` names a pose dependence along the answer's axis of variation, its rate within
/// 20 % of the answer's.
fn assert_pose_dependence_with_its_rate(d: &serde_json::Value, answer: &serde_json::Value) {
    assert_eq!(d["cause"], "pose_dependence", "{d}");
    let t = &answer["details"];
    assert_eq!(
        d["details"]["axis_of_variation"], t["axis_of_variation"],
        "{d}"
    );
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (rate, want) = (
        num(&d["details"]["freq_shift_pct_per_m"]),
        num(&t["freq_shift_pct_per_m"]),
    );
    assert!(
        (rate - want).abs() <= 0.2 * want.abs(),
        "{rate} vs {want} %/m"
    );
}

/// Seed 3: a 1.09 kg absorber on the tool mass-loads its 2029 Hz mode to 1435 Hz and
/// adds a mode of its own. The retune alone leaves a misfit beyond the noise (chi 4.19)
/// and predicted the held-out hits best by half a point (16.6 vs 16.2 %); the retune
/// with a mode added where its misfit remains brings chi within the noise (2.65): a new
/// mode, with the mode it moved.
#[test]
fn lumped_absorber_that_mass_loads_a_mode_is_a_new_mode() {
    let (d, _) = diagnose_with_answer(Effect::UnmodeledMode, 3);
    assert_eq!(d["cause"], "unmodeled_mode", "{d}");
    assert!(d["details"]["moved_mode_hz"].is_number(), "{d}");
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    assert!(
        num(&d["fit_after_pct"]) > num(&d["fit_before_pct"]) + 1.0,
        "{d}"
    );
}

/// Seed 5: a 0.67 kg absorber on the tool, its own mode at 1192 Hz along y. It also loads
/// the 928 Hz mode to 887 Hz, and the mode added after the tool mode's retune landed
/// there (888.6 Hz, 1.4 % damping, chi 6.49): the answer named a loaded twin mode. A mode
/// added within 10 % of a twin mode is now taken for that mode loaded: it is retuned and
/// the mode added where the misfit is left (1193 Hz, chi 2.73).
#[test]
fn lumped_absorber_mode_is_named_beside_the_modes_it_loads() {
    let (d, answer) = diagnose_with_answer(Effect::UnmodeledMode, 5);
    assert_eq!(d["cause"], "unmodeled_mode", "{d}");
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (got, want) = (
        num(&d["details"]["freq_hz"]),
        num(&answer["details"]["freq_hz"]),
    );
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want} Hz: {d}");
    assert_eq!(d["details"]["axis"], answer["details"]["axis"], "{d}");
}

/// Milling, seed 1: a 1.47 kg absorber on the tool. Its best retune "moved" the 2013 Hz
/// tool mode to 888 Hz (a factor 2.3, more than half its stiffness lost could give) and
/// was named `mode_change`; a retune may move its mode by at most a factor 1.5, and the
/// data then name the new mode.
#[test]
fn lumped_milling_absorber_is_not_a_retune_by_a_factor_two() {
    let (d, _) = diagnose_milling_case(Effect::UnmodeledMode, 1);
    assert_eq!(d["cause"], "unmodeled_mode", "{d}");
}

/// Milling, seed 5: the saddle guide at 0.76x stiffness and 1.75x damping moves the
/// 137.1 Hz y mode to 127.3 Hz. The cuts' force is periodic (tooth and spindle harmonics):
/// the Welch points between the harmonics hold little but leakage, and every retune of
/// them predicted the held-out cuts worse (`none`). Retuned to the records' responses in
/// time, the mode is named at its new frequency.
#[test]
fn lumped_milling_mode_change_is_found_in_the_cuts_responses() {
    let (d, answer) = diagnose_milling_case(Effect::ModeChange, 5);
    assert_eq!(d["cause"], "mode_change", "{d}");
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (f, want) = (
        num(&d["details"]["new_freq_hz"]),
        num(&answer["details"]["new_freq_hz"]),
    );
    assert!(
        (f / want - 1.0).abs() < 0.01,
        "{f} Hz, truth {want} Hz: {d}"
    );
    assert!(
        num(&d["fit_after_pct"]) > num(&d["fit_before_pct"]) + 1.0,
        "{d}"
    );
}

/// Milling, seed 17: the ram guide turned by 16° makes a yx/xy response at 133 Hz that
/// the twin lacks. The cuts push along x and y at once, so no harmonic line tells a new
/// cross channel from a changed direct one; fitted to the cuts' responses in time, the
/// 137/140 Hz pair turned together (at one angle in each cut alone) predicts the held-out
/// responses better than every retune, and the turn is named.
#[test]
fn lumped_milling_turned_guide_is_found_in_the_cuts_responses() {
    let (d, answer) = diagnose_milling_case(Effect::CrossCoupling, 17);
    assert_eq!(d["cause"], "cross_coupling", "{d}");
    let ch = d["details"]["channel"].as_str().unwrap_or("");
    assert!(
        ch == answer["details"]["channel"] || ch == answer["details"]["reciprocal_channel"],
        "{d}"
    );
    let num = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    let (f, want) = (
        num(&d["details"]["freq_hz"]),
        num(&answer["details"]["freq_hz"]),
    );
    assert!(
        (f / want - 1.0).abs() < 0.03,
        "{f} Hz, truth {want} Hz: {d}"
    );
    assert!(
        num(&d["fit_after_pct"]) > num(&d["fit_before_pct"]) + 1.0,
        "{d}"
    );
}
