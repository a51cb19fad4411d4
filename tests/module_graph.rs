//! The layering of the renderer (`render/src`): no file imports another in a circle, except a parent module
//! and its own children. A reader can then understand the crate bottom-up, one folder at a time.
//!
//! The graph is read from the sources: every `use` and every path written out in code
//! (`crate::…`, `super::…`, `self::…`, and paths through a module brought in by `use`), each
//! resolved to the file that defines the item, following the `pub use` re-exports of a folder's
//! front `mod.rs` to the child that holds it. Test modules (`#[cfg(test)]`) are left out: tests
//! may use the whole crate. A parent's edges to its own children (it declares them and
//! re-exports their types) are left out too, so the circle a child's `super::…` closes is
//! allowed.
//!
//! The same holds, without layers, for the effects crate (`fx/src`) and the program (`src`).
//!
//! `cargo test --release --test all module_graph:: -- --nocapture` prints the graphs.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crate's module path of each file: `lib.rs` (or `main.rs`) is the root, `a/mod.rs` is
/// `a`, `a/b.rs` is `a::b`.
fn module_files(src: &Path) -> BTreeMap<Vec<String>, PathBuf> {
    let mut files = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = path.strip_prefix(src).unwrap();
            let mut module: Vec<String> = rel
                .iter()
                .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_owned())
                .collect();
            let root = module.len() == 1 && matches!(module[0].as_str(), "lib" | "main");
            if root || module.last().is_some_and(|m| m == "mod") {
                module.pop();
            }
            files.insert(module, path);
        }
    }
    files
}

/// `text` with comments, string and character literals blanked out.
fn code_only(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, s: &[u8]| {
        out.extend(s.iter().map(|&c| if c == b'\n' { '\n' } else { ' ' }));
    };
    while i < b.len() {
        let rest = &b[i..];
        let end = if rest.starts_with(b"//") {
            rest.iter().position(|&c| c == b'\n').unwrap_or(rest.len())
        } else if rest.starts_with(b"/*") {
            rest.windows(2)
                .skip(2)
                .position(|w| w == b"*/")
                .map_or(rest.len(), |p| p + 4)
        } else if rest[0] == b'"' || rest.starts_with(b"r\"") || rest.starts_with(b"r#") {
            string_end(rest)
        } else if rest[0] == b'\'' && char_literal(rest).is_some() {
            char_literal(rest).unwrap()
        } else {
            let c = text[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
            continue;
        };
        blank(&mut out, &rest[..end]);
        i += end;
    }
    out
}

/// The length of the string literal `s` starts with (plain or raw).
fn string_end(s: &[u8]) -> usize {
    if s[0] == b'"' {
        let mut j = 1;
        while j < s.len() && s[j] != b'"' {
            j += if s[j] == b'\\' { 2 } else { 1 };
        }
        return (j + 1).min(s.len());
    }
    let hashes = s[1..].iter().take_while(|&&c| c == b'#').count();
    if s.get(1 + hashes) != Some(&b'"') {
        return 1; // an identifier starting with r, not a raw string
    }
    let close: Vec<u8> = std::iter::once(b'"')
        .chain(std::iter::repeat_n(b'#', hashes))
        .collect();
    let body = 2 + hashes;
    s[body..]
        .windows(close.len())
        .position(|w| w == close.as_slice())
        .map_or(s.len(), |p| body + p + close.len())
}

/// The length of the character literal `s` starts with; `None` for a lifetime.
fn char_literal(s: &[u8]) -> Option<usize> {
    if s.get(1) == Some(&b'\\') {
        return s[2..].iter().position(|&c| c == b'\'').map(|p| p + 3);
    }
    let c = std::str::from_utf8(&s[1..s.len().min(6)])
        .ok()
        .or_else(|| std::str::from_utf8(&s[1..s.len().min(5)]).ok())?
        .chars()
        .next()?;
    (s.get(1 + c.len_utf8()) == Some(&b'\'')).then_some(2 + c.len_utf8())
}

/// `code` without the items under `#[cfg(test)]` (a test module's block, or one item).
fn without_tests(code: &str) -> String {
    let mut out = code.to_owned();
    let mut from = 0;
    while let Some(at) = out[from..].find("#[cfg(test)]").map(|p| p + from) {
        let after = at + "#[cfg(test)]".len();
        let block = out[after..].find('{').map(|p| p + after);
        let semicolon = out[after..].find(';').map(|p| p + after);
        let end = match (block, semicolon) {
            (Some(open), semi) if semi.is_none_or(|s| open < s) => matching_brace(&out, open),
            (_, Some(semi)) => semi + 1,
            _ => out.len(),
        };
        let blanked: String = out[at..end]
            .chars()
            .map(|c| if c == '\n' { '\n' } else { ' ' })
            .collect();
        out.replace_range(at..end, &blanked);
        from = end;
    }
    out
}

/// The index just past the brace that closes the one at `open`.
fn matching_brace(code: &str, open: usize) -> usize {
    let mut depth = 0;
    for (i, c) in code[open..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return open + i + 1;
                }
            }
            _ => {}
        }
    }
    code.len()
}

