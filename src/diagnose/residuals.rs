//! Residual assembly shared by both residual modes: every recording's weighted residual
//! (measured − nominal, torques for equation error, outputs for output error) and the
//! regressor columns of the whole candidate library, accumulated once into Gram matrices so
//! that any subset fit, cross-validation fold or test is a small dense solve.
//!
//! Samples the model cannot evaluate carry no weight; a linearisation point moved by the
//! re-linearisation (`DiagnoseOptions::shift`) is undone in the residual, so estimates stay
//! totals relative to the nominal model.

use super::candidates::{columns_needed, Candidate, NominalWalkCache, TightRuns};
use super::data::MotionData;
use super::error::DiagnoseError;
use super::model::{on_copies, InverseDynamicsModel};
use super::options::DiagnoseOptions;
use super::stats::Gram;

/// Largest share of a recording's samples at which the residual (measured − nominal model)
/// may be undefined (not finite); beyond it the recording is refused
/// ([`DiagnoseError::ResidualUndefined`]).
pub const MAX_UNDEFINED_FRACTION: f64 = 0.5;

/// The weighted residuals and candidate columns of a set of recordings.
pub(super) struct Prepared {
    /// The candidate library.
    pub cands: Vec<Candidate>,
    /// Global column indices of each candidate.
    pub cols_of: Vec<Vec<usize>>,
    /// Per recording: columns (all candidates, flattened) and weighted residual.
    pub blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)>,
    /// Per recording: the Gram matrices of the columns and residual.
    pub grams: Vec<Gram>,
    /// Their sum.
    total: Gram,
    /// Per candidate, the contact compression its column carries, m
    /// ([`Columns::compression`](super::candidates::Columns::compression)), over all
    /// recordings.
    pub compression: Vec<Option<f64>>,
    /// Per recording assembled by [`prepare`], the samples left out (undefined in the
    /// residual or a column, zeroed in both); empty otherwise.
    pub left_out: Vec<Vec<bool>>,
}

/// A recording whose residual `b` (measured − nominal, channel by channel) is undefined at
/// more than [`MAX_UNDEFINED_FRACTION`] of its samples does not fit the model (a pose the
/// mechanism cannot reach, values out of range): refused
/// ([`DiagnoseError::ResidualUndefined`]), not diagnosed from the few samples left (which
/// read as "no mismatch").
fn refuse_undefined(d: &MotionData, b: &[f64]) -> Result<(), DiagnoseError> {
    let n = d.len();
    let nc = b.len() / n.max(1);
    let undefined: Vec<usize> = (0..n)
        .filter(|&i| (0..nc).any(|j| !b[j * n + i].is_finite()))
        .collect();
    if undefined.len() as f64 > MAX_UNDEFINED_FRACTION * n as f64 {
        return Err(DiagnoseError::ResidualUndefined {
            recording: d.name.clone(),
            undefined: undefined.len(),
            samples: n,
            t: d.t[undefined[0]],
        });
    }
    Ok(())
}

/// Refuses, before any candidate's column is made, a recording whose residual at the
/// nominal parameters is mostly undefined (as [`prepare`] would, after one pass of the
/// nominal model instead of the columns' many).
pub(super) fn check_defined(
    model: &dyn InverseDynamicsModel,
    data: &[&MotionData],
) -> Result<(), DiagnoseError> {
    let theta0: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    let nominal = on_copies(data, model, &|d, m| d.model_channels(m, &theta0));
    for (&d, nominal) in data.iter().zip(nominal) {
        let n = d.len();
        let b: Vec<f64> = d
            .channels()
            .iter()
            .zip(&nominal)
            .flat_map(|(&c, nom)| (0..n).map(move |i| d.measured(c)[i] - nom[i]))
            .collect();
        refuse_undefined(d, &b)?;
    }
    Ok(())
}

