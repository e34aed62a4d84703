//! Files of the trajectory study (paper §4.1): the CSV of the ideal run and of each
//! clearance run, and their charts (PNG and SVG, with the `plot` feature).

use super::trajectory::{ClearanceRun, IdealRun};
use std::path::{Path, PathBuf};

/// Why the trajectory files could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The folder could not be created.
    #[error("cannot create {path}: {message}")]
    Create {
        /// Folder.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// A file could not be written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// File.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// A chart could not be drawn.
    #[error("plot {name}: {message}")]
    Plot {
        /// Chart name.
        name: String,
        /// What went wrong.
        message: String,
    },
}

/// Time windows of the clearance study's error table: label, start and end, s.
pub const ERROR_WINDOWS: [(&str, f64, f64); 4] = [
    ("t < 1.5 s", 0.0, 1.5),
    ("near M2, 1.5-2.5 s", 1.5, 2.5),
    ("2.5-3.4 s", 2.5, 3.4),
    ("near M3, > 3.4 s", 3.4, 4.0),
];

/// The largest absolute positioning errors of eq. (4.1) of one clearance run over one of
/// the [`ERROR_WINDOWS`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowErrors {
    /// The window's label.
    pub window: &'static str,
    /// Largest |d_xM|, |d_yM|, |d_zM|, m.
    pub d: [f64; 3],
    /// Largest |δx|, |δy|, |δz|, rad.
    pub delta: [f64; 3],
}

/// The error table of one clearance run: its largest errors over each of the
/// [`ERROR_WINDOWS`], in order.
pub fn window_errors(run: &ClearanceRun) -> Vec<WindowErrors> {
    ERROR_WINDOWS
        .iter()
        .map(|&(window, a, b)| {
            let m = super::trajectory::max_errors(&run.samples, a, b);
            WindowErrors {
                window,
                d: [m[0], m[1], m[2]],
                delta: [m[3], m[4], m[5]],
            }
        })
        .collect()
}

/// Names of the six positioning errors of eq. (4.1), in the order of
/// [`ErrorSample`](super::trajectory::ErrorSample)'s `d` then `delta`.
pub const ERROR_NAMES: [&str; 6] = ["d_xM", "d_yM", "d_zM", "delta_x", "delta_y", "delta_z"];

/// The ideal run as CSV: time (s), drive angles (deg), platform centre (m), its kinematic z
/// (m), deviation (m), rotation (rad), drive torques (N·m), singularity measure.
pub fn ideal_csv(run: &IdealRun) -> String {
    let mut csv = String::from("t_s,q1_deg,q2_deg,q3_deg,xM_m,yM_m,zM_m,zM_kinematic_m,deviation_m,rotation_rad,tau1_Nm,tau2_Nm,tau3_Nm,singularity\n");
    for s in &run.samples {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            s.t,
            s.q_deg[0],
            s.q_deg[1],
            s.q_deg[2],
            s.m[0],
            s.m[1],
            s.m[2],
            s.m_kinematic[2],
            s.deviation,
            s.rotation,
            s.torque[0],
            s.torque[1],
            s.torque[2],
            s.singularity
        ));
    }
    csv
}

/// Positioning errors in the units lash prints them in: d_xM, d_yM, d_zM in mm (from `d`,
/// m), then δx, δy, δz in degrees (from `delta`, rad).
pub fn in_mm_and_degrees(d: &[f64; 3], delta: &[f64; 3]) -> [f64; 6] {
    [
        d[0] * 1e3,
        d[1] * 1e3,
        d[2] * 1e3,
        delta[0].to_degrees(),
        delta[1].to_degrees(),
        delta[2].to_degrees(),
    ]
}

/// A clearance run's positioning errors as CSV: time (s), d_xM, d_yM, d_zM (mm), δx, δy,
/// δz (deg).
pub fn clearance_csv(run: &ClearanceRun) -> String {
    let mut csv = String::from("t_s,dxM_mm,dyM_mm,dzM_mm,dx_deg,dy_deg,dz_deg\n");
    for s in &run.samples {
        let [a, b, c, x, y, z] = in_mm_and_degrees(&s.d, &s.delta);
        csv.push_str(&format!("{},{a},{b},{c},{x},{y},{z}\n", s.t));
    }
    csv
}

fn create(dir: &Path) -> Result<(), OutputError> {
    std::fs::create_dir_all(dir).map_err(|e| OutputError::Create {
        path: dir.into(),
        message: e.to_string(),
    })
}

fn write(path: PathBuf, text: String) -> Result<PathBuf, OutputError> {
    std::fs::write(&path, text).map_err(|e| OutputError::Write {
        path: path.clone(),
        message: e.to_string(),
    })?;
    Ok(path)
}

/// Writes `dir/trajectory_ideal.csv` ([`ideal_csv`]) and, with the `plot` feature, the
/// charts drive_angles, platform_position, drive_torques and singularity (.png, .svg);
/// creates `dir`. Returns the CSV's path.
pub fn write_ideal(run: &IdealRun, dir: &Path) -> Result<PathBuf, OutputError> {
    create(dir)?;
    let csv = write(dir.join("trajectory_ideal.csv"), ideal_csv(run))?;
    #[cfg(feature = "plot")]
    charts::ideal(run, dir)?;
    Ok(csv)
}

