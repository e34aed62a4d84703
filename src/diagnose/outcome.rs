//! What a diagnosis returns: the ranking, the greedy steps, the estimates with their
//! uncertainty, the confounded pairs, the per-channel fit before and after, and the verdict.

use super::adequacy::{Adequacy, ResidualWindow};
use super::locate::Location;
use super::play_dynamics::ContactDamping;
use serde::Serialize;

/// A candidate's test at the nominal model.
#[derive(Debug, Clone, Serialize)]
pub struct Ranked {
    /// Candidate.
    pub candidate: String,
    /// Likelihood-ratio statistic against the nominal model (effective samples).
    pub statistic: f64,
    /// Its p-value.
    pub p_value: f64,
    /// Cross-validated residual RMS with this candidate alone, relative to nominal.
    pub cv_ratio: f64,
    /// Its fitted parameters alone lie in their physically plausible ranges.
    pub plausible: bool,
}

/// One step of the greedy selection.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Candidate added.
    pub added: String,
    /// Likelihood-ratio statistic of the addition.
    pub statistic: f64,
    /// p-value.
    pub p_value: f64,
    /// Cross-validated weighted residual RMS after adding it (noise-floor units).
    pub cv_rms: f64,
    /// Effective BIC after adding it.
    pub bic: f64,
}

/// An estimated parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// Candidate.
    pub candidate: String,
    /// Parameter with unit.
    pub parameter: String,
    /// Value.
    pub value: f64,
    /// Standard deviation including the misfit: the larger of `std_noise_only` inflated by
    /// the residual-to-noise ratio of the channels the parameter acts on (`inflation`) and
    /// the leave-one-recording-out jackknife (`std_jackknife`); see the `adequacy` module.
    pub std: f64,
    /// The standard deviation that treats the residual as random noise (least squares with
    /// effective samples), without any allowance for systematic misfit.
    pub std_noise_only: f64,
    /// Leave-one-recording-out jackknife standard deviation, √((R−1)/R·Σ(x₋ᵣ − x̄)²) over the
    /// R fit recordings; `None` with a single fit recording.
    pub std_jackknife: Option<f64>,
    /// Factor applied to `std_noise_only`: the information-weighted residual-to-noise ratio
    /// (at least 1) of the channels the parameter acts on.
    pub inflation: f64,
    /// The estimate with each fit recording left out in turn (same order as the fit
    /// recordings; empty with a single fit recording).
    pub folds: Vec<f64>,
    /// False if the estimate moves between the leave-one-recording-out folds by more than
    /// its inflated uncertainty and by more than `adequacy::UNSTABLE_FRACTION` of its value:
    /// it soaks up model error rather than measuring physics.
    pub stable: bool,
}

/// A joint's play whose estimate fell below its balls' compression under the joint's own
/// load: the diagnosis resolved no play there, and what the play's column fitted (its reduced
/// dynamic model on linear contacts carries the balls' compliance) is the joint's contact
/// compliance.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct UnresolvedPlay {
    /// The play candidate the selection chose.
    pub play: String,
    /// Its joint's name.
    pub joint: String,
    /// Its estimate, m.
    pub estimate: f64,
    /// The RMS compression of the joint's most loaded ball under the joint's own load in
    /// the reduced dynamic play model, m.
    pub compression: f64,
    /// The joint's contact-compliance candidate named instead (the one that fits best),
    /// where it fits within the confounding tolerance; `None`: none does, the play candidate
    /// stays selected and the verdict says what it stands for.
    pub compliance: Option<String>,
    /// The best of the joint's compliance candidates, whether or not it replaced the play
    /// (`None`: every one is already selected or fits implausibly in the play's place, or
    /// the model declares none).
    pub alternative: Option<String>,
    /// How many compliance candidates the model declares for the joint.
    pub declared: usize,
    /// Cross-validated RMS with that compliance candidate in the play's place / with the
    /// play.
    pub cv_ratio: Option<f64>,
}

