//! No import cycles between source files: a file may use its own ancestors and descendants
//! (a module and its children share one job), but two files that are not nested must not use
//! each other, directly or through others. Paths through `pub use` re-exports are followed to
//! the file that defines the name. Test modules at the end of a file are left out: a test may
//! read back what the code under test wrote.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

mod common;

type Module = Vec<String>;

/// Every use of one source file by another that is not nested in it.
fn edges() -> BTreeMap<Module, BTreeSet<Module>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let files = common::rust_sources(&src);
    // lib.rs and main.rs are both the root: the binary's modules and the library's share src/.
    let mut modules: BTreeMap<Module, String> = BTreeMap::new();
    for file in &files {
        modules
            .entry(module_of(&src, file))
            .or_default()
            .push_str(&code_of(file));
    }
    assert!(modules.len() > 50, "found only {} modules", modules.len());
    let reexports = reexports(&modules);
    let mut edges: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (module, code) in &modules {
        for path in used_paths(module, code) {
            let Some(target) = resolve(&path, &modules, &reexports, 0) else {
                continue;
            };
            if !nested(module, &target) {
                edges.entry(module.clone()).or_default().insert(target);
            }
        }
    }
    assert!(
        edges.values().map(BTreeSet::len).sum::<usize>() > 100,
        "too few uses found: the parser is broken"
    );
    edges
}

#[test]
fn no_two_source_files_use_each_other() {
    let edges = edges();
    let cycles: Vec<String> = cycles(&edges)
        .iter()
        .map(|c| c.iter().map(|m| m.join("/")).collect::<Vec<_>>().join(", "))
        .collect();
    assert!(
        cycles.is_empty(),
        "files that use each other, directly or through the others listed:\n{}",
        cycles.join("\n")
    );
}

/// The folders of src/ from the bottom up (docs/layout.md draws them): the wire types below
/// the recordings, the runtime above both and knowing neither DDS nor MCAP, the two shells
/// (the node, the replay) on top, the binary's folders above the library. `error.rs`, the
/// crate's error that wraps each folder's, stands outside the layers.
const LAYERS: [&str; 17] = [
    "linalg", "geometry", "skinning", "physics", "pipeline", "scene", "msg", "shm", "bag",
    "runtime", "node", "replay", "io", "training", "bench", "demo", "cli",
];

#[test]
fn folders_use_only_the_layers_below_them() {
    let layer = |m: &Module| m.first().and_then(|f| LAYERS.iter().position(|l| l == f));
    let mut upward = BTreeSet::new();
    for (from, targets) in edges() {
        for to in targets {
            if let (Some(a), Some(b)) = (layer(&from), layer(&to)) {
                if b > a {
                    upward.insert((LAYERS[a], LAYERS[b]));
                }
            }
        }
    }
    let shells = ["runtime", "node", "replay"];
    let wrong: Vec<_> = upward
        .iter()
        .filter(|(from, to)| {
            // The recordings and the runtime never reach up into a shell.
            (*from == "bag" && shells.contains(to)) || (*from == "runtime" && shells.contains(to))
        })
        .collect();
    assert!(wrong.is_empty(), "reaching up into the shells: {wrong:?}");
    assert!(
        upward.len() <= 3,
        "{} upward uses between folders (at most 3): {upward:?}",
        upward.len()
    );
}

/// `src/a/b.rs` is `a::b`; `src/a/mod.rs` is `a`; `lib.rs` and `main.rs` are the root.
fn module_of(src: &Path, file: &Path) -> Module {
    let relative = file.strip_prefix(src).unwrap().with_extension("");
    let mut module: Module = relative
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if matches!(
        module.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        module.pop();
    }
    module
}

/// The file's code without line comments and without the test module at its end.
fn code_of(file: &Path) -> String {
    let text = std::fs::read_to_string(file).unwrap();
    let mut code = String::new();
    let mut end = 0;
    for line in text.lines() {
        end += line.len() + 1;
        let rest = text.get(end..).unwrap_or("").trim_start();
        if line.trim_start().starts_with("#[cfg(test)]") && rest.starts_with("mod ") {
            break;
        }
        code.push_str(line.split("//").next().unwrap());
        code.push('\n');
    }
    code
}

fn nested(a: &Module, b: &Module) -> bool {
    a.starts_with(b) || b.starts_with(a)
}

/// Every `crate::` and `super::` path in `code`, made absolute, braces expanded.
fn used_paths(module: &Module, code: &str) -> Vec<Module> {
    let mut paths = Vec::new();
    let bytes = code.as_bytes();
    for (at, _) in code
        .match_indices("crate::")
        .chain(code.match_indices("super::"))
    {
        let joined = at > 0 && matches!(bytes[at - 1], b'_' | b':' | b'0'..=b'9' | b'a'..=b'z');
        if joined {
            continue;
        }
        let (tree, _) = parse_tree(&code[at..]);
        for path in tree {
            paths.push(absolute(module, path));
        }
    }
    paths
}

