//! Andrews' squeezing mechanism (Hairer & Wanner II, sec. VII.7; Bari test set `andrews`):
//! a planar seven-body mechanism driven by a constant torque, 27 unknowns
//! y = (q, v, w, λ) with q the seven angles, v = q', w = q'', λ the six multipliers.
//!
//! Residual (index 2):  q' − v = 0,  v' − w = 0,  M(q)w − f(q, v) + G(q)ᵀλ = 0,  G(q)v = 0.
//! Index 1 replaces the last block by  g_qq(q, v) + G(q)w = 0.
//!
//! The iteration matrix is computed by lash's coloured finite differences (this problem is
//! the validation of that path); the pattern is declared block by block.

use crate::dae::{DaeSystem, EvalError, VarKind};
use crate::sparse::CscPattern;

/// Which constraint level closes the system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AndrewsIndex {
    /// Velocity constraints G(q)v = 0.
    Two,
    /// Acceleration constraints g_qq(q, v) + G(q)w = 0.
    One,
    /// Gear–Gupta–Leimkuhler stabilised index 2: velocity constraints G(q)v = 0 and position
    /// constraints g(q) = 0 with six more multipliers μ in q' = v − G(q)ᵀμ (33 unknowns).
    Ggl,
}

impl AndrewsIndex {
    /// Number of unknowns of the formulation.
    pub fn dim(self) -> usize {
        if self == AndrewsIndex::Ggl {
            33
        } else {
            27
        }
    }
}

// Constants of the Bari test set (kg, m, N/m, kg·m², N·m).
const M1: f64 = 0.04325;
const M2: f64 = 0.00365;
const M3: f64 = 0.02373;
const M4: f64 = 0.00706;
const M5: f64 = 0.07050;
const M6: f64 = 0.00706;
const M7: f64 = 0.05498;
const XA: f64 = -0.06934;
const YA: f64 = -0.00227;
const XB: f64 = -0.03635;
const YB: f64 = 0.03273;
const XC: f64 = 0.014;
const YC: f64 = 0.072;
const C0: f64 = 4530.0;
const I1: f64 = 2.194e-6;
const I2: f64 = 4.410e-7;
const I3: f64 = 5.255e-6;
const I4: f64 = 5.667e-7;
const I5: f64 = 1.169e-5;
const I6: f64 = 5.667e-7;
const I7: f64 = 1.912e-5;
const D: f64 = 0.028;
const DA: f64 = 0.0115;
const E: f64 = 0.02;
const EA: f64 = 0.01421;
const RR: f64 = 0.007;
const RA: f64 = 0.00092;
const L0: f64 = 0.07785;
const SS: f64 = 0.035;
const SA: f64 = 0.01874;
const SB: f64 = 0.01043;
const SC: f64 = 0.018;
const SD: f64 = 0.02;
const TA: f64 = 0.02308;
const TB: f64 = 0.00916;
const U: f64 = 0.04;
const UA: f64 = 0.01228;
const UB: f64 = 0.00449;
const ZF: f64 = 0.02;
const ZT: f64 = 0.04;
const FA: f64 = 0.01421;
const MOM: f64 = 0.033;

/// Consistent initial values y0 (27 components) of the test set.
pub fn initial_values() -> (Vec<f64>, Vec<f64>) {
    initial_values_for(AndrewsIndex::Two)
}

/// Consistent initial values for a formulation (μ = 0 for GGL).
pub fn initial_values_for(index: AndrewsIndex) -> (Vec<f64>, Vec<f64>) {
    let mut y = vec![0.0; index.dim()];
    y[0] = -0.0617138900142764496358948458001;
    y[1] = 0.0;
    y[2] = 0.455279819163070380255912382449;
    y[3] = 0.222668390165885884674473185609;
    y[4] = 0.487364979543842550225598953530;
    y[5] = -0.222668390165885884674473185609;
    y[6] = 1.23054744454982119249735015568;
    y[14] = 14222.4439199541138705911625887;
    y[15] = -10666.8329399655854029433719415;
    y[21] = 98.5668703962410896057654982170;
    y[22] = -6.12268834425566265503114393122;
    let mut yp = vec![0.0; index.dim()];
    yp[..14].copy_from_slice(&y[7..21]);
    (y, yp)
}

/// Largest relative error of the seven angles in `y` against the published values at
/// t = 0.03 s.
pub fn angle_error(y: &[f64]) -> f64 {
    let r = &super::reference::ANDREWS_ANGLES_T003;
    (0..7).map(|i| ((y[i] - r[i]) / r[i]).abs()).fold(0.0, f64::max)
}

