//! Results of an experiment as files: one Markdown page (`README.md`) with
//! the exact command, the settings read from the paper, every table and
//! figure, plus each table as CSV and JSON beside it.
//!
//! Why hand-written Markdown: the pages are read on GitHub beside the code;
//! a table is a header line, a separator and one line per row, which needs no
//! templating crate. CSV goes through the `csv` crate (quoting) and JSON
//! through `serde_json`. Every file is written to a temporary name and
//! renamed, so an interrupted run never leaves a half-written table.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

/// Errors writing results.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// File system error with the path involved.
    #[error("writing {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Encoding a table failed.
    #[error("encoding {what}: {message}")]
    Encode {
        /// Which table or file.
        what: String,
        /// What went wrong.
        message: String,
    },
}

/// Writes `bytes` to `path` (creating its folder) with the one atomic,
/// fsynced write ([`tapeshape_common::fs::write_atomic`]): a reader never
/// sees a partial table.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ReportError> {
    let io = |source| ReportError::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).map_err(io)?;
        }
    }
    tapeshape_common::fs::write_atomic(path, bytes).map_err(io)
}

/// One table cell.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Cell {
    /// A number (printed with [`format_number`]; JSON keeps full precision).
    Num(f64),
    /// Text.
    Text(String),
    /// Nothing to show (JSON `null`, an empty CSV field, `-` in Markdown).
    Missing,
}

impl From<f64> for Cell {
    fn from(x: f64) -> Self {
        if x.is_nan() {
            Cell::Missing
        } else {
            Cell::Num(x)
        }
    }
}

impl From<&str> for Cell {
    fn from(s: &str) -> Self {
        Cell::Text(s.to_string())
    }
}

impl From<String> for Cell {
    fn from(s: String) -> Self {
        Cell::Text(s)
    }
}

impl From<usize> for Cell {
    fn from(x: usize) -> Self {
        Cell::Num(x as f64)
    }
}

impl Cell {
    fn text(&self) -> String {
        match self {
            Cell::Num(x) => format_number(*x),
            Cell::Text(s) => s.clone(),
            Cell::Missing => "-".into(),
        }
    }
}

/// Formats a number for a table: integers as integers, magnitudes below
/// 0.01 in scientific notation with 3 significant digits (errors of 1e-4 mm
/// must not print as 0.00), others with 2 decimals.
pub fn format_number(x: f64) -> String {
    if !x.is_finite() {
        return format!("{x}");
    }
    if x == x.round() && x.abs() < 1e9 {
        return format!("{}", x as i64);
    }
    if x.abs() < 0.01 {
        format!("{x:.2e}")
    } else {
        format!("{x:.2}")
    }
}

/// A table: a file stem, a title, column names and rows of cells.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Table {
    /// File stem of its CSV and JSON (e.g. `errors`).
    pub name: String,
    /// Title shown above it.
    pub title: String,
    /// Column names.
    pub columns: Vec<String>,
    /// Rows, each as long as `columns`.
    pub rows: Vec<Vec<Cell>>,
    /// Notes printed below it (units, definitions).
    pub notes: Vec<String>,
}

impl Table {
    /// An empty table.
    pub fn new(name: &str, title: &str, columns: &[&str]) -> Self {
        Self {
            name: name.into(),
            title: title.into(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            rows: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// Appends a row (padded with [`Cell::Missing`] or cut to the columns).
    pub fn push(&mut self, mut row: Vec<Cell>) {
        row.resize(self.columns.len(), Cell::Missing);
        self.rows.push(row);
    }

    /// The cell in the row whose first cell is the text `key`, column `column`.
    pub fn get(&self, key: &str, column: &str) -> Option<&Cell> {
        let c = self.columns.iter().position(|x| x == column)?;
        self.rows
            .iter()
            .find(|r| matches!(r.first(), Some(Cell::Text(t)) if t == key))
            .map(|r| &r[c])
    }

    /// The table as Markdown (title as a level-3 heading, notes below).
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "### {}\n", self.title);
        let _ = writeln!(s, "| {} |", self.columns.join(" | "));
        let _ = writeln!(
            s,
            "|{}|",
            self.columns
                .iter()
                .enumerate()
                .map(|(i, _)| if i == 0 { "---" } else { "---:" })
                .collect::<Vec<_>>()
                .join("|")
        );
        for r in &self.rows {
            let cells: Vec<String> = r.iter().map(|c| c.text().replace('|', "\\|")).collect();
            let _ = writeln!(s, "| {} |", cells.join(" | "));
        }
        for n in &self.notes {
            let _ = writeln!(s, "\n{n}");
        }
        s
    }

    /// The table as CSV (full precision numbers, empty fields for missing).
    pub fn csv(&self) -> Result<String, ReportError> {
        let enc = |e: &dyn std::fmt::Display| ReportError::Encode {
            what: format!("{}.csv", self.name),
            message: e.to_string(),
        };
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.columns).map_err(|e| enc(&e))?;
        for r in &self.rows {
            w.write_record(r.iter().map(|c| match c {
                Cell::Num(x) => format!("{x}"),
                Cell::Text(t) => t.clone(),
                Cell::Missing => String::new(),
            }))
            .map_err(|e| enc(&e))?;
        }
        let bytes = w.into_inner().map_err(|e| enc(&e))?;
        String::from_utf8(bytes).map_err(|e| enc(&e))
    }

