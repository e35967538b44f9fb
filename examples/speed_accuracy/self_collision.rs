//! Self-collision's crossings against its cost: the generated sheet drops run with each
//! method at each substep count ([`study::crossings_against_cost`]).

use std::error::Error;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use drape_scenes::study::{self, CROSSINGS_SUBSTEPS};
use plotters::prelude::*;

use crate::chart::{COLORS, Chart, Series, write_chart, write_csv};

/// Runs the drops (10 of 32 x 32 for 10 s; with `quick`, 3 of 16 x 16 for 4 s) and writes
/// the chart and its data into `out`.
pub(crate) fn charts(out: &Path, quick: bool) -> Result<Vec<PathBuf>, Box<dyn Error>> {
    let (n, seeds, frames) = if quick {
        (16, 1..4, 240)
    } else {
        (32, 1..11, 600)
    };
    let drops = seeds.clone().count();
    let points = study::crossings_against_cost(n, seeds, frames, &CROSSINGS_SUBSTEPS);
    let mut csv = String::from("method,substeps,iterations,drops,ms_per_frame,crossings,finite\n");
    println!("self-collision: {drops} generated drops of a {n} x {n} sheet, {frames} frames each");
    for p in &points {
        let name = p.method.name();
        writeln!(
            csv,
            "{name},{},2,{},{:.4},{},{}",
            p.substeps, p.drops, p.ms_per_frame, p.crossings, p.finite
        )?;
        println!(
            "  {name:>9} {:>2} x 2: {:>6.2} ms per frame, {} crossings{}",
            p.substeps,
            p.ms_per_frame,
            p.crossings,
            if p.finite { "" } else { "  NOT FINITE" }
        );
    }
    let series = [bevy_drape::cloth::SelfCollisionMethod::ALL]
        .into_iter()
        .flatten()
        .enumerate()
        .map(|(k, method)| {
            let line = points
                .iter()
                .filter(|p| p.method == method && p.finite)
                .map(|p| (p.ms_per_frame, p.crossings as f64 + 1.0))
                .collect();
            Series::line(method.name(), COLORS[k], line)
        })
        .collect();
    let title = format!("Sheet drops: crossings through itself against cost ({drops} drops)");
    let mut written = vec![write_csv(out, "self_collision_crossings", &csv)?];
    written.extend(write_chart(
        out,
        &Chart {
            file: "self_collision_crossings_vs_cost",
            title: &title,
            x_label: "ms per 1/60 s frame (median; 4, 8, 16 substeps x 2 iterations)",
            y_label: "crossings in all drops, plus 1",
            series,
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);
    Ok(written)
}
