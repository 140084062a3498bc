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

use crate::common::modal::{impact, write, Mode, AXES, FS};
use crate::common::{mtwin, s, shared_data, stderr, tmp};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::{json, Value};
use std::path::PathBuf;

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

/// A temporary folder and, in it, the twin the defaults identify from the tryout
/// campaign.
fn campaign_twin() -> (tempfile::TempDir, PathBuf) {
    let dir = tmp();
    let twin = dir.path().join("twin.json");
    let campaign = shared_data().join("tryout_gantry/campaign");
    let o = mtwin(&["identify", "-q", s(&campaign), "--out", s(&twin)]);
    assert!(o.status.success(), "{}", stderr(&o));
    (dir, twin)
}

/// The indices of the pure x or y modes of `base`.
fn pure_modes(base: &[Mode]) -> Vec<usize> {
    (0..base.len())
        .filter(|&i| base[i].d[0].abs().max(base[i].d[1].abs()) > 0.99)
        .collect()
}

/// A case at three force levels: (folder name, hammer axis, cubic mode and its shift,
/// answer).
type LevelCase = (String, usize, Option<(usize, f64)>, Value);

/// The cases of one seed: (folder name, modes, delay in samples, SPEC answer).
fn cases(base: &[Mode], rng: &mut StdRng) -> Vec<(&'static str, Vec<Mode>, f64, Value)> {
    let pure = pure_modes(base);
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
    let (dir, twin) = campaign_twin();
    diagnose_hidden(&dir, &twin, 1..=3);
}

/// The same cases against the one-pose twin the defaults identify from a healthy impact
/// test at the centre (x and y hammer, the tryout files' form): the twin a user has who
/// measured only where the machine cuts.
#[test]
fn tryout_truth_with_hidden_effects_is_diagnosed_against_a_one_pose_twin() {
    let dir = tmp();
    let twin = dir.path().join("twin.json");
    let base = machine();
    let mut rng = StdRng::seed_from_u64(100);
    let healthy = dir.path().join("centre");
    std::fs::create_dir_all(&healthy).expect("folder");
    for axis in 0..2 {
        let rec = impact(&base, axis, 0.0, &mut rng);
        write(
            &healthy.join(format!("imp_{}.csv", ["x", "y"][axis])),
            axis,
            &rec,
            [0.6, 0.4, 0.15],
        );
    }
    let o = mtwin(&["identify", "-q", s(&healthy), "--out", s(&twin)]);
    assert!(o.status.success(), "{}", stderr(&o));
    diagnose_hidden(&dir, &twin, 4..=6);
}

/// Diagnoses every case of `seeds` against `twin` (defaults only) and asserts each is
/// named with its numbers and a held-out gain above one point.
fn diagnose_hidden(
    dir: &tempfile::TempDir,
    twin: &std::path::Path,
    seeds: std::ops::RangeInclusive<u64>,
) {
    let base = machine();
    let mut wrong = Vec::new();
    let mut n = 0;
    for seed in seeds {
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
                    [0.6, 0.4, 0.15],
                );
            }
            let out = dir.path().join(format!("o{seed}_{name}"));
            n += 1;
            wrong.extend(judge(
                twin,
                &folder,
                &out,
                &want,
                &format!("seed {seed} {name}"),
            ));
        }
    }
    assert!(wrong.is_empty(), "{} of {n} wrong: {wrong:#?}", wrong.len());
}

