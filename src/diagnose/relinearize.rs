//! Re-linearisation: one Gauss–Newton step for effects that are not linear in their
//! parameters. The first pass's estimates of model parameters and joint-position sensor
//! offsets move into the model ([`Shifted`]); every column is recomputed around them and the
//! selection runs again, with residuals taken as if from the nominal model so estimates stay
//! totals. The second pass is then reported against the nominal model.

use super::candidates::{Candidate, Effect};
use super::model::{InverseDynamicsModel, ModelParameter, OutputSensitivities};
use super::outcome::Diagnosis;
use super::verdict::verdict_text;

/// The model moved by the first pass's estimates, and the moved (candidate, value) pairs
/// (the linearisation point, `DiagnoseOptions::shift`; empty if no estimate moves the
/// model, which is then the nominal one).
pub(super) fn shift<'a>(
    model: &'a dyn InverseDynamicsModel,
    first: &Diagnosis,
    cands: &[Candidate],
) -> (Shifted<'a>, Vec<(String, f64)>) {
    let mut delta = vec![0.0; model.parameters().len()];
    let mut q_offset = vec![0.0; model.joints()];
    let mut moved: Vec<(String, f64)> = vec![];
    for e in &first.estimates {
        let Some(c) = cands.iter().find(|c| c.name == e.candidate) else {
            continue;
        };
        match (c.effect, c.joint) {
            (Effect::Parameter { index, .. }, _) => delta[index] += e.value,
            (Effect::Declared { group }, _) => {
                let (Some(g), Some(k)) = (
                    model.declared_candidates().get(group).cloned(),
                    c.parameters.iter().position(|p| *p == e.parameter),
                ) else {
                    continue;
                };
                delta[g.parameters[k]] += e.value;
            }
            (Effect::PositionOffset, Some(j)) => q_offset[j] += e.value,
            _ => continue,
        }
        moved.push((c.name.clone(), e.value));
    }
    let shifted = Shifted {
        inner: model,
        delta,
        q_offset,
    };
    (shifted, moved)
}

/// The radial play a finished diagnosis selected first (candidate name) and its estimate
/// (m), for [`LibraryOptions::dynamic_play_clearance`](super::candidates::LibraryOptions);
/// `None` if it selected none with a positive estimate, or the model has no play sites or
/// no compliant transmission (the reduced dynamic play model winds them up).
pub(super) fn dynamic_play_clearance(
    model: &dyn InverseDynamicsModel,
    d: &Diagnosis,
    cands: &[Candidate],
) -> Option<(String, f64)> {
    first_play(model, d, cands, super::candidates::PlayDirection::Radial)
}

/// The reference plays, radial and axial (m), at which the second pass's play candidates
/// take their drive torques from the reduced dynamic play model
/// ([`LibraryOptions::dynamic_play_clearance`](super::candidates::LibraryOptions) and
/// `dynamic_axial_play`): per direction the estimate of the first play of that direction
/// the first pass selected, else the other direction's (so both directions' candidates
/// carry their dynamics into the selection once a play has been found); `(None, None)` when
/// it selected none, or the model cannot run the reduced model.
pub(super) fn dynamic_play_references(
    model: &dyn InverseDynamicsModel,
    d: &Diagnosis,
    cands: &[Candidate],
) -> (Option<f64>, Option<f64>) {
    use super::candidates::PlayDirection;
    let radial = first_play(model, d, cands, PlayDirection::Radial).map(|(_, h)| h);
    let axial = first_play(model, d, cands, PlayDirection::Axial).map(|(_, h)| h);
    (radial.or(axial), axial.or(radial))
}

/// How far (as a factor either way) a selected play's estimate may be from the reference
/// play its candidate's columns were taken at before the selection is repeated at the
/// estimate ([`Diagnosis::dynamic_play_reference_cv`]).
pub const RESIZE_FACTOR: f64 = 1.25;

/// The most passes at resized reference plays (each a whole selection): the secant
/// iteration on the plays stops earlier once every selected play is within
/// [`RESIZE_FACTOR`] of its reference or a pass cross-validates worse than the one before.
pub const MAX_RESIZES: usize = 3;

