//! The entry points: [`diagnose`] on prepared motion data (noise floors, localisation, the
//! selection, estimates, confounding and the held-out check, then one re-linearisation and,
//! when a radial play was selected, the play-dynamics check) and [`diagnose_recordings`] on
//! recordings, which first chooses the differentiation window.

use super::adequacy::{self, BasisResidual};
use super::candidates::{library, Effect, PlayDirection};
use super::data::{Channel, MotionData};
use super::error::DiagnoseError;
use super::locate::{locate, tagged_windows, StateScales};
use super::model::{on_copies, InverseDynamicsModel};
use super::options::DiagnoseOptions;
use super::outcome::{
    ChannelFit, Diagnosis, PlayDynamicsChannel, PlayDynamicsCheck, PlayProbe, ResidualTrace,
};
use super::play_dynamics::{ContactDamping, BALL_CONTACT};
use super::play_size::{
    best_refit, search_constant_damping, search_load_damping, HeldPlay, MAX_CONSTANT_DAMPINGS,
    MAX_LOAD_DAMPINGS, MAX_PLAY_SIZES, PROFILE_SIZES,
};
use super::recording::{Recording, RecordingError, MIN_SAMPLES};
use super::relinearize;
use super::residuals::{prepare_needed, prepare_with, Prepared};
use super::selection::{confounded, estimate, select, Estimates, Selection};
use super::series_joints::name_compliance_at_play;
use super::signal::{noise_floor, rms};
use super::transmission::PlayPlace;
use super::verdict::{verdict, verdict_text};

/// Runs the diagnosis of `model` on the `fit` recordings, checked on `holdout` (equation
/// error on torque channels, output error on output channels). `progress` receives (stage,
/// fraction done).
///
/// Errors: an empty fit set, a recording that does not fit the model
/// ([`MotionData::check`]), or one whose channels differ from the first fit recording's.
pub fn diagnose(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    mut progress: impl FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_dyn(model, fit, holdout, opts, &mut progress)
}

/// [`diagnose`] with the progress callback behind a reference: the diagnosis is compiled
/// once, not once per caller's closure type (in every crate that calls it).
fn diagnose_dyn(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    check_recordings(model, fit, holdout)?;
    if let Some(text) = super::candidates::excluded_unknown(model, &opts.library) {
        let all = library(
            model,
            &super::candidates::LibraryOptions {
                exclude: vec![],
                ..opts.library.clone()
            },
        );
        let mut names: Vec<String> = all.into_iter().map(|c| c.name).collect();
        names.dedup();
        return Err(DiagnoseError::UnknownExclusion {
            text,
            available: names.join(", "),
        });
    }
    let parts;
    let (fit, folds) = match fit {
        [one] => {
            let k = FOLDS_FROM_ONE_RECORDING;
            if one.len() < k * MIN_SAMPLES {
                return Err(DiagnoseError::TooFewSamplesForFolds {
                    recording: one.name.clone(),
                    found: one.len(),
                    folds: k,
                    needed: MIN_SAMPLES,
                });
            }
            parts = one.folds(k);
            let span =
                |d: &MotionData| d.t.last().copied().unwrap_or(0.0) - d.t.first().copied().unwrap_or(0.0);
            let note = format!(
                "Only one recording ({}) was fitted: it was cut into {k} contiguous parts of {:.3} s for cross-validation (leave one part out); parts of one run share its conditions, so held-out recordings are the stronger test.",
                one.name,
                span(one) / k as f64
            );
            (&parts[..], Some(note))
        }
        _ => (fit, None),
    };
    let mut d = diagnose_folds(model, fit, holdout, opts, progress)?;
    d.ends_dropped = fit
        .iter()
        .chain(holdout)
        .map(|m| m.ends_dropped)
        .max()
        .unwrap_or(0);
    if let Some(note) = folds {
        d.verdict = format!("{} {note}", d.verdict);
        d.folds = Some(note);
    }
    Ok(d)
}

/// Samples per fit recording at which [`motion_noise`] reads the model's inertia.
const MOTION_NOISE_SAMPLES: usize = 16;

/// Per joint, the noise the accelerations' noise puts into the model's torque (N m or N):
/// the median over samples of √(Σ_k (∂τ_j/∂q̈_k · σ_q̈k)²), the inertia ∂τ/∂q̈ by differences of
/// the model's torques at [`MOTION_NOISE_SAMPLES`] samples of each fit recording. Zero where
/// the recordings state no acceleration noise.
fn motion_noise(model: &dyn InverseDynamicsModel, fit: &[MotionData], theta: &[f64]) -> Vec<f64> {
    let nj = model.joints();
    let mut per_joint: Vec<Vec<f64>> = vec![vec![]; nj];
    for d in fit {
        if d.qdd_noise.len() != nj || d.qdd_noise.iter().all(|s| *s == 0.0) || d.is_empty() {
            continue;
        }
        for s in 0..MOTION_NOISE_SAMPLES {
            let i = (2 * s + 1) * d.len() / (2 * MOTION_NOISE_SAMPLES);
            let q: Vec<f64> = d.q.iter().map(|v| v[i]).collect();
            let qd: Vec<f64> = d.qd.iter().map(|v| v[i]).collect();
            let qdd: Vec<f64> = d.qdd.iter().map(|v| v[i]).collect();
            let mut tau0 = vec![0.0; nj];
            model.torques(theta, &q, &qd, &qdd, &mut tau0);
            let mut var = vec![0.0; nj];
            for k in 0..nj {
                let h = d.qdd_noise[k].max(1e-9);
                let mut a = qdd.clone();
                a[k] += h;
                let mut tau = vec![0.0; nj];
                model.torques(theta, &q, &qd, &a, &mut tau);
                for j in 0..nj {
                    // (∂τ_j/∂q̈_k · σ_k)² with the step h = σ_k.
                    var[j] += ((tau[j] - tau0[j]) * d.qdd_noise[k] / h).powi(2);
                }
            }
            for j in 0..nj {
                if var[j].is_finite() {
                    per_joint[j].push(var[j].sqrt());
                }
            }
        }
    }
    per_joint
        .into_iter()
        .map(|mut v| {
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        })
        .collect()
}

/// Folds a single fit recording is cut into for cross-validation.
pub const FOLDS_FROM_ONE_RECORDING: usize = 4;

