//! Force elements for clearance contacts: a ball end in a cylindrical socket (radial and
//! axial clearance), and a ball in a spherical socket.

use super::dual::{self as ad, DState, D, POSITIONS, V3};
use super::laws::{Friction, NormalLaw};
use crate::multibody::forces::{BodyLoad, BodyState, ForceElement, LoadDerivative};
use crate::multibody::rotation::{d_rot, skew};
use crate::multibody::{Attach, BodyHandle};
use nalgebra::{Matrix3, Vector3};

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
    out: &mut Vec<LoadDerivative>,
) {
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

/// Jacobian of a 3-vector with respect to a body pair's positions (ball r, p: columns 0..7;
/// socket r, p: 7..14), the closed-form counterpart of [`POSITIONS`] dual numbers.
type J14 = nalgebra::SMatrix<f64, 3, 14>;
/// Gradient of a scalar with respect to the same 14 positions.
type G14 = nalgebra::SMatrix<f64, 1, 14>;

/// One side of a pair for closed-form derivatives: its state and the first of its 7
/// position columns (`None`: the ground, constant).
struct Side {
    st: BodyState,
    col: Option<usize>,
}

impl Side {
    /// The side attached to `a` in state `st`, its positions from column `col`.
    fn new(st: BodyState, a: Attach, col: usize) -> Self {
        Side {
            st,
            col: matches!(a, Attach::Body(_)).then_some(col),
        }
    }
    /// Adds `m` (3 × 3) to the columns of r and `b` (3 × 4) to those of p.
    fn put(&self, j: &mut J14, m: Option<&nalgebra::Matrix3<f64>>, b: Option<&nalgebra::Matrix3x4<f64>>) {
        let Some(c) = self.col else { return };
        if let Some(m) = m {
            let mut v = j.fixed_view_mut::<3, 3>(0, c);
            v += m;
        }
        if let Some(b) = b {
            let mut v = j.fixed_view_mut::<3, 4>(0, c + 3);
            v += b;
        }
    }
    /// ∂(Aᵀ·z)/∂p for a fixed z: Aᵀ(p) = A(p̄) with p̄ = (e0, −e).
    fn d_rot_t(&self, z: &Vector3<f64>) -> nalgebra::Matrix3x4<f64> {
        let p = self.st.p;
        let mut b = d_rot(&nalgebra::Vector4::new(p[0], -p[1], -p[2], -p[3]), z);
        for k in 1..4 {
            b.set_column(k, &(-b.column(k)));
        }
        b
    }
    /// Aᵀ·z and its Jacobian, given z's Jacobian.
    fn rot_t(&self, z: &Vector3<f64>, jz: &J14) -> (Vector3<f64>, J14) {
        let at = self.st.a.transpose();
        let mut j = at * jz;
        self.put(&mut j, None, Some(&self.d_rot_t(z)));
        (at * z, j)
    }
    /// Velocity of the side's material point at base-frame x (Jacobian `jx`), as
    /// `point_velocity`: v + A·(ω × Aᵀ(x − r)).
    fn point_velocity(&self, x: &Vector3<f64>, jx: &J14) -> (Vector3<f64>, J14) {
        let mut jz = *jx;
        self.put(&mut jz, Some(&(-Matrix3::identity())), None);
        let (y, jy) = self.rot_t(&(x - self.st.r), &jz);
        let wy = self.st.omega.cross(&y);
        let mut j = self.st.a * skew(&self.st.omega) * jy;
        self.put(&mut j, None, Some(&d_rot(&self.st.p, &wy)));
        (self.st.v + self.st.a * wy, j)
    }
}

/// u·ω-style helpers: the gradient of a·b from both Jacobians.
fn dot_grad(a: &Vector3<f64>, ja: &J14, b: &Vector3<f64>, jb: &J14) -> G14 {
    a.transpose() * jb + b.transpose() * ja
}

/// A normal contact term's force −u·F(δ, δ̇) and its Jacobian, from δ, δ̇ and u with theirs.
fn normal_term(
    law: &NormalLaw,
    (delta, jdelta): (f64, G14),
    (rate, jrate): (f64, G14),
    (u, ju): (&Vector3<f64>, &J14),
) -> (Vector3<f64>, J14, RateTerm) {
    let (f, f_d, f_r) = law.force_with_derivatives(delta, rate);
    let jf = jdelta * f_d + jrate * f_r;
    let term = RateTerm {
        direction: *u,
        force_rate: f_r,
    };
    (-u * f, -(u * jf) - ju * f, term)
}

/// The loads of a contact force `f` (Jacobian `jf`) at base-frame point `x` (Jacobian `jx`)
/// as [`LoadDerivative`] blocks: +f on the ball side, −f on the socket side (the closed-form
/// counterpart of [`pair_derivatives`]).
fn pair_blocks(
    sides: [(Attach, &Side); 2],
    x: &Vector3<f64>,
    jx: &J14,
    f: &Vector3<f64>,
    jf: &J14,
    out: &mut Vec<LoadDerivative>,
) {
    for (k, (attach, side)) in sides.iter().enumerate() {
        let Attach::Body(h) = *attach else { continue };
        let sign = if k == 0 { 1.0 } else { -1.0 };
        let (fs, jfs) = (f * sign, jf * sign);
        let mut jz = *jx;
        side.put(&mut jz, Some(&(-Matrix3::identity())), None);
        let (s_local, js) = side.rot_t(&(x - side.st.r), &jz);
        let (g, jg) = side.rot_t(&fs, &jfs);
        let jtorque = skew(&s_local) * jg - skew(&g) * js;
        for (wrt_attach, wrt_side) in &sides {
            let (Attach::Body(w), Some(c0)) = (*wrt_attach, wrt_side.col) else {
                continue;
            };
            let mut d = nalgebra::SMatrix::<f64, 6, 13>::zeros();
            d.fixed_view_mut::<3, 7>(0, 0)
                .copy_from(&jfs.fixed_view::<3, 7>(0, c0));
            d.fixed_view_mut::<3, 7>(3, 0)
                .copy_from(&jtorque.fixed_view::<3, 7>(0, c0));
            out.push(LoadDerivative { loaded: h, wrt: w, d });
        }
    }
}

/// A contact between a ball body and a socket body whose load derivatives come from dual
/// numbers: the one place that turns them into the exact Jacobians of a force element.
trait PairContact {
    /// Ball side, socket side, and whether the contact is frictionless (exact derivatives
    /// are given only then; with friction the formulation differences the loads).
    fn sides(&self) -> (Attach, Attach, bool);
    /// The load derivatives with respect to N of the pair's state variables, appended to
    /// `out`, and the contact terms' rates (for the velocity columns,
    /// [`with_velocity_columns`]).
    fn derivatives<const N: usize>(&self, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> Rates;
}

/// [`ForceElement::load_jacobian`] of a pair contact: positions by dual numbers, velocities in
/// closed form.
fn full_jacobian<C: PairContact>(c: &C, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
    let (ball, socket, frictionless) = c.sides();
    if !frictionless {
        return false;
    }
    let first = out.len();
    let rates = c.derivatives::<POSITIONS>(states, out);
    with_velocity_columns(&mut out[first..], &rates, states, ball, socket);
    true
}

/// [`ForceElement::load_jacobian_at_rest`] of a pair contact: positions only.
fn rest_jacobian<C: PairContact>(c: &C, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
    if !c.sides().2 {
        return false;
    }
    c.derivatives::<POSITIONS>(states, out);
    true
}

/// A normal contact term −u·F(δ, δ̇) whose rate δ̇ = u·v_rel is the relative velocity of
/// the two sides' material points at `point` (base frame) along the unit `direction` u;
/// `force_rate` = ∂F/∂δ̇ (N·s/m). The loads depend on the velocities only through such terms.
#[derive(Debug, Clone, Copy)]
struct RateTerm {
    direction: Vector3<f64>,
    force_rate: f64,
}

/// The contact terms of one element (radial and axial at most, kept in fixed places so the
/// Jacobian allocates nothing) and the point (base frame) where they all act.
#[derive(Debug, Clone, Copy, Default)]
struct Rates {
    point: Vector3<f64>,
    terms: [Option<RateTerm>; 2],
}

impl Rates {
    /// The terms present.
    fn terms(&self) -> impl Iterator<Item = &RateTerm> {
        self.terms.iter().flatten()
    }
}

/// `blocks` (derivatives with respect to positions: velocity columns zero) with their
/// velocity columns filled in from the contact terms' rates: ∂f/∂(v, ω') of the ball side is
/// −u·F_δ̇·[uᵀ, (s'×Aᵀu)ᵀ] (s' the contact point in the body's frame), of the socket side
/// the same with the socket's s', A and the opposite sign; each loaded body's torque is
/// s'×(Aᵀ·∂f).
fn with_velocity_columns(
    blocks: &mut [LoadDerivative],
    rates: &Rates,
    states: &[BodyState],
    ball: Attach,
    socket: Attach,
) {
    let side_sign = |a: Attach| -> Option<f64> {
        if a == ball {
            Some(1.0)
        } else if a == socket {
            Some(-1.0)
        } else {
            None
        }
    };
    for blk in blocks {
        let (Some(sign_loaded), Some(sign_wrt)) = (
            side_sign(Attach::Body(blk.loaded)),
            side_sign(Attach::Body(blk.wrt)),
        ) else {
            continue;
        };
        let (sl, sw) = (&states[blk.loaded.index()], &states[blk.wrt.index()]);
        // ∂(force on the ball side)/∂(v, ω') of the wrt body, 3 × 6.
        let mut df = nalgebra::SMatrix::<f64, 3, 6>::zeros();
        let s_w = sw.a.transpose() * (rates.point - sw.r);
        for t in rates.terms() {
            let u = t.direction;
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
    /// Ball centre less socket centre, base frame, m.
    offset: Vector3<f64>,
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
            offset: d,
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
            ..
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

    fn load_jacobian(&self, _t: f64, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
        if self.friction.is_some() {
            return false;
        }
        let first = out.len();
        let rates = self.position_derivatives(states, out);
        with_velocity_columns(
            &mut out[first..],
            &rates,
            states,
            self.ball_body,
            self.socket_body,
        );
        true
    }

    fn load_jacobian_at_rest(&self, _t: f64, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
        if self.friction.is_some() {
            return false;
        }
        self.position_derivatives(states, out);
        true
    }
}

impl ClearanceBearing {
    /// The load derivatives with respect to the pair's positions and the contact terms'
    /// rates, in closed form (the same function as [`PairContact::derivatives`] with
    /// [`POSITIONS`] dual numbers, which a test compares it with; on the MR2120 L1 run the
    /// whole model's Jacobian takes 42 µs with it against 48 µs with the dual numbers).
    /// The blocks are appended to `out`.
    fn position_derivatives(&self, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> Rates {
        // Ball centre c, socket axis a, and d = c − socket centre (`geometry`); the
        // Jacobians only when a contact is closed (an open bearing has no load).
        let g = self.geometry(states);
        let (c, a, d, axial, radial) = (g.centre, g.axis, g.offset, g.axial, g.radial);
        let b = Side::new(g.ball, self.ball_body, 0);
        let s = Side::new(g.socket, self.socket_body, 7);
        let rho = radial.norm();
        let delta_r = rho - self.radial_clearance;
        let delta_a = axial - self.axial_stop;
        let radial_on = delta_r > 0.0 && rho > 0.0;
        if !radial_on && delta_a <= 0.0 {
            return Rates::default();
        }
        let eye = Matrix3::identity();
        let mut jc = J14::zeros();
        b.put(&mut jc, Some(&eye), Some(&d_rot(&b.st.p, &self.ball_centre)));
        let mut ja = J14::zeros();
        s.put(&mut ja, None, Some(&d_rot(&s.st.p, &self.socket_axis)));
        let mut jd = jc;
        s.put(
            &mut jd,
            Some(&(-eye)),
            Some(&(-d_rot(&s.st.p, &self.socket_centre))),
        );
        let jaxial = dot_grad(&d, &jd, &a, &ja);
        let jradial = jd - a * jaxial - ja * axial;
        let (vb, jvb) = b.point_velocity(&c, &jc);
        let (vs, jvs) = s.point_velocity(&c, &jc);
        let (v_rel, jv) = (vb - vs, jvb - jvs);
        let mut f = Vector3::zeros();
        let mut jf = J14::zeros();
        let mut terms = [None; 2];
        if radial_on {
            let n = radial / rho;
            let jrho = n.transpose() * jradial;
            let jn = (jradial - n * jrho) / rho;
            let rate = v_rel.dot(&n);
            let jrate = dot_grad(&v_rel, &jv, &n, &jn);
            let (fr, jfr, term) = normal_term(&self.radial_law, (delta_r, jrho), (rate, jrate), (&n, &jn));
            f += fr;
            jf += jfr;
            terms[0] = Some(term);
        }
        if delta_a > 0.0 {
            let rate = v_rel.dot(&a);
            let jrate = dot_grad(&v_rel, &jv, &a, &ja);
            let (fa, jfa, term) = normal_term(&self.axial_law, (delta_a, jaxial), (rate, jrate), (&a, &ja));
            f += fa;
            jf += jfa;
            terms[1] = Some(term);
        }
        if f == Vector3::zeros() && jf.iter().all(|v| *v == 0.0) {
            return Rates::default();
        }
        pair_blocks(
            [(self.ball_body, &b), (self.socket_body, &s)],
            &c,
            &jc,
            &f,
            &jf,
            out,
        );
        Rates { point: c, terms }
    }
}

/// The dual-number derivatives: the reference the closed form is tested against.
#[cfg(test)]
impl PairContact for ClearanceBearing {
    fn sides(&self) -> (Attach, Attach, bool) {
        (self.ball_body, self.socket_body, self.friction.is_none())
    }
    fn derivatives<const N: usize>(&self, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> Rates {
        let (b, s) = dual_states::<N>(states, self.ball_body, self.socket_body);
        let c = ad::add(&b.r, &b.rot_c(&self.ball_centre));
        let a = s.rot_c(&self.socket_axis);
        let d = ad::sub(&c, &ad::add(&s.r, &s.rot_c(&self.socket_centre)));
        let axial = ad::dot(&d, &a);
        let radial = ad::sub(&d, &ad::scale(&a, axial));
        let rho = ad::dot(&radial, &radial).sqrt();
        let v_rel = ad::sub(&point_velocity(&b, &c), &point_velocity(&s, &c));
        let mut f: V3<N> = [D::c(0.0); 3];
        let mut rates = [None; 2];
        let delta_r = rho - D::c(self.radial_clearance);
        if delta_r.v > 0.0 && rho.v > 0.0 {
            let n = ad::scale(&radial, rho.recip());
            let (fr, term) = normal_force(&self.radial_law, delta_r, ad::dot(&v_rel, &n), &n);
            f = ad::add(&f, &fr);
            rates[0] = Some(term);
        }
        let delta_a = axial - D::c(self.axial_stop);
        if delta_a.v > 0.0 {
            let (fa, term) = normal_force(&self.axial_law, delta_a, ad::dot(&v_rel, &a), &a);
            f = ad::add(&f, &fa);
            rates[1] = Some(term);
        }
        if f.iter().all(|x| x.v == 0.0 && x.g.iter().all(|g| *g == 0.0)) {
            return Rates::default();
        }
        pair_derivatives(self.ball_body, self.socket_body, &b, &s, &c, &f, out);
        Rates {
            point: Vector3::new(c[0].v, c[1].v, c[2].v),
            terms: rates,
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

    fn load_jacobian(&self, _t: f64, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
        full_jacobian(self, states, out)
    }

    fn load_jacobian_at_rest(&self, _t: f64, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
        rest_jacobian(self, states, out)
    }
}

impl PairContact for BallInSocket {
    fn sides(&self) -> (Attach, Attach, bool) {
        (self.ball_body, self.socket_body, self.friction.is_none())
    }
    fn derivatives<const N: usize>(&self, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> Rates {
        let (b, s) = dual_states::<N>(states, self.ball_body, self.socket_body);
        let c = ad::add(&b.r, &b.rot_c(&self.ball_centre));
        let d = ad::sub(&c, &ad::add(&s.r, &s.rot_c(&self.socket_centre)));
        let r = ad::dot(&d, &d).sqrt();
        let delta = r - D::c(self.clearance);
        if !(delta.v > 0.0 && r.v > 0.0) {
            return Rates::default();
        }
        let n = ad::scale(&d, r.recip());
        let v_rel = ad::sub(&point_velocity(&b, &c), &point_velocity(&s, &c));
        let (f, term) = normal_force(&self.law, delta, ad::dot(&v_rel, &n), &n);
        pair_derivatives(self.ball_body, self.socket_body, &b, &s, &c, &f, out);
        Rates {
            point: Vector3::new(c[0].v, c[1].v, c[2].v),
            terms: [Some(term), None],
        }
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

    /// The closed-form position derivatives equal the dual-number ones: radial and axial
    /// contact (each alone and both), a socket on the ground, and Euler parameters off the
    /// unit sphere (the polynomial rotation matrix keeps both exact there too).
    #[test]
    fn closed_form_derivatives_equal_the_dual_numbers() {
        let law = NormalLaw::HuntCrossley {
            k: 1e9,
            n: 1.5,
            alpha: 0.3,
        };
        let make = |socket: Attach, radial: f64, axial: f64| ClearanceBearing {
            name: "b".into(),
            ball_body: Attach::Body(BodyHandle(0)),
            ball_centre: Vector3::new(0.01, 0.0, 0.002),
            socket_body: socket,
            socket_centre: Vector3::new(0.0, 0.01, 0.0),
            socket_axis: Vector3::new(0.0, 0.6, 0.8),
            radial_clearance: radial,
            axial_stop: axial,
            radial_law: law,
            axial_law: NormalLaw::Hertz { k: 3e8, n: 1.5 },
            friction: None,
        };
        let p_ball = from_axis_angle(&Vector3::new(0.3, -0.5, 0.8).normalize(), 0.2) * 1.001;
        let states = [
            state(
                Vector3::new(-0.01 + 3e-5, 0.01 - 2e-5, -0.002 + 4e-5),
                p_ball,
                Vector3::new(0.01, -0.02, 0.005),
                Vector3::new(0.1, 0.4, -0.2),
            ),
            state(
                Vector3::new(1e-5, -2e-5, 0.5e-5),
                from_axis_angle(&Vector3::new(0.0, 0.0, 1.0), 0.1) * 0.999,
                Vector3::new(0.0, 0.01, -0.03),
                Vector3::new(0.2, 0.3, -0.1),
            ),
        ];
        let socket = Attach::Body(BodyHandle(1));
        for (bearing, what) in [
            (make(socket, 1e-5, 1e-5), "radial and axial"),
            (make(socket, 1e-5, 1.0), "radial"),
            (make(socket, 1.0, 1e-5), "axial"),
            (make(Attach::Ground, 1e-5, 1e-5), "socket on the ground"),
        ] {
            let (mut closed, mut dual) = (vec![], vec![]);
            let rc = bearing.position_derivatives(&states, &mut closed);
            let rd = bearing.derivatives::<POSITIONS>(&states, &mut dual);
            assert!(!closed.is_empty(), "{what}: in contact");
            assert_eq!(closed.len(), dual.len(), "{what}");
            assert!((rc.point - rd.point).norm() < 1e-15, "{what}");
            assert_eq!(rc.terms().count(), rd.terms().count(), "{what}");
            for (a, b) in rc.terms().zip(rd.terms()) {
                assert!((a.direction - b.direction).norm() < 1e-12, "{what}");
                assert!(
                    (a.force_rate - b.force_rate).abs() <= 1e-12 * b.force_rate.abs(),
                    "{what}"
                );
            }
            for (a, b) in closed.iter().zip(&dual) {
                assert_eq!((a.loaded, a.wrt), (b.loaded, b.wrt), "{what}");
                let scale = b.d.amax();
                assert!(scale > 0.0, "{what}");
                assert!(
                    (a.d - b.d).amax() <= 1e-10 * scale,
                    "{what}: {}",
                    (a.d - b.d).amax() / scale
                );
            }
        }
        // Out of contact: no blocks.
        let apart = make(socket, 1.0, 1.0);
        let mut none = vec![];
        apart.position_derivatives(&states, &mut none);
        assert!(none.is_empty());
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
        let (mut full, mut rest) = (vec![], vec![]);
        assert!(bearing.load_jacobian(0.0, &states, &mut full));
        assert!(bearing.load_jacobian_at_rest(0.0, &states, &mut rest));
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
