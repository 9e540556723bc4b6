//! The module graph of `src/` read a second way, independent of
//! `repro::pipeline::fingerprint`: `syn` parses every file (use trees, and
//! every path of expressions, types, patterns, attributes and macro bodies)
//! and a name resolution of its own maps each path to the file it lands in.
//! A kind's closure stops at the same harness boundary
//! (`repro::pipeline::fingerprint::is_harness`, the one rule of what a key
//! covers).
#![allow(dead_code)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use proc_macro2::{TokenStream, TokenTree};
use syn::visit::Visit;

use repro::pipeline::fingerprint::{is_harness, module_key};

pub type Graph = BTreeMap<String, BTreeSet<String>>;

pub fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg")
            && a.meta
                .require_list()
                .is_ok_and(|l| l.tokens.to_string() == "test")
    })
}

/// One parsed file: its module path, its child modules, its imports
/// (name -> path as written, `*` for globs), which of them are `pub`, and every
/// other path it names.
#[derive(Default)]
struct File {
    module: Vec<String>,
    children: BTreeSet<String>,
    test_children: BTreeSet<String>,
    uses: Vec<(String, Vec<String>, bool)>,
    paths: Vec<Vec<String>>,
    /// The first segment of every path, one-segment ones too, and every
    /// identifier of a macro body: where a re-exported name may be used.
    names: BTreeSet<String>,
}

fn use_tree(tree: &syn::UseTree, prefix: &mut Vec<String>, public: bool, out: &mut File) {
    match tree {
        syn::UseTree::Path(p) => {
            prefix.push(p.ident.to_string());
            use_tree(&p.tree, prefix, public, out);
            prefix.pop();
        }
        syn::UseTree::Name(n) => {
            let name = n.ident.to_string();
            if name == "self" {
                let last = prefix.last().cloned().unwrap_or_default();
                out.uses.push((last, prefix.clone(), public));
            } else {
                let mut p = prefix.clone();
                p.push(name.clone());
                out.uses.push((name, p, public));
            }
        }
        syn::UseTree::Rename(r) => {
            let mut p = prefix.clone();
            if r.ident != "self" {
                p.push(r.ident.to_string());
            }
            out.uses.push((r.rename.to_string(), p, public));
        }
        syn::UseTree::Glob(_) => out.uses.push(("*".into(), prefix.clone(), public)),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                use_tree(t, prefix, public, out);
            }
        }
    }
}

/// `a::b::c` sequences of identifiers in a token stream (macro bodies), and
/// paths written as string literals (`#[serde(default = "super::f")]`).
fn token_paths(tokens: TokenStream, out: &mut Vec<Vec<String>>, names: &mut BTreeSet<String>) {
    let tts: Vec<TokenTree> = tokens.into_iter().collect();
    let mut i = 0;
    while i < tts.len() {
        match &tts[i] {
            TokenTree::Group(g) => token_paths(g.stream(), out, names),
            TokenTree::Literal(l) => {
                if let Ok(s) = syn::parse_str::<syn::LitStr>(&l.to_string())
                    && let Ok(p) = syn::parse_str::<syn::Path>(&s.value())
                    && p.segments.len() > 1
                {
                    out.push(p.segments.iter().map(|s| s.ident.to_string()).collect());
                }
            }
            TokenTree::Ident(id) => {
                let after_colons =
                    i >= 1 && matches!(&tts[i - 1], TokenTree::Punct(p) if p.as_char() == ':');
                names.insert(id.to_string());
                let mut segs = vec![id.to_string()];
                let mut j = i + 1;
                while j + 2 < tts.len()
                    && matches!(&tts[j], TokenTree::Punct(p) if p.as_char() == ':')
                    && matches!(&tts[j + 1], TokenTree::Punct(p) if p.as_char() == ':')
                    && let TokenTree::Ident(next) = &tts[j + 2]
                {
                    segs.push(next.to_string());
                    j += 3;
                }
                if segs.len() > 1 && !after_colons {
                    out.push(segs);
                }
                i = j;
                continue;
            }
            TokenTree::Punct(_) => {}
        }
        i += 1;
    }
}

struct Visitor<'a>(&'a mut File);

