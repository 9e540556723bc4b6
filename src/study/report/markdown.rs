//! The report as Markdown: `results/REPORT.md` and `docs/report-PROFILE.md`.

use std::fmt::Write as _;

use std::path::Path;

use anyhow::{Context, Result};

use super::{Report, Written, collect, error, number, plain, utc};

/// Markdown table cells must not contain `|`.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

fn short(commit: &Option<String>) -> String {
    commit
        .as_deref()
        .map(|c| format!("`{}`", &c[..c.len().min(12)]))
        .unwrap_or_else(|| "—".into())
}

/// The report as Markdown; `image(id)` is the link to figure `id`'s PNG.
pub fn render(report: &Report, image: impl Fn(&str) -> String) -> String {
    let (profile, generated, frontier) = (&report.profile, report.generated, &report.frontier);
    let figs: Vec<_> = report.built().collect();
    let mut s = String::new();
    let _ = writeln!(s, "# Key numbers and figures, profile `{profile}`\n");
    let _ = writeln!(
        s,
        "Written by `repro report --profile {profile}` on {} from the built figures \
         (`results/ID/compare.parquet`, the fit tables, `provenance.json`). \
         Do not edit: rebuild the figures and rerun the command.\n",
        utc(generated)
    );
    let _ = writeln!(s, "| figure | built | commit | CPU s (all stages) |");
    let _ = writeln!(s, "|---|---|---|---|");
    for f in &figs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} |",
            f.id,
            utc(f.provenance.written),
            short(&f.provenance.commit),
            f.provenance.cpu_s
        );
    }
    let missing: Vec<&str> = report
        .entries
        .iter()
        .filter(|e| e.built.is_none())
        .map(|e| e.id.as_str())
        .collect();
    if !missing.is_empty() {
        let _ = writeln!(
            s,
            "\nNot built at profile `{profile}`: {}.",
            missing.join(", ")
        );
    }
    let _ = writeln!(s, "\n## Key numbers against the paper\n");
    let _ = writeln!(
        s,
        "ours +- error is the fit's quoted 1-sigma error; tolerance is the largest \
         accepted |ours - paper|; source says whether paper H measures its value in a \
         figure or quotes it from its reference 12.\n"
    );
    let _ = writeln!(
        s,
        "| figure | quantity | ours | error | paper | source | tolerance | verdict | reason |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
    for f in &figs {
        for c in &f.compared {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                f.id,
                cell(&c.quantity),
                number(c.ours, c.ours_err),
                error(c.ours_err),
                plain(c.paper),
                crate::stages::compare::source_label(c),
                plain(c.tolerance),
                c.verdict,
                cell(&c.reason)
            );
        }
    }
    let _ = writeln!(s, "\n## Other fitted numbers\n");
    let _ = writeln!(s, "| figure | quantity | value | error |");
    let _ = writeln!(s, "|---|---|---|---|");
    for f in &figs {
        for (q, v) in &f.others {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                f.id,
                cell(q),
                number(v.value, v.error),
                error(v.error)
            );
        }
    }
    let grouped: Vec<String> = figs
        .iter()
        .filter(|f| !f.grouped.is_empty())
        .map(|f| format!("{}: {}", f.id, f.grouped.join(", ")))
        .collect();
    if !grouped.is_empty() {
        let _ = writeln!(
            s,
            "\nFitted once per group (per phi, eta, force, ...), in each figure's fit tables (`results/ID/`), not listed above: {}.",
            grouped.join("; ")
        );
    }
    if !frontier.is_empty() {
        let _ = writeln!(s, "\n## Speed against accuracy (`repro frontier`)\n");
        let _ = writeln!(
            s,
            "mean +- seed-to-seed standard deviation over the master seeds of each configuration.\n"
        );
        for (id, rows) in frontier {
            let _ = writeln!(s, "### {id}\n");
            let _ = writeln!(
                s,
                "| configuration | N | replicas | CPU s | trajectories (MB) | quantity | mean | spread | paper | seeds |"
            );
            let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
            for r in rows {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.0} | {:.1} | {} | {} | {} | {} | {} |",
                    if r.label.is_empty() { "base" } else { &r.label },
                    r.n,
                    r.replicas,
                    r.cpu_s,
                    r.trajectory_bytes / 1e6,
                    cell(&r.quantity),
                    number(r.mean, r.spread),
                    error(r.spread),
                    plain(r.paper),
                    r.values.len()
                );
            }
            let _ = writeln!(s);
        }
    }
    let _ = writeln!(s, "\n## Gallery\n");
    for f in &figs {
        let _ = writeln!(s, "### {}: {}\n", f.id, f.provenance.description);
        if f.png.is_some() {
            let _ = writeln!(s, "![{}]({})\n", f.id, image(&f.id));
        }
        let verdicts: Vec<String> = f
            .compared
            .iter()
            .map(|c| {
                format!(
                    "{} = {} ({})",
                    c.quantity,
                    number(c.ours, c.ours_err),
                    c.verdict
                )
            })
            .collect();
        if !verdicts.is_empty() {
            let _ = writeln!(s, "{}\n", verdicts.join("; "));
        }
    }
    s
}

/// Write `results/REPORT.md` from the figures under `root/results` (profile
/// `profile`, or the one they share); with `docs`, also `root/docs/report-PROFILE.md`
/// and the PNGs as `root/docs/img/ID-PROFILE.png`.
pub fn write(root: &Path, results: &Path, profile: Option<&str>, docs: bool) -> Result<Written> {
    let report = collect(root, results, profile)?;
    write_markdown(&report, root, results, docs)
}

/// Write the Markdown renderings of `report` (see [`write`]).
pub fn write_markdown(report: &Report, root: &Path, results: &Path, docs: bool) -> Result<Written> {
    let profile = &report.profile;
    let mut files = Vec::new();
    let here = results.join("REPORT.md");
    let md = render(report, |id| format!("{id}/figure.png"));
    crate::table::write_atomic(&here, md.as_bytes())?;
    files.push(here);
    let headline = super::headline::render(report);
    let here = results.join("HEADLINE.md");
    crate::table::write_atomic(&here, headline.as_bytes())?;
    files.push(here);
    if docs {
        let img = root.join("docs").join("img");
        std::fs::create_dir_all(&img).with_context(|| format!("creating {}", img.display()))?;
        for f in report.built() {
            if let Some(png) = &f.png {
                let to = img.join(format!("{}-{profile}.png", f.id));
                std::fs::copy(png, &to)
                    .with_context(|| format!("copying {} to {}", png.display(), to.display()))?;
            }
        }
        let doc = root.join("docs").join(format!("report-{profile}.md"));
        let md = render(report, |id| format!("img/{id}-{profile}.png"));
        crate::table::write_atomic(&doc, md.as_bytes())?;
        files.push(doc);
        let doc = root.join("docs").join(format!("headline-{profile}.md"));
        crate::table::write_atomic(&doc, headline.as_bytes())?;
        files.push(doc);
    }
    Ok(Written {
        profile: profile.clone(),
        files,
        figures: report.built().count(),
    })
}
