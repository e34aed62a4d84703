//! A reduced dynamic model of a universal joint's play along a recording: what the
//! quasi-static play candidates leave out — the joint tilting and shifting across its
//! clearance when its load changes, and the ringing of the drives that excites.
//!
//! The unknowns are small deviations from the nominal motion: the drives' wind-up δw (one per
//! drive, rad or m), the joint's four play coordinates e = (shift of side j from side i
//! along base x, y, z in m; tilt of side j about n = z_i × z_j in rad) and the cross's pose
//! from side i, c (m) and ω (rad), base frame. The mechanics are linearised about the nominal
//! model at each sample ([`PlayDynamics`], [`TransmissionDynamics`]); the contact of the play
//! stays nonlinear:
//!
//! ```text
//! M_d·δẅ − T_ë·ë + (D + G)·δẇ − T_ė·ė + (K + S)·δw − T_e·e = 0        the drives
//! −A_ẅ·δẅ + A_ë·ë − A_ẇ·δẇ + A_ė·ė − A_w·δw + A_e·e = Λ_c(e, ė; c, ω) − Λ   the joint
//! m_x·c̈ = F_c + m_x·(g − a_i),   J_x·ω̈ = M_c                             the cross
//! ```
//!
//! with T_e, T_ė, T_ë the joint-side torques' derivatives by the play coordinates, their
//! rates and accelerations, S and G the torques' by the arms' positions and rates, A_e, A_ė,
//! A_ë, A_w, A_ẇ, A_ẅ the joint's generalised reaction's by the same (an arm lags its encoder
//! by δw), Λ the reaction the nominal (ideal) joint carries and Λ_c what the joint's contacts
//! give: the reaction the motion asks of the joint must be what its contacts give — nothing
//! inside the play. F_c, M_c: the balls' force and moment on the cross; g gravity and a_i the
//! nominal acceleration of side i's point at the joint's centre ([`PlayDynamics::cross_load`]).
//!
//! **Velocity products** (G, T_ė, A_ẇ, A_ė; since 2026-11-27): the nominal motion's rates
//! times the play's. Measured with the example (`play_dynamics`, joint F, 6 µm, balls 1e8
//! N/m and 200 N·s/m; what the model leaves of the play's effect on drives A/B/C, RMS over
//! 0.6–5 s in torque-noise units): recording 5 4.71/3.67/5.36 without them, 4.57/3.24/5.26
//! with; recording 3 1.37/0.82/1.58 → 1.27/0.69/1.48; recording 1 1.10/0.76/1.31 →
//! 1.02/0.78/1.23; recording 6 unchanged (0.13/0.12/0.15).
//!
//! **Re-linearised** ([`PlaySample::about`], [`PlayPoint`]): near a singular position the
//! play moves the mechanism far from the nominal configuration (recording 5 at 2.67 s: 6 µm
//! in joint F, 240 µm of the platform), and the derivatives there differ. Expanded about its
//! own motion of a first pass (once: a second pass changed nothing), the model leaves
//! 4.34/2.83/4.99 of recording 5 (from 4.57/3.24/5.26). With balls of 2e8 N/m, drive A's
//! torque at the load peak (2.67 s; truth 0.71 N·m, the same on each drive) is about 0.40
//! linearised about the samples and 0.52 re-linearised; the swing back (2.72 s; truth
//! −0.78) about −0.28, −0.34 re-linearised and −0.53 with the velocity products too. What
//! stays is in 2.6–3.1 s, 10–19 torque-noise units: the diagnosis does not re-linearise yet.
//!
//! **The cross is a body** ([`PlayDynamics::cross_mass`]; the inertia of two perpendicular
//! rods of length s, as the suite's truths give it): each of its four balls sits in a bore
//! of its own side — a side-i ball at ±(s/2)·z_i moves by c + ω × (±(s/2)·z_i) in its bore,
//! a side-j ball at ±(s/2)·z_j by (c − e) + (ω − φ·n) × (±(s/2)·z_j) — so all four can
//! carry load at once, as the truth's do. (Until 2026-11-27 the cross was placed kinematically,
//! half the shift along n and half the tilt per pair: then at most three balls could touch,
//! and under a steady load the joint flipped between two sets of them — a rattle of its own
//! where the truth stays loaded.)
//!
//! **The cross's own load** (2026-11-30, session 54; [`PlayDynamics::cross_load`]). The nominal
//! model carries the cross in side i's link (the truth carves it out of that link as a body
//! of its own), so Λ, the load on side j, leaves out what holds the cross up and drags it
//! along: m_x·(g − a_i), its weight less its mass times side i's acceleration at the joint,
//! which side i's balls carry and side j's do not (test
//! `the_crosss_own_load_rides_on_side_is_balls_only`). Until then the model's cross was
//! weightless and moved only by its balls, so near a load reversal — a joint load of a few
//! newtons against the cross's 0.5 N weight and its share of the arm's accelerations — the
//! joint crossed its play at the wrong moment: the model's swings came up to 1.4 ms late or
//! early, episode by episode, and scaling the play coordinates' inertia by ±5 % moved
//! different episodes in opposite directions (an experiment, not kept). With the load
//! (example `play_dynamics`, joint F, 6 µm, Hertz balls damped 1 N·s/m + 450 s/m × F — the
//! truth's own law —, forces blended, re-linearised once; what the model leaves of the
//! play's effect on drives A/B/C, RMS in torque-noise units): recording 5 over 0.6–5 s
//! 0.59/0.55/1.06 → 0.35/0.28/0.57 (0.6–2.6 s 0.65/0.56/1.11 → 0.06/0.07/0.17; 3.1–5 s
//! 0.36/0.47/0.68 → 0.05/0.07/0.13; the rattle 2.77–3.10 s 1.11/0.88/2.18 → 1.19/0.92/1.97,
//! where an impact peak at 2.846 s sampled between its rise and fall is most of drive C's
//! rest and the timing is right: shifted by a quarter sample either way it leaves 4–5);
//! recording 1 0.40/0.35/0.57 → 0.09/0.07/0.11, recording 3 0.45/0.27/0.70 →
//! 0.16/0.09/0.21; recording 4 (20 + 500 × F) 0.92/0.72/1.15 → 0.23/0.17/0.32, 0.13/0.07/0.17
//! at 1 + 450 × F. The cross's rotational share (J_x times side i's angular acceleration) is
//! left out: J_x is 1.2–2.4e-6 kg·m² (two 24 mm rods of 25 g).
//!
//! **Contacts** ([`JointPlay`]): per ball a radial contact in a bore with radial clearance h
//! and an axial one on the bore's end, h_a/2 away at the centre of a pair's axial play h_a,
//! on a linear penalty law ([`BallContact`]: stiffness on the penetration, damping on its
//! rate, never pulling; the same damping along the bore's wall while in radial contact), or
//! on Hertz's law per direction ([`HertzBalls`], `BallContact::hertz`: F = K·δ^1.5 with K of a
//! ball in a bore of the play's clearance radially, of a ball on the bore's end face
//! axially, from the joint's own bearings; damping as before). Neither is the contact law of
//! the suite's truths (Hertz balls with Hunt–Crossley damping, in the whole 63-DOF model):
//! it is a model of the same geometry, reduced.
//!
//! **Hertz per direction** (2026-11-27, session 28): the truth reports each joint's play
//! coordinates (`TruthRun::joint_play`), and beside the model's (example `play_dynamics`,
//! joint F, 6 µm, recording 5 at the load peak near the direct singularity) they showed the
//! one linear stiffness wrong in both directions: without clearance the truth's joint barely
//! tilts (102 µrad: balls that fit their bores are a conformal contact) but shifts 8.3 µm
//! along the trunnion axis (a ball on a flat end face is soft), the model's 397 µrad and
//! 2.8 µm at 1e8 N/m. With Hertz from the design the model's joint follows the truth's to a
//! few per cent (without clearance −8.25/−3.22/−0.83 µm, 101.6 µrad against −8.17/−3.19/−0.84
//! µm, 102.0 µrad at 2.65 s; with clearance 1 198 µrad against 1 217), and what the model
//! leaves of the play's effect on drives A/B/C (RMS 0.6–5 s, torque-noise units, with the play
//! less without) drops on every recording: 5: 4.57/3.24/5.26 → 4.04/2.77/4.62; 3: 1.27/0.69/1.48
//! → 1.01/0.57/1.27; 1: 1.02/0.78/1.23 → 0.63/0.56/0.81; 6: 0.12/0.12/0.15 → 0.08/0.08/0.08.
//! What stayed on recording 5 was the load peak's torque (0.40 against 0.70 N·m at 2.68 s)
//! with the joint's motion right: the drives' response to it.
//!
//! **The load stiffness at the arms' accelerations** (2026-11-27, session 29): S and the
//! play's couplings were the nominal model's derivatives at the encoders' accelerations,
//! where the linearisation asks for the arms' own (q̈ − ẅ: the torque is M(q_a)·q̈_a + …, so
//! its derivative by the arms' place carries ∂M/∂q_a·q̈_a). Near the direct singularity the
//! drives ring (the nominal torques swing by some 40 N·m at ≈ 20 Hz on recording 5 at
//! 2.6–2.9 s) and M_d changes fast with the configuration, so the difference is large. At the
//! arms' accelerations (Hertz balls, 200 N·s/m; drives A/B/C, torque-noise units) the load
//! peak's window 2.60–2.77 s goes 10.0/9.8/9.7 → 5.3/5.2/5.1, and re-linearised once about the
//! model's own motion ([`PlaySample::about`]) to 1.5/1.4/1.5 (peak 0.69 against the truth's
//! 0.70 N·m). What stays is the rattle after it (2.77–3.10 s: 12.8/6.6/15.0 of 36/32/39): the
//! joint crossing its play every half-period of that ringing.
//!
//! **Load-proportional damping** (2026-11-27, session 30; [`BallContact::load_damping`]). The
//! rattle is deterministic in the truth and steep in its contact's damping (example
//! `truth_sensitivity`, recording 5: tolerances ÷ 10 move the torques by ≤ 0.02 noise units
//! in 2.77–3.10 s; the truth's Hunt–Crossley α at 100 or 1 000 s/m instead of 300 by
//! 6.9/3.3/9.0 and 7.0/4.9/9.2 on drives A/B/C). One constant damping cannot be right under
//! tens of newtons and as a ball barely touches; a damping γ·F proportional to the contact's
//! elastic force — the hysteresis of a Hertzian contact, the form of the truth's law too —
//! can. In the diagnosis γ is one of the dampings cross-validation chooses among
//! ([`DiagnoseOptions::play_contact_dampings`](super::DiagnoseOptions), not by default: chosen
//! on clearance-F, it did not lower the held-out residual; diagnosis log), the truth's value
//! (1.5·α = 450 s/m) not among the values tried (`--play-load-damping` takes any). Measured
//! with held forces, over 200 N·s/m, with the example
//! `play_dynamics` (Hertz balls, 200 N·s/m constant; what the model leaves of the play's
//! effect, drives A/B/C, RMS 0.6–5 s in torque-noise units): recording 5 3.60/2.03/4.32 at
//! γ = 0, 2.49 (drive A) at 100 s/m, 1.84 at 450, 1.97/1.55/2.72 at 1 000 (the rattle
//! window 12.4/6.1/15.0 → 5.7/3.4/8.2), and re-linearised once 1.51/1.08/2.26 (the load
//! peak 1.5/1.5/1.6, the rattle 4.9/2.8/7.0); recording 3 1.28/0.56/1.47 → 0.95 (drive A) at
//! 150 and 450 s/m but 1.48/0.59/1.63 at 1 000; recording 1 0.56/0.50/0.77 →
//! 0.61/0.54/0.79; recording 6 unchanged (0.06). A damping of another form, proportional to
//! the contact's stiffness (β·dF/dδ ∝ √δ), helped recording 5 (1.71 on drive A at
//! β = 3e-4 s) but not recording 3 (1.69). A stiff damping needs no shorter substeps: they
//! take it implicitly (below).
//!
//! **Outputs**: the torque sensors read K·δw + D·δẇ more.
//!
//! **Integration**: semi-implicit (symplectic) Euler over substeps of each sample interval,
//! the linearised mechanics within it as [`Interpolation`] says: held at the interval's end
//! (the diagnosis' default), or the linear forces g − K·x − C·v blended in time from the
//! previous sample's ([`Interpolation::Linear`], since 2026-11-30 an option), which moves
//! the joint across its play when a load reverses within an interval as the finely sampled
//! load does, rather than up to a sample early (test
//! `blended_forces_follow_a_swinging_load_as_a_finely_sampled_model_does`). Blended, with Hertz
//! balls, re-linearised once and a damping of Hunt–Crossley's form (γ·F over a small
//! constant), the model at the truth's play leaves about one noise unit of recording 5's
//! play effect, the rattle included (diagnosis log, "The rattle reproduced at the truth's play");
//! in the diagnosis the bearing cases did not improve (the play's size is estimated through
//! a column scaled from a reference play, and the rattle is steep in the size). The substep a
//! fifth of the period of the fastest mode with every ball in contact
//! ([`SUBSTEPS_PER_PERIOD`]; the cross's own period, ≈ 0.1 ms for 50 g on 1e8 N/m) and short
//! enough to resolve the dampings; where a stiff contact damping (γ·F under a large load)
//! would ask for more than four times as many substeps, the dampings (the system's and the
//! contacts', linearised in the rates) are taken implicitly instead, (M + dt·(C + C_c))·Δv =
//! dt·f(x, v), then x += v·dt — the drives' block eliminated once per sample interval, so a
//! substep factorises only the play and cross block's 10 × 10 Schur complement
//! (`PlaySchur`; the example `play_model_run` 0.798× the CPU time of the dense LU of all
//! the unknowns, 7 alternated whole-process pairs, and the example `play_dynamics` prints
//! the same numbers). (Measured with the example on recording 5, implicit
//! throughout against explicit throughout: the same responses to 0.01 noise units.) A
//! recording's first sample, and the first after a gap longer than
//! [`transmission::MAX_GAP`](super::transmission::MAX_GAP) or a sample without the model's
//! data, starts quasi-statically: the joint against the wall its nominal reaction pushes it to
//! ([`UniversalPlay::shift`](crate::contact::play::UniversalPlay::shift)), then Newton's
//! method on the statics of the joint, its cross and the transmissions.
//!
//! **Stiff substeps** (2026-12-07, session 77; [`Stepping::Stiff`], `lash diagnose
//! --play-stiff-substeps`, not the default yet): most of a bearing diagnosis's time is the
//! substeps above — a few hundred to about a thousand per 2 ms sample interval, set by the
//! cross's modes on its balls (a 50 g cross, 1e-6 kg·m², on Hertz contacts under hundreds
//! of newtons), which the torques barely see. The stiff substeps take the contacts'
//! stiffness and damping into the step's matrix, the Rosenbrock method ROS2 (second order,
//! L-stable; `advance_stiff`) with at least [`STIFF_SUBSTEPS`] per interval, and take a
//! substep again in halves, down to the resolved substeps' length, where a ball starts or
//! stops touching or a contact's load is far from linear over it (a ball that barely
//! touched and is pressed hard: Hertz's stiffness is nearly zero at the start). Tried on
//! the way and dropped: linearly implicit Euler (stable, but first order: at 40 per interval
//! it left 0.98 of drive A's play effect where the resolved substeps leave 0.36, torque-noise
//! units, example `play_dynamics`), the trapezoid and θ = 0.6–0.75 (they blew up in the
//! rattle), ROS2 without the halving (it blew up where balls start touching), and the time
//! derivative of the blended forces in ROS2's stages (the same numbers). Measured: see
//! [`STIFF_SUBSTEPS`] and the test `stiff_substeps_follow_the_resolved_ones_across_the_play`.
//!
//! Measured on the suite's truth (diagnosis log, "What the play leaves in the torques"; example
//! `play_dynamics`): with 6 µm of radial clearance in joint F, the play's effect on drive A's
//! torque, RMS over the record in torque-noise units, and what the model leaves of it: 11.2 →
//! 3.9 on the shaken recording 5 (the torque swing after the load peak near the direct
//! singularity and the rattle while the joint is nearly unloaded), 4.2 → 2.7 on recording 3,
//! and on the four gentle recordings 2.35 → 1.31, 1.00 → 0.37, 0.98 → 0.79, 0.49 → 0.04.

