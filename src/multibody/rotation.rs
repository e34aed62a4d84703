//! Euler parameters (unit quaternions p = (e0, e)) and the derivatives the equations of
//! motion and their Jacobians need (Haug, Computer-Aided Kinematics and Dynamics of
//! Mechanical Systems, ch. 6 and 11; Nikravesh, ch. 6).
//!
//! The rotation matrix is used in its homogeneous quadratic form
//! A(p) = (e0² − eᵀe)·I + 2·e·eᵀ + 2·e0·ẽ, which equals the usual one when pᵀp = 1 and keeps
//! A(p)·s' an exact quadratic form in p, so its first and second derivatives are closed-form.

use nalgebra::{Matrix3, Matrix3x4, Matrix4, Vector3, Vector4};

/// Skew-symmetric matrix ã with ã·b = a × b.
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Rotation matrix A(p) (homogeneous quadratic form).
pub fn rotation(p: &Vector4<f64>) -> Matrix3<f64> {
    let e0 = p[0];
    let e = Vector3::new(p[1], p[2], p[3]);
    Matrix3::identity() * (e0 * e0 - e.dot(&e)) + 2.0 * e * e.transpose() + 2.0 * e0 * skew(&e)
}

/// B(p, s') = ∂(A(p)·s')/∂p, a 3 × 4 matrix linear in p.
///
/// Columns 1–3 are 2·((eᵀs')·I + e·s'ᵀ − s'·eᵀ − e0·s̃'), written entry by entry (no 3 × 3
/// temporaries: the Jacobians call this a few hundred times per evaluation) in the order of
/// operations of the matrix expression, so the numbers are the same (up to the sign of an
/// exact zero, which the expression's 0·(eᵀs') could make negative).
#[inline]
pub fn d_rot(p: &Vector4<f64>, s: &Vector3<f64>) -> Matrix3x4<f64> {
    let e0 = p[0];
    let e = Vector3::new(p[1], p[2], p[3]);
    let c0 = 2.0 * (e0 * s + e.cross(s));
    let sd = s.dot(&e);
    let k = skew(s);
    let mut b = Matrix3x4::zeros();
    b.set_column(0, &c0);
    for j in 0..3 {
        for i in 0..3 {
            let id = if i == j { sd } else { 0.0 };
            b[(i, j + 1)] = 2.0 * (((id + e[i] * s[j]) - s[i] * e[j]) - e0 * k[(i, j)]);
        }
    }
    b
}

/// Hessian ∂²(μᵀ·A(p)·s')/∂p² (4 × 4, constant in p): the second-derivative term of a
/// constraint or force that contains a rotated body vector, weighted by μ.
pub fn d2_rot(mu: &Vector3<f64>, s: &Vector3<f64>) -> Matrix4<f64> {
    let ms = mu.dot(s);
    let c = s.cross(mu);
    let mut h = Matrix4::zeros();
    h[(0, 0)] = 2.0 * ms;
    for k in 0..3 {
        h[(0, k + 1)] = 2.0 * c[k];
        h[(k + 1, 0)] = 2.0 * c[k];
    }
    let ee = -2.0 * ms * Matrix3::identity() + 2.0 * (mu * s.transpose() + s * mu.transpose());
    h.fixed_view_mut::<3, 3>(1, 1).copy_from(&ee);
    h
}

/// L(p) = [−e, −ẽ + e0·I] (3 × 4): body angular velocity ω' = 2·L(p)·ṗ, and ṗ = ½·L(p)ᵀ·ω'
/// on pᵀp = 1.
pub fn l_matrix(p: &Vector4<f64>) -> Matrix3x4<f64> {
    let e0 = p[0];
    let e = Vector3::new(p[1], p[2], p[3]);
    let mut l = Matrix3x4::zeros();
    l.set_column(0, &(-e));
    l.fixed_view_mut::<3, 3>(0, 1)
        .copy_from(&(Matrix3::identity() * e0 - skew(&e)));
    l
}

/// The position coordinates' rates of a mechanism's bodies, q̇ = (v, ½·L(p)ᵀ·ω' − κ·(pᵀp − 1)·p)
/// per body, from positions `q` (7 per body: r in m, then p) and velocities `w` (6 per body:
/// v in m/s, then ω' in rad/s) into `out` (7 per body). `kappa` (1/s) pulls the Euler
/// parameters back to the unit sphere (the explicit ODE form's stabilisation); 0 gives the
/// plain kinematic rates.
pub(crate) fn position_rates(q: &[f64], w: &[f64], kappa: f64, out: &mut [f64]) {
    for ((qb, wb), ob) in q
        .chunks_exact(7)
        .zip(w.chunks_exact(6))
        .zip(out.chunks_exact_mut(7))
    {
        let p = Vector4::new(qb[3], qb[4], qb[5], qb[6]);
        let om = Vector3::new(wb[3], wb[4], wb[5]);
        let pd = 0.5 * l_matrix(&p).transpose() * om - kappa * (p.norm_squared() - 1.0) * p;
        ob[..3].copy_from_slice(&wb[..3]);
        ob[3..].copy_from_slice(pd.as_slice());
    }
}

/// Euler parameters of a rotation by `angle` (rad) about the unit `axis`.
pub fn from_axis_angle(axis: &Vector3<f64>, angle: f64) -> Vector4<f64> {
    let a = axis.normalize();
    let (s, c) = (0.5 * angle).sin_cos();
    Vector4::new(c, s * a.x, s * a.y, s * a.z)
}

