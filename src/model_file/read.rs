//! Reading a model file and its includes into parsed documents, and reading values out of
//! them with their places: quantities with units, parameter references, vectors, names.

use super::error::{ModelFileError, Problem, Source};
use super::schema::{FileDoc, Name, Val};
use super::units::{parse_quantity, Dimension};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

/// A parsed file: its source text and its tables.
#[derive(Debug)]
pub(crate) struct Parsed {
    pub src: Source,
    pub dir: PathBuf,
    pub doc: FileDoc,
    /// Tables imported from a URDF (its bodies may be replaced by a side file's).
    pub urdf: bool,
}

/// Most files an include tree may hold.
const MAX_FILES: usize = 64;

/// Reads `path` and its includes (depth first, includes before the including file's own
/// tables), refusing cycles and missing files with the place of the include.
///
/// `urdf`: a URDF that takes the place of the root file's own `urdf = …` (a side file
/// applied over another copy of its robot); the root need not name one.
pub(crate) fn read_tree(path: &Path, urdf: Option<&Path>) -> Result<Vec<Parsed>, ModelFileError> {
    let mut out = vec![];
    let mut stack = vec![];
    read_one(path, &mut stack, &mut out, None, urdf)?;
    Ok(out)
}

fn read_one(
    path: &Path,
    stack: &mut Vec<PathBuf>,
    out: &mut Vec<Parsed>,
    from: Option<(&Source, usize)>,
    urdf_over: Option<&Path>,
) -> Result<(), ModelFileError> {
    let fail = |message: String| match from {
        Some((src, at)) => src.error(at, Problem::Include, message),
        None => ModelFileError::File {
            file: path.display().to_string(),
            problem: Problem::Read,
            message,
        },
    };
    let text = std::fs::read_to_string(path)
        .map_err(|e| fail(format!("cannot read model file '{}': {e}", path.display())))?;
    let canonical = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    if let Some(k) = stack.iter().position(|p| *p == canonical) {
        let cycle: Vec<String> = stack[k..]
            .iter()
            .chain(std::iter::once(&canonical))
            .map(|p| p.display().to_string())
            .collect();
        return Err(fail(format!("include cycle: {}", cycle.join(" -> "))));
    }
    if out.len() + stack.len() >= MAX_FILES {
        return Err(fail(format!("more than {MAX_FILES} files in the include tree")));
    }
    if is_urdf(path) {
        out.push(super::urdf::import(path, text, from.is_none())?);
        return Ok(());
    }
    let src = Source::new(path, text);
    let doc = parse(&src)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    stack.push(canonical);
    for inc in &doc.include {
        let child = dir.join(inc.get_ref());
        read_one(&child, stack, out, Some((&src, inc.span().start)), None)?;
    }
    stack.pop();
    if let Some(file) = urdf_over.filter(|_| from.is_none()) {
        if !is_urdf(file) {
            return Err(ModelFileError::File {
                file: file.display().to_string(),
                problem: Problem::Include,
                message: "the URDF a side file is applied over must end in .urdf".into(),
            });
        }
        let text = std::fs::read_to_string(file).map_err(|e| ModelFileError::File {
            file: file.display().to_string(),
            problem: Problem::Read,
            message: format!("cannot read URDF: {e}"),
        })?;
        out.push(super::urdf::import(file, text, false)?);
    } else if let Some(u) = &doc.urdf {
        let file = dir.join(u.get_ref());
        if !is_urdf(&file) {
            return Err(src.error(
                u.span().start,
                Problem::Include,
                format!("urdf = '{}' does not name a .urdf file", u.get_ref()),
            ));
        }
        let text = std::fs::read_to_string(&file).map_err(|e| {
            src.error(
                u.span().start,
                Problem::Include,
                format!("cannot read URDF '{}': {e}", file.display()),
            )
        })?;
        out.push(super::urdf::import(&file, text, false)?);
    }
    out.push(Parsed {
        src,
        dir,
        doc,
        urdf: false,
    });
    Ok(())
}

/// Whether `path` names a URDF (by its extension).
pub(crate) fn is_urdf(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("urdf"))
}

/// Parses one file's text.
pub(crate) fn parse(src: &Source) -> Result<FileDoc, ModelFileError> {
    toml::from_str::<FileDoc>(&src.text).map_err(|e| {
        let at = e.span().map(|s| s.start).unwrap_or(0);
        let msg = e.message().trim().to_string();
        let problem = if msg.starts_with("unknown field") {
            Problem::UnknownKey
        } else if msg.starts_with("invalid type") || msg.starts_with("invalid length") {
            Problem::WrongType
        } else {
            Problem::Syntax
        };
        src.error(at, problem, msg)
    })
}