    /// The table as JSON: `{name, title, columns, rows: [{column: value}], notes}`.
    pub fn json(&self) -> serde_json::Value {
        let rows: Vec<serde_json::Value> = self
            .rows
            .iter()
            .map(|r| {
                let mut m = serde_json::Map::new();
                for (c, v) in self.columns.iter().zip(r) {
                    m.insert(
                        c.clone(),
                        serde_json::to_value(v).unwrap_or(serde_json::Value::Null),
                    );
                }
                serde_json::Value::Object(m)
            })
            .collect();
        serde_json::json!({
            "name": self.name,
            "title": self.title,
            "columns": self.columns,
            "rows": rows,
            "notes": self.notes,
        })
    }
}

/// One part of a results page.
#[derive(Debug, Clone)]
pub enum Section {
    /// Markdown text.
    Text(String),
    /// A table (also written as CSV and JSON).
    Table(Table),
    /// A figure already saved in the output folder: file name and caption.
    Figure(String, String),
}

/// A results page.
#[derive(Debug, Clone)]
pub struct Report {
    /// Page title.
    pub title: String,
    /// The exact command that made it.
    pub command: String,
    /// Parts in order.
    pub sections: Vec<Section>,
}

impl Report {
    /// An empty page.
    pub fn new(title: &str, command: &str) -> Self {
        Self {
            title: title.into(),
            command: command.into(),
            sections: Vec::new(),
        }
    }

    /// Appends Markdown text.
    pub fn text(&mut self, t: impl Into<String>) {
        self.sections.push(Section::Text(t.into()));
    }

    /// Appends a table.
    pub fn table(&mut self, t: Table) {
        self.sections.push(Section::Table(t));
    }

    /// Appends a figure (file name relative to the output folder).
    pub fn figure(&mut self, file: &str, caption: &str) {
        self.sections
            .push(Section::Figure(file.into(), caption.into()));
    }

    /// The tables of the page.
    pub fn tables(&self) -> impl Iterator<Item = &Table> {
        self.sections.iter().filter_map(|s| match s {
            Section::Table(t) => Some(t),
            _ => None,
        })
    }

    /// The page as Markdown.
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "# {}\n\nMade by:\n\n```text\n{}\n```\n\n",
            self.title, self.command
        );
        for sec in &self.sections {
            match sec {
                Section::Text(t) => {
                    let _ = writeln!(s, "{t}\n");
                }
                Section::Table(t) => {
                    let _ = writeln!(s, "{}", t.markdown());
                    let _ = writeln!(
                        s,
                        "(also [`{0}.csv`]({0}.csv), [`{0}.json`]({0}.json))\n",
                        t.name
                    );
                }
                Section::Figure(f, c) => {
                    let _ = writeln!(s, "![{c}]({f})\n\n*{c}*\n");
                }
            }
        }
        s
    }

    /// Writes `README.md`, each table's CSV and JSON, and `report.json`
    /// (every table) into `dir`.
    pub fn write(&self, dir: &Path) -> Result<(), ReportError> {
        for t in self.tables() {
            write_atomic(&dir.join(format!("{}.csv", t.name)), t.csv()?.as_bytes())?;
            let j = serde_json::to_string_pretty(&t.json()).map_err(|e| ReportError::Encode {
                what: t.name.clone(),
                message: e.to_string(),
            })?;
            write_atomic(&dir.join(format!("{}.json", t.name)), j.as_bytes())?;
        }
        let all = serde_json::json!({
            "title": self.title,
            "command": self.command,
            "tables": self.tables().map(Table::json).collect::<Vec<_>>(),
        });
        let j = serde_json::to_string_pretty(&all).map_err(|e| ReportError::Encode {
            what: "report.json".into(),
            message: e.to_string(),
        })?;
        write_atomic(&dir.join("report.json"), j.as_bytes())?;
        write_atomic(&dir.join("README.md"), self.markdown().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Table {
        let mut t = Table::new("errors", "Errors", &["method", "S_close", "note"]);
        t.push(vec!["ours".into(), 1.5.into(), "a|b, \"c\"".into()]);
        t.push(vec!["fa".into(), 0.000123.into()]);
        t
    }

    #[test]
    fn numbers_keep_small_errors_visible() {
        assert_eq!(format_number(0.000238), "2.38e-4");
        assert_eq!(format_number(6.391), "6.39");
        assert_eq!(format_number(50.0), "50");
    }

    #[test]
    fn markdown_csv_and_json_agree() {
        let t = sample();
        let md = t.markdown();
        assert!(md.contains("| ours | 1.50 | a\\|b, \"c\" |"), "{md}");
        assert!(md.contains("| fa | 1.23e-4 | - |"), "{md}");
        // CSV quotes the comma and the quotes and round-trips through a reader.
        let csv_text = t.csv().unwrap();
        let mut r = csv::Reader::from_reader(csv_text.as_bytes());
        let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
        assert_eq!(&rows[0][2], "a|b, \"c\"");
        assert_eq!(rows[1][1].parse::<f64>().unwrap(), 0.000123);
        assert_eq!(&rows[1][2], "");
        let j = t.json();
        assert_eq!(j["rows"][0]["S_close"], 1.5);
        assert!(j["rows"][1]["note"].is_null());
        assert_eq!(t.get("fa", "S_close"), Some(&Cell::Num(0.000123)));
    }

    #[test]
    fn report_writes_every_file() {
        let dir = std::env::temp_dir().join(format!("tapeshape-report-{}", std::process::id()));
        let mut r = Report::new("T", "tapeshape-eval x --out d");
        r.text("hello");
        r.table(sample());
        r.write(&dir).unwrap();
        for f in ["README.md", "errors.csv", "errors.json", "report.json"] {
            assert!(dir.join(f).is_file(), "{f} missing");
        }
        let md = std::fs::read_to_string(dir.join("README.md")).unwrap();
        assert!(md.contains("tapeshape-eval x --out d"));
        assert!(!std::fs::read_dir(&dir).unwrap().any(|e| e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".tmp")));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
