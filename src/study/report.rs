//! `repro report`: the gallery and the table of every key number, written from
//! the built figures (`results/ID/compare.parquet`, the fit tables, the figure
//! PNGs and provenance.json) so that no number is typed by hand.
//!
//! Two copies: `results/REPORT.md` (images linked in place) and, on request,
//! `docs/report-PROFILE.md` with the PNGs copied to `docs/img/ID-PROFILE.png`,
//! for the README to link.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::{Context, Result, bail};

use super::frontier::FrontierRow;
use super::results::{Compared, Fitted, Provenance, fitted, provenance, read_compare};

/// One built figure as the report shows it.
pub struct FigureReport {
    pub id: String,
    pub provenance: Provenance,
    pub compared: Vec<Compared>,
    /// Fitted numbers of the figure that are not compared with the paper.
    pub others: Vec<(String, Fitted)>,
    /// `results/ID/figure.png`, if drawn.
    pub png: Option<PathBuf>,
}

/// Every figure under `results` built at `profile` (at the one profile they
/// share if None), in id order.
pub fn collect(results: &Path, profile: Option<&str>) -> Result<(String, Vec<FigureReport>)> {
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(results)
        .with_context(|| {
            format!(
                "listing {}: build figures first (`repro figure ...`)",
                results.display()
            )
        })?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.join("provenance.json").is_file())
        .collect();
    dirs.sort_by_key(|p| fig_order(&p.file_name().unwrap_or_default().to_string_lossy()));
    let mut all = Vec::new();
    for d in dirs {
        let prov = provenance(&d)?;
        all.push((d, prov));
    }
    let mut profiles: Vec<String> = all.iter().map(|(_, p)| p.profile.clone()).collect();
    profiles.sort();
    profiles.dedup();
    let profile = match profile {
        Some(p) => p.to_string(),
        None => match profiles.as_slice() {
            [one] => one.to_string(),
            [] => bail!(
                "no built figure (compare.parquet and provenance.json) under {}",
                results.display()
            ),
            many => bail!(
                "the figures under {} were built at several profiles ({}): choose one with --profile",
                results.display(),
                many.join(", ")
            ),
        },
    };
    let mut out = Vec::new();
    for (d, prov) in all.into_iter().filter(|(_, p)| p.profile == profile) {
        // A figure without paper values (e.g. a qualitative one) has no compare table.
        let compared = if d.join("compare.parquet").is_file() {
            read_compare(&d)?
        } else {
            Vec::new()
        };
        let others = fitted(&d)?
            .into_iter()
            .filter(|(q, _)| !compared.iter().any(|c| &c.quantity == q))
            .collect();
        let png = d.join("figure.png");
        out.push(FigureReport {
            id: d
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
            provenance: prov,
            compared,
            others,
            png: png.is_file().then_some(png),
        });
    }
    if out.is_empty() {
        bail!(
            "no figure under {} was built at profile '{profile}' (built: {}); run `repro figure ID --profile {profile}`",
            results.display(),
            if profiles.is_empty() {
                "none".to_string()
            } else {
                profiles.join(", ")
            }
        );
    }
    Ok((profile, out))
}

/// fig2 before fig15 (numeric order of the trailing number), then by name.
fn fig_order(id: &str) -> (String, u64, String) {
    let stem = id.trim_end_matches(|c: char| c.is_ascii_digit());
    let n = id[stem.len()..].parse().unwrap_or(u64::MAX);
    (stem.to_string(), n, id.to_string())
}

/// `v` to the precision of `err` (two significant digits of the error), or to
/// four significant digits when there is no error.
pub fn number(v: f64, err: f64) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    let a = v.abs();
    let has_err = err.is_finite() && err > 0.0;
    if a >= 1e5 || (a != 0.0 && a < 1e-3 && !has_err) {
        return format!("{v:.3e}");
    }
    if !has_err && v.fract() == 0.0 {
        return format!("{v:.0}");
    }
    let digits = if has_err {
        1 - err.log10().floor() as i32
    } else if a == 0.0 {
        1
    } else {
        3 - a.log10().floor() as i32
    };
    format!("{v:.*}", digits.clamp(0, 8) as usize)
}

fn error(err: f64) -> String {
    if err.is_finite() && err > 0.0 {
        number(err, err)
    } else {
        "—".into()
    }
}

/// Markdown table cells must not contain `|`.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

/// A time as `YYYY-MM-DD HH:MM UTC`.
pub fn utc(t: SystemTime) -> String {
    let s = t
        .duration_since(SystemTime::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    let (days, rem) = (s.div_euclid(86_400), s.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02} {:02}:{:02} UTC",
        rem / 3600,
        rem % 3600 / 60
    )
}

