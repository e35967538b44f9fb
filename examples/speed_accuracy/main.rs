//! Speed against accuracy, and where each method fails: runs the study of `docs/benchmarks.md`
//! ([`drape_scenes::study`]) and writes its charts (SVG and PNG) and their data (CSV) into
//! `docs/charts/`.
//!
//! ```text
//! cargo run --release --example speed_accuracy            # everything, a few minutes
//! cargo run --release --example speed_accuracy -- --quick # smaller budgets, for a check
//! cargo run --release --example speed_accuracy -- --out /tmp/charts
//! cargo run --release --example speed_accuracy -- --self-collision-only # its chart alone
//! ```

use std::error::Error;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use bevy_drape::cloth::SolverMethod;
use drape_scenes::poncho::CharacterMotion;
use drape_scenes::scenes::FRAME_RATE;
use drape_scenes::study::{
    self, Budget, REFERENCE_SUBSTEPS, RUN_FRAMES, STUDY_N, StudyPoint, TRAJECTORY_FRAMES,
};
use plotters::prelude::*;

mod chart;
mod self_collision;

use chart::{COLORS, Chart, Series, write_chart, write_csv};

fn cost_chart_series(
    points: &[StudyPoint],
    adaptive: &StudyPoint,
    early: bool,
    floor: f32,
    floor_label: &str,
) -> Vec<Series> {
    let curve = |method| study::curve(points, method, early);
    let adaptive_error = if early {
        adaptive.early_error
    } else {
        adaptive.error
    };
    let xs: Vec<f64> = points
        .iter()
        .filter(|p| p.stable)
        .map(|p| p.ms_per_second)
        .collect();
    let (x0, x1) = (
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(0.0, f64::max),
    );
    vec![
        Series::line("XPBD (2 iterations)", COLORS[0], curve(SolverMethod::Xpbd)),
        Series::line(
            "hybrid (2 iterations)",
            COLORS[2],
            curve(SolverMethod::Hybrid { long_range: false }),
        ),
        Series::line("mass-spring", COLORS[1], curve(SolverMethod::MassSpring)),
        Series::scatter(
            format!(
                "XPBD adaptive, target 1% strain ({:.1} substeps)",
                adaptive.mean_substeps
            ),
            COLORS[3],
            vec![(adaptive.ms_per_second, adaptive_error as f64)],
        ),
        Series::line(
            floor_label,
            RGBColor(120, 120, 120),
            vec![(x0, floor as f64), (x1, floor as f64)],
        ),
    ]
}

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(|| PathBuf::from("docs/charts"), PathBuf::from);
    std::fs::create_dir_all(&out)?;
    plotters::style::register_font(
        "sans-serif",
        FontStyle::Normal,
        epaint_default_fonts::UBUNTU_LIGHT,
    )
    .map_err(|_| "the chart font does not load")?;
    let started = Instant::now();
    if args.iter().any(|a| a == "--self-collision-only") {
        for path in self_collision::charts(&out, quick)? {
            println!("  {}", path.display());
        }
        return Ok(());
    }
    let mut written = Vec::new();
    let n = if quick { 16 } else { STUDY_N };
    let reference_substeps = if quick { 256 } else { REFERENCE_SUBSTEPS };

    // 1. Error against cost.
    let reference = study::reference(n, reference_substeps);
    let half = study::reference(n, reference_substeps / 2);
    let floor = study::trajectory_error(&reference, &half);
    let early_floor = study::trajectory_error_over(&reference, &half, study::EARLY_FRAMES as usize);
    println!(
        "reference: XPBD {reference_substeps} x 2 at N = {n}; against {} x 2: {early_floor:.2e} m over 1/6 s, {floor:.2e} m over 0.5 s",
        reference_substeps / 2
    );
    let mut budgets = study::study_budgets();
    if quick {
        budgets.retain(|b| b.substeps <= 256);
    }
    let points = study::error_against_cost(n, &budgets, &reference, RUN_FRAMES);
    let adaptive = study::adaptive_point(n, 0.01, &reference, RUN_FRAMES);
    let mut csv = String::from(
        "method,substeps,iterations,stable,ms_per_simulated_second,rms_error_first_sixth_s_m,rms_error_first_half_s_m,end_max_strain,mean_substeps\n",
    );
    for p in points.iter().chain([&adaptive]) {
        let name = if std::ptr::eq(p, &adaptive) {
            "xpbd-adaptive"
        } else {
            p.budget.method.name()
        };
        writeln!(
            csv,
            "{name},{},{},{},{:.4},{:.4e},{:.4e},{:.5},{:.2}",
            p.budget.substeps,
            p.budget.iterations,
            p.stable,
            p.ms_per_second,
            p.early_error,
            p.error,
            p.end_strain,
            p.mean_substeps
        )?;
        println!(
            "  {name:>13} {:>4} x {}: {:>9.2} ms/s, error {:.2e} m (1/6 s) {:.2e} m (0.5 s), end strain {:.2}%{}",
            p.budget.substeps,
            p.budget.iterations,
            p.ms_per_second,
            p.early_error,
            p.error,
            100.0 * p.end_strain,
            if p.stable { "" } else { "  UNSTABLE" }
        );
    }
    writeln!(
        csv,
        "reference-floor,{},2,true,,{early_floor:.4e},{floor:.4e},,",
        reference_substeps / 2
    )?;
    written.push(write_csv(&out, "error_vs_cost", &csv)?);
    let floor_label = format!(
        "reference floor ({reference_substeps} vs {} substeps)",
        reference_substeps / 2
    );
    written.extend(write_chart(
        &out,
        &Chart {
            file: "error_vs_cost",
            title: "S1: RMS error of corner and centre over the first 1/6 s",
            x_label: "cost, ms of one core per simulated second",
            y_label: "RMS position error, m",
            series: cost_chart_series(&points, &adaptive, true, early_floor, &floor_label),
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);
    written.extend(write_chart(
        &out,
        &Chart {
            file: "error_vs_cost_half_second",
            title: "S1: RMS error of corner and centre over the first 0.5 s",
            x_label: "cost, ms of one core per simulated second",
            y_label: "RMS position error, m",
            series: cost_chart_series(&points, &adaptive, false, floor, &floor_label),
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);
    let strain_series = |method: SolverMethod| {
        points
            .iter()
            .filter(|p| p.budget.method == method && p.stable)
            .map(|p| (p.ms_per_second, p.end_strain as f64))
            .collect::<Vec<_>>()
    };
    written.extend(write_chart(
        &out,
        &Chart {
            file: "strain_vs_cost",
            title: "S1: largest strain at t = 2 s against cost",
            x_label: "cost, ms of one core per simulated second",
            y_label: "max strain at 2 s",
            series: vec![
                Series::line(
                    "XPBD (2 iterations)",
                    COLORS[0],
                    strain_series(SolverMethod::Xpbd),
                ),
                Series::line(
                    "hybrid (2 iterations)",
                    COLORS[2],
                    strain_series(SolverMethod::Hybrid { long_range: false }),
                ),
                Series::line(
                    "mass-spring",
                    COLORS[1],
                    strain_series(SolverMethod::MassSpring),
                ),
                Series::scatter(
                    "XPBD adaptive, target 1%",
                    COLORS[3],
                    vec![(adaptive.ms_per_second, adaptive.end_strain as f64)],
                ),
            ],
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);

    // 2. The stability map.
    let stiffnesses: Vec<f32> = if quick {
        vec![1e2, 1e3, 1e4]
    } else {
        (0..9).map(|i| 100.0 * 10f32.powf(i as f32 / 2.0)).collect()
    };
    let map = study::stability_map(n, &stiffnesses, 4096, TRAJECTORY_FRAMES);
    let mut csv = String::from(
        "stiffness_n_per_m,mass_spring_largest_stable_step_s,analytic_bound_s,analytic_2_over_omega_s,xpbd_largest_stable_step_s\n",
    );
    let opt = |v: Option<f32>| v.map_or(String::from("none"), |v| format!("{v:.4e}"));
    for r in &map {
        writeln!(
            csv,
            "{},{},{:.4e},{:.4e},{}",
            r.stiffness,
            opt(r.mass_spring),
            r.bound,
            r.bound_undamped,
            opt(r.xpbd)
        )?;
        println!(
            "  k = {:>9.0} N/m: mass-spring stable to {} s (bound {:.2e} s), XPBD to {} s",
            r.stiffness,
            opt(r.mass_spring),
            r.bound,
            opt(r.xpbd)
        );
    }
    written.push(write_csv(&out, "stability", &csv)?);
    let col = |f: &dyn Fn(&study::StabilityRow) -> Option<f32>| {
        map.iter()
            .filter_map(|r| f(r).map(|h| (r.stiffness as f64, h as f64)))
            .collect::<Vec<_>>()
    };
    written.extend(write_chart(
        &out,
        &Chart {
            file: "stability",
            title: "Largest stable substep against spring stiffness (S1)",
            x_label: "structural stiffness k, N/m (XPBD: compliance 1/k)",
            y_label: "largest stable substep, s",
            series: vec![
                Series::line(
                    "mass-spring, measured (searched to 4096 substeps per frame)",
                    COLORS[1],
                    col(&|r| r.mass_spring),
                ),
                Series::line(
                    "mass-spring, analytic bound (damped)",
                    COLORS[4],
                    col(&|r| Some(r.bound)),
                ),
                Series::line(
                    "2 / omega_max",
                    RGBColor(120, 120, 120),
                    col(&|r| Some(r.bound_undamped)),
                ),
                Series::line(
                    "XPBD, measured (one substep per frame is the largest tried)",
                    COLORS[0],
                    col(&|r| r.xpbd),
                ),
            ],
            legend: SeriesLabelPosition::LowerLeft,
        },
    )?);

    // 3. Small steps: iterations against substeps at equal cost; XPBD against PBD.
    let mut csv = String::from(
        "projections_per_frame,substeps,iterations,rms_error_m,end_max_strain,ms_per_simulated_second\n",
    );
    let mut small_steps = Vec::new();
    for (k, total) in [16u32, 64].into_iter().enumerate() {
        let mut strains = Vec::new();
        for (s, i) in study::equal_cost_splits(total) {
            let settings = study::plain_xpbd(s, i);
            let p = study::measure(
                n,
                Budget::new(SolverMethod::Xpbd, s, i),
                &settings,
                &reference,
                RUN_FRAMES,
            );
            writeln!(
                csv,
                "{total},{s},{i},{:.4e},{:.5},{:.3}",
                p.error, p.end_strain, p.ms_per_second
            )?;
            strains.push((i as f64, p.end_strain as f64));
        }
        small_steps.push(Series::line(
            format!("{total} projections per frame"),
            COLORS[k],
            strains,
        ));
    }
    written.push(write_csv(&out, "small_steps", &csv)?);
    written.extend(write_chart(
        &out,
        &Chart {
            file: "small_steps",
            title: "Plain XPBD at equal cost: substeps x iterations (S1)",
            x_label: "iterations per substep (substeps = projections / iterations)",
            y_label: "max strain at 2 s",
            series: small_steps,
            legend: SeriesLabelPosition::LowerRight,
        },
    )?);
    let iterations = [1u32, 2, 4, 8, 16, 32, 64];
    let mut csv = String::from("iterations,xpbd_sag_m,pbd_sag_m\n");
    let (mut xpbd, mut pbd) = (Vec::new(), Vec::new());
    for &i in &iterations {
        let a = study::sag(SolverMethod::Xpbd, i, 0.05);
        let b = study::sag(SolverMethod::Pbd { stiffness: 0.05 }, i, 0.05);
        writeln!(csv, "{i},{a:.5},{b:.5}")?;
        xpbd.push((i as f64, a as f64));
        pbd.push((i as f64, b as f64));
    }
    written.push(write_csv(&out, "xpbd_vs_pbd", &csv)?);
    written.extend(write_chart(
        &out,
        &Chart {
            file: "xpbd_vs_pbd",
            title: "Sag of a compliant S1 (N = 16) at rest against iterations",
            x_label: "iterations per substep (8 substeps)",
            y_label: "sag of the centre of mass, m",
            series: vec![
                Series::line("XPBD, compliance 0.05 m/N", COLORS[0], xpbd),
                Series::line("PBD, stiffness 0.05", COLORS[1], pbd),
            ],
            legend: SeriesLabelPosition::LowerLeft,
        },
    )?);

    // 4. FABRIK.
    let curves = study::fabrik_residuals(256, 30);
    let mut csv = String::from("chain,iterations,median_residual_m,p90_residual_m\n");
    let mut series = Vec::new();
    for (k, c) in curves.iter().enumerate() {
        for (i, (m, p)) in c.median.iter().zip(&c.p90).enumerate() {
            writeln!(csv, "{},{},{m:.4e},{p:.4e}", c.chain, i + 1)?;
        }
        series.push(Series::line(
            format!("{} (median of 256)", c.chain),
            COLORS[k],
            c.median
                .iter()
                .enumerate()
                .map(|(i, &m)| ((i + 1) as f64, (m as f64).max(1e-7)))
                .collect(),
        ));
    }
    written.push(write_csv(&out, "fabrik", &csv)?);
    written.extend(write_chart(
        &out,
        &Chart {
            file: "fabrik",
            title: "FABRIK on hinge chains: distance to reachable targets",
            x_label: "iterations",
            y_label: "median distance to the target, m",
            series,
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);

    // 5. Splines.
    let rows = study::spline_errors(&[4, 8, 16, 32, 64, 128]);
    let mut csv = String::from(
        "mean_spacing_s,equal_keys_max_error,unequal_keys_nonuniform_tangent_max_error,unequal_keys_uniform_tangent_max_error\n",
    );
    for r in &rows {
        writeln!(
            csv,
            "{:.5},{:.4e},{:.4e},{:.4e}",
            r.spacing, r.equal, r.unequal_nonuniform, r.unequal_uniform
        )?;
    }
    written.push(write_csv(&out, "splines", &csv)?);
    let col = |f: fn(&study::SplineRow) -> f32| {
        rows.iter()
            .map(|r| (r.spacing as f64, f(r) as f64))
            .collect::<Vec<_>>()
    };
    written.extend(write_chart(
        &out,
        &Chart {
            file: "splines",
            title: "Catmull-Rom interpolation of sin(2 pi t) + 0.3 cos(4 pi t)",
            x_label: "mean key spacing, s",
            y_label: "largest error",
            series: vec![
                Series::line("equal spacing (both formulas)", COLORS[0], col(|r| r.equal)),
                Series::line(
                    "unequal spacing, non-uniform tangent",
                    COLORS[2],
                    col(|r| r.unequal_nonuniform),
                ),
                Series::line(
                    "unequal spacing, uniform tangent",
                    COLORS[1],
                    col(|r| r.unequal_uniform),
                ),
            ],
            legend: SeriesLabelPosition::LowerRight,
        },
    )?);

    // 6. The main scene: strain against cost for every budget and motion.
    let (budgets, motions, steps) = if quick {
        (
            study::main_scene_budgets()
                .into_iter()
                .filter(|b| b.substeps <= 8 && b.iterations == 2)
                .collect(),
            vec![CharacterMotion::InPlace],
            180,
        )
    } else {
        (
            study::main_scene_budgets(),
            CharacterMotion::ALL[..4].to_vec(),
            600,
        )
    };
    let points = study::main_scene_points(&budgets, &motions, steps)?;
    let mut csv = String::from(
        "motion,substeps,iterations,exact_edges,stable,ms_per_simulated_second,step_max_strain_median,step_max_strain_max,edge_strain_p999\n",
    );
    for p in &points {
        writeln!(
            csv,
            "{},{},{},{},{},{:.2},{:.5},{:.5},{:.5}",
            p.motion.name(),
            p.budget.substeps,
            p.budget.iterations,
            p.budget.exact_edges,
            p.stable,
            p.ms_per_second,
            p.step_max_strain_median,
            p.step_max_strain_max,
            p.edge_strain_p999
        )?;
        println!(
            "  S3 {:>9} {:>2} x {}{}: {:>7.1} ms/s, step max strain median {:.2}% worst {:.1}%, p99.9 edge {:.2}%",
            p.motion.name(),
            p.budget.substeps,
            p.budget.iterations,
            if p.budget.exact_edges { " exact" } else { "" },
            p.ms_per_second,
            100.0 * p.step_max_strain_median,
            100.0 * p.step_max_strain_max,
            100.0 * p.edge_strain_p999
        );
    }
    written.push(write_csv(&out, "s3_strain_vs_cost", &csv)?);
    // One line per motion, iteration count and edge solve, through its substep counts.
    let s3_series = |value: fn(&study::MainScenePoint) -> f32| {
        let mut series = Vec::new();
        for (k, motion) in motions.iter().enumerate() {
            for (iterations, exact) in [(2, true), (2, false), (4, false)] {
                let line: Vec<(f64, f64)> = points
                    .iter()
                    .filter(|p| {
                        p.motion == *motion
                            && p.budget.iterations == iterations
                            && p.budget.exact_edges == exact
                            && p.stable
                    })
                    .map(|p| (p.ms_per_second, value(p) as f64))
                    .collect();
                if line.is_empty() {
                    continue;
                }
                let name = if exact {
                    format!("{} ({iterations} iterations, exact edges)", motion.name())
                } else {
                    format!("{} ({iterations} iterations)", motion.name())
                };
                let color = COLORS[k % COLORS.len()];
                series.push(if iterations == 2 {
                    Series::line(name, color, line)
                } else {
                    Series::scatter(name, color, line)
                });
            }
        }
        series
    };
    written.extend(write_chart(
        &out,
        &Chart {
            file: "s3_max_strain_vs_cost",
            title: "S3: largest strain of a step (median over the steps) against cost",
            x_label: "cloth cost, ms of one core per simulated second",
            y_label: "median step's largest strain",
            series: s3_series(|p| p.step_max_strain_median),
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);
    written.extend(write_chart(
        &out,
        &Chart {
            file: "s3_p999_strain_vs_cost",
            title: "S3: 99.9th percentile edge strain against cost",
            x_label: "cloth cost, ms of one core per simulated second",
            y_label: "99.9th percentile strain",
            series: s3_series(|p| p.edge_strain_p999),
            legend: SeriesLabelPosition::UpperRight,
        },
    )?);

    written.extend(self_collision::charts(&out, quick)?);

    println!(
        "wrote in {:.0} s ({} frames of {} Hz per run):",
        started.elapsed().as_secs_f32(),
        RUN_FRAMES,
        FRAME_RATE
    );
    for path in written {
        println!("  {}", path.display());
    }
    Ok(())
}
