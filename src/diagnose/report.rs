//! The report folder: `report.md` (for people), `report.json` (for scripts), and residual
//! plots before/after the fit for every held-out recording and channel (PNG and SVG; drawn
//! with the `plot` feature).

use super::format::number;
use super::play_dynamics::{ContactDamping, Interpolation};
use super::Diagnosis;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Why the report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// File system.
    #[error("{path}: {message}")]
    Io {
        /// Path.
        path: String,
        /// Message.
        message: String,
    },
}

fn io(path: &Path, e: impl std::fmt::Display) -> ReportError {
    ReportError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// The file name, without extension, of a held-out recording's channel in a report:
/// `holdout-<recording>-<channel>`, each lower-cased with every run of other characters than
/// ASCII letters and digits one `-` (the plots `.png` / `.svg`, the table `.csv`).
pub fn holdout_stem(recording: &str, channel: &str) -> String {
    format!("holdout-{}-{}", slug(recording), slug(channel))
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect::<String>()
        .split('-')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// Draws the residual before/after the fit for every held-out recording and channel as
/// `dir/holdout-<recording>-<channel>.png` and `.svg`; returns (recording, channel, stem) of
/// each chart.
#[cfg(feature = "plot")]
fn residual_charts(d: &Diagnosis, dir: &Path) -> Result<Vec<(String, String, PathBuf)>, ReportError> {
    use crate::plot::{LineChart, Series};
    let mut plots = vec![];
    for tr in &d.traces {
        let stem = dir.join(holdout_stem(&tr.recording, &tr.channel));
        let chart = LineChart {
            title: format!("{}: {} residual (held out)", tr.recording, tr.channel),
            x_label: "time [s]".into(),
            y_label: format!("measured - model [{}]", tr.unit),
            series: vec![
                Series {
                    name: "nominal model".into(),
                    points: tr.t.iter().copied().zip(tr.before.iter().copied()).collect(),
                },
                Series {
                    name: "with the selected physics".into(),
                    points: tr.t.iter().copied().zip(tr.after.iter().copied()).collect(),
                },
            ],
            y_range: None,
        };
        chart.save(&stem).map_err(|e| io(&stem, e))?;
        plots.push((tr.recording.clone(), tr.channel.clone(), stem));
    }
    Ok(plots)
}

/// Without the `plot` feature no chart is drawn.
#[cfg(not(feature = "plot"))]
fn residual_charts(_: &Diagnosis, _: &Path) -> Result<Vec<(String, String, PathBuf)>, ReportError> {
    Ok(vec![])
}

/// The report's opening lines: explained or unexplained, per channel, with numbers.
fn adequacy_lines(m: &mut String, d: &Diagnosis) {
    let a = &d.adequacy;
    let basis = if a.basis == "held-out" {
        "held-out recordings"
    } else {
        "fit recordings (none held out)"
    };
    if a.unexplained {
        let _ = writeln!(
            m,
            "**Unexplained mismatch remains**: the selected physics explains {} % of the mismatch power above the noise on the {basis}; what remains is not noise (threshold: {:.1}× the noise floor, or a residual far from white).\n",
            super::adequacy::percent_text(a.explained_fraction),
            a.unexplained_noise_ratio
        );
    } else {
        let _ = writeln!(
            m,
            "**What remains is noise** on the {basis}: every channel within {:.1}× its noise floor and not far from white; {}.\n",
            a.unexplained_noise_ratio,
            if a.channels.iter().all(|c| c.noise_ratio_before <= a.unexplained_noise_ratio) {
                "the nominal model was already at noise".to_string()
            } else {
                format!(
                    "the selected physics explains {} % of the mismatch power above the noise",
                    super::adequacy::percent_text(a.explained_fraction)
                )
            }
        );
    }
    for c in &a.channels {
        let state = if c.unexplained { "UNEXPLAINED" } else { "at noise" };
        let mut line = format!(
            "- {}: {state} — {:.1}× the noise floor after the fit ({} {u}; before {:.1}×), {}; lag-1 autocorrelation {:.2}, whiteness p {}; {} of {} windows above {} noise floors",
            c.channel,
            c.noise_ratio_after,
            number(c.rms_after),
            c.noise_ratio_before,
            if c.noise_ratio_before <= a.unexplained_noise_ratio {
                "nothing above the noise to explain".to_string()
            } else {
                format!("{} % explained", super::adequacy::percent_text(c.explained_fraction))
            },
            c.autocorrelation.first().copied().unwrap_or(0.0),
            super::adequacy::p_text(c.whiteness_p),
            c.significant_windows,
            c.windows,
            a.window.1,
            u = c.unit
        );
        if let Some(w) = c.worst_window.as_ref().filter(|_| c.unexplained) {
            line.push_str(&format!(
                "; largest in {} at t = {:.2}–{:.2} s ({:.1}×; {})",
                w.recording,
                w.t0,
                w.t1,
                w.noise_ratio,
                if w.tags.is_empty() {
                    "no distinctive state".to_string()
                } else {
                    w.tags.join(", ")
                }
            ));
        }
        if let Some(st) = c.strongest_state.as_ref().filter(|_| c.unexplained) {
            line.push_str(&format!(
                "; {:.1}× larger in windows {}",
                st.ratio,
                super::locate::windows_phrase(&st.tag)
            ));
        }
        if let Some(text) = super::adequacy::impulses_text(c) {
            line.push_str(&format!("; {text}"));
        }
        let _ = writeln!(m, "{line}.");
    }
    if !a.unstable.is_empty() {
        let _ = writeln!(
            m,
            "- Unstable estimates (soak up model error, not found physics): {}.",
            a.unstable.join("; ")
        );
    }
    if let Some(c) = &d.play_dynamics {
        let _ = writeln!(m, "- {}", super::verdict::play_dynamics_check(c).trim());
    }
    let held: Vec<String> = d
        .relinearization_steps
        .iter()
        .filter(|s| s.fraction < 1.0)
        .map(|s| {
            let (rel, noise) = s.departures.first().map_or((0.0, 0.0), |x| (x.1, x.2));
            format!(
                "{} ({} of its step; at the whole step the residual departed {:.0} % of the step's linear response, {noise:.2} noise units, from the nominal one)",
                s.candidate,
                if s.fraction == 0.0 { "none".to_string() } else { format!("{:.0} %", 100.0 * s.fraction) },
                100.0 * rel
            )
        })
        .collect();
    if !held.is_empty() {
        let _ = writeln!(
            m,
            "- Re-linearisation: held back where the model is not linear between the nominal point and the first pass's estimate (tolerance {:.0} %): {}.",
            100.0 * super::SHIFT_LINEARITY_TOLERANCE,
            held.join("; ")
        );
    }
    if d.relinearization_cv.len() > 1 {
        let cv: Vec<String> = d.relinearization_cv.iter().map(|v| format!("{v:.3}")).collect();
        let _ = writeln!(
            m,
            "- Re-linearisation continued: whole steps from the point reached to the last pass's estimates, each kept while the selection cross-validates better (by more than {:.0e} of it); cross-validated RMS per pass {} noise units; {} pass(es) kept.",
            super::CONTINUED_STEP_GAIN,
            cv.join(" → "),
            d.relinearization_passes
        );
    }
    if let Some(p) = &d.play_probe {
        let grid = super::probe_play_sizes();
        let (lo, hi) = (
            grid.first().copied().unwrap_or(0.0),
            grid.last().copied().unwrap_or(0.0),
        );
        let without = if p.without.is_finite() {
            format!("{:.3}", p.without)
        } else {
            "its refit failed".into()
        };
        // Per other damping, in the order tried, its best refit.
        let mut seen: Vec<super::play_dynamics::ContactDamping> = vec![];
        for &(damping, _, _) in &p.damping_sizes {
            if !seen.contains(&damping) {
                seen.push(damping);
            }
        }
        let others: Vec<String> = seen
            .iter()
            .map(
                |c| match super::play_size::best_refit(p.damping_sizes.iter().filter(|x| x.0 == *c)) {
                    Some((_, h, cv)) => format!("{c}: {:.3} µm at {cv:.3}", h * 1e6),
                    None => format!("{c}: every refit failed"),
                },
            )
            .collect();
        let others = if others.is_empty() {
            String::new()
        } else {
            format!(
                "; then the size searched from there at each other contact damping of the grid ({} refits; the best per damping {})",
                p.damping_sizes.len(),
                others.join(", ")
            )
        };
        let why = match &p.backlash {
            None => format!(
                "A play the first pass saw but could not carry ({}: alone the best by cross-validation, its quasi-static estimate outside its bounds)",
                p.signature
            ),
            Some(b) => format!(
                "A play the first pass may have read as a drive backlash ({b} selected, no play, an estimate unstable; of the plays alone {} cross-validated best)",
                p.signature
            ),
        };
        let _ = writeln!(
            m,
            "- {why}: {} refitted with the first pass's selection (leave-one-recording-out RMS in noise units; without the play {without}) at {} sizes, {:.2}–{:.2} µm in steps of {:.0} %, then {} about the best, at a contact damping of {}{others}: {}.",
            p.candidate,
            grid.len(),
            lo * 1e6,
            hi * 1e6,
            (super::PROBE_PLAY_SIZES.2 - 1.0) * 100.0,
            p.sizes.len().saturating_sub(grid.len()),
            p.damping,
            match (p.best(), p.kept) {
                (Some((c, h, cv)), Some(_)) => format!(
                    "the best {:.3} µm with {c} at {cv:.3}, its size the reference play of the second pass (which chooses its damping from the grid again)",
                    h * 1e6
                ),
                (Some((c, h, cv)), None) => format!(
                    "the best {:.3} µm with {c} at {cv:.3}, not better beyond the confounding tolerance: no play taken to the second pass",
                    h * 1e6
                ),
                (None, _) => "no refit succeeded".into(),
            }
        );
    }
    if let Some(h) = d.dynamic_play_reference {
        let _ = writeln!(
            m,
            "- The radial-play candidates' drive torques and tracker: the reduced dynamic play model at a clearance of {:.2} µm ({}), scaled in proportion to each candidate's clearance.",
            h * 1e6,
            reference_source(d)
        );
    }
    if let Some(c) = d.dynamic_play_damping {
        let tried: Vec<String> = d
            .dynamic_play_damping_cv
            .iter()
            .map(|(c, cv)| format!("{c}: {cv:.3}"))
            .collect();
        let linear = match d.dynamic_play_axial_stiffness {
            Some(k) if d.dynamic_play_axial_stiffness_cv.len() > 1 => {
                let tried: Vec<String> = d
                    .dynamic_play_axial_stiffness_cv
                    .iter()
                    .map(|(k, cv)| format!("{k:.1e} N/m: {cv:.3}"))
                    .collect();
                format!(
                    "on linear stiffnesses, {:.1e} N/m against the bores' walls and {k:.1e} N/m on their end faces, chosen by cross-validation ({})",
                    super::play_dynamics::BALL_CONTACT.stiffness,
                    tried.join(", ")
                )
            }
            Some(k) => format!(
                "on linear stiffnesses, {:.1e} N/m against the bores' walls and {k:.1e} N/m on their end faces",
                super::play_dynamics::BALL_CONTACT.stiffness
            ),
            None => "on one linear stiffness".into(),
        };
        let _ = writeln!(
            m,
            "- The reduced dynamic play model's contact damping: {c}, chosen by cross-validation (leave-one-recording-out RMS in noise units at the reference play: {}{}); the balls {}; {}; {}; {}.",
            if tried.is_empty() { "one value given".into() } else { tried.join(", ") },
            if searched_damping(d) {
                "; at the searched play size the size search's refits chose it, below"
            } else {
                ""
            },
            if d.dynamic_play_hertz {
                "on Hertz's law per direction, with the constants of the joint's own bearings (the plays' columns their response with the play less without; each joint's compliance at zero play a candidate of its own)".to_string()
            } else {
                linear
            },
            if d.dynamic_play_relinearized {
                "the model re-linearised once about its own motion where its response is large"
            } else {
                "the model linearised about the nominal motion"
            },
            match d.dynamic_play_interpolation {
                Some(Interpolation::Linear) => "its forces blended from sample to sample",
                Some(Interpolation::Held) | None => "its forces held at each sample interval's end",
            },
            d.dynamic_play_stepping.unwrap_or_default()
        );
    }
    if let Some(h) = d.dynamic_axial_play_reference {
        let _ = writeln!(
            m,
            "- The axial-play candidates' drive torques and tracker: the reduced dynamic play model at an axial play of {:.2} µm ({}), scaled in proportion to each candidate's play.",
            h * 1e6,
            reference_source(d)
        );
    }
    if d.dynamic_play_reference_cv.len() > 1 {
        let um = |h: Option<f64>| h.map_or("quasi-static".to_string(), |h| format!("{:.2} µm", h * 1e6));
        let tried: Vec<String> = d
            .dynamic_play_reference_cv
            .iter()
            .map(|(r, a, cv)| format!("radial {}, axial {}: {cv:.3}", um(*r), um(*a)))
            .collect();
        let _ = writeln!(
            m,
            "- The reference plays, tried (leave-one-recording-out RMS in noise units): {}; the smallest kept.",
            tried.join("; ")
        );
    }
    if !d.dynamic_play_size_cv.is_empty() {
        // Per damping, in the order first tried: each size with its refit where a few were
        // tried, else the count and the best (the JSON has every refit).
        let mut dampings: Vec<ContactDamping> = vec![];
        for (c, _, _) in &d.dynamic_play_size_cv {
            if !dampings.contains(c) {
                dampings.push(*c);
            }
        }
        let tried: Vec<String> = dampings
            .iter()
            .map(|c| {
                let at = || d.dynamic_play_size_cv.iter().filter(|x| x.0 == *c);
                match (super::play_size::best_refit(at()), at().count()) {
                    (Some((_, h, cv)), n) if n > 1 => {
                        format!("with {c}, {n} sizes, the best {:.3} µm: {cv:.3}", h * 1e6)
                    }
                    (Some((_, h, cv)), _) => format!("with {c}, {:.3} µm: {cv:.3}", h * 1e6),
                    (None, n) => format!("with {c}, {n} sizes: no refit succeeded"),
                }
            })
            .collect();
        let kept = |(c, h, _): &(ContactDamping, f64, f64)| {
            Some(*h) == d.dynamic_play_reference && Some(*c) == d.dynamic_play_damping
        };
        let _ = writeln!(
            m,
            "- The radial play's size, searched, and the contact dampings at the best sizes (the selection refitted with the play's effect held at the reduced model's at each size and damping; leave-one-recording-out RMS in noise units): {}; {}.",
            tried.join("; "),
            if d.dynamic_play_size_cv.iter().any(kept) {
                "the selection at the best size and damping kept"
            } else if d.dynamic_play_size_cv.iter().all(|x| !x.2.is_finite()) {
                "no refit succeeded, the selection before kept"
            } else {
                "a whole selection at the best size and damping did not cross-validate better, the one before kept"
            }
        );
    }
    let _ = writeln!(m);
}

/// Whether the play-size search's refits chose the damping the selection ran with (a
/// damping other than the best of the grid at the reference play).
fn searched_damping(d: &Diagnosis) -> bool {
    let grid_best = d
        .dynamic_play_damping_cv
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(c, _)| *c);
    d.dynamic_play_size_cv
        .iter()
        .any(|(c, h, _)| Some(*h) == d.dynamic_play_reference && Some(*c) == d.dynamic_play_damping)
        && grid_best.is_some_and(|b| Some(b) != d.dynamic_play_damping)
}

/// Where the reduced dynamic play model's reference plays came from, as a parenthesis.
fn reference_source(d: &Diagnosis) -> &'static str {
    let kept = |(r, a, _): &(Option<f64>, Option<f64>, f64)| {
        *r == d.dynamic_play_reference && *a == d.dynamic_axial_play_reference
    };
    if d.dynamic_play_size_cv
        .iter()
        .any(|(_, h, _)| Some(*h) == d.dynamic_play_reference)
    {
        return "the size whose refit cross-validated best in a search on it";
    }
    let probed = d.play_probe.as_ref().and_then(|p| p.kept).is_some();
    match d.dynamic_play_reference_cv.iter().position(kept) {
        Some(k) if k > 0 && probed => {
            "the selection's own estimate of a play, after a pass at the probe's best size"
        }
        Some(k) if k > 0 => "the selection's own estimate of a play, after a pass at the first pass's",
        _ if probed => "the best size of the probe for a play the first pass did not carry",
        _ => "the first pass's estimate of a play",
    }
}