/// Impact tests at three force levels (about 100, 400 and 1000 N, three hits each, each
/// hit ±10 ms off its 0.4 s slot, as a hand-held hammer gives) on the tryout truth,
/// against the campaign twin: the linear machine hammered along x and along y is `none`;
/// a cubic spring on one pure x or y mode, drawn per seed, raising its frequency by 1.5-3 %
/// at the heaviest hits, is a hardening `nonlinearity` of that mode, with a held-out gain.
/// Before the levels' FRFs were compared through their ratio to the twin, the hits'
/// different record lengths put the levels on different lines, and interpolating across a
/// resonance named every linear case of this test a nonlinearity (12 of 12 over six
/// seeds, 11.3 x the variance at 121 Hz).
#[test]
fn tryout_truth_hit_at_three_force_levels_is_linear_unless_a_mode_hardens() {
    use crate::common::modal::impact_levels;
    let (dir, twin) = campaign_twin();
    let base = machine();
    let pure = pure_modes(&base);
    let (mut wrong, mut n) = (Vec::new(), 0);
    for seed in 1..=2u64 {
        let mut rng = StdRng::seed_from_u64(2000 + seed);
        let k = pure[rng.gen_range(0..pure.len())];
        let shift = rng.gen_range(0.015..0.03);
        let axis = if base[k].d[0].abs() > 0.99 { 0 } else { 1 };
        let cases: Vec<LevelCase> = vec![
            ("linear_x".into(), 0, None, json!({"cause": "none"})),
            ("linear_y".into(), 1, None, json!({"cause": "none"})),
            (
                format!("hardening_{:.0}hz", base[k].f0),
                axis,
                Some((k, shift)),
                json!({"cause": "nonlinearity", "freq_hz": base[k].f0, "kind": "hardening",
                       "axis": AXES[axis]}),
            ),
        ];
        for (name, axis, cubic, want) in cases {
            let folder = dir.path().join(format!("l{seed}_{name}"));
            std::fs::create_dir_all(&folder).expect("folder");
            let rec = impact_levels(&base, axis, cubic, &mut rng);
            write(
                &folder.join(format!("imp_{}.csv", AXES[axis])),
                axis,
                &rec,
                [0.6, 0.4, 0.15],
            );
            let out = dir.path().join(format!("ol{seed}_{name}"));
            n += 1;
            let tag = format!("seed {seed} three force levels, {name}");
            wrong.extend(judge(&twin, &folder, &out, &want, &tag));
        }
    }
    assert!(wrong.is_empty(), "{} of {n} wrong: {wrong:#?}", wrong.len());
}

/// A milling case: (folder name, modes, outside vibration (Hz, relative RMS), answer).
type MillingCase = (
    &'static str,
    Vec<crate::common::modal::Mode>,
    Vec<(f64, f64)>,
    Value,
);

/// Milling data from the tryout truth (mechanistic down-milling force with runout and a
/// broadband share of half the force's RMS, 3 s at two spindle speeds drawn per seed)
/// against the campaign twin: a healthy machine is `none`; an outside vibration at two
/// frequencies (drawn in 30-400 Hz, off the tooth harmonics, RMS 10-40 % of each
/// response's) is a `disturbance` at both, within 1 %; a stiffness loss of 10-25 % in one
/// x or y mode is a `mode_change` of that mode. Each named cause gains more than a point.
#[test]
fn tryout_truth_milling_with_hidden_effects_is_diagnosed() {
    let (wrong, n) = milling_cases(0.5);
    assert!(wrong.is_empty(), "{} of {n} wrong: {wrong:#?}", wrong.len());
}

/// The same cases with a purely periodic cutting force (tooth and spindle harmonics only,
/// as the independent tryout generator's milling records have): the Welch FRF evidence
/// between the harmonics holds little but leakage, so a stiffness loss is found by
/// retuning the modes to the records' responses in time (`mode_change`, 129 -> 120.5 Hz
/// and 1210 -> 1108 Hz; both were `unexplained` or `none` before). At most one case of
/// the nine is missed, and never by a false alarm: seed 2's 88 Hz mode gets almost no
/// force from cuts at 7177 and 7972 rpm (its loss changes the held-out response by
/// 0.2 points; `none`).
#[test]
fn tryout_truth_periodic_milling_with_hidden_effects_is_diagnosed() {
    let (wrong, n) = milling_cases(0.0);
    assert!(wrong.len() <= 1, "{} of {n} wrong: {wrong:#?}", wrong.len());
    assert!(
        wrong
            .iter()
            .all(|w| !w.contains("want {\"cause\":\"none\"}")),
        "a false alarm: {wrong:#?}"
    );
}