/// A declared parameter: a named value the diagnosis may perturb, used in place of a number.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Parameter {
    /// Name (as fields refer to it).
    pub name: String,
    /// Nominal value, SI.
    pub nominal: f64,
    /// Its unit as declared (SI).
    pub unit: String,
    /// Lower and upper bounds, SI, if declared.
    pub bounds: Option<(f64, f64)>,
    /// What it is.
    pub description: String,
    #[serde(skip)]
    pub(crate) dimension: Dimension,
}

/// Reading context: the source of the table being read and the parameter values in force.
pub(crate) struct Ctx<'a> {
    pub src: &'a Source,
    pub params: &'a [Parameter],
    pub values: &'a [f64],
}

impl Ctx<'_> {
    pub fn err(&self, at: usize, problem: Problem, message: impl Into<String>) -> ModelFileError {
        self.src.error(at, problem, message)
    }

    /// A required value: `table_at` locates the table it is missing from.
    pub fn need<'v>(
        &self,
        v: &'v Option<Val>,
        key: &str,
        owner: &str,
        table_at: usize,
    ) -> Result<&'v Val, ModelFileError> {
        v.as_ref()
            .ok_or_else(|| self.err(table_at, Problem::Missing, format!("{owner} has no '{key}'")))
    }

    /// A required name.
    pub fn need_name<'v>(
        &self,
        v: &'v Option<Name>,
        key: &str,
        owner: &str,
        table_at: usize,
    ) -> Result<&'v Name, ModelFileError> {
        v.as_ref()
            .ok_or_else(|| self.err(table_at, Problem::Missing, format!("{owner} has no '{key}'")))
    }

    /// The declared parameter a value names, if it is one (index into the parameters).
    pub fn parameter_index(&self, v: &Val) -> Option<usize> {
        match v.get_ref() {
            toml::Value::String(s) => self.params.iter().position(|p| p.name == s.trim()),
            _ => None,
        }
    }

    /// A scalar of dimension `dim`: a number (SI), a string with a unit, or a parameter name.
    pub fn scalar(&self, v: &Val, dim: Dimension, what: &str) -> Result<f64, ModelFileError> {
        let at = v.span().start;
        self.scalar_value(v.get_ref(), dim, what, at)
    }

    fn scalar_value(
        &self,
        v: &toml::Value,
        dim: Dimension,
        what: &str,
        at: usize,
    ) -> Result<f64, ModelFileError> {
        let x = match v {
            toml::Value::Integer(i) => *i as f64,
            toml::Value::Float(f) => *f,
            toml::Value::String(s) => {
                if let Some(k) = self.params.iter().position(|p| p.name == s.trim()) {
                    let p = &self.params[k];
                    if p.dimension != dim && p.dimension != Dimension::Ratio {
                        return Err(self.err(
                            at,
                            Problem::Unit,
                            format!(
                                "{what}: parameter '{}' is in {} but this field is in {dim}",
                                p.name, p.dimension
                            ),
                        ));
                    }
                    self.values.get(k).copied().unwrap_or(p.nominal)
                } else if s
                    .trim()
                    .starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+' || c == '.')
                {
                    parse_quantity(s, dim).map_err(|m| self.err(at, Problem::Unit, format!("{what}: {m}")))?
                } else {
                    let known: Vec<&str> = self.params.iter().map(|p| p.name.as_str()).collect();
                    return Err(self.err(
                        at,
                        Problem::UnknownReference,
                        format!(
                            "{what}: '{s}' is neither a number with a unit nor a declared parameter{}",
                            if known.is_empty() {
                                " (the file declares none)".to_string()
                            } else {
                                format!(" (parameters: {})", known.join(", "))
                            }
                        ),
                    ));
                }
            }
            other => {
                return Err(self.err(
                    at,
                    Problem::WrongType,
                    format!(
                        "{what} must be a number in {dim} or a string such as \"5 {dim}\", not {}",
                        type_name(other)
                    ),
                ))
            }
        };
        if !x.is_finite() {
            return Err(self.err(at, Problem::WrongType, format!("{what} must be finite, not {x}")));
        }
        Ok(x)
    }

    /// A list of scalars of dimension `dim` with one of the lengths in `lens`.
    pub fn list(
        &self,
        v: &Val,
        dim: Dimension,
        lens: &[usize],
        what: &str,
    ) -> Result<Vec<f64>, ModelFileError> {
        let at = v.span().start;
        let toml::Value::Array(items) = v.get_ref() else {
            return Err(self.err(
                at,
                Problem::WrongType,
                format!("{what} must be an array of {} numbers in {dim}", lens_text(lens)),
            ));
        };
        if !lens.is_empty() && !lens.contains(&items.len()) {
            return Err(self.err(
                at,
                Problem::WrongType,
                format!(
                    "{what} must have {} components, not {}",
                    lens_text(lens),
                    items.len()
                ),
            ));
        }
        items
            .iter()
            .map(|x| self.scalar_value(x, dim, what, at))
            .collect()
    }

    /// A 3-vector of dimension `dim`.
    pub fn vec3(&self, v: &Val, dim: Dimension, what: &str) -> Result<Vector3<f64>, ModelFileError> {
        let x = self.list(v, dim, &[3], what)?;
        Ok(Vector3::new(x[0], x[1], x[2]))
    }

    /// A nonzero direction (normalised).
    pub fn direction(&self, v: &Val, what: &str) -> Result<Vector3<f64>, ModelFileError> {
        let x = self.nonzero(v, what)?;
        // Huge components: scaled first, so that the norm does not overflow.
        let x = if x.amax() > 1e150 { x / x.amax() } else { x };
        Ok(x / x.norm())
    }

    /// A vector that gives a direction, as written (not normalised): refused if zero.
    pub fn nonzero(&self, v: &Val, what: &str) -> Result<Vector3<f64>, ModelFileError> {
        let x = self.vec3(v, Dimension::Ratio, what)?;
        // Scaled first, so that huge components do not overflow the norm.
        let big = x.amax();
        let n = if big > 1e150 { (x / big).norm() } else { x.norm() };
        if n.is_nan() || n < 1e-12 {
            return Err(self.err(
                v.span().start,
                Problem::ZeroVector,
                format!("{what} must not be zero"),
            ));
        }
        Ok(x)
    }

    /// A positive scalar.
    pub fn positive(&self, v: &Val, dim: Dimension, what: &str) -> Result<f64, ModelFileError> {
        let x = self.scalar(v, dim, what)?;
        if x <= 0.0 {
            return Err(self.err(
                v.span().start,
                Problem::NotPositive,
                format!("{what} must be positive, not {} {dim}", short(x)),
            ));
        }
        Ok(x)
    }

    /// A non-negative scalar.
    pub fn non_negative(&self, v: &Val, dim: Dimension, what: &str) -> Result<f64, ModelFileError> {
        let x = self.scalar(v, dim, what)?;
        if x < 0.0 {
            return Err(self.err(
                v.span().start,
                Problem::Negative,
                format!("{what} must not be negative, not {} {dim}", short(x)),
            ));
        }
        Ok(x)
    }
}

