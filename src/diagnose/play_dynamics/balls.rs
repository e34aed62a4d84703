//! The trunnion balls of the reduced play model: their contact law (linear or Hertz's, with
//! damping), the joint's play, and each ball's contact as a linear map of the play and cross
//! coordinates, with the loads and the damping and stiffness matrices they give.

use super::{CROSS, NP};
use crate::diagnose::model::PlayDynamics;
use nalgebra::{DMatrix, Vector3};

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
    pub(super) fn spring(&self, radial: bool, d: f64) -> f64 {
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
    pub(super) fn spring_and_damping(&self, radial: bool, d: f64) -> (f64, f64) {
        let spring = self.spring(radial, d);
        let damping = if self.load_damping == 0.0 {
            self.damping
        } else {
            self.damping + self.load_damping * spring
        };
        (spring, damping)
    }

    /// dF/dδ (N/m) of [`spring`](Self::spring) at a penetration `d` (m).
    pub(super) fn spring_rate(&self, radial: bool, d: f64) -> f64 {
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
    pub(super) fn compression(&self, force: f64) -> f64 {
        match self.hertz {
            None => force / self.stiffness.min(self.axial_stiffness),
            Some(k) => (force / k.radial.min(k.axial)).max(0.0).powf(2.0 / 3.0),
        }
    }

    /// The largest contact stiffness dF/dδ (N/m) under a normal force `force` (N), either
    /// direction (Hertz: 1.5·K^(2/3)·F^(1/3)).
    pub(super) fn tangent_stiffness(&self, force: f64) -> f64 {
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
    pub(super) fn scale(&self) -> f64 {
        self.radial.max(0.5 * self.axial).max(1e-9)
    }
}

/// The cross frame: u1 = z_i, u2 = z_j made normal to u1, u3 = u1 × u2 = n (unit, base frame).
pub(super) fn cross_frame(p: &PlayDynamics) -> Option<[Vector3<f64>; 3]> {
    let u1 = p.z_i.try_normalize(1e-12)?;
    let u2 = (p.z_j - u1 * p.z_j.dot(&u1)).try_normalize(1e-12)?;
    Some([u1, u2, u1.cross(&u2)])
}

/// One contact of a trunnion ball: radial (two rows: the ball centre's displacement from its
/// bore's axis in the bore's plane) or axial (one row: its travel towards the bore's end).
#[derive(Debug, Clone, Copy)]
pub(super) enum Contact {
    Radial([[f64; NP]; 2], Support),
    Axial([f64; NP], Support),
}

/// The coordinates a contact's rows act on (where one of them is not zero): its damping's
/// outer products touch only those (a side-i ball's rows leave out the play coordinates), the
/// zeros they skip adding nothing to the sums (so the numbers are the same to the bit).
#[derive(Debug, Clone, Copy)]
pub(super) struct Support {
    pub(super) index: [usize; NP],
    pub(super) len: usize,
}

impl Support {
    pub(super) fn of(rows: &[&[f64; NP]]) -> Self {
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

    pub(super) fn indices(&self) -> &[usize] {
        &self.index[..self.len]
    }
}

impl Contact {
    pub(super) fn radial(rows: [[f64; NP]; 2]) -> Self {
        Contact::Radial(rows, Support::of(&[&rows[0], &rows[1]]))
    }

    pub(super) fn axial(row: [f64; NP]) -> Self {
        Contact::Axial(row, Support::of(&[&row]))
    }
}

/// The balls' contacts as linear maps of the coordinates (play, then cross). The cross frame
/// is u1 = z_i, u2 = z_j (made normal to u1), u3 = u1 × u2 = n. A side-i ball at ±(s/2)·u1
/// on the cross sits in a bore of side i: its displacement is c + ω × (±(s/2)·u1); a side-j
/// ball at ±(s/2)·u2 sits in a bore of side j, which moved by e and turned by φ about u3: its
/// displacement is (c − e) + (ω − φ·u3) × (±(s/2)·u2).
pub(super) fn contacts(p: &PlayDynamics) -> Option<[Contact; 8]> {
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

/// The sums rows\[k\]·x and rows\[k\]·ẋ for every row at once (each summed in the order of the
/// coordinates, as one dot product after the other would): independent sums side by side,
/// in the contact loads of the play model's substeps (most of its time).
pub(super) fn dots<const R: usize>(rows: [&[f64; NP]; R], x: &[f64], xd: &[f64]) -> ([f64; R], [f64; R]) {
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
pub(super) fn contact_load_one(
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
pub(super) fn contact_load(
    ks: &[Contact; 8],
    x: &[f64],
    xd: &[f64],
    play: &JointPlay,
    c: &BallContact,
) -> [f64; NP] {
    let mut out = [0.0; NP];
    for k in ks {
        contact_load_one(k, x, xd, play, c, &mut out, None);
    }
    out
}

/// The contacts' damping matrix −∂load/∂ẋ (N·s/m), and whether any contact added to it
/// (else it is zero, and need not be looked at).
pub(super) struct Damping {
    pub(super) matrix: [[f64; NP]; NP],
    pub(super) added: bool,
    /// In the stiff substeps, the weight dt of the contacts' stiffness K_c added to the
    /// matrix (C_c + dt·K_c); 0: the damping alone.
    pub(super) stiffness_weight: f64,
    /// In the stiff substeps, the contacts' stiffness K_c = −∂load/∂x (N/m), by rows.
    pub(super) stiffness: [[f64; NP]; NP],
}

impl Damping {
    pub(super) fn zero() -> Self {
        Self::weighted(0.0)
    }

    pub(super) fn weighted(stiffness_weight: f64) -> Self {
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
pub(super) fn contact_load_and_damping(
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

/// Σ JᵀJ over the contacts' rows, on the play and cross coordinates.
pub(super) fn contact_gram(ks: &[Contact; 8], n: usize) -> DMatrix<f64> {
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

/// Which of the contacts touch at the play coordinates `x` (bit k: contact k penetrates its
/// wall or end face).
pub(super) fn touching(ks: &[Contact; 8], x: &[f64], play: &JointPlay) -> u8 {
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
