//! Force elements for clearance contacts: a ball end in a cylindrical socket (radial and
//! axial clearance), and a ball in a spherical socket.

use super::dual::{self as ad, DState, D, POSITIONS, V3};
use super::laws::{Friction, NormalLaw};
use crate::multibody::forces::{BodyLoad, BodyState, ForceElement, LoadDerivative};
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

/// The loads of a contact force `f` (with derivatives) at base-frame point `x` as
/// [`LoadDerivative`] blocks: +f on the ball side, −f on the socket side.
fn pair_derivatives<const N: usize>(
    ball: Attach,
    socket: Attach,
    bs: &DState<N>,
    ss: &DState<N>,
    x: &V3<N>,
    f: &V3<N>,
) -> Vec<LoadDerivative> {
    let mut out = vec![];
    let per_body = DState::<N>::PER_BODY;
    for (side, st, sign) in [(ball, bs, 1.0), (socket, ss, -1.0)] {
        let Attach::Body(h) = side else { continue };
        let fs: V3<N> = [f[0] * sign, f[1] * sign, f[2] * sign];
        let s_local = st.rot_t(&ad::sub(x, &st.r));
        let torque = ad::cross(&s_local, &st.rot_t(&fs));
        for (wrt_side, offset) in [(ball, 0usize), (socket, per_body)] {
            let Attach::Body(w) = wrt_side else { continue };
            let mut d = nalgebra::SMatrix::<f64, 6, 13>::zeros();
            for c in 0..per_body {
                for r in 0..3 {
                    d[(r, c)] = fs[r].g[offset + c];
                    d[(3 + r, c)] = torque[r].g[offset + c];
                }
            }
            out.push(LoadDerivative { loaded: h, wrt: w, d });
        }
    }
    out
}

/// The two sides' states carrying derivatives (ball: variables 0..13, socket: 13..26; at
/// rest 0..7 and 7..14).
fn dual_states<const N: usize>(states: &[BodyState], ball: Attach, socket: Attach) -> (DState<N>, DState<N>) {
    let off = |a: Attach, o: usize| matches!(a, Attach::Body(_)).then_some(o);
    (
        DState::new(&state(states, ball), off(ball, 0)),
        DState::new(&state(states, socket), off(socket, DState::<N>::PER_BODY)),
    )
}

/// Velocity of the material point of `st` at base-frame point `x`.
fn point_velocity<const N: usize>(st: &DState<N>, x: &V3<N>) -> V3<N> {
    let s_local = st.rot_t(&ad::sub(x, &st.r));
    ad::add(&st.v, &st.rot(&ad::cross(&st.omega, &s_local)))
}

/// Normal force of `law` along unit `n` (pointing into the contact) with derivatives: −n·F;
/// and the term's dependence on the contact rate δ̇ = v_rel·n.
fn normal_force<const N: usize>(law: &NormalLaw, delta: D<N>, rate: D<N>, n: &V3<N>) -> (V3<N>, RateTerm) {
    let (f, f_d, f_r) = law.force_with_derivatives(delta.v, rate.v);
    let mut fd = delta * f_d + rate * f_r;
    fd.v = f;
    let term = RateTerm {
        direction: Vector3::new(n[0].v, n[1].v, n[2].v),
        force_rate: f_r,
    };
    (ad::scale(n, -fd), term)
}

/// A contact between a ball body and a socket body whose load derivatives come from dual
/// numbers: the one place that turns them into the exact Jacobians of a force element.
trait PairContact {
    /// Ball side, socket side, and whether the contact is frictionless (exact derivatives
    /// are given only then; with friction the formulation differences the loads).
    fn sides(&self) -> (Attach, Attach, bool);
    /// The load derivatives with respect to N of the pair's state variables, and the
    /// contact terms' rates (for the velocity columns, [`with_velocity_columns`]).
    fn derivatives<const N: usize>(&self, states: &[BodyState]) -> (Vec<LoadDerivative>, Rates);
}

/// [`ForceElement::load_jacobian`] of a pair contact: positions by dual numbers, velocities in
/// closed form.
fn full_jacobian<C: PairContact>(c: &C, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
    let (ball, socket, frictionless) = c.sides();
    if !frictionless {
        return None;
    }
    let (blocks, rates) = c.derivatives::<POSITIONS>(states);
    Some(with_velocity_columns(blocks, &rates, states, ball, socket))
}

/// [`ForceElement::load_jacobian_at_rest`] of a pair contact: positions only.
fn rest_jacobian<C: PairContact>(c: &C, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
    c.sides().2.then(|| c.derivatives::<POSITIONS>(states).0)
}

