//! Selection: rank every candidate by its likelihood-ratio test at the nominal model, add
//! effects greedily by cross-validated error and an information criterion (among the
//! candidates the data cannot tell apart, the simpler law), drop members that no longer earn
//! their place given the others (backward elimination), re-weigh the channels once, then
//! estimate the selected parameters with their uncertainty and flag the effects the data
//! cannot separate.
//!
//! Statistics. Residuals are weighted by each channel's noise floor. Model misfit is smooth,
//! so residual samples are not independent: tests and the information criterion use an
//! effective sample count n·(1 − ρ)/(1 + ρ), ρ the lag-1 autocorrelation of the residual left
//! after fitting the whole library (what remains is closest to the noise). Candidates are
//! ranked by the likelihood-ratio statistic n_eff·ln(RSS₀/RSS₁) (χ² with as many degrees of
//! freedom as columns). A candidate joins the model only if (1) its test is significant,
//! (2) the leave-one-recording-out cross-validated residual falls by at least `min_gain`,
//! and (3) the effective BIC falls.

use super::candidates::{separating_experiment, Candidate, Effect};
use super::error::DiagnoseError;
use super::options::DiagnoseOptions;
use super::outcome::{Confound, Estimate, Ranked, Step, UnresolvedPlay};
use super::residuals::Prepared;
use super::signal::{effective_samples, lag1};
use super::stats::{chi2_sf, Gram};

/// The outcome of the greedy selection.
pub(super) struct Selection {
    /// Residuals and columns with the final channel weights.
    pub prep: Prepared,
    /// Selected candidates (indices into the library), in order.
    pub set: Vec<usize>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// Cross-validated RSS of the selection.
    pub cv: f64,
    /// Every candidate's test at the nominal model, strongest first.
    pub ranking: Vec<Ranked>,
    /// Samples × channels.
    pub n: usize,
    /// Effective independent samples.
    pub n_eff: f64,
    /// The Gram matrices of all recordings summed.
    pub total: Gram,
    /// Final channel weights (in the units of the residual `raw` was prepared with).
    pub weight_scale: Vec<f64>,
    /// Selected plays whose estimates fell below their balls' compression, with the
    /// candidate index of the play.
    pub unresolved: Vec<(usize, UnresolvedPlay)>,
}