/// New reference plays (radial, axial; m) when `d`, a selection made with the play
/// candidates' columns at `references`, sized a play of some direction more than
/// [`RESIZE_FACTOR`] away from that direction's reference: per direction the estimate of the
/// first play of that direction it selected, else the reference it had. `None` when every
/// selected play is within the factor (or none was selected).
pub(super) fn resized_references(
    model: &dyn InverseDynamicsModel,
    d: &Diagnosis,
    cands: &[Candidate],
    references: (Option<f64>, Option<f64>),
) -> Option<(Option<f64>, Option<f64>)> {
    use super::candidates::PlayDirection;
    let own = |direction| first_play(model, d, cands, direction).map(|(_, h)| h);
    let (radial, axial) = (own(PlayDirection::Radial), own(PlayDirection::Axial));
    let far = |reference: Option<f64>, estimate: Option<f64>| match (reference, estimate) {
        (Some(r), Some(e)) => e > r * RESIZE_FACTOR || e < r / RESIZE_FACTOR,
        _ => false,
    };
    (far(references.0, radial) || far(references.1, axial))
        .then(|| (radial.or(references.0), axial.or(references.1)))
}

/// The first play of `direction` the diagnosis selected, with its positive estimate (m).
fn first_play(
    model: &dyn InverseDynamicsModel,
    d: &Diagnosis,
    cands: &[Candidate],
    direction: super::candidates::PlayDirection,
) -> Option<(String, f64)> {
    let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    let compliant = (0..model.joints()).any(|j| model.drive_compliance(&theta, j) != 0.0);
    if model.play_sites().is_empty() || !compliant {
        return None;
    }
    d.selected.iter().find_map(|name| {
        let c = cands.iter().find(|c| &c.name == name)?;
        if !matches!(c.effect, Effect::Play { direction: dir, .. } if dir == direction) {
            return None;
        }
        d.estimates
            .iter()
            .find(|e| &e.candidate == name)
            .map(|e| e.value)
            .filter(|h| *h > 0.0 && h.is_finite())
            .map(|h| (name.clone(), h))
    })
}

/// The second pass (`second`, at the shifted point) reported against the nominal model:
/// "before" is the nominal model's, and so are the localisation and the score tests of the
/// first pass; the verdict is written anew.
pub(super) fn against_nominal(
    model: &dyn InverseDynamicsModel,
    first: Diagnosis,
    mut second: Diagnosis,
    cands: &[Candidate],
) -> Diagnosis {
    for (c2, c1) in second.channels.iter_mut().zip(&first.channels) {
        c2.fit_before = c1.fit_before;
        c2.holdout_before = c1.holdout_before;
        c2.holdout_reduction = if c1.holdout_before > 0.0 {
            1.0 - c2.holdout_after / c1.holdout_before
        } else {
            0.0
        };
    }
    for (t2, t1) in second.traces.iter_mut().zip(&first.traces) {
        t2.before = t1.before.clone();
    }
    second.location = first.location;
    second.ranking = first.ranking;
    second.model = first.model;
    // (`found` and `no_significant_mismatch` follow in `adequacy::refresh`.)
    second.verdict = verdict_text(model, &second, cands);
    second
}

/// The nominal model with its parameters moved by `delta` and its joint positions read with
/// `q_offset` removed.
pub(super) struct Shifted<'a> {
    inner: &'a dyn InverseDynamicsModel,
    delta: Vec<f64>,
    q_offset: Vec<f64>,
}

impl Shifted<'_> {
    fn q(&self, q: &[f64]) -> Vec<f64> {
        q.iter().zip(&self.q_offset).map(|(a, b)| a - b).collect()
    }
}

