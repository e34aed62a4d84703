//! What the truth-sensitivity examples share: the drive torques' RMS difference between two
//! truth runs per time window, printed in torque-noise units.

use lash::mechanisms::mr2120::truth::TruthRun;

/// Prints `name` and, per drive A, B, C, the RMS of `base`'s torques less `other`'s over each
/// window [t0, t1) of `windows` (s), in units of `sigma` (N·m). The runs share their times.
pub fn print_torque_differences(
    name: &str,
    base: &TruthRun,
    other: &TruthRun,
    windows: &[(f64, f64)],
    sigma: f64,
) {
    let t = &base.t;
    let rms = |k: usize, (w0, w1): (f64, f64)| {
        let d: Vec<f64> = (0..t.len().min(other.t.len()))
            .filter(|&i| t[i] >= w0 && t[i] < w1)
            .map(|i| base.tau[k][i] - other.tau[k][i])
            .collect();
        (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt() / sigma
    };
    println!("{name}:");
    for (k, drive) in ["A", "B", "C"].iter().enumerate() {
        let cells: Vec<String> = windows
            .iter()
            .map(|&(w0, w1)| format!("{w0:.2}–{w1:.2} s: {:.2}", rms(k, (w0, w1))))
            .collect();
        println!("  drive {drive}:  {}", cells.join("  "));
    }
}
