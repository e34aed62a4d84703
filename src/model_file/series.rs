//! Sampled series for drivers and forces: two columns of a CSV file (a header row naming the
//! columns, comma-separated numbers below it; lines starting with `#` are skipped).

use std::path::Path;

/// Reads columns `time` and `value` of the CSV at `path`; the message names the file and
/// line of any fault.
pub(crate) fn read_columns(path: &Path, time: &str, value: &str) -> Result<(Vec<f64>, Vec<f64>), String> {
    let name = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read series '{name}': {e}"))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines.next().ok_or_else(|| format!("{name}: the file is empty"))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |c: &str| {
        cols.iter()
            .position(|h| *h == c)
            .ok_or_else(|| format!("{name}:1: no column '{c}' (columns: {})", cols.join(", ")))
    };
    let (kt, kv) = (find(time)?, find(value)?);
    let (mut t, mut v) = (vec![], vec![]);
    for (n, line) in lines {
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let cell = |k: usize, c: &str| -> Result<f64, String> {
            let s = cells
                .get(k)
                .ok_or_else(|| format!("{name}:{}: no cell for column '{c}'", n + 1))?;
            let x: f64 = s
                .parse()
                .map_err(|_| format!("{name}:{}: column '{c}': '{s}' is not a number", n + 1))?;
            if !x.is_finite() {
                return Err(format!("{name}:{}: column '{c}': {x} is not finite", n + 1));
            }
            Ok(x)
        };
        let (ti, vi) = (cell(kt, time)?, cell(kv, value)?);
        if let Some(&last) = t.last() {
            if ti <= last {
                return Err(format!(
                    "{name}:{}: time {ti} does not increase (previous {last})",
                    n + 1
                ));
            }
        }
        t.push(ti);
        v.push(vi);
    }
    if t.len() < 2 {
        return Err(format!("{name}: fewer than 2 samples"));
    }
    Ok((t, v))
}
