//! The drive transmissions' dynamics as the diagnosis uses it: a compliant transmission
//! between a motor (whose encoder is recorded) and its joint winds up by w under the
//! joint-side torque τ_s,
//!
//! M_d·ẅ + D·ẇ + K·w = τ_s,
//!
//! with M_d the mechanism's mass matrix in drive coordinates, K = diag(1/c) and D the
//! transmissions' stiffnesses and dampings. Two users share one integrator
//! ([`newmark_interval`], the average-acceleration Newmark rule with the mass matrix,
//! stiffness and load linear in time over each sample interval):
//! - the nominal model ([`crate::diagnose::mechanism`]) integrates the wind-up along a
//!   recording;
//! - the candidate library ([`crate::diagnose::candidates`]) integrates the *linear response*
//!   δw of the transmissions to an extra joint-side torque g(t) on one drive (friction, say),
//!   [`joint_torque_response`]:
//!
//!   M_d·δẅ + D·δẇ + (K + S)·δw = g,
//!
//!   with S = ∂τ_s/∂q_arm the joint-side torques' own dependence on the arms' positions
//!   (gravity and configuration stiffness; [`TransmissionDynamics::load_stiffness`], by
//!   central differences of the nominal model at each sample, at the arms' own rates and
//!   accelerations: q̈_a = q̈ − ẅ, so S carries ∂M_d/∂q_arm·q̈_a — at the encoders'
//!   accelerations it missed −∂M_d/∂q_arm·ẅ, large where the drives ring near the direct
//!   singularity; until 2026-11-27, session 29). The torque sensor of drive k
//!   then reads K_k·δw_k + D_k·δẇ_k more, and the outputs move with the joints by −δw. S is
//!   small against K away from singular positions and grows without bound near the direct
//!   singularity. Measured on the multibody suite (held-out residual in torque-noise units):
//!   *scale-under-coulomb* 1.30× without S, 1.19× with it; *coulomb-under-viscous* 1.19× →
//!   1.09×. (An earlier try, before the nominal model iterated its own wind-up twice per
//!   sample and before friction acted at the arm's rate, left 3.08× with S and 1.37×
//!   without: the nominal model's error near the singularity then exceeded what S corrects.)
//!
//! A friction torque that changes sign within a few milliseconds rings a transmission whose
//! mode lies at some tens of hertz; the quasi-static wind-up c·g (the response's limit for
//! slow g) misses the ringing. Measured on the multibody suite's case of a 0.1 % torque-sensor
//! scale error under 0.3 N·m Coulomb friction in drive B: with the quasi-static wind-up the
//! diagnosis named direction-asymmetric friction and left 3.9× the torque noise on the
//! held-out recordings; with the response it names Coulomb friction in drive B (3.5 % off)
//! and the scale error, and leaves 1.6×.
//!
//! **Backlash** ([`backlash_response`], [`DeadZone`]): the same integrator with one
//! transmission free within its play, its side decided per substep, and the play at one of
//! two places ([`PlayPlace`]): between the spring and the arm (a gear mesh at the output:
//! the spring, ending at a massless node, relaxes through its damper while the arm crosses
//! the play) or in the spring itself (a dead zone of its deflection, gone the moment the arm
//! lets go). Measured on the multibody suite's backlash case (seed 2026, drive B, 10 µrad;
//! held-out residual in noise units): a truth with a gear mesh at the output
//! (`mechanisms::mr2120::truth::GearMesh`: Hertzian flanks, an output gear of its own) is
//! left at 1.03× with the play at the output and 1.45× with it in the spring; a truth with
//! the dead zone in its spring at 1.41× with the play at the output and 1.02× in the spring.

use nalgebra::{DMatrix, DVector};

/// Newmark substeps per sample interval (the transmission mode may lie at a few tens of
/// hertz near a singular position; a few steps per period would shift its phase).
pub const SUBSTEPS: usize = 8;

/// The transmissions' linear dynamics at one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct TransmissionDynamics {
    /// Mass matrix in drive coordinates (kg·m² for revolute drives).
    pub mass: DMatrix<f64>,
    /// Compliance of each transmission, rad/(N·m); 0: rigid.
    pub compliance: Vec<f64>,
    /// Damping of each transmission's torsion, N·m·s/rad.
    pub damping: Vec<f64>,
    /// The nominal wind-up rate ẇ of each transmission at this sample, rad/s (the arm moves
    /// at the encoder's rate less this; zeros where the model carries no wind-up state).
    pub windup_rate: Vec<f64>,
    /// The nominal wind-up w of each transmission at this sample (encoder less joint), rad
    /// (NaN where the model carries no wind-up state: a backlash's response then has none).
    pub windup: Vec<f64>,
    /// S = ∂τ_s/∂q_arm, N·m/rad: how the joint-side torques change with the arms' positions
    /// at this sample (at the arms' own rates and accelerations). A load that winds the transmissions up by δw changes them by −S·δw,
    /// so the response obeys M·δẅ + D·δẇ + (K + S)·δw = g. None: not known (taken as 0).
    pub load_stiffness: Option<DMatrix<f64>>,
}

impl TransmissionDynamics {
    /// K + S, the stiffness the response to a joint-side load sees (S, the load stiffness,
    /// left out where not known or of the wrong shape), N·m/rad.
    pub fn response_stiffness(&self) -> DMatrix<f64> {
        self.response_stiffness_with(self.load_stiffness.as_ref())
    }