/// [`diagnose`] on fit recordings that are the cross-validation folds.
fn diagnose_folds(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    let mut filled = opts.clone();
    if filled.library.speed_scales.is_empty() {
        filled.library.speed_scales = speed_scales(model, fit);
    }
    let opts = &filled;
    let mut first = diagnose_once(model, fit, holdout, opts, None, &mut |s, f| progress(s, 0.5 * f))?;
    let cands = library(model, &opts.library);
    if !opts.relinearize {
        if series_naming(model, &mut first, &cands, opts) {
            first.verdict = verdict_text(model, &first, &cands);
        }
        progress("done", 1.0);
        return Ok(first);
    }
    // Shift the model by the selected parameter and sensor-offset estimates.
    // Each estimate moves the model only as far as the point stays near linear (a
    // departure from the nominal residual would be fitted as if it were data).
    let floors: Vec<f64> = first.channels.iter().map(|c| c.noise_floor).collect();
    let steps = relinearize::linear_steps(model, &first.estimates, &cands, fit, &floors, opts)?;
    let fraction = |name: &str| {
        steps
            .iter()
            .find(|s| s.candidate == name)
            .map_or(1.0, |s| s.fraction)
    };
    let (shifted, moved) = relinearize::shift(model, &first.estimates, &cands, &fraction);
    // The nominal model's walks along the recordings at this point, shared by every pass
    // and refit made on it (the probe, the dampings, stiffnesses and places, the resized
    // references, the size search).
    let mut walks = PassWalks::new(fit, holdout);
    // The plays' dynamics in the selection: the reference plays from the first pass.
    let mut references = if opts.dynamic_play_selection {
        relinearize::dynamic_play_references(model, &first, &cands)
    } else {
        (None, None)
    };
    // A play the first pass saw but could not carry: its dynamics probed, and the best
    // size, where it refits better, the reference of the second pass's plays. (`start`: the
    // furthest fraction its refits reached, where the second passes start.)
    let mut start: f64 = 0.5;
    let probe = if opts.dynamic_play_selection && opts.play_probe && references == (None, None) {
        probe_unseen_play(
            model,
            &shifted,
            &moved,
            fit,
            &first,
            &cands,
            opts,
            &walks,
            &mut |s, f| {
                start = start.max(f);
                progress(s, f)
            },
        )
    } else {
        None
    };
    if let Some(h) = probe.as_ref().and_then(|p| p.kept) {
        references = (Some(h), Some(h));
    }
    let dynamic = references.0.is_some() || references.1.is_some();
    // A backlash found: the second pass takes its dead zone's secant.
    let backlash = relinearize::backlash_reference(model, &first, &cands);
    if moved.is_empty() && !dynamic && backlash.is_none() {
        // Nothing to re-linearise; the play-dynamics check still runs.
        let mut d = first;
        d.play_probe = probe;
        d.relinearization_steps = steps;
        d.play_dynamics =
            play_dynamics_check(model, model, &d, fit, holdout, opts, &cands, None, &mut *progress)?;
        // (After the check, which refits the selection's own columns.)
        series_naming(model, &mut d, &cands, opts);
        d.verdict = verdict_text(model, &d, &cands);
        progress("done", 1.0);
        return Ok(d);
    }
    let mut o2 = opts.clone();
    o2.relinearize = false;
    o2.shift = moved;
    (o2.library.dynamic_play_clearance, o2.library.dynamic_axial_play) = references;
    o2.library.backlash_reference = backlash;
    // With a backlash's dead zone: after the plays' choices, once per further place of its
    // play, the smallest cross-validated error kept.
    let places: Vec<PlayPlace> = match (backlash, opts.backlash_places.split_first()) {
        (Some(_), Some((&first, _))) => {
            o2.library.backlash_place = first;
            opts.backlash_places.clone()
        }
        _ => vec![o2.library.backlash_place],
    };
    // With the play's dynamics: once per contact damping, the smallest cross-validated
    // error kept.
    let dampings: Vec<Option<ContactDamping>> = if dynamic && !opts.play_contact_dampings.is_empty() {
        opts.play_contact_dampings.iter().map(|c| Some(*c)).collect()
    } else {
        vec![o2.library.play_contact_damping]
    };
    // Then, at the kept damping, once per further end-face stiffness (linear balls only).
    let stiffnesses: Vec<Option<f64>> =
        if dynamic && !o2.library.play_contact_hertz && !opts.play_axial_stiffnesses.is_empty() {
            opts.play_axial_stiffnesses.iter().map(|k| Some(*k)).collect()
        } else {
            vec![o2.library.play_axial_stiffness]
        };
    // (One share of the progress per damping and stiffness, and one per pass at resized
    // references.)
    let search = dynamic && opts.play_size_search;
    // (The play-size search's shares after those.)
    let size_share = dampings.len() + stiffnesses.len() + places.len() - 2
        + if dynamic { relinearize::MAX_RESIZES } else { 0 };
    let search_shares = search_shares(opts);
    let passes = size_share + if search { search_shares + 1 } else { 0 };
    // (The passes share what the probe, if it ran, left of the second pass's range.)
    let share = (0.9 - start) / passes as f64;
    let pass = |k: usize,
                damping: Option<ContactDamping>,
                stiffness: Option<f64>,
                place: PlayPlace,
                refs: (Option<f64>, Option<f64>),
                progress: &mut dyn FnMut(&str, f64)| {
        let mut o = o2.clone();
        o.library.play_contact_damping = damping;
        o.library.play_axial_stiffness = stiffness;
        o.library.backlash_place = place;
        (o.library.dynamic_play_clearance, o.library.dynamic_axial_play) = refs;
        diagnose_once(&shifted, fit, holdout, &o, Some(&walks), &mut |s, f| {
            progress(s, start + share * (k as f64 + f))
        })
    };
    let mut second = pass(
        0,
        dampings[0],
        stiffnesses[0],
        places[0],
        references,
        &mut *progress,
    )?;
    // The damping and end-face stiffness the kept pass ran with.
    let (mut used_damping, mut used_stiffness) = (dampings[0], stiffnesses[0]);
    let mut tried = vec![(dampings[0], second.cv_rms_noise_units)];
    for k in 1..dampings.len() {
        let d = pass(
            k,
            dampings[k],
            stiffnesses[0],
            places[0],
            references,
            &mut *progress,
        )?;
        tried.push((dampings[k], d.cv_rms_noise_units));
        if d.cv_rms_noise_units < second.cv_rms_noise_units {
            second = d;
            used_damping = dampings[k];
        }
    }
    let mut tried_stiffness = vec![(stiffnesses[0], second.cv_rms_noise_units)];
    for (k, &stiffness) in stiffnesses.iter().enumerate().skip(1) {
        let d = pass(
            dampings.len() + k - 1,
            second.dynamic_play_damping,
            stiffness,
            places[0],
            references,
            &mut *progress,
        )?;
        tried_stiffness.push((stiffness, d.cv_rms_noise_units));
        if d.cv_rms_noise_units < second.cv_rms_noise_units {
            second = d;
            (used_damping, used_stiffness) = (second.dynamic_play_damping, stiffness);
        }
    }
    // The second pass's own library (its play candidates may differ from the first's:
    // `LibraryOptions::dynamic_play_tracker`; not with the references, see below).
    let cands2 = library(model, &o2.library);
    let selects_backlash = |d: &Diagnosis| {
        d.selected.iter().any(|n| {
            cands2
                .iter()
                .any(|c| &c.name == n && matches!(c.effect, super::candidates::Effect::Backlash { .. }))
        })
    };
    // Another place is kept only where it cross-validates better beyond the confounding
    // tolerance; within it the data do not tell, and the first place stays. (Only with a
    // backlash in the selection: elsewhere the place changes nothing.)
    let mut tried_place = vec![(places[0], second.cv_rms_noise_units)];
    let mut better: Option<Diagnosis> = None;
    let other_places = if selects_backlash(&second) {
        &places[1..]
    } else {
        &[]
    };
    for (k, &place) in other_places.iter().enumerate() {
        let d = pass(
            dampings.len() + stiffnesses.len() + k - 1,
            used_damping,
            used_stiffness,
            place,
            references,
            &mut *progress,
        )?;
        tried_place.push((place, d.cv_rms_noise_units));
        let best = better
            .as_ref()
            .map_or(second.cv_rms_noise_units, |b| b.cv_rms_noise_units);
        if d.cv_rms_noise_units < best {
            better = Some(d);
        }
    }
    if backlash.is_some() && tried_place.len() > 1 {
        let (lo, hi) = tried_place
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &(_, cv)| {
                (lo.min(cv), hi.max(cv))
            });
        let identified = hi >= lo * (1.0 + opts.confound_tolerance);
        if let Some(b) = better
            .filter(|b| b.cv_rms_noise_units * (1.0 + opts.confound_tolerance) <= second.cv_rms_noise_units)
        {
            second = b;
        }
        second.backlash_place_identified = Some(identified);
        second.backlash_place_cv = tried_place;
    }
    if dynamic {
        second.dynamic_play_damping_cv = tried.into_iter().filter_map(|(c, cv)| Some((c?, cv))).collect();
        second.dynamic_play_axial_stiffness_cv = tried_stiffness
            .into_iter()
            .filter_map(|(k, cv)| Some((k?, cv)))
            .collect();
    }
    // The play candidates' columns are secants, exact at their reference play only: where
    // the last pass sized a play far from its reference, once more at its estimates (the
    // kept damping) — a secant iteration on the plays, at most `MAX_RESIZES` times, while
    // the selection cross-validates better; the best kept.
    if dynamic {
        // (Each pass kept has a smaller error than the one before, so `second` is the last.)
        let mut log = vec![(references.0, references.1, second.cv_rms_noise_units)];
        let (damping, stiffness, place, mut at) = (
            second.dynamic_play_damping,
            second.dynamic_play_axial_stiffness,
            second.backlash_place.unwrap_or(places[0]),
            references,
        );
        for k in 0..relinearize::MAX_RESIZES {
            let Some(refs) = relinearize::resized_references(model, &second, &cands2, at) else {
                break;
            };
            let mut d = pass(
                dampings.len() + stiffnesses.len() + places.len() - 2 + k,
                damping,
                stiffness,
                place,
                refs,
                &mut *progress,
            )?;
            log.push((refs.0, refs.1, d.cv_rms_noise_units));
            if d.cv_rms_noise_units >= second.cv_rms_noise_units {
                break;
            }
            carry_choices(&mut second, &mut d);
            (second, at) = (d, refs);
        }
        second.dynamic_play_reference_cv = log;
    }
    // The radial play's size searched about the kept selection (`search_play_size`).
    if search {
        search_play_size(
            model,
            &shifted,
            fit,
            holdout,
            &o2,
            opts,
            &cands2,
            &dampings,
            places[0],
            &walks,
            &mut second,
            (start + share * size_share as f64, share),
            &mut *progress,
        )?;
    }
    // Gauss–Newton continued: where a step was held back (the model not linear enough
    // between the nominal point and the first pass's estimates), a whole step from the
    // point reached to the last pass's estimates and a pass there, at the kept damping,
    // end-face stiffness and reference plays; kept while the selection cross-validates
    // better by `CONTINUED_STEP_GAIN`, at most `MAX_RELINEARIZATIONS` passes in all.
    let (kept_damping, kept_stiffness, kept_place, kept_refs) = (
        second.dynamic_play_damping,
        second.dynamic_play_axial_stiffness,
        second.backlash_place,
        (second.dynamic_play_reference, second.dynamic_axial_play_reference),
    );
    let mut shifted = shifted;
    let mut cv_log = vec![second.cv_rms_noise_units];
    let mut base = relinearize::point_toward(model, &[], &first.estimates, &cands, &fraction);
    // Continued where a step was held back, or always when asked to converge.
    let go_on = steps.iter().any(|s| s.fraction < 1.0) || opts.relinearize_to_convergence;
    let mut passes = 1;
    // What the last kept pass moved the model by (its `DiagnoseOptions::shift`).
    let mut moved_kept = o2.shift.clone();
    while go_on && cv_log.len() < relinearize::MAX_RELINEARIZATIONS {
        let point = relinearize::point_toward(model, &base, &second.estimates, &cands2, &|_| 1.0);
        // Converged: every effect within `relinearize::CONVERGED_STEP` of the point.
        let converged = point.len() == base.len()
            && point.iter().zip(&base).all(|(a, b)| {
                a.candidate == b.candidate
                    && a.parameter == b.parameter
                    && (a.value - b.value).abs() <= relinearize::CONVERGED_STEP * a.value.abs()
            });
        if converged {
            break;
        }
        let (shifted_k, moved_k) = relinearize::shift_toward(model, &[], &point, &cands2, &|_| 1.0);
        let mut o = o2.clone();
        o.shift = moved_k;
        if let Some(place) = kept_place {
            o.library.backlash_place = place;
        }
        if dynamic {
            o.library.play_contact_damping = kept_damping;
            o.library.play_axial_stiffness = kept_stiffness;
            (o.library.dynamic_play_clearance, o.library.dynamic_axial_play) = kept_refs;
        }
        let walks_k = PassWalks::new(fit, holdout);
        let mut d = diagnose_once(&shifted_k, fit, holdout, &o, Some(&walks_k), &mut |s, f| {
            progress(s, 0.9 + 0.05 * f)
        })?;
        cv_log.push(d.cv_rms_noise_units);
        if d.cv_rms_noise_units > (1.0 - relinearize::CONTINUED_STEP_GAIN) * second.cv_rms_noise_units {
            break;
        }
        carry_choices(&mut second, &mut d);
        (second, shifted, base, moved_kept, walks) = (d, shifted_k, point, o.shift, walks_k);
        passes += 1;
    }
    // The further passes kept moved the point the play's columns are computed about, and a
    // rattle does not respond linearly to it: the play's size searched again there.
    if search && passes > 1 {
        let mut o = o2.clone();
        o.shift = moved_kept;
        if let Some(place) = kept_place {
            o.library.backlash_place = place;
        }
        search_play_size(
            model,
            &shifted,
            fit,
            holdout,
            &o,
            opts,
            &cands2,
            &dampings,
            places[0],
            &walks,
            &mut second,
            (0.95, 0.04 / (search_shares + 1) as f64),
            &mut *progress,
        )?;
    }
    let mut d = relinearize::against_nominal(model, first, second, &cands2);
    d.play_probe = probe;
    if !selects_backlash(&d) {
        (d.backlash_place, d.backlash_place_identified) = (None, None);
        d.backlash_place_cv.clear();
    }
    d.relinearization_steps = steps;
    d.relinearization_cv = cv_log;
    d.relinearization_passes = passes;
    // Only a selected play makes the damping matter.
    if relinearize::dynamic_play_references(model, &d, &cands2) != (None, None) {
        d.dynamic_play_damping_identified = super::play_size::damping_identified(
            &d.dynamic_play_damping_cv,
            &d.dynamic_play_size_cv,
            opts.confound_tolerance,
        );
    }
    // "Before" is now the nominal model's: the explained fractions follow, and the verdict.
    adequacy::refresh(&mut d);
    let set: Vec<usize> = d
        .selected
        .iter()
        .filter_map(|n| cands2.iter().position(|c| &c.name == n))
        .collect();
    d.friction = super::equivalents::joint_friction(model, &set, &cands2, &d.estimates);
    if d.dynamic_play_reference.is_none() && d.dynamic_axial_play_reference.is_none() {
        let mut o3 = o2.clone();
        o3.library.backlash_place = d.backlash_place.unwrap_or(o3.library.backlash_place);
        d.play_dynamics = play_dynamics_check(
            model,
            &shifted,
            &d,
            fit,
            holdout,
            &o3,
            &cands2,
            Some(&walks),
            &mut *progress,
        )?;
    }
    // (After the check, which refits the selection's own columns.)
    series_naming(model, &mut d, &cands2, opts);
    d.verdict = verdict_text(model, &d, &cands2);
    progress("done", 1.0);
    Ok(d)
}

