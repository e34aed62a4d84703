//! Quantities in model files: a bare number is SI; a string is a number and a unit
//! (`"30 deg"`, `"5 mm"`, `"12 N"`) whose dimension must match the field's.

use std::fmt;

/// What a field measures (its SI unit in brackets).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    /// A pure number \[1\].
    Ratio,
    /// Length \[m\].
    Length,
    /// Angle \[rad\].
    Angle,
    /// Mass \[kg\].
    Mass,
    /// Moment of inertia [kg m²].
    Inertia,
    /// Time \[s\].
    Time,
    /// Velocity [m/s].
    Velocity,
    /// Angular velocity [rad/s].
    AngularVelocity,
    /// Acceleration [m/s²].
    Acceleration,
    /// Force \[N\].
    Force,
    /// Torque [N m].
    Torque,
    /// Translational stiffness [N/m].
    Stiffness,
    /// Rotational stiffness [N m/rad].
    RotationalStiffness,
    /// Translational damping [N s/m].
    Damping,
    /// Rotational damping [N m s/rad].
    RotationalDamping,
    /// Pressure or elastic modulus \[Pa\].
    Pressure,
    /// Translational compliance [m/N].
    Compliance,
    /// Rotational compliance [rad/(N m)].
    RotationalCompliance,
}

impl Dimension {
    /// The SI unit as printed.
    pub fn si(self) -> &'static str {
        match self {
            Dimension::Ratio => "1",
            Dimension::Length => "m",
            Dimension::Angle => "rad",
            Dimension::Mass => "kg",
            Dimension::Inertia => "kg m^2",
            Dimension::Time => "s",
            Dimension::Velocity => "m/s",
            Dimension::AngularVelocity => "rad/s",
            Dimension::Acceleration => "m/s^2",
            Dimension::Force => "N",
            Dimension::Torque => "N m",
            Dimension::Stiffness => "N/m",
            Dimension::RotationalStiffness => "N m/rad",
            Dimension::Damping => "N s/m",
            Dimension::RotationalDamping => "N m s/rad",
            Dimension::Pressure => "Pa",
            Dimension::Compliance => "m/N",
            Dimension::RotationalCompliance => "rad/(N m)",
        }
    }

    /// The dimension of an SI unit name, for parameter declarations (`unit = "kg"`); `None`
    /// for unknown and non-SI units (`"mm"`).
    pub fn of_si_unit(unit: &str) -> Option<Self> {
        UNITS
            .iter()
            .find(|(name, _, f)| *name == unit.trim() && *f == 1.0)
            .map(|(_, d, _)| *d)
    }
}

impl fmt::Display for Dimension {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.si())
    }
}

/// Accepted units: name, dimension, factor to SI.
const UNITS: &[(&str, Dimension, f64)] = &[
    ("1", Dimension::Ratio, 1.0),
    ("%", Dimension::Ratio, 0.01),
    ("m", Dimension::Length, 1.0),
    ("cm", Dimension::Length, 1e-2),
    ("mm", Dimension::Length, 1e-3),
    ("um", Dimension::Length, 1e-6),
    ("µm", Dimension::Length, 1e-6),
    ("rad", Dimension::Angle, 1.0),
    ("mrad", Dimension::Angle, 1e-3),
    ("deg", Dimension::Angle, std::f64::consts::PI / 180.0),
    ("kg", Dimension::Mass, 1.0),
    ("g", Dimension::Mass, 1e-3),
    ("kg m^2", Dimension::Inertia, 1.0),
    ("kg mm^2", Dimension::Inertia, 1e-6),
    ("g cm^2", Dimension::Inertia, 1e-7),
    ("s", Dimension::Time, 1.0),
    ("ms", Dimension::Time, 1e-3),
    ("m/s", Dimension::Velocity, 1.0),
    ("mm/s", Dimension::Velocity, 1e-3),
    ("rad/s", Dimension::AngularVelocity, 1.0),
    ("deg/s", Dimension::AngularVelocity, std::f64::consts::PI / 180.0),
    ("rpm", Dimension::AngularVelocity, std::f64::consts::PI / 30.0),
    ("m/s^2", Dimension::Acceleration, 1.0),
    ("N", Dimension::Force, 1.0),
    ("kN", Dimension::Force, 1e3),
    ("N m", Dimension::Torque, 1.0),
    ("N mm", Dimension::Torque, 1e-3),
    ("N/m", Dimension::Stiffness, 1.0),
    ("N/mm", Dimension::Stiffness, 1e3),
    ("N m/rad", Dimension::RotationalStiffness, 1.0),
    ("N s/m", Dimension::Damping, 1.0),
    ("N m s/rad", Dimension::RotationalDamping, 1.0),
    ("Pa", Dimension::Pressure, 1.0),
    ("MPa", Dimension::Pressure, 1e6),
    ("GPa", Dimension::Pressure, 1e9),
    ("m/N", Dimension::Compliance, 1.0),
    ("mm/N", Dimension::Compliance, 1e-3),
    ("um/N", Dimension::Compliance, 1e-6),
    ("rad/(N m)", Dimension::RotationalCompliance, 1.0),
    ("mrad/(N m)", Dimension::RotationalCompliance, 1e-3),
    ("urad/(N m)", Dimension::RotationalCompliance, 1e-6),
];

