//! Recordings: CSV files with a header row and a time column, read into named channels.
//! Every defect of a file is reported with its path and line, never by a panic.

use std::path::{Path, PathBuf};

/// The fewest samples a channel needs for the noise-floor estimate (and any fit).
pub const MIN_SAMPLES: usize = 50;

/// A defect in a recording file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be read.
    #[error("{path}: cannot read: {message}")]
    Io {
        /// File.
        path: PathBuf,
        /// The operating system's message.
        message: String,
    },
    /// No header row.
    #[error("{path}: empty file (expected a header row and data rows)")]
    Empty {
        /// File.
        path: PathBuf,
    },
    /// A column the mapping asks for is not in the header.
    #[error("{path}:1: no column '{column}' (mapped to {role}); the header has: {available}")]
    MissingColumn {
        /// File.
        path: PathBuf,
        /// Column name asked for.
        column: String,
        /// What the column was mapped to.
        role: String,
        /// The header's columns.
        available: String,
    },
    /// A model input or output has no column mapped to it.
    #[error("no column is mapped to {role}; map it with {hint}")]
    Unmapped {
        /// The unmapped role.
        role: String,
        /// How to map it.
        hint: String,
    },
    /// A cell is empty, not a number, NaN or infinite.
    #[error("{path}:{line}: column '{column}': {problem} ('{text}')")]
    BadCell {
        /// File.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The cell's text.
        text: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A row has fewer cells than the header.
    #[error("{path}:{line}: {found} cells, the header has {expected}")]
    ShortRow {
        /// File.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Cells found.
        found: usize,
        /// Cells expected.
        expected: usize,
    },
    /// Time does not increase strictly.
    #[error("{path}:{line}: time {t} s does not increase (previous row: {previous} s)")]
    TimeNotIncreasing {
        /// File.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Time on this line.
        t: f64,
        /// Time on the previous data line.
        previous: f64,
    },
    /// Too few samples.
    #[error("{path}: {found} samples; at least {needed} are needed to estimate the noise floor")]
    TooFewSamples {
        /// File.
        path: PathBuf,
        /// Samples found.
        found: usize,
        /// Samples needed.
        needed: usize,
    },
}

/// One recording: a time column and named channels of equal length.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// Where it came from.
    pub source: PathBuf,
    /// Time, s (strictly increasing).
    pub time: Vec<f64>,
    /// (role, values): one per requested column, in the order requested.
    pub channels: Vec<(String, Vec<f64>)>,
}

impl Recording {
    /// The values of the channel mapped to `role`.
    pub fn channel(&self, role: &str) -> Option<&[f64]> {
        self.channels
            .iter()
            .find(|(r, _)| r == role)
            .map(|(_, v)| v.as_slice())
    }

    /// A short name (file stem) for reports.
    pub fn name(&self) -> String {
        self.source
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.source.display().to_string())
    }
}

/// Reads `path`: column `time_column` as time and, for each (role, column) of `map`, that
/// column as the channel `role`. Checks every cell, the time order and the sample count.
pub fn read_csv(
    path: &Path,
    time_column: &str,
    map: &[(String, String)],
) -> Result<Recording, RecordingError> {
    let text = std::fs::read_to_string(path).map_err(|e| RecordingError::Io {
        path: path.into(),
        message: e.to_string(),
    })?;
    parse_csv(path, &text, time_column, map)
}

/// As [`read_csv`], from text already in memory (`path` names it in errors).
pub fn parse_csv(
    path: &Path,
    text: &str,
    time_column: &str,
    map: &[(String, String)],
) -> Result<Recording, RecordingError> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(RecordingError::Empty { path: path.into() });
    };
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |col: &str, role: &str| {
        names
            .iter()
            .position(|n| *n == col)
            .ok_or_else(|| RecordingError::MissingColumn {
                path: path.into(),
                column: col.into(),
                role: role.into(),
                available: names.join(", "),
            })
    };
    let t_idx = find(time_column, "time")?;
    let idx: Vec<usize> = map
        .iter()
        .map(|(role, col)| find(col, role))
        .collect::<Result<_, _>>()?;
    let mut time = vec![];
    let mut cols: Vec<Vec<f64>> = vec![vec![]; map.len()];
    for (i, line) in lines {
        let lineno = i + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() < names.len() {
            return Err(RecordingError::ShortRow {
                path: path.into(),
                line: lineno,
                found: cells.len(),
                expected: names.len(),
            });
        }
        let cell = |k: usize| -> Result<f64, RecordingError> {
            let text = cells[k];
            let bad = |problem: &str| RecordingError::BadCell {
                path: path.into(),
                line: lineno,
                column: names[k].into(),
                text: text.into(),
                problem: problem.into(),
            };
            if text.is_empty() {
                return Err(bad("empty cell"));
            }
            let v: f64 = text.parse().map_err(|_| bad("not a number"))?;
            if v.is_nan() {
                Err(bad("NaN"))
            } else if !v.is_finite() {
                Err(bad("infinite"))
            } else {
                Ok(v)
            }
        };
        let t = cell(t_idx)?;
        if let Some(&prev) = time.last() {
            if t <= prev {
                return Err(RecordingError::TimeNotIncreasing {
                    path: path.into(),
                    line: lineno,
                    t,
                    previous: prev,
                });
            }
        }
        time.push(t);
        for (c, &k) in idx.iter().enumerate() {
            cols[c].push(cell(k)?);
        }
    }
    if time.len() < MIN_SAMPLES {
        return Err(RecordingError::TooFewSamples {
            path: path.into(),
            found: time.len(),
            needed: MIN_SAMPLES,
        });
    }
    Ok(Recording {
        source: path.into(),
        time,
        channels: map.iter().map(|(r, _)| r.clone()).zip(cols).collect(),
    })
}

