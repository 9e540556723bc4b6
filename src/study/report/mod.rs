//! `repro report`: the gallery and the table of every key number, written from
//! the built figures (`results/ID/compare.parquet`, the fit tables, the figure
//! files and provenance.json) so that no number is typed by hand.
//!
//! One model of the report ([`Report`]: every figure of the catalogue, built or
//! not, with what its directory holds) and two renderers of it:
//!
//! - [`markdown`]: `results/REPORT.md` (images linked in place) and, on request,
//!   `docs/report-PROFILE.md` with the PNGs copied to `docs/img/ID-PROFILE.png`,
//!   for the README to link;
//! - [`headline`]: paper H's headline numbers in one table, `results/HEADLINE.md`
//!   and, on request, `docs/headline-PROFILE.md`;
//! - [`html`]: `results/report/`, an index (scoreboard of every figure) and a
//!   page per figure, opened from the file system (no server, no network).

pub mod headline;
pub mod html;
pub mod markdown;

pub use markdown::{write, write_markdown};

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use anyhow::{Context, Result, bail};

use super::frontier::FrontierRow;
use super::results::{Compared, Fitted, Provenance, Tally, fitted, provenance, read_compare};

/// The whole report: every figure at one profile.
pub struct Report {
    pub profile: String,
    pub generated: SystemTime,
    /// Every figure of the catalogue and every built one, in figure order.
    pub entries: Vec<Entry>,
    /// `repro frontier` tables of the built figures that have one.
    pub frontier: Vec<(String, Vec<FrontierRow>)>,
    /// Their charts: file names in `results/frontier/`.
    pub frontier_charts: Vec<String>,
    /// The machine writing the report: host name and CPU count.
    pub machine: String,
}

impl Report {
    pub fn built(&self) -> impl Iterator<Item = &FigureReport> {
        self.entries.iter().filter_map(|e| e.built.as_ref())
    }

    /// The verdicts of every built figure.
    pub fn tally(&self) -> Tally {
        let mut t = Tally::default();
        for f in self.built() {
            t.add(&Tally::of(&f.compared));
        }
        t
    }
}

/// Which paper a figure reproduces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Paper {
    /// Dynamical heterogeneities in a 2D driven granular fluid.
    H,
    /// An intruder pulled through a dense granular fluid.
    I,
    /// Checks of the method, in no paper (stability-*).
    Checks,
}

impl Paper {
    /// From the figure id: `figN` is paper H, `intruder-figN` paper I.
    pub fn of(id: &str) -> Paper {
        if id.starts_with("intruder-") {
            Paper::I
        } else if id.starts_with("fig") {
            Paper::H
        } else {
            Paper::Checks
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Paper::H => "H",
            Paper::I => "I",
            Paper::Checks => "checks",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Paper::H => "paper H (dynamical heterogeneities)",
            Paper::I => "paper I (intruder)",
            Paper::Checks => "checks of the method",
        }
    }
}

/// One figure of the catalogue.
pub struct Entry {
    pub id: String,
    pub paper: Paper,
    /// What it shows, in a line (the pipeline's description).
    pub description: String,
    /// Its main table: the first published stage that says what it is in the
    /// paper (`describes`), else none.
    pub main_table: Option<String>,
    /// None when it is not built at the report's profile.
    pub built: Option<FigureReport>,
}

impl Entry {
    /// The paper's figure number: `Fig. 4`, `Fig. 17 (box)`; the id for checks.
    pub fn figure_number(&self) -> String {
        let bare = self.id.trim_start_matches("intruder-");
        match bare.strip_prefix("fig") {
            Some(rest) if self.paper != Paper::Checks => {
                let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
                let tail = &rest[digits.len()..];
                if tail.is_empty() {
                    format!("Fig. {digits}")
                } else {
                    format!("Fig. {digits} ({tail})")
                }
            }
            _ => self.id.clone(),
        }
    }
}

