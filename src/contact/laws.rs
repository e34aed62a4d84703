//! Normal contact force laws and regularised Coulomb friction.
//!
//! All laws give F(δ, δ̇) ≥ 0 for a penetration δ ≥ 0 (m) and its rate δ̇ (m/s), vanish for
//! δ ≤ 0 and are continuous with a continuous first derivative in δ at δ = 0 (the elastic part
//! ~δ^1.5, the damping part ~δ^1.5·δ̇), so the BDF integrates contact onset and loss without
//! events. The hysteresis laws of Lankarani–Nikravesh and Flores are written for an impact
//! velocity; in a continuous simulation there is no single impact, so lash uses the
//! documented reference velocity `v_ref` in its place.

use super::{positive, ContactError};

/// A normal force law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NormalLaw {
    /// Ideally elastic Hertz contact: F = K·δ^n (the paper's choice).
    Hertz {
        /// Stiffness K, N/m^n.
        k: f64,
        /// Exponent n (1.5 for Hertz point contact).
        n: f64,
    },
    /// Hunt–Crossley: F = K·δ^n·(1 + (3/2)·α·δ̇), α in s/m.
    HuntCrossley {
        /// Stiffness K, N/m^n.
        k: f64,
        /// Exponent n.
        n: f64,
        /// Damping factor α, s/m.
        alpha: f64,
    },
    /// Lankarani–Nikravesh: F = K·δ^n·(1 + 3(1 − e²)/4 · δ̇/v_ref).
    LankaraniNikravesh {
        /// Stiffness K, N/m^n.
        k: f64,
        /// Exponent n.
        n: f64,
        /// Coefficient of restitution e ∈ (0, 1].
        restitution: f64,
        /// Reference (impact) velocity, m/s.
        v_ref: f64,
    },
    /// Flores et al.: F = K·δ^n·(1 + 8(1 − e)/(5e) · δ̇/v_ref).
    Flores {
        /// Stiffness K, N/m^n.
        k: f64,
        /// Exponent n.
        n: f64,
        /// Coefficient of restitution e ∈ (0, 1].
        restitution: f64,
        /// Reference (impact) velocity, m/s.
        v_ref: f64,
    },
}