/// A number for messages: at most 6 significant digits, without binary noise
/// (-1e-5, not -0.000009999999999999999).
pub(crate) fn short(x: f64) -> String {
    if !x.is_finite() || x == 0.0 {
        return format!("{x}");
    }
    let e = x.abs().log10().floor() as i32;
    if (-3..6).contains(&e) {
        let digits = (5 - e).max(0) as usize;
        let t = format!("{x:.digits$}");
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            t
        }
    } else {
        let t = format!("{x:.5e}");
        let (m, ex) = t.split_once('e').unwrap_or((&t, "0"));
        let m = if m.contains('.') {
            m.trim_end_matches('0').trim_end_matches('.')
        } else {
            m
        };
        format!("{m}e{ex}")
    }
}

fn lens_text(lens: &[usize]) -> String {
    let v: Vec<String> = lens.iter().map(|n| n.to_string()).collect();
    v.join(" or ")
}

fn type_name(v: &toml::Value) -> &'static str {
    match v {
        toml::Value::String(_) => "a string",
        toml::Value::Integer(_) => "an integer",
        toml::Value::Float(_) => "a float",
        toml::Value::Boolean(_) => "a boolean",
        toml::Value::Datetime(_) => "a date",
        toml::Value::Array(_) => "an array",
        toml::Value::Table(_) => "a table",
    }
}

/// A candidate a model file declares for the diagnosis (`[[candidate]]`): a name and the
/// declared parameters it perturbs together.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FileCandidate {
    /// Name for reports.
    pub name: String,
    /// Indices into the file's parameters.
    pub parameters: Vec<usize>,
    /// What it is.
    pub description: String,
}