/// Where `opts` ask for it, names a contact compliance at the joint in series whose play is
/// selected ([`name_compliance_at_play`]; two play sites of `model` sharing a contact-compliance
/// parameter are in series) and refreshes what follows from the names (`found`, the unstable
/// list); the caller writes the verdict. Returns whether a name changed.
fn series_naming(
    model: &dyn InverseDynamicsModel,
    d: &mut Diagnosis,
    cands: &[super::candidates::Candidate],
    opts: &DiagnoseOptions,
) -> bool {
    if !opts.name_compliance_at_play {
        return false;
    }
    let series: Vec<Vec<usize>> = (0..model.play_sites().len())
        .map(|s| model.play_site_compliance(s))
        .collect();
    name_compliance_at_play(d, cands, &series);
    let named = d.series_naming.is_some();
    if named {
        adequacy::refresh(d);
    }
    named
}

/// The nominal model's walks along the fit and the held-out recordings at one linearisation
/// point ([`NominalWalk`](super::candidates::NominalWalk), one per recording, filled on first
/// use): every pass and refit made on the model moved to that point shares them, so each
/// recording is walked once per point, not once per contact damping, end-face stiffness,
/// backlash place, reference play and size search.
struct PassWalks {
    fit: super::play_size::Walks,
    holdout: super::play_size::Walks,
}