    /// K + S with another load stiffness S (the torques' stiffness at another configuration;
    /// left out where None or of the wrong shape), N·m/rad.
    pub fn response_stiffness_with(&self, load_stiffness: Option<&DMatrix<f64>>) -> DMatrix<f64> {
        let k = DMatrix::from_diagonal(&self.stiffness());
        match load_stiffness {
            Some(s) if s.shape() == k.shape() => k + s,
            _ => k,
        }
    }

    /// Stiffness of each transmission, N·m/rad (a rigid one: 1e12, far above any other, so
    /// it keeps w ≈ 0 and still reports the torque it transmits).
    pub fn stiffness(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.compliance.len(),
            self.compliance
                .iter()
                .map(|&c| if c > 0.0 { 1.0 / c } else { RIGID_STIFFNESS }),
        )
    }
}

/// Stiffness standing in for a rigid transmission, N·m/rad.
pub const RIGID_STIFFNESS: f64 = 1e12;

/// The state of the transmissions: wind-up, its rate and acceleration.
pub type State = (DVector<f64>, DVector<f64>, DVector<f64>);

/// One sample interval's end: mass matrix, stiffness matrix, load.
pub struct End<'a> {
    /// Mass matrix in drive coordinates.
    pub mass: &'a DMatrix<f64>,
    /// Stiffness matrix, N·m/rad.
    pub stiffness: &'a DMatrix<f64>,
    /// Load (joint-side torques), N·m.
    pub load: &'a DVector<f64>,
}

/// [`SUBSTEPS`] average-acceleration Newmark steps of M·ẅ + D·ẇ + S·w = f over `h`
/// seconds from `state`, M, S and f linear in time from `start` to `end`. None if a step's
/// matrix is singular (an exactly zero pivot) or the ends' sizes differ from the state's.
///
/// Called at every sample of every recording, for the nominal wind-up and for each
/// candidate's response: the substeps work in buffers made once per call (the matrix
/// arithmetic with nalgebra's temporaries spent a third of a diagnosis in the allocator).
pub fn newmark_interval(
    state: &State,
    start: &End,
    end: &End,
    damping: &DVector<f64>,
    h: f64,
) -> Option<State> {
    newmark_interval_with(state, start, end, damping, h, None).map(|(s, _, _)| s)
}

/// A transmission with backlash in [`newmark_interval_with`]: drive `drive`'s spring
/// (`stiffness` K, `damping` D) transmits nothing while the arm is inside the play (or while
/// its contact would pull), and (K·(|w| − b) + D·ẇ·sign w)·sign w on the side it presses
/// beyond (w = w_nom + δw the total wind-up, encoder less arm). The response δw is then driven by the
/// torque the linear spring would carry and the play does not, the *lost torque*
/// L(w, ẇ) = K·w + D·ẇ − T(w, ẇ): K·w + D·ẇ inside the play (the arm free of its rotor),
/// K·b·sign(w) in contact.
///
/// Where the play sits ([`PlayPlace`]) decides when the arm is inside it. Between the spring
/// and the arm (a gear mesh at the output, [`PlayPlace::Output`]) the spring ends at a node
/// (massless) that the arm presses through the flank: in contact the node is at w − b·sign w,
/// and once the arm lets go the spring relaxes through its damper, the node's deflection g
/// decaying as D·ġ + K·g = 0 (time constant D/K) — the arm meets the flank again where
/// |w − g| reaches b. In the spring itself ([`PlayPlace::Spring`], a dead zone) the
/// deflection vanishes as the contact lets go, and the flank is at |w| = b.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadZone {
    /// The drive whose transmission has the play.
    pub drive: usize,
    /// Half the play, rad (> 0).
    pub half_play: f64,
    /// K of that transmission, N·m/rad.
    pub stiffness: f64,
    /// D of that transmission, N·m·s/rad.
    pub damping: f64,
    /// The nominal wind-up and its rate (w_nom, ẇ_nom) at the interval's start and end, rad
    /// and rad/s (linear in time between).
    pub nominal: [(f64, f64); 2],
    /// Where the play sits.
    pub place: PlayPlace,
    /// The spring's deflection g at the interval's start, rad (the node's place against the
    /// rotor; 0 for [`PlayPlace::Spring`] while free).
    pub node: f64,
}

/// Where a transmission's backlash sits ([`DeadZone`]); JSON `"spring"` or `"output"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlayPlace {
    /// In the spring itself: a dead zone of the transmission's deflection, which vanishes as
    /// the contact lets go.
    Spring,
    /// Between the spring and the arm (a gear mesh at the output): the spring relaxes through
    /// its damper while the arm crosses the play.
    #[default]
    Output,
}

impl PlayPlace {
    /// One word for it: "output" or "spring" (as in JSON).
    pub fn word(self) -> &'static str {
        match self {
            PlayPlace::Spring => "spring",
            PlayPlace::Output => "output",
        }
    }
}

impl std::fmt::Display for PlayPlace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PlayPlace::Spring => "in the transmission's spring (a dead zone)",
            PlayPlace::Output => {
                "between the transmission's spring and the arm (at the output, as a gear mesh)"
            }
        })
    }
}

/// Where a dead zone's transmission is: inside its play (or separating), or pressing on the
/// side of this sign.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Side {
    Free,
    Pressing(f64),
}

impl DeadZone {
    /// The side the arm is on at total wind-up `w` and rate `wd` with the node at `g`,
    /// coming from outside contact: beyond the flank (|w − g| ≥ b, to within 1e-9 of b) and
    /// pressing (K·(|w| − b) + D·ẇ·sign > 0, the contact's torque with the node on that flank).
    fn side(&self, w: f64, wd: f64, g: f64) -> Side {
        let m = w - g;
        let s = m.signum();
        if m.abs() >= self.half_play * (1.0 - 1e-9) && self.pushes(s, w, wd) {
            Side::Pressing(s)
        } else {
            Side::Free
        }
    }

