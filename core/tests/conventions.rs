//! The Rust section of `docs/api.md`, enforced on `core/src`: a public
//! function or method returns `Result` if and only if its name starts with
//! `try_`, and no public type is named `...Params` (settings are
//! `...Options`, bundles of inputs `...Input`). The scanner reads the
//! sources as text (signatures over several lines, generics, `where`
//! clauses and closure types included); each rule has a unit test on a bad
//! sample that shows it fails.

use std::path::{Path, PathBuf};

/// A public function's name, return type (empty for `()`) and line.
#[derive(Debug, PartialEq)]
struct Signature {
    name: String,
    ret: String,
    line: usize,
}

/// `src` without comments (line, doc and block comments), string literals
/// emptied, newlines kept so that line numbers stay.
fn strip(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        if b[i..].starts_with(b"//") {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i..].starts_with(b"/*") {
            let mut depth = 0;
            while i < b.len() {
                if b[i..].starts_with(b"/*") {
                    depth += 1;
                    i += 2;
                } else if b[i..].starts_with(b"*/") {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if b[i] == b'\n' {
                        out.push('\n');
                    }
                    i += 1;
                }
            }
        } else if b[i] == b'"' {
            out.push('"');
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                } else if b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            out.push('"');
            i += 1;
        } else {
            let c = src[i..].chars().next().unwrap();
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The public (`pub`, not `pub(crate)` or `pub(super)`) functions and
/// methods of a source file.
fn public_fns(src: &str) -> Vec<Signature> {
    let s = strip(src);
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = s[from..].find("pub ") {
        let at = from + k;
        from = at + 4;
        if at > 0 && is_ident(s[..at].chars().next_back().unwrap()) {
            continue;
        }
        let mut rest = s[at + 4..].trim_start();
        for q in ["const ", "unsafe ", "async ", "extern \"C\" ", "extern "] {
            rest = rest.strip_prefix(q).map_or(rest, str::trim_start);
        }
        let Some(rest) = rest.strip_prefix("fn ") else {
            continue;
        };
        let rest = rest.trim_start();
        let name: String = rest.chars().take_while(|&c| is_ident(c)).collect();
        // The parameter list: the first `(` after the name and generics,
        // matched.
        let open = rest.find('(').unwrap();
        let mut depth = 0;
        let mut close = open;
        for (i, c) in rest[open..].char_indices() {
            match c {
                '(' => depth += 1,
                ')' => {
                    depth -= 1;
                    if depth == 0 {
                        close = open + i;
                        break;
                    }
                }
                _ => {}
            }
        }
        let after = rest[close + 1..].trim_start();
        let ret = match after.strip_prefix("->") {
            None => String::new(),
            Some(r) => return_type(r),
        };
        let line = s[..at].matches('\n').count() + 1;
        out.push(Signature { name, ret, line });
    }
    out
}

/// The return type at the start of `r`: up to `{`, `;` or `where` outside
/// brackets (`->` inside a closure type is not a bracket).
fn return_type(r: &str) -> String {
    let mut depth = 0i32;
    let mut end = r.len();
    let mut prev = ' ';
    for (i, c) in r.char_indices() {
        match c {
            '<' | '(' | '[' => depth += 1,
            '>' if prev != '-' => depth -= 1,
            ')' | ']' => depth -= 1,
            '{' | ';' if depth == 0 => {
                end = i;
                break;
            }
            'w' if depth == 0
                && r[i..].starts_with("where")
                && !is_ident(prev)
                && !r[i + 5..].starts_with(is_ident) =>
            {
                end = i;
                break;
            }
            _ => {}
        }
        prev = c;
    }
    r[..end].split_whitespace().collect::<Vec<_>>().join(" ")
}

fn returns_result(ret: &str) -> bool {
    let r = ret
        .trim_start_matches("core::result::")
        .trim_start_matches("std::result::");
    r == "Result" || r.starts_with("Result<") || r.starts_with("Result <")
}

/// Rule "`try_` means `Result`": violations as `file:line: message`.
fn check_try(file: &str, src: &str) -> Vec<String> {
    public_fns(src)
        .into_iter()
        .filter_map(|f| {
            let is_try = f.name.starts_with("try_");
            let is_result = returns_result(&f.ret);
            match (is_try, is_result) {
                (false, true) => Some(format!(
                    "{file}:{}: `{}` returns {} without the try_ prefix",
                    f.line, f.name, f.ret
                )),
                (true, false) => Some(format!(
                    "{file}:{}: `{}` has the try_ prefix but returns `{}`",
                    f.line, f.name, f.ret
                )),
                _ => None,
            }
        })
        .collect()
}

/// Rule "`Options`, never `Params`": public types named `...Params`.
fn check_params(file: &str, src: &str) -> Vec<String> {
    let s = strip(src);
    let mut v = Vec::new();
    for (n, line) in s.lines().enumerate() {
        let t = line.trim_start();
        for kind in [
            "pub struct ",
            "pub enum ",
            "pub type ",
            "pub trait ",
            "pub union ",
        ] {
            if let Some(rest) = t.strip_prefix(kind) {
                let name: String = rest.chars().take_while(|&c| is_ident(c)).collect();
                if name.contains("Params") {
                    v.push(format!(
                        "{file}:{}: `{name}` (settings are ...Options, inputs ...Input)",
                        n + 1
                    ));
                }
            }
        }
    }
    v
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn core_sources_follow_docs_api_md() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    sources(&root.join("src"), &mut files);
    files.sort();
    assert!(files.len() >= 15, "{files:?}");
    let (mut v, mut fns) = (Vec::new(), 0);
    for f in &files {
        let src = std::fs::read_to_string(f).unwrap();
        let name = f.strip_prefix(root).unwrap().display().to_string();
        fns += public_fns(&src).len();
        v.extend(check_try(&name, &src));
        v.extend(check_params(&name, &src));
    }
    assert!(fns > 150, "found only {fns} public functions");
    assert!(
        v.is_empty(),
        "{} violations of docs/api.md:\n{}",
        v.len(),
        v.join("\n")
    );
}

const BAD: &str = r#"
/// `pub fn in_a_comment() -> Result<(), Error>` is not code.
pub fn hiz_len(w: u32) -> Result<usize, Error> {
    let s = "pub fn in_a_string() -> Result<(), Error> {";
}
impl Thing {
    pub fn trace(
        &self,
        ray: &Ray,
    ) -> Result<Trace, Error> {
        todo!()
    }
    pub const fn try_len(&self) -> usize {
        0
    }
    pub fn try_split(self) -> core::result::Result<(Self, Self), (Error, Self)> {
        todo!()
    }
    pub fn try_map<F>(&self, f: F) -> Result<u32, Error>
    where
        F: Fn(u32) -> u32,
    {
        todo!()
    }
    pub fn apply(&self, f: impl Fn(u32) -> Result<u32, Error>) -> Option<u32> {
        None
    }
    pub(crate) fn helper() -> Result<(), Error> {
        Ok(())
    }
    pub fn try_unit(&self) {}
}
pub struct LayeredParams {
    pub x: f32,
}
pub(crate) struct HiddenParams;
"#;

#[test]
fn the_scanner_reads_multi_line_signatures() {
    let fns = public_fns(BAD);
    let got: Vec<(&str, &str)> = fns
        .iter()
        .map(|f| (f.name.as_str(), f.ret.as_str()))
        .collect();
    assert_eq!(
        got,
        [
            ("hiz_len", "Result<usize, Error>"),
            ("trace", "Result<Trace, Error>"),
            ("try_len", "usize"),
            (
                "try_split",
                "core::result::Result<(Self, Self), (Error, Self)>"
            ),
            ("try_map", "Result<u32, Error>"),
            ("apply", "Option<u32>"),
            ("try_unit", ""),
        ]
    );
    assert_eq!(fns[1].line, 7);
}

#[test]
fn each_rule_fails_on_a_violation() {
    let v = check_try("bad.rs", BAD);
    let names: Vec<&str> = v.iter().map(|s| s.split('`').nth(1).unwrap()).collect();
    assert_eq!(names, ["hiz_len", "trace", "try_len", "try_unit"], "{v:?}");
    let p = check_params("bad.rs", BAD);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(p[0].contains("LayeredParams"));
    // Compliant code passes.
    let good = "pub fn try_hiz_len(w: u32) -> Result<usize, Error> { todo!() }\n\
                pub fn len(&self) -> usize { 0 }\npub struct LayeredOptions;";
    assert!(check_try("good.rs", good).is_empty());
    assert!(check_params("good.rs", good).is_empty());
}
