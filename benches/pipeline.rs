//! Pipeline overheads (run with `cargo bench --bench pipeline`):
//! - `plan_and_lookup_10k`: load specs, expand a 10,001-stage graph and look up every
//!   stage in a fully cached store (target: under 1 s).
//! - `noop_figure_run`: `repro figure --all` on the fixture catalogue, all cached.
//! - `one_sim_one_job` vs `two_sims_two_jobs`: parallel efficiency of independent
//!   simulations (target: the second within 1.15x of the first on 2 free cores).

use std::path::{Path, PathBuf};

use repro::pipeline::{self, Registry, RunOptions, Workspace, toy};

fn main() {
    divan::main();
}

fn reg() -> Registry {
    let mut r = Registry::framework();
    toy::register(&mut r);
    r
}

fn write(root: &Path, rel: &str, text: &str) {
    let p = root.join(rel);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

/// A root with 1,000 simulations (100 phi x 10 replicas), 9,000 analyses (a sweep of
/// 9 cutoffs) and one table, computed once and kept under the target directory.
fn big_root() -> PathBuf {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target"));
    let root = target.join("bench-pipeline-10k");
    if root.join("ready").exists() {
        return root;
    }
    let phis: Vec<String> = (0..100)
        .map(|i| format!("{}", 0.5 + 0.003 * i as f64))
        .collect();
    write(
        &root,
        "experiments/big.yaml",
        &format!(
            "description: synthetic\nkind: toy_simulate\nseed: 1\nprofiles:\n  ci:\n    grid:\n      phi: [{}]\n    replicas: 10\n    params: {{n: 8}}\n",
            phis.join(", ")
        ),
    );
    write(
        &root,
        "pipelines/big.yaml",
        "description: synthetic 10k stages\nstages:\n  - name: s\n    kind: toy_analyse\n    map: big\n    sweep: {a: [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9]}\n  - name: t\n    kind: table\n    gather: [s]\n",
    );
    let run = pipeline::run_figures(
        &Workspace::new(&root),
        &reg(),
        &[],
        "ci",
        &RunOptions::default(),
    )
    .unwrap();
    run.check().unwrap();
    assert_eq!(run.graph.nodes.len(), 10_001);
    std::fs::write(root.join("ready"), "").unwrap();
    root
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn plan_and_lookup_10k(bencher: divan::Bencher) {
    let root = big_root();
    let r = reg();
    bencher.bench(|| {
        let (g, st) = pipeline::figure_status(&Workspace::new(&root), &r, &[], "ci", &[]).unwrap();
        assert_eq!(st.len(), 10_001);
        assert!(
            st.iter()
                .all(|(_, s)| matches!(s, pipeline::State::Cached { .. }))
        );
        g.nodes.len()
    });
}

fn fixture_root() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pipeline");
    for sub in ["experiments", "pipelines"] {
        for e in std::fs::read_dir(src.join(sub)).unwrap().flatten() {
            write(
                d.path(),
                &format!("{sub}/{}", e.file_name().to_string_lossy()),
                &std::fs::read_to_string(e.path()).unwrap(),
            );
        }
    }
    d
}

#[divan::bench(sample_count = 10, sample_size = 1)]
fn noop_figure_run(bencher: divan::Bencher) {
    let d = fixture_root();
    let r = reg();
    let w = Workspace::new(d.path());
    pipeline::run_figures(&w, &r, &[], "small", &RunOptions::default())
        .unwrap()
        .check()
        .unwrap();
    bencher.bench(|| {
        let run = pipeline::run_figures(&w, &r, &[], "small", &RunOptions::default()).unwrap();
        assert!(run.report.executed(&run.graph).is_empty());
    });
}

/// A root whose ci profile has `points` independent simulations of equal cost.
fn sims_root(points: usize) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    let phis: Vec<String> = (0..points)
        .map(|i| format!("{}", 0.7 + 0.01 * i as f64))
        .collect();
    write(
        d.path(),
        "experiments/e.yaml",
        &format!(
            "description: d\nkind: toy_simulate\nseed: 1\nprofiles:\n  ci:\n    grid:\n      phi: [{}]\n    replicas: 1\n    params: {{n: 2000, work: 40000}}\n",
            phis.join(", ")
        ),
    );
    write(
        d.path(),
        "pipelines/p.yaml",
        "description: d\nstages:\n  - name: t\n    kind: table\n    gather: [e]\n",
    );
    d
}

fn sims(bencher: divan::Bencher, points: usize, jobs: usize) {
    let d = sims_root(points);
    let r = reg();
    let w = Workspace::new(d.path());
    let o = RunOptions {
        jobs,
        force: vec!["toy_simulate".into()],
        progress: false,
    };
    bencher.bench(|| {
        pipeline::run_figures(&w, &r, &[], "ci", &o)
            .unwrap()
            .check()
            .unwrap()
    });
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn one_sim_one_job(bencher: divan::Bencher) {
    sims(bencher, 1, 1);
}

#[divan::bench(sample_count = 5, sample_size = 1)]
fn two_sims_two_jobs(bencher: divan::Bencher) {
    sims(bencher, 2, 2);
}
