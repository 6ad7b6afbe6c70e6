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

/// The `confined` column: the protections that held; an older folder's `true` (Landlock's
/// rule on writes held) as `writes`, its `false` as none.
pub fn confined<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Either {
        Old(bool),
        Listed(String),
    }
    Ok(match Option::<Either>::deserialize(d)? {
        None => None,
        Some(Either::Old(true)) => Some("writes".into()),
        Some(Either::Old(false)) => Some(String::new()),
        Some(Either::Listed(t)) if t == "true" => Some("writes".into()),
        Some(Either::Listed(t)) if t == "false" => Some(String::new()),
        Some(Either::Listed(t)) => Some(t),
    })
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

    #[test]
    fn confined_reads_the_protections_and_an_older_folders_yes_or_no() {
        let row = SummaryRow { confined: Some("writes reads".into()), ..SummaryRow::default() };
        let json = serde_json::to_value(&row).unwrap();
        let back = |v: serde_json::Value| {
            let mut j = json.clone();
            j["confined"] = v;
            serde_json::from_value::<SummaryRow>(j).unwrap().confined
        };
        assert_eq!(back(json["confined"].clone()).as_deref(), Some("writes reads"));
        assert_eq!(back(serde_json::Value::Bool(true)).as_deref(), Some("writes"));
        assert_eq!(back(serde_json::Value::Bool(false)).as_deref(), Some(""));
        assert_eq!(back(serde_json::Value::Null), None);
        let mut w = csv::Writer::from_writer(Vec::new());
        w.serialize(&row).unwrap();
        let csv = String::from_utf8(w.into_inner().unwrap()).unwrap();
        for (cell, read) in [("writes reads", Some("writes reads")), ("true", Some("writes")), ("", None)] {
            let text = csv.replace(",writes reads,", &format!(",{cell},"));
            let mut r = csv::Reader::from_reader(text.as_bytes());
            assert_eq!(r.deserialize::<SummaryRow>().next().unwrap().unwrap().confined.as_deref(), read);
        }
    }
}
