//! The run directory's CSV files read by column name (the `csv` crate: quoted fields with
//! commas read right), so a test never depends on where a column stands.

use std::path::Path;

/// A CSV file with a header: its column names and its rows.
#[derive(Clone, Debug)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

/// One row of a [`Table`].
#[derive(Clone, Copy, Debug)]
pub struct Row<'a> {
    table: &'a Table,
    index: usize,
}

impl Table {
    /// Parses CSV text with a header line; panics (naming `what`) on malformed CSV.
    pub fn parse(text: &str, what: &str) -> Self {
        let mut csv = csv::ReaderBuilder::new().from_reader(text.as_bytes());
        let header = csv
            .headers()
            .unwrap_or_else(|e| panic!("{what}: header: {e}"))
            .iter()
            .map(str::to_string)
            .collect();
        let rows = csv
            .records()
            .map(|r| {
                let r = r.unwrap_or_else(|e| panic!("{what}: {e}"));
                r.iter().map(str::to_string).collect()
            })
            .collect();
        Self { header, rows }
    }

    /// Reads the CSV file at `path`.
    pub fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path)
            .unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
        Self::parse(&text, &path.display().to_string())
    }

    /// The column names.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// The position of column `name`; panics naming it when there is none.
    pub fn column(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name:?} in {:?}", self.header))
    }

    /// Number of rows (without the header).
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Row `index` (0 = the first after the header).
    pub fn row(&self, index: usize) -> Row<'_> {
        assert!(
            index < self.rows.len(),
            "row {index} of {}",
            self.rows.len()
        );
        Row { table: self, index }
    }

    /// The rows in order.
    pub fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        (0..self.rows.len()).map(move |index| Row { table: self, index })
    }

    /// Sets column `name` of row `index` to `value`.
    pub fn set(&mut self, index: usize, name: &str, value: &str) {
        let c = self.column(name);
        self.rows[index][c] = value.to_string();
    }

    /// The table as CSV text (header first, a newline after each row).
    pub fn to_csv(&self) -> String {
        let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
        w.write_record(&self.header).expect("writing the header");
        for r in &self.rows {
            w.write_record(r).expect("writing a row");
        }
        String::from_utf8(w.into_inner().expect("flushing")).expect("UTF-8")
    }
}

impl<'a> Row<'a> {
    /// The field of column `name`.
    pub fn get(&self, name: &str) -> &'a str {
        &self.table.rows[self.index][self.table.column(name)]
    }

    /// The field of column `name` as a number; NaN when empty, a panic when not a number.
    pub fn num(&self, name: &str) -> f64 {
        let s = self.get(name);
        if s.is_empty() {
            return f64::NAN;
        }
        s.parse()
            .unwrap_or_else(|_| panic!("column {name}: {s:?} is not a number"))
    }

    /// The field of column `name` parsed as `T`; a panic naming the column when it does not
    /// parse.
    pub fn parse<T: std::str::FromStr>(&self, name: &str) -> T {
        let s = self.get(name);
        s.parse()
            .unwrap_or_else(|_| panic!("column {name}: {s:?} does not parse"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_are_found_by_name_and_quoted_commas_kept() {
        let mut t = Table::parse("a,b,c\n1,\"x, y\",\n3,z,2.5\n", "t.csv");
        assert_eq!(t.len(), 2);
        assert_eq!(t.row(0).get("b"), "x, y");
        assert!(t.row(0).num("c").is_nan());
        assert_eq!(t.row(1).num("c"), 2.5);
        assert_eq!(t.row(1).parse::<u32>("a"), 3);
        t.set(1, "c", "7");
        assert_eq!(t.to_csv(), "a,b,c\n1,\"x, y\",\n3,z,7\n");
    }

    #[test]
    #[should_panic(expected = "no column \"d\"")]
    fn a_missing_column_is_named() {
        Table::parse("a\n1\n", "t.csv").row(0).get("d");
    }
}