/// One built figure as the report shows it.
pub struct FigureReport {
    pub id: String,
    pub dir: PathBuf,
    pub provenance: Provenance,
    pub compared: Vec<Compared>,
    /// Fitted numbers of the figure that are not compared with the paper.
    pub others: Vec<(String, Fitted)>,
    /// Fitted quantities with one value per group (a `group_by` fit), not
    /// compared: named only, their values are in the figure's tables.
    pub grouped: Vec<String>,
    /// `results/ID/figure.png`, if drawn.
    pub png: Option<PathBuf>,
    /// `results/ID/figure.svg`, if drawn.
    pub svg: Option<PathBuf>,
    /// Every Parquet table of its directory.
    pub tables: Vec<TableInfo>,
}

/// A Parquet table of a built figure: its columns with unit and meaning.
pub struct TableInfo {
    /// File name inside the figure's directory.
    pub file: String,
    pub rows: usize,
    /// (name, type, unit, meaning).
    pub columns: Vec<(String, String, String, String)>,
}

fn table_info(path: &Path) -> Result<TableInfo> {
    let (batches, _) = crate::table::read_parquet(path)?;
    let columns = batches
        .first()
        .map(|b| {
            b.schema()
                .fields()
                .iter()
                .map(|f| {
                    let (unit, what) =
                        crate::table::columns::describe(f.name()).unwrap_or_default();
                    (f.name().clone(), f.data_type().to_string(), unit, what)
                })
                .collect()
        })
        .unwrap_or_default();
    Ok(TableInfo {
        file: path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned(),
        rows: batches.iter().map(|b| b.num_rows()).sum(),
        columns,
    })
}