/// Cuts with tooth and spindle harmonics only (the tryout generator's kind) at 7759 and
/// 8960 rpm, against the campaign twin: an outside vibration at 200 Hz and at 298.67 Hz,
/// the second spindle harmonic of the 8960 rpm cut (hidden under a force line there, free
/// in the other cut), is a `disturbance` at both (the tones were searched in the longest
/// part only: 298.7 Hz was missed); the 1210 Hz mode 25 % softer (1047.9 Hz, a 13.4 %
/// move, beyond the 1/1.15 of the first search in time) is a `mode_change` to within 1 %
/// (was a new mode at 860 Hz: the retune stopped on the search's edge).
#[test]
fn tryout_truth_periodic_milling_tone_on_a_spindle_harmonic_and_a_large_loss() {
    use crate::common::modal::{milling, write_milling};
    let (dir, twin) = campaign_twin();
    let base = machine();
    let k = (base.iter())
        .position(|m| (m.f0 - 1210.0).abs() < 1.0)
        .expect("the 1210 Hz mode");
    let mut worn = base.clone();
    worn[k].k *= 0.75;
    worn[k].f0 *= 0.75f64.sqrt();
    let harmonic = 2.0 * 8960.0 / 60.0;
    let cases: Vec<MillingCase> = vec![
        (
            "disturbance",
            base.clone(),
            vec![(200.0, 0.2), (harmonic, 0.3)],
            json!({"cause": "disturbance", "freq_hz": [200.0, harmonic]}),
        ),
        (
            "stiffness_loss",
            worn.clone(),
            vec![],
            json!({"cause": "mode_change", "freq_hz": base[k].f0, "new_freq_hz": worn[k].f0}),
        ),
    ];
    let mut rng = StdRng::seed_from_u64(77);
    let mut wrong = Vec::new();
    for (name, modes, dist, want) in cases {
        let folder = dir.path().join(name);
        std::fs::create_dir_all(&folder).expect("folder");
        for rpm in [7759.0, 8960.0] {
            let rec = milling(&modes, rpm, &dist, 0.0, &mut rng);
            write_milling(
                &folder.join(format!("mill_{rpm:.0}.csv")),
                rpm,
                &rec,
                [0.6, 0.4, 0.15],
            );
        }
        let out = dir.path().join(format!("o_{name}"));
        wrong.extend(judge(&twin, &folder, &out, &want, name));
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}

/// The milling cases of three seeds with a cutting force whose broadband share is
/// `broadband` times its RMS, each diagnosed against the campaign twin: what is wrong,
/// and how many cases.
fn milling_cases(broadband: f64) -> (Vec<String>, usize) {
    use crate::common::modal::{milling, write_milling};
    let (dir, twin) = campaign_twin();
    let base = machine();
    let pure = pure_modes(&base);
    let mut wrong = Vec::new();
    let mut n = 0;
    for seed in 1..=3u64 {
        let mut rng = StdRng::seed_from_u64(1000 + seed);
        let speeds: Vec<f64> = (0..2).map(|_| rng.gen_range(5000.0..9000.0)).collect();
        let tooth = |f: f64| {
            speeds.iter().any(|rpm| {
                let ft = 3.0 * rpm / 60.0;
                let k = (f / ft).round().max(1.0);
                (f / (k * ft) - 1.0).abs() < 0.03
            })
        };
        let mut tones = Vec::new();
        while tones.len() < 2 {
            let f: f64 = rng.gen_range(30.0..400.0);
            if !tooth(f) && tones.iter().all(|t: &f64| (f / t - 1.0).abs() > 0.1) {
                tones.push(f);
            }
        }
        let i = pure[rng.gen_range(0..pure.len())];
        let sf = rng.gen_range(0.75..0.9);
        let mut worn = base.clone();
        worn[i].k *= sf;
        worn[i].f0 *= f64::sqrt(sf);
        let cases: Vec<MillingCase> = vec![
            ("healthy", base.clone(), vec![], json!({"cause": "none"})),
            (
                "disturbance",
                base.clone(),
                tones
                    .iter()
                    .map(|&f| (f, rng.gen_range(0.1..0.4)))
                    .collect(),
                json!({"cause": "disturbance", "freq_hz": tones}),
            ),
            (
                "stiffness_loss",
                worn,
                vec![],
                json!({"cause": "mode_change", "freq_hz": base[i].f0, "new_freq_hz": base[i].f0 * sf.sqrt()}),
            ),
        ];
        for (name, modes, dist, want) in cases {
            let folder: PathBuf = dir.path().join(format!("m{seed}_{name}"));
            std::fs::create_dir_all(&folder).expect("folder");
            for rpm in &speeds {
                let rec = milling(&modes, *rpm, &dist, broadband, &mut rng);
                write_milling(
                    &folder.join(format!("mill_{rpm:.0}.csv")),
                    *rpm,
                    &rec,
                    [0.6, 0.4, 0.15],
                );
            }
            let out = dir.path().join(format!("om{seed}_{name}"));
            n += 1;
            let tag = format!("seed {seed} milling at {speeds:.0?} rpm, {name}");
            wrong.extend(judge(&twin, &folder, &out, &want, &tag));
        }
    }
    (wrong, n)
}

/// Runs `mtwin diagnose` (defaults only) on `folder` against `twin`, prints the verdict,
/// and returns what is wrong against `want` (the SPEC answer: cause, frequencies within
/// 1 % — every one of a list for an outside vibration —, the new frequency, axis and kind where
/// given, a delay within 10 %), or a named cause that gains one point or less.
fn judge(
    twin: &std::path::Path,
    folder: &std::path::Path,
    out: &std::path::Path,
    want: &Value,
    tag: &str,
) -> Option<String> {
    let o = mtwin(&[
        "diagnose",
        "-q",
        "--twin",
        s(twin),
        s(folder),
        "--out",
        s(out),
    ]);
    assert!(o.status.success(), "{tag}: {}", stderr(&o));
    let d: Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("diagnosis.json")).expect("diagnosis.json"),
    )
    .expect("json");
    let (cause, det) = (d["cause"].as_str().unwrap_or("?"), &d["details"]);
    let want_cause = want["cause"].as_str().unwrap_or("?");
    let numbers = match want_cause {
        "none" => true,
        "time_delay" => within(det["delay_s"].as_f64(), want["delay_s"].as_f64(), 0.1),
        "disturbance" => {
            let found = crate::common::f64_list(&det["freq_hz"]);
            crate::common::f64_list(&want["freq_hz"])
                .iter()
                .all(|t| found.iter().any(|f| (f / t - 1.0).abs() <= 0.01))
        }
        _ => {
            within(det["freq_hz"].as_f64(), want["freq_hz"].as_f64(), 0.01)
                && want
                    .get("new_freq_hz")
                    .is_none_or(|f| within(det["new_freq_hz"].as_f64(), f.as_f64(), 0.01))
                && want.get("axis").is_none_or(|a| det["axis"] == *a)
                && want.get("kind").is_none_or(|k| det["kind"] == *k)
        }
    };
    let (before, after) = (
        d["fit_before_pct"].as_f64().unwrap_or(f64::NAN),
        d["fit_after_pct"].as_f64().unwrap_or(f64::NAN),
    );
    eprintln!("{tag}: {cause} {det} | want {want} | held-out {before:.2} -> {after:.2} %");
    (cause != want_cause || !numbers || (want_cause != "none" && after - before <= 1.0)).then(
        || format!("{tag}: found {cause} {det}, want {want}, held-out {before:.2} -> {after:.2}"),
    )
}