impl<'ast> Visit<'ast> for Visitor<'_> {
    fn visit_item(&mut self, i: &'ast syn::Item) {
        let attrs = match i {
            syn::Item::Mod(m) => &m.attrs,
            syn::Item::Fn(f) => &f.attrs,
            syn::Item::Impl(m) => &m.attrs,
            syn::Item::Use(m) => &m.attrs,
            syn::Item::Const(m) => &m.attrs,
            syn::Item::Struct(m) => &m.attrs,
            syn::Item::Enum(m) => &m.attrs,
            syn::Item::Static(m) => &m.attrs,
            syn::Item::Trait(m) => &m.attrs,
            syn::Item::Type(m) => &m.attrs,
            syn::Item::Macro(m) => &m.attrs,
            _ => return syn::visit::visit_item(self, i),
        };
        if is_cfg_test(attrs) {
            if let syn::Item::Mod(m) = i
                && m.content.is_none()
            {
                self.0.test_children.insert(m.ident.to_string());
            }
            return;
        }
        syn::visit::visit_item(self, i);
    }
    fn visit_impl_item(&mut self, i: &'ast syn::ImplItem) {
        let attrs = match i {
            syn::ImplItem::Fn(f) => &f.attrs,
            syn::ImplItem::Const(c) => &c.attrs,
            syn::ImplItem::Type(t) => &t.attrs,
            _ => return syn::visit::visit_impl_item(self, i),
        };
        if !is_cfg_test(attrs) {
            syn::visit::visit_impl_item(self, i);
        }
    }
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        if m.content.is_none() {
            self.0.children.insert(m.ident.to_string());
        }
        syn::visit::visit_item_mod(self, m);
    }
    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        let public = !matches!(u.vis, syn::Visibility::Inherited);
        use_tree(&u.tree, &mut Vec::new(), public, self.0);
    }
    fn visit_path(&mut self, p: &'ast syn::Path) {
        if let Some(first) = p.segments.first() {
            self.0.names.insert(first.ident.to_string());
        }
        if p.segments.len() > 1 {
            self.0
                .paths
                .push(p.segments.iter().map(|s| s.ident.to_string()).collect());
        }
        syn::visit::visit_path(self, p);
    }
    fn visit_vis_restricted(&mut self, _: &'ast syn::VisRestricted) {
        // `pub(in crate::plot)` names a scope, not a dependency.
    }
    fn visit_macro(&mut self, m: &'ast syn::Macro) {
        self.visit_path(&m.path);
        token_paths(m.tokens.clone(), &mut self.0.paths, &mut self.0.names);
    }
    fn visit_attribute(&mut self, a: &'ast syn::Attribute) {
        if let syn::Meta::List(l) = &a.meta {
            token_paths(l.tokens.clone(), &mut self.0.paths, &mut self.0.names);
        } else if let syn::Meta::NameValue(nv) = &a.meta
            && let syn::Expr::Lit(l) = &nv.value
            && !a.path().is_ident("doc")
        {
            token_paths(quote_lit(&l.lit), &mut self.0.paths, &mut self.0.names);
        }
    }
}

fn quote_lit(l: &syn::Lit) -> TokenStream {
    let mut t = TokenStream::new();
    if let syn::Lit::Str(s) = l {
        t.extend([TokenTree::Literal(proc_macro2::Literal::string(&s.value()))]);
    }
    t
}

