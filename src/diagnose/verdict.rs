//! The verdict: one paragraph of prose from a finished diagnosis — where the nominal model
//! disagrees most, which state the residual follows, the missing physics in order of
//! evidence with their estimates, the held-out improvement and the effects the data cannot
//! separate.

use super::candidates::Candidate;
use super::format::number;
use super::locate::Location;
use super::model::InverseDynamicsModel;
use super::outcome::{ChannelFit, Confound, Diagnosis, Estimate};

/// The verdict of a finished diagnosis (after its estimates were moved back to the nominal
/// model).
pub(super) fn verdict_text(model: &dyn InverseDynamicsModel, d: &Diagnosis, cands: &[Candidate]) -> String {
    let set: Vec<usize> = d
        .selected
        .iter()
        .filter_map(|n| cands.iter().position(|c| &c.name == n))
        .collect();
    verdict(
        model,
        &set,
        cands,
        &d.estimates,
        &d.channels,
        &d.confounded,
        &d.location,
    )
}

/// The verdict of a selection `set` (indices into `cands`).
pub(super) fn verdict(
    model: &dyn InverseDynamicsModel,
    set: &[usize],
    cands: &[Candidate],
    estimates: &[Estimate],
    channels: &[ChannelFit],
    confounded: &[Confound],
    location: &Location,
) -> String {
    let mut s = String::new();
    if set.is_empty() {
        s.push_str(&format!(
            "No significant mismatch: no candidate physics improves the cross-validated fit of the {} beyond the noise.",
            model.name()
        ));
        return s;
    }
    if let Some(f) = location.findings.first() {
        s.push_str(&format!("The nominal model disagrees most {}. ", f.text));
    }
    for c in &location.correlations {
        s.push_str(&format!(
            "The {} residual follows the {} (r = {:+.2}). ",
            c.channel, c.state, c.r
        ));
    }
    for a in location.associations.iter().filter(|a| a.ratio > 1.5) {
        s.push_str(&format!(
            "In the {} the residual is {:.1}× larger in windows with {}. ",
            a.channel, a.ratio, a.tag
        ));
    }
    s.push_str("Missing physics, in order of evidence: ");
    let parts: Vec<String> = set
        .iter()
        .map(|&c| {
            let est: Vec<String> = estimates
                .iter()
                .filter(|e| e.candidate == cands[c].name)
                .map(|e| format!("{} = {} ± {}", e.parameter, number(e.value), number(e.std)))
                .collect();
            format!("{} ({})", cands[c].name, est.join(", "))
        })
        .collect();
    s.push_str(&parts.join("; "));
    s.push_str(". ");
    for c in channels {
        if c.holdout_before > 0.0 {
            let u = &c.unit;
            s.push_str(&format!(
                "Held out, the {} residual falls from {} to {} {u} RMS ({:+.1} %; noise floor {} {u}). ",
                c.channel,
                number(c.holdout_before),
                number(c.holdout_after),
                -100.0 * c.holdout_reduction,
                number(c.noise_floor)
            ));
        }
    }
    for c in confounded {
        s.push_str(&format!(
            "The data cannot tell {} from {} (cross-validated fits within {:.1} %); {} would separate them. ",
            c.selected,
            c.alternative,
            100.0 * (c.cv_ratio - 1.0).abs(),
            c.experiment
        ));
    }
    s.trim_end().to_string()
}
