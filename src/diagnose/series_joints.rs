//! Which of two joints in series a contact compliance is named at.
//!
//! The two joints of a leg carry the same force, so their contact compliances lengthen the
//! leg alike: torques and platform outputs cannot tell them apart, and which of the two the
//! selection holds follows the noise (cross-validated fits within a fraction of a per cent;
//! diagnosis log, "A leg's two joints"). Choosing inside the selection changes the path of
//! the passes after it (session 61 measured that), so the choice is made once, after the
//! last pass, with the fit's numbers unchanged: where the selection holds joint X's contact
//! compliance, joint Y's fits as well (a confound within the confounding tolerance), the two
//! joints are in series (the model gives their contact compliances a common parameter,
//! [`InverseDynamicsModel::play_site_compliance`](super::model::InverseDynamicsModel::play_site_compliance):
//! for the MR2120 the joint compliance along their leg), Y's play is selected with stable
//! estimates and X's play is not selected, the compliance is named at Y — one joint's
//! bearings then explain both effects.
//!
//! Its estimate is the selected one read in Y's terms as the confound gives it (the fitted
//! column projected on Y's alone, not a refit: the other estimates stay the selection's), and
//! only where that reading lies within Y's bounds and has the sign of the estimate; its
//! uncertainties and leave-one-out values are scaled by the same factor. X's compliance stays
//! in the report as the confound, the pair turned round; the selection's other confounds
//! keep their cross-validated ratios, taken against the named set (the swapped sets are the
//! same), and lose their equivalents, which were read from X's column.

use super::candidates::{separating_experiment, Candidate, Effect};
use super::outcome::{Confound, Diagnosis, Estimate, SeriesNaming, Step};

/// The play site of a candidate that is a joint's play (radial or axial), if it is one.
fn play_site(c: &Candidate) -> Option<usize> {
    match c.effect {
        Effect::Play { site, .. } => Some(site),
        _ => None,
    }
}

/// The play site of a candidate that is a joint's contact compliance, if it is one.
fn compliance_site(c: &Candidate) -> Option<usize> {
    match c.effect {
        Effect::ContactCompliance { site } => Some(site),
        _ => None,
    }
}

/// Names a selected contact compliance at the joint in series with it whose play is
/// selected, where the data cannot tell the two apart (module doc). `series[s]` are the
/// model's parameters that are play site `s`'s contact compliance
/// ([`play_site_compliance`](super::model::InverseDynamicsModel::play_site_compliance)): two
/// sites sharing one are in series. Renames the selection, the greedy steps, the estimate
/// (its value and uncertainties read in the named joint's terms), the correlations and the
/// confounds; `found`, the adequacy's unstable list and the verdict follow from them
/// (`adequacy::refresh`, `verdict_text`). Keeps what it did in [`Diagnosis::series_naming`];
/// leaves `d` untouched where no such choice arises.
pub(super) fn name_compliance_at_play(d: &mut Diagnosis, cands: &[Candidate], series: &[Vec<usize>]) {
    d.series_naming = rename(
        Selected {
            selected: &mut d.selected,
            steps: &mut d.steps,
            estimates: &mut d.estimates,
            correlations: &mut d.correlations,
            confounded: &mut d.confounded,
        },
        cands,
        series,
    );
}

/// The parts of a diagnosis that name its selected effects.
struct Selected<'a> {
    selected: &'a mut Vec<String>,
    steps: &'a mut Vec<Step>,
    estimates: &'a mut Vec<Estimate>,
    correlations: &'a mut Vec<(String, String, f64)>,
    confounded: &'a mut Vec<Confound>,
}