use super::model::{PlayDynamics, PlayPoint};
use super::transmission::{TransmissionDynamics, MAX_GAP};
use nalgebra::{DMatrix, DVector, SMatrix, Vector3};

/// The trunnion balls' contact in the reduced play model: a linear penalty, or Hertz's law
/// per direction ([`HertzBalls`]), with damping on the penetration's rate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallContact {
    /// Stiffness on a ball's penetration of its bore's clearance (against the bore's wall),
    /// N/m (the linear law; with [`hertz`](Self::hertz) unused).
    pub stiffness: f64,
    /// Stiffness on a ball's penetration of its bore's end face, N/m (the linear law; with
    /// [`hertz`](Self::hertz) unused). A ball on a flat face is a much softer contact than a
    /// ball in a bore that nearly fits it.
    pub axial_stiffness: f64,
    /// Damping on the penetration's rate, and on the ball's sliding along the wall while in
    /// contact, N·s/m (the contact never pulls).
    pub damping: f64,
    /// Load-proportional damping γ, s/m: the normal damping grows with the contact's elastic
    /// force F(δ), c = [`damping`](Self::damping) + γ·F(δ) — the hysteresis of a Hertzian
    /// contact (Hunt & Crossley 1975, J. Appl. Mech. 42(2):440–445: the energy an impact
    /// loses grows with its force), so a barely loaded ball is barely damped and a loaded
    /// one much more; 0 for a constant damping. Along the bore's wall the damping stays
    /// [`damping`](Self::damping).
    pub load_damping: f64,
    /// Hertz's law instead of the linear one: F = K·δ^1.5, K per direction.
    pub hertz: Option<HertzBalls>,
}

/// Hertz constants of a joint's trunnion balls, N/m^1.5: F = K·δ^1.5 on a penetration δ (m).
/// From the joint's own bearing design ([`HertzBalls::from_design`]): a ball against its
/// bore's wall is a sphere inside a concave cylinder of the bore's radius (nearly conformal:
/// the stiffer the smaller the clearance), a ball on its bore's end face a sphere on a plane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HertzBalls {
    /// A ball against its bore's wall, N/m^1.5.
    pub radial: f64,
    /// A ball against its bore's end face, N/m^1.5.
    pub axial: f64,
}

impl HertzBalls {
    /// The constants of a universal joint's balls ([`UniversalPlay`](crate::contact::play::UniversalPlay):
    /// radius, material) in bores of radial clearance `radial` (m).
    pub fn of(
        play: &crate::contact::play::UniversalPlay,
        radial: f64,
    ) -> Result<Self, crate::contact::ContactError> {
        use crate::contact::stiffness::{ball_in_bore, ball_on_flat};
        let m = &play.material;
        Ok(Self {
            radial: ball_in_bore(play.ball_radius, play.ball_radius + radial.max(0.0), m, m)?,
            axial: ball_on_flat(play.ball_radius, m, m)?,
        })
    }

    /// The constants of `design`'s balls (radius, material) in bores of its radial clearance
    /// (as [`of`](Self::of) the joint's [`UniversalPlay`](crate::contact::play::UniversalPlay)).
    pub fn from_design(design: &crate::contact::BearingDesign) -> Result<Self, crate::contact::ContactError> {
        Self::of(
            &crate::contact::play::UniversalPlay::from_design(design),
            design.radial_clearance,
        )
    }
}

impl BallContact {
    /// The normal force (N, ≥ 0) of a penetration `d` (m) of a bore's wall (`radial`) or of
    /// its end face, without the damping.
    fn spring(&self, radial: bool, d: f64) -> f64 {
        if d <= 0.0 {
            return 0.0;
        }
        match self.hertz {
            None => {
                (if radial {
                    self.stiffness
                } else {
                    self.axial_stiffness
                }) * d
            }
            Some(k) => (if radial { k.radial } else { k.axial }) * d * d.sqrt(),
        }
    }

    /// The normal force without the damping ([`spring`](Self::spring), N) and the normal
    /// damping (N·s/m) of a penetration `d` (m) of a bore's wall (`radial`) or of its end
    /// face: [`damping`](Self::damping) + γ·F(δ).
    fn spring_and_damping(&self, radial: bool, d: f64) -> (f64, f64) {
        let spring = self.spring(radial, d);
        let damping = if self.load_damping == 0.0 {
            self.damping
        } else {
            self.damping + self.load_damping * spring
        };
        (spring, damping)
    }

    /// dF/dδ (N/m) of [`spring`](Self::spring) at a penetration `d` (m).
    fn spring_rate(&self, radial: bool, d: f64) -> f64 {
        if d <= 0.0 {
            return 0.0;
        }
        match self.hertz {
            None => {
                if radial {
                    self.stiffness
                } else {
                    self.axial_stiffness
                }
            }
            Some(k) => 1.5 * (if radial { k.radial } else { k.axial }) * d.sqrt(),
        }
    }

    /// The largest penetration (m) a normal force `force` (N) makes, either direction.
    fn compression(&self, force: f64) -> f64 {
        match self.hertz {
            None => force / self.stiffness.min(self.axial_stiffness),
            Some(k) => (force / k.radial.min(k.axial)).max(0.0).powf(2.0 / 3.0),
        }
    }

    /// The largest contact stiffness dF/dδ (N/m) under a normal force `force` (N), either
    /// direction (Hertz: 1.5·K^(2/3)·F^(1/3)).
    fn tangent_stiffness(&self, force: f64) -> f64 {
        match self.hertz {
            None => self.stiffness.max(self.axial_stiffness),
            Some(k) => 1.5 * k.radial.max(k.axial).powf(2.0 / 3.0) * force.max(0.0).cbrt(),
        }
    }
}

/// A damping of the trunnion balls' contacts in the reduced play model: a constant part
/// (N·s/m, across and along the bore's wall) and a part proportional to the contact's elastic
/// force (γ, s/m; normal only): c = constant + γ·F(δ) ([`BallContact::load_damping`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct ContactDamping {
    /// Constant damping, N·s/m.
    pub constant: f64,
    /// Load-proportional damping γ, s/m.
    pub load: f64,
}

/// The constant part (N·s/m) that goes with a load-proportional damping in
/// [`ContactDamping::load_proportional`], for the balls' sliding along their bores' walls:
/// a tenth of the diagnosis' smaller constant damping, 200 N·s/m (this base was 200 N·s/m
/// itself until 2026-11-30). Measured
/// with the example `play_dynamics` (joint F, 6 µm, recording 5, Hertz balls, re-linearised
/// once, forces blended; what the model leaves of the truth's play effect on drives A/B/C,
/// RMS 0.6–5 s in torque-noise units): γ = 500 s/m over 200 N·s/m 1.11 / 0.92 / 1.61, over
/// 20 N·s/m 0.60 / 0.54 / 1.12 (γ = 450 s/m over 1 N·s/m 0.59 / 0.55 / 1.06).
pub const LOAD_DAMPING_BASE: f64 = 20.0;

impl ContactDamping {
    /// A constant damping `c` (N·s/m).
    pub const fn constant(c: f64) -> Self {
        Self {
            constant: c,
            load: 0.0,
        }
    }

    /// A load-proportional damping γ (s/m) over [`LOAD_DAMPING_BASE`].
    pub const fn load_proportional(gamma: f64) -> Self {
        Self {
            constant: LOAD_DAMPING_BASE,
            load: gamma,
        }
    }
}

impl std::fmt::Display for ContactDamping {
    /// "200 N s/m", or "200 N s/m + 1000 s/m × F" with a load-proportional part.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} N s/m", self.constant)?;
        if self.load != 0.0 {
            write!(f, " + {} s/m × F", self.load)?;
        }
        Ok(())
    }
}

impl BallContact {
    /// This contact with damping `d`.
    pub fn with_damping(self, d: ContactDamping) -> Self {
        Self {
            damping: d.constant,
            load_damping: d.load,
            ..self
        }
    }

    /// Its damping, both parts (the field `damping` is the constant part alone).
    pub fn contact_damping(&self) -> ContactDamping {
        ContactDamping {
            constant: self.damping,
            load: self.load_damping,
        }
    }
}

/// The contact the diagnosis log's measurements used: 1e8 N/m, about the secant stiffness F/δ of the
/// MR2120 bearing design's Hertz contact (a 4 mm steel ball in a bore 6 µm larger:
/// K = 1.12e11 N/m^1.5 from [`crate::contact::stiffness::ball_in_bore`], so F/δ = 0.85e8 N/m
/// at 50 N, 1.08e8 at 100 N, 1.55e8 at 300 N), and 2e3 N·s/m, a tenth of critical for a
/// kilogram on it, across and along the wall. Chosen, not fitted. Measured in the example
/// with the cross placed kinematically (before it was a body; joint F, 6 µm, torque-noise
/// units RMS over the record, drive A): damping only across the wall left the joint rocking
/// along its walls in quiet stretches (gentle recording 6: the effect 0.49, left 1.18; along
/// the wall too: 0.68); 2e4 N·s/m quieted that (0.33) but damped the rattle (shaken
/// recording 5: 3.9 → 5.7 left); 1e9 N/m did worse in the loaded window and 1e7 N/m diverged
/// (both before the reactions followed the arms). With the cross a body, recording 6 is left
/// at 0.04 with these values.
pub const BALL_CONTACT: BallContact = BallContact {
    stiffness: 1e8,
    axial_stiffness: 1e8,
    damping: 2e3,
    load_damping: 0.0,
    hertz: None,
};

/// A joint's play in the reduced model: the radial clearance of each trunnion ball in its
/// bore and the axial play of each trunnion pair between its bores' ends (total, ±half
/// either way), as [`BearingDesign`](crate::contact::BearingDesign) defines them. Units: m.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct JointPlay {
    /// Radial clearance h (the ball centre may move h off its bore's axis), m.
    pub radial: f64,
    /// Axial play h_a (total; the cross may move ±h_a/2 along a pair's axis), m.
    pub axial: f64,
}

impl JointPlay {
    /// Radial clearance only.
    pub fn radial(h: f64) -> Self {
        Self {
            radial: h,
            axial: 0.0,
        }
    }

    /// Axial play only.
    pub fn axial(h_a: f64) -> Self {
        Self {
            radial: 0.0,
            axial: h_a,
        }
    }

    /// The larger of the radial clearance and half the axial play, at least 1 nm: the scale
    /// of a ball's travel in the play, m.
    fn scale(&self) -> f64 {
        self.radial.max(0.5 * self.axial).max(1e-9)
    }
}

/// One sample of a recording for the reduced play model: its time and the nominal model's
/// linearisation there.
#[derive(Debug, Clone, Copy)]
pub struct PlaySample<'a> {
    /// Time, s.
    pub t: f64,
    /// The joint's coupling to the drives.
    pub play: &'a PlayDynamics,
    /// The drives' transmissions.
    pub transmission: &'a TransmissionDynamics,
    /// Where given, the nominal model re-linearised at a point of the play's motion near this
    /// sample ([`PlayPoint`]): the model expands about it instead of the nominal motion —
    /// its derivatives, the drives' mass and load stiffness there, and the torques and the
    /// joint's reaction that the point itself carries.
    pub about: Option<&'a PlayPoint>,
}

/// The samples expanded about the points where given ([`PlaySample::about`]; the points in
/// the samples' order, None: the sample's own expansion).
pub fn expanded_about<'a>(
    samples: &[Option<PlaySample<'a>>],
    points: &'a [Option<PlayPoint>],
) -> Vec<Option<PlaySample<'a>>> {
    samples
        .iter()
        .zip(points)
        .map(|(s, p)| {
            s.map(|s| PlaySample {
                about: p.as_ref(),
                ..s
            })
        })
        .collect()
}

/// The reduced play model's state at one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayResponse {
    /// Change of each drive's sensed torque, K·δw + D·δẇ (N·m, or N).
    pub torque: Vec<f64>,
    /// Change of each drive's transmission wind-up δw (rad, or m): the arm lags its encoder
    /// by δw more than in the nominal model.
    pub windup: Vec<f64>,
    /// The play coordinates e: shift along base x, y, z (m), tilt about n (rad).
    pub offset: [f64; 4],
    /// The bore wall's normal force on each ball (side i's two, then side j's), N.
    pub radial_forces: [f64; 4],
    /// The point this sample was expanded about ([`PlaySample::about`]), None about the
    /// nominal motion.
    pub point: Option<ExpansionPoint>,
}

impl PlayResponse {
    /// Output `k` moved by this response, given the output's first-order reading `linear` of
    /// play coordinates and extra wind-up (output units): `linear(e, δw)` about the nominal
    /// motion; where the response was expanded about a point ([`Self::point`]), the outputs
    /// there to all orders and `linear` about it, y(x₁) + S·(x − x₁).
    pub fn output(&self, k: usize, linear: impl Fn(&[f64; 4], &[f64]) -> f64) -> f64 {
        let about = self.point.as_ref().map_or(0.0, |x| {
            x.outputs.get(k).copied().unwrap_or(0.0) - linear(&x.offset, &x.windup)
        });
        linear(&self.offset, &self.windup) + about
    }
}

/// What a response keeps of the point its sample was expanded about ([`PlayPoint`]): to read
/// the outputs there to all orders and about it to first order, y ≈ y(x₁) + S·(x − x₁).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ExpansionPoint {
    /// The point's play coordinates ([`PlayPoint::offset`]).
    pub offset: [f64; 4],
    /// The point's extra wind-up per drive ([`PlayPoint::windup`]).
    pub windup: Vec<f64>,
    /// The outputs there less at the sample ([`PlayPoint::outputs`]).
    pub outputs: Vec<f64>,
}

impl ExpansionPoint {
    /// `self − other` entry by entry (a missing entry counts as zero): the point of a
    /// difference of two responses, for outputs read linearly about it.
    pub fn less(a: Option<&Self>, b: Option<&Self>) -> Option<Self> {
        if a.is_none() && b.is_none() {
            return None;
        }
        let zero = Self::default();
        let (a, b) = (a.unwrap_or(&zero), b.unwrap_or(&zero));
        let diff = |x: &[f64], y: &[f64]| -> Vec<f64> {
            (0..x.len().max(y.len()))
                .map(|k| x.get(k).unwrap_or(&0.0) - y.get(k).unwrap_or(&0.0))
                .collect()
        };
        Some(Self {
            offset: std::array::from_fn(|c| a.offset[c] - b.offset[c]),
            windup: diff(&a.windup, &b.windup),
            outputs: diff(&a.outputs, &b.outputs),
        })
    }
}

/// Play and cross coordinates per joint: e (shift x, y, z; tilt about n), then the cross's
/// translation c (x, y, z) and rotation ω (about x, y, z) from side i, base frame.
const NP: usize = 10;
/// Where the cross's coordinates start.
const CROSS: usize = 4;

