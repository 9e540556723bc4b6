use super::*;
use std::collections::{BTreeMap, BTreeSet};

/// A lookup over fixed values: `fit.phi_c` is 0.80342 ± 0.0123, `eps09.n` is
/// 1000, `eps09.phi` the grid 0.6, 0.7; at `small`, figure `other` is not built.
struct Fixed;

impl Lookup for Fixed {
    fn resolve(&self, r: &Reference) -> Result<Resolved> {
        if r.profile.as_deref() == Some("small") {
            return Ok(Resolved::NotBuilt {
                profile: "small".into(),
                figure: r.figure.clone().unwrap_or("here".into()),
            });
        }
        match &r.target {
            Target::Profile => Ok(Resolved::Text("ci".into())),
            Target::Field { name, field, row } => {
                match (name.as_str(), field.as_str(), row.as_slice()) {
                    ("fit", "phi_c", []) => Ok(Resolved::Number {
                        value: 0.80342,
                        error: 0.0123,
                    }),
                    ("fit", "exponent", [(c, v)]) if c == "N" && *v == 4000.0 => {
                        Ok(Resolved::Number {
                            value: 1.5,
                            error: f64::NAN,
                        })
                    }
                    ("eps09", "n", []) => Ok(Resolved::Param(serde_json::json!(1000))),
                    ("eps09", "phi", []) => Ok(Resolved::Param(serde_json::json!([0.6, 0.7]))),
                    _ => bail!("no {name}.{field}"),
                }
            }
        }
    }
}

#[test]
fn references_parse_into_profile_figure_stage_quantity_row_and_format() {
    let r = Reference::parse("small:convergence-exponents/fit.exponent@N=4000:.3").unwrap();
    assert_eq!(r.profile.as_deref(), Some("small"));
    assert_eq!(r.figure.as_deref(), Some("convergence-exponents"));
    assert_eq!(
        r.target,
        Target::Field {
            name: "fit".into(),
            field: "exponent".into(),
            row: vec![("N".into(), 4000.0)]
        }
    );
    assert_eq!(r.format.decimals, Some(3));
    assert!(!r.format.value_only);
    let two = Reference::parse("slopes.slope@phi=0.76,n=1000").unwrap();
    assert!(
        matches!(two.target, Target::Field { ref row, .. } if row == &[("phi".to_string(), 0.76), ("n".to_string(), 1000.0)])
    );
    let local = Reference::parse("joint.phi_c:value").unwrap();
    assert!(local.is_local() && local.format.value_only);
    assert_eq!(Reference::parse("profile").unwrap().target, Target::Profile);
    for bad in [
        "phi_c",
        "fit.phi_c:.x",
        "fit.phi_c@N",
        "fit.phi_c@N=many",
        "a b.c",
    ] {
        let e = Reference::parse(bad).unwrap_err().to_string();
        assert!(e.contains(bad), "{e}");
    }
}

#[test]
fn a_text_renders_values_parameters_quotations_and_unbuilt_builds() {
    let t = "φ_{c} = {=fit.phi_c} ({=fit.phi_c:.3}, {=fit.phi_c:value.2}) at {=profile}, \
             N = {=eps09.n}, φ = {=eps09.phi}; paper {paper:0.82}; \
             {=fit.exponent@N=4000}; {=small:convergence-exponents/fit.exponent}";
    assert_eq!(
        render(t, &Fixed).unwrap(),
        "φ_{c} = 0.803 ± 0.012 (0.803 ± 0.012, 0.80) at ci, N = 1000, φ = 0.6, 0.7; \
         paper 0.82; 1.50; [small: convergence-exponents not built]"
    );
    // An unknown quantity is an error naming the reference and the text.
    let e = format!("{:#}", render("x {=fit.nope} y", &Fixed).unwrap_err());
    assert!(
        e.contains("{=fit.nope}") && e.contains("x {=fit.nope} y"),
        "{e}"
    );
    // A quotation is one number.
    assert!(render("{paper:about 0.8}", &Fixed).is_err());
    assert!(render("{=fit.phi_c", &Fixed).is_err());
    // A description prints its quotations and names no build.
    assert_eq!(
        quotations("at phi = {paper:0.78}").unwrap(),
        "at phi = 0.78"
    );
    assert!(quotations("at {=fit.phi_c}").is_err());
}

