//! A diagnosis of kept recordings with every play candidate's dynamics on from the first
//! pass, at a reference play the caller gives: an experiment on how far the selection's path
//! is from what the library can express, not a diagnosis (the diagnosis takes a reference
//! play only from its own first pass or its probe). It answers "would the true physics fit
//! better than what the diagnosis chose, had its search path reached it?".
//!
//! The recordings are those `lash diagnose --suite --keep-recordings DIR` writes
//! (`DIR/<case>/recording-01.csv`, …): the fit recordings first, then the held-out ones, split
//! as the suite's design that has that many recordings (the reduced suite's three and one, the
//! full design's four and two). The differentiation half-width is the suite's.
//!
//! ```text
//! cargo run --release --example play_reference_run -- DIR/axial-D 4 "in joint E,in joint Q" out/ref-run
//! ```
//!
//! Arguments: the case's folder, the reference play in µm (radial clearance and axial play
//! alike), an optional comma-separated list of candidate texts to exclude (as `lash diagnose
//! --exclude`), an optional report folder (default `out/play-reference-run`). Prints the
//! selection, its leave-one-recording-out RMS and the estimates; writes the report.

use lash::diagnose::columns::{csv_header, resolve_columns};
use lash::diagnose::recording::read_csv;
use lash::diagnose::suite::SuiteOptions;
use lash::diagnose::{diagnose_recordings, DiagnoseOptions};
use lash::mechanisms::mr2120::record::recording_file;
use std::error::Error;
use std::path::{Path, PathBuf};

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(um)) = (args.first(), args.get(1)) else {
        return Err("usage: play_reference_run DIR REFERENCE_UM [EXCLUDE] [REPORT_DIR]".into());
    };
    let h = um.parse::<f64>()? * 1e-6;
    let exclude: Vec<String> = args
        .get(2)
        .map(|s| {
            s.split(',')
                .filter(|x| !x.trim().is_empty())
                .map(String::from)
                .collect()
        })
        .unwrap_or_default();
    let report = args
        .get(3)
        .map_or_else(|| PathBuf::from("out/play-reference-run"), PathBuf::from);
    let model = lash::diagnose::mr2120::mr2120_model(
        &lash::mechanisms::mr2120::Geometry::default(),
        &lash::mechanisms::mr2120::MassProperties::default(),
    )?;
    // (Recordings counted from 0, as the suite writes them.)
    let file = |r: usize| Path::new(dir).join(recording_file(r));
    let n = (0..).take_while(|&r| file(r).exists()).count();
    let designs = [SuiteOptions::reduced(), SuiteOptions::default()];
    let total = |s: &SuiteOptions| s.fit_recordings + s.holdout_recordings;
    let design = designs.iter().find(|s| total(s) == n).ok_or_else(|| {
        format!(
            "{dir}: {n} recordings; the suite's designs have {} (reduced) or {}",
            total(&designs[0]),
            total(&designs[1])
        )
    })?;
    let header = csv_header(&file(0))?;
    let mapping = resolve_columns(&model, None, &header)?;
    let load = |rs: std::ops::Range<usize>| -> Result<Vec<_>, Box<dyn Error>> {
        rs.map(|r| read_csv(&file(r), "time", &mapping).map_err(Into::into))
            .collect()
    };
    let nfit = design.fit_recordings;
    let (fit, held) = (load(0..nfit)?, load(nfit..n)?);
    let mut opts = DiagnoseOptions::default();
    opts.library.exclude = exclude;
    opts.library.dynamic_play_clearance = Some(h);
    opts.library.dynamic_axial_play = Some(h);
    let window = [design.derivative_window];
    let d = diagnose_recordings(&model, &fit, &held, &window, &opts, |_, _| {})?;
    lash::diagnose::report::write_report(&d, Path::new(&report))?;
    println!(
        "fit recordings 1–{nfit}, held out {}–{n}; reference play {um} µm",
        nfit + 1
    );
    for s in &d.steps {
        println!("added {:<80} CV RMS {:.4} noise units", s.added, s.cv_rms);
    }
    println!(
        "final leave-one-recording-out RMS {:.4} noise units",
        d.cv_rms_noise_units
    );
    for e in &d.estimates {
        println!("{:<80} {} = {:.4e}", e.candidate, e.parameter, e.value);
    }
    for c in &d.channels {
        println!(
            "held out {:<16} {:.4e} {} against a floor of {:.4e} ({:.3}×)",
            c.channel,
            c.holdout_after,
            c.unit,
            c.noise_floor,
            c.holdout_after / c.noise_floor
        );
    }
    println!("report: {}", report.display());
    Ok(())
}
