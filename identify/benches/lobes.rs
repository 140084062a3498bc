//! Stability-lobe timing: ZOA and semi-discretisation of a 10-mode x–y twin, 200 speeds.

use criterion::{criterion_group, criterion_main, Criterion};
use identify::axis::{Axis, Channel};
use identify::lobes::{lobes_sd, lobes_zoa, stable_sd, Cut, SdOptions, Tool};
use identify::model::{ChannelModel, ModalModel, Mode, ModeNum};

/// A 10-mode twin: 5 modes mostly in x, 5 mostly in y, small cross coupling.
fn twin() -> ModalModel {
    let fs = [
        480.0, 650.0, 910.0, 1300.0, 2100.0, 520.0, 700.0, 980.0, 1500.0, 2600.0,
    ];
    let modes: Vec<Mode> = fs
        .iter()
        .enumerate()
        .map(|(i, &f)| Mode::from_hz(f, 0.02 + 0.003 * i as f64))
        .collect();
    let ch = |o, j, gain: &dyn Fn(usize) -> f64| ChannelModel {
        channel: Channel::new(o, j),
        num: (0..10)
            .map(|k| ModeNum {
                b0: gain(k),
                b1: 0.0,
            })
            .collect(),
        d: 0.0,
    };
    let kx = |k: usize| if k < 5 { 8.0 / (1.0 + k as f64) } else { 0.5 };
    let ky = |k: usize| if k >= 5 { 8.0 / (k as f64 - 3.0) } else { 0.5 };
    let kc = |_k: usize| 0.3;
    ModalModel {
        modes,
        channels: vec![
            ch(Axis::X, Axis::X, &kx),
            ch(Axis::Y, Axis::Y, &ky),
            ch(Axis::X, Axis::Y, &kc),
            ch(Axis::Y, Axis::X, &kc),
        ],
    }
}

fn bench(c: &mut Criterion) {
    let model = twin();
    let tool = Tool {
        teeth: 4,
        diameter_m: 0.016,
        helix_deg: 0.0,
    };
    let cut = Cut {
        radial_immersion: 0.5,
        down_milling: true,
        kt: 7e8,
        kr: 0.3,
    };
    let rpm: Vec<f64> = (0..200).map(|i| 3000.0 + 75.0 * i as f64).collect();
    let mut g = c.benchmark_group("lobes_10_modes_200_speeds");
    g.sample_size(10);
    g.bench_function("zoa", |b| {
        b.iter(|| lobes_zoa(&model, &tool, &cut, &rpm).unwrap())
    });
    g.bench_function("sd_one_monodromy", |b| {
        b.iter(|| stable_sd(&model, &tool, &cut, 9000.0, 1e-3).unwrap())
    });
    g.bench_function("sd_200_speeds_m40", |b| {
        b.iter(|| lobes_sd(&model, &tool, &cut, &rpm, &SdOptions::default()).unwrap())
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
