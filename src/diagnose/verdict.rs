//! The verdict: one paragraph of prose from a finished diagnosis — first whether what
//! remains after the fit is noise (with the explained fraction and the remaining noise ratio
//! per channel, and where it is largest), then where the nominal model disagrees most, which
//! state the residual follows, the missing physics in order of evidence with their estimates (uncertainties including the misfit; estimates that move
//! between leave-one-recording-out folds are reported as unstable, not as found physics), the
//! held-out improvement and the effects the data cannot separate.

use super::adequacy::{fold_movement, opening, Adequacy};
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
        &d.adequacy,
    )
}

/// The verdict of a selection `set` (indices into `cands`).
#[allow(clippy::too_many_arguments)]
pub(super) fn verdict(
    model: &dyn InverseDynamicsModel,
    set: &[usize],
    cands: &[Candidate],
    estimates: &[Estimate],
    channels: &[ChannelFit],
    confounded: &[Confound],
    location: &Location,
    adequacy: &Adequacy,
) -> String {
    let mut s = opening(adequacy, !set.is_empty());
    if set.is_empty() {
        if adequacy.unexplained {
            s.push_str(&format!(
                "No candidate physics improves the cross-validated fit of the {} beyond the noise: what remains lies outside the candidate library. ",
                model.name()
            ));
        } else {
            s.push_str(&format!(
                "No candidate physics improves the cross-validated fit of the {} beyond the noise.",
                model.name()
            ));
            return s;
        }
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
    let describe = |c: usize| {
        let est: Vec<String> = estimates
            .iter()
            .filter(|e| e.candidate == cands[c].name)
            .map(|e| {
                let mut t = format!("{} = {} ± {}", e.parameter, number(e.value), number(e.std));
                if e.std > 1.5 * e.std_noise_only {
                    t.push_str(&format!(" (± {} from the noise alone)", number(e.std_noise_only)));
                }
                if !e.stable {
                    t.push_str(&format!(
                        ", moves {:.0} % between leave-one-recording-out fits",
                        100.0 * fold_movement(e)
                    ));
                }
                t
            })
            .collect();
        format!("{} ({})", cands[c].name, est.join(", "))
    };
    let stable = |c: usize| {
        estimates
            .iter()
            .filter(|e| e.candidate == cands[c].name)
            .all(|e| e.stable)
    };
    let found: Vec<String> = set.iter().copied().filter(|&c| stable(c)).map(describe).collect();
    let unstable: Vec<String> = set
        .iter()
        .copied()
        .filter(|&c| !stable(c))
        .map(describe)
        .collect();
    if !found.is_empty() {
        s.push_str("Missing physics, in order of evidence: ");
        s.push_str(&found.join("; "));
        s.push_str(". ");
    }
    if !unstable.is_empty() {
        s.push_str("Unstable (soaks up model error; not found physics): ");
        s.push_str(&unstable.join("; "));
        s.push_str(". ");
    }
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
    for f in super::equivalents::joint_friction(model, set, cands, estimates) {
        if let Some(t) = super::equivalents::friction_sentence(&f) {
            s.push_str(&t);
        }
    }
    for c in confounded {
        let eq = c
            .equivalent
            .as_ref()
            .map(|e| format!(", which reads as {} in its terms", e))
            .unwrap_or_default();
        s.push_str(&format!(
            "The data cannot tell {} from {} (cross-validated fits within {:.1} %{eq}); {}. ",
            c.selected,
            c.alternative,
            100.0 * (c.cv_ratio - 1.0).abs(),
            c.experiment
        ));
    }
    s.trim_end().to_string()
}
