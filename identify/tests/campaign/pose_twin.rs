//! The pose-dependent twin on a generated machine whose modes shift by up to ~10 % across
//! the workspace: a 3×3×2 grid of impact tests (hammer along x and y), the campaign
//! identified, and the twin's FRF at UNMEASURED poses scored against the analytic FRF
//! (xx and yy, 50–2500 Hz). Target ≥ 98 %.

use identify::axis::{Axis, Channel};
use identify::campaign::{identify_campaign, CampaignOptions};
use identify::frf::fit_percent;
use identify::interpolate::TwinEvaluator;
use identify::rational_fit::FitOptions;
use rayon::prelude::*;
use vmachine::daq::{impact_record, Daq};
use vmachine::structure::ModalMachine;

#[test]
fn twin_at_unmeasured_poses_matches_the_analytic_frf() {
    let machine = ModalMachine::default_machine();
    let poses = machine.grid([3, 3, 2]);
    let daq = Daq::default();
    let axes = [Axis::X, Axis::Y];
    let jobs: Vec<(usize, [f64; 3], Axis)> = poses
        .iter()
        .enumerate()
        .flat_map(|(i, p)| axes.iter().map(move |a| (i, *p, *a)))
        .collect();
    let records: Vec<_> = jobs
        .par_iter()
        .map(|(i, p, a)| impact_record(&machine, *p, *a, &axes, 3, &daq, 100 + *i as u64))
        .collect();
    let opts = CampaignOptions {
        fit: FitOptions {
            band_hz: Some((30.0, 2500.0)),
            ..FitOptions::default()
        },
        ..CampaignOptions::default()
    };
    let res = identify_campaign(&records, &opts, &|_, _| {}).unwrap();
    let twin = res.twin;
    assert_eq!(twin.poses.len(), 18);
    // per-pose identification against truth (at the measured poses)
    let freqs0: Vec<f64> = (0..=1225).map(|k| 50.0 + 2.0 * k as f64).collect();
    for pm in twin.poses.iter().take(3) {
        let truth = machine.frf_at(pm.pose, &freqs0, &axes);
        let fits: Vec<String> = pm
            .model
            .channels
            .iter()
            .enumerate()
            .map(|(ci, c)| {
                let ti = truth
                    .channels
                    .iter()
                    .position(|t| t.channel == c.channel)
                    .unwrap();
                let est: Vec<_> = freqs0.iter().map(|&f| pm.model.eval_hz(ci, f)).collect();
                format!(
                    "{} {:.2}",
                    c.channel,
                    fit_percent(&truth.channels[ti].h, &est)
                )
            })
            .collect();
        eprintln!(
            "measured pose {:?}: {} modes {:?}, vs truth {}",
            pm.pose,
            pm.model.modes.len(),
            pm.model
                .modes
                .iter()
                .map(|m| m.freq_hz().round())
                .collect::<Vec<_>>(),
            fits.join(", ")
        );
    }
    if std::env::var_os("MTWIN_VERBOSE").is_some() {
        for pm in &twin.poses {
            let tr: Vec<f64> = (0..machine.modes.len())
                .map(|k| machine.mode_at(k, pm.pose).freq_hz().round())
                .collect();
            eprintln!(
                "{:?}: {:?} truth {:?}",
                pm.pose.map(|v| (v * 100.0).round() / 100.0),
                pm.model
                    .modes
                    .iter()
                    .map(|m| m.freq_hz().round())
                    .collect::<Vec<_>>(),
                tr
            );
        }
        eprintln!("{:?}", twin.interpolation);
    }
    let mut ev = TwinEvaluator::new(&twin).unwrap();
    let freqs: Vec<f64> = (0..=1225).map(|k| 50.0 + 2.0 * k as f64).collect();
    let unmeasured = [
        [0.15, 0.45, 0.1],
        [0.45, 0.15, 0.3],
        [0.2, 0.2, 0.2],
        [0.5, 0.4, 0.05],
    ];
    let mut worst: f64 = 100.0;
    for p in unmeasured {
        let model = ev.model_at(p).clone();
        let truth = machine.frf_at(p, &freqs, &axes);
        for ch in [
            Channel::new(Axis::X, Axis::X),
            Channel::new(Axis::Y, Axis::Y),
        ] {
            let ci = model.channel_index(ch).unwrap();
            let ti = truth.channels.iter().position(|c| c.channel == ch).unwrap();
            let est: Vec<_> = freqs.iter().map(|&f| model.eval_hz(ci, f)).collect();
            let fit = fit_percent(&truth.channels[ti].h, &est);
            eprintln!("pose {p:?} {ch}: {fit:.2} %");
            worst = worst.min(fit);
        }
    }
    eprintln!("worst fit at unmeasured poses: {worst:.2} %");
    assert!(worst >= 98.0, "worst {worst}");
}