/// The module graph of `src` as `syn` reads it: module key -> the modules its
/// non-test code reaches.
pub fn syn_graph(src: &Path) -> Graph {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let mut parsed: BTreeMap<Vec<String>, File> = BTreeMap::new();
    for f in files {
        let rel = f
            .strip_prefix(src)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if rel == "main.rs" {
            continue;
        }
        let mut module: Vec<String> = rel
            .trim_end_matches(".rs")
            .split('/')
            .map(str::to_string)
            .collect();
        if module.last().is_some_and(|l| l == "mod") || module == ["lib"] {
            module.pop();
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let ast = syn::parse_file(&text).unwrap_or_else(|e| panic!("{rel}: {e}"));
        let mut file = File {
            module: module.clone(),
            ..File::default()
        };
        Visitor(&mut file).visit_file(&ast);
        parsed.insert(module, file);
    }
    // Modules under a `#[cfg(test)] mod x;` are no part of the library.
    let tests: BTreeSet<Vec<String>> = parsed
        .values()
        .flat_map(|f| {
            f.test_children.iter().map(|c| {
                let mut m = f.module.clone();
                m.push(c.clone());
                m
            })
        })
        .collect();
    parsed.retain(|m, _| !(1..=m.len()).any(|n| tests.contains(&m[..n])));
    let modules: BTreeSet<Vec<String>> = parsed.keys().cloned().collect();
    let key = |m: &[String]| {
        if m.is_empty() {
            "lib".to_string()
        } else {
            m.join("/")
        }
    };
    let mut graph = Graph::new();
    for (m, f) in &parsed {
        let mut deps = BTreeSet::new();
        for (name, path, public) in &f.uses {
            // A re-export is a dependency when the file itself uses the name.
            if !*public || name == "*" || f.names.contains(name) {
                if let Some(d) = resolve(&parsed, &modules, m, path, 0) {
                    deps.insert(d);
                }
            }
        }
        for p in &f.paths {
            if let Some(d) = resolve(&parsed, &modules, m, p, 0) {
                deps.insert(d);
            }
        }
        deps.remove(m);
        graph.insert(key(m), deps.iter().map(|d| key(d)).collect());
    }
    graph
}

/// The module a path written in module `m` lands in.
fn resolve(
    parsed: &BTreeMap<Vec<String>, File>,
    modules: &BTreeSet<Vec<String>>,
    m: &[String],
    path: &[String],
    depth: usize,
) -> Option<Vec<String>> {
    let file = parsed.get(m)?;
    let mut abs: Vec<String> = match path[0].as_str() {
        "crate" => Vec::new(),
        "self" => m.to_vec(),
        "super" => m[..m.len().checked_sub(1)?].to_vec(),
        first if file.children.contains(first) => {
            let mut a = m.to_vec();
            a.push(first.to_string());
            a
        }
        first => {
            let (_, target, _) = file.uses.iter().find(|(n, _, _)| n == first)?;
            if target[0] == first {
                return None;
            }
            let mut p = target.clone();
            p.extend(path[1..].iter().cloned());
            return resolve(parsed, modules, m, &p, depth + 1);
        }
    };
    for s in &path[1..] {
        if s == "super" {
            abs.pop()?;
        } else {
            abs.push(s.clone());
        }
    }
    let n = (0..=abs.len())
        .rev()
        .find(|&n| modules.contains(&abs[..n]))?;
    let (module, rest) = (abs[..n].to_vec(), &abs[n..]);
    if depth < 8
        && let Some(first) = rest.first()
        && let Some(f) = parsed.get(&module)
    {
        let named: Vec<&Vec<String>> = f
            .uses
            .iter()
            .filter(|(name, _, public)| *public && name == first)
            .map(|(_, p, _)| p)
            .collect();
        let mut tries: Vec<Vec<String>> = named
            .iter()
            .map(|p| p.iter().chain(&rest[1..]).cloned().collect())
            .collect();
        if tries.is_empty() {
            tries = f
                .uses
                .iter()
                .filter(|(name, _, public)| *public && name == "*")
                .map(|(_, p, _)| p.iter().chain(rest).cloned().collect())
                .collect();
        }
        for t in tries {
            if let Some(r) = resolve(parsed, modules, &module, &t, depth + 1) {
                return Some(r);
            }
        }
    }
    Some(module)
}

/// Roots through `graph`, stopped at the harness (the rule of
/// `repro::pipeline::fingerprint`).
pub fn closure(graph: &Graph, roots: &[&str], cut: &[(&str, &str)]) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo: Vec<String> = roots.iter().map(|r| module_key(r)).collect();
    while let Some(k) = todo.pop() {
        if seen.insert(k.clone()) {
            let deps = graph.get(&k).unwrap_or_else(|| panic!("{k} is no module"));
            todo.extend(
                deps.iter()
                    .filter(|d| !is_harness(d) && !cut.contains(&(k.as_str(), d.as_str())))
                    .cloned(),
            );
        }
    }
    seen
}
