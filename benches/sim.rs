//! Speed of the event loop in the driven steady state of paper H (phi = 0.78,
//! eps = 0.9, neighbour-pair kicks at about the balanced rate): 100,000 events
//! per iteration after compression. `repro bench` measures collisions per CPU
//! second with whole runs; this isolates the loop.

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
    e.run_until(e.now + 2.0, u64::MAX);
    bencher
        .counter(divan::counter::ItemsCount::new(100_000usize))
        .bench_local(|| e.run_until(f64::INFINITY, 100_000));
}
