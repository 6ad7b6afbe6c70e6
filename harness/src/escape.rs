//! HTML escaping: text for element content and quoted attribute values, and relative link
//! targets. A leaf: every page that writes HTML (the report, the trend page, the comparison)
//! escapes by these two.

use std::fmt::Write as _;

/// HTML-escape text for element content and quoted attribute values.
pub fn esc(t: &str) -> String {
    let mut s = String::with_capacity(t.len());
    for c in t.chars() {
        match c {
            '&' => s += "&amp;",
            '<' => s += "&lt;",
            '>' => s += "&gt;",
            '"' => s += "&quot;",
            '\'' => s += "&#39;",
            _ => s.push(c),
        }
    }
    s
}

/// A relative link target: percent-encode all but unreserved characters and `/`, then escape.
pub fn href(path: &str) -> String {
    let mut s = String::new();
    for b in path.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            s.push(b as char);
        } else {
            let _ = write!(s, "%{b:02X}");
        }
    }
    esc(&s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_text_and_link_targets() {
        assert_eq!(esc("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
        assert_eq!(href("runs/a b#c.csv"), "runs/a%20b%23c.csv");
    }
}