    /// Whether a contact on the flank of sign `s` pushes at total wind-up `w` and rate `wd`.
    fn pushes(&self, s: f64, w: f64, wd: f64) -> bool {
        self.stiffness * (w * s - self.half_play) + self.damping * wd * s > 0.0
    }

    /// The side a substep solved on `on` ends on, at total wind-up `w` and rate `wd`, the
    /// node relaxed to `g_free` had the arm been free. In the spring, from the wind-up alone
    /// (the deflection is gone once free); at the output, a pressing contact holds while it
    /// pushes.
    fn ends_on(&self, on: Side, w: f64, wd: f64, g_free: f64) -> Side {
        match (on, self.place) {
            (Side::Pressing(s), PlayPlace::Output) if self.pushes(s, w, wd) => Side::Pressing(s),
            (Side::Pressing(_), PlayPlace::Output) => Side::Free,
            (Side::Pressing(_), PlayPlace::Spring) => self.side(w, wd, 0.0),
            (Side::Free, _) => self.side(w, wd, g_free),
        }
    }

    /// The node's deflection after `h` seconds on `side` from `g`, the arm at total wind-up
    /// `w`: on the flank in contact; free, 0 in the spring at once, relaxing at the output.
    fn node_after(&self, side: Side, g: f64, w: f64, h: f64) -> f64 {
        match (side, self.place) {
            (Side::Pressing(s), _) => w - self.half_play * s,
            (Side::Free, PlayPlace::Output) if self.damping > 0.0 => {
                g * (-self.stiffness * h / self.damping).exp()
            }
            (Side::Free, _) => 0.0,
        }
    }

    /// The nominal (w, ẇ) at fraction `f` of the interval.
    fn nominal_at(&self, f: f64) -> (f64, f64) {
        let [(w0, v0), (w1, v1)] = self.nominal;
        (w0 + (w1 - w0) * f, v0 + (v1 - v0) * f)
    }

    /// The lost torque on `side` at total wind-up `w` and rate `wd`, N·m.
    fn lost(&self, side: Side, w: f64, wd: f64) -> f64 {
        match side {
            Side::Free => self.stiffness * w + self.damping * wd,
            Side::Pressing(s) => self.stiffness * self.half_play * s,
        }
    }

    /// The lost torque L (N·m) and the node's deflection (rad) at a start at total wind-up `w`
    /// and rate `wd`, the node unloaded before: on the flank if the arm presses it, else free
    /// with the node at rest.
    fn start(&self, w: f64, wd: f64) -> (f64, f64) {
        let side = self.side(w, wd, 0.0);
        (self.lost(side, w, wd), self.node_after(side, 0.0, w, 0.0))
    }
}

/// Attempts per substep to find the side a dead zone ends it on (the side at the
/// substep's end decides its equation; a side that changes again after this many is kept).
const DEAD_ZONE_ATTEMPTS: usize = 4;

/// [`newmark_interval`] with an optional dead zone in one transmission ([`DeadZone`]; the
/// response δw, its side decided per substep from the state the substep ends in); also
/// returns the lost torque and the node's deflection ([`DeadZone::node`]) at the interval's
/// end (0 and 0 without a dead zone).
pub fn newmark_interval_with(
    state: &State,
    start: &End,
    end: &End,
    damping: &DVector<f64>,
    h: f64,
    dead: Option<&DeadZone>,
) -> Option<(State, f64, f64)> {
    let n = damping.len();
    if dead.is_some_and(|z| z.drive >= n) {
        return None;
    }
    let sized = |m: &DMatrix<f64>| m.nrows() == n && m.ncols() == n;
    if !(sized(start.mass) && sized(end.mass) && sized(start.stiffness) && sized(end.stiffness))
        || start.load.len() != n
        || end.load.len() != n
        || state.0.len() != n
    {
        return None;
    }
    let hs = h / SUBSTEPS as f64;
    let (beta, gamma) = (0.25, 0.5);
    let a0 = 1.0 / (beta * hs * hs);
    let a1 = gamma / (beta * hs);
    let a2 = 1.0 / (beta * hs);
    let a3 = 1.0 / (2.0 * beta) - 1.0;
    let a4 = gamma / beta - 1.0;
    let a5 = hs * (gamma / (2.0 * beta) - 1.0);
    let (mut w, mut wd, mut wdd) = state.clone();
    // Column-major n × n, as nalgebra stores them.
    let (m0, m1) = (start.mass.as_slice(), end.mass.as_slice());
    let (s0, s1) = (start.stiffness.as_slice(), end.stiffness.as_slice());
    let mut m = vec![0.0; n * n];
    let mut kh = vec![0.0; n * n];
    let mut inertial = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    let mut damp = damping.as_slice().to_vec();
    // The side the dead zone (if any) is on: from the state the interval starts in.
    let mut node = dead.map_or(0.0, |z| z.node);
    let mut side = dead.map(|z| {
        let (wn, vn) = z.nominal_at(0.0);
        z.side(wn + w[z.drive], vn + wd[z.drive], node)
    });
    let mut lost = 0.0;
    for step in 1..=SUBSTEPS {
        let f = step as f64 / SUBSTEPS as f64;
        for attempt in 0..DEAD_ZONE_ATTEMPTS {
            // Drive j's spring and damper leave the response's equation while its
            // transmission is free, and its lost torque drives it (see `DeadZone`).
            let (mut dk, mut force) = (0.0, 0.0);
            if let (Some(z), Some(sd)) = (dead, side) {
                let (wn, vn) = z.nominal_at(f);
                damp[z.drive] = damping[z.drive];
                match sd {
                    Side::Free => {
                        dk = -z.stiffness;
                        damp[z.drive] = damping[z.drive] - z.damping;
                        force = z.stiffness * wn + z.damping * vn;
                    }
                    Side::Pressing(s) => force = z.stiffness * z.half_play * s,
                }
            }
            for p in 0..n * n {
                m[p] = m0[p] * (1.0 - f) + m1[p] * f;
                kh[p] = m[p] * a0 + (s0[p] * (1.0 - f) + s1[p] * f);
            }
            for i in 0..n {
                kh[i * n + i] += a1 * damp[i];
                inertial[i] = w[i] * a0 + wd[i] * a2 + wdd[i] * a3;
                let viscous = w[i] * a1 + wd[i] * a4 + wdd[i] * a5;
                rhs[i] = (start.load[i] * (1.0 - f) + end.load[i] * f) + damp[i] * viscous;
            }
            if let Some(z) = dead {
                kh[z.drive * n + z.drive] += dk;
                rhs[z.drive] += force;
            }
            for k in 0..n {
                let x = inertial[k];
                for i in 0..n {
                    rhs[i] += m[k * n + i] * x;
                }
            }
            if !solve_dense_in_place(&mut kh, &mut rhs, n) {
                return None;
            }
            let Some(z) = dead else { break };
            // The side the substep ends on; solved again on it if it differs.
            let j = z.drive;
            let wdd1 = (rhs[j] - w[j]) * a0 - wd[j] * a2 - wdd[j] * a3;
            let wd1 = wd[j] + (wdd[j] * (1.0 - gamma) + wdd1 * gamma) * hs;
            let (wn, vn) = z.nominal_at(f);
            let (wt, vt) = (wn + rhs[j], vn + wd1);
            // The side the substep ends on; where it leaves the node.
            let on = side.unwrap_or(Side::Free);
            let ended = z.ends_on(on, wt, vt, z.node_after(Side::Free, node, wt, hs));
            lost = z.lost(ended, wt, vt);
            let settled = Some(ended) == side;
            side = Some(ended);
            if settled || attempt + 1 == DEAD_ZONE_ATTEMPTS {
                node = z.node_after(ended, node, wt, hs);
                break;
            }
        }
        for i in 0..n {
            let w1 = rhs[i];
            let wdd1 = (w1 - w[i]) * a0 - wd[i] * a2 - wdd[i] * a3;
            wd[i] += (wdd[i] * (1.0 - gamma) + wdd1 * gamma) * hs;
            wdd[i] = wdd1;
            w[i] = w1;
        }
    }
    Some(((w, wd, wdd), lost, node))
}

