//! Simulating a model file's mechanism and reading its sensors: what `lash simulate` writes.

use super::build::BuiltModel;
use super::sensors::{SensorKind, SensorTarget};
use crate::multibody::{ModelError, RunEnd, Simulation, SimulationOptions};
use serde::Serialize;
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// Every sensor's series from one simulation.
#[derive(Debug, Clone, Serialize)]
pub struct SensorRecord {
    /// Column names and units (see [`BuiltModel::sensor_columns`]).
    pub columns: Vec<(String, String)>,
    /// Sample times, s.
    pub t: Vec<f64>,
    /// One row per sample, one value per column.
    pub rows: Vec<Vec<f64>>,
    /// How the run ended.
    pub end: RunEnd,
}

/// Simulates `built` from t = 0 to `t_end` (s), sampling every `dt` (s), and reads every
/// sensor at every sample (rotational joint positions unwrapped). `progress` gets the time
/// reached, s.
pub fn simulate(
    built: BuiltModel,
    t_end: f64,
    dt: f64,
    opts: SimulationOptions,
    progress: impl FnMut(f64),
) -> Result<(BuiltModel, SensorRecord), ModelError> {
    let times = crate::multibody::output_times(t_end, dt)?;
    let BuiltModel {
        mechanism,
        bodies,
        markers,
        joints,
        drivers,
        forces,
        sensors,
    } = built;
    let model = Arc::new(mechanism);
    let mut sim = Simulation::new(model.clone(), 0.0, opts)?;
    let traj = sim.run(&times, progress)?;
    drop(sim);
    let mechanism = Arc::try_unwrap(model)
        .map_err(|_| ModelError::Output("the mechanism is still shared after the simulation".into()))?;
    let built = BuiltModel {
        mechanism,
        bodies,
        markers,
        joints,
        drivers,
        forces,
        sensors,
    };
    let record = read_record(&built, &traj.samples, traj.end)?;
    Ok((built, record))
}

fn read_record(
    built: &BuiltModel,
    samples: &[crate::multibody::Sample],
    end: RunEnd,
) -> Result<SensorRecord, ModelError> {
    let columns: Vec<(String, String)> = built
        .sensor_columns()
        .into_iter()
        .map(|(a, b)| (a, b.to_string()))
        .collect();
    let need_acc = built.needs_accelerations();
    let analysis = crate::multibody::Analysis::new(&built.mechanism)?;
    let mut data = crate::multibody::MechanismData::new(&built.mechanism);
    let mut rows = Vec::with_capacity(samples.len());
    for s in samples {
        let wdot = if need_acc {
            Some(
                analysis
                    .accelerations(&built.mechanism, &mut data, s.t, &s.q, &s.w)?
                    .0,
            )
        } else {
            None
        };
        rows.push(built.read_sensors(s, wdot.as_deref()));
    }
    // Unwrap rotational joint positions.
    let mut col = 0;
    for sensor in &built.sensors {
        let width = match sensor.kind {
            SensorKind::BodyPosition => 3,
            SensorKind::BodyOrientation => 4,
            _ => 1,
        };
        let rotational = matches!(sensor.target, SensorTarget::Joint(k)
            if built.joints[k].coordinate_dimension() == Some(super::units::Dimension::Angle));
        if sensor.kind == SensorKind::JointPosition && rotational {
            for k in 1..rows.len() {
                let d = rows[k][col] - rows[k - 1][col];
                let turns = (d / std::f64::consts::TAU).round();
                if turns != 0.0 {
                    for r in rows[k..].iter_mut() {
                        r[col] -= turns * std::f64::consts::TAU;
                    }
                }
            }
        }
        col += width;
    }
    Ok(SensorRecord {
        columns,
        t: samples.iter().map(|s| s.t).collect(),
        rows,
        end,
    })
}

impl SensorRecord {
    /// Writes `time` (s) and every sensor column under its sensor's name (SI units, as
    /// [`columns`](Self::columns) and `lash check` list them), so the file reads back as a
    /// recording of the same model (`lash diagnose --model FILE.toml`).
    pub fn write_csv(&self, path: &Path) -> Result<(), ModelError> {
        let io = |e: std::io::Error| ModelError::Output(format!("{}: {e}", path.display()));
        let mut f = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        write!(f, "time").map_err(io)?;
        for (c, _) in &self.columns {
            write!(f, ",{c}").map_err(io)?;
        }
        writeln!(f).map_err(io)?;
        for (t, r) in self.t.iter().zip(&self.rows) {
            write!(f, "{t}").map_err(io)?;
            for v in r {
                write!(f, ",{v}").map_err(io)?;
            }
            writeln!(f).map_err(io)?;
        }
        f.flush().map_err(io)
    }

    /// One chart per sensor column against time: `<dir>/<column>.png` and `.svg`.
    #[cfg(feature = "plot")]
    pub fn plot(&self, dir: &Path) -> Result<Vec<std::path::PathBuf>, ModelError> {
        let mut out = vec![];
        for (k, (c, u)) in self.columns.iter().enumerate() {
            let chart = crate::plot::LineChart {
                title: c.clone(),
                x_label: "t [s]".into(),
                y_label: format!("{c} [{u}]"),
                series: vec![crate::plot::Series {
                    name: c.clone(),
                    points: self.t.iter().zip(&self.rows).map(|(t, r)| (*t, r[k])).collect(),
                }],
                y_range: None,
            };
            let stem = dir.join(sanitize(c));
            chart.save(&stem).map_err(ModelError::Output)?;
            out.push(stem.with_extension("png"));
        }
        Ok(out)
    }
}

