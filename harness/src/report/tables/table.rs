//! A table of the report: its title, columns, formatted cells, caption and bold cells, and
//! its writers (`.csv`, `.md`, `.html`).

use crate::run_folder::write_atomic;
use anyhow::Result;
use std::path::Path;

/// A rectangular table of already formatted cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// A sentence under the table saying what the numbers are.
    pub caption: String,
    /// Cells `(row, column)` shown in bold: the best value among the solvers compared, by the
    /// rule of [`ranking`](super::ranking).
    pub bold: Vec<(usize, usize)>,
}

impl Table {
    pub fn to_csv(&self) -> Result<Vec<u8>> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.columns)?;
        for r in &self.rows {
            w.write_record(r)?;
        }
        Ok(w.into_inner()?)
    }

    pub fn to_markdown(&self) -> String {
        let mut s =
            format!("### {}\n\n| {} |\n|{}\n", self.title, self.columns.join(" | "), "---|".repeat(self.columns.len()));
        for (i, r) in self.rows.iter().enumerate() {
            let cells: Vec<String> = r
                .iter()
                .enumerate()
                .map(|(j, c)| if self.bold.contains(&(i, j)) && !c.is_empty() { format!("**{c}**") } else { c.clone() })
                .collect();
            s += &format!("| {} |\n", cells.join(" | "));
        }
        s += &format!("\n{}\n", self.caption);
        s
    }

    /// A standalone page: the title and [`Table::to_html_fragment`].
    pub fn to_html(&self) -> String {
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        format!(
            "<!doctype html>\n<meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\">\n\
             <title>{t}</title>\n<style>body{{font-family:sans-serif}}table{{border-collapse:collapse}}\
             td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}}th{{background:#eee}}</style>\n\
             <h3>{t}</h3>\n{body}",
            t = esc(&self.title),
            body = self.to_html_fragment()
        )
    }

    /// Just the `<table>` and the caption paragraph, for embedding in a larger page.
    pub fn to_html_fragment(&self) -> String {
        let esc = |t: &str| t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        let mut s = "<table>\n<tr>".to_string();
        for c in &self.columns {
            s += &format!("<th>{}</th>", esc(c));
        }
        s += "</tr>\n";
        for (i, r) in self.rows.iter().enumerate() {
            s += "<tr>";
            for (j, c) in r.iter().enumerate() {
                if self.bold.contains(&(i, j)) {
                    s += &format!("<td><b>{}</b></td>", esc(c));
                } else {
                    s += &format!("<td>{}</td>", esc(c));
                }
            }
            s += "</tr>\n";
        }
        s += &format!("</table>\n<p>{}</p>\n", esc(&self.caption));
        s
    }

    /// Write `dir/<stem>.csv|.md|.html`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        write_atomic(&dir.join(format!("{stem}.csv")), &self.to_csv()?)?;
        write_atomic(&dir.join(format!("{stem}.md")), self.to_markdown().as_bytes())?;
        write_atomic(&dir.join(format!("{stem}.html")), self.to_html().as_bytes())
    }
}
