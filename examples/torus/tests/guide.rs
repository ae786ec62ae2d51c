//! The guides quote the real sources: every code block of docs/writing-a-plugin.md and
//! docs/integrators.md that begins with `// from FILE` (or `# from FILE`) must consist of lines
//! of FILE, in order.

use std::path::Path;

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
        let mut src = source.lines().map(str::trim);
        for want in block[1..].iter().map(|l| l.trim()).filter(|l| !l.is_empty()) {
            assert!(src.any(|s| s == want), "{doc} quotes a line not in {file} (or out of order):\n{want}");
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
