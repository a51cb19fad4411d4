//! Typed errors of the fx crate. Every error that comes from user input names the file and, where
//! there is one, the key path inside it (`portal[1].ring.strands`), so a message can be acted on
//! without opening a debugger. Causes are part of the message (not a `source` chain), so each
//! error prints once, complete.

use std::path::PathBuf;

/// Anything that can go wrong reading a shot, generating rings or writing exports.
#[derive(Debug, thiserror::Error)]
pub enum FxError {
    /// The shot (or another input) file could not be read at all.
    #[error("{}: cannot read: {cause}", file.display())]
    Read {
        file: PathBuf,
        cause: std::io::Error,
    },
    /// The file is not valid TOML.
    #[error("{}: {message}", file.display())]
    Syntax { file: PathBuf, message: String },
    /// A key has a missing, unknown or invalid value.
    #[error("{}: {key}: {message}", file.display())]
    Key {
        file: PathBuf,
        key: String,
        message: String,
    },
    /// An output could not be written.
    #[error("{}: cannot write: {cause}", path.display())]
    Write {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// A ring cache is truncated, corrupt or of another version.
    #[error("{}: not a valid ring cache: {message}", file.display())]
    Cache { file: PathBuf, message: String },
    /// A ring point cloud (PLY) is malformed or lacks what the renderer needs.
    #[error("{}: not a valid ring point cloud: {message}", file.display())]
    PointCloud { file: PathBuf, message: String },
    /// Rings generated from a shot came out unusable.
    #[error("{}: frame {frame}: the generated rings cannot be used: {message}", file.display())]
    Rings {
        file: PathBuf,
        frame: i64,
        message: String,
    },
    /// A request that does not fit the shot (e.g. frames outside what can be generated).
    #[error("{0}")]
    Request(String),
}

/// A problem with one key of a shot, before it is tied to a file name.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Dotted key path, e.g. `portal[0].keys[2].scale`.
    pub key: String,
    /// What is wrong and, where it helps, what is expected.
    pub message: String,
}

impl Invalid {
    /// An error at `key`.
    pub fn new(key: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            key: key.into(),
            message: message.into(),
        }
    }

    /// Ties the error to the shot file it came from, with the line its key is on (the file
    /// is read again to find it).
    pub fn in_file(self, file: impl Into<PathBuf>) -> FxError {
        let file = file.into();
        let text = crate::io::read_to_string(&file).ok();
        self.located(file, text.as_deref())
    }

    /// Ties the error to `file`, whose text is `text`, with the line its key is on.
    pub fn in_text(self, file: impl Into<PathBuf>, text: &str) -> FxError {
        self.located(file.into(), Some(text))
    }

    fn located(self, file: PathBuf, text: Option<&str>) -> FxError {
        let line = text.and_then(|text| crate::shot::locate::line_of_key(text, &self.key));
        let message = match line {
            Some(line) if !self.message.contains("(line ") => {
                format!("{} (line {line})", self.message)
            }
            _ => self.message,
        };
        FxError::Key {
            file,
            key: self.key,
            message,
        }
    }
}

impl std::fmt::Display for Invalid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// `text` with every line longer than `max` characters cut to its first `max` and an
/// ellipsis, so a parse error that quotes a huge offending line stays readable.
pub fn shorten_long_lines(text: &str, max: usize) -> String {
    text.lines()
        .map(|line| match line.char_indices().nth(max) {
            Some((cut, _)) => format!("{}… ({} characters)", &line[..cut], line.chars().count()),
            None => line.to_owned(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_are_cut_and_short_ones_kept() {
        let long = "é".repeat(500);
        let text = format!("line 3\n{long}\n  ^");
        let short = shorten_long_lines(&text, 10);
        assert_eq!(
            short,
            format!("line 3\n{}… (500 characters)\n  ^", "é".repeat(10))
        );
        assert_eq!(shorten_long_lines("a\nb", 10), "a\nb");
    }
}
