//! Which of two joints in series a contact compliance is named at.
//!
//! The two joints of a leg carry the same force, so their contact compliances lengthen the
//! leg alike: torques and platform outputs cannot tell them apart, and which of the two the
//! selection holds follows the noise (cross-validated fits within a fraction of a per cent;
//! diagnosis log, "A leg's two joints"). Choosing inside the selection changes the path of
//! the passes after it (session 61 measured that), so the choice is made once, after the
//! last pass, with the fit's numbers unchanged: where the selection holds joint X's contact
//! compliance, joint Y's fits as well (a confound within the confounding tolerance), Y's
//! play is selected and X's is not, the compliance is named at Y — one joint's bearings then
//! explain both effects. Its estimate is the selected one read in Y's terms (the confound's
//! equivalent: the fitted column projected on Y's), its uncertainties scaled alike, and X's
//! compliance stays in the report as the confound, with the experiment that would separate
//! them.

use super::candidates::{Candidate, Effect};
use super::outcome::{Confound, Diagnosis, Estimate, SeriesNaming};

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

/// Names a selected contact compliance at the joint whose play is selected, where the data
/// cannot tell it from the one the selection holds (module doc). Renames the selection, the
/// estimate (its value and uncertainties read in the named joint's terms), the correlations
/// and the confounds; `found`, the adequacy's unstable list and the verdict follow from them
/// (`adequacy::refresh`, `verdict_text`). Keeps what it did in [`Diagnosis::series_naming`];
/// leaves `d` untouched where no such choice arises.
pub(super) fn name_compliance_at_play(d: &mut Diagnosis, cands: &[Candidate]) {
    d.series_naming = rename(
        Selected {
            selected: &mut d.selected,
            estimates: &mut d.estimates,
            correlations: &mut d.correlations,
            confounded: &mut d.confounded,
        },
        cands,
    );
}

/// The parts of a diagnosis that name its selected effects.
struct Selected<'a> {
    selected: &'a mut Vec<String>,
    estimates: &'a mut Vec<Estimate>,
    correlations: &'a mut Vec<(String, String, f64)>,
    confounded: &'a mut Vec<Confound>,
}

/// [`name_compliance_at_play`] on the naming parts.
fn rename(d: Selected<'_>, cands: &[Candidate]) -> Option<SeriesNaming> {
    let by_name = |n: &str| cands.iter().find(|c| c.name == n);
    let selected_play_sites: Vec<usize> = d
        .selected
        .iter()
        .filter_map(|n| by_name(n).and_then(play_site))
        .collect();
    let (held, named, confound) = d.selected.iter().find_map(|s| {
        let x = by_name(s).and_then(compliance_site)?;
        if selected_play_sites.contains(&x) {
            return None;
        }
        // The closest alternative at a joint whose play is selected.
        d.confounded
            .iter()
            .filter(|c| &c.selected == s && c.equivalent_value.is_some())
            .filter(|c| {
                by_name(&c.alternative)
                    .and_then(compliance_site)
                    .is_some_and(|y| y != x && selected_play_sites.contains(&y))
            })
            .min_by(|a, b| (a.cv_ratio - 1.0).abs().total_cmp(&(b.cv_ratio - 1.0).abs()))
            .map(|c| (s.clone(), c.alternative.clone(), c.clone()))
    })?;
    if d.selected.contains(&named) {
        return None;
    }
    let value = confound.equivalent_value?;
    let parameter = by_name(&named)?.parameters.first()?.clone();
    let k = d.estimates.iter().position(|e| e.candidate == held)?;
    let old = d.estimates[k].clone();
    if !(value.is_finite() && old.value.is_finite() && old.value != 0.0) {
        return None;
    }
    let scale = value / old.value;
    let e = &mut d.estimates[k];
    e.candidate = named.clone();
    e.parameter = parameter;
    e.value = value;
    e.std = old.std * scale.abs();
    e.std_noise_only = old.std_noise_only * scale.abs();
    e.std_jackknife = old.std_jackknife.map(|s| s * scale.abs());
    e.folds = old.folds.iter().map(|f| f * scale).collect();
    for s in d.selected.iter_mut().filter(|s| **s == held) {
        *s = named.clone();
    }
    for (a, b, _) in d.correlations.iter_mut() {
        for n in [a, b] {
            if *n == held {
                *n = named.clone();
            }
        }
    }
    // The confounds of the held compliance become the named one's: the pair itself turned
    // round (the held one's estimate read in its own terms), the others measured against
    // the named one's fit (their ratios divided by the pair's).
    let before = std::mem::take(d.confounded);
    for c in before {
        if c.selected != held {
            d.confounded.push(c);
        } else if c.alternative == named {
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
        } else {
            d.confounded.push(Confound {
                selected: named.clone(),
                cv_ratio: c.cv_ratio / confound.cv_ratio,
                equivalent: None,
                equivalent_value: None,
                ..c
            });
        }
    }
    Some(SeriesNaming {
        named,
        instead_of: held,
        cv_ratio: confound.cv_ratio,
    })
}