/// Mass matrix M(q) (7 × 7, symmetric).
pub fn mass_matrix(q: &[f64]) -> [[f64; 7]; 7] {
    let coth = q[1].cos();
    let siph = q[3].sin();
    let siom = q[5].sin();
    let mut m = [[0.0; 7]; 7];
    m[0][0] = M1 * RA * RA + M2 * (RR * RR - 2.0 * DA * RR * coth + DA * DA) + I1 + I2;
    m[1][0] = M2 * (DA * DA - DA * RR * coth) + I2;
    m[1][1] = M2 * DA * DA + I2;
    m[2][2] = M3 * (SA * SA + SB * SB) + I3;
    m[3][3] = M4 * (E - EA).powi(2) + I4;
    m[4][3] = M4 * ((E - EA).powi(2) + ZT * (E - EA) * siph) + I4;
    m[4][4] =
        M4 * (ZT * ZT + 2.0 * ZT * (E - EA) * siph + (E - EA).powi(2)) + M5 * (TA * TA + TB * TB) + I4 + I5;
    m[5][5] = M6 * (ZF - FA).powi(2) + I6;
    m[6][5] = M6 * ((ZF - FA).powi(2) - U * (ZF - FA) * siom) + I6;
    m[6][6] =
        M6 * ((ZF - FA).powi(2) - 2.0 * U * (ZF - FA) * siom + U * U) + M7 * (UA * UA + UB * UB) + I6 + I7;
    for i in 0..7 {
        for j in 0..i {
            m[j][i] = m[i][j];
        }
    }
    m
}

/// Applied forces f(q, v) (7).
pub fn forces(q: &[f64], v: &[f64]) -> [f64; 7] {
    let (sith, coth) = q[1].sin_cos();
    let (siga, coga) = q[2].sin_cos();
    let coph = q[3].cos();
    let coom = q[5].cos();
    let (bep, thp, php, dep, omp, epp) = (v[0], v[1], v[3], v[4], v[5], v[6]);
    let _ = coth;
    let xd = SD * coga + SC * siga + XB;
    let yd = SD * siga - SC * coga + YB;
    let lang = ((xd - XC).powi(2) + (yd - YC).powi(2)).sqrt();
    let force = -C0 * (lang - L0) / lang;
    let fx = force * (xd - XC);
    let fy = force * (yd - YC);
    [
        MOM - M2 * DA * RR * thp * (thp + 2.0 * bep) * sith,
        M2 * DA * RR * bep * bep * sith,
        fx * (SC * coga - SD * siga) + fy * (SD * coga + SC * siga),
        M4 * ZT * (E - EA) * dep * dep * coph,
        -M4 * ZT * (E - EA) * php * (php + 2.0 * dep) * coph,
        -M6 * U * (ZF - FA) * epp * epp * coom,
        M6 * U * (ZF - FA) * omp * (omp + 2.0 * epp) * coom,
    ]
}

/// Constraint Jacobian G(q) = dg/dq (6 × 7).
pub fn constraint_jacobian(q: &[f64]) -> [[f64; 7]; 6] {
    let (sibe, cobe) = q[0].sin_cos();
    let (siga, coga) = q[2].sin_cos();
    let (sibeth, cobeth) = (q[0] + q[1]).sin_cos();
    let (siphde, cophde) = (q[3] + q[4]).sin_cos();
    let (side, code) = q[4].sin_cos();
    let (siomep, coomep) = (q[5] + q[6]).sin_cos();
    let (siep, coep) = q[6].sin_cos();
    let mut g = [[0.0; 7]; 6];
    for r in [0, 2, 4] {
        g[r][0] = -RR * sibe + D * sibeth;
        g[r][1] = D * sibeth;
    }
    for r in [1, 3, 5] {
        g[r][0] = RR * cobe - D * cobeth;
        g[r][1] = -D * cobeth;
    }
    g[0][2] = -SS * coga;
    g[1][2] = -SS * siga;
    g[2][3] = -E * cophde;
    g[2][4] = -E * cophde + ZT * side;
    g[3][3] = -E * siphde;
    g[3][4] = -E * siphde - ZT * code;
    g[4][5] = ZF * siomep;
    g[4][6] = ZF * siomep - U * coep;
    g[5][5] = -ZF * coomep;
    g[5][6] = -ZF * coomep - U * siep;
    g
}