/// Parses `"<number> <unit>"` (or a number alone, SI) as a quantity of dimension `dim`,
/// returning its SI value. The message says what is wrong and which units are accepted.
pub fn parse_quantity(text: &str, dim: Dimension) -> Result<f64, String> {
    let t = text.trim();
    let split = t
        .char_indices()
        .find(|&(k, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || c == '+'
                || c == '-'
                || ((c == 'e' || c == 'E')
                    && t[k + c.len_utf8()..]
                        .chars()
                        .next()
                        .is_some_and(|n| n.is_ascii_digit() || n == '-' || n == '+')))
        })
        .map(|(k, _)| k)
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let value: f64 = num.trim().parse().map_err(|_| {
        format!(
            "'{text}' is not a number followed by a unit (e.g. \"5 {}\")",
            dim.si()
        )
    })?;
    if !value.is_finite() {
        return Err(format!("'{text}' is not finite"));
    }
    let unit = unit.trim();
    if unit.is_empty() {
        return Ok(value);
    }
    let accepted: Vec<&str> = UNITS
        .iter()
        .filter(|(_, d, _)| *d == dim)
        .map(|(n, _, _)| *n)
        .collect();
    match UNITS.iter().find(|(n, _, _)| *n == unit) {
        Some((_, d, f)) if *d == dim => Ok(value * f),
        Some((_, d, _)) => Err(format!(
            "unit '{unit}' is a {} ({d}) but this field is in {dim}; use one of: {}",
            name_of(*d),
            accepted.join(", ")
        )),
        None => Err(format!(
            "unknown unit '{unit}' for a field in {dim}; use one of: {}",
            accepted.join(", ")
        )),
    }
}

fn name_of(d: Dimension) -> &'static str {
    match d {
        Dimension::Ratio => "ratio",
        Dimension::Length => "length",
        Dimension::Angle => "angle",
        Dimension::Mass => "mass",
        Dimension::Inertia => "moment of inertia",
        Dimension::Time => "time",
        Dimension::Velocity => "velocity",
        Dimension::AngularVelocity => "angular velocity",
        Dimension::Acceleration => "acceleration",
        Dimension::Force => "force",
        Dimension::Torque => "torque",
        Dimension::Stiffness => "stiffness",
        Dimension::RotationalStiffness => "rotational stiffness",
        Dimension::Damping => "damping",
        Dimension::RotationalDamping => "rotational damping",
        Dimension::Pressure => "pressure",
        Dimension::Compliance => "compliance",
        Dimension::RotationalCompliance => "rotational compliance",
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn numbers_with_units_become_si() {
        assert_relative_eq!(
            parse_quantity("30 deg", Dimension::Angle).unwrap(),
            std::f64::consts::PI / 6.0
        );
        assert_relative_eq!(parse_quantity("5mm", Dimension::Length).unwrap(), 5e-3);
        assert_relative_eq!(parse_quantity("-1.5e-3 m", Dimension::Length).unwrap(), -1.5e-3);
        assert_relative_eq!(parse_quantity("2", Dimension::Mass).unwrap(), 2.0);
        assert_relative_eq!(parse_quantity("12 N", Dimension::Force).unwrap(), 12.0);
    }

    #[test]
    fn wrong_or_unknown_units_are_refused_with_the_accepted_ones() {
        let e = parse_quantity("5 kg", Dimension::Length).unwrap_err();
        assert!(e.contains("mass") && e.contains("mm"), "{e}");
        let e = parse_quantity("5 furlongs", Dimension::Length).unwrap_err();
        assert!(e.contains("unknown unit 'furlongs'"), "{e}");
        assert!(parse_quantity("five m", Dimension::Length).is_err());
        assert!(parse_quantity("inf m", Dimension::Length).is_err());
    }
}