fn short(commit: &Option<String>) -> String {
    commit
        .as_deref()
        .map(|c| format!("`{}`", &c[..c.len().min(12)]))
        .unwrap_or_else(|| "—".into())
}

/// The report as Markdown; `image(id)` is the link to figure `id`'s PNG.
pub fn render(
    profile: &str,
    figs: &[FigureReport],
    frontier: &[(String, Vec<FrontierRow>)],
    generated: SystemTime,
    image: impl Fn(&str) -> String,
) -> String {
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
    for f in figs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.0} |",
            f.id,
            utc(f.provenance.written),
            short(&f.provenance.commit),
            f.provenance.cpu_s
        );
    }
    let _ = writeln!(s, "\n## Key numbers against the paper\n");
    let _ = writeln!(
        s,
        "ours +- error is the fit's quoted 1-sigma error; tolerance is the largest \
         accepted |ours - paper|.\n"
    );
    let _ = writeln!(
        s,
        "| figure | quantity | ours | error | paper | tolerance | verdict | reason |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|");
    for f in figs {
        for c in &f.compared {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} |",
                f.id,
                cell(&c.quantity),
                number(c.ours, c.ours_err),
                error(c.ours_err),
                c.paper,
                c.tolerance,
                c.verdict,
                cell(&c.reason)
            );
        }
    }
    let _ = writeln!(s, "\n## Other fitted numbers\n");
    let _ = writeln!(s, "| figure | quantity | value | error |");
    let _ = writeln!(s, "|---|---|---|---|");
    for f in figs {
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
                    r.paper,
                    r.values.len()
                );
            }
            let _ = writeln!(s);
        }
    }
    let _ = writeln!(s, "\n## Gallery\n");
    for f in figs {
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

/// `results/frontier/ID-PROFILE.json` of every figure, if any.
fn frontier_tables(
    results: &Path,
    profile: &str,
    ids: &[&str],
) -> Result<Vec<(String, Vec<FrontierRow>)>> {
    let mut out = Vec::new();
    for id in ids {
        let p = results
            .join("frontier")
            .join(format!("{id}-{profile}.json"));
        if let Ok(bytes) = std::fs::read(&p) {
            let rows: Vec<FrontierRow> = serde_json::from_slice(&bytes)
                .with_context(|| format!("parsing {}", p.display()))?;
            out.push((id.to_string(), rows));
        }
    }
    Ok(out)
}

/// Where `write` put the reports.
#[derive(Debug)]
pub struct Written {
    pub profile: String,
    pub files: Vec<PathBuf>,
    pub figures: usize,
}

/// Write `results/REPORT.md` from the figures under `root/results` (profile
/// `profile`, or the one they share); with `docs`, also `root/docs/report-PROFILE.md`
/// and the PNGs as `root/docs/img/ID-PROFILE.png`.
pub fn write(root: &Path, results: &Path, profile: Option<&str>, docs: bool) -> Result<Written> {
    let (profile, figs) = collect(results, profile)?;
    let ids: Vec<&str> = figs.iter().map(|f| f.id.as_str()).collect();
    let frontier = frontier_tables(results, &profile, &ids)?;
    let now = SystemTime::now();
    let mut files = Vec::new();
    let here = results.join("REPORT.md");
    let md = render(&profile, &figs, &frontier, now, |id| {
        format!("{id}/figure.png")
    });
    crate::table::write_atomic(&here, md.as_bytes())?;
    files.push(here);
    if docs {
        let img = root.join("docs").join("img");
        std::fs::create_dir_all(&img).with_context(|| format!("creating {}", img.display()))?;
        for f in &figs {
            if let Some(png) = &f.png {
                let to = img.join(format!("{}-{profile}.png", f.id));
                std::fs::copy(png, &to)
                    .with_context(|| format!("copying {} to {}", png.display(), to.display()))?;
            }
        }
        let doc = root.join("docs").join(format!("report-{profile}.md"));
        let md = render(&profile, &figs, &frontier, now, |id| {
            format!("img/{id}-{profile}.png")
        });
        crate::table::write_atomic(&doc, md.as_bytes())?;
        files.push(doc);
    }
    Ok(Written {
        profile,
        files,
        figures: figs.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A built figure with one compared number, as the `compare` stage writes it.
    fn built(results: &Path, id: &str, profile: &str, ours: f64, err: f64) {
        let d = results.join(id);
        std::fs::create_dir_all(&d).unwrap();
        let b = crate::table::results::CompareColumns {
            quantity: vec!["phi_0".into()],
            ours: vec![ours],
            ours_err: vec![err],
            paper: vec![0.83],
            tolerance: vec![0.01],
            verdict: vec!["agree".into()],
            reason: vec!["|a - b| <= c".into()],
        }
        .batch()
        .unwrap();
        crate::table::write_parquet(&d.join("compare.parquet"), &[b], &[]).unwrap();
        let prov = serde_json::json!({
            "figure": id, "description": "test figure", "profile": profile,
            "git_commit": "0123456789abcdef", "stages": [{"cpu_s": 2.5}, {"cpu_s": 1.5}],
        });
        std::fs::write(d.join("provenance.json"), prov.to_string()).unwrap();
    }

    #[test]
    fn the_report_is_written_from_the_compare_tables() {
        let dir = tempfile::tempdir().unwrap();
        let results = dir.path().join("results");
        built(&results, "fig4", "ci", 0.81234, 0.0021);
        let w = write(dir.path(), &results, None, true).unwrap();
        assert_eq!((w.profile.as_str(), w.figures), ("ci", 1));
        let md = std::fs::read_to_string(results.join("REPORT.md")).unwrap();
        assert!(
            md.contains("| fig4 | phi_0 | 0.8123 | 0.0021 | 0.83 | 0.01 | agree |"),
            "{md}"
        );
        assert!(md.contains("`0123456789ab`"), "commit: {md}");
        assert!(md.contains("| 4 |"), "CPU seconds of all stages: {md}");
        assert!(md.contains("\\|a - b\\|"), "pipes escaped: {md}");
        assert!(dir.path().join("docs/report-ci.md").is_file());

        // Change the number in the compare table: the report follows.
        built(&results, "fig4", "ci", 0.7345, 0.0004);
        write(dir.path(), &results, Some("ci"), false).unwrap();
        let md = std::fs::read_to_string(results.join("REPORT.md")).unwrap();
        assert!(md.contains("| fig4 | phi_0 | 0.73450 | 0.00040 |"), "{md}");
        assert!(!md.contains("0.8123"), "{md}");
    }

    #[test]
    fn a_figure_without_paper_values_is_in_the_gallery() {
        let dir = tempfile::tempdir().unwrap();
        let results = dir.path().join("results");
        built(&results, "fig4", "ci", 0.8, 0.01);
        built(&results, "fig3", "ci", 0.8, 0.01);
        std::fs::remove_file(results.join("fig3/compare.parquet")).unwrap();
        std::fs::write(results.join("fig3/figure.png"), b"png").unwrap();
        write(dir.path(), &results, None, true).unwrap();
        let md = std::fs::read_to_string(dir.path().join("docs/report-ci.md")).unwrap();
        assert!(md.contains("![fig3](img/fig3-ci.png)"), "{md}");
        assert!(
            md.find("### fig3").unwrap() < md.find("### fig4").unwrap(),
            "{md}"
        );
        assert!(dir.path().join("docs/img/fig3-ci.png").is_file());
    }

    #[test]
    fn figures_of_another_profile_are_left_out_or_named() {
        let dir = tempfile::tempdir().unwrap();
        let results = dir.path().join("results");
        built(&results, "fig15", "ci", 1.2, 0.1);
        built(&results, "fig2", "small", 0.5, 0.1);
        let e = write(dir.path(), &results, None, false).unwrap_err();
        assert!(
            e.to_string().contains("several profiles (ci, small)"),
            "{e}"
        );
        let e = write(dir.path(), &results, Some("paper"), false).unwrap_err();
        assert!(
            e.to_string().contains("no figure") && e.to_string().contains("'paper'"),
            "{e}"
        );
        let w = write(dir.path(), &results, Some("small"), false).unwrap();
        assert_eq!(w.figures, 1);
        let md = std::fs::read_to_string(results.join("REPORT.md")).unwrap();
        assert!(md.contains("| fig2 |") && !md.contains("| fig15 |"), "{md}");
    }

    #[test]
    fn numbers_carry_the_precision_of_their_error() {
        assert_eq!(number(0.812345, 0.0021), "0.8123");
        assert_eq!(number(1.19, f64::NAN), "1.190");
        assert_eq!(number(241.3, 12.0), "241");
        assert_eq!(number(f64::NAN, 1.0), "—");
        assert_eq!(number(8.0, f64::NAN), "8", "counts stay integers");
        assert_eq!(number(2.5e-5, f64::NAN), "2.500e-5");
        assert_eq!(
            utc(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_795_000_000)),
            "2026-11-18 11:06 UTC"
        );
    }
}
