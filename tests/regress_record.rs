//! `repro regress --record` never loses bands: when no master seed builds a
//! figure (here every build fails on a pipeline that does not parse), it
//! exits with an error and leaves the golden file as it was.

use std::path::Path;
use std::process::Command;

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn a_recording_no_seed_builds_leaves_the_golden_file_alone() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    for d in ["experiments", "pipelines", "tests/golden"] {
        copy_dir(&src.join(d), &root.join(d));
    }
    // Another pipeline, mid-edit: an alias to no anchor.
    std::fs::write(
        root.join("pipelines/fig3.yaml"),
        "description: d\nstages: *nowhere\n",
    )
    .unwrap();
    let golden = root.join("tests/golden/ci.json");
    let before = std::fs::read(&golden).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_repro"))
        .args([
            "regress",
            "--record",
            "--profile",
            "ci",
            "--seeds",
            "11,12",
            "fig13",
            "--root",
        ])
        .arg(root)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(err.contains("no master seed built fig13"), "{err}");
    assert!(err.contains("pipelines/fig3.yaml"), "{err}");
    assert_eq!(
        std::fs::read(&golden).unwrap(),
        before,
        "the golden file changed"
    );
}