#[cfg(feature = "plot")]
fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model_file::ModelFile;
    use std::path::PathBuf;

    fn shipped(name: &str) -> ModelFile {
        let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("models")
            .join(name);
        ModelFile::load(&p).unwrap_or_else(|e| panic!("{e}"))
    }

    fn column(r: &SensorRecord, name: &str) -> Vec<f64> {
        let k = r.columns.iter().position(|(c, _)| c == name).unwrap();
        r.rows.iter().map(|row| row[k]).collect()
    }

    /// The shipped slider-crank against its closed form: with the crank at θ = ωt the slider
    /// sits at x = r cos θ + √(l² − r² sin² θ); its rate and the crank pin follow.
    #[test]
    fn the_slider_crank_file_moves_as_its_closed_form() {
        let file = shipped("slider_crank.toml");
        let (_, rec) = simulate(
            file.build().unwrap(),
            1.0,
            1e-3,
            SimulationOptions::default(),
            |_| {},
        )
        .unwrap();
        assert_eq!(rec.end, RunEnd::Completed);
        let (r, l, w) = (0.1, 0.3, std::f64::consts::TAU);
        let (x, v, a) = (
            column(&rec, "slider_x"),
            column(&rec, "slider_v"),
            column(&rec, "slider_a"),
        );
        let (theta, px, py) = (
            column(&rec, "crank_angle"),
            column(&rec, "pin_x"),
            column(&rec, "pin_y"),
        );
        let mut worst = [0.0f64; 5];
        for (k, &t) in rec.t.iter().enumerate() {
            let th = w * t;
            let root = (l * l - r * r * th.sin().powi(2)).sqrt();
            let xe = r * th.cos() + root;
            let ve = -r * w * th.sin() - r * r * w * th.sin() * th.cos() / root;
            worst[0] = worst[0].max((x[k] - xe).abs());
            worst[1] = worst[1].max((v[k] - ve).abs());
            worst[2] = worst[2].max((theta[k] - th).abs());
            worst[3] = worst[3].max((px[k] - r * th.cos()).abs().max((py[k] - r * th.sin()).abs()));
            if k > 0 && k + 1 < rec.t.len() {
                // Central difference of the sensor's own velocity (O(dt²) ≈ 1e-4 m/s²).
                let fd = (v[k + 1] - v[k - 1]) / (rec.t[k + 1] - rec.t[k - 1]);
                worst[4] = worst[4].max((a[k] - fd).abs());
            }
        }
        assert!(worst[0] < 1e-7, "slider x off by {:e} m", worst[0]);
        assert!(worst[1] < 1e-6, "slider v off by {:e} m/s", worst[1]);
        assert!(
            worst[2] < 1e-7,
            "crank angle off by {:e} rad (unwrapped over a turn)",
            worst[2]
        );
        assert!(worst[3] < 1e-7, "pin off by {:e} m", worst[3]);
        assert!(
            worst[4] < 1e-2,
            "slider a off its velocity's difference by {:e} m/s^2",
            worst[4]
        );
    }

    /// The shipped linear axis with friction (an include of the nominal file plus a friction
    /// element) obeys m·ẍ = F(t) − F_friction(ẋ): the effort sensor reads the command, and the
    /// friction is Coulomb 12 N (tanh over 5 mm/s) plus viscous 90 N s/m forward, 130 N s/m
    /// backward.
    #[test]
    fn the_linear_axis_file_obeys_its_force_balance() {
        let file = shipped("linear_axis_with_friction.toml");
        let (_, rec) = simulate(
            file.build().unwrap(),
            4.0,
            1e-3,
            SimulationOptions::default(),
            |_| {},
        )
        .unwrap();
        let (v, f) = (column(&rec, "qd"), column(&rec, "force"));
        let mut worst: f64 = 0.0;
        let mut top: f64 = 0.0;
        for k in 1..rec.t.len() - 1 {
            let a = (v[k + 1] - v[k - 1]) / (rec.t[k + 1] - rec.t[k - 1]);
            let c = if v[k] >= 0.0 { 90.0 } else { 130.0 };
            let friction = 12.0 * (v[k] / 0.005).tanh() + c * v[k];
            // Away from reversals, where tanh's slope makes the central difference coarse.
            if v[k].abs() > 0.02 {
                worst = worst.max((8.0 * a - (f[k] - friction)).abs());
            }
            top = top.max(v[k].abs());
        }
        assert!(top > 0.3, "the axis barely moves ({top} m/s)");
        assert!(worst < 0.05, "force balance off by {worst} N");
        let command = 60.0 * (std::f64::consts::TAU * 0.5 * 1.0f64).sin()
            + 20.0 * (std::f64::consts::TAU * 1.3 * 1.0f64).sin();
        let k1 = rec.t.iter().position(|t| (t - 1.0).abs() < 1e-9).unwrap();
        assert!(
            (f[k1] - command).abs() < 1e-3,
            "effort sensor {} N vs command {command} N",
            f[k1]
        );
    }
}
