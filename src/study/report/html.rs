//! The report as HTML: `index.html` (a scoreboard of every figure, filters by
//! paper and verdict) and `ID.html` per built figure (figure, key numbers, fitted
//! numbers, frontier, stages, provenance, tables). Plain HTML with the style
//! inline and a few lines of script; images and tables are relative links, so
//! the pages open from the file system with no server and no network.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use super::{Entry, FigureReport, Report, error, number, plain, utc};
use crate::study::results::{Tally, Verdict};

/// Where the pages find the built figures.
struct Links {
    /// Prefix of `ID/file` as seen from the pages: `../` in `results/report/`,
    /// empty in a copy made with `--out`.
    data: String,
    /// Where the pandas snippet reads from: `results/` (from the repository root)
    /// or empty (from the copy's directory).
    pandas: String,
}

impl Links {
    fn file(&self, id: &str, file: &str) -> String {
        format!("{}{}/{}", self.data, esc(id), esc(file))
    }
}

const STYLE: &str = "
body{font:15px/1.45 system-ui,sans-serif;margin:1.5em auto;max-width:75em;padding:0 1em;color:#222}
h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em}
table{border-collapse:collapse;margin:.5em 0}
th,td{border:1px solid #ccc;padding:.25em .5em;vertical-align:top;text-align:left}
th{background:#f3f3f3}td.n{text-align:right;font-variant-numeric:tabular-nums}
.agree{background:#cdeccd}.disagree{background:#f6c4c4}.out_of_reach{background:#d9e1f2}
.unreliable{background:#f6e2b3}.missing{background:#e4e4e4}.zero{background:none;color:#aaa}
img.thumb{width:160px;height:auto;border:1px solid #ddd}
img.figure{max-width:100%;border:1px solid #ddd}
.unbuilt{color:#888}code,pre{background:#f6f6f6}pre{padding:.6em;overflow-x:auto}
.paper{font-size:.8em;border:1px solid #999;border-radius:3px;padding:0 .3em}
";

/// `<` `>` `&` `"` as entities.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn head(s: &mut String, title: &str) {
    let _ = write!(
        s,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width\">\
         <title>{}</title><style>{STYLE}</style></head><body>\n",
        esc(title)
    );
}

/// CPU seconds as `42 s`, `12.3 min` or `2.1 h`.
fn cpu(s: f64) -> String {
    if !s.is_finite() {
        "—".into()
    } else if s < 600.0 {
        format!("{s:.0} s")
    } else if s < 36_000.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

/// `all 12 cached`, `3 of 12 cached`, `none of 12 cached`.
fn cache_state(f: &FigureReport) -> String {
    let n = f.provenance.stages.len();
    let cached = f.provenance.stages.iter().filter(|s| s.cached).count();
    match cached {
        0 => format!("computed: {n} stages"),
        c if c == n => format!("all {n} stages cached"),
        c => format!("{c} of {n} stages cached"),
    }
}

/// One cell per verdict, coloured when not zero; `data-` attributes for the check.
fn tally_cells(s: &mut String, t: &Tally) {
    for v in Verdict::ALL {
        let n = t.get(v);
        let class = if n == 0 { "zero" } else { v.as_str() };
        let _ = write!(
            s,
            "<td class=\"n {class}\" data-verdict=\"{}\">{n}</td>",
            v.as_str()
        );
    }
}

fn verdict_headers(s: &mut String) {
    for v in Verdict::ALL {
        let _ = write!(s, "<th>{}</th>", v.label());
    }
}

/// The scoreboard: every figure, one row each, totals on top.
fn index(report: &Report, links: &Links) -> String {
    let mut s = String::new();
    head(
        &mut s,
        &format!("repro: figures against the papers ({})", report.profile),
    );
    let built = report.built().count();
    let _ = writeln!(
        s,
        "<h1>Figures against the papers, profile <code>{}</code></h1>\n\
         <p>Written by <code>repro report --html --profile {}</code> on {} from the built figures \
         ({built} of {} built); {}. Every number is read from the figures' tables.</p>",
        esc(&report.profile),
        esc(&report.profile),
        utc(report.generated),
        report.entries.len(),
        esc(&report.machine)
    );
    let total = report.tally();
    let cpu_all: f64 = report.built().map(|f| f.provenance.cpu_s).sum();
    s.push_str("<table id=\"totals\"><tr><th>key numbers</th>");
    verdict_headers(&mut s);
    s.push_str("<th>CPU (all stages)</th></tr>\n<tr>");
    let _ = write!(s, "<td class=\"n\">{}</td>", total.total());
    tally_cells(&mut s, &total);
    let _ = writeln!(s, "<td class=\"n\">{}</td></tr></table>", cpu(cpu_all));
    s.push_str(
        "<p><label>Paper <select id=\"paper\"><option value=\"\">all</option>\
         <option value=\"H\">H: dynamical heterogeneities</option>\
         <option value=\"I\">I: intruder</option>\
         <option value=\"checks\">checks of the method</option></select></label>\n\
         <label>Verdict <select id=\"verdict\"><option value=\"\">any</option>",
    );
    for v in Verdict::ALL {
        let _ = write!(
            s,
            "<option value=\"{}\">has {}</option>",
            v.as_str(),
            v.label()
        );
    }
    s.push_str("<option value=\"not-built\">not built</option></select></label></p>\n");
    s.push_str(
        "<table id=\"scoreboard\"><thead><tr><th>figure</th><th>paper, figure, what it shows</th>",
    );
    verdict_headers(&mut s);
    s.push_str("<th>CPU</th><th>cache</th></tr></thead><tbody>\n");
    for e in &report.entries {
        scoreboard_row(&mut s, e, links, &report.profile);
    }
    s.push_str("</tbody></table>\n");
    // Filters: hide the rows whose paper or verdicts do not match.
    s.push_str(
        "<script>\nfunction filter(){const p=document.getElementById('paper').value,\
         v=document.getElementById('verdict').value;\
         for(const r of document.querySelectorAll('#scoreboard tbody tr'))\
         r.hidden=(p!==''&&r.dataset.paper!==p)||(v!==''&&!r.dataset.verdicts.split(' ').includes(v));}\n\
         document.getElementById('paper').onchange=filter;\
         document.getElementById('verdict').onchange=filter;\n</script>\n</body></html>\n",
    );
    s
}

fn scoreboard_row(s: &mut String, e: &Entry, links: &Links, profile: &str) {
    let Some(f) = &e.built else {
        let _ = write!(
            s,
            "<tr class=\"unbuilt\" data-id=\"{id}\" data-paper=\"{p}\" data-verdicts=\"not-built\">\
             <td>not built</td><td>{num} <span class=\"paper\">{p}</span> <code>{id}</code><br>{d}</td>",
            id = esc(&e.id),
            p = e.paper.as_str(),
            num = esc(&e.figure_number()),
            d = esc(&e.description),
        );
        let _ = writeln!(
            s,
            "<td colspan=\"{}\">run <code>repro figure {} --profile {}</code></td></tr>",
            Verdict::ALL.len() + 2,
            esc(&e.id),
            esc(profile)
        );
        return;
    };
    let t = Tally::of(&f.compared);
    let verdicts: Vec<&str> = Verdict::ALL
        .into_iter()
        .filter(|v| t.get(*v) > 0)
        .map(|v| v.as_str())
        .collect();
    let page = format!("{}.html", esc(&e.id));
    let thumb = match &f.png {
        Some(_) => format!(
            "<a href=\"{page}\"><img class=\"thumb\" src=\"{}\" alt=\"{}\"></a>",
            links.file(&e.id, "figure.png"),
            esc(&e.id)
        ),
        None => format!("<a href=\"{page}\">{}</a>", esc(&e.id)),
    };
    let _ = write!(
        s,
        "<tr data-id=\"{id}\" data-paper=\"{p}\" data-verdicts=\"{v}\"><td>{thumb}</td>\
         <td><a href=\"{page}\">{num}</a> <span class=\"paper\">{p}</span> <code>{id}</code><br>{d}</td>",
        id = esc(&e.id),
        p = e.paper.as_str(),
        v = verdicts.join(" "),
        num = esc(&e.figure_number()),
        d = esc(&e.description),
    );
    tally_cells(s, &t);
    let _ = writeln!(
        s,
        "<td class=\"n\">{}</td><td>{}</td></tr>",
        cpu(f.provenance.cpu_s),
        cache_state(f)
    );
}

/// The page of one built figure.
fn figure_page(report: &Report, e: &Entry, f: &FigureReport, links: &Links) -> String {
    let mut s = String::new();
    let num = e.figure_number();
    head(&mut s, &format!("{} {num}: {}", e.paper.title(), e.id));
    let _ = writeln!(
        s,
        "<p><a href=\"index.html\">all figures</a></p>\n<h1>{num} of {} <code>{}</code></h1>\n<p>{}</p>",
        e.paper.title(),
        esc(&e.id),
        esc(&e.description)
    );
    let image = if f.svg.is_some() {
        Some("figure.svg")
    } else if f.png.is_some() {
        Some("figure.png")
    } else {
        None
    };
    if let Some(img) = image {
        let _ = writeln!(
            s,
            "<p><img class=\"figure\" src=\"{}\" alt=\"{} as rebuilt\"></p>",
            links.file(&e.id, img),
            esc(&e.id)
        );
    }
    key_numbers(&mut s, f);
    if !f.others.is_empty() {
        s.push_str(
            "<h2>Other fitted numbers</h2>\n<table id=\"fitted\"><tr><th>quantity</th>\
             <th>value</th><th>error</th></tr>\n",
        );
        for (q, v) in &f.others {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>",
                esc(q),
                number(v.value, v.error),
                error(v.error)
            );
        }
        s.push_str("</table>\n");
    }
    frontier(&mut s, report, &e.id, links);
    stages(&mut s, f);
    provenance(&mut s, report, f);
    tables(&mut s, e, f, links);
    s.push_str("</body></html>\n");
    s
}

fn key_numbers(s: &mut String, f: &FigureReport) {
    s.push_str("<h2>Key numbers against the paper</h2>\n");
    if f.compared.is_empty() {
        s.push_str("<p>This figure has no number to compare with the paper.</p>\n");
        return;
    }
    s.push_str(
        "<p>ours ± error is the fit's 1-sigma error; tolerance is the largest accepted \
         |ours − paper|; source says whether paper H measures its value in a figure or \
         quotes it from its reference 12.</p>\n<table id=\"key-numbers\"><tr><th>quantity</th><th>ours</th>\
         <th>error</th><th>paper</th><th>source</th><th>tolerance</th><th>verdict</th><th>reason</th></tr>\n",
    );
    for c in &f.compared {
        let _ = writeln!(
            s,
            "<tr class=\"key\"><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td><td>{}</td><td class=\"n\">{}</td><td class=\"{}\">{}</td><td>{}</td></tr>",
            esc(&c.quantity),
            number(c.ours, c.ours_err),
            error(c.ours_err),
            plain(c.paper),
            crate::stages::compare::source_label(c),
            plain(c.tolerance),
            c.verdict.as_str(),
            c.verdict.label(),
            esc(&c.reason)
        );
    }
    s.push_str("</table>\n");
}

fn frontier(s: &mut String, report: &Report, id: &str, links: &Links) {
    let Some((_, rows)) = report.frontier.iter().find(|(f, _)| f == id) else {
        return;
    };
    s.push_str("<h2>Speed against accuracy (<code>repro frontier</code>)</h2>\n");
    let chart = format!("{id}-{}.svg", report.profile);
    if report.frontier_charts.iter().any(|c| c == &chart) {
        let _ = writeln!(
            s,
            "<p><img class=\"figure\" src=\"{}\" alt=\"frontier of {}\"></p>",
            links.file("frontier", &chart),
            esc(id)
        );
    }
    s.push_str(
        "<table id=\"frontier\"><tr><th>configuration</th><th>N</th><th>replicas</th>\
         <th>CPU</th><th>quantity</th><th>mean</th><th>seed spread</th><th>paper</th>\
         <th>seeds</th></tr>\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td></tr>",
            if r.label.is_empty() { "base" } else { &r.label },
            r.n,
            r.replicas,
            cpu(r.cpu_s),
            esc(&r.quantity),
            number(r.mean, r.spread),
            error(r.spread),
            plain(r.paper),
            r.values.len()
        );
    }
    s.push_str("</table>\n");
}

fn stages(s: &mut String, f: &FigureReport) {
    let _ = writeln!(
        s,
        "<h2>Stages</h2>\n<p>{}; {} CPU in all. The key is the stage's cache key: the hash of \
         its spec, inputs and code.</p>\n<table id=\"stages\"><tr><th>stage</th><th>kind</th>\
         <th>seed</th><th>CPU</th><th>wall</th><th>cache</th><th>key</th></tr>",
        cache_state(f),
        cpu(f.provenance.cpu_s)
    );
    for st in &f.provenance.stages {
        let key = st.key.as_deref().unwrap_or("");
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>\
             <td class=\"n\">{}</td><td>{}</td><td><code title=\"{}\">{}</code></td></tr>",
            esc(&st.label),
            esc(&st.kind),
            st.seed.map_or("—".into(), |x| x.to_string()),
            cpu(st.cpu_s),
            cpu(st.wall_s),
            if st.cached { "cached" } else { "computed" },
            esc(key),
            esc(&key[..key.len().min(12)])
        );
    }
    s.push_str("</table>\n");
}

fn provenance(s: &mut String, report: &Report, f: &FigureReport) {
    let p = &f.provenance;
    let _ = writeln!(
        s,
        "<h2>Provenance</h2>\n<table id=\"provenance\">\
         <tr><th>profile</th><td><code>{}</code></td></tr>\
         <tr><th>commit</th><td><code>{}</code></td></tr>\
         <tr><th>repro version</th><td>{}</td></tr>\
         <tr><th>published</th><td>{}</td></tr>\
         <tr><th>machine of this report</th><td>{}</td></tr>\
         <tr><th>every stage's parameters, inputs, seed, code fingerprint</th><td><code>provenance.json</code> below</td></tr>\
         </table>",
        esc(&p.profile),
        esc(p.commit.as_deref().unwrap_or("— (not a git checkout)")),
        esc(&p.version),
        utc(p.written),
        esc(&report.machine)
    );
}

fn tables(s: &mut String, e: &Entry, f: &FigureReport, links: &Links) {
    s.push_str("<h2>Files</h2>\n<ul id=\"files\">");
    for other in ["provenance.json", "README.md", "figure.svg", "figure.png"] {
        if f.dir.join(other).is_file() {
            let _ = write!(
                s,
                "<li><a href=\"{}\">{other}</a></li>",
                links.file(&e.id, other)
            );
        }
    }
    s.push_str("</ul>\n");
    if let Some(main) = &e.main_table {
        let _ = writeln!(
            s,
            "<p>The main table in Python:</p>\n<pre>import pandas as pd\n\
             t = pd.read_parquet(\"{}{}/{}\")\nprint(t)</pre>",
            esc(&links.pandas),
            esc(&e.id),
            esc(main)
        );
    }
    for t in &f.tables {
        let _ = writeln!(
            s,
            "<h3><a href=\"{}\">{}</a> ({} rows)</h3>\n<table class=\"columns\"><tr><th>column</th>\
             <th>type</th><th>unit</th><th>meaning</th></tr>",
            links.file(&e.id, &t.file),
            esc(&t.file),
            t.rows
        );
        for (name, ty, unit, what) in &t.columns {
            let _ = writeln!(
                s,
                "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(name),
                esc(ty),
                esc(unit),
                esc(what)
            );
        }
        s.push_str("</table>\n");
    }
}

/// Write `index.html` and a page per built figure into `out` (default
/// `results/report/`, linking the figures in `results/`); with `out` given, the
/// built figures' files are copied next to the pages, so the directory can be
/// shared on its own. Returns the index.
pub fn write(report: &Report, results: &Path, out: Option<&Path>) -> Result<PathBuf> {
    let default = results.join("report");
    let (dir, links) = match out {
        None => (
            default,
            Links {
                data: "../".into(),
                pandas: "results/".into(),
            },
        ),
        Some(d) => (
            d.to_path_buf(),
            Links {
                data: String::new(),
                pandas: String::new(),
            },
        ),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    if out.is_some() {
        copy_built(report, results, &dir)?;
    }
    for e in &report.entries {
        if let Some(f) = &e.built {
            let page = dir.join(format!("{}.html", e.id));
            crate::table::write_atomic(&page, figure_page(report, e, f, &links).as_bytes())?;
        }
    }
    let index = dir.join("index.html");
    crate::table::write_atomic(&index, self::index(report, &links).as_bytes())?;
    Ok(index)
}

/// Copy every file the pages link into `dir`: the built figures' directories
/// (flat files) and the frontier charts.
fn copy_built(report: &Report, results: &Path, dir: &Path) -> Result<()> {
    let copy = |from: &Path, to: &Path| -> Result<()> {
        std::fs::copy(from, to)
            .map(drop)
            .with_context(|| format!("copying {} to {}", from.display(), to.display()))
    };
    for f in report.built() {
        let to = dir.join(&f.id);
        std::fs::create_dir_all(&to).with_context(|| format!("creating {}", to.display()))?;
        for entry in std::fs::read_dir(&f.dir)?.flatten() {
            let p = entry.path();
            if p.is_file() {
                copy(&p, &to.join(entry.file_name()))?;
            }
        }
    }
    if !report.frontier_charts.is_empty() {
        let to = dir.join("frontier");
        std::fs::create_dir_all(&to).with_context(|| format!("creating {}", to.display()))?;
        for c in &report.frontier_charts {
            copy(&results.join("frontier").join(c), &to.join(c))?;
        }
    }
    Ok(())
}
