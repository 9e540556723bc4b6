//! Code fingerprints: [`fingerprint::Sources`] of `src/` and `Cargo.lock` (every
//! module's hash, the modules it imports, the crates it names, the lock's
//! packages), written to `$OUT_DIR/sources.txt` for the library to derive each
//! stage kind's fingerprint from, with the compiler's version (in every key, and
//! as `REPRO_RUSTC_VERSION` for provenance).
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

#[allow(dead_code)]
#[path = "src/pipeline/fingerprint.rs"]
mod fingerprint;

fn main() {
    let mut sources = fingerprint::Sources::read(Path::new("src"), Path::new("Cargo.lock"));
    // Any change below src/ reruns this script (cargo checks mtimes recursively),
    // so does a change of the lock or of a file a source includes.
    println!("cargo:rerun-if-changed=src");
    println!("cargo:rerun-if-changed=Cargo.lock");
    println!("cargo:rerun-if-changed=assets");
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_else(|| "unknown".into());
    println!("cargo:rustc-env=REPRO_RUSTC_VERSION={version}");
    // The compiler enters every key.
    sources.rustc = version;
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    fs::write(out.join("sources.txt"), sources.to_text()).unwrap();
}
