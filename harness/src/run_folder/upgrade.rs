//! Run folders of older releases read as today's, asv's way: each legacy shape is upgraded
//! where it is read, here, so nothing above `run_folder` handles one (when each stopped being
//! written is in `CHANGELOG.md`):
//!
//! - the `own_rule` verdict, written while `authalic` runs had no reference minimum and the
//!   solver's own rule decided: read as no verdict, since no target judged the run.

use super::status::Verdict;
use serde::{Deserialize, Deserializer};

/// The `verdict` column: a verdict of today, empty, or a legacy one read as none.
pub fn verdict<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Verdict>, D::Error> {
    match Option::<String>::deserialize(d)?.as_deref() {
        None | Some("") | Some("own_rule") => Ok(None),
        Some(text) => Verdict::deserialize(serde::de::value::StrDeserializer::<D::Error>::new(text)).map(Some),
    }
}

#[cfg(test)]
mod tests {
    use super::super::summary::SummaryRow;
    use super::*;

    /// A summary row with `verdict` set to `text` read back.
    fn read(text: &str) -> Option<Verdict> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(SummaryRow { verdict: Some(Verdict::Solved), ..SummaryRow::default() }).unwrap();
        let csv = String::from_utf8(w.into_inner().unwrap()).unwrap();
        let (header, row) = csv.split_once('\n').unwrap();
        let row = row.replace(",solved,", &format!(",{text},"));
        let text = format!("{header}\n{row}");
        let mut r = csv::Reader::from_reader(text.as_bytes());
        r.deserialize::<SummaryRow>().next().unwrap().unwrap().verdict
    }

    #[test]
    fn today_s_verdicts_read_as_written_and_own_rule_as_not_judged() {
        for v in Verdict::ALL {
            assert_eq!(read(v.as_str()), Some(v));
        }
        assert_eq!(read(""), None);
        assert_eq!(read("own_rule"), None, "an older folder's authalic run: not judged");
    }

    #[test]
    fn an_unknown_verdict_is_refused() {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(SummaryRow { verdict: Some(Verdict::Solved), ..SummaryRow::default() }).unwrap();
        let csv = String::from_utf8(w.into_inner().unwrap()).unwrap().replace(",solved,", ",great,");
        let mut r = csv::Reader::from_reader(csv.as_bytes());
        assert!(r.deserialize::<SummaryRow>().next().unwrap().is_err());
    }
}
