//! Hertz contact stiffness K (F = K·δ^1.5) from geometry and materials.
//!
//! Elliptical contacts use the simplified closed forms of Brewe & Hamrock (1977, J.
//! Lubrication Technology 99:485) for the ellipticity k = α^(2/π), the elliptic integrals
//! 𝓔 = 1 + (π/2 − 1)/α and 𝓕 = π/2 + (π/2 − 1)·ln α (α = R_y/R_x ≥ 1), and the
//! load–deflection relation δ = 𝓕·[(9/(2𝓔R))·(W/(πkE'))²]^(1/3), 1/R = 1/R_x + 1/R_y,
//! E' = 2E*. They reduce exactly to Hertz's K = (4/3)·E*·√R_x for a circular contact.

use super::{positive, ContactError};

/// An elastic material.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Young's modulus, Pa.
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
}

impl Material {
    /// Structural steel: E = 210 GPa, ν = 0.3 (the values of the reference paper).
    pub fn steel() -> Self {
        Self { e: 2.1e11, nu: 0.3 }
    }

    /// Checks E > 0 and −1 < ν < 0.5.
    pub fn validate(&self) -> Result<(), ContactError> {
        positive("Young's modulus E", self.e)?;
        if !(self.nu > -1.0 && self.nu < 0.5) {
            return Err(ContactError::OutOfRange {
                what: "Poisson's ratio".into(),
                range: "(−1, 0.5)".into(),
                value: self.nu,
            });
        }
        Ok(())
    }
}

/// Contact modulus E* = 1/((1 − ν1²)/E1 + (1 − ν2²)/E2), Pa.
pub fn contact_modulus(a: &Material, b: &Material) -> f64 {
    1.0 / ((1.0 - a.nu * a.nu) / a.e + (1.0 - b.nu * b.nu) / b.e)
}

/// K for two bodies with principal relative radii of curvature rx, ry (m, both > 0).
pub fn elliptic_k(rx: f64, ry: f64, a: &Material, b: &Material) -> f64 {
    let (rx, ry) = if rx <= ry { (rx, ry) } else { (ry, rx) };
    let e_prime = 2.0 * contact_modulus(a, b);
    let half_pi = std::f64::consts::FRAC_PI_2;
    let alpha = ry / rx;
    let k = alpha.powf(1.0 / half_pi);
    let eps = 1.0 + (half_pi - 1.0) / alpha;
    let f = half_pi + (half_pi - 1.0) * alpha.ln();
    let r = 1.0 / (1.0 / rx + 1.0 / ry);
    std::f64::consts::PI * k * e_prime * (2.0 * eps * r / 9.0).sqrt() / f.powf(1.5)
}

/// K of a ball (radius r_ball) in a cylindrical bore (radius r_bore > r_ball): contact of a
/// sphere inside a concave cylinder, N/m^1.5.
pub fn ball_in_bore(r_ball: f64, r_bore: f64, a: &Material, b: &Material) -> Result<f64, ContactError> {
    positive("ball radius", r_ball)?;
    positive("bore radius", r_bore)?;
    a.validate()?;
    b.validate()?;
    if r_ball > r_bore {
        return Err(ContactError::BallLargerThanSocket {
            ball: r_ball,
            socket: r_bore,
        });
    }
    // Across the bore axis: 1/R = 1/r_ball − 1/r_bore; along it: R = r_ball. A ball that
    // fits exactly has an infinite transverse radius: cap it to keep K finite (line contact).
    let transverse = if r_bore > r_ball {
        1.0 / (1.0 / r_ball - 1.0 / r_bore)
    } else {
        f64::INFINITY
    };
    let transverse = transverse.min(1e4 * r_ball);
    Ok(elliptic_k(r_ball, transverse, a, b))
}

/// K of a ball (radius r_ball) on a flat face, N/m^1.5.
pub fn ball_on_flat(r_ball: f64, a: &Material, b: &Material) -> Result<f64, ContactError> {
    positive("ball radius", r_ball)?;
    a.validate()?;
    b.validate()?;
    Ok(4.0 / 3.0 * contact_modulus(a, b) * r_ball.sqrt())
}

/// K of a ball (radius r_ball) in a spherical socket (radius r_socket > r_ball), N/m^1.5.
pub fn ball_in_socket(r_ball: f64, r_socket: f64, a: &Material, b: &Material) -> Result<f64, ContactError> {
    positive("ball radius", r_ball)?;
    positive("socket radius", r_socket)?;
    a.validate()?;
    b.validate()?;
    if r_ball > r_socket {
        return Err(ContactError::BallLargerThanSocket {
            ball: r_ball,
            socket: r_socket,
        });
    }
    let r = if r_socket > r_ball {
        (1.0 / (1.0 / r_ball - 1.0 / r_socket)).min(1e4 * r_ball)
    } else {
        1e4 * r_ball
    };
    Ok(4.0 / 3.0 * contact_modulus(a, b) * r.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circular_limit_and_ordering() {
        let s = Material::steel();
        let flat = ball_on_flat(0.004, &s, &s).unwrap();
        // Exact Hertz: 4/3 · E/(2(1−ν²)) · √R.
        let exact = 4.0 / 3.0 * 2.1e11 / (2.0 * 0.91) * 0.004f64.sqrt();
        assert!((flat - exact).abs() < 1e-6 * exact);
        // The elliptic formulas reduce to Hertz's circular contact.
        let circ = elliptic_k(0.004, 0.004, &s, &s);
        assert!((circ / flat - 1.0).abs() < 1e-12, "{circ} vs {flat}");
        // Conformal contacts are stiffer than a ball on a flat.
        let bore = ball_in_bore(0.004, 0.00402, &s, &s).unwrap();
        let socket = ball_in_socket(0.004, 0.00402, &s, &s).unwrap();
        assert!(bore > flat && socket > bore, "{flat} {bore} {socket}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let s = Material::steel();
        assert!(matches!(
            ball_in_bore(0.005, 0.004, &s, &s),
            Err(ContactError::BallLargerThanSocket { .. })
        ));
        assert!(matches!(
            ball_on_flat(0.0, &s, &s),
            Err(ContactError::NonPositive { .. })
        ));
        let bad = Material { e: -1.0, nu: 0.3 };
        assert!(ball_on_flat(0.004, &bad, &s).is_err());
    }
}