impl UnresolvedPlay {
    /// What the diagnosis claims the play stands for where no compliance candidate took its
    /// place: "contact compliance of joint F, fitted as radial clearance in joint F (reduced
    /// dynamic model)". None where one did (the selection names that candidate).
    pub fn claim(&self) -> Option<String> {
        self.compliance.is_none().then(|| {
            format!(
                "contact compliance of joint {}, fitted as {}",
                self.joint, self.play
            )
        })
    }
}

/// The name under which a selected candidate `name` is claimed as physics: an unresolved
/// play's [`claim`](UnresolvedPlay::claim), else its own.
pub fn claimed_name(name: &str, unresolved: &[UnresolvedPlay]) -> String {
    unresolved
        .iter()
        .find(|u| u.play == name)
        .and_then(UnresolvedPlay::claim)
        .unwrap_or_else(|| name.to_string())
}

/// Which of two joints in series a contact compliance is named at. The joints of a leg carry
/// the same force, so their contact compliances lengthen the leg alike and the
/// cross-validated choice between them follows the noise; after the fit, the compliance is
/// named at the joint whose play the selection found (one joint's bearings explain both),
/// with its estimate read in that joint's terms and the other joint's kept as a confound.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SeriesNaming {
    /// The compliance named, at the joint whose play is selected.
    pub named: String,
    /// The compliance the selection held, at the other joint.
    pub instead_of: String,
    /// Cross-validated RMS with `named` / with `instead_of` (within the confounding
    /// tolerance).
    pub cv_ratio: f64,
}

/// A pair of effects the data cannot tell apart.
#[derive(Debug, Clone, Serialize)]
pub struct Confound {
    /// The selected effect.
    pub selected: String,
    /// An alternative that fits (cross-validated) as well.
    pub alternative: String,
    /// Cross-validated RMS with the alternative / with the selection.
    pub cv_ratio: f64,
    /// The recording that would separate them.
    pub experiment: String,
    /// The selected estimate expressed as the alternative's parameter, where both have one
    /// (e.g. a force-sensor scale error as a mass error), e.g. "delta \[kg\] = -0.3016": the
    /// selected column's fit projected on the alternative's column; for a pair turned round
    /// by the series naming ([`SeriesNaming`]), the estimate the selection held.
    pub equivalent: Option<String>,
    /// The number in `equivalent`, in the alternative's parameter's unit.
    pub equivalent_value: Option<f64>,
}

/// Residual of one torque channel before and after the fit.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFit {
    /// Channel name.
    pub channel: String,
    /// Unit of the values below (N m for torques).
    pub unit: String,
    /// Noise floor of the measured channel (in `unit`).
    pub noise_floor: f64,
    /// RMS on the fit recordings, nominal model, N·m.
    pub fit_before: f64,
    /// RMS on the fit recordings, fitted model, N·m.
    pub fit_after: f64,
    /// RMS on the held-out recordings, nominal model, N·m.
    pub holdout_before: f64,
    /// RMS on the held-out recordings, fitted model, N·m.
    pub holdout_after: f64,
    /// 1 − after/before on the held-out recordings.
    pub holdout_reduction: f64,
    /// Fraction of the mismatch power above the noise that the selected physics removes,
    /// on the adequacy basis (held-out recordings if any, else the fit recordings); see the
    /// `adequacy` module for its definition.
    pub explained_fraction: f64,
    /// RMS after the fit / noise floor, on the adequacy basis.
    pub noise_ratio_after: f64,
    /// Ljung–Box p-value of the residual after the fit being white (adequacy basis).
    pub whiteness_p: f64,
    /// True if what remains after the fit is not noise: RMS above
    /// `adequacy::UNEXPLAINED_NOISE_RATIO` noise floors, or a residual far from white.
    pub unexplained: bool,
    /// The window where the remaining mismatch is largest (adequacy basis), with its state.
    pub worst_window: Option<ResidualWindow>,
}

