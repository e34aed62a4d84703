//! Criterion benchmarks of the DAE layer on the validation problems (lash's BDF), plus the
//! explicit baseline on the turning stiff spring. For side-by-side ratios against diffsol
//! and explicit stepping in one run, use `cargo run --release -- bench dae`.

use criterion::{criterion_group, criterion_main, Criterion};
use lash::dae::{AbsTol, BdfOptions, BdfSolver};
use lash::validation::{andrews, reference, robertson, stiff_spring, ROBERTSON_ATOL};
use std::hint::black_box;

fn bdf(c: &mut Criterion) {
    let mut g = c.benchmark_group("bdf");
    g.sample_size(20);
    g.bench_function("andrews_index2_projected_1e-6", |b| {
        let (y0, yp0) = andrews::initial_values();
        let opts = BdfOptions {
            suppress_algebraic: true,
            ..BdfOptions::with_tolerances(1e-6, 1e-6)
        };
        b.iter(|| {
            let sys = andrews::Andrews {
                index: andrews::AndrewsIndex::Two,
                project: true,
            };
            let mut s = BdfSolver::new(sys, 0.0, &y0, &yp0, &[], opts.clone()).unwrap();
            s.solve_to(reference::ANDREWS_T_END).unwrap();
            black_box(s.y()[0])
        })
    });
    g.bench_function("stiff_spring_damped_1e-6", |b| {
        let sys = stiff_spring::StiffSpring::validation(true);
        let (y0, yp0) = sys.initial_values();
        b.iter(|| {
            let mut s =
                BdfSolver::new(sys, 0.0, &y0, &yp0, &[], BdfOptions::with_tolerances(1e-6, 1e-6)).unwrap();
            s.solve_to(10.0).unwrap();
            black_box(s.y()[0])
        })
    });
    g.bench_function("robertson_1e11", |b| {
        let (y0, yp0) = robertson::Robertson::initial_values();
        let opts = BdfOptions {
            atol: AbsTol::Vector(ROBERTSON_ATOL.to_vec()),
            ..BdfOptions::with_tolerances(1e-6, 1.0)
        };
        b.iter(|| {
            let mut s = BdfSolver::new(robertson::Robertson, 0.0, &y0, &yp0, &[], opts.clone()).unwrap();
            s.solve_to(reference::ROBERTSON_T_END).unwrap();
            black_box(s.y()[0])
        })
    });
    g.finish();
}

fn explicit(c: &mut Criterion) {
    let mut g = c.benchmark_group("explicit");
    g.sample_size(10);
    g.bench_function("stiff_spring_dopri5_1e-6", |b| {
        let sys = stiff_spring::StiffSpring::validation(true);
        let (y0, _) = sys.initial_values();
        b.iter(|| {
            let o = lash::dae::explicit::Dopri5Options {
                rtol: 1e-6,
                atol: 1e-6,
                ..Default::default()
            };
            let mut d = lash::dae::explicit::Dopri5::new(sys, 0.0, &y0, &[], o).unwrap();
            d.solve_to(10.0).unwrap();
            black_box(d.y()[0])
        })
    });
    g.finish();
}

criterion_group!(benches, bdf, explicit);
criterion_main!(benches);
