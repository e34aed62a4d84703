//! Selected effects read together: the friction laws of one joint summed into the friction
//! it has at speed, and a direction asymmetry of Coulomb friction that acts as an effort
//! offset combined with a selected sensor offset ("Coulomb friction plus an offset", which
//! direction-asymmetric friction and an offset together express in other terms).

use super::candidates::{Candidate, Effect};
use super::model::InverseDynamicsModel;
use super::outcome::Estimate;
use serde::Serialize;

/// The friction one joint has at speed, from every selected friction law of that joint.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct JointFriction {
    /// Joint name.
    pub joint: String,
    /// Unit of the values (N m or N).
    pub unit: String,
    /// Coulomb friction at speed (well above the smoothing velocities): the sum of the
    /// Coulomb levels and the mean of the two levels of direction-asymmetric friction.
    pub coulomb: f64,
    /// Half the difference of the direction-asymmetric levels (forward minus backward): at
    /// speed, a constant effort, indistinguishable from an offset.
    pub asymmetry: f64,
    /// The effort-sensor offset selected for this joint, if any.
    pub offset: Option<f64>,
    /// The offset the data show once the asymmetry is read as one: offset + asymmetry
    /// (`None` without a selected offset or asymmetry).
    pub offset_with_asymmetry: Option<f64>,
    /// The selected laws summed.
    pub laws: Vec<String>,
}

/// Values of a candidate's parameters, in its parameter order.
fn values(c: &Candidate, estimates: &[Estimate]) -> Vec<f64> {
    estimates
        .iter()
        .filter(|e| e.candidate == c.name)
        .map(|e| e.value)
        .collect()
}

/// The friction at speed of every joint with a selected Coulomb-type law (`set`: indices
/// into `cands`).
pub fn joint_friction(
    model: &dyn InverseDynamicsModel,
    set: &[usize],
    cands: &[Candidate],
    estimates: &[Estimate],
) -> Vec<JointFriction> {
    let mut out = vec![];
    for j in 0..model.joints() {
        let mut f = JointFriction {
            joint: model.joint_name(j),
            unit: model.joint_motion(j).effort().into(),
            coulomb: 0.0,
            asymmetry: 0.0,
            offset: None,
            offset_with_asymmetry: None,
            laws: vec![],
        };
        let mut asymmetric = false;
        for &c in set {
            let cand = &cands[c];
            if cand.joint != Some(j) {
                continue;
            }
            let v = values(cand, estimates);
            match (cand.effect, v.as_slice()) {
                (Effect::Coulomb { .. }, [c0]) => {
                    f.coulomb += c0;
                    f.laws.push(cand.name.clone());
                }
                (Effect::AsymmetricFriction { .. }, [cp, cm]) => {
                    f.coulomb += 0.5 * (cp + cm);
                    f.asymmetry += 0.5 * (cp - cm);
                    asymmetric = true;
                    f.laws.push(cand.name.clone());
                }
                (Effect::TorqueOffset, [o]) => f.offset = Some(*o),
                _ => {}
            }
        }
        if f.laws.is_empty() {
            continue;
        }
        if asymmetric {
            if let Some(o) = f.offset {
                f.offset_with_asymmetry = Some(o + f.asymmetry);
            }
        }
        out.push(f);
    }
    out
}

/// A sentence for the verdict where the selection needs reading together: several friction
/// laws in one joint, or direction-asymmetric friction beside an offset.
pub fn friction_sentence(f: &JointFriction) -> Option<String> {
    let u = &f.unit;
    let n = super::format::number;
    match (f.laws.len(), f.offset_with_asymmetry, f.offset) {
        (_, Some(ow), Some(o)) => Some(format!(
            "In {} the friction laws selected ({}) amount to Coulomb friction of {} {u} at speed and a direction asymmetry of {} {u}, which acts as an offset: read together with the {}-sensor offset ({} {u}), the data show Coulomb friction {} {u} and an offset of {} {u}. ",
            f.joint,
            f.laws.join(", "),
            n(f.coulomb),
            n(f.asymmetry),
            if u == "N" { "force" } else { "torque" },
            n(o),
            n(f.coulomb),
            n(ow)
        )),
        (k, _, _) if k > 1 => Some(format!(
            "In {} the friction laws selected ({}) amount to Coulomb friction of {} {u} at speed (the laws differ only in how sharply friction changes sign). ",
            f.joint,
            f.laws.join(", "),
            n(f.coulomb)
        )),
        _ => None,
    }
}