/// The paths one `use` tree names (`a::{b, c::{d, self}}` → `a::b`, `a::c::d`, `a::c`), each
/// with the name it is bound to.
fn expand_use(tree: &str) -> Vec<(Vec<String>, String)> {
    let tree: String = tree.chars().filter(|c| !c.is_whitespace()).collect();
    let mut out = Vec::new();
    expand_into(&tree, &[], &mut out);
    out
}

fn expand_into(tree: &str, prefix: &[String], out: &mut Vec<(Vec<String>, String)>) {
    if let Some(open) = tree.find('{') {
        let head: Vec<String> = tree[..open]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(str::to_owned)
            .collect();
        let mut base = prefix.to_vec();
        base.extend(head);
        let inner = &tree[open + 1..tree.len() - 1];
        let (mut depth, mut start) = (0, 0);
        for (i, c) in inner.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand_into(&inner[start..i], &base, out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        if start < inner.len() {
            expand_into(&inner[start..], &base, out);
        }
        return;
    }
    let (path, alias) = match tree.split_once("as") {
        Some((p, a)) if p.ends_with(|c: char| c.is_alphanumeric()) && !a.contains("::") => {
            (p, Some(a))
        }
        _ => (tree, None),
    };
    let mut full = prefix.to_vec();
    for s in path.split("::").filter(|s| !s.is_empty()) {
        if s != "self" || full.is_empty() {
            full.push(s.to_owned());
        }
    }
    if full.is_empty() || full.last().is_some_and(|s| s == "*") {
        if let Some(last) = full.last()
            && last == "*"
        {
            full.pop();
            out.push((full, String::new()));
        }
        return;
    }
    let bound = alias.map_or_else(|| full.last().unwrap().clone(), str::to_owned);
    out.push((full, bound));
}

/// Every `use` declaration of `code`: (its tree, whether it is `pub`).
fn use_declarations(code: &str) -> Vec<(String, bool)> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = find_word(rest, "use") {
        let before = rest[..at].trim_end();
        let public = before.ends_with("pub") || before.ends_with(')') && before.contains("pub(");
        let after = &rest[at + 3..];
        let end = after.find(';').unwrap_or(after.len());
        out.push((after[..end].trim().to_owned(), public));
        rest = &after[end..];
    }
    out
}

/// The position of `word` standing alone in `text`.
fn find_word(text: &str, word: &str) -> Option<usize> {
    let mut from = 0;
    while let Some(p) = text[from..].find(word).map(|p| p + from) {
        let before = text[..p].chars().next_back();
        let after = text[p + word.len()..].chars().next();
        let ident = |c: Option<char>| c.is_some_and(|c| c.is_alphanumeric() || c == '_');
        if !ident(before) && !ident(after) {
            return Some(p);
        }
        from = p + word.len();
    }
    None
}

/// The paths written out in `code` that start with `crate`, `super`, `self` or one of
/// `roots` (names bound to modules by `use`).
fn inline_paths(code: &str, roots: &BTreeSet<String>) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let chars: Vec<char> = code.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let starts_word = i == 0 || !(chars[i - 1].is_alphanumeric() || chars[i - 1] == '_');
        if !(starts_word && (chars[i].is_alphabetic() || chars[i] == '_')) {
            i += 1;
            continue;
        }
        let mut segments = Vec::new();
        let mut j = i;
        loop {
            let start = j;
            while j < chars.len() && (chars[j].is_alphanumeric() || chars[j] == '_') {
                j += 1;
            }
            segments.push(chars[start..j].iter().collect::<String>());
            if chars.get(j) == Some(&':') && chars.get(j + 1) == Some(&':') {
                j += 2;
                if chars.get(j).is_some_and(|c| c.is_alphabetic() || *c == '_') {
                    continue;
                }
            }
            break;
        }
        let first = segments[0].as_str();
        if segments.len() > 1
            && (matches!(first, "crate" | "super" | "self") || roots.contains(first))
        {
            out.push(segments);
        }
        i = j.max(i + 1);
    }
    out
}

/// A module's public re-exports: bound name → the path it names (crate-absolute, unresolved).
type Reexports = BTreeMap<String, Vec<String>>;