/// The cross frame: u1 = z_i, u2 = z_j made normal to u1, u3 = u1 × u2 = n (unit, base frame).
fn cross_frame(p: &PlayDynamics) -> Option<[Vector3<f64>; 3]> {
    let u1 = p.z_i.try_normalize(1e-12)?;
    let u2 = (p.z_j - u1 * p.z_j.dot(&u1)).try_normalize(1e-12)?;
    Some([u1, u2, u1.cross(&u2)])
}

/// One contact of a trunnion ball: radial (two rows: the ball centre's displacement from its
/// bore's axis in the bore's plane) or axial (one row: its travel towards the bore's end).
#[derive(Debug, Clone, Copy)]
enum Contact {
    Radial([[f64; NP]; 2], Support),
    Axial([f64; NP], Support),
}

/// The coordinates a contact's rows act on (where one of them is not zero): its damping's
/// outer products touch only those (a side-i ball's rows leave out the play coordinates), the
/// zeros they skip adding nothing to the sums (so the numbers are the same to the bit).
#[derive(Debug, Clone, Copy)]
struct Support {
    index: [usize; NP],
    len: usize,
}

impl Support {
    fn of(rows: &[&[f64; NP]]) -> Self {
        let mut s = Support {
            index: [0; NP],
            len: 0,
        };
        for k in 0..NP {
            if rows.iter().any(|r| r[k] != 0.0) {
                s.index[s.len] = k;
                s.len += 1;
            }
        }
        s
    }

    fn indices(&self) -> &[usize] {
        &self.index[..self.len]
    }
}

impl Contact {
    fn radial(rows: [[f64; NP]; 2]) -> Self {
        Contact::Radial(rows, Support::of(&[&rows[0], &rows[1]]))
    }

    fn axial(row: [f64; NP]) -> Self {
        Contact::Axial(row, Support::of(&[&row]))
    }
}

/// The balls' contacts as linear maps of the coordinates (play, then cross). The cross frame
/// is u1 = z_i, u2 = z_j (made normal to u1), u3 = u1 × u2 = n. A side-i ball at ±(s/2)·u1
/// on the cross sits in a bore of side i: its displacement is c + ω × (±(s/2)·u1); a side-j
/// ball at ±(s/2)·u2 sits in a bore of side j, which moved by e and turned by φ about u3: its
/// displacement is (c − e) + (ω − φ·u3) × (±(s/2)·u2).
fn contacts(p: &PlayDynamics) -> Option<[Contact; 8]> {
    let [u1, u2, u3] = cross_frame(p)?;
    let q = p.play.ball_spacing / 2.0;
    // A row: a·e_shift + b·φ + c_row·c + w_row·ω.
    let row = |e: &Vector3<f64>, phi: f64, c: &Vector3<f64>, w: &Vector3<f64>| {
        let mut r = [0.0; NP];
        for k in 0..3 {
            r[k] = e[k];
            r[CROSS + k] = c[k];
            r[CROSS + 3 + k] = w[k];
        }
        r[3] = phi;
        r
    };
    let z = Vector3::zeros();
    let mut out = [Contact::axial([0.0; NP]); 8];
    for (b, sign) in [1.0, -1.0].into_iter().enumerate() {
        // Side i: (c·u2 ± q·ω·u3, c·u3 ∓ q·ω·u2); axial ±c·u1.
        out[b] = Contact::radial([
            row(&z, 0.0, &u2, &(u3 * (sign * q))),
            row(&z, 0.0, &u3, &(u2 * (-sign * q))),
        ]);
        out[4 + b] = Contact::axial(row(&z, 0.0, &(u1 * sign), &z));
        // Side j: ((c−e)·u1 ∓ q·(ω·u3 − φ), (c−e)·u3 ± q·ω·u1); axial ±(c−e)·u2.
        out[2 + b] = Contact::radial([
            row(&(-u1), sign * q, &u1, &(u3 * (-sign * q))),
            row(&(-u3), 0.0, &u3, &(u1 * (sign * q))),
        ]);
        out[6 + b] = Contact::axial(row(&(u2 * -sign), 0.0, &(u2 * sign), &z));
    }
    Some(out)
}

/// The sums rows[k]·x and rows[k]·ẋ for every row at once (each summed in the order of the
/// coordinates, as one dot product after the other would): independent sums side by side,
/// in the contact loads of the play model's substeps (most of its time).
fn dots<const R: usize>(rows: [&[f64; NP]; R], x: &[f64], xd: &[f64]) -> ([f64; R], [f64; R]) {
    let (x, xd) = (&x[..NP], &xd[..NP]);
    let (mut a, mut b) = ([0.0; R], [0.0; R]);
    for k in 0..NP {
        for r in 0..R {
            a[r] += rows[r][k] * x[k];
            b[r] += rows[r][k] * xd[k];
        }
    }
    (a, b)
}

/// The generalised load of one contact at (x, ẋ) (play and cross coordinates) for the
/// joint's `play` (radial clearance; axial stop at half the axial play), added to `out`;
/// returns the ball's normal force (N). With `damp`, adds the contact's damping matrix there,
/// −∂load/∂ẋ (N·s/m; zero where the ball is free or leaving faster than its spring pushes).
fn contact_load_one(
    k: &Contact,
    x: &[f64],
    xd: &[f64],
    play: &JointPlay,
    c: &BallContact,
    out: &mut [f64; NP],
    damp: Option<&mut Damping>,
) -> f64 {
    let h = play.radial;
    let outer = |m: &mut [[f64; NP]; NP], w: f64, u: &[f64; NP], support: &Support| {
        let on = support.indices();
        for &r in on {
            let wr = w * u[r];
            let row = &mut m[r];
            for &cc in on {
                row[cc] += wr * u[cc];
            }
        }
    };
    let add_outer = |damp: &mut Damping, w: f64, u: &[f64; NP], support: &Support| {
        damp.added = true;
        outer(&mut damp.matrix, w, u, support);
    };
    match k {
        Contact::Radial(jb, support) => {
            let (b, bd) = dots([&jb[0], &jb[1]], x, xd);
            // A ball well inside its bore is free, decided on the squared distance (the
            // margin far above its rounding, so the decision is `hypot`'s); `hypot` only
            // near and beyond the wall.
            if b[0] * b[0] + b[1] * b[1] < h * h * (1.0 - 1e-9) {
                return 0.0;
            }
            let r = b[0].hypot(b[1]);
            if r <= h {
                return 0.0;
            }
            // Normal: the penalty and its damping, never pulling; tangential (along the
            // bore's wall): the constant damping, while in contact. In the bore's plane
            // (the rates there, the force back through the two rows): the contact is
            // evaluated at every substep of the play model, most of its time.
            let (nb, tb) = ([b[0] / r, b[1] / r], [-b[1] / r, b[0] / r]);
            let (spring, cd) = c.spring_and_damping(true, r - h);
            let f = (-spring - cd * (nb[0] * bd[0] + nb[1] * bd[1])).min(0.0);
            let ft = -c.damping * (tb[0] * bd[0] + tb[1] * bd[1]);
            let g = [f * nb[0] + ft * tb[0], f * nb[1] + ft * tb[1]];
            for (kk, o) in out.iter_mut().enumerate() {
                *o += g[0] * jb[0][kk] + g[1] * jb[1][kk];
            }
            if let Some(damp) = damp {
                let un: [f64; NP] = std::array::from_fn(|kk| nb[0] * jb[0][kk] + nb[1] * jb[1][kk]);
                let ut: [f64; NP] = std::array::from_fn(|kk| tb[0] * jb[0][kk] + tb[1] * jb[1][kk]);
                let w = damp.stiffness_weight;
                if w > 0.0 && f < 0.0 {
                    // The contact's stiffness −∂load/∂x: along the normal the spring's rate
                    // (and the load damping's, γ·dF/dδ·δ̇, never below zero), across it the
                    // normal force over the ball's distance from the bore's axis (the wall's
                    // curvature turns the force as the ball slides along it).
                    let vn = nb[0] * bd[0] + nb[1] * bd[1];
                    let kn = (c.spring_rate(true, r - h) * (1.0 + c.load_damping * vn)).max(0.0);
                    let kt = -f / r;
                    add_outer(damp, cd + w * kn, &un, support);
                    add_outer(damp, c.damping + w * kt, &ut, support);
                    outer(&mut damp.stiffness, kn, &un, support);
                    outer(&mut damp.stiffness, kt, &ut, support);
                } else {
                    if f < 0.0 {
                        add_outer(damp, cd, &un, support);
                    }
                    add_outer(damp, c.damping, &ut, support);
                }
            }
            -f
        }
        Contact::Axial(row, support) => {
            let ([rx], [rxd]) = dots([row], x, xd);
            let d = rx - 0.5 * play.axial;
            if d <= 0.0 {
                return 0.0;
            }
            let (spring, cd) = c.spring_and_damping(false, d);
            let f = (-spring - cd * rxd).min(0.0);
            for (kk, o) in out.iter_mut().enumerate() {
                *o += f * row[kk];
            }
            if let (Some(damp), true) = (damp, f < 0.0) {
                let w = damp.stiffness_weight;
                if w > 0.0 {
                    let kn = (c.spring_rate(false, d) * (1.0 + c.load_damping * rxd)).max(0.0);
                    add_outer(damp, cd + w * kn, row, support);
                    outer(&mut damp.stiffness, kn, row, support);
                } else {
                    add_outer(damp, cd, row, support);
                }
            }
            -f
        }
    }
}

/// Λ_c and the cross's load: the generalised load of the balls' contacts at (x, ẋ).
fn contact_load(ks: &[Contact; 8], x: &[f64], xd: &[f64], play: &JointPlay, c: &BallContact) -> [f64; NP] {
    let mut out = [0.0; NP];
    for k in ks {
        contact_load_one(k, x, xd, play, c, &mut out, None);
    }
    out
}

/// The contacts' damping matrix −∂load/∂ẋ (N·s/m), and whether any contact added to it
/// (else it is zero, and need not be looked at).
struct Damping {
    matrix: [[f64; NP]; NP],
    added: bool,
    /// In the stiff substeps, the weight dt of the contacts' stiffness K_c added to the
    /// matrix (C_c + dt·K_c); 0: the damping alone.
    stiffness_weight: f64,
    /// In the stiff substeps, the contacts' stiffness K_c = −∂load/∂x (N/m), by rows.
    stiffness: [[f64; NP]; NP],
}

impl Damping {
    fn zero() -> Self {
        Self::weighted(0.0)
    }

    fn weighted(stiffness_weight: f64) -> Self {
        Damping {
            matrix: [[0.0; NP]; NP],
            added: false,
            stiffness_weight,
            stiffness: [[0.0; NP]; NP],
        }
    }
}

/// [`contact_load`] at the state (x, ẋ) (drives, then play and cross: its last [`NP`]
/// coordinates), and the contacts' damping there into `damp` (reused from substep to
/// substep: cleared only when a contact had added to it).
fn contact_load_and_damping(
    ks: &[Contact; 8],
    x: &[f64],
    xd: &[f64],
    play: &JointPlay,
    c: &BallContact,
    damp: &mut Damping,
) -> [f64; NP] {
    let (x, xd) = (&x[x.len() - NP..], &xd[xd.len() - NP..]);
    if damp.added {
        *damp = Damping::weighted(damp.stiffness_weight);
    }
    let mut out = [0.0; NP];
    for k in ks {
        contact_load_one(k, x, xd, play, c, &mut out, Some(damp));
    }
    out
}

/// y ← α·A·x + β·y for the column-major `a` (rows: y's length), with nalgebra's `gemv`'s
/// arithmetic — column by column, y_i = (α·a_ij)·x_j + β·y_i with β on the first column only
/// and y not read when β = 0 — so the results are the same to the bit, on slices the
/// compiler vectorises (the play model's substeps, most of a bearing diagnosis).
fn gemv(y: &mut [f64], alpha: f64, a: &[f64], x: &[f64], beta: f64) {
    gemv_block(y, alpha, a, y.len(), x, beta);
}

/// [`gemv`] with the block of a column-major matrix whose leading dimension is `lda`, from
/// `a`'s first entry: column j is `a[j·lda..j·lda + y.len()]`.
fn gemv_block(y: &mut [f64], alpha: f64, a: &[f64], lda: usize, x: &[f64], beta: f64) {
    let n = y.len();
    debug_assert!(x.is_empty() || a.len() >= (x.len() - 1) * lda + n);
    for (j, &xj) in x.iter().enumerate() {
        let col = &a[j * lda..j * lda + n];
        if j > 0 {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi += alpha * aij * xj);
        } else if beta == 0.0 {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi = alpha * aij * xj);
        } else {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi = alpha * aij * xj + beta * *yi);
        }
    }
}

/// The size m of the leading block of the square, column-major matrices `mats` outside of
/// which every entry is zero (the play model's stiffness and damping act on the drives and the
/// play coordinates, not on the cross's).
fn leading_block(n: usize, mats: &[&DMatrix<f64>]) -> usize {
    (0..=n)
        .find(|&m| {
            mats.iter()
                .all(|a| (0..n).all(|j| (0..n).all(|i| (i < m && j < m) || a[(i, j)] == 0.0)))
        })
        .unwrap_or(n)
}

/// The smallest m (0 < m < n) such that the square `a` is zero outside its leading m × m
/// block and the trailing block after it; 0 when there is none.
fn two_blocks(a: &DMatrix<f64>) -> usize {
    let n = a.nrows();
    (1..n)
        .find(|&m| (0..m).all(|i| (m..n).all(|j| a[(i, j)] == 0.0 && a[(j, i)] == 0.0)))
        .unwrap_or(0)
}

/// y ← α·A·x + β·y (as [`gemv`], to the bit for finite x) for a square `a` that is zero
/// outside its leading m × m block and the trailing block after it.
fn gemv_two_blocks(y: &mut [f64], alpha: f64, a: &[f64], m: usize, x: &[f64], beta: f64) {
    let n = y.len();
    if m == 0 || m == n {
        return gemv(y, alpha, a, x, beta);
    }
    let (y1, y2) = y.split_at_mut(m);
    gemv_block(y1, alpha, a, n, &x[..m], beta);
    gemv_block(y2, alpha, &a[m * n + m..], n, &x[m..], beta);
}

/// x ← x + dt·v (nalgebra's `axpy(dt, v, 1)`, the same arithmetic).
fn step_positions(x: &mut [f64], dt: f64, v: &[f64]) {
    for (xi, &vi) in x.iter_mut().zip(v) {
        *xi += dt * vi;
    }
}

/// The system at one sample: mass, stiffness (drives, play coordinates, then the cross), the
/// drives' dampings and the constant load g: M·ẍ + D·ẋ + K·x = g + [0; Λ_c(e, ė); cross load].
/// About the nominal motion g = [0; −Λ; 0]; about a point x₁ ([`PlaySample::about`])
/// g = f(x₁) + K₁·x₁, with f(x₁) = [Δτ(x₁); −Λ(x₁); 0] what the mechanism exerts there and K₁
/// its stiffness there (the transmissions' own aside): f(x) ≈ f(x₁) − K₁·(x − x₁).
struct System {
    mass: DMatrix<f64>,
    stiffness: DMatrix<f64>,
    /// The transmissions' damping and the mechanism's velocity products linearised in the
    /// rates (where the coupling knows them).
    damping: DMatrix<f64>,
    load: DVector<f64>,
    /// The leading block of the stiffness and the damping outside of which both are zero
    /// ([`leading_block`]): the products with them skip the rest.
    active: usize,
}

