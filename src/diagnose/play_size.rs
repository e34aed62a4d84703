//! The found radial play's size, searched. The play candidates' columns are secants of the
//! reduced dynamic play model's response at a reference play, scaled in proportion to each
//! candidate's play: exact at the reference only, for a joint's rattle moves in time with
//! its play. Here the reduced model is run at each size a pattern search tries
//! ([`search_play_size`]), the play's effect held at that size — the model's own prediction,
//! not a scaled one — and the other selected effects refitted ([`HeldPlay`]); the size
//! whose refit cross-validates best is the one the model explains the data with.
//! A variable projection: one nonlinear parameter searched, the linear ones solved.

use super::candidates::{library, Candidate, Effect, PlayDirection};
use super::candidates::{NominalWalkCache, TightRuns};
use super::data::MotionData;
use super::error::DiagnoseError;
use super::model::InverseDynamicsModel;
use super::options::DiagnoseOptions;
use super::play_dynamics::ContactDamping;
use super::residuals::{prepare_with, Prepared};

/// The multiplicative steps of the play-size search ([`search_play_size`]), largest first:
/// each is tried either way from the best size so far while that improves, then the next.
/// Why 1 % at the end (diagnosis log, "The rattle reproduced at the truth's play"): the reduced
/// model (forces blended, Hertz balls, 20 N·s/m + 500 s/m × F) run at 5.55 / 5.8 / 6.0 /
/// 6.2 / 6.45 µm against a 6 µm truth (clearance-F) left of the play's effect on drive A's
/// torque in fit recording 1 2.21 / 1.13 / 0.43 / 1.73 / 2.02 noise units: a minimum a few
/// per cent wide. (What the model leaves of the truth's effect, not this search's objective.)
pub const PLAY_SIZE_STEPS: [f64; 3] = [1.04, 1.02, 1.01];

/// The most sizes the play-size search ([`search_play_size`]) tries (each a refit of the
/// kept selection with the reduced dynamic play model run at that size).
pub const MAX_PLAY_SIZES: usize = 12;

/// The geometric grid of radial plays (m) a probe for a play the first pass did not see
/// tries ([`probe_play_sizes`], [`PlayProbe`](super::PlayProbe)): (smallest, largest,
/// ratio). The range is the reference paper's (Table 1): 1 µm, its joints "practically
/// without" clearance, to 20 µm, the clearance of its adopted universal joints. Why a ratio
/// of 1.1: the reduced model's rattle near a singular position fits only within a few per
/// cent of the play that made it (diagnosis log, "A play the first pass did not see":
/// seed 11's clearance-under-length, recording 1, 6 µm truth, the model's response at
/// 4.5 / 5.25 / 5.6 / 6 / 6.4 / 6.75 / 8 µm scaled to fit left 4.6 / 3.8 / 2.5 / 0.5 / 2.9
/// / 3.9 / 4.3 torque-noise units of drive A's 11.1, and 4.9 / 4.7 at 3 / 12 µm), so a grid
/// point must fall within 5 % of it for the basin to show; the refinement
/// ([`search_play_size`]) takes it from there.
pub const PROBE_PLAY_SIZES: (f64, f64, f64) = (1e-6, 20e-6, 1.1);

/// The sizes of [`PROBE_PLAY_SIZES`]' grid, smallest first: the smallest, then each the
/// ratio above the one before while within the largest (at most one part in a million
/// above it, for round-off).
///
/// ```
/// let sizes = lash::diagnose::probe_play_sizes();
/// assert_eq!(sizes.len(), 32);
/// assert!(sizes.windows(2).all(|w| (w[1] / w[0] - 1.1).abs() < 1e-12));
/// assert!(sizes[0] == 1e-6 && *sizes.last().unwrap() <= 20e-6);
/// ```
pub fn probe_play_sizes() -> Vec<f64> {
    let (lo, hi, ratio) = PROBE_PLAY_SIZES;
    std::iter::successors(Some(lo), |h| Some(h * ratio))
        .take_while(|h| *h <= hi * (1.0 + 1e-6))
        .collect()
}

