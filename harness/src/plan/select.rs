//! Which runs of a batch run here: `--only` globs on the run names and `--shard I/N`.

/// `--shard I/N`: the runs whose position in the batch's canonical order is `I-1` modulo `N`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> Result<Shard, String> {
        let parse = |t: &str| t.trim().parse::<usize>().ok();
        match s.split_once('/').map(|(i, n)| (parse(i), parse(n))) {
            Some((Some(index), Some(count))) if (1..=count).contains(&index) => Ok(Shard { index, count }),
            _ => Err(format!("'{s}' is not I/N with 1 <= I <= N (e.g. 3/8)")),
        }
    }
}

impl Shard {
    /// Whether the run at `position` of the canonical order belongs to this shard.
    pub fn selects(&self, position: usize) -> bool {
        position % self.count == self.index - 1
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// Glob match of `text` against `pattern` with `*` (any run of characters) and `?` (one).
pub fn glob_match(pattern: &str, text: &str) -> bool {
    let (p, t): (Vec<char>, Vec<char>) = (pattern.chars().collect(), text.chars().collect());
    // Iterative matching with one backtrack point for the last `*`.
    let (mut i, mut j, mut star, mut mark) = (0, 0, None, 0);
    while j < t.len() {
        if i < p.len() && (p[i] == '?' || p[i] == t[j]) {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some(i);
            mark = j;
            i += 1;
        } else if let Some(s) = star {
            i = s + 1;
            mark += 1;
            j = mark;
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn globs() {
        assert!(glob_match("*", "a__sd__kp-newton"));
        assert!(glob_match("*__sd__*", "cow__sd__kp-newton"));
        assert!(!glob_match("*__sd__*", "cow__sarap__kp-newton"));
        assert!(glob_match("cow__*__kp-newton", "cow__bconf__kp-newton"));
        assert!(glob_match("c?w*", "cow__sd__cm"));
        assert!(!glob_match("cow", "cow__sd__cm"));
        assert!(glob_match("*cm", "cow__sd__cm"));
        assert!(glob_match("a*b*c", "aXXbYYbZc"));
        assert!(!glob_match("a*b*c", "aXXbYYbZ"));
    }
}
