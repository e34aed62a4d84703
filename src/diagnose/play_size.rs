//! The found radial play's size, searched. The play candidates' columns are secants of the
//! reduced dynamic play model's response at a reference play, scaled in proportion to each
//! candidate's play: exact at the reference only, for a joint's rattle moves in time with
//! its play. Here the reduced model is run at each size a pattern search tries
//! ([`search_play_size`]), the play's effect held at that size — the model's own prediction,
//! not a scaled one — and the other selected effects refitted ([`held_play_cv`]); the size
//! whose refit cross-validates best is the one the model explains the data with.
//! A variable projection: one nonlinear parameter searched, the linear ones solved.

use super::candidates::library;
use super::data::MotionData;
use super::error::DiagnoseError;
use super::model::InverseDynamicsModel;
use super::options::DiagnoseOptions;
use super::residuals::{prepare, Prepared};

/// The multiplicative steps of the play-size search ([`search_play_size`]), largest first:
/// each is tried either way from the best size so far while that improves, then the next.
/// Why 1 % at the end (README, "The rattle reproduced at the truth's play"): the reduced
/// model (forces blended, Hertz balls, 20 N·s/m + 500 s/m × F) run at 5.55 / 5.8 / 6.0 /
/// 6.2 / 6.45 µm against a 6 µm truth (clearance-F) left of the play's effect on drive A's
/// torque in fit recording 1 2.21 / 1.13 / 0.43 / 1.73 / 2.02 noise units: a minimum a few
/// per cent wide. (What the model leaves of the truth's effect, not this search's objective.)
pub const PLAY_SIZE_STEPS: [f64; 3] = [1.04, 1.02, 1.01];

/// The most sizes the play-size search ([`search_play_size`]) tries (each a refit of the
/// kept selection with the reduced dynamic play model run at that size).
pub const MAX_PLAY_SIZES: usize = 12;