struct Crate {
    files: BTreeMap<Vec<String>, PathBuf>,
    /// Per module: code without comments, strings and tests.
    code: BTreeMap<Vec<String>, String>,
    reexports: BTreeMap<Vec<String>, Reexports>,
}

impl Crate {
    fn read(src: &Path) -> Self {
        let files = module_files(src);
        let code: BTreeMap<_, _> = files
            .iter()
            .map(|(m, p)| {
                let text = std::fs::read_to_string(p).unwrap();
                (m.clone(), without_tests(&code_only(&text)))
            })
            .collect();
        let mut reexports = BTreeMap::new();
        for (module, text) in &code {
            let mut map = Reexports::new();
            for (tree, public) in use_declarations(text) {
                if !public {
                    continue;
                }
                for (path, bound) in expand_use(&tree) {
                    if let Some(abs) = absolute(module, &path, &files) {
                        map.insert(bound, abs);
                    }
                }
            }
            reexports.insert(module.clone(), map);
        }
        Self {
            files,
            code,
            reexports,
        }
    }

    /// The module that defines what `path` (crate-absolute) names, following re-exports.
    fn resolve(&self, path: &[String], depth: u32) -> Option<Vec<String>> {
        let module_len = (0..=path.len())
            .rev()
            .find(|&n| self.files.contains_key(&path[..n]))?;
        let module = path[..module_len].to_vec();
        if depth < 8
            && let Some(item) = path.get(module_len)
            && let Some(target) = self.reexports[&module].get(item)
        {
            let mut next = target.clone();
            next.extend_from_slice(&path[module_len + 1..]);
            if next != path {
                return self.resolve(&next, depth + 1).or(Some(module));
            }
        }
        Some(module)
    }

    /// The modules `module`'s code depends on.
    fn dependencies(&self, module: &[String]) -> BTreeSet<Vec<String>> {
        let code = &self.code[module];
        let mut paths = Vec::new();
        let mut roots = BTreeSet::new();
        for (tree, _) in use_declarations(code) {
            for (path, bound) in expand_use(&tree) {
                let Some(abs) = absolute(module, &path, &self.files) else {
                    continue;
                };
                if self.files.contains_key(&abs) && !bound.is_empty() {
                    roots.insert(bound.clone());
                }
                paths.push(abs);
            }
        }
        let bound_modules: BTreeMap<String, Vec<String>> = use_declarations(code)
            .into_iter()
            .flat_map(|(tree, _)| expand_use(&tree))
            .filter_map(|(path, bound)| {
                let abs = absolute(module, &path, &self.files)?;
                self.files.contains_key(&abs).then_some((bound, abs))
            })
            .collect();
        for path in inline_paths(code, &roots) {
            let abs = match bound_modules.get(&path[0]) {
                Some(base) if !matches!(path[0].as_str(), "crate" | "super" | "self") => {
                    let mut p = base.clone();
                    p.extend_from_slice(&path[1..]);
                    Some(p)
                }
                _ => absolute(module, &path, &self.files),
            };
            paths.extend(abs);
        }
        paths
            .iter()
            .filter_map(|p| self.resolve(p, 0))
            .filter(|d| d != module)
            // A parent declares its children and re-exports their types.
            .filter(|d| !(d.len() == module.len() + 1 && d.starts_with(module)))
            .collect()
    }
}

/// `path` as written in `module`, made crate-absolute; `None` for other crates' paths.
fn absolute(
    module: &[String],
    path: &[String],
    files: &BTreeMap<Vec<String>, PathBuf>,
) -> Option<Vec<String>> {
    let mut base: Vec<String> = match path.first()?.as_str() {
        "crate" => Vec::new(),
        "self" => module.to_vec(),
        "super" => module[..module.len().checked_sub(1)?].to_vec(),
        // A path from a child module declared in this file (`mod x;` then `x::Y`).
        first => {
            let mut child = module.to_vec();
            child.push(first.to_owned());
            if !files.contains_key(&child) {
                return None;
            }
            module.to_vec()
        }
    };
    let mut rest = &path[if path[0] == "crate" || path[0] == "self" || path[0] == "super" {
        1
    } else {
        0
    }..];
    while rest.first().is_some_and(|s| s == "super") {
        base.pop();
        rest = &rest[1..];
    }
    base.extend_from_slice(rest);
    Some(base)
}