/// A normal contact term −u·F(δ, δ̇) whose rate δ̇ = u·v_rel is the relative velocity of
/// the two sides' material points at `point` (base frame) along the unit `direction` u;
/// `force_rate` = ∂F/∂δ̇ (N·s/m). The loads depend on the velocities only through such terms.
#[derive(Debug, Clone, Copy)]
struct RateTerm {
    direction: Vector3<f64>,
    force_rate: f64,
}

/// The contact terms of one element and the point (base frame) where they all act.
#[derive(Debug, Clone, Default)]
struct Rates {
    point: Vector3<f64>,
    terms: Vec<RateTerm>,
}

/// `blocks` (derivatives with respect to positions: velocity columns zero) with their
/// velocity columns filled in from the contact terms' rates: ∂f/∂(v, ω') of the ball side is
/// −u·F_δ̇·[uᵀ, (s'×Aᵀu)ᵀ] (s' the contact point in the body's frame), of the socket side
/// the same with the socket's s', A and the opposite sign; each loaded body's torque is
/// s'×(Aᵀ·∂f).
fn with_velocity_columns(
    mut blocks: Vec<LoadDerivative>,
    rates: &Rates,
    states: &[BodyState],
    ball: Attach,
    socket: Attach,
) -> Vec<LoadDerivative> {
    let side_sign = |a: Attach| -> Option<f64> {
        if a == ball {
            Some(1.0)
        } else if a == socket {
            Some(-1.0)
        } else {
            None
        }
    };
    for blk in &mut blocks {
        let (Some(sign_loaded), Some(sign_wrt)) = (
            side_sign(Attach::Body(blk.loaded)),
            side_sign(Attach::Body(blk.wrt)),
        ) else {
            continue;
        };
        let (sl, sw) = (&states[blk.loaded.index()], &states[blk.wrt.index()]);
        // ∂(force on the ball side)/∂(v, ω') of the wrt body, 3 × 6.
        let mut df = nalgebra::SMatrix::<f64, 3, 6>::zeros();
        for t in &rates.terms {
            let u = t.direction;
            let s_w = sw.a.transpose() * (rates.point - sw.r);
            let w_row = s_w.cross(&(sw.a.transpose() * u));
            for r in 0..3 {
                for c in 0..3 {
                    df[(r, c)] -= u[r] * t.force_rate * sign_wrt * u[c];
                    df[(r, 3 + c)] -= u[r] * t.force_rate * sign_wrt * w_row[c];
                }
            }
        }
        let df = df * sign_loaded;
        let s_l = sl.a.transpose() * (rates.point - sl.r);
        let dn = crate::multibody::rotation::skew(&s_l) * sl.a.transpose() * df;
        for c in 0..6 {
            for r in 0..3 {
                blk.d[(r, 7 + c)] = df[(r, c)];
                blk.d[(3 + r, 7 + c)] = dn[(r, c)];
            }
        }
    }
    blocks
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

    fn load_jacobian(&self, _t: f64, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
        full_jacobian(self, states)
    }

    fn load_jacobian_at_rest(&self, _t: f64, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
        rest_jacobian(self, states)
    }
}

