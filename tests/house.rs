//! The house rules that keep the code readable, checked so they hold: no source file over 800
//! lines, no function over 120 lines (counted from its `fn` line to its closing brace).

mod common;

const MAX_FILE_LINES: usize = 800;
const MAX_FUNCTION_LINES: usize = 120;

#[test]
fn files_and_functions_fit_on_a_few_screens() {
    let files = common::rust_sources(&common::root().join("src"));
    assert!(files.len() > 50, "found only {} source files", files.len());
    let mut problems = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        if lines.len() > MAX_FILE_LINES {
            problems.push(format!("{}: {} lines", file.display(), lines.len()));
        }
        for (name, length) in long_functions(&lines) {
            problems.push(format!("{}: fn {name} is {length} lines", file.display()));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

/// Functions longer than the limit: (name, lines). Braces in strings and comments are counted
/// too, which only ever lengthens a function's span, never hides one.
fn long_functions(lines: &[&str]) -> Vec<(String, usize)> {
    let mut found = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let Some(name) = function_name(line) else {
            continue;
        };
        let (mut depth, mut opened) = (0i64, false);
        for (offset, body) in lines[start..].iter().enumerate() {
            for c in body.chars() {
                match c {
                    '{' => (depth, opened) = (depth + 1, true),
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            // A declaration without a body (in a trait) ends at its semicolon.
            if !opened && body.trim_end().ends_with(';') {
                break;
            }
            if opened && depth <= 0 {
                if offset + 1 > MAX_FUNCTION_LINES {
                    found.push((name.clone(), offset + 1));
                }
                break;
            }
        }
    }
    found
}

/// The name of the function a line declares, if it declares one.
fn function_name(line: &str) -> Option<String> {
    let code = line.split("//").next()?.trim_start();
    let mut words = code.split_whitespace().peekable();
    while let Some(word) = words.next() {
        let qualifier = word.starts_with("pub")
            || matches!(word, "const" | "async" | "unsafe" | "extern" | "\"C\"");
        if word == "fn" {
            let name: String = words
                .next()?
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            return (!name.is_empty()).then_some(name);
        }
        if !qualifier {
            return None;
        }
    }
    None
}