/// The play's coupling the sample expands about: the point's where given, else the sample's.
fn coupling<'a>(s: &PlaySample<'a>) -> &'a PlayDynamics {
    s.about.map_or(s.play, |a| &a.dynamics)
}

/// The system's matrices at one sample ([`System`]).
fn matrices(s: &PlaySample) -> Option<System> {
    let (p, td) = (coupling(s), s.transmission);
    let nj = td.compliance.len();
    let n = nj + NP;
    let (drive_mass, load_stiffness) = match s.about {
        Some(a) => (&a.mass, Some(&a.load_stiffness)),
        None => (&td.mass, td.load_stiffness.as_ref()),
    };
    if drive_mass.shape() != (nj, nj)
        || p.reaction_by_drive.len() != nj
        || p.reaction_by_drive_acceleration.len() != nj
        || p.torque_by_offset
            .iter()
            .chain(&p.torque_by_offset_acceleration)
            .any(|v| v.len() != nj)
    {
        return None;
    }
    let kr = td.response_stiffness_with(load_stiffness);
    let mut mm = DMatrix::zeros(n, n);
    let mut kk = DMatrix::zeros(n, n);
    for a in 0..nj {
        for b in 0..nj {
            mm[(a, b)] = drive_mass[(a, b)];
            kk[(a, b)] = kr[(a, b)];
        }
        for c in 0..4 {
            mm[(a, nj + c)] = -p.torque_by_offset_acceleration[c][a];
            kk[(a, nj + c)] = -p.torque_by_offset[c][a];
            mm[(nj + c, a)] = -p.reaction_by_drive_acceleration[a][c];
            kk[(nj + c, a)] = -p.reaction_by_drive[a][c];
        }
    }
    for r in 0..4 {
        for c in 0..4 {
            mm[(nj + r, nj + c)] = p.reaction_by_offset_acceleration[c][r];
            kk[(nj + r, nj + c)] = p.reaction_by_offset[c][r];
        }
    }
    // The cross: its mass, and two perpendicular rods' inertia (s/2 either side) about u1,
    // u2, twice that about u3.
    let frame = nalgebra::Matrix3::from_columns(&cross_frame(p)?);
    let principal = crate::contact::joints::cross_inertia(p.cross_mass, p.play.ball_spacing);
    let inertia = frame * nalgebra::Matrix3::from_diagonal(&principal) * frame.transpose();
    let cross_mass = p.cross_mass;
    for r in 0..3 {
        mm[(nj + CROSS + r, nj + CROSS + r)] = cross_mass;
        for c in 0..3 {
            mm[(nj + CROSS + 3 + r, nj + CROSS + 3 + c)] = inertia[(r, c)];
        }
    }
    let mut damping = DMatrix::zeros(n, n);
    for a in 0..nj {
        damping[(a, a)] = td.damping[a];
    }
    // The velocity products, laid out as the stiffness: ∂τ_s/∂q̇ as S, the offsets' rates as
    // their positions.
    if p.torque_by_drive_rate.len() == nj && p.torque_by_drive_rate.iter().all(|v| v.len() == nj) {
        for k in 0..nj {
            for j in 0..nj {
                damping[(j, k)] += p.torque_by_drive_rate[k][j];
            }
        }
    }
    if p.torque_by_offset_rate.len() == 4
        && p.torque_by_offset_rate.iter().all(|v| v.len() == nj)
        && p.reaction_by_offset_rate.len() == 4
        && p.reaction_by_drive_rate.len() == nj
    {
        for a in 0..nj {
            for c in 0..4 {
                damping[(a, nj + c)] = -p.torque_by_offset_rate[c][a];
                damping[(nj + c, a)] = -p.reaction_by_drive_rate[a][c];
            }
        }
        for r in 0..4 {
            for c in 0..4 {
                damping[(nj + r, nj + c)] = p.reaction_by_offset_rate[c][r];
            }
        }
    }
    // The constant load: −Λ on the joint's rows; about a point x₁ also the torques' change
    // there, and K₁·x₁.
    let mut load = DVector::zeros(n);
    for r in 0..4 {
        load[nj + r] = -p.reaction[r];
    }
    // The cross's weight and what carries it along with side i, on its balls.
    for r in 0..3 {
        load[nj + CROSS + r] = p.cross_load[r];
    }
    if let Some(a) = s.about {
        if a.windup.len() != nj || a.torque.len() != nj {
            return None;
        }
        let mut x1 = DVector::zeros(n);
        for k in 0..nj {
            x1[k] = a.windup[k];
        }
        for c in 0..4 {
            x1[nj + c] = a.offset[c];
        }
        let mut k_mech = kk.clone();
        for (k, stiffness) in td.stiffness().iter().enumerate() {
            k_mech[(k, k)] -= stiffness;
        }
        load += &k_mech * &x1;
        for k in 0..nj {
            load[k] += a.torque[k];
        }
    }
    mm.iter()
        .chain(kk.iter())
        .chain(damping.iter())
        .chain(load.iter())
        .all(|v| v.is_finite())
        .then_some(System {
            active: leading_block(n, &[&kk, &damping]),
            mass: mm,
            stiffness: kk,
            damping,
            load,
        })
}

/// Σ JᵀJ over the contacts' rows, on the play and cross coordinates.
fn contact_gram(ks: &[Contact; 8], n: usize) -> DMatrix<f64> {
    let nj = n - NP;
    let mut jtj = DMatrix::zeros(n, n);
    let mut add = |row: &[f64; NP]| {
        for r in 0..NP {
            for c in 0..NP {
                jtj[(nj + r, nj + c)] += row[r] * row[c];
            }
        }
    };
    for k in ks {
        match k {
            Contact::Radial(jb, _) => jb.iter().for_each(&mut add),
            Contact::Axial(row, _) => add(row),
        }
    }
    jtj
}

/// How the linearised mechanics varies within a sample interval of the reduced play model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Interpolation {
    /// The matrices and the load held at the interval's end (the model until 2026-11-30, and
    /// the diagnosis' default): the load leads within the interval, so a load that reverses
    /// there moves the joint across its play up to a sample early.
    #[default]
    Held,
    /// The forces g − K·x − C·v blended linearly in time from the previous sample's to this
    /// one's (the mass and the contacts' law as at the interval's end): a load that changes
    /// smoothly within the interval moves the joint as the finely sampled load does.
    Linear,
}

/// How the reduced play model steps through each sample interval ([`respond_stepped`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Stepping {
    /// Substeps short enough to resolve the fastest mode with every ball in contact
    /// ([`SUBSTEPS_PER_PERIOD`] per period; semi-implicit Euler, the dampings taken implicitly
    /// where they are stiff): the model until 2026-12-07.
    Resolved,
    /// Stiff substeps (the Rosenbrock method ROS2, second order and L-stable, its matrix
    /// from the contacts' stiffness and damping), at least `per_sample` per sample interval,
    /// taken again in halves down to the resolved substeps' length where a ball starts or
    /// stops touching or a contact's load is far from linear over a substep.
    Stiff {
        /// Substeps per sample interval where nothing asks for shorter ones.
        per_sample: usize,
    },
}

/// The stiff substeps per sample interval that `lash diagnose --play-stiff-substeps` takes
/// when it is given no count ([`Stepping::Stiff`]). Measured with the
/// example `play_dynamics` (joint F, 6 µm, recording 5, Hertz balls, 20 N·s/m + 500 s/m × F,
/// forces blended, re-linearised once; what the model leaves of the truth's play effect on
/// drives A/B/C, RMS 0.6–5 s in torque-noise units, and the time in the model's three runs):
/// resolved 0.36 / 0.30 / 0.59 in 4.82 s; 40 stiff substeps 0.38 / 0.32 / 0.59 in 1.14 s
/// (the window 3.1–5 s 0.19 / 0.24 / 0.31 against 0.15 / 0.20 / 0.27, the rattle 2.77–3.10 s
/// 1.19 / 0.87 / 1.86 against 1.15 / 0.85 / 1.91); 80 stiff substeps 0.36 / 0.30 / 0.58
/// in 2.24 s; 20: 0.45 / 0.39 / 0.68.
pub const STIFF_SUBSTEPS: usize = 40;

impl Default for Stepping {
    /// [`Stepping::Resolved`]: the stiff substeps are an option (at seed 2026 the suite's
    /// clearance-F case held out at 1.302× the noise with them, 1.169× resolved: the play's
    /// lightly damped ringing in the rattle, which they do not resolve, damped numerically).
    fn default() -> Self {
        Stepping::Resolved
    }
}

impl std::fmt::Display for Stepping {
    /// "resolved substeps" or "40 stiff substeps per sample interval".
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stepping::Resolved => write!(f, "resolved substeps"),
            Stepping::Stiff { per_sample } => write!(f, "{per_sample} stiff substeps per sample interval"),
        }
    }
}

/// How one sample interval is integrated ([`substeps`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Substeps {
    /// Number of substeps.
    n: usize,
    /// The dampings implicit (else explicit, resolved by the substep).
    implicit: bool,
}

/// How far the contacts' load at a stiff substep's second stage may be from its linear
/// prediction (from the first stage's load, stiffness and damping), as a fraction of the
/// larger of the two stages' loads, before the substep is taken again in halves
/// ([`advance_stiff`]). Without it a ball that barely touched at a substep's start (Hertz's
/// stiffness is nearly zero there) and is pressed hard by its end takes its force explicitly
/// — the substeps blew up on the example `play_model_run` at 10 and 20 per sample interval;
/// at 0.1 none did, at 1.0 some still did (2026-12-07, session 77).
const NONLINEAR_TOLERANCE: f64 = 0.1;

/// Cost of an implicit substep (a small LU) in explicit ones, for [`substeps`]' choice (set
/// when the implicit substep factorised all the unknowns; not re-measured since it factorises
/// only the play block's Schur complement, which is cheaper).
const IMPLICIT_COST: usize = 4;

/// Substeps per period of the reduced model's fastest mode (every ball in contact).
///
/// Semi-implicit Euler is stable for dt·ω < 2; five per period is dt·ω = 1.26, a margin of
/// 1.6 (ten per period had 3.2) over the fastest mode estimated with Hertz's stiffness at four
/// times the joint's load: a load peak above that estimate reaches the limit sooner. Measured with
/// the example `play_dynamics` (session 52, suite truth, recording 5 unless named; what the
/// model leaves of the play's effect per drive and window, torque-noise units, and the
/// tracker's): joint F with 6 µm, Hertz balls, 20 N·s/m + 500 s/m × F, blended forces,
/// re-linearised once — 5 (fifth), 10 and 20 substeps per period give the same numbers to
/// 0.01 (drive A 2.77–3.10 s: 3.62 / 3.63 / 3.63), 3.3 per period too; joint D with 10 µm of
/// axial play and joint F on recording 3 (held forces, 200 N·s/m + 1 000 s/m × F): 5 and 10
/// agree to 0.01 on every channel and window. The reduced model's time halves from 10 to 5
/// (14.5 → 8.4 s for joint F's two runs; 3.1 → 1.6 s for the example `play_model_run`).
pub const SUBSTEPS_PER_PERIOD: f64 = 5.0;

/// Substeps for one sample interval of `h` s: [`SUBSTEPS_PER_PERIOD`] per period of the fastest mode
/// with every ball in contact (the largest eigenvalue of M⁻¹·(K + K_c), K_c = k·Σ JᵀJ, k the
/// contact's stiffness — Hertz's under four times the joint's `load`, at least 400 N), and
/// where the velocity products feed a mode (−C not negative semidefinite) dt·λ_max(M⁻¹·(−C))
/// ≤ 0.5. Explicit dampings must be resolved too, dt·λ_max(M⁻¹·(C + C_c)) ≤ 0.5 (C_c = c·Σ JᵀJ,
/// c the contact's damping under four times the load); where that asks for more than
/// [`IMPLICIT_COST`] times the substeps, they are taken implicitly instead ([`respond`]).
/// At least 1, at most 100 000. None if the mass matrix is not positive definite.
fn substeps(sys: &System, ks: &[Contact; 8], contact: &BallContact, load: f64, h: f64) -> Option<Substeps> {
    let jtj = contact_gram(ks, sys.mass.nrows());
    let largest = largest_by_mass(&sys.mass)?;
    let k_contact = contact.tangent_stiffness(4.0 * load.max(100.0));
    let c_contact = contact.damping + contact.load_damping * 4.0 * load.max(100.0);
    let omega = largest(sym(&sys.stiffness) + &jtj * k_contact).sqrt();
    let c = sym(&sys.damping);
    let growing = largest(-c.clone());
    let damped = largest(&jtj * c_contact + c);
    let dt =
        (2.0 * std::f64::consts::PI / SUBSTEPS_PER_PERIOD / omega.max(1e-300)).min(0.5 / growing.max(1e-300));
    let count = |dt: f64| ((h / dt).ceil() as usize).clamp(1, 100_000);
    let (implicit, explicit) = (count(dt), count(dt.min(0.5 / damped.max(1e-300))));
    Some(if explicit > IMPLICIT_COST * implicit {
        Substeps {
            n: implicit,
            implicit: true,
        }
    } else {
        Substeps {
            n: explicit,
            implicit: false,
        }
    })
}

/// The symmetric part of `m`.
fn sym(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}

/// The largest eigenvalue of M⁻¹·A for a symmetric A (of the symmetric part of the mass
/// `mass`, through its Cholesky factor L: of L⁻¹·A·L⁻ᵀ), as a function of A; None if the
/// mass is not positive definite.
fn largest_by_mass(mass: &DMatrix<f64>) -> Option<impl Fn(DMatrix<f64>) -> f64> {
    let linv = sym(mass).cholesky()?.l().try_inverse()?;
    Some(move |m: DMatrix<f64>| {
        let a = sym(&(&linv * m * linv.transpose()));
        a.symmetric_eigenvalues().iter().fold(0.0f64, |x, &v| x.max(v))
    })
}

/// Stiff substeps (ROS2, [`advance_stiff`]) for one sample interval of `h` s: at least
/// `per_sample`, and [`SUBSTEPS_PER_PERIOD`] per period of the fastest mode without the
/// contacts (the largest eigenvalue of M⁻¹·K). None if the mass matrix is not positive definite.
fn stiff_substeps(sys: &System, per_sample: usize, h: f64) -> Option<usize> {
    let largest = largest_by_mass(&sys.mass)?;
    let omega = largest(sym(&sys.stiffness)).sqrt();
    let growing = largest(-sym(&sys.damping));
    let dt = (2.0 * std::f64::consts::PI / SUBSTEPS_PER_PERIOD / omega.max(1e-300))
        .min(0.5 / growing.max(1e-300))
        .min(h / per_sample.max(1) as f64);
    Some(((h / dt).ceil() as usize).clamp(1, 100_000))
}

/// Which of the contacts touch at the play coordinates `x` (bit k: contact k penetrates its
/// wall or end face).
fn touching(ks: &[Contact; 8], x: &[f64], play: &JointPlay) -> u8 {
    let zero = [0.0; NP];
    let mut mask = 0u8;
    for (k, c) in ks.iter().enumerate() {
        let on = match c {
            Contact::Radial(jb, _) => {
                let (b, _) = dots([&jb[0], &jb[1]], x, &zero);
                b[0] * b[0] + b[1] * b[1] > play.radial * play.radial
            }
            Contact::Axial(row, _) => {
                let ([rx], _) = dots([row], x, &zero);
                rx > 0.5 * play.axial
            }
        };
        if on {
            mask |= 1 << k;
        }
    }
    mask
}