/// Writes every held-out residual trace as `dir/holdout-<recording>-<channel>.csv`: time
/// (s), measured less the nominal model and measured less the model with the selected
/// physics (in the channel's unit, named in the header) — the numbers behind the plots.
fn residual_tables(d: &Diagnosis, dir: &Path) -> Result<(), ReportError> {
    for tr in &d.traces {
        let path = dir.join(format!("{}.csv", holdout_stem(&tr.recording, &tr.channel)));
        let mut text = format!(
            "t [s],measured - nominal [{u}],measured - selected [{u}]\n",
            u = tr.unit
        );
        for ((t, b), a) in tr.t.iter().zip(&tr.before).zip(&tr.after) {
            let _ = writeln!(text, "{t},{b:e},{a:e}");
        }
        std::fs::write(&path, text).map_err(|e| io(&path, e))?;
    }
    Ok(())
}

/// Writes the report into `dir` (created if needed); returns the Markdown path.
pub fn write_report(d: &Diagnosis, dir: &Path) -> Result<PathBuf, ReportError> {
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let plots = residual_charts(d, dir)?;
    residual_tables(d, dir)?;
    let json = dir.join("report.json");
    let text = serde_json::to_string_pretty(d).map_err(|e| io(&json, e))?;
    std::fs::write(&json, text).map_err(|e| io(&json, e))?;
    let mut m = String::new();
    let _ = writeln!(m, "# lash diagnose: {}\n", d.model);
    adequacy_lines(&mut m, d);
    let _ = writeln!(m, "## Verdict\n\n{}\n", d.verdict);
    let _ = writeln!(
        m,
        "Fit recordings: {}. Held out: {}. {} residual samples, {:.0} effective (residual autocorrelation).\n",
        d.fit_recordings.join(", "),
        if d.holdout_recordings.is_empty() { "none".into() } else { d.holdout_recordings.join(", ") },
        d.samples,
        d.effective_samples
    );
    if !d.derivative_window.1.is_empty() {
        let _ = writeln!(
            m,
            "Accelerations: rates differentiated by local cubic fits over ±{} samples, chosen by leave-one-recording-out cross-validation on the fit recordings (torque prediction RMS in noise floors: {}).\n",
            d.derivative_window.0,
            d.derivative_window
                .1
                .iter()
                .map(|(w, v)| format!("±{w}: {v:.1}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    if d.ends_dropped > 0 {
        let _ = writeln!(
            m,
            "Up to the first and last {} samples of each recording carry no weight: there the widest differentiation window tried reaches past the recording's ends (its fit is one-sided), and every window is scored on the same samples.\n",
            d.ends_dropped
        );
    }
    let _ = writeln!(m, "## Before and after, per channel\n");
    let _ = writeln!(
        m,
        "| channel | unit | noise floor | fit RMS before | fit RMS after | held-out RMS before | held-out RMS after | held-out reduction |\n|---|---|---|---|---|---|---|---|"
    );
    for c in &d.channels {
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} % |",
            c.channel,
            c.unit,
            number(c.noise_floor),
            number(c.fit_before),
            number(c.fit_after),
            number(c.holdout_before),
            number(c.holdout_after),
            100.0 * c.holdout_reduction
        );
    }
    let _ = writeln!(m, "\n## Where the nominal model disagrees\n");
    for (ch, f) in &d.location.significant_fraction {
        let _ = writeln!(
            m,
            "- {ch}: {:.0} % of the windows above 3 noise floors.",
            100.0 * f
        );
    }
    for c in &d.location.correlations {
        let _ = writeln!(
            m,
            "- {}: the residual follows the {} (r = {:+.2}).",
            c.channel, c.state, c.r
        );
    }
    for a in &d.location.associations {
        let _ = writeln!(
            m,
            "- {}: residual {:.2}× larger in windows {}.",
            a.channel,
            a.ratio,
            super::locate::with_note(
                &super::locate::windows_phrase(&a.tag),
                &format!("{} windows", a.windows)
            )
        );
    }
    let _ = writeln!(m, "\nStrongest windows:\n");
    for f in &d.location.findings {
        let _ = writeln!(m, "- {}", f.text);
    }
    let _ = writeln!(m, "\n## Candidate physics ranked at the nominal model\n");
    let _ = writeln!(
        m,
        "Likelihood-ratio statistic with effective samples; CV ratio = leave-one-recording-out residual RMS with the candidate alone / nominal.\n\n| # | candidate | statistic | p | CV ratio | plausible alone |\n|---|---|---|---|---|---|"
    );
    for (k, r) in d.ranking.iter().enumerate().take(20) {
        let _ = writeln!(
            m,
            "| {} | {} | {:.1} | {:.1e} | {:.3} | {} |",
            k + 1,
            r.candidate,
            r.statistic,
            r.p_value,
            r.cv_ratio,
            if r.plausible { "yes" } else { "no" }
        );
    }
    let _ = writeln!(m, "\n## Greedy selection\n\n| step | added | statistic | p | CV RMS [noise floors] | BIC |\n|---|---|---|---|---|---|");
    for (k, s) in d.steps.iter().enumerate() {
        let _ = writeln!(
            m,
            "| {} | {} | {:.1} | {:.1e} | {:.3} | {:.1} |",
            k + 1,
            s.added,
            s.statistic,
            s.p_value,
            s.cv_rms,
            s.bic
        );
    }
    if let Some(why) = d.nothing_selected() {
        let _ = writeln!(m, "\nNothing joined the model: {why}.");
    }
    let _ = writeln!(
        m,
        "\n## Estimates (± one standard deviation)\n\nstd includes the misfit: the larger of the noise-only std × the residual-to-noise inflation and the leave-one-recording-out jackknife. Unstable: moves between leave-one-recording-out fits by more than its inflated std and more than {:.0} % — it soaks up model error.\n\n| effect | parameter | value | std | std (noise only) | inflation | jackknife std | fold movement | stable |\n|---|---|---|---|---|---|---|---|---|",
        100.0 * super::adequacy::UNSTABLE_FRACTION
    );
    for e in &d.estimates {
        let _ = writeln!(
            m,
            "| {} | {} | {} | {} | {} | {:.2} | {} | {:.1} % | {} |",
            e.candidate,
            e.parameter,
            number(e.value),
            number(e.std),
            number(e.std_noise_only),
            e.inflation,
            e.std_jackknife.map(number).unwrap_or_else(|| "–".into()),
            100.0 * super::adequacy::fold_movement(e),
            if e.stable { "yes" } else { "no (unstable)" }
        );
    }
    if !d.correlations.is_empty() {
        let _ = writeln!(m, "\nStrongly correlated estimates:\n");
        for (a, b, r) in &d.correlations {
            let _ = writeln!(m, "- {a} and {b}: {r:+.2}");
        }
    }
    let _ = writeln!(m, "\n## What this data cannot separate\n");
    if d.confounded.is_empty() {
        let _ = writeln!(
            m,
            "Every selected effect fits clearly better than any alternative outside its own family."
        );
    }
    for c in &d.confounded {
        let _ = writeln!(
            m,
            "- {} or {} (cross-validated fits within {:.2} %{}). {}.",
            c.selected,
            c.alternative,
            100.0 * (c.cv_ratio - 1.0).abs(),
            c.equivalent
                .as_ref()
                .map(|e| format!("; as the latter: {e}"))
                .unwrap_or_default(),
            c.experiment
        );
    }
    let _ = writeln!(m, "\n## Held-out residuals\n");
    if plots.is_empty() && !d.traces.is_empty() {
        let _ = writeln!(
            m,
            "Plots need lash's `plot` feature; the residuals are in report.json.\n"
        );
    }
    for (rec, ch, stem) in &plots {
        let name = stem
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let _ = writeln!(m, "### {rec}, {ch}\n\n![{rec} {ch}]({name}.png)\n");
    }
    let md = dir.join("report.md");
    std::fs::write(&md, m).map_err(|e| io(&md, e))?;
    Ok(md)
}
