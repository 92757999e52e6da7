//! Strict YAML loading: serde_yaml_ng + serde_path_to_error, then validation.
//!
//! Every error names the file, the field path (`bodies[1].radius`), the line
//! and column (1-based) and the reason. Parse errors take the location from
//! the YAML parser when it has one; validation errors (and parse errors inside
//! tagged lists, where the parser buffers the value) are located by walking
//! the text along the field path ([`locate`]).

use super::validate::validate;
use super::Scene;
use std::path::{Path, PathBuf};

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read scene file: {source}")]
    Io {
        /// Scene file.
        file: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Malformed YAML, unknown key, wrong type or missing field.
    #[error("{file}:{line}:{column}: field `{path}`: {reason}")]
    Parse {
        /// Scene file.
        file: PathBuf,
        /// Field path, e.g. `physics.density`.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        reason: String,
    },
    /// Well-formed but physically or numerically invalid.
    #[error("{file}:{line}:{column}: field `{path}`: invalid value: {reason}")]
    Invalid {
        /// Scene file.
        file: PathBuf,
        /// Field path.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong, with the offending numbers.
        reason: String,
    },
}

impl SceneError {
    /// Field path the error refers to ("" for I/O errors).
    pub fn path(&self) -> &str {
        match self {
            SceneError::Io { .. } => "",
            SceneError::Parse { path, .. } | SceneError::Invalid { path, .. } => path,
        }
    }

    /// (line, column), 1-based, where known.
    pub fn location(&self) -> Option<(usize, usize)> {
        match self {
            SceneError::Io { .. } => None,
            SceneError::Parse { line, column, .. } | SceneError::Invalid { line, column, .. } => {
                Some((*line, *column))
            }
        }
    }
}

/// Loads and validates a scene file.
pub fn load(file: &Path) -> Result<Scene, SceneError> {
    let text = std::fs::read_to_string(file).map_err(|source| SceneError::Io {
        file: file.to_path_buf(),
        source,
    })?;
    load_str(&text, file)
}

/// Loads and validates scene text; `file` is only used in messages.
pub fn load_str(text: &str, file: &Path) -> Result<Scene, SceneError> {
    load_str_scaled(text, file, 1.0)
}

/// Loads scene text at a resolution scale `scale` ([`Scene::scaled`]: Δx ×
/// scale; `codimfx sim --scale`) and validates the scaled scene; messages of
/// values that the scale changed say so.
pub fn load_str_scaled(text: &str, file: &Path, scale: f64) -> Result<Scene, SceneError> {
    if !(scale.is_finite() && scale > 0.0) {
        let (line, column) = locate(text, "domain.dx");
        return Err(SceneError::Invalid {
            file: file.to_path_buf(),
            path: "domain.dx".into(),
            line,
            column,
            reason: format!("the resolution scale must be positive and finite, got {scale}"),
        });
    }
    let scene = parse(text, file)?;
    let scene = if scale == 1.0 {
        scene
    } else {
        scene.scaled(scale)
    };
    validate(&scene).map_err(|(path, reason)| {
        let (line, column) = locate(text, &path);
        SceneError::Invalid {
            file: file.to_path_buf(),
            path,
            line,
            column,
            reason: if scale == 1.0 {
                reason
            } else {
                format!("{reason} (at --scale {scale}: dx = {} m)", scene.domain.dx)
            },
        }
    })?;
    Ok(scene)
}

/// Parses scene text without validating values.
fn parse(text: &str, file: &Path) -> Result<Scene, SceneError> {
    let de = serde_yaml_ng::Deserializer::from_str(text);
    let scene: Scene = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = clean_path(&e.path().to_string());
        let inner = e.inner();
        let reason = strip_location(&inner.to_string());
        // Values inside tagged list items are buffered by serde, so the
        // parser's location points at the list; walk the text instead, down
        // to the offending key when the message names one.
        let (line, column) = match inner.location() {
            Some(l)
                if !path.contains('[') && (!path.is_empty() || l.line() > 1 || l.column() > 1) =>
            {
                (l.line(), l.column())
            }
            _ => match unknown_key(&reason) {
                Some(k) => locate(text, &format!("{path}.{k}")),
                None => locate(text, &path),
            },
        };
        SceneError::Parse {
            file: file.to_path_buf(),
            path: if path.is_empty() { ".".into() } else { path },
            line,
            column,
            reason,
        }
    })?;
    Ok(scene)
}

/// The key named by an "unknown field `k`" message.
fn unknown_key(msg: &str) -> Option<&str> {
    let rest = msg.split("unknown field `").nth(1)?;
    rest.split('`').next()
}

/// serde_path_to_error writes `.` for the root and `?` for unknown parts.
fn clean_path(p: &str) -> String {
    if p == "." {
        String::new()
    } else {
        p.to_string()
    }
}

/// Drops serde_yaml_ng's " at line L column C" suffix (we print it ourselves).
fn strip_location(msg: &str) -> String {
    match msg.find(" at line ") {
        Some(i) => msg[..i].to_string(),
        None => msg.to_string(),
    }
}