/// Solves A·x = b in place by Gaussian elimination with partial pivoting (`a`: n × n,
/// column-major, overwritten; `b` becomes x). `false` on an exactly zero pivot (as
/// nalgebra's LU reports a singular matrix).
fn solve_dense_in_place(a: &mut [f64], b: &mut [f64], n: usize) -> bool {
    for k in 0..n {
        let mut piv = k;
        for i in k + 1..n {
            if a[k * n + i].abs() > a[k * n + piv].abs() {
                piv = i;
            }
        }
        let pv = a[k * n + piv];
        if pv == 0.0 {
            return false;
        }
        if piv != k {
            for c in 0..n {
                a.swap(c * n + k, c * n + piv);
            }
            b.swap(k, piv);
        }
        for i in k + 1..n {
            let l = a[k * n + i] / pv;
            if l != 0.0 {
                for c in k + 1..n {
                    a[c * n + i] -= l * a[c * n + k];
                }
                b[i] -= l * b[k];
            }
        }
    }
    for k in (0..n).rev() {
        let mut x = b[k];
        for c in k + 1..n {
            x -= a[c * n + k] * b[c];
        }
        b[k] = x / a[k * n + k];
    }
    true
}

/// Largest sample interval over which the response is integrated, s; a larger gap (or a
/// sample without dynamics) restarts it quasi-statically.
pub const MAX_GAP: f64 = 0.05;

/// A transmission response at one sample: δw (rad), δẇ (rad/s), and the torque it takes off
/// the driven transmission's sensor (N·m).
pub type Response = Option<(DVector<f64>, DVector<f64>, f64)>;

/// The transmissions' wind-up response δw and its rate δẇ at every sample of one recording
/// (times `t`, s) to a joint-side torque `g(i)` (N·m) on drive `j`, with the transmissions'
/// dynamics at each sample. Starts quasi-statically (δw = (K + S)⁻¹·g, the rate from the
/// first two samples' quasi-static values) at the first sample and after every gap; None at
/// samples without dynamics.
pub fn joint_torque_response(
    t: &[f64],
    dynamics: &[Option<TransmissionDynamics>],
    j: usize,
    g: &dyn Fn(usize) -> f64,
) -> Vec<Option<(DVector<f64>, DVector<f64>)>> {
    response(t, dynamics, j, g, None)
        .into_iter()
        .map(|x| x.map(|(w, wd, _)| (w, wd)))
        .collect()
}