/// Parses "role=column,role=column" into pairs, checking every role against `roles` (roles
/// left out are not an error here; [`parse_mapping`] requires all).
pub fn parse_pairs(text: &str, roles: &[String]) -> Result<Vec<(String, String)>, RecordingError> {
    let mut map = vec![];
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((role, col)) = item.split_once('=') else {
            return Err(RecordingError::Unmapped {
                role: item.into(),
                hint: "role=column pairs, e.g. q1=pos_filt1".into(),
            });
        };
        let role = role.trim().to_string();
        if !roles.contains(&role) {
            return Err(RecordingError::Unmapped {
                role: format!(
                    "'{role}' (not an input or output of this model; it has {})",
                    roles.join(", ")
                ),
                hint: "one of the model's roles".into(),
            });
        }
        map.push((role, col.trim().to_string()));
    }
    Ok(map)
}

/// Parses a column mapping "role=column,role=column" and checks that every role in `roles`
/// is mapped (unknown roles are errors too).
pub fn parse_mapping(text: &str, roles: &[String]) -> Result<Vec<(String, String)>, RecordingError> {
    let map = parse_pairs(text, roles)?;
    for r in roles {
        if !map.iter().any(|(m, _)| m == r) {
            return Err(RecordingError::Unmapped {
                role: r.clone(),
                hint: format!("--map {r}=<column>"),
            });
        }
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> Vec<(String, String)> {
        vec![("y".into(), "a".into())]
    }

    fn body(n: usize) -> String {
        (0..n).map(|k| format!("{},{}\n", k as f64 * 0.01, k)).collect()
    }

    #[test]
    fn reads_a_good_file() {
        let text = format!("t,a\n{}", body(60));
        let r = parse_csv(Path::new("x.csv"), &text, "t", &map()).unwrap();
        assert_eq!(r.time.len(), 60);
        assert_eq!(r.channel("y").unwrap()[3], 3.0);
    }

    #[test]
    fn each_defect_names_file_and_line() {
        let p = Path::new("rec.csv");
        let e = parse_csv(p, &format!("t,b\n{}", body(60)), "t", &map()).unwrap_err();
        assert!(matches!(e, RecordingError::MissingColumn { .. }));
        assert!(e.to_string().starts_with("rec.csv:1: no column 'a'"), "{e}");
        let mut text = format!("t,a\n{}", body(60));
        text = text.replacen("0.03,3", "0.03,NaN", 1);
        let e = parse_csv(p, &text, "t", &map()).unwrap_err();
        assert!(e.to_string().starts_with("rec.csv:5: column 'a': NaN"), "{e}");
        let text = format!("t,a\n{}", body(60)).replacen("0.03,3", "0.03,", 1);
        let e = parse_csv(p, &text, "t", &map()).unwrap_err();
        assert!(e.to_string().contains("rec.csv:5: column 'a': empty cell"), "{e}");
        let text = format!("t,a\n{}", body(60)).replacen("0.03,3", "0.01,3", 1);
        let e = parse_csv(p, &text, "t", &map()).unwrap_err();
        assert!(
            matches!(e, RecordingError::TimeNotIncreasing { line: 5, .. }),
            "{e}"
        );
        let e = parse_csv(p, &format!("t,a\n{}", body(10)), "t", &map()).unwrap_err();
        assert!(
            matches!(e, RecordingError::TooFewSamples { found: 10, .. }),
            "{e}"
        );
        let e = parse_csv(p, "", "t", &map()).unwrap_err();
        assert!(matches!(e, RecordingError::Empty { .. }));
    }

    #[test]
    fn mappings_must_cover_every_role() {
        let roles = vec!["q1".to_string(), "tau1".to_string()];
        assert!(parse_mapping("q1=a,tau1=b", &roles).is_ok());
        let e = parse_mapping("q1=a", &roles).unwrap_err();
        assert!(e.to_string().contains("tau1"), "{e}");
        let e = parse_mapping("q1=a,tau1=b,zz=c", &roles).unwrap_err();
        assert!(e.to_string().contains("zz"), "{e}");
    }
}
