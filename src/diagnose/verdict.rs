//! The verdict: one paragraph of prose from a finished diagnosis — first whether what
//! remains after the fit is noise (with the explained fraction and the remaining noise ratio
//! per channel, and where it is largest), then where the nominal model disagrees most, which
//! state the residual follows, the missing physics in order of evidence with their estimates (uncertainties including the misfit; estimates that move
//! between leave-one-recording-out folds are reported as unstable, not as found physics), the
//! held-out improvement and the effects the data cannot separate.

use super::adequacy::{fold_movement, opening, Adequacy};
use super::candidates::Candidate;
use super::format::number;
use super::locate::{Association, Location};
use super::model::InverseDynamicsModel;
use super::outcome::{ChannelFit, Confound, Diagnosis, Estimate, PlayDynamicsCheck, UnresolvedPlay};
use super::play_dynamics::ContactDamping;

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
        d.dynamic_play_reference.is_some() || d.dynamic_axial_play_reference.is_some(),
        &d.unresolved_play,
    ) + &d
        .series_naming
        .as_ref()
        .map(super::series_joints::sentence)
        .unwrap_or_default()
        + &d.play_dynamics
            .as_ref()
            .map(play_dynamics_check)
            .unwrap_or_default()
        + &backlash_place(d)
        + &play_damping(
            d.dynamic_play_damping_identified,
            d.dynamic_play_damping,
            &d.dynamic_play_damping_cv,
            &d.dynamic_play_size_cv,
        )
}

/// Whether the fit recordings told the reduced play model's contact damping (the fields of
/// [`Diagnosis`]: whether identified, the damping kept, the grid's and the size search's
/// records): a sentence only when they did not.
fn play_damping(
    identified: Option<bool>,
    kept: Option<ContactDamping>,
    grid: &[(ContactDamping, f64)],
    sized: &[(ContactDamping, f64, f64)],
) -> String {
    let (Some(false), Some(kept)) = (identified, kept) else {
        return String::new();
    };
    let per = super::play_size::best_per_damping(grid, sized);
    let shown: Vec<String> = per.iter().take(3).map(|(c, cv)| format!("{c} {cv:.4}")).collect();
    let spread = per.get(1).map_or(0.0, |n| 100.0 * (n.1 / per[0].1 - 1.0));
    format!(
        " The reduced play model's contact damping is not identified: the best two dampings tried fit the held-back recordings within {spread:.2} % of each other (leave-one-recording-out RMS in noise units: {}); {kept} was kept, not a finding. Where the play rattles (near a singular position, after a load peak) what stays unexplained depends on it; fitting a recording that crosses the play there under load would tell.",
        shown.join(", ")
    )
}

/// Where a backlash taken as a dead zone sits, and whether the data told.
fn backlash_place(d: &Diagnosis) -> String {
    let Some(place) = d.backlash_place else {
        return String::new();
    };
    let tried: Vec<String> = d
        .backlash_place_cv
        .iter()
        .map(|(p, cv)| format!("{} {cv:.4}", p.word()))
        .collect();
    match d.backlash_place_identified {
        Some(true) => format!(
            " The backlash's play sits {place}, chosen by cross-validation (leave-one-recording-out RMS in noise units: {}).",
            tried.join(", ")
        ),
        Some(false) => format!(
            " Where the backlash's play sits the fit recordings do not tell (leave-one-recording-out RMS in noise units: {}, the same to within the confounding tolerance: they barely cross the play); it was taken {place}, the first place tried, not a finding — fitting a recording in which that drive's torque reverses would tell.",
            tried.join(", ")
        ),
        None => format!(" The backlash's play was taken {place}."),
    }
}

