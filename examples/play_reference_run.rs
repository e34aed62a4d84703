//! A diagnosis of kept recordings with every play candidate's dynamics on from the first
//! pass, at a reference play the caller gives: an experiment on how far the selection's path
//! is from what the library can express, not a diagnosis (the diagnosis takes a reference
//! play only from its own first pass or its probe). It answers "would the true physics fit
//! better than what the diagnosis chose, had its search path reached it?".
//!
//! The recordings are those `lash diagnose --suite --keep-recordings DIR` writes
//! (`DIR/<case>/recording-01.csv`, …): the fit recordings first, then the held-out ones
//! (three and one for a folder of four, as the reduced suite; four and two otherwise). The
//! differentiation half-width is the suite's, 8 samples.
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
use lash::diagnose::{diagnose_recordings, DiagnoseOptions};
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
    let file = |k: usize| PathBuf::from(format!("{dir}/recording-{k:02}.csv"));
    let n = (1..).take_while(|&k| file(k).exists()).count();
    if n < 2 {
        return Err(format!("{dir}: fewer than two recordings (recording-01.csv, …)").into());
    }
    let header = csv_header(&file(1))?;
    let mapping = resolve_columns(&model, None, &header)?;
    let load = |ks: std::ops::RangeInclusive<usize>| -> Result<Vec<_>, Box<dyn Error>> {
        ks.map(|k| read_csv(&file(k), "time", &mapping).map_err(Into::into))
            .collect()
    };
    let nfit = if n == 4 { 3 } else { n - n / 3 };
    let (fit, held) = (load(1..=nfit)?, load(nfit + 1..=n)?);
    let mut opts = DiagnoseOptions::default();
    opts.library.exclude = exclude;
    opts.library.dynamic_play_clearance = Some(h);
    opts.library.dynamic_axial_play = Some(h);
    let d = diagnose_recordings(&model, &fit, &held, &[8], &opts, |_, _| {})?;
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
