use super::*;

fn model(p: Vec<f64>, d: usize, q: Vec<f64>) -> ArimaChannelModel {
    ArimaChannelModel {
        channel: "gz".into(),
        p: p.len(),
        d,
        q: q.len(),
        constant: 0.0,
        ar: p,
        ma: q,
        sigma: 2.0,
        diagnostics: None,
    }
}

#[test]
fn increment_variance_matches_closed_forms() {
    // AR(1): Var(Δx) = 2σ²/(1+φ). MA(1): Var(Δx) = 2σ²(1+θ²−θ). d = 1 random walk: σ².
    let v = model_increment_var(&model(vec![0.6], 0, vec![]));
    assert!((v - 2.0 * 4.0 / 1.6).abs() < 1e-9, "{v}");
    let v = model_increment_var(&model(vec![], 0, vec![0.4]));
    assert!((v - 2.0 * 4.0 * (1.0 + 0.16 - 0.4)).abs() < 1e-9, "{v}");
    let v = model_increment_var(&model(vec![], 1, vec![]));
    assert!((v - 4.0).abs() < 1e-12, "{v}");
}

#[test]
fn huber_consistency_factor_is_the_clipped_second_moment() {
    // scipy's quadrature of min(z², 6.25)φ(z) (tests/reference/special.py): 1e-12.
    assert!((huber_beta(40.0) - 1.0).abs() < 1e-14);
    assert!(huber_beta(0.0).abs() < 1e-15);
    assert!((huber_beta(2.5) - 0.9775599834528068).abs() < 1e-12);
}

/// The index of the sample on which a default channel fed seeded white noise every
/// `period_ns` activates (`gap`: before sample i the clock jumps by that many ns more and
/// the sample is flagged GAP), and the gate after it.
fn activation(period_ns: u64, gap: Option<(usize, u64)>) -> (usize, ChannelGate) {
    let s = GrossErrorSettings::default();
    let p = GateParams::new(&s);
    let mut g = ChannelGate::new(true, 1e-4);
    g.reserve_warmup(s.warmup_samples);
    let x = crate::rng::normal_vec(s.warmup_samples, 7);
    let mut t = 0;
    for (i, &v) in x.iter().enumerate() {
        let jump = gap.filter(|&(at, _)| at == i).map(|(_, ns)| ns);
        t += period_ns + jump.unwrap_or(0);
        if g.warm_push(&p, Some(0.01 * v), t, jump.is_some(), &s.identify, "gz") {
            return (i, g);
        }
    }
    panic!("never activated");
}

#[test]
fn the_warm_up_ends_at_warmup_max_s_of_its_own_time_but_never_below_the_minimum() {
    let s = GrossErrorSettings::default();
    assert_eq!((s.warmup_samples, s.warmup_max_s), (2000, 30.0));
    // The minimum is the identification's own (20 (p_max + q_max + 1) = 120 by default).
    assert_eq!(WarmupLimits::new(&s).min_samples, 120);
    // 100 Hz: 2000 samples (19.99 s) come first, as before the time bound.
    let (i, g) = activation(10_000_000, None);
    assert_eq!(i, 1999);
    assert_eq!(g.mode, Mode::Active);
    // 25 Hz: on the sample at which the kept samples span 30 s (750 intervals of 40 ms:
    // the 751st sample), not at 2000 (80 s); and on an identified model, not the fallback.
    let (i, g) = activation(40_000_000, None);
    assert_eq!(i, 750);
    assert!(
        (g.warmup_span_s() - 30.0).abs() < 1e-9,
        "{}",
        g.warmup_span_s()
    );
    assert_eq!((g.mode, g.counters.fallback_models), (Mode::Active, 0));
    assert_eq!(g.counters.warmup, 751);
    // 2 Hz: 30 s is spanned at the 61st sample, but the channel waits for the 120 the
    // identification needs.
    let (i, g) = activation(500_000_000, None);
    assert_eq!(i, 119);
    assert_eq!(g.counters.fallback_models, 0);
    // 25 Hz with a 100-s gap before sample 100: the gap is no warm-up time (else the
    // channel would have activated on it), so 30 s of samples still take 751 samples.
    let (i, _) = activation(40_000_000, Some((100, 100_000_000_000)));
    assert_eq!(i, 751);
}
