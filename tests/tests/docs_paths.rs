//! The documents cite only what exists: every repository path written in backticks in
//! README.md and docs/ (ARCHITECTURE.md, the user guide docs/guide/, the design pages
//! docs/design/, the other pages), and every relative Markdown link with its `#anchor`.
//! A file moved or renamed without its documents fails here, naming each stale citation.
//! Needs no binary: it reads the files only.

use std::path::{Path, PathBuf};

/// Endings of a cited repository file (a cited folder ends in `/`).
const FILE_ENDINGS: [&str; 10] = [
    ".rs", ".toml", ".md", ".sh", ".py", ".js", ".json", ".html", ".css", ".nc",
];

/// First folders of paths the documents cite that are not in the repository: what a run or
/// a build writes (`runs/`, `logs/`, `target/`, the other hosts' `hosts/<host>/logs/`) and
/// the unpacked npm package of the uPlot refresh recipe (`package/`).
const NOT_IN_THE_REPOSITORY: [&str; 5] = ["runs/", "logs/", "target/", "hosts/", "package/"];

/// The Markdown files checked: README.md and every `.md` under docs/.
fn documents(root: &Path) -> Vec<PathBuf> {
    let mut out = vec![root.join("README.md")];
    let mut dirs = vec![root.join("docs")];
    while let Some(dir) = dirs.pop() {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
            .map(|e| e.expect("a folder entry").path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|e| e == "md") {
                out.push(p);
            }
        }
    }
    out
}

/// Is a code span (the text between backticks) a repository path? It has a folder and a
/// name (`a/b.rs`, `a/b/`), no placeholder or spaces (`logs/<process>.jsonl`, `OUT/…`,
/// `RUN_DIR/iox2.toml` are not), is relative, and ends like a file or a folder.
fn is_repository_path(span: &str) -> bool {
    let body = span.strip_suffix('/').unwrap_or(span);
    let first = span.split('/').next().unwrap_or("");
    body.contains('/')
        && !span.starts_with(['/', '.', '~'])
        && span
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "/_-.".contains(c))
        && !(first.chars().all(|c| c.is_ascii_uppercase() || c == '_'))
        && !NOT_IN_THE_REPOSITORY.iter().any(|p| span.starts_with(p))
        && (span.ends_with('/') || FILE_ENDINGS.iter().any(|e| span.ends_with(e)))
}

/// The code spans of a line (inline code only; fenced blocks are skipped by the caller).
fn code_spans(line: &str) -> Vec<&str> {
    line.split('`').skip(1).step_by(2).collect()
}

/// The targets of the Markdown links of a line: `[text](target)`.
fn link_targets(line: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        match after.find(')') {
            Some(end) => {
                out.push(&after[..end]);
                rest = &after[end..];
            }
            None => break,
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, only letters, digits, spaces, `-` and `_`
/// kept, spaces turned into `-`.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of every heading of a Markdown file (outside fenced blocks).
fn anchors(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            out.push(anchor(line.trim_start_matches('#')));
        }
    }
    out
}

/// Every stale citation of the document `doc`: "file:line: what".
fn stale_citations(root: &Path, doc: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(doc).expect("a document");
    let name = doc.strip_prefix(root).unwrap_or(doc).display().to_string();
    let mut stale = Vec::new();
    let mut fenced = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        let at = format!("{name}:{}", i + 1);
        for span in code_spans(line) {
            if is_repository_path(span) && !root.join(span).exists() {
                stale.push(format!("{at}: `{span}` does not exist"));
            }
        }
        for target in link_targets(line) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, frag) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target, None),
            };
            let path = if file.is_empty() {
                doc.to_path_buf()
            } else {
                doc.parent().expect("a folder").join(file)
            };
            if !path.exists() {
                stale.push(format!("{at}: link ({target}) leads nowhere"));
                continue;
            }
            if let Some(frag) = frag.filter(|_| path.extension().is_some_and(|e| e == "md")) {
                let heads = anchors(&std::fs::read_to_string(&path).expect("a linked page"));
                if !heads.iter().any(|h| h == frag) {
                    stale.push(format!("{at}: link ({target}): no heading #{frag} there"));
                }
            }
        }
    }
    stale
}

#[test]
fn every_path_and_link_the_documents_cite_exists() {
    let root = tests::workspace();
    let docs = documents(&root);
    assert!(
        docs.iter().any(|d| d.ends_with("docs/ARCHITECTURE.md"))
            && docs.iter().any(|d| d.starts_with(root.join("docs/guide"))),
        "{docs:?}"
    );
    let stale: Vec<String> = docs
        .iter()
        .flat_map(|d| stale_citations(&root, d))
        .collect();
    assert!(
        stale.is_empty(),
        "{} stale citations in the documents:\n{}",
        stale.len(),
        stale.join("\n")
    );
}

#[test]
fn the_checker_tells_paths_from_other_code_and_reads_anchors_as_github_does() {
    for path in [
        "view/src/model/mod.rs",
        "deploy/run.sh",
        "coordinator/src/record/",
        "deploy/missions/ocean.nc",
    ] {
        assert!(is_repository_path(path), "{path}");
    }
    for other in [
        "logs/<process>.jsonl",
        "RUN_DIR/iox2.toml",
        "OUT/failures/m0007_robust.toml",
        "/dev/shm/iceoryx2/",
        "<m>/vehicle/<id>/state",
        "vbap_math::fit",
        "run/",
        "math/src",
        "target/view-artifacts/",
        "a b/c.rs",
    ] {
        assert!(!is_repository_path(other), "{other}");
    }
    assert_eq!(
        anchor("§7.1 Control over the links the fleet really has (`[control] law = \"robust\"`, the default)"),
        "71-control-over-the-links-the-fleet-really-has-control-law--robust-the-default"
    );
    assert_eq!(
        link_targets("see [a](x.md#b) and [c](../d/)."),
        vec!["x.md#b", "../d/"]
    );
    // A stale path is found: a document citing one fails, naming it.
    let tmp = tests::TempDir::new("docs-paths");
    let doc = tmp.join("README.md");
    std::fs::write(&doc, "`view/src/model.rs` and [x](nowhere.md)\n").unwrap();
    let stale = stale_citations(&tests::workspace(), &doc);
    assert_eq!(stale.len(), 2, "{stale:?}");
    assert!(
        stale[0].contains("`view/src/model.rs` does not exist"),
        "{stale:?}"
    );
}
