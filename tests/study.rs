//! The speed-against-accuracy study's functions on tiny budgets: they measure what the charts
//! claim (errors fall with the budget, unstable budgets are reported as such, the stability
//! bound holds, the interpolation orders are right), and the adaptive substep budget.

use bevy_drape::cloth::{AdaptiveSubsteps, SolverMethod};
use drape_scenes::scenes::HangingCloth;
use drape_scenes::study::{
    self, Budget, RUN_FRAMES, TRAJECTORY_FRAMES, equal_cost_splits, error_against_cost,
    fewest_fixed_substeps_for_strain, meets_strain, reference,
};

#[test]
fn xpbd_error_falls_as_the_budget_grows() {
    let n = 12;
    let reference = reference(n, 256);
    let budgets: Vec<Budget> = [1, 4, 16]
        .map(|s| Budget::new(SolverMethod::Xpbd, s, 2))
        .to_vec();
    let points = error_against_cost(n, &budgets, &reference, TRAJECTORY_FRAMES);
    let errors: Vec<f32> = points.iter().map(|p| p.error).collect();
    println!("XPBD error at 1, 4, 16 substeps: {errors:?}");
    assert!(points.iter().all(|p| p.stable));
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "{errors:?}");
    // And the finest of them is close: a centimetre over the first half second.
    assert!(errors[2] < 0.01, "{errors:?}");
}

#[test]
fn mass_spring_past_its_bound_is_reported_unstable_and_left_out_of_the_chart() {
    let n = 12;
    let reference = reference(n, 64);
    // Two substeps per frame are far above the stiff springs' stable step; 256 are below it.
    let budgets = [
        Budget::new(SolverMethod::MassSpring, 2, 1),
        Budget::new(SolverMethod::MassSpring, 256, 1),
    ];
    let points = error_against_cost(n, &budgets, &reference, TRAJECTORY_FRAMES);
    println!("{points:?}");
    assert!(!points[0].stable);
    assert!(points[0].error.is_infinite() && points[0].end_strain.is_infinite());
    assert!(points[1].stable && points[1].error.is_finite());
    let curve = study::curve(&points, SolverMethod::MassSpring, false);
    assert_eq!(
        curve.len(),
        1,
        "only the stable budget is a point: {curve:?}"
    );
    assert_eq!(curve[0].1, points[1].error as f64);
}

#[test]
fn the_measured_mass_spring_stability_limit_lies_above_the_analytic_bound_and_near_it() {
    // The bound is the trace condition on Gershgorin estimates of omega_max and gamma_max,
    // which can only overestimate them: a step below it must be stable, and the measured
    // limit should not be far above it.
    let rows = study::stability_map(8, &[1e3, 1e4], 2048, TRAJECTORY_FRAMES);
    for r in &rows {
        println!("{r:?}");
        let h = r
            .mass_spring
            .expect("a stable step exists below 1/60/2048 s");
        assert!(
            h >= r.bound * 0.99,
            "measured {h} below the bound {}",
            r.bound
        );
        assert!(
            h < 4.0 * r.bound,
            "measured {h} far above the bound {}",
            r.bound
        );
        assert!(r.bound <= r.bound_undamped);
        // XPBD with the same stiffness as a compliance holds at one substep per frame.
        assert_eq!(r.xpbd, Some(1.0 / 60.0));
    }
    // Ten times stiffer springs need a sqrt(10) times smaller step.
    let ratio = rows[0].bound_undamped / rows[1].bound_undamped;
    assert!(
        (ratio - 10f32.sqrt()).abs() < 0.05 * 10f32.sqrt(),
        "{ratio}"
    );
}

#[test]
fn equal_cost_splits_keep_the_product() {
    assert_eq!(
        equal_cost_splits(16),
        vec![(16, 1), (8, 2), (4, 4), (2, 8), (1, 16)]
    );
    assert!(equal_cost_splits(12).iter().all(|(s, i)| s * i == 12));
}

#[test]
fn splines_converge_at_third_order_and_the_uniform_tangent_does_not_on_unequal_keys() {
    let rows = study::spline_errors(&[16, 32, 64]);
    for r in &rows {
        println!("{r:?}");
    }
    // Cubic Hermite with tangents exact for quadratics: error O(h^3), a factor 8 per halving.
    let order = |a: f32, b: f32| (a / b).log2();
    assert!(order(rows[1].equal, rows[2].equal) > 2.7);
    assert!(order(rows[1].unequal_nonuniform, rows[2].unequal_nonuniform) > 2.5);
    // Per-index tangents on unequal keys: the velocity is wrong by O(1) at every key, so the
    // error falls only about as h.
    assert!(order(rows[1].unequal_uniform, rows[2].unequal_uniform) < 2.0);
    assert!(rows[2].unequal_uniform > 20.0 * rows[2].unequal_nonuniform);
}