/// Position constraints g(q) (6).
pub fn constraints(q: &[f64]) -> [f64; 6] {
    let (sibe, cobe) = q[0].sin_cos();
    let (siga, coga) = q[2].sin_cos();
    let (sibeth, cobeth) = (q[0] + q[1]).sin_cos();
    let (siphde, cophde) = (q[3] + q[4]).sin_cos();
    let (side, code) = q[4].sin_cos();
    let (siomep, coomep) = (q[5] + q[6]).sin_cos();
    let (siep, coep) = q[6].sin_cos();
    [
        RR * cobe - D * cobeth - SS * siga - XB,
        RR * sibe - D * sibeth + SS * coga - YB,
        RR * cobe - D * cobeth - E * siphde - ZT * code - XA,
        RR * sibe - D * sibeth + E * cophde - ZT * side - YA,
        RR * cobe - D * cobeth - ZF * coomep - U * siep - XA,
        RR * sibe - D * sibeth - ZF * siomep + U * coep - YA,
    ]
}

/// Second-derivative terms g_qq(q)(v, v) of the constraints (6).
pub fn gqq(q: &[f64], v: &[f64]) -> [f64; 6] {
    let (sibe, cobe) = q[0].sin_cos();
    let (siga, coga) = q[2].sin_cos();
    let (sibeth, cobeth) = (q[0] + q[1]).sin_cos();
    let (siphde, cophde) = (q[3] + q[4]).sin_cos();
    let (side, code) = q[4].sin_cos();
    let (siomep, coomep) = (q[5] + q[6]).sin_cos();
    let (siep, coep) = q[6].sin_cos();
    let (bep, thp, gap, php, dep, omp, epp) = (v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    let bt = (bep + thp).powi(2);
    let pd = (php + dep).powi(2);
    let oe = (omp + epp).powi(2);
    [
        -RR * cobe * bep * bep + D * cobeth * bt + SS * siga * gap * gap,
        -RR * sibe * bep * bep + D * sibeth * bt - SS * coga * gap * gap,
        -RR * cobe * bep * bep + D * cobeth * bt + E * siphde * pd + ZT * code * dep * dep,
        -RR * sibe * bep * bep + D * sibeth * bt - E * cophde * pd + ZT * side * dep * dep,
        -RR * cobe * bep * bep + D * cobeth * bt + ZF * coomep * oe + U * siep * epp * epp,
        -RR * sibe * bep * bep + D * sibeth * bt + ZF * siomep * oe - U * coep * epp * epp,
    ]
}

/// The squeezer as a [`DaeSystem`] in the 27-unknown form (33 for GGL).
#[derive(Debug, Clone)]
pub struct Andrews {
    /// Constraint level.
    pub index: AndrewsIndex,
    /// Project accepted steps onto g(q) = 0 and G(q)v = 0 (only meaningful for index 1,
    /// whose solution otherwise drifts off both).
    pub project: bool,
}

impl Andrews {
    /// The formulation without projection.
    pub fn new(index: AndrewsIndex) -> Self {
        Self {
            index,
            project: false,
        }
    }
}

/// Solves the 6 × 6 system A·x = b in place (Gaussian elimination, partial pivoting).
fn solve6(mut a: [[f64; 6]; 6], b: &mut [f64; 6]) -> bool {
    for c in 0..6 {
        let p = (c..6)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap_or(c);
        if a[p][c] == 0.0 {
            return false;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..6 {
            let f = a[r][c] / a[c][c];
            for k in c..6 {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    for c in (0..6).rev() {
        let s: f64 = (c + 1..6).map(|k| a[c][k] * b[k]).sum();
        b[c] = (b[c] - s) / a[c][c];
    }
    true
}

/// Minimum-norm correction x ← x − Gᵀ(GGᵀ)⁻¹·r.
fn correct(g: &[[f64; 7]; 6], r: [f64; 6], x: &mut [f64]) -> bool {
    let mut ggt = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..6 {
            ggt[i][j] = (0..7).map(|k| g[i][k] * g[j][k]).sum();
        }
    }
    let mut m = r;
    if !solve6(ggt, &mut m) {
        return false;
    }
    for k in 0..7 {
        x[k] -= (0..6).map(|i| g[i][k] * m[i]).sum::<f64>();
    }
    true
}

const NAMES: [&str; 7] = ["beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon"];

impl DaeSystem for Andrews {
    fn dim(&self) -> usize {
        self.index.dim()
    }

    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        let (q, v, w, lam) = (&y[0..7], &y[7..14], &y[14..21], &y[21..27]);
        for i in 0..7 {
            r[i] = yp[i] - v[i];
            r[7 + i] = yp[7 + i] - w[i];
        }
        let m = mass_matrix(q);
        let f = forces(q, v);
        let g = constraint_jacobian(q);
        for i in 0..7 {
            let mut s = -f[i];
            for j in 0..7 {
                s += m[i][j] * w[j];
            }
            for (k, gk) in g.iter().enumerate() {
                s += gk[i] * lam[k];
            }
            r[14 + i] = s;
        }
        let extra = match self.index {
            AndrewsIndex::One => gqq(q, v),
            _ => [0.0; 6],
        };
        for k in 0..6 {
            let x = match self.index {
                AndrewsIndex::One => w,
                _ => v,
            };
            r[21 + k] = extra[k] + (0..7).map(|j| g[k][j] * x[j]).sum::<f64>();
        }
        if self.index == AndrewsIndex::Ggl {
            let mu = &y[27..33];
            for i in 0..7 {
                r[i] += (0..6).map(|k| g[k][i] * mu[k]).sum::<f64>();
            }
            let gp = constraints(q);
            r[27..33].copy_from_slice(&gp);
        }
        Ok(())
    }

    fn jacobian_pattern(&self) -> CscPattern {
        let mut e = Vec::new();
        for i in 0..7 {
            e.push((i, i)); // q' in row i
            e.push((i, 7 + i)); // -v
            e.push((7 + i, 7 + i)); // v'
            e.push((7 + i, 14 + i)); // -w
        }
        for i in 14..21 {
            for c in 0..27 {
                e.push((i, c));
            }
        }
        for i in 21..27 {
            for c in 0..14 {
                e.push((i, c));
            }
            if self.index == AndrewsIndex::One {
                for c in 14..21 {
                    e.push((i, c));
                }
            }
        }
        if self.index == AndrewsIndex::Ggl {
            for i in 0..7 {
                for c in 0..7 {
                    e.push((i, c));
                }
                for c in 27..33 {
                    e.push((i, c));
                }
            }
            for i in 27..33 {
                for c in 0..7 {
                    e.push((i, c));
                }
            }
        }
        let n = self.index.dim();
        CscPattern::from_entries(n, n, e).expect("static pattern is valid")
    }

    fn project(&mut self, _t: f64, y: &mut [f64], _p: &[f64]) -> bool {
        if !self.project {
            return false;
        }
        for _ in 0..3 {
            let g = constraint_jacobian(&y[0..7]);
            let r = constraints(&y[0..7]);
            if !correct(&g, r, &mut y[0..7]) {
                return false;
            }
        }
        let g = constraint_jacobian(&y[0..7]);
        let mut gv = [0.0; 6];
        for (k, row) in g.iter().enumerate() {
            gv[k] = (0..7).map(|j| row[j] * y[7 + j]).sum();
        }
        correct(&g, gv, &mut y[7..14])
    }

    fn var_kinds(&self) -> Vec<VarKind> {
        (0..self.index.dim())
            .map(|i| {
                if i < 14 {
                    VarKind::Differential
                } else {
                    VarKind::Algebraic
                }
            })
            .collect()
    }

    fn component_name(&self, i: usize) -> String {
        match i {
            0..=6 => NAMES[i].to_string(),
            7..=13 => format!("{}'", NAMES[i - 7]),
            14..=20 => format!("{}''", NAMES[i - 14]),
            21..=26 => format!("lambda{}", i - 20),
            _ => format!("mu{}", i - 26),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn initial_values_are_consistent() {
        let (y, yp) = initial_values();
        for idx in [AndrewsIndex::One, AndrewsIndex::Two] {
            let mut r = vec![0.0; 27];
            Andrews::new(idx).residual(0.0, &y, &yp, &[], &mut r).unwrap();
            let worst = r.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            assert!(worst < 1e-10, "{idx:?}: {worst}");
        }
        assert!(constraints(&y[..7]).iter().all(|g| g.abs() < 1e-15));
    }

    #[test]
    fn gqq_matches_published_check_values() {
        let (y, _) = initial_values();
        let v = [1.3, -0.7, 0.4, 2.1, -1.1, 0.9, -0.5];
        let expect = [
            0.0007157278957204472,
            -0.004921642162864707,
            0.05405529630875641,
            0.0076068140115984235,
            0.009387745790053647,
            -0.0005230403430121137,
        ];
        let got = gqq(&y[..7], &v);
        for k in 0..6 {
            assert!(
                (got[k] - expect[k]).abs() < 1e-12 * (1.0 + expect[k].abs()),
                "{k}"
            );
        }
    }
}