impl PassWalks {
    /// Empty walks for `fit` and `holdout`.
    fn new(fit: &[MotionData], holdout: &[MotionData]) -> Self {
        Self {
            fit: HeldPlay::fresh_walks(fit),
            holdout: HeldPlay::fresh_walks(holdout),
        }
    }
}

/// The weights and error units of a refit about the selection `d` on `fit`: each channel
/// weighted by the larger of its noise floor and what `d` leaves of it; errors in the
/// measured channels' noise floors, as the selection's (both in the channel's unit).
fn refit_weights(d: &Diagnosis, fit: &[MotionData]) -> (Vec<f64>, Vec<f64>) {
    let weights = d
        .channels
        .iter()
        .map(|c| c.fit_after.max(c.noise_floor))
        .collect();
    (weights, measured_floors(fit))
}

/// The share of a diagnosis's progress the play probe takes where it runs
/// ([`probe_unseen_play`]): after the first pass's half, before the second passes, which
/// share what is left up to 0.9. A probe is tens of refits of the reduced play model (on seed
/// 11's axial-D most of the diagnosis's time), so its refits move the fraction.
const PROBE_SHARE: f64 = 0.1;
// The second passes keep a range after the probe's.
const _: () = assert!(0.5 + PROBE_SHARE < 0.9);

/// The diagnosis's progress fraction at the play probe's `tried`-th refit of at most `most`:
/// from the first pass's end (0.5) by [`PROBE_SHARE`] in proportion, never beyond it.
fn probe_fraction(tried: usize, most: usize) -> f64 {
    0.5 + PROBE_SHARE * tried.min(most) as f64 / most.max(1) as f64
}

/// The play probe's progress label: its `tried`-th refit of at most `most`
/// ([`probe_unseen_play`]).
fn probe_label(tried: usize, most: usize) -> String {
    format!("play probe, refit {tried} of at most {most}")
}

/// The probe for a play the first pass `first` saw but could not carry
/// ([`PlayProbe`]): where [`relinearize::unseen_play`] finds the signature, that joint's
/// radial play with its dynamics refitted beside `first`'s selection on `shifted` (the
/// model moved by `moved`) at each size of the probe's grid and refined, then searched at
/// each other contact damping of the grid ([`probe_play`](super::play_size::probe_play));
/// the best refit's size kept where it refits better than without the play beyond the
/// confounding tolerance. `None` without the signature, or
/// where the play has no dynamic candidate or its refits cannot be assembled (the first
/// pass's choice then stands, as after a play-size search that cannot assemble).
#[allow(clippy::too_many_arguments)]
fn probe_unseen_play(
    model: &dyn InverseDynamicsModel,
    shifted: &dyn InverseDynamicsModel,
    moved: &[(String, f64)],
    fit: &[MotionData],
    first: &Diagnosis,
    cands: &[super::candidates::Candidate],
    opts: &DiagnoseOptions,
    walks: &PassWalks,
    progress: &mut dyn FnMut(&str, f64),
) -> Option<PlayProbe> {
    // The first signature probes the joint's radial play; the second (a backlash in the
    // play's place) the play of the direction that cross-validated best.
    let (signature, site, direction, backlash) = match relinearize::unseen_play(model, first, cands) {
        Some((signature, site)) => (signature, site, PlayDirection::Radial, None),
        None => {
            let (backlash, signature, site, direction) =
                relinearize::play_behind_backlash(model, first, cands)?;
            (signature, site, direction, Some(backlash))
        }
    };
    let mut o = opts.clone();
    o.relinearize = false;
    o.shift = moved.to_vec();
    o.library.dynamic_play_clearance = Some(super::PROBE_PLAY_SIZES.0);
    o.library.dynamic_axial_play = Some(super::PROBE_PLAY_SIZES.0);
    let play = library(model, &o.library).into_iter().find(
        |c| matches!(c.effect, Effect::Play { site: s, direction: d, .. } if s == site && d == direction),
    )?;
    let (weights, floors) = refit_weights(first, fit);
    // (The fraction moves from where the first pass ended by `PROBE_SHARE` over the refits'
    // most — the grid's, its refinement's and each other damping's search — which the label
    // counts against.)
    let own = o
        .library
        .play_contact_damping
        .unwrap_or(BALL_CONTACT.contact_damping());
    let most = super::play_size::probe_refits_most(own, &opts.play_contact_dampings);
    let mut tried = 0;
    let mut on_try = || {
        tried += 1;
        progress(&probe_label(tried, most), probe_fraction(tried, most));
    };
    let refits = super::play_size::probe_play(
        shifted,
        fit,
        &o,
        &first.selected,
        &play.name,
        &opts.play_contact_dampings,
        &weights,
        &floors,
        Some(&walks.fit),
        &mut on_try,
    )
    .ok()
    .flatten()?;
    let kept = refits
        .best()
        .filter(|&(_, _, cv)| cv * (1.0 + opts.confound_tolerance) < refits.without);
    Some(PlayProbe {
        signature,
        backlash,
        candidate: play.name,
        without: refits.without,
        damping: refits.damping,
        sizes: refits.sizes,
        damping_sizes: refits.dampings,
        kept: kept.map(|k| k.1),
        kept_damping: kept.map(|k| k.0),
    })
}