/// The verdict's sentence on a compliance named at the joint whose play is selected.
pub(super) fn sentence(n: &SeriesNaming) -> String {
    format!(
        "The {} is named at the joint whose play was found, one joint's bearings explaining both; the selection held the {}, which fits within {:.2} % — joints in series carry the same force, and no torque or platform recording tells their compliances apart. ",
        n.named,
        n.instead_of,
        100.0 * (n.cv_ratio - 1.0).abs()
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
        estimates: Vec<Estimate>,
        correlations: Vec<(String, String, f64)>,
        confounded: Vec<Confound>,
    }

    impl Parts {
        fn rename(&mut self, cands: &[Candidate]) -> Option<SeriesNaming> {
            rename(
                Selected {
                    selected: &mut self.selected,
                    estimates: &mut self.estimates,
                    correlations: &mut self.correlations,
                    confounded: &mut self.confounded,
                },
                cands,
            )
        }
    }

    /// F's play selected with R's compliance, which F's fits as well: the compliance is
    /// named at F, its estimate read in F's terms (the confound's equivalent, the
    /// uncertainties scaled alike), R's kept as the confound turned round, and another
    /// confound of the held compliance measured against the named one.
    #[test]
    fn a_compliance_is_named_at_the_joint_whose_play_is_selected() {
        let cands = library();
        let (play_f, comp_f, comp_r) = (&cands[0].name, &cands[2].name, &cands[3].name);
        let mut p = Parts {
            selected: vec![play_f.clone(), comp_r.clone()],
            estimates: vec![
                estimate(play_f, "h [m]", 6e-6, 1e-8),
                estimate(comp_r, "s [1]", 1.0, 0.1),
            ],
            correlations: vec![(play_f.clone(), comp_r.clone(), -0.9)],
            confounded: vec![
                confound(comp_r, comp_f, 1.0004, Some(1.25)),
                confound(comp_r, &cands[4].name, 1.002, Some(0.3)),
                confound(play_f, &cands[1].name, 1.01, Some(5e-6)),
            ],
        };
        let n = p.rename(&cands).expect("named at F");
        assert_eq!((&n.named, &n.instead_of), (comp_f, comp_r));
        assert_eq!(n.cv_ratio, 1.0004);
        assert_eq!(p.selected, vec![play_f.clone(), comp_f.clone()]);
        let e = &p.estimates[1];
        assert_eq!((&e.candidate, e.value), (comp_f, 1.25));
        assert!((e.std - 0.125).abs() < 1e-12 && (e.std_noise_only - 0.0625).abs() < 1e-12);
        assert_eq!(e.folds, vec![0.9 * 1.25, 1.1 * 1.25]);
        assert_eq!(p.correlations[0].1, *comp_f);
        let turned = &p.confounded[0];
        assert_eq!((&turned.selected, &turned.alternative), (comp_f, comp_r));
        assert!((turned.cv_ratio - 1.0 / 1.0004).abs() < 1e-15);
        assert_eq!(turned.equivalent_value, Some(1.0));
        let other = &p.confounded[1];
        assert_eq!(&other.selected, comp_f);
        assert!((other.cv_ratio - 1.002 / 1.0004).abs() < 1e-15);
        assert_eq!(other.equivalent_value, None);
        assert_eq!(&p.confounded[2].selected, play_f);
        // Applied again, nothing more to name.
        assert_eq!(p.rename(&cands), None);
    }

    /// No renaming where the held compliance's own play is selected, where the alternative's
    /// play is not, or where the data tell the two apart (no confound).
    #[test]
    fn a_compliance_stays_where_no_play_decides_it() {
        let cands = library();
        let (play_f, play_r, comp_f, comp_r) =
            (&cands[0].name, &cands[1].name, &cands[2].name, &cands[3].name);
        let parts = |selected: Vec<&String>, confounded: Vec<Confound>| Parts {
            selected: selected.into_iter().cloned().collect(),
            estimates: vec![estimate(comp_r, "s [1]", 1.0, 0.1)],
            correlations: vec![],
            confounded,
        };
        let tie = || vec![confound(comp_r, comp_f, 1.0004, Some(1.25))];
        for mut p in [
            parts(vec![play_r, play_f, comp_r], tie()),
            parts(vec![comp_r], tie()),
            parts(vec![play_f, comp_r], vec![]),
            parts(vec![play_f, comp_r], vec![confound(comp_r, comp_f, 1.0004, None)]),
        ] {
            let before = p.selected.clone();
            assert_eq!(p.rename(&cands), None);
            assert_eq!(p.selected, before);
            assert_eq!(p.estimates[0].value, 1.0);
        }
    }
}