/// The static state at sample `s`: K·x = g + [0; Λ_c(x, 0); cross load] ([`System`]) by
/// Newton's method (minimum-norm steps) from the joint against the walls and ends its
/// reaction pushes it to (the cross half-way across n, turned by half the tilt), the
/// transmissions wound up by the torques that asks for.
fn static_start(
    s: &PlaySample,
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
) -> Option<DVector<f64>> {
    let (p, kk) = (coupling(s), &sys.stiffness);
    let nj = s.transmission.compliance.len();
    let [u1, u2, n] = cross_frame(p)?;
    // The reaction the joint carries, where its load pushes it (about a point, the point's
    // own: −g there is the expansion's reaction at the sample, which near a singular position
    // can point elsewhere).
    let reaction = p.reaction;
    let force = Vector3::new(reaction[0], reaction[1], reaction[2]);
    // Side i's pair carries the cross besides (as the system solved below does).
    let shift = p.play.shift_with_cross_weight(
        &p.z_i,
        &p.z_j,
        &force,
        &(n * reaction[3]),
        &Vector3::from(p.cross_load),
        1e-6,
    );
    // A tenth beyond the walls and ends, so that the loaded balls start in contact
    // (Newton's method sees no stiffness inside the play).
    // (Without radial clearance, a tenth of the axial play's half, or of a nanometre.)
    let beyond = 1.1 * play.radial + 0.1 * play.scale();
    let radial = shift.radial_translation * beyond;
    let phi = shift.radial_tilt * beyond;
    // The axial shift per pair: the cross along u1 from side i, side j along u2 from the cross.
    let axial = shift.axial_translation * (1.1 * play.axial + 0.2 * play.scale());
    let (axial_i, axial_j) = (axial.dot(&u1), axial.dot(&u2));
    let e = radial + u1 * axial_i + u2 * axial_j;
    // Radially the cross moves with side j across u1 (it rides side j's trunnions axially),
    // with side i along u1, and half-way along n.
    let c = radial - u1 * radial.dot(&u1) - n * (0.5 * radial.dot(&n)) + u1 * axial_i;
    let mut x = DVector::zeros(nj + NP);
    for k in 0..3 {
        x[nj + k] = e[k];
        x[nj + CROSS + k] = c[k];
        x[nj + CROSS + 3 + k] = 0.5 * phi * n[k];
    }
    x[nj + 3] = phi;
    let zero = [0.0; NP];
    let residual = |x: &DVector<f64>| {
        let lc = contact_load(ks, &x.as_slice()[nj..], &zero, play, contact);
        let mut r = kk * x - &sys.load;
        for k in 0..NP {
            r[nj + k] -= lc[k];
        }
        r
    };
    // The load (N, or N·m), and how far it presses the balls.
    let load = reaction.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    for _ in 0..100 {
        let r = residual(&x);
        let mut jac = kk.clone();
        for c in 0..NP {
            let rotation = c == 3 || c >= CROSS + 3;
            let step = 1e-9 * play.scale() / if rotation { p.play.ball_spacing } else { 1.0 };
            let mut xp = x.clone();
            xp[nj + c] += step;
            let dr = (residual(&xp) - &r) / step;
            jac.set_column(nj + c, &dr);
        }
        // Least squares: a joint pressed in one direction floats in the others (a tangential
        // shift of a ball on its wall is free to first order), so the Jacobian may be
        // singular there; the minimum-norm step leaves those coordinates where they are.
        let tol = 1e-12 * jac.amax();
        let mut dx = jac.svd(true, true).solve(&r, tol).ok()?;
        // No step moves a ball by more than the clearance (or, without play, than the load
        // presses it): where the balls lose contact the Jacobian loses their stiffness, and a
        // full step would fly off.
        let reach = (0..NP)
            .map(|c| {
                let rotation = c == 3 || c >= CROSS + 3;
                dx[nj + c].abs() * if rotation { p.play.ball_spacing / 2.0 } else { 1.0 }
            })
            .fold(0.0, f64::max);
        let limit = play.scale().max(contact.compression(load));
        if reach > limit {
            dx *= limit / reach;
        }
        x -= &dx;
        if reach < 1e-9 * limit {
            break;
        }
    }
    // Converged: the joint's and the cross's loads balance to a millionth of the load.
    let r = residual(&x);
    (x.iter().all(|v| v.is_finite()) && r.rows(nj, NP).amax() <= 1e-6 * load).then_some(x)
}

/// The forces of substep `j` of `n` into `rhs`, in place: g − K·x − C·v of `sys`, blended
/// at the substep's midpoint with `prev`'s where given ([`Interpolation::Linear`]), plus the
/// contacts' loads `lc` on the play coordinates (the last [`NP`] rows).
fn forces_into(
    rhs: &mut DVector<f64>,
    sys: &System,
    prev: Option<&System>,
    at: f64,
    x: &DVector<f64>,
    v: &DVector<f64>,
    lc: &[f64; NP],
) {
    let (r, x, v) = (rhs.as_mut_slice(), x.as_slice(), v.as_slice());
    let size = r.len();
    r.copy_from_slice(sys.load.as_slice());
    // Only the leading blocks where the stiffness and damping are not zero (β = 1: the
    // rest would add zeros).
    let m = sys.active;
    gemv_block(&mut r[..m], -1.0, sys.stiffness.as_slice(), size, &x[..m], 1.0);
    gemv_block(&mut r[..m], -1.0, sys.damping.as_slice(), size, &v[..m], 1.0);
    if let Some(p) = prev {
        let w = 1.0 - at;
        let keep = 1.0 - w;
        for (ri, &pl) in r.iter_mut().zip(p.load.as_slice()) {
            *ri = w * pl + keep * *ri;
        }
        let m = p.active;
        gemv_block(&mut r[..m], -w, p.stiffness.as_slice(), size, &x[..m], 1.0);
        gemv_block(&mut r[..m], -w, p.damping.as_slice(), size, &v[..m], 1.0);
    }
    let nj = r.len() - NP;
    for (ri, &l) in r[nj..].iter_mut().zip(lc) {
        *ri += l;
    }
}

/// Advances (x, v) over one sample interval of `h` s in `steps` substeps of semi-implicit
/// Euler, the mass held: the dampings explicit, v += M⁻¹·f(x, v)·dt, or implicit
/// (linearised in the rates), (M + dt·(C + C_c))·Δv = dt·f(x, v); then x += v·dt with the
/// new v. With `prev` (the previous sample's system, [`Interpolation::Linear`]) the linear
/// forces at each substep's midpoint are blended from its and this sample's; the contacts'
/// loads and the dampings' implicit part stay this sample's. None if a matrix is singular.
#[allow(clippy::too_many_arguments)]
fn advance(
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
    steps: Substeps,
    h: f64,
    x: &mut DVector<f64>,
    v: &mut DVector<f64>,
    prev: Option<&System>,
) -> Option<()> {
    let nj = sys.mass.nrows() - NP;
    let dt = h / steps.n as f64;
    let prev = prev.filter(|p| p.mass.shape() == sys.mass.shape());
    if !steps.implicit {
        let minv = sys.mass.clone().try_inverse()?;
        // The mass couples the drives and the play, and the cross's coordinates among
        // themselves: M⁻¹ in two diagonal blocks (exact zeros between them).
        let mblock = two_blocks(&minv);
        // In place (~2 000 substeps per 2 ms sample interval on the unit tests' joint): rhs = g − K·x − C·v + loads.
        let mut rhs = DVector::zeros(x.len());
        for j in 0..steps.n {
            let lc = contact_load(ks, &x.as_slice()[nj..], &v.as_slice()[nj..], play, contact);
            forces_into(&mut rhs, sys, prev, (j as f64 + 0.5) / steps.n as f64, x, v, &lc);
            gemv_two_blocks(v.as_mut_slice(), dt, minv.as_slice(), mblock, rhs.as_slice(), 1.0);
            step_positions(x.as_mut_slice(), dt, v.as_slice());
        }
        return Some(());
    }
    let base = &sys.mass + &sys.damping * dt;
    let base_inv = base.clone().try_inverse()?;
    let bblock = two_blocks(&base_inv);
    // Built at the first substep in contact (an interval without contact never needs it).
    let mut schur: Option<PlaySchur> = None;
    // The contacts' damping, reused across the substeps.
    let mut damp = Damping::zero();
    // In place, as above: dt·(g − K·x − C·v + loads), then Δv.
    let (mut rhs, mut dv) = (DVector::zeros(x.len()), DVector::zeros(x.len()));
    for j in 0..steps.n {
        let lc = contact_load_and_damping(ks, x.as_slice(), v.as_slice(), play, contact, &mut damp);
        let cc = &damp.matrix;
        forces_into(&mut rhs, sys, prev, (j as f64 + 0.5) / steps.n as f64, x, v, &lc);
        rhs.as_mut_slice().iter_mut().for_each(|r| *r *= dt);
        if !damp.added || cc.iter().flatten().all(|&c| c == 0.0) {
            gemv_two_blocks(
                dv.as_mut_slice(),
                1.0,
                base_inv.as_slice(),
                bblock,
                rhs.as_slice(),
                0.0,
            );
        } else {
            PlaySchur::of(&mut schur, &base, nj)?.solve(cc, dt, &rhs, &mut dv)?;
        }
        for (vi, &d) in v.as_mut_slice().iter_mut().zip(dv.as_slice()) {
            *vi += d;
        }
        step_positions(x.as_mut_slice(), dt, v.as_slice());
    }
    Some(())
}

/// Advances (x, v) over one sample interval of `h` s in stiff substeps: the two-stage
/// Rosenbrock method ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999, SIAM J. Sci. Comput.
/// 20(4):1456–1480; γ = 1 + 1/√2: second order, L-stable) on y = (x, v), ẏ = (v, M⁻¹·f(x, v)),
/// its matrix I − γ·dt·J from the contacts' stiffness and damping at each substep's start:
/// (I − γ·dt·J)·k₁ = F(y), (I − γ·dt·J)·k₂ = F(y + dt·k₁) − 2·k₁, y += dt·(3/2·k₁ + 1/2·k₂).
/// Each solve is (M + g·(C + C_c) + g²·(K + K_c))·k_v = f − g·(K + K_c)·u, k_x = u + g·k_v
/// with g = γ·dt and F = (u, M⁻¹·f), so a contact's own modes need not be resolved while the
/// balls that touch stay the same. A substep across which a ball starts or stops touching
/// (at its second stage or its end) is taken again in halves, down to `finest` substeps per
/// interval (the resolved substeps' length, [`substeps`]), where it is kept; after a kept
/// substep the length doubles again where the grid allows, up to `n` per interval. The linear
/// forces at each stage's time, blended with `prev`'s as [`forces_into`] does.
#[allow(clippy::too_many_arguments)]
fn advance_stiff(
    sys: &System,
    ks: &[Contact; 8],
    play: &JointPlay,
    contact: &BallContact,
    n: usize,
    finest: &dyn Fn() -> Option<usize>,
    h: f64,
    x: &mut DVector<f64>,
    v: &mut DVector<f64>,
    prev: Option<&System>,
) -> Option<()> {
    let size = x.len();
    let nj = size - NP;
    let prev = prev.filter(|p| p.mass.shape() == sys.mass.shape());
    let m = sys.active;
    // Per level k (substeps of h / (n·2^k)): the matrix B = M + g·C + g²·K, its inverse, its
    // blocks and its Schur complement on the play, made on first use.
    struct Level {
        g: f64,
        base: DMatrix<f64>,
        base_inv: DMatrix<f64>,
        bblock: usize,
        schur: Option<PlaySchur>,
    }
    let level = |k: usize| -> Option<Level> {
        let dt = h / (n as f64 * (1u64 << k) as f64);
        let g = (1.0 + std::f64::consts::FRAC_1_SQRT_2) * dt;
        let base = &sys.mass + &sys.damping * g + &sys.stiffness * (g * g);
        let base_inv = base.clone().try_inverse()?;
        Some(Level {
            g,
            bblock: two_blocks(&base_inv),
            base,
            base_inv,
            schur: None,
        })
    };
    let mut levels: Vec<Option<Level>> = Vec::new();
    // The deepest level, found at the first substep taken again.
    let mut deepest: Option<usize> = None;
    let mut damp = Damping::weighted(0.0);
    let (mut f, mut rhs) = (DVector::zeros(size), DVector::zeros(size));
    let (mut k1x, mut k1v) = (DVector::zeros(size), DVector::zeros(size));
    let (mut k2v, mut u) = (DVector::zeros(size), DVector::zeros(size));
    let (mut x2, mut v2) = (DVector::zeros(size), DVector::zeros(size));
    let (mut x0, mut v0) = (x.clone(), v.clone());
    // Solves a stage, rhs = f − g·(K + K_c)·u, into kv.
    let solve = |lv: &mut Level,
                 f: &DVector<f64>,
                 u: &DVector<f64>,
                 damp: &Damping,
                 contact_on: bool,
                 rhs: &mut DVector<f64>,
                 kv: &mut DVector<f64>|
     -> Option<()> {
        let g = lv.g;
        rhs.copy_from(f);
        let r = rhs.as_mut_slice();
        gemv_block(
            &mut r[..m],
            -g,
            sys.stiffness.as_slice(),
            size,
            &u.as_slice()[..m],
            1.0,
        );
        if contact_on {
            let uu = &u.as_slice()[nj..];
            for (row, ri) in damp.stiffness.iter().zip(r[nj..].iter_mut()) {
                *ri -= g * row.iter().zip(uu).map(|(a, b)| a * b).sum::<f64>();
            }
            lv.schur.as_mut()?.solve_factored(rhs, kv)
        } else {
            gemv_two_blocks(kv.as_mut_slice(), 1.0, lv.base_inv.as_slice(), lv.bblock, r, 0.0);
            Some(())
        }
    };
    // Position and length in units of the deepest level's substep (as deep as 2^MAX_DEPTH).
    const MAX_DEPTH: usize = 12;
    let unit = |k: usize| 1u64 << (MAX_DEPTH - k);
    let end = n as u64 * unit(0);
    let (mut pos, mut k) = (0u64, 0usize);
    // The balls touching at the substep's start (the last kept substep's end).
    let mut start = touching(ks, &x.as_slice()[nj..], play);
    while pos < end {
        while levels.len() <= k {
            levels.push(None);
        }
        if levels[k].is_none() {
            levels[k] = Some(level(k)?);
        }
        let lv = levels[k].as_mut()?;
        let span = unit(k);
        let dt = h * span as f64 / end as f64;
        let (t1, t2) = (pos as f64 / end as f64, (pos + span) as f64 / end as f64);
        x0.copy_from(x);
        v0.copy_from(v);
        // Stage 1 at (x, v), the matrix from there.
        damp.stiffness_weight = lv.g;
        let lc = contact_load_and_damping(ks, x.as_slice(), v.as_slice(), play, contact, &mut damp);
        let contact_on = damp.added && damp.matrix.iter().flatten().any(|&c| c != 0.0);
        if contact_on {
            // (S as the implicit substeps', with C_c + g·K_c and the weight g.)
            PlaySchur::of(&mut lv.schur, &lv.base, nj)?.factor(&damp.matrix, lv.g);
        }
        forces_into(&mut f, sys, prev, t1, x, v, &lc);
        solve(lv, &f, v, &damp, contact_on, &mut rhs, &mut k1v)?;
        k1x.copy_from(v);
        k1x.axpy(lv.g, &k1v, 1.0);
        // Stage 2 at y + dt·k₁: F there less 2·k₁.
        x2.copy_from(x);
        x2.axpy(dt, &k1x, 1.0);
        v2.copy_from(v);
        v2.axpy(dt, &k1v, 1.0);
        let lc2 = contact_load(ks, &x2.as_slice()[nj..], &v2.as_slice()[nj..], play, contact);
        // The contacts' load at the second stage against its linear prediction from the
        // first, lc₁ − K_c·Δx − C_c·Δv (C_c = the matrix less g·K_c): a contact far from
        // linear over the substep (a ball that barely touched, pressed hard) is resolved.
        let nonlinear = contact_on && {
            let (dx, dvv) = (&k1x.as_slice()[nj..], &k1v.as_slice()[nj..]);
            let mut miss = 0.0f64;
            let mut size = 0.0f64;
            for r in 0..NP {
                let mut pred = lc[r];
                for c in 0..NP {
                    let kc = damp.stiffness[r][c];
                    let cc = damp.matrix[r][c] - lv.g * kc;
                    pred -= dt * (kc * dx[c] + cc * dvv[c]);
                }
                miss = miss.max((lc2[r] - pred).abs());
                size = size.max(lc[r].abs()).max(lc2[r].abs());
            }
            miss > NONLINEAR_TOLERANCE * size
        };
        forces_into(&mut f, sys, prev, t2, &x2, &v2, &lc2);
        f.gemv(-2.0, &sys.mass, &k1v, 1.0);
        u.copy_from(&v2);
        u.axpy(-2.0, &k1x, 1.0);
        solve(lv, &f, &u, &damp, contact_on, &mut rhs, &mut k2v)?;
        // y += dt·(3/2·k₁ + 1/2·k₂), k₂ₓ = u + g·k₂ᵥ.
        x.axpy(1.5 * dt, &k1x, 1.0);
        x.axpy(0.5 * dt, &u, 1.0);
        x.axpy(0.5 * dt * lv.g, &k2v, 1.0);
        v.axpy(1.5 * dt, &k1v, 1.0);
        v.axpy(0.5 * dt, &k2v, 1.0);
        let at_end = touching(ks, &x.as_slice()[nj..], play);
        let changed = nonlinear || touching(ks, &x2.as_slice()[nj..], play) != start || at_end != start;
        if changed {
            let deepest = match deepest {
                Some(d) => d,
                None => {
                    let finest = finest()?.max(n);
                    let d = ((finest as f64 / n as f64).log2().ceil().max(0.0) as usize).min(MAX_DEPTH);
                    *deepest.insert(d)
                }
            };
            if k < deepest {
                // Again, in halves.
                x.copy_from(&x0);
                v.copy_from(&v0);
                k += 1;
                continue;
            }
        }
        start = at_end;
        pos += span;
        // Longer again where the grid allows.
        while k > 0 && pos % unit(k - 1) == 0 && !changed {
            k -= 1;
        }
    }
    Some(())
}

