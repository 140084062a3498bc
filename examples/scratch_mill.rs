use identify::axis::Axis;
use identify::interpolate::TwinEvaluator;
use vmachine::hidden::{base_twin, AXES, POSE};
use vmachine::structure::ModalMachine;
fn main() {
    let m = ModalMachine::default_machine();
    let tw = base_twin(&m, &AXES);
    for p in &tw.poses {
        println!(
            "fit {:?}",
            p.fit
                .iter()
                .map(|c| format!("{} {:.3}", c.channel, c.fit_pct))
                .collect::<Vec<_>>()
        );
        println!(
            "modes {:?}",
            p.model
                .modes
                .iter()
                .map(|m| format!("{:.2} {:.4}", m.freq_hz(), m.zeta))
                .collect::<Vec<_>>()
        );
    }
    let mut ev = TwinEvaluator::new(&tw).unwrap();
    let model = ev.model_at(POSE).clone();
    let truth = m.model_at(POSE, &AXES);
    let _ = Axis::X;
    for ci in 0..truth.channels.len() {
        let c = truth.channels[ci].channel;
        let mi = model.channel_index(c).unwrap();
        let fr: Vec<f64> = (30..2500).map(|f| f as f64).collect();
        let hmax = fr
            .iter()
            .map(|f| truth.eval_hz(ci, *f).norm())
            .fold(0.0, f64::max);
        let worst = fr
            .iter()
            .map(|f| {
                (
                    (model.eval_hz(mi, *f) - truth.eval_hz(ci, *f)).norm() / hmax,
                    *f,
                )
            })
            .fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        println!(
            "{c}: hmax {hmax:.3e} worst abs err / hmax {:.4} at {} Hz",
            worst.0, worst.1
        );
    }
    let p = &tw.poses[0];
    let fr = &p.frf.freqs_hz;
    println!(
        "stored frf {} lines {:.2}..{:.2} df {:.3}",
        fr.len(),
        fr[0],
        fr[fr.len() - 1],
        fr[1] - fr[0]
    );
    for c in &p.frf.channels {
        let mi = model.channel_index(c.channel).unwrap();
        let ti = truth.channel_index(c.channel).unwrap();
        for f0 in [62.0, 100.0, 186.0, 280.0, 420.0, 450.0, 600.0, 1000.0] {
            let (mut rr, mut ee, mut n) = (0.0, 0.0, 0.0);
            for (i, f) in fr.iter().enumerate() {
                if (*f - f0).abs() <= 0.025 * f0 {
                    rr += (p.model.eval_hz(mi, *f) - c.h[i]).norm_sqr();
                    ee += (model.eval_hz(mi, *f) - truth.eval_hz(ti, *f)).norm_sqr();
                    n += 1.0;
                }
            }
            print!(
                " {f0}: res {:.2e} err {:.2e} n {n} |",
                (rr / n).sqrt(),
                (ee / n).sqrt()
            );
        }
        println!(" {}", c.channel);
    }
}
