//! Number formatting shared by the verdict, the localisation's findings and the reports.

/// A value with four significant-looking digits: fixed for ordinary magnitudes, exponent
/// for small ones (µm-scale outputs).
pub fn number(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}
