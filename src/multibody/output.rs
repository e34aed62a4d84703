//! CSV output: per body (pose and velocity) and per joint (reaction force and torque).

use super::analysis::Analysis;
use super::error::ModelError;
use super::model::Mechanism;
use super::simulation::Sample;
use std::io::Write;

fn io(e: std::io::Error) -> ModelError {
    ModelError::Output(e.to_string())
}

/// Writes one row per sample and body: time, body, position (m), Euler parameters, velocity
/// (m/s), body-frame angular velocity (rad/s).
pub fn write_bodies_csv(
    out: &mut impl Write,
    model: &Mechanism,
    samples: &[Sample],
) -> Result<(), ModelError> {
    writeln!(
        out,
        "t_s,body,x_m,y_m,z_m,e0,e1,e2,e3,vx_m_s,vy_m_s,vz_m_s,wx_rad_s,wy_rad_s,wz_rad_s"
    )
    .map_err(io)?;
    for s in samples {
        let lay = model.layout();
        for (h, b) in model.bodies().iter() {
            let q = &s.q[lay.body_q(h)];
            let w = &s.w[lay.body_w(h)];
            write!(out, "{},{}", s.t, b.name).map_err(io)?;
            for v in q.iter().chain(w) {
                write!(out, ",{v}").map_err(io)?;
            }
            writeln!(out).map_err(io)?;
        }
    }
    Ok(())
}

/// Writes one row per sample and joint: time, joint, reaction force on the joint's second
/// body (N) and torque about the joint origin (N·m), base frame.
pub fn write_reactions_csv(
    out: &mut impl Write,
    model: &Mechanism,
    analysis: &Analysis,
    samples: &[Sample],
) -> Result<(), ModelError> {
    writeln!(out, "t_s,joint,fx_N,fy_N,fz_N,tx_Nm,ty_Nm,tz_Nm").map_err(io)?;
    let names: Vec<String> = model.joints().map(|(_, j)| j.name.clone()).collect();
    for s in samples {
        let r = analysis.reactions(model, s.t, &s.q, &s.lambda);
        for (name, r) in names.iter().zip(r) {
            writeln!(
                out,
                "{},{},{},{},{},{},{},{}",
                s.t, name, r.force[0], r.force[1], r.force[2], r.torque[0], r.torque[1], r.torque[2]
            )
            .map_err(io)?;
        }
    }
    Ok(())
}
