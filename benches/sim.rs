//! Speed of the event loop in the driven steady state of paper H (phi = 0.78,
//! eps = 0.9, neighbour-pair kicks at about the balanced rate): 100,000 events
//! per iteration after compression. `repro bench` measures collisions per CPU
//! second with whole runs; this isolates the loop.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};
use repro::sim::events::calendar::EventCalendar;
use repro::sim::{SimConfig, enskog, initial_state, run};

fn main() {
    divan::main();
}

#[divan::bench(args = [10_000, 100_000], sample_count = 10, sample_size = 1)]
fn driven_events(bencher: divan::Bencher, n: usize) {
    let cfg = SimConfig {
        n,
        ..SimConfig::default()
    };
    let mut e = initial_state::prepare(&cfg, &|_| {}).expect("compression succeeds");
    let omega = enskog::collision_frequency(
        cfg.phi,
        &cfg.radii(),
        &cfg.species_masses(),
        &[0.5, 0.5],
        1.0,
    );
    let (kicks, rate, p_dr) = run::drive(&cfg, omega);
    e.set_restitution(cfg.eps, cfg.collapse_tc);
    // The balanced rule settles at 1.18 x Enskog at phi = 0.78 (docs/sim.md).
    e.set_kicks(kicks, rate * 1.18, p_dr);
    e.run_until(e.time() + 2.0, u64::MAX);
    bencher
        .counter(divan::counter::ItemsCount::new(100_000usize))
        .bench_local(|| e.run_until(f64::INFINITY, 100_000));
}

/// The event calendar alone on a synthetic EDMD workload: per step, pop the
/// minimum at time t, reschedule it to t + Exp(1) and three random other
/// particles to t + Exp(1) (one event per particle, rate 1 per particle),
/// after n warm-up steps from exponential start times.
fn edmd_steps(q: &mut EventCalendar, n: usize, rng: &mut ChaCha8Rng, steps: usize) {
    let wait = Exp::new(1.0).expect("rate 1");
    for _ in 0..steps {
        let (i, t) = q.min();
        q.update(i, t + wait.sample(rng));
        for _ in 0..3 {
            let j = rng.random_range(0..n);
            q.update(j, t + wait.sample(rng));
        }
    }
}

#[divan::bench(args = [10_000, 1_000_000], sample_count = 10, sample_size = 1)]
fn calendar_edmd(bencher: divan::Bencher, n: usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let wait = Exp::new(1.0).expect("rate 1");
    let mut q = EventCalendar::new(n);
    for i in 0..n {
        q.set_lazy(i, wait.sample(&mut rng));
    }
    q.rebuild();
    edmd_steps(&mut q, n, &mut rng, n);
    bencher
        .counter(divan::counter::ItemsCount::new(100_000usize))
        .bench_local(|| edmd_steps(&mut q, n, &mut rng, 100_000));
}