/// The transmissions' response δw, δẇ to backlash `half_play` b (rad) in drive `j`'s
/// transmission, and the torque the dead zone takes from that transmission at each sample
/// (the lost torque L of [`DeadZone`], N·m; the sensor on drive j reads K·δw + D·δẇ − L
/// more than the nominal model), about the nominal wind-up
/// ([`TransmissionDynamics::windup`]): integrated through each sample interval with the
/// dead zone's side decided per substep, so a play crossed within one interval — the torque
/// held at zero while the arm flies across it, then the strike on the other flank — shows at
/// the samples that fall into it. Not linear in b: how long the crossing takes depends on
/// b, on the rate the wind-up had as the torque reversed (τ̇/K) and on how the load
/// accelerates the free arm. Starts at rest on the flank the nominal wind-up presses (δw =
/// (K + S)⁻¹·e_j·K_j·b·sign w_nom) at the first sample and after every gap; None at samples
/// without the nominal wind-up (not finite) or whose sizes do not match.
pub fn backlash_response(
    t: &[f64],
    dynamics: &[Option<TransmissionDynamics>],
    j: usize,
    half_play: f64,
    place: PlayPlace,
) -> Vec<Response> {
    let side = |i: usize| {
        dynamics
            .get(i)
            .and_then(|d| d.as_ref())
            .and_then(|d| Some(d.stiffness().get(j)? * half_play * d.windup.get(j)?.signum()))
            .unwrap_or(f64::NAN)
    };
    response(t, dynamics, j, &side, Some((half_play, place)))
}

