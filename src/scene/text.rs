//! Whitespace-separated text files with line numbers, for error messages that point at a line.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use crate::error::SceneError;

/// A text file split into tokens that remember their (1-based) line.
pub struct TextFile {
    pub path: PathBuf,
    tokens: Vec<(String, usize)>,
    pos: usize,
    lines: usize,
}

impl TextFile {
    pub fn open(path: &Path) -> Result<TextFile, SceneError> {
        let bytes = crate::vfs::read(path).map_err(|e| SceneError::io(path, e))?;
        let text = String::from_utf8(bytes).map_err(|_| {
            SceneError::file(path, "the file is not UTF-8 text; is this the right file?")
        })?;
        Ok(TextFile::parse(path, &text))
    }

    pub fn parse(path: &Path, text: &str) -> TextFile {
        let mut tokens = Vec::new();
        let mut lines = 0;
        for (i, line) in text.lines().enumerate() {
            lines = i + 1;
            tokens.extend(line.split_whitespace().map(|t| (t.to_string(), i + 1)));
        }
        TextFile {
            path: path.to_path_buf(),
            tokens,
            pos: 0,
            lines,
        }
    }

    /// Line of the next token (or the last line at the end of the file).
    pub fn line(&self) -> usize {
        self.tokens
            .get(self.pos)
            .map(|t| t.1)
            .unwrap_or(self.lines.max(1))
    }

    pub fn at_end(&self) -> bool {
        self.pos >= self.tokens.len()
    }

    pub fn error(&self, line: usize, message: impl Into<String>) -> SceneError {
        SceneError::line(&self.path, line, message)
    }

    /// The next token; `what` names it for the error at the end of the file.
    pub fn next_str(&mut self, what: &str) -> Result<(&str, usize), SceneError> {
        match self.tokens.get(self.pos) {
            Some((tok, line)) => {
                self.pos += 1;
                Ok((tok.as_str(), *line))
            }
            None => Err(self.error(
                self.lines.max(1),
                format!(
                    "the file ends where {what} was expected; it is truncated or has too few values"
                ),
            )),
        }
    }

    /// Peeks at the next token without consuming it.
    pub fn peek(&self) -> Option<&str> {
        self.tokens.get(self.pos).map(|t| t.0.as_str())
    }

    pub fn expect_keyword(&mut self, keyword: &str) -> Result<(), SceneError> {
        let (tok, line) = self.next_str(&format!("the keyword '{keyword}'"))?;
        if tok != keyword {
            let tok = tok.to_string();
            return Err(self.error(line, format!("expected '{keyword}', found '{tok}'")));
        }
        Ok(())
    }

    /// The next token as a number of type `T`; non-finite floats are refused.
    pub fn next<T: FromStr + Copy + IsFinite>(&mut self, what: &str) -> Result<T, SceneError> {
        let path = self.path.clone();
        let (tok, line) = self.next_str(what)?;
        parse_token(&path, line, tok, what)
    }

    /// All tokens of the line the next token is on, consuming them.
    pub fn next_line(&mut self) -> Option<(usize, Vec<&str>)> {
        let line = self.tokens.get(self.pos)?.1;
        let start = self.pos;
        while self.pos < self.tokens.len() && self.tokens[self.pos].1 == line {
            self.pos += 1;
        }
        Some((
            line,
            self.tokens[start..self.pos]
                .iter()
                .map(|t| t.0.as_str())
                .collect(),
        ))
    }
}

/// Parses one token, naming the file, line and value in the error.
pub fn parse_token<T: FromStr + Copy + IsFinite>(
    path: &Path,
    line: usize,
    tok: &str,
    what: &str,
) -> Result<T, SceneError> {
    let value: T = tok.parse().map_err(|_| {
        SceneError::line(
            path,
            line,
            format!("{what} must be a number, found '{tok}'"),
        )
    })?;
    if !value.is_finite_value() {
        return Err(SceneError::line(
            path,
            line,
            format!("{what} is not finite ('{tok}'); the file is corrupt"),
        ));
    }
    Ok(value)
}

/// Numbers that can be checked for NaN / infinity (integers always pass).
pub trait IsFinite {
    fn is_finite_value(&self) -> bool;
}

impl IsFinite for f64 {
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
}
impl IsFinite for f32 {
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
}
macro_rules! finite_int {
    ($($t:ty),*) => { $(impl IsFinite for $t { fn is_finite_value(&self) -> bool { true } })* };
}
finite_int!(u32, u64, i32, i64, usize);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_keep_line_numbers() {
        let mut f = TextFile::parse(Path::new("x.txt"), "a 1\n\n  2.5 nan\n");
        assert_eq!(f.next_str("a").unwrap(), ("a", 1));
        assert_eq!(f.next::<u32>("count").unwrap(), 1);
        assert_eq!(f.line(), 3);
        assert_eq!(f.next::<f64>("value").unwrap(), 2.5);
        let err = f.next::<f64>("depth").unwrap_err();
        assert_eq!(err.line, Some(3));
        assert!(err.to_string().contains("not finite"), "{err}");
        let err = f.next::<f64>("depth").unwrap_err();
        assert!(err.to_string().contains("ends where depth"), "{err}");
    }

    #[test]
    fn bad_numbers_name_the_token() {
        let mut f = TextFile::parse(Path::new("cam.txt"), "1.0 x2\n");
        f.next::<f64>("v").unwrap();
        let err = f.next::<f64>("fy").unwrap_err();
        assert_eq!(
            err.to_string(),
            "cam.txt:1: fy must be a number, found 'x2'"
        );
    }
}