/// The strongly connected components of `graph` with more than one member (Tarjan).
fn circles(graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<Vec<String>>> {
    struct State<'a> {
        graph: &'a BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        index: BTreeMap<&'a Vec<String>, usize>,
        low: BTreeMap<&'a Vec<String>, usize>,
        stack: Vec<&'a Vec<String>>,
        on_stack: BTreeSet<&'a Vec<String>>,
        found: Vec<Vec<Vec<String>>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Vec<String>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in &s.graph[v] {
            if !s.index.contains_key(w) {
                visit(s, w);
                let low = s.low[w].min(s.low[v]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.index[w].min(s.low[v]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.clone());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.found.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.found
}

fn name(module: &[String]) -> String {
    if module.is_empty() {
        "lib".to_owned()
    } else {
        module.join("::")
    }
}

/// The import graph of the crate whose sources are in `src` (relative to the repository).
fn graph_of(src: &str) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let krate = Crate::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join(src));
    krate
        .files
        .keys()
        .map(|m| (m.clone(), krate.dependencies(m)))
        .collect()
}

/// The renderer's graph.
fn graph() -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    graph_of("render/src")
}

#[test]
fn no_file_of_the_renderer_imports_another_in_a_circle() {
    assert_no_circle(&graph());
}

#[test]
fn no_file_of_the_effects_crate_or_the_program_imports_another_in_a_circle() {
    assert_no_circle(&graph_of("fx/src"));
    assert_no_circle(&graph_of("src"));
}

/// Prints `graph` and fails naming each circle of files and the imports that close it.
fn assert_no_circle(graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) {
    for (module, deps) in graph {
        let deps: Vec<String> = deps.iter().map(|d| name(d)).collect();
        println!("{} -> {}", name(module), deps.join(", "));
    }
    let found = circles(graph);
    let report: Vec<String> = found
        .iter()
        .map(|c| {
            let members: BTreeSet<&Vec<String>> = c.iter().collect();
            let edges: Vec<String> = c
                .iter()
                .flat_map(|m| {
                    graph[m]
                        .iter()
                        .filter(|d| members.contains(d))
                        .map(move |d| format!("{} -> {}", name(m), name(d)))
                })
                .collect();
            format!("circle of {}: {}", c.len(), edges.join("; "))
        })
        .collect();
    assert!(found.is_empty(), "{}", report.join("\n"));
}

/// The layers of `render/src`, bottom first: a folder (or root file) may use the layers below
/// its own and itself, never one above. `ARCHITECTURE.md` draws the same.
const LAYERS: &[&[&str]] = &[
    &["error", "color", "platform"],
    &["sampling"],
    &["geometry", "texture", "camera"],
    &["media"],
    &["material"],
    &["portals"],
    &["lights"],
    &["through"],
    &["scene"],
    &["integrator"],
    &["prepare"],
    &["frame"],
    &["untrusted", "lib"],
];

/// The layer of the folder (or root file) holding `module`.
fn layer(module: &[String]) -> usize {
    let top = module.first().map_or("lib", String::as_str);
    LAYERS
        .iter()
        .position(|layer| layer.contains(&top))
        .unwrap_or_else(|| panic!("{top} is in no layer of LAYERS: add it where it belongs"))
}

#[test]
fn each_folder_uses_only_the_layers_below_it() {
    let graph = graph();
    let upward: Vec<String> = graph
        .iter()
        .flat_map(|(module, deps)| {
            deps.iter()
                .filter(|d| layer(d) > layer(module))
                .map(move |d| format!("{} -> {}", name(module), name(d)))
        })
        .collect();
    assert!(
        upward.is_empty(),
        "imports of a higher layer:\n{}",
        upward.join("\n")
    );
}

#[test]
fn the_graph_reader_resolves_uses_reexports_and_inline_paths() {
    let tree = expand_use("crate::a::{self, b::{C, d as e}, f::*}");
    let paths: Vec<String> = tree
        .iter()
        .map(|(p, b)| format!("{}={b}", p.join("::")))
        .collect();
    assert_eq!(
        paths,
        [
            "crate::a=a",
            "crate::a::b::C=C",
            "crate::a::b::d=e",
            "crate::a::f="
        ]
    );
    let code = code_only("let s = \"crate::x::Y\"; // crate::z::W\n crate::q::R::new('c', '{')");
    let roots = BTreeSet::from(["geometry".to_owned()]);
    let found = inline_paths(&code, &roots);
    assert_eq!(found, [vec!["crate", "q", "R", "new"]]);
    let code = without_tests("use crate::a;\n#[cfg(test)]\nmod tests { use crate::b; }\n");
    assert!(code.contains("crate::a") && !code.contains("crate::b"));

    // This crate: the integrator reaches the scene's module, and a folder's front re-export
    // leads to the child that defines the type.
    let graph = graph();
    assert!(graph.len() > 20, "{} modules", graph.len());
    assert!(graph.values().map(BTreeSet::len).sum::<usize>() > 50);
}
