//! A small YAML writer for the job templates rift emits: block mappings and sequences, every
//! string double-quoted (so no value is ever read as a number, a boolean or a null).

/// A YAML value.
pub enum Yaml {
    Str(String),
    Int(i64),
    List(Vec<Yaml>),
    Map(Vec<(&'static str, Yaml)>),
}

impl Yaml {
    pub fn str(s: impl Into<String>) -> Self {
        Yaml::Str(s.into())
    }

    /// A mapping from `(key, value)` pairs, in order.
    pub fn map(pairs: impl IntoIterator<Item = (&'static str, Yaml)>) -> Self {
        Yaml::Map(pairs.into_iter().collect())
    }

    pub fn strs<S: Into<String>>(items: impl IntoIterator<Item = S>) -> Self {
        Yaml::List(items.into_iter().map(Yaml::str).collect())
    }

    /// The document text.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        self.write(&mut out, 0);
        out.trim_start_matches('\n').to_owned()
    }

    /// Writes `self` as the value of a key or list item already begun on the current line.
    fn write(&self, out: &mut String, indent: usize) {
        let pad = " ".repeat(indent);
        match self {
            Yaml::Str(s) => out.push_str(&format!(" {}\n", quoted(s))),
            Yaml::Int(n) => out.push_str(&format!(" {n}\n")),
            Yaml::List(items) if items.is_empty() => out.push_str(" []\n"),
            Yaml::Map(pairs) if pairs.is_empty() => out.push_str(" {}\n"),
            Yaml::List(items) => {
                out.push('\n');
                for item in items {
                    out.push_str(&format!("{pad}-"));
                    item.write_item(out, indent + 2);
                }
            }
            Yaml::Map(pairs) => {
                out.push('\n');
                for (key, value) in pairs {
                    out.push_str(&format!("{pad}{key}:"));
                    value.write(out, indent + 2);
                }
            }
        }
    }

    /// Writes `self` as a list item after its `-`: a mapping starts on the dash's line.
    fn write_item(&self, out: &mut String, indent: usize) {
        match self {
            Yaml::Map(pairs) if !pairs.is_empty() => {
                let pad = " ".repeat(indent);
                for (i, (key, value)) in pairs.iter().enumerate() {
                    if i == 0 {
                        out.push_str(&format!(" {key}:"));
                    } else {
                        out.push_str(&format!("{pad}{key}:"));
                    }
                    value.write(out, indent + 2);
                }
            }
            other => other.write(out, indent),
        }
    }
}

/// A double-quoted YAML scalar: backslash, quote and control characters escaped.
fn quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if c.is_control() => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nested_blocks_and_quoted_strings() {
        let doc = Yaml::map([
            ("name", Yaml::str("a \"b\"\n")),
            (
                "steps",
                Yaml::List(vec![Yaml::map([
                    ("n", Yaml::Int(2)),
                    ("args", Yaml::strs(["x", "{{y}}"])),
                ])]),
            ),
            ("none", Yaml::List(vec![])),
        ]);
        let text = doc.to_text();
        assert_eq!(
            text,
            "name: \"a \\\"b\\\"\\n\"\nsteps:\n  - n: 2\n    args:\n      - \"x\"\n      - \"{{y}}\"\nnone: []\n"
        );
    }
}
