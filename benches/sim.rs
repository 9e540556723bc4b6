//! Speed of the event loop in the driven steady state of paper H (phi = 0.78,
//! eps = 0.9, neighbour-pair kicks at about the balanced rate): 100,000 events
//! per iteration after compression. `repro bench` measures collisions per CPU
//! second with whole runs; this isolates the loop.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Exp};
use repro::sim::calendar::EventCalendar;
use repro::sim::tree::EventTree;
use repro::sim::{SimConfig, enskog, init, run};

fn main() {
    divan::main();
}

#[divan::bench(args = [10_000, 100_000], sample_count = 10, sample_size = 1)]
fn driven_events(bencher: divan::Bencher, n: usize) {
    let cfg = SimConfig {
        n,
        ..SimConfig::default()
    };
    let mut e = init::prepare(&cfg, &|_| {}).expect("compression succeeds");
    let omega = enskog::collision_frequency(
        cfg.phi,
        &cfg.radii(),
        &cfg.species_masses(),
        &[0.5, 0.5],
        1.0,
    );
    let (kicks, rate, p_dr) = run::drive(&cfg, omega);
    e.eps = cfg.eps;
    e.tc = cfg.collapse_tc;
    // The balanced rule settles at 1.18 x Enskog at phi = 0.78 (docs/sim.md).
    e.set_kicks(kicks, rate * 1.18, p_dr);
    e.run_until(e.time() + 2.0, u64::MAX);
    bencher
        .counter(divan::counter::ItemsCount::new(100_000usize))
        .bench_local(|| e.run_until(f64::INFINITY, 100_000));
}

/// The event queue alone on a synthetic EDMD workload: per step, pop the
/// minimum at time t, reschedule it to t + Exp(1) and three random other
/// particles to t + Exp(1) (one event per particle, rate 1 per particle),
/// after n warm-up steps from exponential start times. Tree vs calendar.
trait Queue {
    fn make(n: usize) -> Self;
    fn set_lazy(&mut self, i: usize, t: f64);
    fn rebuild(&mut self);
    fn min(&self) -> (usize, f64);
    fn update(&mut self, i: usize, t: f64);
}

macro_rules! queue {
    ($t:ty) => {
        impl Queue for $t {
            fn make(n: usize) -> Self {
                <$t>::new(n)
            }
            fn set_lazy(&mut self, i: usize, t: f64) {
                <$t>::set_lazy(self, i, t)
            }
            fn rebuild(&mut self) {
                <$t>::rebuild(self)
            }
            #[inline]
            fn min(&self) -> (usize, f64) {
                <$t>::min(self)
            }
            #[inline]
            fn update(&mut self, i: usize, t: f64) {
                <$t>::update(self, i, t)
            }
        }
    };
}
queue!(EventTree);
queue!(EventCalendar);

fn edmd_steps<Q: Queue>(q: &mut Q, n: usize, rng: &mut ChaCha8Rng, steps: usize) {
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

#[divan::bench(types = [EventTree, EventCalendar], args = [10_000, 1_000_000], sample_count = 10, sample_size = 1)]
fn queue_edmd<Q: Queue>(bencher: divan::Bencher, n: usize) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let wait = Exp::new(1.0).expect("rate 1");
    let mut q = Q::make(n);
    for i in 0..n {
        q.set_lazy(i, wait.sample(&mut rng));
    }
    q.rebuild();
    edmd_steps(&mut q, n, &mut rng, n);
    bencher
        .counter(divan::counter::ItemsCount::new(100_000usize))
        .bench_local(|| edmd_steps(&mut q, n, &mut rng, 100_000));
}