enum Seg {
    Key(String),
    Index(usize),
}

fn parse_path(path: &str) -> Vec<Seg> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|s| !s.is_empty()) {
        let mut rest = part;
        if let Some(b) = rest.find('[') {
            if b > 0 {
                out.push(Seg::Key(rest[..b].to_string()));
            }
            rest = &rest[b..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let e = stripped.find(']').unwrap_or(stripped.len());
                if let Ok(i) = stripped[..e].parse() {
                    out.push(Seg::Index(i));
                }
                rest = stripped.get(e + 1..).unwrap_or("");
            }
        } else {
            out.push(Seg::Key(rest.to_string()));
        }
    }
    out
}

fn indent_of(line: &str) -> usize {
    line.len() - line.trim_start_matches(' ').len()
}

fn is_blank(line: &str) -> bool {
    let t = line.trim();
    t.is_empty() || t.starts_with('#')
}

/// Finds the (line, column), 1-based, of a field path in block- or flow-style
/// YAML text. Falls back to the deepest enclosing field that was found.
pub fn locate(text: &str, path: &str) -> (usize, usize) {
    let lines: Vec<&str> = text.lines().collect();
    let (mut lo, mut hi) = (0usize, lines.len());
    let mut parent_indent: isize = -1;
    let mut best = (1usize, 1usize);
    // inside a flow collection: (line, column to search from)
    let mut flow: Option<(usize, usize)> = None;
    for seg in parse_path(path) {
        if let Some((l, c)) = flow {
            match seg {
                Seg::Key(k) => {
                    let pat = format!("{k}:");
                    if let Some(p) = lines[l][c..].find(&pat) {
                        best = (l + 1, c + p + 1);
                        flow = Some((l, c + p + pat.len()));
                    }
                }
                Seg::Index(_) => {}
            }
            continue;
        }
        match seg {
            Seg::Key(k) => {
                let pat = format!("{k}:");
                let mut found = None;
                for (l, line) in lines.iter().enumerate().take(hi).skip(lo) {
                    if is_blank(line) {
                        continue;
                    }
                    // strip "- " item markers, which count as indentation
                    let mut ind = indent_of(line);
                    let mut body = &line[ind..];
                    while let Some(b) = body.strip_prefix("- ") {
                        let extra = 2 + (b.len() - b.trim_start_matches(' ').len());
                        ind += extra;
                        body = b.trim_start_matches(' ');
                    }
                    if ind as isize > parent_indent && body.starts_with(&pat) {
                        found = Some((l, ind, body[pat.len()..].trim_start()));
                        break;
                    }
                }
                let Some((l, ind, value)) = found else { break };
                best = (l + 1, ind + 1);
                if value.starts_with('{') || value.starts_with('[') {
                    let col = lines[l].len() - value.len();
                    flow = Some((l, col));
                    continue;
                }
                let mut end = l + 1;
                while end < hi && (is_blank(lines[end]) || indent_of(lines[end]) > ind) {
                    end += 1;
                }
                // a block list may sit at the key's own indentation
                while end < hi
                    && (is_blank(lines[end])
                        || (indent_of(lines[end]) == ind
                            && lines[end].trim_start().starts_with('-')))
                {
                    end += 1;
                    while end < hi && (is_blank(lines[end]) || indent_of(lines[end]) > ind) {
                        end += 1;
                    }
                }
                lo = l + 1;
                hi = end;
                parent_indent = ind as isize;
            }
            Seg::Index(i) => {
                let items: Vec<usize> = (lo..hi)
                    .filter(|&l| !is_blank(lines[l]) && lines[l].trim_start().starts_with('-'))
                    .collect();
                let Some(min_ind) = items.iter().map(|&l| indent_of(lines[l])).min() else {
                    break;
                };
                let items: Vec<usize> = items
                    .into_iter()
                    .filter(|&l| indent_of(lines[l]) == min_ind)
                    .collect();
                let Some(&l) = items.get(i) else { break };
                best = (l + 1, min_ind + 1);
                let end = items.get(i + 1).copied().unwrap_or(hi);
                lo = l;
                hi = end;
                parent_indent = min_ind as isize;
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::locate;

    #[test]
    fn locates_block_and_flow_fields() {
        let t = "version: 1\ndomain:\n  min: [0, 0, 0]\n  dx: 0.1\nbodies:\n  - kind: box\n    min: [0,0,0]\n  - kind: sphere\n    radius: 2\nphysics: {density: -1, viscosity: 0}\n";
        assert_eq!(locate(t, "domain.dx"), (4, 3));
        assert_eq!(locate(t, "bodies[1].radius"), (9, 5));
        assert_eq!(locate(t, "bodies[1]"), (8, 3));
        assert_eq!(locate(t, "physics.density"), (10, 11));
        assert_eq!(locate(t, "bodies[0].kind"), (6, 5));
    }
}