impl NormalLaw {
    /// Hertz law with exponent 1.5.
    pub fn hertz(k: f64) -> Self {
        NormalLaw::Hertz { k, n: 1.5 }
    }

    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), ContactError> {
        let (k, n) = self.stiffness();
        positive("contact stiffness K", k)?;
        positive("contact exponent n", n)?;
        match *self {
            NormalLaw::HuntCrossley { alpha, .. } if !(alpha >= 0.0 && alpha.is_finite()) => {
                Err(ContactError::OutOfRange {
                    what: "Hunt–Crossley damping α".into(),
                    range: "[0, ∞) s/m".into(),
                    value: alpha,
                })
            }
            NormalLaw::LankaraniNikravesh {
                restitution: e,
                v_ref,
                ..
            }
            | NormalLaw::Flores {
                restitution: e,
                v_ref,
                ..
            } => {
                if !(e > 0.0 && e <= 1.0) {
                    return Err(ContactError::OutOfRange {
                        what: "coefficient of restitution".into(),
                        range: "(0, 1]".into(),
                        value: e,
                    });
                }
                positive("reference velocity", v_ref).map(|_| ())
            }
            _ => Ok(()),
        }
    }

    /// (K, n).
    pub fn stiffness(&self) -> (f64, f64) {
        match *self {
            NormalLaw::Hertz { k, n }
            | NormalLaw::HuntCrossley { k, n, .. }
            | NormalLaw::LankaraniNikravesh { k, n, .. }
            | NormalLaw::Flores { k, n, .. } => (k, n),
        }
    }

    /// Damping factor χ such that F = K·δ^n·(1 + χ·δ̇), s/m.
    pub fn damping_factor(&self) -> f64 {
        match *self {
            NormalLaw::Hertz { .. } => 0.0,
            NormalLaw::HuntCrossley { alpha, .. } => 1.5 * alpha,
            NormalLaw::LankaraniNikravesh {
                restitution: e,
                v_ref,
                ..
            } => 3.0 * (1.0 - e * e) / (4.0 * v_ref),
            NormalLaw::Flores {
                restitution: e,
                v_ref,
                ..
            } => 8.0 * (1.0 - e) / (5.0 * e * v_ref),
        }
    }

    /// The same law with another stiffness.
    pub fn with_stiffness(&self, k_new: f64) -> Self {
        let mut s = *self;
        match &mut s {
            NormalLaw::Hertz { k, .. }
            | NormalLaw::HuntCrossley { k, .. }
            | NormalLaw::LankaraniNikravesh { k, .. }
            | NormalLaw::Flores { k, .. } => *k = k_new,
        }
        s
    }

    /// Normal force, N (≥ 0; the damping term cannot pull).
    pub fn force(&self, delta: f64, delta_rate: f64) -> f64 {
        self.force_with_derivatives(delta, delta_rate).0
    }

    /// The normal force (N) and its derivatives with respect to the penetration (N/m) and
    /// the penetration rate (N·s/m).
    pub fn force_with_derivatives(&self, delta: f64, delta_rate: f64) -> (f64, f64, f64) {
        if delta <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let (k, n) = self.stiffness();
        let c = self.damping_factor();
        // δ^(n−1) once; Hertz's n = 3/2 (the usual exponent) and n = 1 without a power.
        let d_nm1 = if n == 1.5 {
            delta.sqrt()
        } else if n == 1.0 {
            1.0
        } else {
            delta.powf(n - 1.0)
        };
        let elastic = k * delta * d_nm1;
        let damp = 1.0 + c * delta_rate;
        let f = elastic * damp;
        if f <= 0.0 {
            return (0.0, 0.0, 0.0);
        }
        (f, k * n * d_nm1 * damp, elastic * c)
    }
}

/// Coulomb friction regularised near zero slip: μ·F_n·tanh(v/v_s) opposing the slip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Friction {
    /// Coefficient of friction μ.
    pub mu: f64,
    /// Slip velocity over which the force builds up, m/s.
    pub v_slip: f64,
}

impl Friction {
    /// Tangential force magnitude factor for a slip speed (force = −factor·F_n·unit slip).
    pub fn factor(&self, slip_speed: f64) -> f64 {
        self.mu * (slip_speed / self.v_slip).tanh()
    }

    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), ContactError> {
        if !(self.mu >= 0.0 && self.mu.is_finite()) {
            return Err(ContactError::OutOfRange {
                what: "friction coefficient".into(),
                range: "[0, ∞)".into(),
                value: self.mu,
            });
        }
        positive("friction slip velocity", self.v_slip).map(|_| ())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn laws_vanish_without_penetration_and_damp_on_approach() {
        let laws = [
            NormalLaw::hertz(1e10),
            NormalLaw::HuntCrossley {
                k: 1e10,
                n: 1.5,
                alpha: 0.2,
            },
            NormalLaw::LankaraniNikravesh {
                k: 1e10,
                n: 1.5,
                restitution: 0.8,
                v_ref: 0.1,
            },
            NormalLaw::Flores {
                k: 1e10,
                n: 1.5,
                restitution: 0.8,
                v_ref: 0.1,
            },
        ];
        for l in laws {
            l.validate().unwrap();
            assert_eq!(l.force(-1e-6, 1.0), 0.0);
            let f = l.force(1e-6, 0.0);
            assert!((f - 1e10 * 1e-9).abs() < 1e-6);
            if l.damping_factor() > 0.0 {
                assert!(l.force(1e-6, 0.01) > f && l.force(1e-6, -0.01) < f);
            }
        }
        assert!(NormalLaw::Flores {
            k: 1.0,
            n: 1.5,
            restitution: 0.0,
            v_ref: 1.0
        }
        .validate()
        .is_err());
        assert!(NormalLaw::hertz(-1.0).validate().is_err());
    }
}