/// `crate::a::b` is `a::b`; `super::a` is a sibling of the file's module (in a `mod.rs`, of the
/// directory's module: the file is that module).
fn absolute(module: &Module, path: Vec<String>) -> Module {
    let mut base = module.clone();
    let mut rest = path.into_iter().peekable();
    if rest.peek().map(String::as_str) == Some("crate") {
        rest.next();
        base.clear();
    }
    while rest.peek().map(String::as_str) == Some("super") {
        rest.next();
        base.pop();
    }
    base.extend(rest.filter(|s| s != "self"));
    base
}

/// A use tree: `a::b::{c, d::{e, f}}` gives a::b::c, a::b::d::e, a::b::d::f. Returns the paths
/// and how many bytes were read.
fn parse_tree(s: &str) -> (Vec<Module>, usize) {
    let bytes = s.as_bytes();
    let (mut prefix, mut i) = (Vec::new(), 0);
    loop {
        let start = i;
        while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
            i += 1;
        }
        if i > start {
            prefix.push(s[start..i].to_string());
        }
        if s[i..].starts_with("::{") {
            return parse_group(s, i + 3, &prefix);
        }
        if !(i > start && s[i..].starts_with("::")) {
            return (vec![prefix], i);
        }
        i += 2;
    }
}

/// The `{...}` group whose contents start at `j`, each tree prefixed with `prefix`.
fn parse_group(s: &str, mut j: usize, prefix: &Module) -> (Vec<Module>, usize) {
    let skip = |j: usize| j + s[j..].len() - s[j..].trim_start().len();
    let mut paths = Vec::new();
    loop {
        j = skip(j);
        if s[j..].starts_with('}') {
            return (paths, j + 1);
        }
        let (inner, read) = parse_tree(&s[j..]);
        paths.extend(inner.into_iter().map(|p| [prefix.clone(), p].concat()));
        j = skip(j + read);
        // An alias (`x as y`) is skipped up to the next separator.
        while j < s.len() && !s[j..].starts_with([',', '}']) {
            j += 1;
        }
        match s.as_bytes().get(j) {
            Some(b',') => j += 1,
            Some(_) => return (paths, j + 1),
            None => return (paths, j),
        }
    }
}

/// `(module, name) -> path` for every `use` of a name in a module.
fn reexports(modules: &BTreeMap<Module, String>) -> BTreeMap<(Module, String), Module> {
    let mut found = BTreeMap::new();
    for (module, code) in modules {
        // Private uses too: a child module may name what its parent imported (`super::Name`).
        for (at, _) in code.match_indices("use ") {
            let statement = at == 0 || matches!(code.as_bytes()[at - 1], b' ' | b'\n' | b')');
            if !statement {
                continue;
            }
            let (tree, _) = parse_tree(&code[at + 4..]);
            for path in tree {
                let name = path.last().cloned().unwrap_or_default();
                let path = match path.first().map(String::as_str) {
                    Some("crate" | "super") => absolute(module, path),
                    Some("self") => [module.clone(), path[1..].to_vec()].concat(),
                    _ => [module.clone(), path].concat(),
                };
                found.insert((module.clone(), name), path);
            }
        }
    }
    found
}

/// The file a path lands in: its longest prefix that is a module, following a re-export of
/// the next name when there is one.
fn resolve(
    path: &Module,
    modules: &BTreeMap<Module, String>,
    reexports: &BTreeMap<(Module, String), Module>,
    depth: usize,
) -> Option<Module> {
    let length = (0..=path.len())
        .rev()
        .find(|&k| modules.contains_key(&path[..k]))?;
    let module = path[..length].to_vec();
    if let (Some(name), true) = (path.get(length), depth < 8) {
        if let Some(target) = reexports.get(&(module.clone(), name.clone())) {
            let followed = [target.clone(), path[length + 1..].to_vec()].concat();
            if let Some(found) = resolve(&followed, modules, reexports, depth + 1) {
                return Some(found);
            }
        }
    }
    Some(module)
}

/// One cycle per strongly connected component with more than one module (Tarjan's algorithm).
fn cycles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct Walk<'a> {
        edges: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<Module, usize>,
        low: BTreeMap<Module, usize>,
        stack: Vec<Module>,
        found: Vec<Vec<Module>>,
    }
    fn visit(w: &mut Walk, v: &Module) {
        let n = w.index.len();
        w.index.insert(v.clone(), n);
        w.low.insert(v.clone(), n);
        w.stack.push(v.clone());
        for u in w.edges.get(v).into_iter().flatten() {
            if !w.index.contains_key(u) {
                visit(w, u);
                let low = w.low[v].min(w.low[u]);
                w.low.insert(v.clone(), low);
            } else if w.stack.contains(u) {
                let low = w.low[v].min(w.index[u]);
                w.low.insert(v.clone(), low);
            }
        }
        if w.low[v] == w.index[v] {
            let at = w.stack.iter().position(|m| m == v).unwrap();
            let component = w.stack.split_off(at);
            if component.len() > 1 {
                w.found.push(component);
            }
        }
    }
    let mut walk = Walk {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !walk.index.contains_key(v) {
            visit(&mut walk, v);
        }
    }
    walk.found
}