/// The verdict of a selection `set` (indices into `cands`); `dynamic_play`: the play
/// candidates took their drive torques from the reduced dynamic play model.
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
    dynamic_play: bool,
    unresolved: &[UnresolvedPlay],
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
    // The localisation reads the nominal model's residual on the fit recordings; said so, for
    // after an opening "What remains is noise" a bare "the residual follows …" reads as the
    // residual after the fit.
    // One sentence per channel: its strongest correlation, the others in brackets.
    for group in location.correlations.chunk_by(|a, b| a.channel == b.channel) {
        let (c, others) = (&group[0], &group[1..]);
        let also: Vec<String> = others
            .iter()
            .map(|o| format!("the {} {:+.2}", o.state, o.r))
            .collect();
        s.push_str(&format!(
            "Against the nominal model, the {} residual follows the {} (r = {:+.2}{}). ",
            c.channel,
            c.state,
            c.r,
            if also.is_empty() {
                String::new()
            } else {
                format!("; also {}", also.join(", "))
            }
        ));
    }
    s.push_str(&association_sentences(&location.associations));
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
        format!(
            "{} ({})",
            super::outcome::claimed_name(&cands[c].name, unresolved),
            est.join(", ")
        )
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
    s.push_str(&unresolved_sentences(unresolved));
    if let Some(t) = play_dynamics(set, cands, adequacy, &stable, dynamic_play) {
        s.push_str(&t);
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
    s.push_str(&confound_sentences(confounded));
    s.trim_end().to_string()
}

/// One sentence per channel on the states whose windows hold a residual more than 1.5× that of
/// the rest, strongest first: "Against the nominal model, the drive A torque residual is larger
/// in windows with a load reversal in drive C (2.6×), with a velocity reversal of drive B (1.8×)
/// and near the direct-kinematics singularity (measure below 0.3; 1.6×)."
fn association_sentences(associations: &[Association]) -> String {
    let strong: Vec<&Association> = associations.iter().filter(|a| a.ratio > 1.5).collect();
    let mut s = String::new();
    for group in strong.chunk_by(|a, b| a.channel == b.channel) {
        let parts: Vec<String> = group
            .iter()
            .map(|a| {
                super::locate::with_note(
                    &super::locate::windows_phrase(&a.tag),
                    &format!("{:.1}×", a.ratio),
                )
            })
            .collect();
        let listed = match parts.split_last() {
            Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
            _ => parts.join(""),
        };
        s.push_str(&format!(
            "Against the nominal model, the {} residual is larger in windows {listed}. ",
            group[0].channel
        ));
    }
    s
}

/// The verdict's sentences on plays whose estimates fell below their balls' compression.
fn unresolved_sentences(unresolved: &[UnresolvedPlay]) -> String {
    let um = |v: f64| format!("{:.2} µm", v * 1e6);
    unresolved
        .iter()
        .map(|u| {
            let head = format!(
                "The {} fitted {}, below the {} its balls compress under the joint's own load (RMS): no play is resolved there, and what it fitted is the joint's contact compliance",
                u.play,
                um(u.estimate),
                um(u.compression)
            );
            match (&u.compliance, &u.alternative, u.cv_ratio) {
                (Some(c), _, Some(r)) => format!(
                    "{head}, named as the {c} (cross-validated fit {:+.2} % against the play's). ",
                    100.0 * (r - 1.0)
                ),
                (None, Some(a), Some(r)) => format!(
                    "{head}; the {a} fits {:.2} % worse (cross-validated), beyond the confounding tolerance, so it is reported as the contact compliance of joint {} in the play model's terms. ",
                    100.0 * (r - 1.0),
                    u.joint
                ),
                _ if u.declared == 0 => {
                    format!("{head}; the model declares no compliance candidate for that joint. ")
                }
                _ => format!(
                    "{head}; its compliance candidates are already in the selection (or fit implausibly in its place), so it is reported as the contact compliance of joint {} in the play model's terms. ",
                    u.joint
                ),
            }
        })
        .collect()
}

/// The verdict's sentences on effects the data cannot tell apart: per selected effect, the
/// [`CONFOUNDS_IN_VERDICT`] closest alternatives (by cross-validated error) with the
/// experiment that would separate them, and a count of the others.
fn confound_sentences(confounded: &[Confound]) -> String {
    let mut s = String::new();
    let mut seen: Vec<&str> = vec![];
    for c in confounded {
        if seen.contains(&c.selected.as_str()) {
            continue;
        }
        seen.push(&c.selected);
        let mut alts: Vec<&Confound> = confounded.iter().filter(|x| x.selected == c.selected).collect();
        alts.sort_by(|a, b| (a.cv_ratio - 1.0).abs().total_cmp(&(b.cv_ratio - 1.0).abs()));
        for a in alts.iter().take(CONFOUNDS_IN_VERDICT) {
            let eq = a
                .equivalent
                .as_ref()
                .map(|e| format!(", which reads as {} in its terms", e))
                .unwrap_or_default();
            s.push_str(&format!(
                "The data cannot tell {} from {} (cross-validated fits within {:.1} %{eq}); {}. ",
                a.selected,
                a.alternative,
                100.0 * (a.cv_ratio - 1.0).abs(),
                a.experiment
            ));
        }
        if let Some(rest) = alts.get(CONFOUNDS_IN_VERDICT..).filter(|r| !r.is_empty()) {
            let widest = rest.iter().map(|a| (a.cv_ratio - 1.0).abs()).fold(0.0, f64::max);
            s.push_str(&format!(
                "{} more candidates fit as well as {} (within {:.1} %; every pair is listed in the report). ",
                rest.len(),
                c.selected,
                100.0 * widest
            ));
        }
    }
    s
}

