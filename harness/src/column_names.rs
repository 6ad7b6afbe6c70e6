//! Column names not known when mapbench was built: the extra columns of an external solver's
//! records. Rows carry `&'static str` column names (the catalogue's are literals); a name read
//! at run time is kept once for the life of the process, so memory grows with the number of
//! distinct names, not with runs or rows.

use std::collections::BTreeSet;
use std::sync::Mutex;

static NAMES: Mutex<BTreeSet<&'static str>> = Mutex::new(BTreeSet::new());

/// The one `'static` copy of `name`.
pub fn intern(name: &str) -> &'static str {
    let mut names = NAMES.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(&kept) = names.get(name) {
        return kept;
    }
    let kept: &'static str = Box::leak(name.to_owned().into_boxed_str());
    names.insert(kept);
    kept
}

/// Whether `name` may be a column of a CSV mapbench writes: ASCII letters, digits and `_`,
/// starting with a letter, at most 64 bytes.
pub fn is_column_name(name: &str) -> bool {
    name.len() <= 64
        && name.starts_with(|c: char| c.is_ascii_alphabetic())
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_name_is_kept_once_and_column_names_are_plain() {
        let a = intern(&String::from("decrease"));
        let b = intern("decrease");
        assert!(std::ptr::eq(a, b));
        assert_eq!(a, "decrease");
        assert!(is_column_name("cg_iters2") && is_column_name("a"));
        for bad in ["", "2x", "a b", "a,b", "é", "_x", &"x".repeat(65)] {
            assert!(!is_column_name(bad), "{bad}");
        }
    }
}
