//! docs/tutorial.md runs: its `sh` blocks, in order, in an empty directory,
//! with `repro` and the Python of `make venv` (`.repro/venv/bin`) on PATH; and
//! what the text says they show, they show.
//!
//! Without that Python (no `make venv`) it prints SKIPPED and passes, unless
//! `REPRO_REQUIRE_VENV=1` (set by `make test`, which installs it first).

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The fenced blocks of `text` whose language is `lang`.
fn blocks(text: &str, lang: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match &mut current {
            None if line.trim_start() == format!("```{lang}") => current = Some(String::new()),
            Some(b) if line.trim_start() == "```" => {
                out.push(std::mem::take(b));
                current = None;
            }
            Some(b) => {
                b.push_str(line);
                b.push('\n');
            }
            None => {}
        }
    }
    out
}

#[test]
fn blocks_are_the_fenced_sh_only() {
    let text = "a\n```sh\necho 1\ncat <<'EOF'\nx\nEOF\n```\n```text\nno\n```\n```sh\necho 2\n```\n";
    assert_eq!(
        blocks(text, "sh"),
        ["echo 1\ncat <<'EOF'\nx\nEOF\n", "echo 2\n"]
    );
}

/// Each block's output, the blocks run as one script so `cd` carries over.
fn run_tutorial(dir: &Path, venv: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(root().join("docs/tutorial.md")).unwrap();
    let sh = blocks(&text, "sh");
    assert!(
        sh.len() >= 6,
        "docs/tutorial.md lost its commands: {} sh blocks",
        sh.len()
    );
    let marker = "=== tutorial block ===";
    let script: String = sh.iter().map(|b| format!("echo '{marker}'\n{b}")).collect();
    let bin = Path::new(env!("CARGO_BIN_EXE_repro"))
        .parent()
        .unwrap()
        .to_path_buf();
    let path = std::env::join_paths([bin, venv.to_path_buf()].into_iter().chain(
        std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()),
    ))
    .unwrap();
    let out = Command::new("bash")
        .args(["-euo", "pipefail", "-c", &script])
        .current_dir(dir)
        .env("PATH", path)
        .env_remove("REPRO_ROOT")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "docs/tutorial.md failed ({}):\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout.split(marker).skip(1).map(str::to_string).collect()
}

#[test]
fn the_tutorial_runs_and_shows_what_it_says() {
    let venv = root().join(".repro/venv/bin");
    if !venv.join("python3").exists() {
        if std::env::var("REPRO_REQUIRE_VENV").is_ok_and(|v| v == "1") {
            panic!(
                "REPRO_REQUIRE_VENV=1 but {} has no python3 (make venv)",
                venv.display()
            );
        }
        eprintln!(
            "SKIPPED the_tutorial_runs_and_shows_what_it_says: no {} (make venv)",
            venv.display()
        );
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = run_tutorial(dir.path(), &venv);
    let mine = dir.path().join("mine");
    for f in [
        "msd_table.parquet",
        "q_table.parquet",
        "figure.png",
        "provenance.json",
    ] {
        assert!(
            mine.join("results/my-msd").join(f).exists(),
            "results/my-msd/{f} missing"
        );
    }
    let block = |words: &str| {
        out.iter()
            .find(|b| b.contains(words))
            .cloned()
            .unwrap_or_default()
    };
    // `why --set mine.n=300`: every simulation is stale (2 phi x 2 replicas).
    let what_if = out
        .iter()
        .find(|b| b.contains("stale by kind") && b.contains("simulate"))
        .expect("why --set");
    assert!(what_if.contains("4 simulate"), "{what_if}");
    // After the script edit: its two stages and what reads them (the table
    // and the figure script), no simulation and no built-in analysis.
    let edited = out
        .iter()
        .find(|b| b.contains("stale by kind: 3 script, 1 table\n"))
        .unwrap_or_else(|| {
            panic!(
                "no `stale by kind: 3 script, 1 table` after the edit:\n{}",
                out.join("\n")
            )
        });
    assert!(
        !edited.contains("simulate") && !edited.contains("overlap"),
        "{edited}"
    );
    assert!(
        edited.contains("what it reads outside the crate changed"),
        "{edited}"
    );
    // `runs --where phi=0.7`: its two replicas.
    assert!(
        block("run(s) of mine").contains("2 run(s) of mine at profile ci"),
        "{out:?}"
    );
    let runs: Vec<_> = std::fs::read_dir(mine.join("runs"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        runs.contains(&"mine_phi=0.7_replica=1.parquet".to_string()),
        "{runs:?}"
    );
    assert!(block("['frame'").contains("'x', 'y'"), "{out:?}");
}
