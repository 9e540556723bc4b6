//! The HTML report of the ci build (`results/`, as `make test` leaves it), opened
//! in headless Chromium: no console message, every image loaded, every local link
//! resolving inside the report's directory (no network, no server), as many
//! key-number rows per figure as its compare.parquet has, scoreboard totals equal
//! to the verdicts `repro regress` prints, and the filters working.
//!
//! Ignored by a plain `cargo test` (it needs the ci build): `make test` runs it
//! after `repro report --profile ci`:
//!
//!     cargo test --release --locked --test report_html -- --ignored
//!
//! Without a browser (`chromium`, `chromium-browser`, `google-chrome` on PATH or
//! REPRO_BROWSER) it prints SKIPPED; with REPRO_REQUIRE_BROWSER=1 (set by .ci/run
//! when it installed Chromium) that is a failure. REPRO_REPORT_SCREENSHOTS=DIR
//! also saves report-index.png and report-figure.png there (docs/img).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use serde_json::Value;

/// The harness: every page of the report in an iframe (the window's load event
/// waits for them all, images included); what the browser saw of each is
/// written into the DOM as JSON.
const CHECK: &str = r#"<script>
window.addEventListener('load', () => {
  const count = cells => Object.fromEntries([...cells].map(c => [c.dataset.verdict, +c.textContent]));
  const seen = {};
  for (const f of document.querySelectorAll('iframe')) {
    const d = f.contentDocument, s = {};
    s.images = d.images.length;
    s.broken = [...d.images].filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute('src'));
    s.key_rows = d.querySelectorAll('tr.key').length;
    const totals = d.querySelector('#totals');
    if (totals) s.totals = count(totals.querySelectorAll('td[data-verdict]'));
    s.rows = {};
    for (const r of d.querySelectorAll('#scoreboard tbody tr'))
      s.rows[r.dataset.id] = {paper: r.dataset.paper, counts: count(r.querySelectorAll('td[data-verdict]'))};
    const paper = d.getElementById('paper');
    if (paper) {
      paper.value = 'I';
      paper.onchange();
      s.shown_for_I = [...d.querySelectorAll('#scoreboard tbody tr')].filter(r => !r.hidden).map(r => r.dataset.paper);
    }
    seen[f.getAttribute('src')] = s;
  }
  const out = document.createElement('pre');
  out.id = 'browser-check';
  out.textContent = JSON.stringify(seen);
  document.body.appendChild(out);
});
</script>"#;

fn browser() -> Option<PathBuf> {
    if let Some(b) = std::env::var_os("REPRO_BROWSER") {
        return Some(PathBuf::from(b));
    }
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|b| std::env::split_paths(&path).map(move |d| d.join(b)))
        .find(|p| p.is_file())
}

/// Headless Chromium on `page` with `args`: (stdout, stderr).
fn chromium(bin: &Path, profile_dir: &Path, page: &Path, args: &[&str]) -> (String, String) {
    let out = Command::new(bin)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-extensions",
            "--disable-background-networking",
            "--enable-logging=stderr",
            "--v=0",
            "--window-size=1280,1000",
        ])
        .arg(format!("--user-data-dir={}", profile_dir.display()))
        .args(args)
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("running the browser");
    assert!(
        out.status.success(),
        "{} failed on {}: {}",
        bin.display(),
        page.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Every page in one browser: what the harness saw of each, by file name, and
/// every console message (a script error is one).
fn check_pages(
    bin: &Path,
    profile_dir: &Path,
    dir: &Path,
    pages: &[String],
) -> (Value, Vec<String>) {
    let frames: String = pages
        .iter()
        .map(|p| format!("<iframe src=\"{p}\" width=\"1280\" height=\"800\"></iframe>\n"))
        .collect();
    let harness = dir.join("browser-check.html");
    std::fs::write(
        &harness,
        format!("<!DOCTYPE html><html><head><meta charset=\"utf-8\"></head><body>\n{frames}{CHECK}</body></html>\n"),
    )
    .unwrap();
    let (dom, log) = chromium(
        bin,
        profile_dir,
        &harness,
        // File pages may read each other (the harness reads its iframes).
        &[
            "--allow-file-access-from-files",
            "--virtual-time-budget=30000",
            "--dump-dom",
        ],
    );
    std::fs::remove_file(&harness).unwrap();
    let console = log
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .map(String::from)
        .collect();
    let start = dom
        .find("<pre id=\"browser-check\">")
        .unwrap_or_else(|| panic!("the check script did not run:\n{dom}"));
    let json = &dom[start + "<pre id=\"browser-check\">".len()..];
    let json = &json[..json.find("</pre>").unwrap()];
    let json = json
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&");
    (serde_json::from_str(&json).unwrap(), console)
}

/// Every `href="..."` and `src="..."` of a page.
fn links(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for attr in ["href=\"", "src=\""] {
        for (i, _) in html.match_indices(attr) {
            let rest = &html[i + attr.len()..];
            out.push(rest[..rest.find('"').unwrap()].replace("&amp;", "&"));
        }
    }
    out
}

/// The ids of the figures in `results` built at profile ci.
fn ci_built(results: &Path) -> Vec<String> {
    let mut ids: Vec<String> = std::fs::read_dir(results)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| {
            std::fs::read(e.path().join("provenance.json"))
                .ok()
                .and_then(|b| serde_json::from_slice::<Value>(&b).ok())
                .is_some_and(|v| v["profile"] == "ci")
        })
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    ids.sort();
    ids
}

fn skip(why: &str) {
    eprintln!("\n*** SKIPPED: the HTML report's browser check: {why} ***\n");
    assert!(
        std::env::var("REPRO_REQUIRE_BROWSER").as_deref() != Ok("1"),
        "REPRO_REQUIRE_BROWSER=1 but the browser check was skipped: {why}"
    );
}