impl PairContact for ClearanceBearing {
    fn sides(&self) -> (Attach, Attach, bool) {
        (self.ball_body, self.socket_body, self.friction.is_none())
    }
    fn derivatives<const N: usize>(&self, states: &[BodyState]) -> (Vec<LoadDerivative>, Rates) {
        let (b, s) = dual_states::<N>(states, self.ball_body, self.socket_body);
        let c = ad::add(&b.r, &b.rot_c(&self.ball_centre));
        let a = s.rot_c(&self.socket_axis);
        let d = ad::sub(&c, &ad::add(&s.r, &s.rot_c(&self.socket_centre)));
        let axial = ad::dot(&d, &a);
        let radial = ad::sub(&d, &ad::scale(&a, axial));
        let rho = ad::dot(&radial, &radial).sqrt();
        let v_rel = ad::sub(&point_velocity(&b, &c), &point_velocity(&s, &c));
        let mut f: V3<N> = [D::c(0.0); 3];
        let mut rates = vec![];
        let delta_r = rho - D::c(self.radial_clearance);
        if delta_r.v > 0.0 && rho.v > 0.0 {
            let n = ad::scale(&radial, rho.recip());
            let (fr, term) = normal_force(&self.radial_law, delta_r, ad::dot(&v_rel, &n), &n);
            f = ad::add(&f, &fr);
            rates.push(term);
        }
        let delta_a = axial - D::c(self.axial_stop);
        if delta_a.v > 0.0 {
            let (fa, term) = normal_force(&self.axial_law, delta_a, ad::dot(&v_rel, &a), &a);
            f = ad::add(&f, &fa);
            rates.push(term);
        }
        if f.iter().all(|x| x.v == 0.0 && x.g.iter().all(|g| *g == 0.0)) {
            return (vec![], Rates::default());
        }
        let rates = Rates {
            point: Vector3::new(c[0].v, c[1].v, c[2].v),
            terms: rates,
        };
        (
            pair_derivatives(self.ball_body, self.socket_body, &b, &s, &c, &f),
            rates,
        )
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

    fn load_jacobian(&self, _t: f64, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
        full_jacobian(self, states)
    }

    fn load_jacobian_at_rest(&self, _t: f64, states: &[BodyState]) -> Option<Vec<LoadDerivative>> {
        rest_jacobian(self, states)
    }
}

impl PairContact for BallInSocket {
    fn sides(&self) -> (Attach, Attach, bool) {
        (self.ball_body, self.socket_body, self.friction.is_none())
    }
    fn derivatives<const N: usize>(&self, states: &[BodyState]) -> (Vec<LoadDerivative>, Rates) {
        let (b, s) = dual_states::<N>(states, self.ball_body, self.socket_body);
        let c = ad::add(&b.r, &b.rot_c(&self.ball_centre));
        let d = ad::sub(&c, &ad::add(&s.r, &s.rot_c(&self.socket_centre)));
        let r = ad::dot(&d, &d).sqrt();
        let delta = r - D::c(self.clearance);
        if !(delta.v > 0.0 && r.v > 0.0) {
            return (vec![], Rates::default());
        }
        let n = ad::scale(&d, r.recip());
        let v_rel = ad::sub(&point_velocity(&b, &c), &point_velocity(&s, &c));
        let (f, term) = normal_force(&self.law, delta, ad::dot(&v_rel, &n), &n);
        let rates = Rates {
            point: Vector3::new(c[0].v, c[1].v, c[2].v),
            terms: vec![term],
        };
        (
            pair_derivatives(self.ball_body, self.socket_body, &b, &s, &c, &f),
            rates,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::rotation::{from_axis_angle, rotation};
    use crate::multibody::BodyHandle;
    use nalgebra::Vector4;

    fn state(r: Vector3<f64>, p: Vector4<f64>, v: Vector3<f64>, omega: Vector3<f64>) -> BodyState {
        BodyState {
            r,
            p,
            a: rotation(&p),
            v,
            omega,
        }
    }

    /// The derivatives at rest are the position columns of the full ones (radial and axial
    /// contact, moving bodies, damped law), with the velocity columns left zero.
    #[test]
    fn derivatives_at_rest_are_the_position_columns() {
        let law = NormalLaw::HuntCrossley {
            k: 1e9,
            n: 1.5,
            alpha: 0.3,
        };
        let bearing = ClearanceBearing {
            name: "b".into(),
            ball_body: Attach::Body(BodyHandle(0)),
            ball_centre: Vector3::new(0.01, 0.0, 0.002),
            socket_body: Attach::Body(BodyHandle(1)),
            socket_centre: Vector3::new(0.0, 0.01, 0.0),
            socket_axis: Vector3::z(),
            radial_clearance: 1e-5,
            axial_stop: 1e-5,
            radial_law: law,
            axial_law: law,
            friction: None,
        };
        let states = [
            state(
                Vector3::new(-0.01 + 3e-5, 0.01, -0.002 + 3e-5),
                Vector4::new(1.0, 0.0, 0.0, 0.0),
                Vector3::new(0.01, -0.02, 0.005),
                Vector3::new(0.1, 0.0, -0.2),
            ),
            state(
                Vector3::zeros(),
                from_axis_angle(&Vector3::new(0.0, 0.0, 1.0), 1e-4),
                Vector3::new(0.0, 0.01, 0.0),
                Vector3::new(0.0, 0.3, 0.0),
            ),
        ];
        let (pen_r, pen_a) = bearing.penetrations(&states);
        assert!(pen_r > 0.0 && pen_a > 0.0, "{pen_r} {pen_a}");
        let full = bearing.load_jacobian(0.0, &states).unwrap();
        let rest = bearing.load_jacobian_at_rest(0.0, &states).unwrap();
        assert_eq!(full.len(), 4);
        assert_eq!(full.len(), rest.len());
        for (f, r) in full.iter().zip(&rest) {
            assert_eq!((f.loaded, f.wrt), (r.loaded, r.wrt));
            let scale = f.d.amax();
            for c in 0..13 {
                for k in 0..6 {
                    let expected = if c < 7 { f.d[(k, c)] } else { 0.0 };
                    assert!((r.d[(k, c)] - expected).abs() <= 1e-12 * scale, "({k}, {c})");
                }
            }
            assert!(
                f.d.columns(7, 6).amax() > 0.0,
                "the full derivatives have velocity columns"
            );
        }
    }
}