/// The play-size search's shares of the progress: one per refit, the sizes at the kept
/// damping and, with the damping search, each damping round's.
fn search_shares(opts: &DiagnoseOptions) -> usize {
    MAX_PLAY_SIZES
        + if opts.play_damping_search {
            (MAX_CONSTANT_DAMPINGS + MAX_LOAD_DAMPINGS) * PROFILE_SIZES
        } else {
            0
        }
}

/// The radial play's size searched (`DiagnoseOptions::play_size_search`, `play_size`) about
/// the selection `second` made on `shifted` (the model moved by `o2.shift`): the kept
/// selection refitted with the play held at each size a pattern search tries, from the
/// selection's estimate; the best size (and damping) becomes the reference of one more whole
/// selection, which replaces `second` if it cross-validates better. The sizes tried are
/// recorded in `second.dynamic_play_size_cv` either way. `progress` receives
/// `base + share × k` at the k-th refit of [`MAX_PLAY_SIZES`] and the damping search's.
#[allow(clippy::too_many_arguments)]
fn search_play_size(
    model: &dyn InverseDynamicsModel,
    shifted: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    o2: &DiagnoseOptions,
    opts: &DiagnoseOptions,
    cands2: &[super::candidates::Candidate],
    dampings: &[Option<ContactDamping>],
    default_place: PlayPlace,
    pass_walks: &PassWalks,
    second: &mut Diagnosis,
    (base, share): (f64, f64),
    progress: &mut dyn FnMut(&str, f64),
) -> Result<(), DiagnoseError> {
    let search_shares = search_shares(opts);
    if let Some((name, h0)) = relinearize::dynamic_play_clearance(model, second, cands2) {
        let mut o = o2.clone();
        o.library.play_contact_damping = second.dynamic_play_damping;
        o.library.play_axial_stiffness = second.dynamic_play_axial_stiffness;
        o.library.backlash_place = second.backlash_place.unwrap_or(default_place);
        (o.library.dynamic_play_clearance, o.library.dynamic_axial_play) =
            (second.dynamic_play_reference, second.dynamic_axial_play_reference);
        let (weights, floors) = refit_weights(second, fit);
        // The size at the kept damping; then every other damping at the best size, and
        // where one is better there, the size again at it (one round of coordinate
        // descent: the damping was chosen at the reference play, and a rattle's damping
        // and timing go together).
        let resolved = |d: Option<ContactDamping>| d.unwrap_or(BALL_CONTACT.contact_damping());
        let kept = resolved(second.dynamic_play_damping);
        let mut tried = 0;
        let mut on_try = || {
            progress("play size", base + share * tried.min(search_shares) as f64);
            tried += 1;
        };
        // The nominal model's walks along the fit recordings, shared by every damping's
        // refits (they depend on neither the play nor the damping) and with the passes on
        // the same model.
        let walks = pass_walks.fit.clone();
        // (A search that cannot assemble its columns leaves the selection as it is, as
        // the play-dynamics check does.)
        let held_at = |damping: ContactDamping| {
            HeldPlay::at_damping(
                shifted,
                fit,
                &o,
                damping,
                &second.selected,
                &name,
                &weights,
                &floors,
                &walks,
            )
        };
        let mut log: Vec<(ContactDamping, f64, f64)> = vec![];
        if let Some(held) = held_at(kept) {
            log.extend(
                held.search(h0, None, &mut on_try)
                    .into_iter()
                    .map(|(h, cv)| (kept, h, cv)),
            );
        }
        if let Some((_, h, cv)) = best_refit(&log) {
            let mut better: Option<(HeldPlay, ContactDamping, f64)> = None;
            for damping in dampings.iter().map(|d| resolved(*d)).filter(|d| *d != kept) {
                let Some(held) = held_at(damping) else { continue };
                on_try();
                let cv_d = held.cv(h).ok().flatten().unwrap_or(f64::NAN);
                log.push((damping, h, cv_d));
                if cv_d < better.as_ref().map_or(cv, |b| b.2) {
                    better = Some((held, damping, cv_d));
                }
            }
            if let Some((held, damping, cv_d)) = better {
                let again = held.search(h, Some(cv_d), &mut on_try);
                log.extend(again.into_iter().skip(1).map(|(h, cv)| (damping, h, cv)));
            }
        }
        // The damping searched (`DiagnoseOptions::play_damping_search`): under a
        // load-proportional damping, its constant part by a pattern search from the best
        // refit so far, then γ at the best constant part; each damping's objective the
        // best of a short search on the size at it from the best size so far (a profile:
        // a rattle's damping and timing go together, and a search on one at a time
        // stalls in the valley between them).
        if opts.play_damping_search {
            let mut profile = |d: ContactDamping, log: &mut Vec<(ContactDamping, f64, f64)>| {
                // (A damping refitted before, the grid's: its best, not refitted again.)
                if let Some(b) = best_refit(log.iter().filter(|x| x.0 == d)) {
                    return b.2;
                }
                let Some(held) = held_at(d) else {
                    return f64::NAN;
                };
                let from = best_refit(log.iter()).map_or(h0, |b| b.1);
                let sizes: Vec<_> = held
                    .refine(from, &mut on_try)
                    .into_iter()
                    .map(|(h, cv)| (d, h, cv))
                    .collect();
                log.extend(&sizes);
                best_refit(&sizes).map_or(f64::NAN, |b| b.2)
            };
            type Never = std::convert::Infallible;
            // (A constant part of zero has no scale to step from.)
            if let Some((d0, _, cv0)) = best_refit(&log).filter(|b| b.0.load > 0.0 && b.0.constant > 0.0) {
                let _ = search_constant_damping::<Never>(d0.constant, Some(cv0), &mut |c| {
                    Ok(profile(ContactDamping { constant: c, ..d0 }, &mut log))
                });
            }
            if let Some((d1, _, cv1)) = best_refit(&log).filter(|b| b.0.load > 0.0) {
                let _ = search_load_damping::<Never>(d1.load, Some(cv1), &mut |g| {
                    Ok(profile(ContactDamping { load: g, ..d1 }, &mut log))
                });
            }
        }
        let best = best_refit(&log).filter(|&(damping, h, _)| {
            second.dynamic_play_reference != Some(h) || resolved(second.dynamic_play_damping) != damping
        });
        if let Some((damping, h, _)) = best {
            let mut o = o.clone();
            o.library.play_contact_damping = Some(damping);
            o.library.dynamic_play_clearance = Some(h);
            let mut d = diagnose_once(shifted, fit, holdout, &o, Some(pass_walks), &mut |s, f| {
                progress(s, base + share * (search_shares as f64 + f))
            })?;
            if d.cv_rms_noise_units < second.cv_rms_noise_units {
                carry_choices(second, &mut d);
                *second = d;
            }
        }
        second.dynamic_play_size_cv = log;
    }
    Ok(())
}