/// Reads `[[candidate]]` declarations from every file, in order: each names one or more
/// declared parameters, no parameter twice, no two candidates with one name.
pub(crate) fn candidates(
    files: &[Parsed],
    params: &[Parameter],
) -> Result<Vec<FileCandidate>, ModelFileError> {
    let mut out: Vec<FileCandidate> = vec![];
    for f in files {
        let cx = Ctx {
            src: &f.src,
            params,
            values: &[],
        };
        for c in &f.doc.candidate {
            let at = c.span().start;
            let d = c.get_ref();
            let name = cx.need_name(&d.name, "name", "a [[candidate]]", at)?;
            let owner = format!("candidate '{}'", name.get_ref());
            if out.iter().any(|o| o.name == *name.get_ref()) {
                return Err(cx.err(
                    name.span().start,
                    Problem::Duplicate,
                    format!("duplicate {owner}"),
                ));
            }
            if d.parameters.is_empty() {
                return Err(cx.err(
                    at,
                    Problem::Missing,
                    format!("{owner} has no 'parameters' (the declared parameters it perturbs)"),
                ));
            }
            let mut idx: Vec<usize> = vec![];
            for p in &d.parameters {
                let k = params
                    .iter()
                    .position(|q| q.name == *p.get_ref())
                    .ok_or_else(|| {
                        let known: Vec<&str> = params.iter().map(|q| q.name.as_str()).collect();
                        cx.err(
                            p.span().start,
                            Problem::UnknownReference,
                            format!(
                                "{owner}: no parameter '{}' (parameters: {})",
                                p.get_ref(),
                                known.join(", ")
                            ),
                        )
                    })?;
                if idx.contains(&k) {
                    return Err(cx.err(
                        p.span().start,
                        Problem::Duplicate,
                        format!("{owner} names parameter '{}' twice", p.get_ref()),
                    ));
                }
                idx.push(k);
            }
            out.push(FileCandidate {
                name: name.get_ref().clone(),
                parameters: idx,
                description: d
                    .description
                    .as_ref()
                    .map(|x| x.get_ref().clone())
                    .unwrap_or_default(),
            });
        }
    }
    Ok(out)
}

/// Reads parameter declarations from every file, in order.
pub(crate) fn parameters(files: &[Parsed]) -> Result<Vec<Parameter>, ModelFileError> {
    let mut out: Vec<Parameter> = vec![];
    for f in files {
        for p in &f.doc.parameter {
            let at = p.span().start;
            let d = p.get_ref();
            let cx = Ctx {
                src: &f.src,
                params: &[],
                values: &[],
            };
            let name = cx.need_name(&d.name, "name", "a [[parameter]]", at)?;
            let owner = format!("parameter '{}'", name.get_ref());
            if let Some(prev) = out.iter().find(|q| q.name == *name.get_ref()) {
                return Err(cx.err(
                    name.span().start,
                    Problem::Duplicate,
                    format!("duplicate parameter '{}'", prev.name),
                ));
            }
            let unit = cx.need_name(&d.unit, "unit", &owner, at)?;
            let dimension = Dimension::of_si_unit(unit.get_ref()).ok_or_else(|| {
                cx.err(
                    unit.span().start,
                    Problem::Unit,
                    format!("{owner}: '{}' is not an SI unit lash knows (kg, m, rad, s, N, N m, N/m, N s/m, m/s, rad/s, kg m^2, Pa, 1, …)", unit.get_ref()),
                )
            })?;
            let nominal = cx.scalar(cx.need(&d.nominal, "nominal", &owner, at)?, dimension, &owner)?;
            let bounds = match &d.bounds {
                Some(b) => {
                    let x = cx.list(b, dimension, &[2], &format!("{owner} bounds"))?;
                    if !(x[0] <= nominal && nominal <= x[1]) {
                        return Err(cx.err(
                            b.span().start,
                            Problem::Inconsistent,
                            format!(
                                "{owner}: bounds [{}, {}] do not contain the nominal value {nominal}",
                                x[0], x[1]
                            ),
                        ));
                    }
                    Some((x[0], x[1]))
                }
                None => None,
            };
            out.push(Parameter {
                name: name.get_ref().clone(),
                nominal,
                unit: unit.get_ref().clone(),
                bounds,
                description: d
                    .description
                    .as_ref()
                    .map(|s| s.get_ref().clone())
                    .unwrap_or_default(),
                dimension,
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    #[test]
    fn short_numbers_drop_binary_noise() {
        use super::short;
        assert_eq!(short(-10e-6 * (1.0 - 1e-16)), "-1e-5");
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(std::f64::consts::FRAC_PI_2), "1.5708");
        assert_eq!(short(12.0), "12");
        assert_eq!(short(2.5e7), "2.5e7");
        assert_eq!(short(0.0), "0");
    }
}