/// Alternatives the verdict names per selected effect that the data cannot tell from it
/// (the closest by cross-validated error); the others are counted.
pub const CONFOUNDS_IN_VERDICT: usize = 3;

/// A residual left several times larger at load reversals after a joint's play was found
/// says what the quasi-static play candidates leave out: the joint crossing its clearance when
/// its load reverses and what that excites — an impact, and the ringing of the drives'
/// transmissions it sets off — which they cannot express (they place the joint against the
/// side its load pushes it to, as if it got there at once). Measured on the multibody suite's
/// bearing truths (diagnosis log, "What the play leaves in the torques"): with lubricated contacts
/// the torque part is mostly the transmissions' ringing near the direct singularity, three
/// times smaller with three times their damping. The channels whose unexplained residual
/// concentrates at load reversals (> 3× larger there) are named.
fn play_dynamics(
    set: &[usize],
    cands: &[Candidate],
    adequacy: &Adequacy,
    stable: &dyn Fn(usize) -> bool,
    dynamic: bool,
) -> Option<String> {
    use super::candidates::Effect;
    let play: Vec<&str> = set
        .iter()
        .copied()
        .filter(|&c| {
            stable(c)
                && matches!(
                    cands[c].effect,
                    Effect::Play { .. } | Effect::Clearance { .. } | Effect::Backlash { .. }
                )
        })
        .map(|c| cands[c].name.as_str())
        .collect();
    let at_reversals: Vec<String> = adequacy
        .channels
        .iter()
        .filter(|c| c.unexplained)
        .filter_map(|c| {
            let e = c.strongest_state.as_ref()?;
            (e.tag.starts_with("load reversal") && e.ratio > 3.0)
                .then(|| format!("{} ({:.1}× at {})", c.channel, e.ratio, e.tag))
        })
        .collect();
    if play.is_empty() || at_reversals.is_empty() {
        return None;
    }
    let model = if dynamic {
        "the reduced dynamic play model of {} (in the selection) does not capture in full"
    } else {
        "the quasi-static play of {} leaves out"
    };
    Some(format!(
        "What the found play does not explain comes at load reversals — {}: the joint crossing its clearance when its load reverses and what that excites (an impact, the ringing of the drives' transmissions), which {}. ",
        at_reversals.join(", "),
        model.replace("{}", &play.join(" and "))
    ))
}

