//! An 18-pose impact campaign like the independent one of issue 17 (3 × 3 × 2 grid,
//! eight modes whose frequencies shift with the pose, hammer along x and y, responses
//! x, y, z; every mode moves the tool along x or along y only, so the cross channels
//! carry nothing but noise), drawn at random per seed. Modes of one direction stay
//! apart by at least the sum of their half-power bandwidths everywhere in the workspace
//! (two modes closer than that are one resonance to any estimator). Defaults only; the
//! twin is judged against the analytic receptance, xx and yy 30-2500 Hz, at the measured
//! poses and at three poses between them.

use crate::common::modal::{impact, receptance, write, Mode};
use crate::common::{mtwin, s, stderr, tmp};
use identify::twin::Twin;
use num_complex::Complex64;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const CENTRE: [f64; 3] = [0.5, 0.4, 0.2];

/// The machine: nominal modes and each mode's relative frequency shift per metre along
/// x, y, z.
struct Machine {
    modes: Vec<Mode>,
    slope: Vec<[f64; 3]>,
}

impl Machine {
    /// With `oblique`, about a third of the modes move the tool in a direction between x
    /// and y (15-75 degrees, as the tryout gantry's 121 Hz mode): their cross channels
    /// carry a response, and modes of different directions may come close or cross.
    /// Without, every mode moves the tool along x or along y only.
    fn draw_with(rng: &mut StdRng, oblique: bool) -> Machine {
        let corners: Vec<[f64; 3]> = [0.2, 0.8]
            .iter()
            .flat_map(|&x| {
                [0.2, 0.6]
                    .iter()
                    .flat_map(move |&y| [0.1, 0.3].map(|z| [x, y, z]))
            })
            .collect();
        loop {
            let mut f0: Vec<f64> = (0..8).map(|_| rng.gen_range(60.0..2400.0)).collect();
            f0.sort_by(f64::total_cmp);
            let m = Machine {
                modes: f0
                    .iter()
                    .map(|&f| {
                        let mut d = [0.0; 3];
                        if oblique && rng.gen_bool(0.35) {
                            let th = rng.gen_range(15f64..75.0).to_radians();
                            d = [th.cos(), th.sin(), 0.0];
                        } else {
                            d[rng.gen_range(0..2)] = 1.0;
                        }
                        Mode {
                            f0: f,
                            zeta: rng.gen_range(0.01..0.05),
                            k: rng.gen_range(2e7..1.5e8) * (f / 500.0).sqrt(),
                            d,
                        }
                    })
                    .collect(),
                slope: (0..8)
                    .map(|_| [0; 3].map(|_| rng.gen_range(-0.25..0.25)))
                    .collect(),
            };
            // modes of one direction resolvable (and not crossing) everywhere
            let ok = (0..8).all(|i| {
                (i + 1..8).all(|j| {
                    (0..3)
                        .map(|a| m.modes[i].d[a] * m.modes[j].d[a])
                        .sum::<f64>()
                        .abs()
                        < 0.5
                        || {
                            let gaps: Vec<f64> = corners
                                .iter()
                                .map(|p| m.at(*p)[i].f0 - m.at(*p)[j].f0)
                                .collect();
                            let need = (m.modes[i].zeta + m.modes[j].zeta)
                                * 0.5
                                * (m.modes[i].f0 + m.modes[j].f0);
                            gaps.iter().all(|g| g.abs() >= need)
                                && (gaps.iter().all(|g| *g > 0.0) || gaps.iter().all(|g| *g < 0.0))
                        }
                })
            });
            if ok {
                return m;
            }
        }
    }

    fn at(&self, p: [f64; 3]) -> Vec<Mode> {
        self.modes
            .iter()
            .zip(&self.slope)
            .map(|(m, s)| Mode {
                f0: m.f0 * (1.0 + (0..3).map(|a| s[a] * (p[a] - CENTRE[a])).sum::<f64>()),
                ..m.clone()
            })
            .collect()
    }
}