#[test]
fn values_print_with_their_error_to_its_significant_digit() {
    assert_eq!(value_with_error(0.80342, 0.0123), "0.803 ± 0.012");
    assert_eq!(value_with_error(0.80342, 0.031), "0.80 ± 0.03");
    assert_eq!(value_with_error(241.3, 17.0), "241 ± 17");
    assert_eq!(value_with_error(-1.3521, 0.061), "−1.35 ± 0.06");
    assert_eq!(value_with_error(0.6, f64::NAN), "0.60");
    assert_eq!(value_with_error(1.000000000000009, 1e-14), "1.00");
    // Without an error, a value the legend's rounding would move is printed
    // to four significant digits: a miss of a tolerance stays visible.
    assert_eq!(value_with_error(1.0440617611423, f64::NAN), "1.044");
    assert_eq!(value_with_error(24.13, f64::NAN), "24.13");
    assert_eq!(value_with_error(241.3, f64::NAN), "241");
    assert_eq!(value_with_error(0.0123456, f64::NAN), "0.01235");
    assert_eq!(value_with_error(1.9e-14, 0.5e-14), "(1.9 ± 0.5) × 10^{−14}");
    assert_eq!(value_with_error(f64::NAN, f64::NAN), "(no fit)");
    assert_eq!(param_text(&serde_json::json!(360000.0)), "360000");
}

#[test]
fn shared_reasons_expand_and_an_unknown_id_is_named() {
    let reasons: BTreeMap<String, String> =
        [("jk".to_string(), "The jackknife.".to_string())].into();
    let mut used = BTreeSet::new();
    assert_eq!(
        expand_reasons("{reason:jk} More.", &reasons, &mut used).unwrap(),
        "The jackknife. More."
    );
    assert!(used.contains("jk"));
    let e = expand_reasons("{reason:nope}", &reasons, &mut used)
        .unwrap_err()
        .to_string();
    assert!(e.contains("nope") && e.contains("jk"), "{e}");
}

#[test]
fn a_typed_number_is_found_and_references_parts_and_years_are_not() {
    // Measurements typed by hand: every one is found.
    assert_eq!(
        typed_numbers("T within 2% but -3.8% at N = 1000, phi 0.60-0.805, 5e-5, 360,000"),
        ["3.8", "1000", "0.60", "0.805", "5e-5", "360", "000"]
    );
    // References, quotations, commands, words with digits, single digits,
    // parts of the paper and a year: none is typed.
    let clean = "phi_c = {=joint.phi_c} against {paper:0.82} (`repro frontier fig4 --n 16000`); \
                 eps09, tau_070, chi4, x0, 2D, c716756 and 5c3aeba; 1/e, 3 replicas; \
                 Eq. 14, Eqs. 14 and 15, Figs. 4-6, Fig. 4a, Sec. 3, Sec. 4.1, Section 3.2 and 4.2.1, \
                 Table 2; Berthier (2011); \
                 {reason:shared}";
    assert_eq!(typed_numbers(clean), Vec::<String>::new());
    // A list of parts ends at the first other word.
    assert_eq!(typed_numbers("Fig. 4 shows 12 points"), ["12"]);
    // Only a section's number has a decimal part: a figure's or equation's does not.
    assert_eq!(
        typed_numbers("Fig. 4.1, Eq. 0.82, Sec. 4.1 at 0.82"),
        ["4.1", "0.82", "0.82"]
    );
    // A year only in parentheses: bare it is a number like any other.
    assert_eq!(typed_numbers("N = 2000"), ["2000"]);
}

#[test]
fn prose_is_every_string_below_a_prose_key_named_by_its_path() {
    let doc = serde_json::json!({
        "description": "Fig. 4",
        "stages": [
            {"name": "fit", "params": {"form": "power_law", "x": "phi"}},
            {"name": "figure", "params": {"panels": [{"notes": ["a", "b"], "x": {"label": "φ"}}]}},
            {"name": "compare", "profiles": {"small": {"out_of_reach": {"phi_c": "c"}}}},
        ],
    });
    let p: Vec<(String, String)> = prose(&doc);
    let texts: Vec<&str> = p.iter().map(|(_, t)| t.as_str()).collect();
    assert_eq!(texts, ["Fig. 4", "a", "b", "φ", "c"]);
    assert_eq!(p[1].0, "stages[figure].params.panels.notes");
    assert_eq!(p[4].0, "stages[compare].profiles.small.out_of_reach.phi_c");
}
