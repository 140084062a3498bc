//! [`band_limited_lti`], the simulation behind the refit's drift check and its fit after
//! the update, and the twin's time fit: 9 modes, two forces (x, y) driving four channels
//! (xx, yx, xy, yy), 15 s at 5120 Hz (76 800 samples), the size of one milling record of
//! case f in `scripts/bench_peers.sh`.
//!
//! Run: `cargo bench -p mtwin-core --bench simulate`.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use mtwin_core::axis::{Axis, Channel};
use mtwin_core::model::{ChannelModel, ModalModel, Mode, ModeNum};
use mtwin_core::simulate::band_limited_lti;

fn model() -> ModalModel {
    let freqs = [
        120.0, 180.0, 250.0, 410.0, 600.0, 880.0, 1200.0, 1700.0, 2300.0,
    ];
    let modes: Vec<Mode> = freqs.iter().map(|&f| Mode::from_hz(f, 0.03)).collect();
    let mut channels = Vec::new();
    for (i, input) in [Axis::X, Axis::Y].into_iter().enumerate() {
        for (o, output) in [Axis::X, Axis::Y].into_iter().enumerate() {
            let a = if i == o { 1e-7 } else { 2e-8 };
            channels.push(ChannelModel {
                channel: Channel::new(output, input),
                num: (0..freqs.len())
                    .map(|k| ModeNum {
                        b0: a * (1.0 + k as f64) * 1e6,
                        b1: a * 10.0,
                    })
                    .collect(),
                d: 0.0,
            });
        }
    }
    ModalModel { modes, channels }
}

fn bench(c: &mut Criterion) {
    let model = model();
    let n = 76_800;
    let forces: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let t = i as f64;
            [(0.37 * t).sin() + (0.011 * t).cos(), (1.3 * t).cos(), 0.0]
        })
        .collect();
    c.bench_function("band_limited_lti 9 modes 2x2 76800 samples", |b| {
        b.iter(|| band_limited_lti(black_box(&model), black_box(&forces), 1.0 / 5120.0))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
