//! Force elements for clearance contacts: a ball end in a cylindrical socket (radial and
//! axial clearance), and a ball in a spherical socket.

use super::laws::{Friction, NormalLaw};
use crate::multibody::forces::{BodyLoad, BodyState, ForceElement};
use crate::multibody::{Attach, BodyHandle};
use nalgebra::Vector3;

use crate::multibody::forces::state_of as state;

/// Applies the contact force `f` (base frame) at base-frame point `x`: +f on the ball side,
/// −f on the socket side.
fn apply_pair(
    states: &[BodyState],
    loads: &mut [BodyLoad],
    ball: Attach,
    socket: Attach,
    x: &Vector3<f64>,
    f: &Vector3<f64>,
) {
    for (side, sign) in [(ball, 1.0), (socket, -1.0)] {
        if let Attach::Body(h) = side {
            let st = &states[h.index()];
            let s_local = st.a.transpose() * (x - st.r);
            loads[h.index()].add_force_at(st, &s_local, &(sign * f));
        }
    }
}

/// Relative velocity of the ball-side material point at `x` with respect to the socket-side
/// material point at `x`, m/s.
fn relative_velocity(b: &BodyState, s: &BodyState, x: &Vector3<f64>) -> Vector3<f64> {
    let vb = b.v + b.a * b.omega.cross(&(b.a.transpose() * (x - b.r)));
    let vs = s.v + s.a * s.omega.cross(&(s.a.transpose() * (x - s.r)));
    vb - vs
}

fn friction_force(
    fr: &Option<Friction>,
    fn_mag: f64,
    v_rel: &Vector3<f64>,
    n: &Vector3<f64>,
) -> Vector3<f64> {
    match fr {
        Some(fr) if fn_mag > 0.0 => {
            let vt = v_rel - n * v_rel.dot(n);
            let s = vt.norm();
            if s < 1e-300 {
                Vector3::zeros()
            } else {
                -vt * (fr.factor(s) * fn_mag / s)
            }
        }
        _ => Vector3::zeros(),
    }
}

/// A ball end (centre fixed on the ball body) in a cylindrical socket (on the socket body):
/// radial contact when the ball centre leaves the socket axis by more than the radial
/// clearance, axial contact when it passes the stop at `axial_stop` along the outward axis.
#[derive(Debug, Clone)]
pub struct ClearanceBearing {
    /// Name.
    pub name: String,
    /// Body carrying the ball.
    pub ball_body: Attach,
    /// Ball centre, ball-body frame, m.
    pub ball_centre: Vector3<f64>,
    /// Body carrying the socket.
    pub socket_body: Attach,
    /// Socket centre (the ball centre's nominal place), socket-body frame, m.
    pub socket_centre: Vector3<f64>,
    /// Unit socket axis pointing outwards (towards the socket's end face), socket-body frame.
    pub socket_axis: Vector3<f64>,
    /// Radial clearance h_LR (socket radius − ball radius), m.
    pub radial_clearance: f64,
    /// Axial travel of the ball centre before it meets the end face, m.
    pub axial_stop: f64,
    /// Law of the radial (ball-in-bore) contact.
    pub radial_law: NormalLaw,
    /// Law of the axial (ball-on-face) contact.
    pub axial_law: NormalLaw,
    /// Optional friction.
    pub friction: Option<Friction>,
}

/// Contact geometry of a bearing at given body states.
struct BearingGeometry {
    ball: BodyState,
    socket: BodyState,
    /// Ball centre, base frame.
    centre: Vector3<f64>,
    /// Outward socket axis, base frame.
    axis: Vector3<f64>,
    /// Travel of the ball centre along the axis from the socket centre, m.
    axial: f64,
    /// Offset of the ball centre from the socket axis, base frame.
    radial: Vector3<f64>,
}

impl ClearanceBearing {
    fn geometry(&self, states: &[BodyState]) -> BearingGeometry {
        let (ball, socket) = (state(states, self.ball_body), state(states, self.socket_body));
        let centre = ball.point(&self.ball_centre);
        let axis = socket.a * self.socket_axis;
        let d = centre - socket.point(&self.socket_centre);
        let axial = d.dot(&axis);
        BearingGeometry {
            ball,
            socket,
            centre,
            axis,
            axial,
            radial: d - axis * axial,
        }
    }

    /// Radial and axial penetrations (m; negative: gap) at the given states.
    pub fn penetrations(&self, states: &[BodyState]) -> (f64, f64) {
        let g = self.geometry(states);
        (g.radial.norm() - self.radial_clearance, g.axial - self.axial_stop)
    }
}

impl ForceElement for ClearanceBearing {
    fn name(&self) -> &str {
        &self.name
    }

    fn bodies(&self) -> Vec<BodyHandle> {
        [self.ball_body, self.socket_body]
            .into_iter()
            .filter_map(Attach::body)
            .collect()
    }

    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let BearingGeometry {
            ball: b,
            socket: s,
            centre: c,
            axis: a,
            axial,
            radial: radial_vec,
        } = self.geometry(states);
        let rho = radial_vec.norm();
        let v_rel = relative_velocity(&b, &s, &c);
        let mut f = Vector3::zeros();
        let delta_r = rho - self.radial_clearance;
        if delta_r > 0.0 && rho > 0.0 {
            let n = radial_vec / rho; // from the axis to the ball centre
            let fn_mag = self.radial_law.force(delta_r, v_rel.dot(&n));
            f += -n * fn_mag + friction_force(&self.friction, fn_mag, &v_rel, &n);
        }
        let delta_a = axial - self.axial_stop;
        if delta_a > 0.0 {
            let fn_mag = self.axial_law.force(delta_a, v_rel.dot(&a));
            f += -a * fn_mag + friction_force(&self.friction, fn_mag, &v_rel, &a);
        }
        if f != Vector3::zeros() {
            apply_pair(states, loads, self.ball_body, self.socket_body, &c, &f);
        }
    }
}

/// A ball (centre fixed on the ball body) in a spherical socket with radial clearance.
#[derive(Debug, Clone)]
pub struct BallInSocket {
    /// Name.
    pub name: String,
    /// Body carrying the ball.
    pub ball_body: Attach,
    /// Ball centre, ball-body frame, m.
    pub ball_centre: Vector3<f64>,
    /// Body carrying the socket.
    pub socket_body: Attach,
    /// Socket centre, socket-body frame, m.
    pub socket_centre: Vector3<f64>,
    /// Clearance (socket radius − ball radius), m.
    pub clearance: f64,
    /// Contact law.
    pub law: NormalLaw,
    /// Optional friction.
    pub friction: Option<Friction>,
}

impl ForceElement for BallInSocket {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        [self.ball_body, self.socket_body]
            .into_iter()
            .filter_map(Attach::body)
            .collect()
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (b, s) = (state(states, self.ball_body), state(states, self.socket_body));
        let c = b.point(&self.ball_centre);
        let d = c - s.point(&self.socket_centre);
        let r = d.norm();
        let delta = r - self.clearance;
        if delta > 0.0 && r > 0.0 {
            let n = d / r;
            let v_rel = relative_velocity(&b, &s, &c);
            let fn_mag = self.law.force(delta, v_rel.dot(&n));
            let f = -n * fn_mag + friction_force(&self.friction, fn_mag, &v_rel, &n);
            apply_pair(states, loads, self.ball_body, self.socket_body, &c, &f);
        }
    }
}
