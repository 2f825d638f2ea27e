//! Figures in the README and docs/ cannot silently go stale: every paragraph, list item or table
//! that names a result file (`benches/results/NAME.json`, written by `benches/record.sh`) may
//! quote only figures that file holds (a table, or a list after a paragraph ending in a colon:
//! those of the file that paragraph names). Tables between `<!-- table -->` markers are rendered from their file by
//! benches/render.py, and must be current. A figure with d decimals matches a number of the file
//! truncated or rounded to d decimals. Figures in code spans are commands, not results.

use std::path::{Path, PathBuf};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

#[test]
fn every_quoted_figure_is_in_the_result_file_it_names() {
    let mut pages = vec![Path::new(ROOT).join("README.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(Path::new(ROOT).join("docs"))
        .expect("docs/")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    pages.extend(docs);
    let mut problems = Vec::new();
    let mut checked = 0;
    for page in &pages {
        let text = std::fs::read_to_string(page).unwrap();
        // The files named by the paragraph above the current table or list, and whether it
        // introduces a list (ends with a colon).
        let (mut above, mut introduces_list) = (Vec::new(), false);
        for block in blocks(&text) {
            let mut names = result_files(block);
            let start = block.trim_start();
            let (table, item) = (start.starts_with('|'), start.starts_with("- "));
            // A table, or the items of a list, quote the file their introducing paragraph names.
            if names.is_empty() && (table || item && introduces_list) {
                names = above.clone();
            }
            if !table && !item {
                above = names.clone();
                introduces_list = block.trim_end().ends_with(':');
            }
            if names.is_empty() {
                continue;
            }
            let mut numbers = Vec::new();
            for name in &names {
                match load_numbers(name) {
                    Ok(found) => numbers.extend(found),
                    Err(why) => problems.push(format!("{}: {why}", page.display())),
                }
            }
            for figure in figures(block) {
                checked += 1;
                if !present(&figure, &numbers) {
                    let start: String = block.chars().take(80).collect();
                    problems.push(format!(
                        "{}: {figure} is not in {names:?} (block: {start}...)",
                        page.display()
                    ));
                }
            }
        }
    }
    assert!(checked > 50, "only {checked} figures cite a result file");
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Paragraphs, and each item of a list, separately.
fn blocks(text: &str) -> Vec<&str> {
    text.split("\n\n")
        .flat_map(|paragraph| {
            let mut items = Vec::new();
            let mut start = 0;
            for (at, _) in paragraph.match_indices("\n- ") {
                items.push(&paragraph[start..at]);
                start = at + 1;
            }
            items.push(&paragraph[start..]);
            items
        })
        .collect()
}

/// The result files a block names (a placeholder such as NAME is not one).
fn result_files(block: &str) -> Vec<String> {
    let mut names = Vec::new();
    for (at, prefix) in block.match_indices("benches/results/") {
        let rest = &block[at + prefix.len()..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == '_')
            .collect();
        let is_json = rest[name.len()..].starts_with(".json");
        if is_json && name.chars().any(|c| c.is_ascii_lowercase()) && !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

/// Every number in the file (strings that hold numbers included), or why it cannot be read.
fn load_numbers(name: &str) -> Result<Vec<f64>, String> {
    let path = Path::new(ROOT).join(format!("benches/results/{name}.json"));
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    collect(&value, &mut out);
    Ok(out)
}

fn collect(value: &serde_json::Value, out: &mut Vec<f64>) {
    match value {
        serde_json::Value::Number(n) => out.extend(n.as_f64()),
        serde_json::Value::String(s) => {
            out.extend(figures(s).iter().map(|f| f.parse::<f64>().unwrap()))
        }
        serde_json::Value::Array(items) => items.iter().for_each(|v| collect(v, out)),
        serde_json::Value::Object(map) => map.values().for_each(|v| collect(v, out)),
        _ => {}
    }
}

/// Decimal figures (digits, a point, digits) outside code spans, thousands separators removed.
fn figures(block: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, part) in block.split('`').enumerate() {
        if i % 2 == 1 {
            continue;
        }
        let chars: Vec<char> = part.chars().collect();
        let mut at = 0;
        while at < chars.len() {
            let starts = chars[at].is_ascii_digit()
                && (at == 0 || !is_word(chars[at - 1]) && chars[at - 1] != '.');
            if !starts {
                at += 1;
                continue;
            }
            let mut end = at;
            while end < chars.len()
                && (is_word(chars[end]) || chars[end] == '.' || chars[end] == ',')
            {
                // A comma is a thousands separator only between digits.
                let comma_inside =
                    chars[end] == ',' && chars.get(end + 1).is_some_and(char::is_ascii_digit);
                if chars[end] == ',' && !comma_inside {
                    break;
                }
                end += 1;
            }
            let token: String = chars[at..end].iter().filter(|c| **c != ',').collect();
            // A unit may follow the number (2526.2x, 0.5s); an exponent may not (1.5e-3).
            let number = token.trim_end_matches(|c: char| c.is_ascii_alphabetic());
            let number = number.trim_end_matches('.');
            let unit = &token[number.len()..];
            let exponent = unit.starts_with(['e', 'E']) && chars.get(end) == Some(&'-');
            if is_decimal(number) && !exponent && !unit.starts_with('.') {
                out.push(number.to_string());
            }
            at = end.max(at + 1);
        }
    }
    out
}

fn is_word(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// Digits, one point, digits, and nothing else (not a version like 1.2.3, not 1e5).
fn is_decimal(token: &str) -> bool {
    let mut parts = token.split('.');
    let (Some(whole), Some(fraction), None) = (parts.next(), parts.next(), parts.next()) else {
        return false;
    };
    !whole.is_empty()
        && !fraction.is_empty()
        && whole.chars().all(|c| c.is_ascii_digit())
        && fraction.chars().all(|c| c.is_ascii_digit())
}

fn present(figure: &str, numbers: &[f64]) -> bool {
    let decimals = figure.split('.').nth(1).map_or(0, str::len) as i32;
    let x: f64 = figure.parse().unwrap();
    let scale = 10f64.powi(decimals);
    let close = |v: f64| (v - x).abs() < 0.5e-3 / scale;
    numbers.iter().any(|v| {
        let v = v.abs();
        close((v * scale + 1e-9).floor() / scale) || close((v * scale).round() / scale)
    })
}

/// Rendered tables (between `<!-- table ... -->` markers) are what `benches/render.py` makes
/// from the result files now: a re-recorded file without a re-render fails here.
#[test]
fn rendered_tables_match_their_result_files() {
    let out = std::process::Command::new("python3")
        .arg(Path::new(ROOT).join("benches/render.py"))
        .arg("--check")
        .output()
        .expect("python3 runs benches/render.py");
    assert!(
        out.status.success(),
        "stale tables, run benches/render.py:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