impl InverseDynamicsModel for Shifted<'_> {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn joints(&self) -> usize {
        self.inner.joints()
    }
    fn joint_name(&self, j: usize) -> String {
        self.inner.joint_name(j)
    }
    fn joint_motion(&self, j: usize) -> super::model::JointMotion {
        self.inner.joint_motion(j)
    }
    fn declared_candidates(&self) -> Vec<super::model::DeclaredCandidate> {
        self.inner.declared_candidates()
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        let mut p = self.inner.parameters();
        for (x, d) in p.iter_mut().zip(&self.delta) {
            x.nominal += d;
        }
        p
    }
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        self.inner.torques(theta, &self.q(q), qd, qdd, tau)
    }
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        self.inner.rotor_regressor(j, qdd, out)
    }
    fn outputs(&self) -> usize {
        self.inner.outputs()
    }
    fn output_name(&self, k: usize) -> String {
        self.inner.output_name(k)
    }
    fn output_unit(&self, k: usize) -> String {
        self.inner.output_unit(k)
    }
    fn output_role(&self, k: usize) -> String {
        self.inner.output_role(k)
    }
    fn evaluate(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64], y: &mut [f64]) {
        self.inner.evaluate(theta, &self.q(q), qd, qdd, tau, y)
    }
    #[allow(clippy::too_many_arguments)]
    fn evaluate_at(
        &self,
        t: f64,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        tau: &mut [f64],
        y: &mut [f64],
    ) {
        self.inner.evaluate_at(t, theta, &self.q(q), qd, qdd, tau, y)
    }
    fn parameter_step(&self, k: usize) -> f64 {
        self.inner.parameter_step(k)
    }
    fn one_sided_differences(&self) -> bool {
        self.inner.one_sided_differences()
    }
    fn play_sites(&self) -> Vec<String> {
        self.inner.play_sites()
    }
    fn derivative_windows(&self) -> Vec<usize> {
        self.inner.derivative_windows()
    }
    fn output_sensitivities(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        y: &[f64],
    ) -> Option<OutputSensitivities> {
        self.inner.output_sensitivities(theta, &self.q(q), qd, qdd, y)
    }
    fn play_dynamics(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
    ) -> Option<Vec<super::model::PlayDynamics>> {
        self.inner.play_dynamics(theta, &self.q(q), qd, qdd)
    }
    #[allow(clippy::too_many_arguments)]
    fn play_dynamics_at(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        site: usize,
        windup: &[f64],
        offset: [f64; 4],
    ) -> Option<super::model::PlayPoint> {
        self.inner
            .play_dynamics_at(theta, &self.q(q), qd, qdd, site, windup, offset)
    }
    fn clearance_sites(&self) -> Vec<String> {
        self.inner.clearance_sites()
    }
    fn clearance_load_scale(&self) -> f64 {
        self.inner.clearance_load_scale()
    }
    fn backlash_torque_scale(&self) -> f64 {
        self.inner.backlash_torque_scale()
    }
    fn drive_compliance(&self, theta: &[f64], j: usize) -> f64 {
        self.inner.drive_compliance(theta, j)
    }
    fn transmission_dynamics(&self, theta: &[f64]) -> Option<super::transmission::TransmissionDynamics> {
        self.inner.transmission_dynamics(theta)
    }
    fn column_defaults(&self) -> super::model::ColumnDefaults {
        self.inner.column_defaults()
    }
    fn configuration_tag(&self, theta: &[f64], q: &[f64], y: &[f64]) -> Option<String> {
        self.inner.configuration_tag(theta, &self.q(q), y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::model::ColumnDefaults;
    use crate::diagnose::transmission::TransmissionDynamics;
    use nalgebra::DMatrix;

    /// A one-joint model that carries transmission dynamics and its own column mapping.
    struct Driven;

    impl InverseDynamicsModel for Driven {
        fn name(&self) -> String {
            "driven".into()
        }
        fn joints(&self) -> usize {
            1
        }
        fn joint_name(&self, _j: usize) -> String {
            "joint 1".into()
        }
        fn parameters(&self) -> Vec<ModelParameter> {
            vec![]
        }
        fn torques(&self, _theta: &[f64], _q: &[f64], _qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
            tau[0] = 0.1 * qdd[0];
        }
        fn column_defaults(&self) -> ColumnDefaults {
            ColumnDefaults::Fixed("q1=a".into())
        }
        fn transmission_dynamics(&self, _theta: &[f64]) -> Option<TransmissionDynamics> {
            Some(TransmissionDynamics {
                mass: DMatrix::from_element(1, 1, 0.1),
                compliance: vec![1e-4],
                damping: vec![2.0],
                windup_rate: vec![0.0],
                load_stiffness: None,
            })
        }
    }

    /// The second pass sees the model it shifts: its transmissions' dynamics (without them
    /// the friction and play columns of the second pass fell back to the quasi-static wind-up)
    /// and its column mapping.
    #[test]
    fn the_shifted_model_keeps_the_transmission_dynamics_and_column_mapping() {
        let inner = Driven;
        let shifted = Shifted {
            inner: &inner,
            delta: vec![],
            q_offset: vec![0.0],
        };
        assert_eq!(
            shifted.transmission_dynamics(&[]),
            inner.transmission_dynamics(&[])
        );
        assert!(shifted.transmission_dynamics(&[]).is_some());
        assert_eq!(shifted.column_defaults(), inner.column_defaults());
    }
}