/// Fit [%] of the twin against the analytic receptance at `p`, worst of xx and yy.
fn vs_truth(twin: &Twin, machine: &Machine, p: [f64; 3]) -> f64 {
    let model = twin.model_at(p).expect("model");
    let modes = machine.at(p);
    [0usize, 1]
        .iter()
        .map(|&a| {
            let ch = identify::axis::Channel {
                output: identify::axis::Axis::ALL[a],
                input: identify::axis::Axis::ALL[a],
            };
            let ci = model.channel_index(ch).expect("direct channel");
            let (t, e): (Vec<Complex64>, Vec<Complex64>) = (0..1300)
                .map(|k| 30.0 + k as f64 * (2500.0 - 30.0) / 1299.0)
                .map(|f| (receptance(&modes, f, a, a), model.eval_hz(ci, f)))
                .unzip();
            identify::frf::fit_percent(&t, &e)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The campaign's grid (3 × 3 × 2).
fn grid() -> Vec<[f64; 3]> {
    [0.1, 0.3]
        .iter()
        .flat_map(|&z| {
            [0.2, 0.4, 0.6]
                .iter()
                .flat_map(move |&y| [0.2, 0.5, 0.8].map(|x| [x, y, z]))
        })
        .collect()
}

/// Impact records (hammer x and y) of `modes` at `pose` into `dir`, named `tag_x.csv`...
fn impacts(dir: &std::path::Path, tag: &str, modes: &[Mode], pose: [f64; 3], rng: &mut StdRng) {
    std::fs::create_dir_all(dir).expect("folder");
    for axis in 0..2 {
        let rec = impact(modes, axis, 0.0, rng);
        write(
            &dir.join(format!("{tag}_{}.csv", ["x", "y"][axis])),
            axis,
            &rec,
            pose,
        );
    }
}

/// A drawn machine, its campaign identified with defaults: (machine, folder, twin).
fn campaign(seed: u64) -> (Machine, tempfile::TempDir, Twin, std::path::PathBuf, StdRng) {
    campaign_with(seed, false)
}

/// [`campaign`] of a machine drawn with or without oblique modes ([`Machine::draw_with`]).
fn campaign_with(
    seed: u64,
    oblique: bool,
) -> (Machine, tempfile::TempDir, Twin, std::path::PathBuf, StdRng) {
    let mut rng = StdRng::seed_from_u64(seed);
    let machine = Machine::draw_with(&mut rng, oblique);
    let dir = tmp();
    let data = dir.path().join("campaign");
    for (g, p) in grid().iter().enumerate() {
        impacts(&data, &format!("p{g:02}"), &machine.at(*p), *p, &mut rng);
    }
    let twin_path = dir.path().join("twin.json");
    let o = mtwin(&["identify", "-q", s(&data), "--out", s(&twin_path)]);
    assert!(o.status.success(), "seed {seed}: {}", stderr(&o));
    let twin = Twin::load(&twin_path).expect("twin loads");
    (machine, dir, twin, twin_path, rng)
}

#[test]
fn eighteen_pose_modal_campaign_twin_fits_the_truth_everywhere() {
    let wrong = fits_everywhere(&[11, 12], false, 99.0);
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Oblique modes (their cross channels carry a response, so the directions share their
/// poles and every isolated mode's residues are made rank one): the worst measured pose
/// at 99.5 %, the target for data of this kind (seeds 31, 32: 99.93 / 99.85 %).
#[test]
fn oblique_modal_campaign_twin_fits_the_truth_everywhere() {
    let wrong = fits_everywhere(&[31, 32], true, 99.5);
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Lightly damped low modes that ring into the next hit (seed 46: 144-157 Hz at 1.0 %
/// keeps 4.4 % of its amplitude after the 0.33 s between hits; seed 47: 92-99 Hz at
/// 1.25 % keeps 9.4 %): each hit's
/// response is separated from the earlier hits' free decays (`spectra/ringing.rs`).
/// Without it the worst measured pose fitted the truth at 95.24 / 96.00 %; with it
/// 99.79 / 99.63 %.
#[test]
fn ringing_modal_campaign_twin_fits_the_truth_everywhere() {
    let wrong = fits_everywhere(&[46, 47], true, 99.5);
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Scan: `MTWIN_SCAN_SEEDS=31-40 cargo test --release --test cli modal_campaign::scan --
/// --ignored --nocapture` prints every seed's worst measured and unmeasured fit of a
/// machine with oblique modes.
#[test]
#[ignore]
fn scan_oblique_modal_campaigns() {
    let seeds = scan_seeds((31, 34));
    let wrong = fits_everywhere(&seeds, true, 99.5);
    eprintln!(
        "{} of {} below target: {wrong:#?}",
        wrong.len(),
        seeds.len()
    );
}

/// The seeds of a scan: `MTWIN_SCAN_SEEDS=A-B`, else `default` (both ends included).
fn scan_seeds(default: (u64, u64)) -> Vec<u64> {
    let (a, b) = std::env::var("MTWIN_SCAN_SEEDS")
        .ok()
        .and_then(|v| {
            let (a, b) = v.split_once('-')?;
            Some((a.parse().ok()?, b.parse().ok()?))
        })
        .unwrap_or(default);
    (a..=b).collect()
}

/// The campaigns of `seeds`, each twin against its truth: a line per seed whose worst
/// measured pose fits below `target` or an unmeasured one below 98 %.
fn fits_everywhere(seeds: &[u64], oblique: bool, target: f64) -> Vec<String> {
    let mut wrong = Vec::new();
    for &seed in seeds {
        let (machine, dir, twin, _, _) = campaign_with(seed, oblique);
        if let Some(keep) = std::env::var_os("MTWIN_SCAN_KEEP") {
            // the records, the twin and the machine (modes at every grid pose) for a look
            let to = std::path::Path::new(&keep).join(format!("seed{seed}"));
            std::fs::create_dir_all(&to).expect("keep folder");
            for e in std::fs::read_dir(dir.path().join("campaign")).expect("campaign") {
                let e = e.expect("entry");
                std::fs::copy(e.path(), to.join(e.file_name())).expect("copy");
            }
            std::fs::copy(dir.path().join("twin.json"), to.join("twin.json")).expect("copy");
            let poses: Vec<serde_json::Value> = grid()
                .iter()
                .map(|p| {
                    let m: Vec<serde_json::Value> = machine
                        .at(*p)
                        .iter()
                        .map(|m| serde_json::json!([m.f0, m.zeta, m.k, m.d]))
                        .collect();
                    serde_json::json!({"pose": p, "modes": m})
                })
                .collect();
            std::fs::write(
                to.join("machine.json"),
                serde_json::Value::from(poses).to_string(),
            )
            .expect("machine.json");
        }
        let grid = grid();
        let measured: Vec<f64> = grid.iter().map(|p| vs_truth(&twin, &machine, *p)).collect();
        let unmeasured: Vec<f64> = [[0.35, 0.3, 0.2], [0.65, 0.5, 0.15], [0.4, 0.55, 0.25]]
            .iter()
            .map(|p| vs_truth(&twin, &machine, *p))
            .collect();
        let worst = measured.iter().copied().fold(f64::INFINITY, f64::min);
        let u_worst = unmeasured.iter().copied().fold(f64::INFINITY, f64::min);
        eprintln!(
            "seed {seed}: modes {:?}; measured worst {worst:.2} %, unmeasured {unmeasured:.2?}",
            machine
                .modes
                .iter()
                .map(|m| (m.f0.round(), m.d[1].atan2(m.d[0]).to_degrees().round()))
                .collect::<Vec<_>>()
        );
        if worst < target || u_worst < 98.0 {
            wrong.push(format!(
                "seed {seed}: measured {measured:.2?}, unmeasured {unmeasured:.2?}"
            ));
        }
    }
    wrong
}

/// Data at two poses along one axis where one mode moves with the pose faster than the
/// campaign showed (by 20-60 %/m of its frequency; 50-150 %/m along the short z travel):
/// `pose_dependence` with that axis and the extra rate (within 20 % or 5 %/m).
#[test]
fn modal_campaign_twin_names_a_pose_dependence_and_its_rate() {
    let mut wrong = Vec::new();
    for seed in [21u64, 22, 23] {
        let (machine, dir, _, twin_path, mut rng) = campaign(seed);
        let a = rng.gen_range(0..3);
        let (lo, hi) = [(0.2, 0.8), (0.2, 0.6), (0.1, 0.3)][a];
        let k = rng.gen_range(0..8);
        let rate = rng.gen_range(0.2..0.6)
            * if a == 2 { 2.5 } else { 1.0 }
            * if rng.gen_bool(0.5) { 1.0 } else { -1.0 };
        let data = dir.path().join("pose_dependence");
        for (tag, v) in [("lo", lo), ("hi", hi)] {
            let mut p = [0.5, 0.4, 0.1];
            p[a] = v;
            let mut modes = machine.at(p);
            modes[k].f0 *= 1.0 + rate * (v - CENTRE[a]);
            impacts(&data, tag, &modes, p, &mut rng);
        }
        let out = dir.path().join("out");
        let o = mtwin(&[
            "diagnose",
            "-q",
            "--twin",
            s(&twin_path),
            s(&data),
            "--out",
            s(&out),
        ]);
        assert!(o.status.success(), "seed {seed}: {}", stderr(&o));
        let d: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("diagnosis.json")).expect("diagnosis.json"),
        )
        .expect("json");
        let det = &d["details"];
        let got = det["freq_shift_pct_per_m"].as_f64().unwrap_or(f64::NAN);
        let want = 100.0 * rate;
        eprintln!(
            "seed {seed}: mode {:.0} Hz, axis {}, {want:.1} %/m -> {} {det}",
            machine.modes[k].f0,
            ["x", "y", "z"][a],
            d["cause"]
        );
        let ok = d["cause"] == "pose_dependence"
            && det["axis_of_variation"] == ["x", "y", "z"][a]
            && ((got - want).abs() <= 0.2 * want.abs() || (got - want).abs() <= 5.0);
        if !ok {
            wrong.push(format!(
                "seed {seed}: want {want:.1} %/m along {}, got {d}",
                ["x", "y", "z"][a]
            ));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// The lifetime refit on a drawn machine, as the tryout's `worn_milling/` asks it: the
/// campaign twin (defaults), then one mode at 150-1500 Hz loses 8-22 % of its stiffness
/// and the worn machine is milled at the centre at three spindle speeds whose tooth
/// passing lies at 0.75-1.05 of the worn mode (3 s each; tooth and spindle harmonics only,
/// or with a broadband share of half the force's RMS); `mtwin refit` with defaults.
/// Judged against the worn machine's analytic receptance at the centre, xx and yy
/// 30-2500 Hz: what is wrong (worn mode not within 1 % of its new frequency, or a fit
/// below `target`), with a line per seed on stderr.
fn refits(seeds: &[u64], target: f64) -> Vec<String> {
    let mut wrong = Vec::new();
    for &seed in seeds {
        let (machine, dir, twin, twin_path, _) = campaign_with(seed, true);
        let mut rng = StdRng::seed_from_u64(seed + 1000);
        let healthy = machine.at(CENTRE);
        let worn_candidates: Vec<usize> = (0..healthy.len())
            .filter(|&i| (150.0..1500.0).contains(&healthy[i].f0))
            .collect();
        let i = worn_candidates[rng.gen_range(0..worn_candidates.len())];
        let sf = rng.gen_range(0.78..0.92);
        let mut worn = healthy.clone();
        let wear = std::env::var_os("MTWIN_SCAN_HEALTHY").is_none();
        if wear {
            worn[i].k *= sf;
            worn[i].f0 *= f64::sqrt(sf);
        }
        let broadband = if rng.gen_bool(0.5) { 0.5 } else { 0.0 };
        let data = dir.path().join("worn_milling");
        std::fs::create_dir_all(&data).expect("folder");
        let mut speeds = Vec::new();
        for _ in 0..3 {
            let rpm = (worn[i].f0 * rng.gen_range(0.75..1.05) * 60.0 / 3.0).round();
            speeds.push(rpm);
            let rec = crate::common::modal::milling(&worn, rpm, &[], broadband, &mut rng);
            crate::common::modal::write_milling(
                &data.join(format!("mill_{rpm:.0}.csv")),
                rpm,
                &rec,
                CENTRE,
            );
        }
        let out = dir.path().join("worn.json");
        let o = mtwin(&["refit", "--twin", s(&twin_path), s(&data), "--out", s(&out)]);
        if !o.status.success() {
            wrong.push(format!("seed {seed}: refit failed: {}", stderr(&o)));
            continue;
        }
        if let Some(keep) = std::env::var_os("MTWIN_SCAN_KEEP") {
            let to = std::path::Path::new(&keep).join(format!("refit{seed}"));
            std::fs::create_dir_all(&to).expect("keep folder");
            for e in std::fs::read_dir(&data).expect("milling") {
                let e = e.expect("entry");
                std::fs::copy(e.path(), to.join(e.file_name())).expect("copy");
            }
            std::fs::copy(&twin_path, to.join("twin.json")).expect("copy");
            std::fs::write(to.join("refit.txt"), stderr(&o)).expect("refit.txt");
        }
        let after = Twin::load(&out).expect("refitted twin loads");
        let fit = |t: &Twin| -> [f64; 2] {
            let model = t.model_at(CENTRE).expect("model");
            [0usize, 1].map(|a| {
                let ch = identify::axis::Channel {
                    output: identify::axis::Axis::ALL[a],
                    input: identify::axis::Axis::ALL[a],
                };
                let ci = model.channel_index(ch).expect("direct channel");
                let (tr, e): (Vec<Complex64>, Vec<Complex64>) = (0..1300)
                    .map(|k| 30.0 + k as f64 * (2500.0 - 30.0) / 1299.0)
                    .map(|f| (receptance(&worn, f, a, a), model.eval_hz(ci, f)))
                    .unzip();
                identify::frf::fit_percent(&tr, &e)
            })
        };
        let (b, a) = (fit(&twin), fit(&after));
        // the refitted twin's mode nearest the worn one's healthy frequency
        let m1 = after.model_at(CENTRE).expect("model");
        let m0 = twin.model_at(CENTRE).expect("model");
        let k = (0..m0.modes.len())
            .min_by(|&p, &q| {
                (m0.modes[p].freq_hz() - healthy[i].f0)
                    .abs()
                    .total_cmp(&(m0.modes[q].freq_hz() - healthy[i].f0).abs())
            })
            .expect("modes");
        let f_new = m1.modes.get(k).map_or(f64::NAN, |m| m.freq_hz());
        let f_err = (f_new / worn[i].f0 - 1.0) * 100.0;
        eprintln!(
            "seed {seed}: mode {:.1} Hz x{sf:.3} -> {:.1} Hz (refit {f_new:.1}, {f_err:+.2} %), \
             {speeds:?} rpm, broadband {broadband}; vs worn truth xx {:.2} -> {:.2} %, yy {:.2} -> {:.2} %; \
             modes (Hz, deg) {:?}",
            healthy[i].f0,
            worn[i].f0,
            b[0],
            a[0],
            b[1],
            a[1],
            healthy
                .iter()
                .map(|m| (m.f0.round(), m.d[1].atan2(m.d[0]).to_degrees().round()))
                .collect::<Vec<_>>()
        );
        // healthy (MTWIN_SCAN_HEALTHY): no mode moves by 1 %, no channel loses 0.5 points
        let moved = (0..m0.modes.len())
            .filter(|&j| (m1.modes[j].freq_hz() / m0.modes[j].freq_hz() - 1.0).abs() > 0.01)
            .count();
        if !wear && (moved > 0 || a[0] < b[0] - 0.5 || a[1] < b[1] - 0.5) {
            wrong.push(format!(
                "seed {seed} healthy: {moved} modes moved; xx {:.2} -> {:.2}, yy {:.2} -> {:.2}",
                b[0], a[0], b[1], a[1]
            ));
        }
        if wear && (f_err.abs() > 1.0 || a[0] < target || a[1] < target) {
            wrong.push(format!(
                "seed {seed}: mode {:.1} -> {:.1} Hz, refit {f_new:.1}; xx {:.2} -> {:.2}, yy {:.2} -> {:.2}",
                healthy[i].f0, worn[i].f0, b[0], a[0], b[1], a[1]
            ));
        }
    }
    wrong
}

/// The default refit from milling with tooth and spindle harmonics only (no broadband
/// share, as the tryout's `worn_milling/`) on drawn worn machines ([`refits`]), the worn
/// mode within 1 % and the twin at 98 % of the worn truth: seed 72 (493 -> 461 Hz, 19°,
/// next to a 415 Hz mode at 62°: no update from the Welch spectra validates, the mode is
/// retuned in time) and seed 75 (375 -> 347 Hz, y: the Welch update stops short and
/// frees a 2142 Hz mode too; the output-error refinement's trust region moves with it).
/// On the code before: every seed of this generator kept its twin (the idle z response
/// vetoed every line); with that mended, seed 72 still kept it (xx 80.7 % of the worn
/// truth) and seed 75 fell to xx 32.2 %. Seed 110 (238 -> 223 Hz, x; within the drift
/// thresholds, found in time): the Welch path validated a 0.003 % move of the 2053 Hz
/// mode and that was applied instead of the retune in time (xx 78.9 -> 78.8 %). Seed 120
/// (1084 -> 997 Hz, x; tooth passing 866-977 Hz): the Welch path moved only a 2211 Hz mode
/// and reproduced the records at 66.2 % (xx 63.9 -> 58.0 %); the retune in time, looked
/// for where that update leaves the records far from reproduced, reaches 99.2 %. Seed 108
/// (626 -> 585 Hz, y): the retune in time was found on the whole records but each half
/// gave relative errors of 17-58 (the output error's FFT length 3^9 for a half record,
/// odd, failed every inverse transform), so it was refused. Seed 116 (713 -> 648 Hz, y):
/// the retune in time stopped at the midpoint to the like-shaped 599 Hz neighbour (653.9
/// Hz, yy 81.5 %).
#[test]
fn refit_from_harmonic_milling_tracks_the_worn_mode() {
    let wrong = refits(&[72, 75, 108, 110, 116, 120], 98.0);
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// Scan: `MTWIN_SCAN_SEEDS=61-70 cargo test --release --test cli modal_campaign::scan_refit
/// -- --ignored --nocapture` prints every seed's refit from worn milling.
#[test]
#[ignore]
fn scan_refit_from_worn_milling() {
    let seeds = scan_seeds((61, 64));
    let wrong = refits(&seeds, 98.0);
    eprintln!(
        "{} of {} below target: {wrong:#?}",
        wrong.len(),
        seeds.len()
    );
}
