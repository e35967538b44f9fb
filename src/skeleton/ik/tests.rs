use super::*;
use crate::skeleton::rig::BoneDesc;

#[test]
fn angle_rates_are_exact_for_a_parabola_and_second_order_otherwise() {
    let dt = 1.0 / 60.0;
    // theta(t) = 0.3 + 2 t - 5 t^2: the rate at the newest sample is exact.
    let theta = |t: f32| 0.3 + 2.0 * t - 5.0 * t * t;
    let mut rates = AngleRates::default();
    assert_eq!(rates.rate(0, 0.0, dt), None);
    for n in 0..3 {
        let t = n as f32 * dt;
        if n == 2 {
            let rate = rates.rate(0, theta(t), dt).unwrap();
            assert!((rate - (2.0 - 10.0 * t)).abs() < 1e-3, "{rate}");
        }
        rates.push(&[theta(t)]);
    }
    // sin(w t): the error falls with the square of the step.
    let error = |dt: f32| {
        let mut rates = AngleRates::default();
        let mut worst = 0.0f32;
        for n in 0..40 {
            let t = n as f32 * dt;
            if let Some(rate) = rates.rate(0, (3.0 * t).sin(), dt).filter(|_| n >= 2) {
                worst = worst.max((rate - 3.0 * (3.0 * t).cos()).abs());
            }
            rates.push(&[(3.0 * t).sin()]);
        }
        worst
    };
    let (coarse, fine) = (error(0.05), error(0.025));
    assert!(fine < 0.3 * coarse, "{coarse} then {fine}");
}

#[test]
fn tracking_starts_from_the_last_step_without_restarts_and_limits_each_step() {
    let rig = Rig::new(&[
        BoneDesc {
            name: "root".into(),
            parent: None,
            offset: [0.0; 3],
            axis: [1.0, 0.0, 0.0],
            limits: None,
        },
        BoneDesc {
            name: "arm".into(),
            parent: Some("root".into()),
            offset: [0.0; 3],
            axis: [0.0, 0.0, 1.0],
            limits: None,
        },
    ])
    .unwrap();
    let chain = IkChain::new(&rig, "arm", 1, Vec3::X).unwrap();
    let arm = chain.bones[0];
    let mut tracking = IkTracking::default();
    let mut pose = rig.rest_pose();
    // Cold: the settings as given, the pose untouched.
    let cold = tracking.warm_start(&chain, &mut pose, &IkSettings::default());
    assert!(cold.restarts);
    pose.angles[arm] = 1.0;
    tracking.follow(&chain, &mut pose, 0.1);
    assert_eq!(pose.angles[arm], 1.0, "the first step is not limited");
    // Warm: from the last angles, no restarts, at most 0.1 rad further.
    let mut next = rig.rest_pose();
    let warm = tracking.warm_start(&chain, &mut next, &IkSettings::default());
    assert!(!warm.restarts);
    assert_eq!(next.angles[arm], 1.0);
    next.angles[arm] = -2.0;
    tracking.follow(&chain, &mut next, 0.1);
    assert!((next.angles[arm] - 0.9).abs() < 1e-6);
    tracking.forget();
    assert!(
        tracking
            .warm_start(&chain, &mut next, &IkSettings::default())
            .restarts
    );
}