/// A pattern search on a play's size: from `h0` (m), each step of [`PLAY_SIZE_STEPS`]
/// tried either way from the best size so far, the way that improves followed while it
/// does, then the next smaller step; at most [`MAX_PLAY_SIZES`] evaluations of `objective`
/// (a refit's leave-one-recording-out RMS; `known`, if given, its value at `h0`, not
/// evaluated again). Returns every (size, objective) tried, in order, `h0` first; a size is
/// never tried twice. A non-finite objective counts as no improvement.
///
/// ```
/// // An objective with its minimum at 6 µm, searched from 5.6 µm: found within the last step.
/// let log = lash::diagnose::search_play_size::<()>(5.6e-6, None, &mut |h| Ok((h / 6e-6).ln().powi(2)))?;
/// let (best, _) = log.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).expect("one tried");
/// assert!((best / 6e-6 - 1.0).abs() <= 0.01 && log.len() <= lash::diagnose::MAX_PLAY_SIZES);
/// # Ok::<(), ()>(())
/// ```
pub fn search_play_size<E>(
    h0: f64,
    known: Option<f64>,
    objective: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<Vec<(f64, f64)>, E> {
    pattern_search(h0, known, &PLAY_SIZE_STEPS, MAX_PLAY_SIZES, &|h| h, objective)
}

/// The multiplicative steps of the load-proportional damping's search
/// ([`search_load_damping`]), largest first. Why these: the damping grid the diagnosis
/// tried before (250, 500, 1 000 s/m) refitted clearance-F's selection at its searched
/// size to 0.981 / 0.985 / 1.006 noise units (session 54): a minimum some tens of per cent
/// wide, whose place a 10 % step resolves to within the data's preference.
pub const LOAD_DAMPING_STEPS: [f64; 3] = [1.5, 1.22, 1.1];

/// The most load-proportional dampings one damping search ([`search_load_damping`]) tries.
pub const MAX_LOAD_DAMPINGS: usize = 10;

/// A pattern search on a load-proportional contact damping γ (s/m), as
/// [`search_play_size`] on a size: from `g0`, each step of [`LOAD_DAMPING_STEPS`] tried
/// either way from the best so far, followed while it improves; at most
/// [`MAX_LOAD_DAMPINGS`] evaluations of `objective`. Each trial value is rounded to three
/// significant digits (a damping is not known better than that, and the report reads it).
/// Returns every (γ, objective) tried, `g0` first.
///
/// ```
/// // An objective with its minimum at 450 s/m, searched from 250 s/m.
/// let log = lash::diagnose::search_load_damping::<()>(250.0, None, &mut |g| Ok((g / 450.0).ln().powi(2)))?;
/// let (best, _) = log.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).expect("one tried");
/// assert!((best / 450.0 - 1.0).abs() <= 0.1 && log.len() <= lash::diagnose::MAX_LOAD_DAMPINGS);
/// # Ok::<(), ()>(())
/// ```
pub fn search_load_damping<E>(
    g0: f64,
    known: Option<f64>,
    objective: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<Vec<(f64, f64)>, E> {
    pattern_search(
        g0,
        known,
        &LOAD_DAMPING_STEPS,
        MAX_LOAD_DAMPINGS,
        &three_digits,
        objective,
    )
}

/// The size search at each damping of the load-proportional damping's search (a profile):
/// the finest step of [`PLAY_SIZE_STEPS`] either way from the best size so far, followed
/// while it improves, at most [`PROFILE_SIZES`] refits.
pub const PROFILE_STEPS: [f64; 1] = [PLAY_SIZE_STEPS[PLAY_SIZE_STEPS.len() - 1]];

/// The most sizes refitted at each damping of the load-proportional damping's search.
pub const PROFILE_SIZES: usize = 4;

/// The multiplicative steps of the constant contact damping's search
/// ([`search_constant_damping`]) under a load-proportional one, largest first: √10 and
/// ⁴√10. The constant part (N·s/m, for the balls' sliding along their walls, over
/// [`LOAD_DAMPING_BASE`](super::play_dynamics::LOAD_DAMPING_BASE) by default) is a
/// regularisation whose size is known within a decade or two, not a measured value.
pub const CONSTANT_DAMPING_STEPS: [f64; 2] = [3.162_277_660_168_379_5, 1.778_279_410_038_922_8];

/// The most constant dampings one search ([`search_constant_damping`]) tries.
pub const MAX_CONSTANT_DAMPINGS: usize = 6;

/// A pattern search on the constant part (N·s/m) of a load-proportional contact damping, as
/// [`search_load_damping`] on γ: steps of [`CONSTANT_DAMPING_STEPS`], at most
/// [`MAX_CONSTANT_DAMPINGS`] evaluations, each trial value to three significant digits.
///
/// ```
/// // An objective with its minimum at 1 N·s/m, searched from 20 N·s/m.
/// let log = lash::diagnose::search_constant_damping::<()>(20.0, None, &mut |c| Ok((c / 1.0).ln().powi(2)))?;
/// let (best, _) = log.iter().copied().min_by(|a, b| a.1.total_cmp(&b.1)).expect("one tried");
/// assert!((best / 1.0).ln().abs() <= 1.8f64.ln() && log.len() <= lash::diagnose::MAX_CONSTANT_DAMPINGS);
/// # Ok::<(), ()>(())
/// ```
pub fn search_constant_damping<E>(
    c0: f64,
    known: Option<f64>,
    objective: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<Vec<(f64, f64)>, E> {
    pattern_search(
        c0,
        known,
        &CONSTANT_DAMPING_STEPS,
        MAX_CONSTANT_DAMPINGS,
        &three_digits,
        objective,
    )
}

/// The refit with the smallest finite leave-one-recording-out RMS among `log`'s (damping,
/// size in m, objective) entries ([`Diagnosis::dynamic_play_size_cv`](super::Diagnosis)'s
/// form); `None` when none is finite.
pub(super) fn best_refit<'a>(
    log: impl IntoIterator<Item = &'a (ContactDamping, f64, f64)>,
) -> Option<(ContactDamping, f64, f64)> {
    log.into_iter()
        .copied()
        .filter(|x| x.2.is_finite())
        .min_by(|a, b| a.2.total_cmp(&b.2))
}

/// Per contact damping tried, its smallest leave-one-recording-out RMS, best first: from the
/// play-size search's refits (`sized`) where they compared two dampings or more, else from
/// the grid at the reference play (`grid`); non-finite refits left out.
pub(super) fn best_per_damping(
    grid: &[(ContactDamping, f64)],
    sized: &[(ContactDamping, f64, f64)],
) -> Vec<(ContactDamping, f64)> {
    let best_per = |log: &mut dyn Iterator<Item = (ContactDamping, f64)>| {
        let mut per: Vec<(ContactDamping, f64)> = vec![];
        for (c, cv) in log.filter(|x| x.1.is_finite()) {
            match per.iter_mut().find(|p| p.0 == c) {
                Some(p) => p.1 = p.1.min(cv),
                None => per.push((c, cv)),
            }
        }
        per.sort_by(|a, b| a.1.total_cmp(&b.1));
        per
    };
    let per = best_per(&mut sized.iter().map(|&(c, _, cv)| (c, cv)));
    if per.len() >= 2 {
        per
    } else {
        best_per(&mut grid.iter().copied())
    }
}

/// Whether the fit recordings told the contact dampings tried apart ([`best_per_damping`]):
/// `Some(false)` when the next-best damping's RMS lies within `tolerance` (relative) of the
/// best's, so the damping kept is not a finding; `None` with fewer than two dampings.
pub(super) fn damping_identified(
    grid: &[(ContactDamping, f64)],
    sized: &[(ContactDamping, f64, f64)],
    tolerance: f64,
) -> Option<bool> {
    match best_per_damping(grid, sized).as_slice() {
        [best, next, ..] => Some(next.1 >= best.1 * (1.0 + tolerance)),
        _ => None,
    }
}

/// `x` rounded to three significant digits.
fn three_digits(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(2 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// The pattern search of [`search_play_size`], [`search_constant_damping`],
/// [`search_load_damping`] and the profile's size refinement on a positive scalar:
/// multiplicative `steps`, largest first, each trial point passed through `snap`; at most
/// `max` evaluations, a `known` value at `x0` counted among them; a point is never
/// evaluated twice.
fn pattern_search<E>(
    x0: f64,
    known: Option<f64>,
    steps: &[f64],
    max: usize,
    snap: &dyn Fn(f64) -> f64,
    objective: &mut dyn FnMut(f64) -> Result<f64, E>,
) -> Result<Vec<(f64, f64)>, E> {
    // (The objective at `x0`, if already known, is the log's first entry.)
    let mut log: Vec<(f64, f64)> = known.map(|f| vec![(x0, f)]).unwrap_or_default();
    let mut eval = |x: f64, log: &mut Vec<(f64, f64)>| -> Result<Option<f64>, E> {
        if let Some(&(_, f)) = log.iter().find(|(y, _)| (y / x - 1.0).abs() < 1e-9) {
            return Ok(Some(f));
        }
        if log.len() >= max {
            return Ok(None);
        }
        let f = objective(x)?;
        log.push((x, f));
        Ok(Some(f))
    };
    let better =
        |f: Option<f64>, best: f64| f.is_some_and(|f| f.is_finite() && (f < best || !best.is_finite()));
    let Some(mut best_f) = eval(x0, &mut log)? else {
        return Ok(log);
    };
    let mut best_x = x0;
    for &s in steps {
        // Which way improves, if either.
        let mut way = None;
        for factor in [s, 1.0 / s] {
            let x = snap(best_x * factor);
            let f = eval(x, &mut log)?;
            if better(f, best_f) {
                (best_x, best_f, way) = (x, f.unwrap_or(best_f), Some(factor));
                break;
            }
        }
        // Followed while it improves.
        while let Some(factor) = way {
            let x = snap(best_x * factor);
            let f = eval(x, &mut log)?;
            if better(f, best_f) {
                (best_x, best_f) = (x, f.unwrap_or(best_f));
            } else {
                way = None;
            }
        }
    }
    Ok(log)
}

/// What [`probe_play`] refitted.
#[derive(Debug)]
pub(super) struct ProbeRefits {
    /// The options' own contact damping, of the grid and its refinement.
    pub damping: ContactDamping,
    /// The refit without the play, on the samples of the best refit's (NaN where it fails
    /// or no size refitted): leave-one-recording-out RMS in noise units.
    pub without: f64,
    /// At [`damping`](Self::damping): every (size in m, leave-one-recording-out RMS in
    /// noise units) tried, in order, the grid's first.
    pub sizes: Vec<(f64, f64)>,
    /// At each other contact damping given: every (damping, size in m, objective) of the
    /// size's search from the best of [`sizes`](Self::sizes), in order.
    pub dampings: Vec<(ContactDamping, f64, f64)>,
}

impl ProbeRefits {
    /// The best refit, (damping, size in m, objective): the smallest finite objective over
    /// [`sizes`](Self::sizes) and [`dampings`](Self::dampings), the first of equals;
    /// `None` when none is finite.
    pub(super) fn best(&self) -> Option<(ContactDamping, f64, f64)> {
        let at_own: Vec<_> = self.sizes.iter().map(|&(h, cv)| (self.damping, h, cv)).collect();
        best_refit(at_own.iter().chain(&self.dampings))
    }
}

/// A probe for a radial play the first pass did not see ([`PlayProbe`](super::PlayProbe)):
/// the candidates named `selected` refitted with the radial play candidate `play` (of
/// `opts`' library: the reduced dynamic play model's) held at each size of
/// [`probe_play_sizes`], then the size refined from the best ([`search_play_size`], its
/// value there known); then, at each contact damping of `dampings` other than the options'
/// own, the size searched from the best so far at the own damping (a rattle's damping and
/// timing go together: the size that fits best moves with the damping, by more than the
/// grid's step). Returns the refits and the refit without the play on the best refit's
/// samples; `None` when `play` is not among the candidates. `walks`: the nominal model's
/// walks along `fit` to share ([`HeldPlay::new`]). `on_try` is called before each
/// refit with the play; a refit that fails counts as no improvement, a damping whose
/// columns cannot be assembled is left out, and where no refit at the own damping
/// succeeded no other damping is tried.
///
/// Errors: those of the columns' and residuals' assembly for the other candidates at the
/// options' own damping.
#[allow(clippy::too_many_arguments)]
pub(super) fn probe_play(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    opts: &DiagnoseOptions,
    selected: &[String],
    play: &str,
    dampings: &[ContactDamping],
    weights: &[f64],
    floors: &[f64],
    walks: Option<&Walks>,
    on_try: &mut dyn FnMut(),
) -> Result<Option<ProbeRefits>, DiagnoseError> {
    let mut with_play = selected.to_vec();
    with_play.push(play.to_string());
    let Some(held) = HeldPlay::new(model, fit, opts, &with_play, play, weights, floors, walks)? else {
        return Ok(None);
    };
    let mut sizes = vec![];
    for &h in &probe_play_sizes() {
        on_try();
        sizes.push((h, held.cv(h).ok().flatten().unwrap_or(f64::NAN)));
    }
    if let Some((h, cv)) = best_size(&sizes) {
        sizes.extend(held.search(h, Some(cv), on_try).into_iter().skip(1));
    }
    let mut refits = ProbeRefits {
        damping: opts
            .library
            .play_contact_damping
            .unwrap_or(super::play_dynamics::BALL_CONTACT.contact_damping()),
        without: f64::NAN,
        sizes,
        dampings: vec![],
    };
    // Each other damping's refit, for the baseline on the best's samples.
    let mut others: Vec<(ContactDamping, HeldPlay)> = vec![];
    if let Some((h0, _)) = best_size(&refits.sizes) {
        for &damping in dampings.iter().filter(|d| **d != refits.damping) {
            let Some(at) = HeldPlay::at_damping(
                model,
                fit,
                opts,
                damping,
                &with_play,
                play,
                weights,
                floors,
                &held.walks,
            ) else {
                continue;
            };
            let log = at.search(h0, None, on_try);
            refits
                .dampings
                .extend(log.iter().map(|&(h, cv)| (damping, h, cv)));
            others.push((damping, at));
        }
    }
    if let Some((damping, h, _)) = refits.best() {
        let at = others.iter().find(|o| o.0 == damping).map_or(&held, |o| &o.1);
        refits.without = at.cv_without(h).ok().flatten().unwrap_or(f64::NAN);
    }
    Ok(Some(refits))
}

/// The most refits with the play [`probe_play`] makes with the options' own damping `own`
/// and the contact dampings `dampings`: the grid's, its refinement's (the best grid size's
/// objective known) and a size search at each other damping.
pub(super) fn probe_refits_most(own: ContactDamping, dampings: &[ContactDamping]) -> usize {
    let others = dampings.iter().filter(|d| **d != own).count();
    probe_play_sizes().len() + MAX_PLAY_SIZES - 1 + others * MAX_PLAY_SIZES
}

/// The (size, objective) with the smallest finite objective in `log`; `None` when none is
/// finite.
pub(super) fn best_size(log: &[(f64, f64)]) -> Option<(f64, f64)> {
    log.iter()
        .copied()
        .filter(|x| x.1.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

/// The selection refitted with a radial play held at trial sizes ([`HeldPlay::cv`]): the
/// columns that do not change with the size — every candidate but the play's, at the
/// selection's reference plays — and the residual, assembled once.
pub(super) struct HeldPlay<'a> {
    model: &'a dyn InverseDynamicsModel,
    fit: &'a [MotionData],
    /// The options with the play candidate alone in the library.
    opts: DiagnoseOptions,
    /// The play candidate.
    play: Candidate,
    /// The other candidates' columns and the residual (channel units).
    others: Prepared,
    /// The selected among `others`.
    refitted: Vec<usize>,
    weights: Vec<f64>,
    floors: Vec<f64>,
    /// Per fit recording, the reduced play model's runs without play (the same at every
    /// trial size: computed by the first assembly that needs them).
    tight: Vec<TightRuns>,
    /// Per fit recording, the nominal model's walk (the same at every trial size and
    /// damping: shared with the refits and passes given them, [`new`](Self::new)).
    pub(super) walks: Walks,
}

/// The nominal model's walks along a set of recordings, one per recording, filled on first
/// use and shared by the assemblies on the same model ([`NominalWalk`](super::candidates::NominalWalk)).
pub(super) type Walks = std::sync::Arc<Vec<NominalWalkCache>>;

impl<'a> HeldPlay<'a> {
    /// For the candidates named `selected` on `fit` (the library and linearisation point of
    /// `opts`), the radial play candidate `play` among them to be held; channel j weighted
    /// by `weights[j]`, errors in units of `floors[j]` (both in the channel's unit). Effects
    /// the linearisation point moved (`opts.shift`) that are not in `selected` are taken
    /// back, as in the selection. `None` when `play` is not among the candidates. `walks`,
    /// where given (one per fit recording of the same model; another length is not used),
    /// are the nominal model's walks along the recordings this refit and its assembly share
    /// with others on that model ([`NominalWalk`](super::candidates::NominalWalk)).
    ///
    /// Errors: those of the columns' and residuals' assembly.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        model: &'a dyn InverseDynamicsModel,
        fit: &'a [MotionData],
        opts: &DiagnoseOptions,
        selected: &[String],
        play: &str,
        weights: &[f64],
        floors: &[f64],
        walks: Option<&Walks>,
    ) -> Result<Option<Self>, DiagnoseError> {
        let walks = walks
            .filter(|w| w.len() == fit.len())
            .cloned()
            .unwrap_or_else(|| Self::fresh_walks(fit));
        let mut o = opts.clone();
        o.library.only = selected.iter().filter(|n| *n != play).cloned().collect();
        o.library.only.extend(
            opts.shift
                .iter()
                .map(|(name, _)| name.clone())
                .filter(|n| !selected.contains(n)),
        );
        // (An empty list would be the whole library.)
        let cands = if o.library.only.is_empty() {
            vec![]
        } else {
            library(model, &o.library)
        };
        o.library.only = vec![play.to_string()];
        let Some(play) = library(model, &o.library).into_iter().find(|c| c.name == play) else {
            return Ok(None);
        };
        let sites = model.play_sites().len();
        let tight: Vec<TightRuns> = fit
            .iter()
            .map(|_| (0..sites).map(|_| Default::default()).collect())
            .collect();
        let others = prepare_with(
            model,
            fit,
            &vec![1.0; weights.len()],
            &cands,
            &o,
            Some(&tight),
            Some(&walks),
        )?;
        let refitted = (0..cands.len())
            .filter(|&k| cands[k].name != play.name && selected.contains(&cands[k].name))
            .collect();
        Ok(Some(HeldPlay {
            model,
            fit,
            opts: o,
            play,
            others,
            refitted,
            weights: weights.to_vec(),
            floors: floors.to_vec(),
            tight,
            walks,
        }))
    }

    /// [`new`](Self::new) with the reduced dynamic play model's contact damping set to
    /// `damping` and the nominal walks shared from `walks`; `None` also where the columns cannot be
    /// assembled (a search at that damping is then left out).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn at_damping(
        model: &'a dyn InverseDynamicsModel,
        fit: &'a [MotionData],
        opts: &DiagnoseOptions,
        damping: ContactDamping,
        selected: &[String],
        play: &str,
        weights: &[f64],
        floors: &[f64],
        walks: &Walks,
    ) -> Option<Self> {
        let mut o = opts.clone();
        o.library.play_contact_damping = Some(damping);
        Self::new(model, fit, &o, selected, play, weights, floors, Some(walks))
            .ok()
            .flatten()
    }

    /// Empty nominal walks, one per recording of `fit` (filled by the first refit that reads
    /// them; [`new`](Self::new) hands them to other refits).
    pub(super) fn fresh_walks(fit: &[MotionData]) -> Walks {
        std::sync::Arc::new(fit.iter().map(|_| NominalWalkCache::new()).collect())
    }

    /// Recordings whose nominal walk with the play sites' dynamics is in the cache (for tests).
    #[cfg(test)]
    pub(super) fn walks_cached(&self) -> usize {
        self.walks.iter().filter(|c| c.has_play_walk()).count()
    }

    /// Runs without play in the cache, over the recordings and play sites (for tests).
    #[cfg(test)]
    pub(super) fn tight_runs_cached(&self) -> usize {
        self.tight.iter().flatten().filter(|c| c.get().is_some()).count()
    }

    /// [`search_play_size`] from `h0` on [`cv`](Self::cv) (`known`: its value at `h0`, if
    /// known), `on_try` called before each refit; a refit that fails counts as no
    /// improvement.
    pub(super) fn search(&self, h0: f64, known: Option<f64>, on_try: &mut dyn FnMut()) -> Vec<(f64, f64)> {
        self.pattern(h0, known, &PLAY_SIZE_STEPS, MAX_PLAY_SIZES, on_try)
    }

    /// The size refined from `h0` ([`PROFILE_STEPS`], at most [`PROFILE_SIZES`] refits of
    /// [`cv`](Self::cv), `h0`'s included), `on_try` called before each; every (size,
    /// objective) tried, `h0` first.
    pub(super) fn refine(&self, h0: f64, on_try: &mut dyn FnMut()) -> Vec<(f64, f64)> {
        self.pattern(h0, None, &PROFILE_STEPS, PROFILE_SIZES, on_try)
    }

    /// [`pattern_search`] on the size with [`cv`](Self::cv) as its objective; a refit that
    /// fails counts as no improvement.
    fn pattern(
        &self,
        h0: f64,
        known: Option<f64>,
        steps: &[f64],
        max: usize,
        on_try: &mut dyn FnMut(),
    ) -> Vec<(f64, f64)> {
        pattern_search::<std::convert::Infallible>(h0, known, steps, max, &|h| h, &mut |h| {
            on_try();
            Ok(self.cv(h).ok().flatten().unwrap_or(f64::NAN))
        })
        .unwrap_or_default()
    }

    /// The leave-one-recording-out RMS (in noise floors) of the selection refitted with the
    /// play held at `h` (m): its effect, the reduced dynamic play model's response at that
    /// play, taken from the residual rather than fitted; the other selected candidates
    /// fitted. `None` when the play's candidate has other than one column.
    ///
    /// Errors: those of the play column's assembly.
    pub(super) fn cv(&self, h: f64) -> Result<Option<f64>, DiagnoseError> {
        self.refit(h, true)
    }

    /// The leave-one-recording-out RMS (in noise floors) of the selection refitted without
    /// the play: as [`cv`](Self::cv) at `h`, on the same samples (those the play's
    /// assembly at `h` leaves out are left out here too), the play's effect not taken from
    /// the residual. The baseline a held play must beat.
    ///
    /// Errors: those of the play column's assembly.
    pub(super) fn cv_without(&self, h: f64) -> Result<Option<f64>, DiagnoseError> {
        self.refit(h, false)
    }

    /// [`cv`](Self::cv) (`hold`) or [`cv_without`](Self::cv_without) (not).
    fn refit(&self, h: f64, hold: bool) -> Result<Option<f64>, DiagnoseError> {
        let mut o = self.opts.clone();
        // The reference of the play's own direction (the probe's second signature holds an
        // axial play).
        match self.play.effect {
            Effect::Play {
                direction: PlayDirection::Axial,
                ..
            } => o.library.dynamic_axial_play = Some(h),
            _ => o.library.dynamic_play_clearance = Some(h),
        }
        let one = prepare_with(
            self.model,
            self.fit,
            &vec![1.0; self.weights.len()],
            std::slice::from_ref(&self.play),
            &o,
            Some(&self.tight),
            Some(&self.walks),
        )?;
        let [col] = one.cols_of[0][..] else {
            return Ok(None);
        };
        let lens: Vec<usize> = self.fit.iter().map(MotionData::len).collect();
        let mut blocks = vec![];
        for (r, ((cols, b), (play_cols, _))) in self.others.blocks.iter().zip(&one.blocks).enumerate() {
            let (mut cols, mut b, mut a) = (cols.clone(), b.clone(), play_cols[col].clone());
            // A sample either assembly left out is left out of both.
            let n = lens[r];
            let out = |p: &Prepared, i: usize| p.left_out.get(r).is_some_and(|o| o[i]);
            for i in 0..n {
                if out(&one, i) || out(&self.others, i) {
                    for j in 0..b.len() / n.max(1) {
                        b[j * n + i] = 0.0;
                        a[j * n + i] = 0.0;
                        for c in cols.iter_mut() {
                            c[j * n + i] = 0.0;
                        }
                    }
                }
            }
            if hold {
                for (bi, ai) in b.iter_mut().zip(&a) {
                    *bi -= h * ai;
                }
            }
            cols.push(a);
            blocks.push((cols, b));
        }
        let mut cands = self.others.cands.clone();
        cands.push(self.play.clone());
        let mut cols_of = self.others.cols_of.clone();
        cols_of.push(vec![blocks.first().map_or(0, |(c, _)| c.len() - 1)]);
        let held = Prepared::new(cands, cols_of, blocks)?.reweighed(&self.weights, &lens)?;
        let factor: Vec<f64> = self
            .weights
            .iter()
            .zip(&self.floors)
            .map(|(w, s)| w / s.max(1e-300))
            .collect();
        Ok(Some(held.cv_rms_rescaled(&self.refitted, &factor, &lens)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_damping_is_identified_only_when_the_next_best_is_worse_beyond_the_tolerance() {
        let c = |constant: f64, load: f64| ContactDamping { constant, load };
        // Session 54's grid on clearance-F: 1.377 against 1.378 and 1.384 (0.07 %).
        let grid = [
            (c(20.0, 1000.0), 1.377),
            (c(20.0, 250.0), 1.378),
            (c(20.0, 500.0), 1.384),
        ];
        assert_eq!(damping_identified(&grid, &[], 0.005), Some(false));
        // 1 % apart: told.
        let told = [(c(20.0, 1000.0), 1.377), (c(20.0, 250.0), 1.391)];
        assert_eq!(damping_identified(&told, &[], 0.005), Some(true));
        // The size search's refits decide where they compared two dampings, each damping at
        // its best size (20 + 250 at 0.9591 beats its own 0.9700 at another size).
        let sized = [
            (c(20.0, 250.0), 5.9e-6, 0.9700),
            (c(20.0, 250.0), 5.92e-6, 0.9591),
            (c(20.0, 500.0), 5.92e-6, 0.9720),
        ];
        assert_eq!(damping_identified(&grid, &sized, 0.005), Some(true));
        assert_eq!(damping_identified(&grid, &sized, 0.02), Some(false));
        // One damping in the refits: the grid's record decides; one damping at all: no answer.
        assert_eq!(damping_identified(&grid, &sized[..2], 0.005), Some(false));
        assert_eq!(damping_identified(&grid[..1], &[], 0.005), None);
        // A failed refit (non-finite) is no evidence.
        let failed = [(c(20.0, 250.0), 1.0), (c(20.0, 500.0), f64::NAN)];
        assert_eq!(damping_identified(&failed, &[], 0.005), None);
    }

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
        let log = search_play_size::<()>(5.6e-6, None, &mut |h| {
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
            search_play_size(5e-6, None, &mut |_| Err::<f64, _>("refit failed")),
            Err("refit failed")
        );
        // A non-finite value is no improvement, however it compares: −∞ and NaN above the
        // start, so each step tries both ways and moves neither.
        let log = search_play_size::<()>(5e-6, None, &mut |h| {
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
        let log = search_play_size::<()>(5e-6, None, &mut |h| {
            Ok(if h == 5e-6 {
                f64::NAN
            } else {
                (h / 6e-6).ln().abs()
            })
        })
        .expect("no error");
        assert!(log[1].1.is_finite() && log.len() > 3, "{log:?}");
        // A value known at the start is not asked for again.
        let mut asked = vec![];
        let log = search_play_size::<()>(5.6e-6, Some(f(5.6e-6)), &mut |h| {
            asked.push(h);
            Ok(f(h))
        })
        .expect("no error");
        assert_eq!(log[0], (5.6e-6, f(5.6e-6)));
        assert!(
            !asked.contains(&5.6e-6) && asked.len() + 1 == log.len(),
            "{asked:?}"
        );
    }
}