/// The verdict's closing sentence on a [`PlayDynamicsCheck`] (also the report's): with the
/// found play's dynamics in the drive torques, the residual over the noise of every channel
/// that moved by more than 5 %, and the play's refitted clearance.
pub(super) fn play_dynamics_check(c: &PlayDynamicsCheck) -> String {
    let moved: Vec<String> = c
        .channels
        .iter()
        .filter(|x| (x.noise_ratio_with - x.noise_ratio_without).abs() > 0.05 * x.noise_ratio_without)
        .map(|x| {
            format!(
                "{} {:.1}× → {:.1}×",
                x.channel, x.noise_ratio_without, x.noise_ratio_with
            )
        })
        .collect();
    let refit = c
        .refit_clearance
        .map(|h| format!("refitted so, the play reads {:.2} µm", h * 1e6))
        .unwrap_or_else(|| "refitted so, the play drops out".into());
    let better = c
        .channels
        .iter()
        .any(|x| x.noise_ratio_with < 0.95 * x.noise_ratio_without);
    if moved.is_empty() || !better {
        return format!(
            " The reduced dynamic play model for the {}, taken at its estimate ({:.2} µm) in the drive torques with the selection refitted, does not explain what remains ({refit}).",
            c.candidate,
            c.clearance * 1e6
        );
    }
    format!(
        " With the drive torques of the reduced dynamic play model for the {}, taken at its estimate ({:.2} µm) with the selection refitted, the residual over the noise goes {}: that much of what remains is the play's dynamics, which no quasi-static candidate expresses ({refit}; the dynamic model cannot tell the two joints of a leg apart, so it does not change the diagnosis).",
        c.candidate,
        c.clearance * 1e6,
        moved.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::adequacy::{ChannelAdequacy, StateExcess};
    use crate::diagnose::candidates::{Effect, PlayDirection};

    fn candidate(name: &str, effect: Effect) -> Candidate {
        crate::diagnose::candidates::test_candidate(name, effect, true)
    }

    /// The windows' states: one sentence per channel, strongest first, only those above 1.5×,
    /// and a configuration tag keeps its own preposition ("near …", not "with near …").
    #[test]
    fn window_states_are_one_sentence_per_channel() {
        let a = |channel: &str, tag: &str, ratio: f64| Association {
            channel: channel.into(),
            tag: tag.into(),
            ratio,
            windows: 5,
        };
        let t = association_sentences(&[
            a("drive A torque", "load reversal in drive C", 2.6),
            a("drive A torque", "velocity reversal of drive B", 1.8),
            a(
                "drive A torque",
                "near the direct-kinematics singularity (measure below 0.3)",
                1.6,
            ),
            a("drive B torque", "acceleration peak of drive B", 1.7),
            a("drive B torque", "high speed of drive A", 1.6),
            a("drive B torque", "drive C at rest", 1.2),
            a("drive C torque", "drive C at rest", 1.4),
        ]);
        assert_eq!(
            t,
            "Against the nominal model, the drive A torque residual is larger in windows with a \
             load reversal in drive C (2.6×), with a velocity reversal of drive B (1.8×) and near \
             the direct-kinematics singularity (measure below 0.3; 1.6×). Against the nominal \
             model, the drive B torque residual is larger in windows with an acceleration peak \
             of drive B (1.7×) and with drive A at high speed (1.6×). "
        );
        assert!(association_sentences(&[a("drive C torque", "drive C at rest", 1.4)]).is_empty());
        assert_eq!(
            super::super::locate::windows_phrase("drive C at rest"),
            "with drive C at rest"
        );
    }

    /// A damping the fit recordings do not tell: the sentence names the spread, the best
    /// dampings and the one kept; none when told or not asked.
    #[test]
    fn an_unidentified_contact_damping_is_said_to_be_no_finding() {
        let c = |constant: f64, load: f64| ContactDamping { constant, load };
        let grid = [
            (c(20.0, 1000.0), 1.377),
            (c(20.0, 250.0), 1.378),
            (c(20.0, 500.0), 1.384),
        ];
        let t = play_damping(Some(false), Some(c(20.0, 1000.0)), &grid, &[]);
        assert!(t.contains("not identified"), "{t}");
        assert!(t.contains("within 0.07 %"), "{t}");
        assert!(
            t.contains("20 N s/m + 1000 s/m × F 1.3770, 20 N s/m + 250 s/m × F 1.3780"),
            "{t}"
        );
        assert!(
            t.contains("20 N s/m + 1000 s/m × F was kept, not a finding"),
            "{t}"
        );
        assert!(play_damping(Some(true), Some(c(20.0, 1000.0)), &grid, &[]).is_empty());
        assert!(play_damping(None, Some(c(20.0, 1000.0)), &grid, &[]).is_empty());
    }

    /// A play below its compression: the sentence says which compliance took its place, or
    /// why none did (fits worse; already selected; none declared).
    #[test]
    fn an_unresolved_play_says_why_it_is_or_is_not_named_as_a_compliance() {
        let u = UnresolvedPlay {
            play: "radial clearance in joint D (reduced dynamic model)".into(),
            joint: "D".into(),
            estimate: 8e-8,
            compression: 5.3e-7,
            compliance: None,
            alternative: None,
            declared: 2,
            cv_ratio: None,
        };
        let text = |u: &UnresolvedPlay| unresolved_sentences(std::slice::from_ref(u));
        let t = text(&u);
        assert!(t.contains("fitted 0.08 µm, below the 0.53 µm"), "{t}");
        assert!(t.contains("already in the selection"), "{t}");
        assert!(t.contains("contact compliance of joint D"), "{t}");
        let none = UnresolvedPlay {
            declared: 0,
            ..u.clone()
        };
        assert!(text(&none).contains("declares no compliance candidate"));
        let worse = UnresolvedPlay {
            alternative: Some("error in joint compliance along leg A".into()),
            cv_ratio: Some(1.0217),
            ..u.clone()
        };
        assert!(text(&worse).contains("fits 2.17 % worse"), "{}", text(&worse));
        let named = UnresolvedPlay {
            compliance: Some("error in joint compliance along leg A".into()),
            alternative: Some("error in joint compliance along leg A".into()),
            cv_ratio: Some(1.003),
            ..u
        };
        assert!(
            text(&named)
                .contains("named as the error in joint compliance along leg A (cross-validated fit +0.30 %"),
            "{}",
            text(&named)
        );
    }

    fn adequacy(tag: &str, ratio: f64, unexplained: bool) -> Adequacy {
        Adequacy {
            basis: "held-out".into(),
            unexplained_noise_ratio: 1.2,
            whiteness_lags: 20,
            whiteness_alpha: 1e-3,
            far_from_white_lag1: 0.3,
            window: (0.5, 3.0),
            channels: vec![ChannelAdequacy {
                channel: "drive A torque".into(),
                unit: "N m".into(),
                noise_floor: 0.02,
                rms_before: 0.19,
                rms_after: 0.13,
                noise_ratio_before: 9.3,
                noise_ratio_after: 6.7,
                explained_fraction: 0.49,
                autocorrelation: vec![0.89],
                ljung_box: 1e4,
                whiteness_p: 0.0,
                far_from_white: true,
                windows: 20,
                significant_windows: 3,
                impulsive_events: Default::default(),
                worst_window: None,
                strongest_state: Some(StateExcess {
                    tag: tag.into(),
                    ratio,
                    windows: 5,
                }),
                unexplained,
            }],
            explained_fraction: 0.7,
            unexplained,
            unstable: vec![],
        }
    }

    /// Ljung–Box rejects whiteness on thousands of samples at the faintest colour: a residual
    /// it rejects with a small lag-1 autocorrelation is said to be weakly coloured, not close
    /// to white.
    #[test]
    fn a_residual_whose_whiteness_is_rejected_is_never_called_close_to_white() {
        let mut a = adequacy("load reversal in drive A", 1.9, true);
        let c = &mut a.channels[0];
        assert_eq!(crate::diagnose::adequacy::whiteness_text(c), "far from white");
        (c.far_from_white, c.autocorrelation, c.whiteness_p) = (false, vec![0.27], 2.8e-239);
        assert_eq!(
            crate::diagnose::adequacy::whiteness_text(c),
            "coloured, but weakly"
        );
        c.whiteness_p = 0.4;
        assert_eq!(crate::diagnose::adequacy::whiteness_text(c), "close to white");
    }

    /// After a joint's play is found, a residual concentrated at load reversals is named as
    /// the play's dynamics; not after friction, not when the residual is elsewhere or at
    /// noise, not when the play's estimate is unstable.
    #[test]
    fn the_play_dynamics_are_named_only_when_the_residual_sits_at_load_reversals() {
        let cands = vec![
            candidate(
                "radial clearance in joint F",
                Effect::Play {
                    site: 2,
                    direction: PlayDirection::Radial,
                    load_scale: 5.0,
                },
            ),
            candidate("Coulomb friction in drive A", Effect::Coulomb { v_c: 0.01 }),
        ];
        let yes = |_: usize| true;
        let at_reversal = adequacy("load reversal in drive A", 9.2, true);
        let t = play_dynamics(&[0], &cands, &at_reversal, &yes, false).expect("a sentence");
        assert!(
            t.contains("drive A torque (9.2× at load reversal in drive A)"),
            "{t}"
        );
        assert!(t.contains("radial clearance in joint F"), "{t}");
        assert!(t.contains("ringing of the drives' transmissions"), "{t}");
        assert!(
            t.contains("quasi-static play of radial clearance in joint F"),
            "{t}"
        );
        // With the play's dynamics in the selection, the sentence says so.
        let t = play_dynamics(&[0], &cands, &at_reversal, &yes, true).expect("a sentence");
        assert!(
            t.contains("reduced dynamic play model of radial clearance in joint F (in the selection)"),
            "{t}"
        );
        assert!(play_dynamics(&[1], &cands, &at_reversal, &yes, false).is_none());
        assert!(play_dynamics(&[0], &cands, &at_reversal, &|_| false, false).is_none());
        let elsewhere = adequacy("acceleration peak of drive A", 9.2, true);
        assert!(play_dynamics(&[0], &cands, &elsewhere, &yes, false).is_none());
        let weak = adequacy("load reversal in drive A", 2.0, true);
        assert!(play_dynamics(&[0], &cands, &weak, &yes, false).is_none());
        let at_noise = adequacy("load reversal in drive A", 9.2, false);
        assert!(play_dynamics(&[0], &cands, &at_noise, &yes, false).is_none());
    }

    /// The play-dynamics check's sentence names the channels it moved with both ratios and
    /// the refitted clearance, and says so when the dynamics explain nothing.
    #[test]
    fn the_verdict_says_how_much_the_plays_dynamics_explain() {
        use crate::diagnose::outcome::PlayDynamicsChannel;
        let ch = |channel: &str, without: f64, with: f64| PlayDynamicsChannel {
            channel: channel.into(),
            noise_ratio_without: without,
            noise_ratio_with: with,
        };
        let check = PlayDynamicsCheck {
            candidate: "radial clearance in joint F (load scale 5 N)".into(),
            clearance: 6.47e-6,
            refit_clearance: Some(3.39e-6),
            selected: vec![],
            channels: vec![ch("drive A torque", 6.6, 3.4), ch("platform y", 1.13, 1.14)],
        };
        let t = play_dynamics_check(&check);
        assert!(t.contains("6.47 µm"), "{t}");
        assert!(t.contains("drive A torque 6.6× → 3.4×"), "{t}");
        assert!(!t.contains("platform y"), "{t}");
        assert!(t.contains("3.39 µm"), "{t}");
        let none = PlayDynamicsCheck {
            channels: vec![ch("drive A torque", 6.6, 6.7)],
            refit_clearance: None,
            ..check
        };
        let t = play_dynamics_check(&none);
        assert!(t.contains("does not explain what remains"), "{t}");
        assert!(t.contains("drops out"), "{t}");
    }

    /// A selected effect that many candidates fit as well gets its three closest named (the
    /// closest first) and the rest counted, not a sentence each.
    #[test]
    fn the_verdict_names_the_closest_confounds_and_counts_the_rest() {
        let confound = |selected: &str, alternative: &str, cv_ratio: f64| Confound {
            selected: selected.into(),
            alternative: alternative.into(),
            cv_ratio,
            experiment: "a slower motion would separate them".into(),
            equivalent: None,
            equivalent_value: None,
        };
        let mut list: Vec<Confound> = (0..10)
            .map(|k| {
                confound(
                    "play in F",
                    &format!("alternative {k}"),
                    1.0 + 0.001 * (10 - k) as f64,
                )
            })
            .collect();
        list.push(confound("compliance of leg C", "drive C compliance", 1.001));
        let s = confound_sentences(&list);
        assert_eq!(
            s.matches("The data cannot tell play in F").count(),
            CONFOUNDS_IN_VERDICT
        );
        // Closest by cross-validated error: alternatives 9, 8, 7 (0.1 %, 0.2 %, 0.3 %).
        let (a9, a8, a7) = (
            s.find("alternative 9").unwrap(),
            s.find("alternative 8").unwrap(),
            s.find("alternative 7").unwrap(),
        );
        assert!(a9 < a8 && a8 < a7, "{s}");
        assert!(!s.contains("alternative 6"), "{s}");
        assert!(
            s.contains("7 more candidates fit as well as play in F (within 1.0 %"),
            "{s}"
        );
        assert!(
            s.contains("The data cannot tell compliance of leg C from drive C compliance"),
            "{s}"
        );
        assert!(
            !s.contains("more candidates fit as well as compliance of leg C"),
            "{s}"
        );
    }
}
