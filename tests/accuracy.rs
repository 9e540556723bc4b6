//! Do the quoted errors of the committed goldens mean what they say? Over the
//! recorded master seeds (tests/golden/ci.json, `repro regress --record`), the
//! quoted 1-sigma interval of each seed must cover the all-seed mean in roughly
//! 68% of seeds: errors several times too small (fit covariances over
//! correlated points) cover far fewer, errors far too large cover all.

use std::path::Path;

use repro::study::coverage::from_golden;
use repro::study::golden::GoldenFile;

/// Coverage bounds: with twenty seeds an honest error covers 13.6 +- 2.1 of them.
const RANGE: (f64, f64) = (0.40, 0.95);

fn ci() -> GoldenFile {
    GoldenFile::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/ci.json")).unwrap()
}

fn covered(g: &GoldenFile, figure: &str, quantity: &str) -> (f64, f64) {
    let q = g
        .quantities
        .iter()
        .find(|q| q.figure == figure && q.quantity == quantity)
        .unwrap_or_else(|| panic!("tests/golden/ci.json has no {figure} {quantity}"));
    assert_eq!(
        q.errors.len(),
        q.values.len(),
        "{figure} {quantity}: the golden file records no per-seed quoted errors; \
         re-record with `repro regress --record --profile ci --seeds 11,...,30`"
    );
    let c = from_golden(g, &[figure.to_string()])
        .into_iter()
        .find(|c| c.quantity == quantity)
        .unwrap_or_else(|| panic!("{figure} {quantity}: fewer than two seeds quote an error"));
    assert!(c.seeds >= 8, "{figure} {quantity}: only {} seeds", c.seeds);
    (c.coverage, c.ratio)
}

#[test]
fn quoted_errors_cover_the_seed_to_seed_scatter() {
    let g = ci();
    for (figure, quantity) in [
        ("fig4", "tau_alpha_070"),
        ("fig4", "tau_alpha_076"),
        ("fig4", "tau_alpha_078"),
        // The tau_alpha fits across state points (replica jackknife).
        ("fig4", "phi_c"),
        ("fig4", "phi_0"),
        ("fig4", "gamma_tau"),
        // Read off the peak of chi4(t) (interpolated between lags).
        ("fig15", "tau4_exponent"),
        // Fits on one state point each (Eq. 8 per phi, the van Hove Gaussian),
        // scaled over a stage's fits, and the fits across them.
        ("fig6", "beta_exponent"),
        ("fig6", "A_beta"),
        ("fig8", "D_gauss"),
        ("fig8", "x0_078_tau"),
        // Fits of P(Nc) with replica samples of the histogram.
        ("fig12", "minus_kappa"),
        ("fig14", "sigma"),
        // Paper I: velocities with replica samples; Fig. 5's fits of a rough
        // collapse with a relative model scatter.
        ("intruder-fig6", "v_ratio_0775"),
        ("intruder-fig5", "beta"),
        ("intruder-fig5", "beta_collapse"),
        // A ratio of two independent measurements (mu from F > 0, mu_E at F = 0).
        ("intruder-fig3", "mu_over_einstein_030"),
    ] {
        let (cov, ratio) = covered(&g, figure, quantity);
        assert!(
            (RANGE.0..=RANGE.1).contains(&cov),
            "{figure} {quantity}: the quoted 1-sigma errors cover the recorded seeds' mean in {:.0}% of seeds \
             (quoted / seed-to-seed spread = {ratio:.2}); honest errors cover about 68%",
            100.0 * cov
        );
    }
}
