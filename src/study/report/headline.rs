//! Paper H's headline numbers in one table (`results/HEADLINE.md`, and with
//! `--docs` `docs/headline-PROFILE.md`): ours, the paper's, where the paper's
//! comes from (its own figure or its reference 12), the verdict and, where we
//! do not agree, the measurement behind it.

use std::fmt::Write as _;

use super::{FigureReport, Report, error, number, plain, utc};

/// One headline number: what the paper calls it, and the figure and quantity
/// that hold ours.
struct Headline {
    label: &'static str,
    figure: &'static str,
    quantity: &'static str,
}

const fn h(label: &'static str, figure: &'static str, quantity: &'static str) -> Headline {
    Headline {
        label,
        figure,
        quantity,
    }
}

/// The numbers paper H's abstract, text and captions state, in its order.
const HEADLINES: [Headline; 16] = [
    h("φ_c (free power law of τ_α, Fig. 4)", "fig4", "phi_c"),
    h("φ_c (joint fit of τ_α, χ4, ξ)", "fig4", "phi_c_joint"),
    h("φ_c (free power law of ξ alone)", "fig4", "phi_c_free_xi"),
    h(
        "φ_c (free power law of χ4(τ_α) alone)",
        "fig4",
        "phi_c_free_chi4",
    ),
    h("φ_0 (VFT of τ_α, Fig. 4)", "fig4", "phi_0"),
    h("γ_τ (free power law of τ_α)", "fig4", "gamma_tau"),
    h(
        "γ_τ (φ_c = 0.82 held, top points)",
        "fig4",
        "gamma_tau_held",
    ),
    h("γ_χ (φ_c of the joint fit)", "fig15", "gamma_chi"),
    h("γ_χ (φ_c = 0.82 held)", "fig15", "gamma_chi_held"),
    h("γ_ξ (φ_c of the joint fit)", "fig17", "gamma_xi"),
    h("γ_ξ (φ_c = 0.82 held)", "fig17", "gamma_xi_held"),
    h("d_f′ (χ4 ∝ ξ^d_f′, Fig. 18)", "fig18", "d_f"),
    h(
        "τ4 exponent (τ4 ∝ τ_α^x, Fig. 15 inset)",
        "fig15",
        "tau4_exponent",
    ),
    h("κ (P(N_c) ∝ N_c^−κ, Fig. 13)", "fig13", "kappa"),
    h("ρ (N* ∝ (φ_c − φ)^−1/ρ, Fig. 13)", "fig13", "rho"),
    h("−θ (Fig. 9)", "fig9", "minus_theta"),
];

/// Cluster shapes, quoted as 1/d_f by the fits of Fig. 11 and −θ′ of Fig. 9.
const SHAPES: [Headline; 3] = [
    h("−θ′ (Fig. 9)", "fig9", "minus_theta_prime"),
    h("1/d_f, slow clusters (Fig. 11)", "fig11", "inv_df_slow"),
    h("1/d_f, fast clusters (Fig. 11)", "fig11", "inv_df_fast"),
];

/// Markdown cells must not contain `|`.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// One row of the table: ours, paper, source, verdict, reason.
fn row(figs: &[&FigureReport], hl: &Headline) -> String {
    let fig = figs.iter().find(|f| f.id == hl.figure);
    let compared = fig.and_then(|f| f.compared.iter().find(|c| c.quantity == hl.quantity));
    let other = fig.and_then(|f| f.others.iter().find(|(q, _)| q == hl.quantity));
    let cells = match (fig, compared, other) {
        (None, ..) => [
            "—".into(),
            "—".into(),
            "—".into(),
            "not built".into(),
            String::new(),
        ],
        (Some(_), Some(c), _) => [
            format!("{} ({})", number(c.ours, c.ours_err), error(c.ours_err)),
            plain(c.paper),
            crate::stages::compare::source_label(c).to_string(),
            c.verdict.label().to_string(),
            // The measurement behind a verdict other than agreement.
            if c.verdict == "agree" {
                String::new()
            } else {
                cell(&c.reason)
            },
        ],
        (Some(_), None, Some((_, v))) => [
            format!("{} ({})", number(v.value, v.error), error(v.error)),
            "not quoted".into(),
            "—".into(),
            "—".into(),
            String::new(),
        ],
        (Some(_), None, None) => [
            "—".into(),
            "—".into(),
            "—".into(),
            "missing".into(),
            format!("{} reports no '{}'", hl.figure, hl.quantity),
        ],
    };
    format!(
        "| {} | {} | `{}` | {} |",
        hl.label,
        hl.figure,
        hl.quantity,
        cells.join(" | ")
    )
}

/// The headline table of `report`.
pub fn render(report: &Report) -> String {
    let figs: Vec<&FigureReport> = report.built().collect();
    let profile = &report.profile;
    let mut s = String::new();
    let _ = writeln!(s, "# Paper H's headline numbers, profile `{profile}`\n");
    let _ = writeln!(
        s,
        "Written by `repro report --profile {profile} --docs` on {} from the built figures' \
         compare and fit tables. Do not edit: rebuild the figures and rerun the command. \
         A paper value quoted from paper H's reference 12 was measured there, with that \
         paper's data, sizes and fit ranges; agreeing with it is a different claim from \
         agreeing with a value paper H measures in its own figures.\n",
        utc(report.generated)
    );
    let _ = writeln!(
        s,
        "| number | figure | quantity | ours (error) | paper | paper's source | verdict | reason |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for hl in HEADLINES.iter().chain(&SHAPES) {
        let _ = writeln!(s, "{}", row(&figs, hl));
    }
    s
}