/// The figures under `results` built at `profile` (at the one profile they
/// share if None), in id order, with the profile chosen.
fn built_figures(results: &Path, profile: Option<&str>) -> Result<(String, Vec<FigureReport>)> {
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
        let grouped = crate::study::results::grouped_quantities(&d)?;
        let others = fitted(&d)?
            .into_iter()
            .filter(|(q, _)| !compared.iter().any(|c| &c.quantity == q) && !grouped.contains(q))
            .collect();
        let grouped = grouped
            .into_iter()
            .filter(|q| !compared.iter().any(|c| &c.quantity == q))
            .collect();
        let mut parquet: Vec<PathBuf> = std::fs::read_dir(&d)
            .with_context(|| format!("listing {}", d.display()))?
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|x| x == "parquet"))
            .collect();
        parquet.sort();
        let tables = parquet
            .iter()
            .map(|p| table_info(p))
            .collect::<Result<Vec<_>>>()?;
        let file = |name: &str| Some(d.join(name)).filter(|p| p.is_file());
        out.push(FigureReport {
            id: d
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned(),
            png: file("figure.png"),
            svg: file("figure.svg"),
            dir: d,
            provenance: prov,
            compared,
            others,
            grouped,
            tables,
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
    // A number a figure only carries (a stage it shares, e.g. intruder-fig1's
    // front speeds) but another figure compares is listed there, with its
    // verdict, not again among the first one's other numbers.
    let compared_elsewhere: Vec<(String, String, f64)> = out
        .iter()
        .flat_map(|f| {
            f.compared
                .iter()
                .map(|c| (f.id.clone(), c.quantity.clone(), c.ours))
        })
        .collect();
    for f in &mut out {
        f.others.retain(|(q, v)| {
            !compared_elsewhere.iter().any(|(id, cq, ours)| {
                id != &f.id && cq == q && (ours == &v.value || ours.is_nan() && v.value.is_nan())
            })
        });
    }
    Ok((profile, out))
}

/// The report of the figures under `results` built at `profile` (or the one
/// profile they share), with every other figure of the catalogue under `root`
/// listed as not built.
pub fn collect(root: &Path, results: &Path, profile: Option<&str>) -> Result<Report> {
    let (profile, figs) = built_figures(results, profile)?;
    let catalogue = crate::pipeline::Catalogue::load(root)?;
    let mut entries: Vec<Entry> = catalogue
        .pipelines
        .iter()
        .map(|(id, (_, spec))| Entry {
            id: id.clone(),
            paper: Paper::of(id),
            description: spec.description.clone(),
            main_table: spec
                .stages
                .iter()
                .map(|s| &s.value)
                .find(|s| s.describes.is_some() && s.publish != Some(false))
                .map(|s| format!("{}.parquet", s.name)),
            built: None,
        })
        .collect();
    // The compare reasons name numbers by reference (docs/spec.md, "Numbers
    // in texts"): resolved now, from the store, at the report's profile.
    let reg = crate::stages::registry();
    let builds = super::built::Built::open(root, &reg, &profile)?;
    for e in &mut entries {
        e.description = builds.render(&e.id, &e.description)?;
    }
    for mut f in figs {
        for c in &mut f.compared {
            c.reason = builds
                .render(&f.id, &c.reason)
                .with_context(|| format!("the reason of {}", c.quantity))?;
        }
        f.provenance.description = builds.render(&f.id, &f.provenance.description)?;
        match entries.iter_mut().find(|e| e.id == f.id) {
            Some(e) => e.built = Some(f),
            None => entries.push(Entry {
                id: f.id.clone(),
                paper: Paper::of(&f.id),
                description: f.provenance.description.clone(),
                main_table: None,
                built: Some(f),
            }),
        }
    }
    for e in &mut entries {
        // The main table as built; compare.parquet when the figure has no other.
        let Some(f) = &e.built else { continue };
        let has = |name: &str| f.tables.iter().any(|t| t.file == name);
        if !e.main_table.as_deref().is_some_and(has) {
            e.main_table = ["compare.parquet"]
                .into_iter()
                .chain(f.tables.iter().map(|t| t.file.as_str()))
                .find(|t| has(*t))
                .map(String::from);
        }
    }
    entries.sort_by_key(|e| (paper_order(e.paper), fig_order(&e.id)));
    let ids: Vec<&str> = entries
        .iter()
        .filter(|e| e.built.is_some())
        .map(|e| e.id.as_str())
        .collect();
    let frontier = frontier_tables(results, &profile, &ids)?;
    let frontier_charts = frontier
        .iter()
        .map(|(id, _)| format!("{id}-{profile}.svg"))
        .filter(|c| results.join("frontier").join(c).is_file())
        .collect();
    Ok(Report {
        profile,
        generated: SystemTime::now(),
        entries,
        frontier,
        frontier_charts,
        machine: machine(),
    })
}

/// `host (N CPUs)`.
fn machine() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .unwrap_or_else(|_| "unknown host".into());
    let cpus = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!("{host} ({cpus} CPUs, {})", std::env::consts::OS)
}

fn paper_order(p: Paper) -> u8 {
    match p {
        Paper::H => 0,
        Paper::I => 1,
        Paper::Checks => 2,
    }
}

/// fig2 before fig15 (numeric order of the trailing number), then by name.
fn fig_order(id: &str) -> (String, u64, String) {
    let stem = id.trim_end_matches(|c: char| c.is_ascii_digit());
    let n = id[stem.len()..].parse().unwrap_or(u64::MAX);
    (stem.to_string(), n, id.to_string())
}

/// `v` to the precision of `err` (two significant digits of the error), or to
/// four significant digits when there is no error; never `-0.00`.
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
        return format!("{:.0}", v + 0.0);
    }
    // A small number measured to better than itself (an energy drift of
    // 3e-14 +- 1e-15) in the error's precision, but as a power of ten: fixed
    // point would print it as zeros.
    if has_err && a != 0.0 && (a < 1e-3 || err < 1e-8) && err < a {
        let mantissa = a.log10().floor() as i32 - err.log10().floor() as i32 + 1;
        return format!("{v:.*e}", mantissa.clamp(0, 8) as usize);
    }
    let digits = if has_err {
        1 - err.log10().floor() as i32
    } else if a == 0.0 {
        1
    } else {
        3 - a.log10().floor() as i32
    };
    let s = format!("{v:.*}", digits.clamp(0, 8) as usize);
    // A negative number rounded to zero is zero.
    match s.strip_prefix('-') {
        Some(z) if z.chars().all(|c| c == '0' || c == '.') => z.to_string(),
        _ => s,
    }
}

