//! A research code embedding lash: a user-defined DAE solved through the public API only.
//!
//! The problem: a bead of mass m sliding without friction on a rotating parabolic wire
//! z = a·r² that spins at a constant rate Ω about the vertical. In the rotating frame, with
//! unknowns y = (r, z, u = r', w = z', λ) — λ the wire's normal force per unit mass — the
//! equations are
//!
//!   r' = u,  z' = w,
//!   u' = Ω²·r + λ·(2a·r),        (centrifugal + constraint)
//!   w' = −g − λ,
//!   0  = 2a·r·u − w              (velocity constraint: index 2).
//!
//! Above the critical rate Ω² > 2ag the bead slides away from the axis. We integrate, stop at
//! the event r = 0.5 m, switch the rotation off (a discontinuity in the data) and restart.
//!
//! Run: `cargo run --release --example user_dae`

use lash::dae::{BdfOptions, BdfSolver, DaeError, DaeSystem, EvalError, JacobianSource, Outcome, VarKind};
use lash::sparse::CscPattern;

struct Bead {
    /// Wire shape coefficient, 1/m.
    a: f64,
    /// Gravity, m/s².
    g: f64,
}

impl DaeSystem for Bead {
    fn dim(&self) -> usize {
        5
    }

    // p[0] = Ω, the rotation rate in rad/s: a parameter, not state.
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        res: &mut [f64],
    ) -> Result<(), EvalError> {
        let (r, _z, u, w, lam) = (y[0], y[1], y[2], y[3], y[4]);
        let om = p[0];
        res[0] = yp[0] - u;
        res[1] = yp[1] - w;
        res[2] = yp[2] - om * om * r - lam * 2.0 * self.a * r;
        res[3] = yp[3] + self.g + lam;
        res[4] = 2.0 * self.a * r * u - w;
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        // Entries of dF/dy + α·dF/dy', as (row, column).
        let e = [
            (0, 0),
            (2, 0),
            (4, 0),
            (1, 1),
            (0, 2),
            (2, 2),
            (4, 2),
            (1, 3),
            (3, 3),
            (4, 3),
            (2, 4),
            (3, 4),
        ];
        CscPattern::from_entries(5, 5, e).expect("valid pattern")
    }

    // Let lash build the Jacobian by coloured finite differences.
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::FiniteDifference
    }

    fn var_kinds(&self) -> Vec<VarKind> {
        use VarKind::*;
        vec![Differential, Differential, Differential, Differential, Algebraic]
    }

    fn component_name(&self, i: usize) -> String {
        ["r", "z", "u", "w", "lambda"][i].into()
    }

    fn num_events(&self) -> usize {
        1
    }

    fn events(&mut self, _t: f64, y: &[f64], _yp: &[f64], _p: &[f64], g: &mut [f64]) {
        g[0] = y[0] - 0.5;
    }
}

/// Consistent (y, y') on the wire at radius r with radial speed u, rotating at Ω: the
/// multiplier follows from differentiating the velocity constraint once more.
/// (This is an index-2 problem, so `calc_ic`, which is for index 1, does not apply.)
fn consistent(b: &Bead, r: f64, u: f64, omega: f64) -> ([f64; 5], [f64; 5]) {
    let w = 2.0 * b.a * r * u;
    let lam =
        -(b.g + 2.0 * b.a * u * u + 2.0 * b.a * omega * omega * r * r) / (1.0 + 4.0 * b.a * b.a * r * r);
    let up = omega * omega * r + 2.0 * b.a * lam * r;
    let wp = -b.g - lam;
    ([r, b.a * r * r, u, w, lam], [u, w, up, wp, 0.0])
}

fn main() -> Result<(), DaeError> {
    let bead = Bead { a: 1.0, g: 9.81 };
    let omega = 5.0; // rad/s, above the critical sqrt(2ag) = 4.43 rad/s
    let (y0, yp0) = consistent(&bead, 0.1, 0.0, omega);
    let mut opts = BdfOptions::with_tolerances(1e-8, 1e-10);
    opts.suppress_algebraic = true; // λ is an index-2 multiplier
    let mut solver = BdfSolver::new(bead, 0.0, &y0, &yp0, &[omega], opts)?;
    println!("consistent start: lambda = {:.6} m/s²", solver.y()[4]);

    println!("{:>8} {:>10} {:>10} {:>12}", "t [s]", "r [m]", "z [m]", "lambda");
    let mut t_out = 0.0;
    while t_out < 3.0 {
        t_out += 0.25;
        match solver.solve_to(t_out)? {
            Outcome::Event { .. } if solver.params()[0] == 0.0 => {
                println!("event: r = 0.5 m crossed at t = {:.6} s", solver.t());
                t_out = solver.t();
            }
            Outcome::Event { .. } => {
                println!(
                    "event: r = 0.5 m reached at t = {:.6} s; rotation switched off",
                    solver.t()
                );
                // Change the parameter — a discontinuity — and restart at order 1 from a
                // state consistent with the new parameter.
                let (t, r, u) = (solver.t(), solver.y()[0], solver.y()[2]);
                let (y, yp) = consistent(solver.system(), r, u, 0.0);
                solver.set_params(&[0.0])?;
                solver.restart_from(t, &y, &yp)?;
                t_out = t;
            }
            _ => println!(
                "{:>8.3} {:>10.6} {:>10.6} {:>12.6}",
                solver.t(),
                solver.y()[0],
                solver.y()[1],
                solver.y()[4]
            ),
        }
    }
    let st = solver.stats();
    println!(
        "{} steps, {} Newton iterations, {} LU factorisations",
        st.steps, st.newton_iters, st.lu_factorisations
    );
    Ok(())
}