/// Ranks and selects on `raw` (residuals divided by the noise floors `sigma`; recording r
/// has `lens[r]` samples per channel); `compliance_of[c]`: the candidates that are the
/// contact compliance of play candidate c's joint ([`super::candidates::compliance_of`]).
pub(super) fn select(
    raw: &Prepared,
    cands: &[Candidate],
    compliance_of: &[Vec<usize>],
    lens: &[usize],
    sigma: &[f64],
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Selection, DiagnoseError> {
    let nj = sigma.len();
    // Channel weights: the larger of the noise floor and the nominal misfit of the channel,
    // so a channel whose misfit dwarfs its noise does not drown the others (one step of
    // feasible generalised least squares).
    let mut weight_scale: Vec<f64> = (0..nj)
        .map(|j| {
            let (ss, cnt) = raw
                .blocks
                .iter()
                .zip(lens)
                .fold((0.0, 0usize), |(ss, cnt), ((_, b), &n)| {
                    (
                        ss + b[j * n..(j + 1) * n].iter().map(|v| v * v).sum::<f64>(),
                        cnt + n,
                    )
                });
            (ss / cnt.max(1) as f64).sqrt().max(sigma[j])
        })
        .collect();
    let mut pass = 0;
    let (prep, set, steps, cv_cur, ranking, n, n_eff, total, unresolved) = loop {
        let prep = raw.reweighed(&weight_scale, lens)?;
        let n: usize = prep.grams.iter().map(|g| g.n).sum();
        // Effective samples from the residual left by the whole library.
        let all: Vec<usize> = (0..cands.len()).collect();
        let total = prep.total().clone();
        let x_all = total.solve(&prep.idx(&all));
        let rhos: Vec<f64> = (0..lens.len())
            .flat_map(|r| {
                let res = prep.residual(r, &all, &x_all);
                let len = lens[r];
                (0..nj)
                    .map(move |j| lag1(&res[j * len..(j + 1) * len]))
                    .collect::<Vec<_>>()
            })
            .collect();
        let rho = rhos.iter().sum::<f64>() / rhos.len() as f64;
        let n_eff = effective_samples(n, rho);
        let lr = |rss0: f64, rss1: f64| n_eff * (rss0.max(1e-300) / rss1.max(1e-300)).ln();
        let bic = |set: &[usize]| n_eff * (prep.rss(set) / n as f64).ln() + prep.dof(set) as f64 * n_eff.ln();
        // Ranking at the nominal model.
        progress("score tests", 0.3);
        let rss0 = total.bb;
        let cv0 = prep.cv_rss(&[]);
        let mut ranking: Vec<(usize, Ranked)> = (0..cands.len())
            .map(|c| {
                let stat = lr(rss0, prep.rss(&[c]));
                let k = prep.cols_of[c].len() + cands[c].grid_parameters;
                (
                    c,
                    Ranked {
                        candidate: cands[c].name.clone(),
                        statistic: stat,
                        p_value: chi2_sf(stat, k),
                        cv_ratio: (prep.cv_rss(&[c]) / cv0).sqrt(),
                        plausible: prep.plausible(&[c]),
                    },
                )
            })
            .collect();
        ranking.sort_by(|a, b| b.1.statistic.total_cmp(&a.1.statistic));
        // Greedy selection.
        let mut set: Vec<usize> = vec![];
        let mut steps = vec![];
        let mut cv_cur = cv0;
        let mut bic_cur = bic(&[]);
        while set.len() < opts.max_effects {
            progress(
                "selection",
                0.4 + 0.4 * set.len() as f64 / opts.max_effects as f64,
            );
            let rss_cur = prep.rss(&set);
            let mut tests: Vec<(usize, f64)> = (0..cands.len())
                .filter(|c| !set.contains(c))
                .map(|c| {
                    let mut s = set.clone();
                    s.push(c);
                    (c, lr(rss_cur, prep.rss(&s)))
                })
                .collect();
            tests.sort_by(|a, b| b.1.total_cmp(&a.1));
            let short: Vec<(usize, f64, f64, f64)> = tests
                .iter()
                .filter(|&&(c, _)| {
                    let mut s = set.clone();
                    s.push(c);
                    prep.plausible(&s)
                })
                .take(opts.shortlist)
                .map(|&(c, stat)| {
                    let mut s = set.clone();
                    s.push(c);
                    (c, stat, prep.cv_rss(&s), bic(&s))
                })
                .collect();
            // Smallest cross-validated error; among those the data cannot tell from it
            // (within the confounding tolerance), the smallest information criterion — the
            // simpler law (Coulomb before Stribeck or asymmetric friction) unless the data
            // ask for more. (Preferring, at such a tie, the compliance of the joint whose play
            // is selected over another joint's was measured and not kept: diagnosis log, "A leg's
            // two joints".)
            let cv_min = short.iter().map(|x| x.2).fold(f64::INFINITY, f64::min);
            let tol = (1.0 + opts.confound_tolerance).powi(2);
            let best = short
                .iter()
                .filter(|x| x.2 <= cv_min * tol)
                .min_by(|a, b| a.3.total_cmp(&b.3))
                .copied();
            let Some((c, stat, cv, b)) = best else { break };
            let k = prep.cols_of[c].len() + cands[c].grid_parameters;
            let p = chi2_sf(stat, k);
            let gain = 1.0 - (cv / cv_cur).sqrt();
            if p > opts.significance || gain < opts.min_gain || b >= bic_cur {
                break;
            }
            set.push(c);
            cv_cur = cv;
            bic_cur = b;
            steps.push(Step {
                added: cands[c].name.clone(),
                statistic: stat,
                p_value: p,
                cv_rms: (cv / n as f64).sqrt(),
                bic: b,
            });
        }
        // Simplify: an effect chosen early may have absorbed part of one found later; if a
        // simpler law of the same family (Coulomb for asymmetric or Stribeck friction) now
        // fits as well (cross-validated, within the confounding tolerance) with a smaller
        // information criterion, it replaces the richer one.
        let tol = (1.0 + opts.confound_tolerance).powi(2);
        for pos in 0..set.len() {
            let c = set[pos];
            let cost = |k: usize| prep.cols_of[k].len() + cands[k].grid_parameters;
            let simpler = (0..cands.len())
                .filter(|&d| !set.contains(&d) && same_family(&cands[c], &cands[d]) && cost(d) < cost(c))
                .filter_map(|d| {
                    let mut s2 = set.clone();
                    s2[pos] = d;
                    if !prep.plausible(&s2) {
                        return None;
                    }
                    let (cv2, b2) = (prep.cv_rss(&s2), bic(&s2));
                    (cv2 <= cv_cur * tol && b2 < bic_cur).then_some((d, cv2, b2))
                })
                .min_by(|a, b| a.2.total_cmp(&b.2));
            if let Some((d, cv2, b2)) = simpler {
                set[pos] = d;
                steps[pos].added = cands[d].name.clone();
                cv_cur = cv2;
                bic_cur = b2;
            }
        }
        // Compliance, not play: a radial play in the reduced dynamic model on linear
        // contacts carries its balls' compression (it scales with the clearance); where its
        // estimate falls below that compression under the joint's own load, no play is
        // resolved and what the column fits is the joint's contact compliance. The joint's
        // compliance candidate takes its place where it fits as well (cross-validated,
        // within the confounding tolerance); the verdict says so either way.
        let mut unresolved = vec![];
        if set.iter().any(|&c| prep.compression[c].is_some()) {
            let x = total.solve(&prep.idx(&set));
            let first: Vec<usize> = set
                .iter()
                .scan(0, |at, &c| {
                    let f = *at;
                    *at += prep.cols_of[c].len();
                    Some(f)
                })
                .collect();
            for pos in 0..set.len() {
                let c = set[pos];
                let (Some(delta), Some(&h)) = (prep.compression[c], x.get(first[pos])) else {
                    continue;
                };
                if h >= delta {
                    continue;
                }
                let best = compliance_of
                    .get(c)
                    .into_iter()
                    .flatten()
                    .copied()
                    .filter(|d| !set.contains(d))
                    .filter_map(|d| {
                        let mut s2 = set.clone();
                        s2[pos] = d;
                        prep.plausible(&s2).then(|| (d, prep.cv_rss(&s2)))
                    })
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let within = best.filter(|&(_, cv2)| cv2 <= cv_cur * tol);
                unresolved.push((
                    c,
                    UnresolvedPlay {
                        play: cands[c].name.clone(),
                        // (The caller names the joint: the selection sees candidates only.)
                        joint: String::new(),
                        estimate: h,
                        compression: delta,
                        compliance: within.map(|(d, _)| cands[d].name.clone()),
                        alternative: best.map(|(d, _)| cands[d].name.clone()),
                        declared: compliance_of.get(c).map_or(0, Vec::len),
                        cv_ratio: best.map(|(_, cv2)| (cv2 / cv_cur.max(1e-300)).sqrt()),
                    },
                ));
                if let Some((d, cv2)) = within {
                    set[pos] = d;
                    steps[pos].added = cands[d].name.clone();
                    cv_cur = cv2;
                    bic_cur = bic(&set);
                }
            }
        }
        // Backward elimination: an effect chosen early may only have stood in for one found
        // later (a length error for a base tilt); the member that would not join now —
        // given all the others, its test is not significant, it lowers the cross-validated
        // error by less than `min_gain` or it does not lower the information criterion — is
        // dropped, the weakest first, until every member earns its place.
        loop {
            let weakest = (0..set.len())
                .filter_map(|pos| {
                    let mut rest = set.clone();
                    let c = rest.remove(pos);
                    if !prep.plausible(&rest) {
                        return None;
                    }
                    let k = prep.cols_of[c].len() + cands[c].grid_parameters;
                    let p = chi2_sf(lr(prep.rss(&rest), prep.rss(&set)), k);
                    let cv_rest = prep.cv_rss(&rest);
                    let gain = 1.0 - (cv_cur / cv_rest.max(1e-300)).sqrt();
                    let bic_rest = bic(&rest);
                    (p > opts.significance || gain < opts.min_gain || bic_cur >= bic_rest)
                        .then_some((pos, gain, cv_rest, bic_rest))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let Some((pos, _, cv_rest, bic_rest)) = weakest else {
                break;
            };
            set.remove(pos);
            steps.remove(pos);
            cv_cur = cv_rest;
            bic_cur = bic_rest;
        }
        // Only what stayed in the selection.
        unresolved.retain(|(c, u)| match &u.compliance {
            Some(name) => set.iter().any(|&k| &cands[k].name == name),
            None => set.contains(c),
        });
        // Re-weigh once: the channel scales the selected physics leaves (a large effect
        // found first no longer inflates its channel's weight, so what hides under it can
        // show).
        if pass == 0 && opts.reweight && !set.is_empty() {
            let x = total.solve(&prep.idx(&set));
            let mut ss = vec![0.0; nj];
            let mut cnt = vec![0usize; nj];
            for r in 0..lens.len() {
                let res = prep.residual(r, &set, &x);
                for j in 0..nj {
                    for v in &res[j * lens[r]..(j + 1) * lens[r]] {
                        ss[j] += (v * weight_scale[j]).powi(2);
                        cnt[j] += 1;
                    }
                }
            }
            let new_w: Vec<f64> = (0..nj)
                .map(|j| (ss[j] / cnt[j].max(1) as f64).sqrt().max(sigma[j]))
                .collect();
            if new_w.iter().zip(&weight_scale).any(|(a, b)| a / b < 0.8) {
                weight_scale = new_w;
                pass += 1;
                continue;
            }
        }
        break (prep, set, steps, cv_cur, ranking, n, n_eff, total, unresolved);
    };
    Ok(Selection {
        prep,
        set,
        steps,
        cv: cv_cur,
        ranking: ranking.into_iter().map(|(_, r)| r).collect(),
        n,
        n_eff,
        total,
        weight_scale,
        unresolved,
    })
}

/// Estimates of the selected parameters and their strongly correlated pairs.
pub(super) struct Estimates {
    /// Coefficients of the selected columns (physical units).
    pub x: Vec<f64>,
    /// Estimates with their standard deviations.
    pub estimates: Vec<Estimate>,
    /// Estimate pairs correlated beyond ±0.8: (a, b, correlation).
    pub correlations: Vec<(String, String, f64)>,
    /// Per estimate, the energy of its weighted column in each channel (its information
    /// per channel, for the misfit inflation of `adequacy::honest_uncertainty`).
    pub shares: Vec<Vec<f64>>,
}

/// Estimates with uncertainty: the least-squares one (effective-sample corrected, the
/// residual treated as noise; `std` and `std_noise_only` until the adequacy check inflates
/// `std`), the leave-one-recording-out refits of the final selection (one small solve per
/// fit recording on the accumulated Gram matrices) and their jackknife standard deviation.
pub(super) fn estimate(sel: &Selection, cands: &[Candidate]) -> Estimates {
    let Selection {
        prep,
        set,
        n,
        n_eff,
        total,
        weight_scale,
        ..
    } = sel;
    let (n, n_eff) = (*n, *n_eff);
    let idx = prep.idx(set);
    let x = total.solve(&idx);
    let dof = (n as f64 - idx.len() as f64).max(1.0);
    let s2 = total.rss(&idx, &x) / dof;
    let cov = total.inverse(&idx) * (s2 * n as f64 / n_eff);
    // Leave-one-recording-out refits of the final selection.
    let folds: Vec<Vec<f64>> = if prep.grams.len() >= 2 {
        prep.grams.iter().map(|g| total.minus(g).solve(&idx)).collect()
    } else {
        vec![]
    };
    let nc = weight_scale.len();
    let shares: Vec<Vec<f64>> = idx
        .iter()
        .map(|&i| {
            let mut e = vec![0.0; nc];
            for (cols, b) in &prep.blocks {
                let len = b.len() / nc.max(1);
                for (j, ej) in e.iter_mut().enumerate() {
                    *ej += cols[i][j * len..(j + 1) * len].iter().map(|v| v * v).sum::<f64>();
                }
            }
            e
        })
        .collect();
    let mut estimates = vec![];
    let mut labels = vec![];
    let mut p = 0;
    for &c in set {
        for name in &cands[c].parameters {
            // Columns are weighted like the residual, so coefficients are in physical units.
            let std = cov[(p, p)].max(0.0).sqrt();
            let fold_values: Vec<f64> = folds.iter().map(|f| f[p]).collect();
            let std_jackknife = (fold_values.len() >= 2).then(|| {
                let r = fold_values.len() as f64;
                let m = fold_values.iter().sum::<f64>() / r;
                ((r - 1.0) / r * fold_values.iter().map(|v| (v - m).powi(2)).sum::<f64>()).sqrt()
            });
            estimates.push(Estimate {
                candidate: cands[c].name.clone(),
                parameter: name.clone(),
                value: x[p],
                std,
                std_noise_only: std,
                std_jackknife,
                inflation: 1.0,
                folds: fold_values,
                stable: true,
            });
            labels.push(format!("{} ({})", cands[c].name, name));
            p += 1;
        }
    }
    let mut correlations = vec![];
    for a in 0..idx.len() {
        for b in 0..a {
            let r = cov[(a, b)] / (cov[(a, a)] * cov[(b, b)]).sqrt();
            if r.abs() > 0.8 {
                correlations.push((labels[a].clone(), labels[b].clone(), r));
            }
        }
    }
    Estimates {
        x,
        estimates,
        correlations,
        shares,
    }
}

/// Effects the data cannot separate: swapping a selected effect for another fits
/// (cross-validated) as well.
/// The pairs of a selected effect and an alternative outside its family that fit as well
/// (cross-validated, within the confounding tolerance); `x` are the selected columns'
/// coefficients (in the order of the selection's columns), from which a one-parameter
/// alternative's equivalent value is read: the selected column's fit projected on the
/// alternative's column.
pub(super) fn confounded(
    sel: &Selection,
    cands: &[Candidate],
    opts: &DiagnoseOptions,
    x: &[f64],
) -> Vec<Confound> {
    let Selection {
        prep,
        set,
        cv,
        unresolved,
        ..
    } = sel;
    let cv_cur = *cv;
    let mut confounded = vec![];
    let g = &prep.total().g;
    let joints = cands.iter().filter_map(|c| c.joint).max().map_or(0, |j| j + 1);
    let mut first_col = 0;
    for (pos, &c) in set.iter().enumerate() {
        let col0 = first_col;
        first_col += prep.cols_of[c].len();
        for d in 0..cands.len() {
            // A play that resolved no play stands for the compliance named in its place.
            if set.contains(&d)
                || same_family(&cands[c], &cands[d])
                || unresolved.iter().any(|(u, _)| *u == d)
            {
                continue;
            }
            let mut s = set.clone();
            s[pos] = d;
            if !prep.plausible(&s) {
                continue;
            }
            let ratio = (prep.cv_rss(&s) / cv_cur).sqrt();
            if ratio < 1.0 + opts.confound_tolerance {
                let equivalent_value = match (
                    prep.cols_of[c].as_slice(),
                    prep.cols_of[d].as_slice(),
                    x.get(col0),
                ) {
                    ([a], [b], Some(&xa)) if g[(*b, *b)] > 0.0 && !cands[d].parameters.is_empty() => {
                        Some(xa * g[(*a, *b)] / g[(*b, *b)])
                    }
                    _ => None,
                };
                let equivalent = equivalent_value.and_then(|v| {
                    cands[d]
                        .parameters
                        .first()
                        .map(|p| format!("{p} = {}", super::format::number(v)))
                });
                confounded.push(Confound {
                    selected: cands[c].name.clone(),
                    alternative: cands[d].name.clone(),
                    cv_ratio: ratio,
                    experiment: separating_experiment(&cands[c], &cands[d], joints),
                    equivalent,
                    equivalent_value,
                });
            }
        }
    }
    confounded
}

/// Variants of one effect in one joint (e.g. Stribeck velocities, or Coulomb within
/// asymmetric friction) are refinements, not rival explanations.
fn same_family(a: &Candidate, b: &Candidate) -> bool {
    use Effect::*;
    let fam = |e: Effect| match e {
        Coulomb { .. } | Stribeck { .. } | AsymmetricFriction { .. } => 1,
        Viscous | AsymmetricViscous => 2,
        RotorInertia => 3,
        TorqueOffset => 4,
        TorqueScale => 5,
        TorqueDelay => 6,
        Parameter { .. } => 7,
        PositionOffset => 8,
        Backlash { .. } => 9,
        Clearance { .. } => 10,
        OutputOffset { .. } => 11,
        OutputDelay { .. } => 12,
        Play { .. } => 13,
        ContactCompliance { .. } => 14,
        Declared { .. } => 7,
    };
    // Load scales of one joint's play are refinements; other joints are rivals.
    let site = |e: Effect| match e {
        Play { site, direction, .. } => Some((site, Some(direction))),
        ContactCompliance { site } => Some((site, None)),
        _ => None,
    };
    a.joint == b.joint
        && fam(a.effect) == fam(b.effect)
        && fam(a.effect) != 7
        && site(a.effect) == site(b.effect)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::PlayDirection;
    use crate::diagnose::model::ParameterFamily;

    fn candidate(name: &str, effect: Effect) -> Candidate {
        crate::diagnose::candidates::test_candidate(name, effect, false)
    }

    /// The radial play of joint `name` at play site `site`.
    fn radial_play(name: &str, site: usize) -> Candidate {
        candidate(
            &format!("radial clearance in joint {name} (reduced dynamic model)"),
            Effect::Play {
                site,
                direction: PlayDirection::Radial,
                load_scale: 5.0,
            },
        )
    }

    /// Sample times of recording `r` (n samples each, 10 ms apart, one record after
    /// another) and the play's column there.
    fn times_and_play(r: usize, n: usize) -> (Vec<f64>, Vec<f64>) {
        let t: Vec<f64> = (0..n).map(|i| (r * n + i) as f64 * 0.01).collect();
        let p = t
            .iter()
            .map(|t| (1.3 * t).sin() + 0.4 * (3.1 * t).cos())
            .collect();
        (t, p)
    }

    /// Deterministic uniform noise of RMS ~0.01 (width 0.035), from `seed`.
    fn noise(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.035
    }

    /// The options of these tests: the default ones, channels not re-weighed.
    fn unweighted() -> DiagnoseOptions {
        DiagnoseOptions {
            reweight: false,
            ..DiagnoseOptions::default()
        }
    }

    /// Selects on `raw` (three recordings of `n` samples, one channel of noise floor 1)
    /// with the plays' compliances `compliance_of`.
    fn select_on(raw: &Prepared, compliance_of: &[Vec<usize>], n: usize) -> Selection {
        select(
            raw,
            &raw.cands,
            compliance_of,
            &[n; 3],
            &[1.0],
            &unweighted(),
            &mut |_, _| {},
        )
        .unwrap()
    }

    /// A play column p, a compliance column p + `apart`·w (w a shape of its own) and an
    /// unrelated column; the residual 0.05·p plus a deterministic noise of RMS ~0.01, over
    /// three recordings; the play's compression `delta` (m).
    fn selection(delta: f64, apart: f64) -> Selection {
        let cands = vec![
            radial_play("F", 0),
            candidate(
                "error in joint compliance along leg C",
                Effect::Parameter {
                    index: 0,
                    family: ParameterFamily::JointCompliance,
                },
            ),
            candidate("torque offset", Effect::TorqueOffset),
        ];
        let n = 400;
        let mut seed = 12345u64;
        let blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)> = (0..3)
            .map(|r| {
                let (t, p) = times_and_play(r, n);
                let c: Vec<f64> = p
                    .iter()
                    .zip(&t)
                    .map(|(p, t)| p + apart * (7.7 * t).sin())
                    .collect();
                let u: Vec<f64> = t.iter().map(|t| (0.37 * t).cos()).collect();
                let w: Vec<f64> = t.iter().map(|t| (7.7 * t).sin()).collect();
                let mut e: Vec<f64> = (0..n).map(|_| noise(&mut seed)).collect();
                // The noise made orthogonal to w, so the play's column fits better than the
                // compliance's by `apart` alone, not by chance.
                let k =
                    e.iter().zip(&w).map(|(a, b)| a * b).sum::<f64>() / w.iter().map(|v| v * v).sum::<f64>();
                e.iter_mut().zip(&w).for_each(|(a, b)| *a -= k * b);
                let b: Vec<f64> = p.iter().zip(&e).map(|(p, e)| 0.05 * p + e).collect();
                (vec![p, c, u], b)
            })
            .collect();
        let mut raw = Prepared::new(cands.clone(), vec![vec![0], vec![1], vec![2]], blocks).unwrap();
        raw.compression = vec![Some(delta), None, None];
        select_on(&raw, &[vec![1], vec![], vec![]], n)
    }

    /// A play whose estimate (0.05) is below its compression (0.2) resolves no play: the
    /// joint's compliance, which fits as well, is named in its place.
    #[test]
    fn a_play_below_its_compression_is_named_as_the_joints_compliance() {
        let sel = selection(0.2, 1e-3);
        assert_eq!(sel.set, vec![1], "the compliance replaces the play");
        assert_eq!(sel.steps[0].added, "error in joint compliance along leg C");
        let (c, u) = &sel.unresolved[0];
        assert_eq!(*c, 0);
        assert!((u.estimate - 0.05).abs() < 0.005, "{}", u.estimate);
        assert_eq!(u.compression, 0.2);
        assert_eq!(
            u.compliance.as_deref(),
            Some("error in joint compliance along leg C")
        );
        assert!(u.cv_ratio.is_some_and(|r| r < 1.005), "{:?}", u.cv_ratio);
    }

    /// Above its compression the play stands; below it, with a compliance that fits
    /// clearly worse, the play stays selected and the record says which fitted worse.
    #[test]
    fn a_resolved_play_or_a_worse_compliance_leaves_the_play_selected() {
        let sel = selection(0.01, 1e-3);
        assert_eq!(sel.set, vec![0]);
        assert!(sel.unresolved.is_empty());
        let sel = selection(0.2, 0.5);
        assert_eq!(sel.set, vec![0]);
        let (_, u) = &sel.unresolved[0];
        assert_eq!(u.compliance, None);
        assert_eq!(u.declared, 1);
        assert_eq!(
            u.alternative.as_deref(),
            Some("error in joint compliance along leg C")
        );
        assert!(u.cv_ratio.is_some_and(|r| r > 1.005), "{:?}", u.cv_ratio);
    }

    /// Two joints' contact compliances that the data cannot tell apart (the other joint's
    /// fits marginally better, within the confounding tolerance): with the play of one of
    /// them selected, the better-fitting one joins by the information criterion, and the
    /// play's own joint's is reported as confounded with it, with an experiment that says
    /// joints in series cannot be told apart by any motion.
    #[test]
    fn two_joints_compliances_that_fit_alike_are_reported_as_confounded() {
        let cands = vec![
            radial_play("F", 0),
            candidate(
                "contact compliance of joint F",
                Effect::ContactCompliance { site: 0 },
            ),
            candidate(
                "contact compliance of joint R",
                Effect::ContactCompliance { site: 1 },
            ),
            candidate("torque offset", Effect::TorqueOffset),
            radial_play("R", 1),
        ];
        let n = 400;
        let mut seed = 777u64;
        let blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)> = (0..3)
            .map(|r| {
                let (t, p) = times_and_play(r, n);
                let q: Vec<f64> = t
                    .iter()
                    .map(|t| (0.9 * t).cos() + 0.3 * (5.3 * t).sin())
                    .collect();
                // F's compliance column departs from the shape in the data by a little.
                let f: Vec<f64> = q
                    .iter()
                    .zip(&t)
                    .map(|(q, t)| q + 0.03 * (11.0 * t).sin())
                    .collect();
                let u: Vec<f64> = t.iter().map(|t| (0.37 * t).cos()).collect();
                let b: Vec<f64> = p
                    .iter()
                    .zip(&q)
                    .map(|(p, q)| 0.05 * p + 0.02 * q + noise(&mut seed))
                    .collect();
                let r_play: Vec<f64> = t.iter().map(|t| (2.3 * t).cos()).collect();
                (vec![p, f, q, u, r_play], b)
            })
            .collect();
        let raw = Prepared::new(
            cands.clone(),
            vec![vec![0], vec![1], vec![2], vec![3], vec![4]],
            blocks,
        )
        .unwrap();
        let opts = unweighted();
        // F's compliance declared as its play's or not, the better-fitting R is taken.
        let sel = select_on(&raw, &[vec![1], vec![], vec![], vec![], vec![2]], n);
        assert_eq!(sel.set, vec![0, 2]);
        assert_eq!(
            select_on(&raw, &[vec![], vec![], vec![], vec![], vec![2]], n).set,
            vec![0, 2]
        );
        let ratio = (sel.prep.cv_rss(&[0, 1]) / sel.cv).sqrt();
        assert!(ratio > 1.0 && ratio < 1.0 + opts.confound_tolerance, "{ratio}");
        let x = sel.total.solve(&sel.prep.idx(&sel.set));
        let conf = confounded(&sel, &cands, &opts, &x);
        let c = conf
            .iter()
            .find(|c| {
                c.selected == "contact compliance of joint R"
                    && c.alternative == "contact compliance of joint F"
            })
            .expect("F's compliance reported as confounded with R's");
        assert!(c.experiment.contains("in series"), "{}", c.experiment);
    }
}