/// A value typed in a spec (the paper's number, a tolerance) as typed: the
/// shortest decimal that reads back as it, at most six significant digits.
pub fn plain(v: f64) -> String {
    if !v.is_finite() {
        return "—".into();
    }
    let s = format!("{}", v + 0.0);
    if s.len() <= 9 {
        return s;
    }
    let short = format!("{:.5e}", v);
    let back: f64 = short.parse().unwrap_or(v);
    let s = format!("{}", back + 0.0);
    if s.len() <= 12 {
        return s;
    }
    // 1e-10, not 1.00000e-10.
    match short.split_once('e') {
        Some((m, e)) => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
        None => short,
    }
}

pub(crate) fn error(err: f64) -> String {
    if err.is_finite() && err > 0.0 && err < 1e-4 {
        format!("{err:.1e}")
    } else if err.is_finite() && err > 0.0 {
        number(err, err)
    } else {
        "—".into()
    }
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
            source: vec![crate::table::results::Source::Figure],
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
            md.contains(
                "| fig4 | phi_0 | 0.8123 | 0.0021 | 0.83 | measured (figure) | 0.01 | agree |"
            ),
            "{md}"
        );
        assert!(md.contains("`0123456789ab`"), "commit: {md}");
        assert!(md.contains("| 4 |"), "CPU seconds of all stages: {md}");
        assert!(md.contains("\\|a - b\\|"), "pipes escaped: {md}");
        assert!(dir.path().join("docs/report-ci.md").is_file());
        // The headline table: the built number with its source, the rest named.
        let hl = std::fs::read_to_string(dir.path().join("docs/headline-ci.md")).unwrap();
        assert!(
            hl.contains("| fig4 | `phi_0` | 0.8123 (0.0021) | 0.83 | measured (figure) | agree |"),
            "{hl}"
        );
        assert!(
            hl.contains("| fig9 | `minus_theta` | — | — | — | not built |"),
            "{hl}"
        );
        assert!(hl.contains("fig4 reports no 'phi_c'"), "{hl}");

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
    fn a_number_another_figure_compares_is_not_listed_again_among_others() {
        let dir = tempfile::tempdir().unwrap();
        let results = dir.path().join("results");
        built(&results, "fig4", "ci", 0.8, 0.01);
        built(&results, "fig3", "ci", 0.7, 0.01);
        // fig3 carries fig4's compared phi_0 (a shared stage) and its own B.
        let rows = [
            ("phi_0".to_string(), 0.8, 0.01),
            ("B".to_string(), 0.25, 0.02),
        ];
        let b = crate::table::results::quantity_batch(&[], &rows, "", None).unwrap();
        crate::table::write_parquet(&results.join("fig3/shared.parquet"), &[b], &[]).unwrap();
        std::fs::remove_file(results.join("fig3/compare.parquet")).unwrap();
        write(dir.path(), &results, None, true).unwrap();
        let md = std::fs::read_to_string(results.join("REPORT.md")).unwrap();
        let others = &md[md.find("## Other fitted numbers").unwrap()..];
        let others = &others[..others.find("## Gallery").unwrap_or(others.len())];
        assert!(others.contains("| fig3 | B | 0.250 | 0.020 |"), "{others}");
        assert!(!others.contains("phi_0"), "{others}");
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
    fn the_html_report_has_a_row_per_figure_and_a_page_per_built_one() {
        let dir = tempfile::tempdir().unwrap();
        let results = dir.path().join("results");
        built(&results, "fig4", "ci", -0.000012, 0.0021);
        std::fs::write(results.join("fig4/figure.png"), b"png").unwrap();
        std::fs::create_dir_all(dir.path().join("pipelines")).unwrap();
        for (id, what) in [("fig4", "tau_alpha(phi)"), ("intruder-fig2", "v(F) <x>")] {
            std::fs::write(
                dir.path().join(format!("pipelines/{id}.yaml")),
                format!("description: \"{what}\"\nstages:\n  - {{name: t, kind: table}}\n"),
            )
            .unwrap();
        }
        let r = collect(dir.path(), &results, None).unwrap();
        assert_eq!(r.entries.len(), 2);
        assert_eq!(r.entries[1].figure_number(), "Fig. 2");
        assert_eq!(r.tally().get(crate::study::results::Verdict::Agree), 1);
        let index = html::write(&r, &results, None).unwrap();
        let page = std::fs::read_to_string(&index).unwrap();
        assert!(
            page.contains("data-id=\"intruder-fig2\" data-paper=\"I\" data-verdicts=\"not-built\""),
            "{page}"
        );
        assert!(page.contains("v(F) &lt;x&gt;"), "escaped: {page}");
        assert!(page.contains("src=\"../fig4/figure.png\""), "{page}");
        assert!(!page.contains("http"), "no network: {page}");
        let fig = std::fs::read_to_string(results.join("report/fig4.html")).unwrap();
        assert_eq!(fig.matches("<tr class=\"key\">").count(), 1, "{fig}");
        assert!(
            fig.contains(">0.0000<") && !fig.contains("-0.0000"),
            "{fig}"
        );
        assert!(!results.join("report/intruder-fig2.html").exists());

        // A copy to share: the figures' files next to the pages.
        let out = dir.path().join("share");
        html::write(&r, &results, Some(&out)).unwrap();
        assert!(out.join("fig4/compare.parquet").is_file());
        let page = std::fs::read_to_string(out.join("index.html")).unwrap();
        assert!(page.contains("src=\"fig4/figure.png\""), "{page}");
        let md = std::fs::read_to_string(results.join("REPORT.md"));
        assert!(md.is_err(), "html alone writes no Markdown");
        let md = markdown::render(&r, |id| format!("{id}/figure.png"));
        assert!(
            md.contains("Not built at profile `ci`: intruder-fig2."),
            "{md}"
        );
    }

    #[test]
    fn numbers_carry_the_precision_of_their_error() {
        assert_eq!(number(0.812345, 0.0021), "0.8123");
        assert_eq!(number(1.19, f64::NAN), "1.190");
        assert_eq!(number(241.3, 12.0), "241");
        assert_eq!(number(f64::NAN, 1.0), "—");
        assert_eq!(number(8.0, f64::NAN), "8", "counts stay integers");
        assert_eq!(number(2.5e-5, f64::NAN), "2.500e-5");
        assert_eq!(number(-0.00001, 0.001), "0.0000", "no negative zero");
        assert_eq!(number(-0.0, f64::NAN), "0");
        assert_eq!(number(-0.012, 0.001), "-0.0120");
        assert_eq!(number(7.0613e-6, 5.9e-6), "7.1e-6");
        assert_eq!(error(5.9e-6), "5.9e-6");
        assert_eq!(error(0.00052), "0.00052");
        assert_eq!(number(3.4933e-14, 2.1e-15), "3.49e-14");
        assert_eq!(
            number(1.5e-4, 3e-4),
            "0.00015",
            "an error above the value: fixed point"
        );
        assert_eq!(plain(0.83), "0.83");
        assert_eq!(plain(0.1 + 0.2), "0.3");
        assert_eq!(plain(-0.0), "0");
        assert_eq!(plain(-1e-10), "-1e-10");
        assert_eq!(plain(1.25e-12), "1.25e-12");
        assert_eq!(
            utc(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1_795_000_000)),
            "2026-11-18 11:06 UTC"
        );
    }
}
