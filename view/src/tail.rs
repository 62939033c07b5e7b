//! Reading a run directory's files as they grow: complete lines only, from where the last
//! read stopped, and CSV fields by column name (never by position: columns may be added).

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};

/// One file read from its start, then only what was appended since. A partial last line
/// (a row still being written) is kept back until its newline arrives.
#[derive(Debug)]
pub struct Tail {
    path: PathBuf,
    /// Bytes consumed so far (always at a line boundary).
    offset: u64,
    /// Bytes of an incomplete last line read ahead.
    partial: Vec<u8>,
}

/// What [`Tail::poll`] found.
#[derive(Debug, PartialEq)]
pub enum Polled {
    /// The complete lines appended since the last poll (none: nothing new, or no file yet).
    Lines(Vec<String>),
    /// The file is shorter than what was read: it was cut back (a coordinator resumed from
    /// its checkpoint) or replaced. Everything read from it must be read again.
    Shrunk,
}

impl Tail {
    /// A reader of `path` (which need not exist yet).
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            offset: 0,
            partial: Vec::new(),
        }
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// True when the file exists.
    pub fn exists(&self) -> bool {
        self.path.exists()
    }

    /// The complete lines appended since the last poll; a file that does not exist yet
    /// has none. Lines are returned without their newline.
    pub fn poll(&mut self) -> io::Result<Polled> {
        let mut file = match File::open(&self.path) {
            Ok(f) => f,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Polled::Lines(Vec::new())),
            Err(e) => return Err(e),
        };
        let len = file.metadata()?.len();
        let seen = self.offset + self.partial.len() as u64;
        if len < seen {
            self.offset = 0;
            self.partial.clear();
            return Ok(Polled::Shrunk);
        }
        if len == seen {
            return Ok(Polled::Lines(Vec::new()));
        }
        file.seek(SeekFrom::Start(seen))?;
        let mut buf = std::mem::take(&mut self.partial);
        file.take(len - seen).read_to_end(&mut buf)?;
        let end = buf.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
        self.partial = buf.split_off(end);
        self.offset += end as u64;
        let text = String::from_utf8_lossy(&buf);
        Ok(Polled::Lines(text.lines().map(str::to_owned).collect()))
    }
}

/// The header of a CSV file: column names to positions.
#[derive(Clone, Debug)]
pub struct Columns {
    names: Vec<String>,
}

impl Columns {
    /// The header line `line` of the file `path`; every name of `required` must be in it.
    pub fn parse(path: &Path, line: &str, required: &[&str]) -> Result<Self> {
        let names: Vec<String> = line.split(',').map(|s| s.trim().to_owned()).collect();
        if let Some(missing) = required.iter().find(|c| !names.iter().any(|n| n == *c)) {
            bail!("{}: no column {missing:?} in the header", path.display());
        }
        Ok(Self { names })
    }

    /// Position of column `name`, if the file has it.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Number of columns.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// True for a header without columns.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// A row split into fields, read through a [`Columns`] index.
pub struct Row<'a> {
    fields: Vec<&'a str>,
}

impl<'a> Row<'a> {
    /// The fields of `line`; `None` for a line with another number of fields than the
    /// header (a partial line of an interrupted run).
    pub fn split(line: &'a str, columns: &Columns) -> Option<Self> {
        let fields: Vec<&str> = line.split(',').collect();
        (fields.len() == columns.len()).then_some(Self { fields })
    }

    /// The text of field `at`.
    pub fn text(&self, at: Option<usize>) -> Option<&'a str> {
        at.and_then(|i| self.fields.get(i).copied())
    }

    /// Field `at` as a number; an empty field, a missing column or text that is no number
    /// is `None`.
    pub fn num(&self, at: Option<usize>) -> Option<f64> {
        self.text(at)
            .filter(|s| !s.is_empty())
            .and_then(|s| s.parse().ok())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn only_complete_lines_are_read_and_a_cut_file_is_noticed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.csv");
        let mut tail = Tail::new(&path);
        assert_eq!(tail.poll().unwrap(), Polled::Lines(vec![]));
        let mut f = File::create(&path).unwrap();
        write!(f, "a,b\n1,2\n3,").unwrap();
        f.flush().unwrap();
        assert_eq!(
            tail.poll().unwrap(),
            Polled::Lines(vec!["a,b".into(), "1,2".into()])
        );
        writeln!(f, "4").unwrap();
        f.flush().unwrap();
        assert_eq!(tail.poll().unwrap(), Polled::Lines(vec!["3,4".into()]));
        assert_eq!(tail.poll().unwrap(), Polled::Lines(vec![]));
        f.set_len(4).unwrap();
        assert_eq!(tail.poll().unwrap(), Polled::Shrunk);
        assert_eq!(tail.poll().unwrap(), Polled::Lines(vec!["a,b".into()]));
    }

    #[test]
    fn fields_are_read_by_column_name() {
        let cols = Columns::parse(Path::new("x.csv"), "t,k,id,x", &["x", "id"]).unwrap();
        let row = Row::split("0.5,3,7,", &cols).unwrap();
        assert_eq!(row.num(cols.index("t")), Some(0.5));
        assert_eq!(row.num(cols.index("id")), Some(7.0));
        assert_eq!(row.num(cols.index("x")), None);
        assert_eq!(row.num(cols.index("nope")), None);
        assert!(Row::split("1,2", &cols).is_none());
        let err = Columns::parse(Path::new("x.csv"), "t,k", &["x"]).unwrap_err();
        assert!(err.to_string().contains("no column \"x\""), "{err}");
    }
}