/// [`name_compliance_at_play`] on the naming parts.
fn rename(d: Selected<'_>, cands: &[Candidate], series: &[Vec<usize>]) -> Option<SeriesNaming> {
    let by_name = |n: &str| cands.iter().find(|c| c.name == n);
    let in_series = |x: usize, y: usize| {
        x != y
            && series
                .get(x)
                .zip(series.get(y))
                .is_some_and(|(a, b)| a.iter().any(|p| b.contains(p)))
    };
    // Sites whose play is selected, and those of them with stable estimates.
    let mut played = vec![];
    let mut stable_play = vec![];
    for n in d.selected.iter() {
        if let Some(site) = by_name(n).and_then(play_site) {
            played.push(site);
            if d.estimates.iter().filter(|e| &e.candidate == n).all(|e| e.stable) {
                stable_play.push(site);
            }
        }
    }
    let (held, named, confound) = d.selected.iter().find_map(|s| {
        let x = by_name(s).and_then(compliance_site)?;
        if played.contains(&x) {
            return None;
        }
        // The closest alternative in series whose play is selected.
        d.confounded
            .iter()
            .filter(|c| &c.selected == s && c.equivalent_value.is_some())
            .filter(|c| {
                by_name(&c.alternative)
                    .and_then(compliance_site)
                    .is_some_and(|y| in_series(x, y) && stable_play.contains(&y))
            })
            .min_by(|a, b| (a.cv_ratio - 1.0).abs().total_cmp(&(b.cv_ratio - 1.0).abs()))
            .map(|c| (s.clone(), c.alternative.clone(), c.clone()))
    })?;
    if d.selected.contains(&named) {
        return None;
    }
    let named_cand = by_name(&named)?;
    let value = confound.equivalent_value?;
    let parameter = named_cand.parameters.first()?.clone();
    let (lo, hi) = named_cand
        .bounds
        .first()
        .copied()
        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
    let k = d.estimates.iter().position(|e| e.candidate == held)?;
    let old = d.estimates[k].clone();
    let scale = value / old.value;
    if !(value.is_finite() && scale.is_finite() && scale > 0.0 && (lo..=hi).contains(&value)) {
        return None;
    }
    let e = &mut d.estimates[k];
    e.candidate = named.clone();
    e.parameter = parameter.clone();
    e.value = value;
    e.std = old.std * scale;
    e.std_noise_only = old.std_noise_only * scale;
    e.std_jackknife = old.std_jackknife.map(|s| s * scale);
    e.folds = old.folds.iter().map(|f| f * scale).collect();
    for s in d.selected.iter_mut().filter(|s| **s == held) {
        *s = named.clone();
    }
    for st in d.steps.iter_mut().filter(|st| st.added == held) {
        st.added = named.clone();
    }
    // Correlations are labelled "candidate (parameter)".
    let (held_label, named_label) = (
        format!("{held} ({})", old.parameter),
        format!("{named} ({parameter})"),
    );
    for (a, b, _) in d.correlations.iter_mut() {
        for n in [a, b] {
            if *n == held_label {
                *n = named_label.clone();
            }
        }
    }
    // The confounds: the pair turned round (the held compliance's estimate in its own terms);
    // the held one's others against the named one (the same swapped sets, their ratios
    // divided by the pair's, the experiment for the new pair); another effect's whose
    // alternative was the named one now with the held one as alternative (swapping either
    // compliance in gives the same set).
    let joints = cands.iter().filter_map(|c| c.joint).max().map_or(0, |j| j + 1);
    let before = std::mem::take(d.confounded);
    for c in before {
        if c.selected == held && c.alternative == named {
            d.confounded.push(Confound {
                selected: named.clone(),
                alternative: held.clone(),
                cv_ratio: 1.0 / c.cv_ratio,
                experiment: c.experiment,
                equivalent: Some(format!(
                    "{} = {}",
                    old.parameter,
                    super::format::number(old.value)
                )),
                equivalent_value: Some(old.value),
            });
        } else if c.selected == held || c.alternative == named {
            // The named compliance in the held one's place.
            let (selected, alternative) = if c.selected == held {
                (named.clone(), c.alternative)
            } else {
                (c.selected, held.clone())
            };
            let experiment = by_name(&selected)
                .zip(by_name(&alternative))
                .map(|(a, b)| separating_experiment(a, b, joints))
                .unwrap_or(c.experiment);
            d.confounded.push(Confound {
                selected,
                alternative,
                cv_ratio: c.cv_ratio / confound.cv_ratio,
                experiment,
                equivalent: None,
                equivalent_value: None,
            });
        } else {
            d.confounded.push(c);
        }
    }
    Some(SeriesNaming {
        named,
        instead_of: held,
        cv_ratio: confound.cv_ratio,
    })
}