/// A pattern search on a play's size: from `h0` (m), each step of [`PLAY_SIZE_STEPS`]
/// tried either way from the best size so far, the way that improves followed while it
/// does, then the next smaller step; at most [`MAX_PLAY_SIZES`] evaluations of `objective`
/// (a refit's leave-one-recording-out RMS). Returns every (size, objective) tried, in order;
/// a size is never tried twice. A non-finite objective counts as no improvement.
///
/// ```
/// // An objective with its minimum at 6 µm, searched from 5.6 µm: found within the last step.
/// let log = lash::diagnose::search_play_size::<()>(5.6e-6, &mut |h| Ok((h / 6e-6).ln().powi(2)))?;
/// let (best, _) = log.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).expect("one tried");
/// assert!((best / 6e-6 - 1.0).abs() <= 0.01 && log.len() <= lash::diagnose::MAX_PLAY_SIZES);
/// # Ok::<(), ()>(())
/// ```
pub fn search_play_size<E>(
    h0: f64,
    objective: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<Vec<(f64, f64)>, E> {
    let mut log: Vec<(f64, f64)> = vec![];
    let mut eval = |h: f64, log: &mut Vec<(f64, f64)>| -> Result<Option<f64>, E> {
        if let Some(&(_, f)) = log.iter().find(|(x, _)| (x / h - 1.0).abs() < 1e-9) {
            return Ok(Some(f));
        }
        if log.len() >= MAX_PLAY_SIZES {
            return Ok(None);
        }
        let f = objective(h)?;
        log.push((h, f));
        Ok(Some(f))
    };
    let better =
        |f: Option<f64>, best: f64| f.is_some_and(|f| f.is_finite() && (f < best || !best.is_finite()));
    let Some(mut best_f) = eval(h0, &mut log)? else {
        return Ok(log);
    };
    let mut best_h = h0;
    for &s in &PLAY_SIZE_STEPS {
        // Which way improves, if either.
        let mut way = None;
        for factor in [s, 1.0 / s] {
            let f = eval(best_h * factor, &mut log)?;
            if better(f, best_f) {
                (best_h, best_f, way) = (best_h * factor, f.unwrap_or(best_f), Some(factor));
                break;
            }
        }
        // Followed while it improves.
        while let Some(factor) = way {
            let f = eval(best_h * factor, &mut log)?;
            if better(f, best_f) {
                (best_h, best_f) = (best_h * factor, f.unwrap_or(best_f));
            } else {
                way = None;
            }
        }
    }
    Ok(log)
}

/// The leave-one-recording-out RMS (in units of each channel's measured noise floor
/// `floors`) of the candidates named `selected` refitted on `fit`, the radial play
/// candidate `play` among them held at its reference `opts.library.dynamic_play_clearance`
/// (m): its effect, the reduced dynamic play model's response at that play, taken from the
/// residual rather than fitted; the others fitted with channel j weighted by `weights[j]`
/// (in the channel's unit). Effects the linearisation point moved (`opts.shift`) that are
/// not in `selected` are taken back, as in the selection. Every radial play candidate's
/// column is the model's at that reference. `None` when no reference is set, `play` is
/// not among the candidates, or it has other than one column.
///
/// Errors: those of the columns' and residuals' assembly.
pub(super) fn held_play_cv(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    opts: &DiagnoseOptions,
    selected: &[String],
    play: &str,
    weights: &[f64],
    floors: &[f64],
) -> Result<Option<f64>, DiagnoseError> {
    let Some(h) = opts.library.dynamic_play_clearance else {
        return Ok(None);
    };
    let mut o = opts.clone();
    o.library.only = selected.to_vec();
    o.library.only.extend(
        opts.shift
            .iter()
            .map(|(name, _)| name.clone())
            .filter(|n| !selected.contains(n)),
    );
    let cands = library(model, &o.library);
    let Some(c) = cands.iter().position(|c| c.name == play) else {
        return Ok(None);
    };
    let raw = prepare(model, fit, &vec![1.0; weights.len()], &cands, &o)?;
    let [col] = raw.cols_of[c][..] else {
        return Ok(None);
    };
    let Prepared {
        cands,
        cols_of,
        mut blocks,
        ..
    } = raw;
    for (cols, b) in &mut blocks {
        for (bi, ai) in b.iter_mut().zip(&cols[col]) {
            *bi -= h * ai;
        }
    }
    let lens: Vec<usize> = fit.iter().map(MotionData::len).collect();
    let held = Prepared::new(cands, cols_of, blocks)?.reweighed(weights, &lens)?;
    let others: Vec<usize> = (0..held.cands.len())
        .filter(|&k| k != c && selected.contains(&held.cands[k].name))
        .collect();
    let factor: Vec<f64> = weights
        .iter()
        .zip(floors)
        .map(|(w, s)| w / s.max(1e-300))
        .collect();
    Ok(Some(held.cv_rms_rescaled(&others, &factor, &lens)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_play_size_search_finds_a_narrow_minimum_within_its_last_step() {
        // A minimum 7 % above the start and a few per cent wide (like what the reduced model
        // left of clearance-F's play effect at sizes around the truth's), a small ripple.
        let truth = 6.0e-6;
        let f = |h: f64| {
            let x = (h / truth).ln();
            0.4 + (x / 0.03).powi(2).min(6.0) + 0.02 * (h * 5e7).sin()
        };
        let mut calls = vec![];
        let log = search_play_size::<()>(5.6e-6, &mut |h| {
            calls.push(h);
            Ok(f(h))
        })
        .expect("no error");
        assert_eq!(log.len(), calls.len());
        assert!(log.len() <= MAX_PLAY_SIZES, "{log:?}");
        // No size twice.
        for (k, (h, _)) in log.iter().enumerate() {
            assert!(
                log[..k].iter().all(|(g, _)| (g / h - 1.0).abs() > 1e-9),
                "{log:?}"
            );
        }
        let (best, _) = log
            .iter()
            .copied()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("one");
        let last = PLAY_SIZE_STEPS[PLAY_SIZE_STEPS.len() - 1] - 1.0;
        assert!((best / truth - 1.0).abs() <= last, "{best} from {log:?}");
        // The objective's errors pass through.
        assert_eq!(
            search_play_size(5e-6, &mut |_| Err::<f64, _>("refit failed")),
            Err("refit failed")
        );
        // A non-finite value is no improvement, however it compares: −∞ and NaN above the
        // start, so each step tries both ways and moves neither.
        let log = search_play_size::<()>(5e-6, &mut |h| {
            Ok(if h > 5.08e-6 {
                f64::NAN
            } else if h > 5e-6 {
                f64::NEG_INFINITY
            } else {
                1.0
            })
        })
        .expect("no error");
        assert_eq!(log.len(), 1 + 2 * PLAY_SIZE_STEPS.len(), "{log:?}");
        // A non-finite start: the first finite size is better.
        let log = search_play_size::<()>(5e-6, &mut |h| {
            Ok(if h == 5e-6 {
                f64::NAN
            } else {
                (h / 6e-6).ln().abs()
            })
        })
        .expect("no error");
        assert!(log[1].1.is_finite() && log.len() > 3, "{log:?}");
    }
}
