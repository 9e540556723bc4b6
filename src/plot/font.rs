//! The embedded font: DejaVu Sans (assets/DejaVuSans.LICENSE), so figures look the
//! same on every machine and no fontconfig is needed. It covers the symbols the
//! papers use: Greek (τ α χ φ ξ γ ε η κ ρ), sub- and superscript digits, − ≈ ≤ √.

use std::sync::OnceLock;

use anyhow::{Result, anyhow};

static DEJAVU_SANS: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");

/// Register the font under "sans-serif" (the family SVG output names) once.
pub fn register() -> Result<()> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(
            "sans-serif",
            plotters::style::FontStyle::Normal,
            DEJAVU_SANS,
        )
        .is_ok()
    });
    ok.then_some(())
        .ok_or_else(|| anyhow!("the embedded DejaVu Sans font could not be parsed"))
}
