//! Benchmarks of the plot area: trajectory Parquet I/O.
//! `cargo bench --bench plot` (prints the artifact size per particle per frame first).

use repro::table::trajectory::{from_parquet_bytes, random_walk, to_parquet_bytes};

const MILLION: usize = 1_000_000;

fn main() {
    for velocities in [false, true] {
        let (n, frames) = (10_000, 20);
        let bytes = to_parquet_bytes(&random_walk(n, frames, velocities, 1)).unwrap();
        println!(
            "random walk, {n} particles x {frames} frames, velocities {velocities}: {} bytes, \
             {:.2} bytes per particle per frame",
            bytes.len(),
            bytes.len() as f64 / (n * frames) as f64
        );
    }
    divan::main();
}

#[divan::bench(sample_count = 5)]
fn write_1e6_particles_1_frame(b: divan::Bencher) {
    let t = random_walk(MILLION, 1, false, 2);
    b.bench(|| to_parquet_bytes(divan::black_box(&t)).unwrap());
}

#[divan::bench(sample_count = 5)]
fn read_1e6_particles_1_frame(b: divan::Bencher) {
    let bytes = to_parquet_bytes(&random_walk(MILLION, 1, false, 2)).unwrap();
    b.with_inputs(|| bytes.clone())
        .bench_values(|bytes| from_parquet_bytes(bytes).unwrap());
}