/// Residual time series of one held-out recording and channel (the report's plots and
/// `holdout-<recording>-<channel>.csv`).
#[derive(Debug, Clone, Serialize)]
pub struct ResidualTrace {
    /// Recording.
    pub recording: String,
    /// Channel.
    pub channel: String,
    /// Unit of the residuals.
    pub unit: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Measured less the nominal model, in [`Self::unit`].
    pub before: Vec<f64>,
    /// Measured less the model with the selected physics, in [`Self::unit`].
    pub after: Vec<f64>,
}

/// One first-pass estimate's step into the second pass's linearisation point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinearizationStep {
    /// The candidate.
    pub candidate: String,
    /// The fraction of its estimate moved into the model (0: it stayed at the nominal
    /// point).
    pub fraction: f64,
    /// Per fraction tried, in order: (fraction, departure of the second pass's
    /// nominal-equivalent residual relative to the step's linear response, the same in
    /// noise units — RMS of the channel that departs most).
    pub departures: Vec<(f64, f64, f64)>,
}

/// A probe for a play the first pass did not see ([`Diagnosis::play_probe`]): of the first
/// pass's candidates alone, the one that cross-validated best was a joint's quasi-static play
/// (tracker rows only) with an estimate outside its bounds, and the pass selected no play —
/// the signature of a rattle that the quasi-static shift cannot carry; or (the second
/// signature, since 2026-12-06) the pass selected a drive backlash and no play, beside an
/// unstable estimate (one that soaks up model error): near a
/// singular position a joint's rattle shows in the drive torques, which a backlash carries
/// and the play's quasi-static columns do not. The joint's radial play (on the second
/// signature: the play of the joint and direction that cross-validated best alone among the
/// plays), with its dynamics (the reduced dynamic play model's response at each size, held,
/// the first pass's selection refitted), tried at sizes in a geometric grid
/// ([`PROBE_PLAY_SIZES`](super::PROBE_PLAY_SIZES)) and refined about the best
/// ([`search_play_size`](super::search_play_size)), at the library's contact damping; then
/// the size searched from the best there at each other damping of the grid. Under Hertz's law the held effect is the
/// response with the play less without, and the joint's contact compliance at zero play is
/// not among the refitted candidates (the second pass has it): the probe only chooses the
/// reference play; the second pass's selection decides whether a play is found.
#[derive(Debug, Clone, Serialize)]
pub struct PlayProbe {
    /// The quasi-static play candidate that cross-validated best alone, its estimate outside
    /// its bounds; or, where the first pass selected a drive backlash and no play
    /// ([`backlash`](Self::backlash)), the play that cross-validated best alone among the
    /// plays.
    pub signature: String,
    /// The drive backlash the first pass selected where it selected no play (the second
    /// signature): the
    /// probe then tries the play of [`signature`](Self::signature)'s joint and direction;
    /// `None` on the first signature.
    pub backlash: Option<String>,
    /// The dynamic play candidate probed.
    pub candidate: String,
    /// The first pass's selection refitted without the play, on the samples of the best
    /// size's refit: leave-one-recording-out RMS, noise units (the probe's weights); NaN
    /// where that refit failed.
    pub without: f64,
    /// The contact damping of the grid and its refinement (the options' own).
    pub damping: ContactDamping,
    /// Each size tried (m) at [`damping`](Self::damping) with the refit's
    /// leave-one-recording-out RMS (noise units; NaN where the refit failed), in order: the
    /// grid, then the refinement.
    pub sizes: Vec<(f64, f64)>,
    /// Then, at each other contact damping of the grid
    /// ([`DiagnoseOptions::play_contact_dampings`](super::DiagnoseOptions)): (damping, size
    /// in m, RMS in noise units) of the size's search from the best size at [`damping`](Self::damping), in order.
    pub damping_sizes: Vec<(ContactDamping, f64, f64)>,
    /// The size taken as the reference play of the second pass (m): the best refit's over
    /// [`sizes`](Self::sizes) and [`damping_sizes`](Self::damping_sizes), when it refits
    /// better than [`without`](Self::without) beyond the confounding tolerance
    /// ([`DiagnoseOptions::confound_tolerance`](super::DiagnoseOptions)); `None` otherwise.
    pub kept: Option<f64>,
    /// The contact damping of the best refit, with [`kept`](Self::kept). The second pass
    /// still chooses its damping from the whole grid, at the kept size.
    pub kept_damping: Option<ContactDamping>,
}

