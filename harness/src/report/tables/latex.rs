//! A table as LaTeX for a paper: a `table` float of booktabs `tabular`s (one per
//! [`block`](Table::blocks)), the bold cells in `\textbf`, the caption and a label
//! `tab:<stem>`. Needs `\usepackage{booktabs}`; the text is escaped so any stock class
//! compiles it (`\input{per_mesh.tex}`).

use super::table::Table;

impl Table {
    /// The `.tex` twin of the table, labelled `tab:<stem>`.
    pub fn to_latex(&self, stem: &str) -> String {
        let t = self;
        let mut s = format!(
            "% {} (mapbench report; needs \\usepackage{{booktabs}})\n\\begin{{table}}[htbp]\n\\centering\n\\small\n",
            ascii_comment(&t.title)
        );
        for (k, b) in t.blocks().iter().enumerate() {
            if k > 0 {
                s += "\\medskip\n\n";
            }
            let align: String = (0..b.columns.len()).map(|j| if numeric_column(b, j) { 'r' } else { 'l' }).collect();
            s += &format!("\\begin{{tabular}}{{{align}}}\n\\toprule\n");
            s += &b.columns.iter().map(|c| escape(c)).collect::<Vec<_>>().join(" & ");
            s += " \\\\\n\\midrule\n";
            for (i, r) in b.rows.iter().enumerate() {
                let cells: Vec<String> = r
                    .iter()
                    .enumerate()
                    .map(|(j, c)| {
                        let c = escape(c);
                        if b.bold.contains(&(i, j)) && !c.is_empty() {
                            format!("\\textbf{{{c}}}")
                        } else {
                            c
                        }
                    })
                    .collect();
                s += &cells.join(" & ");
                s += " \\\\\n";
            }
            s += "\\bottomrule\n\\end{tabular}\n";
        }
        s += &format!(
            "\\caption{{{}. {}}}\n\\label{{tab:{}}}\n\\end{{table}}\n",
            escape(&t.title),
            escape(&t.caption),
            label(stem)
        );
        s
    }
}

/// A column of numbers (every filled cell starts with a digit, a sign or a point) is set
/// flush right, any other flush left.
fn numeric_column(t: &Table, j: usize) -> bool {
    let mut cells = t.rows.iter().filter_map(|r| r.get(j)).filter(|c| !c.is_empty()).peekable();
    cells.peek().is_some() && cells.all(|c| c.starts_with(|ch: char| ch.is_ascii_digit() || "-+.".contains(ch)))
}

/// Text as LaTeX: its special characters escaped, the report's symbols (dagger, section,
/// dashes, relations, superscripts) as commands pdfLaTeX knows, any other character outside
/// Latin-1 as `?`.
pub fn escape(text: &str) -> String {
    let mut s = String::with_capacity(text.len());
    for c in text.chars() {
        let r: &str = match c {
            '\\' => "\\textbackslash{}",
            '&' | '%' | '$' | '#' | '_' | '{' | '}' => {
                s.push('\\');
                s.push(c);
                continue;
            }
            '~' => "\\textasciitilde{}",
            '^' => "\\textasciicircum{}",
            '<' => "\\textless{}",
            '>' => "\\textgreater{}",
            '|' => "\\textbar{}",
            '\u{2013}' => "--",
            '\u{2014}' => "---",
            '\u{2020}' => "\\dag{}",
            '\u{00a7}' => "\\S{}",
            '\u{2264}' => "$\\le$",
            '\u{2265}' => "$\\ge$",
            '\u{2260}' => "$\\neq$",
            '\u{2248}' => "$\\approx$",
            '\u{00d7}' => "$\\times$",
            '\u{2212}' => "$-$",
            '\u{00b1}' => "$\\pm$",
            '\u{00b7}' => "$\\cdot$",
            '\u{221e}' => "$\\infty$",
            '\u{2192}' => "$\\to$",
            '\u{2026}' => "\\ldots{}",
            '\u{201c}' => "``",
            '\u{201d}' => "''",
            '\u{2018}' | '\u{2019}' => "'",
            '\u{2070}' => "$^{0}$",
            '\u{00b9}' => "$^{1}$",
            '\u{00b2}' => "$^{2}$",
            '\u{00b3}' => "$^{3}$",
            '\u{2074}'..='\u{2079}' => {
                s += &format!("$^{{{}}}$", c as u32 - 0x2070);
                continue;
            }
            '\u{207b}' => "$^{-}$",
            '\u{00a0}' => "~",
            c if c.is_ascii() && !c.is_ascii_control() => {
                s.push(c);
                continue;
            }
            c if c.is_ascii_whitespace() => " ",
            c if ('\u{00c0}'..='\u{00ff}').contains(&c) => {
                s.push(c);
                continue;
            }
            _ => "?",
        };
        s += r;
    }
    s
}

/// A title in a `%` comment line: one line, ASCII.
fn ascii_comment(text: &str) -> String {
    text.chars().map(|c| if c.is_ascii() && !c.is_ascii_control() { c } else { ' ' }).collect()
}

/// A label LaTeX accepts: letters, digits, `-` and `:`.
fn label(stem: &str) -> String {
    stem.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == ':' { c } else { '-' }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::tables::table::Layout;

    #[test]
    fn the_latex_twin_is_booktabs_with_escaped_text_and_bold_cells() {
        let t = Table {
            title: "Per mesh: E* & time".into(),
            columns: vec!["dataset".into(), "time [s]".into(), "gap_%".into()],
            rows: vec![
                vec!["cow_1k".into(), "0.0213 (0.0209–0.0218)†".into(), "1e-6".into()],
                vec!["a#b".into(), "".into(), "≤ 5 × 10⁻⁴ §".into()],
            ],
            caption: "50% of runs, E − E* ≤ 1e-6 and ∂ unknown".into(),
            bold: vec![(0, 1)],
            layout: Layout::default(),
        };
        let tex = t.to_latex("per_mesh");
        assert!(
            tex.contains("\\begin{tabular}{lrl}\n\\toprule\ndataset & time [s] & gap\\_\\% \\\\\n\\midrule\n"),
            "{tex}"
        );
        assert!(tex.contains("cow\\_1k & \\textbf{0.0213 (0.0209--0.0218)\\dag{}} & 1e-6 \\\\"), "{tex}");
        assert!(tex.contains("a\\#b &  & $\\le$ 5 $\\times$ 10$^{-}$$^{4}$ \\S{} \\\\"), "{tex}");
        assert!(
            tex.contains("\\caption{Per mesh: E* \\& time. 50\\% of runs, E $-$ E* $\\le$ 1e-6 and ? unknown}"),
            "{tex}"
        );
        assert!(tex.contains("\\label{tab:per-mesh}") && tex.ends_with("\\end{table}\n"), "{tex}");
        assert!(tex.is_ascii() || tex.chars().all(|c| c.is_ascii() || ('\u{00c0}'..='\u{00ff}').contains(&c)));
        assert_eq!(
            escape("\\{~^}<|>"),
            "\\textbackslash{}\\{\\textasciitilde{}\\textasciicircum{}\\}\\textless{}\\textbar{}\\textgreater{}"
        );
    }
}