#[test]
fn fabrik_gets_within_a_millimetre_of_most_reachable_targets() {
    let curves = study::fabrik_residuals(64, 20);
    assert_eq!(curves.len(), 3);
    for c in &curves {
        println!("{}: median {:?}", c.chain, c.median);
        assert!(c.median[19] < 1e-3, "{}: {}", c.chain, c.median[19]);
        assert!(c.median[19] < c.median[0]);
    }
}

#[test]
fn the_adaptive_budget_meets_its_target_with_fewer_substeps_than_a_fixed_budget() {
    // The crate's defaults (damping on), 2 iterations; the target must hold after every
    // frame of the 2 s run.
    let (n, target, fraction) = (32, 0.01, 1.0);
    let fixed_settings = Budget::new(SolverMethod::Xpbd, 1, 2).settings();
    let fixed =
        fewest_fixed_substeps_for_strain(n, &fixed_settings, target, fraction, RUN_FRAMES, 32)
            .expect("some fixed budget meets 1%");
    let mut settings = fixed_settings;
    settings.substeps = 8;
    settings.adaptive = Some(AdaptiveSubsteps::target(target));
    let run = HangingCloth { n }.run(&settings, RUN_FRAMES).trajectory;
    let over = run.strain.iter().filter(|&&s| s > target).count();
    println!(
        "fixed budget: {fixed} substeps; adaptive: mean {:.2} substeps, {over} of {} frames over, end strain {:.4}, counts {:?}",
        run.mean_substeps(),
        run.strain.len(),
        run.end_strain(),
        run.substeps
    );
    assert!(meets_strain(&run, target, fraction));
    assert!(run.mean_substeps() < fixed as f32);
}

#[test]
fn the_adaptive_count_rises_at_once_and_falls_after_calm_steps_within_its_bounds() {
    let budget = AdaptiveSubsteps {
        target_strain: 0.01,
        min_substeps: 2,
        max_substeps: 10,
        ..AdaptiveSubsteps::default()
    };
    let mut calm = 0;
    assert_eq!(budget.next(4, 0.02, &mut calm), 6);
    assert_eq!(budget.next(8, 0.02, &mut calm), 10);
    assert_eq!(budget.next(4, f32::NAN, &mut calm), 6);
    // In the band between 70% and 100% of the target the count holds.
    for _ in 0..100 {
        assert_eq!(budget.next(4, 0.008, &mut calm), 4);
    }
    // Below it, 1 + grow times fewer (at least one fewer) after CALM_STEPS steps in a row.
    let mut count = 9;
    for _ in 0..budget.calm_steps {
        count = budget.next(count, 0.001, &mut calm);
    }
    assert_eq!(count, 6);
    let mut count = 4;
    for _ in 0..budget.calm_steps {
        count = budget.next(count, 0.001, &mut calm);
    }
    assert_eq!(count, 3);
    for _ in 0..10 * budget.calm_steps {
        count = budget.next(count, 0.001, &mut calm);
    }
    assert_eq!(count, 2);
}

/// S3 in place: the median step's largest strain and the 99.9th percentile edge fall as the
/// substeps or the iterations grow, and 8 x 2 with the structural edges solved exactly while
/// the poncho touches the body (the default) holds it tighter than 16 x 2 without them.
#[test]
fn the_main_scene_strain_falls_as_substeps_or_iterations_grow() {
    use drape_scenes::poncho::CharacterMotion;
    use drape_scenes::study::MainSceneBudget;
    let budget = |substeps, iterations, exact_edges| MainSceneBudget {
        substeps,
        iterations,
        exact_edges,
    };
    let budgets = [
        budget(4, 2, false),
        budget(8, 2, false),
        budget(16, 2, false),
        budget(8, 4, false),
        budget(8, 2, true),
    ];
    let points = study::main_scene_points(&budgets, &[CharacterMotion::InPlace], 600)
        .expect("the scene's files load from the repository");
    for p in &points {
        println!(
            "S3 {:?}: step max strain median {:.4}, p99.9 {:.4}",
            p.budget, p.step_max_strain_median, p.edge_strain_p999
        );
        assert!(p.stable);
    }
    let median = |i: usize| points[i].step_max_strain_median;
    let p999 = |i: usize| points[i].edge_strain_p999;
    // Substeps: 4, 8, 16 (x 2).
    assert!(median(0) > median(1) && median(1) > median(2));
    assert!(p999(0) > p999(1) && p999(1) > p999(2));
    // Iterations: 8 x 4 against 8 x 2.
    assert!(median(3) < median(1) && p999(3) < p999(1));
    // The exact edges at 8 x 2 against 16 x 2 without them.
    assert!(median(4) < median(2) && p999(4) < p999(2));
}