impl PlayProbe {
    /// Every refit with the play, (contact damping, size in m, leave-one-recording-out RMS
    /// in noise units), in order: [`sizes`](Self::sizes) at [`damping`](Self::damping),
    /// then [`damping_sizes`](Self::damping_sizes).
    pub fn refits(&self) -> impl Iterator<Item = (ContactDamping, f64, f64)> + '_ {
        self.sizes
            .iter()
            .map(|&(h, cv)| (self.damping, h, cv))
            .chain(self.damping_sizes.iter().copied())
    }

    /// The best of [`refits`](Self::refits): the smallest finite RMS, the first of equals;
    /// `None` when none is finite.
    pub fn best(&self) -> Option<(ContactDamping, f64, f64)> {
        self.refits()
            .filter(|x| x.2.is_finite())
            .min_by(|a, b| a.2.total_cmp(&b.2))
    }
}

/// The outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// Model.
    pub model: String,
    /// Fit recordings (the parts, when one recording was cut into folds).
    pub fit_recordings: Vec<String>,
    /// How cross-validation folds were made when only one recording was fitted (`None`:
    /// leave-one-recording-out over the fit recordings as given).
    pub folds: Option<String>,
    /// Held-out recordings.
    pub holdout_recordings: Vec<String>,
    /// Samples × channels in the fit.
    pub samples: usize,
    /// Effective independent samples.
    pub effective_samples: f64,
    /// Where the nominal residual is significant, tied to the mechanism's state.
    pub location: Location,
    /// Every candidate's test at the nominal model, strongest first.
    pub ranking: Vec<Ranked>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// Selected effects, in order.
    pub selected: Vec<String>,

    /// The selected effects whose estimates are all stable (see the `adequacy` module): the
    /// physics the diagnosis claims as found. The others only soak up model error. A play
    /// that resolved no play is claimed as its joint's contact compliance
    /// ([`UnresolvedPlay::claim`]; its estimates keep the play's name).
    pub found: Vec<String>,
    /// Estimates.
    pub estimates: Vec<Estimate>,
    /// Estimate pairs correlated beyond ±0.8: (a, b, correlation).
    pub correlations: Vec<(String, String, f64)>,
    /// Effects the data cannot separate.
    pub confounded: Vec<Confound>,
    /// Plays the selection chose whose estimates fell below their balls' compression: the
    /// joints' contact compliance, not play ([`UnresolvedPlay`]).
    pub unresolved_play: Vec<UnresolvedPlay>,
    /// A contact compliance named at the joint whose play is selected rather than at the
    /// joint in series with it that fitted as well ([`SeriesNaming`]); `None` where the
    /// selection needed no such choice.
    pub series_naming: Option<SeriesNaming>,
    /// Per joint with selected Coulomb-type friction: the laws summed into the friction at
    /// speed, and an asymmetry read together with an offset ([`super::equivalents`]).
    pub friction: Vec<super::equivalents::JointFriction>,
    /// Per channel, before/after.
    pub channels: Vec<ChannelFit>,
    /// True if the diagnosis finds no missing physics (no selected effect with stable
    /// estimates, `found` empty) and nothing unexplained remains (`unexplained` false): a
    /// mismatch the library cannot name is still a mismatch.
    pub no_significant_mismatch: bool,
    /// Fraction of the mismatch power above the noise (in noise-floor units, summed over the
    /// channels) that the selected physics removes; see the `adequacy` module.
    pub explained_fraction: f64,
    /// True if any channel's residual after the fit is not noise.
    pub unexplained: bool,
    /// Whether what remains after the fit is noise: per channel ratios, whiteness, windows.
    pub adequacy: Adequacy,
    /// How much of what remains the found radial play's dynamics explain (`None` when no
    /// radial play was selected, or the model has no play dynamics).
    pub play_dynamics: Option<PlayDynamicsCheck>,
    /// The radial clearance (m) at which the selection's play candidates took their drive
    /// torques from the reduced dynamic play model
    /// ([`DiagnoseOptions::dynamic_play_selection`](super::DiagnoseOptions)); `None` when they
    /// were quasi-static.
    pub dynamic_play_reference: Option<f64>,
    /// The axial play (m, total) at which the axial-play candidates took theirs; `None`
    /// when they were quasi-static.
    pub dynamic_axial_play_reference: Option<f64>,
    /// The balls' contact damping the reduced dynamic play model took in the selection
    /// (JSON `{"constant": N·s/m, "load": s/m}`), chosen by cross-validation among
    /// [`DiagnoseOptions::play_contact_dampings`](super::DiagnoseOptions) at the reference
    /// play, or, with the play-size search, by its refits at the searched size, among the
    /// grid's dampings and, with the damping search, the dampings it tried
    /// ([`dynamic_play_size_cv`](Self::dynamic_play_size_cv)); `None` when the play
    /// candidates were quasi-static.
    pub dynamic_play_damping: Option<ContactDamping>,
    /// Each damping tried and the selection's leave-one-recording-out RMS with it (noise
    /// units).
    pub dynamic_play_damping_cv: Vec<(ContactDamping, f64)>,
    /// Whether the fit recordings told the contact dampings tried apart (JSON
    /// `dynamic_play_damping_identified`): `Some(false)` when the next-best damping's
    /// leave-one-recording-out RMS lies within
    /// [`DiagnoseOptions::confound_tolerance`](super::DiagnoseOptions) of the best's (the
    /// play-size search's refits where they compared two dampings or more, else the grid's at
    /// the reference play), so the damping kept is not a finding and the verdict says so;
    /// `None` when fewer than two dampings were tried or no play was selected.
    pub dynamic_play_damping_identified: Option<bool>,
    /// The balls' stiffness on their bores' end faces (N/m, the linear law) the reduced
    /// dynamic play model took in the selection, chosen by cross-validation among
    /// [`DiagnoseOptions::play_axial_stiffnesses`](super::DiagnoseOptions); `None` when the
    /// play candidates were quasi-static or on Hertz's law.
    pub dynamic_play_axial_stiffness: Option<f64>,
    /// Each end-face stiffness tried (N/m) and the selection's leave-one-recording-out RMS
    /// with it (noise units), at the kept damping.
    pub dynamic_play_axial_stiffness_cv: Vec<(f64, f64)>,
    /// Whether the reduced dynamic play model's balls were on Hertz's law per direction
    /// ([`LibraryOptions::play_contact_hertz`](super::candidates::LibraryOptions)) rather
    /// than one linear stiffness (JSON `dynamic_play_hertz`); false where no reduced dynamic
    /// play model ran (no play selected), whatever the options.
    pub dynamic_play_hertz: bool,
    /// Where the play of a backlash taken as a dead zone in the selection sits in its
    /// transmission (JSON `"spring"` or `"output"`), chosen by cross-validation among
    /// [`DiagnoseOptions::backlash_places`](super::DiagnoseOptions); `None` when no backlash
    /// was taken as a dead zone.
    pub backlash_place: Option<super::transmission::PlayPlace>,
    /// Each place tried and the selection's leave-one-recording-out RMS with it (noise
    /// units).
    pub backlash_place_cv: Vec<(super::transmission::PlayPlace, f64)>,
    /// Whether the places tried told apart: `Some(false)` when their leave-one-recording-out
    /// errors lie within
    /// [`DiagnoseOptions::confound_tolerance`](super::DiagnoseOptions) of each other (fit
    /// recordings that barely cross the play), so the place kept is the first of
    /// [`DiagnoseOptions::backlash_places`](super::DiagnoseOptions), not a finding; `None`
    /// with one place or none.
    pub backlash_place_identified: Option<bool>,
    /// Whether the reduced dynamic play model was re-linearised about its own motion where
    /// its response is large
    /// ([`LibraryOptions::play_relinearize`](super::candidates::LibraryOptions)); JSON
    /// `dynamic_play_relinearized`; false where no reduced dynamic play model ran.
    pub dynamic_play_relinearized: bool,
    /// How the reduced dynamic play model's linearised mechanics varied within a sample
    /// interval ([`LibraryOptions::play_interpolation`](super::candidates::LibraryOptions));
    /// JSON `dynamic_play_interpolation` (`"held"` or `"linear"`; null where no reduced
    /// dynamic play model ran).
    pub dynamic_play_interpolation: Option<super::play_dynamics::Interpolation>,
    /// How the reduced dynamic play model stepped through each sample interval
    /// ([`LibraryOptions::play_stepping`](super::candidates::LibraryOptions)); JSON
    /// `dynamic_play_stepping` (`{"kind": "resolved"}` or `{"kind": "stiff", "per_sample":
    /// 40}`; null where no reduced dynamic play model ran).
    pub dynamic_play_stepping: Option<super::play_dynamics::Stepping>,
    /// The reference plays tried at the kept damping — (radial clearance, axial play) in m,
    /// `None` where that direction's candidates were quasi-static — and the selection's
    /// leave-one-recording-out RMS with them (noise units): the first pass's estimates, then,
    /// while the last selection sized a play more than [`RESIZE_FACTOR`](super::RESIZE_FACTOR)
    /// away from its reference and cross-validated better than the one before, its estimates
    /// (at most [`MAX_RESIZES`](super::MAX_RESIZES) times). The kept selection is the one
    /// with the smallest. Empty when the play candidates were quasi-static.
    pub dynamic_play_reference_cv: Vec<(Option<f64>, Option<f64>, f64)>,
    /// The contact dampings and radial play sizes (m) the play-size search
    /// ([`DiagnoseOptions::play_size_search`](super::DiagnoseOptions)) refitted the kept
    /// selection at, in the order tried, each with the refit's leave-one-recording-out RMS
    /// (noise units): the sizes at the kept damping, every other damping at the best of
    /// them, and the sizes again at a damping better there; then, with the damping search
    /// ([`DiagnoseOptions::play_damping_search`](super::DiagnoseOptions)), each constant
    /// part and each γ it tried with the sizes refined at it; empty when it did not run.
    /// Where the search ran again after further Gauss–Newton passes, that search's.
    pub dynamic_play_size_cv: Vec<(super::play_dynamics::ContactDamping, f64, f64)>,
    /// The probe for a play the first pass's quasi-static columns could not carry
    /// ([`DiagnoseOptions::play_probe`](super::DiagnoseOptions)); `None` when it did not
    /// run (or its play had no dynamic candidate, or no refit could be assembled).
    pub play_probe: Option<PlayProbe>,
    /// The first pass's estimates that moved the model for the second pass, each with the
    /// fraction of its step kept ([`SHIFT_LINEARITY_TOLERANCE`](super::SHIFT_LINEARITY_TOLERANCE));
    /// empty without a second pass.
    pub relinearization_steps: Vec<LinearizationStep>,
    /// Cross-validated RMS (noise units) of each re-linearised pass tried, in order: the
    /// step from the nominal point, then the whole steps to the last pass's estimates taken
    /// while a step was held back ([`MAX_RELINEARIZATIONS`](super::MAX_RELINEARIZATIONS)).
    /// Empty when nothing was re-linearised.
    pub relinearization_cv: Vec<f64>,
    /// Re-linearised passes whose selection is reported (Gauss–Newton steps kept): 0 when
    /// nothing was re-linearised, 1 for the step from the nominal point, more when further
    /// whole steps cross-validated better.
    pub relinearization_passes: usize,
    /// One-paragraph verdict.
    pub verdict: String,
    /// Leave-one-recording-out residual RMS of the final model on the fit recordings, in
    /// units of the measured channels' noise floors (without the accelerations' share, so
    /// comparable between pre-processing choices).
    pub cv_rms_noise_units: f64,
    /// Half-width (samples) of the rate differentiation, and the cross-validated RMS of each
    /// half-width tried (empty if it was given).
    pub derivative_window: (usize, Vec<(usize, f64)>),
    /// The most samples left out at either end of any recording (fit, cross-validation and
    /// held-out check alike; [`MotionData::without_ends`](super::data::MotionData::without_ends)):
    /// `lash diagnose` leaves out the widest differentiation window tried, whose fit is
    /// one-sided there, from every window's evaluation, so the cross-validation compares
    /// windows on the same samples (fewer from a recording too short to spare them). 0 when
    /// the accelerations were recorded.
    pub ends_dropped: usize,
    /// Held-out residual traces.
    #[serde(skip)]
    pub traces: Vec<ResidualTrace>,
}

