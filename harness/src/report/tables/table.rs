//! A table of the report: its title, columns, formatted cells, caption and bold cells, and
//! its writers (`.csv`, `.md`, `.html`, `.tex`). A wide table is shown in blocks of columns
//! ([`Table::blocks`]) so no page scrolls sideways; the CSV and Markdown keep it whole.

use crate::escape::esc;
use crate::run_folder::write_atomic;
use anyhow::Result;
use std::path::Path;

/// A rectangular table of already formatted cells.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Table {
    pub title: String,
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// A sentence under the table saying what the numbers are.
    pub caption: String,
    /// Cells `(row, column)` shown in bold: the best value among the solvers compared, by the
    /// rule of [`ranking`](super::ranking).
    pub bold: Vec<(usize, usize)>,
    /// How the table is cut when it is too wide for a page.
    pub layout: Layout,
}

/// The columns a wide table repeats in every block (`keys`, the row's name) and the width of
/// the groups the rest comes in (`group`: a solver's three cells stay together).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    pub keys: usize,
    pub group: usize,
}

impl Default for Layout {
    fn default() -> Self {
        Layout { keys: 1, group: 1 }
    }
}

/// The characters a block may span: 1400 px of page at about 7 px per character of the
/// tables' font, less the cells' padding.
const BLOCK_CHARS: usize = 170;

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
        format!(
            "<!doctype html>\n<meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width\">\n\
             <title>{t}</title>\n<style>body{{font-family:sans-serif;max-width:1400px}}table{{border-collapse:collapse;\
             margin:.5em 0}}td,th{{border:1px solid #bbb;padding:2px 6px;text-align:right}}th{{background:#eee}}</style>\n\
             <h3>{t}</h3>\n{body}",
            t = esc(&self.title),
            body = self.to_html_fragment()
        )
    }

    /// The `<table>`s of the [`blocks`](Table::blocks) and the caption paragraph, for
    /// embedding in a larger page.
    pub fn to_html_fragment(&self) -> String {
        let mut s = String::new();
        for b in self.blocks() {
            s += "<table>\n<tr>";
            for c in &b.columns {
                s += &format!("<th>{}</th>", esc(c));
            }
            s += "</tr>\n";
            for (i, r) in b.rows.iter().enumerate() {
                s += "<tr>";
                for (j, c) in r.iter().enumerate() {
                    if b.bold.contains(&(i, j)) {
                        s += &format!("<td><b>{}</b></td>", esc(c));
                    } else {
                        s += &format!("<td>{}</td>", esc(c));
                    }
                }
                s += "</tr>\n";
            }
            s += "</table>\n";
        }
        s += &format!("<p>{}</p>\n", esc(&self.caption));
        s
    }

    /// The table cut into blocks no wider than `BLOCK_CHARS`: each repeats the key columns
    /// and takes whole groups of the rest, as many as fit (at least one). A table that fits is
    /// its one block.
    pub fn blocks(&self) -> Vec<Table> {
        let keys = self.layout.keys.min(self.columns.len());
        let group = self.layout.group.max(1);
        let width = |j: usize| {
            let header = self.columns[j].split_whitespace().map(|w| w.chars().count()).max().unwrap_or(0);
            let cells = self.rows.iter().filter_map(|r| r.get(j)).map(|c| c.chars().count()).max().unwrap_or(0);
            header.max(cells) + 2
        };
        let key_width: usize = (0..keys).map(width).sum();
        let groups: Vec<std::ops::Range<usize>> =
            (keys..self.columns.len()).step_by(group).map(|a| a..(a + group).min(self.columns.len())).collect();
        let mut cuts: Vec<Vec<std::ops::Range<usize>>> = vec![Vec::new()];
        let mut used = key_width;
        for g in groups {
            let w: usize = g.clone().map(width).sum();
            let last = cuts.last_mut().expect("one block at least");
            if !last.is_empty() && used + w > BLOCK_CHARS {
                cuts.push(vec![g]);
                used = key_width + w;
            } else {
                last.push(g);
                used += w;
            }
        }
        if cuts.len() == 1 {
            return vec![self.clone()];
        }
        cuts.into_iter()
            .map(|gs| {
                let cols: Vec<usize> = (0..keys).chain(gs.into_iter().flatten()).collect();
                let pick = |r: &Vec<String>| cols.iter().map(|&j| r.get(j).cloned().unwrap_or_default()).collect();
                Table {
                    title: self.title.clone(),
                    columns: pick(&self.columns),
                    rows: self.rows.iter().map(pick).collect(),
                    caption: self.caption.clone(),
                    bold: self
                        .bold
                        .iter()
                        .filter_map(|&(i, j)| cols.iter().position(|&c| c == j).map(|k| (i, k)))
                        .collect(),
                    layout: Layout { keys, group },
                }
            })
            .collect()
    }

    /// Write `dir/<stem>.csv|.md|.html|.tex`.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<()> {
        write_atomic(&dir.join(format!("{stem}.csv")), &self.to_csv()?)?;
        write_atomic(&dir.join(format!("{stem}.md")), self.to_markdown().as_bytes())?;
        write_atomic(&dir.join(format!("{stem}.html")), self.to_html().as_bytes())?;
        write_atomic(&dir.join(format!("{stem}.tex")), self.to_latex(stem).as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wide(solvers: usize) -> Table {
        let mut columns = vec!["dataset".to_string(), "energy".to_string()];
        let mut row = vec!["cow".to_string(), "sd".to_string()];
        for s in 0..solvers {
            columns.extend([format!("s{s} iter"), format!("s{s} time [s]"), format!("s{s} energy")]);
            row.extend(["12".to_string(), "0.0213 (0.0209–0.0218)".to_string(), "2.08413".to_string()]);
        }
        Table {
            title: "wide".into(),
            columns,
            rows: vec![row],
            caption: "c".into(),
            bold: vec![(0, 2), (0, 2 + 3 * (solvers - 1) + 1)],
            layout: Layout { keys: 2, group: 3 },
        }
    }

    #[test]
    fn a_wide_table_is_cut_into_blocks_of_whole_groups_with_the_keys_repeated() {
        let t = wide(16);
        let blocks = t.blocks();
        assert!(blocks.len() > 1, "{} blocks", blocks.len());
        let mut seen = Vec::new();
        for b in &blocks {
            assert_eq!(b.columns[..2], ["dataset", "energy"]);
            assert_eq!((b.columns.len() - 2) % 3, 0, "whole solvers only: {:?}", b.columns);
            let w: usize = (0..b.columns.len())
                .map(|j| {
                    b.columns[j].split_whitespace().map(str::len).max().unwrap().max(b.rows[0][j].chars().count()) + 2
                })
                .sum();
            assert!(w <= BLOCK_CHARS, "{w}");
            seen.extend(b.columns[2..].iter().cloned());
        }
        assert_eq!(seen, t.columns[2..], "every column once, in order");
        // The bold cells follow their columns.
        assert_eq!(blocks[0].bold, [(0, 2)]);
        let last = blocks.last().unwrap();
        let k = last.columns.iter().position(|c| c == "s15 time [s]").unwrap();
        assert_eq!(last.bold, [(0, k)]);
        assert_eq!(t.to_html_fragment().matches("<table>").count(), blocks.len());
        // A narrow table is its one block.
        assert_eq!(wide(2).blocks(), [wide(2)]);
    }
}