/// The implicit substep's matrix A = B + dt·C_c, B = M + dt·C held over a sample interval and
/// the contacts' damping C_c on the play and cross coordinates only (the last [`NP`]): the
/// drives' block B₁₁ is eliminated once per interval, and each substep in contact factorises
/// only the play block's Schur complement S = B₂₂ − B₂₁·B₁₁⁻¹·B₁₂ + dt·C_c, a fixed-size
/// [`NP`] × [`NP`] LU on the stack instead of a dense LU of all the unknowns. With
/// z = B₁₁⁻¹·r₁: S·y = r₂ − B₂₁·z, then x₁ = z − B₁₁⁻¹·B₁₂·y.
struct PlaySchur {
    /// B₁₁⁻¹ (drives × drives).
    b11_inv: DMatrix<f64>,
    /// B₂₁ (play × drives).
    b21: DMatrix<f64>,
    /// B₁₁⁻¹·B₁₂ (drives × play).
    q: DMatrix<f64>,
    /// B₂₂ − B₂₁·B₁₁⁻¹·B₁₂.
    s0: SMatrix<f64, NP, NP>,
    /// z = B₁₁⁻¹·r₁ (drives).
    z: DVector<f64>,
    /// The factors of S + w·C_c of the last [`factor`](Self::factor), and its swaps.
    lu: [[f64; NP]; NP],
    swaps: Swaps,
}

impl PlaySchur {
    /// The elimination in `slot`, made there from `b` on first use ([`new`](Self::new)).
    fn of<'a>(slot: &'a mut Option<Self>, b: &DMatrix<f64>, nj: usize) -> Option<&'a mut Self> {
        if slot.is_none() {
            *slot = Some(Self::new(b, nj)?);
        }
        slot.as_mut()
    }

    /// The elimination of `b`'s first `nj` unknowns; None if their block is singular.
    fn new(b: &DMatrix<f64>, nj: usize) -> Option<Self> {
        let b11_inv = b.view((0, 0), (nj, nj)).clone_owned().try_inverse()?;
        let b12 = b.view((0, nj), (nj, NP));
        let b21 = b.view((nj, 0), (NP, nj)).clone_owned();
        let q = &b11_inv * b12;
        let s0 = SMatrix::<f64, NP, NP>::from_fn(|r, c| {
            b[(nj + r, nj + c)] - (0..nj).map(|k| b21[(r, k)] * q[(k, c)]).sum::<f64>()
        });
        Some(Self {
            b11_inv,
            b21,
            q,
            s0,
            z: DVector::zeros(nj),
            lu: [[0.0; NP]; NP],
            swaps: ([(0, 0); NP], 0),
        })
    }

    /// Solves (B + dt·C_c)·Δv = `rhs` into `dv`, C_c = `cc` on the play block; None if the
    /// Schur complement is singular.
    fn solve(
        &mut self,
        cc: &[[f64; NP]; NP],
        dt: f64,
        rhs: &DVector<f64>,
        dv: &mut DVector<f64>,
    ) -> Option<()> {
        self.factor(cc, dt);
        self.solve_factored(rhs, dv)
    }

    /// Factorises S = B₂₂ − B₂₁·B₁₁⁻¹·B₁₂ + w·`cc` for [`solve_factored`](Self::solve_factored).
    fn factor(&mut self, cc: &[[f64; NP]; NP], w: f64) {
        self.lu = std::array::from_fn(|c| std::array::from_fn(|r| self.s0[(r, c)] + w * cc[r][c]));
        self.swaps = lu_factor(&mut self.lu);
    }

    /// [`solve`](Self::solve) with the factors of the last [`factor`](Self::factor).
    fn solve_factored(&mut self, rhs: &DVector<f64>, dv: &mut DVector<f64>) -> Option<()> {
        let nj = self.b11_inv.nrows();
        let (r1, r2) = rhs.as_slice().split_at(nj);
        gemv(self.z.as_mut_slice(), 1.0, self.b11_inv.as_slice(), r1, 0.0);
        let mut y: [f64; NP] = std::array::from_fn(|r| r2[r]);
        gemv(&mut y, -1.0, self.b21.as_slice(), self.z.as_slice(), 1.0);
        if !lu_apply(&self.lu, &self.swaps, &mut y) {
            return None;
        }
        let (x1, x2) = dv.as_mut_slice().split_at_mut(nj);
        x1.copy_from_slice(self.z.as_slice());
        gemv(x1, -1.0, self.q.as_slice(), &y, 1.0);
        x2.copy_from_slice(&y);
        Some(())
    }
}

/// Solves A·x = `b` in place (`b` becomes x) for the [`NP`] × [`NP`] matrix `a`, given by
/// columns (a[c][r]) and overwritten by its factors: the LU with partial pivoting of
/// nalgebra's `LU::new` and `solve_mut` for fixed-size matrices, their operations in their
/// order (the first largest |entry| as the pivot, a column of zeros skipped, the multipliers
/// scaled by the pivot's reciprocal), so the result is theirs to the bit, without their
/// generic views — the implicit substep's solve, in the play model's innermost loop. False
/// where a pivot is zero.
#[cfg(test)]
fn lu_solve(a: &mut [[f64; NP]; NP], b: &mut [f64; NP]) -> bool {
    let swaps = lu_factor(a);
    lu_apply(a, &swaps, b)
}

/// The row swaps of [`lu_factor`]: the pairs, and how many.
type Swaps = ([(usize, usize); NP], usize);

/// The factorisation of [`lu_solve`], in place: `a` becomes its factors.
fn lu_factor(a: &mut [[f64; NP]; NP]) -> Swaps {
    let mut swaps = [(0usize, 0usize); NP];
    let mut nswaps = 0;
    for i in 0..NP {
        let mut piv = i;
        let mut largest = a[i][i].abs();
        for r in i + 1..NP {
            let v = a[i][r].abs();
            if v > largest {
                largest = v;
                piv = r;
            }
        }
        let diag = a[i][piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps[nswaps] = (i, piv);
            nswaps += 1;
            for col in a.iter_mut().take(i) {
                col.swap(i, piv);
            }
            a[i].swap(i, piv);
        }
        let inv_diag = 1.0 / diag;
        for v in &mut a[i][i + 1..] {
            *v *= inv_diag;
        }
        let (left, right) = a.split_at_mut(i + 1);
        let coeffs = &left[i];
        for col in right.iter_mut() {
            if piv != i {
                col.swap(i, piv);
            }
            let p = -col[i];
            for (v, &c) in col[i + 1..].iter_mut().zip(&coeffs[i + 1..]) {
                *v += p * c;
            }
        }
    }
    (swaps, nswaps)
}

/// The solve of [`lu_solve`] with the factors of [`lu_factor`]: `b` becomes x; false where
/// a pivot is zero.
fn lu_apply(a: &[[f64; NP]; NP], (swaps, nswaps): &Swaps, b: &mut [f64; NP]) -> bool {
    for &(i1, i2) in &swaps[..*nswaps] {
        b.swap(i1, i2);
    }
    // L (unit diagonal), then U.
    for i in 0..NP - 1 {
        let coeff = -b[i];
        for r in i + 1..NP {
            b[r] += coeff * a[i][r];
        }
    }
    for i in (0..NP).rev() {
        let diag = a[i][i];
        if diag == 0.0 {
            return false;
        }
        let coeff = b[i] / diag;
        b[i] = coeff;
        for r in 0..i {
            b[r] += -coeff * a[i][r];
        }
    }
    true
}