/// Euler parameters of a proper rotation matrix (Shepperd's method).
pub fn from_matrix(a: &Matrix3<f64>) -> Vector4<f64> {
    let tr = a.trace();
    let p = if tr >= a[(0, 0)].max(a[(1, 1)]).max(a[(2, 2)]) {
        let e0 = 0.5 * (1.0 + tr).max(0.0).sqrt();
        Vector4::new(
            e0,
            (a[(2, 1)] - a[(1, 2)]) / (4.0 * e0),
            (a[(0, 2)] - a[(2, 0)]) / (4.0 * e0),
            (a[(1, 0)] - a[(0, 1)]) / (4.0 * e0),
        )
    } else if a[(0, 0)] >= a[(1, 1)] && a[(0, 0)] >= a[(2, 2)] {
        let e1 = 0.5 * (1.0 + 2.0 * a[(0, 0)] - tr).max(0.0).sqrt();
        Vector4::new(
            (a[(2, 1)] - a[(1, 2)]) / (4.0 * e1),
            e1,
            (a[(0, 1)] + a[(1, 0)]) / (4.0 * e1),
            (a[(0, 2)] + a[(2, 0)]) / (4.0 * e1),
        )
    } else if a[(1, 1)] >= a[(2, 2)] {
        let e2 = 0.5 * (1.0 + 2.0 * a[(1, 1)] - tr).max(0.0).sqrt();
        Vector4::new(
            (a[(0, 2)] - a[(2, 0)]) / (4.0 * e2),
            (a[(0, 1)] + a[(1, 0)]) / (4.0 * e2),
            e2,
            (a[(1, 2)] + a[(2, 1)]) / (4.0 * e2),
        )
    } else {
        let e3 = 0.5 * (1.0 + 2.0 * a[(2, 2)] - tr).max(0.0).sqrt();
        Vector4::new(
            (a[(1, 0)] - a[(0, 1)]) / (4.0 * e3),
            (a[(0, 2)] + a[(2, 0)]) / (4.0 * e3),
            (a[(1, 2)] + a[(2, 1)]) / (4.0 * e3),
            e3,
        )
    };
    if p[0] < 0.0 {
        -p
    } else {
        p
    }
}

/// Small-angle orientation error: the rotation vector taking `a_ref` to `a` (rad, in the
/// base frame), exact for any angle below π.
pub fn rotation_vector(a: &Matrix3<f64>, a_ref: &Matrix3<f64>) -> Vector3<f64> {
    let d = a * a_ref.transpose();
    let p = from_matrix(&d);
    let e = Vector3::new(p[1], p[2], p[3]);
    let s = e.norm();
    if s < 1e-300 {
        return Vector3::zeros();
    }
    e * (2.0 * s.atan2(p[0]) / s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p_test() -> Vector4<f64> {
        Vector4::new(0.8, 0.3, -0.4, 0.2).normalize()
    }

    #[test]
    fn rotation_is_orthonormal_and_matches_axis_angle() {
        let p = from_axis_angle(&Vector3::z(), std::f64::consts::FRAC_PI_2);
        let a = rotation(&p);
        assert!((a * Vector3::x() - Vector3::y()).norm() < 1e-15);
        let a = rotation(&p_test());
        assert!((a.transpose() * a - Matrix3::identity()).norm() < 1e-14);
        assert!((a.determinant() - 1.0).abs() < 1e-14);
        assert!((from_matrix(&a) - p_test()).norm() < 1e-14);
    }

    #[test]
    fn first_and_second_derivatives_match_finite_differences() {
        let p = Vector4::new(0.7, 0.2, -0.5, 0.4); // deliberately not normalised
        let s = Vector3::new(0.3, -1.2, 0.7);
        let mu = Vector3::new(-0.4, 0.9, 1.5);
        let b = d_rot(&p, &s);
        let h = d2_rot(&mu, &s);
        let eps = 1e-6;
        for k in 0..4 {
            let mut dp = Vector4::zeros();
            dp[k] = eps;
            let fd = (rotation(&(p + dp)) * s - rotation(&(p - dp)) * s) / (2.0 * eps);
            assert!((fd - b.column(k)).norm() < 1e-8, "B column {k}");
            let fd2 =
                (d_rot(&(p + dp), &s).transpose() * mu - d_rot(&(p - dp), &s).transpose() * mu) / (2.0 * eps);
            assert!((fd2 - h.column(k)).norm() < 1e-8, "H column {k}");
        }
    }

    #[test]
    fn angular_velocity_relation() {
        // ṗ = ½ Lᵀ ω' reproduces Ȧ = A·ω̃'.
        let p = p_test();
        let w = Vector3::new(0.3, -0.7, 1.1);
        let pdot = 0.5 * l_matrix(&p).transpose() * w;
        let eps = 1e-7;
        let adot = (rotation(&(p + eps * pdot)) - rotation(&(p - eps * pdot))) / (2.0 * eps);
        assert!((adot - rotation(&p) * skew(&w)).norm() < 1e-7);
        assert!((2.0 * l_matrix(&p) * pdot - w).norm() < 1e-14);
    }

    #[test]
    fn rotation_vector_recovers_small_rotations() {
        let a0 = rotation(&p_test());
        let dv = Vector3::new(1e-3, -2e-3, 0.5e-3);
        let a = rotation(&from_axis_angle(&dv, dv.norm())) * a0;
        assert!((rotation_vector(&a, &a0) - dv).norm() < 1e-15);
    }
}
