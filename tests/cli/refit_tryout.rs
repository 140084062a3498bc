//! The default refit on data from an independent generator (`tryout_gantry` in the shared
//! data): the twin the default `mtwin identify` makes from the impact campaign, then the
//! default `mtwin refit` on milling records of the worn machine (one mode lost stiffness;
//! the cutting excites the tooth-passing harmonics and a broadband share). Scored against
//! the generator's analytic FRF of the worn machine at the milling pose: the worn mode
//! moves to its new frequency (computed from `truth/machine.json`), no other mode moves or
//! takes its place, the twin comes closer to the worn truth around the mode and no worse
//! elsewhere, and the history grows by one entry.

use crate::common::*;
use identify::axis::{Axis, Channel};
use identify::frf::{fit_percent, Frf};
use identify::model::ModalModel;
use identify::read::read_frf_csv;
use identify::twin::Twin;
use std::path::PathBuf;

fn tryout() -> PathBuf {
    let t = shared_data().join("tryout_gantry");
    assert!(
        t.join("truth/machine.json").is_file(),
        "shared data tryout_gantry not found at {}",
        t.display()
    );
    t
}

/// Fit [%] of the model's channel `ch` to the truth over `band`.
fn fit(model: &ModalModel, truth: &Frf, ch: Channel, band: (f64, f64)) -> f64 {
    let ci = model.channel_index(ch).expect("modelled channel");
    let tc = truth
        .channels
        .iter()
        .find(|c| c.channel == ch)
        .expect("truth channel");
    let (mut t, mut m) = (Vec::new(), Vec::new());
    for (f, h) in truth.freqs_hz.iter().zip(&tc.h) {
        if *f >= band.0 && *f <= band.1 {
            t.push(*h);
            m.push(model.eval_hz(ci, *f));
        }
    }
    fit_percent(&t, &m)
}

#[test]
fn default_refit_tracks_the_worn_mode_of_the_tryout_gantry() {
    let t = tryout();
    let d = tmp();
    let base = d.path().join("base.json");
    let out = d.path().join("worn.json");
    let mut campaign: Vec<PathBuf> = std::fs::read_dir(t.join("campaign"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    campaign.sort();
    let mut args = vec!["identify", "-q"];
    args.extend(campaign.iter().map(|p| s(p)));
    args.extend(["--out", s(&base)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "identify: {}", stderr(&o));

    let mut milling: Vec<PathBuf> = std::fs::read_dir(t.join("worn_milling"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    milling.sort();
    let mut args = vec!["refit", "--twin", s(&base)];
    args.extend(milling.iter().map(|p| s(p)));
    args.extend(["--out", s(&out)]);
    let o = mtwin(&args);
    assert!(o.status.success(), "refit: {}", stderr(&o));
    eprintln!("{}", stderr(&o));

    // the wear, from the generator's description
    let machine: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.join("truth/machine.json")).unwrap())
            .unwrap();
    let f0 = machine["wear"]["mode_f0_hz"].as_f64().unwrap();
    let factor = machine["wear"]["stiffness_factor"].as_f64().unwrap();
    let f_worn = f0 * factor.sqrt();

    let truth_path = t.join("truth/centre_worn.csv");
    let truth = read_frf_csv(&truth_path).unwrap();
    let pose = pose_of(&truth_path);
    let before = Twin::load(&base).unwrap();
    let after = Twin::load(&out).unwrap();
    let m0 = before.model_at(pose).unwrap();
    let m1 = after.model_at(pose).unwrap();

    // the worn mode: the one nearest its healthy frequency, now within 1 % of the worn one
    let k = (0..m0.modes.len())
        .min_by(|&a, &b| {
            (m0.modes[a].freq_hz() - f0)
                .abs()
                .total_cmp(&(m0.modes[b].freq_hz() - f0).abs())
        })
        .unwrap();
    let f1 = m1.modes[k].freq_hz();
    eprintln!(
        "worn mode {k}: {:.2} Hz -> {f1:.2} Hz (truth {f_worn:.2} Hz)",
        m0.modes[k].freq_hz()
    );
    assert!(
        (f1 - f_worn).abs() < 0.01 * f_worn,
        "mode {k} at {f1:.2} Hz, worn truth {f_worn:.2} Hz"
    );
    // one mode changed: no other moves (nor takes the worn mode's place)
    for j in (0..m0.modes.len()).filter(|&j| j != k) {
        let (a, b) = (m0.modes[j].freq_hz(), m1.modes[j].freq_hz());
        assert!(
            (b - a).abs() < 0.01 * a,
            "mode {j} moved {a:.2} -> {b:.2} Hz"
        );
    }

    // closer to the worn truth around the mode, no worse in y nor over the whole band
    let (xx, yy) = (
        Channel::new(Axis::X, Axis::X),
        Channel::new(Axis::Y, Axis::Y),
    );
    let (near, all) = ((300.0, 700.0), (30.0, 2500.0));
    for (ch, band) in [(xx, near), (yy, near), (xx, all), (yy, all)] {
        let (a, b) = (fit(&m0, &truth, ch, band), fit(&m1, &truth, ch, band));
        eprintln!("{ch} {band:?} Hz vs worn truth: {a:.2} % -> {b:.2} %");
        if ch == xx && band == near {
            assert!(b > a && b >= 95.0, "{ch} {band:?}: {a:.2} % -> {b:.2} %");
        } else {
            assert!(b >= a - 0.1, "{ch} {band:?}: {a:.2} % -> {b:.2} %");
        }
    }

    assert_eq!(after.history.len(), before.history.len() + 1);
    assert_eq!(after.history.last().unwrap().kind, "refit");
    assert_eq!(after.history.last().unwrap().previous_poses, before.poses);
}
