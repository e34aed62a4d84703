//! Criterion benchmarks of the 63-DOF MR2120 clearance model (L1, the paper's trajectory):
//! lash's BDF over the first 0.25 s. For the side-by-side comparison with explicit stepping
//! at equal accuracy, use `cargo run --release -- bench mr2120`.

use criterion::{criterion_group, criterion_main, Criterion};
use lash::bench::mr2120::{bench_mechanism, BENCH_DAMPING};
use lash::mechanisms::mr2120::trajectory::clearance_options;
use lash::multibody::Simulation;
use std::hint::black_box;
use std::sync::Arc;

fn clearance_l1(c: &mut Criterion) {
    let model = bench_mechanism("L1", BENCH_DAMPING).unwrap();
    let mech = Arc::new(model.mechanism);
    let times: Vec<f64> = (1..=25).map(|k| k as f64 * 0.01).collect();
    let mut grp = c.benchmark_group("mr2120_clearance_l1");
    grp.sample_size(10);
    grp.bench_function("bdf_rtol_1e-4_first_0.25s", |b| {
        b.iter(|| {
            let mut opts = clearance_options();
            opts.bdf.rtol = 1e-4;
            opts.bdf.atol = lash::dae::AbsTol::Scalar(1e-6);
            opts.singularity_warning = 0.0;
            let mut sim = Simulation::new(mech.clone(), 0.0, opts).unwrap();
            let tr = sim.run(&times, |_| {}).unwrap();
            black_box(tr.samples.len())
        })
    });
    grp.finish();
}

criterion_group!(benches, clearance_l1);
criterion_main!(benches);