/// The selection of a diagnosis refitted with its first radial play's drive torques from a
/// reduced dynamic model of the joint in its clearance ([`super::play_dynamics`]) taken at the
/// play's estimate: how much of what the quasi-static play leaves is the play's dynamics. It
/// does not change the diagnosis.
#[derive(Debug, Clone, Serialize)]
pub struct PlayDynamicsCheck {
    /// The play (candidate name).
    pub candidate: String,
    /// The clearance the reduced model was taken at: the diagnosis' estimate, m.
    pub clearance: f64,
    /// The play's clearance refitted with the dynamic drive-torque rows, m (`None` if the
    /// refit dropped it).
    pub refit_clearance: Option<f64>,
    /// What the refit kept of the selection.
    pub selected: Vec<String>,
    /// Per channel, the residual over the noise floor (adequacy basis) without and with the
    /// play's dynamics.
    pub channels: Vec<PlayDynamicsChannel>,
}

/// One channel of a [`PlayDynamicsCheck`].
#[derive(Debug, Clone, Serialize)]
pub struct PlayDynamicsChannel {
    /// Channel.
    pub channel: String,
    /// Residual RMS over the noise floor after the diagnosis' fit.
    pub noise_ratio_without: f64,
    /// The same with the play's dynamics in the drive torques.
    pub noise_ratio_with: f64,
}

impl Diagnosis {
    /// The estimate of the first selected candidate whose name starts with `prefix` (a
    /// candidate's name carries its joint and, where it has several, its scale: "Coulomb
    /// friction in joint 2" matches each velocity scale's).
    pub fn estimate_named(&self, prefix: &str) -> Option<&Estimate> {
        self.estimates.iter().find(|e| e.candidate.starts_with(prefix))
    }

    /// What to say when no candidate joined the model (None when one did): no significant
    /// mismatch, or — when a mismatch stays unexplained — that no library candidate explains it.
    pub fn nothing_selected(&self) -> Option<&'static str> {
        match (self.steps.is_empty(), self.unexplained) {
            (false, _) => None,
            (true, true) => Some("no library candidate explains the mismatch that remains (see the verdict)"),
            (true, false) => Some("no significant mismatch"),
        }
    }
}
