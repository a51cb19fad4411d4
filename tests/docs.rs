//! The user docs hold together: every link in `README.md`, `ARCHITECTURE.md` and `docs/*.md`
//! resolves (a file, and a heading where the link names one), and every repository path they
//! name in backticks exists, so a renamed file or folder cannot leave the docs behind.

use crate::common;

use common::root;
use std::path::{Path, PathBuf};

/// The pages checked: the front page, the map of the code and the user guide.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md"), root().join("ARCHITECTURE.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    pages.extend(guide);
    pages
}

/// The targets of the Markdown links (and images) in `text`, outside code.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in prose_lines(text) {
        let mut rest = line.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else {
                break;
            };
            out.push(after[..end].to_owned());
            rest = &after[end..];
        }
    }
    out
}

/// The lines of `text` outside fenced code blocks.
fn unfenced(text: &str) -> impl Iterator<Item = &str> {
    let mut fenced = false;
    text.lines().filter(move |line| {
        let fence = line.trim_start().starts_with("```");
        fenced ^= fence;
        !fence && !fenced
    })
}

/// The lines of `text` outside fenced code blocks, with inline code removed.
fn prose_lines(text: &str) -> Vec<String> {
    unfenced(text)
        .map(|line| line.split('`').step_by(2).collect::<Vec<_>>().join(""))
        .collect()
}

/// What `text` puts in inline backticks, outside fenced code blocks.
fn inline_code(text: &str) -> Vec<String> {
    unfenced(text)
        .flat_map(|line| line.split('`').skip(1).step_by(2).map(str::to_owned))
        .collect()
}

/// GitHub's anchor of a heading: lower case, punctuation dropped, spaces as hyphens.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of the headings of the Markdown file at `path`.
fn anchors(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    prose_lines(&text)
        .iter()
        .filter_map(|l| l.strip_prefix('#'))
        .map(|h| slug(h.trim_start_matches('#')))
        .collect()
}

/// Why `target`, linked from `page`, does not resolve; `None` when it does.
fn broken_link(page: &Path, target: &str) -> Option<String> {
    if target.starts_with("https://") || target.starts_with("http://") {
        return None;
    }
    let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
    let path = if file.is_empty() {
        page.to_path_buf()
    } else {
        page.parent().unwrap().join(file)
    };
    if !path.exists() {
        return Some(format!("{target}: no such file"));
    }
    let is_markdown = path.extension().is_some_and(|e| e == "md");
    (!anchor.is_empty() && is_markdown && !anchors(&path).contains(&anchor.to_owned()))
        .then(|| format!("{target}: no heading #{anchor} in {}", path.display()))
}

/// The folders a path in the docs may be written from: the repository, and the source roots
/// of the three crates (the map of the code names files within them).
fn bases() -> Vec<PathBuf> {
    ["", "render/src", "fx/src", "src"]
        .iter()
        .map(|b| root().join(b))
        .collect()
}

/// Paths that `.gitignore` anchors at the root: made by the set-up, not in a fresh clone.
fn made_by_setup(path: &str) -> bool {
    let ignore = std::fs::read_to_string(root().join(".gitignore")).unwrap();
    ignore
        .lines()
        .filter_map(|l| l.strip_prefix('/'))
        .any(|ignored| path.trim_end_matches('/') == ignored.trim_end_matches('/'))
}

/// Why the inline code `code` names a repository path that does not exist; `None` when it is
/// no repository path (a command, a pattern, another program's path) or exists.
fn missing_path(code: &str) -> Option<String> {
    let looks_like_path = code.contains('/')
        && !code.contains(char::is_whitespace)
        && !code.contains(['<', '*', '#', '%', '…', '{', '=', '(', ':'])
        && !code.starts_with(['.', '-', '/']);
    if !looks_like_path || made_by_setup(code) {
        return None;
    }
    let first = code.split('/').next().unwrap_or("");
    let bases = bases();
    let rooted: Vec<&PathBuf> = bases.iter().filter(|b| b.join(first).exists()).collect();
    if rooted.is_empty() || rooted.iter().any(|b| b.join(code).exists()) {
        return None;
    }
    Some(format!("`{code}`: no such path"))
}

#[test]
fn every_link_and_path_in_the_docs_resolves() {
    let mut problems = Vec::new();
    let mut checked = (0, 0);
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let name = page.strip_prefix(root()).unwrap().display().to_string();
        for target in links(&text) {
            checked.0 += 1;
            problems.extend(broken_link(&page, &target).map(|p| format!("{name}: {p}")));
        }
        for code in inline_code(&text) {
            checked.1 += 1;
            problems.extend(missing_path(&code).map(|p| format!("{name}: {p}")));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The pages were read.
    assert!(checked.0 >= 12 && checked.1 > 100, "{checked:?}");
}

#[test]
fn the_readme_links_every_page_of_the_guide() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let linked = links(&readme);
    for page in pages().iter().skip(2) {
        let name = format!("docs/{}", page.file_name().unwrap().to_string_lossy());
        assert!(linked.contains(&name), "README.md does not link {name}");
    }
}

#[test]
fn the_checks_find_what_is_broken() {
    let page = root().join("README.md");
    assert!(broken_link(&page, "docs/portals.md").is_none());
    assert!(broken_link(&page, "docs/no-such-page.md").is_some());
    assert!(broken_link(&page, "docs/portals.md#an-opening").is_none());
    assert!(broken_link(&page, "docs/portals.md#no-such-heading").is_some());
    assert!(missing_path("render/src/scene/schema.rs").is_none());
    assert!(missing_path("integrator/direct.rs").is_none());
    assert!(missing_path("render/src/no_such_file.rs").is_some());
    assert!(missing_path("scene/no_such_file.rs").is_some());
    // Commands, patterns, and paths outside the repository are not checked.
    assert!(missing_path("rift render examples/shots/x.toml").is_none());
    assert!(missing_path("out/showcase.####.exr").is_none());
    assert!(missing_path("1/spp").is_none());
    assert_eq!(slug("Light through openings"), "light-through-openings");
    assert_eq!(slug("Rings and `rift fx`"), "rings-and-rift-fx");
}
