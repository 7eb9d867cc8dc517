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
        line_per_sample: None,
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

/// The index of the sample on which a default channel that identifies inline, fed seeded
/// white noise every `period_ns`, activates (`gap`: before sample i the clock jumps by that many
/// ns more and the sample is flagged GAP), and the gate after it.
fn activation(period_ns: u64, gap: Option<(usize, u64)>) -> (usize, ChannelGate) {
    let s = GrossErrorSettings {
        identify_defer_s: 0.0,
        ..GrossErrorSettings::default()
    };
    let (i, g) = activation_with(&s, period_ns, gap, s.warmup_samples);
    (i.expect("never activated"), g)
}

/// As [`activation`] with settings `s` and `n` samples (`None`: not activated within them).
fn activation_with(
    s: &GrossErrorSettings,
    period_ns: u64,
    gap: Option<(usize, u64)>,
    n: usize,
) -> (Option<usize>, ChannelGate) {
    let p = GateParams::new(s);
    let id = Identifier::new(s.identify, p.warmup.defer_max > 0);
    let mut g = ChannelGate::new(true, 1e-4);
    g.reserve_warmup(&p.warmup);
    let x = crate::rng::normal_vec(n, 7);
    let mut t = 0;
    for (i, &v) in x.iter().enumerate() {
        let jump = gap.filter(|&(at, _)| at == i).map(|(_, ns)| ns);
        t += period_ns + jump.unwrap_or(0);
        if g.warm_push(&p, Some(0.01 * v), t, jump.is_some(), &id, "gz") {
            return (Some(i), g);
        }
    }
    (None, g)
}

#[test]
fn a_deferred_identification_activates_on_the_sample_the_data_fix_with_the_inline_model() {
    let s = GrossErrorSettings::default();
    assert_eq!(s.identify_defer_s, 0.5);
    // 100 Hz: the window closes on sample 1999 (as inline), and the channel takes the model
    // 0.5 s of its own time later: on sample 2049, the 50th interval after the close.
    let (i, g) = activation_with(&s, 10_000_000, None, 3000);
    assert_eq!(i, Some(2049));
    let (_, inline) = activation(10_000_000, None);
    assert_eq!(
        g.model, inline.model,
        "the same window gives the same model"
    );
    assert_eq!(g.resolution(), inline.resolution());
    assert_eq!(g.counters.warmup, 2050);
    // The predictor went on through the 50 samples since: a rerun (the worker's timing is
    // the only thing that can differ) ends in the same state, to the bit.
    let (_, again) = activation_with(&s, 10_000_000, None, 3000);
    assert_eq!(g.pred, again.pred);
    assert_eq!(
        (g.sig2, g.jump2, g.x_acc, g.slope),
        (again.sig2, again.jump2, again.x_acc, again.slope)
    );
    // A channel staggered by 3 (the stage gives each its index) takes the same model 3
    // samples later.
    let (i3, g3) = {
        let p = GateParams::new(&s);
        let id = Identifier::new(s.identify, true);
        let mut g = ChannelGate::new(true, 1e-4);
        g.set_stagger(3);
        g.reserve_warmup(&p.warmup);
        let x = crate::rng::normal_vec(3000, 7);
        let i = x.iter().enumerate().position(|(i, &v)| {
            g.warm_push(
                &p,
                Some(0.01 * v),
                (i as u64 + 1) * 10_000_000,
                false,
                &id,
                "gz",
            )
        });
        (i, g)
    };
    assert_eq!(i3, Some(2052));
    assert_eq!(g3.model, inline.model);
    // Time stamps that stop advancing after the close end the deferral after `warmup_samples`
    // more samples (here: all on one stamp, 2 Hz before it; the window closes on sample 119).
    let mut frozen = GrossErrorSettings {
        warmup_samples: 200,
        ..s
    };
    frozen.identify_defer_s = 0.5;
    let p = GateParams::new(&frozen);
    assert_eq!(
        (p.warmup.defer_max, p.warmup.capacity()),
        (200, 200 + 200 + MAX_STAGGER)
    );
    let id = Identifier::new(frozen.identify, true);
    let mut g = ChannelGate::new(true, 1e-4);
    g.reserve_warmup(&p.warmup);
    let x = crate::rng::normal_vec(1000, 7);
    let at = x.iter().enumerate().position(|(i, &v)| {
        let t = (i.min(119) as u64 + 1) * 500_000_000;
        g.warm_push(&p, Some(0.01 * v), t, false, &id, "gz")
    });
    assert_eq!(at, Some(119 + 200));
}

#[test]
fn a_gate_cloned_during_the_deferral_takes_the_same_model() {
    let s = GrossErrorSettings::default();
    let p = GateParams::new(&s);
    let id = Identifier::new(s.identify, true);
    let mut g = ChannelGate::new(true, 1e-4);
    g.reserve_warmup(&p.warmup);
    let x = crate::rng::normal_vec(2100, 7);
    for (i, &v) in x[..2010].iter().enumerate() {
        assert!(!g.warm_push(
            &p,
            Some(0.01 * v),
            (i as u64 + 1) * 10_000_000,
            false,
            &id,
            "gz"
        ));
    }
    // The two share the worker's result: the first to activate takes it, the other
    // identifies the same window again itself.
    let mut h = g.clone();
    let run = |g: &mut ChannelGate| {
        (2010..2100).find(|&i| {
            g.warm_push(
                &p,
                Some(0.01 * x[i]),
                (i as u64 + 1) * 10_000_000,
                false,
                &id,
                "gz",
            )
        })
    };
    assert_eq!(run(&mut g), Some(2049));
    assert_eq!(run(&mut h), Some(2049));
    assert_eq!(g.model, h.model);
    assert_eq!(g.pred, h.pred);
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