/// The reduced play model along one recording's samples (in time order; None where the
/// nominal model gave no data, which restarts it) for the joint's `play`, the mechanics
/// within each sample interval as `interpolation` says, stepped as [`Stepping::default`]
/// says ([`respond_stepped`]). None at the samples without data or where a matrix is
/// singular.
pub fn respond(
    samples: &[Option<PlaySample<'_>>],
    play: &JointPlay,
    contact: &BallContact,
    interpolation: Interpolation,
) -> Vec<Option<PlayResponse>> {
    respond_stepped(samples, play, contact, interpolation, Stepping::default())
}

/// [`respond`], each sample interval stepped as `stepping` says.
pub fn respond_stepped(
    samples: &[Option<PlaySample<'_>>],
    play: &JointPlay,
    contact: &BallContact,
    interpolation: Interpolation,
    stepping: Stepping,
) -> Vec<Option<PlayResponse>> {
    let mut out = vec![None; samples.len()];
    // (time, x, v) of the last sample reached.
    let mut state: Option<(f64, DVector<f64>, DVector<f64>)> = None;
    // The last sample's system, for [`Interpolation::Linear`].
    let mut prev_sys: Option<System> = None;
    for (i, s) in samples.iter().enumerate() {
        let Some(s) = s else {
            state = None;
            continue;
        };
        let (Some(sys), Some(ks)) = (matrices(s), contacts(coupling(s))) else {
            state = None;
            continue;
        };
        let nj = s.transmission.compliance.len();
        let next = match state.take() {
            Some((t0, mut x, mut v)) if s.t > t0 && s.t - t0 <= MAX_GAP => {
                let r = coupling(s).reaction;
                let load = r[0].hypot(r[1]).hypot(r[2]);
                let prev = prev_sys
                    .as_ref()
                    .filter(|_| interpolation == Interpolation::Linear);
                let per_sample = match stepping {
                    Stepping::Stiff { per_sample } => Some(per_sample),
                    Stepping::Resolved => None,
                };
                let stiff = match per_sample.and_then(|p| stiff_substeps(&sys, p, s.t - t0)) {
                    Some(n) => {
                        let finest = || substeps(&sys, &ks, contact, load, s.t - t0).map(|st| st.n);
                        let (x0, v0) = (x.clone(), v.clone());
                        let kept = advance_stiff(
                            &sys,
                            &ks,
                            play,
                            contact,
                            n,
                            &finest,
                            s.t - t0,
                            &mut x,
                            &mut v,
                            prev,
                        );
                        if kept.is_none() {
                            x.copy_from(&x0);
                            v.copy_from(&v0);
                        }
                        kept.is_some()
                    }
                    None => false,
                };
                if !stiff {
                    let Some(steps) = substeps(&sys, &ks, contact, load, s.t - t0) else {
                        continue;
                    };
                    if advance(&sys, &ks, play, contact, steps, s.t - t0, &mut x, &mut v, prev).is_none() {
                        state = None;
                        continue;
                    }
                }
                (x, v)
            }
            _ => match static_start(s, &sys, &ks, play, contact) {
                Some(x) => (x, DVector::zeros(nj + NP)),
                None => continue,
            },
        };
        prev_sys = Some(sys);
        let (x, v) = next;
        if !x.iter().chain(v.iter()).all(|a| a.is_finite()) {
            continue;
        }
        let k = s.transmission.stiffness();
        out[i] = Some(PlayResponse {
            torque: (0..nj)
                .map(|a| k[a] * x[a] + s.transmission.damping[a] * v[a])
                .collect(),
            windup: x.rows(0, nj).iter().copied().collect(),
            offset: [x[nj], x[nj + 1], x[nj + 2], x[nj + 3]],
            point: s.about.map(|a| ExpansionPoint {
                offset: a.offset,
                windup: a.windup.clone(),
                outputs: a.outputs.clone(),
            }),
            radial_forces: std::array::from_fn(|b| {
                let mut sink = [0.0; NP];
                contact_load_one(
                    &ks[b],
                    &x.as_slice()[nj..],
                    &v.as_slice()[nj..],
                    play,
                    contact,
                    &mut sink,
                    None,
                )
            }),
        });
        state = Some((s.t, x, v));
    }
    out
}

/// Test fixtures: one compliant drive carrying a joint of 1 kg (side j) on axes x and y,
/// n = z, loaded along z, whose shift along z moves the drive's torque.
#[cfg(test)]
pub(crate) mod fixtures {
    use super::*;
    use crate::contact::play::UniversalPlay;

    /// The joint under `load` N along z, the drive's torque moving by `tau_per_m` N·m per m
    /// of its shift along z; 1 kg on each shift coordinate, 1e-4 kg·m² on the tilt.
    pub(crate) fn hanging_joint(load: f64, tau_per_m: f64) -> PlayDynamics {
        PlayDynamics {
            z_i: Vector3::x(),
            z_j: Vector3::y(),
            play: UniversalPlay {
                ball_spacing: 0.024,
                ball_radius: 0.004,
                material: crate::contact::Material::steel(),
            },
            cross_mass: 0.05,
            cross_load: [0.0; 3],
            reaction: [0.0, 0.0, load, 0.0],
            torque_by_offset: [vec![0.0], vec![0.0], vec![tau_per_m], vec![0.0]],
            torque_by_offset_acceleration: [vec![0.0], vec![0.0], vec![0.0], vec![0.0]],
            reaction_by_offset: [[0.0; 4]; 4],
            reaction_by_offset_acceleration: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1e-4],
            ],
            reaction_by_drive: vec![[0.0; 4]],
            reaction_by_drive_acceleration: vec![[0.0; 4]],
            torque_by_offset_rate: vec![],
            reaction_by_offset_rate: vec![],
            reaction_by_drive_rate: vec![],
            torque_by_drive_rate: vec![],
        }
    }

    /// The drive: 0.01 kg·m² on 1e-4 rad/(N·m), damped by 5 N·m·s/rad.
    pub(crate) fn one_drive() -> TransmissionDynamics {
        TransmissionDynamics {
            mass: DMatrix::from_element(1, 1, 0.01),
            compliance: vec![1e-4],
            damping: vec![5.0],
            windup_rate: vec![0.0],
            windup: vec![0.0],
            load_stiffness: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The substeps' own products and LU give nalgebra's numbers to the bit (the play
    /// model's results, and so every diagnosis's, do not move with them): `gemv` at β = 0, 1
    /// and another β, `gemv_two_blocks` on a matrix zero between its two diagonal blocks and
    /// `lu_solve` against `LU::solve_mut`, including a zero column and row swaps. Random
    /// numbers of mixed magnitudes, a fixed seed (CI reproduces a failure).
    #[test]
    fn the_substeps_products_and_lu_are_nalgebras_to_the_bit() {
        use proptest::collection::vec;
        use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 200,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::deterministic_rng(RngAlgorithm::ChaCha),
        );
        let strategy = (
            1usize..14,
            vec((-1.0f64..1.0, -8i32..8), 14 * 14),
            vec(-1.0f64..1.0, 14),
            -2.0f64..2.0,
            0usize..NP + 1,
        );
        runner
            .run(&strategy, |(n, entries, x, alpha, zero_col)| {
                let value = |k: usize| entries[k].0 * 10f64.powi(entries[k].1);
                let a = DMatrix::from_fn(n, n, |r, c| value(r * 14 + c));
                let xv = DVector::from_column_slice(&x[..n]);
                for beta in [0.0, 1.0, 0.37] {
                    let mut want = DVector::from_fn(n, |r, _| x[(r + 3) % 14]);
                    let mut got = want.clone();
                    want.gemv(alpha, &a, &xv, beta);
                    gemv(got.as_mut_slice(), alpha, a.as_slice(), xv.as_slice(), beta);
                    let same = want
                        .iter()
                        .zip(got.iter())
                        .all(|(p, q)| p.to_bits() == q.to_bits());
                    proptest::prop_assert!(same, "gemv, beta {beta}: {want} against {got}");
                    // Zero between a leading block and the rest.
                    let m = (n / 2).max(1);
                    let blocks =
                        DMatrix::from_fn(n, n, |r, c| if (r < m) == (c < m) { a[(r, c)] } else { 0.0 });
                    if m < n {
                        proptest::prop_assert_eq!(two_blocks(&blocks), m);
                    }
                    let mut want = DVector::from_fn(n, |r, _| x[(r + 5) % 14]);
                    let mut got = want.clone();
                    want.gemv(alpha, &blocks, &xv, beta);
                    gemv_two_blocks(
                        got.as_mut_slice(),
                        alpha,
                        blocks.as_slice(),
                        two_blocks(&blocks),
                        xv.as_slice(),
                        beta,
                    );
                    let same = want
                        .iter()
                        .zip(got.iter())
                        .all(|(p, q)| p.to_bits() == q.to_bits());
                    proptest::prop_assert!(same, "two blocks, beta {beta}: {want} against {got}");
                }
                // The LU, on the play block's size; a column of zeros where asked.
                let s = SMatrix::<f64, NP, NP>::from_fn(|r, c| {
                    if c == zero_col {
                        0.0
                    } else {
                        value((r * NP + c) % (14 * 14))
                    }
                });
                let mut want = SMatrix::<f64, NP, 1>::from_fn(|r, _| x[r]);
                let ok_want = s.lu().solve_mut(&mut want);
                let mut cols: [[f64; NP]; NP] = std::array::from_fn(|c| std::array::from_fn(|r| s[(r, c)]));
                let mut got: [f64; NP] = std::array::from_fn(|r| x[r]);
                let ok_got = lu_solve(&mut cols, &mut got);
                proptest::prop_assert_eq!(ok_want, ok_got);
                if ok_want {
                    let same = want.iter().zip(&got).all(|(p, q)| p.to_bits() == q.to_bits());
                    proptest::prop_assert!(same, "lu: {want} against {got:?}");
                }
                Ok(())
            })
            .unwrap();
    }

    /// The implicit substep's elimination of the drives solves the same system as a dense LU
    /// of all the unknowns, with three drives and with none, for a contact damping on a few
    /// play coordinates (a symmetric positive definite B, not symmetric coupling blocks).
    #[test]
    fn the_play_blocks_schur_complement_solves_the_whole_implicit_system() {
        for nj in [3usize, 0] {
            let n = nj + NP;
            let b = DMatrix::from_fn(n, n, |r, c| {
                let off = 0.3 * ((r * 7 + c * 3) as f64).sin();
                if r == c {
                    4.0 + r as f64
                } else {
                    off
                }
            });
            let mut cc = [[0.0; NP]; NP];
            for (k, u) in [[1.0, 0.5, 0.0, -0.2], [0.0, 1.0, 2.0, 0.3]].iter().enumerate() {
                for r in 0..4 {
                    for c in 0..4 {
                        cc[r + 2 * k][c + 2 * k] += 300.0 * u[r] * u[c];
                    }
                }
            }
            let dt = 1e-4;
            let rhs = DVector::from_fn(n, |r, _| (r as f64 * 1.3).cos());
            let mut dv = DVector::zeros(n);
            let mut schur = PlaySchur::new(&b, nj).expect("regular drive block");
            schur.solve(&cc, dt, &rhs, &mut dv).expect("regular complement");
            let mut a = b.clone();
            for r in 0..NP {
                for c in 0..NP {
                    a[(nj + r, nj + c)] += dt * cc[r][c];
                }
            }
            let dense = a.clone().lu().solve(&rhs).expect("regular");
            let err = (&dv - &dense).amax() / dense.amax();
            assert!(err < 1e-13, "nj = {nj}: relative difference {err:e}");
            // And it is a solution: A·Δv = rhs to round-off.
            assert!(
                (&a * &dv - &rhs).amax() < 1e-12 * rhs.amax() * a.amax(),
                "nj = {nj}"
            );
        }
    }

    /// `n` samples 2 ms apart, the joint at sample i `play(i)`.
    fn every_2_ms<'a>(
        n: usize,
        play: impl Fn(usize) -> &'a PlayDynamics,
        transmission: &'a TransmissionDynamics,
    ) -> Vec<Option<PlaySample<'a>>> {
        sampled(0.002, n, play, transmission)
    }

    /// `n` samples `dt` s apart, the joint at sample i `play(i)`.
    fn sampled<'a>(
        dt: f64,
        n: usize,
        play: impl Fn(usize) -> &'a PlayDynamics,
        transmission: &'a TransmissionDynamics,
    ) -> Vec<Option<PlaySample<'a>>> {
        (0..n)
            .map(|i| {
                Some(PlaySample {
                    t: dt * i as f64,
                    play: play(i),
                    transmission,
                    about: None,
                })
            })
            .collect()
    }

    /// One drive, a joint whose side j weighs 1 kg and hangs on it: axes x and y, n = z. The
    /// nominal joint holds side j up with 200 N; with play, side j sits 2h lower (each pair
    /// takes half the drop) plus 200 N over the four balls' stiffness along n (4·k·¼ = k),
    /// and the drive's torque follows by T_e. Reversed, the load sends it across the play to
    /// the other wall, without blowing up on the way.
    #[test]
    fn a_hanging_joint_sits_on_its_wall_and_crosses_the_play_when_the_load_reverses() {
        let h = 5e-6;
        let k = BALL_CONTACT.stiffness;
        let tau_per_m = 1000.0;
        let dynamics = |load: f64| fixtures::hanging_joint(load, tau_per_m);
        let transmission = fixtures::one_drive();
        let (up, down) = (dynamics(200.0), dynamics(-200.0));
        let samples = every_2_ms(400, |i| if i < 200 { &up } else { &down }, &transmission);
        let r = respond(
            &samples,
            &JointPlay::radial(h),
            &BALL_CONTACT,
            Interpolation::Held,
        );
        let sits = -2.0 * h - 200.0 / k;
        let first = r[0].as_ref().unwrap();
        assert!(
            (first.offset[2] - sits).abs() < 1e-3 * sits.abs(),
            "{:?}",
            first.offset
        );
        assert!((first.torque[0] - tau_per_m * sits).abs() < 1e-3 * (tau_per_m * sits).abs());
        let before = r[199].as_ref().unwrap();
        assert!(
            (before.offset[2] - sits).abs() < 1e-3 * sits.abs(),
            "{:?}",
            before.offset
        );
        let last = r[399].as_ref().unwrap();
        assert!(
            (last.offset[2] + sits).abs() < 1e-2 * sits.abs(),
            "{:?}",
            last.offset
        );
        assert!((last.torque[0] + tau_per_m * sits).abs() < 1e-2 * (tau_per_m * sits).abs());
        let widest = r.iter().flatten().map(|x| x.offset[2].abs()).fold(0.0, f64::max);
        assert!(widest < 2.0 * h + 5.0 * 200.0 / k, "{widest}");
    }

    /// A load that swings within sample intervals, as near the direct singularity: the
    /// hanging joint's 200 N from t₀ = 0.2013 s (between two samples) swung as
    /// 200·cos(2π·20 Hz·(t − t₀)), so the joint crosses its play every 25 ms. The reference is
    /// the held model sampled every 20 µs (what held and blended both tend to as the sampling
    /// refines). Sampled every 2 ms, the blended forces follow it far more closely than the
    /// held ones, which lead by up to a sample; held, the error shrinks with the sampling.
    #[test]
    fn blended_forces_follow_a_swinging_load_as_a_finely_sampled_model_does() {
        let h = 5e-6;
        let start = 0.2013;
        let load = |t: f64| 200.0 * (2.0 * std::f64::consts::PI * 20.0 * (t - start).max(0.0)).cos();
        let transmission = fixtures::one_drive();
        // The joint's shift along z every 2 ms over 0.3 s, sampled every `dt` s.
        let shift = |dt: f64, interpolation: Interpolation| -> Vec<f64> {
            let every = (2e-3 / dt).round() as usize;
            let n = 150 * every;
            let t: Vec<f64> = (0..n).map(|i| dt * i as f64).collect();
            let joints: Vec<PlayDynamics> = t
                .iter()
                .map(|&t| fixtures::hanging_joint(load(t), 1000.0))
                .collect();
            let samples = sampled(dt, n, |i| &joints[i], &transmission);
            let r = respond(&samples, &JointPlay::radial(h), &BALL_CONTACT, interpolation);
            r.iter()
                .step_by(every)
                .map(|x| x.as_ref().unwrap().offset[2])
                .collect()
        };
        // The largest difference from the reference, in units of the wall-to-wall travel
        // (2h either way, and the balls' compression under 200 N on each wall).
        let travel = 4.0 * h + 2.0 * 200.0 / BALL_CONTACT.stiffness;
        let reference = shift(2e-5, Interpolation::Held);
        let apart = |z: &[f64]| {
            z.iter()
                .zip(&reference)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
                / travel
        };
        let (fine_held, fine_blended) = (
            apart(&shift(2e-4, Interpolation::Held)),
            apart(&shift(2e-4, Interpolation::Linear)),
        );
        let (held, blended) = (
            apart(&shift(2e-3, Interpolation::Held)),
            apart(&shift(2e-3, Interpolation::Linear)),
        );
        // (Measured, in wall-to-wall travels: every 0.2 ms held 0.075, blended 0.0085; every
        // 2 ms held 0.72 — a whole sample early at a crossing — and blended 0.013.)
        // The joint does cross: it sits on the lower wall, then swings to the upper one.
        let (low, high) = reference
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), &z| (a.min(z), b.max(z)));
        assert!(low < -1.5 * h && high > 1.5 * h, "{low:e} .. {high:e} m");
        assert!(
            fine_held < 0.5 * held,
            "held every 0.2 ms {fine_held}, every 2 ms {held}"
        );
        assert!(
            blended < 0.05 && blended < 0.05 * held,
            "blended {blended}, held {held}"
        );
        assert!(
            fine_blended < 0.2 * fine_held.max(1e-3),
            "{fine_blended} vs {fine_held}"
        );
    }

    /// Load-proportional damping (γ·F, Hunt–Crossley's form) takes the ringing out of the
    /// landing after the load reverses, where the undamped contact keeps ringing; it changes
    /// nothing at rest (the joint sits where it did). A damping 500× critical for the
    /// kilogram on the balls stays stable on the stiffness's substeps (the dampings are
    /// implicit) and creeps onto the far wall without a bounce.
    #[test]
    fn load_proportional_damping_settles_the_landing_and_a_stiff_damping_stays_stable() {
        let h = 5e-6;
        let k = BALL_CONTACT.stiffness;
        let transmission = fixtures::one_drive();
        let (up, down) = (
            fixtures::hanging_joint(200.0, 1000.0),
            fixtures::hanging_joint(-200.0, 1000.0),
        );
        let samples = every_2_ms(300, |i| if i < 100 { &up } else { &down }, &transmission);
        let sits = 2.0 * h + 200.0 / k;
        // The ringing about the far wall over the last 100 samples, m RMS.
        let ringing = |d: ContactDamping| {
            let r = respond(
                &samples,
                &JointPlay::radial(h),
                &BALL_CONTACT.with_damping(d),
                Interpolation::Held,
            );
            assert!(
                (r[0].as_ref().unwrap().offset[2] + sits).abs() < 1e-3 * sits,
                "{d}: {:?}",
                r[0].as_ref().unwrap().offset
            );
            let late: Vec<f64> = r[200..]
                .iter()
                .map(|x| x.as_ref().unwrap().offset[2] - sits)
                .collect();
            (late.iter().map(|x| x * x).sum::<f64>() / late.len() as f64).sqrt()
        };
        let undamped = ringing(ContactDamping::constant(0.0));
        let load = ringing(ContactDamping {
            constant: 0.0,
            load: 100.0,
        });
        let stiff = ringing(ContactDamping::constant(1e7));
        // (Measured: 8.4e-6, 1e-20 and 1.1e-7 m: the stiff damping creeps onto the wall,
        // its time constant c/k = 0.1 s.)
        assert!(undamped > 0.5 * h, "the undamped landing rings: {undamped:e} m");
        assert!(load < 1e-3 * undamped, "{load:e} against {undamped:e} m");
        assert!(stiff.is_finite() && stiff < 0.05 * h, "{stiff:e} m");
    }

    /// Expanded about a point x₁ of its own motion, a model whose mechanics is linear (the
    /// fixture's coefficients do not change with the configuration) answers as about the
    /// sample: the point's torque change T_e·e₁ and reaction Λ carry exactly what the
    /// expansion about the sample does (the constant load g = f(x₁) + K₁·x₁ and its signs).
    /// With the drive's load stiffness S at the point, the drive's stiffness is K + S there.
    #[test]
    fn expanded_about_a_point_of_a_linear_mechanism_the_response_is_the_same() {
        let (h, tau_per_m) = (5e-6, 1000.0);
        let joint = fixtures::hanging_joint(200.0, tau_per_m);
        let transmission = fixtures::one_drive();
        let plain = every_2_ms(300, |_| &joint, &transmission);
        let at = respond(&plain, &JointPlay::radial(h), &BALL_CONTACT, Interpolation::Held);
        let (e1, w1) = (-7e-6, 3e-5);
        let point = PlayPoint {
            windup: vec![w1],
            offset: [0.0, 0.0, e1, 0.0],
            dynamics: joint.clone(),
            torque: vec![tau_per_m * e1],
            load_stiffness: DMatrix::zeros(1, 1),
            mass: transmission.mass.clone(),
            outputs: vec![],
        };
        // The samples expanded about `point`, answered.
        let about = |point: &PlayPoint| {
            let samples: Vec<Option<PlaySample>> = plain
                .iter()
                .map(|s| {
                    s.map(|s| PlaySample {
                        about: Some(point),
                        ..s
                    })
                })
                .collect();
            respond(
                &samples,
                &JointPlay::radial(h),
                &BALL_CONTACT,
                Interpolation::Held,
            )
        };
        let expanded = about(&point);
        for i in [0, 150, 299] {
            let (a, b) = (at[i].as_ref().unwrap(), expanded[i].as_ref().unwrap());
            assert!(
                (a.offset[2] - b.offset[2]).abs() < 1e-9 * h,
                "{i}: {:?} vs {:?}",
                a.offset,
                b.offset
            );
            assert!(
                (a.torque[0] - b.torque[0]).abs() < 1e-9 * a.torque[0].abs() + 1e-12,
                "{i}: {:?} vs {:?}",
                a.torque,
                b.torque
            );
        }
        // With a load stiffness at the point (and the point at the sample) the drive is
        // stiffer: the same torque over K + S instead of K.
        let stiff = PlayPoint {
            load_stiffness: DMatrix::from_element(1, 1, 1e4),
            windup: vec![0.0],
            offset: [0.0; 4],
            torque: vec![0.0],
            ..point.clone()
        };
        let stiffer = about(&stiff);
        let (a, b) = (at[299].as_ref().unwrap(), stiffer[299].as_ref().unwrap());
        let k = transmission.stiffness()[0];
        let ratio = b.windup[0] / a.windup[0];
        assert!(
            (ratio - k / (k + 1e4)).abs() < 1e-3,
            "{ratio} vs {}",
            k / (k + 1e4)
        );
    }

    /// Without play the joint hangs on its balls' stiffness alone: 200 N / k below the centre.
    #[test]
    fn without_play_a_hanging_joint_sits_on_its_balls_compliance() {
        let joint = fixtures::hanging_joint(200.0, 0.0);
        let transmission = fixtures::one_drive();
        let samples = every_2_ms(50, |_| &joint, &transmission);
        let r = respond(
            &samples,
            &JointPlay::default(),
            &BALL_CONTACT,
            Interpolation::Held,
        );
        let sits = -200.0 / BALL_CONTACT.stiffness;
        for at in [&r[0], &r[49]] {
            let at = at.as_ref().expect("a response");
            assert!((at.offset[2] - sits).abs() < 0.02 * sits.abs(), "{:?}", at.offset);
        }
    }

    /// Axial play: pressed by 60 N along z_i = x, the cross sits against one end of side
    /// i's pair (h_a/2 and 60 N on one ball's end) and side j's pair carries the force across
    /// its axis (y) on both balls, 30 N each, with no radial clearance: side j sits
    /// h_a/2 + 60/k + 30/k away along −x. Reversed, it crosses the axial play to the other end.
    #[test]
    fn a_joint_pressed_along_a_trunnion_axis_sits_against_the_end_of_its_axial_play() {
        let (h_a, k) = (1e-5, BALL_CONTACT.stiffness);
        let mut push = fixtures::hanging_joint(0.0, 0.0);
        push.reaction = [60.0, 0.0, 0.0, 0.0];
        let mut pull = push.clone();
        pull.reaction = [-60.0, 0.0, 0.0, 0.0];
        let transmission = fixtures::one_drive();
        let samples = every_2_ms(400, |i| if i < 200 { &push } else { &pull }, &transmission);
        let r = respond(
            &samples,
            &JointPlay::axial(h_a),
            &BALL_CONTACT,
            Interpolation::Held,
        );
        let sits = -(0.5 * h_a + 90.0 / k);
        for (at, sign) in [(&r[0], 1.0), (&r[199], 1.0), (&r[399], -1.0)] {
            let at = at.as_ref().unwrap();
            assert!(
                (at.offset[0] - sign * sits).abs() < 0.02 * sits.abs(),
                "{:?}",
                at.offset
            );
            assert!(
                at.offset[1].abs() < 0.02 * sits.abs() && at.offset[2].abs() < 0.02 * sits.abs(),
                "{:?}",
                at.offset
            );
            for ball in &at.radial_forces[2..] {
                assert!((ball - 30.0).abs() < 0.6, "{:?}", at.radial_forces);
            }
        }
    }

    /// Side j's offset `coordinate` sits at `sits` (within 2 %) at the first and last of 50
    /// samples of `joint` with `play` on `contact`.
    fn assert_sits(
        contact: &BallContact,
        joint: &PlayDynamics,
        play: &JointPlay,
        coordinate: usize,
        sits: f64,
    ) {
        let transmission = fixtures::one_drive();
        let samples = every_2_ms(50, |_| joint, &transmission);
        let r = respond(&samples, play, contact, Interpolation::Held);
        for at in [&r[0], &r[49]] {
            let at = at.as_ref().expect("a response");
            assert!(
                (at.offset[coordinate] - sits).abs() < 0.02 * sits.abs(),
                "{:?} vs {sits:e}",
                at.offset
            );
        }
    }

    /// The linear law per direction: pressed along x by 60 N against the end of a 10 µm
    /// axial play, with the end faces five times softer than the walls, side j sits
    /// h_a/2 + 60/k_a + 30/k away (the end face's compression, then a wall's); hanging
    /// without play on 200 N, 2·100/k lower whatever the end faces' stiffness.
    #[test]
    fn with_linear_balls_each_direction_has_its_own_stiffness() {
        let (k, k_a, h_a) = (BALL_CONTACT.stiffness, BALL_CONTACT.stiffness / 5.0, 1e-5);
        let contact = BallContact {
            axial_stiffness: k_a,
            ..BALL_CONTACT
        };
        let sits_at = |joint: &PlayDynamics, play: &JointPlay, coordinate: usize, sits: f64| {
            assert_sits(&contact, joint, play, coordinate, sits)
        };
        let mut push = fixtures::hanging_joint(0.0, 0.0);
        push.reaction = [60.0, 0.0, 0.0, 0.0];
        sits_at(
            &push,
            &JointPlay::axial(h_a),
            0,
            -(0.5 * h_a + 60.0 / k_a + 30.0 / k),
        );
        sits_at(
            &fixtures::hanging_joint(200.0, 0.0),
            &JointPlay::default(),
            2,
            -2.0 * 100.0 / k,
        );
    }

    /// With Hertz's law per direction the same statics hold with δ = (F/K)^(2/3): hanging
    /// without play on 200 N, side j sits two balls' compressions under 100 N lower (one
    /// ball of each pair in series); pressed along x by 60 N against the end of a 10 µm axial
    /// play, it sits h_a/2 + δ_axial(60 N) + δ_radial(30 N) away.
    #[test]
    fn with_hertz_balls_the_joint_sits_on_each_directions_own_compression() {
        let hertz = HertzBalls {
            radial: 1e10,
            axial: 2e9,
        };
        let contact = BallContact {
            hertz: Some(hertz),
            ..BALL_CONTACT
        };
        let delta = |f: f64, k: f64| (f / k).powf(2.0 / 3.0);
        let sits_at = |joint: &PlayDynamics, play: &JointPlay, coordinate: usize, sits: f64| {
            assert_sits(&contact, joint, play, coordinate, sits)
        };
        let hanging = fixtures::hanging_joint(200.0, 0.0);
        sits_at(
            &hanging,
            &JointPlay::default(),
            2,
            -2.0 * delta(100.0, hertz.radial),
        );
        let h_a = 1e-5;
        let mut push = fixtures::hanging_joint(0.0, 0.0);
        push.reaction = [60.0, 0.0, 0.0, 0.0];
        let sits = -(0.5 * h_a + delta(60.0, hertz.axial) + delta(30.0, hertz.radial));
        sits_at(&push, &JointPlay::axial(h_a), 0, sits);
        // From the MR2120 design: a 4 mm steel ball in a bore 6 µm larger is some ten times
        // stiffer than on a flat end face (1.12e11 against ~1e10 N/m^1.5).
        let design = crate::contact::BearingDesign::mr2120(6e-6, 0.0, crate::contact::Damping::Elastic);
        let k = HertzBalls::from_design(&design).unwrap();
        assert!((k.radial / 1.12e11 - 1.0).abs() < 0.05, "{k:?}");
        assert!(k.radial > 5.0 * k.axial, "{k:?}");
    }

    /// The stiff substeps ([`Stepping::Stiff`]) against the resolved ones on the hanging
    /// joint with the MR2120's Hertz balls (6 µm, 20 N·s/m + 500 s/m × F, the bearing
    /// preset's kind of damping), its 200 N swung at 20 Hz along z so that it crosses its
    /// play every 25 ms, the forces blended: every sample answered, the joint on the same
    /// wall, its shift along z within a small part of the wall-to-wall travel and the drive's
    /// torque within a small part of its swing, at 10 and 40 substeps per sample interval.
    /// (Before a substep was taken again where a contact's load is far from linear over it,
    /// the example `play_model_run`'s joint blew up at 10 and 20 per interval.)
    #[test]
    fn stiff_substeps_follow_the_resolved_ones_across_the_play() {
        let h = 6e-6;
        let design = crate::contact::BearingDesign::mr2120(h, 0.0, crate::contact::Damping::Elastic);
        let contact = BallContact {
            hertz: Some(HertzBalls::from_design(&design).unwrap()),
            ..BALL_CONTACT.with_damping(ContactDamping::load_proportional(500.0))
        };
        let load = |t: f64| 200.0 * (2.0 * std::f64::consts::PI * 20.0 * t).cos();
        let transmission = fixtures::one_drive();
        let joints: Vec<PlayDynamics> = (0..250)
            .map(|i| fixtures::hanging_joint(load(0.002 * i as f64), 1000.0))
            .collect();
        let samples = every_2_ms(250, |i| &joints[i], &transmission);
        let run = |stepping: Stepping| {
            respond_stepped(
                &samples,
                &JointPlay::radial(h),
                &contact,
                Interpolation::Linear,
                stepping,
            )
        };
        let resolved = run(Stepping::Resolved);
        let swing = |r: &[Option<PlayResponse>], f: &dyn Fn(&PlayResponse) -> f64| {
            let v: Vec<f64> = r.iter().flatten().map(f).collect();
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        };
        let travel = swing(&resolved, &|x| x.offset[2]);
        let torque_swing = swing(&resolved, &|x| x.torque[0]);
        // The joint does cross its play: about 2h either way and the balls' compression.
        assert!(travel > 3.0 * h, "{travel:e} m");
        for per_sample in [10, 40] {
            let stiff = run(Stepping::Stiff { per_sample });
            assert!(
                stiff.iter().all(Option::is_some),
                "{per_sample}: a sample unanswered"
            );
            let apart = |f: &dyn Fn(&PlayResponse) -> f64| {
                stiff
                    .iter()
                    .zip(&resolved)
                    .map(|(a, b)| (f(a.as_ref().unwrap()) - f(b.as_ref().unwrap())).abs())
                    .fold(0.0, f64::max)
            };
            let (shift, torque) = (
                apart(&|x| x.offset[2]) / travel,
                apart(&|x| x.torque[0]) / torque_swing,
            );
            // (Measured: at 10 per interval 0.0033 of the travel and 0.022 of the torque's
            // swing, at 40 0.0046 and 0.0027.)
            assert!(
                shift < 0.05 && torque < 0.05,
                "{per_sample}: shift {shift}, torque {torque}"
            );
        }
    }

    /// Both trunnion pairs carry the joint's load in series, through the cross: pressed by
    /// Λ = (0, 60, 80) N (axes x and y, n = z), the side-i pair (bores along x) carries the
    /// whole 100 N across its axis, 50 N per ball along −(0.6, 0.8); the side-j pair (bores
    /// along y) the 80 N along n, 40 N per ball, and the 60 N along y on one axial end. Side j
    /// then sits below side i by both pairs' displacements added: along n by
    /// 0.8·(h + 50/k) plus h + 40/k, along y by 0.6·(h + 50/k) plus 60/k. (Statics of the cross, not the model's
    /// maps; a cross placed half-way between its sides could not load both pairs so.)
    #[test]
    fn the_crosss_two_pairs_carry_the_load_in_series_all_four_balls_on_their_walls() {
        let (h, k) = (5e-6, BALL_CONTACT.stiffness);
        let mut joint = fixtures::hanging_joint(80.0, 0.0);
        joint.reaction = [0.0, 60.0, 80.0, 0.0];
        let transmission = fixtures::one_drive();
        let samples = every_2_ms(200, |_| &joint, &transmission);
        let r = respond(
            &samples,
            &JointPlay::radial(h),
            &BALL_CONTACT,
            Interpolation::Held,
        );
        for at in [&r[0], &r[199]] {
            let at = at.as_ref().unwrap();
            for (ball, expected) in at.radial_forces.iter().zip([50.0, 50.0, 40.0, 40.0]) {
                assert!(
                    (ball - expected).abs() < 0.02 * expected,
                    "{:?}",
                    at.radial_forces
                );
            }
            let along_n = -(0.8 * (h + 50.0 / k) + h + 40.0 / k);
            let along_y = -(0.6 * (h + 50.0 / k) + 60.0 / k);
            assert!(
                (at.offset[2] - along_n).abs() < 0.02 * along_n.abs(),
                "{:?}",
                at.offset
            );
            assert!(
                (at.offset[1] - along_y).abs() < 0.02 * along_y.abs(),
                "{:?}",
                at.offset
            );
            assert!(
                at.offset[0].abs() < 0.02 * h && at.offset[3].abs() < 0.02 * h / 0.024,
                "{:?}",
                at.offset
            );
        }
    }

    /// The cross's own load (its weight and what carries it along with side i) goes to side
    /// i's balls only: side j's carry the joint's reaction Λ as before, side i's Λ − m_x·(g −
    /// a_i) — here Λ = (0, 60, 80) N on side j and the cross pulled by 20 N along −z, so side
    /// i's pair carries |(60, 100)| = 116.6 N, side j's 80 N.
    #[test]
    fn the_crosss_own_load_rides_on_side_is_balls_only() {
        let mut joint = fixtures::hanging_joint(80.0, 0.0);
        joint.reaction = [0.0, 60.0, 80.0, 0.0];
        joint.cross_load = [0.0, 0.0, -20.0];
        let transmission = fixtures::one_drive();
        let samples = every_2_ms(200, |_| &joint, &transmission);
        let r = respond(
            &samples,
            &JointPlay::radial(5e-6),
            &BALL_CONTACT,
            Interpolation::Held,
        );
        let side_i = 0.5 * (60.0f64.hypot(100.0));
        for at in [&r[0], &r[199]] {
            let at = at.as_ref().unwrap();
            for (ball, expected) in at.radial_forces.iter().zip([side_i, side_i, 40.0, 40.0]) {
                assert!(
                    (ball - expected).abs() < 0.02 * expected,
                    "{:?}",
                    at.radial_forces
                );
            }
        }
    }
}
