//! One doStep of the slave core (no C layer): 2 force axes, 9 modes, pose interpolation
//! on a 3×3×2 grid twin (tensor splines): the axes moving every step, and standing still
//! (the discretisation is then reused). Target < 1 µs.

use criterion::{criterion_group, criterion_main, Criterion};
use mtwin_core::axis::Axis;
use mtwin_core::twin::Twin;
use mtwin_fmu::slave::Slave;
use vmachine::structure::ModalMachine;

fn twin() -> Twin {
    ModalMachine::default_machine().exact_twin([3, 3, 2], &[Axis::X, Axis::Y])
}

fn bench(c: &mut Criterion) {
    let tw = twin();
    let mut s = Slave::new(&tw).expect("slave");
    s.enter_init().expect("init");
    s.exit_init().expect("init");
    let (vfx, vfy, vx, vy) = (0u32, 1u32, 2u32, 3u32);
    let dt = 1e-4;
    let mut t = 0.0;
    let mut k = 0u64;
    c.bench_function("do_step_9_modes_2_axes_moving_pose", |b| {
        b.iter(|| {
            k += 1;
            let x = 0.3 + 0.2 * ((k % 1000) as f64 * 1e-3);
            s.set_real(&[vfx, vfy, vx, vy], &[100.0, -50.0, x, 0.2])
                .expect("set");
            let mut y = [0.0; 2];
            s.get_real(&[5, 6], &mut y).expect("get");
            s.do_step(t, dt).expect("step");
            t += dt;
            y
        })
    });
    c.bench_function("do_step_9_modes_2_axes_fixed_pose", |b| {
        b.iter(|| {
            s.set_real(&[vfx, vfy, vx, vy], &[100.0, -50.0, 0.3, 0.2])
                .expect("set");
            let mut y = [0.0; 2];
            s.get_real(&[5, 6], &mut y).expect("get");
            s.do_step(t, dt).expect("step");
            t += dt;
            y
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