/// Weighted residuals (channel j divided by `sigma[j]`) and columns of `cands` on `data`
/// (at least one recording, all with the channels of the first).
pub(super) fn prepare(
    model: &dyn InverseDynamicsModel,
    data: &[MotionData],
    sigma: &[f64],
    cands: &[Candidate],
    opts: &DiagnoseOptions,
) -> Result<Prepared, DiagnoseError> {
    prepare_with(model, data, sigma, cands, opts, None, None)
}

/// [`prepare`], the reduced play model's runs without play taken from `tight` (one
/// [`TightRuns`] per recording, in the order of `data`) and the nominal model's walks along
/// the recordings from `walks` (one per recording) where given
/// ([`columns_with`](super::candidates::columns_with)).
pub(super) fn prepare_with(
    model: &dyn InverseDynamicsModel,
    data: &[MotionData],
    sigma: &[f64],
    cands: &[Candidate],
    opts: &DiagnoseOptions,
    tight: Option<&[TightRuns]>,
    walks: Option<&[NominalWalkCache]>,
) -> Result<Prepared, DiagnoseError> {
    prepare_needed(model, data, sigma, cands, opts, tight, walks, None)
}

/// [`prepare_with`], the parameter candidates not `needed` (one flag per candidate, where
/// given) with zero columns and no model passes
/// ([`columns_needed`](super::candidates::columns_needed)): the residual and the samples left
/// out are those of [`prepare_with`], and so is [`Prepared::residual`] over needed
/// candidates.
#[allow(clippy::too_many_arguments)]
pub(super) fn prepare_needed(
    model: &dyn InverseDynamicsModel,
    data: &[MotionData],
    sigma: &[f64],
    cands: &[Candidate],
    opts: &DiagnoseOptions,
    tight: Option<&[TightRuns]>,
    walks: Option<&[NominalWalkCache]>,
    needed: Option<&[bool]>,
) -> Result<Prepared, DiagnoseError> {
    let mut cols_of = vec![];
    let mut blocks = vec![];
    let mut left_out = vec![];
    // Every recording's columns (side by side on copies of the model where it makes them).
    let recordings: Vec<usize> = (0..data.len()).collect();
    let all = on_copies(&recordings, model, &|&r, m| {
        let cache = tight.and_then(|t| t.get(r)).map(Vec::as_slice);
        columns_needed(
            cands,
            &data[r],
            m,
            &opts.library,
            cache,
            walks.and_then(|w| w.get(r)),
            needed,
        )
    });
    // The play candidates' compressions over all recordings (RMS, weighted by samples).
    let mut compression_ss: Vec<Option<(f64, usize)>> = vec![None; cands.len()];
    for (d, cs) in data.iter().zip(&all) {
        for (acc, v) in compression_ss.iter_mut().zip(&cs.compression) {
            if let Some(v) = v {
                let (ss, k) = acc.unwrap_or((0.0, 0));
                *acc = Some((ss + v * v * d.len() as f64, k + d.len()));
            }
        }
    }
    let compression: Vec<Option<f64>> = compression_ss
        .iter()
        .map(|a| a.filter(|&(_, k)| k > 0).map(|(ss, k)| (ss / k as f64).sqrt()))
        .collect();
    for (d, c) in data.iter().zip(all) {
        let (mut per, nominal) = (c.cols, c.nominal);
        let n = d.len();
        let chans = d.channels();
        let nc = chans.len();
        let mut b = vec![0.0; nc * n];
        for (j, &c) in chans.iter().enumerate() {
            let meas = d.measured(c);
            for i in 0..n {
                b[j * n + i] = (meas[i] - nominal[j][i]) / sigma[j];
            }
        }
        refuse_undefined(d, &b)?;
        // Samples the model cannot evaluate (e.g. beyond a singular configuration), or where
        // a candidate's column is undefined (e.g. a time derivative next to such a sample),
        // carry no weight.
        let mut out = vec![false; n];
        for (i, out) in out.iter_mut().enumerate() {
            let undefined = (0..nc).any(|j| {
                !b[j * n + i].is_finite()
                    || per
                        .iter()
                        .any(|cc| cc.iter().any(|col| !col[j * n + i].is_finite()))
            });
            *out = undefined;
            if undefined {
                for j in 0..nc {
                    b[j * n + i] = 0.0;
                    for cc in per.iter_mut() {
                        for col in cc.iter_mut() {
                            col[j * n + i] = 0.0;
                        }
                    }
                }
            }
        }
        // Residual as if from the nominal model, linearised at the shifted point: the k-th
        // shift entry of a candidate goes with its k-th column (a declared candidate moves
        // one entry per parameter).
        for (c, cand) in cands.iter().enumerate() {
            let values = opts.shift.iter().filter(|(name, _)| *name == cand.name);
            for (value, col) in values.map(|(_, v)| v).zip(&per[c]) {
                for (i, (bi, ci)) in b.iter_mut().zip(col).enumerate() {
                    *bi += value * ci / sigma[i / n];
                }
            }
        }
        let mut flat = vec![];
        let mut idx = vec![];
        for cc in per {
            let mut ids = vec![];
            for mut col in cc {
                for j in 0..nc {
                    for v in &mut col[j * n..(j + 1) * n] {
                        *v /= sigma[j];
                    }
                }
                ids.push(flat.len());
                flat.push(col);
            }
            idx.push(ids);
        }
        cols_of = idx;
        blocks.push((flat, b));
        left_out.push(out);
    }
    let mut prep = Prepared::new(cands.to_vec(), cols_of, blocks)?;
    prep.compression = compression;
    prep.left_out = left_out;
    Ok(prep)
}

