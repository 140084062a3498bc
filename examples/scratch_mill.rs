use identify::campaign::group_by_pose;
use identify::diagnose::{evidence, points};
use identify::modal_update::{chi, update_modes, Prior};
use vmachine::hidden::{base_twin, milling_case, Effect, AXES};
use vmachine::structure::ModalMachine;
fn main() {
    let m = ModalMachine::default_machine();
    let tw = base_twin(&m, &AXES);
    let model = tw.poses[0].model.clone();
    for seed in [104u64, 106] {
        let c = milling_case(Effect::PoseDependence, seed, &tw);
        for g in group_by_pose(&c.records, 1e-3) {
            let recs: Vec<_> = g.records.iter().map(|&i| c.records[i].clone()).collect();
            let e = evidence(&recs).unwrap();
            let pts = points(&e, (30.0, 2500.0), 0.8);
            let npts: usize = pts.iter().map(|p| p.h.len()).sum();
            for k in [0usize, 2, 3] {
                let truth = m.mode_at(k, g.pose).freq_hz();
                let r = update_modes(
                    &model,
                    &[k],
                    &pts,
                    Prior {
                        ln_wn: 0.3,
                        ..Prior::default()
                    },
                    40,
                )
                .unwrap();
                println!("seed {seed} pose {:.3} pts {npts} mode {k}: truth {truth:.2}  retune {:.2} chi {:.2} -> {:.2}", g.pose[0], r.model.modes[k].freq_hz(), chi(&model, &pts, 0.0), chi(&r.model, &pts, 0.0));
            }
        }
    }
}
