//! Criterion benchmarks of the 63-DOF MR2120 clearance model (L1, the paper's trajectory):
//! lash's BDF over the first 0.25 s. For the side-by-side comparison with explicit stepping
//! at equal accuracy, use `cargo run --release -- bench mr2120`.

use criterion::{criterion_group, criterion_main, Criterion};
use lash::bench::mr2120::BENCH_DAMPING;
use lash::mechanisms::mr2120::clearance::{bearing_design, clearance_model, clearance_set};
use lash::mechanisms::mr2120::paper::TABLE2;
use lash::mechanisms::mr2120::trajectory::{clearance_options, drive_laws};
use lash::mechanisms::mr2120::{Geometry, MassProperties};
use lash::multibody::Simulation;
use nalgebra::Vector3;
use std::hint::black_box;
use std::sync::Arc;

fn clearance_l1(c: &mut Criterion) {
    let g = Geometry::default();
    let set = clearance_set("L1").unwrap();
    let model = clearance_model(
        &g,
        &MassProperties::default(),
        Vector3::from(TABLE2[0].m),
        Some(drive_laws(&g)),
        &bearing_design(&set, BENCH_DAMPING),
    )
    .unwrap();
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