/// The verdict's sentence on a compliance named at the joint whose play is selected (with a
/// leading space, as the verdict's appended sentences have).
pub(super) fn sentence(n: &SeriesNaming) -> String {
    format!(
        " Of two contact compliances the data cannot tell apart (fits within {:.2} %: joints in series carry the same force, and no torque or platform recording separates them), the {} is named rather than the {} the selection held: the play found is at that joint, and one joint's bearings then explain both.",
        100.0 * (n.cv_ratio - 1.0).abs(),
        n.named,
        n.instead_of
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::PlayDirection;

    fn cand(name: &str, effect: Effect, parameters: &[&str]) -> Candidate {
        Candidate {
            name: name.into(),
            effect,
            joint: None,
            parameters: parameters.iter().map(|p| p.to_string()).collect(),
            grid_parameters: 0,
            bounds: vec![(0.0, 10.0); parameters.len()],
        }
    }

    fn library() -> Vec<Candidate> {
        let play = |joint: &str, site| {
            cand(
                &format!("radial clearance in joint {joint}"),
                Effect::Play {
                    site,
                    direction: PlayDirection::Radial,
                    load_scale: 1.0,
                },
                &["h [m]"],
            )
        };
        let compliance = |joint: &str, site| {
            cand(
                &format!("contact compliance of joint {joint}"),
                Effect::ContactCompliance { site },
                &["s [1]"],
            )
        };
        vec![
            play("F", 0),
            play("R", 1),
            compliance("F", 0),
            compliance("R", 1),
            cand(
                "torque offset in drive A",
                Effect::TorqueOffset,
                &["offset [N m]"],
            ),
        ]
    }

    fn estimate(candidate: &str, parameter: &str, value: f64, std: f64) -> Estimate {
        Estimate {
            candidate: candidate.into(),
            parameter: parameter.into(),
            value,
            std,
            std_noise_only: 0.5 * std,
            std_jackknife: Some(std),
            inflation: 1.0,
            folds: vec![0.9 * value, 1.1 * value],
            stable: true,
        }
    }

    fn confound(selected: &str, alternative: &str, cv_ratio: f64, value: Option<f64>) -> Confound {
        Confound {
            selected: selected.into(),
            alternative: alternative.into(),
            cv_ratio,
            experiment: "a sensor between the joints would separate them".into(),
            equivalent: value.map(|v| format!("s [1] = {v}")),
            equivalent_value: value,
        }
    }

    struct Parts {
        selected: Vec<String>,
        steps: Vec<Step>,
        estimates: Vec<Estimate>,
        correlations: Vec<(String, String, f64)>,
        confounded: Vec<Confound>,
    }

    /// F (site 0) and R (site 1) share their leg's compliance parameter 7: in series.
    const IN_SERIES: [&[usize]; 2] = [&[7], &[7]];

    impl Parts {
        fn rename(&mut self, cands: &[Candidate], series: &[&[usize]]) -> Option<SeriesNaming> {
            let series: Vec<Vec<usize>> = series.iter().map(|s| s.to_vec()).collect();
            rename(
                Selected {
                    selected: &mut self.selected,
                    steps: &mut self.steps,
                    estimates: &mut self.estimates,
                    correlations: &mut self.correlations,
                    confounded: &mut self.confounded,
                },
                cands,
                &series,
            )
        }
    }

    fn step(added: &str) -> Step {
        Step {
            added: added.into(),
            statistic: 10.0,
            p_value: 1e-3,
            cv_rms: 1.0,
            bic: 0.0,
        }
    }

    fn parts(cands: &[Candidate], selected: &[usize], confounded: Vec<Confound>) -> Parts {
        let play_f = &cands[0].name;
        let selected: Vec<String> = selected.iter().map(|&k| cands[k].name.clone()).collect();
        let estimates = selected
            .iter()
            .map(|n| {
                if n.starts_with("radial") {
                    estimate(n, "h [m]", 6e-6, 1e-8)
                } else {
                    estimate(n, "s [1]", 1.0, 0.1)
                }
            })
            .collect();
        Parts {
            steps: selected.iter().map(|n| step(n)).collect(),
            correlations: selected
                .iter()
                .filter(|n| *n != play_f)
                .map(|n| (format!("{play_f} (h [m])"), format!("{n} (s [1])"), -0.9))
                .collect(),
            selected,
            estimates,
            confounded,
        }
    }

    /// F's play selected with R's compliance, which F's fits as well, the two joints in
    /// series: the compliance is named at F, its estimate read in F's terms (the confound's
    /// equivalent, the uncertainties scaled alike), the steps and correlations renamed, R's
    /// kept as the confound turned round, the held compliance's other confound measured
    /// against the named one, and another effect's confound with F's compliance as its
    /// alternative given R's instead.
    #[test]
    fn a_compliance_is_named_at_the_joint_whose_play_is_selected() {
        let cands = library();
        let (play_f, play_r, comp_f, comp_r) =
            (&cands[0].name, &cands[1].name, &cands[2].name, &cands[3].name);
        let mut p = parts(
            &cands,
            &[0, 3],
            vec![
                confound(comp_r, comp_f, 1.0004, Some(1.25)),
                confound(comp_r, &cands[4].name, 1.002, Some(0.3)),
                confound(play_f, play_r, 1.01, Some(5e-6)),
                confound(play_f, comp_f, 1.006, Some(0.2)),
            ],
        );
        let n = p.rename(&cands, &IN_SERIES).expect("named at F");
        assert_eq!((&n.named, &n.instead_of), (comp_f, comp_r));
        assert_eq!(n.cv_ratio, 1.0004);
        assert_eq!(p.selected, vec![play_f.clone(), comp_f.clone()]);
        assert_eq!(p.steps[1].added, *comp_f);
        let e = &p.estimates[1];
        assert_eq!((&e.candidate, e.value), (comp_f, 1.25));
        assert!((e.std - 0.125).abs() < 1e-12 && (e.std_noise_only - 0.0625).abs() < 1e-12);
        assert_eq!(e.folds, vec![0.9 * 1.25, 1.1 * 1.25]);
        assert_eq!(p.correlations[0].1, format!("{comp_f} (s [1])"));
        let turned = &p.confounded[0];
        assert_eq!((&turned.selected, &turned.alternative), (comp_f, comp_r));
        assert!((turned.cv_ratio - 1.0 / 1.0004).abs() < 1e-15);
        assert_eq!(turned.equivalent_value, Some(1.0));
        let other = &p.confounded[1];
        assert_eq!(&other.selected, comp_f);
        assert!((other.cv_ratio - 1.002 / 1.0004).abs() < 1e-15);
        assert_eq!(other.equivalent_value, None);
        assert_eq!(&p.confounded[2].selected, play_f);
        assert_eq!(p.confounded[2].cv_ratio, 1.01);
        let swapped = &p.confounded[3];
        assert_eq!((&swapped.selected, &swapped.alternative), (play_f, comp_r));
        assert!((swapped.cv_ratio - 1.006 / 1.0004).abs() < 1e-15);
        let said = sentence(&n);
        assert!(
            said.starts_with(" Of two")
                && said.contains("within 0.04 %")
                && said.contains("the contact compliance of joint F is named rather than the contact compliance of joint R"),
            "{said}"
        );
        // Applied again, nothing more to name.
        assert_eq!(p.rename(&cands, &IN_SERIES), None);
    }

    /// No renaming where the held compliance's own play is selected, where the alternative's
    /// play is not, where the data tell the two apart (no confound, or none with a value),
    /// where the joints are not in series, where the alternative's play is unstable, or where
    /// the reading lies outside the alternative's bounds.
    #[test]
    fn a_compliance_stays_where_no_play_decides_it() {
        let cands = library();
        let (comp_f, comp_r) = (&cands[2].name, &cands[3].name);
        let tie = |v: f64| vec![confound(comp_r, comp_f, 1.0004, Some(v))];
        let unstable = {
            let mut p = parts(&cands, &[0, 3], tie(1.25));
            p.estimates[0].stable = false;
            p
        };
        let cases: Vec<(Parts, [&[usize]; 2])> = vec![
            (parts(&cands, &[1, 0, 3], tie(1.25)), IN_SERIES),
            (parts(&cands, &[3], tie(1.25)), IN_SERIES),
            (parts(&cands, &[0, 3], vec![]), IN_SERIES),
            (
                parts(&cands, &[0, 3], vec![confound(comp_r, comp_f, 1.0004, None)]),
                IN_SERIES,
            ),
            (parts(&cands, &[0, 3], tie(1.25)), [&[1], &[2]]),
            (unstable, IN_SERIES),
            (parts(&cands, &[0, 3], tie(12.0)), IN_SERIES),
            (parts(&cands, &[0, 3], tie(-0.5)), IN_SERIES),
        ];
        for (k, (mut p, series)) in cases.into_iter().enumerate() {
            let before = p.selected.clone();
            assert_eq!(p.rename(&cands, &series), None, "case {k}");
            assert_eq!(p.selected, before, "case {k}");
            assert!(
                p.estimates.iter().all(|e| e.value == 1.0 || e.value == 6e-6),
                "case {k}"
            );
        }
    }
}