impl Prepared {
    /// Accumulates the Gram matrices of `blocks` (one per recording; none is an error).
    pub(super) fn new(
        cands: Vec<Candidate>,
        cols_of: Vec<Vec<usize>>,
        blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)>,
    ) -> Result<Prepared, DiagnoseError> {
        let grams: Vec<Gram> = blocks.iter().map(|(c, b)| Gram::new(c, b)).collect();
        let total = Gram::sum(&grams).ok_or(DiagnoseError::NoFitRecordings)?;
        let compression = vec![None; cands.len()];
        Ok(Prepared {
            cands,
            cols_of,
            blocks,
            grams,
            total,
            compression,
            left_out: vec![],
        })
    }
    /// The same columns and residual with channel j divided by `w[j]` (recording r has
    /// `lens[r]` samples per channel).
    pub(super) fn reweighed(&self, w: &[f64], lens: &[usize]) -> Result<Prepared, DiagnoseError> {
        let blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)> = self
            .blocks
            .iter()
            .zip(lens)
            .map(|((cols, b), &n)| {
                let scale =
                    |v: &[f64]| -> Vec<f64> { v.iter().enumerate().map(|(i, x)| x / w[i / n]).collect() };
                (cols.iter().map(|c| scale(c)).collect(), scale(b))
            })
            .collect();
        let mut prep = Prepared::new(self.cands.clone(), self.cols_of.clone(), blocks)?;
        prep.compression = self.compression.clone();
        Ok(prep)
    }
    /// Global column indices of the candidates in `set`.
    pub(super) fn idx(&self, set: &[usize]) -> Vec<usize> {
        set.iter().flat_map(|&c| self.cols_of[c].clone()).collect()
    }
    /// The Gram matrices of all recordings summed.
    pub(super) fn total(&self) -> &Gram {
        &self.total
    }
    /// Residual sum of squares of a fit of `set` on all recordings.
    pub(super) fn rss(&self, set: &[usize]) -> f64 {
        let g = self.total();
        let idx = self.idx(set);
        let x = g.solve(&idx);
        g.rss(&idx, &x)
    }
    /// Leave-one-recording-out cross-validated RSS (plain RSS with one recording).
    pub(super) fn cv_rss(&self, set: &[usize]) -> f64 {
        let idx = self.idx(set);
        let total = self.total();
        if self.grams.len() < 2 {
            return total.rss(&idx, &total.solve(&idx));
        }
        self.grams
            .iter()
            .map(|fold| {
                let train = total.minus(fold);
                fold.rss(&idx, &train.solve(&idx))
            })
            .sum()
    }
    /// Leave-one-recording-out residual RMS of `set` with channel j rescaled by `factor[j]`
    /// (e.g. to noise-floor units, comparable between pre-processing choices).
    pub(super) fn cv_rms_rescaled(&self, set: &[usize], factor: &[f64], lens: &[usize]) -> f64 {
        let idx = self.idx(set);
        let total = self.total();
        let (mut ss, mut n) = (0.0, 0usize);
        for (r, fold) in self.grams.iter().enumerate() {
            let train = if self.grams.len() > 1 {
                total.minus(fold)
            } else {
                total.clone()
            };
            let x = train.solve(&idx);
            let res = self.residual(r, set, &x);
            for (j, f) in factor.iter().enumerate() {
                for v in &res[j * lens[r]..(j + 1) * lens[r]] {
                    ss += (v * f).powi(2);
                    n += 1;
                }
            }
        }
        (ss / n.max(1) as f64).sqrt()
    }
    /// True if every coefficient of a fit of `set` lies within its candidate's bounds.
    pub(super) fn plausible(&self, set: &[usize]) -> bool {
        let g = self.total();
        let x = g.solve(&self.idx(set));
        let mut p = 0;
        for &c in set {
            for &(lo, hi) in &self.cands[c].bounds {
                if !(x[p] >= lo && x[p] <= hi) {
                    return false;
                }
                p += 1;
            }
        }
        true
    }
    /// Degrees of freedom of `set`: its columns and its grid-searched parameters.
    pub(super) fn dof(&self, set: &[usize]) -> usize {
        set.iter()
            .map(|&c| self.cols_of[c].len() + self.cands[c].grid_parameters)
            .sum()
    }
    /// Weighted residual series of a fit of `set` on recording r, per joint.
    pub(super) fn residual(&self, r: usize, set: &[usize], x: &[f64]) -> Vec<f64> {
        let (cols, b) = &self.blocks[r];
        let idx = self.idx(set);
        let mut out = b.clone();
        for (p, &i) in idx.iter().enumerate() {
            for (o, c) in out.iter_mut().zip(&cols[i]) {
                *o -= x[p] * c;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::candidates::{library, Effect, LibraryOptions, NominalWalkCache};
    use crate::diagnose::model::{DeclaredCandidate, InverseDynamicsModel, ModelParameter, ParameterFamily};

    /// One joint whose torque is linear in two parameters a user's model file declares
    /// together: τ = (0.1 + a)·q̈ + b·q̇.
    struct Declares {
        a: f64,
        b: f64,
    }

    impl InverseDynamicsModel for Declares {
        fn name(&self) -> String {
            "declares".into()
        }
        fn joints(&self) -> usize {
            1
        }
        fn joint_name(&self, _j: usize) -> String {
            "joint 1".into()
        }
        fn parameters(&self) -> Vec<ModelParameter> {
            let p = |name: &str, nominal: f64| ModelParameter {
                name: name.into(),
                unit: "N m s^2".into(),
                nominal,
                scale: 0.1,
                family: ParameterFamily::MassProperties,
            };
            vec![p("a", self.a), p("b", self.b)]
        }
        fn declared_candidates(&self) -> Vec<DeclaredCandidate> {
            vec![DeclaredCandidate {
                name: "pair".into(),
                parameters: vec![0, 1],
                bounds: vec![(-1.0, 1.0), (-1.0, 1.0)],
            }]
        }
        fn torques(&self, theta: &[f64], _q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
            tau[0] = (0.1 + theta[0]) * qdd[0] + theta[1] * qd[0];
        }
    }

    /// A recording of `n` samples at 100 Hz of one joint moving as sin(w·t) (rad, w in
    /// rad/s), its torque 0.3·cos(3t) N·m.
    fn sine(n: usize, w: f64) -> MotionData {
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        MotionData {
            name: "sine".into(),
            q: vec![t.iter().map(|t| (w * t).sin()).collect()],
            qd: vec![t.iter().map(|t| w * (w * t).cos()).collect()],
            qdd: vec![t.iter().map(|t| -w * w * (w * t).sin()).collect()],
            qdd_noise: vec![],
            tau: vec![t.iter().map(|t| 0.3 * (3.0 * t).cos()).collect()],
            y: vec![],
            ends_dropped: 0,
            t,
        }
    }

    /// The second pass's residual "as if from the nominal model" at a point a declared
    /// candidate moved (one shift entry per parameter) is the nominal residual when the
    /// model is linear in them: each entry goes with its own column.
    #[test]
    fn a_declared_candidates_shift_pairs_each_value_with_its_own_column() {
        let data = sine(300, 2.0);
        let pair = |m: &dyn InverseDynamicsModel| -> Vec<Candidate> {
            library(m, &LibraryOptions::default())
                .into_iter()
                .filter(|c| c.name == "pair")
                .collect()
        };
        let nominal = Declares { a: 0.0, b: 0.0 };
        let moved = Declares { a: 0.05, b: -0.2 };
        let opts = DiagnoseOptions::default();
        let at0 = prepare(
            &nominal,
            std::slice::from_ref(&data),
            &[0.02],
            &pair(&nominal),
            &opts,
        )
        .unwrap();
        let mut o = opts.clone();
        o.shift = vec![("pair".into(), 0.05), ("pair".into(), -0.2)];
        let at1 = prepare(&moved, std::slice::from_ref(&data), &[0.02], &pair(&moved), &o).unwrap();
        let (b0, b1) = (&at0.blocks[0].1, &at1.blocks[0].1);
        assert_eq!(at1.blocks[0].0.len(), 2, "one column per declared parameter");
        let scale = b0.iter().map(|v| v.abs()).fold(0.0, f64::max);
        let worst = b0.iter().zip(b1).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-6 * scale, "{worst} against {scale}");
    }

    /// [`Declares`] with its two parameters left undeclared, each its own candidate; its
    /// torque evaluations counted.
    struct Loose(Declares, std::sync::atomic::AtomicUsize);

    impl InverseDynamicsModel for Loose {
        fn name(&self) -> String {
            "loose".into()
        }
        fn joints(&self) -> usize {
            1
        }
        fn joint_name(&self, j: usize) -> String {
            self.0.joint_name(j)
        }
        fn parameters(&self) -> Vec<ModelParameter> {
            self.0.parameters()
        }
        fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
            self.1.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.0.torques(theta, q, qd, qdd, tau)
        }
    }

    /// The held-out residual's assembly without the columns it does not read
    /// ([`prepare_needed`]): the residual, the samples left out and every needed candidate's
    /// columns are those of the whole library's assembly to the bit, the left-out parameter
    /// candidates' columns (a parameter's, a declared pair's) are zero, and the residual after
    /// a fit of needed candidates is the same.
    #[test]
    fn an_assembly_of_the_needed_columns_leaves_the_residual_and_its_samples_as_they_were() {
        let mut data = sine(300, 2.0);
        // A sample the columns cannot use (a rate missing): left out of both assemblies.
        data.qd[0][150] = f64::NAN;
        let data = std::slice::from_ref(&data);
        let (opts, sigma) = (DiagnoseOptions::default(), [0.02]);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let loose = Loose(Declares { a: 0.02, b: 0.1 }, Default::default());
        let declares = Declares { a: 0.02, b: 0.1 };
        for model in [&loose as &dyn InverseDynamicsModel, &declares] {
            let cands = library(model, &LibraryOptions::default());
            let costly =
                |c: &Candidate| matches!(c.effect, Effect::Parameter { .. } | Effect::Declared { .. });
            let viscous = cands
                .iter()
                .position(|c| matches!(c.effect, Effect::Viscous))
                .expect("a viscous candidate");
            // The viscous friction and, where there are two, the first parameter needed.
            let parameters: Vec<usize> = (0..cands.len()).filter(|&c| costly(&cands[c])).collect();
            let set: Vec<usize> = std::iter::once(viscous)
                .chain(
                    parameters
                        .iter()
                        .copied()
                        .filter(|_| parameters.len() > 1)
                        .take(1),
                )
                .collect();
            let needed: Vec<bool> = (0..cands.len()).map(|c| set.contains(&c)).collect();
            assert!(
                parameters.iter().any(|&c| !needed[c]),
                "{}: a parameter left out",
                model.name()
            );
            let all = prepare_with(model, data, &sigma, &cands, &opts, None, None).unwrap();
            let some = prepare_needed(model, data, &sigma, &cands, &opts, None, None, Some(&needed)).unwrap();
            assert!(all.left_out[0][150] && all.left_out == some.left_out);
            assert_eq!(bits(&all.blocks[0].1), bits(&some.blocks[0].1));
            for (c, cand) in cands.iter().enumerate() {
                for &k in &all.cols_of[c] {
                    let (a, b) = (&all.blocks[0].0[k], &some.blocks[0].0[k]);
                    if !needed[c] && costly(cand) {
                        assert!(b.iter().all(|v| *v == 0.0), "{}", cand.name);
                        assert!(a.iter().any(|v| *v != 0.0), "{}", cand.name);
                    } else {
                        assert_eq!(bits(a), bits(b), "{}", cand.name);
                    }
                }
            }
            let x: Vec<f64> = (0..set.iter().map(|&c| all.cols_of[c].len()).sum())
                .map(|k| 0.01 * (k as f64 + 1.0))
                .collect();
            assert_eq!(
                bits(&all.residual(0, &set, &x)),
                bits(&some.residual(0, &set, &x))
            );
        }
    }

    /// A recording's walk cache keeps the model passes' columns (here the parameters'
    /// differences) and the nominal channels: a second assembly on it makes none of them again and gives the first's
    /// columns to the bit, which are a fresh assembly's; an assembly on other data (another
    /// nominal motion) does not take them.
    #[test]
    fn a_walk_cache_makes_each_model_pass_once_per_recording() {
        let recording = |w: f64| sine(200, w);
        let model = Loose(Declares { a: 0.02, b: 0.1 }, Default::default());
        let calls = || model.1.load(std::sync::atomic::Ordering::Relaxed);
        let cands = library(&model, &LibraryOptions::default());
        let (opts, sigma) = (DiagnoseOptions::default(), [0.02]);
        let bits = |p: &Prepared| -> Vec<Vec<u64>> {
            p.blocks[0]
                .0
                .iter()
                .map(|c| c.iter().map(|x| x.to_bits()).collect())
                .collect()
        };
        let data = [recording(2.0)];
        let walks = [NominalWalkCache::new()];
        let assemble = |data: &[MotionData], walks: Option<&[NominalWalkCache]>| {
            let before = calls();
            let p = prepare_with(&model, data, &sigma, &cands, &opts, None, walks).unwrap();
            (p, calls() - before)
        };
        let (fresh, fresh_calls) = assemble(&data, None);
        let (first, first_calls) = assemble(&data, Some(&walks));
        let kept = walks[0].passes_kept();
        let (second, second_calls) = assemble(&data, Some(&walks));
        // Two parameters, each a central difference: four passes of the 200 samples that the
        // second assembly does not make, nor the nominal pass.
        assert_eq!(kept, 2);
        assert_eq!(first_calls, fresh_calls);
        assert_eq!(
            second_calls + 5 * 200,
            first_calls,
            "{second_calls} against {first_calls}"
        );
        assert!(bits(&first) == bits(&fresh) && bits(&second) == bits(&fresh));
        // Other data on the same cache: its own passes, as a fresh assembly's.
        let other = [recording(2.5)];
        let (moved, moved_calls) = assemble(&other, Some(&walks));
        let (moved_fresh, _) = assemble(&other, None);
        assert_eq!(moved_calls, first_calls);
        assert!(bits(&moved) == bits(&moved_fresh) && bits(&moved) != bits(&fresh));
    }
}