/// Writes `dir/trajectory_<set>.csv` for every run ([`clearance_csv`]) and, with the `plot`
/// feature, one chart `error_<name>` (.png, .svg) per error of [`ERROR_NAMES`] with a line
/// per run; `dir` must exist.
pub fn write_clearance(runs: &[ClearanceRun], dir: &Path) -> Result<(), OutputError> {
    for run in runs {
        write(
            dir.join(format!("trajectory_{}.csv", run.set)),
            clearance_csv(run),
        )?;
    }
    #[cfg(feature = "plot")]
    charts::clearance(runs, dir)?;
    Ok(())
}

/// Creates the output folder of the clearance study (before its long runs start).
pub fn create_dir(dir: &Path) -> Result<(), OutputError> {
    create(dir)
}

#[cfg(feature = "plot")]
mod charts {
    use super::{ClearanceRun, IdealRun, OutputError, ERROR_NAMES};
    use crate::mechanisms::mr2120::trajectory::IdealSample;
    use crate::plot::{LineChart, Series};
    use std::path::Path;

    fn save(chart: &LineChart, dir: &Path, name: &str) -> Result<(), OutputError> {
        chart.save(&dir.join(name)).map_err(|e| OutputError::Plot {
            name: name.into(),
            message: e.to_string(),
        })
    }

    pub(super) fn ideal(run: &IdealRun, dir: &Path) -> Result<(), OutputError> {
        // Torques blow up at the singular end; scale the plot to 3x the range where regular.
        let regular: Vec<f64> = run
            .samples
            .iter()
            .filter(|s| s.singularity > 1e-2)
            .flat_map(|s| s.torque)
            .collect();
        let (tlo, thi) = regular
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
        let torque_range = (
            tlo - 2.0 * (thi - tlo).abs().max(1.0),
            thi + 2.0 * (thi - tlo).abs().max(1.0),
        );
        let series3 = |f: &dyn Fn(&IdealSample, usize) -> f64, names: [&str; 3]| -> Vec<Series> {
            (0..3)
                .map(|i| Series {
                    name: names[i].into(),
                    points: run.samples.iter().map(|s| (s.t, f(s, i))).collect(),
                })
                .collect()
        };
        let charts = [
            (
                "drive_angles",
                LineChart {
                    title: "MR2120 drive angles along M1-M2-M3 (ideal model)".into(),
                    x_label: "t [s]".into(),
                    y_label: "q [deg]".into(),
                    series: series3(&|s, i| s.q_deg[i], ["q1", "q2", "q3"]),
                    y_range: None,
                },
            ),
            (
                "platform_position",
                LineChart {
                    title: "Platform centre M (ideal model)".into(),
                    x_label: "t [s]".into(),
                    y_label: "coordinate [m]".into(),
                    series: series3(&|s, i| s.m[i], ["x_M", "y_M", "z_M"]),
                    y_range: None,
                },
            ),
            (
                "drive_torques",
                LineChart {
                    title: "Drive torques (ideal model; clipped near M3, full values in the CSV)".into(),
                    x_label: "t [s]".into(),
                    y_label: "torque [N m]".into(),
                    series: series3(&|s, i| s.torque[i], ["tau1", "tau2", "tau3"]),
                    y_range: Some(torque_range),
                },
            ),
            (
                "singularity",
                LineChart {
                    title: "Singularity measure of the constraint Jacobian".into(),
                    x_label: "t [s]".into(),
                    y_label: "sigma_min / sigma_max [-]".into(),
                    series: vec![Series {
                        name: "measure".into(),
                        points: run.samples.iter().map(|s| (s.t, s.singularity)).collect(),
                    }],
                    y_range: None,
                },
            ),
        ];
        for (stem, chart) in &charts {
            save(chart, dir, stem)?;
        }
        Ok(())
    }

    pub(super) fn clearance(runs: &[ClearanceRun], dir: &Path) -> Result<(), OutputError> {
        for (k, name) in ERROR_NAMES.iter().enumerate() {
            let unit = if k < 3 { "mm" } else { "deg" };
            let series = runs
                .iter()
                .map(|r| Series {
                    name: r.set.clone(),
                    points: r
                        .samples
                        .iter()
                        .map(|s| (s.t, super::in_mm_and_degrees(&s.d, &s.delta)[k]))
                        .collect(),
                })
                .collect();
            let chart = LineChart {
                title: format!("MR2120 positioning error {name} along M1-M2-M3 (eq. 4.1)"),
                x_label: "t [s]".into(),
                y_label: format!("{name} [{unit}]"),
                series,
                y_range: None,
            };
            chart
                .save(&dir.join(format!("error_{name}")))
                .map_err(|e| OutputError::Plot {
                    name: name.to_string(),
                    message: e.to_string(),
                })?;
        }
        Ok(())
    }
}
