//! One table specification, two outputs: each column is defined once, with its Markdown heading,
//! its CSV key and how a row fills it. A column may be Markdown-only or CSV-only, and its CSV
//! cell may be formatted apart from the Markdown one (more digits, no units).

type Cell<'a, R> = Box<dyn Fn(&R) -> String + 'a>;

struct Column<'a, R> {
    heading: Option<String>,
    key: Option<&'static str>,
    left: bool,
    md: Cell<'a, R>,
    csv: Option<Cell<'a, R>>,
}

/// A table of rows `R`.
pub struct Table<'a, R> {
    columns: Vec<Column<'a, R>>,
}

impl<R> Default for Table<'_, R> {
    fn default() -> Self {
        Self {
            columns: Vec::new(),
        }
    }
}

/// One Markdown line: `|`, each cell followed by `|`.
fn md_line(cells: impl Iterator<Item = String>) -> String {
    cells.fold("|".to_owned(), |line, cell| line + &cell + "|") + "\n"
}

impl<'a, R> Table<'a, R> {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    fn push(
        mut self,
        heading: Option<&str>,
        key: Option<&'static str>,
        md: impl Fn(&R) -> String + 'a,
    ) -> Self {
        self.columns.push(Column {
            heading: heading.map(str::to_owned),
            key,
            left: false,
            md: Box::new(md),
            csv: None,
        });
        self
    }

    /// A column in both outputs, the same text in each (right-aligned in Markdown).
    pub fn col(self, heading: &str, key: &'static str, f: impl Fn(&R) -> String + 'a) -> Self {
        self.push(Some(heading), Some(key), f)
    }

    /// A column in the Markdown table only.
    pub fn md(self, heading: &str, f: impl Fn(&R) -> String + 'a) -> Self {
        self.push(Some(heading), None, f)
    }

    /// A column in the CSV only.
    pub fn csv(self, key: &'static str, f: impl Fn(&R) -> String + 'a) -> Self {
        self.push(None, Some(key), f)
    }

    /// The last column's CSV cell, formatted apart from its Markdown one.
    pub fn csv_as(mut self, f: impl Fn(&R) -> String + 'a) -> Self {
        if let Some(c) = self.columns.last_mut() {
            c.csv = Some(Box::new(f));
        }
        self
    }

    /// The last column left-aligned in Markdown (text rather than figures).
    pub fn left(mut self) -> Self {
        if let Some(c) = self.columns.last_mut() {
            c.left = true;
        }
        self
    }

    /// The Markdown table: heading row, alignment row, one line per row.
    pub fn markdown<'r>(&self, rows: impl IntoIterator<Item = &'r R>) -> String
    where
        R: 'r,
    {
        let cols: Vec<(&str, &Column<R>)> = (self.columns.iter())
            .filter_map(|c| Some((c.heading.as_deref()?, c)))
            .collect();
        let mut out = md_line(cols.iter().map(|(h, _)| match h {
            &"" => " ".to_owned(),
            h => format!(" {h} "),
        }));
        out += &md_line(
            cols.iter()
                .map(|(_, c)| if c.left { "---" } else { "---:" }.to_owned()),
        );
        for r in rows {
            out += &md_line(cols.iter().map(|(_, c)| format!(" {} ", (c.md)(r))));
        }
        out
    }

    /// The CSV: a header of keys, one line per row.
    pub fn csv_text<'r>(&self, rows: impl IntoIterator<Item = &'r R>) -> String
    where
        R: 'r,
    {
        let cols: Vec<(&str, &Cell<R>)> = (self.columns.iter())
            .filter_map(|c| Some((c.key?, c.csv.as_ref().unwrap_or(&c.md))))
            .collect();
        let mut out = cols.iter().map(|c| c.0).collect::<Vec<_>>().join(",") + "\n";
        for r in rows {
            out += &(cols.iter().map(|c| c.1(r)).collect::<Vec<_>>().join(",") + "\n");
        }
        out
    }
}

/// `{:.2}%` of a fraction.
pub fn pct(x: f64) -> String {
    format!("{:.2}%", 100.0 * x)
}

/// `*` for a count that is oversubscribed, else nothing.
pub fn star(oversubscribed: bool) -> &'static str {
    if oversubscribed {
        "*"
    } else {
        ""
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_specification_writes_both_outputs() {
        let t = Table::<(u32, f64)>::new()
            .col("n", "n", |r| r.0.to_string())
            .left()
            .col("time (s)", "seconds", |r| format!("{:.2}", r.1))
            .csv_as(|r| format!("{:.4}", r.1))
            .md("share", |r| pct(r.1))
            .csv("flag", |r| (r.0 > 1).to_string());
        let rows = [(1, 0.5), (2, 0.25)];
        assert_eq!(
            t.markdown(&rows),
            "| n | time (s) | share |\n|---|---:|---:|\n| 1 | 0.50 | 50.00% |\n| 2 | 0.25 | 25.00% |\n"
        );
        assert_eq!(
            t.csv_text(&rows),
            "n,seconds,flag\n1,0.5000,false\n2,0.2500,true\n"
        );
        assert_eq!((star(true), star(false)), ("*", ""));
    }
}