/// The response of [`joint_torque_response`] (`dead` None: the load `g` throughout) or of
/// [`backlash_response`] (`dead` the half play and where it sits: `g` only for the
/// quasi-static start, the dead zone's lost torque within the intervals); with the lost
/// torque at each sample (0 without a dead zone).
fn response(
    t: &[f64],
    dynamics: &[Option<TransmissionDynamics>],
    j: usize,
    g: &dyn Fn(usize) -> f64,
    dead: Option<(f64, PlayPlace)>,
) -> Vec<Response> {
    /// One sample's mass, stiffness, load and damping, and drive j's nominal wind-up, its
    /// rate, stiffness and damping.
    struct Sample {
        mass: DMatrix<f64>,
        stiffness: DMatrix<f64>,
        load: DVector<f64>,
        damping: DVector<f64>,
        nominal: (f64, f64),
        kj: f64,
    }
    impl Sample {
        fn end(&self) -> End<'_> {
            End {
                mass: &self.mass,
                stiffness: &self.stiffness,
                load: &self.load,
            }
        }
        fn quasi_static(&self) -> Option<DVector<f64>> {
            self.stiffness.clone().lu().solve(&self.load)
        }
    }
    let n_s = t.len();
    let mut out = vec![None; n_s];
    let at = |i: usize| -> Option<Sample> {
        let dy = dynamics.get(i)?.as_ref()?;
        let nd = dy.compliance.len();
        if j >= nd || dy.damping.len() != nd || dy.mass.shape() != (nd, nd) {
            return None;
        }
        let mut load = DVector::zeros(nd);
        load[j] = g(i);
        let nominal = (
            dy.windup.get(j).copied().unwrap_or(0.0),
            dy.windup_rate.get(j).copied().unwrap_or(0.0),
        );
        load[j].is_finite().then(|| Sample {
            mass: dy.mass.clone(),
            stiffness: dy.response_stiffness(),
            load,
            damping: DVector::from_column_slice(&dy.damping),
            nominal,
            kj: dy.stiffness()[j],
        })
    };
    // Within the intervals a dead zone's forcing is its own (no load).
    let interval_end = |s: &Sample| -> DVector<f64> {
        if dead.is_some() {
            DVector::zeros(s.load.len())
        } else {
            s.load.clone()
        }
    };
    let zone_at = |s: &Sample, nominal: [(f64, f64); 2], node: f64| {
        dead.map(|(b, place)| DeadZone {
            drive: j,
            half_play: b,
            stiffness: s.kj,
            damping: s.damping[j],
            nominal,
            place,
            node,
        })
    };
    // The last sample: its index, state, dynamics and the node's deflection.
    let mut prev: Option<(usize, State, Sample, f64)> = None;
    for i in 0..n_s {
        let Some(now) = at(i) else {
            prev = None;
            continue;
        };
        let stepped = prev.as_ref().and_then(|(p, state, before, node)| {
            let h = t[i] - t[*p];
            if !(h > 0.0 && h <= MAX_GAP) {
                return None;
            }
            let zone = zone_at(&now, [before.nominal, now.nominal], *node);
            let (l0, l1) = (interval_end(before), interval_end(&now));
            let start = End {
                load: &l0,
                ..before.end()
            };
            let end = End {
                load: &l1,
                ..now.end()
            };
            newmark_interval_with(state, &start, &end, &now.damping, h, zone.as_ref())
        });
        let (state, lost, node) = match stepped {
            Some(s) => s,
            None => {
                let Some(w) = now.quasi_static() else {
                    prev = None;
                    continue;
                };
                // The rate from the next sample's quasi-static wind-up, when there is one.
                let wd = (i + 1 < n_s && t[i + 1] > t[i] && t[i + 1] - t[i] <= MAX_GAP)
                    .then(|| at(i + 1).and_then(|next| next.quasi_static()))
                    .flatten()
                    .map(|w1| (w1 - &w) / (t[i + 1] - t[i]))
                    .unwrap_or_else(|| DVector::zeros(w.len()));
                let n = w.len();
                // A dead zone starts at rest on its flank (the next sample's flank may be
                // the other: no rate from the difference), the torque it takes from its
                // state there.
                let (wd, lost, node) = match zone_at(&now, [now.nominal; 2], 0.0) {
                    Some(zone) => {
                        let (wt, vt) = (now.nominal.0 + w[j], now.nominal.1);
                        let (lost, node) = zone.start(wt, vt);
                        (DVector::zeros(n), lost, node)
                    }
                    None => (wd, 0.0, 0.0),
                };
                ((w, wd, DVector::zeros(n)), lost, node)
            }
        };
        if !state.0.iter().chain(state.1.iter()).all(|v| v.is_finite())
            || !lost.is_finite()
            || !node.is_finite()
        {
            prev = None;
            continue;
        }
        out[i] = Some((state.0.clone(), state.1.clone(), lost));
        prev = Some((i, state, now, node));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One drive's dynamics (inertia `j`, stiffness `k`, damping `d`) along a nominal
    /// (wind-up, its rate, torque) per sample.
    fn along(nominal: &[(f64, f64, f64)], j: f64, k: f64, d: f64) -> Vec<Option<TransmissionDynamics>> {
        nominal
            .iter()
            .map(|&(w, wd, _)| {
                Some(TransmissionDynamics {
                    windup: vec![w],
                    windup_rate: vec![wd],
                    ..one_drive(j, 1.0 / k, d)
                })
            })
            .collect()
    }

    fn one_drive(m: f64, c: f64, d: f64) -> TransmissionDynamics {
        TransmissionDynamics {
            mass: DMatrix::from_element(1, 1, m),
            compliance: vec![c],
            damping: vec![d],
            windup_rate: vec![0.0],
            windup: vec![0.0],
            load_stiffness: None,
        }
    }

    /// The in-place elimination pivots (a zero leading entry) and refuses a singular matrix.
    #[test]
    fn the_dense_solve_pivots_and_refuses_a_singular_matrix() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 4.0]);
        let b = DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let (mut aa, mut x) = (a.as_slice().to_vec(), b.as_slice().to_vec());
        assert!(solve_dense_in_place(&mut aa, &mut x, 3));
        let r = &a * DVector::from_vec(x) - &b;
        assert!(r.amax() < 1e-14, "{r}");
        let mut singular = vec![1.0, 2.0, 2.0, 4.0];
        assert!(!solve_dense_in_place(&mut singular, &mut [1.0, 1.0], 2));
    }

    /// Three coupled drives over one interval: the buffered substeps give the Newmark rule
    /// written with nalgebra's matrix arithmetic (the form this replaced), to round-off;
    /// ends of the wrong size give None.
    #[test]
    fn the_coupled_newmark_interval_matches_the_matrix_form() {
        let m0 = DMatrix::from_row_slice(
            3,
            3,
            &[0.05, 0.01, -0.004, 0.01, 0.04, 0.002, -0.004, 0.002, 0.03],
        );
        let m1 = &m0 * 1.2;
        let s0 = DMatrix::from_row_slice(3, 3, &[1e4, -2e3, 0.0, -1.5e3, 8e3, 500.0, 0.0, 700.0, 1.2e4]);
        let s1 = &s0 * 0.9;
        let (f0, f1) = (
            DVector::from_vec(vec![0.3, -0.2, 1.0]),
            DVector::from_vec(vec![0.5, 0.1, 0.8]),
        );
        let d = DVector::from_vec(vec![3.0, 0.0, 7.5]);
        let state = (
            DVector::from_vec(vec![1e-5, -2e-5, 3e-5]),
            DVector::from_vec(vec![1e-3, 0.0, -2e-3]),
            DVector::from_vec(vec![0.1, -0.3, 0.2]),
        );
        let h = 2e-3;
        let start = End {
            mass: &m0,
            stiffness: &s0,
            load: &f0,
        };
        let end = End {
            mass: &m1,
            stiffness: &s1,
            load: &f1,
        };
        let (w, wd, wdd) = newmark_interval(&state, &start, &end, &d, h).unwrap();
        // The matrix form.
        let hs = h / SUBSTEPS as f64;
        let (a0, a1, a2, a3, a4, a5) = (4.0 / (hs * hs), 2.0 / hs, 4.0 / hs, 1.0, 1.0, 0.0);
        let (mut x, mut xd, mut xdd) = state.clone();
        for step in 1..=SUBSTEPS {
            let f = step as f64 / SUBSTEPS as f64;
            let m = &m0 * (1.0 - f) + &m1 * f;
            let kh = &m * a0 + &s0 * (1.0 - f) + &s1 * f + DMatrix::from_diagonal(&(&d * a1));
            let rhs = &f0 * (1.0 - f)
                + &f1 * f
                + &m * (&x * a0 + &xd * a2 + &xdd * a3)
                + d.component_mul(&(&x * a1 + &xd * a4 + &xdd * a5));
            let x1 = kh.lu().solve(&rhs).unwrap();
            let xdd1 = (&x1 - &x) * a0 - &xd * a2 - &xdd * a3;
            xd = &xd + (&xdd + &xdd1) * (0.5 * hs);
            xdd = xdd1;
            x = x1;
        }
        assert!((&w - &x).amax() < 1e-12 * x.amax(), "{w} vs {x}");
        assert!((&wd - &xd).amax() < 1e-10 * xd.amax(), "{wd} vs {xd}");
        assert!((&wdd - &xdd).amax() < 1e-8 * xdd.amax(), "{wdd} vs {xdd}");
        let short = DVector::from_vec(vec![0.3, -0.2]);
        let bad = End {
            mass: &m0,
            stiffness: &s0,
            load: &short,
        };
        assert!(newmark_interval(&state, &start, &bad, &d, h).is_none());
    }

    /// A slow load: the response is the quasi-static wind-up c·g, less the damper's share
    /// c²·D·ġ (the next term of the slow expansion; the inertial one, c²·M·g̈, is 20× smaller).
    #[test]
    fn a_slow_torque_winds_the_transmission_up_quasi_statically() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-3).collect();
        let dy = vec![Some(one_drive(0.04, 1e-4, 12.6)); t.len()];
        let g = |i: usize| (2.0 * t[i]).sin();
        let r = joint_torque_response(&t, &dy, 0, &g);
        let c = 1e-4;
        for i in 500..t.len() {
            let (w, _) = r[i].as_ref().unwrap();
            let expected = c * g(i) - c * c * 12.6 * 2.0 * (2.0 * t[i]).cos();
            assert!(
                (w[0] - expected).abs() < 2e-5 * c,
                "sample {i}: {} vs {expected}",
                w[0]
            );
        }
    }

    /// The joint-side torques' stiffness S adds to the transmission's: a slow load winds it
    /// up by g/(K + S) (here S = K/4, so 20 % less than c·g), and a load stiffness of the
    /// wrong shape is ignored.
    #[test]
    fn the_load_stiffness_stiffens_the_response() {
        let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-3).collect();
        let c = 1e-4;
        let mut dy = one_drive(0.04, c, 0.0);
        dy.load_stiffness = Some(DMatrix::from_element(1, 1, 0.25 / c));
        let g = |_: usize| 1.0;
        let r = joint_torque_response(&t, &vec![Some(dy.clone()); t.len()], 0, &g);
        let (w, _) = r[1000].as_ref().unwrap();
        assert!((w[0] - 0.8 * c).abs() < 1e-9 * c, "{}", w[0]);
        dy.load_stiffness = Some(DMatrix::zeros(2, 2));
        let r = joint_torque_response(&t, &vec![Some(dy); t.len()], 0, &g);
        let (w, _) = r[1000].as_ref().unwrap();
        assert!((w[0] - c).abs() < 1e-9 * c, "{}", w[0]);
    }

    /// A torque step rings the transmission at its own frequency, ω = √(K/M), decaying with
    /// ζ = D/(2√(KM)): compared with the closed-form step response of the oscillator.
    #[test]
    fn a_torque_step_rings_the_transmission_as_the_oscillator_does() {
        let (m, c, d) = (0.04, 1e-4, 4.0);
        let (k, h) = (1.0 / c, 2e-3);
        let t: Vec<f64> = (0..400).map(|i| i as f64 * h).collect();
        let dy = vec![Some(one_drive(m, c, d)); t.len()];
        let step = 100;
        // The step is applied over one sample interval (the load is linear within it), so
        // compare from two intervals after it with the exact response to that ramp.
        let g = |i: usize| if i >= step { 1.0 } else { 0.0 };
        let r = joint_torque_response(&t, &dy, 0, &g);
        let wn = (k / m).sqrt();
        let zeta = d / (2.0 * (k * m).sqrt());
        let wdamp = wn * (1.0 - zeta * zeta).sqrt();
        // Unit-step response of the oscillator, and the ramp over [0, h] as the difference of
        // two ramp responses (integrals of the step response).
        let ramp = |s: f64| {
            if s <= 0.0 {
                return 0.0;
            }
            let steps = 2000;
            let ds = s / steps as f64;
            (0..steps)
                .map(|q| {
                    let x = (q as f64 + 0.5) * ds;
                    c * (1.0
                        - (-zeta * wn * x).exp()
                            * ((wdamp * x).cos() + zeta * wn / wdamp * (wdamp * x).sin()))
                        * ds
                })
                .sum::<f64>()
        };
        let t0 = t[step - 1];
        let mut worst: f64 = 0.0;
        for i in step + 2..t.len() {
            let s = t[i] - t0;
            let exact = (ramp(s) - ramp(s - h)) / h;
            let (w, _) = r[i].as_ref().unwrap();
            worst = worst.max((w[0] - exact).abs());
        }
        // Ringing amplitude is of the order of c·1 N·m = 1e-4 rad; what remains is Newmark's
        // period elongation, (ω·h/8)²/12 per period.
        assert!(worst < 1e-2 * c, "worst deviation {worst:e} rad");
        // And it does ring: the response overshoots the quasi-static value (by e^(−ζπ/√(1−ζ²))
        // for a sudden step, less for a step spread over a sample interval).
        let peak = r.iter().flatten().map(|(w, _)| w[0]).fold(f64::MIN, f64::max);
        assert!(peak > 1.4 * c, "peak {peak:e} rad");
    }

    /// An arm (inertia J) on a transmission with backlash b whose joint-side load reverses
    /// at a steady rate τ̇: the response of [`backlash_response`] about the linear nominal
    /// wind-up reproduces the dead-zone transmission simulated on its own at 1 µs steps —
    /// its torque held at zero while the arm crosses the play (about 2·b·K/|τ̇| = 2 ms here,
    /// at the wind-up's rate), then the strike on the other flank and its ringing — at the
    /// 500 Hz samples, one of which falls into the crossing.
    #[test]
    fn a_reversal_through_the_play_holds_the_torque_at_zero_as_the_dead_zone_does() {
        let (j, k, d, b) = (0.02, 1e4, 5.66, 1e-5);
        let (rate, t0) = (-100.0, 0.0511);
        let load = |t: f64| rate * (t - t0);
        let truth_zone = |w: f64, wd: f64| {
            let over = w.abs() - b;
            if over <= 0.0 {
                0.0
            } else {
                w.signum() * (k * over + d * wd * w.signum()).max(0.0)
            }
        };
        // J·ẅ + T(w, ẇ) = τ_L(t) from the quasi-static start, semi-implicit Euler at 1 µs;
        // the transmitted torque at every 2 ms sample.
        let simulate = |torque: &dyn Fn(f64, f64) -> f64, w0: f64| {
            let (dt, per) = (1e-6, 2000);
            let (mut w, mut wd) = (w0, rate / k);
            let mut out = vec![(w, wd, torque(w, wd))];
            for step in 1..=50 * per {
                let t = (step - 1) as f64 * dt;
                wd += dt * (load(t) - torque(w, wd)) / j;
                w += dt * wd;
                if step % per == 0 {
                    out.push((w, wd, torque(w, wd)));
                }
            }
            out
        };
        let nominal = simulate(&|w, wd| k * w + d * wd, load(0.0) / k);
        let truth = simulate(&truth_zone, load(0.0) / k + b);
        let t: Vec<f64> = (0..=50).map(|i| i as f64 * 2e-3).collect();
        let dynamics = along(&nominal, j, k, d);
        let r = backlash_response(&t, &dynamics, 0, b, PlayPlace::Spring);
        let reading = |i: usize| {
            let (w, wd, lost) = r[i].as_ref().unwrap();
            nominal[i].2 + k * w[0] + d * wd[0] - lost
        };
        // The sample 0.9 ms into the crossing (t = 52 ms): the nominal transmission carries
        // 0.09 N·m, the dead zone nothing.
        assert!(
            nominal[26].2.abs() > 0.08 && truth[26].2.abs() < 1e-3,
            "{:?} {:?}",
            nominal[26],
            truth[26]
        );
        assert!(reading(26).abs() < 0.005, "reading {} N·m", reading(26));
        // Over the whole record the response explains the dead zone's effect to within 10 %.
        let (mut effect, mut left) = (0.0, 0.0);
        for i in 0..t.len() {
            effect += (truth[i].2 - nominal[i].2).powi(2);
            left += (truth[i].2 - reading(i)).powi(2);
        }
        assert!(effect.sqrt() > 0.05, "effect {} N·m", effect.sqrt());
        assert!(
            left.sqrt() < 0.1 * effect.sqrt(),
            "left {} of {} N·m",
            left.sqrt(),
            effect.sqrt()
        );
        // Before the reversal the arm rests on the loaded flank: lagging by b, the torque
        // as the nominal transmission's.
        let (w, _, _) = r[10].as_ref().unwrap();
        assert!((w[0] - b).abs() < 1e-3 * b && (reading(10) - nominal[10].2).abs() < 1e-9);
    }

    /// The same arm with the play between the spring and the arm (a gear mesh at the
    /// output): the spring ends at a massless node, D·ġ + K·g = T, which the arm presses
    /// through a rigid flank (g = w − b·sign) or lets go of (T = 0, the spring relaxing
    /// through its damper). Simulated alone at 0.1 µs, read every 2 ms: the response at the
    /// output explains it to within 10 %, and the dead zone in the spring does not — the
    /// two places part where the spring, still wound as the arm lets go, relaxes across the
    /// play.
    #[test]
    fn a_play_at_the_output_lets_the_spring_relax_as_the_arm_crosses_it() {
        let (j, k, d, b) = (0.02, 1e4, 20.0, 1e-5);
        let (rate, t0) = (-400.0, 0.0511);
        let load = |t: f64| rate * (t - t0);
        // (w, ẇ, transmitted torque) every 2 ms; `series`: the play at the output.
        let simulate = |series: bool| {
            let (dt, per) = (1e-7, 20_000);
            let (mut w, mut wd) = (load(0.0) / k, rate / k);
            if series {
                w += b;
            }
            // The node's deflection and whether the arm presses its flank (side s).
            let (mut g, mut s) = (w - b, 1.0);
            let mut pressing = series;
            let torque = |w: f64, wd: f64, g: &mut f64, pressing: &mut bool, s: &mut f64| -> f64 {
                if !series {
                    return k * w + d * wd;
                }
                if *pressing {
                    *g = w - b * *s;
                    let t = k * *g + d * wd;
                    if t * *s > 0.0 {
                        return t;
                    }
                    *pressing = false;
                }
                *g *= (-k * dt / d).exp();
                let m = w - *g;
                if m.abs() >= b && (k * (w - b * m.signum()) + d * wd) * m.signum() > 0.0 {
                    (*pressing, *s) = (true, m.signum());
                    *g = w - b * *s;
                    return k * *g + d * wd;
                }
                0.0
            };
            let mut out = vec![(w, wd, torque(w, wd, &mut g, &mut pressing, &mut s))];
            for step in 1..=50 * per {
                let t = (step - 1) as f64 * dt;
                let tq = torque(w, wd, &mut g, &mut pressing, &mut s);
                wd += dt * (load(t) - tq) / j;
                w += dt * wd;
                if step % per == 0 {
                    let (mut g2, mut p2, mut s2) = (g, pressing, s);
                    out.push((w, wd, torque(w, wd, &mut g2, &mut p2, &mut s2)));
                }
            }
            out
        };
        let nominal = simulate(false);
        let truth = simulate(true);
        let t: Vec<f64> = (0..=50).map(|i| i as f64 * 2e-3).collect();
        let dynamics = along(&nominal, j, k, d);
        let left = |place: PlayPlace| {
            let r = backlash_response(&t, &dynamics, 0, b, place);
            let (mut effect, mut left) = (0.0, 0.0);
            for i in 0..t.len() {
                let (w, wd, lost) = r[i].as_ref().unwrap();
                let reading = nominal[i].2 + k * w[0] + d * wd[0] - lost;
                effect += (truth[i].2 - nominal[i].2).powi(2);
                left += (truth[i].2 - reading).powi(2);
            }
            (effect.sqrt(), left.sqrt())
        };
        let (effect, output) = left(PlayPlace::Output);
        let (_, spring) = left(PlayPlace::Spring);
        assert!(effect > 0.05, "effect {effect} N·m");
        assert!(output < 0.1 * effect, "output: left {output} of {effect} N·m");
        assert!(
            spring > 3.0 * output,
            "spring: left {spring}, output {output} of {effect} N·m"
        );
    }
}
