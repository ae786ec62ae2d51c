//! The guides quote the real sources: every code block of docs/writing-a-plugin.md and
//! docs/integrators.md that begins with `// from FILE` (or `# from FILE`) must be a contiguous
//! run of FILE's lines (blank lines aside), or several such runs in order, each gap marked by an
//! elision line (`// …`, or `# …` in TOML): an excerpt cannot leave lines out silently.

use std::path::Path;

/// Whether `line` (trimmed) marks an elision in an excerpt.
fn is_elision(line: &str) -> bool {
    matches!(line, "// …" | "# …" | "…")
}

/// Checks an excerpt (`block`, without its `from` line) against `source`: each run between
/// elisions must be contiguous lines of `source`, the runs in order. Returns the first line
/// that breaks it, with why.
fn check_excerpt(block: &[&str], source: &str) -> Result<(), String> {
    let src: Vec<&str> = source.lines().map(str::trim).collect();
    let mut from = 0;
    for run in block.split(|l| is_elision(l.trim())) {
        let run: Vec<&str> = run.iter().map(|l| l.trim()).filter(|l| !l.is_empty()).collect();
        let Some(first) = run.first() else { continue };
        // The run's first line, then every next one after nothing but blank lines.
        let starts = (from..src.len()).filter(|&i| src[i] == *first);
        let mut found = None;
        'start: for start in starts {
            let mut at = start;
            for want in &run[1..] {
                at += 1;
                while at < src.len() && src[at].is_empty() {
                    at += 1;
                }
                if at >= src.len() || src[at] != *want {
                    continue 'start;
                }
            }
            found = Some(at + 1);
            break;
        }
        from = found
            .ok_or_else(|| format!("not a contiguous run of the file after line {from} (mark a gap with `// …`):\n{}", run.join("\n")))?;
    }
    Ok(())
}

/// Checks the excerpts of the guide at `doc` (relative to the repository) and returns how many
/// there are.
fn check_excerpts(doc: &str) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let guide = std::fs::read_to_string(root.join(doc)).unwrap();
    let mut checked = 0;
    let mut lines = guide.lines();
    while let Some(line) = lines.next() {
        if !line.starts_with("```") || line == "```" {
            continue;
        }
        let block: Vec<&str> = lines.by_ref().take_while(|l| !l.starts_with("```")).collect();
        let Some(file) = block.first().and_then(|f| f.strip_prefix("// from ").or_else(|| f.strip_prefix("# from "))) else { continue };
        let source = std::fs::read_to_string(root.join(file)).unwrap_or_else(|e| panic!("{doc}: {file}: {e}"));
        if let Err(e) = check_excerpt(&block[1..], &source) {
            panic!("{doc} quotes {file} wrongly: {e}");
        }
        checked += 1;
    }
    checked
}

#[test]
fn the_plugin_guides_excerpts_match_the_sources() {
    let checked = check_excerpts("docs/writing-a-plugin.md");
    assert!(checked >= 8, "only {checked} excerpts found");
}

#[test]
fn the_integrator_guides_excerpts_match_the_sources() {
    let checked = check_excerpts("docs/integrators.md");
    assert!(checked >= 12, "only {checked} excerpts found");
}

/// The check refuses what it is for: a line left out without an elision, lines out of order, a
/// line the file does not have; and accepts a marked gap and blank lines.
#[test]
fn an_excerpt_must_be_contiguous_or_say_where_it_is_not() {
    let source = "fn a() {\n    one();\n\n    two();\n    three();\n}\n";
    assert!(check_excerpt(&["fn a() {", "    one();", "    two();"], source).is_ok());
    assert!(check_excerpt(&["fn a() {", "    one();", "", "", "    two();"], source).is_ok());
    assert!(check_excerpt(&["fn a() {", "    // …", "    three();", "}"], source).is_ok());
    assert!(check_excerpt(&["fn a() {", "    two();"], source).is_err(), "a silent gap");
    assert!(check_excerpt(&["    two();", "    one();"], source).is_err(), "out of order");
    assert!(check_excerpt(&["    two();", "// …", "    one();"], source).is_err(), "runs out of order");
    assert!(check_excerpt(&["    four();"], source).is_err(), "not in the file");
}
