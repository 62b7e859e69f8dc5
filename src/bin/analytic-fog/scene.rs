//! The scene file: JSON parsed with serde into a [`SceneDesc`], errors reported at the
//! line (and column) where the offending field is written.

use crate::CliResult;
use analytic_fog::{Scene, SceneDesc, SceneError};
use std::fs;
use std::path::Path;

pub(crate) fn load_scene(path: &Path) -> CliResult<Scene> {
    let name = path.display();
    let bytes = fs::read(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    let desc: SceneDesc =
        serde_json::from_slice(&bytes).map_err(|e| json_error(&name.to_string(), &bytes, &e))?;
    Scene::new(desc).map_err(|e| scene_error(&name.to_string(), &bytes, &e))
}

/// `S.json:LINE:COL: field PATH: message` for a serde_json error.
fn json_error(name: &str, text: &[u8], e: &serde_json::Error) -> String {
    let (line, col) = (e.line(), e.column());
    let full = e.to_string();
    let suffix = format!(" at line {line} column {col}");
    let msg = full.strip_suffix(&suffix).unwrap_or(&full);
    if line == 0 {
        return format!("{name}: {msg}");
    }
    let path = json_path_at(text, line_col_offset(text, line, col));
    if path.is_empty() {
        format!("{name}:{line}:{col}: {msg}")
    } else {
        format!("{name}:{line}:{col}: field {path}: {msg}")
    }
}

/// `S.json:LINE: field PATH: message` for a scene that does not validate.
fn scene_error(name: &str, text: &[u8], e: &SceneError) -> String {
    let field = e.field();
    match json_line_of(text, field) {
        Some(line) => format!("{name}:{line}: field {e}"),
        None => format!("{name}: field {e}"),
    }
}

/// The byte offset of serde_json's (1-based line, column) position.
fn line_col_offset(text: &[u8], line: usize, col: usize) -> usize {
    let mut start = 0;
    let mut l = 1;
    for (i, &c) in text.iter().enumerate() {
        if l == line {
            break;
        }
        if c == b'\n' {
            l += 1;
            start = i + 1;
        }
    }
    (start + col).saturating_sub(1)
}

/// An object or array being walked: where its own path ends in the path buffer.
struct Frame {
    is_obj: bool,
    expect_key: bool,
    base: usize,
    index: usize,
}

/// Walks (possibly malformed) JSON text and calls `ev(offset, path)` at the start of every
/// key and value and at the end of every object and array, with the path of that value in
/// the notation of [`SceneError`] (`height_fog[0].components[1].scattering`). Stops when
/// `ev` returns true. Iterative, and the path is kept in one buffer: linear time and no
/// recursion, whatever the nesting.
fn json_walk(text: &[u8], mut ev: impl FnMut(usize, &str) -> bool) {
    use std::fmt::Write as _;
    let mut stack: Vec<Frame> = Vec::new();
    let mut path = String::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        match c {
            b'{' | b'[' => {
                if ev(i, &path) {
                    return;
                }
                let is_obj = c == b'{';
                stack.push(Frame {
                    is_obj,
                    expect_key: is_obj,
                    base: path.len(),
                    index: 0,
                });
                if !is_obj {
                    path.push_str("[0]");
                }
                i += 1;
            }
            b'}' | b']' => {
                let base = stack.pop().map_or(0, |f| f.base);
                path.truncate(base);
                if ev(i, &path) {
                    return;
                }
                i += 1;
            }
            b',' => {
                if let Some(f) = stack.last_mut() {
                    path.truncate(f.base);
                    if f.is_obj {
                        f.expect_key = true;
                    } else {
                        f.index += 1;
                        let _ = write!(path, "[{}]", f.index);
                    }
                }
                i += 1;
            }
            b'"' => {
                let start = i;
                let mut s = Vec::new();
                i += 1;
                while i < text.len() && text[i] != b'"' {
                    if text[i] == b'\\' {
                        i += 1;
                    }
                    if i < text.len() {
                        s.push(text[i]);
                    }
                    i += 1;
                }
                i += 1;
                if let Some(f) = stack.last_mut() {
                    if f.is_obj && f.expect_key {
                        f.expect_key = false;
                        path.truncate(f.base);
                        if f.base > 0 {
                            path.push('.');
                        }
                        path.push_str(&String::from_utf8_lossy(&s));
                    }
                }
                if ev(start, &path) {
                    return;
                }
            }
            b':' => i += 1,
            c if c.is_ascii_whitespace() => i += 1,
            _ => {
                // A number or literal.
                if ev(i, &path) {
                    return;
                }
                while i < text.len() && !b",:{}[]\" \t\r\n".contains(&text[i]) {
                    i += 1;
                }
            }
        }
    }
}

/// The path of the value being read at byte `offset` (for a serde_json error there):
/// that of the last event at or before it.
fn json_path_at(text: &[u8], offset: usize) -> String {
    let mut last = None;
    json_walk(text, |at, _| {
        if at > offset {
            return true;
        }
        last = Some(at);
        false
    });
    let mut path = String::new();
    if let Some(last) = last {
        json_walk(text, |at, p| {
            if at == last {
                path = p.to_string();
            }
            at >= last
        });
    }
    path
}

/// The 1-based line where the value at `field` (or its nearest written ancestor: a
/// channel `scattering[2]` written as one number is found at `scattering`) starts.
fn json_line_of(text: &[u8], field: &str) -> Option<usize> {
    // "height_fog[0].components: extinction[0]" names the components list.
    let field = field.split(':').next().unwrap_or(field).trim();
    let mut candidates = vec![field.to_string()];
    let mut f = field;
    while let Some(cut) = f.rfind(['.', '[']) {
        f = &f[..cut];
        candidates.push(f.to_string());
    }
    let mut found: Vec<Option<usize>> = vec![None; candidates.len()];
    json_walk(text, |at, p| {
        if let Some(k) = candidates.iter().position(|c| c == p) {
            if found[k].is_none() {
                found[k] = Some(at);
            }
        }
        found[0].is_some()
    });
    let at = found.into_iter().flatten().next()?;
    Some(1 + text[..at].iter().filter(|&&c| c == b'\n').count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_paths() {
        let text = br#"{ "up": [0, 1, 0],
  "height_fog": [ { "base_height": 0.0, "falloff": 0.08,
      "components": [ { "scattering": 0.02, "absorption": [0, -1, 0] } ] } ] }"#;
        assert_eq!(json_line_of(text, "up[1]"), Some(1));
        assert_eq!(json_line_of(text, "height_fog[0].falloff"), Some(2));
        assert_eq!(
            json_line_of(text, "height_fog[0].components[0].absorption[1]"),
            Some(3)
        );
        // Written as one number: found at its parent.
        assert_eq!(
            json_line_of(text, "height_fog[0].components[0].scattering[2]"),
            Some(3)
        );
        assert_eq!(
            json_line_of(text, "height_fog[0].components: extinction[0]"),
            Some(3)
        );
        let s = std::str::from_utf8(text).unwrap();
        let at = s.find("-1").unwrap();
        assert_eq!(
            json_path_at(text, at),
            "height_fog[0].components[0].absorption[1]"
        );
        let at = s.find("0.08").unwrap();
        assert_eq!(json_path_at(text, at), "height_fog[0].falloff");
        // Deep or broken nesting does not recurse.
        let deep = vec![b'['; 100_000];
        assert!(json_path_at(&deep, 99_999).ends_with("[0]"));
        assert_eq!(json_path_at(b"\"abc", 3), "");
    }
}