/// A later pass `to` replacing `from` takes over the record of the choices made before it
/// (the dampings, end-face stiffnesses, reference plays, play sizes and backlash places
/// tried), which a single pass does not make.
fn carry_choices(from: &mut Diagnosis, to: &mut Diagnosis) {
    to.dynamic_play_damping_cv = std::mem::take(&mut from.dynamic_play_damping_cv);
    to.dynamic_play_axial_stiffness_cv = std::mem::take(&mut from.dynamic_play_axial_stiffness_cv);
    to.dynamic_play_reference_cv = std::mem::take(&mut from.dynamic_play_reference_cv);
    to.dynamic_play_size_cv = std::mem::take(&mut from.dynamic_play_size_cv);
    to.backlash_place_cv = std::mem::take(&mut from.backlash_place_cv);
    to.backlash_place_identified = from.backlash_place_identified;
}

/// How much of what remains the found play's dynamics explain: when the diagnosis selected a
/// radial play of a joint, its selection refitted (the same candidates, at the same
/// linearisation point `opts.shift`, on the model moved there, `moved`) with that play's
/// drive torques from the reduced dynamic play model ([`super::play_dynamics`]) at its
/// estimate ([`LibraryOptions::dynamic_play_clearance`](super::candidates::LibraryOptions)).
/// It does not change the diagnosis: the dynamic columns cannot tell the two joints of a leg
/// apart (measured, diagnosis log), the quasi-static tracker rows can. `None` when off
/// ([`DiagnoseOptions::play_dynamics`]), when no radial play was selected, or when the refit
/// fails.
#[allow(clippy::too_many_arguments)]
fn play_dynamics_check(
    model: &dyn InverseDynamicsModel,
    moved: &dyn InverseDynamicsModel,
    d: &Diagnosis,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    cands: &[super::candidates::Candidate],
    walks: Option<&PassWalks>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Option<PlayDynamicsCheck>, DiagnoseError> {
    if !opts.play_dynamics {
        return Ok(None);
    }
    let Some((candidate, h)) = relinearize::dynamic_play_clearance(model, d, cands) else {
        return Ok(None);
    };
    // After the continued passes' stages (at most 0.95).
    progress("play dynamics", 0.96);
    let mut o3 = opts.clone();
    o3.relinearize = false;
    o3.library.only = d.selected.clone();
    o3.library.dynamic_play_clearance = Some(h);
    // (The check refits the same candidates, their quasi-static tracker rows included.)
    o3.library.dynamic_play_tracker = false;
    // A check that cannot run (a refit the data do not support) leaves the diagnosis as it is.
    let Ok(refit) = diagnose_once(moved, fit, holdout, &o3, walks, &mut |_, _| {}) else {
        return Ok(None);
    };
    let refit_clearance = refit
        .estimates
        .iter()
        .find(|e| e.candidate == candidate)
        .map(|e| e.value);
    Ok(Some(PlayDynamicsCheck {
        candidate,
        clearance: h,
        refit_clearance,
        selected: refit.selected.clone(),
        channels: d
            .channels
            .iter()
            .zip(&refit.channels)
            .map(|(a, b)| PlayDynamicsChannel {
                channel: a.channel.clone(),
                noise_ratio_without: a.noise_ratio_after,
                noise_ratio_with: b.noise_ratio_after,
            })
            .collect(),
    }))
}

/// Each joint's typical speed in the fit recordings: the 95th percentile of |q̇| (rad/s or
/// m/s), for the velocity scales of prismatic joints' friction candidates.
fn speed_scales(model: &dyn InverseDynamicsModel, fit: &[MotionData]) -> Vec<f64> {
    (0..model.joints())
        .map(|j| {
            let mut v: Vec<f64> = fit
                .iter()
                .flat_map(|d| d.qd[j].iter().map(|x| x.abs()))
                .filter(|x| x.is_finite())
                .collect();
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            v[((v.len() - 1) as f64 * 0.95) as usize]
        })
        .collect()
}

/// Checks every recording against the model and the channels of every fit and held-out
/// recording against those of the first fit recording.
fn check_recordings(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
) -> Result<(), DiagnoseError> {
    let first = fit.first().ok_or(DiagnoseError::NoFitRecordings)?;
    first.check(model)?;
    let expected = first.channels();
    // Channel names without asking the model about joints or outputs it does not have.
    let names = |chans: &[Channel]| {
        if chans.is_empty() {
            return "none".to_string();
        }
        chans
            .iter()
            .map(|c| match *c {
                Channel::Torque(j) if j >= model.joints() => format!("torque of joint {}", j + 1),
                Channel::Output(k) if k >= model.outputs() => format!("output {}", k + 1),
                c => c.name(model),
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let others = fit[1..]
        .iter()
        .map(|d| ("fit", d))
        .chain(holdout.iter().map(|d| ("held-out", d)));
    for (role, d) in others {
        let chans = d.channels();
        if chans != expected {
            return Err(DiagnoseError::ChannelMismatch {
                role,
                recording: d.name.clone(),
                channels: names(&chans),
                reference: first.name.clone(),
                expected: names(&expected),
            });
        }
        d.check(model)?;
    }
    // A recording the model cannot evaluate is refused after one nominal pass.
    let all: Vec<&MotionData> = fit.iter().chain(holdout).collect();
    super::residuals::check_defined(model, &all)
}

/// Each channel's measured noise floor: the median over the fit recordings (in the
/// channel's unit; at least 1e-12).
fn measured_floors(fit: &[MotionData]) -> Vec<f64> {
    let chans = fit.first().map(MotionData::channels).unwrap_or_default();
    chans
        .iter()
        .map(|&c| {
            let mut v: Vec<f64> = fit.iter().map(|d| noise_floor(d.measured(c))).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2].max(1e-12)
        })
        .collect()
}

/// One pass of the diagnosis at the model's nominal parameters (recordings checked by
/// [`check_recordings`]).
fn diagnose_once(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    walks: Option<&PassWalks>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    let chans = fit.first().map(MotionData::channels).unwrap_or_default();
    let nj = chans.len();
    progress("noise floor", 0.0);
    let theta0: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    // Noise floor per channel: median over the fit recordings of the measured channel's,
    // with a torque channel's share of the accelerations' noise added in quadrature.
    let from_motion = motion_noise(model, fit, &theta0);
    let measured = measured_floors(fit);
    let sigma: Vec<f64> = chans
        .iter()
        .zip(&measured)
        .map(|(&c, m)| match c {
            Channel::Torque(j) => m.hypot(from_motion.get(j).copied().unwrap_or(0.0)),
            Channel::Output(_) => *m,
        })
        .collect();
    progress("locate", 0.1);
    let location = locate(model, fit, &theta0, &sigma, &opts.locate);
    let cands = library(model, &opts.library);
    progress("candidate regressors", 0.2);
    let lens: Vec<usize> = fit.iter().map(MotionData::len).collect();
    let raw = prepare_with(
        model,
        fit,
        &vec![1.0; nj],
        &cands,
        opts,
        None,
        walks.map(|w| w.fit.as_slice()),
    )?;
    let compliance = super::candidates::compliance_of(model, &cands);
    let sel = select(&raw, &cands, &compliance, &lens, &sigma, opts, &mut *progress)?;
    progress("estimates", 0.85);
    let Estimates {
        x,
        mut estimates,
        correlations,
        shares,
    } = estimate(&sel, &cands);
    let confounded = confounded(&sel, &cands, opts, &x);
    let Selection {
        prep,
        set,
        steps,
        ranking,
        n,
        n_eff,
        weight_scale,
        unresolved,
        ..
    } = sel;
    let sites = model.play_sites();
    let unresolved_play: Vec<_> = unresolved
        .into_iter()
        .map(|(c, mut u)| {
            if let super::candidates::Effect::Play { site, .. } = cands[c].effect {
                u.joint = sites.get(site).cloned().unwrap_or_default();
            }
            u
        })
        .collect();
    progress("held-out check", 0.9);
    let (mut channels, traces, fit_after) = channel_fits(
        model,
        fit,
        holdout,
        &prep,
        &set,
        &x,
        &weight_scale,
        &sigma,
        opts,
        walks,
    )?;
    // In units of the measured channels' own noise floors: comparable between
    // differentiation windows (whose acceleration noise the total floor would excuse).
    let factor: Vec<f64> = (0..nj).map(|j| weight_scale[j] / measured[j]).collect();
    let cv_rms_noise_units = prep.cv_rms_rescaled(&set, &factor, &lens);
    // Is what remains noise? On the held-out recordings if any, else on the fit ones.
    progress("adequacy", 0.95);
    let held_out = !holdout.is_empty();
    let basis_data = if held_out { holdout } else { fit };
    let scales = StateScales::of(model, basis_data);
    let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    let basis_values = on_copies(basis_data, model, &|d, m| d.model_all(m, &theta));
    let basis: Vec<BasisResidual> = basis_data
        .iter()
        .zip(&basis_values)
        .enumerate()
        .map(|(r, (d, values))| BasisResidual {
            name: &d.name,
            t: &d.t,
            after: if held_out {
                traces[r * nj..(r + 1) * nj]
                    .iter()
                    .map(|tr| tr.after.clone())
                    .collect()
            } else {
                fit_after[r].clone()
            },
            windows: tagged_windows(model, d, &theta, values, &sigma, &scales, &opts.locate),
            measured: chans
                .iter()
                .map(|c| match c {
                    Channel::Torque(j) => d.tau[*j].as_slice(),
                    Channel::Output(k) => d.y[*k].as_slice(),
                })
                .collect(),
            rates: chans
                .iter()
                .map(|c| match c {
                    Channel::Torque(j) => d.qd.get(*j).map(Vec::as_slice),
                    Channel::Output(_) => None,
                })
                .collect(),
        })
        .collect();
    let mut adequacy = adequacy::assess(
        &mut channels,
        &basis,
        held_out,
        (opts.locate.window_s, opts.locate.threshold),
    );
    // Uncertainty including the misfit: the larger of the fit and basis noise ratios.
    let ratio: Vec<f64> = channels
        .iter()
        .map(|c| (c.fit_after / c.noise_floor.max(1e-300)).max(c.noise_ratio_after))
        .collect();
    adequacy::honest_uncertainty(&mut estimates, &shares, &ratio);
    adequacy.unstable = adequacy::unstable_names(&estimates);
    let selected: Vec<String> = set.iter().map(|&c| cands[c].name.clone()).collect();
    let found = adequacy::found_effects(&selected, &estimates, &unresolved_play);
    // Whether this pass ran the reduced dynamic play model (about a selected play).
    let dynamic_model =
        opts.library.dynamic_play_clearance.is_some() || opts.library.dynamic_axial_play.is_some();
    let verdict = verdict(
        model,
        &set,
        &prep.cands,
        &estimates,
        &channels,
        &confounded,
        &location,
        &adequacy,
        dynamic_model,
        &unresolved_play,
    );
    let friction = super::equivalents::joint_friction(model, &set, &prep.cands, &estimates);
    // (Not "done": a pass ends inside the whole diagnosis, which says "done" itself.)
    progress("pass finished", 1.0);
    Ok(Diagnosis {
        friction,
        model: model.name(),
        fit_recordings: fit.iter().map(|d| d.name.clone()).collect(),
        folds: None,
        holdout_recordings: holdout.iter().map(|d| d.name.clone()).collect(),
        samples: n,
        effective_samples: n_eff,
        location,
        ranking,
        steps,
        no_significant_mismatch: adequacy::no_significant_mismatch(&found, adequacy.unexplained),
        found,
        selected,
        play_dynamics: None,
        dynamic_play_reference: opts.library.dynamic_play_clearance,
        dynamic_axial_play_reference: opts.library.dynamic_axial_play,
        dynamic_play_damping: dynamic_model.then(|| {
            opts.library
                .play_contact_damping
                .unwrap_or(BALL_CONTACT.contact_damping())
        }),
        dynamic_play_damping_cv: vec![],
        dynamic_play_axial_stiffness: (dynamic_model && !opts.library.play_contact_hertz).then(|| {
            opts.library
                .play_axial_stiffness
                .unwrap_or(BALL_CONTACT.axial_stiffness)
        }),
        dynamic_play_axial_stiffness_cv: vec![],
        // (False where no reduced dynamic play model ran, whatever the options.)
        dynamic_play_hertz: opts.library.play_contact_hertz && dynamic_model,
        backlash_place: opts
            .library
            .backlash_reference
            .is_some()
            .then_some(opts.library.backlash_place),
        backlash_place_cv: vec![],
        backlash_place_identified: None,
        dynamic_play_damping_identified: None,
        dynamic_play_relinearized: opts.library.play_relinearize && dynamic_model,
        dynamic_play_interpolation: dynamic_model.then_some(opts.library.play_interpolation),
        dynamic_play_stepping: dynamic_model.then_some(opts.library.play_stepping),
        dynamic_play_reference_cv: vec![],
        dynamic_play_size_cv: vec![],
        play_probe: None,
        relinearization_steps: vec![],
        relinearization_cv: vec![],
        relinearization_passes: 0,
        estimates,
        correlations,
        confounded,
        unresolved_play,
        series_naming: None,
        channels,
        explained_fraction: adequacy.explained_fraction,
        unexplained: adequacy.unexplained,
        adequacy,
        verdict,
        cv_rms_noise_units,
        derivative_window: (0, vec![]),
        ends_dropped: 0,
        traces,
    })
}

/// Chooses the half-width of the rate differentiation by leave-one-recording-out
/// cross-validation of the whole diagnosis on the fit recordings (the held-out recordings
/// play no part), then diagnoses with it. Short windows pass acceleration noise into the
/// inertial regressors; long ones bias fast motion: the cross-validated torque prediction
/// error measures both.
///
/// Errors: `windows` empty or containing 0 ([`DiagnoseError::DerivativeWindows`]), and those
/// of [`diagnose`].
pub fn diagnose_recordings(
    model: &dyn InverseDynamicsModel,
    fit: &[Recording],
    holdout: &[Recording],
    windows: &[usize],
    opts: &DiagnoseOptions,
    mut progress: impl FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    diagnose_recordings_dyn(model, fit, holdout, windows, opts, &mut progress)
}

/// [`diagnose_recordings`] compiled once (the progress callback behind a reference).
fn diagnose_recordings_dyn(
    model: &dyn InverseDynamicsModel,
    fit: &[Recording],
    holdout: &[Recording],
    windows: &[usize],
    opts: &DiagnoseOptions,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Diagnosis, DiagnoseError> {
    if windows.is_empty() || windows.contains(&0) {
        let given: Vec<String> = windows.iter().map(usize::to_string).collect();
        return Err(DiagnoseError::DerivativeWindows {
            given: given.join(", "),
        });
    }
    let nj = model.joints();
    // Every window is scored on the same samples: the ends the widest window of the grid
    // differentiates one-sidedly carry no weight for any of them (nor in the held-out check).
    let ends = windows.iter().copied().max().unwrap_or(0);
    let differentiated = |r: &Recording| (1..=nj).any(|j| r.channel(&format!("qdd{j}")).is_none());
    // A recording fitted alone keeps what its cross-validation folds need.
    let keep = if fit.len() == 1 {
        FOLDS_FROM_ONE_RECORDING * MIN_SAMPLES
    } else {
        MIN_SAMPLES
    };
    let load = |recs: &[Recording], w: usize| -> Result<Vec<MotionData>, _> {
        recs.iter()
            .map(|r| {
                let d = if model.outputs() > 0 {
                    MotionData::from_recording_with_outputs(r, model, w)
                } else {
                    MotionData::from_recording(r, nj, w)
                }?;
                Ok::<_, RecordingError>(if differentiated(r) {
                    d.without_ends(ends, keep)
                } else {
                    d
                })
            })
            .collect()
    };
    let mut scores = vec![];
    if windows.len() > 1 {
        for (k, &w) in windows.iter().enumerate() {
            progress(
                "choosing the differentiation window",
                k as f64 / windows.len() as f64 * 0.5,
            );
            // (The play-dynamics check does not move the cross-validated error.)
            let o = DiagnoseOptions {
                play_dynamics: false,
                ..opts.clone()
            };
            let d = diagnose_dyn(model, &load(fit, w)?, &[], &o, &mut |_, _| {})?;
            scores.push((w, d.cv_rms_noise_units));
        }
    }
    let w = scores
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|s| s.0)
        .unwrap_or(windows[0]);
    let mut d = diagnose_dyn(model, &load(fit, w)?, &load(holdout, w)?, opts, &mut |s, f| {
        progress(s, 0.5 + 0.5 * f)
    })?;
    d.derivative_window = (w, scores);
    Ok(d)
}

/// Per channel before/after on the fit and held-out recordings, the held-out residual
/// traces (recording-major, channel-minor), and per fit recording and channel the residual
/// after the fit (in the channel's unit).
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
fn channel_fits(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    prep: &Prepared,
    set: &[usize],
    x: &[f64],
    sigma: &[f64],
    noise: &[f64],
    opts: &DiagnoseOptions,
    walks: Option<&PassWalks>,
) -> Result<(Vec<ChannelFit>, Vec<ResidualTrace>, Vec<Vec<Vec<f64>>>), DiagnoseError> {
    let chans = fit.first().map(MotionData::channels).unwrap_or_default();
    let nj = chans.len();
    let mut fit_b = vec![vec![]; nj];
    let mut fit_a = vec![vec![]; nj];
    let mut per_recording = vec![];
    for r in 0..fit.len() {
        let n = fit[r].len();
        let before = &prep.blocks[r].1;
        let after = prep.residual(r, set, x);
        let mut rec = vec![];
        for j in 0..nj {
            let a: Vec<f64> = after[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]).collect();
            // Samples the model cannot evaluate (zero weight: residual and columns exactly
            // 0) are left out of the RMS.
            for (i, &bv) in before[j * n..(j + 1) * n].iter().enumerate() {
                if !masked(bv, a[i]) {
                    fit_b[j].push(bv * sigma[j]);
                    fit_a[j].push(a[i]);
                }
            }
            rec.push(a);
        }
        per_recording.push(rec);
    }
    let mut ho_b = vec![vec![]; nj];
    let mut ho_a = vec![vec![]; nj];
    let mut traces = vec![];
    if !holdout.is_empty() {
        // Only the selected candidates' columns are read here, and the shifted ones' move
        // the residual: the other parameters' passes and plays' runs over the held-out
        // recordings are left out (the same residual, samples and selected columns, a
        // re-linearised play's to the position analyses' tolerance; `prepare_needed`).
        let needed: Vec<bool> = prep
            .cands
            .iter()
            .enumerate()
            .map(|(c, cand)| set.contains(&c) || opts.shift.iter().any(|(name, _)| *name == cand.name))
            .collect();
        let hp = prepare_needed(
            model,
            holdout,
            sigma,
            &prep.cands,
            opts,
            None,
            walks.map(|w| w.holdout.as_slice()),
            Some(&needed),
        )?;
        for r in 0..holdout.len() {
            let n = holdout[r].len();
            let before = &hp.blocks[r].1;
            let after = hp.residual(r, set, x);
            for j in 0..nj {
                let b: Vec<f64> = before[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]).collect();
                let a: Vec<f64> = after[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]).collect();
                for i in 0..n {
                    if !masked(b[i], a[i]) {
                        ho_b[j].push(b[i]);
                        ho_a[j].push(a[i]);
                    }
                }
                traces.push(ResidualTrace {
                    recording: holdout[r].name.clone(),
                    channel: chans[j].name(model),
                    unit: chans[j].unit(model),
                    t: holdout[r].t.clone(),
                    before: b,
                    after: a,
                });
            }
        }
    }
    let channels = (0..nj)
        .map(|j| {
            let (hb, ha) = (rms(&ho_b[j]), rms(&ho_a[j]));
            ChannelFit {
                channel: chans[j].name(model),
                unit: chans[j].unit(model),
                noise_floor: noise[j],
                fit_before: rms(&fit_b[j]),
                fit_after: rms(&fit_a[j]),
                holdout_before: hb,
                holdout_after: ha,
                holdout_reduction: if hb > 0.0 { 1.0 - ha / hb } else { 0.0 },
                // Set by the adequacy check.
                explained_fraction: 0.0,
                noise_ratio_after: 0.0,
                whiteness_p: 1.0,
                unexplained: false,
                worst_window: None,
            }
        })
        .collect();
    Ok((channels, traces, per_recording))
}

/// A sample the model could not evaluate: `prepare` gives it zero weight (residual and
/// every column exactly 0, so the fitted residual is exactly 0 too).
fn masked(before: f64, after: f64) -> bool {
    before == 0.0 && after == 0.0
}

#[cfg(test)]
mod tests {
    use super::{probe_fraction, probe_label, PROBE_SHARE};

    /// The play probe moves the diagnosis's progress from the first pass's end by its share,
    /// one step per refit, never back and never beyond its share (a probe that stops early
    /// leaves the second passes to start where it reached).
    #[test]
    fn the_play_probe_moves_the_progress_by_its_share_one_refit_at_a_time() {
        let most = 79;
        let fractions: Vec<f64> = (0..=most + 3).map(|k| probe_fraction(k, most)).collect();
        assert_eq!(fractions[0], 0.5);
        assert!((fractions[most] - (0.5 + PROBE_SHARE)).abs() < 1e-15);
        assert!(fractions.windows(2).take(most).all(|w| w[1] > w[0]));
        assert!(fractions[most..].iter().all(|f| *f == fractions[most]));
        assert_eq!(probe_fraction(0, 0), 0.5);
        assert_eq!(probe_label(3, most), "play probe, refit 3 of at most 79");
    }
}