#[test]
#[ignore = "needs the ci build: `make test` runs it after `repro report --profile ci`"]
fn the_html_report_of_the_ci_build_holds_in_a_browser() {
    let t0 = Instant::now();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let results = root.join("results");
    let Some(bin) = browser() else {
        return skip("no chromium on PATH (apt-get install chromium, or set REPRO_BROWSER)");
    };
    let built = ci_built(&results);
    assert!(
        !built.is_empty(),
        "no figure built at profile ci under {}: run `repro figure --ci --profile ci` first",
        results.display()
    );
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("report");
    let profile_dir = tmp.path().join("browser-profile");
    let repro = env!("CARGO_BIN_EXE_repro");
    let run = Command::new(repro)
        .args(["report", "--profile", "ci", "--html", "--out"])
        .arg(&out)
        .arg("--root")
        .arg(root)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "repro report --html: {}",
        String::from_utf8_lossy(&run.stderr)
    );

    let mut pages = vec!["index.html".to_string()];
    pages.extend(built.iter().map(|id| format!("{id}.html")));
    let (seen, console) = check_pages(&bin, &profile_dir, &out, &pages);
    assert!(console.is_empty(), "console messages: {console:#?}");
    for name in &pages {
        let s = &seen[name.as_str()];
        assert_eq!(
            s["broken"],
            Value::Array(vec![]),
            "{name}: images not loaded"
        );
        let html = std::fs::read_to_string(out.join(name)).unwrap();
        for l in links(&html) {
            assert!(
                !l.contains("://") && !l.starts_with("//") && !l.contains(".."),
                "{name}: link {l} leaves the report's directory"
            );
            let target = out.join(l.split('#').next().unwrap());
            assert!(target.exists(), "{name}: link {l} does not resolve");
        }
        let id = name.trim_end_matches(".html");
        if id == "index" {
            continue;
        }
        let rows = if results.join(id).join("compare.parquet").is_file() {
            repro::study::results::read_compare(&results.join(id))
                .unwrap()
                .len()
        } else {
            0
        };
        assert_eq!(
            s["key_rows"], rows,
            "{id}: key-number rows against compare.parquet"
        );
    }
    let index = &seen["index.html"];

    // Scoreboard: one row per figure of the catalogue, the built ones with counts
    // whose sums are the totals on top.
    let rows = index["rows"].as_object().expect("scoreboard rows");
    let catalogue = repro::pipeline::Catalogue::load(root).unwrap();
    for id in catalogue.pipelines.keys() {
        assert!(rows.contains_key(id), "{id} has no scoreboard row");
    }
    let verdicts = ["agree", "disagree", "out_of_reach", "unreliable", "missing"];
    let sum = |ids: &mut dyn Iterator<Item = &String>| {
        let mut s: BTreeMap<&str, u64> = verdicts.iter().map(|v| (*v, 0)).collect();
        for id in ids {
            for v in verdicts {
                *s.get_mut(v).unwrap() += rows[id]["counts"][v].as_u64().unwrap_or(0);
            }
        }
        s
    };
    let all = sum(&mut rows.keys());
    for v in verdicts {
        assert_eq!(index["totals"][v], all[v], "total of {v}");
    }
    assert!(
        index["shown_for_I"]
            .as_array()
            .is_some_and(|a| !a.is_empty() && a.iter().all(|p| p == "I")),
        "the paper filter: {}",
        index["shown_for_I"]
    );

    // The totals against `repro regress` over the built figures it has bands for.
    let golden: Value =
        serde_json::from_slice(&std::fs::read(root.join("tests/golden/ci.json")).unwrap()).unwrap();
    let mut gated: Vec<String> = golden["quantities"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|q| q["figure"].as_str().map(String::from))
        .filter(|f| built.contains(f))
        .collect();
    gated.sort();
    gated.dedup();
    let regress = Command::new(repro)
        .args(["regress", "--profile", "ci", "--root"])
        .arg(root)
        .args(&gated)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&regress.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("verdicts against the paper: "))
        .unwrap_or_else(|| panic!("repro regress printed no verdicts:\n{text}"));
    let ours = sum(&mut gated.iter());
    let expected = format!(
        "verdicts against the paper: {} agree, {} disagree, {} out of reach, {} unreliable, {} missing",
        ours["agree"], ours["disagree"], ours["out_of_reach"], ours["unreliable"], ours["missing"]
    );
    assert!(
        line.starts_with(&expected),
        "scoreboard {expected}\nregress   {line}"
    );
    if gated.len() == built.len() {
        let total: u64 = all.values().sum();
        assert!(line.contains(&format!("({total} key numbers")), "{line}");
    }

    if let Some(dir) = std::env::var_os("REPRO_REPORT_SCREENSHOTS") {
        let dir = PathBuf::from(dir);
        std::fs::create_dir_all(&dir).unwrap();
        let figure = ["fig4", built[0].as_str()]
            .into_iter()
            .find(|id| built.iter().any(|b| b == id))
            .unwrap();
        for (page, png, height) in [
            ("index.html".to_string(), "report-index.png", 1000),
            (format!("{figure}.html"), "report-figure.png", 1600),
        ] {
            chromium(
                &bin,
                &profile_dir,
                &out.join(page),
                &[
                    &format!("--window-size=1280,{height}"),
                    "--hide-scrollbars",
                    "--virtual-time-budget=10000",
                    &format!("--screenshot={}", dir.join(png).display()),
                ],
            );
        }
    }
    eprintln!(
        "browser check: {} pages of {} built figures in {:.1} s",
        pages.len(),
        built.len(),
        t0.elapsed().as_secs_f64()
    );
}
